"""A GNSS receiver's clock against the DVL's dead reckoning: the offset of its stamps from its
positions, where its course is too noisy to date (docs/robustness.md, 'Sensor clocks').

:mod:`adaptnav.mission.clocks` dates a GNSS from its course over ground against the gyro. A
surface fix of metres of σ on a vessel at 2 m/s leaves the course over its chords undecided
(the demo, the paper's trials), so stamps 18 s late went unseen up to 0.4.11. The positions
themselves still carry the clock: where the vehicle turns, starts or stops, the track
dead-reckoned from the DVL moves τ seconds ahead of fixes stamped τ late. Since 0.4.12 the
fixes' means over windows of :data:`WINDOW_S` (their positions linearly interpolated, boxed
over the window) are fitted on the dead-reckoned track's, boxed the same way and taken τ
earlier, over consecutive windows g_k = g_0 + k L:

    a_k = w b_k(τ) + c,        b_k(τ) = D̄(g_{k+1} - τ) - D̄(g_k - τ),

a_k the change of the fixes' mean (north + i east, m), D(t) the DVL's levelled horizontal
velocity turned by the gyro's yaw since the IMU's start and integrated (:func:`dead_reckoned`),
D̄ its mean over the window, w a complex slope and c a complex constant. w's angle takes the
start's unknown heading and |w| the DVL's scale, so no heading is needed; c takes a steady
current or a DVL bias. Only the changes between neighbouring windows are fitted, so the
yaw's slow drift (the gyro's bias) and a scale error change w by nothing a lag can use: a
straight track at a steady speed gives the same changes at every lag and dates nothing.

The complex fit's sums are those of :mod:`adaptnav.mission.clocks`' real one, per pair of
components: ``Σ conj(b) a = Σ (b_N a_N + b_E a_E) + i Σ (b_N a_E - b_E a_N)``, each a real
correlation over the lags (``clocks.Scan``; four scans of six FFT correlations at phases
1 s apart). The residual ``RSS(τ) = Σ |a - ā|² - |Σ conj(b - b̄)(a - ā)|² / Σ |b - b̄|²``,
its least, the parabola through it and the σ by Gauss-Newton with N_eff are clocks.py's
(``s² = RSS / (2N - 4)``: two real components, four real parameters; N and N_eff count
the real residuals, two a window, as the likelihood ratio of a complex normal does). The rule
is clocks.py's (:meth:`adaptnav.mission.clocks.ClockOffset.decisive`: likelihood ratio, slope
band and ``|τ| > 4 σ``) with its share of the signal not asked (``min_ratio = 1``: a track's
changes are mostly its speed's steps, which no lag changes).

Pure NumPy, no I/O: :func:`check` is called by :func:`adaptnav.mission.loader.cross_check`,
which warns of each :class:`Finding` or raises the MissionError naming the GNSS's file and
``t_s``, as for the other clocks.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission import axes, clocks, scales
from adaptnav.mission.config import MissionConfig

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]


WINDOW_S = 10.0
"""Width of the windows the fixes are averaged over (s): a wave's roll of a high antenna
(metres at 5-12 s) averages out, a turn of a minute does not."""
WINDOW_PERIODS = 4.0
"""A window holds at least this many of the receiver's periods (a slow receiver's windows
are wider)."""


class Readings(Protocol):
    """A sensor's readings as the loader holds them (``loader.SensorData``)."""

    @property
    def kind(self) -> str: ...
    @property
    def t(self) -> Array: ...
    @property
    def z(self) -> Array: ...
    @property
    def period(self) -> float: ...


def dead_reckoned(dvl: scales.Dvl, tilt: axes.AccelTilt, gyro: axes.Gyro) -> tuple[Array, CArray]:
    """The DVL's track: its levelled horizontal velocity (north + i east in a frame whose yaw is
    the gyro's integral since the IMU's start) integrated from its first reading, at its
    readings' times (m). Levelled as in :func:`adaptnav.mission.scales.dvl_chords`."""
    horizontal = scales.level(dvl.v_b, *scales.tilt_at(tilt, dvl.t))
    yaw = gyro.change(np.full(dvl.t.size, gyro.t[0]), dvl.t, 2)
    inside = np.isfinite(yaw)
    u = scales.integral(dvl.t[inside], horizontal[inside] * np.exp(1j * yaw[inside]))
    return dvl.t[inside], np.asarray(u, dtype=complex)


