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

Each less what the mission's configuration already compensates (since 0.4.6; before, a known
part was scored as an error of the estimate): a latency less the sensor's ``latency_s``, a
depth bias less its ``surface_h_m``, the DVL misalignment relative to its ``mounting_rpy_deg``
(:func:`relative_misalignment`), an inclinometer's biases less its mounting's roll and pitch
(:func:`_true_si`). A ``simulation.json`` that is there but damaged is an error naming the file
and the key (:class:`CalibrationTruthError`), not a truth with states missing or wrong.

The error of an estimate is ``estimate - true``, and ``error / σ`` says whether the filter's
σ covers it (within ±2 about 95 % of the time for a consistent filter).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.api.results import file_digest
from adaptnav.core import attitude
from adaptnav.core.formats import SIMULATION_FILE, read_json_object
from adaptnav.mission import MissionError, load_config
from adaptnav.mission.calibration import calibration_states
from adaptnav.mission.loader import CONFIG_NAME

if TYPE_CHECKING:
    from adaptnav.api.results import Result
    from adaptnav.mission import MissionConfig
    from adaptnav.mission.config import SensorConfig

Array = NDArray[np.float64]

__all__ = [
    "TRUTH_KEYS",
    "CalibrationTruthError",
    "calibration_errors",
    "comparison_truth",
    "mission_truth",
    "relative_misalignment",
    "run_surfaces",
    "simulation_truth",
    "true_values",
    "units",
]

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
None for a number, offset): the simulated error (SI) is ``value[index] - offset``; the state's
true value is that error less the part the mission's configuration already compensates
(:func:`true_values`)."""
_LENGTHS = {"dvl_misalignment_rad": 3, "inclinometer_bias_rad": 2}
"""The recorded lists and their lengths (the simulator's ``Calibration.as_dict``)."""


class CalibrationTruthError(ValueError):
    """``simulation.json`` is there but its true calibration errors cannot be read (not JSON,
    a value of the wrong type or length, not finite): the message names the file and the key.
    Scoring against what could be read of it would be silently wrong."""


def units(config: MissionConfig) -> dict[str, tuple[float, str]]:
    """Each calibration state of the mission (``dvl.scale``) → (factor from SI to its report
    unit, the unit), in the order of the error state."""
    return {
        name: (st.quantity.factor, st.quantity.unit)
        for st in calibration_states(config)
        for name in st.names
    }


def run_surfaces(meta: Mapping[str, Any] | None) -> dict[str, float]:
    """The water-surface heights a run measured for its depth meters with ``surface_h_m =
    "auto"`` (``meta["surface_h_m"]``, api/runner.py ``resolve_surfaces``), by sensor; empty
    when it measured none."""
    found = (meta or {}).get("surface_h_m")
    if not isinstance(found, Mapping):
        return {}
    return {
        str(k): float(v)
        for k, v in found.items()
        if isinstance(v, int | float) and not isinstance(v, bool)
    }


def true_values(
    config: MissionConfig,
    simulation: Mapping[str, Any] | None,
    surfaces: Mapping[str, float] | None = None,
) -> dict[str, float]:
    """The true value, in its report unit, of each calibration state of the mission that the
    simulator's record ``simulation`` (``simulation.json``) gives (module docstring), less what
    the mission's configuration already compensates (:func:`_true_si`); ``surfaces``: a run's
    measured ``"auto"`` water surfaces (:func:`run_surfaces`). Empty without a record or its
    ``calibration`` section (null too); a key that is not recorded gives its states no truth
    (a simulator before 0.4.3 recorded no latency). :class:`CalibrationTruthError` naming the
    key for a section or a value that is there but not what the simulator writes."""
    section = (simulation or {}).get("calibration")
    if section is None:
        return {}
    if not isinstance(section, Mapping):
        raise CalibrationTruthError(
            f"calibration: {section!r} is not an object of true calibration errors"
        )
    out: dict[str, float] = {}
    for st in calibration_states(config):
        sensor = config.sensors[st.sensor]
        surface = _surface(sensor, st.sensor, surfaces or {})
        for state, name in zip(st.quantity.states, st.names, strict=True):
            value = _true_si(section, sensor, state, surface)
            if value is not None:
                out[name] = value * st.quantity.factor
    return out


def simulation_truth(
    config: MissionConfig,
    root: str | Path,
    surfaces: Mapping[str, float] | None = None,
    sha256: str | None = None,
) -> dict[str, float]:
    """:func:`true_values` of ``config`` against the mission folder ``root``'s
    ``simulation.json``: empty without that file (a real mission), a
    :class:`CalibrationTruthError` naming it and the key when it is there but unreadable, or,
    given the digest the run recorded (``sha256``, ``meta.simulation_sha256``), when it is not
    that file: a mission simulated again into the same folder, or another simulation of the same
    name (up to 0.4.8 its true errors scored the run's estimates, silently wrong)."""
    path = Path(root) / SIMULATION_FILE
    if not path.is_file():
        return {}
    if sha256 is not None:
        now = str(file_digest(path)["sha256"])
        if now != sha256:
            raise CalibrationTruthError(
                f"{path}: not the simulation the run was made from (simulated again after the "
                f"run, or another mission's): its SHA-256 begins {now[:12]}, and the run's "
                f"summary.json records {sha256[:12]} (meta.simulation_sha256); run the filter "
                "again on this mission, or give the run's own mission folder"
            )
    info = read_json_object(path, CalibrationTruthError)
    try:
        return true_values(config, info, surfaces)
    except CalibrationTruthError as exc:
        raise CalibrationTruthError(f"{path}: {exc}") from None


def comparison_truth(
    config: MissionConfig, root: str | Path, results: Mapping[str, Result]
) -> dict[str, float]:
    """:func:`simulation_truth` for runs of one mission from one start (a comparison; the
    report's calibration figure), with the water surfaces they measured (:func:`run_surfaces`:
    measured once, at the shared alignment, so the same in each)."""
    surfaces: dict[str, float] = {}
    for result in results.values():
        surfaces = {**run_surfaces(result.meta), **surfaces}
    return simulation_truth(config, root, surfaces)


def mission_truth(
    folder: str | Path, surfaces: Mapping[str, float] | None = None, sha256: str | None = None
) -> dict[str, float]:
    """:func:`simulation_truth` of the mission folder ``folder`` (its ``mission.toml`` and
    ``simulation.json``, checked against the run's ``sha256`` when given); empty when either is
    missing or the configuration unreadable (not a mission), a :class:`CalibrationTruthError`
    for a ``simulation.json`` that is there but damaged (since 0.4.6; it gave no or part of the
    truth before) or not the run's."""
    root = Path(folder)
    try:
        config = load_config(root / CONFIG_NAME)
    except MissionError:
        return {}
    return simulation_truth(config, root, surfaces, sha256)


def _surface(sensor: SensorConfig, name: str, surfaces: Mapping[str, float]) -> float | None:
    """A depth meter's water-surface height as the run used it (m): its ``surface_h_m``, or for
    ``"auto"`` the height the run measured, rounded to the mm as the runner sets it
    (api/runner.py ``resolve_surfaces``); None for ``"auto"`` without that measurement."""
    if sensor.surface_h_m != "auto":
        return sensor.surface_h()
    return round(surfaces[name], 3) if name in surfaces else None


def _true_si(
    section: Mapping[str, Any], sensor: SensorConfig, state: str, surface: float | None
) -> float | None:
    """A state's true value (SI): the simulated error less what the configuration compensates
    (docs/metrics.md, 'Calibration'); None when not recorded, or for a depth bias whose
    ``"auto"`` surface the run did not record.

    * latency: the loader moves every reading by ``latency_s`` (mission/loader.py), so the
      state sees the simulated lag less it, exactly;
    * depth bias: the model reads ``h_s - h + b`` (sensors/depth.py) where the simulator reads
      ``-h + b_sim``, so ``b = b_sim - h_s``;
    * DVL misalignment: :func:`relative_misalignment`;
    * inclinometer biases: the simulated sensor sits on the body axes, the model reads the
      roll and pitch of ``C_nb C_bs`` (``C_bs = euler_to_dcm(mounting)``). Level, that is the
      mounting's own roll and pitch (``Rz(ψ) C_bs``'s), so ``b = b_sim - (m_roll, m_pitch)``;
      tilted, the mounting's pitch and yaw mix the vehicle's roll and pitch (by ~|m| × tilt),
      which no constant bias follows: the level value is the truth scored (docs/metrics.md).
    """
    entry = TRUTH_KEYS.get((sensor.kind, state))
    if entry is None:
        return None
    key, index, offset = entry
    if key not in section:
        twin = key.removesuffix("_rad") + "_deg"
        if twin != key + "_deg" and twin in section:  # the simulator writes both or neither
            raise CalibrationTruthError(f"calibration: {twin} without {key}")
        return None
    recorded = _recorded(section, key)
    if index is not None and sensor.kind == "dvl":
        return float(relative_misalignment(recorded, sensor.mounting_rpy_deg)[index])
    value = float(recorded[0 if index is None else index]) - offset
    if state == "latency":
        return value - (sensor.latency_s or 0.0)
    if sensor.kind == "depth":
        return None if surface is None else value - surface
    if index is not None and sensor.mounting_rpy_deg is not None:
        return value - math.radians(sensor.mounting_rpy_deg[index])
    return value


def _recorded(section: Mapping[str, Any], key: str) -> Array:
    """``section[key]`` as the simulator writes it, a finite number (returned as one element)
    or a list of :data:`_LENGTHS` finite numbers; :class:`CalibrationTruthError` naming the key
    otherwise."""
    value = section[key]
    n = _LENGTHS.get(key)
    items = value if n is not None and isinstance(value, list) else [value]
    numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in items)
    if (n is not None and len(items) != n) or not numbers:
        wanted = "a number" if n is None else f"a list of {n} numbers"
        raise CalibrationTruthError(f"calibration.{key}: {value!r} is not {wanted}")
    out = np.asarray(items, dtype=float)
    if not np.all(np.isfinite(out)):
        raise CalibrationTruthError(f"calibration.{key}: {value!r} is not finite")
    return out


