"""IMU holes: what the motion over a stretched or filled interval can be (docs/robustness.md,
'The σ over a hole').

Where samples are lost (or dropped for a non-finite value) the loader stretches the next
row's increments over the hole (a hole within the default ``imu.max_gap_s``) or fills the
lost time with the mean of the rates of the rows either side, the trapezoid of rates (a
longer one, :func:`trapezoid`; loader._filled). The motion in the hole is unknown; its error
is that of the repair. For a hole of m periods whose row holds the increments of its last k
(the row after lost samples: k = 1), the error of the repair is, per axis,

    e = Σ_{j=1..m} x_j - (m / k) T_k                                   (stretched)
    e = Σ_{j=1..m} x_j - [T_k + (m - k) (x_0 + T_k / k) / 2]           (filled)

with T_k = Σ_{j=m-k+1..m} x_j (x the increments of one period, x_0 the row before the hole;
the first sum what happened, the rest what the repair makes of it). Its mean square over the
table, in non-overlapping windows of m rows, is the variance the engine adds to P over the
interval: the gyro's to the attitude error, the accelerometers' to the velocity error (body
axes; the engine turns them into the navigation frame with the step's attitude). The mean
is taken over every window and over those near the hole (the larger of the two): the
mission's own IMU says how fast it turns and accelerates in windows as long as the hole, and
where. No guess, no setting. Cost: one pass over the table per distinct (m, k), only when
there are holes.

An IMU in rates (``imu.format`` rates) has its holes integrated by the trapezoid of the rates
either side (models.strapdown.rates_to_increments): with x = p ω (p the period), the filled
error above with k = 1, x_0 the sample before the hole, x_m the one after
(:func:`find_rate_holes`; since 0.4.13).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission.config import DEFAULT_GAP_PERIODS

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

HOLE_MARGIN = 0.5
"""An interval is a hole when it exceeds the span of its increments by this many periods."""
WHOLE_PERIODS = 0.25
"""A rates IMU's interval is a hole only within this many periods of a whole number of them."""
REGULAR_SHARE = 0.75
"""... and only with the intervals either side longer than this share of a period (jittered
stamps: a long interval beside a short one; loader._lost_samples asks the same)."""
MIN_WINDOWS = 8
"""Fewer windows than this in the table: the windows are overlapping ones (a short table)."""
WIDE_HOLE_RAD = math.radians(30.0)
"""A hole whose attitude σ exceeds this on an axis is warned about at load (loader): the
error-state filter's model is linear in small angles, and 30° is well beyond them."""
NEAR_WINDOWS = 8
NEAR_S = 120.0
"""The windows near a hole: those ending within this many windows, or seconds, of it (in
runs of an eighth of that, :func:`blocked_errors`)."""
CHUNK_ROWS = 1 << 20
"""IMU rows taken at a time by :func:`blocked_errors` (temporaries of about 100 MB)."""


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


def trapezoid(m: int) -> bool:
    """Whether a hole of m periods is filled with the trapezoid of rates (beyond the default
    ``imu.max_gap_s``, :data:`~adaptnav.mission.config.DEFAULT_GAP_PERIODS` periods) rather
    than stretched at the next row's rate (docs/robustness.md, 'The σ over a hole')."""
    return m > DEFAULT_GAP_PERIODS


def repair_errors(
    dtheta: Array,
    dvel: Array,
    m: int,
    k: int,
    tiled: bool | None = None,
    fill: bool | None = None,
) -> tuple[Array, IntArray]:
    """The squares of ``e`` (module docstring) per axis over the table's windows of m rows
    after its first (each needs the row before it), (W, 6), velocity then attitude, and the
    windows' last rows (W,): of the trapezoid's filling when :func:`trapezoid` (m), else of
    the stretch. ``dtheta``, ``dvel``: (N, 3), one period each. Non-overlapping windows
    (``tiled``; by default when there are :data:`MIN_WINDOWS` of them), or every window of a
    short table. ``fill``: the trapezoid's error whatever m (an IMU in rates,
    :func:`find_rate_holes`); by default :func:`trapezoid` (m) decides."""
    n = dtheta.shape[0]
    if n < m + 1:
        return np.zeros((0, 6)), np.zeros(0, dtype=np.int64)
    if tiled is None:
        tiled = (n - 1) // m >= MIN_WINDOWS
    # windows [j, j + m) for j in starts, the row before each j - 1
    starts = np.arange(1, n - m + 1, m if tiled else 1)
    out = np.empty((starts.size, 6))
    filled = trapezoid(m) if fill is None else fill
    for c, x in enumerate((dvel, dtheta)):
        s = np.empty((n + 1, 3))
        s[0] = 0.0
        np.cumsum(x, axis=0, out=s[1:])
        total = s[starts + m] - s[starts]
        tail = s[starts + m] - s[starts + m - k]
        if filled:
            before = s[starts] - s[starts - 1]
            e = total - tail - (m - k) * 0.5 * (before + tail / k)
        else:
            e = total - (m / k) * tail
        out[:, 3 * c : 3 * c + 3] = e * e
    return out, (starts + m - 1).astype(np.int64)


