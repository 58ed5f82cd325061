"""The data behind the comparison's figures, shared by the static figures
(:mod:`adaptnav.viz.plots`, matplotlib PNGs) and the report's interactive ones
(:mod:`adaptnav.viz.interactive`, Plotly), so both draw the same numbers in the same colours.

* :func:`envelope`: the min/max envelope that reduces a long series (docs/report.md, 'Long
  series'); :func:`stride` for series that are smooth (the reference, the truth);
* :func:`start_time`, :func:`minutes`: times as minutes since the shared navigation start;
* :data:`DISPLAY`: per sensor kind, the unit shown and the components' names;
* :func:`nominal_r`, :func:`true_sigma_column`, :func:`r_hat`, :func:`actual_error2`,
  :func:`outliers`: Fig. 10's series (the paper's noise-variance figure);
* :func:`nis_means`: running means of NIS per reading dimension (docs/metrics.md, 'NIS');
* :func:`filter_label`: a filter's display name; its colour is
  :func:`adaptnav.analysis.compare.filter_colour`, the one mapping every figure uses.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.analysis.compare import FILTER_LABELS
from adaptnav.api.results import Result

if TYPE_CHECKING:
    from adaptnav.mission import Mission

Array = NDArray[np.float64]

MAX_POINTS = 4000
"""Most points drawn per series (after :func:`envelope` or :func:`stride`)."""
ADAPTIVE = ("maeskf", "vb", "robust")
"""Filters whose R̂ Fig. 10 shows (MESKF's is the nominal R, the oracle's the true σ²)."""
ERROR_WINDOW = 30
"""Fewest readings per running mean of the actual squared measurement error
(:func:`actual_error2`)."""
NIS_WINDOW = 100
"""Readings per running mean in :func:`nis_means`."""
TRUE_SIGMA_COLUMNS = ("sigma_m_s", "sigma_m", "sigma_rad")
"""The simulator's per-reading true σ column, one of these per sensor table."""

DISPLAY: dict[str, tuple[float, str, tuple[str, ...]]] = {
    "dvl": (1.0, "m/s", ("x (forward)", "y (right)", "z (down)")),
    "depth": (1.0, "m", ("depth",)),
    "inclinometer": (180.0 / math.pi, "deg", ("roll", "pitch")),
    "heading": (180.0 / math.pi, "deg", ("yaw",)),
    "gnss": (1.0, "m", ("north", "east", "height")),
    "nhc": (1.0, "m/s", ("y (lateral)", "z (vertical)")),
}
"""Per sensor kind: the scale from SI to the shown unit, the shown unit, component names."""


def filter_label(name: str) -> str:
    """A filter's display name (:data:`adaptnav.analysis.compare.FILTER_LABELS`)."""
    return FILTER_LABELS.get(name, name)


