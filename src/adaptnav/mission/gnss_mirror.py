"""A GNSS track mirrored: latitude and longitude swapped, or a hemisphere's sign lost, found by
its shape against the DVL's dead reckoning (docs/robustness.md, 'A GNSS track mirrored').

Every fix of a receiver whose latitude and longitude are swapped, or whose longitude W is
written as E (a latitude S as N), is plausible on its own, and the start's position comes from
the fixes: up to 0.4.12 the demo so ran 3 933 km off, exit 0, a post-run warning only. In the
fixes' local level frame (z = north + i east, m) swapping the two gives ``i conj(z)`` (each
axis scaled by the cosines of the two latitudes), negating the longitude ``conj(z)`` and the
latitude ``-conj(z)``: the mirror image of the true track, turned. The track dead-reckoned
from the DVL (:func:`adaptnav.mission.gnss_clock.dead_reckoned`: its levelled velocity turned
by the gyro's yaw since the IMU's start) is not mirrored. Over the windows of
:mod:`adaptnav.mission.gnss_clock` the fixes' mean's changes a_k are fitted at lag 0 on the
track's b_k both as they are and mirrored,

    a_k = w b_k + c,        conj(a_k) = w' b_k + c',

w, w' complex slopes (the start's unknown heading, the DVL's scale), c, c' complex constants
(a current, a DVL bias). Both fits share ``Σ |a - ā|²``; their residuals are
``RSS = Σ |a - ā|² - |C|² / Σ |b - b̄|²`` with ``C = Σ conj(b - b̄)(a - ā)`` for the first and
``C' = Σ (b - b̄)(a - ā)`` for the second. On a straight track (b_k = e^{iθ} r_k, r_k real)
``|C| = |C'|``: a mirror is then a rotation and nothing can be told; where the vehicle turns,
a mirrored GNSS follows the mirrored model and a right one the direct model.

The rule is in the style of :meth:`adaptnav.mission.clocks.ClockOffset.decisive`, with the
mirror in place of the offset: the likelihood ratio statistic ``N_eff ln V`` (V = RSS / RSS',
N_eff the mirrored fit's real residuals, two a window, shrunk by their lag-one correlation as
:func:`adaptnav.mission.clocks.n_eff` does, less the four parameters) at least
:data:`MIN_LOG_LR`, and the mirrored slope's scale |w'| within :data:`SCALE_BAND` (a right
DVL's 1, stretched by a swap's axis scaling). The track's changes must spread by
:data:`adaptnav.mission.axes.SIGNAL_FACTOR` times the fixes' own noise, as gnss_clock asks.

A gyro whose z axis is negated mirrors the dead reckoning instead, and looks the same. Where
the mission aligns at rest, :func:`earth_rate` sets the gyro's mean rate about the local
vertical against the earth rate's down component ``-Ω sin L`` at the fixes' latitude: of the
other sign (:meth:`EarthRate.flipped`), the gyro's z or the latitude's sign is wrong (a
latitude negated both mirrors the fixes and moves the rate expected), and the loader names
both.

Pure NumPy, no I/O: :func:`check` is called by :func:`adaptnav.mission.loader.cross_check`
after the DVL's clock and before the GNSS's, which raises the MissionError naming the GNSS's
file and its ``lat_rad``, ``lon_rad`` columns. Since 0.4.13.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptnav.core.earth import OMEGA_IE
from adaptnav.mission import axes, clocks, gnss_clock, scales
from adaptnav.mission.config import MissionConfig

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

MIN_LOG_LR = axes.CONFIDENCE**2
"""Least ``N_eff ln V`` (twice the log likelihood ratio) for the mirror to be decided: 16, the
project's 4 σ as a χ²(1) statistic (p ≈ 6e-5). One alternative is weighed, not ~10³ lags as in
clocks.py (whose :data:`adaptnav.mission.clocks.MIN_LOG_LR` of 30 pays for them). Right tracks
measured at -9 or below (docs/robustness.md, 'A GNSS track mirrored')."""
SCALE_BAND = (0.5, 2.0)
"""Scales |w'| of the mirrored fit a mirrored GNSS may show: 1 for a sign lost; a swap scales
the read north by ``1 / cos L_true`` and east by ``cos L_read`` (1.12 and 0.56 on the demo's
27° N, 56° E: 0.86 measured)."""


@dataclass(frozen=True)
class Mirror:
    """The two fits of a GNSS track's changes on the DVL's: residual variance ratio ``ratio``
    (direct over mirrored), the slopes' scales ``k`` (mirrored) and ``k_direct``, the windows
    ``n`` (real residuals, two a window) and ``n_eff`` of them independent, over
    ``t_from``-``t_to`` (s)."""

    ratio: float
    k: float
    k_direct: float
    n: int
    n_eff: float
    t_from: float
    t_to: float

    @property
    def log_lr(self) -> float:
        """``N_eff ln V``: the likelihood ratio statistic of the mirrored fit over the direct."""
        return self.n_eff * math.log(max(self.ratio, 1e-300))

    def mirrored(self) -> bool:
        """The mirrored fit beats the direct decisively at a plausible scale (module docstring)."""
        return self.log_lr >= MIN_LOG_LR and SCALE_BAND[0] <= self.k <= SCALE_BAND[1]


def _changes(
    t: Array, p: CArray, period: float, track: tuple[Array, CArray]
) -> tuple[CArray, CArray, Array] | None:
    """The fixes' window means' changes a, the track's b over the same windows, and the
    windows' start times, where both count (no gap in the fixes, the track covering both)."""
    width = max(gnss_clock.WINDOW_S, gnss_clock.WINDOW_PERIODS * period)
    g0, a, m = gnss_clock.windows(t, p, width, period)
    s, d = gnss_clock.boxed(*track, width)
    if s.size < 2:
        return None
    g = g0 + width * np.arange(a.size + 1)
    inside = (g >= s[0]) & (g <= s[-1])
    at = np.interp(g, s, d.real) + 1j * np.interp(g, s, d.imag)
    use = (m > 0.0) & inside[:-1] & inside[1:]
    b = np.diff(at)
    return a[use], np.asarray(b[use], dtype=complex), g[:-1][use]


