"""Measurement models: H against finite differences, residual signs, hand values.

docs/filters.md, 'Measurement models' and 'Verification'.

The Jacobian check: for every sensor, J = ∂/∂dx of the residual of the reading a truth
``x_hat ⊕ dx`` would give, ``y(dx) = z(x_hat ⊕ dx) - h(x_hat)``, at dx = 0, by central differences
with per-column steps and Richardson extrapolation. For DVL, depth and inclinometer this is exactly
``∂h(x_hat ⊕ dx)/∂dx``; for heading the difference is wrapped; for GNSS it is the same in NED
metres (the residual's own units), which also avoids differencing latitudes as raw numbers. The
conversion itself is checked separately against the exact geodetic <-> NED transformation.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from adaptnav.core import attitude, earth
from adaptnav.models import errorstate, strapdown
from adaptnav.models.errorstate import ATT, BG, N_STATES, POS, VEL
from adaptnav.sensors import (
    DVL,
    GNSS,
    Depth,
    Heading,
    Inclinometer,
    Measurement,
    MeasurementModel,
    NonHolonomic,
    PendulumInclinometer,
    dvl,
    gnss,
)

Model = DVL | Depth | Inclinometer | Heading | GNSS | NonHolonomic

# Per-column FD steps: 10 m of position is 1.6e-6 rad of latitude, far above float64 resolution;
# rotations and rates are small enough for Richardson's O(ε⁴) to reach 1e-10.
STEPS = np.array([10.0] * 3 + [1e-3] * 3 + [1e-4] * 3 + [1e-3] * 3 + [1e-4] * 3)
# GNSS residuals are (lat_z - lat_pred)·R with ~1.4e-9 m of rounding in each reading, so larger
# steps: rounding then costs < 2.5e-7 in J and the O(ε⁴) truncation (ε⁴|l|/30) < 3e-8.
GNSS_STEPS = np.array([100.0] * 3 + [1e-3] * 3 + [2e-2] * 3 + [1e-3] * 3 + [1e-4] * 3)
RTOL = 1e-6
MAX_PITCH = math.radians(89.0)


# --- strategies --------------------------------------------------------------------------------


def _rotvec(axis: list[float], angle: float) -> np.ndarray:
    a = np.array(axis)
    n = float(np.linalg.norm(a))
    assume(n > 0.1)
    return a / n * angle


rotvecs = st.builds(
    _rotvec, st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), st.floats(0.0, math.pi)
)


def _vec(bound: float) -> st.SearchStrategy[np.ndarray]:
    return st.lists(st.floats(-bound, bound), min_size=3, max_size=3).map(np.array)


def _state(lat_deg: float, lon_deg: float, h: float, v, rv, b_g) -> np.ndarray:
    return strapdown.NavState(
        math.radians(lat_deg),
        math.radians(lon_deg),
        h,
        v,
        attitude.rotvec_to_quat(rv),
        np.array([0.01, -0.02, 0.03]),
        b_g,
    ).to_array()


states = st.builds(
    _state,
    st.floats(-80.0, 80.0),
    st.floats(-180.0, 180.0),
    st.floats(-1000.0, 1000.0),
    _vec(10.0),
    rotvecs,
    _vec(0.01),
)
levers = _vec(3.0)
rates = _vec(0.5)
mountings = st.one_of(
    st.none(), rotvecs.map(lambda rv: attitude.quat_to_dcm(attitude.rotvec_to_quat(rv)))
)


def _mounting(C_sb: np.ndarray | None) -> np.ndarray:
    return np.eye(3) if C_sb is None else C_sb


# --- helpers -----------------------------------------------------------------------------------


def _reading(model: Model, x: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    if isinstance(model, DVL | NonHolonomic):
        return model.predict(x, w)
    return model.predict(x)


def _residual(model: Model, x_hat: np.ndarray, z: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    m = model.evaluate(x_hat, z, w)
    assert m is not None
    return m.y


def _fd_jacobian(fun: Callable[[np.ndarray], np.ndarray], steps: np.ndarray) -> np.ndarray:
    """Central differences, Richardson-extrapolated: (4 J(ε) - J(2ε)) / 3, error O(ε⁴)."""

    def central(scale: float) -> np.ndarray:
        cols = []
        for j in range(N_STATES):
            e = np.zeros(N_STATES)
            e[j] = steps[j] * scale
            cols.append((fun(e) - fun(-e)) / (2.0 * e[j]))
        return np.column_stack(cols)

    return (4.0 * central(1.0) - central(2.0)) / 3.0


def _check_H(
    model: Model, x: np.ndarray, w: np.ndarray | None = None, steps: np.ndarray = STEPS
) -> None:
    def y_of(dx: np.ndarray) -> np.ndarray:
        return _residual(model, x, _reading(model, errorstate.inject(x, dx), w), w)

    J = _fd_jacobian(y_of, steps)
    m = model.evaluate(x, _reading(model, x, w), w)
    assert m is not None
    err = float(np.abs(m.H - J).max())
    assert err <= RTOL * max(1.0, float(np.abs(J).max())), f"max|H - J| = {err:.3e}\nH={m.H}\nJ={J}"


def _pitch(x: np.ndarray, C_sb: np.ndarray | None) -> float:
    C = attitude.quat_to_dcm(x[6:10]) @ _mounting(C_sb).T
    return float(attitude.dcm_to_euler(C)[1])


# --- H against finite differences, every sensor ------------------------------------------------

FD = settings(max_examples=60, deadline=None, derandomize=True)


@FD
@given(states, levers, rates, mountings)
def test_dvl_H_matches_finite_differences(x, l_b, w, C_sb) -> None:
    _check_H(DVL(0.01, l_b, _mounting(C_sb)), x, w)


@FD
@given(states, levers, rates, mountings)
def test_nhc_H_matches_finite_differences(x, l_b, w, C_sb) -> None:
    _check_H(NonHolonomic(0.1, l_b, _mounting(C_sb)), x, w)


def test_nhc_hand_values() -> None:
    """Level, heading 30°, 10 m/s along the heading: no lateral or vertical velocity. With the
    vehicle frame 2° to the right of the body (C_sb a yaw of 2°), the lateral reads
    -10 sin 2°. Yawing right at 0.5 rad/s, a point 1.5 m behind the IMU moves to the left:
    (ω × l)_y = ω_z l_x = -0.75 m/s."""
    yaw = math.radians(30.0)
    v_n = 10.0 * np.array([math.cos(yaw), math.sin(yaw), 0.0])
    x = strapdown.NavState.from_euler(0.7, 0.2, 10.0, v_n, 0.0, 0.0, yaw).to_array()
    np.testing.assert_allclose(NonHolonomic(0.1).predict(x), [0.0, 0.0], atol=1e-12)
    C_sb = attitude.euler_to_dcm(0.0, 0.0, math.radians(2.0)).T
    lat = NonHolonomic(0.1, C_sb=C_sb).predict(x)
    np.testing.assert_allclose(lat, [-10.0 * math.sin(math.radians(2.0)), 0.0], atol=1e-12)
    rear = NonHolonomic(0.1, np.array([-1.5, 0.0, 0.0]))
    np.testing.assert_allclose(rear.predict(x, np.array([0.0, 0.0, 0.5])), [-0.75, 0.0], atol=1e-12)
    m = rear.evaluate(x, np.zeros(2), np.array([0.0, 0.0, 0.5]))
    assert m is not None and m.names == ("nhc_y", "nhc_z")
    np.testing.assert_allclose(m.y, [0.75, 0.0], atol=1e-12)


@FD
@given(states, levers)
def test_depth_H_matches_finite_differences(x, l_b) -> None:
    _check_H(Depth(0.05, l_b), x)


@FD
@given(states, mountings)
def test_inclinometer_H_matches_finite_differences(x, C_sb) -> None:
    assume(abs(_pitch(x, C_sb)) < MAX_PITCH)
    _check_H(Inclinometer(1e-3, _mounting(C_sb)), x)


@FD
@given(states, mountings, _vec(4.0))
def test_pendulum_inclinometer_H_matches_finite_differences(x, C_sb, a) -> None:
    """The pendulum reads the tilt of the true specific force ``f̃ - b_a,true``: a reading made
    at the injected state (its true b_a) from the same accelerometer output f̃."""
    f = np.array([0.0, 0.0, -9.8]) + a
    model = PendulumInclinometer(1e-3, _mounting(C_sb))
    f_s = _mounting(C_sb) @ (f - x[10:13])
    assume(abs(math.atan2(f_s[0], math.hypot(f_s[1], f_s[2]))) < MAX_PITCH)

    def y_of(dx: np.ndarray) -> np.ndarray:
        m = model.evaluate(x, model.predict(errorstate.inject(x, dx), f), None, f)
        assert m is not None
        return m.y

    J = _fd_jacobian(y_of, STEPS)
    m = model.evaluate(x, model.predict(x, f), None, f)
    assert m is not None
    err = float(np.abs(m.H - J).max())
    assert err <= RTOL * max(1.0, float(np.abs(J).max())), f"max|H - J| = {err:.3e}"
    assert np.all(m.H[:, :9] == 0.0) and np.all(m.H[:, 12:] == 0.0)  # it sees no attitude


def test_pendulum_inclinometer_hand_values() -> None:
    """At rest a pendulum reads the attitude's roll and pitch; a level vessel accelerating
    forward by a reads a pitch of atan(a/g), one turning to starboard (centripetal acceleration
    a to the right) a roll of -atan(a/g) (the apparent vertical leans outward)."""
    g = 9.79
    roll, pitch = math.radians(3.0), math.radians(-2.0)
    x = strapdown.NavState.from_euler(0.5, 0.9, 0.0, np.zeros(3), roll, pitch, 1.0).to_array()
    x[10:13] = 0.0
    C_bn = attitude.euler_to_dcm(roll, pitch, 1.0).T
    at_rest = C_bn @ np.array([0.0, 0.0, -g])
    model = PendulumInclinometer(1e-3)
    np.testing.assert_allclose(model.predict(x, at_rest), [roll, pitch], atol=1e-12)
    np.testing.assert_allclose(model.predict(x, at_rest), Inclinometer(1e-3).predict(x), atol=1e-12)
    level = strapdown.NavState.from_euler(0.5, 0.9, 0.0, np.zeros(3), 0.0, 0.0, 1.0).to_array()
    level[10:13] = 0.0
    a = 0.4
    np.testing.assert_allclose(
        model.predict(level, np.array([a, 0.0, -g])), [0.0, math.atan(a / g)], atol=1e-12
    )
    np.testing.assert_allclose(
        model.predict(level, np.array([0.0, a, -g])), [-math.atan(a / g), 0.0], atol=1e-12
    )
    level[10:13] = [a, 0.0, 0.0]  # the bias estimate is taken out of the accelerometer's output
    np.testing.assert_allclose(model.predict(level, np.array([a, 0.0, -g])), [0.0, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="specific force"):
        model.evaluate(level, np.zeros(2))


@FD
@given(states, mountings)
def test_heading_H_matches_finite_differences(x, C_sb) -> None:
    assume(abs(_pitch(x, C_sb)) < MAX_PITCH)
    _check_H(Heading(1e-2, _mounting(C_sb)), x)


@FD
@given(states, levers, st.booleans())
def test_gnss_H_matches_finite_differences(x, l_b, use_height) -> None:
    _check_H(GNSS(2.0, l_b, use_height), x, steps=GNSS_STEPS)


@pytest.mark.parametrize("lat_deg", [80.0, 45.0, -80.0])
@pytest.mark.parametrize("yaw_deg", [0.0, 50.0, -120.0])
def test_gnss_lever_arm_curvature_terms(lat_deg: float, yaw_deg: float) -> None:
    """The dr block's lever-arm terms (a/R up to a tan(lat)/R ≈ 5e-6) are resolved: the FD of
    the position columns is good to ~3e-11, so compare them at 1e-9, below the smallest of them
    (a_N R_M'/ρ_M² ≈ 1e-8)."""
    x = strapdown.NavState.from_euler(
        math.radians(lat_deg), 2.0, 30.0, [3, -2, 1], 0.3, -0.2, math.radians(yaw_deg)
    ).to_array()
    model = GNSS(1.0, np.array([3.0, -3.0, 3.0]))

    def y_of(dx: np.ndarray) -> np.ndarray:
        return _residual(model, x, model.predict(errorstate.inject(x, dx)), None)

    J = _fd_jacobian(y_of, GNSS_STEPS)
    H = model.jacobian(x)
    assert np.abs(H[:, POS] - J[:, POS]).max() < 1e-9
    assert np.abs(H[:, POS] - np.eye(3)).max() > 1e-8  # the terms are there to be tested


def test_heading_H_near_the_wrap() -> None:
    """Yaw within 1e-5 rad of ±π: the FD readings straddle the cut and the residual unwraps them."""
    for yaw in (math.pi - 1e-5, -math.pi + 1e-5, math.pi):
        x = strapdown.NavState.from_euler(0.5, 1.0, 0.0, [1.0, 0.0, 0.0], 0.2, -0.3, yaw)
        _check_H(Heading(1e-2), x.to_array())


# --- residual sign: y ≈ H dx for a reading from x_true = x_hat ⊕ dx -----------------------------

DX = np.array([0.3, -0.2, 0.4, 0.02, -0.01, 0.03, 1e-4, -2e-4, 1.5e-4, 0, 0, 0, 1e-4, -2e-4, 3e-4])


def _first_order(model: Model, x: np.ndarray, w: np.ndarray | None = None) -> None:
    z = _reading(model, errorstate.inject(x, DX), w)
    m = model.evaluate(x, z, w)
    assert m is not None
    lin = m.H @ DX
    bound = 0.02 * (np.abs(m.H) @ np.abs(DX)) + 1e-12
    assert np.all(np.abs(m.y - lin) <= bound), (m.y, lin)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(states, levers, rates, mountings, st.booleans())
def test_residual_is_truth_minus_estimate_to_first_order(x, l_b, w, C_sb, use_height) -> None:
    C = _mounting(C_sb)
    _first_order(DVL(0.01, l_b, C), x, w)
    _first_order(Depth(0.05, l_b), x)
    _first_order(GNSS(2.0, l_b, use_height), x)
    assume(abs(_pitch(x, C_sb)) < math.radians(80.0))
    _first_order(Inclinometer(1e-3, C), x)
    _first_order(Heading(1e-2, C), x)


def _level(yaw_deg: float = 0.0, v=(0.0, 0.0, 0.0), h: float = -10.0) -> np.ndarray:
    return strapdown.NavState.from_euler(
        math.radians(45.0), 0.1, h, v, 0.0, 0.0, math.radians(yaw_deg)
    ).to_array()


def _dx(**blocks: list[float]) -> np.ndarray:
    names = {"r": POS, "v": VEL, "phi": ATT, "bg": BG}
    d = np.zeros(N_STATES)
    for k, val in blocks.items():
        d[names[k]] = val
    return d


def test_residual_signs_by_hand() -> None:
    """Truth ahead of the estimate in each sensed quantity gives a positive residual."""
    x = _level()
    # truly faster north, heading north: the DVL reads more forward speed than predicted
    z = DVL(0.01).predict(errorstate.inject(x, _dx(v=[0.1, 0, 0])))
    assert DVL(0.01).evaluate(x, z).y == pytest.approx([0.1, 0.0, 0.0])
    # truly 1 m deeper (dr_D = +1): depth residual +1
    z = Depth(0.1).predict(errorstate.inject(x, _dx(r=[0, 0, 1.0])))
    assert Depth(0.1).evaluate(x, z).y == pytest.approx([1.0])
    # truly yawed 0.01 rad further clockwise (phi_D > 0): heading residual +0.01
    z = Heading(0.01).predict(errorstate.inject(x, _dx(phi=[0, 0, 0.01])))
    assert Heading(0.01).evaluate(x, z).y == pytest.approx([0.01])
    # truly rolled right about north at yaw 0: roll residual +
    z = Inclinometer(0.01).predict(errorstate.inject(x, _dx(phi=[0.01, 0, 0])))
    assert Inclinometer(0.01).evaluate(x, z).y == pytest.approx([0.01, 0.0], abs=1e-9)
    # truly 5 m north, 3 m east, 2 m down of the estimate
    g = GNSS(1.0)
    z = g.predict(errorstate.inject(x, _dx(r=[5.0, 3.0, 2.0])))
    assert g.evaluate(x, z).y == pytest.approx([5.0, 3.0, 2.0], abs=1e-8)


# --- hand-worked values ------------------------------------------------------------------------


def test_dvl_hand_values() -> None:
    # level, yaw 90°: body x points east, so eastward 2 m/s is forward 2 m/s
    x = _level(90.0, v=(0.0, 2.0, 0.0))
    assert dvl.predict(x, np.zeros(3)) == pytest.approx([2.0, 0.0, 0.0], abs=1e-12)
    # 0.1 rad/s yaw rate with the DVL 1 m forward: it moves 0.1 m/s to the right
    x = _level()
    s = DVL(0.01, np.array([1.0, 0.0, 0.0]))
    assert s.predict(x, np.array([0.0, 0.0, 0.1])) == pytest.approx([0.0, 0.1, 0.0], abs=1e-12)
    # the same rate entirely explained by the gyro bias: no lever-arm velocity
    xb = x.copy()
    xb[strapdown.NOM_BG] = [0.0, 0.0, 0.1]
    assert s.predict(xb, np.array([0.0, 0.0, 0.1])) == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    # DVL mounted rotated 90° about body z (its x is the body's right): forward motion is its -y
    x = _level(0.0, v=(1.5, 0.0, 0.0))
    rot = DVL(0.01, C_sb=attitude.euler_to_dcm(0.0, 0.0, math.pi / 2).T)
    assert rot.predict(x) == pytest.approx([0.0, -1.5, 0.0], abs=1e-12)
    m = rot.evaluate(x, np.array([0.0, -1.4, 0.0]))
    assert m is not None
    assert m.y == pytest.approx([0.0, 0.1, 0.0], abs=1e-12)
    assert m.names == ("dvl_x", "dvl_y", "dvl_z")
    np.testing.assert_allclose(m.R, np.diag([1e-4] * 3))


def test_depth_hand_values() -> None:
    x = _level(h=-50.0)
    assert Depth(0.1).predict(x) == pytest.approx([50.0])
    assert Depth(0.1, np.array([0.0, 0.0, 2.0])).predict(x) == pytest.approx([52.0])
    # nose up 30°: a sensor 2 m forward sits 1 m higher
    x30 = strapdown.NavState.from_euler(0.7, 0.0, -50.0, [0, 0, 0], 0.0, math.radians(30.0), 1.0)
    assert Depth(0.1, np.array([2.0, 0.0, 0.0])).predict(x30.to_array()) == pytest.approx([49.0])
    m = Depth(0.1).evaluate(x, 50.5)
    assert m is not None
    assert m.y == pytest.approx([0.5])
    assert m.names == ("depth",)
    # Heights ellipsoidal, the water surface 45 m above the ellipsoid: 95 m below it is 50 m
    # below the surface.
    assert Depth(0.1, surface_h=45.0).predict(_level(h=-5.0)) == pytest.approx([50.0])
    with pytest.raises(ValueError, match="surface_h"):
        Depth(0.1, surface_h=math.nan)


def test_attitude_sensors_hand_values() -> None:
    x = strapdown.NavState.from_euler(0.7, 0.0, 0.0, [0, 0, 0], 0.1, -0.2, 1.0).to_array()
    assert Inclinometer(1e-3).predict(x) == pytest.approx([0.1, -0.2])
    assert Heading(1e-2).predict(x) == pytest.approx([1.0])
    # a compass mounted 90° to starboard reads the heading + 90° (level vehicle)
    xl = _level(10.0)
    mount = attitude.euler_to_dcm(0.0, 0.0, math.pi / 2).T
    assert Heading(1e-2, mount).predict(xl) == pytest.approx([math.radians(100.0)])
    # mounted 90° to starboard (its y points aft): nose up is its positive roll
    xp = strapdown.NavState.from_euler(0.7, 0.0, 0.0, [0, 0, 0], 0.0, 0.1, 0.0).to_array()
    assert Inclinometer(1e-3, mount).predict(xp) == pytest.approx([0.1, 0.0], abs=1e-12)


def test_heading_residual_wraps() -> None:
    x = _level(-179.0)
    m = Heading(1e-2).evaluate(x, math.radians(179.0))
    assert m is not None
    assert m.y == pytest.approx([math.radians(-2.0)])
    m = Heading(1e-2).evaluate(_level(179.0), math.radians(-179.0))
    assert m is not None
    assert m.y == pytest.approx([math.radians(2.0)])
    # a reading given on another branch (0..360°) means the same
    m = Heading(1e-2).evaluate(_level(-90.0), math.radians(270.5))
    assert m is not None
    assert m.y == pytest.approx([math.radians(0.5)])


def test_wrap_keeps_in_range_angles_exact() -> None:
    assert attitude.wrap_angle(1e-20) == 1e-20  # no rounding through a + π
    assert attitude.wrap_angle(np.array([math.pi, -math.pi, 3 * math.pi / 2])) == pytest.approx(
        [math.pi, math.pi, -math.pi / 2]
    )


def test_gnss_hand_values() -> None:
    x = _level(h=20.0)
    lat, lon, h = x[0], x[1], x[2]
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    g = GNSS(np.array([1.0, 1.0, 3.0]))
    m = g.evaluate(x, np.array([lat + 1e-6, lon - 2e-6, h + 3.0]))
    assert m is not None
    assert m.y == pytest.approx([1e-6 * rm, -2e-6 * rn * math.cos(lat), -3.0], rel=1e-8)
    assert m.names == ("gnss_N", "gnss_E", "gnss_D")
    np.testing.assert_allclose(m.R, np.diag([1.0, 1.0, 9.0]))
    # antenna 2 m above the IMU on a level vehicle
    assert GNSS(1.0, np.array([0.0, 0.0, -2.0])).predict(x)[2] == pytest.approx(22.0)
    # 2-D fix: two components
    m2 = GNSS(1.0, use_height=False).evaluate(x, np.array([lat, lon]))
    assert m2 is not None
    assert m2.y.shape == (2,) and m2.H.shape == (2, N_STATES) and m2.names == ("gnss_N", "gnss_E")
    # across the antimeridian: 2e-7 rad east of the estimate, not 2π west
    xa = x.copy()
    xa[1] = math.pi - 1e-7
    m = GNSS(1.0).evaluate(xa, np.array([lat, -math.pi + 1e-7, h]))
    assert m is not None
    assert m.y[1] == pytest.approx(2e-7 * rn * math.cos(lat), rel=1e-6)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(states, levers)
def test_gnss_antenna_position_matches_exact_geodesy(x, l_b) -> None:
    """The first-order lever-arm shift in lat/lon/h agrees with the exact NED -> geodetic map."""
    lat, lon, h = x[0], x[1], x[2]
    a = attitude.quat_to_dcm(x[6:10]) @ l_b
    lat_e, lon_e, h_e = earth.ned_to_geodetic(a, lat, lon, h)
    pred = gnss.predict(x, l_b)
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    err_m = [
        (pred[0] - lat_e) * rm,
        float(attitude.wrap_angle(pred[1] - lon_e)) * rn * math.cos(lat),
        pred[2] - h_e,
    ]
    assert np.abs(err_m).max() < 1e-4  # O(|a|²/R) ≈ 4e-6 m, rounding of ECEF ~1e-8 m


# --- configuration and readings ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("make", "field", "value"),
    [
        (lambda: DVL(-0.01), "sigma", "-0.01"),
        (lambda: DVL(np.array([0.01, math.nan, 0.01])), "sigma", "nan"),
        (lambda: DVL(np.array([0.01, 0.01])), "sigma", "shape (2,)"),
        (lambda: DVL(0.01, np.array([0.0, math.nan, 0.0])), "l_b", "nan"),
        (lambda: DVL(0.01, np.zeros(2)), "l_b", "shape (2,)"),
        (lambda: DVL(0.01, C_sb=2.0 * np.eye(3)), "C_sb", "2."),
        (lambda: DVL(0.01, C_sb=np.diag([1.0, 1.0, -1.0])), "C_sb", "-1."),
        (lambda: DVL(0.01, name=""), "name", "''"),
        (lambda: Depth(0.0), "sigma", "0.0"),
        (lambda: Depth(math.nan), "sigma", "nan"),
        (lambda: Depth(0.1, np.array([0.0, 0.0, math.inf])), "l_b", "inf"),
        (lambda: Inclinometer(np.array([1e-3, -1e-3])), "sigma", "-0.001"),
        (lambda: Inclinometer(1e-3, np.eye(2)), "C_sb", "shape (2, 2)"),
        (lambda: Heading(-1.0), "sigma", "-1.0"),
        (lambda: Heading(np.array([0.1, 0.1])), "sigma", "shape (2,)"),
        (lambda: GNSS(np.array([1.0, 1.0]), use_height=True), "sigma", "shape (2,)"),
        (lambda: GNSS(math.inf), "sigma", "inf"),
        (lambda: GNSS(1.0, np.array([math.nan, 0, 0])), "l_b", "nan"),
        (lambda: GNSS(1.0, use_height=1), "use_height", "1"),  # type: ignore[arg-type]
    ],
)
def test_bad_config_is_refused_with_field_and_value(make, field, value) -> None:
    with pytest.raises(ValueError) as info:
        make()
    msg = str(info.value)
    assert field in msg and value in msg, msg


