"""The RTS smoother (docs/smoothing.md): the readable backward pass against the exact posterior
of a linear-Gaussian model, and the compiled pass (compiled/smoother.py) against it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from adaptnav.compiled import smoother as smk
from adaptnav.compiled.propagation import _W
from adaptnav.core import attitude
from adaptnav.estimation import smoother
from adaptnav.models.strapdown import NOM_SIZE

Array = NDArray[np.float64]


def _spd(rng: np.random.Generator, n: int, scales: Array) -> Array:
    """A random SPD matrix with standard deviations ``scales`` and moderate correlations."""
    A = rng.normal(size=(n, n))
    C = A @ A.T + n * np.eye(n)
    d = 1.0 / np.sqrt(np.diag(C))
    return np.asarray(C * np.outer(d, d) * np.outer(scales, scales), dtype=float)


def _nominal(rng: np.random.Generator, N: int, m: int) -> Array:
    """N plausible nominal states (16 + m): position near 26.8° N, random attitude."""
    x = np.zeros((N, NOM_SIZE + m))
    x[:, 0] = math.radians(26.8) + rng.normal(0.0, 1e-4, N)
    x[:, 1] = math.radians(56.0) + rng.normal(0.0, 1e-4, N)
    x[:, 2] = rng.normal(0.0, 5.0, N)
    x[:, 3:6] = rng.normal(0.0, 2.0, (N, 3))
    for j in range(N):
        x[j, 6:10] = attitude.euler_to_quat(*rng.uniform(-0.3, 0.3, 3))
    x[:, 10:] = rng.normal(0.0, 1e-3, (N, 6 + m))
    return x


@pytest.fixture(name="linear")
def _linear() -> tuple[smoother.Nodes, Array, dict[str, Array]]:
    return _kalman(0.6)


def _kalman(
    p_update: float, rates: tuple[float, ...] = ()
) -> tuple[smoother.Nodes, Array, dict[str, Array]]:
    """A closed-loop Kalman filter on a random linear-Gaussian model (15 states, 24 nodes 1 s
    apart, an update at a node with probability ``p_update``, none at 5-7 - consecutive nodes
    without one included), its nodes and its filtered means; and the model, for the batch
    posterior. ``rates``: declared states after the core, one per 1/τ (1/s), each a
    Gauss-Markov process of its own (0: a random walk) that only the readings couple to the
    core, as errorstate.StateLayout has them."""
    rng = np.random.default_rng(5)
    m = len(rates)
    n, N, d = 15 + m, 24, 4
    scales = np.concatenate([np.logspace(1, -5, 15), np.full(m, 0.01)])
    Phi = np.stack([np.eye(n) + 0.05 * rng.normal(size=(n, n)) * np.outer(scales, 1 / scales)
                    for _ in range(N)])  # fmt: skip
    Phi[:, 9:, :] *= np.eye(n)[9:]  # rows 9-14 diagonal, as the biases' are
    decay = np.exp(-np.asarray(rates, dtype=float))  # over the 1 s between nodes
    Phi[:, 15:, 15:] = np.diag(decay)
    Phi[:, :15, 15:] = 0.0
    Q = np.stack([_spd(rng, n, 0.05 * scales) for _ in range(N)])
    Q[:, :15, 15:] = Q[:, 15:, :15] = 0.0
    Q[:, 15:, 15:] = np.diag(np.full(m, 1e-5))
    H = rng.normal(size=(d, n)) / scales
    R = np.diag(rng.uniform(0.5, 2.0, d))
    P0 = _spd(rng, n, scales)
    updated = rng.random(N) < p_update
    updated[[5, 6, 7]] = False
    truth = rng.multivariate_normal(np.zeros(n), P0)
    z = np.zeros((N, d))
    mean, P = np.zeros(n), P0.copy()
    means, Ps, priors, dxs = [], [], [], []
    for j in range(N):
        if j > 0:
            truth = Phi[j] @ truth + rng.multivariate_normal(np.zeros(n), Q[j])
            mean, P = Phi[j] @ mean, Phi[j] @ P @ Phi[j].T + Q[j]
        priors.append(P.copy())
        dx = np.zeros(n)
        if updated[j]:
            z[j] = H @ truth + rng.multivariate_normal(np.zeros(d), R)
            S = H @ P @ H.T + R
            K = np.linalg.solve(S, H @ P).T
            dx = K @ (z[j] - H @ mean)
            IKH = np.eye(n) - K @ H
            P = IKH @ P @ IKH.T + K @ R @ K.T
            mean = mean + dx
        means.append(mean.copy())
        Ps.append(P.copy())
        dxs.append(dx)
    nodes = smoother.Nodes(
        np.arange(N, dtype=float), _nominal(rng, N, m), np.array(dxs), np.array(Ps),
        np.array(priors), Phi, reset=False,
    )  # fmt: skip
    model = {"Phi": Phi, "Q": Q, "H": H, "R": R, "P0": P0, "z": z, "updated": updated}
    return nodes, np.array(means), model


def _batch_posterior(model: dict[str, Array]) -> tuple[Array, Array]:
    """Mean and covariance of all the states given all the readings, from the joint Gaussian's
    information form: prior N(0, P0) on the first state, x_j = Φ_j x_{j-1} + w_j,
    z_j = H x_j + v_j where updated."""
    Phi, Q, H, R, P0 = model["Phi"], model["Q"], model["H"], model["R"], model["P0"]
    N, n = Phi.shape[0], Phi.shape[1]
    J = np.zeros((N * n, N * n))
    h = np.zeros(N * n)
    J[:n, :n] += np.linalg.inv(P0)
    for j in range(1, N):
        Qi = np.linalg.inv(Q[j])
        a, b = slice((j - 1) * n, j * n), slice(j * n, (j + 1) * n)
        J[a, a] += Phi[j].T @ Qi @ Phi[j]
        J[a, b] -= Phi[j].T @ Qi
        J[b, a] -= Qi @ Phi[j]
        J[b, b] += Qi
    Ri = np.linalg.inv(R)
    for j in np.flatnonzero(model["updated"]):
        b = slice(j * n, (j + 1) * n)
        J[b, b] += H.T @ Ri @ H
        h[b] += H.T @ Ri @ model["z"][j]
    cov = np.linalg.inv(J)
    return (cov @ h).reshape(N, n), cov


def _assert_posterior(means: Array, e_s: Array, P_s: Array, model: dict[str, Array]) -> None:
    """The filtered means plus the smoothed errors, and the smoothed covariances, are the
    batch posterior's (:func:`_batch_posterior`), in units of its σ."""
    mu, cov = _batch_posterior(model)
    n = means.shape[1]
    for j in range(means.shape[0]):
        block = cov[j * n : (j + 1) * n, j * n : (j + 1) * n]
        sd = np.sqrt(np.diag(block))
        np.testing.assert_allclose((means[j] + e_s[j] - mu[j]) / sd, 0.0, atol=1e-7)
        np.testing.assert_allclose(P_s[j] / np.outer(sd, sd), block / np.outer(sd, sd),
                                   atol=1e-7)  # fmt: skip


