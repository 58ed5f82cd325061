"""The DVL's and the depth meter's scale, and the DVL's direction, against the other sensors
(mission/scales.py; docs/robustness.md, 'DVL and depth scales').

Synthetic motion with a known answer (helpers/diving.py): a vehicle at 1.5 m/s pitching ±15°
(a yo-yo) and turning, with a DVL, a depth meter, a GNSS track and a heading sensor that read
it with white noise. Right tables must pass; a unit slip or an axis negated or swapped must be
found and named."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pandas as pd
import pytest

from adaptnav.core import attitude
from adaptnav.core.earth import OMEGA_IE
from adaptnav.mission import axes, scales
from helpers import diving

V = ["vx_m_s", "vy_m_s", "vz_m_s"]


def _fits(
    tabs: dict[str, pd.DataFrame], heading: bool = True
) -> tuple[scales.Fit | None, scales.Fit | None, scales.Fit | None]:
    """(depth slope, DVL speed ratio, DVL direction) of the tables."""
    imu = tabs["imu"]
    t = imu["t_s"].to_numpy()[1:]
    dt = np.diff(imu["t_s"].to_numpy())
    rates = imu[["gyro_x_rad_s", "gyro_y_rad_s", "gyro_z_rad_s"]].to_numpy()[1:]
    accel = imu[["accel_x_m_s2", "accel_y_m_s2", "accel_z_m_s2"]].to_numpy()[1:]
    tilt = axes.AccelTilt.of(t, dt, accel * dt[:, None], None, 1e-3 / math.sqrt(diving.RATE_HZ))
    gyro = axes.Gyro.of(t, dt, rates * dt[:, None], None, 1e-4 / math.sqrt(diving.RATE_HZ))
    d = tabs["dvl"]
    dvl = scales.Dvl.of(d["t_s"].to_numpy(), d[V].to_numpy(), None, 0.5, 0.02)
    dep = tabs["depth"]
    depth = scales.depth_scale(
        dep["t_s"].to_numpy(), dep["depth_m"].to_numpy(), dvl, tilt, np.zeros(3)
    )
    g = tabs["gps"]
    track = scales.Track.of(
        g["t_s"].to_numpy(),
        np.radians(g["lat_deg"].to_numpy()),
        np.radians(g["lon_deg"].to_numpy()),
        2.0,
    )
    h = tabs["heading"]
    psi = (h["t_s"].to_numpy(), np.radians(h["yaw_deg"].to_numpy())) if heading else None
    speed, turn = scales.dvl_track(track, dvl, tilt, gyro, psi)
    return depth, speed, turn


def test_right_tables_give_one_and_no_turn() -> None:
    depth, speed, turn = _fits(diving.tables())
    assert depth is not None and speed is not None and turn is not None
    assert abs(depth.k - 1.0) < 0.03 and not depth.outside(scales.DEPTH_BAND), depth
    assert abs(speed.k - 1.0) < 0.03 and not speed.outside(scales.SPEED_BAND), speed
    assert abs(turn.angle_deg) < 2.0 and not turn.turned(), turn


@pytest.mark.parametrize(
    ("factor", "k", "unit"),
    [(1 / 0.3048, 3.28, "feet"), (10.05, 10.05, "kPa"), (0.1005, 0.1, "bar"), (1.458, 1.46, "psi")],
)
def test_a_depth_in_another_unit_is_named(factor: float, k: float, unit: str) -> None:
    tabs = diving.tables()
    tabs["depth"] = tabs["depth"].assign(depth_m=tabs["depth"]["depth_m"] * factor)
    depth = _fits(tabs)[0]
    assert depth is not None and depth.outside(scales.DEPTH_BAND), depth
    assert abs(depth.k / k - 1.0) < 0.05 and unit in scales.depth_cause(depth)


def test_a_dvl_in_knots_is_named_by_the_track_and_by_the_depth() -> None:
    tabs = diving.tables()
    tabs["dvl"] = tabs["dvl"].assign(**{c: tabs["dvl"][c] * 1.943844 for c in V})
    depth, speed, turn = _fits(tabs)
    assert speed is not None and speed.outside(scales.SPEED_BAND) and abs(speed.k - 1.944) < 0.05
    assert "knots" in scales.speed_cause(speed)
    assert depth is not None and depth.outside(scales.DEPTH_BAND)
    assert "the DVL in knots" in scales.depth_cause(depth)
    assert turn is not None and not turn.turned()


def test_a_dvl_x_negated_turns_the_direction_and_the_depth_over() -> None:
    tabs = diving.tables()
    tabs["dvl"] = tabs["dvl"].assign(vx_m_s=-tabs["dvl"]["vx_m_s"])
    depth, speed, turn = _fits(tabs)
    assert depth is not None and depth.k < -0.8 and depth.outside(scales.DEPTH_BAND)
    assert "x axis negated" in scales.depth_cause(depth)
    assert speed is not None and not speed.outside(scales.SPEED_BAND)  # the speed is right
    assert turn is not None and turn.turned() and abs(turn.angle_deg) > 170.0
    assert "x axis negated" in scales.turn_cause(turn)


def test_a_dvl_x_and_y_swapped_turns_the_direction_by_a_right_angle() -> None:
    tabs = diving.tables()
    tabs["dvl"] = tabs["dvl"].assign(vx_m_s=tabs["dvl"]["vy_m_s"], vy_m_s=tabs["dvl"]["vx_m_s"])
    depth, _, turn = _fits(tabs)
    assert depth is None or not depth.outside(scales.DEPTH_BAND)  # the x axis is gone: no climb
    assert turn is not None and turn.turned() and abs(abs(turn.angle_deg) - 90.0) < 5.0
    assert "swapped" in scales.turn_cause(turn)
    assert _fits(tabs, heading=False)[2] is None  # without a heading nothing is said


def test_a_surface_vessel_says_nothing_of_its_depth() -> None:
    """Its depth barely moves, the DVL's vertical displacements are noise: a slope near 0
    with a small σ would read as a depth in bar. The correlation gate keeps it undecided, even
    with the depth in feet."""
    tabs = diving.tables(pitch_deg=0.0)
    assert _fits(tabs)[0] is None
    tabs["depth"] = tabs["depth"].assign(depth_m=tabs["depth"]["depth_m"] / 0.3048)
    assert _fits(tabs)[0] is None


def test_the_through_origin_fit_leaves_outliers_out() -> None:
    rng = np.random.default_rng(3)
    b = rng.uniform(20.0, 60.0, 200)
    a = 1.5 * b + rng.normal(0.0, 1.0, b.size)
    a[::20] += 100.0
    fit = scales.through_origin(a, b)
    assert fit is not None and abs(fit[0] - 1.5) < 0.01 and fit[2] <= 190
    w = scales.through_origin(b * np.exp(1j * 0.5), b.astype(complex))
    assert w is not None and abs(np.angle(w[0]) - 0.5) < 1e-9
    assert scales.through_origin(a[:5], b[:5]) is None


def test_likely_unit_names_only_a_near_slope() -> None:
    assert scales.likely_unit(3.3, scales.UNITS_DEPTH) == "feet"
    assert scales.likely_unit(2.0, scales.UNITS_DEPTH) is None
    assert scales.likely_unit(-1.0, scales.UNITS_DEPTH) is None
    assert scales.likely_unit(3.6, scales.UNITS_SPEED) == "km/h"


def _rest_imu(lat: float, rate: float, hours: float = 3.0) -> tuple[axes.Gyro, axes.AccelTilt]:
    """A body rolled 5° and pitched -3° at latitude ``lat`` (rad), turning about the vertical
    at ``rate`` (rad/s) from a yaw of 40°: its gyro reads the earth rate and the turn, exactly
    (``ω_b = C_bn (ω_ie + rate·down)``), at 10 Hz; its accelerometers read ``-g`` turned."""
    t = np.arange(0.1, hours * 3600.0 + 1e-9, 0.1)
    w_n = np.array([OMEGA_IE * math.cos(lat), 0.0, -OMEGA_IE * math.sin(lat)])
    roll, pitch = math.radians(5.0), math.radians(-3.0)
    c_nb0 = attitude.euler_to_dcm(roll, pitch, 0.0)
    yaw = math.radians(40.0) + rate * (t - 0.05)  # at each interval's middle
    cy, sy = np.cos(yaw), np.sin(yaw)
    # C_bn = C_nb0ᵀ Rz(ψ)ᵀ: each row turned by -ψ about down, then by the fixed tilt.
    w_z = np.column_stack([cy * w_n[0] + sy * w_n[1], -sy * w_n[0] + cy * w_n[1]])
    w_turned = np.column_stack([w_z, np.full(t.size, w_n[2] + rate)])
    w_b = w_turned @ c_nb0
    f_b = np.tile(c_nb0.T @ np.array([0.0, 0.0, -9.81]), (t.size, 1))
    dt = np.full(t.size, 0.1)
    return axes.Gyro.of(t, dt, w_b * 0.1), axes.AccelTilt.of(t, dt, f_b * 0.1)


@pytest.mark.parametrize("lat_deg", [26.8, -45.0, 70.0])
@pytest.mark.parametrize("rate_deg_s", [0.0, 0.5])
def test_the_carried_yaw_follows_the_body_at_any_latitude(
    lat_deg: float, rate_deg_s: float
) -> None:
    """The earth's rate taken off with the right sign: a body fixed to the earth keeps its yaw
    over 3 h (the wrong sign: 2 Ω sin L T, 40° at 26.8° N), one turning turns by its rate."""
    lat, rate = math.radians(lat_deg), math.radians(rate_deg_s)
    gyro, tilt = _rest_imu(lat, rate)
    start = scales.StartYaw(math.radians(40.0), math.radians(1.0), 0.0, 0.0)
    h = scales.carried_yaw(gyro, tilt, lat, start)
    truth = math.radians(40.0) + rate * (h.t - h.t[0])
    err = np.degrees(np.abs(axes.wrap(h.yaw - truth)))
    assert float(err.max()) < 0.01, float(err.max())
    assert h.sigma is not None and np.allclose(h.sigma, math.radians(1.0))


def test_the_carried_yaw_sigma_grows_with_the_bias_and_the_arw() -> None:
    start = scales.StartYaw(math.radians(1.0), math.radians(1.0), math.radians(1.0) / 3600, 0.0)
    assert math.degrees(float(start.sigma_after(np.array([3 * 3600.0]))[0])) == pytest.approx(
        math.sqrt(10.0)
    )
    arw = scales.StartYaw(0.0, 0.0, 0.0, math.radians(0.1) / 60.0)  # 0.1 deg/sqrt(h)
    assert math.degrees(float(arw.sigma_after(np.array([4 * 3600.0]))[0])) == pytest.approx(0.2)


def _carried_turn(tabs: dict[str, pd.DataFrame], bias_deg_h: float = 1.0) -> scales.Fit | None:
    """The direction fit with the start's yaw (the true 0°, σ 1°) carried by the gyro; the
    helper's gyro has no earth rate, so the latitude given is 0."""
    imu = tabs["imu"]
    t = imu["t_s"].to_numpy()[1:]
    dt = np.diff(imu["t_s"].to_numpy())
    rates = imu[["gyro_x_rad_s", "gyro_y_rad_s", "gyro_z_rad_s"]].to_numpy()[1:]
    accel = imu[["accel_x_m_s2", "accel_y_m_s2", "accel_z_m_s2"]].to_numpy()[1:]
    tilt = axes.AccelTilt.of(t, dt, accel * dt[:, None])
    gyro = axes.Gyro.of(t, dt, rates * dt[:, None])
    d = tabs["dvl"]
    dvl = scales.Dvl.of(d["t_s"].to_numpy(), d[V].to_numpy(), None, 0.5, 0.02)
    g = tabs["gps"]
    lat, lon = np.radians(g["lat_deg"].to_numpy()), np.radians(g["lon_deg"].to_numpy())
    track = scales.Track.of(g["t_s"].to_numpy(), lat, lon, 2.0)
    start = scales.StartYaw(0.0, math.radians(1.0), math.radians(bias_deg_h) / 3600.0, 0.0)
    return scales.dvl_track(track, dvl, tilt, gyro, scales.carried_yaw(gyro, tilt, 0.0, start))[1]


