"""Rauch-Tung-Striebel smoothing of the closed-loop error-state filter, readable form.

docs/smoothing.md. The forward filter leaves, at each *node* j (an output row or a measurement
epoch), the nominal state ``x_j`` after the epoch's feedback, the error covariance ``P_j``
after everything the epoch did, the correction ``dx_j`` it fed back (zero without an update),
the covariance ``P⁻_j`` the update started from (``P_j`` without one) and the transition
``Φ_j`` of the error state from node j-1 to node j. Closed loop, the filtered error estimate
at a node is zero and its prediction at the next node is zero too; RTS in error-state form
then reads, from the last node backwards (``e^s``, ``P^s``: the smoothed error and its
covariance, relative to ``x_j``)::

    e⁻_{j+1} = dx_{j+1} + G⁻¹ e^s_{j+1},     P⁻s_{j+1} = G⁻¹ P^s_{j+1} G⁻ᵀ
    C_j      = P_j Φ_{j+1}ᵀ (P⁻_{j+1})⁻¹
    e^s_j    = C_j e⁻_{j+1}
    P^s_j    = P_j + C_j (P⁻s_{j+1} - P⁻_{j+1}) C_jᵀ
    x^s_j    = x_j ⊕ e^s_j

starting from ``e^s = 0``, ``P^s = P`` at the last node. The first line takes the smoothed
error back to the coordinates before node j+1's feedback: G is the reset Jacobian
(:func:`adaptnav.models.errorstate.reset_jacobian`: ``I + ½ [dx_att×]`` on the attitude block and
``-[dx_vel×]`` in the velocity-attitude block) when the filter resets P, the identity
otherwise. Nothing else of the update is needed: RTS uses only the prediction ``P⁻_{j+1} = Φ
P_j Φᵀ + Q`` (with any inflation of P before the update counted as process noise), so gating,
adaptive R and Joseph form leave the backward pass as it is. ``P_j`` must be what node j's
update left: an inflation after it (the windowed NIS test) is the next interval's process
noise, in ``P⁻_{j+1}`` only (docs/smoothing.md, 'Inflations of P').

``P⁻_{j+1}`` is factored after scaling by its diagonal (positions in m² beside gyro biases in
rad²/s²: condition numbers of 1e20 otherwise). The compiled twin is
:mod:`adaptnav.compiled.smoother`; it multiplies the gains between update nodes out (one gain
per interval, docs/smoothing.md, 'From update node to update node'), which this node-by-node
form checks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from adaptnav.core import attitude
from adaptnav.models import errorstate
from adaptnav.models.errorstate import ATT, VEL

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Nodes:
    """What the forward pass stores for the backward one, per node j = 0..N-1 (module
    docstring): ``t`` (N,), ``x`` (N, 16 + m), ``dx`` (N, n), ``P``, ``P_prior``, ``Phi``
    (N, n, n; ``Phi[0]`` unused) with n = 15 + m error states, and how the filter resets P
    after feedback."""

    t: Array
    x: Array
    dx: Array
    P: Array
    P_prior: Array
    Phi: Array
    reset: int = errorstate.RESET_INVARIANT
    """The filter's reset after feedback (errorstate.RESET_*)."""
    rows: NDArray[np.int64] | None = None
    """The node of each output row, where the nodes come from a run (else None)."""


def reset_inverse(dx: Array, n: int, reset: int) -> Array:
    """``G⁻¹`` for the reset Jacobian G of ``reset`` (errorstate.RESET_*;
    :func:`adaptnav.models.errorstate.reset_jacobian`): with ``h = ½ dx_att``, the attitude block
    ``A⁻¹ = (I - [h×] + h hᵀ) / (1 + |h|²)`` and, for RESET_INVARIANT, the velocity-attitude block
    ``[dv̂×] A⁻¹`` (G is block upper triangular, its velocity block the identity); the identity
    for RESET_OFF."""
    Gi = np.eye(n)
    if reset >= errorstate.RESET_ATTITUDE:
        h = 0.5 * np.asarray(dx[ATT], dtype=float)
        Gi[ATT, ATT] = (np.eye(3) - attitude.skew(h) + np.outer(h, h)) / (1.0 + h @ h)
    if reset == errorstate.RESET_INVARIANT:
        Gi[VEL, ATT] = attitude.skew(dx[VEL]) @ Gi[ATT, ATT]
    return Gi


def gain_transpose(P_prior: Array, B: Array) -> Array:
    """``X = (P⁻)⁻¹ B`` by a Cholesky factor of ``D P⁻ D``, ``D = diag(P⁻)^(-1/2)``: with
    ``B = Φ P_j``, ``X = C_jᵀ``."""
    d = 1.0 / np.sqrt(np.diag(P_prior))
    factor = scipy.linalg.cho_factor(P_prior * np.outer(d, d), lower=True)
    return np.asarray(d[:, None] * scipy.linalg.cho_solve(factor, d[:, None] * B), dtype=float)


def rts(nodes: Nodes) -> tuple[Array, Array, Array]:
    """The smoothed nominal states ``x^s`` (N, 16 + m), error covariances ``P^s`` (N, n, n) and
    errors ``e^s`` (N, n) at every node (module docstring)."""
    N, n = nodes.dx.shape
    x_s = nodes.x.copy()
    P_s = nodes.P.copy()
    e_s = np.zeros((N, n))
    for j in range(N - 2, -1, -1):
        k = j + 1
        Gi = reset_inverse(nodes.dx[k], n, nodes.reset)
        e_prior = nodes.dx[k] + Gi @ e_s[k]
        P_prior_s = Gi @ P_s[k] @ Gi.T
        X = gain_transpose(nodes.P_prior[k], nodes.Phi[k] @ nodes.P[j])
        e_s[j] = X.T @ e_prior
        P = nodes.P[j] + X.T @ (P_prior_s - nodes.P_prior[k]) @ X
        P_s[j] = 0.5 * (P + P.T)
        x_s[j] = errorstate.inject(nodes.x[j], e_s[j])
    return x_s, P_s, e_s