def bucket_size(n: int, max_points: int = MAX_POINTS) -> int:
    """Readings per bucket of :func:`envelope` for a series of ``n`` readings: 1 when the
    series is drawn whole (``n ≤ max_points``), else ``⌈n / (max_points // 2)⌉``."""
    if n <= max_points:
        return 1
    return math.ceil(n / max(max_points // 2, 1))


def envelope(t: Array, y: Array, max_points: int = MAX_POINTS) -> tuple[Array, Array]:
    """At most ``max_points`` of the series ``y(t)``: a series longer than that is cut into
    ``max_points // 2`` buckets of :func:`bucket_size` consecutive readings, and each bucket is
    drawn by its minimum and its maximum, in time order, so a one-sample spike survives. NaN
    gaps stay gaps (an all-NaN bucket gives NaN)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = t.size
    k = bucket_size(n, max_points)
    if k == 1:
        return t, y
    buckets = math.ceil(n / k)
    pad = buckets * k - n
    yp = np.concatenate([y, np.full(pad, np.nan)]).reshape(buckets, k)
    finite = np.isfinite(yp)
    i_min = np.argmin(np.where(finite, yp, np.inf), axis=1)
    i_max = np.argmax(np.where(finite, yp, -np.inf), axis=1)
    base = np.arange(buckets) * k
    first = base + np.minimum(i_min, i_max)
    second = base + np.maximum(i_min, i_max)
    idx = np.stack([first, second], axis=1).reshape(-1)
    idx = np.minimum(idx, n - 1)
    empty = np.repeat(~finite.any(axis=1), 2)
    ys = np.where(empty, np.nan, y[idx])
    return t[idx], ys


def stride(n: int, max_points: int = MAX_POINTS) -> slice:
    """Every k-th of ``n`` readings, at most ``max_points``: for smooth series only."""
    return slice(None, None, max(1, math.ceil(n / max_points)))


def minutes(t: Array, t0: float) -> Array:
    """Times ``t`` (s) as minutes since ``t0``."""
    return (np.asarray(t, dtype=float) - t0) / 60.0


def start_time(results: Mapping[str, Result], t0: float | None) -> float:
    """The shared navigation start ``t0``, else the earliest solution time."""
    if t0 is not None and math.isfinite(t0):
        return t0
    return min(float(r.solution["t_s"].iloc[0]) for r in results.values())


def nominal_r(mission: Mission, sensor: str, dim: int) -> Array:
    """The nominal R's diagonal (SI) of ``sensor``, the one MESKF uses throughout."""
    sigma = np.atleast_1d(np.asarray(mission.config.sensors[sensor].sigma_si(), dtype=float))
    return np.broadcast_to(sigma**2, (dim,)).astype(float)


def true_sigma_column(table: pd.DataFrame) -> str | None:
    """The simulator's per-reading true σ column of a sensor table, or None."""
    return next((c for c in TRUE_SIGMA_COLUMNS if c in table.columns), None)


def r_hat(result: Result, sensor: str, component: int) -> tuple[Array, Array] | None:
    """(t, R̂) the run used for ``component`` of ``sensor`` at each reading (``Result.noise``,
    SI), or None when it recorded none."""
    noise = result.noise
    rows = noise[(noise["sensor"] == sensor) & (noise["component"] == component)]
    if rows.empty:
        return None
    return rows["t_s"].to_numpy(dtype=float), rows["r_hat"].to_numpy(dtype=float)


def actual_error2(table: pd.DataFrame, col: str, scale: float) -> tuple[int, Array, Array]:
    """(window, t, mean of the squared measurement error): measured minus the simulator's true
    value, in the shown unit squared, as a running mean over ``window`` readings
    (:data:`ERROR_WINDOW` or more)."""
    # What the errors really were (pendulum error and outliers included, which the
    # simulator's σ leaves out): the reference an estimate of R can be held against.
    # A longer mission gets a longer mean, so the drawn curve stays a line, not a band.
    window = max(ERROR_WINDOW, len(table) // 500)
    err = table[col].to_numpy(dtype=float) - table[f"true_{col}"].to_numpy(dtype=float)
    err2 = pd.Series((err * scale) ** 2).rolling(window, min_periods=window // 2).mean()
    return window, table["t_s"].to_numpy(dtype=float), err2.to_numpy(dtype=float)


def outliers(table: pd.DataFrame, col: str) -> NDArray[np.bool_] | None:
    """Which readings of ``col`` the simulator spiked (``is_outlier``), or None when the table
    does not say."""
    if "is_outlier" not in table.columns:
        return None
    out = table["is_outlier"].to_numpy(dtype=bool)
    # An outlier event spikes only some axes: mark it on those (spike_<axis>_m_s).
    spike = f"spike_{col.split('_')[0][-1]}_m_s"
    if spike in table.columns:
        # Not in place: to_numpy may be a (read-only) view of the mission's table.
        out = out & (table[spike].to_numpy(dtype=float) != 0.0)
    return out


def nis_means(results: Mapping[str, Result]) -> dict[str, dict[str, tuple[Array, Array]]]:
    """Per aided sensor and filter: (t, running mean over :data:`NIS_WINDOW` used readings of
    each reading's NIS divided by its dimension); 1 is what a consistent filter gives
    (docs/metrics.md, 'NIS')."""
    per_sensor: dict[str, dict[str, tuple[Array, Array]]] = {}
    r_cols = [c for c in next(iter(results.values())).ledger.columns if c.startswith("r_")]
    for name, r in results.items():
        ledger = r.ledger
        used = ledger[(ledger["fate"] == "used") & np.isfinite(ledger["statistic"].astype(float))]
        for sensor, rows in used.groupby("sensor"):
            dim = np.isfinite(rows[r_cols].to_numpy(dtype=float)).sum(axis=1)
            value = rows["statistic"].to_numpy(dtype=float) / np.maximum(dim, 1)
            mean = pd.Series(value).rolling(NIS_WINDOW, min_periods=1).mean().to_numpy()
            per_sensor.setdefault(str(sensor), {})[name] = (
                rows["t"].to_numpy(dtype=float),
                np.asarray(mean, dtype=float),
            )
    return per_sensor


def aided_sensors(mission: Mission) -> list[str]:
    """The mission's sensors with ``use = "aid"`` and a table, in configuration order."""
    return [
        name
        for name, cfg in mission.config.sensors.items()
        if cfg.use == "aid" and name in mission.tables
    ]