@pytest.mark.parametrize(
    ("change", "angle", "words"),
    [("none", 0.0, ""), ("negate", 180.0, "x axis negated"), ("swap", 90.0, "x and y swapped")],
)
def test_without_a_heading_sensor_the_start_s_yaw_carried_tells_the_direction(
    change: str, angle: float, words: str
) -> None:
    tabs = diving.tables()
    dvl = tabs["dvl"]
    if change == "negate":
        tabs["dvl"] = dvl.assign(vx_m_s=-dvl["vx_m_s"])
    elif change == "swap":
        tabs["dvl"] = dvl.assign(vx_m_s=dvl["vy_m_s"], vy_m_s=dvl["vx_m_s"])
    turn = _carried_turn(tabs)
    assert turn is not None and abs(abs(turn.angle_deg) - angle) < 5.0, turn
    assert turn.turned() == (change != "none"), turn
    assert 1.0 <= turn.angle_se_deg < 2.0  # the start's σ (1°) joins the fit's
    assert words in scales.turn_cause(turn, carried=True)
    assert "initial.rpy_deg" in scales.turn_cause(turn, carried=True)


def test_chords_whose_carried_yaw_is_too_uncertain_do_not_count() -> None:
    """A gyro whose bias σ carries the yaw beyond 10° within a minute leaves too few chords."""
    tabs = diving.tables()
    tabs["dvl"] = tabs["dvl"].assign(vx_m_s=-tabs["dvl"]["vx_m_s"])
    assert _carried_turn(tabs, bias_deg_h=600.0) is None
    turn = _carried_turn(tabs, bias_deg_h=60.0)  # 10° at 9.9 min: all but the last chords
    assert turn is not None and turn.turned() and turn.t_to < 600.0


