"""The gyro and accelerometer axes against the aiding sensors' angles (mission/axes.py) and the
earth rate at rest (engine/align.py ``axes_at_rest``): docs/robustness.md, 'IMU axes'.

Synthetic motion with a known answer: a body rolling, pitching and yawing in sines, its exact
increments, and sensors that read its true angles plus noise. A right IMU must pass; a flipped,
swapped or deg/s axis must be found and blamed on the right side."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from adaptnav.core import earth
from adaptnav.engine.align import coarse_align
from adaptnav.mission import axes
from adaptnav.models.imu_noise import ImuNoise

RATE_HZ = 100.0
DURATION_S = 300.0


def _motion(
    seed: int = 3,
    periods: tuple[float, float, float] = (7.0, 11.0, 40.0),
    duration: float = DURATION_S,
) -> dict[str, np.ndarray]:
    """Roll, pitch and yaw sines (amplitudes 3°, 2°, 20°) sampled at the IMU's rate, the
    increments of small angles (each axis's angle change; the rule takes rates for Euler rates at
    small roll and pitch), the specific force of the levelled body at rest plus the tilt, and a
    heading and inclinometer reading the true angles with noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration + 1e-9, 1.0 / RATE_HZ)
    amp = np.radians([3.0, 2.0, 20.0])
    ang = np.column_stack(
        [a * np.sin(2 * math.pi * t / p) for a, p in zip(amp, periods, strict=True)]
    )
    dtheta = np.diff(ang, axis=0) + rng.normal(0.0, 1e-6, (t.size - 1, 3))
    roll, pitch = ang[1:, 0], ang[1:, 1]
    g = 9.81
    f = np.column_stack(
        [g * np.sin(pitch), -g * np.sin(roll) * np.cos(pitch), -g * np.cos(roll) * np.cos(pitch)]
    )
    dvel = f / RATE_HZ + rng.normal(0.0, 1e-5, f.shape)
    ts = np.arange(0.2, duration, 0.2)
    true = np.column_stack([np.interp(ts, t, ang[:, i]) for i in range(3)])
    return {
        "t": t[1:],
        "dt": np.full(t.size - 1, 1.0 / RATE_HZ),
        "dtheta": dtheta,
        "dvel": dvel,
        "ts": ts,
        "incl": true[:, :2] + rng.normal(0.0, math.radians(0.1), (ts.size, 2)),
        "yaw": true[:, 2] + rng.normal(0.0, math.radians(0.5), ts.size),
    }


def _refs(m: dict[str, np.ndarray]) -> list[axes.Reference]:
    return [
        axes.Reference("heading", "yaw", 2, m["ts"], m["yaw"]),
        axes.Reference("incl", "roll", 0, m["ts"], m["incl"][:, 0], tilt=0),
        axes.Reference("incl", "pitch", 1, m["ts"], m["incl"][:, 1], tilt=1),
    ]


NOISE = (1e-6 * math.sqrt(RATE_HZ), 1e-5 * math.sqrt(RATE_HZ))
"""The ARW and VRW of :func:`_motion`'s increments' noise (rad/√s, m/s/√s)."""


def _found(
    m: dict[str, np.ndarray], refs: list[axes.Reference] | None = None
) -> list[axes.AxisFinding]:
    return list(
        axes.check_axes(
            axes.ImuViews(m["t"], m["dt"], m["dtheta"], m["dvel"], NOISE), refs or _refs(m)
        )
    )


def test_a_right_imu_follows_every_reference_with_a_slope_of_one() -> None:
    m = _motion()
    assert _found(m) == []
    gyro = axes.Gyro.of(m["t"], m["dt"], m["dtheta"], arw=NOISE[0])
    for ref in _refs(m):
        s = axes.best_slope(gyro, ref.axis, ref.t, ref.value)
        assert s is not None and abs(s[1].k - 1.0) < 5 * s[1].se + 0.02, (ref.angle, s)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_flipped_gyro_axis_is_found_and_blamed_on_the_gyro(axis: int) -> None:
    m = _motion()
    m["dtheta"] = m["dtheta"].copy()
    m["dtheta"][:, axis] *= -1.0
    found = _found(m)
    assert len(found) == 1, found
    f = found[0]
    assert (f.instrument, f.axis) == ("gyro", axis)
    assert f.at_zero.k < -0.8 and f.slope.upper < axes.MIN_SLOPE and "opposite" in f.cause()


