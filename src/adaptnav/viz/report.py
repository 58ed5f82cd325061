"""One self-contained HTML page from a comparison folder
(:meth:`adaptnav.analysis.compare.Comparison.save`).

:func:`write_report` reads ``comparison.json``, the run folders' ``summary.json`` (filter
settings, speed) and ``events.parquet``, the figures under ``figures/`` and, when it can find
the mission folder (``<compare_dir>/mission``, else the ``mission_dir`` that ``comparison.json``
records), its configuration (:func:`adaptnav.mission.load_config`: sensors, rates, nominal σ,
lever arms, IMU noise; docs/data-format.md) and the simulator's ``simulation.json`` (seed,
disturbances injected, timeline). :func:`report_data` gathers all of it, numbers computed, into
one frozen :class:`ReportData`; the Jinja2 templates under ``viz/templates/`` only format it
into one HTML file a person reads from top to bottom:

0. when some run found a sensor at odds with the INS and the other sensors, its warning
   (``meta.warnings`` of the run folder's ``summary.json``; :mod:`adaptnav.api.diagnosis`);
1. the scenario (trajectory, duration, distance, seed, disturbances; docs/simulation.md);
2. the sensors and the IMU noise model;
3. each filter's settings (gate q, VB ρ, N, α0, matching window; docs/filters.md, 'Gate' and
   the sections on the three filters);
4. our RMSE and relative RMSE (docs/metrics.md, 'Accuracy'; paper eqs. (32), (33); the distance is
   the horizontal length of the reference track) beside the paper's Table 3
   (``<table id="comparison">``, one row per filter), then each filter's consistency: the mean
   NEES of position, velocity and attitude and the share of epochs inside the χ²(3) 95 % band
   (``<table id="consistency">``, docs/metrics.md); for a smoothed comparison (``adaptnav
   compare --smooth``) the numbers are the RTS-smoothed solutions' and the forward solutions'
   RMSE, relative RMSE and mean position NEES stand beside them (docs/smoothing.md); when some
   run estimated calibration states (docs/calibration.md), their final estimates ± σ per filter
   from the run folders' ``calibration.json``, beside the true values of ``simulation.json``
   when known (``<table id="calibration-estimates">``,
   :func:`adaptnav.analysis.calibration.simulation_truth`; docs/metrics.md, 'Calibration');
5. every figure (the paper's Figs. 7-10, ledger counts, NIS, the calibration states) as a
   ``<figure>`` with a caption saying what to look at: the time series that ``comparison.json``
   lists under ``interactive`` (position error, each sensor's measurements and R̂, NIS,
   calibration states; :mod:`adaptnav.viz.interactive`) as zoomable Plotly figures, the others
   (trajectory, ledger counts) as their PNG in a ``data:`` URI;
6. the ledger counts (``<table id="ledger">``), the divergence guard's events
   (docs/robustness.md) and the shared initial alignment (docs/alignment.md).

The page needs nothing else (docs/report.md): the Plotly library is inlined once, each
interactive figure's data sits in a ``<script type="application/json">`` element and one small
script (``templates/render.js``) draws them; there are no external scripts, style sheets, fonts
or images and nothing is fetched. Every string from the files is escaped (the templates are
rendered with ``autoescape``; the figures' JSON by :func:`_script_json`).
"""

from __future__ import annotations

import base64
import datetime as _dt
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import jinja2
from markupsafe import Markup

from adaptnav.analysis.calibration import CalibrationTruthError, run_surfaces, simulation_truth
from adaptnav.analysis.compare import (
    COMPARISON_JSON,
    FILTER_LABELS,
    FORMAT_NAME,
    FORMAT_VERSION,
    NEES_BAND_TEXT,
    PAPER_TABLE3,
)
from adaptnav.api.results import CALIBRATION_FILE, TABLE_FILES, RunFolderError, check_files
from adaptnav.api.runner import heading_origin
from adaptnav.core.formats import SIMULATION_FILE, format_problem
from adaptnav.mission import MissionConfig, MissionError, load_config
from adaptnav.viz.series import MAX_POINTS

__all__ = ["REPORT_FILE", "ReportData", "ReportError", "report_data", "write_report"]

REPORT_FILE = "report.html"
MISSION_SUBDIR = "mission"
TEMPLATE = "report.html.j2"
EVENTS_SHOWN = 12
PLOTLY_CONFIG: dict[str, Any] = {
    "displaylogo": False,
    "showLink": False,
    "showSendToCloud": False,
    "typesetMath": False,
    "responsive": True,
    "toImageButtonOptions": {"format": "png", "scale": 2},
}
"""The interactive figures' Plotly config: no link or button leads out of the page (no Plotly
logo, no 'send to cloud'), no MathJax; the camera button saves a PNG locally."""
"""Most events listed per filter in the report (all are in the run's events.parquet)."""

Num = float | str | None
"""A number read from the files: None when absent, the text itself when it is not a number
(shown as it is)."""
Quantity = tuple[Any, str]
"""A mission.toml quantity ``[value, "unit"]``, the value one number or a list."""


class ReportError(ValueError):
    """The comparison folder is missing or unreadable; the message names the file."""


# --- the data model ------------------------------------------------------------------------


@dataclass(frozen=True)
class Segment:
    """One segment of the simulated trajectory (min)."""

    name: str
    start_min: float | None
    end_min: float | None
    length_min: float | None


@dataclass(frozen=True)
class TurnOnBias:
    """The IMU turn-on bias the simulator applied: gyro (deg/h) and accelerometer (mg)."""

    setting: str
    gyro_deg_h: tuple[float, ...]
    accel_mg: tuple[float, ...]


