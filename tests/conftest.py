"""Fixtures shared by the bad-input tests (tests/test_robustness.py, tests/test_screening.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers import badinput


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny mission of the bad-input tests (CSV tables), written once; tests copy it."""
    return badinput.tiny_mission(tmp_path_factory.mktemp("tiny") / "mission")


@pytest.fixture()
def mission(source: Path, tmp_path: Path) -> Path:
    """A fresh copy of the tiny mission for one test to corrupt."""
    return badinput.copy_mission(source, tmp_path / "mission")
