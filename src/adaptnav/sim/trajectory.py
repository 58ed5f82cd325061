"""Vessel trajectories from a compact description: segments, sea state and waves (issue 4).

A :class:`TrajectorySpec` (start point, initial course, a list of segments, a sea-state profile
and a wave model) is turned by :func:`build` into a :class:`Trajectory` whose
:attr:`~Trajectory.motion` is an :class:`adaptnav.sim.kinematics.Motion`: geodetic position with
two exact time derivatives and ZYX Euler angles with one. The true states and the error-free
IMU signals (earth rate, transport rate, Coriolis and normal gravity included) then follow from
:mod:`adaptnav.sim.kinematics` exactly as the core mechanization defines them.

Smooth profiles
---------------
Speed ``s(t)``, course rate ``χ̇(t)``, depth ``z(t)`` and the sea-state level ``E(t)`` are sums of
non-overlapping *smooth steps* (:class:`StepProfile`)::

    y(t) = y0 + Σ_j Δ_j S((t - a_j) / w_j),
    S(x) = x⁴ (35 - 84 x + 70 x² - 20 x³)   on [0, 1]   (0 before, 1 after),

the septic "smootherstep" whose first three derivatives vanish at both ends, so every profile is
C³. ``S'(x) = 140 x³ (1 - x)³`` peaks at 35/16 in the middle, so a change Δ at a peak rate
``r`` takes ``w = 35 |Δ| / (16 r)``. The course is the closed-form integral of its rate,
``χ(t) = χ0 + ∫ χ̇``, with ``∫_0^x S = 7x⁵ - 14x⁶ + 10x⁷ - 5x⁸/2`` (= 1/2 at x = 1).

Horizontal track
----------------
Local offsets ``n(t) = ∫ s cos χ``, ``e(t) = ∫ s sin χ`` (m). Their rates and accelerations are
closed forms (``n̈ = ṡ cos χ - s χ̇ sin χ``, ``ë = ṡ sin χ + s χ̇ cos χ``); the offsets
themselves are integrated once, by 8-point Gauss-Legendre quadrature between knots 1 s apart
that include every profile breakpoint (no knot interval straddles a joint of a profile), and
evaluated between knots by the quintic Hermite interpolant of (n, ṅ, n̈) at the two knots
(error ``≤ h⁶ max|n⁽⁶⁾| / 46080`` ≈ 1e-12 m for h = 1 s). Position,
velocity and acceleration are thus consistent to far below a micrometre.

Geodetic position, as in :func:`adaptnav.sim.kinematics.turn_with_waves`, with constant scale
factors of the start point (a definition of the motion, not an approximation)::

    L = L0 + N / (R_M(L0) + h0),   λ = λ0 + E / ((R_N(L0) + h0) cos L0),   h = h0 - z + ζ,

where ``N = n + d cos β``, ``E = e + d sin β`` add the horizontal wave (orbital) displacement d
along the wave direction β and ζ is the heave. (The resulting NED ground speed differs from
``s`` by the ratio of the radii, < 1e-3 over tens of km.)

Waves and attitude
------------------
Each wave channel (roll, pitch, yaw, heave, horizontal displacement) is a sum of sinusoids
``E(t) Σ_i A_i sin(2π t / T_i + φ_i)`` scaled by the sea-state level E(t), with exact first and
second derivatives by the product rule. Attitude (ZYX)::

    φ = φ0 + roll waves - k_heel s χ̇ / g0,   θ = θ0 + pitch waves,   ψ = χ + yaw waves,

with a static list/trim (φ0, θ0) and an optional heel in turns: a displacement ship heels
*outward* in a steady turn, by roughly the centripetal tilt ``s χ̇ / g`` (k_heel = 1 by default;
e.g. Lewis (ed.), *Principles of Naval Architecture* vol. III, 1989, §"turning").

Static phase (alignment alongside). The presets start with E = 0 and s = 0 (the vessel moored
in a sheltered harbour): the IMU is then *truly at rest* on the rotating Earth (only list and
trim, no wave motion, no heave), so ZUPTs are exact and the static alignment's levelling and
gyrocompassing see earth rate and gravity only. Waves ramp in smoothly after departure.

Sources: Groves (2013) §2.4, §5.4 (through :mod:`adaptnav.sim.kinematics`); Abramowitz & Stegun
25.4.29-30 (Gauss-Legendre); the smoothstep family is standard (Perlin 2002, "Improving noise").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core import earth
from adaptnav.core.units import G0
from adaptnav.sim.kinematics import Motion

Array = NDArray[np.float64]
IntArray = NDArray[np.intp]

STEP_PEAK_SLOPE = 35.0 / 16.0
"""max S'(x): a smooth step of height Δ and width w changes at up to 35 Δ / (16 w) per second."""
KNOT_SPACING = 1.0
"""Spacing (s) of the knots at which the horizontal track is integrated."""
_GAUSS = np.polynomial.legendre.leggauss(8)


