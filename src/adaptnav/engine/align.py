"""Static alignment and initialisation: coarse levelling and gyrocompassing, then a
zero-velocity fine alignment by the filter itself (docs/alignment.md).

The vehicle is at rest for a window of T seconds (the paper: 10 min alongside). Conventions of
``docs/conventions.md``: NED n-frame, FRD body, ``C_nb = Rz(ψ) Ry(θ) Rx(φ)``, error state
``dx = x_true ⊖ x_hat`` with ``C_true = Exp(phi) C_hat``; the IMU is corrected as
``f = f̃ - b_a``, ``ω = ω̃ - b_g``.

Coarse alignment (Groves (2013) §5.6.2, §5.6.3), from the window means ``f̄ = Σ Δv / T``,
``ω̄ = Σ Δθ / T``:

* Levelling. At rest ``f_b = C_nbᵀ [0, 0, -g] = [g sθ, -g sφ cθ, -g cφ cθ]``, so::

      φ = atan2(-f̄_y, -f̄_z),    θ = atan2(f̄_x, sqrt(f̄_y² + f̄_z²)).

* Gyrocompassing. At rest ``ω_ib_b = C_nbᵀ ω_ie_n``, ``ω_ie_n = Ω [cos L, 0, -sin L]``. In the
  levelled frame ``ω_l = Ry(θ) Rx(φ) ω̄ = Rz(ψ)ᵀ ω_ie_n = Ω [cψ cos L, -sψ cos L, -sin L]``::

      ψ = atan2(-ω_l,y, ω_l,x).

Error of the coarse solution (first order; derived for this error convention, cf. Groves
§5.6.2 and §14.4.1): with the window-mean errors ``e_f = C_nb δf̄_b`` and ``e_ω = C_nb δω̄_b``
(bias plus averaged white noise), the levelled frame makes the estimated f_n vertical and the
gyrocompass makes the estimated earth rate's east component zero, whence::

      phi_N = e_f,E / g,    phi_E = -e_f,N / g,
      phi_D = e_ω,E / (Ω cos L) - tan L · phi_N          (gyrocompass)

so ``σ_level ≈ sqrt(σ_ba² + VRW²/T) / g`` and
``σ_ψ ≈ sqrt((σ_bg² + ARW²/T) / (Ω cos L)² + (tan L σ_level)²)``. Gyrocompassing is used when
σ_ψ is below ``max_heading_sigma`` (5° by default) and no better heading is given; otherwise the
given heading (a heading sensor's mean reading, or the configuration) with its σ; with neither,
:class:`AlignmentError`. At 26.8° N, Ω cos L = 13.43 deg/h: a 1 deg/h gyro gives
σ_ψ ≈ 4.3° in 10 min (gyrocompassing just usable), a 10 deg/h MEMS gyro 43° (not).

Fine alignment (Groves §14.4.1, §15.3.1): the error-state filter (fixed R, exact epochs) runs over
the same window from the coarse attitude, with zero-velocity pseudo-measurements
(:class:`adaptnav.sensors.zupt.ZeroVelocity`) and GNSS position fixes if given. Its initial P
carries the coarse solution's errors *with their correlation to the biases* (the relations
above with e_f, e_ω driven by the turn-on biases): the coarse tilt is exactly the one that
cancels the horizontal accelerometer bias, and the gyrocompass heading the one that cancels the
east gyro bias. What the window can and cannot estimate, at rest:

* the vertical accelerometer bias, the north and (weakly, through the heading's drift into
  tilt) the down gyro bias, and the white-noise part of the attitude error are estimated;
* the horizontal accelerometer bias is **not separable from tilt** (the ZUPT sees only
  ``g phi - C b_a``) and the east gyro bias not from the heading error (the gyrocompass limit
  ``phi_D = δb_g,E / (Ω cos L)``): their P stays near the coarse σ, and only motion or other
  sensors (inclinometer, heading, DVL in turns) separate them afterwards.

A given heading is applied at the window's start; the barely observable down gyro bias drifts
it over the window, and P carries that (a 10 deg/h gyro: up to 1.7° more in 10 min).

The fine alignment runs the engine ``at_rest``: F is built with the specific force of a vehicle
at rest, ``-g_n``, not the measured ``f_hat = C_hat (f̃ - b_a_hat)``. At rest the horizontal part
of f_hat is accelerometer noise and the tilt estimate's wander; in ``-[f_hat×] phi`` it made the
heading look observable (the true error dynamics have the true, vertical f), a classic EKF
inconsistency: over 24 seeds with the paper's IMU the alignment claimed a heading σ of 3.3°
against an actual RMS of 4.5°. With ``-g_n`` it claims 3.9° against 3.7°
(tests/unit/test_align.py).

Sources: Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*,
2nd ed. (2013), §5.6 (initialisation and alignment), §14.4 (fine alignment), §15.3.1 (ZUPT);
the procedure in words: docs/alignment.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core import attitude, earth
from adaptnav.core.units import G0
from adaptnav.engine.batch import EngineConfig, EngineOutput, SensorChannel, run_batch
from adaptnav.estimation.noise.fixed import FixedNoise
from adaptnav.models.errorstate import ATT, BA, BG, N_STATES, POS, VEL
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.models.strapdown import NavState
from adaptnav.sensors.gnss import GNSS
from adaptnav.sensors.zupt import ZeroVelocity

Array = NDArray[np.float64]
HeadingSource = Literal["gyrocompass", "heading"]

MAX_HEADING_SIGMA = math.radians(5.0)
"""Default: gyrocompass only if its predicted heading σ is below 5°."""
DEFAULT_ZUPT = ZeroVelocity()
"""Default zero-velocity pseudo-measurement: σ 0.01 m/s per axis."""


class AlignmentError(ValueError):
    """The alignment cannot be done with these inputs (the message says why)."""


class NotStaticError(AlignmentError):
    """The IMU data of the alignment window do not look like a vehicle at rest."""


@dataclass(frozen=True)
class StaticTolerances:
    """How far the window's IMU data may be from a vehicle at rest (checked in coarse alignment).

    With ``σ`` the bias and white-noise figures passed to :func:`coarse_align`:

    * ``| |f̄| - g | <= specific_force + 5 σ_ba`` (a vehicle accelerating along its axis);
    * ``| |ω̄| - Ω | <= mean_rate + 5 sqrt(σ_bg² + ARW²/T)`` (a turning vehicle; skipped when
      the gyro bias σ is unknown);
    * every ``block_length``-second mean of f and ω within ``block_specific_force + 6 VRW/√τ``
      and ``block_rate + 6 ARW/√τ`` of the window mean (waves, rolling, handling).

    A vehicle moving at constant velocity on a straight line cannot be told from one at rest by
    its IMU; that is the user's responsibility (or the GNSS fixes').
    """

    specific_force: float = 0.1
    mean_rate: float = 1e-4
    block_specific_force: float = 0.1
    block_rate: float = 0.01
    block_length: float = 1.0

    def __post_init__(self) -> None:
        for name in (
            "specific_force",
            "mean_rate",
            "block_specific_force",
            "block_rate",
            "block_length",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name}: value {v!r} must be finite and > 0")


@dataclass(frozen=True, eq=False)
class CoarseInfo:
    """What coarse alignment found and how good it expects it to be.

    Attributes:
        heading_source: ``"gyrocompass"`` or ``"heading"`` (the given heading).
        sigma_level: predicted σ of roll and pitch (rad); NaN if the accel bias σ is unknown.
        sigma_heading: predicted σ of the yaw returned (rad).
        sigma_gyrocompass: predicted σ of the gyrocompass yaw (rad); inf if the gyro bias σ is
            unknown or at the poles.
        yaw_gyrocompass: the gyrocompass yaw (rad), computed whether used or not.
        duration: window length T (s).
        gravity: normal gravity g(L, h) used (m/s²).
        mean_specific_force: f̄_b (m/s², body).
        mean_angular_rate: ω̄_b (rad/s, body).
        sigma_rate: σ of each component of ω̄_b, ``sqrt(σ_bg² + ARW²/T)`` (rad/s); NaN if the
            gyro bias σ is unknown.
    """

    heading_source: HeadingSource
    sigma_level: float
    sigma_heading: float
    sigma_gyrocompass: float
    yaw_gyrocompass: float
    duration: float
    gravity: float
    mean_specific_force: Array
    mean_angular_rate: Array
    sigma_rate: float = math.nan


def _increments(dtheta: ArrayLike, dvel: ArrayLike, dt: ArrayLike) -> tuple[Array, Array, Array]:
    dth = np.asarray(dtheta, dtype=float)
    dv = np.asarray(dvel, dtype=float)
    if dth.ndim != 2 or dth.shape[1] != 3 or dv.shape != dth.shape:
        raise ValueError(
            f"dtheta and dvel must both have shape (N, 3), got {dth.shape} and {dv.shape}"
        )
    if dth.shape[0] < 1:
        raise AlignmentError("the alignment window holds no IMU samples")
    d = np.broadcast_to(np.asarray(dt, dtype=float), (dth.shape[0],)).copy()
    if not (np.all(np.isfinite(d)) and np.all(d > 0.0)):
        raise ValueError("IMU interval lengths dt must be finite and > 0")
    if not (np.all(np.isfinite(dth)) and np.all(np.isfinite(dv))):
        raise ValueError("IMU increments must be finite")
    return dth, dv, d


def _check_lat(lat: float) -> float:
    lat = float(lat)
    if not (math.isfinite(lat) and abs(lat) <= earth.MAX_LAT_RAD):
        raise ValueError(
            f"latitude {lat!r} rad is not within ±{earth.MAX_LAT_DEG:g}° (the "
            "latitude-longitude mechanization is singular at the poles)"
        )
    return lat


def _check_static(
    dth: Array,
    dv: Array,
    d: Array,
    f_mean: Array,
    w_mean: Array,
    g: float,
    sigma_ba: float,
    sigma_w: float | None,
    arw: float,
    vrw: float,
    tol: StaticTolerances,
) -> None:
    """Raise :class:`NotStaticError` unless the window looks like a vehicle at rest."""
    T = float(d.sum())
    df = abs(float(np.linalg.norm(f_mean)) - g)
    lim_f = tol.specific_force + 5.0 * sigma_ba
    if df > lim_f:
        f_norm = float(np.linalg.norm(f_mean))
        in_g = abs(f_norm * G0 - g) <= lim_f  # what accelerations logged in g read at rest
        raise NotStaticError(
            f"the alignment window is not static: mean |f| = {f_norm:.4f} m/s² "
            f"differs from g = {g:.4f} m/s² by {df:.4f} > {lim_f:.4f} m/s²"
            + (": that is gravity in g, the accelerations logged in g, not m/s²?" if in_g else "")
        )
    dw = abs(float(np.linalg.norm(w_mean)) - earth.OMEGA_IE)
    lim_w = math.inf if sigma_w is None else tol.mean_rate + 5.0 * sigma_w
    if dw > lim_w:
        w_norm = float(np.linalg.norm(w_mean))
        in_deg = abs(math.radians(w_norm) - earth.OMEGA_IE) <= lim_w  # deg/s read as rad/s
        raise NotStaticError(
            f"the alignment window is not static: mean |ω| = {w_norm:.3e} rad/s "
            f"differs from the earth rate {earth.OMEGA_IE:.3e} rad/s by {dw:.3e} > {lim_w:.3e}"
            + (": as deg/s it would be at rest, the rates logged in deg/s, not rad/s?"
               if in_deg else "")
        )  # fmt: skip
    n = dth.shape[0]
    per = max(1, round(tol.block_length / float(np.median(d))))
    nb = n // per
    if nb < 2:
        return
    cut = nb * per
    tb = d[:cut].reshape(nb, per).sum(axis=1)
    fb = dv[:cut].reshape(nb, per, 3).sum(axis=1) / tb[:, None]
    wb = dth[:cut].reshape(nb, per, 3).sum(axis=1) / tb[:, None]
    tau = float(tb.min())
    dev_f = float(np.linalg.norm(fb - f_mean, axis=1).max())
    dev_w = float(np.linalg.norm(wb - w_mean, axis=1).max())
    lim_bf = tol.block_specific_force + 6.0 * vrw / math.sqrt(tau) * math.sqrt(3.0)
    lim_bw = tol.block_rate + 6.0 * arw / math.sqrt(tau) * math.sqrt(3.0)
    if dev_f > lim_bf:
        raise NotStaticError(
            f"the alignment window is not static: {tau:.3g}-s means of the specific force move "
            f"by up to {dev_f:.4f} m/s² > {lim_bf:.4f} m/s² (over {T:.1f} s)"
        )
    if dev_w > lim_bw:
        raise NotStaticError(
            f"the alignment window is not static: {tau:.3g}-s means of the angular rate move "
            f"by up to {dev_w:.3e} rad/s > {lim_bw:.3e} rad/s (over {T:.1f} s)"
        )


def coarse_align(
    dtheta: ArrayLike,
    dvel: ArrayLike,
    dt: ArrayLike,
    lat: float,
    heading: float | None = None,
    *,
    heading_sigma: float | None = None,
    h: float = 0.0,
    gyro_bias_sigma: float | None = None,
    accel_bias_sigma: float | None = None,
    imu_noise: ImuNoise | None = None,
    max_heading_sigma: float = MAX_HEADING_SIGMA,
    tolerances: StaticTolerances = StaticTolerances(),
) -> tuple[float, float, float, CoarseInfo]:
    """Coarse static alignment: roll and pitch by levelling, yaw by gyrocompassing or given.

    Args:
        dtheta, dvel: IMU increments over the static window, (N, 3) (rad, m/s), body FRD.
        dt: interval lengths (s), scalar or (N,).
        lat: latitude (rad); ``h`` the ellipsoidal height (m), for g(L, h).
        heading: a yaw (rad) from a heading sensor's mean reading or the configuration; used
            when gyrocompassing is not good enough (or is worse than ``heading_sigma``).
        heading_sigma: its σ (rad); required with ``heading``.
        gyro_bias_sigma, accel_bias_sigma: σ of the *window-mean* IMU biases (rad/s, m/s²), i.e.
            the uncertainty of the uncalibrated turn-on plus in-run bias. Default: the in-run σ
            of ``imu_noise`` if given, else unknown (an unknown gyro σ disables gyrocompassing,
            as its quality cannot be judged; an unknown accel σ makes ``sigma_level`` NaN).
        imu_noise: for the white-noise terms (ARW, VRW) and the default bias σ.
        max_heading_sigma: gyrocompass only if its predicted heading σ is below this (rad).
        tolerances: the static-window checks (:class:`StaticTolerances`).

    Returns:
        ``(roll, pitch, yaw, info)`` in rad, with :class:`CoarseInfo` (module docstring for the
        equations and the predicted σ).

    Raises:
        NotStaticError: the window does not look like a vehicle at rest.
        AlignmentError: no heading is available (gyro too poor or its σ unknown, none given).
    """
    dth, dv, d = _increments(dtheta, dvel, dt)
    lat = _check_lat(lat)
    if heading is not None:
        heading, heading_sigma = _check_heading(heading, heading_sigma)
    arw = imu_noise.arw if imu_noise is not None else 0.0
    vrw = imu_noise.vrw if imu_noise is not None else 0.0
    if gyro_bias_sigma is None and imu_noise is not None:
        gyro_bias_sigma = imu_noise.gyro_bias_sigma
    if accel_bias_sigma is None and imu_noise is not None:
        accel_bias_sigma = imu_noise.accel_bias_sigma

    T = float(d.sum())
    f_mean = dv.sum(axis=0) / T
    w_mean = dth.sum(axis=0) / T
    g = float(earth.gravity(lat, h))
    sigma_f = math.sqrt((accel_bias_sigma or 0.0) ** 2 + vrw**2 / T)
    sigma_w = math.sqrt((gyro_bias_sigma or 0.0) ** 2 + arw**2 / T)
    # With the gyro bias σ unknown, the mean rate cannot be judged: only the block checks run.
    sigma_w_check = None if gyro_bias_sigma is None else sigma_w
    _check_static(dth, dv, d, f_mean, w_mean, g, sigma_f, sigma_w_check, arw, vrw, tolerances)

    roll, pitch = level(f_mean)
    w_l = attitude.euler_to_dcm(roll, pitch, 0.0) @ w_mean
    yaw_gc = math.atan2(-w_l[1], w_l[0])

    sigma_level = sigma_f / g if accel_bias_sigma is not None else math.nan
    horizontal_rate = earth.OMEGA_IE * math.cos(lat)
    if gyro_bias_sigma is None or horizontal_rate < 1e-3 * earth.OMEGA_IE:
        sigma_gc = math.inf
    else:
        tilt = 0.0 if math.isnan(sigma_level) else math.tan(lat) * sigma_level
        sigma_gc = math.hypot(sigma_w / horizontal_rate, tilt)

    usable = sigma_gc <= max_heading_sigma
    if usable and (heading_sigma is None or sigma_gc <= heading_sigma):
        source: HeadingSource = "gyrocompass"
        yaw, sigma_heading = yaw_gc, sigma_gc
    elif heading is not None and heading_sigma is not None:
        source = "heading"
        yaw, sigma_heading = float(attitude.wrap_angle(heading)), heading_sigma
    else:
        raise _no_heading(gyro_bias_sigma, sigma_gc, max_heading_sigma, horizontal_rate, lat)
    info = CoarseInfo(
        source, sigma_level, sigma_heading, sigma_gc, yaw_gc, T, g, f_mean, w_mean,
        sigma_w if gyro_bias_sigma is not None else math.nan,
    )  # fmt: skip
    return roll, pitch, yaw, info


EARTH_RATE_SIGMAS = 5.0
"""σ of the window-mean rate beyond which the earth rate it measured is not the expected one."""
FLIPPED_BAND = 0.25
"""How near the vertical earth rate of a flipped z axis (as a fraction of it, plus 3 σ) the
measured one must be to be taken as flipped rather than as a vehicle turning at rest."""


def axes_at_rest(
    info: CoarseInfo, lat: float, heading: float | None, heading_sigma: float | None
) -> tuple[Literal["accel", "vertical", "horizontal"], str] | None:
    """What the earth rate measured at rest says of the gyro's axes: which of them is wrong and
    why, in words (None: nothing wrong, or the gyro too poor to tell). ``info`` is
    :func:`coarse_align`'s; ``heading``, ``heading_sigma`` (rad) a heading given to it, if any
    (docs/robustness.md, 'IMU axes').

    * **accelerometers**: at rest the specific force points up, ``f_z < 0`` (FRD): levelled to
      a roll beyond ±90°, the vehicle would be upside down. The z axis's sign is flipped (or
      the IMU mounted upside down and its table not turned). Checked first: the gyro checks
      below take the levelled frame from the accelerometers.

    In the levelled frame the earth rate is ``ω_l = Ω [cψ cos L, -sψ cos L, -sin L]`` (module
    docstring), its vertical component free of the heading. With ``σ_ω`` the window mean's σ:

    * **vertical**: ``ω_l,D`` more than 5 σ_ω from ``-Ω sin L`` and within
      ``3 σ_ω + 0.25 Ω |sin L|`` of ``+Ω sin L``: the vertical axis turns the wrong way (a z
      axis's sign flipped, or the latitude's sign). A vehicle turning at rest moves ``ω_l,D``
      anywhere; only a value this near the mirror image is taken for a flip;
    * **horizontal**, with a heading given: the gyrocompass yaw more than
      ``5 sqrt(σ_gc² + σ_h²)`` from it, when that bound is under 90°: an x or y axis flipped,
      the two swapped, or the given heading wrong (a turning vehicle does not move the
      horizontal components).
    """
    roll, pitch = level(info.mean_specific_force)
    if abs(roll) > 0.5 * math.pi:
        f = info.mean_specific_force
        return "accel", (
            f"at rest the accelerometers' mean specific force [{f[0]:.3g}, {f[1]:.3g}, "
            f"{f[2]:.3g}] m/s² points down in the body (z down: it should point up, f_z < 0), "
            f"a roll of {math.degrees(roll):.1f}°: the vehicle upside down? Is the sign of the "
            "accelerometer's z axis flipped, or the IMU mounted upside down?"
        )
    w_l = attitude.euler_to_dcm(roll, pitch, 0.0) @ info.mean_angular_rate
    sigma = info.sigma_rate
    if not math.isfinite(sigma):
        return None
    expected = -earth.OMEGA_IE * math.sin(lat)
    off = abs(float(w_l[2]) - expected)
    if off > EARTH_RATE_SIGMAS * sigma and abs(float(w_l[2]) + expected) <= (
        3.0 * sigma + FLIPPED_BAND * abs(expected)
    ):
        return "vertical", (
            f"at rest the gyros measure a vertical (down) earth rate of {float(w_l[2]):.3e} "
            f"rad/s where {expected:.3e} is expected at latitude {math.degrees(lat):.4g}° "
            f"(σ {sigma:.2g}): its mirror image. Is the sign of the gyro's vertical (z) axis "
            "flipped, or the latitude's?"
        )
    if heading is None or heading_sigma is None:
        return None
    bound = EARTH_RATE_SIGMAS * math.hypot(info.sigma_gyrocompass, heading_sigma)
    miss = abs(float(attitude.wrap_angle(info.yaw_gyrocompass - heading)))
    if bound < 0.5 * math.pi and miss > bound:
        return "horizontal", (
            f"at rest the gyros' earth rate points to a heading of "
            f"{math.degrees(info.yaw_gyrocompass):.1f}° where {math.degrees(heading):.1f}° is "
            f"given, {math.degrees(miss):.1f}° off (more than {math.degrees(bound):.1f}°, 5 σ of "
            "both). Is an x or y gyro axis's sign flipped, or are the two swapped? Or is the "
            "given heading wrong (or its σ too small)?"
        )
    return None


def level(f_mean: ArrayLike) -> tuple[float, float]:
    """Roll and pitch (rad) of a body at rest from its mean specific force ``f`` (body FRD,
    m/s²), the coarse levelling (module docstring): ``roll = atan2(-f_y, -f_z)``,
    ``pitch = atan2(f_x, hypot(f_y, f_z))``."""
    f = np.asarray(f_mean, dtype=float)
    return math.atan2(-f[1], -f[2]), math.atan2(f[0], math.hypot(f[1], f[2]))


def window_specific_force(
    imu_t: ArrayLike, imu_dt: ArrayLike, dvel: ArrayLike, window: float
) -> Array:
    """The mean specific force (body, m/s²) over the static window of :func:`align`, the first
    ``window`` seconds of the IMU data: what :func:`level` takes, before the alignment itself
    (a heading sensor's reading is turned into the body's heading at this attitude:
    api/runner.py ``sensor_heading``)."""
    t = np.atleast_1d(np.asarray(imu_t, dtype=float))
    d = np.broadcast_to(np.asarray(imu_dt, dtype=float), t.shape)
    n = _window_samples(t, d, float(t[0] - d[0]), float(window))
    return np.asarray(np.asarray(dvel, dtype=float)[:n].sum(axis=0) / d[:n].sum(), dtype=float)


def _check_heading(heading: float, heading_sigma: float | None) -> tuple[float, float]:
    """A given heading and its σ as floats; ValueError unless finite (σ > 0 and required)."""
    if heading_sigma is None:
        raise ValueError("heading_sigma (rad) is required when a heading is given")
    heading = float(heading)
    if not math.isfinite(heading):
        raise ValueError(f"heading must be finite, got {heading!r}")
    heading_sigma = float(heading_sigma)
    if not (math.isfinite(heading_sigma) and heading_sigma > 0.0):
        raise ValueError(f"heading_sigma must be finite and > 0, got {heading_sigma!r}")
    return heading, heading_sigma


def _no_heading(
    gyro_bias_sigma: float | None,
    sigma_gc: float,
    max_heading_sigma: float,
    horizontal_rate: float,
    lat: float,
) -> AlignmentError:
    """The error when gyrocompassing is not good enough and no heading is given: why the
    gyrocompass was refused (σ_ψ against the limit, module docstring; docs/alignment.md)."""
    why = (
        "the gyro bias σ is unknown, so gyrocompassing cannot be judged"
        if gyro_bias_sigma is None
        else (
            f"gyrocompassing would give a heading σ of {math.degrees(sigma_gc):.3g}° "
            f"> {math.degrees(max_heading_sigma):.3g}° (gyro bias σ "
            f"{math.degrees(gyro_bias_sigma) * 3600:.3g} deg/h against the earth rate's "
            f"horizontal {math.degrees(horizontal_rate) * 3600:.3g} deg/h at "
            f"{math.degrees(lat):.2f}°)"
        )
    )
    return AlignmentError(
        f"no heading for the alignment: {why}; give one: a heading sensor (not off) with "
        "readings in the static window, or a yaw in initial.rpy_deg with its σ in "
        "initial.sigma_attitude_deg"
    )


# --- initial covariance -------------------------------------------------------------------------


def _mean_factor(tau: float, T: float) -> float:
    """Window mean of a Gauss-Markov bias over its initial value, ``(τ/T)(1 - e^{-T/τ})``."""
    return 1.0 if math.isinf(tau) else (tau / T) * (-math.expm1(-T / tau))


def coarse_covariance(
    C_nb: ArrayLike,
    lat: float,
    duration: float,
    imu_noise: ImuNoise,
    accel_bias_sigma: float,
    gyro_bias_sigma: float,
    heading_source: HeadingSource,
    heading_sigma: float | None = None,
    h: float = 0.0,
) -> Array:
    """Joint covariance (9×9) of ``[phi, db_a, db_g]`` at the window start after coarse alignment.

    The coarse errors are linear in independent sources (module docstring)::

        e_f = C_nb (κ_a b_a0 + w_a) + n_f,    e_ω = C_nb (κ_g b_g0 + w_g) + n_ω,
        phi_N = e_f,E / g,  phi_E = -e_f,N / g,
        phi_D = e_ω,E / (Ω cos L) - tan L phi_N   (gyrocompass)   or  n_ψ (given heading),
        db_a = b_a0,  db_g = b_g0,

    with turn-on biases ``b_0 ~ N(0, σ_0²)`` (the bias estimate starts at zero), ``κ`` the
    window-mean factor of a Gauss-Markov bias (1 for a random walk), in-run wander of the
    window mean ``w ~ N(0, q T / 3)`` (q the bias driving PSD), averaged white noise
    ``n_f ~ N(0, VRW²/T)``, ``n_ω ~ N(0, ARW²/T)`` and ``n_ψ ~ N(0, heading_sigma²)``.
    """
    C = np.asarray(C_nb, dtype=float)
    T = float(duration)
    g = float(earth.gravity(lat, h))
    ka = _mean_factor(imu_noise.accel_bias_tau, T)
    kg = _mean_factor(imu_noise.gyro_bias_tau, T)
    # Sources: b_a0, b_g0, w_a, w_g, n_f, n_ω (3 each), n_ψ (1).
    var = np.concatenate(
        [
            np.full(3, accel_bias_sigma**2),
            np.full(3, gyro_bias_sigma**2),
            np.full(3, imu_noise.accel_bias_psd * T / 3.0),
            np.full(3, imu_noise.gyro_bias_psd * T / 3.0),
            np.full(3, imu_noise.vrw**2 / T),
            np.full(3, imu_noise.arw**2 / T),
            [(heading_sigma or 0.0) ** 2],
        ]
    )
    Ef = np.zeros((3, 19))  # e_f in n
    Ef[:, 0:3] = ka * C
    Ef[:, 6:9] = C
    Ef[:, 12:15] = np.eye(3)
    Ew = np.zeros((3, 19))  # e_ω in n
    Ew[:, 3:6] = kg * C
    Ew[:, 9:12] = C
    Ew[:, 15:18] = np.eye(3)
    J = np.zeros((9, 19))
    J[0] = Ef[1] / g
    J[1] = -Ef[0] / g
    if heading_source == "gyrocompass":
        J[2] = Ew[1] / (earth.OMEGA_IE * math.cos(lat)) - math.tan(lat) * J[0]
    elif heading_source == "heading":
        if heading_sigma is None:
            raise ValueError("heading_sigma is required for a given heading")
        J[2, 18] = 1.0
    else:
        raise ValueError(
            f"heading_source must be 'gyrocompass' or 'heading', got {heading_source!r}"
        )
    J[3:6, 0:3] = np.eye(3)
    J[6:9, 3:6] = np.eye(3)
    P = (J * var) @ J.T
    return np.asarray(0.5 * (P + P.T), dtype=float)


# --- fine alignment -----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class FineAlignment:
    """The filter at the end of the static window.

    Attributes:
        x: nominal 16-state at ``t_end``.
        P: 15×15 error covariance at ``t_end``.
        t_end: end of the window (s), the stamp of the last IMU sample used.
        zupt_mean_nis: mean NIS of the ZUPTs over the window's second half (≈ 3 when the
            vehicle really was at rest and σ_zupt fits; much larger: it moved).
        output: the engine's run (solution samples, ledger) for diagnostics.
    """

    x: Array
    P: Array
    t_end: float
    zupt_mean_nis: float
    output: EngineOutput


def fine_align(
    imu_t: ArrayLike,
    imu_dt: ArrayLike,
    dtheta: ArrayLike,
    dvel: ArrayLike,
    x0: ArrayLike,
    P0: ArrayLike,
    imu_noise: ImuNoise,
    *,
    t0: float | None = None,
    zupt: ZeroVelocity = DEFAULT_ZUPT,
    zupt_period: float = 0.1,
    gnss: GNSS | None = None,
    gnss_readings: tuple[ArrayLike, ArrayLike] | None = None,
    output_every: int = 100,
) -> FineAlignment:
    """Fine alignment: the ESKF over the static window with ZUPTs (and GNSS fixes if given).

    Runs :func:`adaptnav.engine.batch.run_batch` (``FixedNoise``, exact epochs, covariance reset)
    from ``x0``, ``P0`` at ``t0`` (default: the start of the first IMU interval, ``imu_t[0] -
    imu_dt[0]``) over all the IMU intervals given, with zero-velocity readings every ``zupt_period``
    seconds and the GNSS fixes ``gnss_readings = (t (n,), z (n, d))`` stamped inside the window
    (``z`` as :class:`adaptnav.sensors.gnss.GNSS` reads them). What this can and cannot estimate at
    rest is in the module docstring: the horizontal accelerometer bias is not separable from tilt,
    the east gyro bias not from heading.
    """
    t = np.atleast_1d(np.asarray(imu_t, dtype=float))
    dth, dv, d = _increments(dtheta, dvel, imu_dt)
    if t.shape != (dth.shape[0],):
        raise ValueError(f"imu_t must have shape ({dth.shape[0]},), got {t.shape}")
    start = float(t[0] - d[0]) if t0 is None else float(t0)
    t_end = float(t[-1])
    if not (math.isfinite(zupt_period) and zupt_period > 0.0):
        raise ValueError(f"zupt_period must be finite and > 0, got {zupt_period!r}")
    n_z = math.floor((t_end - start) / zupt_period + 1e-9)
    if n_z < 1:
        raise AlignmentError(
            f"the window ({t_end - start:.3g} s) is shorter than one ZUPT period ({zupt_period} s)"
        )
    t_z = np.minimum(start + zupt_period * np.arange(1, n_z + 1), t_end)
    readings: dict[str, tuple[ArrayLike, ArrayLike]] = {zupt.name: (t_z, np.zeros((n_z, 3)))}
    strategy = FixedNoise()
    channels = [SensorChannel(zupt, zupt_period, strategy)]
    if gnss_readings is not None:
        if gnss is None:
            raise ValueError("gnss_readings need a GNSS model (gnss=GNSS(sigma=...))")
        tg = np.atleast_1d(np.asarray(gnss_readings[0], dtype=float))
        zg = np.asarray(gnss_readings[1], dtype=float).reshape(tg.size, -1)
        keep = (tg > start) & (tg <= t_end)
        if np.any(keep):
            period = float(np.median(np.diff(tg))) if tg.size > 1 else 1.0
            channels.append(SensorChannel(gnss, period, strategy))
            readings[gnss.name] = (tg[keep], zg[keep])
    # At rest F takes -g_n, not the nominal's own (noisy) motion, so the velocity-attitude term
    # of the reset, which follows that motion, would make P depend on the noise
    # (docs/filters.md, 'The velocity-attitude term'; tests/unit/test_align.py).
    config = EngineConfig(
        imu_noise, "exact", True, output_every, at_rest=True, invariant_reset=False
    )
    out = run_batch(config, channels, x0, P0, start, t, d, dth, dv, readings)
    half = start + 0.5 * (t_end - start)
    nis = [
        r["statistic"]
        for r in out.ledger
        if r["sensor"] == zupt.name and r["fate"] == "used" and r["t"] >= half
    ]
    mean_nis = float(np.mean(nis)) if nis else math.nan
    return FineAlignment(out.x_final, out.P_final, t_end, mean_nis, out)


# --- both ----------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Alignment:
    """Result of :func:`align`: the initial state and covariance for navigation from ``t_end``.

    Attributes:
        x0: nominal 16-state at ``t_end`` (fine-aligned, biases estimated).
        P0: its 15×15 error covariance.
        t_end: the time (s) navigation starts from: the end of the static window.
        roll, pitch, yaw: the coarse alignment's angles (rad).
        heading_source: ``"gyrocompass"`` or ``"heading"``.
        coarse: the coarse alignment's :class:`CoarseInfo` (predicted σ_level, σ_heading).
        P_start: the fine alignment's initial covariance (from the coarse alignment).
        zupt_mean_nis: see :class:`FineAlignment`.
        output: the fine alignment's engine run.
    """

    x0: Array
    P0: Array
    t_end: float
    roll: float
    pitch: float
    yaw: float
    heading_source: HeadingSource
    coarse: CoarseInfo
    P_start: Array
    zupt_mean_nis: float
    output: EngineOutput

    @property
    def std(self) -> Array:
        """σ of the 15 error states at ``t_end``: sqrt(diag(P0))."""
        return np.sqrt(np.diag(self.P0))

    @property
    def sigma_level(self) -> float:
        """Predicted σ of the coarse roll and pitch (rad)."""
        return self.coarse.sigma_level

    @property
    def sigma_heading(self) -> float:
        """Predicted σ of the coarse yaw (rad)."""
        return self.coarse.sigma_heading


def align(
    imu_t: ArrayLike,
    imu_dt: ArrayLike,
    dtheta: ArrayLike,
    dvel: ArrayLike,
    window: float,
    position: Sequence[float],
    imu_noise: ImuNoise,
    accel_bias_sigma: float,
    gyro_bias_sigma: float,
    *,
    heading: float | None = None,
    heading_sigma: float | None = None,
    gnss: GNSS | None = None,
    gnss_readings: tuple[ArrayLike, ArrayLike] | None = None,
    position_sigma: float = 10.0,
    velocity_sigma: float = 0.1,
    zupt: ZeroVelocity = DEFAULT_ZUPT,
    zupt_period: float = 0.1,
    max_heading_sigma: float = MAX_HEADING_SIGMA,
    tolerances: StaticTolerances = StaticTolerances(),
) -> Alignment:
    """Static alignment over the first ``window`` seconds of the IMU data (docs/alignment.md).

    Coarse alignment (:func:`coarse_align`) on the window's mean increments, then fine alignment
    (:func:`fine_align`) over the same window from the coarse attitude, zero velocity, the given
    ``position = (lat, lon, h)`` (rad, rad, m) and zero biases, with the initial covariance of
    :func:`coarse_covariance` (position ``position_sigma`` m and velocity ``velocity_sigma`` m/s
    per axis, uncorrelated).

    Args:
        imu_t, imu_dt, dtheta, dvel: the IMU table (intervals ``(t_k - dt_k, t_k]``); only the
            window ``[imu_t[0] - imu_dt[0], + window]`` is used.
        window: length of the static window (s); must not exceed the data.
        position: (lat, lon, h) of the vehicle at rest.
        imu_noise: the filter's IMU noise model (white noise, in-run biases).
        accel_bias_sigma, gyro_bias_sigma: σ of the uncalibrated turn-on biases (m/s², rad/s),
            the initial bias uncertainty.
        heading, heading_sigma: an external heading (rad) and σ (rad), see :func:`coarse_align`.
        gnss, gnss_readings: optional GNSS model and fixes ``(t, z)`` for the fine alignment.
        zupt, zupt_period: the zero-velocity pseudo-measurement and its period (s).
        max_heading_sigma, tolerances: see :func:`coarse_align`.
    """
    t, d, dth, dv = _imu_arrays(imu_t, imu_dt, dtheta, dvel)
    window = float(window)
    if not (math.isfinite(window) and window > 0.0):
        raise ValueError(f"window must be finite and > 0 s, got {window!r}")
    lat, lon, h = _position(position)
    for name, s in (
        ("accel_bias_sigma", accel_bias_sigma),
        ("gyro_bias_sigma", gyro_bias_sigma),
        ("position_sigma", position_sigma),
        ("velocity_sigma", velocity_sigma),
    ):
        if not (math.isfinite(s) and s >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0, got {s!r}")

    start = float(t[0] - d[0])
    n = _window_samples(t, d, start, window)
    tw, dw, dthw, dvw = t[:n], d[:n], dth[:n], dv[:n]
    T = float(dw.sum())
    sa, sg = _window_bias_sigmas(imu_noise, T, accel_bias_sigma, gyro_bias_sigma)
    roll, pitch, yaw, info = coarse_align(
        dthw, dvw, dw, lat, heading, heading_sigma=heading_sigma, h=h, gyro_bias_sigma=sg,
        accel_bias_sigma=sa, imu_noise=imu_noise, max_heading_sigma=max_heading_sigma,
        tolerances=tolerances,
    )  # fmt: skip
    x0 = NavState.from_euler(lat, lon, h, np.zeros(3), roll, pitch, yaw).to_array()
    P0 = np.zeros((N_STATES, N_STATES))
    P0[POS, POS] = np.eye(3) * position_sigma**2
    P0[VEL, VEL] = np.eye(3) * velocity_sigma**2
    idx = np.r_[ATT, BA, BG]
    P0[np.ix_(idx, idx)] = coarse_covariance(
        attitude.euler_to_dcm(roll, pitch, yaw), lat, T, imu_noise, accel_bias_sigma,
        gyro_bias_sigma, info.heading_source,
        info.sigma_heading if info.heading_source == "heading" else None, h,
    )  # fmt: skip
    fine = fine_align(
        tw, dw, dthw, dvw, x0, P0, imu_noise, t0=start, zupt=zupt, zupt_period=zupt_period,
        gnss=gnss, gnss_readings=gnss_readings,
    )  # fmt: skip
    return Alignment(
        fine.x, fine.P, fine.t_end, roll, pitch, yaw, info.heading_source, info, P0,
        fine.zupt_mean_nis, fine.output,
    )  # fmt: skip


def _imu_arrays(
    imu_t: ArrayLike, imu_dt: ArrayLike, dtheta: ArrayLike, dvel: ArrayLike
) -> tuple[Array, Array, Array, Array]:
    """``(t, dt, dtheta, dvel)`` of :func:`align` as float arrays, ``dt`` broadcast to ``t``;
    ValueError unless ``t`` is a non-empty 1-D array and the increments are (N, 3)."""
    t = np.atleast_1d(np.asarray(imu_t, dtype=float))
    dth = np.asarray(dtheta, dtype=float)
    dv = np.asarray(dvel, dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"imu_t must be a non-empty 1-D array, got shape {t.shape}")
    d = np.broadcast_to(np.asarray(imu_dt, dtype=float), t.shape).copy()
    if dth.shape != (t.size, 3) or dv.shape != (t.size, 3):
        raise ValueError(
            f"dtheta and dvel must have shape ({t.size}, 3), got {dth.shape} and {dv.shape}"
        )
    return t, d, dth, dv


def _position(position: Sequence[float]) -> tuple[float, float, float]:
    """``(lat, lon, h)`` as floats, the latitude checked (:func:`_check_lat`)."""
    if len(position) != 3:
        raise ValueError(f"position must be (lat, lon, h), got {position!r}")
    lat, lon, h = (float(p) for p in position)
    return _check_lat(lat), lon, h


def _window_samples(t: Array, d: Array, start: float, window: float) -> int:
    """Number of IMU intervals in the static window ``[start, start + window]``, to half an
    interval; AlignmentError if the data end before it."""
    stop = start + window
    half_dt = 0.5 * float(np.median(d))
    if t[-1] < stop - half_dt:
        raise AlignmentError(
            f"the alignment window ({window:.6g} s) is longer than the IMU data "
            f"({t[-1] - start:.6g} s from t = {start:.6g} s)"
        )
    return int(np.searchsorted(t, stop + half_dt, side="right"))


def _window_bias_sigmas(
    imu_noise: ImuNoise, T: float, accel_bias_sigma: float, gyro_bias_sigma: float
) -> tuple[float, float]:
    """σ of the window-mean accelerometer and gyro biases (what coarse alignment sees), as in
    :func:`coarse_covariance`: ``sqrt((κ σ_0)² + q T / 3)``."""
    ka = _mean_factor(imu_noise.accel_bias_tau, T)
    kg = _mean_factor(imu_noise.gyro_bias_tau, T)
    sa = math.sqrt((ka * accel_bias_sigma) ** 2 + imu_noise.accel_bias_psd * T / 3.0)
    sg = math.sqrt((kg * gyro_bias_sigma) ** 2 + imu_noise.gyro_bias_psd * T / 3.0)
    return sa, sg
