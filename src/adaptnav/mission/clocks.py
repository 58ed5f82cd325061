"""A sensor's clock against the IMU's: the time offset of an aiding sensor that sees rotation.

A heading sensor whose stamps are 18 s after its readings were taken (a logger's clock set
apart, a latency not written in ``latency_s``) passes the IMU-axes check (mission/axes.py): it
tries lags within ±1 s only, and a vehicle that turns slowly still shows most of the
reference's rotation at lag 0. The filter then takes an 18-s-old yaw as the present one
(docs/robustness.md, 'Sensor clocks'). The same angle changes that judge an axis date the
sensor: over a wide range of lags τ (±:data:`MAX_OFFSET_S`), the reference's angle changes are
fitted on the gyro's taken τ earlier,

    a_k = k b_k(τ) + c,        b_k(τ) = θ(g_{k+1} - τ) - θ(g_k - τ),

on a uniform grid g of step h (the reference's period, at least the IMU's and
:data:`MIN_STEP_S`; the reference's angle, unwrapped, interpolated linearly onto it; a grid
coarser than :data:`MAX_STEP_S` is tried at phases that far apart), θ the
gyro's integral about the reference's axis (:class:`adaptnav.mission.axes.Gyro`), c a constant
gyro bias. τ > 0: the reference's stamps are late by τ (its reading at stamp t was taken at
t - τ, what ``latency_s = τ`` takes off). Every sum of the least-squares fit at every lag,
Σ a b(τ), Σ b(τ)², Σ b(τ), Σ a², Σ a and the count over the intervals both sides cover, is a
cross-correlation of a reference-side series with an IMU-side one, so all the lags cost six
FFT correlations (NumPy's real FFT) instead of a fit per lag. The residual
variance ``s²(τ) = RSS(τ) / (N(τ) - 2)`` is least at the offset; a parabola through its three
grid values about the least one places it between grid points.

The offset's σ is the nonlinear least squares' (Gauss-Newton): ``σ_τ² = 2 s² / RSS''(τ̂)``,
RSS'' from the same parabola, times ``N / N_eff``, where ``N_eff = N (1 - ρ) / (1 + ρ)`` counts
the independent residuals (ρ their lag-one correlation, if positive: a GNSS course interpolated
between chords is correlated over a chord), and at least the grid's own ``h / √12``.

The decision (:meth:`ClockOffset.decisive`) asks the offset to beat lag 0 decisively, since a
wave's roll repeats every period and so gives a fit nearly as good one period away. Lag 0 is
judged as a right sensor would be there, with the slope found at τ̂ (its scale does not depend
on its clock; with the slope free, a roll 18 s late on the demo's sea fits at lag 0 inverted,
k = -0.85, and that fit explains most of it): ``s0² = Σ (a - ā - k̂ (b(0) - b̄))² / (N - 1)``.
Both ``s0²`` and ``s²(τ̂)`` (and k̂, the rotation's share, ``N_eff``) are summed over the same
intervals, those the IMU covers at τ̂ and at 0 (:class:`_Both`; since 0.4.12, docs/robustness.md,
'Sensor clocks'): a step the IMU covers at one lag only cannot make it win.

* the likelihood ratio ``N_eff ln V ≥`` :data:`MIN_LOG_LR`, ``V = s0² / s²(τ̂)`` (χ²(1) beyond
  5.5 σ, so that even after the ~10³ lags tried chance stays below 1e-4);
* lag 0 leaves at least :data:`MIN_SHARE` of the rotation's variance, ``k̂² Σ (b - b̄)² / N``
  at τ̂, unexplained beyond what τ̂ leaves: ``(s0² - s²(τ̂)) / (k̂² Σ (b - b̄)² / N)``, the
  offset's size in the rotation, not in the sensor's own noise (a heading's noise can make
  V small when the shift is plain). A right sensor has its least variance at lag 0, and a lag
  a wave period away cannot beat it by a quarter of the rotation;
* the slope at the offset a right axis's: ``k`` within :data:`SLOPE_BAND` (a flipped or swapped
  axis is the axis check's finding, not a clock's);
* ``|τ̂| >`` :data:`CONFIDENCE` ``σ_τ``.

The loader refuses such an offset when it lies beyond ``max(1 s, 2 periods)`` of the sensor
(:meth:`ClockOffset.beyond`); within, it is a latency the axis check allows for, and a warning.

**A DVL and a depth meter** (since 0.4.12) measure no angle; the same scan
(:func:`series_offset`: any IMU-side cumulative series, m columns fitted with one slope and a
constant each, the sums added over the columns) dates them against a series whose changes
they follow. The DVL's three axes follow ``U``, the sum of the body velocity's changes the
accelerometers and the gyro predict (mission/dvl_axes.py: ``Δu = Δv_f + g_b h - Δθ × v_b``,
with ``ω × l`` at the DVL's point, in its axes), with k ≈ 1 on a right DVL
(:func:`dvl_offset`). A depth meter follows ``W(t) = ∫ (C_nb v_b)_down dt``, the DVL's velocity
turned down by the accelerometers' levelled tilt, the vertical displacement of
mission/scales.py's depth scale check (:func:`depth_offset`), on a vehicle that dives
(:data:`MIN_DIVE_M`). Both scans judge the same intervals at every lag (a stretch of the
DVL's larger noise at one end would favour the lags that slide it out) and clip a reading's
outliers (:data:`CLIP_SIGMAS`), and take positive slopes only (a yo-yo's depth half a period
off fits inverted). The DVL's readings shape its prediction (the centripetal term, the
gravity's mean), so an offset found beyond 1 s is scanned again with them moved by it.

Pure NumPy, no I/O: :func:`adaptnav.mission.loader.load_mission` calls
:func:`clock_offset` for each reference of the axis check, :func:`dvl_offset` and
:func:`depth_offset` for each DVL and depth meter whose ``scale_check`` is on, and raises the
MissionError. The scan's parts, :class:`Reference`, :class:`Scan`, :func:`parabola` and
:func:`n_eff`, are public since 0.4.12 for :mod:`adaptnav.mission.gnss_clock`, which dates a
GNSS's positions with a complex slope (a rotation and a scale) that :func:`series_offset`'s one
real slope cannot fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

from adaptnav.mission import axes, dvl_axes, scales

Array = NDArray[np.float64]

MAX_OFFSET_S = 60.0
"""Widest offset looked for either way (s): the configuration's bound on ``latency_s``."""
MIN_STEP_S = 0.1
"""Finest grid step (s): a 100-Hz heading is interpolated onto 0.1 s, which dates to a tenth of
a second as well, at a tenth of the cost (the FFTs' length)."""
MAX_STEP_S = 1.0
"""Widest spacing of the lags tried (s): a grid coarser than that (a GNSS course between chords
tens of seconds apart) is tried at phases this far apart."""
GAP_PERIODS = 3.0
"""A grid interval within a gap of the reference's readings longer than this many of its
periods is left out (its interpolated change would be a ramp)."""
MIN_SHARE = 0.25
"""Least share of the reference's rotation (its variance over the grid's intervals at the
offset, ``k² Σ (b - b̄)² / N``) that lag 0 leaves unexplained beyond what the offset does."""
MIN_LOG_LR = 30.0
"""Least likelihood ratio statistic ``N_eff ln V`` (χ²(1): p ≈ 4e-8; times ~10³ lags, 5e-5)."""
SLOPE_BAND = (0.8, 1.25)
"""Slopes of a right axis: a compass's deviation, a drift angle, a pendulum's response."""
SLOPE_SURE = 0.1
"""A slope farther than this from 1 at the offset makes it doubtful (:attr:`ClockOffset.alias`):
right stamps give 0.93-1.00 on every right dataset measured, and a sea's components repeat well
enough that stamps 70 or 90 s late (beyond the scan) fit at an alias within it with 0.81."""
CONFIDENCE = 4.0
"""σ's the offset must lie from zero."""
EDGE_LAGS = 2
"""Lags scanned past ±:data:`MAX_OFFSET_S` (in the scan's spacing): up to 0.4.11 an offset of
exactly 60 s lay on the scan's edge, where the parabola has no neighbour, so its σ was infinite
and the axis check then blamed the gyro (a heading with ``latency_s = 60`` on right stamps)."""
MIN_DIVE_M = 2.0
"""Least span (m) of a depth's running median over :data:`DIVE_WINDOW_S` for its clock to be
read: a surface vessel's depth is waves and noise, which repeat (paper-1's, spanning 1.2 m so,
fits the DVL's vertical displacement 20 s off nearly as well as at its stamps; the demos'
span 0.25-1.26 m); the A-KIT dives that are dated span 5.1-26 m."""
DEPTH_RATIO = 2.0
"""A depth's offset is material when lag 0 leaves twice its residual variance, whatever its
share of the depth's changes: a steady dive's changes are its rate, which a few seconds' shift
hardly moves (A-KIT 9, 30 m, stamped 5 s late: a share of 0.12, a ratio of 4.3, and the run
1745 m off), while right stamps give a ratio of 1 (their least variance at lag 0)."""
DIVE_WINDOW_S = 60.0
"""Window of the depth's running median (s) whose span :data:`MIN_DIVE_M` judges."""
CLIP_SIGMAS = 20.0
"""A DVL's or a depth's changes are clipped this many of ``sqrt(σ_MAD² + s_b²)`` from their
median (:meth:`Reference.robust`): the demo's DVL outliers of 0.5-3 m/s against its motion's
0.01-0.03 m/s a period. Tighter bounds clip the motion too, in the DVL's noisy stretches (3-10
× its σ): the slope of right stamps was 0.81-0.91 at 6, 0.85-0.93 at 10, 0.90-0.95 at 20 on
demo seeds 1-3."""
MIN_PERIODS = 2.0
"""An offset within this many of the sensor's periods (or within ±1 s) is not refused."""


