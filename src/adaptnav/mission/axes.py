"""Cross-checks of the IMU's axes against the aiding sensors that see rotation.

An IMU logged with one axis's sign flipped, two axes swapped, or rates in deg/s where rad/s are
declared passes every check on its own table: the values are plausible, only wrong. The filter
then runs to a state far off without a word (the demo with its gyro z negated: 308 m off, exit
0, up to 0.4.9). The sensors that measure an angle see it: between two readings a heading sensor
shows the yaw change Δψ, an inclinometer the roll and pitch changes, a GNSS receiver's track the
change of course; the gyro's matching axis integrates about the same angle over the same
interval (docs/robustness.md, 'IMU axes').

For each pair (reference angle, gyro axis) :func:`axis_slope` fits, over the intervals between
consecutive reference readings (for GNSS: between consecutive chords of the track),

    a_i = k b_i + c Δt_i,        b_i = ∫ ω_j dt over the interval,

where a_i is the reference's angle change (wrapped to [-π, π)), ω_j the gyro's axis j turned
into the sensor's frame (ω_s = C_sb ω_b, the sensor's mounting rotation), and c absorbs a
constant gyro bias. The fit is robust: intervals whose residual lies beyond 5 σ (σ from the
median absolute deviation) are left out, three times over, so that spikes and wrapped angles
do not decide. Its standard error is ``se = sqrt(Σ r² / (n - 2) / Σ (b - b̄_Δt)²)``.

A right axis gives k ≈ 1: the reference angles' rates are the gyro's for small roll and pitch
(Euler rates, Groves eq. 2.58: ψ̇ = (ω_y sin φ + ω_z cos φ) / cos θ, φ̇ ≈ ω_x, θ̇ ≈ ω_y), and a
magnetic compass's deviation or a GNSS track's drift angle change it by a few per cent. A
flipped sign gives k ≈ -1, a swapped axis k ≈ 0, rates in deg/s read as rad/s k ≈ 1/57.3.
The rule: an axis is refused when ``k + 4 se < 0.5`` at every lag τ in
[-:data:`MAX_LAG_S`, +:data:`MAX_LAG_S`] tried between the reference's stamps and the IMU's:
with 4-σ confidence the axis shows less than half of the reference's rotation, none, or the
opposite, even allowing the reference an unmodelled latency of up to a second (a latency of a
quarter of a wave period would otherwise turn an oscillation's k to 0). Where the vehicle does
not turn enough for the fit to decide (se large) nothing is said, and a fit decides only when
the spread of the IMU's changes is :data:`SIGNAL_FACTOR` times the variance of their own noise
(the gyro's ARW): a still vehicle's gyro noise against a sensor's noise gives k ≈ 0 with a small
se over many intervals, which would read as a swapped axis.

An inclinometer's roll and pitch are fitted the same way on the accelerometers' levelled roll
and pitch as well (:class:`AccelTilt`, 0.1-s means, their noise from the VRW): an accelerometer
axis flipped or swapped shows there. When the gyro and the accelerometers both fail against
one inclinometer angle, the inclinometer is blamed (its sign, unit, or roll and pitch swapped).

Pure NumPy, no I/O: :func:`adaptnav.mission.loader.load_mission` calls :func:`check_axes` and
turns a finding into a MissionError naming the IMU file and column.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from adaptnav.core import earth

Array = NDArray[np.float64]

MIN_SLOPE = 0.5
"""The fewest of the reference's radians a gyro axis may show per radian (module docstring)."""
CONFIDENCE = 4.0
"""Standard errors the slope's interval spans above its estimate before it is judged."""
MAX_LAG_S = 1.0
"""Largest unmodelled latency of a reference the rule allows for (s)."""
LAG_STEP_S = 0.1
"""Step of the lags tried (s)."""
MIN_INTERVALS = 20
"""Fewest intervals a fit needs."""
SIGNAL_FACTOR = 10.0
"""How many times the variance of its own noise the spread of an IMU angle's changes must be
for a fit to decide (:func:`axis_slope`)."""
OUTLIER_SIGMAS = 5.0
"""Residuals beyond this many robust σ are left out of the fit."""
CHORD_SIGMAS = 20.0
"""A GNSS chord is long enough for its course when it spans this many position σ: the course
then has a σ of about sqrt(2) / 20 rad (4°)."""
MAX_CHORD_S = 60.0
"""Longest time a GNSS chord may span (s)."""
TILT_BLOCK_S = 0.1
"""Length of the blocks the accelerometers are averaged over for their tilt (s)."""
TILT_GRAVITY = 9.8
"""Gravity the accelerometers' noise is scaled by into an angle (m/s²)."""
IMU_HOLE_S = 1.0
"""An IMU interval longer than this (s) is a hole (samples lost, the next row's increments
stretched over it by the loader: a constant rate assumed, which a turning vehicle's rotation
is not); the reference intervals that overlap one are left out of the axis fit."""