def _assert_store(sm: smk.Store, x_s: Array, P_s: Array) -> None:
    """The compiled pass's store holds the readable pass's smoothed x and P (P in units of its
    σ)."""
    N, n = P_s.shape[0], P_s.shape[1]
    np.testing.assert_allclose(sm[smk.SM_X][:N], x_s, rtol=1e-12, atol=1e-12)
    got = np.zeros((N, n, n))
    for j in range(N):
        smk.unpack(sm[smk.SM_P][j], got[j], n)
    sd = np.sqrt(np.diagonal(P_s, axis1=1, axis2=2))
    np.testing.assert_allclose(got / (sd[:, :, None] * sd[:, None, :]),
                               P_s / (sd[:, :, None] * sd[:, None, :]), atol=1e-9)  # fmt: skip


def test_rts_is_the_exact_posterior_of_a_linear_gaussian_model(
    linear: tuple[smoother.Nodes, Array, dict[str, Array]],
) -> None:
    nodes, means, model = linear
    _, P_s, e_s = smoother.rts(nodes)
    _assert_posterior(means, e_s, P_s, model)
    # the smoother used what came after: it differs from the filter but at the last node
    assert np.abs(e_s[:-1]).max() > 0.0 and np.all(e_s[-1] == 0.0)
    assert np.all(np.diag(P_s[0]) < np.diag(nodes.P[0]))