def mirror_fit(
    t: Array, north: Array, east: Array, period: float, track: tuple[Array, CArray]
) -> Mirror | None:
    """The direct and mirrored fits of the fixes (``north``, ``east`` m at ``t``, receiver
    period ``period`` s) on the dead-reckoned ``track`` (times, north + i east m) (module
    docstring). None: too few windows, or the track's changes not above the fixes' noise."""
    ok = np.isfinite(t) & np.isfinite(north) & np.isfinite(east)
    t, p = t[ok], north[ok] + 1j * east[ok]
    if not gnss_clock.long_enough(t, period) or track[0].size < 2:
        return None
    got = _changes(t, p, period, track)
    if got is None or got[0].size < axes.MIN_INTERVALS:
        return None
    a, b, g = got
    a, b = a - a.mean(), b - b.mean()
    saa, sbb = float(np.sum(np.abs(a) ** 2)), float(np.sum(np.abs(b) ** 2))
    width = max(gnss_clock.WINDOW_S, gnss_clock.WINDOW_PERIODS * period)
    if sbb <= axes.SIGNAL_FACTOR * gnss_clock.fix_noise(t, p, width) * a.size:
        return None
    direct, mirror = complex(np.vdot(b, a)), complex(np.sum(b * a))
    rss_d = max(saa - abs(direct) ** 2 / sbb, 0.0)
    rss_m = max(saa - abs(mirror) ** 2 / sbb, 0.0)
    w = mirror.conjugate() / sbb  # conj(a) = w' b: w' = Σ conj(b) conj(a) / Σ |b|²
    # Each window gives two real residuals (north, east), as gnss_clock counts them.
    r = np.conj(a) - w * b
    n = 2 * a.size
    n_eff = clocks.n_eff(np.stack([r.real, r.imag])) * (n - 4.0) / n
    ratio = rss_d / rss_m if rss_m > 0.0 else math.inf
    return Mirror(ratio, abs(w), abs(direct) / sbb, n, n_eff, float(g[0]), float(g[-1] + width))