@dataclass(frozen=True)
class ClockOffset:
    """A reference's time offset ``offset_s`` ± ``se_s`` against the IMU (> 0: its stamps are
    late), the slope ``k`` there and ``k_zero`` fitted at lag 0, the residual variance ratio
    ``ratio`` (lag 0 with the slope ``k``, over the offset), the ``share`` of the rotation's
    variance lag 0 misses beyond the offset, the intervals ``n`` and ``n_eff`` of them
    independent (module docstring), and ``min_ratio``, a ratio that makes the offset material
    whatever its share (a depth's: :data:`DEPTH_RATIO`)."""

    offset_s: float
    se_s: float
    k: float
    k_zero: float
    ratio: float
    share: float
    n: int
    n_eff: float
    min_ratio: float = math.inf

    @property
    def log_lr(self) -> float:
        """``N_eff ln V``: the likelihood ratio statistic of the offset against lag 0."""
        return self.n_eff * math.log(max(self.ratio, 1e-300))

    def decisive(self) -> bool:
        """The offset beats lag 0 decisively at a right axis's slope (module docstring)."""
        lo, hi = SLOPE_BAND
        return (
            (self.share >= MIN_SHARE or self.ratio >= self.min_ratio)
            and self.log_lr >= MIN_LOG_LR
            and lo <= self.k <= hi
            and abs(self.offset_s) > CONFIDENCE * self.se_s
        )

    @property
    def alias(self) -> bool:
        """The slope at the offset lies more than :data:`SLOPE_SURE` from 1: the stamps are off,
        but the offset found may be an alias of the true one (a wave period away, or the true
        one beyond ±:data:`MAX_OFFSET_S`)."""
        return abs(self.k - 1.0) > SLOPE_SURE

    def beyond(self, period_s: float) -> bool:
        """The offset lies beyond ``max(axes.MAX_LAG_S, MIN_PERIODS × period_s)``."""
        return abs(self.offset_s) > max(axes.MAX_LAG_S, MIN_PERIODS * period_s)