@pytest.mark.parametrize("steps", [0, 1, 2, 7])
def test_accumulated_phi_is_the_product_of_the_steps(steps: int) -> None:
    """A node's stored Φ is ``Φ_k ⋯ Φ_1`` of the steps since the node before (the identity
    for none), whatever layout accumulate keeps it in; Φ's of the propagation's structure:
    rows 9-14 diagonal, position rows without the attitude columns."""
    rng = np.random.default_rng(steps)
    sm = smk.store(4, 1, NOM_SIZE, smk.CORE)
    expected = np.eye(smk.CORE)
    for k in range(2):  # two nodes in a row: the accumulator restarts from the second
        expected = np.eye(smk.CORE)
        for _ in range(steps):
            Phi = np.eye(smk.CORE) + 0.1 * rng.normal(size=(smk.CORE, smk.CORE))
            Phi[9:] = np.diag(np.diag(Phi))[9:]
            Phi[0:3, 6:] = 0.0
            flat = np.zeros(_W * _W)
            flat.reshape(_W, _W)[: smk.CORE, : smk.CORE] = Phi.T
            smk.accumulate(sm, flat)
            expected = Phi @ expected
        j = smk.node(sm, float(k), np.zeros(NOM_SIZE), np.eye(smk.CORE), smk._NO_DX,
                     smk._NO_PRIOR)  # fmt: skip
        stored = sm[smk.SM_PHI][j]
        np.testing.assert_allclose(stored[: smk.PHI_DIAG].reshape(9, smk.CORE), expected[:9],
                                   rtol=1e-13, atol=1e-13)  # fmt: skip
        np.testing.assert_allclose(stored[smk.PHI_DIAG :], np.diag(expected)[9:], rtol=1e-13)
        off = expected[9:, :] - np.diag(np.diag(expected))[9:, :]
        assert np.all(off == 0.0)  # the product keeps rows 9-14 diagonal: nothing is lost


def _store(nodes: smoother.Nodes, rates: tuple[float, ...] = ()) -> smk.Store:
    """The compiled store holding ``nodes``, filled as the forward pass fills it; ``rates``: the
    declared states' 1/τ (none: random walks), from which the store has their Φ."""
    N, n = nodes.dx.shape
    sm = smk.store(1, 1, nodes.x.shape[1], n, np.array(rates) if rates else None)
    sm = smk.grown(sm, N, N)
    for j in range(N):
        sm[smk.SM_ACC][: smk.CORE, : smk.CORE] = nodes.Phi[j][: smk.CORE, : smk.CORE]
        sm[smk.SM_COUNT][smk.K_STEPS] = 1  # Φ_acc holds the steps since the last node
        has_update = bool(np.any(nodes.dx[j] != 0.0))
        prior = nodes.P_prior[j] if has_update else np.empty((0, 0))
        smk.node(sm, nodes.t[j], nodes.x[j], nodes.P[j], nodes.dx[j], prior)
    return sm


@pytest.mark.parametrize(
    ("declared", "sparse", "reset"), [(0, False, 1), (0, False, 2), (4, False, 2), (0, True, 2)]
)
def test_compiled_backward_equals_the_twin(
    linear: tuple[smoother.Nodes, Array, dict[str, Array]], declared: int, sparse: bool, reset: int
) -> None:
    """With the reset Jacobian (``reset``: errorstate.RESET_ATTITUDE or RESET_INVARIANT) and real
    nominal states; ``declared`` states beyond the core (random walks, Φ = I there, as
    errorstate.StateLayout has them). The compiled pass multiplies the gains between update
    nodes out, the twin goes node by node; ``sparse``: an update at a fifth of the nodes, for
    runs of many nodes without one."""
    base = _kalman(0.2)[0] if sparse else linear[0]
    rng = np.random.default_rng(11)
    N, n = base.dx.shape[0], 15 + declared
    grow = np.eye(n)[None].repeat(N, axis=0)
    P, P_prior, Phi = grow.copy(), grow.copy(), grow.copy()
    extra = slice(15, n)
    P[:, :15, :15], P_prior[:, :15, :15], Phi[:, :15, :15] = base.P, base.P_prior, base.Phi
    P[:, extra, extra] *= 1e-4
    P_prior[:, extra, extra] = P[:, extra, extra] + 1e-6 * np.eye(declared)
    has_update = np.any(base.dx != 0.0, axis=1)
    P_prior = np.where(has_update[:, None, None], P_prior, P)  # no update: P⁻ is P
    dx = np.zeros((N, n))
    dx[:, :15] = base.dx
    dx[:, 6:9] = np.where(base.dx[:, 6:9] != 0.0, rng.normal(0.0, 0.02, (N, 3)), 0.0)
    dx[:, 3:6] = np.where(base.dx[:, 3:6] != 0.0, rng.normal(0.0, 0.05, (N, 3)), 0.0)
    nodes = smoother.Nodes(
        base.t, _nominal(rng, N, declared), dx, P, P_prior, Phi, reset=reset
    )  # fmt: skip
    x_s, P_s, _ = smoother.rts(nodes)
    assert np.all(np.diagonal(P_s, axis1=1, axis2=2) > 0.0)
    sm = _store(nodes)
    smk.backward(sm, reset)
    assert sm[smk.SM_COUNT][smk.K_FAILED] == 0
    _assert_store(sm, x_s, P_s)