# --- smooth steps ---------------------------------------------------------------------------


def _smooth_steps(x: ArrayLike) -> tuple[Array, Array, Array]:
    """(S, S', S'') at x (clipped to [0, 1]), sharing ``u`` and ``v = u (1 - u)``."""
    u = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    u2 = u * u
    v = u * (1.0 - u)
    v2 = v * v
    s0 = u2 * u2 * (35.0 + u * (-84.0 + u * (70.0 - 20.0 * u)))
    return s0, 140.0 * v2 * v, 420.0 * v2 * (1.0 - 2.0 * u)


def smooth_step(x: ArrayLike) -> Array:
    """S(x) = x⁴ (35 - 84x + 70x² - 20x³) on [0, 1], 0 below, 1 above (C³)."""
    return _smooth_steps(x)[0]


def smooth_step_d1(x: ArrayLike) -> Array:
    """S'(x) = 140 x³ (1 - x)³ on [0, 1], 0 outside."""
    return _smooth_steps(x)[1]


def smooth_step_d2(x: ArrayLike) -> Array:
    """S''(x) = 420 x² (1 - x)² (1 - 2x) on [0, 1], 0 outside."""
    return _smooth_steps(x)[2]


def smooth_step_integral(x: ArrayLike) -> Array:
    """∫_0^x S = 7x⁵ - 14x⁶ + 10x⁷ - 5x⁸/2 on [0, 1]; 0 below; 1/2 + (x - 1) above."""
    xa = np.asarray(x, dtype=float)
    u = np.clip(xa, 0.0, 1.0)
    inside = u**5 * (7.0 + u * (-14.0 + u * (10.0 - 2.5 * u)))
    return np.asarray(np.where(xa > 1.0, 0.5 + (xa - 1.0), inside), dtype=float)


