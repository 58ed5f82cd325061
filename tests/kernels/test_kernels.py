"""The compiled propagation (adaptnav.compiled.propagation) against its NumPy twin
(adaptnav.engine.propagation).

* compiled == twin to 1e-9 over 10 000 random 100 Hz steps, compared at intermediate points
  (each side runs on from its own state, so differences would accumulate), Gauss-Markov and
  random-walk biases both covered, plus a violent run that takes every non-series branch;
* the partial-interval kernel == its twin;
* two pieces [0, s] + [s, dt] == one piece [0, dt] to the integration error of the scheme;
* the covariance in blocks: compiled == twin, and close to every step's;
* chaining calls == one call; inputs are never modified.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptnav.compiled import propagation as kernels
from adaptnav.core import attitude
from adaptnav.engine.propagation import (
    low_pass,
    propagate,
    propagate_numpy,
    propagate_partial,
    propagate_partial_numpy,
)
from adaptnav.models import errorstate, strapdown

R_EARTH = 6.4e6  # m per rad, for position differences


def _random_state(rng: np.random.Generator, speed: float = 10.0) -> np.ndarray:
    return strapdown.NavState(
        lat=math.radians(rng.uniform(-80.0, 80.0)),
        lon=rng.uniform(-math.pi, math.pi),
        h=rng.uniform(-200.0, 200.0),
        v_n=rng.uniform(-speed, speed, 3),
        q_nb=attitude.rotvec_to_quat(rng.uniform(-1.8, 1.8, 3)),
        b_a=rng.normal(0.0, 0.02, 3),
        b_g=rng.normal(0.0, 1e-4, 3),
    ).to_array()


def _random_P(rng: np.random.Generator) -> np.ndarray:
    sig = np.array([3.0] * 3 + [0.1] * 3 + [0.01] * 3 + [0.01] * 3 + [1e-4] * 3)
    L = np.tril(rng.normal(0.0, 0.3, (15, 15)), -1) + np.eye(15)
    return (sig[:, None] * (L @ L.T)) * sig[None, :]


def _random_imu(
    rng: np.random.Generator, x0: np.ndarray, n: int, dt: float, rate: float = 0.5
) -> tuple[np.ndarray, np.ndarray]:
    """Increments from random rates up to ``rate`` and specific force = gravity ± 2 m/s².

    Gravity is resolved along the attitude the rates themselves produce, so the force stays
    near 1 g in the body frame for the whole run.
    """
    w = rng.uniform(-rate, rate, (n, 3))
    q = x0[strapdown.NOM_ATT]
    f = np.empty((n, 3))
    for k in range(n):
        q = attitude.quat_mult(q, attitude.rotvec_to_quat(w[k] * dt))
        f[k] = attitude.quat_to_dcm(q).T @ [0.0, 0.0, -9.8] + rng.uniform(-2.0, 2.0, 3)
    return w * dt, f * dt


def _q_psd(rng: np.random.Generator) -> np.ndarray:
    return np.concatenate(
        [
            rng.uniform(0.5, 2.0, 3) * 1e-6,  # VRW² (m/s/√s)²
            rng.uniform(0.5, 2.0, 3) * 1e-9,  # ARW² (rad/√s)²
            rng.uniform(0.5, 2.0, 3) * 1e-10,
            rng.uniform(0.5, 2.0, 3) * 1e-14,
        ]
    )


def _assert_states_close(x: np.ndarray, ref: np.ndarray, tol: float = 1e-9) -> None:
    """Position in metres (< 1e-6 m), the rest relative to each quantity's size (< tol)."""
    pos = np.array([(x[0] - ref[0]) * R_EARTH, (x[1] - ref[1]) * R_EARTH, x[2] - ref[2]])
    assert np.abs(pos).max() < 1e-6, pos
    for sl in (strapdown.NOM_VEL, strapdown.NOM_ATT, strapdown.NOM_BA, strapdown.NOM_BG):
        scale = max(float(np.abs(ref[sl]).max()), 1e-300)
        assert np.abs(x[sl] - ref[sl]).max() <= tol * scale, (sl, x[sl] - ref[sl])