def boxed(t: Array, x: CArray, width: float) -> tuple[Array, CArray]:
    """The mean of ``x`` (linearly interpolated between its samples at ``t``) over
    ``[s - width / 2, s + width / 2]`` at times s on a grid of :data:`clocks.MIN_STEP_S`: the
    grid's trapezoidal integral's differences (``x`` is put on the grid first: the integral of
    a sample interval seconds long is not linear within it)."""
    h = clocks.MIN_STEP_S
    f = t[0] + h * np.arange(int((t[-1] - t[0]) / h) + 1)
    c = scales.integral(f, np.interp(f, t, x.real) + 1j * np.interp(f, t, x.imag))
    half = max(1, round(0.5 * width / h))
    mean = (c[2 * half :] - c[: -2 * half]) / (2 * half * h)
    return f[half:-half], np.asarray(mean, dtype=complex)


def windows(t: Array, p: CArray, width: float, period: float) -> tuple[float, CArray, Array]:
    """The fixes' window means' changes ``a`` over the grid g_k from its start (returned) by
    ``width``, and 1 where no gap of more than clocks.GAP_PERIODS periods lies in the two
    windows (a mean across a gap is a ramp)."""
    s, mean = boxed(t, p, width)
    g = s[0] + width * np.arange(int((s[-1] - s[0]) / width) + 1)
    at = np.interp(g, s, mean.real) + 1j * np.interp(g, s, mean.imag)
    gaps = np.diff(t) > clocks.GAP_PERIODS * period
    # before[i]: the gaps among the fix intervals ahead of fix i. A window pair spans
    # [g_k - L/2, g_{k+1} + L/2]; the intervals it touches run from the one holding its
    # start (fix k0 - 1 on) to the one holding its end (up to fix k1).
    before = np.concatenate([[0], np.cumsum(gaps)])
    k0 = np.searchsorted(t, g[:-1] - 0.5 * width, side="right")
    k1 = np.searchsorted(t, g[1:] + 0.5 * width, side="left")
    touched = before[np.minimum(k1, t.size - 1)] - before[np.maximum(k0 - 1, 0)]
    m = (touched == 0).astype(float)
    a = np.diff(at)
    return float(g[0]), np.asarray(a * m, dtype=complex), m


def gnss_offset(
    t: Array,
    north: Array,
    east: Array,
    period: float,
    track: tuple[Array, CArray],
    max_offset_s: float = clocks.MAX_OFFSET_S,
) -> clocks.ClockOffset | None:
    """The offset of the fixes (``north``, ``east`` m at ``t``, receiver period ``period``)
    against the dead-reckoned ``track`` (times, north + i east m) (module docstring): ``k``
    and ``k_zero`` are |w| at the offset and at lag 0. None: too few windows, or the track's
    changes between windows not above the fixes' own noise (a straight track at a steady
    speed: no clock to read)."""
    ok = np.isfinite(t) & np.isfinite(north) & np.isfinite(east)
    t, p = t[ok], north[ok] + 1j * east[ok]
    width = max(WINDOW_S, WINDOW_PERIODS * period)
    if not long_enough(t, period) or track[0].size < 2:
        return None
    s, d = boxed(*track, width)
    if s.size < 2 or float(s[-1] - s[0]) < (axes.MIN_INTERVALS + 2) * width:
        # A DVL track shorter than the fixes need (three readings left, or its last 26 s):
        # up to 0.4.12 an IndexError or a NaN in the scan's sums.
        return None
    g0, a, m = windows(t, p, width, period)
    # One column each: clocks' scan takes a reference's changes (m, intervals) and the IMU
    # side's columns (n, m).
    b_n, b_e = np.ascontiguousarray(d.real[:, None]), np.ascontiguousarray(d.imag[:, None])
    ref_n = clocks.Reference(g0, width, a.real[None, :], m)
    ref_e = clocks.Reference(g0, width, a.imag[None, :], m)
    nn, ee = (clocks.Scan.of(r, s, b, max_offset_s) for r, b in ((ref_n, b_n), (ref_e, b_e)))
    ne, en = (clocks.Scan.of(r, s, b, max_offset_s) for r, b in ((ref_e, b_n), (ref_n, b_e)))
    n, saa, sbb = nn.n + ee.n, nn.saa + ee.saa, nn.sbb + ee.sbb
    sab = (nn.sab + ee.sab) + 1j * (ne.sab - en.sab)
    return _judge(nn.tau, (n, saa, sab, sbb), (ref_n, ref_e), (s, d), fix_noise(t, p, width))