def test_swapped_gyro_axes_and_deg_per_s_are_told_apart() -> None:
    m = _motion()
    swapped = dict(m, dtheta=m["dtheta"][:, [1, 0, 2]])
    f = _found(swapped)[0]
    assert f.instrument == "gyro" and abs(f.at_zero.k) < 0.3 and "swapped" in f.cause()
    in_deg = dict(m, dtheta=np.degrees(m["dtheta"]))
    f = _found(in_deg)[0]
    assert abs(f.at_zero.k * 180 / math.pi - 1.0) < 0.1 and "deg/s" in f.cause()


def test_a_flipped_accelerometer_axis_is_blamed_on_the_accelerometers() -> None:
    m = _motion()
    m["dvel"] = m["dvel"].copy()
    m["dvel"][:, 1] *= -1.0  # y: the levelled roll turns the other way
    found = _found(m)
    assert [(f.instrument, f.angle) for f in found] == [("accelerometer", "roll")]


def test_a_reference_that_both_imu_instruments_contradict_is_blamed() -> None:
    m = _motion()
    m["incl"] = m["incl"] * np.array([-1.0, 1.0])  # the inclinometer's roll sign flipped
    found = _found(m)
    assert [(f.instrument, f.angle) for f in found] == [("reference", "roll")]
    assert "its sign flipped" in found[0].cause()


def test_a_reference_late_by_up_to_a_second_is_not_taken_for_a_swap() -> None:
    """Stamped 0.8 s late on a 3-s roll, the reference's changes lag the gyro's by a quarter
    period: at lag 0 the slope is near 0 and would be refused; the lag search finds it."""
    m = _motion(periods=(3.0, 11.0, 40.0))
    late = axes.Reference("incl", "roll", 0, m["ts"] + 0.8, m["incl"][:, 0])
    gyro = axes.Gyro.of(m["t"], m["dt"], m["dtheta"])
    a, dt = axes.wrap(np.diff(late.value)), np.diff(late.t)
    at_zero = axes.axis_slope(a, gyro.change(late.t[:-1], late.t[1:], 0), dt)
    assert at_zero is not None and at_zero.upper < axes.MIN_SLOPE  # what the lag search avoids
    assert _found(m, [late]) == []


def test_a_large_gyro_bias_and_spikes_in_the_reference_do_not_decide() -> None:
    m = _motion()
    m["dtheta"] = m["dtheta"] + math.radians(1.0) / RATE_HZ  # 1 deg/s on every axis
    spikes = np.random.default_rng(5).random(m["ts"].size) < 0.02
    m["yaw"] = np.where(spikes, m["yaw"] + 2.0, m["yaw"])
    assert _found(m) == []
    m["dtheta"][:, 2] *= -1.0
    assert [f.angle for f in _found(m)] == ["yaw"]


def test_a_still_imu_against_a_still_reference_says_nothing() -> None:
    """At rest the gyro's changes are its noise, the reference's its own: over many intervals
    their slope is about 0 with a small σ, which would read as a swapped axis. The noise floor
    (the spread of the gyro's changes against its declared ARW) keeps such a fit from deciding."""
    rng = np.random.default_rng(1)
    m = _motion()
    arw = 1e-4 * math.sqrt(RATE_HZ)  # a MEMS gyro's noise, 0.34 deg/sqrt(h) per axis
    still = rng.normal(0.0, 1e-4, m["dtheta"].shape)
    flat = [axes.Reference("incl", "roll", 0, m["ts"], rng.normal(0.0, 1e-4, m["ts"].size))]
    views = axes.ImuViews(m["t"], m["dt"], still, m["dvel"], (arw, 0.0))
    assert list(axes.check_axes(views, flat)) == []
    undeclared = axes.Gyro.of(m["t"], m["dt"], still)  # no noise declared: it decides
    s = axes.best_slope(undeclared, 0, flat[0].t, flat[0].value)
    assert s is not None and s[0].upper < axes.MIN_SLOPE