def _assert_P_close(P: np.ndarray, ref: np.ndarray, tol: float = 1e-9) -> None:
    err = float(np.abs(P - ref).max() / np.abs(ref).max())
    assert err < tol, err
    assert np.array_equal(P, P.T)  # the compiled P is exactly symmetric


def _compare_run(
    seed: int,
    n: int,
    chunks: int,
    dt: float,
    taus: tuple[float, float],
    rate: float = 0.5,
    tau_f: float = 0.0,
    block_s: float = 0.0,
) -> None:
    rng = np.random.default_rng(seed)
    x, P = _random_state(rng), _random_P(rng)
    dth, dv = _random_imu(rng, x, n, dt, rate)
    q = _q_psd(rng)
    wp, fp = dth[0] / dt, dv[0] / dt  # first sample of a mission: prev = current
    xc, Pc, wc, fc = x, P, wp, fp
    xn, Pn, wn, fn = x, P, wp, fp
    lc, ln = np.full(3, np.nan), np.full(3, np.nan)  # F's low-passed f, carried across chunks
    for idx in np.array_split(np.arange(n), chunks):
        xc, Pc, wc, fc = propagate(
            xc, Pc, dth[idx], dv[idx], dt, wc, fc, q, *taus, f_lp=lc, tau_f=tau_f, block_s=block_s
        )
        xn, Pn, wn, fn = propagate_numpy(
            xn, Pn, dth[idx], dv[idx], dt, wn, fn, q, *taus, f_lp=ln, tau_f=tau_f, block_s=block_s
        )
        _assert_states_close(xc, xn)
        _assert_P_close(Pc, Pn)
        np.testing.assert_array_equal(wc, wn)
        np.testing.assert_array_equal(fc, fn)
        np.testing.assert_allclose(lc, ln, rtol=1e-9, atol=1e-12)
    assert np.abs(xc[2] - x[2]) > 0.1  # it did move


def test_compiled_equals_twin_over_10000_steps() -> None:
    """10 000 steps at 100 Hz, compared at 5 points; τ_a finite (GM), τ_g = inf (random walk)."""
    _compare_run(seed=1, n=10_000, chunks=5, dt=0.01, taus=(600.0, math.inf))


def test_compiled_equals_twin_with_low_passed_specific_force() -> None:
    """F with the specific force low-passed (τ_f = 1 s, the engine's default), over chunks."""
    _compare_run(seed=5, n=2_000, chunks=4, dt=0.01, taus=(600.0, 600.0), tau_f=1.0)


def test_compiled_equals_twin_in_covariance_blocks() -> None:
    """P in blocks of 0.1 s (docs/filters.md, 'Covariance blocks'), chunks not a multiple of
    the block (each call closes its last, shorter block)."""
    _compare_run(seed=7, n=3_005, chunks=3, dt=0.01, taus=(600.0, math.inf), block_s=0.1)


@pytest.mark.parametrize(("rate", "bound"), [(0.0, 1e-5), (0.5, 1e-4)])
def test_covariance_blocks_approximate_the_per_step_propagation(rate: float, bound: float) -> None:
    """20 s at 100 Hz, blocks of 0.2 s against every step: each σ within ``bound`` (relative).

    The block drops, per block, the commutators of the steps' F T (Magnus) and the third-order
    terms of exp(Σ F T); both are of order (F T_block)² times F's change over the block or
    (F T_block)³, with |f| T_block ≈ 2 m/s here. Measured: 2.3e-6 for a vehicle holding still
    (F constant: the third-order terms and the noise's trapezoid alone), 1.4e-5 when the rates
    (0.5 rad/s) and the specific force (±2 m/s² of noise) change at every step; the bounds
    leave a factor of 4-7. The blocks must change P at all (else the test compares a thing with
    itself).
    """
    rng = np.random.default_rng(8)
    x, P = _random_state(rng), _random_P(rng)
    n, dt = 2_000, 0.01
    if rate > 0.0:
        dth, dv = _random_imu(rng, x, n, dt, rate)
    else:
        C = attitude.quat_to_dcm(x[strapdown.NOM_ATT])
        dth, dv = np.zeros((n, 3)), np.tile(C.T @ [0.0, 0.0, -9.8] * dt, (n, 1))
    q = _q_psd(rng)
    args = (dth, dv, dt, dth[0] / dt, dv[0] / dt, q, 600.0, math.inf)
    _, every, _, _ = propagate(x, P, *args)
    _, blocks, _, _ = propagate(x, P, *args, block_s=0.2)
    change = np.abs(np.sqrt(np.diag(blocks)) / np.sqrt(np.diag(every)) - 1.0)
    assert change.max() < bound, change
    assert np.abs(blocks - every).max() > 1e-12 * np.abs(every).max()