def test_the_depth_at_fixes_pairs_only_readings_near_a_fix() -> None:
    """An AUV that surfaces for fixes between dives: only the readings at the surface count,
    and an atmosphere left in the readings shows whole (since 0.4.11)."""
    t = np.arange(0.0, 3600.0, 1.0)
    dive = 40.0 * np.clip(np.sin(2.0 * np.pi * t / 1200.0), 0.0, None)  # 0 at the surface
    depth = 0.4 + dive
    t_fix = t[dive == 0.0] + 0.3  # fixes only while surfaced, stamped 0.3 s after the depth
    at = scales.depth_at_fixes(t, depth, t_fix, antenna_above_m=1.5)
    assert at is not None and at.n == t_fix.size
    assert at.depth_m == pytest.approx(0.4) and at.under_m == pytest.approx(0.4 - 1.5)
    at = scales.depth_at_fixes(t, depth + scales.ATMOSPHERE_M, t_fix, antenna_above_m=1.5)
    assert at is not None and at.under_m == pytest.approx(0.4 + 10.08 - 1.5)
    assert "absolute pressure" in scales.surface_cause(at)
    far = scales.depth_at_fixes(t[::5], depth[::5], t[::5][dive[::5] == 0.0] + 2.5, 1.5)
    assert far is None  # no depth reading within a second of any fix


