"""Long-run variance: how much a sum of correlated terms varies beyond what their own variances
say (docs/calibration.md, 'Correlated readings').

For terms g_k (k = 1..n) with autocovariances Γ_l, ``Var(Σ_k g_k) = Σ_{|l|<n} (n - |l|) Γ_l``,
which is n Γ_0 only when the terms are uncorrelated. The Bartlett-weighted sum of the sample
autocovariances estimates it, positive semi-definite by construction (Newey & West 1987)::

    S = Γ_0 + Σ_{0<l<b} (1 - l/b) (Γ_l + Γ_lᵀ),      Γ_l = Σ_k g_k g_{k-l}ᵀ

The bandwidth b is taken from the data (Newey & West 1994, "Automatic lag selection in
covariance matrix estimation", Rev. Econ. Stud. 61(4), Bartlett kernel): with the sample
autocovariances γ_l of a scalar series up to lag ``p = ⌊4 (n/100)^(2/9)⌋``::

    s_0 = γ_0 + 2 Σ_{l=1..p} γ_l,      s_1 = 2 Σ_{l=1..p} l γ_l,
    b = 1.1447 ((s_1 / s_0)²)^(1/3) n^(1/3)                     (at most n/4)

It looks at several lags, not only the first, so a correlation that shows at lags of 5-20
readings (the innovations of a filter, which tracks the slowest part of an error into its
states) widens it even when the lag-1 correlation is small.

A strongly correlated series needs a bandwidth longer than a few hundred terms can support,
and the Bartlett sum then falls short (an AR(1) series of 400 terms with ρ = 0.5: 20 % short
in variance). :func:`variance_factor` therefore prewhitens first (Andrews & Monahan 1992,
"An improved heteroskedasticity and autocorrelation consistent covariance matrix estimator",
Econometrica 60(4)): ``u_k = g_k - ρ̂ g_{k-1}`` with ρ̂ the lag-1 correlation (clipped to
±:data:`MAX_RHO`), the Bartlett sum of the u_k with their own bandwidth, recoloured by
``1 / (1 - ρ̂)²``. What the AR(1) leaves, at longer lags, the bandwidth of the u_k still sees.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

__all__ = ["MAX_RHO", "MIN_TERMS", "bandwidth", "bartlett", "variance_factor"]

MIN_TERMS = 20
"""Fewer terms than this say nothing about their correlation (:func:`variance_factor`)."""
MAX_RHO = 0.95
"""Largest lag-1 correlation the prewhitening takes (its recolouring 1 / (1 - ρ̂)² ≤ 400)."""


def bartlett(g: Array, bandwidth: float) -> Array:
    """``S = Σ_{|l|<b} (1 - |l|/b) Γ_l`` of the rows g_k of ``g`` (n, d), ``Γ_l = Σ_k g_k
    g_{k-l}ᵀ`` (module docstring): the covariance of ``Σ_k g_k`` when the g_k are correlated
    over fewer than b terms; ``Γ_0`` alone (the sandwich) for b ≤ 1."""
    S = g.T @ g
    lag = 1
    while lag < bandwidth:
        G = g[lag:].T @ g[:-lag]
        S += (1.0 - lag / bandwidth) * (G + G.T)
        lag += 1
    return np.asarray(S, dtype=float)


def bandwidth(g: Array) -> float:
    """Newey & West's (1994) Bartlett bandwidth b of the scalar series ``g`` (module docstring,
    taken about its mean); 0 when the series has no variance or fewer than 3 terms."""
    n = g.size
    if n < 3:
        return 0.0
    v = g - g.mean()
    p = min(int(4.0 * (n / 100.0) ** (2.0 / 9.0)), n - 1)
    gam = np.array([np.dot(v[lag:], v[: n - lag]) / n for lag in range(p + 1)])
    lags = np.arange(1, p + 1)
    s0 = gam[0] + 2.0 * gam[1:].sum()
    s1 = 2.0 * np.sum(lags * gam[1:])
    if not (gam[0] > 0.0 and s0 > 0.0):
        return 0.0
    return float(min(1.1447 * ((s1 / s0) ** 2) ** (1.0 / 3.0) * n ** (1.0 / 3.0), n / 4.0))


def variance_factor(g: Array) -> float:
    """``S / Γ_0`` of the scalar series ``g`` about its mean, S its long-run variance
    prewhitened (module docstring): by how much the variance of a sum of the terms exceeds the
    sum of their variances (1 for uncorrelated terms, ``(1 + ρ) / (1 - ρ)`` for an AR(1) series
    of lag-1 correlation ρ). NaN for fewer than :data:`MIN_TERMS` finite terms or no variance:
    their correlation is unknown."""
    g = np.asarray(g, dtype=float)
    g = g[np.isfinite(g)]
    if g.size < MIN_TERMS:
        return math.nan
    v = g - g.mean()
    g0 = float(v @ v)
    if not g0 > 0.0:
        return math.nan
    rho = float(np.clip(np.dot(v[1:], v[:-1]) / np.dot(v[:-1], v[:-1]), -MAX_RHO, MAX_RHO))
    u = v[1:] - rho * v[:-1]
    S_u = bartlett((u - u.mean())[:, None], bandwidth(u))[0, 0] * v.size / u.size
    return float(S_u / (1.0 - rho) ** 2 / g0)
