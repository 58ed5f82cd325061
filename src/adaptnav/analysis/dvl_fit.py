"""A DVL's scale and mounting misalignment fitted against a reference trajectory, without the
filter (docs/calibration.md, 'Against a reference').

Where a mission has a reference with velocity and attitude (a post-processed INS, GNSS with a
heading reference, a simulation's truth), the readings themselves say how the DVL is
calibrated: at each reading time t_k the reference gives ``h_k``, the velocity an error-free DVL
would read (:func:`adaptnav.sensors.dvl.ideal`, the filter's model)::

    h_k = C_sb (C_nb(t_k)ᵀ v_n(t_k) + ω_ib_b(t_k) × l_b)

and the readings are fitted to ``z_k = (1 + s) M(δ) h_k + ε_k`` with the filter's conventions
for the scale s and the misalignment δ = (roll, pitch, yaw) (``M = euler_to_dcm(δ)ᵀ``,
:mod:`adaptnav.sensors.calibration`), so the numbers compare with the filter's states
``<dvl>.scale`` and ``<dvl>.misalignment_*``. The reference velocity v_n is its velocity
columns (``source="velocity"``) or the rate of change of its positions (``source="position"``:
``v_N = (R_M + h) dL/dt``, ``v_E = (R_N + h) cos L dλ/dt``, ``v_D = -dh/dt`` by central
differences, Groves 2013 eq. 2.111, the radii of :mod:`adaptnav.core.earth`). The two differ
where a reference's velocity is not the derivative of its positions, as on A-KIT, whose
positions move faster than its velocity by -0.45 to +0.25 % depending on the segment
(docs/calibration.md); the positions are what a run is scored against. Both are interpolated
linearly, the attitude by spherical linear interpolation, at t_k; ω_ib_b is the IMU's mean rate
``Δθ / Δt`` interpolated from the interval mid-times, less the reference's gyro bias when it has
one (a simulation's truth).

Interpolation needs a reference sampled finely enough for the vehicle's motion between its rows:
linear interpolation across a step Δ cuts the corners of a turn and averages out the swell's
oscillations, so h_k is wrong by an amount the fit reads as calibration. A reading whose
reference interval (the rows either side of it) is longer than :data:`MAX_REFERENCE_STEP_S` is
left out and counted (:attr:`DvlFit.in_gaps`), as a navigation engineer leaves out a stretch
without reference rather than invent one; when that is the median reading, the reference is too
coarse and the fit is refused. A-KIT's reference steps 1.0 s everywhere, a simulation's 0.1 s.
Measured on the simulated demo and paper-1 missions (DVL 0.4 % fast, 0.5°, -0.3°, 0.8° off) with
the truth thinned: at 2 s every quantity stays within 2σ on demo, while at 10 s the demo's roll
comes out -10.0 ± 2.9° and at 60 s (one row a minute) its pitch -5.6 ± 0.24°. On paper-1, whose
σ are five times smaller, the swell already shows at 1 s: the scale comes out 0.469 ± 0.014 %
(0.405 at 0.1 s; true 0.4), so the limit stops gross coarseness, not every interpolation bias.

The fit is weighted Gauss-Newton least squares (each axis weighted by its own residual
variance), with readings more than :data:`OUTLIER_SIGMAS` σ off excluded and the fit repeated
until none is; σ per axis is the larger of the robust one (1.4826 × the median absolute
residual) and the sensor's configured σ, as a DVL's noise grows with speed and a mission that
spends most of its readings at rest would otherwise have a robust σ of the resting noise and
leave out every reading under way. The covariance is ``A⁻¹ S A⁻¹``, ``A = Jᵀ W J``, with S the
long-run covariance of the readings' parts ``g_k = J_kᵀ W r_k`` of the gradient, because a real
DVL's residuals against a reference are correlated from reading to reading (the reference's own
errors, the sea bottom, the water) and its noise varies with speed: the g_k prewhitened by a
first-order autoregression (Andrews & Monahan 1992), Newey-West (1987) with Bartlett weights on
what is left over a bandwidth of ``n^(2/3)`` readings (corrected for its fixed share of n,
Kiefer & Vogelsang 2005), and recoloured; each σ is at least that of ``S = Σ g_k g_kᵀ``, the
sandwich of White (1980) for uncorrelated readings (:func:`_covariance`). The long bandwidth
is for a slow error under a larger white one, whose lag-1 correlation the white noise sets:
sized from it (Andrews 1991, up to 0.4.7) the bandwidth was 0 and σ 2.3-7.5 times too small
(docs/calibration.md). Readings are taken in order, a gap (an excluded reading, a dropout) not
counted. Checked on 400 readings with
AR(1) noise (tests/integration/test_dvl_fit.py, 200 draws): the errors over σ have an RMS of
0.93-1.02 for uncorrelated noise and 1.03-1.26 for a lag-1 correlation of 0.8, where the plain
sandwich gives 2.7-3.3; on 10 000 readings with a slow error (0.99) under heteroskedastic white
noise 0.95-1.5 (4.7-6.8 up to 0.4.7); over 40 simulated missions per case, docs/calibration.md.

This is what the reference says, not the truth: a reference that is itself a DVL-aided
solution carries its own estimate of the DVL's calibration, its attitude and time alignment
errors enter the fit, and noise in its velocity (a rate of noisy positions) biases the scale
low by about the noise's power over the speed's (an error in the regressor, not in z).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation, Slerp

from adaptnav.analysis.floor import dvl_readings, dvl_sensor, imu_rate_at
from adaptnav.core import earth
from adaptnav.estimation import long_run
from adaptnav.mission import Mission
from adaptnav.models.strapdown import NOM_ATT, NOM_BG, NOM_SIZE, NOM_VEL
from adaptnav.sensors import dvl
from adaptnav.sensors.calibration import MISALIGNMENT, SCALE, misalignment
from adaptnav.sensors.calibration import misalignment_derivatives as derivatives
from adaptnav.sensors.kind import IdealInput

Array = NDArray[np.float64]

__all__ = [
    "DvlFit",
    "ReadingsFit",
    "fit_dvl",
    "fit_readings",
    "position_rate",
    "reference_consistency",
]

OUTLIER_SIGMAS = 5.0
"""A reading with an axis this many robust σ off the fit is excluded from it."""
MAX_RHO = long_run.MAX_RHO
"""Largest lag-1 correlation the covariance's bandwidth and prewhitening take."""
MIN_READINGS = 30
"""Fewest readings the fit keeps: its σ is estimated from the readings' own scatter (module
docstring), which a handful of readings cannot give (two readings fit four numbers almost
exactly, and their scatter says nothing)."""
MAX_SIGMA = {"scale": 0.10, "angle": math.radians(10.0)}
"""Largest σ of the scale (a ratio) and of a misalignment angle (rad) a fit may have: beyond,
the readings do not observe the quantity (a DVL at rest, a straight line), and its estimate is
not a calibration but noise, however it is printed."""
MAX_REFERENCE_STEP_S = 2.0
"""Longest reference interval (s) a reading may fall in (module docstring): twice A-KIT's 1.0 s
step; on simulated missions thinned to 2 s the fit moves by at most 2σ, at 5-60 s by 2-20σ."""
MAX_CONDITION = 1e10
"""Above this condition number of ``Jᵀ W J`` the readings do not observe the four numbers."""
NAMES = (*SCALE.states, *MISALIGNMENT.states)
"""The fitted quantities, as the filter's calibration states name them after the sensor."""
_ATTITUDE = ("roll_rad", "pitch_rad", "yaw_rad")
_VELOCITY = ("vn_m_s", "ve_m_s", "vd_m_s")
_GYRO_BIAS = ("bg_x_rad_s", "bg_y_rad_s", "bg_z_rad_s")
_POSITION = ("lat_rad", "lon_rad", "h_m")
Source = Literal["velocity", "position"]
"""Where the reference velocity comes from (module docstring)."""


