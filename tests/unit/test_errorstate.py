"""F, Φ, G/Q and feedback of the 15-state error model against finite differences.

docs/filters.md, 'Error-state model', 'Propagation', 'Feedback and reset' and 'Verification'.

Two independent checks:

* F against the continuous-time nonlinear error dynamics g(dx) = d/dt (x_true ⊖ x_hat), written
  here from the textbook nominal equations (not from errorstate) in a "delta form" that never
  subtracts two large numbers, so even the 1e-8-sized earth-rate and gravity-gradient terms
  are resolved. F = ∂g/∂dx at 0 by Richardson-extrapolated central differences.
* Φ (from F at the step's midpoint) against the finite-difference Jacobian of one whole
  mechanization step strapdown.propagate, at dt = 0.01 s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adaptnav.core import attitude, earth
from adaptnav.models import errorstate, strapdown
from adaptnav.models.errorstate import ATT, BA, BG, POS, VEL
from adaptnav.models.imu_noise import ImuNoise

BLOCKS = {"r": POS, "v": VEL, "phi": ATT, "ba": BA, "bg": BG}


def _state(
    lat: float, h: float, v: np.ndarray, rotvec: np.ndarray, b_a: np.ndarray, b_g: np.ndarray
):
    return strapdown.NavState(lat, 0.3, h, v, attitude.rotvec_to_quat(rotvec), b_a, b_g).to_array()


states = st.builds(
    lambda lat, h, v, rv, ba, bg, w, f: (
        _state(math.radians(lat), h, np.array(v), np.array(rv), np.array(ba), np.array(bg)),
        np.array(w),
        np.array(f),
    ),
    st.floats(-80.0, 80.0),
    st.floats(-500.0, 500.0),
    st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3),
    st.lists(st.floats(-1.8, 1.8), min_size=3, max_size=3),
    st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3),
    st.lists(st.floats(-1e-3, 1e-3), min_size=3, max_size=3),
    st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3),
    st.lists(st.floats(-20.0, 20.0), min_size=3, max_size=3),
)
taus = st.sampled_from([(math.inf, math.inf), (3600.0, 1800.0), (300.0, 100.0)])


# --- continuous nominal dynamics, written independently from errorstate -------------------------


def _omega_in(lat: float, h: float, v: np.ndarray) -> np.ndarray:
    return earth.earth_rate_n(lat) + earth.transport_rate_n(lat, h, v)


def _vdot(lat: float, h: float, v: np.ndarray, C: np.ndarray, f_b: np.ndarray) -> np.ndarray:
    """v' = C f + g - (2 ω_ie + ω_en) × v (Groves 5.53)."""
    cor = 2.0 * earth.earth_rate_n(lat) + earth.transport_rate_n(lat, h, v)
    return C @ f_b + earth.gravity_n(lat, h) - np.cross(cor, v)


def _Cdot(lat: float, h: float, v: np.ndarray, C: np.ndarray, w_b: np.ndarray) -> np.ndarray:
    """C' = C [ω_ib×] - [ω_in×] C (Groves 5.47)."""
    return C @ attitude.skew(w_b) - attitude.skew(_omega_in(lat, h, v)) @ C


def _left_jacobian_inv(phi: np.ndarray) -> np.ndarray:
    t2 = float(phi @ phi)
    K = attitude.skew(phi)
    if t2 < 1e-10:
        return np.eye(3) - 0.5 * K + K @ K / 12.0
    t = math.sqrt(t2)
    return np.eye(3) - 0.5 * K + (1.0 / t2 - (1 + math.cos(t)) / (2 * t * math.sin(t))) * K @ K


