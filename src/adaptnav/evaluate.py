"""Accuracy and consistency metrics of a run against a reference trajectory (spec §10).

The reference ("truth") is a table with ``t_s, lat_rad, lon_rad, h_m`` and optionally
``vn_m_s, ve_m_s, vd_m_s`` and ``roll_rad, pitch_rad, yaw_rad``, times non-decreasing.

Every metric is computed over the truth samples that lie inside the solution's time span
``[t_first, t_last]``; the estimate is interpolated linearly in time to those samples
(lat, lon unwrapped, h, velocity, Euler angles unwrapped, standard deviations).

Errors are **estimate minus truth**, resolved in the local NED frame **at each truth point**,
computed exactly through ECEF: ``e_n = C_ne(lat_ref, lon_ref) (r_e(est) - r_e(ref))``
(Groves 2.112, 2.150). (The filter's own error state is truth minus estimate; the sign does not
matter to any metric here.)

* P-32: ``RMSE = sqrt(mean(dN² + dE² + dD²))`` in metres;
* P-33: ``relative RMSE (%) = 100 RMSE / D`` with D the travelled distance of the reference,
  the sum of its 3-D steps ``|r_e(k+1) - r_e(k)|`` (a chord's length is the same in every
  Cartesian frame, so this is the local-metre step);
* NEES of position with P's diagonal only (the engine records no correlations):
  ``sum_i (e_i / sd_i)²`` over N, E, D, expected 3 for a consistent filter;
* NIS per sensor from the ledger: the mean of the used readings' NIS, ``y' S^-1 y``; for a
  consistent filter with independent innovations ``K mean ~ chi²(sum_k d_k)``, which gives
  the two-sided 95 % bounds of the mean (spec §9).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.stats import chi2

from adaptnav import earth
from adaptnav.attitude import wrap_angle
from adaptnav.engine import MAX_DIM
from adaptnav.results import Result, jsonable, ledger_counts

Array = NDArray[np.float64]

TRUTH_POSITION = ("t_s", "lat_rad", "lon_rad", "h_m")
TRUTH_VELOCITY = ("vn_m_s", "ve_m_s", "vd_m_s")
TRUTH_ATTITUDE = ("roll_rad", "pitch_rad", "yaw_rad")
POSITION_SD = ("sd_dr_N", "sd_dr_E", "sd_dr_D")
NIS_CONFIDENCE = 0.95
"""Two-sided probability of the NIS bounds."""


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
    """P-32: ``RMSE = sqrt(mean(dN² + dE² + dD²))`` (m); NaN for no samples."""
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
    """Length of the reference path, ``D = sum_k |r_e(k+1) - r_e(k)|`` (m): the sum of its
    3-D steps, each equal to the step's length in local metres (P-33's denominator)."""
    _check_truth(truth)
    r = earth.geodetic_to_ecef(
        _column(truth, "lat_rad"), _column(truth, "lon_rad"), _column(truth, "h_m")
    ).reshape(-1, 3)
    if r.shape[0] < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(r, axis=0), axis=1)))


def relative_rmse_pct(rmse_m: float, distance_m: float) -> float:
    """P-33: ``100 RMSE / D`` (%); NaN when the distance is zero."""
    return 100.0 * rmse_m / distance_m if distance_m > 0.0 else math.nan


def outage_drift(
    solution: pd.DataFrame, truth: pd.DataFrame, windows: Sequence[tuple[float, float]]
) -> pd.DataFrame:
    """The inertial drift over aiding outages, scored against the withheld reference.

    For each window ``(start, length)`` (s), over the truth samples in ``(start, start +
    length]``: the horizontal error at the last one (``end_horizontal_m``, the drift), its
    maximum, the 3-D error at the end, the distance travelled (the truth's steps) and the drift
    as a percentage of it. Also the filter's claimed horizontal σ at the end,
    ``sqrt(sd_N² + sd_E²)`` (NaN if the solution has no ``sd_dr_*``), to judge its
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
                "drift_pct": 100.0 * horizontal[k] / dist if dist > 0.0 else math.nan,
                "claimed_sd_horizontal_m": float(sd_h[k]),
            }
        )
    return pd.DataFrame(rows)


