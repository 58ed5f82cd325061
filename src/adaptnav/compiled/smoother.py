"""Compiled RTS smoothing: the forward pass's node store and the backward pass.

The equations: docs/smoothing.md; readable twin :mod:`adaptnav.estimation.smoother`, which
``tests/kernels/test_smoother.py`` holds this module equal to.

The forward pass (:mod:`adaptnav.engine.batch`) keeps a :data:`Store` when smoothing is on:
per *node* (each output row and each measurement epoch) its time, the nominal state after the
node, P after the node (at an update node the P the update left, before the windowed NIS test
could inflate it: update.node_P) and the core transition Φ from the previous node, and for an
update node the fed-back correction dx and P before the update (P packed, upper triangle by
rows: :func:`pack`). Φ is accumulated step by step (:func:`accumulate`,
``Φ_acc ← Φ_step Φ_acc``); declared states are
uncoupled in Φ (errorstate.StateLayout), each a random walk or a Gauss-Markov process, so their
part of Φ is diagonal: ``exp(-Δt/τ)`` over the Δt since the node before, from the node times and
the store's 1/τ (1 for a random walk). The store is sized by the engine before each IMU chunk
(at most one node per output row and per queued reading), so these kernels never grow it.

Memory per node: (1 + 16 + m) + n(n+1)/2 + 141 + m float64 and two int64 (n = 15 + m error
states, m declared; Φ's rows 9-14 are diagonal and only their diagonal is kept), 2.2 KB for the
core, plus n + n(n+1)/2 float64 (1.1 KB) per update node.

The backward pass (:func:`backward`) goes from update node to update node: a node between two
of them is corrected only by what the later one brings, through one gain over the interval
(docs/smoothing.md, 'The backward pass'). The transitions over each interval
(:func:`transitions`) depend on the forward pass only and are formed first, in threads; the
chain of update nodes (:func:`anchors`) is sequential; the nodes between them
(:func:`interiors`) are smoothed in threads as the chain passes them, from the factors the
chain formed (since 0.4.11; up to 0.4.10 the chain formed the transitions as it went, kept n
float64 per update node, and the interiors formed each factor again). While it runs the pass
keeps those factors in at most ``threads + 1`` buffers of :data:`CHUNK` update nodes, 6 KB
per update node (1.5 MB per buffer for the 15 core states).
"""

from __future__ import annotations

import math
import queue
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptnav.compiled.propagation import _W, jit, jit_inline, jit_nogil
from adaptnav.compiled.update import _cho_solve, _cholesky, inject, reset_velocity
from adaptnav.models.errorstate import RESET_INVARIANT, RESET_OFF

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]
CORE = 15

Store = tuple[NDArray[Any], ...]
"""``(t (N,), x (N, 16 + m), dx (M, n), P (N, n(n+1)/2), Phi (N, N_PHI + m), prior (N,)
int64: the node's row in dx and P_prior (-1: no update), P_prior (M, n(n+1)/2), acc (24, 16):
Φ_acc (rows 0-14, columns 0-14) and scratch, counters (N_COUNT,) int64, out (N,) int64: the
node of each output row, inv_tau (m,): the declared states' 1/τ)``; N nodes, M of them with an
update, m declared states."""
SM_T, SM_X, SM_DX, SM_P, SM_PHI, SM_PRIOR, SM_PM, SM_ACC, SM_COUNT, SM_OUT, SM_TAU = range(11)
PHI_DIAG = 9 * CORE
"""A stored Φ: its rows 0-8 (row-major, 135 numbers), then the diagonal of rows 9-14, the
whole of those rows (the biases' Gauss-Markov dynamics: :func:`accumulate`), then the
diagonal of the m declared states' rows (from :data:`N_PHI` on)."""
N_PHI = PHI_DIAG + 6
K_NODES, K_PRIORS, K_STEPS, K_FAILED = range(4)
"""Counters: nodes and update nodes stored, steps accumulated into Φ since the last node,
update nodes whose P⁻ could not be factored (no backward gain to them)."""
N_COUNT = 4
NODE_ARRAYS = (SM_T, SM_X, SM_P, SM_PHI, SM_PRIOR, SM_OUT)
"""The store's arrays with a row per node."""
UPDATE_ARRAYS = (SM_DX, SM_PM)
"""The store's arrays with a row per update node."""
Rows = tuple[IntArray, IntArray, Array, Array, NDArray[np.bool_]]
"""Where :func:`backward` writes the output rows it smooths between update nodes: ``(slot
(N,): each node's output row or -1, columns: packed P elements (:func:`packed_index`), X (R,
16 + m), C (R, len(columns)), done (R,))``, :func:`gather`'s ``X`` and ``C`` filled as the pass
goes and ``done`` set for the rows filled."""
_NO_DX, _NO_PRIOR = np.empty(0), np.empty((0, 0))
""":func:`node`'s arguments for a node without an update (constants: no allocation per row)."""