@dataclass(frozen=True, eq=False)
class StepProfile:
    """``y(t) = initial + Σ_j deltas[j] S((t - starts[j]) / widths[j])`` (module docstring).

    Steps are sorted and may not overlap (``starts[j] + widths[j] <= starts[j + 1]``), so at
    any time at most one is in progress; evaluation is a binary search plus prefix sums.
    """

    initial: float
    starts: Array = field(default_factory=lambda: np.zeros(0))
    widths: Array = field(default_factory=lambda: np.zeros(0))
    deltas: Array = field(default_factory=lambda: np.zeros(0))
    _sum_d: Array = field(init=False, repr=False)
    _sum_dc: Array = field(init=False, repr=False)

    def __post_init__(self) -> None:
        a = np.asarray(self.starts, dtype=float).reshape(-1)
        w = np.asarray(self.widths, dtype=float).reshape(-1)
        d = np.asarray(self.deltas, dtype=float).reshape(-1)
        if not (a.shape == w.shape == d.shape):
            raise ValueError("starts, widths and deltas must have the same length")
        if np.any(w <= 0.0) or not np.all(np.isfinite(np.concatenate([a, w, d]))):
            raise ValueError("step widths must be > 0 and all values finite")
        if a.size > 1 and np.any(a[:-1] + w[:-1] > a[1:] + 1e-9):
            raise ValueError("steps must be sorted and must not overlap")
        object.__setattr__(self, "starts", a)
        object.__setattr__(self, "widths", w)
        object.__setattr__(self, "deltas", d)
        # Prefix sums over completed steps: Σ Δ_i and Σ Δ_i (a_i + w_i / 2).
        object.__setattr__(self, "_sum_d", np.concatenate([[0.0], np.cumsum(d)]))
        object.__setattr__(self, "_sum_dc", np.concatenate([[0.0], np.cumsum(d * (a + 0.5 * w))]))

    def _locate(self, t: Array) -> tuple[IntArray, Array, Array, Array]:
        """(k, x, Δ, w): k steps have started; x, Δ, w of the last started one (Δ = 0 if none)."""
        k = np.searchsorted(self.starts, t, side="right")
        j = np.maximum(k - 1, 0)
        if self.starts.size == 0:
            zero = np.zeros_like(t)
            return k, zero, zero, np.ones_like(t)
        w = self.widths[j]
        delta = np.where(k > 0, self.deltas[j], 0.0)
        x = (t - self.starts[j]) / w
        return k, x, delta, w

    def value(self, t: ArrayLike) -> Array:
        return self.derivatives(t)[0]

    def rate(self, t: ArrayLike) -> Array:
        """dy/dt."""
        return self.derivatives(t)[1]

    def accel(self, t: ArrayLike) -> Array:
        """d²y/dt²."""
        return self.derivatives(t)[2]

    def derivatives(self, t: ArrayLike) -> tuple[Array, Array, Array]:
        """(y, dy/dt, d²y/dt²) from one search of the steps (the simulator asks for all three
        at millions of instants)."""
        tt = np.asarray(t, dtype=float)
        if self.starts.size == 0:
            return np.full_like(tt, self.initial), np.zeros_like(tt), np.zeros_like(tt)
        k, x, delta, w = self._locate(tt)
        s0, s1, s2 = _smooth_steps(x)
        before = self._sum_d[np.maximum(k - 1, 0)]
        return self.initial + before + delta * s0, (delta / w) * s1, (delta / (w * w)) * s2

    def integral(self, t: ArrayLike) -> Array:
        """∫_0^t y (valid for steps at times >= 0)."""
        tt = np.asarray(t, dtype=float)
        k, x, delta, w = self._locate(tt)
        m = np.maximum(k - 1, 0)
        done = tt * self._sum_d[m] - self._sum_dc[m]
        return np.asarray(
            self.initial * tt + done + delta * w * smooth_step_integral(x), dtype=float
        )

    @property
    def breakpoints(self) -> Array:
        """Start and end times of every step."""
        return np.concatenate([self.starts, self.starts + self.widths])


# --- the description ------------------------------------------------------------------------


@dataclass(frozen=True)
class Static:
    """At rest (speed brought to zero at the segment's start if needed) for ``duration`` s."""

    duration: float


@dataclass(frozen=True)
class Straight:
    """Constant course for ``duration`` s; the speed changes to ``speed`` (m/s) at the start
    (a smooth step within the segment), or is kept if None."""

    duration: float
    speed: float | None = None


@dataclass(frozen=True)
class Turn:
    """A course change of ``angle`` rad (> 0: to starboard, clockwise seen from above) at a peak
    rate ``rate`` (rad/s, > 0), or of whatever angle ``duration`` s at that rate gives.

    The rate ramps up and down as smooth steps of width ``w = 35 rate / (16 α_max)``
    (``TrajectorySpec.max_yaw_accel``), so the segment lasts ``|angle| / rate + w``; a turn too
    small for that is one smooth step of the course at a lower peak rate (duration ``2 w``).
    ``speed`` changes the speed at the segment's start as for :class:`Straight`.
    """

    angle: float | None = None
    rate: float = math.radians(1.0)
    duration: float | None = None
    speed: float | None = None


@dataclass(frozen=True)
class DepthChange:
    """Depth (m, positive down) changes by ``delta`` as one smooth step over ``duration`` s,
    course kept; ``speed`` as for :class:`Straight`."""

    duration: float
    delta: float
    speed: float | None = None


