"""Compiled epochs (adaptnav.compiled.update and the engine's compiled loop) against their twins.

* every sensor's compiled linearisation == its ``evaluate`` (y and H) at random states, lever
  arms and mounting rotations, wrapped residuals included; the registry and its hook;
* ``correct`` == kalman.correct; ``stacked_update`` == the strategies' ``update``: FixedNoise,
  CovarianceMatching (innovation- and residual-based, windows not yet full, just full, full),
  VariationalBayes (stacked sensors, several iterations, with and without early stop);
  ``gate_statistic`` == gate.apply_gate; ``inject``/``reset`` == errorstate;
* the engine == the previous, readable engine (tests/helpers/engine_reference.py) over whole
  missions: the three filters, both epoch policies, batch and streaming, outliers and gates, NaN,
  duplicate and late readings, a sensor linearised by its Python ``evaluate``.

All to 1e-9 relative (positions: 1e-6 m; covariances: 1e-9 of sqrt(P_ii P_jj)).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from adaptnav.compiled import update as uk
from adaptnav.core import attitude
from adaptnav.engine import batch as engine
from adaptnav.estimation import kalman
from adaptnav.estimation.gate import Gate, Guard, apply_gate
from adaptnav.estimation.health import DivergenceGuard
from adaptnav.estimation.noise import (
    Block,
    CovarianceMatching,
    FixedNoise,
    MatchingState,
    VariationalBayes,
    VBState,
)
from adaptnav.estimation.noise.process import QAdaptation
from adaptnav.models import errorstate, strapdown
from adaptnav.sensors import DVL, GNSS, Depth, Heading, Inclinometer
from adaptnav.sensors.base import Measurement
from adaptnav.sensors.inclinometer import PendulumInclinometer
from adaptnav.sensors.nhc import NonHolonomic
from adaptnav.sensors.zupt import ZeroVelocity
from helpers import engine_reference, synthetic

_F0 = np.array([0.3, -0.2, -9.8])
"""A specific force for the pendulum inclinometer's linearisation (m/s²)."""

RTOL = 1e-9


