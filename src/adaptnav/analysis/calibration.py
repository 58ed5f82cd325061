"""Calibration estimates against the simulator's true calibration errors (docs/metrics.md,
'Calibration'; the states: docs/calibration.md).

A run that estimates calibration states has each one's final estimate, σ and prior σ in
``Result.meta["calibration"]`` (``calibration.json``), in its report unit (%, deg, m). A
simulated mission records the true errors in ``simulation.json``'s ``calibration`` section
(docs/simulation.md, 'Calibration errors'), in SI and named after the simulator's sensors. A
mission names its sensors as it likes, so a state ``<sensor>.<state>`` is matched through its
sensor's kind in the mission's configuration (:data:`TRUTH_KEYS`):

* ``dvl.scale`` = ``dvl_scale_factor - 1`` (the simulator's factor s reads ``s`` times the true
  value, the state ``1 + scale`` times);
* ``dvl.misalignment_{roll,pitch,yaw}`` = ``dvl_misalignment_rad[0, 1, 2]``;
* ``depth.bias`` = ``depth_bias_m``;
* ``inclinometer.bias_{roll,pitch}`` = ``inclinometer_bias_rad[0, 1]``;
* ``dvl.latency``, ``gnss.latency``, ``heading.latency`` = ``dvl_latency_s``,
  ``gps_latency_s``, ``heading_latency_s`` (not recorded before 0.4.3: no true value then).

The error of an estimate is ``estimate - true``, and ``error / σ`` says whether the filter's
σ covers it (within ±2 about 95 % of the time for a consistent filter).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from adaptnav.analysis.compare import simulation_info
from adaptnav.mission import MissionError, load_config
from adaptnav.mission.calibration import calibration_states
from adaptnav.mission.loader import CONFIG_NAME

if TYPE_CHECKING:
    from adaptnav.api.results import Result
    from adaptnav.mission import MissionConfig

__all__ = ["TRUTH_KEYS", "calibration_errors", "mission_truth", "true_values", "units"]

TRUTH_KEYS: dict[tuple[str, str], tuple[str, int | None, float]] = {
    ("dvl", "scale"): ("dvl_scale_factor", None, 1.0),
    ("dvl", "misalignment_roll"): ("dvl_misalignment_rad", 0, 0.0),
    ("dvl", "misalignment_pitch"): ("dvl_misalignment_rad", 1, 0.0),
    ("dvl", "misalignment_yaw"): ("dvl_misalignment_rad", 2, 0.0),
    ("depth", "bias"): ("depth_bias_m", None, 0.0),
    ("inclinometer", "bias_roll"): ("inclinometer_bias_rad", 0, 0.0),
    ("inclinometer", "bias_pitch"): ("inclinometer_bias_rad", 1, 0.0),
    ("dvl", "latency"): ("dvl_latency_s", None, 0.0),
    ("gnss", "latency"): ("gps_latency_s", None, 0.0),
    ("heading", "latency"): ("heading_latency_s", None, 0.0),
}
"""(sensor kind, state) → (key of ``simulation.json``'s ``calibration``, index in its list or
None for a number, offset): the true state (SI) is ``value[index] - offset``."""


def units(config: MissionConfig) -> dict[str, tuple[float, str]]:
    """Each calibration state of the mission (``dvl.scale``) → (factor from SI to its report
    unit, the unit), in the order of the error state."""
    return {
        name: (st.quantity.factor, st.quantity.unit)
        for st in calibration_states(config)
        for name in st.names
    }


def true_values(config: MissionConfig, simulation: Mapping[str, Any] | None) -> dict[str, float]:
    """The true value, in its report unit, of each calibration state of the mission that the
    simulator's record ``simulation`` (``simulation.json``) gives (module docstring); empty
    without a record or its ``calibration`` section."""
    section = (simulation or {}).get("calibration")
    if not isinstance(section, Mapping):
        return {}
    out: dict[str, float] = {}
    for st in calibration_states(config):
        kind = config.sensors[st.sensor].kind
        for state, name in zip(st.quantity.states, st.names, strict=True):
            value = _true_si(section, kind, state)
            if value is not None:
                out[name] = value * st.quantity.factor
    return out


def mission_truth(folder: str | Path) -> dict[str, float]:
    """:func:`true_values` of the mission folder ``folder`` (its ``mission.toml`` and
    ``simulation.json``); empty when either is missing or unreadable (a real mission)."""
    root = Path(folder)
    try:
        config = load_config(root / CONFIG_NAME)
    except MissionError:
        return {}
    return true_values(config, simulation_info(root))


def _true_si(section: Mapping[str, Any], kind: str, state: str) -> float | None:
    """A state's true value (SI) from a ``calibration`` section; None when not recorded."""
    if (kind, state) not in TRUTH_KEYS:
        return None
    key, index, offset = TRUTH_KEYS[(kind, state)]
    value = section.get(key)
    if index is not None:
        value = value[index] if isinstance(value, list) and index < len(value) else None
    if not isinstance(value, int | float) or isinstance(value, bool):
        return None
    return float(value) - offset


def calibration_errors(
    result: Result, truth: Mapping[str, float]
) -> dict[str, dict[str, float | str]]:
    """Per calibration state of the run with a true value in ``truth`` (:func:`true_values`),
    in its report unit: ``unit, true, estimate, sigma, error = estimate - true,
    error_over_sigma`` (NaN when σ is not positive), and ``error_over_sigma_long_run``, the
    error over the σ allowing for correlated readings (``sigma_long_run``, docs/calibration.md
    'Correlated readings'; NaN when the run has none); empty when there is none."""
    out: dict[str, dict[str, float | str]] = {}
    for name, found in (result.meta.get("calibration") or {}).items():
        if name not in truth:
            continue
        estimate, sigma = float(found["estimate"]), float(found["sigma"])
        long_run = found.get("sigma_long_run")
        lr = float(long_run) if long_run is not None else math.nan
        error = estimate - truth[name]
        out[name] = {
            "unit": str(found["unit"]),
            "true": truth[name],
            "estimate": estimate,
            "sigma": sigma,
            "error": error,
            "error_over_sigma": error / sigma if sigma > 0.0 else math.nan,
            "error_over_sigma_long_run": error / lr if lr > 0.0 else math.nan,
        }
    return out
