"""The static alignment's heading from a heading sensor (docs/alignment.md, 'Heading source').

Up to 0.4.6 a heading sensor never gave the alignment its heading: a mission whose gyro cannot
gyrocompass (the tiny mission's 1 deg/h gyro over a 20-s window predicts σ_ψ ≈ 6° > 5°) and
without a configured ``rpy_deg`` stopped with 'no heading for the alignment', and
``use = "init"`` was refused for anything but a GNSS. The truth the tests score against is the
simulator's (truth.csv), independent of the alignment's code.
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav import api
from adaptnav.api import runner
from adaptnav.api.stream import Stream, replay
from adaptnav.cli import app
from adaptnav.core import attitude
from adaptnav.core.units import G0
from adaptnav.mission import ImuData, SensorData, load_mission, parse_config, write_mission
from adaptnav.mission.config import with_overrides
from adaptnav.models.strapdown import NOM_ATT, NOM_SIZE
from adaptnav.sensors import heading as heading_model
from adaptnav.sim import scenarios
from helpers import badinput
from helpers.missions import config_dict

HEADING_SIGMA_DEG = 0.5
"""The tiny mission's heading sensor σ (helpers/badinput.py, the demo's sensors)."""


def cli(*args: Any) -> Any:
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    return res


def _heading_for_the_alignment(mission: Path, use: str) -> None:
    """No configured heading; the heading sensor (off in the tiny mission) set to ``use``."""
    toml = (mission / "mission.toml").read_text()
    lines = [line for line in toml.splitlines() if not line.startswith("rpy_deg")]
    toml = "\n".join(lines) + "\n"
    head = toml.index("[sensors.heading]")
    toml = toml[:head] + toml[head:].replace('use = "off"', f'use = "{use}"', 1)
    (mission / "mission.toml").write_text(toml)


def _true_yaw_deg(mission: Path, t: float) -> float:
    truth = badinput.read(mission, "truth")
    k = int(np.argmin(np.abs(truth["t_s"].to_numpy() - t)))
    return math.degrees(float(truth["yaw_rad"].iloc[k]))


@pytest.mark.parametrize("use", ["init", "aid"])
def test_a_heading_sensor_gives_the_alignment_its_heading(
    mission: Path, tmp_path: Path, use: str
) -> None:
    _heading_for_the_alignment(mission, use)
    out = tmp_path / "run"
    res = cli("run", mission, "--filter", "meskf", "--out", out)
    assert res.exit_code == 0, res.output
    assert "heading from heading sensor 'heading'" in " ".join(res.output.split())
    meta = json.loads((out / "summary.json").read_text())["meta"]
    assert meta["heading_source"] == "heading"
    assert meta["heading_from"] == "sensors.heading"
    assert meta["heading_readings"] == 19  # 1 Hz, readings in (0.x s, 20.x s]
    yaw = meta["coarse_rpy_deg"][2]
    # One reading's σ (0.5°), not the mean's: within 3 σ of the truth at the window's end.
    assert abs(yaw - _true_yaw_deg(mission, meta["alignment_s"])) < 3 * HEADING_SIGMA_DEG
    assert meta["sigma_attitude_deg"][2] <= HEADING_SIGMA_DEG
    ledger = pd.read_parquet(out / "ledger.parquet")
    reasons = set(ledger.loc[ledger["sensor"] == "heading", "reason"])
    if use == "init":
        assert reasons == {runner.INIT_REASON}
    else:
        assert "sensor used only for initialisation" not in reasons
        assert (ledger.loc[ledger["sensor"] == "heading", "fate"] == "used").sum() > 20


def test_without_a_heading_the_alignment_still_says_what_to_give(
    mission: Path, tmp_path: Path
) -> None:
    _heading_for_the_alignment(mission, "off")
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 2
    assert "a heading sensor (not off) with readings in the static window" in res.output


def test_an_init_heading_sensor_without_readings_at_rest_is_an_error(
    mission: Path, tmp_path: Path
) -> None:
    _heading_for_the_alignment(mission, "init")
    table = badinput.read(mission, "heading")
    badinput.write(mission, "heading", table[table["t_s"] > 30.0])
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 2
    assert "sensors.heading (use = 'init')" in res.output
    assert "no reading in the static window" in res.output


def test_init_heading_with_a_configured_heading_is_an_error(mission: Path, tmp_path: Path) -> None:
    toml = (mission / "mission.toml").read_text()
    head = toml.index("[sensors.heading]")
    toml = toml[:head] + toml[head:].replace('use = "off"', 'use = "init"', 1)
    (mission / "mission.toml").write_text(toml)
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 2
    assert "initial.rpy_deg, which would be taken: drop one" in res.output


def test_a_stream_takes_the_heading_as_the_batch_run(mission: Path) -> None:
    _heading_for_the_alignment(mission, "aid")
    loaded = load_mission(mission)
    batch = api.run(loaded, "meskf")
    rows = []
    with Stream(loaded, "meskf") as stream:
        for item in replay(loaded):
            rows += stream.push_item(item)
    a, b = pd.DataFrame(rows).to_numpy(), batch.solution.to_numpy()
    assert a.shape == b.shape
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale)


def test_the_heading_is_exact_under_a_tilted_body_and_mounting() -> None:
    """A body at roll 5°, pitch -3°, yaw 100° with the compass mounted at (2°, 4°, 30°): its
    readings are the model's (sensors/heading.py) at the true attitude; the body's yaw comes
    back to 1e-9 rad (the levelled tilt is exact: the specific force is the body's at rest)."""
    roll, pitch, yaw = np.radians([5.0, -3.0, 100.0])
    mounting = [2.0, 4.0, 30.0]
    cfg = parse_config(
        config_dict(
            sensors={
                "compass": {
                    "kind": "heading", "file": "c.csv", "sigma": [0.3, "deg"], "rate_hz": 1.0,
                    "use": "init", "mounting_rpy_deg": mounting,
                }
            },
            initial={"lat_deg": 26.8, "lon_deg": 56.0, "alignment_s": 10.0},
        )
    )  # fmt: skip
    C_nb = attitude.euler_to_dcm(roll, pitch, yaw)
    f_b = C_nb.T @ np.array([0.0, 0.0, -G0])  # at rest: the reaction to gravity
    n, dt = 1200, 0.01
    t = dt * np.arange(1, n + 1)
    imu = ImuData(t, np.full(n, dt), np.zeros((n, 3)), np.tile(f_b * dt, (n, 1)))
    C_sb = attitude.euler_to_dcm(*np.radians(mounting)).T
    x = np.zeros(NOM_SIZE)
    x[NOM_ATT] = attitude.euler_to_quat(roll, pitch, yaw)
    z = float(heading_model.predict(x, C_sb)[0])
    readings = SensorData("compass", "heading", np.arange(1.0, 11.0), np.full((10, 1), z),
                          np.arange(10, dtype=np.int64))  # fmt: skip
    got, sigma, info = runner.sensor_heading(cfg, imu, {"compass": readings}, "compass", 0.0)
    assert got is not None and sigma is not None
    assert abs(float(attitude.wrap_angle(got - yaw))) < 1e-9
    assert sigma == pytest.approx(math.radians(0.3))
    assert info == {"heading_from": "sensors.compass", "heading_readings": 10}


def test_a_dvl_moving_inside_the_alignment_window_is_warned_about(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The demo starts moving at 600 s: aligned over 620 s, the mean of its DVL's vx over the
    window's last seconds exceeds max(0.05 m/s, 4 σ/√k) (k readings): a warning naming the
    file, the column and the row; over 600 s (its static phase) none. Up to 0.4.8 nothing was
    said (6.8 m RMSE against 2.6 m, helper audit)."""
    sim = scenarios.generate(scenarios.demo(), 1)
    write_mission(tmp_path / "m", sim.config, sim.tables)
    m = load_mission(tmp_path / "m")
    said = "sensor 'dvl' reads"
    for alignment_s, warned in ((600.0, False), (620.0, True)):
        cfg = with_overrides(m.config, [("initial.alignment_s", alignment_s)])
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="adaptnav.api"):
            api.initial_state(replace(m, config=cfg))
        assert (said in caplog.text) is warned, (alignment_s, caplog.text)
    assert "dvl.parquet, vx_m_s: sensor 'dvl' reads +0.05" in caplog.text
    assert "was it moving (initial.alignment_s too long)?" in caplog.text