@pytest.mark.parametrize(("threads", "chunk"), [(1, 2), (2, 1), (2, 3), (3, 2), (7, 0)])
def test_the_backward_pass_gives_the_same_bits_in_any_number_of_threads(
    threads: int, chunk: int
) -> None:
    """The chain of update nodes goes in runs of ``chunk``, each run's intervals smoothed by
    whichever thread is free (compiled.smoother.anchors, interiors); every node must come out
    exactly as from one thread in one run, the update node whose P⁻ fails included (its
    interval keeps its filtered values)."""
    nodes = _kalman(0.4)[0]
    updates = np.flatnonzero(np.any(nodes.dx != 0.0, axis=1))
    assert updates.size >= 6 and np.sum(np.diff(updates) > 2) >= 3  # intervals with nodes inside
    bad = nodes.P_prior.copy()
    j = int(updates[4])  # an update node with nodes between it and the one before
    assert j - updates[3] > 2
    bad[j] = -np.eye(15)
    nodes = smoother.Nodes(nodes.t, nodes.x, nodes.dx, nodes.P, bad, nodes.Phi, True)
    one, many = _store(nodes), _store(nodes)
    smk.backward(one, True, 1, updates.size)
    smk.backward(many, True, threads, chunk)
    assert one[smk.SM_COUNT][smk.K_FAILED] == many[smk.SM_COUNT][smk.K_FAILED] == 1
    for key in (smk.SM_X, smk.SM_P):
        np.testing.assert_array_equal(many[key], one[key])
    before = _store(nodes)
    assert not np.array_equal(many[smk.SM_P], before[smk.SM_P])  # it did smooth
    inside = slice(int(updates[3]) + 1, j)
    np.testing.assert_array_equal(many[smk.SM_X][inside], before[smk.SM_X][inside])


def test_without_full_the_reported_elements_are_those_of_the_full_pass() -> None:
    """``full=False`` (what the engine runs) smooths all of x and, at the nodes without an
    update, only the elements of P^s the solution reports: those must equal the full pass's,
    the update nodes must be whole, and the rest is the filtered P."""
    from adaptnav.engine.batch import P_CROSS_PAIRS

    nodes = _kalman(0.4)[0]
    N, n = nodes.dx.shape
    has_update = np.any(nodes.dx != 0.0, axis=1)
    full, part = _store(nodes), _store(nodes)
    smk.backward(full, True, 2, 2)
    smk.backward(part, True, 2, 2, full=False)
    np.testing.assert_array_equal(part[smk.SM_X][:N], full[smk.SM_X][:N])
    reported = smk.reported(n)
    assert set(P_CROSS_PAIRS) <= set(reported)
    cols = [smk.packed_index(i, j, n) for i, j in reported]
    others = sorted(set(range(smk.packed_size(n))) - set(cols))
    np.testing.assert_allclose(part[smk.SM_P][:N][:, cols], full[smk.SM_P][:N][:, cols],
                               rtol=1e-13, atol=0.0)  # fmt: skip
    last = int(np.flatnonzero(has_update)[-1])
    inner = ~has_update & (np.arange(N) < last)
    assert inner.sum() >= 5
    np.testing.assert_array_equal(part[smk.SM_P][:N][has_update], full[smk.SM_P][:N][has_update])
    filtered = _store(nodes)[smk.SM_P][:N]
    np.testing.assert_array_equal(part[smk.SM_P][:N][inner][:, others], filtered[inner][:, others])
    assert not np.array_equal(full[smk.SM_P][:N][inner][:, others], filtered[inner][:, others])