def nees_position(solution: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Normalised position error squared at the truth times inside the solution span.

    ``NEES_k = (dN/sd_N)² + (dE/sd_E)² + (dD/sd_D)²`` with the ``sd_dr_*`` columns (linearly
    interpolated). Only P's diagonal is kept by the engine, so this ignores the correlations
    between the N, E, D errors; for a consistent filter its mean is about 3. Columns
    ``t_s, nees``.
    """
    missing = [c for c in POSITION_SD if c not in solution.columns]
    if missing:
        raise ValueError(f"solution lacks columns {missing}")
    errors = position_errors(solution, truth)
    t_sol = _solution_time(solution)
    t = _column(errors, "t_s")
    e = errors[["dN_m", "dE_m", "dD_m"]].to_numpy(dtype=float)
    sd = np.stack([_interp(t, t_sol, _column(solution, c)) for c in POSITION_SD], axis=-1)
    return pd.DataFrame({"t_s": t, "nees": np.sum((e / sd) ** 2, axis=1)})


@dataclass(frozen=True)
class NisSummary:
    """Mean NIS of one sensor's used readings with its chi-square bounds (spec §9).

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
    return float(chi2.ppf(a / 2.0, dof)) / count, float(chi2.ppf(1.0 - a / 2.0, dof)) / count


def nis_summary(ledger: pd.DataFrame) -> dict[str, NisSummary]:
    """Per sensor (sorted), the mean NIS (ledger ``statistic``) of its ``used`` rows with a
    finite statistic; the dimension of a row is its number of finite ``r_j``. Sensors without
    such rows are left out."""
    used = ledger[(ledger["fate"] == "used") & np.isfinite(ledger["statistic"].astype(float))]
    r_cols = [f"r_{j}" for j in range(MAX_DIM)]
    out: dict[str, NisSummary] = {}
    for sensor in sorted(set(used["sensor"])):
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
    """Accuracy of one run against the reference (spec §10; P-32, P-33).

    Position metrics cover the truth samples inside the solution span: ``duration_s`` and
    ``distance_m`` are that span's and that stretch of the reference's.
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
    mean_nees_position: float
    yaw_rmse_rad: float
    counts: dict[str, dict[str, int]]
    mean_nis: dict[str, float]
    nis: dict[str, NisSummary]

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly: plain types, NaN → None, NIS summaries as dicts (with
        ``consistent``)."""
        d = asdict(self)
        d["nis"] = {k: {**asdict(v), "consistent": v.consistent} for k, v in self.nis.items()}
        result: dict[str, Any] = jsonable(d, "metrics")
        return result


def evaluate(result: Result, truth: pd.DataFrame) -> Metrics:
    """Metrics of ``result`` against the reference ``truth`` (see the module docstring).

    Raises ValueError if no truth sample lies within the solution's time span.
    """
    errors = position_errors(result.solution, truth)
    if errors.empty:
        raise ValueError(
            f"no truth sample within the solution span of {result.filter!r} on {result.mission!r}"
        )
    t_truth = _check_truth(truth)
    inside = truth[_in_span(t_truth, _solution_time(result.solution))]
    r = rmse(errors)
    distance = travelled_distance(inside)
    t = _column(errors, "t_s")
    horizontal = _column(errors, "horizontal_m")
    if all(c in result.solution.columns for c in POSITION_SD):
        mean_nees = float(_column(nees_position(result.solution, truth), "nees").mean())
    else:
        mean_nees = math.nan
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
        mean_nees_position=mean_nees,
        yaw_rmse_rad=yaw_rmse,
        counts=ledger_counts(result.ledger),
        mean_nis={k: v.mean for k, v in nis.items()},
        nis=nis,
    )