def _error_rate(
    x_hat: np.ndarray,
    dx: np.ndarray,
    w_raw: np.ndarray,
    f_raw: np.ndarray,
    tau_a: float,
    tau_g: float,
):
    """g(dx) = d/dt (x_true ⊖ x_hat) with x_true = x_hat ⊕ dx, both driven by the same raw IMU."""
    xt = errorstate.inject(x_hat, dx)
    L, h, v = x_hat[0], x_hat[2], x_hat[3:6]
    Lt, ht, vt = xt[0], xt[2], xt[3:6]
    C = attitude.quat_to_dcm(x_hat[6:10])
    Ct = attitude.quat_to_dcm(xt[6:10])
    rm, rn = earth.meridian_radius(L) + h, earth.transverse_radius(L) + h
    Ldot, hdot = v[0] / rm, -v[2]
    Ldot_t = vt[0] / (earth.meridian_radius(Lt) + ht)
    ldot = v[1] / (rn * math.cos(L))
    ldot_t = vt[1] / ((earth.transverse_radius(Lt) + ht) * math.cos(Lt))
    dL = dx[0] / rm  # exact by the definition of ⊕
    dl = dx[1] / (rn * math.cos(L))

    out = np.empty(15)
    out[0] = (earth.meridian_radius_dlat(L) * Ldot + hdot) * dL + rm * (Ldot_t - Ldot)
    d_rn_cos = (earth.transverse_radius_dlat(L) * Ldot + hdot) * math.cos(L) - rn * math.sin(
        L
    ) * Ldot
    out[1] = d_rn_cos * dl + rn * math.cos(L) * (ldot_t - ldot)
    out[2] = vt[2] - v[2]
    out[3:6] = _vdot(Lt, ht, vt, Ct, f_raw - xt[10:13]) - _vdot(L, h, v, C, f_raw - x_hat[10:13])
    E = Ct @ C.T  # = Exp(phi)
    Edot = (
        _Cdot(Lt, ht, vt, Ct, w_raw - xt[13:16]) @ C.T
        + Ct @ _Cdot(L, h, v, C, w_raw - x_hat[13:16]).T
    )
    W = Edot @ E.T
    out[6:9] = _left_jacobian_inv(dx[6:9]) @ np.array([W[2, 1], W[0, 2], W[1, 0]])
    out[9:12] = -dx[9:12] / tau_a
    out[12:15] = -dx[12:15] / tau_g
    return out


EPS = np.array([10.0] * 3 + [1e-2] * 3 + [1e-4] * 3 + [1e-3] * 3 + [1e-5] * 3)


def _jacobian(fun, n: int = 15, eps: np.ndarray = EPS) -> np.ndarray:
    """Central differences, Richardson-extrapolated: (4 J(ε) - J(2ε)) / 3, error O(ε⁴)."""

    def central(scale: float) -> np.ndarray:
        cols = []
        for j in range(n):
            e = np.zeros(n)
            e[j] = eps[j] * scale
            cols.append((fun(e) - fun(-e)) / (2 * e[j]))
        return np.column_stack(cols)

    return (4.0 * central(1.0) - central(2.0)) / 3.0


def _assert_blocks_close(A: np.ndarray, B: np.ndarray, rtol: float, atol: float = 0.0) -> None:
    """Every 3×3 block of A equals B's to rtol relative to the block's own size."""
    for rn_, rs in BLOCKS.items():
        for cn_, cs in BLOCKS.items():
            a, b = A[rs, cs], B[rs, cs]
            scale = np.abs(b).max()
            err = np.abs(a - b).max()
            assert err <= rtol * scale + atol, (
                f"block F[{rn_},{cn_}]: error {err:.3e}, size {scale:.3e}"
            )


@settings(max_examples=60, deadline=None, derandomize=True)
@given(states, taus)
def test_F_matches_continuous_error_dynamics(sample, tau) -> None:
    x, w_raw, f_raw = sample
    C = attitude.quat_to_dcm(x[6:10])
    f_n = C @ (f_raw - x[10:13])
    F = errorstate.system_matrix(x[0], x[2], x[3:6], C, f_n, *tau)
    J = _jacobian(lambda dx: _error_rate(x, dx, w_raw, f_raw, *tau))
    _assert_blocks_close(F, J, rtol=1e-6, atol=1e-18)


def test_F_small_terms_are_present() -> None:
    """The 1e-5..1e-8-sized Coriolis, transport-rate and gravity-gradient entries are not zero
    (so the block test above is really comparing them)."""
    x = _state(
        math.radians(26.8), 0.0, np.array([2.0, 1.0, 0.1]), np.zeros(3), np.zeros(3), np.zeros(3)
    )
    F = errorstate.system_matrix(x[0], x[2], x[3:6], np.eye(3), np.array([0, 0, -9.79]))
    # dr_D > 0: truly deeper, where gravity is stronger: dv_D/dr_D = -dg/dh = +2g/R
    assert F[5, 2] == pytest.approx(2 * 9.79 / 6.37e6, rel=0.01)
    # -[(2ω_ie + ω_en)×] at (N, E) is (2ω_ie + ω_en)_D ≈ -2Ω sin L (Coriolis)
    assert F[3, 4] == pytest.approx(-2 * earth.OMEGA_IE * math.sin(x[0]), rel=0.01)
    assert abs(F[6, 0]) > 1e-12  # earth rate's latitude dependence


