"""Cross-checks of a DVL's and a depth meter's scale, and the DVL's direction, at load.

A DVL logged in knots, a depth in feet or as a pressure in kPa, or a DVL whose x axis is
negated passes every check of its own table: each reading is plausible, only wrong. The filter
then runs to a state far off without a word (paper-1 with its DVL in knots: 6 km RMSE, exit 0,
up to 0.4.9). The other sensors see it (docs/robustness.md, 'DVL and depth scales'):

* **The depth against the DVL's vertical velocity.** Over intervals of about
  :data:`DEPTH_INTERVAL_S` between depth readings, the depth's change a_i is fitted on the
  integral b_i of the DVL's velocity turned down, ``v_D = -sθ v_x + sφ cθ v_y + cφ cθ v_z``
  (body FRD, the DVL's mounting applied; roll φ and pitch θ levelled from the accelerometers,
  :class:`adaptnav.mission.axes.AccelTilt`), as ``a_i = k b_i + c Δt_i`` by the robust fit of
  :func:`adaptnav.mission.axes.axis_slope` (c takes a DVL's vertical bias or a pitch
  misalignment at a steady speed). The depth's change is taken at the DVL's point: the lever
  arms' vertical difference, turned by the tilt, is taken off. A right pair gives k ≈ 1 (a
  depth meter's density and gravity, a DVL's sound speed: a few per cent); feet 3.28, psi 1.45,
  kPa 9.9, bar 0.099, a DVL in knots 0.51, a DVL's x negated (on a vehicle that flies
  pitched) -1. The rule: refused when the slope's interval ``k ± 4 se`` lies wholly outside
  :data:`DEPTH_BAND` (0.8, 1.25): psi is the nearest unit slip above, knots below. A fit
  decides only when the depth's changes correlate with the DVL's vertical displacements by
  :data:`MIN_CORRELATION` (0.9) or more, the bias term's share taken out, and the latter
  spread by ten times their own noise: the noise in the DVL's side then cannot pull a right
  pair's slope below 0.81. A surface vessel's depth barely moves (paper-1: correlation 0.38),
  and nothing is said there.
* **The DVL's speed against a GNSS track.** Over chords of the track spanning
  :data:`SPEED_CHORD_S` (a chord shorter than :data:`SPEED_CHORD_SIGMAS` position σ, a stop,
  is left out), the chord's length is fitted on the length of the DVL's displacement over the
  same time, its levelled horizontal velocity turned by the gyro's yaw since the chord's start
  (so that a turn shortens both alike): ``|G_i| = q |D_i|`` through the origin, robustly (as
  above; :func:`through_origin`), and k = 1 / q, the DVL's metres per metre of the track, is
  judged. A right DVL gives k ≈ 1 over ground (a bottom track; a water track differs by the
  current, which a round trip averages out); knots give 1.94, ft/s 3.28, km/h 3.6. Refused when
  ``k ± 4 se`` lies wholly outside :data:`SPEED_BAND` (0.7, 1.4).
* **The DVL's direction against the GNSS course and a heading sensor.** With a heading sensor,
  each DVL displacement is turned by the heading at the chord's start and the complex ratio
  ``w = G / (e^{iψ} D)`` fitted over the chords (robust complex least squares). A right DVL
  gives arg w ≈ 0 (a compass's deviation, a drift angle: a few degrees); its x negated 180°,
  x and y swapped ±90°, an undeclared yaw mounting its angle. Refused when ``|arg w|`` exceeds
  :data:`MAX_TURN_DEG` even 4 σ down.
* **The same without a heading sensor** (since 0.4.10): the heading the mission's start gives
  (``initial.rpy_deg``'s yaw with its σ, :class:`StartYaw`) carried forward by the gyro,
  :func:`carried_yaw`: ``ψ(t) = ψ0 + ∫ (ω_D + Ω sin L) dt``, ω_D the gyro's rate about the
  local vertical (levelled by the accelerometers: :func:`down`), ``-Ω sin L`` the earth rate's
  down component (a body fixed to the earth reads it and its yaw does not change); the
  transport rate (``v_E tan L / R``: 0.007°/h at 2 m/s) is left out. Its σ grows as
  ``sqrt(σ0² + (σ_b T)² + ARW² T)``; only chords within :data:`MAX_YAW_SIGMA_DEG` count, and
  the σ of the last one is added to the fit's (in quadrature) before the rule is applied.

Pure NumPy, no I/O: :func:`adaptnav.mission.loader.load_mission` calls :func:`depth_scale` and
:func:`dvl_track` and turns a finding into a MissionError naming the file and column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptnav.core.earth import OMEGA_IE
from adaptnav.mission import axes, screening

Array = NDArray[np.float64]

DEPTH_BAND = (0.8, 1.25)
"""The depth's metres per metre of the DVL's vertical displacement a right pair may show."""
SPEED_BAND = (0.7, 1.4)
"""The GNSS track's metres per metre of the DVL's displacement a right pair may show."""
MAX_TURN_DEG = 30.0
"""Largest angle between the DVL's direction (turned by the heading) and the GNSS course."""
WARN_TURN_DEG = 2.0
"""Angle between the DVL's direction (turned by the heading) and the GNSS course beyond which,
decided at :data:`CONFIDENCE` σ, the loader warns (since 0.4.13): a declination or a DVL yaw
mounting not set. Right missions measure within 0.7° (docs/robustness.md, 'A heading a few
degrees off the GNSS course')."""
MAX_YAW_SIGMA_DEG = 10.0
"""Largest σ of a yaw carried by the gyro from the start's heading for a chord to count (°)."""
CONFIDENCE = axes.CONFIDENCE
"""Standard errors a fit's interval spans each way before it is judged."""
DEPTH_INTERVAL_S = 10.0
"""Span of the intervals between depth readings (s)."""
MIN_CORRELATION = 0.9
"""Fewest of the depth's changes' correlation with the DVL's vertical displacements (the bias
term's share taken out) for a fit to decide: the noise in the DVL's side then takes at most
1 - 0.9² = 19 % of its spread, so that it cannot pull a right pair's slope below 0.81. A
surface vessel's heave correlates at about 0.4 (paper-1)."""
SPEED_CHORD_S = 20.0
"""Span of the GNSS chords (s)."""
SPEED_CHORD_SIGMAS = 10.0
"""A chord shorter than this many position σ is left out."""
MIN_CHORDS = 12
"""Fewest chords a speed fit needs."""
SPIKE_MADS = 5.0
"""The Hampel threshold (median absolute deviations) of the spikes left out of a DVL's readings
before they are integrated for a check (:meth:`Dvl.of`; since 0.4.13)."""
SPIKE_FLOOR_M_S = 1e-3
"""The least scale of that test (m/s, a DVL's output step): a quiet stretch's MAD is near 0."""
COVER_SHARE = 0.5
"""An interval with fewer DVL readings than this share of its span's nominal count (a gap)
is left out."""
UNITS_DEPTH = {
    "feet": 1.0 / 0.3048,
    "psi (gauge pressure)": 1.458,
    "kPa (gauge pressure)": 10.05,
    "bar (gauge pressure)": 0.1005,
    "inches": 1.0 / 0.0254,
    "cm": 100.0,
    "mm": 1000.0,
    "the DVL in knots": 1.0 / 1.943844,
    "the DVL in ft/s": 0.3048,
    "the DVL in km/h": 1.0 / 3.6,
}
"""Slopes of the depth on the DVL's vertical displacement for the likely unit slips (seawater:
1 m ≈ 10.05 kPa)."""
UNITS_SPEED = {"knots": 1.943844, "ft/s": 1.0 / 0.3048, "km/h": 3.6}
"""Ratios of the DVL's speed to the GNSS track's for the likely unit slips."""
UNIT_TOLERANCE = 0.15
"""A slope within this relative distance (log) of a unit's is named as that unit."""