@dataclass(frozen=True)
class Series:
    """The IMU's side of a scan: a cumulative series ``values`` (n, m) at times ``t`` (n,)
    whose changes the reference's m columns follow (the gyro's integral about an axis; the
    DVL's velocity predicted by the accelerometers and the gyro, mission/dvl_axes.py; a depth
    integrated from the DVL's vertical velocity), and ``noise``, the variance per second of
    its changes (ARW², VRW², ...), below which a change decides nothing."""

    t: Array
    values: Array
    noise: float

    @property
    def dt(self) -> float:
        """The series' mean spacing (s)."""
        return float(self.t[-1] - self.t[0]) / max(self.t.size - 1, 1)


@dataclass(frozen=True)
class Reference:
    """The reference's changes ``a`` (m columns, grid intervals) over a grid from ``t0`` by
    ``step`` (its period), ``m`` (grid intervals) 1 where they count (0 over a gap): the sensor's
    side of the fit ``a_k = k b_k(τ) + c`` (module docstring). Built by :meth:`of` from readings,
    or directly from changes already on a grid (mission/gnss_clock.py's window means)."""

    t0: float
    step: float
    a: Array
    m: Array

    @classmethod
    def of(cls, t: Array, values: Array, imu_dt: float) -> Reference:
        """The readings ``values`` (n, m) at ``t`` interpolated linearly onto the grid."""
        period = float(np.median(np.diff(t)))
        step = max(period, imu_dt, MIN_STEP_S)
        g = t[0] + step * np.arange(int((t[-1] - t[0]) / step) + 1)
        a = np.diff(np.stack([np.interp(g, t, v) for v in values.T]), axis=1)
        # The reading interval that holds each grid interval's end: a long one is a gap.
        i = np.clip(np.searchsorted(t, g[1:]), 1, t.size - 1)
        m = (t[i] - t[i - 1] <= GAP_PERIODS * period).astype(float)
        return cls(float(t[0]), step, a * m, m)

    def without_holes(self, t: Array, span: float) -> Reference:
        """Without the intervals whose lags within ±``span`` reach a hole of the series'
        stamps ``t``: an interval longer than :data:`adaptnav.mission.axes.IMU_HOLE_S` and
        :data:`GAP_PERIODS` of the series' median spacing (IMU samples lost, bridged by the
        loader's repair at a rate assumed; a DVL's gap under a depth's series), across which
        the series' change is a ramp. The same intervals are left out at every lag, as
        :meth:`robust` leaves the ends (since 0.4.13: up to 0.4.12 the demo with 60 s of IMU
        lost at 830 s and ``imu.max_gap_s`` raised was refused: its inclinometer "stamped
        54.9 s after its readings")."""
        gaps = np.diff(t)
        # A hole is longer than IMU_HOLE_S whatever the spacing: the median (a sort of a day of
        # IMU stamps) only where some interval is.
        if not np.any(gaps > axes.IMU_HOLE_S):
            return self
        i = np.flatnonzero(gaps > max(axes.IMU_HOLE_S, GAP_PERIODS * float(np.median(gaps))))
        if not i.size:
            return self
        g = self.t0 + self.step * np.arange(self.a.shape[1] + 1)
        start, end = t[i], t[i + 1]  # disjoint and in order: the last starting before an
        k = np.searchsorted(start, g[1:] + span, side="left")  # interval's end is the only
        hit = (k > 0) & (end[np.maximum(k - 1, 0)] > g[:-1] - span)  # one reaching its start
        m = self.m * ~hit
        return Reference(self.t0, self.step, self.a * m, m)

    def robust(self, t: Array, theta: Array, max_offset_s: float) -> Reference:
        """Only the intervals the IMU's ``t`` covers at every lag within ±``max_offset_s`` (the
        same intervals judged at each lag: a stretch of larger noise at one end would otherwise
        favour the lags that slide it out), each column's changes clipped about their median
        at :data:`CLIP_SIGMAS` × ``sqrt(σ_MAD² + s_b²)``: their robust σ (1.4826 MAD; a DVL's
        noise, which can be a tenth of its motion's) with the spread ``s_b`` of the IMU's
        changes of ``theta`` at lag 0 (the motion's, free of the sensor's outliers)."""
        g = self.t0 + self.step * np.arange(self.a.shape[1] + 1)
        m = self.m * ((g[:-1] - max_offset_s >= t[0]) & (g[1:] + max_offset_s <= t[-1]))
        use = m > 0.0
        if not np.any(use):
            return Reference(self.t0, self.step, self.a * m, m)
        mid = np.median(self.a[:, use], axis=1, keepdims=True)
        mad = np.median(np.abs(self.a[:, use] - mid), axis=1, keepdims=True)
        spread = np.std(self.imu(t, theta, 0.0)[0][:, use], axis=1, keepdims=True)
        bound = CLIP_SIGMAS * np.hypot(1.4826 * mad, spread)
        return Reference(self.t0, self.step, np.clip(self.a, mid - bound, mid + bound) * m, m)

    def imu(self, t: Array, theta: Array, tau: float, lags: int = 0) -> tuple[Array, Array]:
        """The IMU's changes (m, intervals) of the columns of ``theta`` (n, m) over the grid's
        intervals taken ``tau`` earlier, the grid extended by ``lags`` steps either way, and 1
        where the IMU covers them."""
        ge = self.t0 - tau + self.step * np.arange(-lags, self.a.shape[1] + 1 + lags)
        inside = (ge >= t[0]) & (ge <= t[-1])
        covered = (inside[1:] & inside[:-1]).astype(float)
        b = np.diff(np.stack([np.interp(ge, t, v) for v in theta.T]), axis=1)
        return b * covered, covered