@pytest.mark.parametrize(
    ("model", "bad"),
    [
        (DVL(0.01), np.array([0.1, math.nan, 0.0])),
        (Depth(0.1), math.nan),
        (Depth(0.1), np.array([math.inf])),
        (Inclinometer(1e-3), np.array([math.nan, 0.0])),
        (Heading(1e-2), math.nan),
        (GNSS(1.0), np.array([0.7, math.nan, 0.0])),
        (GNSS(1.0, use_height=False), np.array([math.nan, 0.1])),
        (NonHolonomic(0.1), np.array([0.0, math.nan])),
    ],
)
def test_nan_reading_is_no_measurement(model: Model, bad) -> None:
    assert model.evaluate(_level(), bad, np.zeros(3)) is None


def test_wrong_reading_shape_and_missing_rate_raise() -> None:
    with pytest.raises(ValueError, match="dvl reading must have shape"):
        DVL(0.01).evaluate(_level(), np.zeros(2))
    with pytest.raises(ValueError, match="gnss reading must have shape"):
        GNSS(1.0).evaluate(_level(), np.zeros(2))
    with pytest.raises(ValueError, match="omega_ib_b"):
        DVL(0.01, np.array([1.0, 0.0, 0.0])).evaluate(_level(), np.zeros(3))
    with pytest.raises(ValueError, match="nominal state"):
        Depth(0.1).evaluate(np.zeros(15), 1.0)