@dataclass(frozen=True)
class Slope:
    """The fitted slope ``k`` of a reference's angle changes on the IMU's, its standard error
    ``se``, the intervals kept ``n`` and the lag ``lag_s`` it was taken at."""

    k: float
    se: float
    n: int
    lag_s: float

    @property
    def upper(self) -> float:
        """``k + CONFIDENCE se``: the most of the reference's rotation the axis may show."""
        return self.k + CONFIDENCE * self.se


Instrument = Literal["gyro", "accelerometer", "reference"]
"""Which side a finding blames: the IMU's gyro or accelerometer axis, or the aiding sensor."""


@dataclass(frozen=True)
class AxisFinding:
    """An ``instrument`` whose angle does not follow the other's: the IMU's ``axis`` (0, 1, 2:
    x, y, z of the body) against ``reference``'s ``angle`` (yaw, roll, pitch or course), the
    :class:`Slope` at the lag that suits the IMU best (what the rule judges), over
    ``t_from``-``t_to``. ``instrument`` "reference": the gyro and the
    accelerometers agree with each other and both disagree with the sensor."""

    instrument: Instrument
    axis: int
    reference: str
    angle: str
    slope: Slope
    at_zero: Slope
    """The slope with the reference's stamps as they are (lag 0)."""
    t_from: float
    t_to: float

    def cause(self) -> str:
        """What the slope points to, in words."""
        k, se = self.at_zero.k, self.at_zero.se
        deg = 180.0 / math.pi  # a unit slip of degrees and radians: k = 1 / 57.3
        if self.instrument == "reference":
            if k < -MIN_SLOPE:
                return (
                    f"the gyro and the accelerometers agree, the sensor's {self.angle} turns the "
                    "opposite way: is its sign flipped, or its mounting_rpy_deg not set?"
                )
            if abs(k * deg - 1.0) + CONFIDENCE * se * deg < 0.5:
                return (
                    f"the gyro and the accelerometers agree, the sensor's {self.angle} turns "
                    f"{1.0 / k:.3g} times less: radians where degrees are read (_deg columns)?"
                )
            return (
                f"the gyro and the accelerometers agree, the sensor's {self.angle} does not "
                "follow them: are its roll and pitch swapped, or in the wrong unit?"
            )
        other = " (or the reference's sense)" if self.angle in ("yaw", "course") else ""
        # Since 0.4.13: a GNSS's coordinates swapped or a hemisphere's sign lost mirror its
        # track, so that its course turns the other way, or not with the gyro at all.
        mirror = (
            " Or is the GNSS's track mirrored: latitude and longitude swapped, or a "
            "hemisphere's sign (E/W, N/S) lost?"
            if self.angle == "course"
            else ""
        )
        if k < -MIN_SLOPE:
            if self.instrument == "accelerometer":
                return (
                    "it turns the opposite way: is an axis's sign flipped (y or z for the roll, "
                    "x for the pitch), or are y and z swapped?"
                )
            return f"it turns the opposite way: is the axis's sign flipped{other}?{mirror}"
        if self.instrument == "gyro" and abs(k * deg - 1.0) + CONFIDENCE * se * deg < 0.5:
            return (
                f"it turns {1.0 / k:.3g} times as far as the reference: rates in deg/s "
                "where rad/s are read?"
            )
        return (
            "it does not turn with the reference: are two axes swapped, or the sensor's stamps "
            f"off by more than a second (latency_s)?{mirror}"
        )


def axis_slope(
    a: Array, b: Array, dt: Array, lag_s: float = 0.0, noise_var: Array | None = None
) -> Slope | None:
    """The robust fit ``a = k b + c dt`` of the module's docstring (None: too few intervals, or
    the IMU's angle changes ``b`` not above their own noise: with ``noise_var`` (n,) the
    variance of each ``b_i``'s noise, their spread must be :data:`SIGNAL_FACTOR` times the
    noise's, else a still vehicle's noise against the reference's would look like a swapped
    axis)."""
    ok = np.isfinite(a) & np.isfinite(b) & np.isfinite(dt)
    nv = np.zeros(int(ok.sum())) if noise_var is None else np.asarray(noise_var, float)[ok]
    a, design = a[ok], np.column_stack([b[ok], dt[ok]])
    keep = np.ones(a.size, dtype=bool)
    for _ in range(3):
        if np.count_nonzero(keep) < MIN_INTERVALS:
            return None
        coef = np.linalg.lstsq(design[keep], a[keep], rcond=None)[0]
        r = a - design @ coef
        s = 1.4826 * float(np.median(np.abs(r[keep] - np.median(r[keep]))))
        keep = np.abs(r) <= OUTLIER_SIGMAS * s + 1e-15
    n = int(np.count_nonzero(keep))
    if n < MIN_INTERVALS:
        return None
    coef = np.linalg.lstsq(design[keep], a[keep], rcond=None)[0]
    bb, tt = design[keep, 0], design[keep, 1]
    # The spread of b left once the bias term has taken its share (b's component along dt).
    spread = float(bb @ bb - (bb @ tt) ** 2 / (tt @ tt))
    if spread <= SIGNAL_FACTOR * float(nv[keep].sum()) or spread <= 0.0:
        return None
    res = a[keep] - design[keep] @ coef
    se = math.sqrt(float(res @ res) / max(n - 2, 1) / spread)
    return Slope(float(coef[0]), se, n, lag_s)