@dataclass(frozen=True)
class Scan:
    """At each lag ``tau`` (s, ascending, evenly spaced, ±``max_offset_s`` and
    :data:`EDGE_LAGS` spacings past it) the count N and the sums over the columns of the
    centred Σ (a - ā)², Σ (a - ā)(b - b̄), Σ (b - b̄)² of the fit ``a = k b + c`` (one slope, a
    constant per column), from six FFT correlations a column and phase (module docstring)."""

    tau: Array
    n: Array
    saa: Array
    sab: Array
    sbb: Array

    @classmethod
    def of(cls, ref: Reference, t: Array, theta: Array, max_offset_s: float) -> Scan:
        """Every lag j h + φ within ±``max_offset_s``: per phase φ (a grid coarser than
        :data:`MAX_STEP_S`, a GNSS course's, is tried at phases that far apart) six
        correlations a column over the lags j, and :data:`EDGE_LAGS` spacings past them."""
        phases = _phases(ref.step)
        span = _span(ref.step, max_offset_s)
        lags = math.ceil(span / ref.step)
        x = np.vstack([np.stack([a, a**2, a, ref.m, ref.m, ref.m]) for a in ref.a])
        rows = []
        for p in range(phases):
            phase = p * ref.step / phases
            b, mi = ref.imu(t, theta, phase, lags)
            y = np.vstack([np.stack([c, mi, mi, mi, c, c**2]) for c in b])
            sums = _correlate(x, y)[:, ::-1].reshape(ref.a.shape[0], 6, -1)
            tau = phase + ref.step * np.arange(-lags, lags + 1)
            rows.append(np.concatenate([np.broadcast_to(tau, sums[:, :1].shape), sums], axis=1))
        both = np.concatenate(rows, axis=2)
        tau, sab, saa, sa, n, sb, sbb = both[:, :, np.argsort(both[0, 0])].transpose(1, 0, 2)
        keep = np.abs(tau[0]) <= span + 1e-9
        n = np.round(n)
        with np.errstate(divide="ignore", invalid="ignore"):
            centred = (n, saa - sa**2 / n, sab - sa * sb / n, sbb - sb**2 / n)
        return cls(tau[0][keep], *(v.sum(axis=0)[keep] for v in centred))