def packed_size(n: int) -> int:
    """Length of a packed symmetric n×n matrix."""
    return n * (n + 1) // 2


@jit_inline
def packed_index(i: int, j: int, n: int) -> int:
    """Where :func:`pack` puts ``P[i, j]`` (i ≤ j) of an n×n matrix (compiled, and callable
    from Python)."""
    return i * n - i * (i - 1) // 2 + (j - i)


def store(c: int, m: int, nominal_size: int, n: int, inv_tau: Array | None = None) -> Store:
    """An empty store for ``c`` nodes and ``m`` update nodes, n error states, the declared ones'
    1/τ ``inv_tau`` (n - 15; None: random walks). A run without smoothing has none (None): the
    engine's loop is then compiled without the smoother's code (adaptnav.engine.batch,
    '_navigate')."""
    k = packed_size(n)
    counts = np.zeros(N_COUNT, dtype=np.int64)
    rates = np.zeros(n - CORE) if inv_tau is None else np.array(inv_tau, dtype=float)
    if rates.shape != (n - CORE,):
        raise ValueError(f"inv_tau: {n - CORE} rates expected, got {rates.shape}")
    return (
        np.zeros(c), np.zeros((c, nominal_size)), np.zeros((m, n)), np.zeros((c, k)),
        np.zeros((c, N_PHI + n - CORE)), np.full(c, -1, dtype=np.int64), np.zeros((m, k)),
        np.eye(CORE + 9, _W), counts, np.zeros(c, dtype=np.int64), rates,
    )  # fmt: skip