def test_low_pass_of_F_only_changes_P() -> None:
    """The nominal state does not see the low-pass; P does, and with τ_f → 0 it is the
    measured-f P again, bit for bit at τ_f = 0."""
    rng = np.random.default_rng(6)
    x, P = _random_state(rng), _random_P(rng)
    dth, dv = _random_imu(rng, x, 500, 0.01, 2.0)
    dv = dv + rng.normal(0.0, 0.05 * 0.01, dv.shape)  # accelerometer noise
    q = _q_psd(rng)
    args = (dth, dv, 0.01, dth[0] / 0.01, dv[0] / 0.01, q, 600.0, 600.0)
    x0, P0, _, _ = propagate(x, P, *args)
    x1, P1, _, _ = propagate(x, P, *args, tau_f=1.0)
    _, P2, _, _ = propagate(x, P, *args, tau_f=1e-9)
    _, P3, _, _ = propagate(x, P, *args, tau_f=0.0)
    np.testing.assert_array_equal(x0, x1)
    assert np.abs(P1 - P0).max() > 1e-6 * np.abs(P0).max()
    np.testing.assert_allclose(P2, P0, rtol=1e-12, atol=0.0)
    np.testing.assert_array_equal(P3, P0)


def test_low_pass_is_a_first_order_filter() -> None:
    """A step in f: the filter output after t is f (1 - exp(-t/τ)) (exact discretisation)."""
    flp = np.full(3, np.nan)
    low_pass(flp, np.zeros(3), 0.01, 2.0)
    for _ in range(100):
        low_pass(flp, np.array([1.0, -2.0, 9.8]), 0.01, 2.0)
    np.testing.assert_allclose(flp, np.array([1.0, -2.0, 9.8]) * (1.0 - math.exp(-0.5)))


def test_compiled_equals_twin_other_bias_models() -> None:
    """τ_a = inf with τ_g finite, then both finite and short (strong decay)."""
    _compare_run(seed=2, n=600, chunks=3, dt=0.01, taus=(math.inf, 300.0))
    _compare_run(seed=3, n=300, chunks=2, dt=0.01, taus=(5.0, 2.0))


def test_compiled_equals_twin_in_violent_motion() -> None:
    """dt = 1 s at up to 1 km/s and 3 rad/s: rotation angles > 0.1 rad per step and latitude
    steps > 1e-4 rad, i.e. every branch off the series paths in kernels."""
    rng = np.random.default_rng(4)
    x, P = _random_state(rng, speed=1000.0), _random_P(rng)
    dth, dv = _random_imu(rng, x, 60, 1.0, rate=3.0)
    q = _q_psd(rng)
    args = (dth, dv, 1.0, dth[0], dv[0], q, 900.0, 900.0)
    xc, Pc, _, _ = propagate(x, P, *args)
    xn, Pn, _, _ = propagate_numpy(x, P, *args)
    _assert_states_close(xc, xn)
    _assert_P_close(Pc, Pn)


def test_varying_dt_matches_twin() -> None:
    rng = np.random.default_rng(5)
    x, P = _random_state(rng), _random_P(rng)
    dth, dv = _random_imu(rng, x, 200, 0.01)
    dts = rng.uniform(0.005, 0.02, 200)
    q = _q_psd(rng)
    xc, Pc, _, _ = propagate(x, P, dth, dv, dts, dth[0] / 0.01, dv[0] / 0.01, q, 100.0, 50.0)
    xn, Pn, _, _ = propagate_numpy(x, P, dth, dv, dts, dth[0] / 0.01, dv[0] / 0.01, q, 100.0, 50.0)
    _assert_states_close(xc, xn)
    _assert_P_close(Pc, Pn)


