"""The oracle baseline: the ESKF told each reading's true noise and which readings are outliers.

It is the practical limit an adaptive filter can reach on a simulated mission (issue 5): the
same engine and models as MESKF, no gate, and per reading

* ``R_k = diag(σ_k²)`` with σ_k the simulator's true standard deviation of that reading
  (``sigma_*`` truth columns, the noise-segment factor and sea state included). The pendulum
  inclinometer's acceleration error is not noise: the default pendulum model predicts it
  (docs/inclinometer.md), so the instrument's σ is its true R. With ``model = "attitude"`` it
  is a time-correlated error no per-reading variance describes, and the oracle is then no
  bound;
* a reading flagged ``is_outlier`` is not used: it is dropped with the reason
  :data:`OUTLIER_REASON`, so the ledger still holds it.

A sensor whose table has no truth column keeps its nominal R (the configured σ is then the
truth, as for a simulation with that sensor's disturbances off); the sensors so treated are
listed in the run's meta. A mission with no truth column at all has no oracle: ValueError.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.mission import Mission

Array = NDArray[np.float64]

OUTLIER_REASON = "oracle: known outlier"
SIGMA_COLUMNS: dict[str, str] = {
    "dvl": "sigma_m_s",
    "depth": "sigma_m",
    "inclinometer": "sigma_rad",
    "heading": "sigma_rad",
    "gnss": "sigma_m",
    "nhc": "sigma_m_s",
}
"""The simulator's per-reading true σ column of each sensor kind (docs/simulation.md)."""


@dataclass(frozen=True)
class OracleNoise:
    """One sensor's oracle knowledge, row-aligned with its :class:`~adaptnav.mission.SensorData`.

    ``r_diag`` (n, d): each reading's true variance per component, or None (nominal R);
    ``outlier`` (n,): readings known to be outliers."""

    r_diag: Array | None
    outlier: NDArray[np.bool_]


def _column(table: pd.DataFrame, name: str, rows: NDArray[np.int64]) -> Array:
    return np.asarray(table[name].to_numpy(dtype=float)[rows], dtype=float)


def sensor_noise(mission: Mission, name: str) -> OracleNoise:
    """The oracle's per-reading variances and outlier flags of sensor ``name``."""
    data = mission.sensors[name]
    table = mission.tables[name]
    n, d = data.z.shape
    rows = data.rows
    outlier = np.zeros(n, dtype=bool)
    if "is_outlier" in table.columns:
        outlier = np.asarray(table["is_outlier"].to_numpy(dtype=bool)[rows], dtype=bool)
    col = SIGMA_COLUMNS.get(data.kind)
    if col is None or col not in table.columns:
        return OracleNoise(None, outlier)
    sigma = _column(table, col, rows)
    var = np.repeat((sigma**2)[:, None], d, axis=1)
    # A reading with no usable σ (a dropout row, NaN) keeps NaN here and is refused by the engine
    # as invalid anyway; give it the nominal-sized placeholder the engine's check accepts.
    bad = ~np.all(np.isfinite(var) & (var > 0.0), axis=1)
    if np.any(bad):
        ok = var[~bad]
        var[bad] = np.median(ok, axis=0) if ok.size else 1.0
    return OracleNoise(var, outlier)


def mission_noise(mission: Mission, sensors: list[str]) -> dict[str, OracleNoise]:
    """:func:`sensor_noise` of each of ``sensors``; ValueError if none has truth columns."""
    out = {name: sensor_noise(mission, name) for name in sensors}
    if sensors and all(o.r_diag is None and not o.outlier.any() for o in out.values()):
        wanted = sorted({SIGMA_COLUMNS.get(mission.sensors[s].kind, "?") for s in sensors})
        raise ValueError(
            f"oracle: mission {mission.root} has no per-reading truth (columns {wanted} or "
            "'is_outlier' in the sensor tables); the oracle needs a simulated mission"
        )
    return out