@dataclass(frozen=True)
class EarthRate:
    """The gyro's mean rate about the local vertical ``rate`` (rad/s, levelled) over the
    alignment's ``span_s`` seconds at rest, its σ ``sigma`` (the gyro's bias σ and ARW), and
    ``expected``, the earth rate's down component ``-Ω sin L`` at the fixes' latitude L."""

    rate: float
    expected: float
    sigma: float
    span_s: float

    def flipped(self) -> bool:
        """The rate lies off ``expected`` by more than :data:`axes.CONFIDENCE` σ and nearer
        ``-expected``: the gyro's z negated, or the latitude's sign (module docstring)."""
        off = abs(self.rate - self.expected)
        return off > axes.CONFIDENCE * self.sigma and abs(self.rate + self.expected) < off


def earth_rate(
    views: axes.ImuViews, span_s: float, lat: float, bias_sigma: float
) -> EarthRate | None:
    """The gyro's down rate over the IMU's first ``span_s`` seconds (an alignment at rest),
    against ``-Ω sin lat``; ``bias_sigma`` the gyro's bias σ (rad/s). The rate is the change of
    :func:`scales.carried_yaw` (from 0, at latitude 0: the levelled gyro alone) over the span.
    None: no span, or the IMU shorter."""
    gyro, tilt = views.gyro(), views.tilt()
    if span_s <= 0.0 or not math.isfinite(lat) or gyro.t[-1] - gyro.t[0] < span_s:
        return None
    turn = scales.carried_yaw(gyro, tilt, 0.0, scales.StartYaw(0.0, 0.0, 0.0, 0.0))
    if turn.t.size < 2 or turn.t[-1] < gyro.t[0] + span_s:  # a hole within the span
        return None
    rate = float(np.interp(gyro.t[0] + span_s, turn.t, turn.yaw) - turn.yaw[0]) / span_s
    sigma = math.hypot(bias_sigma, views.noise[0] / math.sqrt(span_s))
    return EarthRate(rate, -OMEGA_IE * math.sin(lat), sigma, span_s)


@dataclass(frozen=True)
class Finding:
    """GNSS ``name``'s track found ``mirror``-imaged against DVL ``dvl``'s, and the gyro's
    ``earth`` rate at rest against the fixes' latitude (None: no alignment at rest)."""

    name: str
    dvl: str
    mirror: Mirror
    earth: EarthRate | None = None


def check(
    config: MissionConfig, views: axes.ImuViews, sensors: Mapping[str, gnss_clock.Readings]
) -> list[Finding]:
    """Each GNSS receiver (its ``scale_check`` on) whose track is decisively the mirror image
    of the first DVL's dead-reckoned track (module docstring). Nothing without a DVL."""
    judged = [
        n for n, g in sensors.items()
        if g.kind == "gnss" and config.sensors[n].check_scale and g.t.size > 2
    ]  # fmt: skip
    first = gnss_clock.dvl_track(config, views, sensors) if judged else None
    if first is None:
        return []
    dvl_name, track = first
    out = []
    for name in judged:
        g = sensors[name]
        fixes = gnss_clock.local_fixes(g)
        found = None if fixes is None else mirror_fit(*fixes, track)
        if found is not None and found.mirrored():
            lat = float(np.nanmedian(g.z[:, 0]))
            out.append(Finding(name, dvl_name, found, _earth(config, views, lat)))
    return out


def _earth(config: MissionConfig, views: axes.ImuViews, lat: float) -> EarthRate | None:
    """:func:`earth_rate` over the alignment (``initial.mode = "alignment"``, at rest for
    ``alignment_s``), the gyro's bias σ that of ``imu.initial_bias_sigma``; None otherwise."""
    if config.initial.mode != "alignment":
        return None
    bias = float(config.imu.initial_bias_sigma.si(config.imu.noise.to_imu_noise())[0])
    return earth_rate(views, float(config.initial.alignment_s), lat, bias)