def _phases(step: float) -> int:
    """The phases a grid of ``step`` is scanned at, :data:`MAX_STEP_S` apart at most."""
    # A 1-Hz sensor whose clock runs a little slow (1.0002 s) is not split into two phases.
    return max(1, math.ceil(step / MAX_STEP_S - 0.05))


def _span(step: float, max_offset_s: float) -> float:
    """The lags a scan of a grid of ``step`` reaches either way: ``max_offset_s`` and
    :data:`EDGE_LAGS` of its spacings past it, so that an offset of exactly ±``max_offset_s``
    (a ``latency_s`` of 60 s on right stamps) has neighbours either side for its parabola."""
    return max_offset_s + EDGE_LAGS * step / _phases(step)


def _correlate(x: Array, y: Array) -> Array:
    """``out[:, s] = Σ_q x[:, q] y[:, q + s]`` for s = 0 .. y's length - x's (row by row): the
    circular correlation of a real FFT as long as y (a power of two), where no product wraps.
    Reversed, index ``lags + j`` pairs reference interval q with the IMU's q - j."""
    size = 1 << (y.shape[1] - 1).bit_length()
    spectrum = np.conj(np.fft.rfft(x, size, axis=1)) * np.fft.rfft(y, size, axis=1)
    return np.asarray(np.fft.irfft(spectrum, size, axis=1)[:, : y.shape[1] - x.shape[1] + 1])


