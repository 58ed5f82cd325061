"""A depth that puts the GNSS antenna under water while it fixes (an absolute pressure, a
pressure unit) is warned about at load, naming the sensors and the likely cause
(docs/robustness.md, 'A depth offset at the surface'; since 0.4.11: up to 0.4.10 nothing)."""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import pandas as pd
import pytest

from adaptnav.api.stream import Stream, replay
from adaptnav.mission import load_mission


def _depth_times(demo: Path, tmp_path: Path, add: float = 0.0, mul: float = 1.0) -> Path:
    root = tmp_path / "mission"
    shutil.copytree(demo, root)
    df = pd.read_parquet(root / "depth.parquet")
    df["depth_m"] = df["depth_m"] * mul + add
    df.to_parquet(root / "depth.parquet")
    return root


def _warned(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if "under water" in r.getMessage()]


def test_an_absolute_pressure_depth_is_warned_about(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The demo's depth meter sits 6.2 m below the antenna by the lever arms (1.2 m, -5 m) and
    reads 1.2 m; with an atmosphere (10.08 m) left in it reads 11.3 m at the fixes."""
    root = _depth_times(demo, tmp_path, add=10.08)
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(root)
    (line,) = _warned(caplog)
    assert line.startswith("depth.parquet: sensor 'depth' reads 11.3 m"), line
    assert "of sensor 'gps' (gps.parquet)" in line and "absolute pressure" in line, line
    assert "[sensors.depth] scale_check = false" in line, line


def test_a_right_depth_or_one_unchecked_says_nothing(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(demo)
        root = _depth_times(demo, tmp_path, add=10.08)
        toml = root / "mission.toml"
        text = toml.read_text()
        i = text.index("[sensors.depth]") + len("[sensors.depth]\n")
        toml.write_text(text[:i] + "scale_check = false\n" + text[i:])
        load_mission(root)
    assert _warned(caplog) == []


def test_a_depth_in_kpa_on_a_surface_vessel_is_warned_about(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A gauge pressure in kPa (10.05 per metre) reads 12.3 where 1.2 m is: the scale check
    against the DVL decides nothing on a vessel that does not dive; the antenna does."""
    root = _depth_times(demo, tmp_path, mul=10.05)
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(root)
    (line,) = _warned(caplog)
    assert "in kPa" in line, line


def test_a_stream_warns_of_it_too_without_a_dvl(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A stream makes the check with its other cross-checks over its first window
    (docs/streaming.md, 'Cross-checks'), even with no DVL beside the depth meter."""
    root = _depth_times(demo, tmp_path, add=10.08)
    toml = root / "mission.toml"
    text = toml.read_text()
    i = text.index('use = "aid"', text.index("[sensors.dvl]"))
    toml.write_text(text[:i] + 'use = "off"' + text[i + len('use = "aid"') :])
    mission = load_mission(root)
    caplog.clear()
    with (
        caplog.at_level(logging.WARNING, logger="adaptnav.mission"),
        Stream(mission, "robust") as stream,
    ):
        for item in replay(mission):
            stream.push_item(item)
    (line,) = _warned(caplog)
    assert "sensor 'depth' reads 11.3 m" in line, line


def test_a_gnss_lever_arm_with_its_z_sign_slipped_is_warned_about(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The demo's antenna 5 m above the IMU written as 5 m below it (lever z +5 where -5 is):
    by the lever arms it sits 3.8 m below the depth meter (z 1.2 m), which reads 1.2 m, under
    water at the surface, so the antenna is 5.0 m under water while it fixes. Up to 0.4.12 a
    negative antenna height above the meter was taken as 0 and nothing was said (1.2 m read,
    within the 2-m margin); the run's heights then disagree with the GNSS's by 10 m."""
    root = _depth_times(demo, tmp_path)
    toml = root / "mission.toml"
    text = toml.read_text()
    i = text.index("lever_arm_m = [0.0, 0.0, -5.0]", text.index("[sensors.gps]"))
    toml.write_text(text[:i] + "lever_arm_m = [0.0, 0.0, 5.0]" + text[i + 30 :])
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(root)
    (line,) = _warned(caplog)
    assert "reads 1.22 m" in line and "antenna 5.02 m under water" in line, line
    assert "the antenna 3.8 m below the depth meter" in line, line
    assert "is a lever arm's z sign wrong?" in line, line