@dataclass(frozen=True)
class DvlDisturbances:
    """The DVL disturbances the simulator realised (docs/simulation.md)."""

    outlier_samples: str
    outlier_events: str
    navigation_samples: str
    noise_segments: int
    noise_time_s: float
    factors: tuple[float, float] | None
    """Smallest and largest σ factor of the noise segments; None without segments."""
    dropouts: int
    dropout_time_s: float


@dataclass(frozen=True)
class Simulation:
    """What ``simulation.json`` says of a simulated mission."""

    preset: str
    seed: str
    duration_s: Num
    duration_min: float | None
    static_end_s: Num
    distance_km: float | None
    heading_error_deg: float | None
    turn_on: TurnOnBias | None
    switched_on: tuple[str, ...]
    switched_off: tuple[str, ...]
    dvl: DvlDisturbances | None
    segments: tuple[Segment, ...] | None
    """None: no timeline recorded."""


@dataclass(frozen=True)
class Scenario:
    """The mission and, for a simulated one, its simulation; the scored span of the first run."""

    mission: str
    description: str
    simulation: Simulation | None
    scored_duration_min: float | None
    scored_distance_km: float | None


@dataclass(frozen=True)
class SensorRow:
    """One ``[sensors.<name>]`` of the mission's configuration."""

    name: str
    kind: str
    """The kind, and for an inclinometer the model that reads it (docs/inclinometer.md)."""
    use: str
    rate_hz: float | None
    sigma: Quantity
    lever_arm_m: tuple[float, float, float] | None
    overrides: tuple[tuple[str, float | int], ...]


@dataclass(frozen=True)
class Sensors:
    """The sensors and the IMU of the mission's configuration."""

    rows: tuple[SensorRow, ...]
    imu_rate_hz: float
    imu_format: str
    imu_noise: tuple[tuple[str, Quantity], ...]
    initial_bias_sigma: tuple[tuple[str, Quantity], ...]


@dataclass(frozen=True)
class FilterSettingsRow:
    """A filter's settings as its run folder's ``summary.json`` records them (docs/filters.md)."""

    kind: str
    gate_q: float | None
    """The gate's q; None: no gate."""
    gate_rule: str
    gate_reference: str
    gate_sensors: tuple[str, ...]
    guard_probability: float | None
    """The guard's p when it is on, else None (docs/robustness.md)."""
    guard_headroom: str
    guard_lockout_s: str
    q_adaptation_target: str | None
    noise: str
    """How R is chosen: ``matching``, ``vb``, ``oracle`` or ``fixed``."""
    matching_window: str
    matching_floor: str
    vb_rho: str
    vb_iterations: str
    vb_alpha0: str
    r_bounds: tuple[str, str] | None
    nis_test: tuple[str, str] | None
    """The windowed NIS test: (NIS/d threshold, window) when it is on."""
    epochs: str
    start: str


@dataclass(frozen=True)
class FilterRow:
    """One filter's settings (None: no summary.json) and speed."""

    label: str
    settings: FilterSettingsRow | None
    imu_samples_per_s: Num


@dataclass(frozen=True)
class ResultRow:
    """One filter's scores beside the paper's Table 3 (NaN where the paper has none)."""

    label: str
    rmse_m: Num
    relative_rmse_pct: Num
    paper_rmse_m: float
    paper_relative_rmse_pct: float
    horizontal_rmse_m: Num
    max_horizontal_error_m: Num
    final_horizontal_error_m: Num
    distance_km: float | None
    duration_min: float | None
    forward_rmse_m: Num = None
    """A smoothed run's forward solution's RMSE (docs/smoothing.md); None otherwise."""
    forward_relative_rmse_pct: Num = None


@dataclass(frozen=True)
class Against:
    """VB-MAESKF's change of the relative RMSE against another filter, ours and the paper's."""

    other: str
    lowers: bool
    change_pct: float
    """Size of the change (%), ≥ 0 when ``lowers``."""
    paper_pct: float | None


@dataclass(frozen=True)
class Summary:
    """The ranking by relative RMSE and how it compares with the paper's."""

    ranking: tuple[tuple[str, float], ...]
    against: tuple[Against, ...]
    paper_order_reproduced: bool | None
    """None: not applicable (not a paper mission, or fewer than two of its filters)."""


@dataclass(frozen=True)
class NeesRow:
    """One filter's mean NEES and % of epochs in the band, per block of ``_NEES_BLOCKS``."""

    label: str
    blocks: tuple[tuple[Num, float | None], ...]
    forward_position: Num = None
    """A smoothed run's forward solution's mean position NEES (docs/smoothing.md)."""


@dataclass(frozen=True)
class CalibrationRow:
    """One calibration state: its prior σ, its true value when known, and each filter's final
    estimate (docs/calibration.md), in the state's report unit."""

    state: str
    unit: str
    prior_sigma: Num
    true: float | None
    estimates: tuple[tuple[Num, Num, float | None, Num] | None, ...]
    """Per filter of :attr:`Calibration.filters`: (estimate, σ, error / σ or None when the true
    value is unknown, σ allowing for correlated readings or None: ``sigma_long_run``); None:
    the filter did not estimate this state."""


@dataclass(frozen=True)
class Calibration:
    """The runs' calibration states (the runs' ``calibration.json``)."""

    filters: tuple[str, ...]
    """Labels of the filters that estimated some."""
    rows: tuple[CalibrationRow, ...]
    truth_known: bool
    """Some state has a true value (a simulated mission's ``simulation.json``)."""


@dataclass(frozen=True)
class Figure:
    """One figure: its caption and either its interactive specification or its PNG."""

    stem: str
    number: int
    png_base64: str | None
    """The PNG as base64; None when the figure is shown interactive."""
    caption: str
    spec: Markup | None = None
    """The interactive figure's Plotly JSON, escaped to sit inside a ``<script>`` element
    (:func:`_script_json`); None: the PNG is shown."""