def test_models_satisfy_the_protocol_and_configs_are_frozen() -> None:
    models: list[MeasurementModel] = [
        DVL(0.01),
        Depth(0.1),
        Inclinometer(1e-3),
        Heading(1e-2),
        GNSS(1.0),
        GNSS(1.0, use_height=False),
        NonHolonomic(0.1),
    ]
    for model, dim in zip(models, (3, 1, 2, 1, 3, 2, 2), strict=True):
        assert isinstance(model, MeasurementModel)
        assert model.dim == dim
    d = DVL([0.01, 0.02, 0.03], [1.0, 2.0, 3.0])  # lists are accepted and stored as arrays
    assert isinstance(d.sigma, np.ndarray) and d.l_b.dtype == np.float64
    with pytest.raises(ValueError):
        d.l_b[0] = 5.0  # read-only: the config cannot change under the filter's feet


def test_measurement_checks_shapes() -> None:
    with pytest.raises(ValueError, match="Measurement"):
        Measurement(np.zeros(2), np.zeros((2, N_STATES)), np.eye(3), ("a", "b"))


def test_calibration_regressors_are_the_readings_derivatives() -> None:
    """``sensors.calibration.regressors`` against finite differences of the conventions
    (sensors/calibration.py): ``(1 + s) z``, ``M(δ) z``, ``z + b``; up to one constant factor
    per state (the long-run factor is a ratio, blind to it): here +1 for scale and bias, -1 for
    the misalignment angles."""
    from adaptnav.sensors import calibration as cal

    rng = np.random.default_rng(5)
    z = rng.normal(0.0, 1.5, (7, 3))
    eps = 1e-7
    (scale,) = cal.regressors(cal.SCALE, z) or ()
    np.testing.assert_allclose(scale, ((1.0 + eps) * z - z) / eps, rtol=1e-6)
    angles = cal.regressors(cal.MISALIGNMENT, z)
    assert angles is not None
    for a, h in enumerate(angles):
        d = np.zeros(3)
        d[a] = eps
        fd = (z @ cal.misalignment(d).T - z @ cal.misalignment(-d).T) / (2 * eps)
        np.testing.assert_allclose(h, -fd, atol=1e-6)
    tilt = cal.regressors(cal.TILT_BIAS, z[:, :2])
    depth = cal.regressors(cal.DEPTH_BIAS, z[:, :1])
    assert tilt is not None and depth is not None
    np.testing.assert_array_equal(tilt[0], np.tile([1.0, 0.0], (7, 1)))
    np.testing.assert_array_equal(tilt[1], np.tile([0.0, 1.0], (7, 1)))
    np.testing.assert_array_equal(depth[0], np.ones((7, 1)))
    # a quantity it does not know, or readings of the wrong width: no regressor
    assert cal.regressors(cal.MISALIGNMENT, z[:, :2]) is None
    assert cal.regressors(cal.TILT_BIAS, z[:, :1]) is None


