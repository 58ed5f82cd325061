"""Accuracy and consistency metrics of a run against a reference trajectory (docs/metrics.md).

The reference ("truth") is a table with ``t_s, lat_rad, lon_rad, h_m`` and optionally
``vn_m_s, ve_m_s, vd_m_s`` and ``roll_rad, pitch_rad, yaw_rad``, times non-decreasing.

Every metric is computed over the truth samples that lie inside the solution's time span
``[t_first, t_last]``; the estimate is interpolated linearly in time to those samples
(lat, lon unwrapped, h, velocity, Euler angles unwrapped, standard deviations). A reference
denser than the solution is first interpolated to the solution's rows instead
(:func:`scoring_reference`): the sparser series is the one interpolated.

Errors are **estimate minus truth**, resolved in the local NED frame **at each truth point**,
computed exactly through ECEF: ``e_n = C_ne(lat_ref, lon_ref) (r_e(est) - r_e(ref))``
(Groves 2.112, 2.150). (The filter's own error state is truth minus estimate; the sign does not
matter to any metric here.)

* paper eq. (32): ``RMSE = sqrt(mean(dN² + dE² + dD²))`` in metres;
* paper eq. (33): ``relative RMSE (%) = 100 RMSE / D`` with D the **horizontal** length of the
  reference track, the sum of its horizontal (N, E) steps (:func:`travelled_distance`), so that
  a vessel's heave, which the reference records, does not lengthen it;
* NEES of position, velocity and attitude (:func:`nees`), each with the full 3×3 block of P
  the engine records: ``NEES_k = e_kᵀ P_k⁻¹ e_k``, χ²(3)-distributed for a consistent filter
  (mean 3; 95 % of the epochs inside ``[χ²₀.₀₂₅(3), χ²₀.₉₇₅(3)] ≈ [0.216, 9.348]``,
  :data:`NEES_BAND`);
* NIS per sensor from the ledger: the mean of the used readings' NIS, ``y' S^-1 y``; for a
  consistent filter with independent innovations ``K mean ~ chi²(sum_k d_k)``, which gives
  the two-sided 95 % bounds of the mean.

A smoothed run (``Result.forward`` set, docs/smoothing.md) is scored on its RTS-smoothed
``solution``; :func:`forward_metrics` scores its forward solution by the same :func:`evaluate`,
and :func:`forward_columns` gives the :data:`FORWARD_KEYS` of that score as ``forward_<key>``,
to be read beside the smoothed ones.

The definitions, in words and equations, are in docs/metrics.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal, get_args

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.special import gammaincinv

from adaptnav.api.results import (
    Result,
    check_finite,
    covariance_block,
    has_covariances,
    jsonable,
    ledger_counts,
)
from adaptnav.core import earth
from adaptnav.core.attitude import wrap_angle
from adaptnav.engine.batch import MAX_DIM
from adaptnav.models.errorstate import STATE_NAMES

Array = NDArray[np.float64]

TRUTH_POSITION = ("t_s", "lat_rad", "lon_rad", "h_m")
TRUTH_VELOCITY = ("vn_m_s", "ve_m_s", "vd_m_s")
TRUTH_ATTITUDE = ("roll_rad", "pitch_rad", "yaw_rad")
POSITION_SD = ("sd_dr_N", "sd_dr_E", "sd_dr_D")
NIS_CONFIDENCE = 0.95
COVERAGE_GAP = 10.0
"""A step between reference samples longer than this many times their median step is a hole
in the reference (:func:`reference_coverage`)."""
COVERAGE_MIN_GAP_S = 1.0
"""...and at least this long: a 100-Hz reference with a 0.5-s hiccup still covers the run."""
LAG_MAX_S = 60.0
"""Largest time offset of a reference :func:`reference_lag` searches, s."""
LAG_STEP_S = 0.1
"""Its finest step, s."""
LAG_SAMPLES = 1000
"""Reference samples it uses at most (evenly thinned)."""
LAG_GAIN = 4.0
"""How many times smaller the velocity misfit at the best offset must be than at 0."""
DENSER = 0.75
"""A reference whose median step is below this share of the solution's is *denser* than the
solution, and the run is scored at the solution's epochs (:func:`scoring_reference`)."""
COVERAGE_WARN = 0.95
"""``evaluate`` warns when the reference covers less of the run than this share."""
"""Two-sided probability of the NIS bounds."""
NeesBlock = Literal["position", "velocity", "attitude"]
NEES_BLOCKS: tuple[NeesBlock, ...] = get_args(NeesBlock)
NEES_STATES: dict[NeesBlock, tuple[str, str, str]] = {
    "position": ("dr_N", "dr_E", "dr_D"),
    "velocity": ("dv_N", "dv_E", "dv_D"),
    "attitude": ("phi_N", "phi_E", "phi_D"),
}
"""The error states (:data:`adaptnav.models.errorstate.STATE_NAMES`) of each NEES block."""


def _chi2_ppf(q: float, dof: float) -> float:
    """χ²_dof quantile: ``2 P⁻¹(dof/2, q)`` with P the regularised lower incomplete gamma
    function, as scipy.stats.chi2.ppf evaluates it (scipy.stats alone takes ~1 s to import)."""
    return 2.0 * float(gammaincinv(0.5 * dof, q))


