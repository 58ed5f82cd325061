"""The sea-trial simulator (issue 4): trajectory, IMU errors, aiding sensors, presets, output.

Each claim of docs/simulation.md is checked against an independent computation: Allan
deviation theory for the IMU noise, the DVL's specified σ, the configured outlier rate, the
physics of a pendulum, the core mechanization for the whole ``paper-1`` IMU stream, the paper's
distances and durations, reproducibility and the mission loader.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav.core import earth
from adaptnav.core.units import DEG
from adaptnav.engine import propagation
from adaptnav.mission import load_mission
from adaptnav.sim import allan, imu_model, scenarios, sensors
from adaptnav.sim import kinematics as kin
from adaptnav.sim import trajectory as tr

Array = np.ndarray
SEED = 7


@pytest.fixture(scope="module")
def paper1() -> tuple[scenarios.Scenario, tr.Trajectory]:
    sc = scenarios.paper_1()
    return sc, tr.build(sc.trajectory)


@pytest.fixture(scope="module")
def paper1_sensors(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
) -> tuple[dict[str, pd.DataFrame], dict[str, object]]:
    sc, traj = paper1
    return scenarios.sensor_tables(sc, traj, SEED)


# --- trajectory ---------------------------------------------------------------------------------


def _five_point(f: Callable[[Array], Array], t: Array, h: float) -> Array:
    """Central 5-point derivative (truncation error h⁴ f⁽⁵⁾ / 30)."""
    return np.asarray((-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h))


def test_smooth_step_and_profiles_are_consistent() -> None:
    x = np.linspace(-0.2, 1.2, 141)
    h = 1e-4
    np.testing.assert_allclose(
        _five_point(tr.smooth_step, x, h), tr.smooth_step_d1(x), rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(
        _five_point(tr.smooth_step_d1, x, h), tr.smooth_step_d2(x), rtol=0, atol=1e-7
    )
    np.testing.assert_allclose(
        _five_point(tr.smooth_step_integral, x, h), tr.smooth_step(x), rtol=0, atol=1e-9
    )
    assert tr.smooth_step_d1(0.5) == pytest.approx(tr.STEP_PEAK_SLOPE)
    p = tr.StepProfile(1.0, np.array([2.0, 10.0]), np.array([4.0, 3.0]), np.array([2.0, -0.5]))
    t = np.linspace(0.0, 20.0, 401)
    np.testing.assert_allclose(_five_point(p.value, t, 1e-3), p.rate(t), atol=1e-8)
    np.testing.assert_allclose(_five_point(p.rate, t, 1e-3), p.accel(t), atol=1e-7)
    np.testing.assert_allclose(_five_point(p.integral, t, 1e-3), p.value(t), atol=1e-8)
    assert p.value(np.array([20.0]))[0] == pytest.approx(2.5)


def test_motion_derivatives_and_track_integral(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
) -> None:
    _, traj = paper1
    m = traj.motion
    t = np.linspace(1.0, traj.duration - 1.0, 1501)
    h = 1e-3
    # Exact local NED rates of change: the scale factors are constants of the motion.
    np.testing.assert_allclose(_five_point(m.position, t, h), m.position_rate(t), atol=1e-12)
    np.testing.assert_allclose(_five_point(m.position_rate, t, h), m.position_accel(t), atol=1e-14)
    np.testing.assert_allclose(_five_point(m.euler, t, h), m.euler_rate(t), atol=1e-9)
    # The Hermite-interpolated track against direct Gauss-Legendre integration of s cos χ.
    for t1 in (777.777, 4321.5, 10123.4):
        x, w = np.polynomial.legendre.leggauss(40)
        tau = np.linspace(0.0, t1, 2001)
        a, b = tau[:-1, None], tau[1:, None]
        nodes = 0.5 * (a + b) + 0.5 * (b - a) * x[None, :]
        s, chi = traj.speed.value(nodes), traj.course(nodes)
        n_ref = float(np.sum(0.5 * (b - a) * w[None, :] * s * np.cos(chi)))
        n, _ = traj._track(np.array([t1]))
        assert abs(n[0] - n_ref) < 1e-6


def test_static_phase_is_truly_at_rest(paper1: tuple[scenarios.Scenario, tr.Trajectory]) -> None:
    _, traj = paper1
    t = np.linspace(0.0, traj.static_end, 601)
    k = kin.true_kinematics(traj.motion, t)
    assert traj.static_end == 600.0
    assert np.all(k.v_n == 0.0) and np.all(k.omega_nb_b == 0.0)
    lat, h = traj.spec.lat0, traj.spec.h0
    f_rest = np.einsum("nji,j->ni", k.C_nb, -earth.gravity_n(lat, h))
    np.testing.assert_allclose(k.f_b, f_rest, rtol=0, atol=1e-14)
    # Waves start after departure.
    later = kin.true_kinematics(traj.motion, np.linspace(1500.0, 1600.0, 1001))
    assert np.ptp(later.position[:, 2]) > 0.3  # heave, m
    assert np.degrees(np.ptp(traj.motion.euler(np.linspace(1500.0, 1600.0, 1001))[:, 0])) > 4.0


@pytest.mark.parametrize(
    ("preset", "distance_m", "duration_min"), [("paper-1", 23e3, 183.0), ("paper-2", 9.63e3, 83.0)]
)
def test_preset_distances_and_durations(
    preset: str, distance_m: float, duration_min: float
) -> None:
    sc = scenarios.PRESETS[preset]()
    traj = tr.build(sc.trajectory)
    # Travelled distance of the true path (10 Hz polyline, waves included) and of the track.
    t = np.arange(0.0, traj.duration, 0.1)
    p = traj.motion.position(t)
    ned = earth.geodetic_to_ned(p[:, 0], p[:, 1], p[:, 2], p[0, 0], p[0, 1], p[0, 2])
    path = float(np.sum(np.linalg.norm(np.diff(ned[:, :2], axis=0), axis=1)))
    assert traj.distance() == pytest.approx(distance_m, rel=0.05)
    assert path == pytest.approx(distance_m, rel=0.05)
    assert traj.duration / 60.0 == pytest.approx(duration_min, rel=0.05)
    assert traj.static_end == 600.0
    v = np.linalg.norm(kin.true_kinematics(traj.motion, t[t > 900.0]).v_n[:, :2], axis=1)
    assert 2.0 < float(np.median(v)) < 2.5  # about 2 m/s


def test_mechanization_reproduces_paper1(paper1: tuple[scenarios.Scenario, tr.Trajectory]) -> None:
    """Noise-free IMU of the whole paper-1 trajectory through the compiled mechanization."""
    _, traj = paper1
    dt = 0.01
    n = math.floor(traj.duration / dt + 1e-9)
    t = np.arange(0, n + 1) * dt
    dth, dv = kin.imu_increments(traj.motion, t)
    x_true = kin.true_states(traj.motion, t[[0, -1]])
    P, q = np.zeros((15, 15)), np.zeros(12)
    w0, f0 = dth[0] / dt, dv[0] / dt

    def end_error(x: Array) -> Array:
        xt = x_true[1]
        return np.asarray(earth.geodetic_to_ned(x[0], x[1], x[2], xt[0], xt[1], xt[2]))

    # Free inertial over 183 min: the horizontal end point within 5 m (measured ≈ 1 m). The
    # vertical channel is unstable by physics (time constant √(R/2g) ≈ 570 s): rounding-level
    # errors grow by e^19 over the run, to tens of metres; it also drags the east velocity
    # through the Coriolis term.
    x, _, _, _ = propagation.propagate(x_true[0], P, dth, dv, dt, w0, f0, q)
    err = end_error(x)
    assert np.hypot(err[0], err[1]) < 5.0
    # The same with the vertical channel held at the truth every 10 s (what the depth meter
    # does in a mission): the whole 3-D end point agrees to far below a millimetre.
    x, wp, fp = x_true[0].copy(), w0, f0
    for a in range(0, n, 1000):
        b = min(n, a + 1000)
        x, _, wp, fp = propagation.propagate(x, P, dth[a:b], dv[a:b], dt, wp, fp, q)
        xt = kin.true_states(traj.motion, t[b : b + 1])[0]
        x[2], x[5] = xt[2], xt[5]
    assert np.linalg.norm(end_error(x)) < 1e-3


# --- IMU error model ------------------------------------------------------------------------------


def test_allan_deviation_recovers_arw_and_vrw() -> None:
    model = imu_model.PAPER_IMU_CALIBRATED
    dt, n = 0.01, 360_000  # one hour at 100 Hz
    zeros = np.zeros((n, 3))
    rng = imu_model.generators(np.random.SeedSequence(SEED))
    th, dv, _ = imu_model.corrupt(zeros, zeros, dt, model, rng)
    adev_g = allan.overlapping_adev(th / dt, dt, [100])[0]  # τ = 1 s
    adev_a = allan.overlapping_adev(dv / dt, dt, [100])[0]
    # At 1 s the in-run bias adds σ√(2τ/3T) ≈ 0.014 deg/h to 4 deg/h: white noise only.
    np.testing.assert_allclose(adev_g, model.arw, rtol=0.10)
    np.testing.assert_allclose(adev_a, model.vrw, rtol=0.10)
    assert model.arw / (DEG / 60.0) == pytest.approx(0.0667)
    assert model.vrw / 9.80665e-6 == pytest.approx(55.0)


def test_allan_deviation_recovers_gauss_markov_bias() -> None:
    """The Gauss-Markov hump (σ 1 deg/h, τ 1 h): 0.6166 σ near 1.89 τ, and its whole shape."""
    model = imu_model.PAPER_IMU_CALIBRATED
    T = model.gyro_bias_tau
    x_peak, ratio = allan.gauss_markov_peak()
    assert x_peak == pytest.approx(1.893, abs=0.005) and ratio == pytest.approx(0.6166, abs=1e-3)
    dt, n = 60.0, 120_000  # 2000 h at one sample per minute: ~500 peak-length averages
    zeros = np.zeros((n, 3))
    rng = imu_model.generators(np.random.SeedSequence(SEED))
    th, dv, _ = imu_model.corrupt(zeros, zeros, dt, model, rng, stationary_start=True)
    m = np.array([15, 30, 60, 114, 240, 480])  # τ = 0.25 T .. 8 T
    tau = m * dt
    for meas, sigma, q in (
        (allan.overlapping_adev(th / dt, dt, m), model.gyro_bias_sigma, model.arw),
        (allan.overlapping_adev(dv / dt, dt, m), model.accel_bias_sigma, model.vrw),
    ):
        theory = np.hypot(allan.adev_gauss_markov(sigma, T, tau), allan.adev_white(q, tau))
        np.testing.assert_allclose(meas, theory[:, None] * np.ones((1, 3)), rtol=0.10)
        at_peak = meas[3]
        np.testing.assert_allclose(at_peak, ratio * sigma, rtol=0.10)


@pytest.mark.parametrize("n", [0, 1, 2, 7, 100, 101, 4099])
@pytest.mark.parametrize("phi", [0.0, 0.5, math.exp(-0.01 / 3600.0), 1.0])
def test_first_order_recursion_is_the_sequential_one(n: int, phi: float) -> None:
    """The blocked recursion of the Gauss-Markov biases against its definition, one row at a
    time: the same values up to roundings (n: one block, blocks of √n with and without a
    short last one; φ from white noise to a random walk)."""
    rng = np.random.default_rng(SEED)
    u, y0 = rng.standard_normal((n, 3)), rng.standard_normal(3)
    expected, y = np.empty((n, 3)), y0.copy()
    for k in range(n):
        y = phi * y + u[k]
        expected[k] = y
    scale = np.abs(expected).max(initial=1.0)
    got = imu_model.first_order_recursion(u, phi, y0)
    assert got.shape == (n, 3)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13 * scale)


def test_turn_on_bias_and_switches() -> None:
    model = imu_model.PAPER_IMU
    n, dt = 1000, 0.01
    zeros = np.zeros((n, 3))
    draws = []
    for seed in range(400):
        rng = imu_model.generators(np.random.SeedSequence(seed))
        _, _, e = imu_model.corrupt(zeros, zeros, dt, model, rng, white=False, in_run=False)
        np.testing.assert_array_equal(e.gyro_bias, np.broadcast_to(e.gyro_turn_on, (n, 3)))
        draws.append(np.concatenate([e.gyro_turn_on, e.accel_turn_on]))
    std = np.std(np.array(draws), axis=0)
    np.testing.assert_allclose(std[:3], 20.0 * DEG / 3600.0, rtol=0.15)
    np.testing.assert_allclose(std[3:], 50e-3 * 9.80665, rtol=0.15)
    # Everything off: the exact increments come back unchanged.
    rng = imu_model.generators(np.random.SeedSequence(1))
    ones = np.ones((n, 3)) * 1e-3
    th, dv, _ = imu_model.corrupt(
        ones, ones, dt, model, rng, white=False, in_run=False, turn_on=False
    )
    np.testing.assert_array_equal(th, ones)
    np.testing.assert_array_equal(dv, ones)
    cal = imu_model.PAPER_IMU.calibrated()
    assert cal.gyro_turn_on_sigma == cal.gyro_bias_sigma == pytest.approx(DEG / 3600.0)


# --- aiding sensors ------------------------------------------------------------------------------


def test_dvl_noise_matches_the_specification(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
    paper1_sensors: tuple[dict[str, pd.DataFrame], dict[str, object]],
) -> None:
    sc, traj = paper1
    d = paper1_sensors[0]["dvl"]
    z = d[["vx_m_s", "vy_m_s", "vz_m_s"]].to_numpy()
    true = d[["true_vx_m_s", "true_vy_m_s", "true_vz_m_s"]].to_numpy()
    speed = np.linalg.norm(true, axis=1)
    nominal = 0.02 * speed + 0.002
    err = z - true
    clean = (d.is_outlier == 0) & (d.is_dropout == 0) & (d.noise_factor == 1.0)
    moving = clean & (speed > 1.0)
    at_rest = clean & (d.t_s < traj.static_end)
    assert moving.sum() > 20_000 and at_rest.sum() > 1500
    # σ = 2 % of speed + 2 mm/s per axis, within 10 % (measured: ~1 %).
    np.testing.assert_allclose(np.std(err[moving] / nominal[moving, None], axis=0), 1.0, rtol=0.1)
    np.testing.assert_allclose(np.std(err[at_rest], axis=0), 0.002, rtol=0.1)
    np.testing.assert_allclose(d.sigma_m_s[clean], nominal[clean])
    # Noise segments: σ × 3-10, as saved in sigma_m_s.
    seg = (d.noise_factor > 1.0) & (d.is_outlier == 0) & (d.is_dropout == 0)
    assert seg.sum() > 0.05 * len(d)
    assert d.noise_factor[seg].between(3.0, 10.0).all()
    ratio = err[seg] / d.sigma_m_s[seg].to_numpy()[:, None]
    np.testing.assert_allclose(np.std(ratio, axis=0), 1.0, rtol=0.1)
    # The config states the nominal σ at the cruising speed.
    assert sc.dvl.nominal_sigma(sc.cruise_speed) == pytest.approx(0.048)


def test_dvl_outliers_and_dropouts(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
    paper1_sensors: tuple[dict[str, pd.DataFrame], dict[str, object]],
) -> None:
    sc, traj = paper1
    tables, info = paper1_sensors
    d = tables["dvl"]
    dvl_info = info["dvl"]
    assert isinstance(dvl_info, dict)
    nav = (d.t_s > traj.static_end) & (d.is_dropout == 0)
    rate = d.is_outlier[nav].sum() / nav.sum()
    assert rate == pytest.approx(sc.dvl.outlier_rate, abs=0.5 / nav.sum())  # exactly, to rounding
    assert d.is_outlier[~nav].sum() == 0
    spikes = d[["spike_x_m_s", "spike_y_m_s", "spike_z_m_s"]].to_numpy()
    out = d.is_outlier.to_numpy() == 1
    hit = np.abs(spikes[out])
    assert np.all((hit == 0.0) | ((hit >= 0.5) & (hit <= 3.0)))
    assert np.all(hit.max(axis=1) >= 0.5)
    assert np.all(spikes[~out] == 0.0)
    assert (hit > 0).sum(axis=1).max() >= 2  # some outliers hit several axes
    # Bursts: runs of consecutive outliers.
    runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], out.astype(int), [0]]))))[::2]
    assert runs.max() >= 2 and (runs == 1).sum() > (runs >= 2).sum()
    assert dvl_info["outlier_events"] == runs.size or runs.size <= dvl_info["outlier_events"]
    # Dropouts are NaN rows, ≈ 2 % of the navigation time.
    drop = d.is_dropout.to_numpy() == 1
    assert np.all(np.isnan(d.vx_m_s[drop])) and not np.any(np.isnan(d.vx_m_s[~drop]))
    frac = drop.sum() / (d.t_s > traj.static_end).sum()
    assert frac == pytest.approx(sc.dvl.dropout_fraction, rel=0.1)


def test_pendulum_inclinometer_reads_the_specific_force_tilt() -> None:
    """A level hull (no waves, list, trim or heel): the pendulum's error is the tilt of the
    apparent vertical, atan(a_fwd / g) in pitch and -atan(a_right / g) in roll, with the
    vessel's acceleration a from finite differences of its true velocity."""
    sc = scenarios.paper_1()
    spec = dataclasses.replace(sc.trajectory, list_trim=(0.0, 0.0), heel_factor=0.0)
    traj = tr.build(spec, waves=False)
    dist = dataclasses.replace(sensors.Disturbances.perfect(), inclinometer_pendulum=True)
    # Times across the first departure and the first turns.
    t = np.arange(600.0, 2200.0, 0.5)
    truth = scenarios._truth_at(traj, t, waves=False)
    df = sensors.inclinometer(sc.inclinometer, truth, np.random.default_rng(0), dist)
    h = 1e-3
    x_p, x_m = kin.true_states(traj.motion, t + h), kin.true_states(traj.motion, t - h)
    v_dot = (x_p[:, 3:6] - x_m[:, 3:6]) / (2 * h)  # error h² v⁽³⁾/6 < 1e-8 m/s²
    lat, hh, v = truth.x[:, 0], truth.x[:, 2], truth.x[:, 3:6]
    w_ie = earth.OMEGA_IE * np.stack([np.cos(lat), 0 * lat, -np.sin(lat)], axis=1)
    rm = earth.meridian_radius(lat) + hh
    rn = earth.transverse_radius(lat) + hh
    w_en = np.stack([v[:, 1] / rn, -v[:, 0] / rm, -v[:, 1] * np.tan(lat) / rn], axis=1)
    g = earth.gravity(lat, hh)
    f_n = v_dot + np.cross(2 * w_ie + w_en, v)
    f_n[:, 2] -= g
    yaw = traj.motion.euler(t)[:, 2]
    a_fwd = np.cos(yaw) * f_n[:, 0] + np.sin(yaw) * f_n[:, 1]
    a_right = -np.sin(yaw) * f_n[:, 0] + np.cos(yaw) * f_n[:, 1]
    roll_err = -np.arctan2(a_right, -f_n[:, 2])
    pitch_err = np.arctan2(a_fwd, np.hypot(a_right, f_n[:, 2]))
    np.testing.assert_allclose(df.accel_err_roll_rad, roll_err, rtol=0, atol=1e-8)
    np.testing.assert_allclose(df.accel_err_pitch_rad, pitch_err, rtol=0, atol=1e-8)
    # Speed changes tilt it in pitch, turns in roll (outward: a starboard turn reads to port).
    assert np.degrees(np.abs(pitch_err).max()) > 0.2
    assert np.degrees(np.abs(roll_err).max()) > 0.2
    in_turn = traj.course_rate.value(t) > 0.9 * DEG
    assert np.all(roll_err[in_turn] < 0.0)
    np.testing.assert_allclose(df.roll_rad, df.true_roll_rad + df.accel_err_roll_rad, atol=1e-15)