def long_enough(t: Array, period: float) -> bool:
    """Stamps ``t`` (finite ones) of a receiver of period ``period`` (NaN: their median
    interval) span enough windows for a fit: :data:`axes.MIN_INTERVALS` pairs and two more."""
    t = t[np.isfinite(t)]
    if t.size < 3:
        return False
    step = period if math.isfinite(period) else float(np.median(np.diff(t)))
    return float(t[-1] - t[0]) >= (axes.MIN_INTERVALS + 2) * max(WINDOW_S, WINDOW_PERIODS * step)


def fix_noise(t: Array, p: CArray, width: float) -> float:
    """The variance (m², both components) the fixes' white noise gives a change of their
    window means, ``4 σ² / m`` (m fixes a window, σ² each component's). σ² is taken from the
    fixes' second differences, which a steady course and speed leave at zero: their ``|d|²``
    is ``12 σ²`` on average over both components, its median ``12 σ² ln 2`` (a circular
    normal's)."""
    d = p[2:] - 2.0 * p[1:-1] + p[:-2]
    var = float(np.median(np.abs(d) ** 2)) / math.log(2.0) / 12.0 if d.size else 0.0
    per = max(width / float(np.median(np.diff(t))), 1.0)
    return 4.0 * var / per


def _judge(
    tau: Array,
    sums: tuple[Array, Array, CArray, Array],
    refs: tuple[clocks.Reference, clocks.Reference],
    track: tuple[Array, CArray],
    noise: float,
) -> clocks.ClockOffset | None:
    """The complex fit at every lag from its centred sums (module docstring)."""
    n, saa, sab, sbb = sums
    with np.errstate(divide="ignore", invalid="ignore"):
        w = sab / sbb
        rss = np.maximum(saa - np.abs(sab) ** 2 / sbb, 0.0)
    windows = float(refs[0].m.sum())
    valid = (n >= 2 * max(axes.MIN_INTERVALS, 0.5 * windows)) & (
        sbb > axes.SIGNAL_FACTOR * noise * n / 2.0
    )
    zero = int(np.argmin(np.abs(tau)))
    if not valid[zero]:
        return None
    var = np.where(valid, rss / np.maximum(n - 4.0, 1.0), np.inf)
    j = int(np.argmin(var))
    shift, curvature = clocks.parabola(rss, j)
    h = float(tau[1] - tau[0]) if tau.size > 1 else refs[0].step
    # Each window gives two real residuals (north, east), counted as clocks.py counts one.
    n_eff = _n_eff(refs, track, float(tau[j]), complex(w[j])) * float(n[j])
    sigma2 = float(rss[j]) / max(float(n[j]) - 5.0, 1.0)
    se = math.sqrt(2.0 * sigma2 / curvature) * h if curvature > 0.0 else math.inf
    se = max(se * math.sqrt(float(n[j]) / n_eff), h / math.sqrt(12.0))
    # Lag 0 judged with the slope found at the offset, as clocks.py does.
    wj = complex(w[j])
    rss0 = float(saa[zero] - 2.0 * (wj.conjugate() * sab[zero]).real + abs(wj) ** 2 * sbb[zero])
    var0 = rss0 / max(float(n[zero]) - 2.0, 1.0)
    signal = float(abs(wj) ** 2 * sbb[j] / n[j])
    return clocks.ClockOffset(
        offset_s=float(tau[j]) + shift * h,
        se_s=se,
        k=abs(wj),
        k_zero=float(abs(w[zero])),
        ratio=var0 / float(var[j]) if var[j] > 0.0 else math.inf,
        share=(var0 - float(var[j])) / signal if signal > 0.0 else 0.0,
        n=int(n[j]),
        n_eff=n_eff,
        # The share of the signal is not asked: a track's changes between windows are mostly
        # its speed's steps (a start from rest), which no lag changes, so an 18-s offset leaves
        # only 0.09 of them unexplained on the demo. A ratio of 1 passes whenever the
        # likelihood ratio does.
        min_ratio=1.0,
    )