def test_a_gnss_track_gives_the_course_that_a_flipped_gyro_z_contradicts() -> None:
    m = _motion()
    speed, lat0 = 5.0, math.radians(45.0)
    yaw = np.cumsum(m["dtheta"][:, 2])
    north = np.cumsum(speed * np.cos(yaw) / RATE_HZ)
    east = np.cumsum(speed * np.sin(yaw) / RATE_HZ)
    tg = m["t"][::100]
    lat = lat0 + north[::100] / float(earth.meridian_radius(lat0))
    lon = east[::100] / (float(earth.transverse_radius(lat0)) * math.cos(lat0))
    tc, chi = axes.course(tg, lat, lon, sigma_m=0.05)
    ref = [axes.Reference("gnss", "course", 2, tc, chi)]
    assert _found(m, ref) == []
    flipped = dict(m, dtheta=m["dtheta"] * np.array([1.0, 1.0, -1.0]))
    assert [f.angle for f in _found(flipped, ref)] == ["course"]
    # The GNSS's longitude negated mirrors the course instead (since 0.4.13 the words say so).
    tc, chi = axes.course(tg, lat, -lon, sigma_m=0.05)
    (found,) = _found(m, [axes.Reference("gnss", "course", 2, tc, chi)])
    assert found.angle == "course" and "track mirrored" in found.cause(), found.cause()


# --- the earth rate at rest ------------------------------------------------------------------


def _at_rest(
    lat: float, yaw: float, flip: tuple[float, float, float] = (1.0, 1.0, 1.0)
) -> tuple[float, float, float, object]:
    """coarse_align over 600 s at rest of a navigation-grade IMU (0.01 deg/h) at ``lat``
    heading ``yaw``, its axes multiplied by ``flip``."""
    n = 60_000
    cy, sy = math.cos(yaw), math.sin(yaw)
    w_n = earth.OMEGA_IE * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    c_bn = np.array([[cy, sy, 0.0], [-sy, cy, 0.0], [0.0, 0.0, 1.0]])
    w_b = c_bn @ w_n * np.array(flip)
    f_b = np.array([0.0, 0.0, -float(earth.gravity(lat, 0.0))])
    dt = 0.01
    noise = ImuNoise(
        arw=math.radians(0.002) / 60, vrw=1e-5, gyro_bias_sigma=math.radians(0.01) / 3600,
        gyro_bias_tau=3600.0, accel_bias_sigma=1e-4, accel_bias_tau=3600.0,
    )  # fmt: skip
    return coarse_align(
        np.tile(w_b * dt, (n, 1)), np.tile(f_b * dt, (n, 1)), dt, lat, yaw,
        heading_sigma=math.radians(1.0), imu_noise=noise,
    )  # fmt: skip


def test_the_earth_rate_at_rest_finds_a_flipped_vertical_gyro() -> None:
    from adaptnav.engine.align import axes_at_rest

    lat = math.radians(30.0)
    *_, info = _at_rest(lat, math.radians(40.0))
    assert axes_at_rest(info, lat, math.radians(40.0), math.radians(1.0)) is None
    *_, info = _at_rest(lat, math.radians(40.0), (1.0, 1.0, -1.0))
    found = axes_at_rest(info, lat, math.radians(40.0), math.radians(1.0))
    assert found is not None and found[0] == "vertical"
    # A latitude given with the wrong sign looks the same: the message names both.
    assert "latitude" in found[1]


def test_the_earth_rate_at_rest_finds_a_flipped_horizontal_gyro_against_the_heading() -> None:
    from adaptnav.engine.align import axes_at_rest

    lat, yaw = math.radians(30.0), math.radians(40.0)
    *_, info = _at_rest(lat, yaw, (1.0, -1.0, 1.0))
    found = axes_at_rest(info, lat, yaw, math.radians(1.0))
    assert found is not None and found[0] == "horizontal"
    # Without a heading to compare with, or a gyro too poor to gyrocompass, nothing is said.
    assert axes_at_rest(info, lat, None, None) is None
    poor = replace(info, sigma_gyrocompass=math.radians(30.0))
    assert axes_at_rest(poor, lat, yaw, math.radians(1.0)) is None


def test_the_accelerometers_at_rest_must_point_up() -> None:
    from adaptnav.engine.align import axes_at_rest

    lat, yaw = math.radians(30.0), math.radians(40.0)
    *_, info = _at_rest(lat, yaw)
    upside = replace(info, mean_specific_force=-info.mean_specific_force)
    found = axes_at_rest(upside, lat, yaw, math.radians(1.0))
    assert found is not None and found[0] == "accel"


SIGMAS = {"yaw": math.radians(0.5), "roll": math.radians(0.1), "pitch": math.radians(0.1)}
"""The noise σ of :func:`_motion`'s heading and inclinometer (rad)."""


def _segments(m: dict[str, np.ndarray]) -> list[axes.SegmentFinding]:
    views = axes.ImuViews(m["t"], m["dt"], m["dtheta"], m["dvel"], NOISE)
    found = [axes.segment_finding(views, r, SIGMAS[r.angle]) for r in _refs(m)]
    return [f for f in found if f is not None]