@dataclass(frozen=True)
class DvlFit:
    """The fit of :func:`fit_dvl`: per quantity (:data:`NAMES`) its estimate and σ in the
    filter's report units (scale in %, angles in degrees), and what went into it."""

    sensor: str
    source: Source
    estimate: dict[str, float]
    sigma: dict[str, float]
    readings: int
    """Readings inside the IMU and reference spans with every component finite."""
    used: int
    """Of them, the ones the fit kept (the rest more than :data:`OUTLIER_SIGMAS` σ off)."""
    residual_rms_m_s: tuple[float, float, float]
    """RMS residual per DVL axis (m/s)."""
    rho: float
    """Largest lag-1 correlation of the readings' parts of the fit's gradient: how correlated
    the readings' errors are from one to the next, as far as the fit is concerned (a
    diagnostic; a slow error under a larger white one hardly shows in it)."""
    bandwidth: float
    """Bartlett bandwidth, in readings, of the long-run covariance: ``n^(2/3)`` of the n
    readings used (:func:`_covariance`; up to 0.4.7 sized from a lag-1 correlation)."""
    in_gaps: int = 0
    """Finite readings left out, not in :attr:`readings`, because the reference rows either side
    are more than :data:`MAX_REFERENCE_STEP_S` apart (module docstring)."""
    outside: int = 0
    """Finite readings left out, not in :attr:`readings`, because they lie outside the reference's
    (or the IMU's) time span: a reference that ends before the DVL's last reading (up to 0.4.8
    they were left out without being counted)."""