def _step_jacobian_error(x: np.ndarray, w: np.ndarray, f: np.ndarray, dt: float, tau) -> float:
    """max |Φ - J| for one step of length dt, J the FD Jacobian of strapdown.propagate."""
    x = x.copy()
    x[1] = 0.0  # longitude drives nothing; 0 keeps its float64 roundoff negligible in dr_E

    def step(xx: np.ndarray) -> np.ndarray:
        return strapdown.propagate(xx, w, f, w, f, dt, 0.0, dt, *tau)[0]

    x1, mid = strapdown.propagate(x, w, f, w, f, dt, 0.0, dt, *tau)
    F = errorstate.system_matrix(mid.lat, mid.h, mid.v_n, mid.C_nb, mid.f_n, *tau)
    eps = np.array([100.0] * 3 + [1e-2] * 3 + [1e-2] * 3 + [1e-1] * 3 + [1e-2] * 3)
    J = _jacobian(lambda dx: errorstate.difference(step(errorstate.inject(x, dx)), x1), eps=eps)
    return float(np.abs(errorstate.transition(F, dt) - J).max() / np.abs(J).max())


@settings(max_examples=40, deadline=None, derandomize=True)
@given(states, taus)
def test_Phi_matches_one_mechanization_step(sample, tau) -> None:
    """Φ = I + F dt + (F dt)²/2, F at the step's midpoint, vs the FD Jacobian of one step.

    At dt = 5 ms (a 200 Hz IMU) they agree to 1e-6 relative (max-norm; ‖J‖ = 1). What remains is
    O(dt³): the series truncation (e.g. the r←v←phi←b_g chain, |f| dt³/6) and the trapezoidal
    position update; the next test shows it shrinks as dt³, which a wrong term would not.
    """
    x, w, f = sample
    assert _step_jacobian_error(x, w, f, 0.005, tau) <= 1e-6


def test_Phi_residual_is_third_order() -> None:
    """Halving dt divides the Φ-vs-step mismatch by ≈ 8: only O(dt³) truncation is left."""
    rng = np.random.default_rng(11)
    for _ in range(3):
        x = _state(
            rng.uniform(-1.3, 1.3),
            0.0,
            rng.normal(0, 4, 3),
            rng.normal(0, 1, 3),
            np.zeros(3),
            np.zeros(3),
        )
        w, f = rng.normal(0, 0.3, 3), np.array([0.0, 0.0, -9.8]) + rng.normal(0, 2, 3)
        e_coarse = _step_jacobian_error(x, w, f, 0.04, (math.inf, math.inf))
        e_fine = _step_jacobian_error(x, w, f, 0.02, (math.inf, math.inf))
        assert 6.0 < e_coarse / e_fine < 10.0, (e_coarse, e_fine)
        assert e_fine < 2e-5  # at 100 Hz (dt = 0.01) this is ~1e-6


def test_Phi_detects_a_sign_error() -> None:
    """The step test is sharp: flipping the sign of [f×] in F makes it fail by far."""
    rng = np.random.default_rng(3)
    x = _state(0.5, 10.0, rng.normal(0, 3, 3), rng.normal(0, 1, 3), np.zeros(3), np.zeros(3))
    x[1] = 0.0
    w, f = rng.normal(0, 0.2, 3), np.array([0.5, -0.3, -9.8])
    dt = 0.01
    x1, mid = strapdown.propagate(x, w, f, w, f, dt, 0.0, dt)
    F = errorstate.system_matrix(mid.lat, mid.h, mid.v_n, mid.C_nb, mid.f_n)
    F[VEL, ATT] *= -1.0
    eps = np.array([100.0] * 3 + [1e-2] * 6 + [1e-1] * 3 + [1e-2] * 3)
    J = _jacobian(
        lambda dx: errorstate.difference(
            strapdown.propagate(errorstate.inject(x, dx), w, f, w, f, dt, 0.0, dt)[0], x1
        ),
        eps=eps,
    )
    assert np.abs(errorstate.transition(F, dt) - J).max() > 1e-2


@settings(max_examples=50, deadline=None, derandomize=True)
@given(states, st.lists(st.floats(-1.0, 1.0), min_size=15, max_size=15))
def test_inject_and_difference_are_inverse(sample, d) -> None:
    x = sample[0]
    dx = np.array(d) * np.array([50.0] * 3 + [1.0] * 3 + [0.3] * 3 + [0.01] * 3 + [1e-4] * 3)
    back = errorstate.difference(errorstate.inject(x, dx), x)
    np.testing.assert_allclose(back, dx, rtol=1e-9, atol=1e-8)


