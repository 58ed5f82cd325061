"""Run a filter on a mission: the library's front door (``adaptnav.run``).

Mission (``adaptnav.mission``) → sensor models and channels (``adaptnav.estimation.settings``) →
initial state (static alignment, ``adaptnav.engine.align``, or the configured state) → the multirate
engine (``adaptnav.engine.batch``) → a :class:`~adaptnav.api.results.Result`. Readings that never
reach the engine (removed at load, inside the alignment window, or of a sensor used only for
initialisation) are written to the ledger with their reason, so no reading disappears.
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, get_args

import numpy as np
import pandas as pd

from adaptnav import __version__
from adaptnav.api import oracle
from adaptnav.api.diagnosis import calibration_correlated, with_warnings
from adaptnav.api.results import Result, dropped_ledger, file_digest, ledger_frame
from adaptnav.core import attitude, earth
from adaptnav.core.formats import SIMULATION_FILE
from adaptnav.engine import batch as engine
from adaptnav.engine.align import (
    CoarseInfo,
    align,
    axes_at_rest,
    level,
    window_specific_force,
)
from adaptnav.engine.channels import build_channels
from adaptnav.estimation.long_run import variance_factor
from adaptnav.estimation.settings import FilterKind, FilterSettings
from adaptnav.mission import (
    ImuData,
    Mission,
    MissionConfig,
    MissionError,
    SensorData,
    calibration,
    load_mission,
)
from adaptnav.mission.config import with_overrides
from adaptnav.mission.loader import CONFIG_NAME, build_sensor_model
from adaptnav.mission.tables import imu_columns
from adaptnav.models import errorstate
from adaptnav.models.errorstate import ATT, BA, BG, N_STATES, POS, VEL
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.models.strapdown import NOM_ATT, NOM_BA, NOM_BG, NOM_SIZE, NavState
from adaptnav.sensors.calibration import regressors as calibration_regressors
from adaptnav.sensors.inclinometer import PendulumInclinometer
from adaptnav.sensors.registry import KINDS

__all__ = [
    "FilterError",
    "engine_config",
    "heading_origin",
    "initial_state",
    "ledger_row",
    "run",
    "sensor_channels",
    "sensor_heading",
    "start_state",
]


log = logging.getLogger("adaptnav.api")

OFF_REASON = "sensor off"
"""Ledger reason of every reading of a sensor with ``use = "off"``."""
BEFORE_START_REASON = "before navigation start (alignment)"
"""Ledger reason of the readings inside the static alignment window (docs/alignment.md)."""
INIT_REASON = "sensor used only for initialisation"
"""Ledger reason of every reading of a sensor with ``use = "init"``."""
GIVEN_START_REASON = "before navigation start (the given start state)"
GIVEN_INIT_REASON = 'sensor use = "init", not used: the start state was given'
"""The two reasons above when the run starts from a state it is given (``initial=`` of
:func:`run` or a Stream, or ``initial.mode = "state"``): no alignment ran, and nothing used the
sensor (up to 0.4.8 these readings had the alignment's reasons)."""


def start_reasons(aligned: bool) -> tuple[str, str]:
    """The ledger reasons of a ``use = "init"`` sensor's readings and of a reading at or before
    the navigation start: the alignment's when the run ``aligned``, else the given start's."""
    if aligned:
        return INIT_REASON, BEFORE_START_REASON
    return GIVEN_INIT_REASON, GIVEN_START_REASON


class FilterError(MissionError):
    """The filter broke down numerically on this mission (e.g. an innovation covariance that
    is not positive definite): almost always a bad reading or a wrong σ; the message says
    where in time."""


def ledger_row(sensor: str, row: int, t: float, reason: str) -> dict[str, Any]:
    """A ledger row for a reading dropped before the engine (same keys as the engine's)."""
    rec: dict[str, Any] = {
        "t": t,
        "t_epoch": math.nan,
        "sensor": sensor,
        "row": row,
        "fate": "dropped",
        "reason": reason,
        "statistic": math.nan,
        "threshold": math.nan,
        "iterations": 0,
    }
    for j in range(engine.MAX_DIM):
        rec[f"nu_{j}"] = math.nan
        rec[f"r_{j}"] = math.nan
    return rec


def initial_state(mission: Mission) -> tuple[np.ndarray, np.ndarray, float, dict[str, Any]]:
    """(x0, P0, t0, info) from the mission's ``[initial]`` section (docs/alignment.md), over its
    IMU and sensors: :func:`start_state`."""
    return start_state(mission.config, mission.imu, mission.sensors)


def start_state(
    cfg: MissionConfig, imu: ImuData, sensors: Mapping[str, SensorData]
) -> tuple[np.ndarray, np.ndarray, float, dict[str, Any]]:
    """(x0, P0, t0, info) from ``[initial]`` of ``cfg`` (docs/alignment.md), given the IMU
    intervals and the loaded readings (a GNSS sensor's fixes may give the position).

    ``alignment``: coarse + fine static alignment over the first ``alignment_s`` seconds, at the
    configured position (or the mean of GNSS fixes in the window); navigation starts at its end.
    ``state``: the configured state and σ's (biases from ``[imu.initial_bias]``, else zero),
    from the IMU's first interval start.
    """
    noise = cfg.imu.noise.to_imu_noise()
    gyro_sigma, accel_sigma = cfg.imu.initial_bias_sigma.si(noise)
    ini = cfg.initial
    t_start = float(imu.t[0] - imu.dt[0])
    if ini.mode == "state":
        x0, P0 = _configured_state(cfg, accel_sigma, gyro_sigma)
        return x0, P0, t_start, {"initial": "state"}
    position = _alignment_position(cfg, sensors, t_start, t_start + ini.alignment_s)
    heading, heading_sigma, given = _given_heading(cfg, imu, sensors, t_start)
    a = align(
        imu.t, imu.dt, imu.dtheta, imu.dvel, ini.alignment_s, position, noise,
        accel_sigma, gyro_sigma, heading=heading, heading_sigma=heading_sigma,
        position_sigma=ini.sigma_position_m, velocity_sigma=ini.sigma_velocity_m_s,
    )  # fmt: skip
    if cfg.imu.check_axes:
        check_axes_at_rest(cfg, a.coarse, position[0], heading, heading_sigma, given)
    check_angles_at_rest(cfg, sensors, a.x0, a.P0, a.coarse.mean_specific_force, t_start, a.t_end)
    check_depth_at_rest(cfg, sensors, a.x0, t_start, a.t_end)
    check_motion_at_rest(cfg, sensors, t_start, a.t_end)
    x0 = _at_the_imu(cfg, a.x0)
    info = {
        "initial": "alignment",
        "alignment_s": ini.alignment_s,
        "heading_source": a.heading_source,
        **(given if a.heading_source == "heading" else {}),
        "coarse_rpy_deg": [math.degrees(v) for v in (a.roll, a.pitch, a.yaw)],
        "aligned_rpy_deg": list(np.degrees(attitude.quat_to_euler(a.x0[6:10]))),
        "sigma_attitude_deg": list(np.degrees(a.std[ATT])),
    }
    return x0, a.P0, a.t_end, info


def _position_gnss(cfg: MissionConfig) -> str | None:
    """The GNSS sensor whose fixes a static alignment takes its position from
    (:func:`_alignment_position`): the first one not off, when ``[initial]`` gives no position;
    None when it does, or there is none."""
    ini = cfg.initial
    if ini.lat_deg is not None and ini.lon_deg is not None:
        return None
    return cfg.first_sensor("gnss")


def heading_origin(initial: Mapping[str, Any]) -> str:
    """Where a run's start took its heading from, in words, from the ``initial`` of its
    summary (:func:`start_state`'s info): gyrocompassing, the configured ``rpy_deg`` or a
    heading sensor (docs/alignment.md, 'Heading source')."""
    source = initial.get("heading_source")
    if source == "gyrocompass":
        return "gyrocompassing"
    if source != "heading":
        return str(initial.get("initial", "–"))
    given = str(initial.get("heading_from", ""))
    if given.startswith("sensors."):
        n = initial.get("heading_readings", "?")
        return f"heading sensor {given.removeprefix('sensors.')!r} (mean of {n} readings at rest)"
    return "the configured heading (initial.rpy_deg, e.g. the quay's charted bearing)"


def _given_heading(
    cfg: MissionConfig, imu: ImuData, sensors: Mapping[str, SensorData], t_start: float
) -> tuple[float | None, float | None, dict[str, Any]]:
    """The heading (rad), its σ and how it was got, that the static alignment takes when
    gyrocompassing is worse or unusable (docs/alignment.md, 'Heading source'): the configured
    ``rpy_deg`` yaw, else the heading sensor's (:func:`sensor_heading`), else none."""
    ini = cfg.initial
    if ini.rpy_deg is not None:
        sigma = float(ini.sigma_attitude_rad()[2])
        return math.radians(ini.rpy_deg[2]), sigma, {"heading_from": "initial.rpy_deg"}
    name = cfg.first_sensor("heading")
    if name is None:
        return None, None, {}
    return sensor_heading(cfg, imu, sensors, name, t_start)


def sensor_heading(
    cfg: MissionConfig,
    imu: ImuData,
    sensors: Mapping[str, SensorData],
    name: str,
    t_start: float,
) -> tuple[float | None, float | None, dict[str, Any]]:
    """The body's heading (rad) and σ from heading sensor ``name``'s readings at rest: the yaw
    ψ at which the sensor's model predicts the circular mean of its readings in the static
    window, at the roll and pitch of the levelled IMU (engine/align.py ``level``). A yaw turn δ
    of the body about the down axis turns the sensor's yaw by δ whatever its mounting
    (``C_ns = C_z(δ) C_nb C_sbᵀ``), so ``ψ = wrap(z̄ - h(roll, pitch, 0))`` exactly. σ is one
    reading's: a compass's error is mostly slow (deviation, a mounting left out), not averaged
    down over a window. None when the sensor has no finite reading in the window; a
    :class:`MissionError` then if the sensor is there only for this (``use = "init"``)."""
    sc, window = cfg.sensors[name], cfg.initial.alignment_s
    d = sensors.get(name)
    inside = np.zeros(0, dtype=bool)
    if d is not None:
        inside = (d.t > t_start) & (d.t <= t_start + window) & np.all(np.isfinite(d.z), axis=1)
    if not np.any(inside):
        if sc.use != "init":
            return None, None, {}
        raise MissionError(
            f"{CONFIG_NAME}: sensors.{name} (use = 'init') gives the alignment its heading but "
            f"has no reading in the static window ({t_start:.6g} s to "
            f"{t_start + window:.6g} s) of {sc.file}",
            file=CONFIG_NAME,
            field=f"sensors.{name}",
        )
    assert d is not None
    roll, pitch = level(window_specific_force(imu.t, imu.dt, imu.dvel, window))
    x = np.zeros(NOM_SIZE)
    x[NOM_ATT] = attitude.euler_to_quat(roll, pitch, 0.0)
    model: Any = build_sensor_model(name, sc)
    z = float(np.angle(np.mean(np.exp(1j * d.z[inside, 0]))))
    yaw = float(attitude.wrap_angle(z - float(model.predict(x)[0])))
    n = int(inside.sum())
    return yaw, float(model.sigma), {"heading_from": f"sensors.{name}", "heading_readings": n}


def _at_the_imu(cfg: MissionConfig, x0: np.ndarray) -> np.ndarray:
    """The aligned state moved from the GNSS antenna to the IMU when the position is the mean of
    a GNSS sensor's fixes (:func:`_alignment_position`): a fix is the antenna's position,
    ``r_a = r + C_nb l_g`` (sensors/gnss.py), so ``r = r_a - C_nb l_g``; the height only when the
    fixes gave it (``use_height``), else it is the configured one. Unchanged for a configured
    position or a GNSS without a lever arm."""
    gnss = _position_gnss(cfg)
    if gnss is None:
        return x0
    gc = cfg.sensors[gnss]
    d = attitude.quat_to_dcm(x0[NOM_ATT]) @ gc.lever_arm()
    if not gc.use_height:
        d[2] = 0.0
    if not np.any(d):
        return x0
    lat, lon, h = earth.ned_to_geodetic(-d, x0[0], x0[1], x0[2])
    x = x0.copy()
    x[:3] = (float(lat), float(lon), float(h))
    return x


AT_REST_KINDS = ("inclinometer", "heading")
"""Angle sensors whose readings in the static window are checked against the alignment."""
AT_REST_SIGMAS = 10.0
AT_REST_FLOOR_RAD = math.radians(2.0)
"""An angle sensor's mean over the static window may differ from what the aligned state
predicts by max(AT_REST_FLOOR_RAD, AT_REST_SIGMAS σ), σ² = H P0 Hᵀ + R per component
(:func:`check_angles_at_rest`)."""


AT_REST_HINTS = {"heading": ", or, a magnetic compass, its declination_deg"}
"""A kind's own cause, added to :func:`check_angles_at_rest`'s list."""


def check_axes_at_rest(
    cfg: MissionConfig,
    coarse: CoarseInfo,
    lat: float,
    heading: float | None,
    heading_sigma: float | None,
    given: Mapping[str, Any],
) -> None:
    """A :class:`MissionError` naming the IMU file when the earth rate the gyros measured over
    the static window is not the one expected at its latitude and heading (engine/align.py
    :func:`~adaptnav.engine.align.axes_at_rest`; docs/robustness.md, 'IMU axes'): a flipped or
    swapped gyro axis, which no check on the IMU table alone sees. ``given``: where the heading
    came from (:func:`_given_heading`)."""
    found = axes_at_rest(coarse, lat, heading, heading_sigma)
    if found is None:
        return
    columns = imu_columns(cfg.imu.format)
    source = given.get("heading_from", "?")
    origin = f" The heading is from {source}." if found[0] == "horizontal" else ""
    field = {
        "accel": columns[5],
        "vertical": columns[2],
        "horizontal": f"{columns[0]}, {columns[1]}",
    }[found[0]]
    raise MissionError(
        f"{cfg.imu.file}: {found[1]}{origin} Fix the IMU table, or, if it is right, set "
        "imu.axis_check = false (docs/robustness.md, 'IMU axes')",
        file=cfg.imu.file,
        field=field,
    )


def check_angles_at_rest(
    cfg: MissionConfig,
    sensors: Mapping[str, SensorData],
    x0: np.ndarray,
    P0: np.ndarray,
    f_mean: np.ndarray,
    t_from: float,
    t0: float,
) -> None:
    """An inclinometer or heading sensor whose mean reading over the static alignment window
    disagrees with the aligned state (levelled by the accelerometers, the heading from the
    gyrocompass or the configuration) by more than max(2°, 10 σ), σ² = H P0 Hᵀ + R, is a
    :class:`MissionError` naming its file and column: degrees read as radians, a unit or sign
    slip, or a mounting (``mounting_rpy_deg``) not set. Such a sensor passes the plausibility
    limits when its angles are small, and the guard alone then rejects it until the lockout
    inflates P far enough to take it (docs/robustness.md, 'Angles at rest'). ``f_mean``: the
    window's mean specific force (body, m/s²), what a pendulum reads at rest."""
    for name, sc in cfg.sensors.items():
        if sc.kind not in AT_REST_KINDS or name not in sensors:
            continue
        d = sensors[name]
        inside = (d.t > t_from) & (d.t <= t0) & np.all(np.isfinite(d.z), axis=1)
        if not np.any(inside):
            continue
        model: Any = build_sensor_model(name, sc)
        args = (x0, f_mean) if isinstance(model, PendulumInclinometer) else (x0,)
        pred = np.asarray(model.predict(*args), dtype=float)
        H = np.asarray(model.jacobian(*args), dtype=float)[:, :N_STATES]
        mean = np.angle(np.mean(np.exp(1j * d.z[inside]), axis=0))
        diff = attitude.wrap_angle(mean - pred)
        sd = np.sqrt(np.einsum("ij,jk,ik->i", H, P0[:N_STATES, :N_STATES], H) + np.diag(model.R))
        tol = np.maximum(AT_REST_FLOOR_RAD, AT_REST_SIGMAS * sd)
        bad = np.flatnonzero(np.abs(diff) > tol)
        if bad.size:
            j = int(bad[0])
            column = KINDS[sc.kind].columns[j]
            row = int(d.rows[np.flatnonzero(inside)[0]])
            raise MissionError(
                f"{sc.file}, {column}: over the static alignment window ({int(inside.sum())} "
                f"readings from data row {row}) sensor {name!r} reads {mean[j]:.4g} rad on average "
                f"where the aligned IMU gives {pred[j]:.4g} rad, {math.degrees(diff[j]):+.3g}° "
                f"off (more than {math.degrees(tol[j]):.3g}°): degrees read as radians, a sign, "
                f"or a mounting_rpy_deg to set{AT_REST_HINTS.get(sc.kind, '')}?",
                file=sc.file,
                field=column,
            )


MOTION_SPAN_S = 5.0
MOTION_SIGMAS = 4.0
MOTION_FLOOR_M_S = 0.05
"""A DVL's mean over any MOTION_SPAN_S of the static alignment window above max(MOTION_FLOOR_M_S,
MOTION_SIGMAS σ/√k) (k readings in the span) on some axis is warned about
(:func:`check_motion_at_rest`)."""


def check_motion_at_rest(
    cfg: MissionConfig, sensors: Mapping[str, SensorData], t_from: float, t0: float
) -> None:
    """Warn (log) when a DVL says the vehicle moved inside the static alignment window: the
    mean of its readings over some :data:`MOTION_SPAN_S` stretch above max(MOTION_FLOOR_M_S,
    MOTION_SIGMAS σ/√k) on some axis. The alignment takes the vehicle at rest; a window that
    runs into the start of the motion (alignment_s too long) corrupts its levelling and heading
    without an error (docs/alignment.md; up to 0.4.8 nothing was said: the demo aligned to 620 s,
    0.1 m/s at its end, 6.8 m RMSE against 2.6 m). A warning, not an error: a vessel moored in
    a swell moves back and forth about rest, and its means over a few seconds need not vanish."""
    for name, sc in cfg.sensors.items():
        if sc.kind != "dvl" or name not in sensors:
            continue
        d = sensors[name]
        inside = (d.t > t_from) & (d.t <= t0) & np.all(np.isfinite(d.z), axis=1)
        t, z = d.t[inside], d.z[inside]
        if t.size < 2:
            continue
        ends = np.searchsorted(t, t + MOTION_SPAN_S, side="right")
        csum = np.vstack([np.zeros((1, z.shape[1])), np.cumsum(z, axis=0)])
        k = (ends - np.arange(t.size))[:, None]
        means = (csum[ends] - csum[: t.size]) / k
        sigma = np.broadcast_to(np.asarray(sc.sigma_si(), dtype=float), (z.shape[1],))
        tol = np.maximum(MOTION_FLOOR_M_S, MOTION_SIGMAS * sigma / np.sqrt(k))
        over = np.argwhere(np.abs(means) > tol)
        if over.size:
            i, j = (int(v) for v in over[0])
            log.warning(
                "%s, %s: sensor %r reads %+.3g m/s on average over %.3g s from data row %d "
                "(t = %.6g s) inside the static alignment window (to %.6g s), which takes the "
                "vehicle at rest: was it moving (initial.alignment_s too long)?",
                sc.file, KINDS[sc.kind].columns[j], name, means[i, j], MOTION_SPAN_S,
                int(d.rows[np.flatnonzero(inside)[i]]), t[i], t0,
            )  # fmt: skip


SURFACE_SIGMAS = 5.0
SURFACE_FLOOR_M = 2.0
"""A depth meter's water surface measured at rest may differ from its ``surface_h_m`` by
max(SURFACE_FLOOR_M, SURFACE_SIGMAS σ), σ² = σ_h,GNSS² + σ_depth² (:func:`check_depth_at_rest`;
the GNSS heights' errors are correlated over a window, so σ is one fix's, not the mean's)."""


@dataclass(frozen=True)
class SurfaceAtRest:
    """A depth meter's water surface as the static alignment window shows it
    (:func:`surfaces_at_rest`)."""

    sensor: str
    gnss: str
    h_m: float
    """The surface's height, in the GNSS heights' frame (ellipsoidal), m."""
    sigma_m: float
    depth_m: float
    """The meter's mean reading over the window."""
    readings: int
    row: int
    """The data row of its first reading in the window."""


def _height_gnss(cfg: MissionConfig) -> str | None:
    """The GNSS sensor whose heights give the static alignment its height
    (:func:`_alignment_position`): the first one not off, with ``use_height``, when ``[initial]``
    gives no position; else None."""
    g = _position_gnss(cfg) if cfg.initial.mode == "alignment" else None
    return g if g is not None and cfg.sensors[g].use_height else None


def surfaces_at_rest(
    cfg: MissionConfig, sensors: Mapping[str, SensorData], x0: np.ndarray, t_from: float, t0: float
) -> list[SurfaceAtRest]:
    """Each depth meter's water-surface height over the static window ``(t_from, t0]``, where
    GNSS heights give the alignment its height: the depth model ``z = h_s - h + (C_nb l_d)_D``
    (sensors/depth.py) at the GNSS antenna's mean height ``h_a = h - (C_nb l_g)_D`` gives
    ``h_s = mean(z) + mean(h_a) + (C_nb l_g)_D - (C_nb l_d)_D``, C_nb the aligned attitude.
    Empty without such a GNSS or without readings in the window."""
    g = _height_gnss(cfg)
    if g is None or g not in sensors:
        return []
    fixes = sensors[g]
    ok = (fixes.t > t_from) & (fixes.t <= t0) & np.isfinite(fixes.z[:, 2])
    if not np.any(ok):
        return []
    C = attitude.quat_to_dcm(x0[NOM_ATT])
    gc = cfg.sensors[g]
    h_imu = float(np.mean(fixes.z[ok, 2])) + float((C @ gc.lever_arm())[2])
    sd_h = float(np.atleast_1d(gc.sigma_si())[-1])
    out = []
    for name, sc in cfg.sensors.items():
        if sc.kind != "depth" or sc.use == "off" or name not in sensors:
            continue
        d = sensors[name]
        inside = (d.t > t_from) & (d.t <= t0) & np.isfinite(d.z[:, 0])
        if not np.any(inside):
            continue
        z = float(np.mean(d.z[inside, 0]))
        h_s = z + h_imu - float((C @ sc.lever_arm())[2])
        sd = math.hypot(sd_h, float(np.atleast_1d(sc.sigma_si())[0]))
        row = int(d.rows[np.flatnonzero(inside)[0]])
        out.append(SurfaceAtRest(name, g, h_s, sd, z, int(inside.sum()), row))
    return out


def check_depth_at_rest(
    cfg: MissionConfig, sensors: Mapping[str, SensorData], x0: np.ndarray, t_from: float, t0: float
) -> None:
    """A depth meter whose water surface, measured at rest against the GNSS heights
    (:func:`surfaces_at_rest`), lies more than max(2 m, 5 σ) from its ``surface_h_m`` (0 when
    not given) is a :class:`MissionError` naming its file, the GNSS and the height to set. GNSS
    heights are ellipsoidal and the sea's surface lies near the geoid, tens of metres off: the
    filter would otherwise fight the two sensors over that height for the whole run
    (docs/filters.md, 'Depth and the water surface'). ``"auto"`` is not checked: it is what
    is measured."""
    for s in surfaces_at_rest(cfg, sensors, x0, t_from, t0):
        sc = cfg.sensors[s.sensor]
        if sc.surface_h_m == "auto":
            continue
        given = sc.surface_h()
        tol = max(SURFACE_FLOOR_M, SURFACE_SIGMAS * s.sigma_m)
        if abs(s.h_m - given) > tol:
            gfile = cfg.sensors[s.gnss].file
            raise MissionError(
                f"{sc.file}, depth_m: over the static alignment window ({s.readings} readings "
                f"from data row {s.row}) sensor {s.sensor!r} reads {s.depth_m:.3g} m, which puts "
                f"the water surface at {s.h_m:.2f} m by the GNSS heights of {gfile}, not at "
                f"surface_h_m = {given:g} m (more than {tol:.3g} m off). GNSS heights are "
                "ellipsoidal and the sea's surface lies near the geoid (plus the tide): set "
                f'[sensors.{s.sensor}] surface_h_m = {s.h_m:.2f}, or "auto" to measure it so '
                "on every run",
                file=sc.file,
                field="depth_m",
            )


def resolve_surfaces(
    cfg: MissionConfig, sensors: Mapping[str, SensorData], x0: np.ndarray, t_from: float, t0: float
) -> tuple[MissionConfig, dict[str, float]]:
    """``cfg`` with every depth meter's ``surface_h_m = "auto"`` replaced by the height
    :func:`surfaces_at_rest` measures, and those heights by sensor; a :class:`MissionError`
    when one cannot be measured."""
    auto = [n for n, sc in cfg.sensors.items() if sc.surface_h_m == "auto"]
    if not auto:
        return cfg, {}
    found = {s.sensor: s.h_m for s in surfaces_at_rest(cfg, sensors, x0, t_from, t0)}
    for name in auto:
        if name not in found:
            raise MissionError(
                f'{CONFIG_NAME}: [sensors.{name}] surface_h_m = "auto" measures the water '
                'surface at rest: it needs a static alignment ([initial] mode = "alignment", '
                "no lat_deg/lon_deg) whose first GNSS sensor has use_height = true, and fixes "
                f"and readings of {name!r} inside the window; give the height instead",
                file=CONFIG_NAME,
                field=f"sensors.{name}.surface_h_m",
            )
    paths = [(f"sensors.{n}.surface_h_m", round(found[n], 3)) for n in auto]
    return with_overrides(cfg, paths, CONFIG_NAME), {n: found[n] for n in auto}


def _configured_state(
    cfg: MissionConfig, accel_sigma: float, gyro_sigma: float
) -> tuple[np.ndarray, np.ndarray]:
    """``initial.mode = "state"``: x0 and a diagonal P0 from ``[initial]`` and
    ``[imu.initial_bias]`` (docs/alignment.md)."""
    ini = cfg.initial
    assert ini.lat_deg is not None and ini.lon_deg is not None and ini.rpy_deg is not None
    roll, pitch, yaw = np.radians(ini.rpy_deg)
    x0 = NavState.from_euler(
        math.radians(ini.lat_deg), math.radians(ini.lon_deg), ini.h_m, ini.v_ned_m_s,
        roll, pitch, yaw,
    ).to_array()  # fmt: skip
    x0[NOM_BG], x0[NOM_BA] = cfg.imu.initial_bias.si()
    sig = np.zeros(N_STATES)
    sig[POS] = ini.sigma_position_m
    sig[VEL] = ini.sigma_velocity_m_s
    sig[ATT] = ini.sigma_attitude_rad()
    sig[BA] = accel_sigma
    sig[BG] = gyro_sigma
    return x0, np.diag(sig**2)


POSITION_SIGMAS = 10.0
POSITION_FLOOR_M = 50.0
"""A configured start position (``initial.lat_deg/lon_deg``) and the mean GNSS fix of the static
window must agree horizontally within max(POSITION_FLOOR_M, POSITION_SIGMAS σ), σ² =
``sigma_position_m``² + a fix's horizontal σ² (:func:`check_configured_position`)."""


def _window_fixes(g: SensorData, t_from: float, window_end: float) -> tuple[np.ndarray, int]:
    """The GNSS fixes ``g`` with finite values inside the static window ``[t_from,
    window_end]`` (a mask) and how many rows lie there at all."""
    window = (g.t >= t_from) & (g.t <= window_end)
    return window & np.all(np.isfinite(g.z), axis=1), int(window.sum())


def _mean_fix(g: SensorData, inside: np.ndarray) -> tuple[float, float]:
    """Mean latitude and circular-mean longitude (rad) of the fixes ``inside``."""
    lat = float(np.mean(g.z[inside, 0]))
    return lat, float(np.angle(np.mean(np.exp(1j * g.z[inside, 1]))))


def check_configured_position(
    cfg: MissionConfig, sensors: Mapping[str, SensorData], t_from: float, window_end: float
) -> None:
    """A configured start position (``initial.lat_deg/lon_deg``, which a static alignment takes
    instead of the GNSS fixes) more than max(POSITION_FLOOR_M, POSITION_SIGMAS σ) horizontally
    from the mean fix of the first GNSS sensor not off in the window is a :class:`MissionError`
    naming both: one of them is wrong, and up to 0.4.8 the configured one was taken without a
    word (a template's position 8000 km from the fixes: every row that far off, exit 0)."""
    ini, gnss = cfg.initial, cfg.first_sensor("gnss")
    if ini.lat_deg is None or ini.lon_deg is None or gnss is None or gnss not in sensors:
        return
    g, gc = sensors[gnss], cfg.sensors[gnss]
    inside, _ = _window_fixes(g, t_from, window_end)
    if not np.any(inside):
        return
    lat, lon = _mean_fix(g, inside)
    lat0, lon0 = math.radians(ini.lat_deg), math.radians(ini.lon_deg)
    hav = (
        math.sin((lat - lat0) / 2) ** 2
        + math.cos(lat) * math.cos(lat0) * math.sin((lon - lon0) / 2) ** 2
    )
    dist = 2.0 * earth.A * math.asin(min(1.0, math.sqrt(hav)))
    sd = math.hypot(ini.sigma_position_m, float(np.max(np.atleast_1d(gc.sigma_si())[:2])))
    tol = max(POSITION_FLOOR_M, POSITION_SIGMAS * sd)
    if dist > tol:
        row = int(g.rows[np.flatnonzero(inside)[0]])
        raise MissionError(
            f"{CONFIG_NAME}: initial.lat_deg, lon_deg = {ini.lat_deg:.6f}, {ini.lon_deg:.6f} is "
            f"{dist:.4g} m from the mean of the {int(inside.sum())} fixes of sensor {gnss!r} "
            f"({gc.file}, from data row {row}) in the static alignment window, "
            f"{math.degrees(lat):.6f}, {math.degrees(lon):.6f} (more than {tol:.3g} m): the "
            "alignment takes the configured position, so one of the two is wrong. Correct it, "
            "or drop initial.lat_deg/lon_deg to align at the fixes",
            file=CONFIG_NAME,
            field="initial.lat_deg",
        )


def _alignment_position(
    cfg: MissionConfig, sensors: Mapping[str, SensorData], t_from: float, window_end: float
) -> tuple[float, float, float]:
    """Where to align: the configured position (checked against the GNSS fixes in the window,
    :func:`check_configured_position`), else the mean of the first GNSS sensor's valid
    fixes inside the static window ``[t_from, window_end]`` (docs/alignment.md); an error naming
    the file if neither. Fixes before the IMU's first interval are not the vehicle at rest (up
    to 0.4.5 they were averaged in: a vessel's approach 2 km away moved the start 1.4 km). The
    longitude is the circular mean: alongside on the antimeridian, or with fixes written
    0..360° at Greenwich, the arithmetic mean of ±180° (or of 0 and 360°) is half the world off
    (up to 0.4.5: 6240 km, exit 0)."""
    ini = cfg.initial
    if ini.lat_deg is not None and ini.lon_deg is not None:
        check_configured_position(cfg, sensors, t_from, window_end)
        return (math.radians(ini.lat_deg), math.radians(ini.lon_deg), ini.h_m)
    gnss = _position_gnss(cfg)
    if gnss is None or gnss not in sensors:
        raise MissionError(
            f"{CONFIG_NAME}: alignment: no position to align at (initial.lat_deg/lon_deg, or a "
            "GNSS sensor with readings)",
            file=CONFIG_NAME,
        )
    g = sensors[gnss]
    inside, in_window = _window_fixes(g, t_from, window_end)
    if not np.any(inside):
        file = cfg.sensors[gnss].file
        raise MissionError(
            f"{file}: no valid fix of sensor {gnss!r} inside the static alignment window "
            f"({t_from:.6g} s <= t <= {window_end:.6g} s; {in_window} row(s) there, none "
            "finite and plausible), and no initial.lat_deg/lon_deg to align at",
            file=file,
            field=gnss,
        )
    lat, lon = _mean_fix(g, inside)
    if not abs(lat) <= earth.MAX_LAT_RAD:
        file = cfg.sensors[gnss].file
        raise MissionError(
            f"{file}: the fixes of sensor {gnss!r} in the alignment window are at latitude "
            f"{math.degrees(lat):.6f}°, within {90.0 - earth.MAX_LAT_DEG:g}° of a pole, where the "
            "latitude-longitude mechanization is singular (docs/conventions.md)",
            file=file,
            field="lat_rad",
        )
    h = float(np.mean(g.z[inside, 2])) if g.z.shape[1] > 2 else ini.h_m
    return (lat, lon, h)


def mission_folder(root: str | Path) -> str:
    """The mission folder a run records (``meta.mission_dir``), absolute: evaluate and export
    find the mission from any working folder (up to 0.4.7 it was recorded as typed, and a
    relative one found nothing, or a folder of the same name, from another folder)."""
    return str(Path(root).resolve())


SIMULATION_DIGEST_KEY = "simulation_sha256"
"""``meta`` key of a run: the SHA-256 of its mission's ``simulation.json`` (the simulator's true
errors, which ``evaluate`` and ``report`` score the calibration states against) when it has one."""


def simulation_digest(root: str | Path) -> dict[str, str]:
    """``{SIMULATION_DIGEST_KEY: hex}`` of the mission folder ``root``'s ``simulation.json``, or
    empty without one (a real mission): a re-simulated mission (``simulate --force`` into the
    same folder) or another simulation of the same name is then told from the run's own
    (:func:`adaptnav.analysis.calibration.simulation_truth`)."""
    path = Path(root) / SIMULATION_FILE
    if not path.is_file():
        return {}
    return {SIMULATION_DIGEST_KEY: str(file_digest(path)["sha256"])}


def check_initial(
    initial: Any, t_from: float = -math.inf, t_to: float = math.inf
) -> tuple[np.ndarray, np.ndarray, float]:
    """A given ``initial = (x0, P0, t0)`` as arrays, checked: x0 the nominal state (at least
    :data:`NOM_SIZE` numbers), P0 (at least :data:`N_STATES` square), both finite, P0's diagonal
    positive, t0 finite and within ``[t_from, t_to]`` (the IMU's span). ValueError naming what is
    wrong (up to 0.4.4: a NaN P0 ran with every reading rejected, a NaN or late t0 gave a
    solution of one row, a wrong shape a broadcast error from deep inside)."""
    try:
        x0, P0, t0 = initial
    except (TypeError, ValueError):
        raise ValueError(f"initial: expected (x0, P0, t0), got {initial!r:.80}") from None
    x = np.asarray(x0, dtype=float).ravel()
    P = np.asarray(P0, dtype=float)
    t = float(t0)
    if x.size < NOM_SIZE or not np.all(np.isfinite(x)):
        raise ValueError(f"initial x0: {x.size} values, at least {NOM_SIZE} finite ones needed")
    if P.ndim != 2 or P.shape[0] != P.shape[1] or P.shape[0] < N_STATES:
        raise ValueError(f"initial P0: shape {P.shape}, a square of at least {N_STATES} needed")
    if not (np.all(np.isfinite(P)) and np.all(np.diag(P) > 0.0)):
        raise ValueError("initial P0: every element finite and the diagonal > 0 needed")
    _check_covariance(P)
    if not abs(x[0]) <= earth.MAX_LAT_RAD:
        raise ValueError(
            f"initial x0: latitude {math.degrees(x[0]):.6f}° is not within ±{earth.MAX_LAT_DEG:g}° "
            "(the mechanization is singular at the poles)"
        )
    if not (math.isfinite(t) and t_from <= t <= t_to):
        raise ValueError(f"initial t0: {t!r} s is not within the IMU's span [{t_from}, {t_to}] s")
    return x, P, t


def _check_covariance(P: np.ndarray) -> None:
    """P0 must be a covariance: symmetric (to 1e-9 of its scale) and positive definite (a
    Cholesky factor exists). Up to 0.4.5 an asymmetric or indefinite P0 ran, the smoother then
    failed on every node and every NEES was NaN. ValueError otherwise."""
    scale = np.sqrt(np.outer(np.diag(P), np.diag(P)))
    if not np.all(np.abs(P - P.T) <= 1e-9 * scale):
        i, j = np.unravel_index(int(np.argmax(np.abs(P - P.T) / scale)), P.shape)
        raise ValueError(f"initial P0: not symmetric (P0[{i}, {j}] = {P[i, j]!r}, P0[{j}, {i}] = "
                         f"{P[j, i]!r})")  # fmt: skip
    try:
        np.linalg.cholesky(P / scale)
    except np.linalg.LinAlgError:
        raise ValueError("initial P0: not positive definite (no Cholesky factor)") from None


def check_arguments(
    mission: object, *, smooth: object = False, epoch_policy: object = None
) -> None:
    """The arguments of :func:`run` (and ``compare``) whose wrong type would be taken silently
    or fail deep inside: ``smooth`` must be a bool (the string "no" is true), ``mission`` a
    Mission or a path, ``epoch_policy`` None, "exact" or "grid". TypeError / ValueError naming
    the argument."""
    if not isinstance(mission, Mission | str | os.PathLike):
        raise TypeError(f"mission: a Mission or a mission folder, not {type(mission).__name__}")
    if not isinstance(smooth, bool | np.bool_):
        raise TypeError(f"smooth: True or False, not {smooth!r}")
    if epoch_policy is not None and epoch_policy not in get_args(engine.EpochPolicy):
        raise ValueError(f"epoch_policy: {epoch_policy!r} is not 'exact' or 'grid'")


def run(
    mission: Mission | str | Path,
    filter: FilterKind | None = None,
    *,
    settings: FilterSettings | None = None,
    epoch_policy: engine.EpochPolicy | None = None,
    initial: tuple[np.ndarray, np.ndarray, float] | None = None,
    imu_noise: ImuNoise | None = None,
    smooth: bool = False,
    progress: engine.Progress | None = None,
) -> Result:
    """Run one filter on a mission and return its :class:`~adaptnav.api.results.Result`.

    Args:
        mission: a loaded :class:`~adaptnav.mission.Mission` or its folder.
        filter: ``"robust"``, ``"meskf"``, ``"maeskf"``, ``"vb"`` or ``"oracle"`` (a
            simulated mission's limit: true per-reading R, known outliers dropped;
            :mod:`adaptnav.api.oracle`); default: the mission's ``filter.kind``.
        settings: filter settings overriding the mission's ``[filter]`` section.
        epoch_policy: ``"exact"`` or ``"grid"``; default: the mission's.
        initial: (x0, P0, t0) to start from instead of the mission's ``[initial]`` (e.g. to
            share one alignment between filters).
        imu_noise: the IMU noise model for the engine's process noise Q (docs/filters.md,
            'Error-state model') instead of the mission's ``[imu.noise]`` (e.g. to scale the
            gyro-bias Q, the paper's Fig. 6, without touching the mission); the alignment of
            ``initial_state`` keeps the mission's.
        smooth: also run the RTS backward pass (docs/smoothing.md): the result's ``solution``
            is the smoothed one and ``forward`` the filter's.
        progress: called with each step as it begins: ``"aligning"`` (unless ``initial`` is
            given or the mission starts from a configured state), ``"filtering"``,
            ``"smoothing"`` (:data:`adaptnav.engine.batch.Phase`); it does not change the run.
    """
    check_arguments(mission, smooth=smooth, epoch_policy=epoch_policy)
    m = mission if isinstance(mission, Mission) else load_mission(mission)
    cfg = m.config
    s = settings if settings is not None else cfg.filter_settings()
    if filter is not None:
        s = s.with_kind(filter)
    policy = epoch_policy or cfg.filter.epoch_policy
    noise = imu_noise if imu_noise is not None else cfg.imu.noise.to_imu_noise()

    started = time.perf_counter()
    if initial is None and cfg.initial.mode != "state" and progress is not None:
        progress("aligning")
    if initial is not None:
        x0, P0, t0 = check_initial(initial, float(m.imu.t[0] - m.imu.dt[0]), float(m.imu.t[-1]))
        init_info: dict[str, Any] = {"initial": "given"}
    else:
        x0, P0, t0, init_info = initial_state(m)
    cfg, surfaces = resolve_surfaces(cfg, m.sensors, x0, float(m.imu.t[0] - m.imu.dt[0]), t0)
    if surfaces:
        m, init_info = replace(m, config=cfg), {**init_info, "surface_h_m": surfaces}
    states = calibration.calibration_states(cfg)
    x0, P0 = calibration.extend(x0[:NOM_SIZE], P0[:N_STATES, :N_STATES], states)
    feed = _feed(m, s, t0, states, initial is None and cfg.initial.mode != "state")
    nav_from = int(np.searchsorted(m.imu.t, t0 + 1e-9, side="left"))
    config = engine_config(cfg, s, policy, noise, states, smooth)
    out = _run_engine(m, s.kind, config, feed, (x0, P0, t0), nav_from, progress)
    elapsed = time.perf_counter() - started
    out, ledger = _with_file_rows(out, m, feed)
    imu_samples = int(m.imu.t.size - nav_from)
    meta: dict[str, Any] = {
        "mission_dir": mission_folder(m.root),
        **simulation_digest(m.root),
        "adaptnav_version": __version__,
        "filter_settings": s.as_dict(),
        "epoch_policy": policy,
        "engine": engine_meta(config),
        **(
            {"oracle_nominal_R": [n for n, o in feed.known.items() if o.r_diag is None]}
            if s.kind == "oracle"
            else {}
        ),
        "imu_samples": imu_samples,
        "q_scale_final": out.q_scale,
        "elapsed_s": elapsed,
        "imu_samples_per_s": imu_samples / elapsed if elapsed > 0 else math.nan,
        **init_info,
    }
    kinds: Mapping[str, str] = {n: c.kind for n, c in cfg.sensors.items()}
    repairs = [r.__dict__ for r in m.repairs]
    result = Result.from_engine(out, s.kind, cfg.mission.name, meta, repairs, kinds, ledger=ledger)
    result = with_warnings(result, feed.channels)
    return _with_calibration(result, states, m.sensors) if states else result


def _with_calibration(
    result: Result,
    states: tuple[calibration.CalibrationState, ...],
    sensors: Mapping[str, SensorData],
) -> Result:
    """``result`` with ``meta.calibration`` (:func:`_calibration`) and, in ``meta.warnings``,
    the sensors whose calibration scores are correlated (diagnosis.calibration_correlated)."""
    found = _calibration(states, result.solution, result.ledger, sensors)
    factors = [
        (st.sensor, name, found[name]["long_run_factor"]) for st in states for name in st.names
    ]
    flagged = [w.as_dict() for w in calibration_correlated(factors)]
    return replace(
        result,
        meta={
            **result.meta,
            "calibration": found,
            "warnings": [*result.meta.get("warnings", []), *flagged],
        },
    )


def engine_meta(config: engine.EngineConfig) -> dict[str, Any]:
    """The engine's settings that a mission may set and a run's ``summary.json`` records, beside
    the filter's: F's specific-force low-pass, the covariance blocks and the reset
    (docs/filters.md)."""
    return {
        "specific_force_tau_s": config.specific_force_tau_s,
        "covariance_block_s": config.covariance_block_s,
        "reset": {
            errorstate.RESET_OFF: "off",
            errorstate.RESET_ATTITUDE: "attitude",
            errorstate.RESET_INVARIANT: "invariant",
        }[config.reset_mode],
    }


def engine_config(
    cfg: MissionConfig,
    s: FilterSettings,
    policy: engine.EpochPolicy,
    noise: ImuNoise,
    states: tuple[calibration.CalibrationState, ...],
    smooth: bool = False,
) -> engine.EngineConfig:
    """The engine's settings for filter ``s`` on a mission configured by ``cfg``: Q from
    ``noise``, the epoch policy, the output rate, the divergence guard, Q adaptation, the state
    layout with the calibration states, F's specific-force low-pass, the covariance blocks and the
    reset if configured."""
    config = engine.EngineConfig(
        noise, policy, output_every=cfg.output_every(), divergence=s.divergence_guard(),
        q_adaptation=s.q_adaptation, smooth=smooth, layout=calibration.layout(states),
    )  # fmt: skip
    if cfg.filter.specific_force_tau_s is not None:
        config = replace(config, specific_force_tau_s=cfg.filter.specific_force_tau_s)
    if cfg.filter.covariance_block_s is not None:
        config = replace(config, covariance_block_s=cfg.filter.covariance_block_s)
    if cfg.filter.invariant_reset is not None:
        config = replace(config, invariant_reset=cfg.filter.invariant_reset)
    return config


def _calibration(
    states: tuple[calibration.CalibrationState, ...],
    solution: pd.DataFrame,
    ledger: pd.DataFrame,
    sensors: Mapping[str, SensorData],
) -> dict[str, dict[str, Any]]:
    """Each calibration state's estimate and σ at the end of the run (smoothed: the whole
    run's), with its prior σ, in its report unit, and the correlation time of a Gauss-Markov
    quantity (``tau_s``; None for a random walk) (docs/calibration.md; ``calibration.json``),
    and the σ allowing for the correlation of its sensor's readings: ``sigma_long_run = σ
    sqrt(max(1, F))``, F the long-run variance factor (:func:`_long_run_factor`; None, and so
    ``sigma_long_run``, where it cannot be told)."""
    out: dict[str, dict[str, Any]] = {}
    last = solution.iloc[-1]
    for st in states:
        f = st.quantity.factor
        factors = _long_run_factor(st, ledger, sensors[st.sensor])
        for name, lrv in zip(st.names, factors, strict=True):
            sigma = float(last[f"sd_{name}"]) * f
            known = math.isfinite(lrv)
            out[name] = {
                "estimate": float(last[name]) * f,
                "sigma": sigma,
                "sigma_long_run": sigma * math.sqrt(max(1.0, lrv)) if known else None,
                "long_run_factor": lrv if known else None,
                "prior_sigma": st.sigma * f,
                "tau_s": st.tau if math.isfinite(st.tau) else None,
                "unit": st.quantity.unit,
            }
    return out


def _long_run_factor(
    st: calibration.CalibrationState, ledger: pd.DataFrame, data: SensorData
) -> list[float]:
    """Per state of ``st``, the long-run variance factor F (estimation.long_run.variance_factor)
    of its score over the sensor's used readings, ``g_k = Σ_j h_kj ν_kj / r_kj``: h the state's
    regressor at reading k (sensors.calibration.regressors), ν the innovation and r the R the
    filter used (docs/calibration.md, 'Correlated readings'). The filter's σ takes the g_k as
    uncorrelated; F is by how much the variance of their sum exceeds that. NaN where the
    regressor or the readings are unknown."""
    used = ledger[(ledger["sensor"] == st.sensor) & (ledger["fate"] == "used")]
    file_rows = used["row"].to_numpy(dtype=np.int64)
    idx = np.clip(np.searchsorted(data.rows, file_rows), 0, max(len(data.rows) - 1, 0))
    if len(data.rows) == 0 or not np.array_equal(data.rows[idx], file_rows):
        return [math.nan] * len(st.names)
    d = data.z.shape[1]
    nu = used[[f"nu_{j}" for j in range(d)]].to_numpy(dtype=float)
    r = used[[f"r_{j}" for j in range(d)]].to_numpy(dtype=float)
    hook = KINDS[data.kind].reading_rate
    rate = None if hook is None or idx.size < 3 else hook(data.z[idx], data.t[idx])
    hs = calibration_regressors(st.quantity, data.z[idx], rate)
    if hs is None:
        return [math.nan] * len(st.names)
    w = nu / np.where(r > 0.0, r, np.nan)
    return [variance_factor(np.sum(h * w, axis=1)) for h in hs]


@dataclass(frozen=True)
class _Feed:
    """What the engine is fed from a mission, and the fates of the readings it is not."""

    channels: list[engine.SensorChannel]
    readings: dict[str, tuple[np.ndarray, ...]]
    kept: dict[str, np.ndarray]
    """Per aiding sensor: which of its loaded readings reach the engine."""
    extra: list[pd.DataFrame]
    """Ledger tables (:func:`adaptnav.api.results.dropped_ledger`) of the readings that never
    reach it, in the order they were found."""
    known: dict[str, oracle.OracleNoise]
    """The oracle's true noise per sensor (empty for every other kind)."""


def _feed(
    m: Mission,
    s: FilterSettings,
    t0: float,
    states: tuple[calibration.CalibrationState, ...],
    aligned: bool,
) -> _Feed:
    """The channels and readings of the aiding sensors after the navigation start ``t0``;
    every other reading (dropped at load, of a sensor off or used only to initialise, inside
    the alignment or before a given start (``aligned`` False: :func:`start_reasons`), or a
    known outlier for the oracle) gets its ledger row with the reason."""
    cfg = m.config
    init_reason, before_reason = start_reasons(aligned)
    d = m.dropped
    extra = [
        dropped_ledger([r.sensor for r in d], [r.row for r in d], [r.t for r in d],
                       [r.reason for r in d])
    ]  # fmt: skip
    for name, data in m.off.items():
        extra.append(dropped_ledger(name, data.rows, data.t, OFF_REASON))
    aiding = [n for n in m.sensors if cfg.sensors[n].use == "aid"]
    known = oracle.mission_noise(m, aiding) if s.kind == "oracle" else {}
    periods, kept = {}, {}
    readings: dict[str, tuple[np.ndarray, ...]] = {}
    for name, data in m.sensors.items():
        scfg = cfg.sensors[name]
        if scfg.use != "aid":
            why = init_reason if scfg.use == "init" else OFF_REASON
            extra.append(dropped_ledger(name, data.rows, data.t, why))
            continue
        early = data.t < m.imu.start
        before = (data.t <= t0) & ~early
        for mask, why in ((early, engine.BEFORE_IMU_REASON), (before, before_reason)):
            extra.append(dropped_ledger(name, data.rows[mask], data.t[mask], why))
        keep = data.t > t0
        if name in known:
            out = keep & known[name].outlier
            extra.append(dropped_ledger(name, data.rows[out], data.t[out], oracle.OUTLIER_REASON))
            keep &= ~out
        kept[name] = keep
        r_diag = known[name].r_diag if name in known else None
        readings[name] = (
            (data.t[keep], data.z[keep])
            if r_diag is None
            else (data.t[keep], data.z[keep], r_diag[keep])
        )
        periods[name] = data.period
    return _Feed(sensor_channels(cfg, s, periods, states), readings, kept, extra, known)


def sensor_channels(
    cfg: MissionConfig,
    s: FilterSettings,
    periods: Mapping[str, float],
    states: tuple[calibration.CalibrationState, ...],
) -> list[engine.SensorChannel]:
    """The engine channels of the aiding sensors ``periods`` names (in its order, with their
    nominal periods, s): each sensor's model (``[sensors.<name>]``, its calibration states)
    with the filter's R strategy, gate and guard (engine/channels.py)."""
    sensors = [
        # A single-sample table has no median interval; its period matters only to VB's
        # irregular-rate variant, where one sample makes it moot.
        (
            build_sensor_model(n, cfg.sensors[n], calibration.indices(states, n)),
            p if math.isfinite(p) else 1.0,
        )
        for n, p in periods.items()
    ]
    overrides = {n: cfg.sensors[n].overrides() for n in periods}
    return build_channels(s, sensors, overrides)


def _run_engine(
    m: Mission,
    kind: str,
    config: engine.EngineConfig,
    feed: _Feed,
    start: tuple[np.ndarray, np.ndarray, float],
    nav_from: int,
    progress: engine.Progress | None,
) -> engine.EngineOutput:
    """The engine over the IMU samples after the start; a numerical breakdown, or a navigation
    that reached a pole, is a :class:`FilterError` naming the mission, not a traceback
    (docs/robustness.md)."""
    x0, P0, t0 = start
    imu = m.imu
    try:
        return engine.run_batch(
            config, feed.channels, x0, P0, t0, imu.t[nav_from:], imu.dt[nav_from:],
            imu.dtheta[nav_from:], imu.dvel[nav_from:], feed.readings, progress,
            imu.holes.after(nav_from) if len(imu.holes) else None,
        )  # fmt: skip
    except engine.PoleError as exc:
        raise FilterError(f"{m.root / CONFIG_NAME}: the {kind} filter stopped: {exc}",
                          file=CONFIG_NAME) from None  # fmt: skip
    except np.linalg.LinAlgError as exc:
        raise FilterError(
            f"{m.root / CONFIG_NAME}: the {kind} filter broke down: {exc}. A reading far from "
            "what the filter predicts, or a sensor sigma far from the truth, near that time: "
            "check the readings, their units and [sensors.<name>] sigma / limits "
            "(docs/robustness.md)",
            file=CONFIG_NAME,
        ) from None


def _with_file_rows(
    out: engine.EngineOutput, m: Mission, feed: _Feed
) -> tuple[engine.EngineOutput, pd.DataFrame]:
    """The engine's events with rows of the files instead of its own reading indices, and the
    ledger table: the engine's rows so mapped, then the rows that never reached it; every
    reading keeps its fate."""
    rows_of = {name: m.sensors[name].rows[feed.kept[name]] for name in feed.readings}
    ledger = ledger_frame(out.ledger)
    sensor, row = ledger["sensor"].to_numpy(), ledger["row"].to_numpy(copy=True)
    for name, rows in rows_of.items():
        at = np.flatnonzero((sensor == name) & (row >= 0))
        row[at] = rows[row[at]]
    ledger["row"] = row
    tables = [t for t in (ledger, *feed.extra) if len(t)]
    if len(tables) > 1:
        ledger = pd.concat(tables, ignore_index=True)
    elif tables:
        ledger = tables[0]

    holes = m.imu.holes
    hole_ends = m.imu.t[holes.index]

    def file_row(rec: dict[str, Any]) -> dict[str, Any]:
        if rec["sensor"] in rows_of and rec["row"] >= 0:
            return {**rec, "row": int(rows_of[rec["sensor"]][rec["row"]])}
        if rec["event"] == engine.HOLE_EVENT:  # the IMU file's row after the hole
            j = min(int(np.searchsorted(hole_ends, rec["t"])), len(holes) - 1)
            return {**rec, "row": int(holes.row[j])}
        return rec

    # Events name the reading that triggered them: the same mapping.
    return replace(out, events=[file_row(e) for e in out.events]), ledger