def fit_dvl(mission: Mission, sensor: str | None = None, source: Source = "velocity") -> DvlFit:
    """The DVL ``sensor`` (default: the first loaded sensor of kind "dvl") of ``mission``
    fitted against the mission's reference, its velocity taken from ``source`` (module
    docstring). ValueError when the mission has no reference with that velocity and an
    attitude, no finite reading inside it, a reference too coarse for the readings
    (:data:`MAX_REFERENCE_STEP_S`), or readings that do not observe the scale and the
    three angles (a DVL that never moves)."""
    name = dvl_sensor(mission, sensor, "fit_dvl")
    t, z, h, in_gaps, outside = _predicted(mission, name, source)
    nominal = np.broadcast_to(mission.config.sensors[name].sigma_si(), (3,))
    if t.size < MIN_READINGS:
        gaps = (
            f" ({in_gaps} more left out in reference gaps over {MAX_REFERENCE_STEP_S:g} s)"
            if in_gaps
            else ""
        )
        raise ValueError(
            f"fit_dvl: {t.size} reading(s) of {name!r} inside the reference{gaps}; the fit "
            f"needs at least {MIN_READINGS} to estimate the calibration and its σ"
        )
    fit = fit_readings(z, h, np.asarray(nominal, dtype=float))
    _check_observed(fit, name)
    factors = (SCALE.factor, *(MISALIGNMENT.factor,) * 3)
    rms = np.sqrt(np.mean(fit.residuals**2, axis=0))
    return DvlFit(
        name,
        source,
        {k: float(v * f) for k, v, f in zip(NAMES, fit.p, factors, strict=True)},
        {
            k: float(math.sqrt(c) * f)
            for k, c, f in zip(NAMES, np.diag(fit.cov), factors, strict=True)
        },
        int(t.size),
        int(fit.keep.sum()),
        (float(rms[0]), float(rms[1]), float(rms[2])),
        fit.rho,
        fit.bandwidth,
        in_gaps,
        outside,
    )


def _check_observed(fit: ReadingsFit, name: str) -> None:
    """ValueError naming the quantities whose σ exceeds :data:`MAX_SIGMA`, or when the fit
    kept fewer than :data:`MIN_READINGS` readings."""
    kept = int(fit.keep.sum())
    if kept < MIN_READINGS:
        raise ValueError(
            f"fit_dvl: only {kept} of the readings of {name!r} agree with the others to within "
            f"{OUTLIER_SIGMAS:g} σ; the fit needs at least {MIN_READINGS}"
        )
    sigma = np.sqrt(np.diag(fit.cov))
    limits = (MAX_SIGMA["scale"], *(MAX_SIGMA["angle"],) * 3)
    factors = (SCALE.factor, *(MISALIGNMENT.factor,) * 3)
    units = ("%", "°", "°", "°")
    poor = [
        f"{k} ± {v * f:.3g} {u}"
        for k, v, lim, f, u in zip(NAMES, sigma, limits, factors, units, strict=True)
        if not v <= lim
    ]
    if poor:
        raise ValueError(
            f"fit_dvl: the readings of {name!r} do not observe its calibration ({', '.join(poor)}; "
            f"a fit is reported up to σ {100 * MAX_SIGMA['scale']:g} % and "
            f"{math.degrees(MAX_SIGMA['angle']):g}°): the vehicle at rest, or too little "
            "speed or turning under way, over the reference's span"
        )


@dataclass(frozen=True)
class ReadingsFit:
    """:func:`fit_readings`'s result, in SI (the scale a ratio, the angles in rad)."""

    p: Array
    """(s, δ_roll, δ_pitch, δ_yaw)."""
    cov: Array
    """Their covariance (4, 4) (module docstring; :func:`_covariance`)."""
    keep: NDArray[np.bool_]
    """The readings the fit kept."""
    residuals: Array
    """``z - (1 + s) M(δ) h`` of the kept readings (m, 3)."""
    rho: float
    bandwidth: float