def _assert_rel(a: Any, b: Any, tol: float = RTOL) -> None:
    """max |a - b| <= tol * max |b| (relative to the array's scale; NaN where b is NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (a.shape, b.shape)
    nan = np.isnan(b)
    assert np.array_equal(np.isnan(a), nan), (a, b)
    if nan.all():
        return
    scale = max(float(np.abs(b[~nan]).max()), 1e-300)
    err = float(np.abs(a[~nan] - b[~nan]).max())
    assert err <= tol * scale, f"max error {err:.3e} vs scale {scale:.3e}\n{a}\n{b}"


def _assert_P(P: np.ndarray, ref: np.ndarray, tol: float = RTOL) -> None:
    """Covariances: |ΔP_ij| <= tol sqrt(P_ii P_jj)."""
    d = np.sqrt(np.abs(np.diag(ref)))
    err = np.abs(P - ref) / np.maximum(np.outer(d, d), 1e-300)
    assert float(err.max()) <= tol, float(err.max())


def _random_state(rng: np.random.Generator) -> np.ndarray:
    return strapdown.NavState(
        lat=math.radians(rng.uniform(-80.0, 80.0)),
        lon=rng.uniform(-math.pi, math.pi),
        h=rng.uniform(-200.0, 200.0),
        v_n=rng.uniform(-5.0, 5.0, 3),
        q_nb=attitude.rotvec_to_quat(rng.uniform(-1.5, 1.5, 3)),
        b_a=rng.normal(0.0, 0.02, 3),
        b_g=rng.normal(0.0, 1e-3, 3),
    ).to_array()


def _rotation(rng: np.random.Generator) -> np.ndarray:
    return attitude.quat_to_dcm(attitude.rotvec_to_quat(rng.uniform(-1.0, 1.0, 3)))


def _random_P(rng: np.random.Generator) -> np.ndarray:
    sig = np.array([3.0] * 3 + [0.1] * 3 + [0.01] * 3 + [0.01] * 3 + [1e-4] * 3)
    L = np.tril(rng.normal(0.0, 0.3, (15, 15)), -1) + np.eye(15)
    P = (sig[:, None] * (L @ L.T)) * sig[None, :]
    return 0.5 * (P + P.T)


def _models(rng: np.random.Generator) -> list[Any]:
    return [
        DVL(0.01, rng.uniform(-3, 3, 3), _rotation(rng)),
        DVL(0.02),
        Depth(0.05, rng.uniform(-3, 3, 3)),
        Depth(0.05, rng.uniform(-3, 3, 3), surface_h=rng.uniform(-100, 100)),
        Inclinometer(0.002, _rotation(rng)),
        Inclinometer((0.001, 0.003)),
        PendulumInclinometer(0.002, _rotation(rng)),
        PendulumInclinometer((0.001, 0.003)),
        Heading(0.01, _rotation(rng)),
        GNSS(2.0, rng.uniform(-3, 3, 3)),
        GNSS((1.0, 1.5), rng.uniform(-3, 3, 3), use_height=False),
        ZeroVelocity(0.01),
        NonHolonomic(0.05, rng.uniform(-3, 3, 3), _rotation(rng)),
        NonHolonomic((0.1, 0.05)),
    ]


def _reading(
    model: Any, x: np.ndarray, w: np.ndarray, rng: np.random.Generator, f: np.ndarray = _F0
) -> np.ndarray:
    if isinstance(model, DVL | NonHolonomic):
        pred = model.predict(x, w)
    elif isinstance(model, PendulumInclinometer):
        pred = model.predict(x, f)
    else:
        pred = np.atleast_1d(model.predict(x))
    z = pred + rng.normal(0.0, 0.05, pred.shape)
    if isinstance(model, GNSS):
        z = pred + rng.normal(0.0, 1e-6, pred.shape)
    if isinstance(model, Heading | Inclinometer | PendulumInclinometer) and rng.random() < 0.5:
        z = z + 2.0 * math.pi * rng.integers(-2, 3)  # any branch: the residual is wrapped
    return np.asarray(z, dtype=float)


def _linearise(
    model: Any, x: np.ndarray, z: np.ndarray, w: np.ndarray, row: int, f: np.ndarray = _F0
) -> Any:
    spec = uk.compiled_linearisation(model)
    assert spec is not None
    y = np.full(row + 4, 7.0)
    H = np.full((row + 4, 15), 7.0)
    zz = np.zeros(3)
    zz[: z.size] = z
    uk.linearise(spec[0], spec[1], x, zz, w, f, y, H, row)
    return y, H


def _evaluate(model: Any, x: np.ndarray, z: np.ndarray, w: Any, f: np.ndarray = _F0) -> Any:
    if isinstance(model, PendulumInclinometer):
        return model.evaluate(x, z, w, f)
    return model.evaluate(x, z, w)


# --- linearisations ------------------------------------------------------------------------------


def test_compiled_linearisations_equal_evaluate() -> None:
    rng = np.random.default_rng(1)
    for _ in range(60):
        x = _random_state(rng)
        w = rng.uniform(-0.5, 0.5, 3)
        f = np.array([0.0, 0.0, -9.8]) + rng.uniform(-3.0, 3.0, 3)
        for model in _models(rng):
            z = _reading(model, x, w, rng, f)
            m = _evaluate(model, x, z, w, f)
            assert m is not None
            row = int(rng.integers(0, 4))
            y, H = _linearise(model, x, z, w, row, f)
            d = model.dim
            _assert_rel(y[row : row + d], m.y)
            _assert_rel(H[row : row + d], m.H)
            assert np.all(y[:row] == 7.0) and np.all(H[:row] == 7.0)  # other rows untouched


def test_wrapped_residuals_equal_evaluate() -> None:
    """Heading across ±π, GNSS across the antimeridian, angles far outside (-π, π]."""
    rng = np.random.default_rng(2)
    x = _random_state(rng)
    x[1] = math.pi - 1e-7
    gnss = GNSS(1.0, (1.0, 2.0, 0.5))
    z = gnss.predict(x)
    z[1] = -math.pi + 2e-7
    cases: list[tuple[Any, np.ndarray]] = [(gnss, z)]
    yaw = attitude.quat_to_euler(x[6:10])[2]
    for dz in (math.pi - 1e-9, -math.pi + 1e-9, 3 * math.pi, -5 * math.pi, 0.0):
        cases.append((Heading(0.01), np.array([yaw + dz])))
        cases.append((Inclinometer(0.01), np.array([dz, -dz])))
        cases.append((PendulumInclinometer(0.01), np.array([dz, -dz])))
    for model, zc in cases:
        m = _evaluate(model, x, zc, None)
        assert m is not None
        y, H = _linearise(model, x, zc, np.zeros(3), 0)
        _assert_rel(y[: model.dim], m.y)
        _assert_rel(H[: model.dim], m.H)


def test_registry_exact_class_and_hook() -> None:
    class MyDepth(Depth):
        pass

    class Hooked:
        def compiled_linearisation(self) -> tuple[int, np.ndarray]:
            return uk.LIN_ZUPT, np.zeros(uk.N_PAR)

    assert uk.compiled_linearisation(MyDepth(0.1)) is None  # a subclass may change evaluate
    assert uk.compiled_linearisation(object()) is None
    spec = uk.compiled_linearisation(Hooked())
    assert spec is not None and spec[0] == uk.LIN_ZUPT
    for model in _models(np.random.default_rng(0)):
        spec = uk.compiled_linearisation(model)
        assert spec is not None and spec[1].shape == (uk.N_PAR,)


# --- correction, strategies, gate, feedback -------------------------------------------------------


def _stack(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    x = _random_state(rng)
    w = rng.uniform(-0.5, 0.5, 3)
    models = _models(rng)
    chosen = rng.choice(len(models), n, replace=False)
    ms = [_evaluate(models[i], x, _reading(models[i], x, w, rng), w) for i in chosen]
    return np.vstack([m.H for m in ms]), np.concatenate([m.y for m in ms])


def test_correct_equals_kalman_correct() -> None:
    rng = np.random.default_rng(3)
    for trial in range(40):
        P = _random_P(rng)
        H, y = _stack(rng, int(rng.integers(1, 4)))
        D = y.size
        if trial % 2:
            R = np.diag(rng.uniform(1e-4, 1.0, D))
        else:
            A = rng.normal(0.0, 0.1, (D, D))
            R = A @ A.T + np.diag(rng.uniform(1e-3, 1.0, D))
        ref = kalman.correct(P, H, y, R)
        dx, Pn = np.zeros(15), np.zeros((15, 15))
        assert uk.correct(P, H, y, R, dx, Pn)
        _assert_rel(dx, ref.dx)
        _assert_P(Pn, ref.P)
        assert np.array_equal(Pn, Pn.T)


def test_correct_refuses_a_non_positive_definite_S() -> None:
    P = np.zeros((15, 15))
    H = np.zeros((1, 15))
    H[0, 2] = 1.0
    assert not uk.correct(P, H, np.ones(1), np.zeros((1, 1)), np.zeros(15), np.zeros((15, 15)))


def _tables(strategies: list[Any], models: list[Any]) -> engine.Navigator:
    """A Navigator only for its packed per-sensor tables."""
    chans = [engine.SensorChannel(m, 1.0, s) for m, s in zip(models, strategies, strict=True)]
    cfg = engine.EngineConfig(synthetic.NOISE)
    return engine.Navigator(
        cfg, chans, np.r_[0.5, 0.1, 0, 0, 0, 0, 1, 0, 0, 0, [0] * 6], np.eye(15), 0.0
    )


def _set_state(nav: engine.Navigator, i: int, st: Any) -> None:
    """Write a strategy state object into the navigator's tables."""
    if isinstance(st, VBState):
        d = st.alpha.size
        nav._s_state[i, uk.X_ALPHA : uk.X_ALPHA + d] = st.alpha
        nav._s_state[i, uk.X_BETA : uk.X_BETA + d] = st.beta
    elif isinstance(st, MatchingState):
        W, d = st.squares.shape
        nav._rings[i, 0, :W, :d] = st.squares
        nav._rings[i, 1, :W, :d] = st.hph
        nav._s_int[i, uk.S_COUNT] = st.count
        block = np.zeros((3, 3))
        block[:d, :d] = st.R
        nav._s_state[i, uk.X_MR : uk.X_MR + 9] = block.ravel()
    nav._s_int[i, uk.S_VERSION] += 1