Segment = Static | Straight | Turn | DepthChange


@dataclass(frozen=True)
class WaveComponent:
    """One sinusoid ``amplitude sin(2π t / period + phase)`` (rad or m at sea-state level 1)."""

    amplitude: float
    period: float
    phase: float = 0.0


@dataclass(frozen=True)
class Waves:
    """Wave-induced motion at sea-state level 1: sums of sinusoids per channel.

    ``roll``, ``pitch``, ``yaw`` in rad; ``heave`` (up) and ``horizontal`` (orbital surge/sway
    displacement along the NED direction ``direction``, rad from north) in m.
    """

    roll: tuple[WaveComponent, ...] = ()
    pitch: tuple[WaveComponent, ...] = ()
    yaw: tuple[WaveComponent, ...] = ()
    heave: tuple[WaveComponent, ...] = ()
    horizontal: tuple[WaveComponent, ...] = ()
    direction: float = 0.0


@dataclass(frozen=True)
class SeaState:
    """At ``start`` (s) the sea-state level moves to ``level`` as a smooth step of ``width`` s.

    Level 0 is calm (no waves), 1 the nominal sea of :class:`Waves`; amplitudes scale linearly.
    """

    start: float
    level: float
    width: float = 120.0


@dataclass(frozen=True)
class TrajectorySpec:
    """A trajectory: start point (rad, rad, m), initial course (rad), segments, sea state.

    ``list_trim`` is the static (roll, pitch) of the hull (rad); ``heel_factor`` scales the
    outward heel in turns; ``max_accel`` (m/s²) and ``max_yaw_accel`` (rad/s²) set the widths
    of speed and course-rate changes (module docstring).
    """

    lat0: float
    lon0: float
    h0: float
    course0: float
    segments: tuple[Segment, ...]
    waves: Waves = Waves()
    sea_state: tuple[SeaState, ...] = ()
    list_trim: tuple[float, float] = (0.0, 0.0)
    heel_factor: float = 1.0
    max_accel: float = 0.05
    max_yaw_accel: float = math.radians(0.2)
    min_step: float = 5.0
    """Shortest smooth step (s)."""


@dataclass(frozen=True)
class SegmentSpan:
    """Where a segment of the description ended up in time (s)."""

    kind: str
    start: float
    end: float


# --- building -----------------------------------------------------------------------------------


@dataclass
class _Steps:
    starts: list[float] = field(default_factory=list)
    widths: list[float] = field(default_factory=list)
    deltas: list[float] = field(default_factory=list)

    def add(self, start: float, width: float, delta: float) -> None:
        if delta != 0.0:
            self.starts.append(start)
            self.widths.append(width)
            self.deltas.append(delta)

    def profile(self, initial: float) -> StepProfile:
        return StepProfile(
            initial, np.array(self.starts), np.array(self.widths), np.array(self.deltas)
        )


def _change_width(delta: float, peak_rate: float, minimum: float) -> float:
    return max(minimum, STEP_PEAK_SLOPE * abs(delta) / peak_rate)


class _Profiles(NamedTuple):
    """The smooth profiles of the track at some instants (:meth:`Trajectory._profiles`)."""

    speed: Array
    speed_rate: Array
    course: Array
    course_rate: Array
    course_accel: Array


class _Grid(NamedTuple):
    """Evenly spaced instants as anchors (every :data:`_ANCHOR_EVERY`-th) plus offsets j h
    (:func:`_even_grid`)."""

    anchors: Array
    """The instants t_0, t_B, t_2B, ... (rows,)."""
    offsets: Array
    """j h, j = 0 .. B - 1 (B,)."""
    residual: Array
    """t - (anchor + offset) exactly, (rows, B) (0 past the last instant)."""
    size: int


_ANCHOR_EVERY = 64
"""Instants per anchor of a wave's angle addition on an even grid (:func:`_sincos`)."""


