"""The sweep's table and statistics over its rows (docs/metrics.md; the paper's Table 3 and
Figs. 4 and 6).

A sweep gives one row per :class:`~adaptnav.experiments.spec.RunSpec` (:func:`runs_table`):
the spec's :data:`SPEC_COLUMNS`, the run's :data:`METRICS` (RMSE and relative RMSE, paper eqs.
(32), (33), horizontal distance travelled, duration, the mean NEES of position, velocity and
attitude and the share of epochs inside the χ²(3) 95 % band, DVL used / rejected counts) and
``error``. Over those rows: :func:`summarize` (mean, std, median, min, max, of the NEES too),
:func:`paired_comparison` (VB-MAESKF's win rate against each other filter, paired by seed, and
its RMSE ratio, e.g. to the oracle), :func:`curve` and :func:`curve_spread` (a metric against
the swept parameter).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from adaptnav.analysis.compare import NEES_COLUMNS
from adaptnav.experiments.spec import RunSpec, config_tag, disturbance_tag

__all__ = [
    "METRICS",
    "NEES_METRICS",
    "SPEC_COLUMNS",
    "SUMMARY_METRICS",
    "curve",
    "curve_spread",
    "finished",
    "paired_comparison",
    "runs_table",
    "summarize",
]

METRICS: tuple[str, ...] = (
    "rmse_m",
    "relative_rmse_pct",
    "horizontal_rmse_m",
    "final_horizontal_error_m",
    "distance_m",
    "duration_s",
    *NEES_COLUMNS,
    "dvl_used",
    "dvl_rejected",
    "dvl_dropped",
    "gate_q",
    "elapsed_s",
)
"""Metric columns of a sweep's table (docs/metrics.md; :class:`adaptnav.analysis.evaluate.Metrics`;
``gate_q``: the DVL gate's q, NaN ungated; ``elapsed_s``: wall time of the run and its
evaluation). Runs cached before a metric existed have NaN for it."""
NEES_METRICS: tuple[str, ...] = NEES_COLUMNS
"""The consistency metrics among :data:`METRICS`: mean NEES per block (3 for a consistent
filter) and the share of epochs inside the χ²(3) 95 % band (0.95); docs/metrics.md."""
SUMMARY_METRICS: tuple[str, ...] = ("rmse_m", "relative_rmse_pct", *NEES_METRICS)
"""What :func:`summarize` summarises by default (those of them the table has)."""
SPEC_COLUMNS: tuple[str, ...] = (
    "key", "preset", "seed", "filter", "q", "q_scale", "config", "disturbances",
    "gated",
)  # fmt: skip


def _row(spec: RunSpec, record: Mapping[str, Any] | None, error: str | None) -> dict[str, Any]:
    metrics = record["metrics"] if record is not None else {}
    row: dict[str, Any] = {
        "key": spec.key(),
        "preset": spec.preset,
        "seed": spec.seed,
        "filter": spec.filter,
        "q": math.nan if spec.q is None else spec.q,
        "q_scale": 1.0 if spec.q_scale is None else spec.q_scale,
        "config": config_tag(spec.config),
        "disturbances": "default"
        if spec.disturbances is None
        else disturbance_tag(spec.disturbances),
        "gated": False,
    }
    for name in METRICS:
        v = metrics.get(name)
        row[name] = math.nan if v is None else float(v)
    row["gated"] = bool(math.isfinite(row["gate_q"]))
    row["error"] = error
    return row


def runs_table(
    specs: Sequence[RunSpec],
    records: Mapping[str, Mapping[str, Any]],
    errors: Mapping[str, str],
) -> pd.DataFrame:
    """One row per spec, in their order: :data:`SPEC_COLUMNS`, :data:`METRICS` (NaN where
    ``records``, by key, has none) and ``error`` (``errors``' text, else None). ``q`` is NaN
    for a filter's default, ``q_scale`` 1.0 for the mission's Q, ``disturbances``
    ``"default"`` or the tag of the mission name."""
    return pd.DataFrame(
        [_row(s, records.get(s.key()), errors.get(s.key())) for s in specs],
        columns=[*SPEC_COLUMNS, *METRICS, "error"],
    )


def finished(table: pd.DataFrame) -> pd.DataFrame:
    """The rows of runs that finished: no ``error`` and a finite RMSE."""
    keep = table["error"].isna() if "error" in table.columns else True
    return table[keep & np.isfinite(table["rmse_m"].astype(float))]


def summarize(
    table: pd.DataFrame,
    by: Sequence[str] = ("preset", "filter"),
    metrics: Sequence[str] | None = None,
) -> pd.DataFrame:
    """Monte Carlo statistics per group (Table 3 over seeds): ``n`` and, per metric,
    ``<metric>_mean``, ``_std`` (sample, ddof = 1; NaN for one run), ``_median``, ``_min``,
    ``_max``. Failed runs (error or NaN RMSE) are left out. Groups in order of appearance.

    ``metrics`` defaults to those of :data:`SUMMARY_METRICS` that ``table`` has: RMSE,
    relative RMSE, and the mean NEES of position, velocity and attitude and their shares of
    epochs in the χ²(3) 95 % band (a statistic is NaN if any run of the group lacks the metric,
    e.g. a reference without attitude, or a run cached before the metric existed)."""
    if metrics is None:
        metrics = [m for m in SUMMARY_METRICS if m in table.columns]
    ok = finished(table)
    rows = []
    for keys, g in ok.groupby(list(by), sort=False):
        row: dict[str, Any] = dict(
            zip(by, keys if isinstance(keys, tuple) else (keys,), strict=True)
        )
        row["n"] = len(g)
        for m in metrics:
            v = g[m].to_numpy(dtype=float)
            row[f"{m}_mean"] = float(np.mean(v))
            row[f"{m}_std"] = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
            row[f"{m}_median"] = float(np.median(v))
            row[f"{m}_min"] = float(np.min(v))
            row[f"{m}_max"] = float(np.max(v))
        rows.append(row)
    cols = [
        *by,
        "n",
        *(f"{m}_{s}" for m in metrics for s in ("mean", "std", "median", "min", "max")),
    ]
    return pd.DataFrame(rows, columns=cols)


def paired_comparison(
    table: pd.DataFrame, filter: str = "vb", metric: str = "rmse_m"
) -> pd.DataFrame:
    """``filter`` against every other filter of ``table``, per preset, paired by seed.

    Columns: ``preset, filter, other, n`` (seeds with both), ``wins`` (seeds where
    ``filter``'s metric is lower; a tie counts ½), ``win_rate = wins / n``, ``ratio_mean`` and
    ``ratio_median`` of the per-seed ratio ``filter / other``, ``ratio_of_means``. Each (preset,
    seed, filter) must appear once (one configuration per filter, e.g. a Monte Carlo table):
    ValueError otherwise."""
    ok = finished(table)
    if ok.duplicated(["preset", "seed", "filter"]).any():
        raise ValueError("paired_comparison: a (preset, seed, filter) appears more than once")
    rows = []
    for preset, g in ok.groupby("preset", sort=False):
        wide = g.pivot(index="seed", columns="filter", values=metric)
        if filter not in wide.columns:
            continue
        for other in [f for f in dict.fromkeys(g["filter"]) if f != filter]:
            pair = wide[[filter, other]].dropna()
            a = pair[filter].to_numpy(dtype=float)
            b = pair[other].to_numpy(dtype=float)
            wins = float(np.sum(a < b) + 0.5 * np.sum(a == b))
            n = int(a.size)
            ratio = a / b
            rows.append(
                {
                    "preset": preset,
                    "filter": filter,
                    "other": other,
                    "n": n,
                    "wins": wins,
                    "win_rate": wins / n if n else math.nan,
                    "ratio_mean": float(np.mean(ratio)) if n else math.nan,
                    "ratio_median": float(np.median(ratio)) if n else math.nan,
                    "ratio_of_means": float(np.mean(a) / np.mean(b)) if n else math.nan,
                }
            )
    cols = ["preset", "filter", "other", "n", "wins", "win_rate", "ratio_mean", "ratio_median",
            "ratio_of_means"]  # fmt: skip
    return pd.DataFrame(rows, columns=cols)


def curve(table: pd.DataFrame, parameter: str, metric: str = "relative_rmse_pct") -> pd.DataFrame:
    """``metric`` against ``parameter`` (``"q"`` or ``"q_scale"``) per (preset, filter): for
    each value, ``n``, ``mean``, ``std`` (ddof = 1), ``min``, ``max`` over seeds (the paper's
    Figs. 4 and 6 with the seed spread). Rows with a NaN parameter (a filter's default q) are
    left out; sorted by preset, filter (order of appearance) and parameter."""
    ok = finished(table)
    ok = ok[np.isfinite(ok[parameter].astype(float))]
    rows = []
    for (preset, filt), g in ok.groupby(["preset", "filter"], sort=False):
        values = g[parameter].to_numpy(dtype=float)
        for value in np.unique(values):
            v = g[metric].to_numpy(dtype=float)[values == value]
            rows.append(
                {
                    "preset": preset,
                    "filter": filt,
                    parameter: float(value),
                    "n": int(v.size),
                    "mean": float(np.mean(v)),
                    "std": float(np.std(v, ddof=1)) if v.size > 1 else math.nan,
                    "min": float(np.min(v)),
                    "max": float(np.max(v)),
                }
            )
    return pd.DataFrame(rows, columns=["preset", "filter", parameter, "n", "mean", "std", "min",
                                       "max"])  # fmt: skip


def curve_spread(curve_table: pd.DataFrame, parameter: str) -> pd.DataFrame:
    """How much each filter's mean moves over the parameter (sensitivity, Figs. 4 and 6): per
    (preset, filter) ``values`` (count), ``best`` (lowest mean) at ``best_at``, ``worst`` at
    ``worst_at``, ``worst_over_best = worst / best``."""
    rows = []
    for (preset, filt), g in curve_table.groupby(["preset", "filter"], sort=False):
        i_best = int(np.argmin(g["mean"].to_numpy(dtype=float)))
        i_worst = int(np.argmax(g["mean"].to_numpy(dtype=float)))
        best = float(g["mean"].iloc[i_best])
        worst = float(g["mean"].iloc[i_worst])
        rows.append(
            {
                "preset": preset,
                "filter": filt,
                "values": len(g),
                "best": best,
                "best_at": float(g[parameter].iloc[i_best]),
                "worst": worst,
                "worst_at": float(g[parameter].iloc[i_worst]),
                "worst_over_best": worst / best if best > 0 else math.nan,
            }
        )
    return pd.DataFrame(rows, columns=["preset", "filter", "values", "best", "best_at", "worst",
                                       "worst_at", "worst_over_best"])  # fmt: skip