def grown(sm: Store, nodes: int, priors: int) -> Store:
    """``sm`` with room for at least ``nodes`` nodes and ``priors`` update nodes (doubling),
    what it holds kept."""
    out = list(sm)
    for key, need in (
        (SM_T, nodes),
        (SM_X, nodes),
        (SM_DX, priors),
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
def unpack(packed: Array, out: Array, n: int) -> None:
    """The symmetric n×n matrix of :func:`pack`'s ``packed`` into ``out[:n, :n]``."""
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
            if a != 0.0:  # e.g. Φ's column 1 (east position error) beside its diagonal
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
    from (``prior[0, 0]`` not NaN), dx and that P (else dx may be empty); Φ_acc
    becomes the node's Φ (the identity if no step was accumulated since the last node), the
    declared states' part ``exp(-(t - t_prev)/τ)`` (module docstring). Returns the node's
    index."""
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
    rates = sm[SM_TAU]
    if rates.shape[0] > 0:
        span = t - sm[SM_T][j - 1] if steps and j > 0 else 0.0
        for a in range(rates.shape[0]):
            phi[N_PHI + a] = math.exp(-span * rates[a]) if rates[a] > 0.0 else 1.0
    if prior.shape[0] > 0 and not math.isnan(prior[0, 0]):
        m = counts[K_PRIORS]
        pack(prior, sm[SM_PM][m])
        for i in range(sm[SM_DX].shape[1]):
            sm[SM_DX][m, i] = dx[i]
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
        sm[SM_OUT][o] = node(sm, t, x, P, _NO_DX, _NO_PRIOR)


@jit
def gather(sm: Store, rows: IntArray, columns: IntArray) -> tuple[Array, Array]:
    """The stored x of the nodes ``rows`` (len(rows), 16 + m) and their packed P's elements
    ``columns`` (:func:`packed_index`; len(rows), len(columns)), in one pass over the rows."""
    X = np.empty((rows.shape[0], sm[SM_X].shape[1]))
    C = np.empty((rows.shape[0], columns.shape[0]))
    for i in range(rows.shape[0]):
        x, p = sm[SM_X][rows[i]], sm[SM_P][rows[i]]
        for c in range(X.shape[1]):
            X[i, c] = x[c]
        for c in range(columns.shape[0]):
            C[i, c] = p[columns[c]]
    return X, C


@jit_inline
def _reset_inverse(dx: Array, reset: int) -> tuple[float, ...]:
    """``G⁻¹`` of the attitude block (row-major 3×3), twin of smoother.reset_inverse."""
    if reset == RESET_OFF:
        return (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    h0, h1, h2 = 0.5 * dx[6], 0.5 * dx[7], 0.5 * dx[8]
    s = 1.0 / (1.0 + h0 * h0 + h1 * h1 + h2 * h2)
    return (
        (1.0 + h0 * h0) * s, (h2 + h0 * h1) * s, (-h1 + h0 * h2) * s,
        (-h2 + h1 * h0) * s, (1.0 + h1 * h1) * s, (h0 + h1 * h2) * s,
        (h1 + h2 * h0) * s, (-h0 + h2 * h1) * s, (1.0 + h2 * h2) * s,
    )  # fmt: skip


@jit_inline
def _to_prior_coordinates(dx: Array, reset: int, e: Array, P: Array, rows: Array) -> None:
    """``e ← G⁻¹ e``, ``P ← G⁻¹ P G⁻ᵀ`` in place for the reset ``G`` of ``reset``
    (errorstate.RESET_*): ``G⁻¹ = J(-dv̂) diag(I, A⁻¹)`` with A the attitude block and
    J(d) = I except ``-[d×]`` in the velocity-attitude block (update.reset_velocity)."""
    Gi = _reset_inverse(dx, reset)
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
    if reset == RESET_INVARIANT:
        d0, d1, d2 = dx[3], dx[4], dx[5]
        e6, e7, e8 = e[6], e[7], e[8]
        e[3] += d1 * e8 - d2 * e7  # e_v += [dv̂×] e_att
        e[4] += d2 * e6 - d0 * e8
        e[5] += d0 * e7 - d1 * e6
        reset_velocity(P, -d0, -d1, -d2, rows)


@jit_inline
def _product(X: Array, Y: Array, out: Array, acc: Array, n: int, xt: bool) -> None:
    """``out = X Y`` (``Xᵀ Y`` when ``xt``) of W×W matrices that are zero from row and column
    n on (W = out.shape[1], a multiple of 4; out is neither X nor Y). Four rows of out at a time
    in ``acc`` (4, W): four independent chains of row updates, which LLVM vectorizes."""
    W = out.shape[1]
    for i in range(0, W, 4):
        for q in range(4):
            for c in range(W):
                acc[q, c] = 0.0
        for m in range(n):
            if xt:
                a0, a1, a2, a3 = X[m, i], X[m, i + 1], X[m, i + 2], X[m, i + 3]
            else:
                a0, a1, a2, a3 = X[i, m], X[i + 1, m], X[i + 2, m], X[i + 3, m]
            for c in range(W):
                y = Y[m, c]
                acc[0, c] += a0 * y
                acc[1, c] += a1 * y
                acc[2, c] += a2 * y
                acc[3, c] += a3 * y
        for q in range(4):
            for c in range(W):
                out[i + q, c] = acc[q, c]


@jit_inline
def _psi_product(psi: Array, P: Array, A: Array, acc: Array, n: int) -> None:
    """``A = Ψ P`` for a stored-layout Ψ (:data:`PHI_DIAG`; diagonal on the declared states,
    from :data:`N_PHI` on) and P as in :func:`_product`; rows 0-8 three at a time in ``acc``."""
    W = A.shape[1]
    for i in range(0, 9, 3):
        for q in range(3):
            for c in range(W):
                acc[q, c] = 0.0
        for m in range(CORE):
            a0, a1, a2 = psi[i * CORE + m], psi[(i + 1) * CORE + m], psi[(i + 2) * CORE + m]
            for c in range(W):
                y = P[m, c]
                acc[0, c] += a0 * y
                acc[1, c] += a1 * y
                acc[2, c] += a2 * y
        for q in range(3):
            for c in range(W):
                A[i + q, c] = acc[q, c]
    for i in range(9, CORE):
        a = psi[PHI_DIAG + i - 9]
        for c in range(W):
            A[i, c] = a * P[i, c]
    for i in range(CORE, n):
        a = psi[N_PHI + i - CORE]
        for c in range(W):
            A[i, c] = a * P[i, c]


@jit_inline
def _psi_times(psi: Array, phi: Array, acc: Array) -> None:
    """``Ψ ← Ψ Φ``, both in the stored layout (rows 9-14 and the declared states' diagonal, and
    so are the product's)."""
    for i in range(9):
        for c in range(CORE):
            acc[0, c] = 0.0
        for m in range(9):
            a = psi[i * CORE + m]
            for c in range(CORE):
                acc[0, c] += a * phi[m * CORE + c]
        for c in range(9, CORE):
            acc[0, c] += psi[i * CORE + c] * phi[PHI_DIAG + c - 9]
        for c in range(CORE):
            psi[i * CORE + c] = acc[0, c]
    for a in range(6):
        psi[PHI_DIAG + a] *= phi[PHI_DIAG + a]
    for a in range(N_PHI, psi.shape[0]):
        psi[a] *= phi[a]


@jit
def _factor(
    sm: Store, b: int, reset: int, e: Array, Ps: Array, Pm: Array, L: Array, D: Array, T: Array
) -> bool:
    """At update node b, from its smoothed error ``e`` and covariance ``Ps`` (taken in place to
    the coordinates before its feedback, equation (1)): with ``Δ = diag(P⁻)^(-1/2)``, the
    Cholesky factor L of ``Δ P⁻ Δ`` (its condition is ~1e2 where P⁻'s is ~1e20),
    ``D = Δ (P⁻s - P⁻) Δ``, Δ's diagonal into ``T[3]`` and ``Δ e⁻`` (``e⁻ = dx + e``) into
    ``T[4]``. False if P⁻ is not positive definite. All (W, W), zero from row and column n on;
    ``Pm`` and ``T[:3]``: scratch."""
    n = e.shape[0]
    r = sm[SM_PRIOR][b]
    dx = sm[SM_DX][r]
    _to_prior_coordinates(dx, reset, e, Ps, T[:3])
    unpack(sm[SM_PM][r], Pm, n)
    d, f = T[3], T[4]
    for i in range(n):
        if not Pm[i, i] > 0.0:
            return False
        d[i] = 1.0 / math.sqrt(Pm[i, i])
        f[i] = d[i] * (dx[i] + e[i])
    for i in range(n):
        for c in range(n):
            D[i, c] = (Ps[i, c] - Pm[i, c]) * (d[i] * d[c])
            Pm[i, c] *= d[i] * d[c]
    return _cholesky(Pm, n, L)


@jit_inline
def _finish(
    out: Array, Pj: Array, A: Array, B: Array, M: Array, acc: Array, n: int, full: bool
) -> None:
    """``P_j + Aᵀ B`` into the packed ``out``: all of it when ``full``, else only the elements
    :func:`reported` (one column dot product each instead of a matrix product; the rest of
    ``out`` is left as it is). ``M`` (W, W), ``acc`` (≥ 4, W): scratch."""
    W = A.shape[1]
    if full:
        _product(A, B, M, acc, n, True)
        k = 0
        for i in range(n):
            for c in range(i, n):
                out[k] = Pj[i, c] + M[i, c]
                k += 1
        return
    for c in range(W):
        acc[0, c] = 0.0
    for m in range(n):
        for c in range(W):
            acc[0, c] += A[m, c] * B[m, c]
    for i in range(n):
        out[packed_index(i, i, n)] = Pj[i, i] + acc[0, i]
    for base in range(0, 9, 3):
        for p in range(3):
            for q in range(p + 1, 3):
                i, c = base + p, base + q
                t = 0.0
                for m in range(n):
                    t += A[m, i] * B[m, c]
                out[packed_index(i, c, n)] = Pj[i, c] + t


@jit
def _smooth_from(
    sm: Store,
    j: int,
    psi: Array,
    L: Array,
    D: Array,
    d: Array,
    f: Array,
    e: Array,
    scratch: Array,
    full: bool,
) -> None:
    """Node j from the update node b after it, given b's :func:`_factor` (L, ``D = Δ (P⁻s -
    P⁻) Δ``, Δ's diagonal d, ``f = Δ e⁻``): with ``A = Ψ P_j``, ``Ψ = Φ(b, j)`` and
    ``Y = (Δ P⁻ Δ)⁻¹ Δ A`` (two triangular solves), ``e^s_j = Yᵀ f`` into ``e`` and x_j, and
    ``P^s_j = P_j + Yᵀ D Y`` into the store's P (all of it or the elements :func:`reported`,
    :func:`_finish`): equation (6) of docs/smoothing.md, ``Aᵀ v`` and ``P_j + Aᵀ U A``, without
    forming ``U``. ``scratch`` (5, W, W): zero from row and column n on."""
    n = e.shape[0]
    W = scratch.shape[1]
    Pj, A, Y, acc = scratch[0], scratch[1], scratch[2], scratch[4]
    unpack(sm[SM_P][j], Pj, n)
    _psi_product(psi, Pj, A, acc, n)
    for i in range(n):
        for c in range(W):
            Y[i, c] = d[i] * A[i, c]
    _cho_solve(L, n, Y, Y, W)
    for c in range(W):
        acc[0, c] = 0.0
    for m in range(n):
        a = f[m]
        for c in range(W):
            acc[0, c] += a * Y[m, c]
    for i in range(n):
        e[i] = acc[0, i]
    _product(D, Y, A, acc, n, False)
    _finish(sm[SM_P][j], Pj, Y, A, scratch[3], acc, n, full)
    inject(sm[SM_X][j], e)


def reported(n: int) -> list[tuple[int, int]]:
    """The elements ``(i, j)``, i ≤ j, of an n×n ``P^s`` that a backward pass with
    ``full=False`` smooths at the nodes that are not update nodes: the diagonal and the 3×3
    blocks of rows and columns 0-2, 3-5 and 6-8, what the smoothed solution reports (σ of
    every state and the correlations within position, velocity and attitude;
    adaptnav.engine.batch.P_CROSS_PAIRS)."""
    return sorted({(i, i) for i in range(n)} | {
        (b + p, b + q) for b in (0, 3, 6) for p in range(3) for q in range(p + 1, 3)
    })  # fmt: skip


def backward(
    sm: Store,
    reset: int,
    threads: int = 1,
    chunk: int = 0,
    full: bool = True,
    rows: Rows | None = None,
) -> None:
    """The RTS backward pass over the stored nodes, in place: each node's x becomes ``x^s``
    and its packed P becomes ``P^s`` (docs/smoothing.md, 'The backward pass').

    From update node to update node. At update node b, with ``v = (P⁻)⁻¹ e⁻`` and
    ``U = (P⁻)⁻¹ (P⁻s - P⁻) (P⁻)⁻¹`` (applied through b's :func:`_factor`); every node j
    from the update node a before b up to b - 1 then has ``e^s_j = Aᵀ v`` and
    ``P^s_j = P_j + Aᵀ U A``, ``A = Φ(b, j) P_j``, ``Φ(b, j) = Φ_b ⋯ Φ_{j+1}`` (built from b
    backwards): the node-by-node recursion (1)-(5) with its gains multiplied out, as the nodes
    between a and b have no update (``P⁻ = P``, dx = 0 there). The nodes from the last update
    node on keep their filtered values: nothing after them observes anything. When update node
    b's P⁻ is not positive definite, the nodes a..b-1 keep their filtered values and b is
    counted (``K_FAILED``). Without ``full``, the nodes that are not update nodes get only the
    elements :func:`reported` of ``P^s`` (one matrix product fewer per node); the update nodes
    always get all of it, as the pass goes on from them.

    The chain of update nodes is sequential (each anchor starts from the smoothed update node
    after it): :func:`anchors` goes along it in runs of ``chunk`` update nodes (0:
    :data:`CHUNK`), leaving each b's factor in a buffer of the run. The nodes strictly between
    two update nodes need only that factor, so :func:`interiors` smooths a run's intervals from
    its buffer as soon as its anchors are done, in ``threads`` threads (this one included; the
    kernels release the GIL). The result does not depend on ``threads``: every node is computed
    by the same arithmetic. ``rows``: the output rows to fill with the nodes between update
    nodes as they are smoothed (:data:`Rows`; the caller gathers the rest), instead of reading
    them back from the store afterwards, scattered over it."""
    counts = sm[SM_COUNT]
    counts[K_FAILED] = 0
    ups = np.flatnonzero(sm[SM_PRIOR][: counts[K_NODES]] >= 0).astype(np.int64)
    if ups.size == 0:
        return
    n = sm[SM_DX].shape[1]
    W = (n + 3) // 4 * 4
    e = np.zeros(n)
    out = rows if rows is not None else _NO_ROWS
    step = chunk if chunk > 0 else CHUNK
    runs = [(max(hi - step, 0), hi) for hi in range(int(ups.size), 0, -step)]
    if threads <= 1:
        factors = np.zeros((step, 3, W, W))
        for lo, hi in runs:
            transitions(sm, ups, lo, hi)
            anchors(sm, reset, ups, lo, hi, e, factors)
            interiors(sm, ups, lo, hi, factors, full, *out)
        return
    _in_threads(sm, reset, ups, runs, threads, full, out)


_NO_ROWS: Rows = (
    np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 0)), np.empty((0, 0)),
    np.empty(0, np.bool_),
)  # fmt: skip
""":data:`Rows` for a pass that fills none."""


