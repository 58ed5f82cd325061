"""The exporters refuse a damaged run folder and options ROS 2 tools would refuse (issue 12):
exit 2 naming the file, row and column or the option, never a traceback deep in ``rosbags``
(up to 0.4.4: a solution of no rows, a NaN time or a stamp beyond 2038 did that) and never a
bag or a track written on from a NaN pose, times that go back or an invalid topic name (up
to 0.4.4 all written, exit 0)."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.cli import app
from helpers.run_folders import reseal

runner = CliRunner()


def _cli(*args: Any) -> Any:
    res = runner.invoke(app, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    return res


@pytest.fixture(scope="module")
def run(source: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run of the tiny mission, written once for the module's tests to copy."""
    out = tmp_path_factory.mktemp("export") / "run"
    assert _cli("run", source, "--out", out, "--quiet").exit_code == 0
    return out


def _nan_lat(s: pd.DataFrame) -> pd.DataFrame:
    return s.assign(lat_rad=s["lat_rad"].where(s.index != 7))


def _nan_time(s: pd.DataFrame) -> pd.DataFrame:
    return s.assign(t_s=s["t_s"].where(s.index != 5))


DAMAGE: dict[str, tuple[Callable[[pd.DataFrame], pd.DataFrame], str]] = {
    "no rows": (lambda s: s.iloc[:0], "solution.parquet: no rows"),
    "nan time": (_nan_time, "solution.parquet row 5, t_s: nan is not a time"),
    "reversed": (lambda s: s.iloc[::-1], "solution.parquet row 1, t_s:"),
    "repeated rows": (
        lambda s: pd.concat([s.iloc[:10], s.iloc[5:]]),
        "solution.parquet row 10, t_s:",
    ),
    "nan latitude": (_nan_lat, "solution row 7, lat_rad: nan is not a finite number"),
}


@pytest.mark.parametrize("exporter", ["rosbag", "track"])
@pytest.mark.parametrize("damage", list(DAMAGE))
def test_a_damaged_solution_is_refused_naming_its_row(
    run: Path, tmp_path: Path, exporter: str, damage: str
) -> None:
    change, message = DAMAGE[damage]
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    solution = pd.read_parquet(run / "solution.parquet")
    change(solution).reset_index(drop=True).to_parquet(copy / "solution.parquet", index=False)
    if damage == "nan latitude":  # checked after the digest; the times before it
        reseal(copy, "solution.parquet")
    res = _cli("export", exporter, copy, "--out", tmp_path / "out", "--quiet")
    assert res.exit_code == 2, res.output
    assert message in " ".join(res.output.split()), res.output
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--stamp-origin-ns", "3000000000000000000", "outside ROS 2's time range"),
        ("--stamp-origin-ns", "-5000000000000", "outside ROS 2's time range"),
        ("--topic", "", "--topic: '' is not a ROS 2 topic name"),
        ("--topic", "no slash", "is not a ROS 2 topic name"),
        ("--topic", "/a//b", "is not a ROS 2 topic name"),
        ("--topic", "/9lives", "is not a ROS 2 topic name"),
        ("--topic", "/adaptnav/datum", "is the datum's topic"),
        ("--frame-id", "/map", "--frame-id: '/map' is not a frame id"),
        ("--child-frame-id", "map", "is the world frame too"),
    ],
)
def test_rosbag_export_options_ros_would_refuse_are_errors(
    run: Path, tmp_path: Path, option: str, value: str, message: str
) -> None:
    res = _cli("export", "rosbag", run, "--out", tmp_path / "bag", f"{option}={value}")
    assert res.exit_code == 2, res.output
    assert message in " ".join(res.output.split()), res.output
    assert not (tmp_path / "bag").exists()


def test_a_valid_topic_and_origin_are_written(run: Path, tmp_path: Path) -> None:
    """The checks let through what ROS 2 accepts: underscores, a hidden topic's leading
    underscore, the last second before 2038."""
    origin = (2**31 - 3600) * 10**9
    res = _cli(
        "export", "rosbag", run, "--out", tmp_path / "bag", "--topic", "/_nav/odom_2",
        "--frame-id", "odom", "--stamp-origin-ns", origin, "--quiet",
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert np.any([p.suffix == ".db3" for p in (tmp_path / "bag").iterdir()])


def test_evaluate_refuses_a_solution_position_that_is_not_finite(run: Path, tmp_path: Path) -> None:
    """Up to 0.4.4 the RMSE came out NaN while the NEES left the row out, exit 0."""
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    solution = pd.read_parquet(run / "solution.parquet")
    _nan_lat(solution).to_parquet(copy / "solution.parquet", index=False)
    reseal(copy, "solution.parquet")  # what evaluate checks after the digest
    res = _cli("evaluate", copy, "--json")
    assert res.exit_code == 2, res.output
    assert f"{copy}: solution row 7, lat_rad: nan is not a finite number" in " ".join(
        res.output.split()
    )


def test_a_run_is_not_saved_into_a_mission_folder(source: Path, tmp_path: Path) -> None:
    """results.save of a run into its mission's folder, or onto a file: RunFolderError (up to
    0.4.4 the folder became a mission and a run at once; a file gave FileExistsError)."""
    from adaptnav import api
    from adaptnav.api.results import RunFolderError

    mission = shutil.copytree(source, tmp_path / "mission")
    result = api.run(mission, "meskf")
    with pytest.raises(RunFolderError, match="a mission folder"):
        api.results.save(result, mission)
    (tmp_path / "file").write_text("x")
    with pytest.raises(RunFolderError, match="a file, not a folder"):
        api.results.save(result, tmp_path / "file")
    assert not (mission / "summary.json").exists()