@dataclass(frozen=True)
class Fit:
    """A fitted ratio ``k`` (for the direction: ``angle_deg`` too), its standard error ``se``,
    the intervals kept ``n``, over ``t_from``-``t_to``."""

    k: float
    se: float
    n: int
    t_from: float
    t_to: float
    angle_deg: float = 0.0
    angle_se_deg: float = 0.0

    def outside(self, band: tuple[float, float]) -> bool:
        """``k ± CONFIDENCE se`` lies wholly outside ``band``."""
        return self.k - CONFIDENCE * self.se > band[1] or self.k + CONFIDENCE * self.se < band[0]

    def turned(self) -> bool:
        """``|angle|`` beyond :data:`MAX_TURN_DEG` even ``CONFIDENCE`` σ down."""
        return abs(self.angle_deg) - CONFIDENCE * self.angle_se_deg > MAX_TURN_DEG

    def off_course(self) -> bool:
        """``|angle|`` beyond :data:`WARN_TURN_DEG` and not zero even ``CONFIDENCE`` σ in:
        a turn of a few degrees, decided (since 0.4.13)."""
        a = abs(self.angle_deg)
        return a > WARN_TURN_DEG and a > CONFIDENCE * self.angle_se_deg


def likely_unit(k: float, units: dict[str, float]) -> str | None:
    """The unit whose slope lies within :data:`UNIT_TOLERANCE` of ``k`` (None: none)."""
    if k <= 0.0:
        return None
    name, ratio = min(units.items(), key=lambda u: abs(math.log(k / u[1])))
    return name if abs(math.log(k / ratio)) <= UNIT_TOLERANCE else None