def _even_grid(t: Array) -> _Grid | None:
    """``t`` as anchors plus offsets if it is evenly spaced to rounding (within 64 ulps of its
    largest instant), else None. The residual is exact (the sum ``anchor + offset`` and its
    rounding error, Knuth's TwoSum)."""
    n, b = t.size, _ANCHOR_EVERY
    if n < 2 * b:
        return None
    h = (t[-1] - t[0]) / (n - 1)
    rows = -(-n // b)
    anchors, offsets = t[::b], h * np.arange(b)
    expected = anchors[:, None] + offsets[None, :]
    back = expected - anchors[:, None]
    rounding = (anchors[:, None] - (expected - back)) + (offsets[None, :] - back)
    pad = expected.reshape(-1)[n:]
    residual = (np.concatenate([t, pad]).reshape(rows, b) - expected) - rounding
    residual.reshape(-1)[n:] = 0.0
    if np.abs(residual).max() > 64.0 * float(np.spacing(max(abs(t[0]), abs(t[-1])))):
        return None
    return _Grid(anchors, offsets, residual, n)


def _sincos(omega: float, phase: float, t: Array, grid: _Grid | None) -> tuple[Array, Array]:
    """sin and cos of ``ω t + φ``. On an even grid by angle addition from the anchors,
    ``sin(α + ω j h) = sin α cos ω j h + cos α sin ω j h`` (α = ω t_a + φ), and the residual r
    to first order, ``sin(β + ω r) = sin β + ω r cos β`` (ω r < 1e-9: the second order is below
    1e-18): two sines and cosines per 64 instants instead of two per instant, as exact as the
    direct evaluation (whose own argument ω t rounds to half an ulp)."""
    if grid is None:
        arg = omega * t + phase
        return np.sin(arg), np.cos(arg)
    a = omega * grid.anchors + phase
    sa, ca = np.sin(a)[:, None], np.cos(a)[:, None]
    so, co = np.sin(omega * grid.offsets), np.cos(omega * grid.offsets)
    sn, cs = sa * co + ca * so, ca * co - sa * so
    turn = omega * grid.residual
    sn, cs = sn + turn * cs, cs - turn * sn
    return sn.reshape(-1)[: grid.size], cs.reshape(-1)[: grid.size]


def _wave_sum(
    comps: Sequence[WaveComponent], t: Array, grid: _Grid | None, order: int
) -> list[Array]:
    """Σ A sin(ωt + φ) and its first ``order`` (1 or 2) derivatives."""
    sums = [np.zeros_like(t) for _ in range(order + 1)]
    for c in comps:
        w = 2.0 * math.pi / c.period
        sn, cs = _sincos(w, c.phase, t, grid)
        sums[0] += c.amplitude * sn
        sums[1] += c.amplitude * w * cs
        if order == 2:
            sums[2] -= c.amplitude * w * w * sn
    return sums


def _scaled(level: tuple[Array, Array, Array], sums: list[Array]) -> list[Array]:
    """``E(t) Σ`` and its derivatives by the product rule, as many as ``sums`` has."""
    e0, e1, e2 = level
    out = [e0 * sums[0], e1 * sums[0] + e0 * sums[1]]
    if len(sums) == 3:
        out.append(e2 * sums[0] + 2.0 * e1 * sums[1] + e0 * sums[2])
    return out


class Trajectory:
    """A built trajectory: the profiles, the knots of the horizontal track and the Motion.

    Attributes:
        spec: the description.
        duration: end time (s); the trajectory starts at t = 0.
        spans: where each segment lies in time.
        speed, course_rate, depth, sea_state: the smooth profiles (:class:`StepProfile`).
        motion: the :class:`~adaptnav.sim.kinematics.Motion` (vectorised closed forms).
    """

    def __init__(self, spec: TrajectorySpec, waves: bool = True) -> None:
        self.spec = spec
        self.waves_on = waves
        speed, rate, depth = _Steps(), _Steps(), _Steps()
        t, v, spans = 0.0, 0.0, []
        for seg in spec.segments:
            start = t
            target = 0.0 if isinstance(seg, Static) else getattr(seg, "speed", None)
            if target is not None and target != v:
                if target < 0.0:
                    raise ValueError(f"{seg}: speed must be >= 0")
                w = _change_width(target - v, spec.max_accel, spec.min_step)
                speed.add(t, w, target - v)
                v = target
                speed_end = t + w
            else:
                speed_end = t
            if isinstance(seg, Turn):
                dur = self._add_turn(seg, t, rate)
            else:
                dur = float(seg.duration)
                if isinstance(seg, DepthChange):
                    depth.add(t, dur, seg.delta)
            if not dur > 0.0 or speed_end > t + dur + 1e-9:
                raise ValueError(
                    f"{seg}: the segment ({dur:g} s) is shorter than its speed change "
                    f"({speed_end - t:g} s)"
                )
            t += dur
            spans.append(SegmentSpan(type(seg).__name__.lower(), start, t))
        self.duration = t
        self.spans = tuple(spans)
        self.speed = speed.profile(0.0)
        self.course_rate = rate.profile(0.0)
        self.depth = depth.profile(0.0)
        levels = _Steps()
        level = 0.0
        for s in sorted(spec.sea_state, key=lambda s: s.start):
            levels.add(s.start, s.width, s.level - level)
            level = s.level
        self.sea_state = levels.profile(0.0)
        self._build_knots()
        self._k_lat = 1.0 / (float(earth.meridian_radius(spec.lat0)) + spec.h0)
        self._k_lon = 1.0 / (
            (float(earth.transverse_radius(spec.lat0)) + spec.h0) * math.cos(spec.lat0)
        )
        self._cache_t: Array | None = None
        self._cache: dict[str, Array] = {}
        self.motion = Motion(
            position=lambda tt: self._eval(tt)["p"],
            position_rate=lambda tt: self._eval(tt)["pd"],
            position_accel=lambda tt: self._eval(tt)["pdd"],
            euler=lambda tt: self._eval(tt)["e"],
            euler_rate=lambda tt: self._eval(tt)["ed"],
            breakpoints=tuple(self.breakpoints.tolist()),
        )

    def _add_turn(self, seg: Turn, t: float, rate: _Steps) -> float:
        if not seg.rate > 0.0:
            raise ValueError(f"{seg}: rate must be > 0")
        w = _change_width(seg.rate, self.spec.max_yaw_accel, self.spec.min_step)
        if seg.angle is not None:
            angle = float(seg.angle)
            if abs(angle) / seg.rate >= w:
                dur = abs(angle) / seg.rate + w
                r = math.copysign(seg.rate, angle)
            else:  # a small turn: ramp up and straight down again at a lower peak rate
                dur = 2.0 * w
                r = angle / w
        elif seg.duration is not None:
            dur = float(seg.duration)
            if dur < 2.0 * w:
                raise ValueError(f"{seg}: a turn at this rate needs at least {2 * w:g} s")
            r = seg.rate
        else:
            raise ValueError(f"{seg}: give the turn's angle or its duration")
        rate.add(t, w, r)
        rate.add(t + dur - w, w, -r)
        return dur

    # --- horizontal track --------------------------------------------------------------------

    def _profiles(self, t: Array) -> _Profiles:
        """Speed, course and course rate at t, with the derivatives the motion needs."""
        s, sd, _ = self.speed.derivatives(t)
        chid, chidd, _ = self.course_rate.derivatives(t)
        chi = self.spec.course0 + self.course_rate.integral(t)
        return _Profiles(s, sd, chi, chid, chidd)

    @staticmethod
    def _track_rates(p: _Profiles) -> tuple[Array, Array, Array, Array]:
        """(ṅ, ė, n̈, ë) of the track from its profiles."""
        s, sd, chid = p.speed, p.speed_rate, p.course_rate
        c, sn = np.cos(p.course), np.sin(p.course)
        return s * c, s * sn, sd * c - s * chid * sn, sd * sn + s * chid * c

    def _build_knots(self) -> None:
        regular = np.arange(0.0, self.duration, KNOT_SPACING)
        brk = np.concatenate([self.speed.breakpoints, self.course_rate.breakpoints])
        knots = np.unique(np.concatenate([regular, brk, [self.duration]]))
        knots = knots[(knots >= 0.0) & (knots <= self.duration)]
        # Merge knots closer than 1 ms (rounding of breakpoints) to keep intervals well-posed.
        keep = np.concatenate([[True], np.diff(knots) > 1e-3])
        knots = knots[keep]
        x, w = _GAUSS
        a, b = knots[:-1], knots[1:]
        half = 0.5 * (b - a)
        tau = (0.5 * (a + b))[:, None] + half[:, None] * x[None, :]
        dn, de, _, _ = self._track_rates(self._profiles(tau.ravel()))
        wts = half[:, None] * w[None, :]
        n_inc = np.sum(dn.reshape(tau.shape) * wts, axis=1)
        e_inc = np.sum(de.reshape(tau.shape) * wts, axis=1)
        self._knots = knots
        self._kn = np.concatenate([[0.0], np.cumsum(n_inc)])
        self._ke = np.concatenate([[0.0], np.cumsum(e_inc)])
        dn_k, de_k, ddn_k, dde_k = self._track_rates(self._profiles(knots))
        self._kdn, self._kde, self._kddn, self._kdde = dn_k, de_k, ddn_k, dde_k

    def _track(self, t: Array) -> tuple[Array, Array]:
        """(n, e) by quintic Hermite interpolation between knots."""
        kn = self._knots
        i = np.clip(np.searchsorted(kn, t, side="right") - 1, 0, kn.size - 2)
        h = kn[i + 1] - kn[i]
        u = (t - kn[i]) / h
        u2 = u * u
        u3 = u2 * u
        u4 = u3 * u
        u5 = u4 * u
        h0 = 1.0 - 10.0 * u3 + 15.0 * u4 - 6.0 * u5
        h1 = u - 6.0 * u3 + 8.0 * u4 - 3.0 * u5
        h2 = 0.5 * u2 - 1.5 * u3 + 1.5 * u4 - 0.5 * u5
        h3 = 10.0 * u3 - 15.0 * u4 + 6.0 * u5
        h4 = -4.0 * u3 + 7.0 * u4 - 3.0 * u5
        h5 = 0.5 * u3 - u4 + 0.5 * u5
        hh = h * h
        n = (
            h0 * self._kn[i]
            + h1 * h * self._kdn[i]
            + h2 * hh * self._kddn[i]
            + h3 * self._kn[i + 1]
            + h4 * h * self._kdn[i + 1]
            + h5 * hh * self._kddn[i + 1]
        )
        e = (
            h0 * self._ke[i]
            + h1 * h * self._kde[i]
            + h2 * hh * self._kdde[i]
            + h3 * self._ke[i + 1]
            + h4 * h * self._kde[i + 1]
            + h5 * hh * self._kdde[i + 1]
        )
        return n, e

    # --- the motion --------------------------------------------------------------------------

    def waves(self, t: ArrayLike) -> dict[str, tuple[Array, Array, Array]]:
        """Per channel (roll, pitch, yaw, heave, horizontal): value, rate, acceleration at t,
        scaled by the sea-state level (zeros when built with ``waves=False``)."""
        tt = np.asarray(t, dtype=float)
        grid, level = _even_grid(tt), self.sea_state.derivatives(tt)
        out: dict[str, tuple[Array, Array, Array]] = {}
        for name in ("roll", "pitch", "yaw", "heave", "horizontal"):
            v0, v1, v2 = self._channel(name, tt, grid, level, 2)
            out[name] = (v0, v1, v2)
        return out

    def _channel(
        self,
        name: str,
        t: Array,
        grid: _Grid | None,
        level: tuple[Array, Array, Array],
        order: int,
    ) -> list[Array]:
        """One wave channel and its first ``order`` derivatives (:meth:`waves`)."""
        comps: tuple[WaveComponent, ...] = getattr(self.spec.waves, name) if self.waves_on else ()
        if not comps:
            return [np.zeros_like(t) for _ in range(order + 1)]
        return _scaled(level, _wave_sum(comps, t, grid, order))

    def _eval(self, t: Array) -> dict[str, Array]:
        # kinematics.true_kinematics asks for p, ṗ, p̈, e, ė of one and the same time array.
        c = self._cache_t
        if c is t and c.size and c[0] == t[0] and c[-1] == t[-1]:
            return self._cache
        tt = np.asarray(t, dtype=float)
        grid = _even_grid(tt) if self.waves_on else None
        level = self.sea_state.derivatives(tt)
        prof = self._profiles(tt)
        self._cache = {
            **self._position(tt, prof, self._channel("horizontal", tt, grid, level, 2),
                             self._channel("heave", tt, grid, level, 2)),
            **self._attitude(prof, *(self._channel(name, tt, grid, level, 1)
                                     for name in ("roll", "pitch", "yaw"))),
        }  # fmt: skip
        self._cache_t = t
        return self._cache

    def _position(
        self, t: Array, prof: _Profiles, horizontal: list[Array], heave: list[Array]
    ) -> dict[str, Array]:
        """p, ṗ, p̈ (module docstring, 'Horizontal track')."""
        spec = self.spec
        n, e = self._track(t)
        dn, de, ddn, dde = self._track_rates(prof)
        cb, sb = math.cos(spec.waves.direction), math.sin(spec.waves.direction)
        d0, d1, d2 = horizontal
        q0, q1, q2 = heave
        z0, z1, z2 = self.depth.derivatives(t)
        k_lat, k_lon = self._k_lat, self._k_lon
        return {
            "p": np.stack(
                [spec.lat0 + k_lat * (n + cb * d0), spec.lon0 + k_lon * (e + sb * d0),
                 spec.h0 - z0 + q0], axis=-1,
            ),
            "pd": np.stack([k_lat * (dn + cb * d1), k_lon * (de + sb * d1), q1 - z1], axis=-1),
            "pdd": np.stack([k_lat * (ddn + cb * d2), k_lon * (dde + sb * d2), q2 - z2], axis=-1),
        }  # fmt: skip

    def _attitude(
        self, prof: _Profiles, roll: list[Array], pitch: list[Array], yaw: list[Array]
    ) -> dict[str, Array]:
        """e, ė (module docstring, 'Waves and attitude')."""
        spec = self.spec
        s, sd, r, rd = prof.speed, prof.speed_rate, prof.course_rate, prof.course_accel
        k = spec.heel_factor / G0
        return {
            "e": np.stack(
                [spec.list_trim[0] + roll[0] - k * s * r, spec.list_trim[1] + pitch[0],
                 prof.course + yaw[0]], axis=-1,
            ),
            "ed": np.stack(
                [roll[1] - k * (sd * r + s * rd), pitch[1], r + yaw[1]], axis=-1
            ),
        }  # fmt: skip

    # --- summaries -----------------------------------------------------------------------------

    @property
    def breakpoints(self) -> Array:
        """The joints of the motion (sorted, s): the start and end of every smooth step of the
        speed, course rate, depth and sea state, where a derivative of the motion jumps (module
        docstring, 'Smooth profiles'; docs/simulation.md, 'Exact increments')."""
        profiles = (self.speed, self.course_rate, self.depth, self.sea_state)
        return np.unique(np.concatenate([p.breakpoints for p in profiles]))

    @property
    def static_end(self) -> float:
        """End of the leading static segment (0 if the trajectory does not start static)."""
        first = self.spans[0] if self.spans else None
        return first.end if first is not None and first.kind == "static" else 0.0

    def distance(self, t0: float = 0.0, t1: float | None = None) -> float:
        """Length of the track (∫ s dt, m) between t0 and t1 (default: the end), waves excluded."""
        end = self.duration if t1 is None else t1
        ends = self.speed.integral(np.array([t0, end]))
        return float(ends[1] - ends[0])

    def course(self, t: ArrayLike) -> Array:
        """Track course χ(t) (rad, not wrapped)."""
        return np.asarray(
            self.spec.course0 + self.course_rate.integral(np.asarray(t, dtype=float)), dtype=float
        )


def build(spec: TrajectorySpec, waves: bool = True) -> Trajectory:
    """Build the trajectory of ``spec`` (``waves=False``: the same track on a calm sea)."""
    return Trajectory(spec, waves)