def relative_misalignment(simulated: ArrayLike, mounting_rpy_deg: Sequence[float] | None) -> Array:
    """The DVL misalignment state's true value δ (rad, ZYX) for the simulated misalignment
    ``simulated`` and the configured mounting: the simulated DVL reads ``M(δ_sim) v_b`` (its
    nominal frame is the body's, sim/sensors.py), the model ``M(δ) C_sb v_b`` with ``C_sb =
    euler_to_dcm(m)ᵀ`` and ``M(δ) = euler_to_dcm(δ)ᵀ`` (sensors/calibration.py), so
    ``euler_to_dcm(δ) = euler_to_dcm(m)ᵀ euler_to_dcm(δ_sim)``, exactly: the rotation from the
    configured frame to the true one. A difference of the Euler angles is right to first order
    only: a mounting of (0.5°, -0.3°, 0) and a simulated (0.5°, -0.3°, 2°) give (0.011°,
    0.017°, 2.000°), not (0, 0, 2°), beyond the 0.001° the table shows."""
    d = np.asarray(simulated, dtype=float)
    if mounting_rpy_deg is None or not any(mounting_rpy_deg):
        return d  # exact, where the round trip through a DCM would round
    m = np.radians(np.asarray(mounting_rpy_deg, dtype=float))
    C = attitude.euler_to_dcm(*m).T @ attitude.euler_to_dcm(*d)
    return np.asarray(attitude.dcm_to_euler(C), dtype=float)


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