@pytest.mark.parametrize("taus", [(math.inf, math.inf), (600.0, 60.0)])
def test_partial_interval_equals_twin(taus: tuple[float, float]) -> None:
    rng = np.random.default_rng(6)
    dt = 0.01
    for _ in range(20):
        x, P, q = _random_state(rng), _random_P(rng), _q_psd(rng)
        C = attitude.quat_to_dcm(x[strapdown.NOM_ATT])
        w_cur = rng.uniform(-0.5, 0.5, 3)
        f_cur = C.T @ [0.0, 0.0, -9.8] + rng.uniform(-2.0, 2.0, 3)
        w_prev = w_cur + rng.uniform(-0.1, 0.1, 3)
        f_prev = f_cur + rng.uniform(-1.0, 1.0, 3)
        ta, tb = np.sort(rng.uniform(0.0, dt, 2))
        for a, b in ((ta, tb), (0.0, tb), (ta, dt), (0.0, dt)):
            args = (w_prev, f_prev, w_cur, f_cur, dt, a, b, q, *taus)
            xc, Pc = propagate_partial(x, P, *args)
            xn, Pn = propagate_partial_numpy(x, P, *args)
            _assert_states_close(xc, xn, tol=1e-12)
            _assert_P_close(Pc, Pn, tol=1e-12)


def test_whole_interval_partial_equals_run_step() -> None:
    rng = np.random.default_rng(7)
    x, P, q = _random_state(rng), _random_P(rng), _q_psd(rng)
    dth, dv = _random_imu(rng, x, 2, 0.01)
    wp, fp = dth[0] / 0.01, dv[0] / 0.01
    x1, P1, _, _ = propagate(x, P, dth[1:], dv[1:], 0.01, wp, fp, q, 300.0, 300.0)
    x2, P2 = propagate_partial(x, P, wp, fp, dth[1] / 0.01, dv[1] / 0.01, 0.01, 0.0, 0.01, q,
                               300.0, 300.0)  # fmt: skip
    _assert_states_close(x2, x1, tol=1e-13)
    _assert_P_close(P2, P1, tol=1e-13)


def _split_discrepancy(
    rng: np.random.Generator, dt: float, q: np.ndarray
) -> tuple[np.ndarray, float, float]:
    """Worst |x_split ⊖ x_whole| per block (r, v, phi, b), relative P difference, and the worst
    ratio of the position difference to the trapezoid bound v̈ s (T - s) T / 4."""
    worst, worst_P, worst_ratio = np.zeros(4), 0.0, 0.0
    for _ in range(10):
        x, P = _random_state(rng), _random_P(rng)
        C = attitude.quat_to_dcm(x[strapdown.NOM_ATT])
        w_cur = rng.uniform(-0.5, 0.5, 3)
        f_cur = C.T @ [0.0, 0.0, -9.8] + rng.uniform(-2.0, 2.0, 3)
        # smooth motion: rates change by <= 1 rad/s² and 10 m/s³
        w_prev = w_cur + rng.uniform(-1.0, 1.0, 3) * dt
        f_prev = f_cur + rng.uniform(-10.0, 10.0, 3) * dt
        s = rng.uniform(0.1, 0.9) * dt
        rates = (w_prev, f_prev, w_cur, f_cur, dt)
        x1, P1 = propagate_partial(x, P, *rates, 0.0, dt, q, 600.0, 600.0)
        xa, Pa = propagate_partial(x, P, *rates, 0.0, s, q, 600.0, 600.0)
        x2, P2 = propagate_partial(xa, Pa, *rates, s, dt, q, 600.0, 600.0)
        d = np.abs(errorstate.difference(x2, x1))
        worst = np.maximum(worst, [d[0:3].max(), d[3:6].max(), d[6:9].max(), d[9:].max()])
        worst_P = max(worst_P, float(np.abs(P2 - P1).max() / np.abs(P1).max()))
        v_ddot = np.linalg.norm(w_cur) * np.linalg.norm(f_cur) + np.abs(f_cur - f_prev).max() / dt
        worst_ratio = max(worst_ratio, float(d[0:3].max() / (v_ddot * s * (dt - s) * dt / 4.0)))
    return worst, worst_P, worst_ratio


