"""True calibration errors of the simulated sensors (docs/simulation.md, 'Calibration errors').

Each error against an independent computation on the demo scenario: the DVL's scale factor and
misalignment (rotations built here from elementary ones, not by ``attitude.euler_to_dcm``),
the depth and inclinometer biases; the truth columns stay the error-free readings, the random
streams are untouched (so with every disturbance on, calibrated minus uncalibrated readings is
the error alone), and no error leaves every table as the simulator made it before errors existed.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav.core.units import DEG
from adaptnav.sim import scenarios
from adaptnav.sim import trajectory as tr
from adaptnav.sim.sensors import Calibration, Disturbances

SEED = 11
PERFECT = Disturbances.perfect()
ALL_ON = Disturbances()
V = ["vx_m_s", "vy_m_s", "vz_m_s"]
TRUE_V = ["true_vx_m_s", "true_vy_m_s", "true_vz_m_s"]

DEMO_TABLES_DIGEST = "e4f0cfdef4c3828909aa04301329a4a2ddc7963384471012142d565b1eac2dfa"
"""Digest (:func:`_digest`) of the demo's sensor tables for SEED, every disturbance on, as the
simulator made them before calibration errors were added (commit 74b9c87)."""


@pytest.fixture(scope="module")
def demo() -> tuple[scenarios.Scenario, tr.Trajectory]:
    sc = scenarios.demo()
    return sc, tr.build(sc.trajectory)


def _tables(
    demo: tuple[scenarios.Scenario, tr.Trajectory],
    dist: Disturbances,
    cal: Calibration | None = None,
) -> dict[str, pd.DataFrame]:
    sc, traj = demo
    return scenarios.sensor_tables(sc, traj, SEED, dist, cal)[0]


def _digest(tables: dict[str, pd.DataFrame]) -> str:
    """SHA-256 of the tables' names, columns and values to 1e-9 (independent of the Parquet
    writer's version)."""
    h = hashlib.sha256()
    for name in sorted(tables):
        df = tables[name]
        h.update(name.encode())
        h.update(",".join(df.columns).encode())
        h.update(np.round(df.to_numpy(dtype=float), 9).tobytes())
    return h.hexdigest()


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# --- DVL ---------------------------------------------------------------------------------------


def test_dvl_scale_factor_scales_the_readings_not_the_truth(
    demo: tuple[scenarios.Scenario, tr.Trajectory],
) -> None:
    cal = Calibration(dvl_scale=1.01)
    exact = _tables(demo, PERFECT)["dvl"]
    d = _tables(demo, PERFECT, cal)["dvl"]
    true = d[TRUE_V].to_numpy()
    assert np.abs(true[:, 0]).max() > 1.5  # under way
    np.testing.assert_array_equal(true, exact[TRUE_V].to_numpy())  # error-free truth columns
    np.testing.assert_allclose(d[V].to_numpy(), 1.01 * true, rtol=1e-15, atol=0.0)
    # Every disturbance on: the same noise, spikes and dropouts, so only 0.01 z differs.
    on, on_cal = _tables(demo, ALL_ON)["dvl"], _tables(demo, ALL_ON, cal)["dvl"]
    diff = on_cal[V].to_numpy() - on[V].to_numpy()
    valid = ~np.isnan(on[V].to_numpy()).any(axis=1)
    assert valid.sum() > 1000 and (~valid).any()
    np.testing.assert_array_equal(np.isnan(diff).any(axis=1), ~valid)
    np.testing.assert_allclose(diff[valid], 0.01 * on[TRUE_V].to_numpy()[valid], atol=1e-12)


def test_a_yaw_misalignment_turns_the_dvl_reading_the_other_way(
    demo: tuple[scenarios.Scenario, tr.Trajectory],
) -> None:
    # The true DVL frame is turned +1° about z (to starboard): forward motion reads as moving
    # 1° to port, a negative y component.
    d = _tables(demo, PERFECT, Calibration(dvl_misalignment=(0.0, 0.0, 1.0 * DEG)))["dvl"]
    v, true = d[V].to_numpy(), d[TRUE_V].to_numpy()
    fwd = true[:, 0] > 1.0
    assert fwd.sum() > 100
    turned = np.arctan2(v[:, 1], v[:, 0]) - np.arctan2(true[:, 1], true[:, 0])
    np.testing.assert_allclose(turned[fwd], -1.0 * DEG, atol=1e-12)
    assert (v[fwd, 1] < true[fwd, 1] - 0.01).all()
    np.testing.assert_allclose(np.hypot(v[:, 0], v[:, 1]), np.hypot(true[:, 0], true[:, 1]))
    np.testing.assert_allclose(v[:, 2], true[:, 2], rtol=0.0, atol=1e-15)


