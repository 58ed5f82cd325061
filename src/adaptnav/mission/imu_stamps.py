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

import itertools
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
STEP_ROWS = 25
"""Rows either side of an interval whose median offsets from the grid must agree: the IMU's
clock is continuous, so a count of periods that is wrong (a row stamped 1.6 periods after the one
before, one period late or two early?) shows as a step of a whole period there."""
MAX_PASSES = 8
"""Passes of :func:`_resolve_counts`; a table still with steps after them is left uncertain."""
MAD_SIGMA = 1.4826


@dataclass(frozen=True, eq=False)
class StampFit:
    """The grid fitted to jittered stamps: ``stamps`` (the grid's times of the rows), the
    ``period`` (s), the robust σ and the largest |stamp - grid| (s), and ``follow``, the slope
    of ``|Δv|`` against the stamped interval in units of the specific force; ``certain``: the
    offsets from the grid agree within half a period either side of every interval
    (:func:`_resolve_counts`), so every row's count of periods is known and the grid may replace
    the stamps."""

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

    Each interval counts ``max(1, round(dt / T))`` periods (``T`` the median interval), those
    that break the grid's continuity corrected (:func:`_resolve_counts`); the period is the
    slope of the line through ``t`` against the cumulative count ``c``; the offsets
    ``t - T c`` are smoothed by a running median (which follows clock drift and keeps the step
    of lost samples), then by a running mean of what is left (the median of a uniform jitter is
    a poor estimate); the grid is that offset plus ``T c``."""
    if t.size <= SMOOTH_ROWS:
        return None
    dt = np.diff(t)
    period = float(np.median(dt))
    scatter = MAD_SIGMA * float(np.median(np.abs(dt - period))) / math.sqrt(2.0)
    if not period > 0.0 or scatter < JITTER_FRACTION * period:
        return None
    count, certain = _resolve_counts(t, dt, period)
    c = np.concatenate([[0.0], np.cumsum(count)])
    period = float(np.polyfit(c, t, 1)[0])  # the median interval is only within the jitter
    offset = t - period * c
    grid = median_filter(offset, size=SMOOTH_ROWS, mode="mirror") + period * c
    grid += uniform_filter1d(t - grid, size=SMOOTH_ROWS, mode="mirror")
    res = t - grid
    sigma = MAD_SIGMA * float(np.median(np.abs(res - np.median(res))))
    follow = _follow(np.linalg.norm(dvel, axis=1), dt, count, period)
    return StampFit(grid, period, sigma, float(np.max(np.abs(res))), follow, certain)


def _resolve_counts(t: Array, dt: Array, period: float) -> tuple[Array, bool]:
    """Periods per interval, and whether they are certain. From ``round(dt / T)`` (at least 1),
    each pass finds the runs of intervals where the median offset ``t - T c`` of the
    :data:`STEP_ROWS` rows after differs from that of the rows before by half a period or more (a
    wrong count makes such a run about :data:`STEP_ROWS` wide) and changes, in each run, the
    count of the interval most in keeping with the step (the one whose ``dt / T`` lies farthest
    from its count in the step's direction, its count staying at least 1). Certain when no step
    of half a period is left after :data:`MAX_PASSES` passes. Past either end of the table a
    window takes the end row's offset (since 0.4.10; up to 0.4.9 the rows before it, mirrored,
    so that a first or last interval jittered past 1.5 periods kept a count of 2: the last row
    re-stamped a period late, a period's increments over two, or the first a period early and
    the second row taken for one after a lost sample)."""
    ratio = dt / period
    count = np.maximum(1.0, np.rint(ratio))
    for _ in range(MAX_PASSES):
        off = t - period * np.concatenate([[0.0], np.cumsum(count)])
        half = STEP_ROWS // 2
        # "nearest": a window past the table's end holds the end row's offset, not the rows
        # before it mirrored (which hid a wrong count of the first or last interval)
        ahead = median_filter(off, size=STEP_ROWS, origin=-half, mode="nearest")
        behind = median_filter(off, size=STEP_ROWS, origin=half, mode="nearest")
        step = (ahead[1:] - behind[:-1]) / period
        jump = np.rint(step)
        if not np.any(jump):
            return count, True
        edges = np.flatnonzero(np.diff(np.concatenate([[0.0], jump, [0.0]])))
        for a, b in itertools.pairwise(edges.tolist()):
            if jump[a] == 0.0:
                continue
            sign = float(np.sign(jump[a]))  # one period per run and pass
            lean = (ratio[a:b] - count[a:b]) * sign
            lean[count[a:b] + sign < 1.0] = -np.inf  # no interval of under one period
            k = a + int(np.argmax(lean))
            if np.isfinite(lean[k - a]):
                count[k] += sign
    return count, False


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