def test_two_pieces_equal_one_piece_to_integration_error() -> None:
    """[0, s] then [s, dt] against [0, dt] at 100 Hz: rates up to 0.5 rad/s and |f| ≈ 12 m/s²,
    changing by <= 1 rad/s² and 10 m/s³ (smooth vehicle motion).

    The scheme is second order, so the two differ by its local integration error:

    * position is by the trapezoid, whose error for a velocity of curvature v̈ is -v̈ τ³/12 over
      a piece of length τ; splitting changes it by v̈ (T³ - s³ - (T - s)³)/12 = v̈ s (T - s) T/4,
      |v̈| <= |ω| |f| + |ḟ|: checked case by case (measured <= 1.08 × that bound; ~1e-6 m);
    * velocity and attitude by the neglected higher-order terms of the midpoint, coning and
      sculling rules: < 1e-8 m/s and < 1e-10 rad (measured ~4e-9 m/s, ~1e-11 rad);
    * biases decay exactly, exp(-s/τ) exp(-(T - s)/τ) = exp(-T/τ);
    * Φ over two pieces equals Φ over one to second order in F T; P differs by < 1e-7 of
      max |P| (measured ~3e-9).

    Halving dt (same cases) must shrink the position and P differences ~8× (third order) and
    the velocity and attitude ones >= 4×, as truncation errors do and a mistake would not.
    """
    rng = np.random.default_rng(8)
    d1, p1, ratio = _split_discrepancy(rng, 0.01, _q_psd(rng))
    assert ratio < 1.5
    assert d1[1] < 1e-8  # m/s
    assert d1[2] < 1e-10  # rad
    assert d1[3] < 1e-17  # exp(-s/τ) exp(-(T - s)/τ) = exp(-T/τ)
    assert p1 < 1e-7
    rng = np.random.default_rng(8)
    d2, p2, _ = _split_discrepancy(rng, 0.005, _q_psd(rng))
    assert d2[0] < d1[0] / 7.0
    assert p2 < p1 / 7.0
    assert d2[1] < d1[1] / 3.5
    assert d2[2] < d1[2] / 3.5


def test_chained_calls_equal_one_call() -> None:
    """Carrying (x, P, w_prev, f_prev) from one call to the next is the same as one long call."""
    rng = np.random.default_rng(9)
    x, P, q = _random_state(rng), _random_P(rng), _q_psd(rng)
    dth, dv = _random_imu(rng, x, 3000, 0.01)
    wp, fp = dth[0] / 0.01, dv[0] / 0.01
    x1, P1, w1, f1 = propagate(x, P, dth, dv, 0.01, wp, fp, q, 600.0, 600.0)
    x2, P2, w2, f2 = x, P, wp, fp
    for idx in np.array_split(np.arange(3000), 7):
        x2, P2, w2, f2 = propagate(x2, P2, dth[idx], dv[idx], 0.01, w2, f2, q, 600.0, 600.0)
    np.testing.assert_array_equal(w2, w1)
    np.testing.assert_array_equal(f2, f1)
    np.testing.assert_array_equal(w1, dth[-1] / 0.01)
    _assert_states_close(x2, x1, tol=1e-13)
    _assert_P_close(P2, P1, tol=1e-13)