def fit_readings(z: Array, h: Array, nominal: Array) -> ReadingsFit:
    """Fit ``z_k = (1 + s) M(δ) h_k`` to the readings z (n, 3) given the error-free h (n, 3),
    in reading order, and the sensor's configured σ per axis ``nominal`` (3,) (module
    docstring: exclusions, weights, covariance)."""
    keep = np.ones(z.shape[0], dtype=bool)
    for _ in range(10):  # the exclusions settle in 2-4 rounds; a reading may come back
        p = _solve(z[keep], h[keep])[0]
        res = z - _model(p, h)
        scale = np.maximum(1.4826 * np.median(np.abs(res[keep]), axis=0), nominal)
        out = np.any(np.abs(res) > OUTLIER_SIGMAS * scale, axis=1)
        if np.array_equal(~out, keep):
            break
        keep = ~out
    p, J, r, w = _solve(z[keep], h[keep])
    W = np.tile(w, int(keep.sum()))
    A_inv = np.asarray(np.linalg.inv(J.T @ (J * W[:, None])), dtype=float)
    # each reading's part of the normal equations' gradient, g_k = Σ_axes J_kᵀ W r_k (n, 4)
    g = (J * (W * r.reshape(-1))[:, None]).reshape(-1, 3, 4).sum(axis=1)
    rho, bandwidth, cov = _covariance(g, A_inv)
    return ReadingsFit(p, cov, keep, r, rho, bandwidth)


def _covariance(g: Array, A_inv: Array) -> tuple[float, float, Array]:
    """(ρ, b, C): the fit's covariance C from the readings' parts g_k (n, 4) of the gradient
    and ``A⁻¹ = (Jᵀ W J)⁻¹``, the larger per quantity of two sandwiches ``A⁻¹ S A⁻¹``:

    * S_b, the long-run covariance of the g_k prewhitened (Andrews & Monahan 1992): ``g_k =
      B g_{k-1} + u_k`` (:func:`_prewhiten`), the Bartlett sum of the u_k
      (``estimation.long_run.bartlett``) over ``b = n^(2/3)`` readings, recoloured, ``S_b =
      (I - B)⁻¹ S_u (I - B)⁻ᵀ / (1 - b/n + (b/n)²/3)``; the divisor is what the Bartlett sum
      takes of the long-run covariance on average at a fixed b/n when the terms sum to zero,
      as the g_k do at the fit (Kiefer & Vogelsang 2005, "A new asymptotic theory for
      heteroskedasticity-autocorrelation robust tests", Econometric Theory 21(6));
    * S_0 = Σ g_k g_kᵀ, White's (1980) sandwich of uncorrelated readings.

    ``C = Δ A⁻¹ S_b A⁻¹ Δ``, ``Δ = diag(max(1, √(c0_ii / cb_ii)))``: S_b's correlations, each
    σ at least the sandwich's; positive semi-definite, as S_b is. ρ is the largest of the
    g_k's columns' lag-1 correlations, a diagnostic: nothing is sized from it."""
    n = g.shape[0]
    white = A_inv @ (g.T @ g) @ A_inv
    rho = _lag1(g)
    if n < 10:
        return rho, 0.0, np.asarray(white, dtype=float)
    B, u = _prewhiten(g)
    # A bandwidth that grows with n faster than the MSE-optimal n^(1/3) (Andrews 1991), so
    # that a slow error under a larger white one is summed whole: sized from the lag-1
    # correlation of what prewhitening leaves, which the white noise sets, it was 0 and σ
    # 2.3-7.5 times too small (docs/calibration.md). The price is noise in S_b, about that
    # of 1.5 n / b independent looks, hence the floor below.
    b = n ** (2.0 / 3.0)
    x = b / n
    D = np.linalg.inv(np.eye(g.shape[1]) - B)
    S = D @ long_run.bartlett(u, b) @ D.T / (1.0 - x + x * x / 3.0)
    slow = A_inv @ S @ A_inv
    # The sandwich as a floor: on the demo mission (2600 readings, two thirds at rest) S_b's
    # noise alone made white readings' σ 11-21 % smaller in the median and too small.
    d = np.sqrt(np.maximum(1.0, np.diag(white) / np.diag(slow)))
    return rho, float(b), np.asarray(slow * np.outer(d, d), dtype=float)