@dataclass(frozen=True)
class LedgerRow:
    """The fate of one sensor's readings in one filter's run."""

    label: str
    sensor: str
    used: str
    rejected: str
    dropped: str
    mean_nis: Num


@dataclass(frozen=True)
class GuardEvent:
    """One divergence guard event (estimation/health.py)."""

    t: float
    sensor: str
    event: str
    factor: float


@dataclass(frozen=True)
class EventRow:
    """One filter's guard events: counts (None: no events table), Q scale, the first ones."""

    label: str
    counts: tuple[int, int, int] | None
    """Lockouts, NIS tests, covariance repairs."""
    q_scale: float | None
    """The Q adaptation's last scale β; None: never scaled."""
    first: tuple[GuardEvent, ...]
    more: int


@dataclass(frozen=True)
class Initial:
    """The shared initial state (docs/alignment.md), from ``comparison.json``."""

    how: str
    alignment_s: Num
    heading_from: str
    t0_s: Num
    lat_deg: Num
    lon_deg: Num
    h_m: Num
    coarse_rpy_deg: tuple[Num, ...] | None
    rpy_deg: tuple[Num, ...] | None
    sigma_attitude_deg: tuple[Num, ...] | None
    sigma_position_m: tuple[Num, ...] | None
    sigma_velocity_m_s: tuple[Num, ...] | None


@dataclass(frozen=True)
class ReportData:
    """Everything the page shows, in the order it shows it."""

    title: str
    filters: tuple[str, ...]
    scenario: Scenario
    sensors: Sensors | None
    """None: the mission's configuration was not found or not valid."""
    settings: tuple[FilterRow, ...]
    results: tuple[ResultRow, ...]
    summary: Summary
    smoothed: bool
    """The runs are RTS-smoothed (``adaptnav compare --smooth``, docs/smoothing.md): the
    forward solutions' scores are shown beside theirs."""
    nees_blocks: tuple[str, ...]
    nees_band: str
    nees: tuple[NeesRow, ...]
    nees_diagonal: tuple[str, ...]
    """Filters whose NEES use P's diagonal only."""
    calibration: Calibration | None
    """None: no run estimated calibration states."""
    figures: tuple[Figure, ...]
    plotly_js: Markup | None
    """The Plotly library, inlined once when some figure is interactive; None otherwise."""
    plotly_config: Markup
    """The interactive figures' Plotly ``config`` (:data:`PLOTLY_CONFIG`) as escaped JSON."""
    max_points: int
    """Most points per series of an interactive figure (the envelope rule, docs/report.md)."""
    ledger: tuple[LedgerRow, ...]
    events: tuple[EventRow, ...]
    warnings: tuple[tuple[str, str], ...]
    """(filter, message) of every sensor a run found at odds with the rest (api/diagnosis.py)."""
    initial: Initial | None
    version: str
    written: _dt.datetime
    shown: str
    mission_dir: str | None


# --- reading the files ---------------------------------------------------------------------


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise ReportError(f"{path}: missing") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ReportError(f"{path}: not readable JSON ({exc})") from exc


def _optional_json(path: Path) -> dict[str, Any] | None:
    try:
        value = _read_json(path)
    except ReportError:
        return None
    return value if isinstance(value, dict) else None


def _mission_dir(compare_dir: Path, doc: Mapping[str, Any]) -> Path | None:
    local = compare_dir / MISSION_SUBDIR
    if (local / "mission.toml").is_file():
        return local
    recorded = doc.get("mission_dir")
    if isinstance(recorded, str) and (Path(recorded) / "mission.toml").is_file():
        return Path(recorded)
    return None


def _mission_config(folder: Path | None) -> MissionConfig | None:
    """The mission's typed configuration (:func:`adaptnav.mission.load_config`,
    docs/data-format.md); None when the folder is unknown or its ``mission.toml`` unreadable or
    not valid."""
    if folder is None:
        return None
    try:
        return load_config(folder / "mission.toml")
    except MissionError:
        return None


def _number(value: Any) -> Num:
    """A JSON value as :data:`Num`: None when absent (or a bool), a float when it converts."""
    if value is None or isinstance(value, bool):
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def _numbers(values: Any) -> tuple[Num, ...] | None:
    return tuple(_number(v) for v in values) if isinstance(values, list) else None


def _div(a: Any, b: float) -> float | None:
    try:
        return float(a) / b
    except (TypeError, ValueError):
        return None


def _sub(a: Any, b: Any) -> float | None:
    try:
        return float(a) - float(b)
    except (TypeError, ValueError):
        return None


def _mul(a: Any, b: float) -> float | None:
    try:
        return float(a) * b
    except (TypeError, ValueError):
        return None


def _label(name: Any) -> str:
    return str(FILTER_LABELS.get(name, name))


# --- the sections' data --------------------------------------------------------------------


def _scenario(
    doc: Mapping[str, Any], config: MissionConfig | None, sim: Mapping[str, Any] | None
) -> Scenario:
    results: Mapping[str, Any] = doc.get("results", {})
    first: Mapping[str, Any] = next(iter(results.values()), {})
    return Scenario(
        mission=str(doc.get("mission", "?")),
        description=config.mission.description if config else "",
        simulation=_simulation(sim) if sim else None,
        scored_duration_min=_div(first.get("duration_s"), 60.0),
        scored_distance_km=_div(first.get("distance_m"), 1000.0),
    )