def test_public_functions_do_not_modify_their_inputs() -> None:
    rng = np.random.default_rng(10)
    x, P, q = _random_state(rng), _random_P(rng), _q_psd(rng)
    dth, dv = _random_imu(rng, x, 50, 0.01)
    dts = np.full(50, 0.01)
    wp, fp = dth[0] / 0.01, dv[0] / 0.01
    w_cur, f_cur = dth[1] / 0.01, dv[1] / 0.01
    inputs = (x, P, dth, dv, dts, wp, fp, w_cur, f_cur, q)
    saved = [a.copy() for a in inputs]
    for fn in (propagate, propagate_numpy):
        out = fn(x, P, dth, dv, dts, wp, fp, q, 60.0, 60.0)
        assert not any(np.shares_memory(o, i) for o in out for i in inputs)
    for fn2 in (propagate_partial, propagate_partial_numpy):
        out2 = fn2(x, P, wp, fp, w_cur, f_cur, 0.01, 0.002, 0.007, q, 60.0, 60.0)
        assert not any(np.shares_memory(o, i) for o in out2 for i in inputs)
    for a, b in zip(inputs, saved, strict=True):
        np.testing.assert_array_equal(a, b)


def test_in_place_kernel_contract() -> None:
    """kernels.propagate_run overwrites x, P, w_prev, f_prev, f_lp and nothing else."""
    rng = np.random.default_rng(11)
    x, P, q = _random_state(rng), _random_P(rng), _q_psd(rng)
    dth, dv = _random_imu(rng, x, 20, 0.01)
    dts = np.full(20, 0.01)
    wp, fp = dth[0] / 0.01, dv[0] / 0.01
    l_out = np.full(3, np.nan)
    x_out, P_out, w_out, f_out = propagate(
        x, P, dth, dv, dts, wp, fp, q, 60.0, 60.0, f_lp=l_out, tau_f=1.0
    )
    assert np.all(np.isfinite(l_out))
    xk, Pk, wk, fk, lk = x.copy(), P.copy(), wp.copy(), fp.copy(), np.full(3, np.nan)
    dth0, dv0, q0 = dth.copy(), dv.copy(), q.copy()
    kernels.propagate_run(xk, Pk, dth, dv, dts, wk, fk, q, 60.0, 60.0, lk, 1.0, 0.0)
    for got, want in ((xk, x_out), (Pk, P_out), (wk, w_out), (fk, f_out), (lk, l_out)):
        np.testing.assert_array_equal(got, want)
    for a, b in ((dth, dth0), (dv, dv0), (q, q0)):
        np.testing.assert_array_equal(a, b)


def test_in_place_partial_kernel_contract() -> None:
    """kernels.propagate_partial overwrites x and P and leaves the rates alone."""
    rng = np.random.default_rng(12)
    x, P, q = _random_state(rng), _random_P(rng), _q_psd(rng)
    rates = [rng.uniform(-0.5, 0.5, 3), rng.uniform(-10.0, 10.0, 3)] * 2
    x_out, P_out = propagate_partial(x, P, *rates, 0.01, 0.003, 0.008, q, 60.0, 60.0)
    xk, Pk, saved = x.copy(), P.copy(), [r.copy() for r in rates]
    kernels.propagate_partial(
        xk, Pk, *rates, 0.01, 0.003, 0.008, q, 60.0, 60.0, np.full(3, np.nan), 0.0
    )
    np.testing.assert_array_equal(xk, x_out)
    np.testing.assert_array_equal(Pk, P_out)
    for r, r0 in zip(rates, saved, strict=True):
        np.testing.assert_array_equal(r, r0)


def test_bad_shapes_and_intervals_are_refused() -> None:
    x, P, z3, q = np.zeros(16), np.eye(15), np.zeros(3), np.zeros(12)
    with pytest.raises(ValueError, match="P must be"):
        propagate(x, np.eye(14), np.zeros((2, 3)), np.zeros((2, 3)), 0.01, z3, z3, q)
    with pytest.raises(ValueError, match="dt must be"):
        propagate(x, P, np.zeros((2, 3)), np.zeros((2, 3)), 0.0, z3, z3, q)
    with pytest.raises(ValueError, match="ta < tb"):
        propagate_partial(x, P, z3, z3, z3, z3, 0.01, 0.005, 0.005, q)
    with pytest.raises(ValueError, match="ta < tb"):
        propagate_partial_numpy(x, P, z3, z3, z3, z3, 0.01, 0.0, 0.02, q)