def test_a_latency_regressor_is_minus_the_readings_rate() -> None:
    """The latency's regressor (0.4.3): ``z(t - τ) ≈ z - τ ż``, so ``-ż`` from the kind's
    ``reading_rate``: exact on a quadratic in time at uneven times (central differences), a
    heading across the ±π wrap, a GNSS fix moving at a known NED velocity; none without a rate,
    and NaN for times that do not increase."""
    from adaptnav.sensors import calibration as cal
    from adaptnav.sensors.base import readings_rate
    from adaptnav.sensors.gnss import fix_rate
    from adaptnav.sensors.heading import heading_rate

    t = np.array([0.0, 0.4, 1.0, 1.3, 2.0, 2.9])
    z = np.stack([t**2, 3.0 * t, -t], axis=1)
    rate = readings_rate(z, t)
    np.testing.assert_allclose(rate[1:-1], np.stack([2 * t, 3 + 0 * t, -1 + 0 * t], 1)[1:-1])
    (h,) = cal.regressors(cal.LATENCY, z, rate) or ()
    np.testing.assert_array_equal(h, -rate)
    assert cal.regressors(cal.LATENCY, z) is None
    assert np.isnan(readings_rate(z, np.r_[t[:3], t[2], t[4:]])).all()
    yaw = np.remainder(3.0 + 0.2 * t + math.pi, 2 * math.pi) - math.pi  # crosses +π
    np.testing.assert_allclose(heading_rate(yaw[:, None], t), 0.2)
    lat0, v = math.radians(45.0), np.array([3.0, -4.0, 0.5])
    rm = float(earth.meridian_radius(lat0)) + 10.0
    rn = float(earth.transverse_radius(lat0)) + 10.0
    fixes = np.stack([lat0 + v[0] * t / rm, math.pi - 1e-7 + v[1] * t / (rn * math.cos(lat0)),
                      10.0 - v[2] * t], axis=1)  # fmt: skip
    fixes[:, 1] = np.remainder(fixes[:, 1] + math.pi, 2 * math.pi) - math.pi  # the antimeridian
    np.testing.assert_allclose(fix_rate(fixes, t), np.tile(v, (t.size, 1)), rtol=1e-6, atol=1e-6)
