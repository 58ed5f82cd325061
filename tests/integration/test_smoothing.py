"""RTS smoothing in the engine (docs/smoothing.md) on synthetic missions whose IMU and sensor
errors follow the filter's own model (tests/helpers/synthetic.py), without GNSS: storing the
nodes leaves the forward pass as it was, the compiled backward pass equals the readable one over
the stored nodes, and over a seeded Monte Carlo the smoothed solution is better than the forward
one and as consistent."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from adaptnav.engine import batch as engine
from adaptnav.engine import prefault
from adaptnav.estimation import smoother
from adaptnav.estimation.health import OFF, DivergenceGuard
from adaptnav.estimation.noise import FixedNoise, VariationalBayes
from adaptnav.models import errorstate
from adaptnav.models.errorstate import CORE, N_STATES, StateBlock, StateLayout
from adaptnav.models.strapdown import NOM_SIZE
from helpers import synthetic

NAMES = ("dvl", "depth")


DEPTH_BIAS_GM = StateLayout((StateBlock("depth.bias", ("depth.bias",), (2 * 0.3**2 / 20,),
                                        (1 / 20.0,)),))  # fmt: skip
"""A depth bias as a Gauss-Markov state: σ 0.3 m, τ = 20 s."""


def _run(
    seed: int,
    smooth: bool,
    vb: bool = False,
    layout: StateLayout = CORE,
    divergence: DivergenceGuard = OFF,
) -> tuple[engine.Navigator, synthetic.Dataset]:
    ds = synthetic.make(seed, duration=120.0, sensors=NAMES)
    periods = synthetic.periods()
    strategy = VariationalBayes() if vb else FixedNoise()
    models = dict(ds.models)
    x0, P0 = ds.x0_hat, ds.P0
    if layout.n > N_STATES:  # the depth meter reads its bias state (truth: none)
        models["depth"] = replace(ds.models["depth"], cal_bias=N_STATES)  # type: ignore[type-var]
        x0 = np.concatenate([x0, [0.2]])
        P0 = np.zeros((layout.n, layout.n))
        P0[:N_STATES, :N_STATES] = ds.P0
        P0[N_STATES, N_STATES] = 0.3**2
    channels = [
        engine.SensorChannel(models[n], periods[n], strategy)  # type: ignore[arg-type]
        for n in NAMES
    ]
    nav = engine.Navigator(
        engine.EngineConfig(synthetic.NOISE, smooth=smooth, layout=layout, divergence=divergence),
        channels, x0, P0, ds.t0,
    )  # fmt: skip
    for n in NAMES:
        nav.feed_measurements(n, *ds.readings[n])
    nav.feed_imu(ds.imu_t, ds.dt, ds.dtheta, ds.dvel)
    nav.flush()
    return nav, ds


@pytest.mark.parametrize("vb", [False, True])
def test_storing_nodes_leaves_the_forward_pass_bit_for_bit(vb: bool) -> None:
    plain, with_store = _run(3, False, vb)[0].output(), _run(3, True, vb)[0].output()
    assert plain.smoothed is None and with_store.smoothed is not None
    for name in ("t", "x", "P_diag", "P_cross", "x_final", "P_final"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(with_store, name))
    assert pd.DataFrame(plain.ledger).equals(pd.DataFrame(with_store.ledger))  # NaN-aware


def test_the_store_faulted_in_by_a_helper_changes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """engine.prefault over every store the navigator allocates (however small) or over none:
    the same smoothed solution, bit for bit."""
    started: list[int] = []
    start = prefault.start

    def spy(arrays: list[np.ndarray]) -> prefault.Prefault | None:
        started.append(len(arrays))
        return start(arrays)

    monkeypatch.setattr(prefault, "MIN_BYTES", 0)
    monkeypatch.setattr(prefault, "start", spy)
    helped = _run(5, True, vb=True)[0].output().smoothed
    assert started and started[0] == len(engine.smk.NODE_ARRAYS) + len(engine.smk.UPDATE_ARRAYS)
    monkeypatch.setattr(prefault, "start", lambda arrays: None)
    alone = _run(5, True, vb=True)[0].output().smoothed
    assert helped is not None and alone is not None
    for name in ("t", "x", "P_diag", "P_cross", "declared", "declared_var"):
        np.testing.assert_array_equal(getattr(helped, name), getattr(alone, name))


@pytest.mark.parametrize("layout", [CORE, DEPTH_BIAS_GM], ids=["core", "Gauss-Markov bias"])
def test_compiled_smoothing_equals_the_readable_pass_over_the_stored_nodes(
    layout: StateLayout,
) -> None:
    nav, _ = _run(4, True, vb=True, layout=layout)
    nodes = nav.smoother_nodes()
    if layout.n > N_STATES:  # the bias's Φ between nodes: exp(-Δt/τ)
        np.testing.assert_allclose(nodes.Phi[1:, N_STATES, N_STATES],
                                   np.exp(-np.diff(nodes.t) / 20.0), rtol=1e-14)  # fmt: skip
    assert nodes.rows is not None
    # Between nodes the store's P⁻ is the propagation of the previous P plus a PSD process
    # noise: what RTS assumes.
    for k in range(1, nodes.t.size):
        Q = nodes.P_prior[k] - nodes.Phi[k] @ nodes.P[k - 1] @ nodes.Phi[k].T
        d = np.sqrt(np.diag(nodes.P_prior[k]))
        assert np.linalg.eigvalsh(Q / np.outer(d, d)).min() > -1e-9
    x_s, P_s, _ = smoother.rts(nodes)
    out = nav.output()
    sm = out.smoothed
    assert sm is not None and sm.failed == 0
    rows = nodes.rows
    np.testing.assert_allclose(sm.x, x_s[rows, :NOM_SIZE], rtol=0, atol=1e-9)
    np.testing.assert_allclose(sm.declared, x_s[rows, NOM_SIZE:], rtol=0, atol=1e-12)
    diag = np.diagonal(P_s[rows], axis1=1, axis2=2)[:, :N_STATES]
    np.testing.assert_allclose(sm.P_diag, diag, rtol=1e-9)
    np.testing.assert_array_equal(sm.t, out.t)
    # the last row has nothing after it; every output row and epoch is a node
    np.testing.assert_array_equal(sm.x[-1], out.x[-1])
    assert sm.nodes == nodes.t.size and sm.update_nodes == int(np.sum(np.any(nodes.dx, axis=1)))
    with pytest.raises(RuntimeError, match="smoothed"):
        nav.feed_imu([1e9], 0.01, np.zeros((1, 3)), np.zeros((1, 3)))


def _errors(out: engine.Smoothed | engine.EngineOutput, ds: synthetic.Dataset) -> np.ndarray:
    idx = np.searchsorted(ds.truth_t, out.t - 1e-9)
    return np.array(
        [errorstate.difference(ds.truth[i], x)[:9] for i, x in zip(idx, out.x, strict=True)]
    )


def _nees(out: engine.Smoothed | engine.EngineOutput, errors: np.ndarray) -> list[float]:
    """Mean NEES of the position, velocity and attitude blocks over the run."""
    P = np.zeros((out.t.size, N_STATES, N_STATES))
    P[:, range(N_STATES), range(N_STATES)] = out.P_diag
    for (i, j), c in zip(engine.P_CROSS_PAIRS, out.P_cross.T, strict=True):
        P[:, i, j] = P[:, j, i] = c
    blocks = (slice(0, 3), slice(3, 6), slice(6, 9))
    return [
        float(
            np.mean(
                [e[b] @ np.linalg.solve(Pk[b, b], e[b]) for e, Pk in zip(errors, P, strict=True)]
            )
        )
        for b in blocks
    ]


def test_monte_carlo_smoothed_is_better_where_observable_and_as_consistent() -> None:
    """Ten seeds, 2 minutes each, DVL and depth (no GNSS). What the data observe - velocity,
    depth, roll and pitch - the smoothed solution has with a clearly lower RMSE; horizontal
    position and heading are not observed (their forward errors are the initial ones), so
    smoothing cannot improve them and must not make them worse. Mean NEES of each block in the
    band of tests/integration/test_consistency.py ([1, 4.5]; χ²(3) mean 3)."""
    rms_f, rms_s, nees = [], [], []
    for seed in range(20, 30):
        nav, ds = _run(seed, True)
        out = nav.output()
        assert out.smoothed is not None
        ef, es = _errors(out, ds), _errors(out.smoothed, ds)
        rms_f.append(np.sqrt(np.mean(ef**2, axis=0)))
        rms_s.append(np.sqrt(np.mean(es**2, axis=0)))
        nees.append(_nees(out.smoothed, es))
    f, s = np.mean(rms_f, axis=0), np.mean(rms_s, axis=0)
    detail = f"RMSE forward {f.round(5)}, smoothed {s.round(5)}, NEES {np.round(nees, 2).tolist()}"
    assert np.linalg.norm(s[3:6]) < 0.8 * np.linalg.norm(f[3:6]), detail  # velocity
    assert s[2] < 0.5 * f[2], detail  # depth
    assert np.linalg.norm(s[6:8]) < 0.9 * np.linalg.norm(f[6:8]), detail  # roll, pitch
    assert np.linalg.norm(s[:2]) < 1.02 * np.linalg.norm(f[:2]), detail  # unobserved
    assert s[8] < 1.02 * f[8], detail
    for block, value in zip(
        ("position", "velocity", "attitude"), np.mean(nees, axis=0), strict=True
    ):
        assert 1.0 <= value <= 4.5, f"{block}: {detail}"


@pytest.mark.parametrize("seed", [1, 3])
def test_an_inflation_after_an_update_is_process_noise_not_the_filtered_covariance(
    seed: int,
) -> None:
    """The windowed NIS test inflates P after an update (P ← k P). The node stores the P the
    update left, so the inflation reaches the backward pass as process noise of the next
    interval: no smoothed variance above the forward one, the store's P at each update node
    no larger than its P⁻ (an update only removes uncertainty), and the compiled pass equal
    to the readable one. Up to 0.4.8 the node held k P: the pass took the inflation for
    uncertainty at the node itself and carried it backwards, smoothed σ up to 3.4 × the
    forward σ (demo, robust, nis_ratio 3; docs/smoothing.md, 'Inflations of P')."""
    dg = DivergenceGuard(nis_ratio=1.3, window=10)  # fires on a consistent filter, k ~ 1.3-2
    nav, _ = _run(seed, True, divergence=dg)
    nodes = nav.smoother_nodes()
    out = nav.output()
    sm = out.smoothed
    assert sm is not None and sm.failed == 0
    assert sum(e["event"] == "nis" for e in out.events) >= 4
    for k in np.flatnonzero(np.any(nodes.dx, axis=1)):  # P⁺ = G⁻¹ P G⁻ᵀ before the reset
        Gi = smoother.reset_inverse(nodes.dx[k], N_STATES, nodes.reset)
        d = np.sqrt(np.diag(nodes.P_prior[k]))
        removed = (nodes.P_prior[k] - Gi @ nodes.P[k] @ Gi.T) / np.outer(d, d)
        assert np.linalg.eigvalsh(removed).min() > -1e-9, f"node {k} at t = {nodes.t[k]}"
    ratio = sm.P_diag / out.P_diag
    assert ratio.max() <= 1.0 + 1e-9, f"smoothed variance {ratio.max():.3g} × the forward one"
    x_s, P_s, _ = smoother.rts(nodes)
    assert nodes.rows is not None
    diag = np.diagonal(P_s[nodes.rows], axis1=1, axis2=2)[:, :N_STATES]
    np.testing.assert_allclose(sm.P_diag, diag, rtol=1e-9)
    np.testing.assert_allclose(sm.x, x_s[nodes.rows, :NOM_SIZE], rtol=0, atol=1e-9)


def test_a_run_without_any_update_smooths_to_the_forward_solution() -> None:
    """No reading at all after the start: no update node, nothing to smooth towards. The
    smoothed solution is the forward one, and the store reads as nodes (up to 0.4.8
    ``smoother_nodes`` raised IndexError on an empty set of update nodes)."""
    ds = synthetic.make(5, duration=20.0, sensors=NAMES)
    channels = [
        engine.SensorChannel(ds.models[n], synthetic.periods()[n], FixedNoise())  # type: ignore[arg-type]
        for n in NAMES
    ]
    config = engine.EngineConfig(synthetic.NOISE, smooth=True)
    nav = engine.Navigator(config, channels, ds.x0_hat, ds.P0, ds.t0)
    nav.feed_imu(ds.imu_t, ds.dt, ds.dtheta, ds.dvel)
    nav.flush()
    nodes = nav.smoother_nodes()
    assert not np.any(nodes.dx) and np.array_equal(nodes.P_prior, nodes.P)
    out = nav.output()
    assert out.smoothed is not None and out.smoothed.update_nodes == 0
    np.testing.assert_array_equal(out.smoothed.x, out.x)
    np.testing.assert_array_equal(out.smoothed.P_diag, out.P_diag)


def test_smoothing_needs_its_store_from_the_start() -> None:
    nav, _ = _run(3, False)
    with pytest.raises(RuntimeError, match="smooth=True"):
        nav.smooth()
    with pytest.raises(RuntimeError, match="no forward store"):
        nav.smoother_nodes()
    assert replace(nav.config, smooth=True).smooth