def _n_eff(
    refs: tuple[clocks.Reference, clocks.Reference],
    track: tuple[Array, CArray],
    tau: float,
    w: complex,
) -> float:
    """The share of the windows' residuals at lag ``tau`` that are independent,
    ``(1 - ρ) / (1 + ρ)``, ρ their lag-one correlation when positive: :func:`clocks.n_eff` of
    the complex residual's real and imaginary parts, whose pooled ρ is
    ``Re Σ r_{k+1} conj(r_k) / Σ |r_k|²``."""
    s, d = track
    b_n, covered = refs[0].imu(s, np.ascontiguousarray(d.real[:, None]), tau)
    b_e, _ = refs[0].imu(s, np.ascontiguousarray(d.imag[:, None]), tau)
    use = (refs[0].m * covered) > 0.0
    r = (refs[0].a[0] + 1j * refs[1].a[0])[use] - w * (b_n[0] + 1j * b_e[0])[use]
    if r.size == 0:
        return 1.0
    return clocks.n_eff(np.stack([r.real, r.imag])) / (2.0 * float(r.size))


@dataclass(frozen=True)
class Finding:
    """GNSS ``name``'s decisive offset ``found`` beyond ±:data:`adaptnav.mission.axes.MAX_LAG_S`,
    its ``period`` (s) and what the loader says of it (``words``, with the fix)."""

    name: str
    found: clocks.ClockOffset
    period: float
    words: str


def dvl_track(
    config: MissionConfig, views: axes.ImuViews, sensors: Mapping[str, Readings]
) -> tuple[str, tuple[Array, CArray]] | None:
    """The first DVL's name and its dead-reckoned track (:func:`dead_reckoned`: times, north +
    i east m), which the GNSS's checks by its positions take; None: no DVL, or too few of its
    readings or of the accelerometers' tilt blocks for a track."""
    name = next((n for n, d in sensors.items() if d.kind == "dvl"), None)
    if name is None or sensors[name].t.size < 2:
        return None
    d, dcfg = sensors[name], config.sensors[name]
    period = d.period if math.isfinite(d.period) else float(np.median(np.diff(d.t)))
    dvl = scales.Dvl.of(d.t, d.z[:, :3], dcfg.sensor_from_body(), period, 0.0)
    tilt = views.tilt()
    if dvl.t.size < 2 or tilt.t.size < 2:
        return None
    gyro = views.gyro()
    track = unbroken(dead_reckoned(dvl, tilt, gyro), *gyro.holes)
    return None if track[0].size < 2 else (name, track)