def _in_threads(
    sm: Store,
    reset: int,
    ups: IntArray,
    runs: list[tuple[int, int]],
    threads: int,
    full: bool,
    out: Rows,
) -> None:
    """:func:`backward`'s runs in ``threads`` threads: first the transitions of every interval
    (:func:`transitions`, the update nodes shared out between the threads), then the chain on
    this thread and the intervals on the others (and on this one once the chain is done); a
    run's factors live in one of ``threads + 1`` buffers, taken by the chain and given back by
    whoever smoothed the run's intervals, so at most that many runs wait between the two
    parts."""
    n = sm[SM_DX].shape[1]
    W = (n + 3) // 4 * 4
    e = np.zeros(n)
    free: queue.SimpleQueue[Array] = queue.SimpleQueue()
    for _ in range(threads + 1):
        free.put(np.zeros((runs[0][1] - runs[0][0], 3, W, W)))
    ready: queue.SimpleQueue[tuple[int, int, Array] | None] = queue.SimpleQueue()

    def drain() -> None:
        while (run := ready.get()) is not None:
            lo, hi, factors = run
            interiors(sm, ups, lo, hi, factors, full, *out)
            free.put(factors)

    with ThreadPoolExecutor(threads - 1) as pool:
        cuts = np.linspace(0, ups.size, threads + 1).astype(np.int64)
        shares = [
            pool.submit(transitions, sm, ups, cuts[i], cuts[i + 1]) for i in range(1, threads)
        ]
        transitions(sm, ups, cuts[0], cuts[1])
        for f in shares:
            f.result()
        helpers = [pool.submit(drain) for _ in range(threads - 1)]
        try:
            for lo, hi in runs:
                factors = free.get()
                anchors(sm, reset, ups, lo, hi, e, factors)
                ready.put((lo, hi, factors))
        finally:
            for _ in range(threads):
                ready.put(None)
        drain()
        for f in helpers:
            f.result()