def test_a_misalignment_is_the_transposed_zyx_rotation_with_the_scale(
    demo: tuple[scenarios.Scenario, tr.Trajectory],
) -> None:
    roll, pitch, yaw = 0.7 * DEG, -1.5 * DEG, 2.0 * DEG
    cal = Calibration(dvl_scale=0.98, dvl_misalignment=(roll, pitch, yaw))
    d = _tables(demo, PERFECT, cal)["dvl"]
    c_mis = (_rz(yaw) @ _ry(pitch) @ _rx(roll)).T
    # small angles: C_mis ≈ I - [δ×] to second order
    delta = np.array([roll, pitch, yaw])
    skew = np.array([[0, -yaw, pitch], [yaw, 0, -roll], [-pitch, roll, 0]])
    assert np.abs(c_mis - (np.eye(3) - skew)).max() < np.dot(delta, delta)
    expected = 0.98 * d[TRUE_V].to_numpy() @ c_mis.T
    np.testing.assert_allclose(d[V].to_numpy(), expected, rtol=0.0, atol=1e-14)


# --- depth and inclinometer --------------------------------------------------------------------


def test_depth_bias_shifts_the_readings_by_exactly_the_bias(
    demo: tuple[scenarios.Scenario, tr.Trajectory],
) -> None:
    cal = Calibration(depth_bias=-0.7)
    d = _tables(demo, PERFECT, cal)["depth"]
    np.testing.assert_array_equal(d.true_depth_m, _tables(demo, PERFECT)["depth"].true_depth_m)
    np.testing.assert_allclose(d.depth_m - d.true_depth_m, -0.7, rtol=0.0, atol=1e-12)
    on, on_cal = _tables(demo, ALL_ON)["depth"], _tables(demo, ALL_ON, cal)["depth"]
    np.testing.assert_allclose(on_cal.depth_m - on.depth_m, -0.7, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("pendulum", [False, True], ids=["attitude", "pendulum"])
def test_inclinometer_biases_shift_the_angles_it_outputs(
    demo: tuple[scenarios.Scenario, tr.Trajectory], pendulum: bool
) -> None:
    bias = (0.5 * DEG, -0.3 * DEG)
    dist = Disturbances(**{**PERFECT.as_dict(), "inclinometer_pendulum": pendulum})
    d = _tables(demo, dist, Calibration(inclinometer_bias=bias))["inclinometer"]
    # pendulum: what it outputs is the tilt of the specific force, the truth plus accel_err
    out_roll = d.true_roll_rad + d.accel_err_roll_rad
    out_pitch = d.true_pitch_rad + d.accel_err_pitch_rad
    assert (d.accel_err_roll_rad != 0.0).any() == pendulum
    np.testing.assert_allclose(d.roll_rad - out_roll, bias[0], rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(d.pitch_rad - out_pitch, bias[1], rtol=0.0, atol=1e-12)


# --- no error, and the truth written -----------------------------------------------------------


def test_no_calibration_error_leaves_the_tables_as_before(
    demo: tuple[scenarios.Scenario, tr.Trajectory],
) -> None:
    assert _digest(_tables(demo, ALL_ON)) == DEMO_TABLES_DIGEST
    assert _digest(_tables(demo, ALL_ON, Calibration())) == DEMO_TABLES_DIGEST
    assert _digest(_tables(demo, ALL_ON, Calibration(depth_bias=1e-6))) != DEMO_TABLES_DIGEST


def test_simulation_json_has_the_true_errors_only_when_there_are_some(tmp_path: Path) -> None:
    a = scenarios.simulate("demo", SEED, tmp_path / "a")
    b = scenarios.simulate("demo", SEED, tmp_path / "b", calibration=Calibration())
    cal = Calibration(depth_bias=0.25, inclinometer_bias=(0.0, 0.2 * DEG))
    c = scenarios.simulate("demo", SEED, tmp_path / "c", calibration=cal)
    ha, hb, hc = (scenarios.table_hashes(p) for p in (a, b, c))
    assert ha == hb
    assert "calibration" not in json.loads((a / "simulation.json").read_text())
    assert {k for k in ha if ha[k] != hc[k]} == {
        "depth.parquet",
        "inclinometer.parquet",
        "simulation.json",
    }
    truth = json.loads((c / "simulation.json").read_text())["calibration"]
    assert truth["depth_bias_m"] == 0.25 and truth["dvl_scale_factor"] == 1.0
    assert truth["inclinometer_bias_deg"] == pytest.approx([0.0, 0.2])
    assert truth["inclinometer_bias_rad"] == pytest.approx([0.0, 0.2 * DEG])
    assert truth["dvl_misalignment_rad"] == truth["dvl_misalignment_deg"] == [0.0, 0.0, 0.0]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"dvl_scale": 0.0}, "DVL scale factor 0 is not within 1 ± 0.5"),
        ({"dvl_scale": math.nan}, "DVL scale factor nan"),
        ({"dvl_misalignment": (0.0, 0.0)}, "DVL misalignment needs 3 angles, got 2"),
        ({"dvl_misalignment": (0.0, 11 * DEG, 0.0)}, "DVL misalignment angle 11° is beyond"),
        ({"depth_bias": math.inf}, "depth bias inf m is beyond ±100 m"),
        ({"depth_bias": -100.5}, "depth bias -100.5 m is beyond ±100 m"),
        ({"depth_bias": math.nan}, "depth bias nan m is beyond ±100 m"),
        ({"inclinometer_bias": (0.0, -10.5 * DEG)}, "inclinometer bias angle -10.5°"),
    ],
)
def test_impossible_errors_are_refused(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        Calibration(**kwargs)  # type: ignore[arg-type]