NEES_DOF = 3
NEES_CONFIDENCE = 0.95
NEES_BAND: tuple[float, float] = (
    _chi2_ppf((1.0 - NEES_CONFIDENCE) / 2.0, NEES_DOF),
    _chi2_ppf((1.0 + NEES_CONFIDENCE) / 2.0, NEES_DOF),
)
"""Two-sided 95 % interval of one epoch's NEES for a consistent filter, χ²(3) quantiles
0.025 and 0.975: about [0.216, 9.348]."""
assert all(n in STATE_NAMES for names in NEES_STATES.values() for n in names)
FORWARD_KEYS: tuple[str, ...] = ("rmse_m", "relative_rmse_pct", "mean_nees_position")
"""The metrics of a smoothed run's forward solution shown beside the smoothed ones, each as
``forward_<key>`` (:func:`forward_columns`)."""


def _column(frame: pd.DataFrame, name: str) -> Array:
    return np.asarray(frame[name].to_numpy(dtype=float), dtype=float)


def _check_truth(truth: pd.DataFrame) -> Array:
    missing = [c for c in TRUTH_POSITION if c not in truth.columns]
    if missing:
        raise ValueError(f"truth lacks columns {missing}")
    t = _column(truth, "t_s")
    if t.size and (not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0.0)):
        raise ValueError("truth: t_s must be finite and non-decreasing")
    return t


def _solution_time(solution: pd.DataFrame) -> Array:
    if "t_s" not in solution.columns:
        raise ValueError("solution lacks column 't_s'")
    t = _column(solution, "t_s")
    if t.size == 0:
        raise ValueError("solution has no rows")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0.0):
        raise ValueError("solution: t_s must be finite and non-decreasing")
    return t


def _in_span(t_truth: Array, t_sol: Array) -> NDArray[np.bool_]:
    return np.asarray((t_truth >= t_sol[0]) & (t_truth <= t_sol[-1]), dtype=bool)


def _interp(t: Array, t_sol: Array, values: Array, unwrap: bool = False) -> Array:
    v = np.unwrap(values) if unwrap else values
    return np.asarray(np.interp(t, t_sol, v), dtype=float)


def scoring_reference(truth: pd.DataFrame, t_sol: Array) -> tuple[pd.DataFrame, str]:
    """The reference at the epochs a run is scored at, and which they are
    (docs/metrics.md, 'What is scored'):

    * ``"reference"``: its own samples, the solution interpolated to them (the module
      docstring), when the reference is no denser than the solution: a 1-Hz GNSS reference
      against 10-Hz rows;
    * ``"solution"``: the solution's rows, the reference interpolated linearly to them (lat,
      lon and Euler angles unwrapped), when its median step is below :data:`DENSER` times the
      solution's. Rows outside the reference's span or inside one of its holes (a step longer
      than :func:`reference_coverage` allows) are not scored.

    Interpolating the sparser of the two keeps the interpolation error below what the filter
    claims: up to 0.4.6 a run with ``output_rate_hz = 1`` against the simulator's 10-Hz truth
    had its attitude scored between rows 1 s apart across the waves' ±2° of roll, a mean
    attitude NEES of 514 against 2.2 for the same filter at 10 Hz, exit 0.
    """
    t_ref = _check_truth(truth)
    if t_ref.size < 2 or t_sol.size < 2:
        return truth, "reference"
    step_ref = float(np.median(np.diff(t_ref)))
    if not step_ref < DENSER * float(np.median(np.diff(t_sol))):
        return truth, "reference"
    longest = max(COVERAGE_MIN_GAP_S, COVERAGE_GAP * step_ref)
    k = np.searchsorted(t_ref, t_sol, side="right")  # t_ref[k-1] <= t < t_ref[k]
    at_sample = (k > 0) & (t_ref[np.maximum(k - 1, 0)] == t_sol)
    inside = (k > 0) & (k < t_ref.size)
    step = np.where(inside, t_ref[np.minimum(k, t_ref.size - 1)] - t_ref[np.maximum(k - 1, 0)],
                    np.inf)  # fmt: skip
    t = t_sol[at_sample | (inside & (step <= longest))]
    columns = [c for c in (*TRUTH_VELOCITY, *TRUTH_ATTITUDE) if c in truth.columns]
    out = {"t_s": t}
    for c in (*TRUTH_POSITION[1:], *columns):
        out[c] = _interp(t, t_ref, _column(truth, c), unwrap=c in ("lon_rad", *TRUTH_ATTITUDE))
    for c in ("lon_rad", *TRUTH_ATTITUDE):
        if c in out:
            out[c] = wrap_angle(out[c])
    return pd.DataFrame(out), "solution"


def ned_errors(
    lat: Array, lon: Array, h: Array, lat_ref: Array, lon_ref: Array, h_ref: Array
) -> Array:
    """Exact NED vectors (N, 3) from each reference point to its estimate point, resolved at
    the reference: ``C_ne(lat_ref, lon_ref) (r_e(est) - r_e(ref))``."""
    d = earth.geodetic_to_ecef(lat, lon, h) - earth.geodetic_to_ecef(lat_ref, lon_ref, h_ref)
    C = earth.C_ne(lat_ref, lon_ref)
    return np.asarray(np.einsum("nij,nj->ni", C, d.reshape(-1, 3)), dtype=float)