@dataclass(frozen=True)
class Dvl:
    """A DVL's readings at times ``t`` (n,) as body velocities ``v_b`` (n, 3) (its mounting
    applied: ``v_b = C_bs v_s``), its nominal ``period`` (s) and σ (m/s)."""

    t: Array
    v_b: Array
    period: float
    sigma: float

    @classmethod
    def of(cls, t: Array, v_s: Array, c_sb: Array | None, period: float, sigma: float) -> Dvl:
        """From the sensor-frame readings ``v_s`` (n, 3) and ``C_sb``, its isolated spikes
        left out: a Hampel test at :data:`SPIKE_MADS` (:func:`screening.spike_mask`, the
        floor the larger of σ and :data:`SPIKE_FLOOR_M_S`). The loader leaves spikes to the
        filter's guard, but here 1 % of readings spiked by 1-3 m/s put one in a third of the
        10-s intervals, more than a robust fit can leave out: up to 0.4.12 A-KIT 4 with
        `--faults --seed 0` had its right depth refused (slope 0.703 ± 0.024 on the DVL;
        0.985 clean), seed 1 gave 0.76, seed 3 1.33, A-KIT 6 seed 2 0.68."""
        v = np.asarray(v_s, dtype=float)
        ok = np.isfinite(t) & np.all(np.isfinite(v), axis=1)  # before turning: inf·0 is NaN
        v_b = v[ok] if c_sb is None else v[ok] @ np.asarray(c_sb, dtype=float)
        tt = np.asarray(t, dtype=float)[ok]
        floor = np.full(3, max(sigma, SPIKE_FLOOR_M_S))
        spike = screening.spike_mask(tt, v_b, SPIKE_MADS, floor, period)
        # A run of flagged readings is a manoeuvre faster than the window (A-KIT 1's DVL at
        # 1 Hz: -0.30, -0.13, -0.12 m/s down at 231-233 s), not spikes.
        run = np.zeros_like(spike)
        run[1:] |= spike[1:] & spike[:-1]
        run[:-1] |= spike[:-1] & spike[1:]
        keep = ~(spike & ~run)
        return cls(tt[keep], v_b[keep], period, sigma)

    def covered(self, t0: Array, t1: Array) -> NDArray[np.bool_]:
        """Intervals (t0, t1] holding at least :data:`COVER_SHARE` of their nominal readings."""
        count = np.searchsorted(self.t, t1, side="right") - np.searchsorted(self.t, t0)
        return np.asarray(count >= COVER_SHARE * (t1 - t0) / self.period, dtype=bool)


def tilt_at(tilt: axes.AccelTilt, t: Array) -> tuple[Array, Array]:
    """Roll and pitch (rad) levelled from the accelerometers at times ``t``."""
    return np.interp(t, tilt.t, tilt.angles[:, 0]), np.interp(t, tilt.t, tilt.angles[:, 1])