def _simulation(sim: Mapping[str, Any]) -> Simulation:
    heading = sim.get("initial_heading_error_rad")
    imu = sim.get("imu", {})
    turn_on = None
    if isinstance(imu, dict) and imu.get("gyro_turn_on_rad_s") is not None:
        turn_on = TurnOnBias(
            setting=str(imu.get("turn_on", "")),
            gyro_deg_h=tuple(math.degrees(v) * 3600.0 for v in imu["gyro_turn_on_rad_s"]),
            accel_mg=tuple(v / 9.80665 * 1000.0 for v in imu.get("accel_turn_on_m_s2", [])),
        )
    switches = sim.get("disturbances", {})
    if not isinstance(switches, dict):
        switches = {}
    segments = sim.get("segments")
    dvl = sim.get("dvl")
    return Simulation(
        preset=str(sim.get("preset", "?")),
        seed=str(sim.get("seed", "?")),
        duration_s=_number(sim.get("duration_s")),
        duration_min=_div(sim.get("duration_s"), 60.0),
        static_end_s=_number(sim.get("static_end_s")),
        distance_km=_div(sim.get("distance_m"), 1000.0),
        heading_error_deg=math.degrees(heading) if heading is not None else None,
        turn_on=turn_on,
        switched_on=tuple(sorted(k for k, v in switches.items() if v)),
        switched_off=tuple(sorted(k for k, v in switches.items() if not v)),
        dvl=_dvl_disturbances(dvl) if isinstance(dvl, dict) else None,
        segments=_segments(segments) if isinstance(segments, list) and segments else None,
    )


def _segments(segments: list[Any]) -> tuple[Segment, ...]:
    return tuple(
        Segment(
            name=str(s[0]),
            start_min=_div(s[1], 60.0),
            end_min=_div(s[2], 60.0),
            length_min=_div(_sub(s[2], s[1]), 60.0),
        )
        for s in segments
        if isinstance(s, list) and len(s) >= 3
    )


def _dvl_disturbances(dvl: Mapping[str, Any]) -> DvlDisturbances:
    segs = [s for s in dvl.get("noise_segments", []) if isinstance(s, list) and len(s) >= 3]
    drops = [d for d in dvl.get("dropouts", []) if isinstance(d, list) and len(d) >= 2]
    factors = [float(s[2]) for s in segs]
    return DvlDisturbances(
        outlier_samples=str(dvl.get("outlier_samples", "?")),
        outlier_events=str(dvl.get("outlier_events", "?")),
        navigation_samples=str(dvl.get("navigation_samples", "?")),
        noise_segments=len(segs),
        noise_time_s=sum(float(s[1]) - float(s[0]) for s in segs),
        factors=(min(factors), max(factors)) if factors else None,
        dropouts=len(drops),
        dropout_time_s=sum(float(d[1]) - float(d[0]) for d in drops),
    )


def _sensors(config: MissionConfig) -> Sensors:
    """The sensors and the IMU of the mission's configuration (docs/data-format.md); a sensor's
    overrides are its own gate q, VB ρ and matching window (docs/filters.md)."""
    rows = []
    for name, s in config.sensors.items():
        kind = f"{s.kind} ({s.model or 'pendulum'})" if s.kind == "inclinometer" else s.kind
        overrides = tuple(
            (k, v)
            for k in ("gate_q", "vb_rho", "matching_window")
            if (v := getattr(s, k)) is not None
        )
        rows.append(SensorRow(name, kind, s.use, s.rate_hz, s.sigma, s.lever_arm_m, overrides))
    imu = config.imu
    return Sensors(
        rows=tuple(rows),
        imu_rate_hz=imu.rate_hz,
        imu_format=imu.format,
        imu_noise=tuple(imu.noise.model_dump(exclude_none=True).items()),
        initial_bias_sigma=tuple(imu.initial_bias_sigma.model_dump(exclude_none=True).items()),
    )


def _filter_row(name: str, summary: Mapping[str, Any] | None) -> FilterRow:
    """One filter's settings from its ``summary.json`` (the ``filter_settings`` that
    :class:`adaptnav.estimation.settings.FilterSettings` records; docs/filters.md)."""
    meta = (summary or {}).get("meta", {})
    fs = meta.get("filter_settings") if isinstance(meta, dict) else None
    rate = _number(meta.get("imu_samples_per_s")) if isinstance(meta, dict) else None
    if not isinstance(fs, dict):
        return FilterRow(_label(name), None, rate)
    kind = str(fs.get("kind", name))
    p_guard = fs.get("guard_probability")
    qa = fs.get("q_adaptation")
    bounds = (fs.get("r_bounds") or {}).get(kind)
    dg = (fs.get("divergence") or {}).get(kind)
    settings = FilterSettingsRow(
        kind=kind,
        gate_q=(fs.get("gate_q") or {}).get(kind) or None,  # 0: no gate (since 0.4.9)
        gate_rule=str(fs.get("gate_rule")),
        gate_reference=str(fs.get("gate_reference", "adapted")),
        gate_sensors=tuple(fs.get("gate_sensors", [])),
        guard_probability=p_guard if isinstance(p_guard, int | float) and p_guard > 0 else None,
        guard_headroom=str(fs.get("guard_headroom")),
        guard_lockout_s=str(fs.get("guard_lockout_s")),
        q_adaptation_target=str(qa.get("target")) if isinstance(qa, Mapping) else None,
        noise={"maeskf": "matching", "vb": "vb", "robust": "vb", "oracle": "oracle"}.get(
            kind, "fixed"
        ),
        matching_window=str(fs.get("matching_window")),
        matching_floor=str(fs.get("matching_floor")),
        vb_rho=str(fs.get("vb_rho")),
        vb_iterations=str(fs.get("vb_iterations")),
        vb_alpha0=str(fs.get("vb_alpha0")),
        r_bounds=(str(bounds[0]), str(bounds[1])) if bounds else None,
        nis_test=(
            (str(dg.get("nis_ratio")), str(dg.get("window")))
            if isinstance(dg, dict) and dg.get("nis_ratio")
            else None
        ),
        epochs=str(meta.get("epoch_policy", "?")),
        start=str(meta.get("initial", "?")),
    )
    return FilterRow(_label(name), settings, rate)