def clock_offset(
    gyro: axes.Gyro, axis: int, t: Array, angle: Array, max_offset_s: float = MAX_OFFSET_S
) -> ClockOffset | None:
    """The time offset of the readings ``angle`` (rad) at ``t`` against the gyro's ``axis``
    (module docstring): :func:`series_offset` of the angle, unwrapped, against the gyro's
    integral. None: too few readings, or at lag 0 the fit undecided (the IMU's changes not
    :data:`adaptnav.mission.axes.SIGNAL_FACTOR` times their own noise: a vehicle that does not
    turn has no clock to read)."""
    ok = np.isfinite(t) & np.isfinite(angle)
    if np.count_nonzero(ok) <= axes.MIN_INTERVALS:
        return None
    theta = gyro.theta[:, axis : axis + 1]
    series = Series(gyro.t, theta, gyro.arw**2)
    return series_offset(series, t[ok], np.unwrap(angle[ok])[:, None], max_offset_s)


def series_offset(
    series: Series,
    t: Array,
    values: Array,
    max_offset_s: float = MAX_OFFSET_S,
    robust: bool = False,
) -> ClockOffset | None:
    """The time offset of the readings ``values`` (n, m) at ``t`` against the IMU-side
    ``series``'s columns (module docstring; m > 1: one slope for all the columns, a constant
    each). ``robust`` (a DVL's, a depth's): :meth:`Reference.robust`, and only lags with a
    positive slope (a yo-yo's depth half a period off fits inverted as well as at its offset;
    a negated sensor is the axis or sign checks' finding). None: too few finite readings, or
    the fit undecided at lag 0 (the series' changes not
    :data:`adaptnav.mission.axes.SIGNAL_FACTOR` times their noise)."""
    ok = np.isfinite(t) & np.all(np.isfinite(values), axis=1)
    t, values = t[ok], values[ok]
    if t.size <= axes.MIN_INTERVALS:
        return None
    ref = Reference.of(t, values, series.dt)
    ref = ref.without_holes(series.t, _span(ref.step, max_offset_s))
    theta = np.ascontiguousarray(series.values)  # one copy of the columns, not one a phase
    if robust:
        ref = ref.robust(series.t, theta, _span(ref.step, max_offset_s))
        if _still(ref, series, theta):  # the scan's own test at lag 0, before its FFTs
            return None
    cols = ref.a.shape[0]
    scan = Scan.of(ref, series.t, theta, max_offset_s)
    n, saa, sab, sbb = scan.n, scan.saa, scan.sab, scan.sbb
    with np.errstate(divide="ignore", invalid="ignore"):
        k = sab / sbb
        rss = np.maximum(saa - sab * k, 0.0)
    noise = series.noise * ref.step
    valid = (n >= max(axes.MIN_INTERVALS, 0.5 * cols * float(ref.m.sum()))) & (
        sbb > axes.SIGNAL_FACTOR * noise * n
    )
    zero = int(np.argmin(np.abs(scan.tau)))
    if not valid[zero]:
        return None
    valid &= (k > 0.0) | (not robust)
    # Degrees of freedom: the slope and a constant per column.
    var = np.where(valid, rss / np.maximum(n - 1.0 - cols, 1.0), np.inf)
    j = int(np.argmin(var))
    shift, curvature = parabola(rss, j)
    h = float(scan.tau[1] - scan.tau[0]) if scan.tau.size > 1 else ref.step
    sigma2 = float(rss[j]) / max(float(n[j]) - 2.0 - cols, 1.0)
    se = math.sqrt(2.0 * sigma2 / curvature) * h if curvature > 0.0 else math.inf
    both = _Both.of(ref, series.t, theta, float(scan.tau[j]))
    se = max(se * math.sqrt(float(n[j]) / both.n_eff), h / math.sqrt(12.0))
    return ClockOffset(
        offset_s=float(scan.tau[j]) + shift * h,
        se_s=se,
        k=both.k,
        k_zero=float(k[zero]),
        ratio=both.var0 / both.var if both.var > 0.0 else math.inf,
        share=(both.var0 - both.var) / both.signal if both.signal > 0.0 else 0.0,
        n=both.n,
        n_eff=both.n_eff,
    )


