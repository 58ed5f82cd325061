"""IMU holes: what the motion over a stretched interval can be (docs/robustness.md, 'IMU
samples lost', 'The σ over a hole').

Where samples are lost (or dropped for a non-finite value) the loader stretches the next row's
increments over the hole, a constant rate assumed. The motion in the hole is unknown; its
error is that of the stretch. For a hole of m periods whose row holds the increments of its
last k (the row after lost samples: k = 1), the error of the repair is, per axis,

    e = Σ_{j=1..m} x_j - (m/k) Σ_{j=m-k+1..m} x_j

(x the increments of one period; the first sum what happened, the second what the repair
makes of it). Its mean square over the rest of the mission, taken in non-overlapping windows
of m rows, is the variance the engine adds to P over the interval: the gyro's to the attitude
error, the accelerometers' to the velocity error (body axes; the engine turns them into the
navigation frame with the step's attitude). The mission's own IMU says how fast it turns and
accelerates in windows as long as the hole: no guess, no setting. Cost: one pass over the
table per distinct (m, k), only when there are holes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

HOLE_MARGIN = 0.5
"""An interval is a hole when it exceeds the span of its increments by this many periods."""
MIN_WINDOWS = 8
"""Fewer windows than this in the table: the windows are overlapping ones (a short table)."""
WIDE_HOLE_RAD = math.radians(30.0)
"""A hole whose attitude σ exceeds this on an axis is warned about at load (loader): the
error-state filter's model is linear in small angles, and 30° is well beyond them."""
NEAR_WINDOWS = 8
NEAR_S = 120.0
"""The windows near a hole: those ending within this many windows, or seconds, of it."""


@dataclass(frozen=True, eq=False)
class ImuHoles:
    """The stretched intervals of an :class:`~adaptnav.mission.loader.ImuData`: their indices
    (sorted), their 0-based data rows in the IMU file, the periods m they span and k their
    increments hold, and ``var`` (n, 6): the variances of the repair's error, velocity (m²/s²)
    then attitude (rad²), body axes (the order of the engine's noise PSDs)."""

    index: IntArray
    row: IntArray
    periods: IntArray
    held: IntArray
    var: Array

    def __len__(self) -> int:
        return int(self.index.size)

    @staticmethod
    def none() -> ImuHoles:
        """No hole."""
        empty = np.zeros(0, dtype=np.int64)
        return ImuHoles(empty, empty, empty, empty, np.zeros((0, 6)))

    def after(self, start: int) -> tuple[IntArray, Array]:
        """The holes at or after interval ``start``, indexed from it, and their variances:
        the engine's arguments (adaptnav.engine.batch.Navigator.feed_imu)."""
        keep = self.index >= start
        return self.index[keep] - start, np.ascontiguousarray(self.var[keep])


def repair_errors(dtheta: Array, dvel: Array, m: int, k: int) -> tuple[Array, IntArray]:
    """The squares of ``e`` (module docstring) per axis over the table's windows of m rows,
    (W, 6), velocity then attitude, and the windows' last rows (W,). ``dtheta``, ``dvel``:
    (N, 3), one period each. Non-overlapping windows, or every window of a short table."""
    n = dtheta.shape[0]
    if n < m:
        return np.zeros((0, 6)), np.zeros(0, dtype=np.int64)
    tiled = n // m >= MIN_WINDOWS
    ends = np.arange(m - 1, (n // m) * m, m) if tiled else np.arange(m - 1, n)
    out = np.empty((ends.size, 6))
    for c, x in enumerate((dvel, dtheta)):
        if tiled:
            w = x[: (n // m) * m].reshape(-1, m, 3)
            total, tail = w.sum(axis=1), w[:, m - k :, :].sum(axis=1)
        else:
            s = np.concatenate([np.zeros((1, 3)), np.cumsum(x, axis=0)])
            total = s[m:] - s[:-m]
            tail = s[m:] - s[m - k : n + 1 - k]
        e = total - (m / k) * tail
        out[:, 3 * c : 3 * c + 3] = e * e
    return out, ends.astype(np.int64)


def hole_variances(sq: Array, ends: IntArray, at: IntArray, reach: int) -> Array:
    """The variances of holes ending at rows ``at`` (n, 6): per axis the larger of the mean
    square of the repair's error over every window and over those ending within ``reach``
    rows of the hole (the motion where it happened: a turn, waves), from
    :func:`repair_errors`. Cumulative sums over the windows: one pass, whatever the holes."""
    if not ends.size:
        return np.zeros((at.size, 6))
    whole = sq.mean(axis=0)
    c = np.concatenate([np.zeros((1, 6)), np.cumsum(sq, axis=0)])
    lo = np.searchsorted(ends, at - reach, side="left")
    hi = np.searchsorted(ends, at + reach, side="right")
    count = np.maximum(hi - lo, 1)[:, None]
    near = np.where((hi > lo)[:, None], (c[hi] - c[lo]) / count, 0.0)
    return np.asarray(np.maximum(whole[None, :], near), dtype=float)


def find_holes(
    dtheta: Array, dvel: Array, own_dt: Array, dt: Array, rows: IntArray, period: float
) -> ImuHoles:
    """The intervals ``dt`` longer than their increments' span ``own_dt`` by more than
    :data:`HOLE_MARGIN` periods, each with the variances of :func:`hole_variance` (the
    windows' errors computed once per distinct (m, k)). ``dtheta``, ``dvel``: the rows'
    increments as read (one period each but at the holes); ``rows``: their data rows in the
    file."""
    idx = np.flatnonzero(dt - own_dt > HOLE_MARGIN * period)
    if not idx.size:
        return ImuHoles.none()
    m = np.maximum(np.rint(dt[idx] / period), 2).astype(np.int64)
    k = np.clip(np.rint(own_dt[idx] / period), 1, m - 1).astype(np.int64)
    var = np.zeros((idx.size, 6))
    for mm, kk in set(zip(m.tolist(), k.tolist(), strict=True)):
        sq, ends = repair_errors(dtheta, dvel, mm, kk)
        reach = max(NEAR_WINDOWS * mm, round(NEAR_S / period))
        these = (m == mm) & (k == kk)
        var[these] = hole_variances(sq, ends, idx[these], reach)
    return ImuHoles(idx.astype(np.int64), rows[idx].astype(np.int64), m, k, var)


def recent_variance(dtheta: Array, dvel: Array, m: int, k: int) -> Array:
    """The variances of a hole of m periods whose sample holds k, from the samples before it
    alone (a stream's, api.Stream.push_imu): the mean square of the repair's error over their
    windows (:func:`repair_errors`); zeros when they are fewer than m."""
    sq, _ = repair_errors(dtheta, dvel, m, k)
    return sq.mean(axis=0) if sq.shape[0] else np.zeros(6)