def test_pendulum_error_grows_with_the_sea(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
    paper1_sensors: tuple[dict[str, pd.DataFrame], dict[str, object]],
) -> None:
    _, traj = paper1
    inc = paper1_sensors[0]["inclinometer"]
    lev = traj.sea_state.value(inc.t_s.to_numpy())
    err = np.hypot(inc.accel_err_roll_rad, inc.accel_err_pitch_rad)
    calm = (inc.t_s < 600.0).to_numpy()
    rough = lev > 1.55
    normal = (np.abs(lev - 1.0) < 0.01) & (traj.course_rate.value(inc.t_s.to_numpy()) == 0.0)
    assert float(err[calm].max()) < 1e-9  # at rest the pendulum is exact
    rms = {k: float(np.sqrt(np.mean(err[m] ** 2))) for k, m in (("n", normal), ("r", rough))}
    assert rms["r"] > 1.4 * rms["n"] > 0.05 * DEG


def test_depth_noise_follows_the_sea_state(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
    paper1_sensors: tuple[dict[str, pd.DataFrame], dict[str, object]],
) -> None:
    sc, traj = paper1
    d = paper1_sensors[0]["depth"]
    lev = traj.sea_state.value(d.t_s.to_numpy())
    spec = sc.depth
    expected = spec.sigma_calm + (spec.sigma_nominal - spec.sigma_calm) * lev**2
    np.testing.assert_allclose(d.sigma_m, expected)
    assert d.sigma_m.max() < 2.0
    err = (d.depth_m - d.true_depth_m).to_numpy()
    for m in (lev < 0.01, np.abs(lev - 1.0) < 0.01, lev > 1.59):
        assert m.sum() > 300
        np.testing.assert_allclose(np.std(err[m]), expected[m].mean(), rtol=0.1)