def blocked_errors(
    dtheta: Array, dvel: Array, m: int, k: int, block: int, fill: bool | None = None
) -> tuple[Array, IntArray, IntArray]:
    """:func:`repair_errors` summed over runs of ``block`` consecutive windows: the sums
    (B, 6), the windows in each (B,) and the last row of each run's last window (B,). The
    table is taken :data:`CHUNK_ROWS` rows at a time, so that the temporaries stay small (a
    day at 200 Hz, m = 2: 8.6 million windows, summed without holding them). ``fill``: as
    :func:`repair_errors`'s."""
    n = dtheta.shape[0]
    w = (n - 1) // m  # windows after the first row
    if w < MIN_WINDOWS:  # a short table: every window
        sq, ends = repair_errors(dtheta, dvel, m, k, fill=fill)
        return sq, np.ones(ends.size, dtype=np.int64), ends
    per = block * max(1, CHUNK_ROWS // (block * m))  # windows per chunk, whole runs
    sums: list[Array] = []
    counts: list[IntArray] = []
    lasts: list[IntArray] = []
    for w0 in range(0, w, per):
        w1 = min(w0 + per, w)
        rows = slice(w0 * m, w1 * m + 1)  # the chunk's windows and the row before the first
        sq, last = repair_errors(dtheta[rows], dvel[rows], m, k, tiled=True, fill=fill)
        runs = np.arange(0, w1 - w0, block)
        sums.append(np.add.reduceat(sq, runs, axis=0))
        counts.append(np.diff(np.append(runs, w1 - w0)))
        lasts.append(w0 * m + last[np.minimum(runs + block, w1 - w0) - 1])
    return np.concatenate(sums), np.concatenate(counts), np.concatenate(lasts).astype(np.int64)


def hole_variances(
    sums: Array, counts: IntArray, ends: IntArray, at: IntArray, reach: int
) -> Array:
    """The variances of holes ending at rows ``at`` (n, 6): per axis the larger of the mean
    square of the repair's error over every window and over those (in runs, from
    :func:`blocked_errors`) ending within ``reach`` rows of the hole (the motion where it
    happened: a turn, waves). Cumulative sums over the runs: one pass, whatever the holes."""
    if not ends.size:
        return np.zeros((at.size, 6))
    whole = sums.sum(axis=0) / counts.sum()
    c = np.concatenate([np.zeros((1, 6)), np.cumsum(sums, axis=0)])
    cn = np.concatenate([[0], np.cumsum(counts)])
    lo = np.searchsorted(ends, at - reach, side="left")
    hi = np.searchsorted(ends, at + reach, side="right")
    count = np.maximum(cn[hi] - cn[lo], 1)[:, None]
    near = np.where((hi > lo)[:, None], (c[hi] - c[lo]) / count, 0.0)
    return np.asarray(np.maximum(whole[None, :], near), dtype=float)


def find_holes(
    dtheta: Array, dvel: Array, own_dt: Array, dt: Array, rows: IntArray, period: float
) -> ImuHoles:
    """The intervals ``dt`` longer than their increments' span ``own_dt`` by more than
    :data:`HOLE_MARGIN` periods, each with the variances of :func:`hole_variances` (the
    windows' errors computed once per distinct (m, k), in runs of an eighth of the reach).
    ``dtheta``, ``dvel``: the rows' increments as read (one period each but at the holes);
    ``rows``: their data rows in the file."""
    idx = np.flatnonzero(dt - own_dt > HOLE_MARGIN * period)
    if not idx.size:
        return ImuHoles.none()
    m = np.maximum(np.rint(dt[idx] / period), 2).astype(np.int64)
    k = np.clip(np.rint(own_dt[idx] / period), 1, m - 1).astype(np.int64)
    var = _variances(dtheta, dvel, idx, m, k, period, None)
    return ImuHoles(idx.astype(np.int64), rows[idx].astype(np.int64), m, k, var)


def find_rate_holes(
    gyro: Array, accel: Array, gaps: Array, rows: IntArray, period: float
) -> ImuHoles:
    """The holes of an IMU in rates: the intervals ``gaps`` between kept samples longer than
    1 + :data:`HOLE_MARGIN` periods, within :data:`WHOLE_PERIODS` of a whole number of them
    and with the intervals either side over :data:`REGULAR_SHARE` of a period (not jittered
    stamps), m = rint(gap / period) (at least 2). Interval i (of
    ``gaps``, and of the loader's ImuData) lies between samples i and i + 1; its ``row`` is
    the file row of sample i + 1, the one after the hole. The loader integrates a hole by the
    trapezoid of the rates either side (models.strapdown.rates_to_increments); its error over
    m periods from sample s, per axis, with x = p ω (p the period, ω the rates)

        e = Σ_{i=s}^{s+m-1} (x_i + x_{i+1}) / 2 - m (x_s + x_{s+m}) / 2
          = Σ_{i=s+1}^{s+m-1} x_i - (m - 1) (x_s + x_{s+m}) / 2

    which is the filled repair's error (module docstring) with k = 1 and x_0 = x_s: the same
    windows, :func:`blocked_errors` with ``fill``, and the same variances
    (docs/robustness.md, 'The σ over a hole'). Since 0.4.13; up to 0.4.12 a rates IMU's holes
    grew P by the white noise alone."""
    ratio = gaps / period
    # Jittered stamps give a long interval beside a short one, not samples lost: a hole is
    # regular either side and within a quarter period of whole periods (as loader's
    # _lost_samples asks of an increments IMU's).
    before = np.concatenate([gaps[1:2], gaps[:-1]]) if gaps.size > 1 else gaps
    after = np.concatenate([gaps[1:], gaps[-2:-1]]) if gaps.size > 1 else gaps
    idx = np.flatnonzero(
        (ratio > 1.0 + HOLE_MARGIN)
        & (np.abs(ratio - np.rint(ratio)) < WHOLE_PERIODS)
        & (np.minimum(before, after) > REGULAR_SHARE * period)
    )
    if not idx.size:
        return ImuHoles.none()
    m = np.maximum(np.rint(gaps[idx] / period), 2).astype(np.int64)
    k = np.ones(idx.size, dtype=np.int64)
    x_th, x_v = gyro * period, accel * period
    var = _variances(x_th, x_v, idx + 1, m, k, period, True)
    return ImuHoles(idx.astype(np.int64), rows[idx + 1].astype(np.int64), m, k, var)


def windows_for(m: int, k: int, n: int) -> tuple[int, float]:
    """The windows' length for a hole of m periods (k held) measured on n rows, and the factor
    on their variances: m and 1 when the rows hold a window of m (n >= m + 1); else the
    longest the rows hold twice over, m' = (n - 1) // 2, its variances times (m / m')² (a rate
    held wrong over the hole: its error grows as the hole's length squared); (0, 0) when no
    window longer than k fits. Since 0.4.13: before, a hole longer than the table (or, on a
    stream, than the last 120 s) had no window and a σ of 0 (helper aud2's audit)."""
    if n >= m + 1:
        return m, 1.0
    fit = (n - 1) // 2
    return (fit, (m / fit) ** 2) if fit > k else (0, 0.0)


def capped(var: Array) -> Array:
    """Variances (..., 6) with the attitude's (the last three) at most π²: an angle unknown
    beyond ±180° is simply unknown (the scaled variances of :func:`windows_for`)."""
    out = np.array(var, dtype=float)
    out[..., 3:] = np.minimum(out[..., 3:], math.pi**2)
    return out


def _variances(
    dtheta: Array,
    dvel: Array,
    at: IntArray,
    m: IntArray,
    k: IntArray,
    period: float,
    fill: bool | None,
) -> Array:
    """:func:`hole_variances` of the holes whose windows end at rows ``at``, m periods long
    and k held, the windows' errors computed once per distinct (m, k), in runs of an eighth
    of the reach (:data:`NEAR_WINDOWS` windows or :data:`NEAR_S` seconds)."""
    var = np.zeros((at.size, 6))
    for mm, kk in set(zip(m.tolist(), k.tolist(), strict=True)):
        # A hole longer than the table: the longest windows it holds, scaled (windows_for).
        w, scale = windows_for(mm, kk, dtheta.shape[0])
        if not w:
            continue
        reach = max(NEAR_WINDOWS * w, round(NEAR_S / period))
        block = max(1, reach // w // NEAR_WINDOWS)
        filled = trapezoid(mm) if fill is None else fill
        runs = blocked_errors(dtheta, dvel, w, kk, block, filled)
        these = (m == mm) & (k == kk)
        found = hole_variances(*runs, at[these], reach)
        var[these] = found if w == mm else capped(scale * found)
    return var


def recent_variance(dtheta: Array, dvel: Array, m: int, k: int) -> Array:
    """The variances of a hole of m periods whose sample holds k, from the samples before it
    alone (a stream's, api.Stream.push_imu): the mean square of the repair's error over their
    windows (:func:`repair_errors`); when they are fewer than m, over the longest windows they
    hold, scaled (:func:`windows_for`; up to the first 0.4.13 version zeros: a stream's hole
    longer than the 120 s it keeps had a σ of 0); zeros with no window at all."""
    w, scale = windows_for(m, k, dtheta.shape[0])
    if not w:
        return np.zeros(6)
    sq, _ = repair_errors(dtheta, dvel, w, k, fill=trapezoid(m))
    if not sq.shape[0]:
        return np.zeros(6)
    mean = sq.mean(axis=0)
    return mean if w == m else capped(scale * mean)