def _run_stacked(strategies: list[Any], rng: np.random.Generator, states: list[Any]) -> None:
    """One stacked update of DVL + depth + inclinometer, compiled vs readable."""
    models = [DVL(0.02, rng.uniform(-2, 2, 3), _rotation(rng)), Depth(0.1), Inclinometer(0.003)]
    nav = _tables(strategies, models)
    for i, st in enumerate(states):
        _set_state(nav, i, st)
    x = _random_state(rng)
    w = rng.uniform(-0.3, 0.3, 3)
    P = _random_P(rng)
    ms = [m.evaluate(x, _reading(m, x, w, rng), w) for m in models]
    blocks = [
        Block(m.name, me.y, me.H, m.R, st) for m, me, st in zip(models, ms, states, strict=True)
    ]
    ref = strategies[0].update(P, blocks)
    ws = uk.workspace(3)
    H, y, Rb = ws[uk.WS_H], ws[uk.WS_Y], ws[uk.WS_RB]
    off = np.zeros(4, dtype=np.int64)
    for b, me in enumerate(ms):
        d = me.y.size
        off[b + 1] = off[b] + d
        H[off[b] : off[b + 1]] = me.H
        y[off[b] : off[b + 1]] = me.y
        Rb[b, :d, :d] = me.R
    D = int(off[-1])
    it = uk.stacked_update(
        nav._kind, P, H, y, D, 3, np.arange(3, dtype=np.int64), off, Rb, nav._s_int,
        nav._s_flt, nav._s_state, nav._rings, ws,
    )  # fmt: skip
    assert it == ref.iterations
    _assert_rel(ws[uk.WS_DX], ref.correction.dx)
    _assert_P(ws[uk.WS_P_NEW], ref.correction.P)
    R_used = ws[uk.WS_R_USED][:D, :D]
    for b, Rr in enumerate(ref.R_used):
        _assert_rel(R_used[off[b] : off[b + 1], off[b] : off[b + 1]], Rr)
    for m, st in zip(models, ref.states, strict=True):
        got = nav.adaptation_state(m.name)
        if st is None:
            assert got is None
            continue
        for name in st.__dataclass_fields__:
            _assert_rel(getattr(got, name), getattr(st, name))