def test_sensor_clocks_are_asynchronous(
    paper1_sensors: tuple[dict[str, pd.DataFrame], dict[str, object]],
) -> None:
    tables, _ = paper1_sensors
    firsts = {k: float(v.t_s.iloc[0]) for k, v in tables.items()}
    assert len(set(firsts.values())) == len(firsts)
    for name, rate in (("dvl", 3.0), ("depth", 1.0), ("inclinometer", 5.0), ("gps", 1.0)):
        dt = np.diff(tables[name].t_s.to_numpy())
        assert np.all(dt > 0.0)
        assert np.median(dt) == pytest.approx(1.0 / rate, rel=0.01)
        assert 0.0 < np.std(dt) < 0.05 / rate


def test_switching_one_disturbance_keeps_the_others(
    paper1: tuple[scenarios.Scenario, tr.Trajectory],
    paper1_sensors: tuple[dict[str, pd.DataFrame], dict[str, object]],
) -> None:
    sc, traj = paper1
    all_on = paper1_sensors[0]["dvl"]
    no_out, _ = scenarios.sensor_tables(sc, traj, SEED, sensors.Disturbances(dvl_outliers=False))
    d = no_out["dvl"]
    assert d.is_outlier.sum() == 0
    same = (all_on.is_outlier == 0).to_numpy()
    np.testing.assert_array_equal(d.vx_m_s[same], all_on.vx_m_s[same])
    clean, _ = scenarios.sensor_tables(sc, traj, SEED, sensors.Disturbances.clean())
    c = clean["dvl"]
    assert not c.vx_m_s.isna().any() and (c.noise_factor == 1.0).all()
    assert (clean["inclinometer"].accel_err_roll_rad == 0.0).all()


