"""Declared error-state blocks beyond the 15 core states (models/errorstate.py, StateLayout;
docs/architecture.md, 'Adding a state block'): the compiled kernels take their size from P,
equal their readable twins, and an unobserved block leaves the core untouched."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptnav.compiled import update as uk
from adaptnav.engine import batch as engine
from adaptnav.engine.propagation import (
    propagate,
    propagate_numpy,
    propagate_partial,
    propagate_partial_numpy,
)
from adaptnav.estimation import kalman
from adaptnav.estimation.noise import FixedNoise
from adaptnav.models import errorstate
from adaptnav.models.errorstate import CORE, N_STATES, StateBlock, StateLayout
from adaptnav.models.strapdown import NOM_SIZE, NavState
from helpers import synthetic

SCALE = StateBlock("dvl_scale", ("dvl_scale",), (1e-10,))
MISALIGNMENT = StateBlock("dvl_misalignment", ("dvl_mis_x", "dvl_mis_y", "dvl_mis_z"), (0.0,) * 3)
LAYOUT = StateLayout((SCALE, MISALIGNMENT))
GM_BIAS = StateBlock("gnss_bias", ("gnss_bias_N", "gnss_bias_E"), (2 * 2.5**2 / 120.0,) * 2,
                     (1 / 120.0, 1 / 30.0))  # fmt: skip
GM_LAYOUT = StateLayout((SCALE, GM_BIAS, StateBlock("depth_bias", ("depth_bias",), (1e-6,))))


def test_a_layout_names_and_places_its_blocks() -> None:
    assert CORE.n == N_STATES and CORE.nominal_size == NOM_SIZE
    assert LAYOUT.n == 19 and LAYOUT.nominal_size == 20
    assert LAYOUT.slice("gyro_bias") == slice(12, 15)
    assert LAYOUT.slice("dvl_scale") == slice(15, 16)
    assert LAYOUT.slice("dvl_misalignment") == slice(16, 19)
    assert LAYOUT.names[15:] == ("dvl_scale", "dvl_mis_x", "dvl_mis_y", "dvl_mis_z")
    assert LAYOUT.extra_psd().tolist() == [1e-10, 0.0, 0.0, 0.0]
    with pytest.raises(KeyError, match="no state block 'x'"):
        LAYOUT.slice("x")
    with pytest.raises(ValueError, match="unique"):
        StateLayout((SCALE, SCALE))
    with pytest.raises(ValueError, match="one PSD per state"):
        StateBlock("b", ("b0", "b1"), (1.0,))
    with pytest.raises(ValueError, match=">= 0"):
        StateBlock("b", ("b0",), (-1.0,))


def _state(rng: np.random.Generator) -> np.ndarray:
    core = NavState.from_euler(
        math.radians(rng.uniform(-70, 70)), rng.uniform(-3, 3), rng.uniform(-100, 100),
        rng.normal(0, 5, 3), *rng.uniform(-0.5, 0.5, 2), rng.uniform(-3, 3),
        b_a=rng.normal(0, 0.02, 3), b_g=rng.normal(0, 1e-4, 3),
    ).to_array()  # fmt: skip
    return np.concatenate([core, rng.normal(0.0, 0.01, LAYOUT.n - N_STATES)])


def _covariance(rng: np.random.Generator) -> np.ndarray:
    # Coupled on purpose: the cross blocks are what the kernels must carry.
    sig = np.array([3.0] * 3 + [0.1] * 3 + [0.01] * 3 + [0.01] * 3 + [1e-4] * 3 + [0.01] * 4)
    L = np.tril(rng.normal(0.0, 0.3, (LAYOUT.n, LAYOUT.n)), -1) + np.eye(LAYOUT.n)
    return (sig[:, None] * (L @ L.T)) * sig[None, :]


def _rel(a: np.ndarray, b: np.ndarray, tol: float = 1e-9) -> None:
    scale = np.maximum(np.abs(b), 1e-12 * np.max(np.abs(b)))
    assert np.max(np.abs(a - b) / scale) < tol


def test_gauss_markov_step_is_the_integral_of_its_model() -> None:
    """``b' = -b/τ + w``, w of PSD q, over T: transition exp(-T/τ) and added variance
    ∫₀ᵀ exp(-2s/τ) q ds (by quadrature here); a random walk (1/τ = 0) gives 1 and q T; and a
    stationary process keeps its variance q τ / 2."""
    from scipy.integrate import quad

    q, T = np.array([0.3, 0.3, 2e-3]), 0.7
    r = np.array([1 / 120.0, 2.0, 0.0])
    d, qd = errorstate.gauss_markov(q, r, T)
    for k in range(3):
        integral = quad(lambda u, k=k: math.exp(-2.0 * u * r[k]) * q[k], 0.0, T)[0]
        assert qd[k] == pytest.approx(integral, rel=1e-12)
        assert d[k] == pytest.approx(math.exp(-T * r[k]), rel=1e-15)
    steady = q[:2] / (2.0 * r[:2])
    np.testing.assert_allclose(d[:2] ** 2 * steady + qd[:2], steady, rtol=1e-12)
    Phi, Qd = errorstate.augment(np.eye(N_STATES), np.zeros((N_STATES, N_STATES)), q, T, r)
    np.testing.assert_array_equal(np.diag(Phi)[N_STATES:], d)
    np.testing.assert_array_equal(np.diag(Qd)[N_STATES:], qd)
    assert GM_LAYOUT.kernel_psd(np.ones(12)).tolist() == [
        *[1.0] * 12, 1e-10, *GM_BIAS.psd, 1e-6, 0.0, *GM_BIAS.inv_tau, 0.0,
    ]  # fmt: skip
    with pytest.raises(ValueError, match="one 1/tau per state"):
        StateBlock("b", ("b0", "b1"), (1.0, 1.0), (0.1,))
    with pytest.raises(ValueError, match="1/tau must be finite and >= 0"):
        StateBlock("b", ("b0",), (1.0,), (-0.1,))


@pytest.mark.parametrize("layout", [LAYOUT, GM_LAYOUT], ids=["random walks", "Gauss-Markov"])
def test_compiled_propagation_of_declared_blocks_equals_the_twin(layout: StateLayout) -> None:
    rng = np.random.default_rng(3)
    core_q = errorstate.noise_psd(synthetic.NOISE)
    q = layout.kernel_psd(core_q)
    q[12 : 12 + 4] += 1e-8
    for _ in range(3):
        x, P = _state(rng), _covariance(rng)
        n = 200
        dth = rng.normal(0.0, 0.01, (n, 3)) * 0.01
        dv = (np.array([0.0, 0.0, -9.8]) + rng.normal(0.0, 0.5, (n, 3))) * 0.01
        args = (dth, dv, 0.01, dth[0] / 0.01, dv[0] / 0.01, q, 300.0, 200.0)
        xc, Pc, _, _ = propagate(x, P, *args)
        xn, Pn, _, _ = propagate_numpy(x, P, *args)
        _rel(xc, xn)
        _rel(Pc, Pn)
        # the declared states' nominal values follow their mean: constant, or exp(-t/τ)
        decay = np.exp(-n * 0.01 * layout.extra_inv_tau())
        _rel(xc[NOM_SIZE:], x[NOM_SIZE:] * decay, 1e-12)
        w, f = dth[0] / 0.01, dv[0] / 0.01
        part = (w, f, w * 1.1, f * 0.9, 0.01, 0.002, 0.007, q, 300.0, 200.0)
        got, want = propagate_partial(x, P, *part), propagate_partial_numpy(x, P, *part)
        for a, b in zip(got, want, strict=True):
            _rel(a, b)
    if layout is LAYOUT:  # 12 + m PSDs alone still mean random walks
        args = (dth, dv, 0.01, dth[0] / 0.01, dv[0] / 0.01, q[: 12 + 4], 300.0, 200.0)
        _rel(propagate(x, P, *args)[1], Pc)


def test_compiled_correction_feedback_and_reset_with_declared_states() -> None:
    rng = np.random.default_rng(4)
    for D in (1, 3, 5):
        P = _covariance(rng)
        H = rng.normal(0.0, 1.0, (D, LAYOUT.n))
        H[:, rng.integers(0, LAYOUT.n, 4)] = 0.0  # sparse, as a sensor's H is
        y, R = rng.normal(0.0, 0.1, D), np.diag(rng.uniform(0.01, 0.1, D))
        dx, P_new = np.zeros(LAYOUT.n), np.zeros((LAYOUT.n, LAYOUT.n))
        assert uk.correct(P, H, y, R, dx, P_new)
        ref = kalman.correct(P, H, y, R)
        _rel(dx, ref.dx)
        _rel(P_new, ref.P)
        x = _state(rng)
        xi = x.copy()
        uk.inject(xi, ref.dx)
        _rel(xi, errorstate.inject(x, ref.dx))
        Pr = P.copy()
        uk.reset(Pr, ref.dx)
        G = errorstate.reset_jacobian(ref.dx)
        _rel(Pr, G @ P @ G.T)


def _run(layout: StateLayout) -> engine.Navigator:
    ds = synthetic.make(7, duration=120.0)
    m = layout.n - N_STATES
    x0 = np.concatenate([ds.x0_hat, np.full(m, 0.02)])
    P0 = np.zeros((layout.n, layout.n))
    P0[:N_STATES, :N_STATES] = ds.P0
    P0[N_STATES:, N_STATES:] = np.diag(np.full(m, 1e-4))
    periods = synthetic.periods()
    names = ("dvl", "depth")
    channels = [engine.SensorChannel(ds.models[n], periods[n], FixedNoise()) for n in names]  # type: ignore[arg-type]
    cfg = engine.EngineConfig(synthetic.NOISE, layout=layout)
    nav = engine.Navigator(cfg, channels, x0, P0, ds.t0)
    for n in names:
        nav.feed_measurements(n, *ds.readings[n])
    nav.feed_imu(ds.imu_t, ds.dt, ds.dtheta, ds.dvel)
    nav.flush()
    return nav


def test_an_unobserved_block_leaves_the_core_alone_and_grows_as_a_random_walk() -> None:
    core, wide = _run(CORE), _run(LAYOUT)
    a, b = core.output(), wide.output()
    np.testing.assert_array_equal(a.x, b.x)  # the core's solution, bit for bit
    np.testing.assert_array_equal(a.P_diag, b.P_diag)
    np.testing.assert_array_equal(core.P, wide.P[:N_STATES, :N_STATES])
    np.testing.assert_array_equal(core.x, wide.x[:NOM_SIZE])
    assert np.all(wide.x[NOM_SIZE:] == 0.02)  # no reading sees them: no feedback
    assert np.all(wide.P[:N_STATES, N_STATES:] == 0.0)  # nothing couples them to the core
    elapsed = wide.t - synthetic.make(7, duration=120.0).t0
    grown = 1e-4 + LAYOUT.extra_psd() * elapsed  # P_ee + q t: a random walk
    _rel(np.diag(wide.P)[N_STATES:], grown)
    with pytest.raises(ValueError, match=r"x0 must be \(20,\), P0 \(19, 19\)"):
        engine.Navigator(
            engine.EngineConfig(synthetic.NOISE, layout=LAYOUT), [], core.x, core.P, 0.0
        )


def test_an_unobserved_gauss_markov_block_keeps_its_sigma_and_its_mean_decays() -> None:
    """Started at its steady variance q τ / 2, an unobserved Gauss-Markov state keeps it
    (a random walk's would grow by q t), its nominal value follows its mean, exp(-t/τ) of the
    start, and the core is untouched."""
    tau = np.array([40.0, 300.0, 1e4, 7.0])
    steady = StateLayout(
        (StateBlock("gm", ("g0", "g1", "g2", "g3"), tuple(2e-4 / tau), tuple(1.0 / tau)),)
    )
    core, wide = _run(CORE), _run(steady)
    np.testing.assert_array_equal(core.output().x, wide.output().x)
    np.testing.assert_array_equal(core.P, wide.P[:N_STATES, :N_STATES])
    elapsed = wide.t - synthetic.make(7, duration=120.0).t0
    _rel(np.diag(wide.P)[N_STATES:], np.full(4, 1e-4), 1e-9)
    _rel(wide.x[NOM_SIZE:], 0.02 * np.exp(-elapsed / tau), 1e-9)
    assert np.all(wide.P[:N_STATES, N_STATES:] == 0.0)
