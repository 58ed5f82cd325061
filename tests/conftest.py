"""Fixtures shared across the test folders (unit/, kernels/, integration/).

The tiny mission of the bad-input tests (tests/integration/test_robustness.py,
tests/unit/test_screening.py), from :mod:`helpers.badinput`; the simulated demo of the
cross-check tests (test_imu_axes.py, test_dvl_depth_scales.py). Helpers that are not fixtures live
in the :mod:`helpers` package (tests/helpers/), imported as ``from helpers import ...``.
"""

from __future__ import annotations

import os
from pathlib import Path

# pytest-xdist's workers (make test runs two) get COLUMNS=80 in their environment, where a
# plain pytest has none: the CLI's tables and long paths would then wrap at 80 columns instead
# of its own 120 for a pipe (cli/_app.py), and tests that look for a line would see it split.
# Before helpers.cli imports the CLI, whose consoles read the width once.
os.environ.pop("COLUMNS", None)
os.environ.pop("LINES", None)

import pytest

from helpers import badinput
from helpers.cli import cli


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny mission of the bad-input tests (CSV tables), written once; tests copy it."""
    return badinput.tiny_mission(tmp_path_factory.mktemp("tiny") / "mission")


@pytest.fixture()
def mission(source: Path, tmp_path: Path) -> Path:
    """A fresh copy of the tiny mission for one test to corrupt."""
    return badinput.copy_mission(source, tmp_path / "mission")


@pytest.fixture(scope="session")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``adaptnav simulate demo`` (seed 1), written once; tests copy it before changing it."""
    out = tmp_path_factory.mktemp("demo") / "demo"
    assert cli("simulate", "demo", "--out", out, "-q").exit_code == 0
    return out