# --- the written mission ----------------------------------------------------------------------


def test_same_seed_same_files_and_the_mission_loads(tmp_path: Path) -> None:
    a = scenarios.simulate("demo", 3, tmp_path / "a", sensors.Disturbances())
    b = scenarios.simulate("demo", 3, tmp_path / "b", sensors.Disturbances())
    c = scenarios.simulate("demo", 4, tmp_path / "c", sensors.Disturbances())
    ha, hb, hc = (scenarios.table_hashes(p) for p in (a, b, c))
    assert set(ha) >= {"mission.toml", "imu.parquet", "dvl.parquet", "truth.parquet"}
    assert ha == hb
    assert all(ha[k] != hc[k] for k in ha if k.endswith(".parquet") and k != "truth.parquet")
    assert ha["truth.parquet"] != hc["truth.parquet"]  # the true biases differ

    m = load_mission(a)
    cfg = m.config
    assert not m.repairs and not m.dropped
    assert set(m.sensors) == {"dvl", "depth", "inclinometer", "gps"}  # heading is "off"
    assert {n: s.use for n, s in cfg.sensors.items()} == {
        "dvl": "aid", "depth": "aid", "inclinometer": "aid", "heading": "off", "gps": "init",
    }  # fmt: skip
    assert cfg.initial.mode == "alignment" and cfg.initial.alignment_s == 600.0
    assert cfg.imu.format == "increments" and cfg.imu.rate_hz == 100.0
    assert len(m.imu) == 90640 and np.allclose(m.imu.dt, 0.01)
    assert m.truth is not None and len(m.truth) == 9065
    assert {"bg_x_rad_s", "ba_z_m_s2", "sea_state"} <= set(m.truth.columns)
    assert {"is_outlier", "sigma_m_s"} <= set(m.tables["dvl"].columns)
    # The configured noise is the sensors' nominal (clean) accuracy and the calibrated IMU.
    assert cfg.sensors["dvl"].sigma_si() == pytest.approx(0.048)
    assert cfg.sensors["inclinometer"].sigma_si() == pytest.approx(0.1 * DEG)
    g_sigma, a_sigma = cfg.imu.initial_bias_sigma.si(cfg.imu.noise.to_imu_noise())
    assert g_sigma == pytest.approx(DEG / 3600.0) and a_sigma == pytest.approx(0.25e-3 * 9.80665)
    assert cfg.initial.rpy_deg is not None
    # NaN DVL rows reach the loader as NaN readings (the engine records them as dropped).
    dvl = m.sensors["dvl"]
    assert np.isnan(dvl.z).any() == bool(m.tables["dvl"].is_dropout.any())