def _paper(mission: str, name: str) -> tuple[float, float]:
    return PAPER_TABLE3.get(mission, {}).get(name, (math.nan, math.nan))


def _result_row(mission: str, name: str, r: Mapping[str, Any]) -> ResultRow:
    p_rmse, p_rel = _paper(mission, name)
    return ResultRow(
        label=_label(name),
        rmse_m=_number(r.get("rmse_m")),
        relative_rmse_pct=_number(r.get("relative_rmse_pct")),
        paper_rmse_m=p_rmse,
        paper_relative_rmse_pct=p_rel,
        horizontal_rmse_m=_number(r.get("horizontal_rmse_m")),
        max_horizontal_error_m=_number(r.get("max_horizontal_error_m")),
        final_horizontal_error_m=_number(r.get("final_horizontal_error_m")),
        distance_km=_div(r.get("distance_m"), 1000.0),
        duration_min=_div(r.get("duration_s"), 60.0),
        forward_rmse_m=_number(r.get("forward_rmse_m")),
        forward_relative_rmse_pct=_number(r.get("forward_relative_rmse_pct")),
    )


def _reduction(better: float | None, worse: float | None) -> float | None:
    """Relative reduction 100 (1 - better / worse) in %; None when either is missing."""
    if better is None or worse is None or not worse:
        return None
    return 100.0 * (1.0 - better / worse)


def _summary(
    mission: str, filters: Sequence[str], results: Mapping[str, Mapping[str, Any]]
) -> Summary:
    """The filters ranked by relative RMSE, VB-MAESKF's reduction of it against MESKF and
    MAESKF beside the paper's (docs/metrics.md), and whether the paper's ordering holds."""
    rel = {
        n: float(results[n]["relative_rmse_pct"])
        for n in filters
        if n in results and isinstance(results[n].get("relative_rmse_pct"), int | float)
    }
    ranked = sorted(rel, key=lambda n: rel[n])
    against = []
    for other in ("meskf", "maeskf"):
        ours = _reduction(rel.get("vb"), rel.get(other))
        if ours is None:
            continue
        theirs = _reduction(_paper(mission, "vb")[1], _paper(mission, other)[1])
        against.append(
            Against(
                other=FILTER_LABELS[other],
                lowers=ours >= 0,
                change_pct=ours if ours >= 0 else -ours,
                paper_pct=theirs if theirs is not None and math.isfinite(theirs) else None,
            )
        )
    paper_order = [n for n in ("vb", "maeskf", "meskf") if n in rel]
    reproduced = None
    if mission in PAPER_TABLE3 and len(paper_order) > 1:
        reproduced = [n for n in ranked if n in paper_order] == paper_order
    return Summary(
        ranking=tuple((_label(n), rel[n]) for n in ranked),
        against=tuple(against),
        paper_order_reproduced=reproduced,
    )


_NEES_BLOCKS = ("position", "velocity", "attitude")


def _nees_row(name: str, r: Mapping[str, Any]) -> NeesRow:
    return NeesRow(
        label=_label(name),
        blocks=tuple(
            (_number(r.get(f"mean_nees_{b}")), _mul(r.get(f"nees_{b}_in_95"), 100.0))
            for b in _NEES_BLOCKS
        ),
        forward_position=_number(r.get("forward_mean_nees_position")),
    )


_CAPTIONS: dict[str, str] = {
    "trajectory": (
        "Estimated tracks, east against north of the navigation start, over the reference "
        "(black), as the paper's Figs. 7 and 8. Look at where each track leaves the reference "
        "and whether it comes back; the right panel zooms on the end of the run, where the "
        "accumulated error shows (markers: each run's end point, black square: the "
        "reference's)."
    ),
    "position_error": (
        "3-D (top) and horizontal (bottom) position error over time, estimate minus reference, "
        "as the paper's Fig. 9. Look at the jumps: they follow DVL outlier bursts and noisy "
        "segments that a filter trusted; in the paper VB-MAESKF's error stays lowest "
        "throughout, bounded on the round trip and growing on the straight run."
    ),
    "ledger_counts": (
        "Fate of the aiding readings after the navigation start, per sensor and filter: fused "
        "(used); rejected, by the guard (the χ² test on the nominal R that every filter runs "
        "on every sensor) or, for MESKF and MAESKF, also by the paper's per-component gate on "
        "the DVL; and dropped as invalid (e.g. DVL dropouts). The ledger's reason says which "
        "test rejected each reading. Look at how many good readings a gate throws away beside "
        "the outliers it catches: VB-MAESKF has no gate of its own and de-weights instead; "
        "what it rejects is the guard's."
    ),
    "nis": (
        "Running mean of the normalised innovation squared per component (NIS divided by the "
        "reading's dimension) for each aiding sensor. A consistent filter stays near 1 (black "
        "line). Above 1 the filter trusts the sensor more than it deserves (R too small: "
        "MESKF in rough sea); below 1 it distrusts it."
    ),
}


_CALIBRATION_CAPTION = (
    "The sensors' calibration states the filters estimated (docs/calibration.md), one panel "
    "per state: each filter's estimate over time (its line) and its claimed ±2σ (dotted), and "
    "the true value the simulator injected (black) where it is known. Look at whether an "
    "estimate settles on the true value inside its own 2σ, and how fast σ shrinks: a state "
    "the motion does not make observable keeps its prior σ."
)
_SMOOTHED_CALIBRATION = (
    " The runs are RTS-smoothed (docs/smoothing.md): drawn are the forward solutions, the "
    "filters learning the states as they ran; the table gives the smoothed final estimates."
)
_SMOOTHED_POSITION_ERROR = (
    " Left: each filter's forward solution, as it ran; right: the same run RTS-smoothed "
    "(docs/smoothing.md), every reading used both ways in time, on the same axes (a baseline "
    "that is not a filter, the DVL dead reckoning, is drawn alike in both): look at how much "
    "of each jump the smoother takes out."
)