def wrap(angle: Array) -> Array:
    """Angles wrapped to [-π, π)."""
    return np.asarray((angle + math.pi) % (2.0 * math.pi) - math.pi, dtype=float)


@dataclass(frozen=True)
class Gyro:
    """The gyro's integral ``theta`` (N + 1, 3), rad, at times ``t`` (N + 1,): the IMU's
    increments summed from the first interval's start, turned by ``C_sb``."""

    t: Array
    theta: Array
    arw: float = 0.0
    """The gyro's angle random walk (rad/√s): the noise of an angle change over Δt is
    ``arw √Δt``."""

    @classmethod
    def of(
        cls, t: Array, dt: Array, dtheta: Array, c_sb: Array | None = None, arw: float = 0.0
    ) -> Gyro:
        """From the IMU's intervals ``(t - dt, t]`` and increments (ImuData's arrays)."""
        level = c_sb is None or np.array_equal(c_sb, np.eye(3))
        d = dtheta if level else dtheta @ np.asarray(c_sb, dtype=float).T
        theta = np.empty((d.shape[0] + 1, 3))  # one array for a day of samples, not two
        theta[0] = 0.0
        np.cumsum(d, axis=0, out=theta[1:])
        return cls(np.concatenate([[t[0] - dt[0]], t]), theta, arw)

    def noise_var(self, dt: Array) -> Array:
        """Variance of the noise of the angle changes over intervals ``dt``: ``arw² Δt``."""
        return np.asarray(self.arw**2 * dt, dtype=float)

    @cached_property
    def holes(self) -> tuple[Array, Array]:
        """Starts and ends (s) of the IMU's intervals longer than :data:`IMU_HOLE_S`."""
        i = np.flatnonzero(np.diff(self.t) > IMU_HOLE_S)
        return self.t[i], self.t[i + 1]

    def across_hole(self, t0: Array, t1: Array) -> NDArray[np.bool_]:
        """Each interval (t0, t1] that overlaps a hole (:attr:`holes`, disjoint and in order:
        the last one starting before t1 is the only one that can reach past t0)."""
        start, end = self.holes
        if not start.size:
            return np.zeros(t0.shape, dtype=bool)
        k = np.searchsorted(start, t1, side="left")
        return np.asarray((k > 0) & (end[np.maximum(k - 1, 0)] > t0), dtype=bool)

    def in_hole(self, t: Array) -> NDArray[np.bool_]:
        """Each time ``t`` strictly inside a hole (:attr:`holes`): the IMU's angle there is the
        repair's, a straight line, not the vehicle's."""
        start, end = self.holes
        k = np.searchsorted(start, t, side="right") - 1
        return (
            np.asarray((k >= 0) & (t < end[np.maximum(k, 0)]), dtype=bool)
            if start.size
            else (np.zeros(t.shape, dtype=bool))
        )

    def window(self, t0: float, t1: float) -> Gyro:
        """The integral over the samples from just before ``t0`` to just after ``t1`` (views,
        no copy): a segment's fits interpolate in it, not in a day of samples."""
        i0 = max(int(np.searchsorted(self.t, t0, side="right")) - 1, 0)
        i1 = min(int(np.searchsorted(self.t, t1, side="left")) + 1, self.t.size)
        return Gyro(self.t[i0:i1], self.theta[i0:i1], self.arw)

    def change(self, t0: Array, t1: Array, axis: int) -> Array:
        """∫ ω_axis dt over each (t0, t1] (NaN where outside the IMU's span)."""
        inside = (t0 >= self.t[0]) & (t1 <= self.t[-1])
        col = self.theta[:, axis]
        out = np.interp(t1, self.t, col) - np.interp(t0, self.t, col)
        return np.where(inside, out, math.nan)


def _lags() -> Array:
    """The lags tried (s), from -MAX_LAG_S to +MAX_LAG_S by LAG_STEP_S."""
    n = round(MAX_LAG_S / LAG_STEP_S)
    return np.asarray(np.arange(-n, n + 1) * LAG_STEP_S, dtype=float)