CHUNK = 256
"""Update nodes per run of :func:`anchors` handed on to :func:`interiors` (:func:`backward`)."""


@jit_nogil
def transitions(sm: Store, ups: IntArray, lo: int, hi: int) -> None:
    """For the update nodes ``b = ups[k]``, k from lo to hi - 1, the transitions
    ``Φ(b, j) = Φ_b ⋯ Φ_{j+1}`` from every node j from the update node a before b (or node 0)
    up to b - 2, each into node j + 1's row of the store's Φ, where ``Φ_{j+1}`` was (each stored
    Φ serves one interval only, and is used up); node a + 1's row then holds ``Φ(b, a)``, as it
    does already when b = a + 1. They depend on the forward pass only, not on what the backward
    pass smooths, and the intervals share no row: calls on disjoint ranges may run at once,
    before :func:`anchors` and :func:`interiors` (:func:`backward`) read them."""
    psi = np.zeros(sm[SM_PHI].shape[1])
    acc = np.zeros((1, CORE))
    for k in range(lo, hi):
        b = ups[k]
        a = ups[k - 1] if k > 0 else 0
        if b - a < 2:
            continue
        psi[:] = sm[SM_PHI][b]
        for j in range(b - 2, a - 1, -1):
            _psi_times(psi, sm[SM_PHI][j + 1], acc)
            sm[SM_PHI][j + 1, :] = psi


