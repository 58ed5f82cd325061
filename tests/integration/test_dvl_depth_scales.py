"""A DVL in knots or with an axis negated or swapped, a depth in feet or as a pressure: a load
error naming the file, the column and the likely unit, never a run far off with exit 0
(docs/robustness.md, 'DVL and depth scales')."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest

from adaptnav.mission import MissionError, load_mission
from helpers import diving
from helpers.cli import cli, error_line

V = ["vx_m_s", "vy_m_s", "vz_m_s"]


def _copy(demo: Path, tmp_path: Path, heading_aid: bool = False) -> Path:
    root = tmp_path / "mission"
    shutil.copytree(demo, root)
    if heading_aid:
        toml = root / "mission.toml"
        text = toml.read_text()
        i = text.index("[sensors.heading]")
        j = text.index('use = "off"', i)
        toml.write_text(text[:j] + 'use = "aid"' + text[j + len('use = "off"') :])
    return root


def test_a_dvl_in_knots_is_an_error_against_the_gnss_track(demo: Path, tmp_path: Path) -> None:
    """Up to 0.4.9 the demo ran 191 m RMS off (2.6 m right), exit 0, an 'at odds' warning."""
    root = _copy(demo, tmp_path)
    df = pd.read_parquet(root / "dvl.parquet")
    df[V] = df[V] * 1.943844
    df.to_parquet(root / "dvl.parquet")
    line = error_line(cli("run", root, "--out", tmp_path / "out", "-q"))
    assert "dvl.parquet: the speed of DVL 'dvl'" in line and "in knots" in line, line
    assert "[sensors.dvl] scale_check = false" in line, line


@pytest.mark.parametrize(
    ("change", "expect"), [("negate", "x axis negated"), ("swap", "x and y swapped")]
)
def test_a_dvl_axis_negated_or_swapped_is_an_error_with_a_heading_sensor(
    demo: Path, tmp_path: Path, change: str, expect: str
) -> None:
    root = _copy(demo, tmp_path, heading_aid=True)
    df = pd.read_parquet(root / "dvl.parquet")
    if change == "negate":
        df["vx_m_s"] = -df["vx_m_s"]
    else:
        df[["vx_m_s", "vy_m_s"]] = df[["vy_m_s", "vx_m_s"]].to_numpy()
    df.to_parquet(root / "dvl.parquet")
    line = error_line(cli("run", root, "--out", tmp_path / "out", "-q"))
    assert "the direction of DVL 'dvl'" in line and expect in line, line


@pytest.mark.parametrize(
    ("change", "expect"),
    [("negate", "x axis negated"), ("swap", "x and y swapped"), ("both", "x axis negated")],
)
def test_a_dvl_axis_negated_or_swapped_is_an_error_by_the_start_s_heading(
    demo: Path, tmp_path: Path, change: str, expect: str
) -> None:
    """The demo as simulated: its heading sensor off, initial.rpy_deg's yaw carried by the gyro
    (since 0.4.10). Up to 0.4.9 it loaded and ran 297-392 m RMS off, exit 0."""
    root = _copy(demo, tmp_path)
    load_mission(root)  # the right DVL passes (0.6°)
    df = pd.read_parquet(root / "dvl.parquet")
    if change == "negate":
        df["vx_m_s"] = -df["vx_m_s"]
    elif change == "swap":
        df[["vx_m_s", "vy_m_s"]] = df[["vy_m_s", "vx_m_s"]].to_numpy()
    else:
        df[["vx_m_s", "vy_m_s"]] = -df[["vx_m_s", "vy_m_s"]]
    df.to_parquet(root / "dvl.parquet")
    with pytest.raises(MissionError) as err:
        load_mission(root)
    text = str(err.value)
    assert text.startswith("dvl.parquet: the direction of DVL 'dvl'") and expect in text, text
    assert "the start's heading (initial.rpy_deg's yaw" in text and "carried by the gyro" in text
    assert err.value.field == "vx_m_s" and "initial.rpy_deg's yaw wrong" in text, text


def test_scale_check_false_loads_the_dvl_as_it_is(demo: Path, tmp_path: Path) -> None:
    root = _copy(demo, tmp_path)
    df = pd.read_parquet(root / "dvl.parquet")
    df[V] = df[V] * 1.943844
    df.to_parquet(root / "dvl.parquet")
    toml = root / "mission.toml"
    toml.write_text(
        toml.read_text().replace("[sensors.dvl]\n", "[sensors.dvl]\nscale_check = false\n")
    )
    load_mission(root)


@pytest.mark.parametrize(
    ("factor", "unit"), [(1 / 0.3048, "feet"), (10.05, "kPa"), (0.1005, "bar")]
)
def test_a_depth_in_another_unit_on_a_diving_vehicle_is_anerror_line(
    tmp_path: Path, factor: float, unit: str
) -> None:
    tabs = diving.tables()
    load_mission(diving.mission(tmp_path / "right", tabs))  # the right tables load
    tabs["depth"] = tabs["depth"].assign(depth_m=tabs["depth"]["depth_m"] * factor)
    with pytest.raises(MissionError) as err:
        load_mission(diving.mission(tmp_path / "wrong", tabs))
    text = str(err.value)
    assert text.startswith("depth.csv: the depth of sensor 'depth'") and unit in text, text
    assert err.value.field == "depth_m" and "[sensors.depth] scale_check = false" in text
    load_mission(diving.mission(tmp_path / "off", tabs, depth={"scale_check": False}))