def down(v_b: Array, roll: Array, pitch: Array) -> Array:
    """The down component of body vectors ``v_b`` (n, 3) at the tilt given (NED, FRD)."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    return np.asarray(-sp * v_b[:, 0] + sr * cp * v_b[:, 1] + cr * cp * v_b[:, 2], dtype=float)


def level(v_b: Array, roll: Array, pitch: Array) -> NDArray[np.complex128]:
    """The horizontal components of body vectors ``v_b`` (n, 3) at the tilt given, as
    forward + i right in the level frame of the body's yaw (NED, FRD)."""
    sr, cr, sp, cp = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    forward = cp * v_b[:, 0] + sp * sr * v_b[:, 1] + sp * cr * v_b[:, 2]
    return np.asarray(forward + 1j * (cr * v_b[:, 1] - sr * v_b[:, 2]), dtype=complex)


def integral(t: Array, v: Array) -> Array:
    """The trapezoidal integral of ``v`` from ``t[0]`` at each ``t`` (``v`` (n,) or (n, k))."""
    steps = 0.5 * (v[1:] + v[:-1]) * np.diff(t).reshape((-1,) + (1,) * (v.ndim - 1))
    return np.concatenate([np.zeros((1, *v.shape[1:]), dtype=v.dtype), np.cumsum(steps, axis=0)])


