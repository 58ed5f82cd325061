"""A heading a few degrees off the GNSS course, the DVL's direction turned by it: a magnetic
heading whose declination is not set, or a DVL yaw mounting not set, is warned about at load,
naming both settings with the value that would take the angle off (docs/robustness.md, 'A
heading a few degrees off the GNSS course'; since 0.4.13: up to 0.4.12 the demo's 5° declination
ran 17.8 m RMS against 3.5 m right, silent)."""

from __future__ import annotations

import logging
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav.mission import load_mission

D_DEG = 5.0
"""The declination of the tests (east): the compass reads the true heading less it."""


def _heading_aiding(demo: Path, tmp_path: Path, magnetic: bool, key: str = "") -> Path:
    """The demo with its heading sensor aiding; ``magnetic``: its headings less D; ``key``:
    a line added to ``[sensors.heading]``."""
    root = tmp_path / "mission"
    shutil.copytree(demo, root)
    toml = root / "mission.toml"
    text = toml.read_text()
    i = text.index("[sensors.heading]\n")
    j = text.index('use = "off"', i)
    text = text[:j] + 'use = "aid"' + text[j + len('use = "off"') :]
    toml.write_text(text.replace("[sensors.heading]\n", f"[sensors.heading]\n{key}", 1))
    if magnetic:
        table = pd.read_parquet(root / "heading.parquet")
        yaw = table["yaw_rad"].to_numpy() - math.radians(D_DEG)
        table["yaw_rad"] = np.angle(np.exp(1j * yaw))
        table.to_parquet(root / "heading.parquet")
    return root


def _warned(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if "off the GNSS course" in r.getMessage()]


def test_an_undeclared_declination_of_5_degrees_is_warned_about(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(_heading_aiding(demo, tmp_path, magnetic=True))
    (line,) = _warned(caplog)
    assert line.startswith("dvl.parquet: the direction of DVL 'dvl' (vx_m_s, vy_m_s), turned by "
                           "the heading of sensor 'heading'"), line  # fmt: skip
    # The compass reads ψ − D, so the DVL's direction lies D east of the course by it.
    found = re.search(r": ([+-][\d.]+)° ± ([\d.]+)° off over", line)
    assert found is not None, line
    assert abs(float(found[1]) - D_DEG) < 4.0 * float(found[2]), line
    setting = re.search(r"declination_deg = ([-\d.]+) in \[sensors.heading\] \(now 0", line)
    assert setting is not None and float(setting[1]) == pytest.approx(float(found[1])), line
    assert "mounting_rpy_deg yaw" in line and "[sensors.dvl]" in line, line


def test_a_right_heading_or_a_declared_declination_says_nothing(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(_heading_aiding(demo, tmp_path / "right", magnetic=False))
        key = f"declination_deg = {D_DEG:g}\n"
        load_mission(_heading_aiding(demo, tmp_path / "declared", magnetic=True, key=key))
    assert _warned(caplog) == []