def test_stacked_fixed_update_equals_FixedNoise() -> None:
    rng = np.random.default_rng(4)
    for _ in range(10):
        _run_stacked([FixedNoise()] * 3, rng, [None] * 3)


@pytest.mark.parametrize(("dof", "weights_only"), [(None, False), (3.0, False), (3.0, True)])
@pytest.mark.parametrize("tol", [0.0, 1e-3])
def test_stacked_vb_update_equals_VariationalBayes(
    tol: float, dof: float | None, weights_only: bool
) -> None:
    """Several fixed-point iterations (all of them with tol = 0; early stop with 1e-3), with
    the paper's Gaussian readings and with Student-t ones (a λ per sensor's reading; with
    ``weights_only``, β learning the Gaussian update's ½ B)."""
    rng = np.random.default_rng(5)
    for _ in range(10):
        strat = VariationalBayes(
            rho=0.97, iterations=int(rng.integers(1, 8)), tol=tol, dof=dof,
            weights_only=weights_only,
        )  # fmt: skip
        states = [VBState(rng.uniform(1.0, 30.0, d), rng.uniform(1e-6, 1e-2, d)) for d in (3, 1, 2)]
        _run_stacked([strat] * 3, rng, states)


@pytest.mark.parametrize("residual_based", [False, True])
@pytest.mark.parametrize("count", [0, 3, 4, 5])
def test_stacked_matching_update_equals_CovarianceMatching(
    residual_based: bool, count: int
) -> None:
    """Windows not yet full, becoming full at this update (IAE), full; the first block's
    window rules the stack (a second sensor with another window, as the readable update)."""
    rng = np.random.default_rng(6 + count)
    for _ in range(5):
        strats = [
            CovarianceMatching(5, 0.05, residual_based),
            CovarianceMatching(5, 0.05, residual_based),
            CovarianceMatching(7, 0.3, residual_based),
        ]
        states = []
        for s, d in zip(strats, (3, 1, 2), strict=True):
            sq = rng.uniform(0.0, 1e-3, (s.window, d))
            hph = rng.uniform(0.0, 1e-4, (s.window, d)) if residual_based else np.zeros_like(sq)
            R = np.diag(rng.uniform(1e-5, 1e-3, d))
            states.append(MatchingState(sq, hph, min(count, s.window), R))
        _run_stacked(strats, rng, states)


