"""End to end through the CLI: a mission folder → `adaptnav run` → `adaptnav evaluate`, also
RTS-smoothed (`run --smooth`, docs/smoothing.md)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.analysis import evaluate
from adaptnav.api import results
from adaptnav.cli import app
from adaptnav.core import attitude
from adaptnav.mission import load_mission, parse_config, write_mission
from helpers import synthetic

runner = CliRunner()


def _mission(tmp_path: Path, seed: int = 5, duration: float = 60.0) -> Path:
    ds = synthetic.make(seed, duration=duration)
    x0 = ds.truth[0]
    rpy = np.degrees(attitude.quat_to_euler(x0[6:10]))
    config = parse_config(
        {
            "mission": {"name": "synthetic-turn"},
            "imu": {
                "file": "imu.parquet",
                "format": "increments",
                "rate_hz": 100.0,
                "noise": {
                    "arw": [0.0667, "deg/sqrt(h)"],
                    "vrw": [55, "ug/sqrt(Hz)"],
                    "gyro_bias_sigma": [1, "deg/h"],
                    "gyro_bias_tau": [1, "h"],
                    "accel_bias_sigma": [0.25, "mg"],
                    "accel_bias_tau": [1, "h"],
                },
            },
            "sensors": {
                "dvl": {"kind": "dvl", "file": "dvl.parquet", "sigma": [0.02, "m/s"],
                        "rate_hz": 3.0},
                "depth": {"kind": "depth", "file": "depth.parquet", "sigma": [0.1, "m"],
                          "rate_hz": 1.0},
                "gnss": {
                    "kind": "gnss", "file": "gnss.parquet", "sigma": [2.0, "m"], "rate_hz": 1.0,
                    "use_height": True,
                },
            },
            "initial": {
                "mode": "state",
                "lat_deg": math.degrees(x0[0]),
                "lon_deg": math.degrees(x0[1]),
                "h_m": float(x0[2]),
                "v_ned_m_s": [float(v) for v in x0[3:6]],
                "rpy_deg": [float(a) for a in rpy],
                "sigma_position_m": 2.0,
                "sigma_velocity_m_s": 0.05,
                "sigma_attitude_deg": [0.06, 0.06, 0.3],
            },
            "truth": {"file": "truth.parquet"},
        }
    )  # fmt: skip
    t = ds.imu_t
    imu = pd.DataFrame({"t_s": t})
    for i, ax in enumerate("xyz"):
        imu[f"dtheta_{ax}_rad"] = ds.dtheta[:, i]
        imu[f"dvel_{ax}_m_s"] = ds.dvel[:, i]
    tables = {"imu": imu}
    cols = {
        "dvl": ["vx_m_s", "vy_m_s", "vz_m_s"],
        "depth": ["depth_m"],
        "gnss": ["lat_rad", "lon_rad", "h_m"],
    }
    for name, (ts, z) in ds.readings.items():
        tables[name] = pd.DataFrame({"t_s": ts, **{c: z[:, j] for j, c in enumerate(cols[name])}})
    k = np.arange(0, ds.truth_t.size, 10)
    eul = np.array([attitude.quat_to_euler(q) for q in ds.truth[k, 6:10]])
    tables["truth"] = pd.DataFrame(
        {
            "t_s": ds.truth_t[k], "lat_rad": ds.truth[k, 0], "lon_rad": ds.truth[k, 1],
            "h_m": ds.truth[k, 2], "vn_m_s": ds.truth[k, 3], "ve_m_s": ds.truth[k, 4],
            "vd_m_s": ds.truth[k, 5], "roll_rad": eul[:, 0], "pitch_rad": eul[:, 1],
            "yaw_rad": eul[:, 2],
        }
    )  # fmt: skip
    root = tmp_path / "mission"
    write_mission(root, config, tables)
    return root


@pytest.mark.parametrize("kind", ["meskf", "maeskf", "vb"])
def test_run_then_evaluate_json(tmp_path: Path, kind: str) -> None:
    mission = _mission(tmp_path)
    out = tmp_path / f"run-{kind}"
    res = runner.invoke(app, ["run", str(mission), "--filter", kind, "--out", str(out)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["evaluate", str(out), "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["filter"] == kind
    assert {"rmse_m", "relative_rmse_pct", "distance_m", "duration_s"} <= d.keys()
    # 60 s at 2 m/s; GNSS at 2 m keeps the error at the metre level.
    assert 110.0 < d["distance_m"] < 130.0
    assert 0.0 < d["rmse_m"] < 3.0
    assert d["relative_rmse_pct"] == pytest.approx(100 * d["rmse_m"] / d["distance_m"])
    for block in ("position", "velocity", "attitude"):
        assert f"mean_nees_{block}" in d and f"nees_{block}_in_95" in d
    assert d["mean_nees_position"] > 0.0 and d["nees_uses_correlations"] is True
    # not smoothed: no forward solution anywhere
    assert not (out / "forward.parquet").exists()
    assert not [k for k in d if "forward" in k]
    res = runner.invoke(app, ["evaluate", str(out)])
    assert res.exit_code == 0 and "RMSE (m)" in res.stdout
    assert "mean NEES, attitude" in res.stdout
    assert "forward" not in res.stdout and "smoothed" not in res.stdout


def test_run_smooth_keeps_the_forward_solution_and_evaluate_scores_both(tmp_path: Path) -> None:
    mission = _mission(tmp_path)
    out = tmp_path / "run"
    res = runner.invoke(app, ["run", str(mission), "-f", "vb", "--smooth", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "RTS-smoothed" in res.stdout and "nodes" in res.stdout and "MiB" in res.stdout
    assert (out / "forward.parquet").is_file()
    res = runner.invoke(app, ["evaluate", str(out), "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    # Scored here straight from the run folder's tables, not through the command.
    r, truth = results.load(out), pd.read_parquet(out / "truth.parquet")
    assert r.forward is not None
    forward = evaluate.rmse(evaluate.position_errors(r.forward, truth))
    smoothed = evaluate.rmse(evaluate.position_errors(r.solution, truth))
    assert d["forward_rmse_m"] == pytest.approx(forward, rel=1e-12)
    assert d["forward_relative_rmse_pct"] == pytest.approx(100 * forward / d["distance_m"])
    nees = evaluate.nees_position(r.forward, truth)["nees"]
    assert d["forward_mean_nees_position"] == pytest.approx(np.nanmean(nees), rel=1e-12)
    assert d["rmse_m"] == pytest.approx(smoothed, rel=1e-12)
    assert abs(d["rmse_m"] - d["forward_rmse_m"]) > 1e-3 * d["forward_rmse_m"]
    res = runner.invoke(app, ["evaluate", str(out)])
    assert res.exit_code == 0, res.output
    assert "RTS-smoothed" in res.stdout and "forward" in res.stdout
    assert f"{d['forward_rmse_m']:.3f}" in res.stdout and f"{d['rmse_m']:.3f}" in res.stdout


def test_every_reading_has_a_fate(tmp_path: Path) -> None:
    mission = _mission(tmp_path, duration=20.0)
    out = tmp_path / "run"
    assert runner.invoke(app, ["run", str(mission), "--out", str(out)]).exit_code == 0
    r = results.load(out)
    for name in ("dvl", "depth", "gnss"):
        n_rows = len(pd.read_parquet(mission / f"{name}.parquet"))
        rows = r.ledger[r.ledger["sensor"] == name]["row"]
        assert sorted(rows) == list(range(n_rows)), name


def test_bad_mission_gives_a_clear_error_not_a_traceback(tmp_path: Path) -> None:
    mission = _mission(tmp_path, duration=5.0)
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(toml.replace("[initial]", "[initial]\nspeeed = 3", 1))
    res = runner.invoke(app, ["run", str(mission), "--out", str(tmp_path / "r")])
    assert res.exit_code == 2
    assert "speeed" in res.output and "Traceback" not in res.output


def test_evaluate_needs_a_run_folder(tmp_path: Path) -> None:
    res = runner.invoke(app, ["evaluate", str(tmp_path / "nothing"), "--json"])
    assert res.exit_code == 2 and "Traceback" not in res.output


# --- simulate: the sensors' true calibration errors (docs/simulation.md) ----------------------


def test_simulate_calibration_flags_reach_simulation_json(tmp_path: Path) -> None:
    out = tmp_path / "m"
    args = ["simulate", "demo", "--out", str(out), "--dvl-scale", "1.01"]
    args += ["--dvl-misalignment-deg", "0.5,-0.25,1", "--depth-bias-m", "-0.3"]
    args += ["--inclinometer-bias-deg", "-0.5,0.2", "--dvl-latency-ms", "150"]
    args += ["--gps-latency-ms", "-20", "--heading-latency-ms", "75"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    truth = json.loads((out / "simulation.json").read_text())["calibration"]
    assert truth["dvl_scale_factor"] == 1.01 and truth["depth_bias_m"] == -0.3
    assert truth["dvl_latency_s"] == pytest.approx(0.15)
    assert truth["gps_latency_s"] == pytest.approx(-0.02)
    assert truth["heading_latency_s"] == pytest.approx(0.075)
    assert truth["dvl_misalignment_deg"] == pytest.approx([0.5, -0.25, 1.0])
    assert truth["dvl_misalignment_rad"] == pytest.approx(np.radians([0.5, -0.25, 1.0]).tolist())
    assert truth["inclinometer_bias_deg"] == pytest.approx([-0.5, 0.2])
    assert truth["inclinometer_bias_rad"] == pytest.approx(np.radians([-0.5, 0.2]).tolist())


def test_a_simulated_dvl_latency_stamps_each_reading_late(tmp_path: Path) -> None:
    """``--dvl-latency-ms 150`` (0.4.3): the DVL's stamps are those of the mission without it
    plus 0.15 s, its readings and every other table the same; the truth of its state
    ``dvl.latency`` is 150 ms (analysis.calibration.true_values); the GPS and the heading
    likewise with theirs."""
    from adaptnav.analysis.calibration import mission_truth

    late_args = ["--dvl-latency-ms", "150", "--gps-latency-ms", "200", "--heading-latency-ms", "50"]
    for name, extra in (("plain", []), ("late", late_args)):
        res = runner.invoke(app, ["simulate", "demo", "--out", str(tmp_path / name), *extra])
        assert res.exit_code == 0, res.output
    plain, late = (load_mission(tmp_path / n) for n in ("plain", "late"))
    np.testing.assert_allclose(late.sensors["dvl"].t, plain.sensors["dvl"].t + 0.15, atol=1e-9)
    np.testing.assert_array_equal(late.sensors["dvl"].z, plain.sensors["dvl"].z)
    np.testing.assert_array_equal(late.sensors["depth"].t, plain.sensors["depth"].t)
    for sensor, lag in (("gps", 0.2), ("heading", 0.05)):
        a, b = (pd.read_parquet(tmp_path / n / f"{sensor}.parquet") for n in ("late", "plain"))
        np.testing.assert_allclose(a["t_s"], b["t_s"] + lag, atol=1e-9)
        assert a.drop(columns="t_s").equals(b.drop(columns="t_s"))
    toml = (tmp_path / "late" / "mission.toml").read_text()
    head = '[sensors.dvl]\nkind = "dvl"\n'
    assert head in toml
    (tmp_path / "late" / "mission.toml").write_text(
        toml.replace(head, head + 'estimate = ["latency"]\n')
    )
    assert mission_truth(tmp_path / "late") == {"dvl.latency": pytest.approx(150.0)}


def test_a_negative_seed_is_refused(tmp_path: Path) -> None:
    """Up to 0.3.5 `simulate --seed -1` ended in numpy's ValueError traceback, exit 1."""
    from adaptnav.sim.scenarios import simulate

    for command in (["simulate", "demo"], ["demo"]):
        res = runner.invoke(app, [*command, "--out", str(tmp_path / "m"), "--seed", "-1"])
        assert res.exit_code == 2 and "Traceback" not in res.output
        assert "--seed" in res.output and not (tmp_path / "m").exists()
    with pytest.raises(ValueError, match="seed -1: a simulation seed is a non-negative integer"):
        simulate("demo", -1, tmp_path / "api")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--dvl-scale", "abc"], "'abc' is not a number"),
        (["--dvl-scale", "0"], "scale factor 0 is not within 1 ± 0.5"),
        (["--dvl-scale", "101"], "scale factor 101 is not within"),
        (["--dvl-misalignment-deg", "1,2"], "is not 3 comma-separated numbers (got 2 values)"),
        (["--dvl-misalignment-deg", "0,x,1"], "'0,x,1' is not 3 comma-separated numbers"),
        (["--dvl-misalignment-deg", "0,0,12"], "angle 12° is beyond ±10°"),
        (["--depth-bias-m", "nan"], "depth bias nan m is beyond ±100 m"),
        (["--depth-bias-m", "1e6"], "depth bias 1e+06 m is beyond ±100 m"),
        (["--inclinometer-bias-deg", "0.1"], "is not 2 comma-separated numbers (got 1 values)"),
        (["--inclinometer-bias-deg=-10.5,0"], "angle -10.5° is beyond ±10°"),
        (["--dvl-latency-ms", "1500"], "DVL latency 1.5 s is beyond ±1 s"),
        (["--dvl-latency-ms", "nan"], "DVL latency nan s is beyond ±1 s"),
        (["--gps-latency-ms", "-2000"], "GPS latency -2 s is beyond ±1 s"),
        (["--heading-latency-ms", "inf"], "heading latency inf s is beyond ±1 s"),
    ],
)
def test_simulate_refuses_bad_calibration_values(
    tmp_path: Path, args: list[str], message: str
) -> None:
    out = tmp_path / "m"
    res = runner.invoke(app, ["simulate", "demo", "--out", str(out), *args])
    assert res.exit_code == 2 and "Traceback" not in res.output
    flag = args[0].split("=")[0]
    lines = [line for line in res.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and lines[0].startswith(f"error: {flag}: "), res.output
    assert message in lines[0]
    assert not out.exists()


def test_simulate_refuses_a_disturbance_both_on_and_off(tmp_path: Path) -> None:
    """``--enable waves --disable waves`` ran with the last word winning, silently (up to
    0.4.5); it is refused before anything is simulated, as --clean with --perfect is."""
    out = tmp_path / "m"
    args = ["simulate", "demo", "--out", str(out), "--enable", "waves", "--disable", "waves"]
    res = runner.invoke(app, args)
    assert res.exit_code == 2 and "--enable waves and --disable waves" in res.output
    assert not out.exists()
