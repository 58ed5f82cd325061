"""Allan deviation: the overlapping estimator and the theory of the simulated noise terms.

Overlapping Allan variance of a rate series y_k sampled every τ0, from the integrated signal
``x_k = τ0 Σ_{i<=k} y_i`` (angle, velocity), at averaging time τ = m τ0 (IEEE Std 952-1997
Annex C; Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065, 2008, eq. 14)::

    σ²(τ) = Σ_{k=0}^{N-2m} (x_{k+2m} - 2 x_{k+m} + x_k)² / (2 τ² (N - 2m + 1))

with N + 1 values of x (x_0 = 0). Theory for the terms :mod:`adaptnav.sim.imu_model` simulates:

* white rate noise of root-PSD Q (ARW, VRW): ``σ(τ) = Q / √τ``;
* rate random walk of root-PSD K: ``σ(τ) = K √(τ/3)``;
* first-order Gauss-Markov of σ and correlation time T (e.g. Jerath, Brennan & Lagoa 2018,
  "Bridging the gap between sensor noise modeling and sensor characterization", Measurement
  116; the autocorrelation ``σ² e^{-|t|/T}`` through IEEE 952 eq. C.2)::

      σ²(τ) = (σ² T² / τ²) (2τ/T - 3 + 4 e^{-τ/T} - e^{-2τ/T}),

  which rises as ``σ √(2τ/3T)`` (random-walk-like), peaks at ``0.6166 σ`` near ``τ = 1.893 T``
  and falls as ``σ √(2T/τ)`` (white-like). This hump is *not* the flat floor ``0.664 B`` of
  flicker ("bias instability") noise: the simulator generates Gauss-Markov biases, so that
  is the theory to test against.

Independent terms add in variance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def overlapping_adev(rate: ArrayLike, tau0: float, m: Sequence[int] | ArrayLike) -> Array:
    """Overlapping Allan deviation of ``rate`` (N,) or (N, k), sampled every ``tau0`` s, at
    averaging factors ``m`` (τ = m τ0); returns (len(m),) or (len(m), k)."""
    y = np.asarray(rate, dtype=float)
    squeeze = y.ndim == 1
    if squeeze:
        y = y[:, None]
    n = y.shape[0]
    x = np.concatenate([np.zeros((1, y.shape[1])), np.cumsum(y, axis=0) * tau0])
    ms = np.atleast_1d(np.asarray(m, dtype=int))
    out = np.empty((ms.size, y.shape[1]))
    for i, mm in enumerate(ms):
        if mm < 1 or 2 * mm > n:
            raise ValueError(f"averaging factor {mm} needs 1 <= m <= N/2 = {n // 2}")
        d = x[2 * mm :] - 2.0 * x[mm:-mm] + x[: -2 * mm]
        tau = mm * tau0
        out[i] = np.sqrt(np.sum(d * d, axis=0) / (2.0 * tau * tau * d.shape[0]))
    return out[:, 0] if squeeze else out


def adev_white(q: float, tau: ArrayLike) -> Array:
    """``Q / √τ`` for white rate noise of root-PSD Q."""
    return np.asarray(q / np.sqrt(np.asarray(tau, dtype=float)), dtype=float)


def adev_random_walk(k: float, tau: ArrayLike) -> Array:
    """``K √(τ/3)`` for a rate random walk of root-PSD K."""
    return np.asarray(k * np.sqrt(np.asarray(tau, dtype=float) / 3.0), dtype=float)


def adev_gauss_markov(sigma: float, corr_time: float, tau: ArrayLike) -> Array:
    """Allan deviation of a first-order Gauss-Markov process (σ, T) (module docstring)."""
    x = np.asarray(tau, dtype=float) / corr_time
    var = sigma**2 * (2.0 * x - 3.0 + 4.0 * np.exp(-x) - np.exp(-2.0 * x)) / (x * x)
    return np.asarray(np.sqrt(var), dtype=float)


def gauss_markov_peak() -> tuple[float, float]:
    """(τ/T, σ_A/σ) at the maximum of :func:`adev_gauss_markov`: ≈ (1.893, 0.6166)."""
    x = np.linspace(1.0, 3.0, 200001)
    a = adev_gauss_markov(1.0, 1.0, x)
    i = int(np.argmax(a))
    return float(x[i]), float(a[i])


def log_spaced_factors(n: int, per_decade: int = 5, max_fraction: float = 0.1) -> Array:
    """Distinct averaging factors m, log-spaced from 1 to ``max_fraction`` n."""
    top = max(1.0, max_fraction * n)
    ms = np.unique(np.round(np.logspace(0, math.log10(top), per_decade * 10)).astype(int))
    return np.asarray(ms, dtype=float)