def unbroken(track: tuple[Array, CArray], start: Array, end: Array) -> tuple[Array, CArray]:
    """The longest part (in time) of ``track`` (times, north + i east m) between the IMU's holes
    (``start``, ``end``, s; :attr:`adaptnav.mission.axes.Gyro.holes`): across a hole the gyro's
    yaw is the repair's, and the track after it is turned by the rotation lost, which no one
    slope fits (since 0.4.13, helper aud2's audit: the demo with 100 s of IMU lost at 700 s had
    its right GNSS refused as mirrored)."""
    t, p = track
    if not start.size or not t.size:
        return track
    piece = np.searchsorted(end, t, side="right")  # the holes ended by t
    ok = (piece >= start.size) | (t <= start[np.minimum(piece, start.size - 1)])
    ids = np.unique(piece[ok])
    spans = [float(np.ptp(t[ok & (piece == i)])) for i in ids]
    keep = ok & (piece == ids[int(np.argmax(spans))]) if ids.size else ok
    return t[keep], np.asarray(p[keep], dtype=complex)


def local_fixes(g: Readings) -> tuple[Array, Array, Array, float] | None:
    """A receiver's finite fixes as the checks by its positions take them: their times, north
    and east (m, :func:`adaptnav.mission.axes.flatten`'s frame) and the receiver's period (its
    median interval when ``rate_hz`` is not given). Finite only: the frame's origin is the
    first fix, and ±inf (kept by the loader for the engine to drop) has no cosine (up to the
    audit of 0.4.13 a RuntimeWarning). None: fewer than three."""
    ok = np.isfinite(g.t) & np.isfinite(g.z[:, 0]) & np.isfinite(g.z[:, 1])
    if np.count_nonzero(ok) < 3:
        return None
    north, east = axes.flatten(g.z[ok, 0], g.z[ok, 1])
    period = g.period if math.isfinite(g.period) else float(np.median(np.diff(g.t[ok])))
    return g.t[ok], north, east, period


def check(
    config: MissionConfig, views: axes.ImuViews, sensors: Mapping[str, Readings]
) -> list[Finding]:
    """Each GNSS receiver against the first DVL's dead-reckoned track (both ``use`` aid or
    init) whose fixes follow the track decisively better at an offset beyond 1 s than as
    stamped: the loader refuses it beyond two of its periods, else warns (docs/robustness.md,
    'Sensor clocks'). Nothing without a DVL (a car's GNSS is dated by its course:
    mission/clocks.py). Since 0.4.12."""
    long = [n for n, g in sensors.items() if g.kind == "gnss" and long_enough(g.t, g.period)]
    first = dvl_track(config, views, sensors) if long else None
    if first is None:
        return []
    dvl_name, track = first
    out = []
    for name in long:
        g = sensors[name]
        fixes = local_fixes(g)
        if fixes is None:
            continue
        found = gnss_offset(*fixes, track)
        gp = fixes[3]
        if found is None or not found.decisive() or abs(found.offset_s) <= axes.MAX_LAG_S:
            continue
        width = max(WINDOW_S, WINDOW_PERIODS * gp)
        latency = config.sensors[name].latency_s or 0.0
        words = _words(name, dvl_name, found, latency, (g.t[0], g.t[-1], width))
        out.append(Finding(name, found, gp, words))
    return out


def _words(
    name: str,
    dvl: str,
    found: clocks.ClockOffset,
    latency_s: float,
    span: tuple[float, float, float],
) -> str:
    """What :func:`check` says of GNSS ``name``'s offset against DVL ``dvl``, and the fix;
    ``span``: the fixes' first and last stamps and the windows' width (s)."""
    tau = found.offset_s
    when = "after" if tau > 0.0 else "before"
    return (
        f"the stamps of sensor {name!r} (lat_rad, lon_rad) lie {abs(tau):.1f} ± "
        f"{found.se_s:.1f} s {when} its fixes were taken: its positions' changes over "
        f"{found.n // 2} windows of {span[2]:g} s follow the track dead-reckoned from DVL "
        f"{dvl!r}, turned by the gyro, at that offset (scale {found.k:.3g}, 1 expected); as "
        f"stamped, the residual variance is {found.ratio:.3g} times as large (likelihood ratio "
        f"{found.log_lr:.0f}), from t = {span[0]:.1f} to {span[1]:.1f} s. Set latency_s = "
        f"{latency_s + tau:.1f} in [sensors.{name}] (now {latency_s:g}), or set the logger's "
        "clock right."
    )