@pytest.mark.parametrize("how", ["zero", "noise", "held"])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_gyro_axis_that_fails_mid_mission_is_found_in_its_span(axis: int, how: str) -> None:
    """720 s of readings (0.2 to 720.2 s: six spans of 120 s); from 360.2 s one gyro axis
    reads 0, its white noise only, or its last increment (a constant rate, which the fit's bias
    term takes): the whole mission's fit still passes it (up to 0.4.12 nothing else looked),
    the spans name it from 360.2 s to the end, following before."""
    m = _motion(duration=720.4)
    after = m["t"] > 360.2
    if how == "noise":
        rng = np.random.default_rng(5)
        m["dtheta"][after, axis] = rng.normal(0.0, NOISE[0] / math.sqrt(RATE_HZ), after.sum())
    else:
        held = 0.0 if how == "zero" else m["dtheta"][np.argmax(after) - 1, axis]
        m["dtheta"][after, axis] = held
    assert not [f for f in _found(m) if f.instrument == "gyro"]
    (f,) = _segments(m)
    assert (f.axis, f.angle) == (axis, ["roll", "pitch", "yaw"][axis])
    assert f.follows_to == pytest.approx(360.2)
    assert (f.t_from, f.t_to) == (pytest.approx(360.2), pytest.approx(720.2))
    assert (f.slope is None) != (f.quiet is None)
    if f.quiet is not None:
        assert f.quiet.ratio < 0.05  # a fiftieth of the rotation, at most: noise or nothing
    assert "1 expected" not in f.words()


def test_a_right_gyro_follows_in_every_span_and_a_still_one_is_not_judged() -> None:
    """The right IMU over 720 s: no span fails. Still (no motion at all, the gyro's and the
    accelerometers' noise only) beside a reference noisier than its σ says (0.5° against 0.1°,
    white): the reference's angle about its line is 5 σ, but it moves from reading to reading
    as much as white noise does (√2 times that), so it is not taken for a rotation the IMU
    misses."""
    assert not _segments(_motion(duration=720.4))
    m = _motion(duration=720.4)
    rng = np.random.default_rng(9)
    m["dtheta"] = rng.normal(0.0, NOISE[0] / math.sqrt(RATE_HZ), m["dtheta"].shape)
    level = np.array([0.0, 0.0, -9.81]) / RATE_HZ
    m["dvel"] = level + rng.normal(0.0, NOISE[1] / math.sqrt(RATE_HZ), m["dvel"].shape)
    m["incl"] = rng.normal(0.0, math.radians(0.5), m["incl"].shape)
    m["yaw"] = rng.normal(0.0, math.radians(2.5), m["yaw"].shape)
    assert not _segments(m)


@pytest.mark.parametrize(("column", "angle"), [(0, "pitch"), (1, "roll")])
def test_an_accelerometer_axis_reading_only_noise_mid_mission_is_found(
    column: int, angle: str
) -> None:
    """The accelerometer x (or y) reading only its white noise from 360.2 s: the levelled pitch
    (or roll) stops following the inclinometer's while the gyro still does; the spans name the
    accelerometers, following up to 360.2 s (up to 0.4.12 nothing looked at spans)."""
    m = _motion(duration=720.4)
    after = m["t"] > 360.2
    rng = np.random.default_rng(6)
    m["dvel"][after, column] = rng.normal(0.0, NOISE[1] / math.sqrt(RATE_HZ), after.sum())
    (f,) = _segments(m)
    assert (f.instrument, f.angle) == ("accelerometer", angle)
    assert f.follows_to == pytest.approx(360.2)
    # the span 360.2-480.2 s may be undecided: its first levelled block straddles the failure
    assert f.t_from in (pytest.approx(360.2), pytest.approx(480.2))


def test_an_inclinometer_that_fails_mid_mission_is_blamed_not_the_imu() -> None:
    """The inclinometer's roll reading only its noise from 360.2 s while the gyro and the
    accelerometers go on turning: both stop following it from the same span, so the sensor is
    blamed, as the whole mission's fit blames a reference both instruments contradict."""
    m = _motion(duration=720.4)
    late = m["ts"] > 360.2
    m["incl"][late, 0] = np.random.default_rng(8).normal(0.0, SIGMAS["roll"], late.sum())
    (f,) = _segments(m)
    assert (f.instrument, f.angle, f.t_from) == ("reference", "roll", pytest.approx(360.2))