@dataclass(frozen=True)
class _Both:
    """The fit at the offset τ̂ and lag 0 judged on the same intervals, those the IMU covers
    at both (module docstring): the slope ``k`` at τ̂ (one for every column, a constant each),
    the residual variances ``var`` there and ``var0`` at lag 0 with that slope, the rotation's
    ``signal`` ``k² Σ (b - b̄)² / N``, the count ``n`` (over the columns) and ``n_eff`` of them
    independent. Up to 0.4.11 lag 0 was judged on every interval and τ̂ on those it covers: a
    last 10 s of an inclinometer pegged at 90°, left out only at τ̂ = -18 s, made that a clock
    offset decisively better than lag 0."""

    k: float
    var: float
    var0: float
    signal: float
    n: int
    n_eff: float

    @classmethod
    def of(cls, ref: Reference, t: Array, theta: Array, tau: float) -> _Both:
        """From the reference's changes (m, intervals) and the IMU's columns ``theta`` (n, m)
        at ``tau`` and at 0 (direct sums: two lags, not a scan)."""
        b, covered = ref.imu(t, theta, tau)
        b0, covered0 = ref.imu(t, theta, 0.0)
        use = (ref.m * covered * covered0) > 0.0
        a, b, b0 = ref.a[:, use], b[:, use], b0[:, use]
        cols, n = a.shape[0], int(a.size)
        if a.shape[1] < 3:
            return cls(math.nan, 0.0, 0.0, 0.0, n, float(n))
        a = a - a.mean(axis=1, keepdims=True)
        bc = b - b.mean(axis=1, keepdims=True)
        b0c = b0 - b0.mean(axis=1, keepdims=True)
        sbb = float(np.sum(bc * bc))
        k = float(np.sum(a * bc)) / sbb if sbb > 0.0 else math.nan
        r = a - k * bc
        r0 = a - k * b0c
        # Degrees of freedom: the slope and a constant per column (lag 0's slope is given).
        var = float(np.sum(r * r)) / max(n - 1 - cols, 1)
        var0 = float(np.sum(r0 * r0)) / max(n - cols, 1)
        return cls(k, var, var0, k * k * sbb / n, n, n_eff(r))


def _still(ref: Reference, series: Series, theta: Array) -> bool:
    """At lag 0, the series' changes over the intervals judged are too few or not
    :data:`adaptnav.mission.axes.SIGNAL_FACTOR` times their noise (a vehicle at rest): what
    :func:`series_offset` finds at lag 0 after its scan, from direct sums (make bench's day at
    rest: the DVL's scan of 259 k readings, 1.5 s, left out)."""
    b, covered = ref.imu(series.t, theta, 0.0)
    use = (ref.m * covered) > 0.0
    n = float(np.count_nonzero(use)) * b.shape[0]
    if n < max(axes.MIN_INTERVALS, 0.5 * b.shape[0] * float(ref.m.sum())):
        return True
    centred = b[:, use] - b[:, use].mean(axis=1, keepdims=True)
    return bool(
        float(np.sum(centred * centred)) <= axes.SIGNAL_FACTOR * series.noise * ref.step * n
    )


def dvl_offset(
    blocks: dvl_axes.Blocks, dvl: dvl_axes.Readings, vrw: float, max_offset_s: float = MAX_OFFSET_S
) -> ClockOffset | None:
    """The time offset of a DVL's readings against the velocity the IMU predicts for them
    (:func:`series_offset`, the three axes with one slope): ``U + ω × l`` at the blocks'
    edges, turned into the DVL's axes (:func:`adaptnav.mission.dvl_axes.velocity_integral`),
    whose changes a right DVL's velocity changes follow with k ≈ 1; ``vrw``: the
    accelerometers' velocity random walk (m/s/√s). The prediction's centripetal and gravity
    terms take the DVL's own readings: an offset beyond ±:data:`adaptnav.mission.axes.MAX_LAG_S`
    is scanned again with them at their stamps less the offset (a DVL 18 s late on A-KIT 1
    fits at 18.0 s with k 0.74 at its stamps, 0.9-1 so). None: undecided (a vehicle at
    rest)."""
    if dvl.t.size <= axes.MIN_INTERVALS or blocks.h.size < 2:
        return None
    found = _dvl_scan(blocks, dvl, vrw, 0.0, max_offset_s)
    if found is None or abs(found.offset_s) <= axes.MAX_LAG_S:
        return found
    return _dvl_scan(blocks, dvl, vrw, found.offset_s, max_offset_s) or found


def _dvl_scan(
    blocks: dvl_axes.Blocks, dvl: dvl_axes.Readings, vrw: float, late_s: float, max_offset_s: float
) -> ClockOffset | None:
    """:func:`dvl_offset`'s scan, the prediction made with the readings taken ``late_s``
    before their stamps."""
    edges, u = dvl_axes.velocity_integral(blocks, dvl.t - late_s, dvl.body(), dvl.lever)
    rate = blocks.dtheta / blocks.h[:, None]
    w = np.column_stack([np.interp(edges, blocks.mid, rate[:, k]) for k in range(3)])
    series = Series(edges, dvl.to_sensor(u + np.cross(w, dvl.lever)), vrw**2)
    return series_offset(series, dvl.t, dvl.v_s, max_offset_s, robust=True)