_INTERACTIVE: dict[str, str] = {
    "position_error": (
        " Dotted (bottom): each filter's claimed horizontal 2σ, 2 √(σ_N² + σ_E²): an error "
        "that stays under it is one the filter knew it could have."
    ),
}
"""What an interactive figure shows beyond its static version, added to its caption."""


def _caption(stem: str, sim: bool, smoothed: bool = False) -> str:
    if stem == "position_error" and smoothed:
        return _CAPTIONS[stem] + _SMOOTHED_POSITION_ERROR
    if stem == "calibration":
        return _CALIBRATION_CAPTION + (_SMOOTHED_CALIBRATION if smoothed else "")
    if stem in _CAPTIONS:
        return _CAPTIONS[stem]
    if stem.startswith("noise_"):
        sensor = stem[len("noise_") :]
        text = (
            f"{sensor}: its measurements (top: grey; the simulator's true value in black and "
            "injected outliers as red crosses where known) and the noise variance R̂ that "
            "each adaptive filter (MAESKF, VB-MAESKF, robust) used at each reading (bottom, "
            "log scale), as the paper's Fig. 10. Grey dashes: the nominal R that MESKF uses "
            "throughout"
        )
        if sim:
            text += (
                "; black line: the true σ² the simulator applied; black dots: the actual "
                "squared error (running mean), pendulum error and outliers included"
            )
        text += (
            ". Look for R̂ rising where the measurements jump and falling back afterwards: "
            "MAESKF follows the innovations of its window, VB-MAESKF rises at once and "
            "forgets at the rate of ρ, and robust does as VB-MAESKF within its bounds on R̂."
        )
        if sensor == "inclinometer":
            text += (
                " The inclinometer is a pendulum: vessel accelerations tilt it, an error its "
                "nominal σ (and the simulator's σ column) leave out, so compare R̂ with the "
                "actual squared error."
            )
        return text
    return f"Figure {stem}."


def _figures(
    compare_dir: Path,
    files: Sequence[Any],
    specs: Mapping[str, Any],
    sim: bool,
    smoothed: bool = False,
) -> tuple[Figure, ...]:
    """The figures ``files`` lists, each interactive when ``specs`` (``comparison.json``'s
    ``interactive``: stem → file) has it, else its PNG."""
    figures = []
    for k, rel in enumerate(files, start=1):
        stem = Path(str(rel)).stem
        caption = _caption(stem, sim, smoothed)
        if stem in specs:
            spec = _spec(compare_dir / str(specs[stem]))
            figures.append(Figure(stem, k, None, caption + _INTERACTIVE.get(stem, ""), spec))
            continue
        path = compare_dir / str(rel)
        try:
            data = base64.b64encode(path.read_bytes()).decode("ascii")
        except OSError as exc:
            raise ReportError(f"{path}: figure missing ({exc.strerror})") from exc
        figures.append(Figure(stem, k, data, caption))
    return tuple(figures)


def _spec(path: Path) -> Markup:
    """An interactive figure's Plotly JSON (``figures/<stem>.plotly.json``), checked and
    escaped for a ``<script>`` element."""
    doc = _read_json(path)
    if not (isinstance(doc, dict) and isinstance(doc.get("data"), list)):
        raise ReportError(f"{path}: not a Plotly figure (no 'data' list)")
    try:
        return _script_json(doc)
    except ValueError as exc:  # NaN or infinity, which JSON.parse refuses
        raise ReportError(f"{path}: not valid JSON for the page ({exc})") from exc


def _script_json(value: Any) -> Markup:
    """``value`` as JSON that may sit inside ``<script type="application/json">``: ``<``, ``>``
    and ``&`` (which JSON has only inside strings) written as ``\\u`` escapes, so no string
    from the files can close the element."""
    text = json.dumps(value, separators=(",", ":"), allow_nan=False)
    for char in "<>&":
        text = text.replace(char, f"\\u{ord(char):04x}")
    return Markup(text)


def _plotly_js() -> Markup:
    """The Plotly library of the installed ``plotly`` package, to inline in the page."""
    from plotly.offline import get_plotlyjs

    # A "</script" inside the library would end its element early; it has none today.
    return Markup(get_plotlyjs().replace("</script", "<\\/script"))


def _simulation_digest(summaries: Mapping[str, Mapping[str, Any] | None]) -> str | None:
    """The SHA-256 of the mission's ``simulation.json`` that the runs recorded
    (``meta.simulation_sha256``, since 0.4.9), or None (older runs, a real mission)."""
    for summary in summaries.values():
        meta = (summary or {}).get("meta")
        digest = meta.get("simulation_sha256") if isinstance(meta, Mapping) else None
        if isinstance(digest, str):
            return digest
    return None