def _prewhiten(g: Array) -> tuple[Array, Array]:
    """(B, u): ``g_k = B g_{k-1} + u_k`` fitted by least squares, B's singular values capped at
    :data:`MAX_RHO` (so that ``(I - B)⁻¹`` stays bounded), and the residuals u (n - 1, d)."""
    X, Y = g[:-1], g[1:]
    B = np.linalg.lstsq(X, Y, rcond=None)[0].T
    U, sv, Vt = np.linalg.svd(B)
    B = (U * np.minimum(sv, MAX_RHO)) @ Vt
    return np.asarray(B, dtype=float), np.asarray(Y - X @ B.T, dtype=float)


def _lag1(g: Array) -> float:
    """The largest of g's columns' lag-1 correlations (0 for fewer than 3 rows)."""
    if g.shape[0] < 3:
        return 0.0
    num = np.sum(g[1:] * g[:-1], axis=0)
    den = np.sqrt(np.sum(g[1:] ** 2, axis=0) * np.sum(g[:-1] ** 2, axis=0))
    return float(np.max(np.where(den > 0.0, num / np.where(den > 0.0, den, 1.0), 0.0)))


def _predicted(mission: Mission, name: str, source: Source) -> tuple[Array, Array, Array, int, int]:
    """(t, z, h, in_gaps, outside) of the finite readings of ``name`` inside the reference: the
    readings z and the reference's error-free h, each (n, 3), how many finite readings were left
    out in the reference's gaps (:func:`_in_reference_gaps`) and how many outside its span."""
    truth = mission.truth
    if truth is None:
        raise ValueError("fit_dvl: the mission has no reference (truth) table")
    if source not in ("velocity", "position"):
        raise ValueError(f"fit_dvl: source {source!r} is not 'velocity' or 'position'")
    needs = _VELOCITY if source == "velocity" else _POSITION
    missing = [c for c in ("t_s", *needs, *_ATTITUDE) if c not in truth.columns]
    if missing:
        raise ValueError(f"fit_dvl: the reference (truth) table lacks columns {missing}")
    t_ref = truth["t_s"].to_numpy(dtype=float)
    if t_ref.size < 3 or not np.all(np.diff(t_ref) > 0.0):
        raise ValueError("fit_dvl: the reference's t_s must be increasing, with 3 rows or more")
    v_ref = (
        truth[list(_VELOCITY)].to_numpy(dtype=float)
        if source == "velocity"
        else position_rate(t_ref, truth[list(_POSITION)].to_numpy(dtype=float))
    )
    t, z, valid = dvl_readings(mission, name, t_ref, "fit_dvl")
    t, z = t[valid], z[valid]
    outside = int(np.all(np.isfinite(mission.sensors[name].z), axis=1).sum()) - t.size
    gap = _in_reference_gaps(t_ref, t, name)
    t, z = t[~gap], z[~gap]
    rpy = truth[list(_ATTITUDE)].to_numpy(dtype=float)
    q_nb = Slerp(t_ref, Rotation.from_euler("ZYX", rpy[:, ::-1]))(t).as_quat()
    x = np.zeros((t.size, NOM_SIZE))
    x[:, NOM_VEL] = np.column_stack([np.interp(t, t_ref, v_ref[:, i]) for i in range(3)])
    x[:, NOM_ATT] = q_nb[:, [3, 0, 1, 2]]  # scipy's scalar-last to the state's scalar-first
    omega = imu_rate_at(mission, t)
    if all(c in truth.columns for c in _GYRO_BIAS):
        x[:, NOM_BG] = np.column_stack([np.interp(t, t_ref, truth[c]) for c in _GYRO_BIAS])
    model = mission.config.sensors[name]
    h = dvl.ideal(
        IdealInput(x, omega, np.zeros_like(omega), model.lever_arm(), model.sensor_from_body())
    )
    return t, z, np.asarray(h, dtype=float), int(gap.sum()), outside