def test_inject_attitude_convention() -> None:
    """C_true = Exp(phi) C_hat: a +90° phi about down turns a north-pointing nose east."""
    x = strapdown.NavState.from_euler(0.3, 0.2, 0.0, [0, 0, 0], 0.0, 0.0, 0.0).to_array()
    dx = np.zeros(15)
    dx[8] = math.pi / 2
    yaw = attitude.quat_to_euler(errorstate.inject(x, dx)[6:10])[2]
    assert yaw == pytest.approx(math.pi / 2)


def test_inject_position_is_metres() -> None:
    x = strapdown.NavState.from_euler(0.5, 0.2, 10.0, [0, 0, 0], 0.0, 0.0, 0.0).to_array()
    dx = np.zeros(15)
    dx[0:3] = [100.0, -50.0, 2.0]
    xt = errorstate.inject(x, dx)
    ned = earth.geodetic_to_ned(xt[0], xt[1], xt[2], x[0], x[1], x[2])
    np.testing.assert_allclose(ned, [100.0, -50.0, 2.0], atol=2e-3)  # curvature: ~d²/R


def test_reset_jacobian_matches_finite_differences() -> None:
    """phi' = Log(Exp(phi) Exp(-phi_hat)); ∂phi'/∂phi at phi_hat is I + ½[phi_hat×] to 1st order."""
    phi_hat = np.array([0.01, -0.02, 0.015])

    def new_error(phi: np.ndarray) -> np.ndarray:
        q = attitude.quat_mult(attitude.rotvec_to_quat(phi), attitude.rotvec_to_quat(-phi_hat))
        return attitude.quat_to_rotvec(q)

    J = np.column_stack(
        [(new_error(phi_hat + e) - new_error(phi_hat - e)) / 2e-6 for e in np.eye(3) * 1e-6]
    )
    G = errorstate.reset_jacobian(np.concatenate([np.zeros(6), phi_hat, np.zeros(6)]))[ATT, ATT]
    # G is the left Jacobian of SO(3) to first order; its next term is [phi_hat×]²/6.
    np.testing.assert_allclose(G, J, atol=float(phi_hat @ phi_hat) / 6 * 1.1)
    assert np.abs(G - np.eye(3)).max() > 5e-3  # and the first-order term is really there


def _dvl_sensitivity(x: np.ndarray, d: np.ndarray) -> np.ndarray:
    """∂h/∂ε of the DVL reading (lever arm, rate) at ``x ⊕ ε d``, by central differences of the
    nonlinear ``dvl.predict`` and ``inject`` (not of any Jacobian)."""
    from adaptnav.sensors import dvl

    w = np.array([0.01, -0.02, 0.05])
    lever = (1.0, 0.2, 1.5)
    eps = 1e-6
    up = dvl.predict(errorstate.inject(x, eps * d), w, lever)
    down = dvl.predict(errorstate.inject(x, -eps * d), w, lever)
    return np.asarray((up - down) / (2 * eps))


def _vertical_rotation(x: np.ndarray) -> np.ndarray:
    """The error direction of a rotation of the whole solution about the vertical at ``x``:
    ``dv = e_D × v``, ``phi = e_D`` (docs/filters.md, 'Feedback and reset')."""
    d = np.zeros(errorstate.N_STATES)
    d[VEL] = np.cross([0.0, 0.0, 1.0], x[3:6])
    d[ATT] = (0.0, 0.0, 1.0)
    return d


def test_the_reset_keeps_the_vertical_rotation_unseen_by_the_dvl() -> None:
    """A DVL cannot see the whole solution turned about the vertical. The direction that held
    no information before a feedback must hold none after it: ``G N(x⁻)`` is unseen at
    ``x⁺``. With the attitude block's reset alone it is seen through ``e_D × dv̂``."""
    x = _state(0.6, -20.0, np.array([1.8, -0.9, 0.1]), np.array([0.02, -0.01, 2.1]),
               np.zeros(3), np.array([1e-5, -2e-5, 3e-5]))  # fmt: skip
    N = _vertical_rotation(x)
    assert np.abs(_dvl_sensitivity(x, N)).max() < 1e-8  # unseen before the feedback
    dx = np.zeros(errorstate.N_STATES)
    dx[VEL] = (0.05, -0.03, 0.01)
    after = errorstate.inject(x, dx)
    G = errorstate.reset_jacobian(dx)
    assert np.abs(_dvl_sensitivity(after, G @ N)).max() < 1e-8
    G_att = errorstate.reset_jacobian(dx, errorstate.RESET_ATTITUDE)
    seen = np.abs(_dvl_sensitivity(after, G_att @ N)).max()
    assert seen > 0.5 * np.linalg.norm(np.cross([0.0, 0.0, 1.0], dx[VEL]))
    # An attitude correction as well: the attitude block's own first-order term is left, a tilt
    # of ½ |phî| per unit of yaw (gravity makes tilt observable; the rotation stays unseen to
    # first order).
    dx[ATT] = (2e-4, -1e-4, 3e-3)
    after = errorstate.inject(x, dx)
    G = errorstate.reset_jacobian(dx)
    bound = np.linalg.norm(x[3:6]) * 0.5 * np.linalg.norm(dx[ATT][:2]) * 1.5
    assert np.abs(_dvl_sensitivity(after, G @ N)).max() < bound
    G_off = errorstate.reset_jacobian(dx, errorstate.RESET_OFF)
    assert np.array_equal(G_off, np.eye(errorstate.N_STATES))


