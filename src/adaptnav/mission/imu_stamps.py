"""Jittered stamps on a fixed-rate increments IMU (docs/robustness.md, 'Jittered IMU stamps').

An IMU that outputs increments samples on its own clock, one period per row; a logger that
stamps each row when it arrives scatters the stamps about that grid by ``e_k``. The engine takes
each row's increments over its stamped interval ``T + e_k - e_{k-1}``, so gravity (and the
Coriolis terms) are integrated over the stamped time while the specific force is the one of a
period: the velocity at row ``k`` is off by ``-f e_k`` (``g e_k`` down), an error its σ does
not hold. :func:`fit_stamp_grid` fits the grid the stamps scatter about and tells whether the
increments follow the stamps (true irregular intervals) or not (jitter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter, uniform_filter1d

Array = NDArray[np.float64]

JITTER_FRACTION = 0.02
"""Robust σ of the stamps about a regular grid, as a fraction of the period, from which they
are taken as jittered (0.2 ms at 100 Hz: a velocity error of 2 mm/s, g σ, per row)."""
FOLLOW_LIMIT = 0.5
"""The increments follow the stamps when ``|Δv|`` changes with the stamped interval by more than
this fraction of the specific force (1: increments over each stamped interval; 0: over one
period each, whatever the stamps say)."""
SMOOTH_ROWS = 101
"""Rows of the running median that gives the grid's local offset (it follows clock drift)."""
HALF_BAND = 0.1
"""An interval within this many periods of a half-way point (1.5, 2.5, ... periods) makes the
count of periods of the rows uncertain: the stamps jitter by a quarter period or more, and a
row stamped 1.6 periods after the one before may be one period late or two early."""
MAD_SIGMA = 1.4826


@dataclass(frozen=True, eq=False)
class StampFit:
    """The grid fitted to jittered stamps: ``stamps`` (the grid's times of the rows), the
    ``period`` (s), the robust σ and the largest |stamp - grid| (s), and ``follow``, the slope
    of ``|Δv|`` against the stamped interval in units of the specific force; ``certain``: no
    interval is near a half-way point (:data:`HALF_BAND`), so every row's count of periods is
    the nearest whole number and the grid may replace the stamps."""

    stamps: Array
    period: float
    sigma: float
    worst: float
    follow: float
    certain: bool

    @property
    def jitter(self) -> bool:
        """The increments are one period each whatever the stamps say: the stamps jitter."""
        return self.follow < FOLLOW_LIMIT


def fit_stamp_grid(t: Array, dvel: Array) -> StampFit | None:
    """The grid the stamps ``t`` (N,) scatter about, or None when their intervals are regular
    (robust σ below :data:`JITTER_FRACTION` of the median interval) or the table is shorter
    than :data:`SMOOTH_ROWS`. ``dvel`` (N, 3): the rows' velocity increments (NaN allowed).

    Each interval counts ``max(1, round(dt / T))`` periods (``T`` the median interval), the
    period is the slope of the line through ``t`` against the count ``c``; the offsets are
    smoothed by a running median (which follows clock drift and keeps the step of lost samples),
    then by a running mean of what is left (the median of a uniform jitter is a poor
    estimate); the grid is that offset plus ``T c``."""
    if t.size <= SMOOTH_ROWS:
        return None
    dt = np.diff(t)
    period = float(np.median(dt))
    scatter = MAD_SIGMA * float(np.median(np.abs(dt - period))) / math.sqrt(2.0)
    if not period > 0.0 or scatter < JITTER_FRACTION * period:
        return None
    count = np.maximum(1.0, np.rint(dt / period))
    c = np.concatenate([[0.0], np.cumsum(count)])
    period = float(np.polyfit(c, t, 1)[0])  # the median interval is only within the jitter
    offset = t - period * c
    grid = median_filter(offset, size=SMOOTH_ROWS, mode="mirror") + period * c
    grid += uniform_filter1d(t - grid, size=SMOOTH_ROWS, mode="mirror")
    res = t - grid
    sigma = MAD_SIGMA * float(np.median(np.abs(res - np.median(res))))
    follow = _follow(np.linalg.norm(dvel, axis=1), dt, count, period)
    ratio = dt / period
    certain = not np.any((ratio > 1.0) & (np.abs(ratio - np.floor(ratio) - 0.5) < HALF_BAND))
    return StampFit(grid, period, sigma, float(np.max(np.abs(res))), follow, certain)


def _follow(dv: Array, dt: Array, count: Array, period: float) -> float:
    """Slope of ``|Δv_k|`` against the interval ``dt_k``, each less the mean of its two
    neighbours (which removes the slow change of the specific force), over rows of one period
    with neighbours of one period, divided by the median specific force ``|Δv| / T``."""
    mag = dv[1:]
    one = (count == 1.0) & np.isfinite(mag)
    inner = one[1:-1] & one[:-2] & one[2:]
    x = (dt[1:-1] - 0.5 * (dt[:-2] + dt[2:]))[inner]
    y = (mag[1:-1] - 0.5 * (mag[:-2] + mag[2:]))[inner]
    force = float(np.median(mag[one])) / period if np.any(one) else 0.0
    sxx = float(np.dot(x, x))
    if sxx == 0.0 or force == 0.0:
        return 1.0
    return float(np.dot(x, y)) / sxx / force