def test_perfect_mission_is_exact(tmp_path: Path) -> None:
    sim = scenarios.generate(scenarios.demo(), 1, sensors.Disturbances.perfect())
    imu = sim.tables["imu"]
    t = np.concatenate([[0.0], imu.t_s.to_numpy()])
    dth, dv = kin.imu_increments(sim.trajectory.motion, t)
    np.testing.assert_array_equal(imu[["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]], dth)
    np.testing.assert_array_equal(imu[["dvel_x_m_s", "dvel_y_m_s", "dvel_z_m_s"]], dv)
    d = sim.tables["dvl"]
    np.testing.assert_array_equal(d.vx_m_s, d.true_vx_m_s)
    assert np.all(np.diff(d.t_s) == pytest.approx(1.0 / 3.0))
    uncal = scenarios.generate(
        scenarios.demo(), 1, sensors.Disturbances(imu_uncalibrated_turn_on=True)
    )
    g_sigma, _ = uncal.config.imu.initial_bias_sigma.si(uncal.config.imu.noise.to_imu_noise())
    assert g_sigma == pytest.approx(20.0 * DEG / 3600.0)
    with pytest.raises(ValueError, match="unknown preset"):
        scenarios.simulate("paper-3", 1, tmp_path, sensors.Disturbances())


def _tiny(lat0: float, lon0: float, course0: float) -> scenarios.Scenario:
    """The demo cut to 20 s alongside then 20 s at 1 m/s (a fraction of a second to simulate),
    starting at (lat0, lon0) on the course ``course0`` (rad)."""
    base = scenarios.demo()
    spec = dataclasses.replace(
        base.trajectory, lat0=lat0, lon0=lon0, course0=course0,
        segments=(tr.Static(20.0), tr.Straight(20.0, 1.0)),
        sea_state=(tr.SeaState(20.0, 1.0, 10.0),), max_accel=0.5, min_step=1.0,
    )  # fmt: skip
    return dataclasses.replace(base, name="tiny", trajectory=spec)


@pytest.mark.parametrize("course_deg", [270.0, 90.0], ids=["westwards", "eastwards"])
def test_longitudes_across_the_antimeridian_are_wrapped(tmp_path: Path, course_deg: float) -> None:
    """A track crossing 180° writes its truth and GPS longitudes in [-π, π) (docs/simulation.md,
    'What is written'): past -180° the loader drops the fixes as implausible and refuses the
    truth (up to 0.4.6 the truth ran on to -180.00014°); the wrap moves a longitude by whole
    turns only, after the GPS noise is added (a fix 2 m off the line, noise σ 2.9 m)."""
    r = earth.transverse_radius(0.3) * math.cos(0.3)
    lon0 = -math.pi + 2.0 / r if course_deg == 270.0 else math.pi - 2.0 / r
    sc = _tiny(0.3, lon0, course_deg * DEG)
    out = scenarios.simulate_scenario(sc, SEED, tmp_path / "m")
    truth, gps = (pd.read_parquet(out / f"{n}.parquet") for n in ("truth", "gps"))
    for name, lon in (("truth", truth.lon_rad), ("gps", gps.lon_rad)):
        assert ((lon >= -math.pi) & (lon < math.pi)).all(), f"{name}: {lon.min()}, {lon.max()}"
    track = tr.build(sc.trajectory).motion.position(truth.t_s.to_numpy())[:, 1]
    assert np.any(np.abs(track) > math.pi)  # the track does cross
    turns = (truth.lon_rad.to_numpy() - track) / (2.0 * math.pi)
    np.testing.assert_allclose(turns, np.round(turns), rtol=0, atol=1e-12)
    m = load_mission(out)
    assert not m.dropped and m.sensors["gps"].t.size == len(gps)


@pytest.mark.parametrize(
    ("lat0_deg", "course_deg", "pole"),
    [(earth.MAX_LAT_DEG, 0.0, "north"), (-earth.MAX_LAT_DEG, 180.0, "south"), (90.0, 0.0, "north")],
    ids=["north", "south", "across"],
)
def test_a_trajectory_reaching_a_pole_is_refused_before_writing(
    tmp_path: Path, lat0_deg: float, course_deg: float, pole: str
) -> None:
    """A track that comes within 0.01° of a pole (``earth.MAX_LAT_DEG``) or crosses one is a
    ValueError naming the first instant and the latitude, and nothing is written: there the
    latitude-longitude mechanization is singular (docs/conventions.md; up to 0.4.6 the mission
    was written and only the run refused it). The start is 10 m short of the limit (5 m short
    of the pole for ``across``), the track heads for it at 1 m/s; the same start heading away
    is simulated."""
    short = 10.0 if abs(lat0_deg) < 90.0 else 5.0
    rm = float(earth.meridian_radius(math.radians(lat0_deg)))
    lat0 = math.radians(lat0_deg) - math.copysign(short, lat0_deg) / rm
    sc = _tiny(lat0, 0.5, course_deg * DEG)
    motion = tr.build(sc.trajectory).motion
    t = np.arange(0, 4001) / 100.0
    t_first = t[np.flatnonzero(np.abs(motion.position(t)[:, 0]) > earth.MAX_LAT_RAD)[0]]
    out = tmp_path / "m"
    with pytest.raises(ValueError, match=rf"within 0\.01° of the {pole} pole") as info:
        scenarios.simulate_scenario(sc, SEED, out)
    got = re.search(r"at ([\d.]+) s its latitude reaches (-?[\d.]+)°", str(info.value))
    assert got is not None, str(info.value)
    t_got, lat_got = float(got[1]), float(got[2])
    assert t_first <= t_got <= t_first + 0.1 + 1e-9  # checked every 0.1 s
    there = math.degrees(motion.position(np.array([t_got]))[0, 0])
    assert abs(lat_got) > earth.MAX_LAT_DEG and lat_got == pytest.approx(there, abs=1e-7)
    assert ("crosses the pole" in str(info.value)) == (abs(lat0_deg) == 90.0)
    assert not out.exists()
    if abs(lat0_deg) < 90.0:
        away = _tiny(lat0, 0.5, course_deg * DEG + math.pi)
        scenarios.generate(away, SEED)  # 10 m inside the limit, heading away: simulated