def best_slope(
    imu: Gyro | AccelTilt, axis: int, t: Array, angle: Array
) -> tuple[Slope, Slope] | None:
    """The slope with the largest :attr:`Slope.upper` over the lags tried, and the slope at lag
    0, of the angle changes between consecutive readings ``angle`` at ``t`` on the IMU's
    ``axis`` (None: undecided at some lag, so nothing is said)."""
    ok = np.isfinite(t) & np.isfinite(angle)
    t, angle = t[ok], angle[ok]
    if t.size <= MIN_INTERVALS:
        return None
    a, dt = wrap(np.diff(angle)), np.diff(t)
    noise = imu.noise_var(dt)
    found: list[Slope] = []
    # Lag 0 first: a right axis passes there, and the others need not be tried.
    for lag in sorted(_lags(), key=abs):
        t0, t1 = t[:-1] - lag, t[1:] - lag
        b = imu.change(t0, t1, axis)
        if isinstance(imu, Gyro):
            # Up to 0.4.11 a 2-h hole's one stretched row (×720 000) was an interval whose
            # leverage set the fit's slope to 0: "the gyro's x axis does not turn".
            b = np.where(imu.across_hole(t0, t1), math.nan, b)
        s = axis_slope(a, b, dt, float(lag), noise)
        if s is None:
            return None
        found.append(s)
        if s.upper >= MIN_SLOPE:
            break
    return max(found, key=lambda x: x.upper), found[0]


def flatten(lat: Array, lon: Array) -> tuple[Array, Array]:
    """North and east (m) of fixes (rad) from the first, in its local level frame
    (:func:`adaptnav.core.earth.geodetic_to_ned` at zero height)."""
    r_n = earth.geodetic_to_ned(lat, lon, 0.0, float(lat[0]), float(lon[0]), 0.0)
    return np.asarray(r_n[:, 0], dtype=float), np.asarray(r_n[:, 1], dtype=float)


def course(t: Array, lat: Array, lon: Array, sigma_m: float) -> tuple[Array, Array]:
    """A GNSS track's course (rad from north) over consecutive chords at their middle times.

    Each chord spans readings i to i + m, m the fewest that cover :data:`CHORD_SIGMAS` σ at the
    track's median speed (at most :data:`MAX_CHORD_S`); a chord shorter than that (a stop) has
    a NaN course. The track is flattened in its first fix's local level frame."""
    ok = np.isfinite(t) & np.isfinite(lat) & np.isfinite(lon)
    t, lat, lon = t[ok], lat[ok], lon[ok]
    if t.size < 3:
        return np.empty(0), np.empty(0)
    north, east = flatten(lat, lon)
    step = np.hypot(np.diff(north), np.diff(east))
    speed = float(np.median(step / np.maximum(np.diff(t), 1e-9)))
    period = float(np.median(np.diff(t)))
    need = CHORD_SIGMAS * max(sigma_m, 1e-3)
    span = min(need / speed, MAX_CHORD_S) if speed > 0.0 else MAX_CHORD_S
    m = max(1, round(span / period))
    i = np.arange(0, t.size - m, m)
    j = i + m
    dn, de = north[j] - north[i], east[j] - east[i]
    chi = np.where(np.hypot(dn, de) >= need, np.arctan2(de, dn), math.nan)
    return 0.5 * (t[i] + t[j]), chi


@dataclass(frozen=True)
class Reference:
    """An aiding sensor's angle: ``name`` (the sensor), ``angle`` (its word), the body axis it
    turns about, its readings (times, radians) and its mounting ``c_sb`` (None: the body's).
    ``tilt``: the angle is an inclinometer's roll (0) or pitch (1), which the accelerometers
    level too (:class:`AccelTilt`); None for a yaw or course."""

    name: str
    angle: str
    axis: int
    t: Array
    value: Array
    c_sb: Array | None = None
    tilt: int | None = None