def _calibration(
    folder: Path,
    names: Sequence[Any],
    config: MissionConfig | None,
    mission_dir: Path | None,
    summaries: Mapping[str, Mapping[str, Any] | None],
) -> Calibration | None:
    """The calibration states of the runs that estimated some (their ``calibration.json``),
    in the order the runs list them, with the true values the simulator recorded
    (:func:`adaptnav.analysis.calibration.simulation_truth`, with the water surfaces the runs
    measured) when the mission is known; :class:`ReportError` naming ``simulation.json`` and
    the key when it is damaged (a figure against a truth read in part would mislead)."""
    found: dict[str, dict[str, Any]] = {}
    for name in names:
        doc = _optional_json(folder / str(name) / CALIBRATION_FILE)
        if doc:
            found[str(name)] = doc
    if not found:
        return None
    truth: dict[str, float] = {}
    if config is not None and mission_dir is not None:
        surfaces: dict[str, float] = {}
        for summary in summaries.values():
            surfaces = {**run_surfaces((summary or {}).get("meta")), **surfaces}
        try:
            sha = _simulation_digest(summaries)
            truth = simulation_truth(config, mission_dir, surfaces, sha)
        except CalibrationTruthError as exc:
            raise ReportError(str(exc)) from None
    rows = []
    for state in dict.fromkeys(s for doc in found.values() for s in doc):
        entries = [doc.get(state) for doc in found.values()]
        first = next((e for e in entries if isinstance(e, dict)), None)
        if first is None:  # a malformed file: no entry of this state to show
            continue
        true = truth.get(state)
        rows.append(
            CalibrationRow(
                state=state,
                unit=str(first.get("unit", "")),
                prior_sigma=_number(first.get("prior_sigma")),
                true=true,
                estimates=tuple(_estimate(e, true) for e in entries),
            )
        )
    return Calibration(tuple(_label(n) for n in found), tuple(rows), bool(truth))


def _estimate(entry: Any, true: float | None) -> tuple[Num, Num, float | None, Num] | None:
    """(estimate, σ, error / σ, σ allowing for correlated readings) of one state's
    ``calibration.json`` entry (docs/calibration.md, 'Correlated readings'; a run folder
    written before 0.3.9 has no ``sigma_long_run``: None); None without an entry."""
    if not isinstance(entry, dict):
        return None
    estimate, sigma = _number(entry.get("estimate")), _number(entry.get("sigma"))
    z = None
    if true is not None and isinstance(estimate, float) and isinstance(sigma, float) and sigma > 0:
        z = (estimate - true) / sigma
    return (estimate, sigma, z, _number(entry.get("sigma_long_run")))


def _ledger(names: Sequence[Any], results: Mapping[str, Mapping[str, Any]]) -> list[LedgerRow]:
    rows = []
    for name in names:
        counts = results.get(name, {}).get("counts") or {}
        nis = results.get(name, {}).get("mean_nis") or {}
        for sensor in sorted(counts):
            c = counts[sensor]
            used, rejected, dropped = (str(c.get(f, 0)) for f in ("used", "rejected", "dropped"))
            rows.append(
                LedgerRow(
                    _label(name), str(sensor), used, rejected, dropped, _number(nis.get(sensor))
                )
            )
    return rows


def _events(folder: Path, name: str, summary: Mapping[str, Any] | None) -> EventRow:
    """A filter's divergence guard events (estimation/health.py): counts, then the first ones.
    ``summary``: the run folder's ``summary.json``, whose digest of ``events.parquet`` the table
    must match (:func:`adaptnav.api.results.check_files`; a ReportError naming it otherwise)."""
    import pandas as pd

    run_dir = folder / str(name)
    path = run_dir / TABLE_FILES["events"]
    try:
        ev = pd.read_parquet(path) if path.is_file() else None
    except Exception:  # an unreadable table is shown as such, the report still written
        ev = None
    if ev is None:
        return EventRow(_label(name), None, None, (), 0)
    if summary is not None:
        try:
            check_files(run_dir, summary, [path.name])
        except RunFolderError as exc:
            raise ReportError(str(exc)) from None
    lockout, nis, covariance = (
        int((ev["event"] == k).sum()) for k in ("lockout", "nis", "covariance")
    )
    q = ev[ev["event"] == "q_scale"]
    head = ev.head(EVENTS_SHOWN)
    first = tuple(
        GuardEvent(float(t), str(sensor), str(event), float(factor))
        for t, sensor, event, factor in zip(
            head["t"].to_numpy(dtype=float),
            head["sensor"],
            head["event"],
            head["factor"].to_numpy(dtype=float),
            strict=True,
        )
    )
    return EventRow(
        label=_label(name),
        counts=(lockout, nis, covariance),
        q_scale=float(q["factor"].to_numpy(dtype=float)[-1]) if len(q) else None,
        first=first,
        more=max(0, len(ev) - EVENTS_SHOWN),
    )


def _warnings(name: str, summary: Mapping[str, Any] | None) -> list[tuple[str, str]]:
    """A filter's sensors at odds with the rest: ``meta.warnings`` of its run folder's
    ``summary.json`` (api/diagnosis.py), as (filter, message); none if it has none or could
    not be read (None)."""
    meta = (summary or {}).get("meta")
    found = meta.get("warnings") if isinstance(meta, dict) else None
    if not isinstance(found, list):
        return []
    return [
        (_label(name), str(w["message"])) for w in found if isinstance(w, dict) and "message" in w
    ]


def _initial(ini: Mapping[str, Any]) -> Initial | None:
    if not ini:
        return None
    return Initial(
        how=str(ini.get("initial", "?")),
        alignment_s=_number(ini.get("alignment_s")),
        heading_from=heading_origin(ini),
        t0_s=_number(ini.get("t0_s")),
        lat_deg=_number(ini.get("lat_deg")),
        lon_deg=_number(ini.get("lon_deg")),
        h_m=_number(ini.get("h_m")),
        coarse_rpy_deg=_numbers(ini.get("coarse_rpy_deg")),
        rpy_deg=_numbers(ini.get("rpy_deg")),
        sigma_attitude_deg=_numbers(ini.get("sigma_attitude_deg")),
        sigma_position_m=_numbers(ini.get("sigma_position_m")),
        sigma_velocity_m_s=_numbers(ini.get("sigma_velocity_m_s")),
    )


# --- the page ------------------------------------------------------------------------------