@jit_nogil
def anchors(
    sm: Store, reset: int, ups: IntArray, lo: int, hi: int, e: Array, factors: Array
) -> None:
    """The backward pass's sequential part (:func:`backward`), for the update nodes
    ``b = ups[k]``, k from hi - 1 down to lo (``ups``: the update nodes, ascending), after the
    runs above hi: at each b its factor (:func:`_factor`: L, D and ``T``'s rows 3-4 into
    ``factors[k - lo]``, for :func:`interiors`) and from it the smoothed x and P of the update
    node a before b (or of node 0), which the factor at a starts from (:func:`_smooth_from`,
    all of P^s); NaN in ``T[5, 0]`` when b's P⁻ is not positive definite (counted), else 0.
    ``factors`` (≥ hi - lo, 3, W, W): zero from row and column n on. ``Φ(b, a)`` is node
    a + 1's row of the store's Φ, as :func:`transitions` (over the same range, before) left it.
    ``e``: the smoothed error of ``ups[hi]`` (zero at the last update node), left as that of
    ``ups[lo]``."""
    counts = sm[SM_COUNT]
    n = sm[SM_DX].shape[1]
    W = (n + 3) // 4 * 4
    Ps, Pm, scratch = np.zeros((W, W)), np.zeros((W, W)), np.zeros((5, W, W))
    unpack(sm[SM_P][ups[hi - 1]], Ps, n)
    for k in range(hi - 1, lo - 1, -1):
        b = ups[k]
        if b == 0:
            break
        a = ups[k - 1] if k > 0 else 0
        L, D, T = factors[k - lo, 0], factors[k - lo, 1], factors[k - lo, 2]
        if _factor(sm, b, reset, e, Ps, Pm, L, D, T):
            T[5, 0] = 0.0
            _smooth_from(sm, a, sm[SM_PHI][a + 1], L, D, T[3], T[4], e, scratch, True)
        else:
            counts[K_FAILED] += 1
            e[:] = 0.0
            T[5, 0] = math.nan
        unpack(sm[SM_P][a], Ps, n)