@pytest.mark.parametrize(("threads", "chunk"), [(1, 0), (2, 2)])
def test_the_pass_fills_the_output_rows_between_update_nodes_as_gather_would(
    threads: int, chunk: int
) -> None:
    """``backward(..., rows=...)`` (what the engine runs since 0.4.11): the output rows whose
    node lies strictly between two update nodes are written as the pass smooths them, equal to
    what :func:`gather` reads from the smoothed store afterwards, and flagged done; every other
    row (an update node's, those after the last update node, the earlier of two rows on one
    node) is left alone for the caller to gather."""
    nodes = _kalman(0.4)[0]
    N, n = nodes.dx.shape
    idx = np.insert(np.arange(N), 4, 3)  # node 3 has two rows, 3 and 4: the slot is row 4
    slot = np.full(N, -1, dtype=np.int64)
    slot[idx] = np.arange(idx.size)
    columns = np.array([smk.packed_index(i, j, n) for i, j in smk.reported(n)], dtype=np.int64)
    has_update = np.any(nodes.dx != 0.0, axis=1)
    last = int(np.flatnonzero(has_update)[-1])
    between = ~has_update[idx] & (idx > 0) & (idx < last) & (slot[idx] == np.arange(idx.size))
    assert between.sum() >= 5 and not between[3] and between[4]
    sm = _store(nodes)
    X, C = np.full((idx.size, nodes.x.shape[1]), np.nan), np.full((idx.size, columns.size), np.nan)
    done = np.zeros(idx.size, dtype=np.bool_)
    smk.backward(sm, True, threads, chunk, full=False, rows=(slot, columns, X, C, done))
    np.testing.assert_array_equal(done, between)
    gx, gc = smk.gather(sm, idx, columns)
    np.testing.assert_array_equal(X[done], gx[done])
    np.testing.assert_array_equal(C[done], gc[done])
    assert np.all(np.isnan(X[~done])) and np.all(np.isnan(C[~done]))


def test_reset_inverse_undoes_the_reset_jacobian() -> None:
    from adaptnav.models.errorstate import (
        RESET_ATTITUDE,
        RESET_INVARIANT,
        RESET_OFF,
        reset_jacobian,
    )

    dx = np.zeros(17)
    dx[3:9] = (0.05, -0.04, 0.01, 0.03, -0.02, 0.05)
    for mode in (RESET_ATTITUDE, RESET_INVARIANT):
        np.testing.assert_allclose(
            smoother.reset_inverse(dx, 17, mode) @ reset_jacobian(dx, mode), np.eye(17),
            atol=1e-15,
        )  # fmt: skip
    assert not np.array_equal(
        smoother.reset_inverse(dx, 17, RESET_ATTITUDE),
        smoother.reset_inverse(dx, 17, RESET_INVARIANT),
    )
    assert np.array_equal(smoother.reset_inverse(dx, 17, RESET_OFF), np.eye(17))


def test_a_node_whose_prior_is_not_positive_definite_keeps_its_filtered_values(
    linear: tuple[smoother.Nodes, Array, dict[str, Array]],
) -> None:
    nodes, _, _ = linear
    bad = nodes.P_prior.copy()
    j = int(np.flatnonzero(np.any(nodes.dx != 0.0, axis=1))[-1])
    bad[j] = -np.eye(15)
    sm = _store(smoother.Nodes(nodes.t, nodes.x, nodes.dx, nodes.P, bad, nodes.Phi, False))
    smk.backward(sm, False)
    assert sm[smk.SM_COUNT][smk.K_FAILED] == 1
    np.testing.assert_array_equal(sm[smk.SM_X][j - 1], nodes.x[j - 1])


@pytest.mark.parametrize("rates", [(0.0, 0.0), (0.3, 0.05), (1.0, 0.0)])
def test_gauss_markov_declared_states_smooth_exactly(rates: tuple[float, float]) -> None:
    """Two declared states after the core, Gauss-Markov (1/τ > 0) or random walks, coupled to
    the core by the readings only: the readable pass is the exact posterior, and the compiled
    pass, whose store has their Φ from the node times and 1/τ alone, equals it."""
    nodes, means, model = _kalman(0.5, rates)
    x_s, P_s, e_s = smoother.rts(nodes)
    _assert_posterior(means, e_s, P_s, model)
    N = means.shape[0]
    assert np.abs(e_s[:-1, 15:]).max() > 0.0  # the declared states were smoothed too
    sm = _store(nodes, rates)
    np.testing.assert_allclose(sm[smk.SM_PHI][1:N, smk.N_PHI :], np.exp(-np.array(rates))[None]
                               .repeat(N - 1, 0), rtol=1e-15)  # fmt: skip
    smk.backward(sm, False, 2, 3)
    _assert_store(sm, x_s, P_s)