def position_errors(solution: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Estimate-minus-truth errors at the truth times inside the solution span.

    Columns ``t_s, dN_m, dE_m, dD_m, horizontal_m = sqrt(dN² + dE²), error_m = |e|``; with
    truth velocity also ``dvN_m_s, dvE_m_s, dvD_m_s``; with truth attitude also ``droll_rad,
    dpitch_rad, dyaw_rad`` (Euler-angle differences wrapped to (-π, π]). Position errors are in
    NED at each truth point, exact (see the module docstring).
    """
    t_truth = _check_truth(truth)
    t_sol = _solution_time(solution)
    keep = _in_span(t_truth, t_sol)
    t = t_truth[keep]
    lat = _interp(t, t_sol, _column(solution, "lat_rad"))
    lon = _interp(t, t_sol, _column(solution, "lon_rad"), unwrap=True)
    h = _interp(t, t_sol, _column(solution, "h_m"))
    e = ned_errors(
        lat,
        lon,
        h,
        _column(truth, "lat_rad")[keep],
        _column(truth, "lon_rad")[keep],
        _column(truth, "h_m")[keep],
    )
    out: dict[str, Array] = {
        "t_s": t,
        "dN_m": e[:, 0],
        "dE_m": e[:, 1],
        "dD_m": e[:, 2],
        "horizontal_m": np.hypot(e[:, 0], e[:, 1]),
        "error_m": np.sqrt(np.sum(e * e, axis=1)),
    }
    if all(c in truth.columns for c in TRUTH_VELOCITY):
        for c, name in zip(TRUTH_VELOCITY, ("dvN_m_s", "dvE_m_s", "dvD_m_s"), strict=True):
            out[name] = _interp(t, t_sol, _column(solution, c)) - _column(truth, c)[keep]
    if all(c in truth.columns for c in TRUTH_ATTITUDE):
        for c in TRUTH_ATTITUDE:
            est = _interp(t, t_sol, _column(solution, c), unwrap=True)
            out[f"d{c}"] = wrap_angle(est - _column(truth, c)[keep])
    return pd.DataFrame(out)


def rmse(errors: pd.DataFrame) -> float:
    """``RMSE = sqrt(mean(dN² + dE² + dD²))`` (m), paper eq. (32) (docs/metrics.md, 'Accuracy');
    NaN for no samples."""
    e = errors[["dN_m", "dE_m", "dD_m"]].to_numpy(dtype=float)
    if e.shape[0] == 0:
        return math.nan
    return float(np.sqrt(np.mean(np.sum(e * e, axis=1))))


def horizontal_rmse(errors: pd.DataFrame) -> float:
    """``sqrt(mean(dN² + dE²))`` (m); NaN for no samples."""
    e = errors[["dN_m", "dE_m"]].to_numpy(dtype=float)
    if e.shape[0] == 0:
        return math.nan
    return float(np.sqrt(np.mean(np.sum(e * e, axis=1))))


def travelled_distance(truth: pd.DataFrame) -> float:
    """Horizontal length of the reference track (m), the denominator of paper eq. (33)
    (docs/metrics.md, 'Accuracy'): ``D = sum_k sqrt(dN_k² + dE_k²)`` where
    ``[dN_k, dE_k, dD_k] = C_ne(mid_k) (r_e(k+1) - r_e(k))`` is step k resolved in the local NED
    frame at its mid-point (lat and lon averaged). The vertical part of each step is left out, so a
    vessel's heave (or a car's climb) does not lengthen the distance the errors are scored
    against."""
    _check_truth(truth)
    lat, lon, h = (_column(truth, c) for c in TRUTH_POSITION[1:])
    if lat.size < 2:
        return 0.0
    lon = np.unwrap(lon)
    r = earth.geodetic_to_ecef(lat, lon, h).reshape(-1, 3)
    C = earth.C_ne(0.5 * (lat[1:] + lat[:-1]), 0.5 * (lon[1:] + lon[:-1]))
    steps = np.einsum("nij,nj->ni", C.reshape(-1, 3, 3), np.diff(r, axis=0))
    return float(np.sum(np.hypot(steps[:, 0], steps[:, 1])))


MIN_DISTANCE_M = 1.0
"""The shortest horizontal distance (m) a percentage of it is given for (:func:`relative_rmse_pct`,
:func:`outage_drift`'s ``drift_pct``): below it the denominator is of the order of the position
error itself, or of the reference's own jitter, and says nothing about the run (a stationary
run of 0.5 s travelled 6e-9 m and scored 66 billion %); a vessel at 0.5 m/s passes it in 2 s."""


def relative_rmse_pct(rmse_m: float, distance_m: float) -> float:
    """``100 RMSE / D`` (%), paper eq. (33) (docs/metrics.md, 'Accuracy'); NaN when the distance
    is below :data:`MIN_DISTANCE_M` (before 0.4.6: only when it was zero)."""
    return 100.0 * rmse_m / distance_m if distance_m >= MIN_DISTANCE_M else math.nan


def outage_drift(
    solution: pd.DataFrame, truth: pd.DataFrame, windows: Sequence[tuple[float, float]]
) -> pd.DataFrame:
    """The inertial drift over aiding outages, scored against the withheld reference.

    For each window ``(start, length)`` (s), over the truth samples in ``(start, start +
    length]``: the horizontal error at the last one (``end_horizontal_m``, the drift), its
    maximum, the 3-D error at the end, the horizontal distance travelled (the truth's steps,
    :func:`travelled_distance`) and the drift as a percentage of it (horizontal over
    horizontal; NaN below :data:`MIN_DISTANCE_M`). Also the filter's claimed horizontal σ at
    the end, ``sqrt(sd_N² + sd_E²)`` (NaN if the solution has no ``sd_dr_*``), to judge its
    consistency. A window with no truth sample is an error.
    """
    errors = position_errors(solution, truth)
    t_e = _column(errors, "t_s")
    horizontal, error = _column(errors, "horizontal_m"), _column(errors, "error_m")
    if all(c in solution.columns for c in POSITION_SD[:2]):
        t_sol = _solution_time(solution)
        sd_n, sd_e = (_interp(t_e, t_sol, _column(solution, c)) for c in POSITION_SD[:2])
        sd_h = np.hypot(sd_n, sd_e)
    else:
        sd_h = np.full(t_e.size, math.nan)
    t_truth = _column(truth, "t_s")
    rows = []
    for i, (start, length) in enumerate(windows):
        inside = (t_e > start) & (t_e <= start + length)
        if not inside.any():
            raise ValueError(f"outage {i} ({start:g} s + {length:g} s): no truth sample inside")
        k = int(np.flatnonzero(inside)[-1])
        in_truth = (t_truth >= start) & (t_truth <= start + length)
        dist = travelled_distance(truth[in_truth]) if in_truth.sum() > 1 else 0.0
        rows.append(
            {
                "outage": i,
                "start_s": float(start),
                "length_s": float(length),
                "end_horizontal_m": float(horizontal[k]),
                "max_horizontal_m": float(horizontal[inside].max()),
                "end_error_m": float(error[k]),
                "distance_m": dist,
                "drift_pct": 100.0 * horizontal[k] / dist if dist >= MIN_DISTANCE_M else math.nan,
                "claimed_sd_horizontal_m": float(sd_h[k]),
            }
        )
    return pd.DataFrame(rows)


def euler_quaternions(roll: Array, pitch: Array, yaw: Array) -> Array:
    """Unit quaternions ``q_nb`` (N, 4, ``[w, x, y, z]``, Hamilton) of ZYX Euler angles, row by
    row: ``q = q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll)``, the quaternion of ``C_nb = Rz(yaw) Ry(pitch)
    Rx(roll)`` (docs/conventions.md), each factor ``[cos(a/2), sin(a/2) axis]``."""
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    return np.stack(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ],
        axis=-1,
    )


def rotation_vectors_between(q_true: Array, q_hat: Array) -> Array:
    """``phi = Log(q_true ⊗ q_hat*)`` (N, 3) for unit quaternions (N, 4): the rotation vector
    in n that carries ``C_nb_hat`` onto ``C_nb_true``, ``C_nb_true = Exp(phi) C_nb_hat``
    (docs/conventions.md, docs/metrics.md). The shorter of the two quaternions of the rotation
    (``w >= 0``) is taken, so ``|phi| <= π``; ``phi = 2 atan2(|v|, w) v / |v|``, and ``2 v / w``
    in the limit ``|v| = 0``."""
    a, b = q_true.T, q_hat.T
    w = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    v = np.stack(
        [
            -a[0] * b[1] + a[1] * b[0] - a[2] * b[3] + a[3] * b[2],
            -a[0] * b[2] + a[1] * b[3] + a[2] * b[0] - a[3] * b[1],
            -a[0] * b[3] - a[1] * b[2] + a[2] * b[1] + a[3] * b[0],
        ],
        axis=-1,
    )
    sign = np.where(w < 0.0, -1.0, 1.0)
    w, v = w * sign, v * sign[:, None]
    vn = np.sqrt(np.sum(v * v, axis=1))
    safe = np.where(vn > 0.0, vn, 1.0)
    scale = np.where(vn > 0.0, 2.0 * np.arctan2(vn, w) / safe, 2.0 / w)
    return np.asarray(v * scale[:, None], dtype=float)


def block_errors(solution: pd.DataFrame, truth: pd.DataFrame, block: NeesBlock) -> pd.DataFrame:
    """The errors a NEES block is made of, at the truth times inside the solution span
    (solution interpolated as in :func:`position_errors`). Columns ``t_s, e_0, e_1, e_2``:

    * ``position``: the NED position errors of :func:`position_errors` (m; estimate minus
      truth, the sign does not matter to a NEES);
    * ``velocity``: truth minus estimate of ``vn_m_s, ve_m_s, vd_m_s`` (m/s);
    * ``attitude``: ``phi = Log(C_nb_true C_nb_hatᵀ)`` (rad), the rotation vector in n that
      carries the estimated attitude onto the true one, ``C_nb_true = Exp(phi) C_nb_hat``
      (docs/conventions.md), from the Euler angles of both.

    Raises ValueError if the truth lacks the block's columns (velocity and attitude are
    optional in a reference).
    """
    if block not in NEES_STATES:
        raise ValueError(f"block: {block!r} is not one of {', '.join(NEES_BLOCKS)}")
    t_truth = _check_truth(truth)
    if block == "position":
        return _position_block(position_errors(solution, truth))
    group = TRUTH_VELOCITY if block == "velocity" else TRUTH_ATTITUDE
    missing = [c for c in group if c not in truth.columns]
    if missing:
        raise ValueError(f"truth lacks columns {missing}: no {block} NEES")
    t_sol = _solution_time(solution)
    keep = _in_span(t_truth, t_sol)
    t = t_truth[keep]
    unwrap = block == "attitude"
    est = [_interp(t, t_sol, _column(solution, c), unwrap=unwrap) for c in group]
    ref = [_column(truth, c)[keep] for c in group]
    if block == "velocity":
        e = np.stack([r - x for r, x in zip(ref, est, strict=True)], axis=-1)
    elif t.size == 0:
        e = np.zeros((0, 3))
    else:
        e = rotation_vectors_between(euler_quaternions(*ref), euler_quaternions(*est))
    return pd.DataFrame({"t_s": t, "e_0": e[:, 0], "e_1": e[:, 1], "e_2": e[:, 2]})


def _position_block(errors: pd.DataFrame) -> pd.DataFrame:
    """The position NEES block's errors (:func:`block_errors`) from :func:`position_errors`."""
    t, e = _column(errors, "t_s"), errors[["dN_m", "dE_m", "dD_m"]].to_numpy(dtype=float)
    return pd.DataFrame({"t_s": t, "e_0": e[:, 0], "e_1": e[:, 1], "e_2": e[:, 2]})