class ImuViews:
    """The IMU's gyro integral (:class:`Gyro`) and levelled accelerometers (:class:`AccelTilt`)
    in a sensor's frame, each built on first use and kept: the checks at load (this module's
    and mission/scales.py's) share them, so a day of samples is integrated once. ``noise``:
    the IMU's (ARW rad/√s, VRW m/s/√s), below which its angle changes decide nothing."""

    def __init__(
        self,
        t: Array,
        dt: Array,
        dtheta: Array,
        dvel: Array,
        noise: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        self._imu = (t, dt, dtheta, dvel)
        self._noise = noise
        self._gyros: dict[bytes, Gyro] = {}
        self._tilts: dict[bytes, AccelTilt] = {}

    @property
    def samples(self) -> tuple[Array, Array, Array, Array]:
        """The IMU's ``(t, dt, dtheta, dvel)`` as given (mission/dvl_axes.py sums its own
        blocks of them)."""
        return self._imu

    @property
    def noise(self) -> tuple[float, float]:
        """The IMU's (ARW rad/√s, VRW m/s/√s)."""
        return self._noise

    @staticmethod
    def _key(c_sb: Array | None) -> bytes:
        level = c_sb is None or np.array_equal(c_sb, np.eye(3))
        return b"" if level else np.asarray(c_sb, dtype=float).tobytes()

    def gyro(self, c_sb: Array | None = None) -> Gyro:
        """The gyro's integral turned by ``C_sb`` (None: the body's axes)."""
        key = self._key(c_sb)
        if key not in self._gyros:
            t, dt, dtheta, _ = self._imu
            self._gyros[key] = Gyro.of(t, dt, dtheta, c_sb, self._noise[0])
        return self._gyros[key]

    def tilt(self, c_sb: Array | None = None) -> AccelTilt:
        """The accelerometers' levelled roll and pitch, the specific force turned by ``C_sb``."""
        key = self._key(c_sb)
        if key not in self._tilts:
            t, dt, _, dvel = self._imu
            self._tilts[key] = AccelTilt.of(t, dt, dvel, c_sb, self._noise[1])
        return self._tilts[key]


DEAD_RATE = 1e-9
"""A gyro axis whose rate (Δθ / Δt) varies by no more than this over every sample (rad/s,
0.0002 °/h) reads nothing: a real gyro's noise and the earth's rate move it far more."""
DEAD_TURN_SIGMAS = 20.0
DEAD_TURN_RAD = math.radians(1.0)
"""A reference turns when its angle's 1st-99th percentile range spans this many of its σ and
at least this angle (white noise spans 4.7 σ; the rule holds only where the gyro reads nothing)."""


@dataclass(frozen=True)
class DeadAxis:
    """A gyro ``axis`` that reads the constant ``rate`` (rad/s) on every sample while a
    reference's angle turns through ``turn`` (rad, its 1st-99th percentile range)."""

    axis: int
    rate: float
    turn: float


def dead_axis(gyro: Gyro, axis: int, t: Array, angle: Array, sigma: float) -> DeadAxis | None:
    """The gyro's ``axis`` dead against a reference (readings ``angle`` at ``t``, noise σ
    ``sigma``, rad) that turns (:data:`DEAD_TURN_SIGMAS`, :data:`DEAD_TURN_RAD`). Such an axis
    decides no fit (its changes are not above their noise), so up to 0.4.11 the axis check said
    nothing and the DVL-axes check blamed the DVL for what the dead gyro x did to its
    prediction ("is the y axis negated?"); a dead z was silent."""
    rate = np.diff(gyro.theta[:, axis]) / np.diff(gyro.t)
    if rate.size < 2 or float(np.ptp(rate)) > DEAD_RATE:
        return None
    ok = np.isfinite(t) & np.isfinite(angle)
    if np.count_nonzero(ok) < MIN_INTERVALS:
        return None
    lo, hi = np.percentile(np.unwrap(angle[ok]), [1.0, 99.0])
    turn = float(hi - lo)
    if turn < max(DEAD_TURN_SIGMAS * sigma, DEAD_TURN_RAD):
        return None
    return DeadAxis(axis, float(np.median(rate)), turn)


def check_axes(views: ImuViews, references: list[Reference]) -> Iterator[AxisFinding]:
    """Every reference whose angle the gyro's matching axis, or for a tilt the accelerometers'
    levelling, does not follow (the rule of the module's docstring), in the order given. A
    tilt that neither follows blames the reference (:class:`AxisFinding`)."""
    for ref in references:
        found: list[tuple[Instrument, tuple[Slope, Slope]]] = []
        s = best_slope(views.gyro(ref.c_sb), ref.axis, ref.t, ref.value)
        if s is not None and s[0].upper < MIN_SLOPE:
            found.append(("gyro", s))
        if ref.tilt is not None:
            a = best_slope(views.tilt(ref.c_sb), ref.tilt, ref.t, ref.value)
            if a is not None and a[0].upper < MIN_SLOPE:
                found.append(("accelerometer", a))
        if not found:
            continue
        inst: Instrument = "reference" if len(found) == 2 else found[0][0]
        best, zero = found[0][1]
        yield AxisFinding(
            inst, ref.axis, ref.name, ref.angle, best, zero, float(ref.t[0]), float(ref.t[-1])
        )


@dataclass(frozen=True)
class AccelTilt:
    """Roll and pitch ``angles`` (m, 2), rad, levelled from the accelerometers' means over
    blocks of about :data:`TILT_BLOCK_S` (times ``t`` their middles), the specific force turned
    by ``C_sb``: ``φ = atan2(-f_y, -f_z)``, ``θ = atan2(f_x, sqrt(f_y² + f_z²))`` (the coarse
    levelling of engine/align.py, what a pendulum inclinometer reads)."""

    t: Array
    angles: Array
    block_sigma: float = 0.0
    """σ of one block's levelled angle from the accelerometers' white noise (rad):
    ``VRW / (g √T_block)``."""

    @classmethod
    def of(
        cls, t: Array, dt: Array, dvel: Array, c_sb: Array | None = None, vrw: float = 0.0
    ) -> AccelTilt:
        """From the IMU's intervals ``(t - dt, t]`` and velocity increments; ``vrw`` the
        accelerometers' velocity random walk (m/s/√s)."""
        per = max(1, round(TILT_BLOCK_S / float(np.median(dt))))
        nb = t.size // per
        cut = nb * per
        span = dt[:cut].reshape(nb, per).sum(axis=1)
        f = dvel[:cut].reshape(nb, per, 3).sum(axis=1) / span[:, None]
        if c_sb is not None:
            f = f @ np.asarray(c_sb, dtype=float).T
        mid = t[:cut].reshape(nb, per)[:, -1] - 0.5 * span
        roll = np.arctan2(-f[:, 1], -f[:, 2])
        pitch = np.arctan2(f[:, 0], np.hypot(f[:, 1], f[:, 2]))
        sigma = vrw / (TILT_GRAVITY * math.sqrt(float(np.median(span))))
        return cls(mid, np.column_stack([np.unwrap(roll), pitch]), sigma)

    def noise_var(self, dt: Array) -> Array:
        """Variance of the noise of the angle changes, two blocks' each: ``2 σ_block²``."""
        return np.full(dt.shape, 2.0 * self.block_sigma**2)

    def window(self, t0: float, t1: float) -> AccelTilt:
        """The blocks from just before ``t0`` to just after ``t1`` (views, no copy): a span's
        fits interpolate in them, not in a day of blocks (as :meth:`Gyro.window`)."""
        i0 = max(int(np.searchsorted(self.t, t0, side="right")) - 1, 0)
        i1 = min(int(np.searchsorted(self.t, t1, side="left")) + 1, self.t.size)
        return AccelTilt(self.t[i0:i1], self.angles[i0:i1], self.block_sigma)

    def change(self, t0: Array, t1: Array, axis: int) -> Array:
        """The levelled angle ``axis`` (0 roll, 1 pitch) at t1 less that at t0 (NaN outside)."""
        inside = (t0 >= self.t[0]) & (t1 <= self.t[-1])
        col = self.angles[:, axis]
        out = np.interp(t1, self.t, col) - np.interp(t0, self.t, col)
        return np.where(inside, out, math.nan)


SEGMENT_S = 120.0
"""Length (s) of the consecutive spans a reference is cut into for :func:`segment_finding`: a
few minutes hold enough intervals for a fit (a heading at 1 Hz: 300) and name where an axis
stopped within them."""
QUIET_SIGMAS = 3.0
"""A span's reference turns, for :func:`quiet_axis`, when the robust σ of its angle about a
line is this many times its noise (the reference's σ and the IMU angle's: the gyro's random walk
over the span, the levelled angle's block σ): white noise's is 1."""
QUIET_SMOOTH = 1.0
"""... and when the robust σ of its changes from reading to reading is at most this many times
that σ about the line: a rotation moves the angle smoothly, white noise (a reference noisier
than its configured σ) gives √2."""


@dataclass(frozen=True)
class Quiet:
    """An IMU angle (a gyro axis's integral, the accelerometers' levelled roll or pitch) that
    shows ``ratio`` of a reference's rotation over ``n`` readings: the robust σ of its angle
    about a line over the reference's, the reference's noise taken out."""

    ratio: float
    n: int


@dataclass(frozen=True)
class SegmentFinding:
    """The ``instrument`` (the gyro's ``axis``, the accelerometers' levelling, or the reference
    when both disagree with it) against ``reference``'s ``angle``: it follows (decided, the rule
    of the module's docstring) up to ``follows_to`` (s; None: no span before) and fails from
    ``t_from`` to ``t_to``: a fitted :class:`Slope` below the rule (``slope``), or changes at
    the level of the IMU's noise while the reference turns (``quiet``)."""

    instrument: Instrument
    axis: int
    reference: str
    angle: str
    t_from: float
    t_to: float
    follows_to: float | None
    slope: Slope | None
    quiet: Quiet | None

    def words(self) -> str:
        """How far it follows the reference, in words."""
        if self.slope is not None:
            s = self.slope
            return f"slope {s.k:.2g} ± {s.se:.2g}, {s.n} intervals"
        q = self.quiet
        assert q is not None
        return (
            f"its angle about a line {q.ratio:.2g} times the sensor's over {q.n} readings, at "
            "the level of its own noise: it does not see the sensor's rotation"
        )


def _about_line(t: Array, x: Array) -> float:
    """σ, from the median absolute deviation, of ``x`` less its least-squares line in ``t``."""
    d = x - np.polyval(np.polyfit(t - t[0], x, 1), t - t[0])
    return 1.4826 * float(np.median(np.abs(d - np.median(d))))


def quiet_axis(
    imu: Gyro | AccelTilt, axis: int, t: Array, angle: Array, sigma: float
) -> Quiet | None:
    """The IMU's angle ``axis`` (the gyro's integral, or the accelerometers' levelled roll or
    pitch) showing only its noise (or nothing) while a reference (readings ``angle`` at ``t``,
    noise σ ``sigma``, rad) turns, over one span: about their lines (a steady turn and a bias
    taken out), the reference's angle has a robust σ :data:`QUIET_SIGMAS` times its noise (σ,
    and the IMU angle's: the gyro's random walk ``ARW √T`` over the span, the levelled angle's
    block σ), moves smoothly (:data:`QUIET_SMOOTH`: not a noise larger than σ) and spans
    :data:`DEAD_TURN_RAD`, and the IMU's angle less than :data:`MIN_SLOPE` of it (the
    reference's noise taken out: ``sqrt(s_ref² - σ²)``). The slope fit cannot decide there (the
    IMU's changes are not above their noise, :data:`SIGNAL_FACTOR`), which is what a failed axis
    reads. Amplitudes, not a fit: a reference's latency does not matter. None: the reference
    does not turn, or the IMU follows it."""
    ok = np.isfinite(t) & np.isfinite(angle)
    t, angle = t[ok], np.unwrap(angle[ok])
    if t.size <= MIN_INTERVALS or not (t[0] >= imu.t[0] and t[-1] <= imu.t[-1]):
        return None
    if isinstance(imu, Gyro):
        own = np.interp(t, imu.t, imu.theta[:, axis])
        noise = imu.arw * math.sqrt(float(t[-1] - t[0]))
    else:
        own, noise = np.interp(t, imu.t, imu.angles[:, axis]), imu.block_sigma
    sa, sb = _about_line(t, angle), _about_line(t, own)
    step = 1.4826 * float(np.median(np.abs(np.diff(angle) - np.median(np.diff(angle)))))
    if sa < QUIET_SIGMAS * math.hypot(sigma, noise) or step > QUIET_SMOOTH * sa:
        return None
    d = angle - np.polyval(np.polyfit(t - t[0], angle, 1), t - t[0])
    lo, hi = np.percentile(d, [1.0, 99.0])
    shown = math.sqrt(sa**2 - sigma**2)
    if hi - lo < DEAD_TURN_RAD or sb >= MIN_SLOPE * shown:
        return None
    return Quiet(sb / shown, int(t.size))


def _segment_verdict(
    imu: Gyro | AccelTilt, axis: int, t: Array, angle: Array, sigma: float | None
) -> tuple[bool, Slope | None, Quiet | None] | None:
    """(follows, the failing slope, the failing quiet) of one span; None: undecided. A span
    follows only when its slope is above :data:`MIN_SLOPE` even :data:`CONFIDENCE` standard
    errors down: one that holds a failure near its start can pass the rule with a wide
    interval (k = 0.12 ± 0.22), which is no sign that the axis follows there; such a span is
    undecided. The quiet rule is tried only where the slope cannot decide at all (the IMU's
    changes at their noise): a span whose slope decides but widely, e.g. a vessel getting
    under way, its pendulum inclinometer tilted by the surge as the gyro is not, is left
    alone."""
    s = best_slope(imu, axis, t, angle)
    if s is not None:
        if s[0].upper < MIN_SLOPE:
            return False, s[0], None
        return (True, None, None) if s[0].k - CONFIDENCE * s[0].se >= MIN_SLOPE else None
    if sigma is None:
        return None
    q = quiet_axis(imu, axis, t, angle, sigma)
    return None if q is None else (False, None, q)


Failure = tuple[float | None, float, float, Slope | None, Quiet | None]
"""Where an IMU angle stops following a reference: (the end of the last span that follows
before, the first failing span's start, the last failing span's end, its slope, its quiet)."""


def _first_failure(
    spans: list[tuple[Array, Array]], imu: Gyro | AccelTilt, axis: int, sigma: float | None
) -> Failure | None:
    """The first span that fails and those failing after it, up to one that follows; with
    none, the record's tail (:func:`_tail_failure`)."""
    follows: list[float] = []
    bad: list[tuple[float, float, Slope | None, Quiet | None]] = []
    for ts, us in spans:
        v = _span_verdict(imu, axis, ts, us, sigma)
        if v is None:
            continue
        if v[0]:
            if bad:
                break
            follows.append(float(ts[-1]))
        else:
            bad.append((float(ts[0]), float(ts[-1]), v[1], v[2]))
    if not bad:
        return _tail_failure(spans[-1], imu, axis, sigma, follows)
    last = follows[-1] if follows else None
    return last, bad[0][0], bad[-1][1], bad[0][2], bad[0][3]


def _span_verdict(
    imu: Gyro | AccelTilt, axis: int, ts: Array, us: Array, sigma: float | None
) -> tuple[bool, Slope | None, Quiet | None] | None:
    """:func:`_segment_verdict` on the readings ``us`` at ``ts``, the IMU's angles cut to them
    (a day's 864 000 tilt blocks interpolated at every span took 2.5 s of a day's load)."""
    part = imu.window(ts[0] - MAX_LAG_S, ts[-1] + MAX_LAG_S)
    return _segment_verdict(part, axis, ts, us, sigma)


def _tail_failure(
    last: tuple[Array, Array],
    imu: Gyro | AccelTilt,
    axis: int,
    sigma: float | None,
    follows: list[float],
) -> Failure | None:
    """An axis that fails within the last span: the span's second half, then that half's, down
    to :data:`SEGMENT_S` / 4, each judged alone. A failure in the last span's second half
    leaves it undecided or following (the good part's changes lead its fit) and no span after
    it tells (since 0.4.13, helper aud2's audit: the demo's gyro x reading its noise from 780,
    800 or 830 s was blamed on the DVL, or loaded). ``follows``: the ends of the spans that
    follow before."""
    ts, us = last
    while ts[-1] - ts[ts.size // 2] >= SEGMENT_S / 4:
        ts, us = ts[ts.size // 2 :], us[us.size // 2 :]
        v = _span_verdict(imu, axis, ts, us, sigma)
        if v is not None and not v[0]:
            before = [f for f in follows if f <= ts[0]]
            return before[-1] if before else None, float(ts[0]), float(ts[-1]), v[1], v[2]
        if v is not None:
            return None  # the half follows: the axis does to the end
    return None


def _spans(ref: Reference, gyro: Gyro) -> list[tuple[Array, Array]]:
    """A reference's finite readings cut into consecutive spans of about :data:`SEGMENT_S`
    (the reading at a bound ends one and starts the next); none if there are fewer than two.
    Readings within an IMU hole are left out: the IMU's angle there is a line (since 0.4.13,
    helper aud2's audit: the demo with 150 s lost at 650 s had its right inclinometer blamed)."""
    ok = np.isfinite(ref.t) & np.isfinite(ref.value) & ~gyro.in_hole(ref.t)
    t, angle = ref.t[ok], ref.value[ok]
    n = int((t[-1] - t[0]) // SEGMENT_S) if t.size > 1 else 0
    if n < 2:
        return []  # one span: the whole mission's fit
    edges = np.searchsorted(t, np.linspace(t[0], t[-1], n + 1)[1:-1]).tolist()
    pairs = zip([0, *edges], [*edges, t.size - 1], strict=True)
    return [(t[i : j + 1], angle[i : j + 1]) for i, j in pairs]


def segment_finding(views: ImuViews, ref: Reference, sigma: float | None) -> SegmentFinding | None:
    """A gyro axis, or for an inclinometer's angle the accelerometers' levelling, that follows a
    reference over the whole mission's fit (:func:`check_axes`) but not over a part of it: the
    reference's readings cut into consecutive spans of about :data:`SEGMENT_S` (:func:`_spans`),
    each judged only where it decides, by the rule of the module's docstring
    (:func:`best_slope`) or, where the IMU's angle shows nothing above its noise, by
    :func:`quiet_axis` (``sigma``: the reference's noise, rad; None: not judged so, as a GNSS
    course's). The first failing span and those failing after it, up to one that follows; when
    the gyro and the accelerometers both fail from the same span, the reference is blamed (as
    :func:`check_axes` does). Up to 0.4.12 an axis that failed mid-mission (zeroed, or reading
    its noise) was averaged away by the whole mission's fit (docs/robustness.md, 'An IMU axis
    that fails mid-mission')."""
    turned = views.gyro(ref.c_sb)
    spans = _spans(ref, turned)
    if not spans:
        return None
    gyro = _first_failure(spans, turned, ref.axis, sigma)
    tilt = None
    if ref.tilt is not None:
        tilt = _first_failure(spans, views.tilt(ref.c_sb), ref.tilt, sigma)
    if gyro is None and tilt is None:
        return None
    inst: Instrument = "gyro" if tilt is None else "accelerometer" if gyro is None else "reference"
    if inst == "reference" and gyro is not None and tilt is not None and gyro[1] != tilt[1]:
        inst = "gyro" if gyro[1] < tilt[1] else "accelerometer"  # the first to fail
    f = gyro if inst != "accelerometer" else tilt
    assert f is not None
    return SegmentFinding(inst, ref.axis, ref.name, ref.angle, f[1], f[2], f[0], f[3], f[4])