def depth_offset(
    t: Array,
    depth: Array,
    dvl: scales.Dvl,
    tilt: axes.AccelTilt,
    lever_m: Array,
    max_offset_s: float = MAX_OFFSET_S,
) -> ClockOffset | None:
    """The time offset of a depth meter's readings ``depth`` (m) at ``t`` against the DVL's
    vertical displacement, ``W(t) = ∫ (C_nb v_b)_down dt`` with the accelerometers' levelled
    tilt (the integral of mission/scales.py's depth scale check), with the depth's lever arm
    ``lever_m`` (its own less the DVL's, body, m) turned down by the tilt at the same instants
    and added: it moves with the vehicle's attitude, so with the lag (taken off the readings
    at their stamps instead, it is turned by the tilt of a time τ off when they are off: on
    A-KIT 9, 1.84 m forward, stamps 5 and 18 s late and 10 s early then read 4.63, 17.70 and
    10.34 s, against 5.08, 18.11 and 9.92 s so). The DVL's own noise, ``σ² T`` a second
    (period T), is the series' noise: a vehicle whose depth changes less is undecided (None),
    and so is one whose depth's running median over :data:`DIVE_WINDOW_S` spans less than
    :data:`MIN_DIVE_M` (a vehicle that does not dive)."""
    ok = np.isfinite(t) & np.isfinite(depth)
    t, depth = t[ok], depth[ok]
    if dvl.t.size <= axes.MIN_INTERVALS or t.size <= axes.MIN_INTERVALS:
        return None
    size = max(1, round(DIVE_WINDOW_S / float(np.median(np.diff(t)))))
    if float(np.ptp(median_filter(depth, size=size, mode="nearest"))) < MIN_DIVE_M:
        return None
    roll, pitch = scales.tilt_at(tilt, dvl.t)
    w = scales.integral(dvl.t, scales.down(dvl.v_b, roll, pitch))
    lever = np.broadcast_to(np.asarray(lever_m, dtype=float), (dvl.t.size, 3))
    arm = scales.down(lever, roll, pitch)
    series = Series(dvl.t, (w + arm)[:, None], dvl.sigma**2 * dvl.period)
    found = series_offset(series, t, depth[:, None], max_offset_s, robust=True)
    return None if found is None else replace(found, min_ratio=DEPTH_RATIO)


def parabola(rss: Array, j: int) -> tuple[float, float]:
    """The vertex's shift (grid steps) of the parabola through ``rss`` at j - 1, j, j + 1,
    ``(RSS_{j-1} - RSS_{j+1}) / (2 RSS'')`` clipped to ±1/2, and its second difference
    ``RSS'' = RSS_{j-1} - 2 RSS_j + RSS_{j+1}`` (0 at the edge or where it does not open upward):
    the offset between grid points and its σ's curvature (module docstring)."""
    if j == 0 or j == rss.size - 1 or not np.all(np.isfinite(rss[j - 1 : j + 2])):
        return 0.0, 0.0
    lo, mid, hi = (float(v) for v in rss[j - 1 : j + 2])
    curvature = lo - 2.0 * mid + hi
    if curvature <= 0.0:
        return 0.0, 0.0
    return float(np.clip(0.5 * (lo - hi) / curvature, -0.5, 0.5)), curvature


def n_eff(r: Array) -> float:
    """The count of residuals ``r`` (a column's, or m columns' as (m, N)) shrunk by their
    lag-one correlation ρ (within each column, pooled) when positive: ``N (1 - ρ) / (1 + ρ)``
    (module docstring; a complex residual is its real and imaginary parts as two columns)."""
    r = np.atleast_2d(r)
    r = r - r.mean(axis=1, keepdims=True)
    # Sums of products, not ``@``: a BLAS dot wakes its threads, 10 ms each on a busy machine.
    denom = float(np.sum(r * r))
    rho = float(np.sum(r[:, 1:] * r[:, :-1])) / denom if denom > 0.0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    return float(r.size) * (1.0 - rho) / (1.0 + rho)
