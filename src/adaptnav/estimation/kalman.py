"""Plain Kalman correction functions. Pure: they return new values.

docs/filters.md, 'Kalman correction' (paper eqs. (25)-(27)). Closed loop: the prior error
estimate is zero (x⁻ = 0; docs/filters.md, 'Feedback and reset'), so the innovation is the
measurement residual itself, ``ν = y - H x⁻ = y``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptnav.models import errorstate

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Correction:
    """Result of one (stacked) update: posterior error dx⁺, covariance P⁺, innovation ν, its
    covariance S = H P⁻ Hᵀ + R and the normalised innovation squared ν S⁻¹ ν (NIS)."""

    dx: Array
    P: Array
    innovation: Array
    S: Array
    nis: float


def innovation_covariance(P: Array, H: Array, R: Array) -> Array:
    """``S = H P⁻ Hᵀ + R``."""
    S = H @ P @ H.T + R
    return np.asarray(0.5 * (S + S.T), dtype=float)


def correct(P: Array, H: Array, y: Array, R: Array) -> Correction:
    """Kalman update with x⁻ = 0 (paper eqs. (25)-(27)), covariance in Joseph form.

    ``K = P⁻ Hᵀ S⁻¹``, ``dx⁺ = K y``, ``P⁺ = (I - K H) P⁻ (I - K H)ᵀ + K R Kᵀ`` — equal to
    ``P⁻ - K S Kᵀ`` for the optimal K, but symmetric and positive semi-definite in floating point.
    """
    S = innovation_covariance(P, H, R)
    PHt = P @ H.T
    cho = np.linalg.cholesky(S)
    # K = P Hᵀ S⁻¹ through the Cholesky factor: no explicit inverse.
    K = np.linalg.solve(cho.T, np.linalg.solve(cho, PHt.T)).T
    dx = K @ y
    IKH = np.eye(P.shape[0]) - K @ H
    P_new = IKH @ P @ IKH.T + K @ R @ K.T
    w = np.linalg.solve(cho, y)
    return Correction(dx, 0.5 * (P_new + P_new.T), y.copy(), S, float(w @ w))


def midpoint_jacobian(
    x: Array,
    P: Array,
    y: Array,
    R: Array,
    jacobian: Callable[[Array], Array],
    iterations: int,
) -> Array:
    """H of the midpoint update (docs/calibration.md, 'The midpoint update'): the stacked
    readings' H linearised at ``x ⊕ ½ dx``, the residuals y staying those at x.

    ``jacobian(x)`` gives the stacked H at a nominal state. Starting from ``H = jacobian(x)``,
    each iteration takes ``dx`` from :func:`correct` with that H, y and R and sets
    ``H = jacobian(x ⊕ ½ dx)``. For a reading that multiplies two states,
    ``h(x ⊕ dx) - h(x) = H(x ⊕ ½ dx) dx`` exactly (a secant; to third order in dx in general):
    the update's linear prediction is right along its own step, where the tangent at x is not.
    0 iterations: H at x.
    """
    H = jacobian(x)
    for _ in range(iterations):
        dx = correct(P, H, y, R).dx
        H = jacobian(errorstate.inject(x, 0.5 * dx))
    return H