def test_gate_statistic_equals_apply_gate() -> None:
    rng = np.random.default_rng(7)
    for _ in range(50):
        d = int(rng.integers(1, 4))
        A = rng.normal(size=(d, d))
        S = A @ A.T + np.diag(rng.uniform(0.1, 1.0, d))
        nu = rng.normal(0.0, 2.0, d)
        for rule, code in (("component", uk.GATE_COMPONENT), ("chi2", uk.GATE_CHI2)):
            ref = apply_gate(Gate(10.0, rule), nu, S)  # type: ignore[arg-type]
            _assert_rel(uk.gate_statistic(code, nu, S), ref.statistic)


def test_gate_refuses_an_unknown_reference() -> None:
    with pytest.raises(ValueError, match="gate reference: value 'R'"):
        Gate(10.0, "component", "R")  # type: ignore[arg-type]


def test_inject_and_reset_equal_errorstate() -> None:
    rng = np.random.default_rng(8)
    for k in range(50):
        x = _random_state(rng)
        dx = rng.normal(0.0, 1.0, 15) * np.r_[[5.0] * 3, [0.1] * 3, [0.3 if k % 2 else 1e-4] * 3,
                                            [1e-3] * 3, [1e-5] * 3]  # fmt: skip
        ref = errorstate.inject(x, dx)
        got = x.copy()
        uk.inject(got, dx)
        assert np.abs(errorstate.difference(got, ref)[:3]).max() < 1e-6  # m
        _assert_rel(got[3:], ref[3:])
        P = _random_P(rng)
        mode = (errorstate.RESET_ATTITUDE, errorstate.RESET_INVARIANT)[k % 2]
        G = errorstate.reset_jacobian(dx, mode)
        P_ref = G @ P @ G.T
        P_ref = 0.5 * (P_ref + P_ref.T)
        uk.reset(P, dx, mode)
        _assert_P(P, P_ref)
        assert np.array_equal(P, P.T)


# --- the engine against the previous, readable one ---------------------------------------------