def test_an_antenna_below_the_depth_meter_is_under_water_where_the_meter_is() -> None:
    """Lever arms that put the antenna 3.8 m below the depth meter: where the meter reads 1.2 m
    (under water) the antenna is 5 m down; where it reads 0 (in air, however high) nothing is
    bounded. Up to 0.4.12 the loader passed the height clipped at 0: 1.2 m under."""
    t = np.arange(0.0, 600.0, 1.0)
    at = scales.depth_at_fixes(t, np.full(t.size, 1.2), t + 0.2, antenna_above_m=-3.8)
    assert at is not None and at.under_m == pytest.approx(5.0)
    assert "3.8 m below the depth meter" in scales.surface_cause(at)
    dry = scales.depth_at_fixes(t, np.zeros(t.size), t + 0.2, antenna_above_m=-3.8)
    assert dry is not None and dry.under_m == pytest.approx(0.0)


def test_off_course_is_beyond_the_tolerance_and_four_sigma_from_zero() -> None:
    """The load's warning of a heading a few degrees off (since 0.4.13): beyond
    scales.WARN_TURN_DEG (2°) and beyond 4 σ, by hand."""
    fit = partial(scales.Fit, 1.0, 0.01, 12, 0.0, 1.0)
    assert fit(5.1, 1.1).off_course()  # 5.1 > 2 and > 4.4
    assert not fit(3.1, 1.1).off_course()  # within 4 σ of zero
    assert not fit(1.5, 0.1).off_course()  # decided, but under 2°
    assert fit(-2.5, 0.2).off_course() and not fit(-2.5, 0.2).turned()