@jit_nogil
def interiors(
    sm: Store,
    ups: IntArray,
    lo: int,
    hi: int,
    factors: Array,
    full: bool,
    slot: IntArray,
    columns: IntArray,
    X: Array,
    C: Array,
    done: NDArray[np.bool_],
) -> None:
    """The backward pass's parallel part (:func:`backward`), after :func:`anchors` over the
    same range: for the update nodes ``b = ups[lo:hi]``, from b's factor that :func:`anchors`
    left in ``factors[k - lo]`` and the ``Φ(b, j)`` that :func:`transitions` left in the
    store's Φ, the nodes strictly between the update node before b (or node 0) and b
    (:func:`_smooth_from`: all of P^s or, without ``full``, its elements :func:`reported`);
    nothing when b's factor failed.
    A node with an output row in ``slot`` (:data:`Rows`; ``slot`` may be empty) is copied to
    its row of X and C as :func:`gather` would, while it is at hand. Intervals are
    independent: calls on disjoint ranges may run at once."""
    n = sm[SM_DX].shape[1]
    W = (n + 3) // 4 * 4
    e = np.zeros(n)
    scratch = np.zeros((5, W, W))
    for k in range(lo, hi):
        b = ups[k]
        a = ups[k - 1] if k > 0 else 0
        L, D, T = factors[k - lo, 0], factors[k - lo, 1], factors[k - lo, 2]
        if b - a < 2 or math.isnan(T[5, 0]):
            continue
        for j in range(b - 1, a, -1):  # Φ(b, j) where Φ_{j+1} was (transitions)
            _smooth_from(sm, j, sm[SM_PHI][j + 1], L, D, T[3], T[4], e, scratch, full)
            r = slot[j] if slot.shape[0] > 0 else -1
            if r >= 0:
                x, p = sm[SM_X][j], sm[SM_P][j]
                for c in range(X.shape[1]):
                    X[r, c] = x[c]
                for c in range(columns.shape[0]):
                    C[r, c] = p[columns[c]]
                done[r] = True