class PythonOnly:
    """A sensor with no compiled linearisation (the engine calls its evaluate)."""

    def __init__(self, model: Any) -> None:
        self.model = model

    @property
    def name(self) -> str:
        return str(self.model.name)

    @property
    def dim(self) -> int:
        return int(self.model.dim)

    @property
    def R(self) -> np.ndarray:
        return np.asarray(self.model.R)

    def predict(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(self.model.predict(x))

    def evaluate(self, x: np.ndarray, z: Any, omega_ib_b: Any = None) -> Measurement | None:
        return self.model.evaluate(x, z, omega_ib_b)  # type: ignore[no-any-return]


def _strategy(kind: str) -> Any:
    if kind == "meskf":
        return FixedNoise()
    if kind == "maeskf":
        return CovarianceMatching(window=6)
    if kind == "rae":
        return CovarianceMatching(window=4, residual_based=True, gap_periods=1.5)
    if kind == "vbt":
        return VariationalBayes(rho=0.95, iterations=4, tol=1e-8, irregular=True, dof=4.0)
    if kind == "vbb":  # R̂ bounds tight enough to bind both ways on this mission
        return VariationalBayes(rho=0.95, iterations=4, tol=1e-8, r_floor=0.8, r_ceiling=3.0)
    if kind == "maeb":
        return CovarianceMatching(window=6, ceiling=2.0, gap_periods=1.5)
    return VariationalBayes(rho=0.95, iterations=4, tol=1e-8, irregular=True)


def _channels(
    kind: str,
    ds: synthetic.Dataset,
    python_depth: bool,
    reference: str = "adapted",
    guard: Guard | None = None,
) -> list[engine.SensorChannel]:
    periods = synthetic.periods()
    out = []
    for name in ds.readings:
        model: Any = ds.models[name]
        if python_depth and name == "depth":
            model = PythonOnly(model)
        gate = None
        if name == "dvl":
            q = 1e6 if kind in ("vb", "vbt") and reference == "adapted" else 60.0
            gate = Gate(q, "chi2" if kind == "maeskf" else "component", reference)  # type: ignore[arg-type]
        out.append(engine.SensorChannel(model, periods[name], _strategy(kind), gate, guard))
    return out


def _mission(seed: int) -> tuple[synthetic.Dataset, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """30 s with outliers, plus NaN readings, duplicates at one stamp and a shared epoch."""
    ds = synthetic.make(seed, duration=30.0, dvl_outlier_rate=0.1)
    readings = {k: (t.copy(), z.copy()) for k, (t, z) in ds.readings.items()}
    t, z = readings["dvl"]
    z[5, 1] = np.nan
    t[20] = t[19]  # a duplicate (same sensor, same stamp)
    td, zd = readings["depth"]
    td[3] = t[30]  # depth and DVL at one epoch
    readings["dvl"] = (t, z)
    readings["depth"] = (td, zd)
    return ds, readings


def _every_step(**settings: Any) -> engine.EngineConfig:
    """The engine's settings with P propagated at every IMU step, as the readable engine does
    (covariance blocks: docs/filters.md; the blocks have their own test below)."""
    return engine.EngineConfig(synthetic.NOISE, covariance_block_s=0.0, **settings)


def _compare(out: engine.EngineOutput, ref: engine.EngineOutput, tol: float = RTOL) -> None:
    assert len(out.events) == len(ref.events)
    for a, b in zip(out.events, ref.events, strict=True):
        for key in ("t", "sensor", "row", "event", "detail"):
            assert a[key] == b[key], (key, a, b)
        for key in ("statistic", "threshold", "factor"):
            _assert_rel(a[key], b[key], 1e-8)
    assert np.abs(errorstate.difference(out.x_final, ref.x_final)[:3]).max() < 1e-6
    _assert_rel(out.x_final[3:], ref.x_final[3:])
    _assert_P(out.P_final, ref.P_final, tol)
    np.testing.assert_array_equal(out.t, ref.t)
    _assert_rel(out.x[:, 3:], ref.x[:, 3:])
    _assert_rel(out.P_diag, ref.P_diag)
    _assert_rel(out.P_cross, ref.P_cross)
    assert len(out.ledger) == len(ref.ledger)
    for a, b in zip(out.ledger, ref.ledger, strict=True):
        assert list(a) == list(b)
        for key in ("t", "t_epoch", "sensor", "row", "fate", "reason", "iterations"):
            assert a[key] == b[key] or (a[key] != a[key] and b[key] != b[key]), (key, a, b)
        for key in ("statistic", "threshold", "nu_0", "nu_1", "nu_2", "r_0", "r_1", "r_2"):
            _assert_rel(a[key], b[key], max(1e-8, 100 * tol))


@pytest.mark.parametrize(
    ("kind", "policy", "python_depth", "reference"),
    [
        ("meskf", "exact", False, "adapted"),
        ("maeskf", "exact", True, "adapted"),
        ("maeskf", "exact", False, "nominal"),
        ("rae", "grid", False, "adapted"),
        ("vb", "exact", False, "adapted"),
        ("vb", "grid", True, "adapted"),
        ("vb", "exact", True, "nominal"),
        ("vbt", "exact", True, "adapted"),
    ],
)
def test_batch_engine_equals_the_readable_engine(
    kind: str, policy: str, python_depth: bool, reference: str
) -> None:
    ds, readings = _mission(11)
    cfg = _every_step(epoch_policy=policy, output_every=7)
    args = (ds.x0_hat, ds.P0, ds.t0, ds.imu_t, ds.dt, ds.dtheta, ds.dvel, readings)
    out = engine.run_batch(cfg, _channels(kind, ds, python_depth, reference), *args)
    ref = engine_reference.run_batch(cfg, _channels(kind, ds, python_depth, reference), *args)
    fates = {r["fate"] + r["reason"] for r in ref.ledger}
    assert len(fates) >= 3  # used, rejected by the gate, and dropped
    _compare(out, ref)


def _with_holes(ds: synthetic.Dataset) -> tuple[tuple[Any, ...], tuple[Any, Any]]:
    """The mission's IMU with three holes, as the loader leaves them (mission.imu_holes): 4, 1
    and 150 samples lost before rows 400, 1200 and 2000, the rows after them stretched over the
    hole; and variances of their unknown motion (velocity, attitude)."""
    n = ds.imu_t.size
    dts = np.broadcast_to(ds.dt, (n,)).copy()
    lost = {400: 4, 1200: 1, 2000: 150}
    keep = np.ones(n, dtype=bool)
    for k, m in lost.items():
        keep[k - m : k] = False
        dts[k] *= m + 1
    dth, dv = ds.dtheta * (dts / ds.dt)[:, None], ds.dvel * (dts / ds.dt)[:, None]
    at = np.flatnonzero(np.isin(np.arange(n)[keep], list(lost)))
    var = np.array([[1e-4, 2e-4, 3e-4, 1e-6, 2e-6, 4e-6]]) * np.array([[1.0], [0.2], [30.0]])
    return (ds.imu_t[keep], dts[keep], dth[keep], dv[keep]), (at, var)


@pytest.mark.parametrize(("kind", "policy"), [("meskf", "exact"), ("vb", "grid")])
def test_imu_holes_equal_the_readable_engine(kind: str, policy: str) -> None:
    """The variances of an IMU hole's unknown motion added over its interval as process noise
    (docs/robustness.md, 'The σ over a hole'): the compiled loop as the readable engine, with
    readings inside the 1.5-s hole splitting it; each hole an event."""
    ds, readings = _mission(11)
    imu, holes = _with_holes(ds)
    cfg = _every_step(epoch_policy=policy, output_every=7)
    args = (ds.x0_hat, ds.P0, ds.t0, *imu, readings)
    out = engine.run_batch(cfg, _channels(kind, ds, False), *args, imu_holes=holes)
    ref = engine_reference.run_batch(cfg, _channels(kind, ds, False), *args, imu_holes=holes)
    _compare(out, ref)
    assert [e["event"] for e in out.events].count(engine.HOLE_EVENT) == 3
    inside = (readings["dvl"][0] > imu[0][holes[0][2]] - 1.5) & (
        readings["dvl"][0] < imu[0][holes[0][2]]
    )
    assert inside.sum() >= 2  # readings in the long hole
    plain = engine.run_batch(cfg, _channels(kind, ds, False), *args)
    assert np.all(out.P_diag[-1, 6:9] > plain.P_diag[-1, 6:9])  # the holes did count


# A guard wide open to rejections (p = 0.2) and a divergence guard with a short lockout (0.1 s;
# 0.4 s after a step, health.is_step) and a low NIS threshold, so that on 30 s every path
# fires: guard rejections, lockouts, NIS events.
GUARD = Guard(0.2, headroom=1.0, lockout_s=0.1, lockout_max=9.0)
DIVERGENCE = DivergenceGuard(nis_ratio=1.05, window=3, inflate_max=9.0)


@pytest.mark.parametrize("kind", ["meskf", "maeb", "vbb", "vbt"])
def test_guard_and_divergence_guard_equal_the_readable_engine(kind: str) -> None:
    ds, readings = _mission(13)
    cfg = _every_step(output_every=7, divergence=DIVERGENCE)
    args = (ds.x0_hat, ds.P0, ds.t0, ds.imu_t, ds.dt, ds.dtheta, ds.dvel, readings)
    out = engine.run_batch(cfg, _channels(kind, ds, kind == "vbt", guard=GUARD), *args)
    ref = engine_reference.run_batch(cfg, _channels(kind, ds, kind == "vbt", guard=GUARD), *args)
    reasons = {r["reason"] for r in ref.ledger}
    assert "guard chi2 (nominal R)" in reasons
    assert {e["event"] for e in ref.events} >= {"lockout", "nis"}
    # Dozens of inflations of P by up to 9× in 30 s magnify the rounding differences of the
    # two engines' summation orders: 2e-9 of sqrt(P_ii P_jj) measured, against 1e-9 elsewhere,
    # and matching's R̂ (a difference of two near-equal means) 6e-8 where 1e-8 holds elsewhere.
    _compare(out, ref, tol=1e-8)


@pytest.mark.parametrize("kind", ["meskf", "vb"])
def test_streaming_engine_equals_the_readable_engine(kind: str) -> None:
    """Readings fed chunk by chunk, some after the IMU passed them (late), the rest flushed."""
    ds, readings = _mission(12)
    cfg = _every_step()
    navs = [
        engine.Navigator(cfg, _channels(kind, ds, True), ds.x0_hat, ds.P0, ds.t0),
        engine_reference.Navigator(cfg, _channels(kind, ds, True), ds.x0_hat, ds.P0, ds.t0),
    ]
    step = 137
    for a in range(0, ds.imu_t.size - 200, step):
        t_lo, t_hi = ds.imu_t[a] - 0.3, ds.imu_t[min(a + step, ds.imu_t.size - 1)] - 0.3
        for nav in navs:
            for name, (t, z) in readings.items():
                for row in np.nonzero((t >= t_lo) & (t < t_hi))[0]:
                    nav.feed_measurement(name, float(t[row]), z[row], int(row))
            nav.feed_imu(
                ds.imu_t[a : a + step], ds.dt, ds.dtheta[a : a + step], ds.dvel[a : a + step]
            )
    for nav in navs:
        nav.feed_measurement("dvl", float(ds.imu_t[-1]) + 5.0, readings["dvl"][1][0], 999)
        nav.flush()
    out, ref = navs[0].output(), navs[1].output()  # type: ignore[attr-defined]
    assert any(r["reason"].startswith("late") for r in ref.ledger)
    assert any(r["reason"].startswith("after") for r in ref.ledger)
    _compare(out, ref)
    for name in readings:
        got, want = navs[0].adaptation_state(name), navs[1].adaptation_state(name)
        if want is not None:
            _assert_rel(got.beta, want.beta)


@pytest.mark.parametrize("kind", ["meskf", "vb"])
def test_covariance_blocks_carry_across_chunks(kind: str) -> None:
    """With covariance blocks (the default, 0.1 s; docs/filters.md, 'Covariance blocks') the
    IMU fed in chunks of 137 samples gives the one-piece run: a block open at a chunk's end goes
    on in the next call. And the blocks change the run by little but not nothing: each σ
    within 1e-4 of the every-step run's (kernel-level bound, tests/kernels/test_kernels.py)."""
    ds, readings = _mission(12)
    cfg = engine.EngineConfig(synthetic.NOISE, output_every=7)
    assert cfg.covariance_block_s > 0.0
    args = (ds.x0_hat, ds.P0, ds.t0, ds.imu_t, ds.dt, ds.dtheta, ds.dvel, readings)
    whole = engine.run_batch(cfg, _channels(kind, ds, False), *args)
    nav = engine.Navigator(cfg, _channels(kind, ds, False), ds.x0_hat, ds.P0, ds.t0)
    for name, (t, z) in readings.items():
        nav.feed_measurements(name, t, z)
    dts = np.broadcast_to(ds.dt, ds.imu_t.shape)
    for a in range(0, ds.imu_t.size, 137):
        b = slice(a, a + 137)
        nav.feed_imu(ds.imu_t[b], dts[b], ds.dtheta[b], ds.dvel[b])
    nav.flush()
    _compare(nav.output(), whole)
    every = engine.run_batch(
        replace(cfg, covariance_block_s=0.0), _channels(kind, ds, False), *args
    )
    change = np.abs(np.sqrt(whole.P_diag / every.P_diag) - 1.0)
    assert 1e-12 < change.max() < 1e-4, change.max()


def test_engine_refuses_a_strategy_without_compiled_update() -> None:
    class Custom(FixedNoise):
        pass

    chans = [engine.SensorChannel(Depth(0.1), 1.0, Custom())]
    with pytest.raises(TypeError, match="no compiled update"):
        engine.Navigator(engine.EngineConfig(synthetic.NOISE), chans, np.zeros(16), np.eye(15), 0.0)


@pytest.mark.parametrize("kind", ["meskf", "vbt"])
def test_q_adaptation_equals_the_readable_engine(kind: str) -> None:
    """The IMU noisier than Q says (30× in σ) so that β moves and q_scale events fire."""
    ds, readings = _mission(17)
    rng = np.random.default_rng(17)
    sd = np.sqrt(np.broadcast_to(ds.dt, ds.dvel.shape[:1]))[:, None]
    dvel = ds.dvel + rng.normal(0.0, 30 * synthetic.NOISE.vrw * sd, ds.dvel.shape)
    dth = ds.dtheta + rng.normal(0.0, 30 * synthetic.NOISE.arw * sd, ds.dtheta.shape)
    qa = QAdaptation(gain=0.5, target=0.2, window=5)
    cfg = _every_step(output_every=7, q_adaptation=qa)
    args = (ds.x0_hat, ds.P0, ds.t0, ds.imu_t, ds.dt, dth, dvel, readings)
    out = engine.run_batch(cfg, _channels(kind, ds, kind == "vbt"), *args)
    ref = engine_reference.run_batch(cfg, _channels(kind, ds, kind == "vbt"), *args)
    assert ref.q_scale > 2.0
    assert "q_scale" in {e["event"] for e in ref.events}
    _assert_rel(np.array([out.q_scale]), np.array([ref.q_scale]), 1e-9)
    _compare(out, ref)