def test_the_reset_modes_nest() -> None:
    """RESET_INVARIANT = RESET_ATTITUDE plus the velocity-attitude block ``-[dv̂×]``, nothing
    else; declared states stay the identity."""
    dx = np.arange(1.0, 18.0) * 1e-3
    G2 = errorstate.reset_jacobian(dx)
    G1 = errorstate.reset_jacobian(dx, errorstate.RESET_ATTITUDE)
    diff = G2 - G1
    np.testing.assert_array_equal(diff[VEL, ATT], -attitude.skew(dx[VEL]))
    diff[VEL, ATT] = 0.0
    assert not diff.any()
    assert G2.shape == (17, 17) and np.array_equal(G2[15:, :], np.eye(17)[15:, :])


def test_noise_input_and_discretization() -> None:
    """Qd is symmetric PSD and ≈ G Q Gᵀ dt for small dt; Gauss-Markov PSD is 2σ²/τ."""
    noise = ImuNoise.from_datasheet(
        arw=(0.0667, "deg/sqrt(h)"),
        vrw=(55, "ug/sqrt(Hz)"),
        gyro_bias_sigma=(1, "deg/h"),
        gyro_bias_tau=(3600, "s"),
        accel_bias_sigma=(0.25, "mg"),
        accel_bias_tau=(1, "h"),
    )
    q = errorstate.noise_psd(noise)
    assert q[0] == pytest.approx((55e-6 * 9.80665) ** 2)
    assert q[3] == pytest.approx((0.0667 * math.pi / 180 / 60) ** 2)
    assert q[9] == pytest.approx(2 * (math.radians(1) / 3600) ** 2 / 3600)
    C = attitude.euler_to_dcm(0.1, -0.2, 1.0)
    G = errorstate.noise_input_matrix(C)
    F = errorstate.system_matrix(
        0.4, 0.0, np.array([1.0, 2.0, 0.0]), C, np.array([0, 0, -9.8]), 3600.0, 3600.0
    )
    dt = 0.01
    Qd = errorstate.discrete_noise(errorstate.transition(F, dt), G, q, dt)
    np.testing.assert_allclose(Qd, Qd.T, atol=0)
    assert np.linalg.eigvalsh(Qd).min() > -1e-25
    # to O(dt): Qd_vv = C Q_a Cᵀ dt; ARW leaks in through (f dt)² arw², ~1e-5 relative here.
    np.testing.assert_allclose(Qd[VEL, VEL], C @ np.diag(q[:3]) @ C.T * dt, rtol=1e-4, atol=1e-14)


def test_gauss_markov_bias_variance_reaches_steady_state() -> None:
    """Iterating P = Φ P Φᵀ + Qd converges to σ² on the bias blocks: 2σ²/τ and Qd are right."""
    sigma_g, sigma_a, tau, dt = 1e-5, 2e-3, 50.0, 0.1
    noise = ImuNoise(
        arw=0.0,
        vrw=0.0,
        gyro_bias_sigma=sigma_g,
        gyro_bias_tau=tau,
        accel_bias_sigma=sigma_a,
        accel_bias_tau=tau,
    )
    F = np.zeros((15, 15))
    F[BA, BA] = F[BG, BG] = -np.eye(3) / tau
    Phi = errorstate.transition(F, dt)
    Qd = errorstate.discrete_noise(
        Phi, errorstate.noise_input_matrix(np.eye(3)), errorstate.noise_psd(noise), dt
    )
    P = np.zeros((15, 15))
    for _ in range(5000):
        P = errorstate.predict_covariance(P, Phi, Qd)
    np.testing.assert_allclose(np.diag(P)[BA], sigma_a**2, rtol=1e-4)
    np.testing.assert_allclose(np.diag(P)[BG], sigma_g**2, rtol=1e-4)


def test_inject_refuses_wrong_shapes() -> None:
    with pytest.raises(ValueError, match="inject needs shapes"):
        errorstate.inject(np.zeros(16), np.zeros(14))
