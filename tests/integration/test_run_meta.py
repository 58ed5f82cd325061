"""A run records what made it: the package version and the engine's settings a mission may set
(``summary.json``'s ``meta``), beside the filter's settings; batch and stream alike."""

from __future__ import annotations

from pathlib import Path

import pytest

import adaptnav
from adaptnav import api
from adaptnav.api import results
from adaptnav.api.stream import Stream, replay
from adaptnav.engine.batch import COVARIANCE_BLOCK_S
from adaptnav.mission import load_mission
from helpers.missions import config_dict, dvl_table, imu_rates, write_dir

STATE = {"mode": "state", "lat_deg": 26.8, "lon_deg": 56.0, "rpy_deg": [0.0, 0.0, 30.0]}


def _mission(root: Path, **filter_section: object) -> Path:
    cfg = config_dict(initial=STATE, filter=filter_section)
    return write_dir(root, cfg, {"imu.csv": imu_rates(300), "dvl.csv": dvl_table(8)})


@pytest.mark.parametrize(
    ("section", "reset"),
    [({}, "invariant"), ({"invariant_reset": False}, "attitude")],
)
def test_the_run_records_version_and_engine_settings(
    tmp_path: Path, section: dict[str, object], reset: str
) -> None:
    engine = {"specific_force_tau_s": 0.0, "covariance_block_s": COVARIANCE_BLOCK_S, "reset": reset}
    result = api.run(_mission(tmp_path / "m", **section), "meskf")
    assert result.meta["adaptnav_version"] == adaptnav.__version__
    assert result.meta["engine"] == engine
    back = results.load(results.save(result, tmp_path / "run"))
    assert back.meta["engine"] == engine  # summary.json keeps it


def test_a_stream_records_the_same(tmp_path: Path) -> None:
    mission = load_mission(_mission(tmp_path / "m", covariance_block_s=0.05))
    batch = api.run(mission, "meskf")
    with Stream(mission, "meskf") as stream:
        for item in replay(mission):
            stream.push_item(item)
    assert stream.result is not None
    assert stream.result.meta["engine"] == batch.meta["engine"]
    assert batch.meta["engine"]["covariance_block_s"] == 0.05
    assert stream.result.meta["adaptnav_version"] == adaptnav.__version__


def test_the_mission_folder_is_recorded_absolute(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Given as a relative path, the mission folder is recorded absolute, batch and stream:
    evaluate (calibration truth) and export rosbag (stamp origin) read it from wherever they
    run (up to 0.4.7 it was recorded as typed, and from another folder found nothing, or a
    folder of the same name there)."""
    _mission(tmp_path / "m")
    monkeypatch.chdir(tmp_path)
    mission = load_mission(Path("m"))
    batch = api.run(mission, "meskf")
    assert batch.meta["mission_dir"] == str((tmp_path / "m").resolve())
    with Stream(mission, "meskf") as stream:
        for item in replay(mission):
            stream.push_item(item)
    assert stream.result is not None
    assert stream.result.meta["mission_dir"] == batch.meta["mission_dir"]