def _comparison(folder: Path) -> dict[str, Any]:
    if not folder.is_dir():
        raise ReportError(f"comparison folder {folder} does not exist")
    doc = _read_json(folder / COMPARISON_JSON)
    if not isinstance(doc, dict):
        raise ReportError(f"{folder / COMPARISON_JSON}: not an {FORMAT_NAME} file")
    problem = format_problem(doc, FORMAT_NAME, FORMAT_VERSION)
    if problem:
        raise ReportError(f"{folder / COMPARISON_JSON}: {problem}")
    return doc


def report_data(compare_dir: str | Path, *, shown_as: str | Path | None = None) -> ReportData:
    """Read the comparison folder ``compare_dir`` (and its mission folder, when found) into
    the page's data; ``shown_as`` as in :func:`write_report`.

    Raises :class:`ReportError` naming the file when ``comparison.json`` or a figure it lists
    is missing or unreadable, or a run's ``events.parquet`` is not the one the run wrote.
    """
    from adaptnav import __version__

    folder = Path(compare_dir)
    doc = _comparison(folder)
    mission_dir = _mission_dir(folder, doc)
    config = _mission_config(mission_dir)
    sim = _optional_json(mission_dir / SIMULATION_FILE) if mission_dir else None
    names = doc.get("filters", [])
    results: Mapping[str, Mapping[str, Any]] = doc.get("results", {})
    scored = doc.get("filters", list(results))
    mission = str(doc.get("mission", "?"))
    title = f"adaptnav: filters compared on {mission}"
    if sim and sim.get("seed") is not None:
        title += f" (seed {sim['seed']})"
    summaries = {n: _optional_json(folder / str(n) / "summary.json") for n in names}
    calibration = _calibration(folder, names, config, mission_dir, summaries)
    shown = folder.resolve() if shown_as is None else Path(shown_as)
    if mission_dir is not None and shown_as is not None and mission_dir == folder / MISSION_SUBDIR:
        mission_dir = shown / MISSION_SUBDIR
    smoothed = any("forward_rmse_m" in r for r in results.values())
    specs = doc.get("interactive")
    specs = specs if isinstance(specs, dict) else {}
    figures = _figures(folder, doc.get("figures") or [], specs, sim is not None, smoothed)
    return ReportData(
        title=title,
        filters=tuple(_label(n) for n in names),
        scenario=_scenario(doc, config, sim),
        sensors=_sensors(config) if config else None,
        settings=tuple(_filter_row(n, summaries[n]) for n in names),
        results=tuple(
            _result_row(str(doc.get("mission", "")), n, results.get(n, {})) for n in scored
        ),
        summary=_summary(str(doc.get("mission", "")), names, results),
        smoothed=smoothed,
        nees_blocks=_NEES_BLOCKS,
        nees_band=NEES_BAND_TEXT,
        nees=tuple(_nees_row(n, results.get(n, {})) for n in scored),
        nees_diagonal=tuple(
            _label(n) for n in scored if results.get(n, {}).get("nees_uses_correlations") is False
        ),
        calibration=calibration,
        figures=figures,
        plotly_js=_plotly_js() if any(f.spec is not None for f in figures) else None,
        plotly_config=_script_json(PLOTLY_CONFIG),
        max_points=MAX_POINTS,
        ledger=tuple(_ledger(scored, results)),
        events=tuple(_events(folder, n, summaries[n]) for n in names),
        warnings=tuple(w for n in names for w in _warnings(n, summaries[n])),
        initial=_initial(doc.get("initial") or {}),
        version=__version__,
        written=_dt.datetime.now(_dt.UTC),
        shown=str(shown),
        mission_dir=str(mission_dir) if mission_dir else None,
    )


def _num(value: Num, fmt: str = "{:.2f}", missing: str = "–") -> str:
    """Jinja filter ``num``: ``value`` formatted with ``fmt``; ``missing`` when it is absent or
    not finite; a text that is no number as it is."""
    if value is None:
        return missing
    if isinstance(value, str):
        return value
    return fmt.format(value) if math.isfinite(value) else missing


def _geodetic(value: Num, letters: str) -> str:
    """Jinja filter ``geodetic``: a latitude or longitude (deg) as ``33.900035° S``, the
    hemisphere from its sign (``letters``: ``"NS"`` or ``"EW"``); ``–`` when absent."""
    if value is None or isinstance(value, str) or not math.isfinite(value):
        return _num(value)
    return f"{abs(value):.6f}° {letters[0] if value >= 0.0 else letters[1]}"


def _quantity(value: Quantity) -> str:
    """Jinja filter ``quantity``: ``[value, "unit"]`` as text (``0.01, 0.02 m/s``)."""
    v, unit = value
    shown = ", ".join(str(x) for x in v) if isinstance(v, list) else str(v)
    return f"{shown} {unit}"


@cache
def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("adaptnav.viz", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    env.filters["num"] = _num
    env.filters["geodetic"] = _geodetic
    env.filters["quantity"] = _quantity
    return env


def write_report(
    compare_dir: str | Path,
    out_file: str | Path | None = None,
    *,
    shown_as: str | Path | None = None,
) -> Path:
    """Write the HTML report of the comparison folder ``compare_dir``; returns its path
    (default ``compare_dir/report.html``). ``shown_as``: the folder's path to print in the
    page instead of ``compare_dir`` (a temporary folder renamed there afterwards).

    Raises :class:`ReportError` (a ValueError) naming the file when ``comparison.json`` or a
    figure it lists is missing or unreadable, or a run's ``events.parquet`` is not the one the
    run wrote.
    """
    data = report_data(compare_dir, shown_as=shown_as)
    page = _environment().get_template(TEMPLATE).render(report=data)
    out = Path(out_file) if out_file is not None else Path(compare_dir) / REPORT_FILE
    out.parent.mkdir(parents=True, exist_ok=True)
    # Whole or not at all: a temporary beside it, renamed over it (never a half-written page).
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(page, encoding="utf-8")
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out
