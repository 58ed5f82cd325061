"""Compiled RTS smoothing: the forward pass's node store and the backward pass.

The equations: docs/smoothing.md; readable twin :mod:`adaptnav.estimation.smoother`, which
``tests/kernels/test_smoother.py`` holds this module equal to.

The forward pass (:mod:`adaptnav.engine.batch`) keeps a :data:`Store` when smoothing is on:
per *node* (each output row and each measurement epoch) its time, the nominal state after the
node, the fed-back correction dx, P after the node and, for an update, P before it (both packed,
upper triangle by rows: :func:`pack`), and the core transition Φ from the previous node. Φ is
accumulated step by step (:func:`accumulate`, ``Φ_acc ← Φ_step Φ_acc``); declared state blocks
are random walks uncoupled in Φ (errorstate.StateLayout), so their part of Φ is the identity
and is not stored. The store is sized by the engine before each IMU chunk (at most one node per
output row and per queued reading), so these kernels never grow it.

Memory per node: (1 + 16 + m) + n + n(n+1)/2 + 141 float64 and two int64 (n = 15 + m error
states, m declared; Φ's rows 9-14 are diagonal and only their diagonal is kept), 2.4 KB for the
core, plus n(n+1)/2 float64 (0.94 KB) per update node.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptnav.compiled.propagation import _W, jit, jit_inline
from adaptnav.compiled.update import _cho_solve, _cholesky, inject

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]
CORE = 15

Store = tuple[NDArray[Any], ...]
"""``(t (N,), x (N, 16 + m), dx (N, n), P (N, n(n+1)/2), Phi (N, N_PHI), prior (N,) int64,
P_prior (M, n(n+1)/2), acc (24, 16): Φ_acc (rows 0-14, columns 0-14) and scratch,
counters (N_COUNT,) int64,
out (N,) int64: the node of each output row)``."""
SM_T, SM_X, SM_DX, SM_P, SM_PHI, SM_PRIOR, SM_PM, SM_ACC, SM_COUNT, SM_OUT = range(10)
PHI_DIAG = 9 * CORE
"""A stored Φ: its rows 0-8 (row-major, 135 numbers), then the diagonal of rows 9-14, the
whole of those rows (the biases' Gauss-Markov dynamics: :func:`accumulate`)."""
N_PHI = PHI_DIAG + 6
K_NODES, K_PRIORS, K_STEPS, K_ON, K_FAILED = range(5)
"""Counters: nodes and update nodes stored, steps accumulated into Φ since the last node,
smoothing on (1) or off (0), nodes where the backward gain could not be formed."""
N_COUNT = 5
NODE_ARRAYS = (SM_T, SM_X, SM_DX, SM_P, SM_PHI, SM_PRIOR, SM_OUT)
"""The store's arrays with a row per node (:data:`SM_PM` has one per update node)."""


def packed_size(n: int) -> int:
    """Length of a packed symmetric n×n matrix."""
    return n * (n + 1) // 2


def packed_index(i: int, j: int, n: int) -> int:
    """Where :func:`pack` puts ``P[i, j]`` (i ≤ j) of an n×n matrix."""
    return i * n - i * (i - 1) // 2 + (j - i)


def store(capacity: int, n_priors: int, nominal_size: int, n: int, on: bool) -> Store:
    """An empty store for ``capacity`` nodes and ``n_priors`` update nodes; ``on = False``: a
    store of size zero that the kernels leave alone (the forward pass as without smoothing)."""
    c, m = (capacity, n_priors) if on else (0, 0)
    k = packed_size(n)
    counts = np.zeros(N_COUNT, dtype=np.int64)
    counts[K_ON] = int(on)
    return (
        np.zeros(c), np.zeros((c, nominal_size)), np.zeros((c, n)), np.zeros((c, k)),
        np.zeros((c, N_PHI)), np.full(c, -1, dtype=np.int64), np.zeros((m, k)),
        np.eye(CORE + 9, _W), counts, np.zeros(c, dtype=np.int64),
    )  # fmt: skip


def grown(sm: Store, nodes: int, priors: int) -> Store:
    """``sm`` with room for at least ``nodes`` nodes and ``priors`` update nodes (doubling),
    what it holds kept; a store that is off stays as it is."""
    if sm[SM_COUNT][K_ON] == 0:
        return sm
    out = list(sm)
    for key, need in (
        (SM_T, nodes),
        (SM_X, nodes),
        (SM_DX, nodes),
        (SM_P, nodes),
        (SM_PHI, nodes),
        (SM_PRIOR, nodes),
        (SM_OUT, nodes),
        (SM_PM, priors),
    ):
        a = sm[key]
        if need > a.shape[0]:
            b = np.zeros((max(need, 2 * a.shape[0]), *a.shape[1:]), dtype=a.dtype)
            b[: a.shape[0]] = a
            out[key] = b
    return tuple(out)


@jit_inline
def pack(P: Array, out: Array) -> None:
    """The upper triangle of P (n×n) by rows into ``out`` (n(n+1)/2)."""
    n = P.shape[0]
    k = 0
    for i in range(n):
        for j in range(i, n):
            out[k] = P[i, j]
            k += 1


@jit_inline
def unpack(packed: Array, out: Array) -> None:
    """The symmetric n×n matrix of :func:`pack`'s ``packed`` into ``out``."""
    n = out.shape[0]
    k = 0
    for i in range(n):
        for j in range(i, n):
            out[i, j] = packed[k]
            out[j, i] = packed[k]
            k += 1


@jit
def accumulate(sm: Store, PhiT: Array) -> None:
    """``Φ_acc ← Φ Φ_acc`` for one propagation step's Φ (given as the flat ``Φᵀ`` of the
    propagation kernels, row stride 16); counts the step. Rows 9-14 of Φ are diagonal (the
    biases' Gauss-Markov dynamics), rows 0-8 full, and so are Φ_acc's: only its rows 0-8 are
    products, in which a row 9-14 of Φ_acc adds one element. The first step after a node takes
    the step's Φ as it is (Φ_acc is the identity then: it is not reset at the node). The caller
    calls it only when smoothing."""
    acc = sm[SM_ACC]
    counts = sm[SM_COUNT]
    if counts[K_STEPS] == 0:
        for i in range(9):
            for j in range(CORE):
                acc[i, j] = PhiT[j * _W + i]
        for i in range(9, CORE):
            acc[i, i] = PhiT[i * _W + i]
        counts[K_STEPS] = 1
        return
    # Rows padded to 16 (a zero column) with the width known only at run time: LLVM then
    # vectorizes the row updates instead of unrolling them (as compiled.propagation does).
    nw = acc.shape[1]
    for i in range(9):
        r = CORE + i
        for j in range(nw):
            acc[r, j] = 0.0
        for k in range(9):
            a = PhiT[k * _W + i]
            for j in range(nw):
                acc[r, j] += a * acc[k, j]
        for k in range(9, CORE):
            acc[r, k] += PhiT[k * _W + i] * acc[k, k]
    for i in range(9, CORE):
        acc[i, i] *= PhiT[i * _W + i]
    for i in range(9):
        for j in range(nw):
            acc[i, j] = acc[CORE + i, j]
    counts[K_STEPS] += 1


@jit
def node(sm: Store, t: float, x: Array, P: Array, dx: Array, prior: Array) -> int:
    """Store a node at t: x and P after it, and when ``prior`` holds the P an update started
    from (``prior[0, 0]`` not NaN), dx and that P (else dx is zero and may be empty); Φ_acc
    becomes the node's Φ (the identity if no step was accumulated since the last node). Returns
    the node's index."""
    counts = sm[SM_COUNT]
    j = int(counts[K_NODES])
    sm[SM_T][j] = t
    for i in range(x.shape[0]):
        sm[SM_X][j, i] = x[i]
    pack(P, sm[SM_P][j])
    acc = sm[SM_ACC]
    phi = sm[SM_PHI][j]
    steps = counts[K_STEPS] > 0  # else nothing was propagated since the last node: Φ = I
    for i in range(9):
        for c in range(CORE):
            phi[i * CORE + c] = acc[i, c] if steps else (1.0 if i == c else 0.0)
    for a in range(6):
        phi[PHI_DIAG + a] = acc[9 + a, 9 + a] if steps else 1.0
    updated = prior.shape[0] > 0 and not math.isnan(prior[0, 0])
    for i in range(sm[SM_DX].shape[1]):
        sm[SM_DX][j, i] = dx[i] if updated else 0.0
    if updated:
        m = counts[K_PRIORS]
        pack(prior, sm[SM_PM][m])
        sm[SM_PRIOR][j] = m
        counts[K_PRIORS] = m + 1
    else:
        sm[SM_PRIOR][j] = -1
    counts[K_NODES] = j + 1
    counts[K_STEPS] = 0
    return j


@jit
def output_node(sm: Store, o: int, t: float, x: Array, P: Array) -> None:
    """Output row o's node: the last node if nothing was propagated since it (an update at the
    row's time), else a new node at t with x and P."""
    counts = sm[SM_COUNT]
    if counts[K_STEPS] == 0 and counts[K_NODES] > 0:
        sm[SM_OUT][o] = counts[K_NODES] - 1
    else:
        sm[SM_OUT][o] = node(sm, t, x, P, np.empty(0), np.empty((0, 0)))


@jit_inline
def _reset_inverse(dx: Array, reset: bool) -> tuple[float, ...]:
    """``G⁻¹`` of the attitude block (row-major 3×3), twin of smoother.reset_inverse."""
    if not reset:
        return (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    h0, h1, h2 = 0.5 * dx[6], 0.5 * dx[7], 0.5 * dx[8]
    s = 1.0 / (1.0 + h0 * h0 + h1 * h1 + h2 * h2)
    return (
        (1.0 + h0 * h0) * s, (h2 + h0 * h1) * s, (-h1 + h0 * h2) * s,
        (-h2 + h1 * h0) * s, (1.0 + h1 * h1) * s, (h0 + h1 * h2) * s,
        (h1 + h2 * h0) * s, (-h0 + h2 * h1) * s, (1.0 + h2 * h2) * s,
    )  # fmt: skip


@jit_inline
def _to_prior_coordinates(Gi: tuple[float, ...], e: Array, P: Array, rows: Array) -> None:
    """``e ← G⁻¹ e``, ``P ← G⁻¹ P G⁻ᵀ`` in place, G⁻¹ acting on the attitude block (6-8)."""
    n = P.shape[0]
    e6, e7, e8 = e[6], e[7], e[8]
    for a in range(3):
        e[6 + a] = Gi[3 * a] * e6 + Gi[3 * a + 1] * e7 + Gi[3 * a + 2] * e8
    for a in range(3):
        for j in range(n):
            rows[a, j] = Gi[3 * a] * P[6, j] + Gi[3 * a + 1] * P[7, j] + Gi[3 * a + 2] * P[8, j]
    for a in range(3):
        for j in range(n):
            P[6 + a, j] = rows[a, j]
    for i in range(n):
        p6, p7, p8 = P[i, 6], P[i, 7], P[i, 8]
        for a in range(3):
            P[i, 6 + a] = Gi[3 * a] * p6 + Gi[3 * a + 1] * p7 + Gi[3 * a + 2] * p8


@jit_inline
def _gain_transpose(Pm: Array, B: Array, L: Array, d: Array) -> bool:
    """``B ← (P⁻)⁻¹ B`` (= C_jᵀ for B = Φ P_j) by the Cholesky factor of ``D P⁻ D``,
    ``D = diag(P⁻)^(-1/2)`` (Pm overwritten by the scaled matrix); False if P⁻ is not positive
    definite."""
    n = Pm.shape[0]
    for i in range(n):
        if not Pm[i, i] > 0.0:
            return False
        d[i] = 1.0 / math.sqrt(Pm[i, i])
    for i in range(n):
        for j in range(n):
            Pm[i, j] *= d[i] * d[j]
            B[i, j] *= d[i]
    if not _cholesky(Pm, n, L):
        return False
    _cho_solve(L, n, B, B, n)
    for i in range(n):
        for j in range(n):
            B[i, j] *= d[i]
    return True


@jit
def backward(sm: Store, reset: bool) -> None:
    """The RTS backward pass over the stored nodes, in place: each node's x becomes ``x^s``
    and its packed P becomes ``P^s`` (docs/smoothing.md). A node whose P⁻ is not positive
    definite keeps its filtered values and is counted (``K_FAILED``)."""
    counts = sm[SM_COUNT]
    N = counts[K_NODES]
    if N == 0:
        return
    n = sm[SM_DX].shape[1]
    e_s, e_prior, d = np.zeros(n), np.zeros(n), np.zeros(n)
    Ps, Pj, Pm, B = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    L, T, rows, Pf = np.zeros((n, n)), np.zeros((n, n)), np.zeros((3, n)), np.zeros((n, n))
    unpack(sm[SM_P][N - 1], Ps)
    Pf[:, :] = Ps  # the filtered P of node k (the store's slot holds P^s once k is done)
    counts[K_FAILED] = 0
    for j in range(N - 2, -1, -1):
        k = j + 1
        dx = sm[SM_DX][k]
        pi = sm[SM_PRIOR][k]
        if pi >= 0:  # back to the coordinates before node k's feedback
            _to_prior_coordinates(_reset_inverse(dx, reset), e_s, Ps, rows)
            for i in range(n):
                e_prior[i] = dx[i] + e_s[i]
            unpack(sm[SM_PM][pi], Pm)
        else:
            for i in range(n):
                e_prior[i] = e_s[i]
            Pm[:, :] = Pf
        for i in range(n):  # Ps ← P⁻s - P⁻, before Pm is scaled
            for c in range(n):
                Ps[i, c] -= Pm[i, c]
        unpack(sm[SM_P][j], Pj)
        Pf[:, :] = Pj
        phi = sm[SM_PHI][k]
        for i in range(n):  # B = Φ P_j (Φ = I on declared blocks); inner loops along rows
            for c in range(n):
                B[i, c] = 0.0 if i < CORE else Pj[i, c]
            if i < 9:
                for m in range(CORE):
                    a = phi[i * CORE + m]
                    if a != 0.0:
                        for c in range(n):
                            B[i, c] += a * Pj[m, c]
            elif i < CORE:
                a = phi[PHI_DIAG + i - 9]
                for c in range(n):
                    B[i, c] = a * Pj[i, c]
        if not _gain_transpose(Pm, B, L, d):
            counts[K_FAILED] += 1
            for i in range(n):
                e_s[i] = 0.0
            Ps[:, :] = Pj
            continue
        for i in range(n):  # e^s_j = C e⁻ = Bᵀ e⁻
            s = 0.0
            for m in range(n):
                s += B[m, i] * e_prior[m]
            e_s[i] = s
        for i in range(n):  # T = (P⁻s - P⁻) X
            for c in range(n):
                T[i, c] = 0.0
            for m in range(n):
                a = Ps[i, m]
                for c in range(n):
                    T[i, c] += a * B[m, c]
        for i in range(n):  # P^s_j = P_j + Xᵀ T, upper triangle, then mirrored
            for c in range(i, n):
                Ps[i, c] = Pj[i, c]
        for m in range(n):
            for i in range(n):
                a = B[m, i]
                for c in range(i, n):
                    Ps[i, c] += a * T[m, c]
        for i in range(n):
            for c in range(i):
                Ps[i, c] = Ps[c, i]
        pack(Ps, sm[SM_P][j])
        inject(sm[SM_X][j], e_s)