def spans(t: Array, span_s: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Consecutive non-overlapping intervals (i, j) of readings at ``t`` of about ``span_s``
    each; one spanning more than 1.5 × it (a gap) is left out."""
    if t.size < 2:
        return np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp)
    m = max(1, round(span_s / float(np.median(np.diff(t)))))
    i = np.arange(0, t.size - m, m)
    j = i + m
    keep = t[j] - t[i] <= 1.5 * span_s
    return i[keep], j[keep]


def depth_scale(
    t: Array,
    depth: Array,
    dvl: Dvl,
    tilt: axes.AccelTilt,
    lever_m: Array,
) -> Fit | None:
    """The slope k of the depth's changes on the DVL's vertical displacements (module
    docstring; None: undecided). ``lever_m``: the depth meter's lever arm less the DVL's
    (body, m)."""
    ok = np.isfinite(t) & np.isfinite(depth)
    t, depth = t[ok], depth[ok]
    if dvl.t.size < 2 or t.size <= axes.MIN_INTERVALS:
        return None
    roll, pitch = tilt_at(tilt, dvl.t)
    w = integral(dvl.t, down(dvl.v_b, roll, pitch))
    r_d, p_d = tilt_at(tilt, t)
    arm = down(np.broadcast_to(np.asarray(lever_m, dtype=float), (t.size, 3)), r_d, p_d)
    i, j = spans(t, DEPTH_INTERVAL_S)
    t0, t1 = t[i], t[j]
    inside = (t0 >= dvl.t[0]) & (t1 <= dvl.t[-1]) & dvl.covered(t0, t1)
    a = (depth[j] - arm[j]) - (depth[i] - arm[i])
    b = np.where(inside, np.interp(t1, dvl.t, w) - np.interp(t0, dvl.t, w), math.nan)
    dt = t1 - t0
    good = np.isfinite(b)
    if np.count_nonzero(good) < axes.MIN_INTERVALS:
        return None
    bb, tt = b[good], dt[good]
    spread = float(bb @ bb - (bb @ tt) ** 2 / (tt @ tt))
    aa = a[good] - tt * float(a[good] @ tt) / float(tt @ tt)
    bd = bb - tt * float(bb @ tt) / float(tt @ tt)
    if spread <= 0.0 or abs(float(aa @ bd)) < MIN_CORRELATION * math.sqrt(float(aa @ aa) * spread):
        return None
    s = axes.axis_slope(a, b, dt, noise_var=dvl.sigma**2 * dvl.period * dt)
    if s is None:
        return None
    return Fit(s.k, s.se, s.n, float(t0[good][0]), float(t1[good][-1]))


def through_origin(a: Array, b: Array) -> tuple[complex, float, int] | None:
    """The robust fit ``a = k b`` of real or complex ``a``, ``b``: k, its standard error, the
    points kept (residuals beyond :data:`axes.OUTLIER_SIGMAS` robust σ left out, three times;
    None: fewer than :data:`MIN_CHORDS` kept). Complex: each component's σ, from the median
    |residual| of a circular normal (1.1774 σ)."""
    cplx = bool(np.iscomplexobj(a) or np.iscomplexobj(b))
    a, b = np.asarray(a, dtype=complex), np.asarray(b, dtype=complex)
    # A b of zeros (a DVL reading zeros throughout: bottom lock lost) has no k to give; up to
    # 0.4.11 its 0/0 was a RuntimeWarning and a NaN fit.
    keep = np.abs(b) > 0.0
    for _ in range(3):
        if np.count_nonzero(keep) < MIN_CHORDS:
            return None
        k = complex(np.vdot(b[keep], a[keep]) / np.vdot(b[keep], b[keep]).real)
        r = np.abs(a - k * b)
        s = float(np.median(r[keep])) / (1.1774 if cplx else 0.6745)
        keep = (r <= axes.OUTLIER_SIGMAS * s + 1e-15) & (np.abs(b) > 0.0)
    n = int(np.count_nonzero(keep))
    if n < MIN_CHORDS:
        return None
    k = complex(np.vdot(b[keep], a[keep]) / np.vdot(b[keep], b[keep]).real)
    rk = np.abs(a[keep] - k * b[keep])
    dof = 2 * n - 2 if cplx else n - 1
    se = math.sqrt(float(rk @ rk) / dof / float(np.vdot(b[keep], b[keep]).real))
    return k, se, n


@dataclass(frozen=True)
class Track:
    """A GNSS track's chords: start and end times ``t0``, ``t1`` (n,) and displacements ``g``
    (n,) north + i east (m); chords shorter than :data:`SPEED_CHORD_SIGMAS` σ are NaN."""

    t0: Array
    t1: Array
    g: Array

    @classmethod
    def of(cls, t: Array, lat: Array, lon: Array, sigma_m: float) -> Track:
        """From fixes (rad) with a horizontal σ ``sigma_m``."""
        ok = np.isfinite(t) & np.isfinite(lat) & np.isfinite(lon)
        t, lat, lon = t[ok], lat[ok], lon[ok]
        if t.size < 3:
            empty = np.empty(0)
            return cls(empty, empty, empty.astype(complex))
        north, east = axes.flatten(lat, lon)
        i, j = spans(t, SPEED_CHORD_S)
        g = (north[j] - north[i]) + 1j * (east[j] - east[i])
        short = np.abs(g) < SPEED_CHORD_SIGMAS * max(sigma_m, 1e-3)
        return cls(t[i], t[j], np.where(short, complex(math.nan, math.nan), g))


def dvl_chords(
    track: Track, dvl: Dvl, tilt: axes.AccelTilt, gyro: axes.Gyro
) -> tuple[Array, Array]:
    """The DVL's displacement over each chord (north + i east in a frame whose yaw is the
    gyro's integral from its start) and the gyro's yaw at each chord's start (rad)."""
    horizontal = level(dvl.v_b, *tilt_at(tilt, dvl.t))
    yaw = gyro.change(np.full(dvl.t.size, gyro.t[0]), dvl.t, 2)
    u = integral(dvl.t, horizontal * np.exp(1j * np.nan_to_num(yaw)))
    t0, t1 = track.t0, track.t1
    inside = (t0 >= max(dvl.t[0], gyro.t[0])) & (t1 <= min(dvl.t[-1], gyro.t[-1]))
    inside &= dvl.covered(t0, t1)
    d = np.interp(t1, dvl.t, u.real) - np.interp(t0, dvl.t, u.real)
    d = d + 1j * (np.interp(t1, dvl.t, u.imag) - np.interp(t0, dvl.t, u.imag))
    yaw0 = gyro.change(np.full(t0.size, gyro.t[0]), t0, 2)
    return np.where(inside, d, complex(math.nan, math.nan)), yaw0


@dataclass(frozen=True)
class Heading:
    """A heading to turn the DVL's displacements by: the body's yaw (rad) at times ``t`` and
    its σ (rad) there (None: a heading sensor's, whose slow errors the rule's margin holds)."""

    t: Array
    yaw: Array
    sigma: Array | None = None


@dataclass(frozen=True)
class StartYaw:
    """The heading the mission's start gives at the IMU's first instant: ``yaw`` and its σ
    ``sigma`` (rad), and the gyro's bias σ ``bias_sigma`` (rad/s) and ARW ``arw`` (rad/√s)
    that a yaw carried from it drifts by."""

    yaw: float
    sigma: float
    bias_sigma: float
    arw: float

    def sigma_after(self, dt: Array) -> Array:
        """σ of the yaw carried for ``dt`` (s): ``sqrt(σ0² + (σ_b Δt)² + ARW² Δt)``."""
        dt = np.maximum(dt, 0.0)
        return np.asarray(
            np.sqrt(self.sigma**2 + (self.bias_sigma * dt) ** 2 + self.arw**2 * dt), dtype=float
        )


def carried_yaw(gyro: axes.Gyro, tilt: axes.AccelTilt, lat: float, start: StartYaw) -> Heading:
    """The start's yaw carried forward by the gyro (module docstring) at the IMU's start and
    the accelerometers' block times, with its σ. ``lat``: the latitude (rad) the earth rate's
    down component ``-Ω sin L`` is taken at. Each step's rate about the vertical is the gyro's
    increment between block times turned down at the blocks' mean roll and pitch. It ends at
    the IMU's first hole (:attr:`axes.Gyro.holes`): after it the yaw carried misses the rotation
    lost in it (since the audit of 0.4.13: the demo with 150 s of IMU lost at 700 s was warned
    of a DVL +95° off the course, 'initial.rpy_deg's yaw off')."""
    holes = gyro.holes[0]
    end = float(holes[0]) if holes.size else float(gyro.t[-1])
    inside = (tilt.t > gyro.t[0]) & (tilt.t <= end)
    ang = tilt.angles[inside]
    if ang.shape[0] < 2:
        return Heading(np.empty(0), np.empty(0), np.empty(0))
    t = np.concatenate([[gyro.t[0]], tilt.t[inside]])
    theta = np.column_stack([np.interp(t, gyro.t, gyro.theta[:, k]) for k in range(3)])
    roll = np.concatenate([ang[:1, 0], 0.5 * (ang[1:, 0] + ang[:-1, 0])])
    pitch = np.concatenate([ang[:1, 1], 0.5 * (ang[1:, 1] + ang[:-1, 1])])
    turn = integral_steps(down(np.diff(theta, axis=0), roll, pitch))
    since = t - t[0]
    # The gyro reads the earth rate's down component -Ω sin L on a body fixed to the earth.
    yaw = start.yaw + turn + OMEGA_IE * math.sin(lat) * since
    return Heading(t, np.asarray(yaw, dtype=float), start.sigma_after(since))


def integral_steps(steps: Array) -> Array:
    """The running sum of ``steps`` (n,) from 0: (n + 1,)."""
    out = np.empty(steps.size + 1)
    out[0] = 0.0
    np.cumsum(steps, out=out[1:])
    return out


def dvl_track(
    track: Track,
    dvl: Dvl,
    tilt: axes.AccelTilt,
    gyro: axes.Gyro,
    heading: tuple[Array, Array] | Heading | None = None,
) -> tuple[Fit | None, Fit | None]:
    """The DVL's speed ratio (the GNSS track's chord lengths on the DVL's) and, with a
    ``heading`` (a heading sensor's (times, yaw rad), or a :class:`Heading` such as the start's
    carried by the gyro), the direction fit (module docstring); None: undecided."""
    d, yaw0 = dvl_chords(track, dvl, tilt, gyro)
    ok = np.isfinite(track.g) & np.isfinite(d)
    if np.count_nonzero(ok) < MIN_CHORDS:
        return None, None
    g, d, t0, t1 = track.g[ok], d[ok], track.t0[ok], track.t1[ok]
    speed = through_origin(np.abs(g), np.abs(d))
    ratio = None
    if speed is not None and speed[0].real > 0.0:  # the DVL's per the track's: 1 / k
        k = float(speed[0].real)
        ratio = Fit(1.0 / k, speed[1] / k**2, speed[2], float(t0[0]), float(t1[-1]))
    if heading is None:
        return ratio, None
    if not isinstance(heading, Heading):
        heading = Heading(heading[0], heading[1])
    return ratio, direction(g, d, (t0, t1), yaw0[ok], heading)


def direction(
    g: Array, d: Array, times: tuple[Array, Array], yaw0: Array, heading: Heading
) -> Fit | None:
    """The fit of ``w = G / (e^{i(ψ - ψ_g)} D)`` over the chords (start and end times
    ``times``): ψ the ``heading`` at each chord's start, ψ_g the gyro's yaw ``yaw0`` there (the
    frame of :func:`dvl_chords`). With the heading's σ, only chords whose σ at their end is
    within :data:`MAX_YAW_SIGMA_DEG` count, and the largest σ among them joins the fit's."""
    # Finite readings only: ±inf (kept by the loader for the engine to drop) would unwrap every
    # reading after it to NaN, and warn (up to the audit of 0.4.13 a RuntimeWarning).
    ok = np.isfinite(heading.t) & np.isfinite(heading.yaw)
    if np.count_nonzero(ok) < 2:
        return None
    t0, t1 = times
    ht = heading.t[ok]
    psi = np.interp(t0, ht, np.unwrap(heading.yaw[ok]), left=math.nan, right=math.nan)
    sig = np.zeros(t0.size)
    if heading.sigma is not None:
        sig = np.interp(t1, ht, heading.sigma[ok], left=math.inf, right=math.inf)
        psi = np.where(sig <= math.radians(MAX_YAW_SIGMA_DEG), psi, math.nan)
    h = np.exp(1j * (psi - yaw0)) * d
    fin = np.isfinite(h)
    w = through_origin(g[fin], h[fin])
    if w is None or abs(w[0]) == 0.0:
        return None
    ang = math.degrees(math.atan2(w[0].imag, w[0].real))
    se = math.hypot(min(w[1] / abs(w[0]), math.pi), float(np.max(sig[fin])))
    k = abs(w[0])
    t_from, t_to = float(t0[fin][0]), float(t1[fin][-1])
    return Fit(1.0 / k, w[1] / k**2, w[2], t_from, t_to, ang, math.degrees(se))


def depth_cause(fit: Fit) -> str:
    """What a depth slope outside :data:`DEPTH_BAND` points to, in words."""
    if fit.k < 0.0:
        return (
            "the depth grows as the DVL rises: is the DVL's x axis negated (a vehicle that flies "
            "pitched climbs along it), or its mounting_rpy_deg not set?"
        )
    unit = likely_unit(fit.k, UNITS_DEPTH)
    if unit is not None and unit.startswith("the DVL"):
        return f"{unit} where m/s are read (the depth right)?"
    if unit is not None:
        return f"the depth in {unit} where metres are read?"
    return "the depth's unit, or the DVL's, is not the one read?"


def speed_cause(fit: Fit) -> str:
    """What a DVL speed ratio outside :data:`SPEED_BAND` points to, in words."""
    unit = likely_unit(fit.k, UNITS_SPEED)
    if unit is not None:
        return f"the DVL's readings in {unit} where m/s are read?"
    return (
        "the DVL's readings in another unit, or a water-track DVL in a strong current "
        "(the model takes a bottom track)?"
    )


def turn_cause(fit: Fit, carried: bool = False) -> str:
    """What the DVL's direction off the GNSS course points to, in words; ``carried``: the
    heading was the start's carried by the gyro (then the start's yaw may be the one wrong)."""
    a = abs(fit.angle_deg)
    other = " (or initial.rpy_deg's yaw wrong by as much)" if carried else ""
    if a > 135.0:
        return (
            "the DVL's x axis negated (or x and y both: the DVL turned 180°), or its "
            f"mounting_rpy_deg not set{other}?"
        )
    if a > 45.0:
        return f"the DVL's x and y swapped, or its mounting_rpy_deg not set (a yaw of ±90°){other}?"
    if carried:
        return "the DVL's mounting_rpy_deg (its yaw) not set, or initial.rpy_deg's yaw off?"
    return "the DVL's mounting_rpy_deg (its yaw) not set, or the heading sensor's north off?"


ATMOSPHERE_M = 10.08
"""One standard atmosphere (101.325 kPa) in metres of sea water (1025 kg/m³, 9.81 m/s²): what
a depth meter that reads absolute pressure shows at the surface."""
AIR_MARGIN_M = 2.0
"""How far under the water a GNSS antenna may seem by the depth at its fixes before the depth
is doubted (m): waves, pitch and a lever arm measured roughly."""
SUBMERGED_M = 0.5
"""A depth meter reading this much or more at the fixes is under water, and the antenna's depth
is its reading less the antenna's height above it, whatever that height's sign; below, the
meter may be in air (reading 0), where an antenna below it by the lever arms bounds nothing
(m; since 0.4.13)."""
FIX_PAIR_S = 1.0
"""Largest time between a fix and the depth reading paired with it (s)."""
MIN_FIXES = 20
"""Fewest paired fixes the check needs."""


@dataclass(frozen=True)
class AtFixes:
    """A depth meter's median reading ``depth_m`` (m, as read) at ``n`` GNSS fixes over
    ``t_from``-``t_to``, and how far that puts the antenna under water, ``under_m``."""

    depth_m: float
    under_m: float
    n: int
    t_from: float
    t_to: float
    antenna_above_m: float = 0.0


def depth_at_fixes(
    t_depth: Array, depth: Array, t_fix: Array, antenna_above_m: float
) -> AtFixes | None:
    """The depth read at a GNSS receiver's fixes: a receiver fixes only with its antenna above
    the water, so the depth meter then reads at most ``antenna_above_m``, the antenna's height
    above it (body z of the meter less the antenna's, lever arms FRD, level vehicle). Each fix is
    paired with the nearest depth reading within :data:`FIX_PAIR_S`; ``under_m`` is the median
    reading less ``antenna_above_m``, taken as 0 where it is negative (an antenna below the
    meter) unless the meter reads :data:`SUBMERGED_M` or more: a meter in air reads 0 however
    high it is (up to 0.4.12 a negative height was always taken as 0, so a lever arm's z sign
    slipped went unseen). None: fewer than :data:`MIN_FIXES` pairs (docs/robustness.md, 'A
    depth offset at the surface')."""
    ok = np.isfinite(t_depth) & np.isfinite(depth)
    t_depth, depth = t_depth[ok], depth[ok]
    t_fix = t_fix[np.isfinite(t_fix)]
    if t_depth.size == 0 or t_fix.size < MIN_FIXES:
        return None
    # The readings either side of each fix, one and the same where there is only one (up to
    # 0.4.11 a depth meter of one reading was an IndexError here).
    hi = np.minimum(np.searchsorted(t_depth, t_fix), t_depth.size - 1)
    lo = np.maximum(hi - 1, 0)
    j = np.where(np.abs(t_depth[lo] - t_fix) <= np.abs(t_depth[hi] - t_fix), lo, hi)
    near = np.abs(t_depth[j] - t_fix) <= FIX_PAIR_S
    if np.count_nonzero(near) < MIN_FIXES:
        return None
    d = float(np.median(depth[j[near]]))
    t = t_fix[near]
    bound = antenna_above_m if d >= SUBMERGED_M else max(antenna_above_m, 0.0)
    return AtFixes(d, d - bound, int(near.sum()), float(t[0]), float(t[-1]), antenna_above_m)


def surface_cause(at: AtFixes) -> str:
    """What a depth that puts a GNSS antenna under water points to, in words."""
    if at.antenna_above_m < 0.0 and at.depth_m >= SUBMERGED_M:
        words = (
            f"the lever arms put the antenna {-at.antenna_above_m:.3g} m below the depth meter "
            "(body FRD, z down: an antenna above the meter has the smaller z): is a lever "
            "arm's z sign wrong?"
        )
        if at.depth_m <= AIR_MARGIN_M:  # the reading alone would not have been doubted
            return words
        return f"{words} Or {_depth_cause(at, 0.0)}"
    return _depth_cause(at, max(at.antenna_above_m, 0.0))


def _depth_cause(at: AtFixes, above: float) -> str:
    """The depth's own causes: an atmosphere left in (``above``: the antenna's height above the
    meter, at the surface it reads 0 to this), a pressure unit, an offset."""
    if 0.75 * ATMOSPHERE_M <= at.depth_m <= 1.25 * ATMOSPHERE_M + above:
        return (
            f"is the depth an absolute pressure (one atmosphere, about {ATMOSPHERE_M:.1f} m of "
            "sea water, left in), or in kPa (about 10 per metre)? If the atmosphere, take it "
            "off the table's depths (with heights from the depth alone, surface_h_m = "
            f"{ATMOSPHERE_M:.1f} does the same)."
        )
    return (
        "is the depth a pressure (in kPa: about 10 per metre; absolute: 101 kPa at the "
        "surface), offset, or are the lever arms wrong?"
    )