def _in_reference_gaps(t_ref: Array, t: Array, name: str) -> NDArray[np.bool_]:
    """Which readings (times t, inside the reference's span) fall in a reference interval
    longer than :data:`MAX_REFERENCE_STEP_S`; ValueError when the median one does, as the
    reference then cannot give the velocity and attitude at the readings (module docstring)."""
    j = np.clip(np.searchsorted(t_ref, t, side="right") - 1, 0, t_ref.size - 2)
    step = t_ref[j + 1] - t_ref[j]
    if step.size and float(np.median(step)) > MAX_REFERENCE_STEP_S:
        raise ValueError(
            f"fit_dvl: the reference (truth) is too coarse for the readings of {name!r}: its "
            f"rows around them are {float(np.median(step)):.3g} s apart (median; the fit takes "
            f"at most {MAX_REFERENCE_STEP_S:g} s), and its velocity and attitude interpolated "
            "across such steps are not the vehicle's at the readings"
        )
    return np.asarray(step > MAX_REFERENCE_STEP_S, dtype=bool)


def position_rate(t: Array, llh: Array) -> Array:
    """NED velocity (n, 3) of the positions ``llh`` (lat, lon rad, h m) at times t, by central
    differences (one-sided at the ends; module docstring)."""
    lat, lon, h = llh.T
    return np.column_stack(
        [
            np.gradient(lat, t) * (earth.meridian_radius(lat) + h),
            np.gradient(lon, t) * (earth.transverse_radius(lat) + h) * np.cos(lat),
            -np.gradient(h, t),
        ]
    )


def reference_consistency(truth: pd.DataFrame) -> tuple[float, float]:
    """How far a reference's velocity columns and the rate of its positions
    (:func:`position_rate`) disagree, horizontally: (the least-squares factor k of
    ``v_pos ≈ k v``, minus 1, in %; the 95th percentile of ``|v_pos - v|``, m/s). About 0 and the
    positions' own noise over the sampling interval for a reference whose velocity is the
    derivative of its positions; on A-KIT -0.45 to +0.25 % and 0.04-0.15 m/s
    (docs/calibration.md, 'Against a reference'). ValueError without the columns."""
    missing = [c for c in ("t_s", *_POSITION, *_VELOCITY) if c not in truth.columns]
    if missing:
        raise ValueError(f"reference_consistency: the reference lacks columns {missing}")
    t = truth["t_s"].to_numpy(dtype=float)
    v = truth[list(_VELOCITY[:2])].to_numpy(dtype=float)
    vp = position_rate(t, truth[list(_POSITION)].to_numpy(dtype=float))[:, :2]
    scale = float(100.0 * (np.sum(vp * v) / np.sum(v * v) - 1.0))
    return scale, float(np.percentile(np.linalg.norm(vp - v, axis=1), 95.0))


def _model(p: Array, h: Array) -> Array:
    """``(1 + s) M(δ) h_k`` for every reading (n, 3)."""
    return np.asarray((1.0 + p[0]) * (h @ misalignment(p[1:]).T), dtype=float)


def _solve(z: Array, h: Array) -> tuple[Array, Array, Array, Array]:
    """Weighted Gauss-Newton fit of ``p = (s, δ)`` to the readings z (n, 3): (p, J at p (3n, 4),
    residuals (n, 3), the per-axis weights (3,)). The weights are the inverse residual variances
    of an unweighted first pass, so an axis noisier than the others counts less."""
    p = np.zeros(4)
    w = np.ones(3)
    for it in range(12):
        J = _jacobian(p, h)
        r = (z - _model(p, h)).reshape(-1)
        if it == 1:  # weights from the first (unweighted) fit's residuals
            w = 1.0 / np.maximum(np.mean(r.reshape(-1, 3) ** 2, axis=0), 1e-12)
        W = np.tile(w, r.size // 3)
        A = J.T @ (J * W[:, None])
        if np.linalg.cond(A) > MAX_CONDITION:
            raise ValueError(
                "fit_dvl: the readings do not observe the DVL's scale and misalignment (the "
                "reference velocity is too small or never changes direction)"
            )
        step = np.linalg.solve(A, J.T @ (W * r))
        p = p + step
        if it >= 2 and np.max(np.abs(step)) < 1e-12:
            break
    J = _jacobian(p, h)
    return p, J, z - _model(p, h), w


def _jacobian(p: Array, h: Array) -> Array:
    """``∂[(1 + s) M(δ) h_k]/∂(s, δ)`` for h (n, 3): (3n, 4), rows reading by reading."""
    J = np.empty((h.shape[0], 3, 4))
    J[:, :, 0] = h @ misalignment(p[1:]).T
    for i, dM in enumerate(derivatives(p[1:])):
        J[:, :, 1 + i] = (1.0 + p[0]) * (h @ dM.T)
    return J.reshape(-1, 4)