PD_RATIO = 1e-12
"""A covariance counts as positive definite when its smallest eigenvalue exceeds this
fraction of its largest (:func:`nees_from`)."""


def nees_from(errors: Array, P: Array) -> Array:
    """``NEES_k = e_kᵀ P_k⁻¹ e_k`` for errors (N, d) and covariances (N, d, d); NaN where e
    or P has a non-finite element or P is not positive definite (smallest eigenvalue at most
    :data:`PD_RATIO` times the largest).

    All rows at once by symmetric elimination, ``P = L D Lᵀ`` (:func:`_ldl_quadratic`):
    ``NEES = Σ_i y_i² / D_i`` with ``L y = e``. The pivots decide definiteness without
    eigenvalues for almost every row: with all ``D_i > 0``, ``det P = Π D_i`` and the AM-GM
    bound on the other d - 1 eigenvalues give ``λ_min / λ_max ≥ det P (d-1)^(d-1) / tr(P)^d``;
    a row whose bound clears twice :data:`PD_RATIO` (room for rounding) is positive definite.
    The few others are decided by their eigenvalues and solved by LU (docs/metrics.md,
    'Consistency: NEES')."""
    e = np.asarray(errors, dtype=float)
    Pa = np.asarray(P, dtype=float)
    out = np.full(e.shape[0], math.nan)
    rows = np.flatnonzero(np.all(np.isfinite(e), axis=1) & np.all(np.isfinite(Pa), axis=(1, 2)))
    if rows.size == 0:
        return out
    d = e.shape[1]
    q, pivots = _ldl_quadratic(e[rows], Pa[rows])
    trace = np.trace(Pa[rows], axis1=1, axis2=2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        bound = np.prod(pivots, axis=1) * float((d - 1) ** (d - 1)) / trace**d
    sure = np.all(pivots > 0.0, axis=1) & (bound > 2.0 * PD_RATIO)
    out[rows[sure]] = q[sure]
    doubt = rows[~sure]
    if doubt.size:
        eig = np.linalg.eigvalsh(Pa[doubt])
        pd_rows = doubt[eig[:, 0] > PD_RATIO * np.maximum(eig[:, -1], 1e-300)]
        x = np.linalg.solve(Pa[pd_rows], e[pd_rows][..., None])[..., 0]
        out[pd_rows] = np.einsum("ni,ni->n", e[pd_rows], x)
    return out


def _ldl_quadratic(e: Array, P: Array) -> tuple[Array, Array]:
    """``(eᵀ P⁻¹ e, D)`` row by row for symmetric P (N, d, d) by Gaussian elimination without
    pivoting (``P = L D Lᵀ``, ``L y = e``, ``eᵀ P⁻¹ e = Σ_i y_i² / D_i``), vectorised over the
    rows: the pivots D (N, d) are those of the Cholesky factor squared. Meaningful only where
    every pivot is positive (:func:`nees_from` checks)."""
    A = np.array(P, dtype=float)
    y = np.array(e, dtype=float)
    d = y.shape[1]
    q = np.zeros(y.shape[0])
    pivots = np.empty_like(y)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for k in range(d):
            piv = A[:, k, k]
            pivots[:, k] = piv
            q += y[:, k] ** 2 / piv
            f = A[:, k + 1 :, k] / piv[:, None]
            A[:, k + 1 :, k + 1 :] -= f[:, :, None] * A[:, None, k, k + 1 :]
            y[:, k + 1 :] -= f * y[:, k, None]
    return q, pivots


def nees(solution: pd.DataFrame, truth: pd.DataFrame, block: NeesBlock) -> pd.DataFrame:
    """Normalised estimation error squared of one 3-dof block, at the truth times inside the
    solution span (docs/metrics.md).

    ``NEES_k = e_kᵀ P_k⁻¹ e_k`` with e_k the block's errors (:func:`block_errors`: position NED
    m, velocity NED m/s, attitude rotation vector phi rad) and P_k its 3×3 block of the
    filter's covariance: variances ``sd_<state>²`` and covariances ``cov_<a>_<b>`` of the
    solution table, each element interpolated linearly in time (a convex mix of two covariances,
    so still one). For a consistent filter NEES_k ~ χ²(3): mean 3, and inside
    :data:`NEES_BAND` at 95 % of the epochs. A solution without the ``cov_`` columns (a run
    folder written before they were recorded) gives the diagonal-only NEES
    ``sum_i (e_i / sd_i)²``; ``attrs["uses_correlations"]`` of the returned table says which.
    Columns ``t_s, nees``; NaN where the covariance is unknown or not positive definite.
    """
    return _nees_of(solution, block_errors(solution, truth, block), block)  # checks block


def _nees_of(solution: pd.DataFrame, errors: pd.DataFrame, block: NeesBlock) -> pd.DataFrame:
    """:func:`nees` from the block's errors (:func:`block_errors`)."""
    names = NEES_STATES[block]
    sd = [f"sd_{n}" for n in names]
    missing = [c for c in sd if c not in solution.columns]
    if missing:
        raise ValueError(f"solution lacks columns {missing}")
    t_sol = _solution_time(solution)
    t = _column(errors, "t_s")
    P_sol = covariance_block(solution, names)
    P = np.empty((t.size, 3, 3))
    for i in range(3):
        for j in range(i, 3):  # P is symmetric: each pair interpolated once
            P[:, i, j] = P[:, j, i] = _interp(t, t_sol, P_sol[:, i, j])
    e = errors[["e_0", "e_1", "e_2"]].to_numpy(dtype=float)
    out = pd.DataFrame({"t_s": t, "nees": nees_from(e, P)})
    out.attrs["uses_correlations"] = has_covariances(solution, names)
    return out


def nees_position(solution: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """:func:`nees` of the position block (columns ``t_s, nees``)."""
    return nees(solution, truth, "position")


def fraction_in_band(values: Array, band: tuple[float, float] = NEES_BAND) -> float:
    """The fraction of the finite ``values`` inside ``[band[0], band[1]]`` (NaN for none):
    for per-epoch NEES of a consistent filter with :data:`NEES_BAND`, about 0.95."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan
    return float(np.mean((v >= band[0]) & (v <= band[1])))


def _nees_summary(
    solution: pd.DataFrame,
    truth: pd.DataFrame,
    block: NeesBlock,
    errors: pd.DataFrame | None = None,
) -> tuple[float, float, int | None]:
    """Mean NEES, its in-band fraction and the number of epochs they are over for ``block``:
    NaNs and None if the truth lacks the block or the solution its σ's; NaNs and 0 if no
    epoch has a finite NEES. An epoch whose P block is not finite or not positive definite
    has no NEES (:func:`nees_from`) and is left out of the mean, so the count says over how
    many of the scored epochs it is. ``errors``: the block's errors (:func:`block_errors`)
    when the caller has them already."""
    group = {"position": TRUTH_POSITION, "velocity": TRUTH_VELOCITY, "attitude": TRUTH_ATTITUDE}
    sd = [f"sd_{n}" for n in NEES_STATES[block]]
    if not all(c in truth.columns for c in group[block]) or not all(
        c in solution.columns for c in sd
    ):
        return math.nan, math.nan, None
    if errors is None:
        errors = block_errors(solution, truth, block)
    v = _column(_nees_of(solution, errors, block), "nees")
    finite = v[np.isfinite(v)]
    if finite.size == 0:
        return math.nan, math.nan, 0
    return float(finite.mean()), fraction_in_band(finite), int(finite.size)


@dataclass(frozen=True)
class NisSummary:
    """Mean NIS of one sensor's used readings with its chi-square bounds (docs/metrics.md, 'NIS').

    ``count`` readings of ``dof = sum_k d_k`` components in all; ``dim = dof / count`` is the
    reading dimension (the expected mean). With independent innovations and a consistent
    filter ``count * mean ~ chi²(dof)``, so ``[lower, upper] = chi2.ppf([a/2, 1 - a/2], dof) /
    count`` holds the mean with probability ``1 - a`` (:data:`NIS_CONFIDENCE`).
    """

    sensor: str
    count: int
    dim: float
    dof: int
    mean: float
    lower: float
    upper: float

    @property
    def consistent(self) -> bool:
        return self.lower <= self.mean <= self.upper


def nis_bounds(count: int, dof: int, confidence: float = NIS_CONFIDENCE) -> tuple[float, float]:
    """Two-sided bounds of the mean of ``count`` NIS values with ``dof`` degrees of freedom in
    all: ``chi2.ppf((1 ∓ confidence) / 2, dof) / count``."""
    if count < 1 or dof < 1:
        raise ValueError(f"nis_bounds: count {count} and dof {dof} must be >= 1")
    a = 1.0 - confidence
    return _chi2_ppf(a / 2.0, dof) / count, _chi2_ppf(1.0 - a / 2.0, dof) / count


def nis_summary(ledger: pd.DataFrame) -> dict[str, NisSummary]:
    """Per sensor (sorted), the mean NIS (ledger ``statistic``) of its ``used`` rows with a
    finite statistic; the dimension of a row is its number of finite ``r_j``. Sensors without
    such rows are left out."""
    used = ledger[(ledger["fate"] == "used") & np.isfinite(ledger["statistic"].astype(float))]
    r_cols = [f"r_{j}" for j in range(MAX_DIM)]
    out: dict[str, NisSummary] = {}
    for sensor in sorted(set(used["sensor"].unique())):
        rows = used[used["sensor"] == sensor]
        count = len(rows)
        dof = int(np.isfinite(rows[r_cols].to_numpy(dtype=float)).sum())
        if dof < 1:
            continue
        lower, upper = nis_bounds(count, dof)
        out[str(sensor)] = NisSummary(
            sensor=str(sensor),
            count=count,
            dim=dof / count,
            dof=dof,
            mean=float(rows["statistic"].astype(float).mean()),
            lower=lower,
            upper=upper,
        )
    return out


@dataclass(frozen=True)
class Metrics:
    """Accuracy and consistency of one run against the reference (docs/metrics.md; paper eqs.
    (32), (33)).

    Position metrics cover the truth samples inside the solution span: ``duration_s`` and
    ``distance_m`` are that span's and the horizontal length of that stretch of the
    reference. ``run_duration_s`` is the solution's own span and ``reference_coverage`` the
    share of it the reference covers (:func:`reference_coverage`): below 1 the metrics score
    only part of the run. ``reference_lag_s``: how late the reference's stamps look against
    the run's (:func:`reference_lag`; 0 when they agree, NaN when it cannot be told).
    ``mean_nees_<block>`` is the mean NEES of the position, velocity
    and attitude errors (expected 3 for a consistent filter; NaN when the truth lacks the block) and
    ``nees_<block>_in_95`` the fraction of epochs whose NEES lies in :data:`NEES_BAND`
    (expected 0.95). ``nees_<block>_epochs`` is how many of the ``samples`` epochs both are
    over (since 0.4.6): an epoch whose P block is not finite or not positive definite has no
    NEES and is left out (None when the block is not scored; :func:`nees_warning`).
    ``nees_uses_correlations`` is False when the solution has no covariance columns (an older
    run folder): the NEES then use P's diagonal only. ``scored_at``: ``"reference"`` when the
    epochs scored are the reference's samples, ``"solution"`` when they are the solution's
    rows, the reference being denser (:func:`scoring_reference`, since 0.4.7).
    """

    filter: str
    mission: str
    rmse_m: float
    relative_rmse_pct: float
    horizontal_rmse_m: float
    max_horizontal_error_m: float
    max_error_m: float
    final_horizontal_error_m: float
    distance_m: float
    duration_s: float
    samples: int
    run_duration_s: float
    reference_coverage: float
    reference_lag_s: float
    mean_nees_position: float
    mean_nees_velocity: float
    mean_nees_attitude: float
    nees_position_in_95: float
    nees_velocity_in_95: float
    nees_attitude_in_95: float
    nees_uses_correlations: bool
    yaw_rmse_rad: float
    counts: dict[str, dict[str, int]]
    mean_nis: dict[str, float]
    nis: dict[str, NisSummary]
    nees_position_epochs: int | None = None
    nees_velocity_epochs: int | None = None
    nees_attitude_epochs: int | None = None
    scored_at: str = "reference"

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly: plain types, NaN → None, NIS summaries as dicts (with
        ``consistent``)."""
        d = asdict(self)
        d["nis"] = {k: {**asdict(v), "consistent": v.consistent} for k, v in self.nis.items()}
        result: dict[str, Any] = jsonable(d, "metrics")
        return result


def evaluate(result: Result, truth: pd.DataFrame, *, table: str = "solution") -> Metrics:
    """Metrics of ``result`` against the reference ``truth`` (see the module docstring).

    Raises ValueError if no truth sample lies within the solution's time span, or if a
    solution position is not finite (a damaged run folder: the RMSE would be NaN while the
    NEES, which leaves such rows out, would not). ``table`` names the solution in those
    messages: :func:`forward_metrics` scores the forward solution through here, and its
    problems are the forward table's, not the smoothed one's.
    """
    check_finite(result.solution, ("lat_rad", "lon_rad", "h_m"), table)
    t_truth = _check_truth(truth)
    t_sol = _solution_time(result.solution)
    scored, scored_at = scoring_reference(truth, t_sol)
    errors = position_errors(result.solution, scored)
    if errors.empty:
        raise ValueError(
            f"no truth sample within the {table} span of {result.filter!r} on {result.mission!r}"
        )
    in_span = _in_span(t_truth, t_sol)
    inside = truth[in_span]
    r = rmse(errors)
    distance = travelled_distance(inside)
    t = _column(errors, "t_s")
    horizontal = _column(errors, "horizontal_m")
    # The position errors scored above are the position NEES block's: not computed twice.
    known = {"position": _position_block(errors)}
    consistency = {b: _nees_summary(result.solution, scored, b, known.get(b)) for b in NEES_BLOCKS}
    if "dyaw_rad" in errors.columns:
        yaw_rmse = float(np.sqrt(np.mean(_column(errors, "dyaw_rad") ** 2)))
    else:
        yaw_rmse = math.nan
    nis = nis_summary(result.ledger)
    return Metrics(
        filter=result.filter,
        mission=result.mission,
        rmse_m=r,
        relative_rmse_pct=relative_rmse_pct(r, distance),
        horizontal_rmse_m=horizontal_rmse(errors),
        max_horizontal_error_m=float(horizontal.max()),
        max_error_m=float(_column(errors, "error_m").max()),
        final_horizontal_error_m=float(horizontal[-1]),
        distance_m=distance,
        duration_s=float(t[-1] - t[0]),
        samples=int(t.size),
        run_duration_s=float(t_sol[-1] - t_sol[0]),
        reference_coverage=reference_coverage(t_truth[in_span], t_sol),
        reference_lag_s=reference_lag(result.solution, inside),
        mean_nees_position=consistency["position"][0],
        mean_nees_velocity=consistency["velocity"][0],
        mean_nees_attitude=consistency["attitude"][0],
        nees_position_in_95=consistency["position"][1],
        nees_velocity_in_95=consistency["velocity"][1],
        nees_attitude_in_95=consistency["attitude"][1],
        nees_uses_correlations=has_covariances(result.solution, NEES_STATES["position"]),
        yaw_rmse_rad=yaw_rmse,
        counts=ledger_counts(result.ledger),
        mean_nis={k: v.mean for k, v in nis.items()},
        nis=nis,
        nees_position_epochs=consistency["position"][2],
        nees_velocity_epochs=consistency["velocity"][2],
        nees_attitude_epochs=consistency["attitude"][2],
        scored_at=scored_at,
    )


def reference_coverage(t_ref: Array, t_sol: Array) -> float:
    """The share of the solution's span ``[t_sol[0], t_sol[-1]]`` that the reference samples
    ``t_ref`` (inside that span, increasing) cover (docs/metrics.md, 'What is scored'): the sum
    of the steps between consecutive samples no longer than :data:`COVERAGE_GAP` times their
    median step (at least :data:`COVERAGE_MIN_GAP_S`), over the span. 1 for a reference
    sampled over the whole run; a reference that starts late, ends early or has a hole scores
    only part of the run, and ``evaluate`` says so. A one-epoch solution: 1 if a sample is
    at its time."""
    span = float(t_sol[-1] - t_sol[0])
    if span <= 0.0:
        return 1.0 if t_ref.size else 0.0
    steps = np.diff(t_ref)
    if steps.size == 0:
        return 0.0
    longest = max(COVERAGE_MIN_GAP_S, COVERAGE_GAP * float(np.median(steps)))
    return min(1.0, float(steps[steps <= longest].sum()) / span)


def reference_lag(solution: pd.DataFrame, reference: pd.DataFrame) -> float:
    """How late the reference's stamps are against the run's (s), from the velocities: the d
    in ``[-LAG_MAX_S, LAG_MAX_S]`` (1-s steps, refined to the reference's median step, at
    least ``LAG_STEP_S``, about the best) that minimises the mean of
    ``|v_run(t - d) - v_ref(t)|²`` over the reference samples at least ``LAG_MAX_S`` inside
    the run (at most ``LAG_SAMPLES`` of them), reported when it is at least two steps and
    ``LAG_GAIN`` times better than d = 0, else 0. NaN without velocities in both, or a run
    too short to search. A reference on another clock (GPS time against UTC: 18 s) scored a
    1.3-m run as 31.8 m, silently (up to 0.4.5); a vehicle at constant velocity shows no lag,
    and none is reported."""
    if not all(c in reference.columns for c in TRUTH_VELOCITY):
        return math.nan
    t_sol = _solution_time(solution)
    t_ref = _column(reference, "t_s")
    keep = np.flatnonzero((t_ref >= t_sol[0] + LAG_MAX_S) & (t_ref <= t_sol[-1] - LAG_MAX_S))
    if keep.size < 10:
        return math.nan
    keep = keep[:: max(1, keep.size // LAG_SAMPLES)]
    t = t_ref[keep]
    v_ref = np.stack([_column(reference, c)[keep] for c in TRUTH_VELOCITY], axis=1)
    v_sol = [_column(solution, c) for c in TRUTH_VELOCITY]

    def misfit(d: float) -> float:
        return float(np.mean(sum((np.interp(t - d, t_sol, v) - v_ref[:, j]) ** 2
                                 for j, v in enumerate(v_sol))))  # fmt: skip

    step = max(LAG_STEP_S, float(np.median(np.diff(t_ref))))
    coarse = max(1.0, step)  # then refined to the step about the coarse minimum
    lags = np.arange(-LAG_MAX_S, LAG_MAX_S + 0.5 * coarse, coarse)
    d0 = float(lags[int(np.argmin([misfit(d) for d in lags]))])
    fine = np.clip(d0 + np.arange(-coarse, coarse + 0.5 * step, step), -LAG_MAX_S, LAG_MAX_S)
    cost = [misfit(d) for d in fine]
    best = float(fine[int(np.argmin(cost))])
    if abs(best) < 2.0 * step or not min(cost) * LAG_GAIN < misfit(0.0):
        return 0.0
    return best


def lag_warning(metrics: Metrics) -> str | None:
    """The warning ``evaluate`` gives when the reference looks late or early against the run
    (:func:`reference_lag`), or None."""
    lag = metrics.reference_lag_s
    if not (math.isfinite(lag) and lag != 0.0):
        return None
    return (
        f"the reference's velocity matches the run's best with its stamps {abs(lag):.1f} s "
        f"{'late' if lag > 0 else 'early'}: is it on another clock (GPS time against UTC is "
        "18 s)? The metrics compare the run with where the reference was at another time"
    )


def coverage_warning(metrics: Metrics) -> str | None:
    """The warning ``evaluate`` gives when the reference covers less than
    :data:`COVERAGE_WARN` of the run, or None."""
    if not metrics.reference_coverage < COVERAGE_WARN:
        return None
    return (
        f"the reference covers {100.0 * metrics.reference_coverage:.1f} % of the run's "
        f"{metrics.run_duration_s:.1f} s (samples over {metrics.duration_s:.1f} s): the metrics "
        "score that part only"
    )


def nees_warning(metrics: Metrics) -> str | None:
    """The warning ``evaluate`` gives when a mean NEES leaves out epochs (their P block not
    finite or not positive definite, :func:`nees_from`), or None: a mean over part of the run
    is not the run's, and one over no epoch is missing for that reason, not for want of a
    reference (docs/metrics.md, 'Consistency: NEES')."""
    parts = []
    for block in NEES_BLOCKS:
        used = getattr(metrics, f"nees_{block}_epochs")
        if used is not None and used < metrics.samples:
            over = f"{used} of" if used else "none of the"
            parts.append(f"{block} over {over} {metrics.samples} epochs")
    if not parts:
        return None
    return (
        f"mean NEES of {', '.join(parts)}: at the epochs left out the covariance block was not "
        f"finite or not positive definite (smallest eigenvalue at most {PD_RATIO:g} of the "
        "largest)"
    )


def forward_metrics(result: Result, truth: pd.DataFrame) -> Metrics | None:
    """The metrics of a smoothed run's forward solution, ``result.forward`` (its ``solution``
    is then the RTS-smoothed one, docs/smoothing.md), by :func:`evaluate` itself; None for a
    run that was not smoothed. Its ValueErrors name the table ``forward`` (a run folder's
    ``forward.parquet``), so that they are not taken for the smoothed solution's."""
    if result.forward is None:
        return None
    return evaluate(replace(result, solution=result.forward, forward=None), truth, table="forward")


def forward_columns(forward: Metrics) -> dict[str, float]:
    """``{forward_<key>: value}`` for the :data:`FORWARD_KEYS` of a forward solution's
    metrics (:func:`forward_metrics`)."""
    return {f"forward_{key}": getattr(forward, key) for key in FORWARD_KEYS}
