"""The paper's sea trials as simulated missions, and :func:`simulate` that writes them.

Presets (docs/simulation.md; Davari & Gholami 2019, §3 and Table 3), near Qeshm island (26.8° N,
56.0° E, sea level), each starting with 10 minutes alongside (static, calm: the alignment):

* ``paper-1``: a round trip of ≈ 23 km in ≈ 183 min (the mission length, static window
  included), at ≈ 2.3 m/s with course changes and a 180° turn at the far end, a rougher patch
  of sea in the middle, back alongside at the end;
* ``paper-2``: a mostly straight run of ≈ 9.63 km in ≈ 83 min with a few small course
  corrections;
* ``demo``: 10 min alongside then 5 min under way with a turn (quick checks, not the paper's).

The trajectory (and its waves) is fixed per preset; the seed drives every error, so Monte Carlo
runs share the track and differ in noise, biases, outliers, segments and clocks. Each error
source has its own random stream (``np.random.SeedSequence(seed).spawn``), so switching one
disturbance off leaves the others' realisations unchanged.

The mission written (docs/data-format.md, docs/simulation.md):

* ``imu.parquet``: increments at 100 Hz (``Δθ, Δv`` over (t_{k-1}, t_k], t_k = k/100 s) from
  :func:`adaptnav.sim.kinematics.imu_increments` (exact) corrupted by
  :mod:`adaptnav.sim.imu_model`;
* ``dvl``, ``depth``, ``inclinometer`` (use ``aid``), ``gps`` (use ``init``), ``heading`` (use
  ``off``) tables by :mod:`adaptnav.sim.sensors`, with the injected truth in extra columns,
  and one (use ``aid``) per :attr:`Scenario.extra_sensors`;
* ``truth.parquet`` at 10 Hz, with the true biases and the sea-state level as extra columns;
* ``mission.toml``: alignment over the static window, position from the GPS fixes in it,
  heading from the quay's charted bearing (σ 1°, :attr:`Scenario.initial_heading_sigma`), the
  IMU noise model and the *residual* turn-on σ as ``imu.initial_bias_sigma`` (what the
  alignment can calibrate: :mod:`adaptnav.sim.imu_model`), every sensor's nominal σ;
* ``simulation.json``: seed, switches, the realised turn-on biases and scale factors, the
  given heading's error, the DVL's segments, dropouts and outlier counts, clock offsets, and
  the sensors' true calibration errors when there are some (``calibration``;
  docs/simulation.md, 'Calibration errors').
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.core import attitude, earth
from adaptnav.core.formats import SIMULATION_FILE
from adaptnav.core.units import DEG, G0, si_unit
from adaptnav.mission import MissionConfig, parse_config, write_mission
from adaptnav.sensors.registry import KINDS
from adaptnav.sim import imu_model, kinematics, sensors
from adaptnav.sim import trajectory as tr
from adaptnav.sim.imu_model import PAPER_IMU, ImuErrorModel, ImuErrors
from adaptnav.sim.sensors import (
    Calibration,
    DepthSpec,
    Disturbances,
    DvlSpec,
    GenericSpec,
    GpsSpec,
    HeadingSpec,
    InclinometerSpec,
    Truth,
)

Array = NDArray[np.float64]

__all__ = [
    "PRESETS",
    "Calibration",
    "Disturbances",
    "GenericSpec",
    "Scenario",
    "SimulatedMission",
    "generate",
    "paper_1",
    "paper_2",
    "sensor_tables",
    "simulate",
    "simulate_scenario",
    "table_hashes",
]

QESHM = (26.8 * DEG, 56.0 * DEG)
"""Start point of the presets (rad): near Qeshm island, Persian Gulf."""

NOMINAL_WAVES = tr.Waves(
    roll=(tr.WaveComponent(3.0 * DEG, 7.3, 0.0), tr.WaveComponent(1.0 * DEG, 5.4, 1.1)),
    pitch=(tr.WaveComponent(1.2 * DEG, 6.1, 0.4), tr.WaveComponent(0.5 * DEG, 9.2, 2.0)),
    yaw=(tr.WaveComponent(0.6 * DEG, 8.3, 0.7),),
    heave=(tr.WaveComponent(0.30, 6.7, 0.0), tr.WaveComponent(0.12, 9.6, 1.3)),
    horizontal=(
        tr.WaveComponent(0.15, 6.7, 0.5 * math.pi),
        tr.WaveComponent(0.06, 9.6, 1.3 + 0.5 * math.pi),
    ),
    direction=40.0 * DEG,
)
"""Waves at sea-state level 1: a moderate sea (≈ 0.6 m significant height), periods 5-10 s;
roll 3° + 1°, pitch 1.2° + 0.5°, yaw 0.6°, heave 0.3 m + 0.12 m, horizontal (orbital) motion
0.15 m + 0.06 m (about half the water particles' orbit: the hull does not follow it fully)."""


@dataclass(frozen=True)
class Scenario:
    """Everything a simulated mission is made of (besides the seed and the switches).

    Attributes:
        name, description: the mission's name and a line about it.
        trajectory: the track, sea state and waves.
        imu: the IMU error model with the *uncompensated* turn-on offsets (Table 2).
        calibrated_imu: the same after the pre-mission calibration (residual turn-on σ): what
            the simulator applies unless ``Disturbances.imu_uncalibrated_turn_on``.
        imu_rate_hz, truth_rate_hz: rates of the IMU and truth tables.
        dvl, depth, inclinometer, heading, gps: the sensors.
        extra_sensors: registered kinds without a function of their own in
            :mod:`adaptnav.sim.sensors`, simulated from their declarations (``ideal_reading``
            plus white noise) and written with ``use = "aid"``; none in the presets.
        cruise_speed: speed (m/s) at which the DVL's nominal σ is written to the config.
        initial_heading_sigma: σ (rad) of the heading written to ``[initial]`` (the quay's
            bearing; the alignment uses it if the gyrocompass is worse); None: none written.
        paper_distance, paper_duration: the paper's figures (m, s) for comparison.
    """

    name: str
    description: str
    trajectory: tr.TrajectorySpec
    imu: ImuErrorModel = PAPER_IMU
    calibrated_imu: ImuErrorModel = field(default_factory=PAPER_IMU.calibrated)
    imu_rate_hz: float = 100.0
    truth_rate_hz: float = 10.0
    dvl: DvlSpec = field(default_factory=DvlSpec)
    depth: DepthSpec = field(default_factory=DepthSpec)
    inclinometer: InclinometerSpec = field(default_factory=InclinometerSpec)
    heading: HeadingSpec = field(default_factory=HeadingSpec)
    gps: GpsSpec = field(default_factory=GpsSpec)
    extra_sensors: tuple[GenericSpec, ...] = ()
    cruise_speed: float = 2.3
    initial_heading_sigma: float | None = 1.0 * DEG
    paper_distance: float | None = None
    paper_duration: float | None = None


# --- presets ---------------------------------------------------------------------------------


def paper_1() -> Scenario:
    """Trajectory No. 1: round trip ≈ 23 km, ≈ 183 min (module docstring)."""
    S, T, R = tr.Straight, tr.Turn, DEG
    segments: tuple[tr.Segment, ...] = (
        tr.Static(600.0),
        S(300.0, 1.5),
        T(35 * R, rate=1.0 * R),
        S(1150.0, 2.2),
        T(-20 * R),
        S(2030.0, 2.35),
        T(10 * R),
        S(1480.0),
        T(180 * R, rate=1.5 * R, speed=1.8),
        S(1480.0, 2.35),
        T(-10 * R),
        S(2030.0),
        T(20 * R),
        S(1150.0, 2.2),
        T(-35 * R, rate=1.0 * R, speed=1.5),
        S(240.0),
        tr.Static(186.0),
    )
    sea = (
        tr.SeaState(600.0, 0.5, 180.0),
        tr.SeaState(1200.0, 1.0, 300.0),
        tr.SeaState(4200.0, 1.6, 300.0),
        tr.SeaState(6300.0, 1.0, 300.0),
        tr.SeaState(10200.0, 0.4, 300.0),
    )
    spec = tr.TrajectorySpec(
        QESHM[0], QESHM[1], 0.0, 125.0 * DEG, segments, NOMINAL_WAVES, sea,
        list_trim=(0.4 * DEG, 0.3 * DEG),
    )  # fmt: skip
    return Scenario(
        "paper-1",
        "Simulated sea trial No. 1 (Davari & Gholami 2019): round trip near Qeshm island",
        spec,
        paper_distance=23e3,
        paper_duration=183 * 60.0,
    )


def paper_2() -> Scenario:
    """Trajectory No. 2: mostly straight ≈ 9.63 km, ≈ 83 min (module docstring)."""
    S, T, R = tr.Straight, tr.Turn, DEG
    segments: tuple[tr.Segment, ...] = (
        tr.Static(600.0),
        S(300.0, 1.8),
        T(8 * R, rate=0.5 * R),
        S(1500.0, 2.35),
        T(-12 * R, rate=0.5 * R),
        S(1400.0),
        T(6 * R, rate=0.5 * R),
        S(830.0),
        S(180.0, 1.0),
        tr.Static(120.0),
    )
    sea = (
        tr.SeaState(600.0, 0.6, 180.0),
        tr.SeaState(1300.0, 1.0, 300.0),
        tr.SeaState(2800.0, 1.4, 300.0),
        tr.SeaState(3800.0, 1.0, 300.0),
    )
    spec = tr.TrajectorySpec(
        QESHM[0], QESHM[1], 0.0, 250.0 * DEG, segments, NOMINAL_WAVES, sea,
        list_trim=(-0.3 * DEG, 0.5 * DEG),
    )  # fmt: skip
    return Scenario(
        "paper-2",
        "Simulated sea trial No. 2 (Davari & Gholami 2019): straight run near Qeshm island",
        spec,
        paper_distance=9.63e3,
        paper_duration=83 * 60.0,
    )


def demo() -> Scenario:
    """10 min alongside, then 5 min under way with a 90° turn (not one of the paper's)."""
    S, T, R = tr.Straight, tr.Turn, DEG
    segments: tuple[tr.Segment, ...] = (
        tr.Static(600.0),
        S(120.0, 2.0),
        T(90 * R, rate=1.5 * R),
        S(110.0),
    )
    sea = (tr.SeaState(600.0, 1.0, 120.0),)
    spec = tr.TrajectorySpec(
        QESHM[0], QESHM[1], 0.0, 30.0 * DEG, segments, NOMINAL_WAVES, sea,
        list_trim=(0.4 * DEG, 0.3 * DEG),
    )  # fmt: skip
    return Scenario("demo", "Short demonstration mission (not the paper's)", spec)


PRESETS: dict[str, Callable[[], Scenario]] = {
    "paper-1": paper_1,
    "paper-2": paper_2,
    "demo": demo,
}
"""Preset name → scenario factory."""


# --- generation ------------------------------------------------------------------------------

_STREAMS = (
    "imu",
    "dvl_clock",
    "dvl_noise",
    "dvl_segments",
    "dvl_outliers",
    "dvl_dropouts",
    "depth_clock",
    "depth_noise",
    "inclinometer_clock",
    "inclinometer_noise",
    "heading_clock",
    "heading_noise",
    "gps_clock",
    "gps_noise",
    "initial_heading",
)
"""Independent random streams, one per error source (order fixed: part of reproducibility)."""


@dataclass(frozen=True, eq=False)
class SimulatedMission:
    """A generated mission in memory: the config, the tables (keyed as ``write_mission``
    wants them), the realised IMU errors and the metadata saved as ``simulation.json``."""

    config: MissionConfig
    tables: dict[str, pd.DataFrame]
    imu_errors: ImuErrors
    trajectory: tr.Trajectory
    meta: dict[str, Any]


def _truth_at(traj: tr.Trajectory, t: Array, waves: bool) -> Truth:
    k = kinematics.true_kinematics(traj.motion, t)
    x = kinematics.true_states(traj.motion, t)
    lev = traj.sea_state.value(t) if waves else np.zeros_like(t)
    return Truth(t, x, k.omega_ib_b, k.f_b, lev)


def _config(
    sc: Scenario,
    imu: ImuErrorModel,
    static_end: float,
    heading_deg: float | None,
    description: str,
    pendulum: bool = True,
) -> MissionConfig:
    """The simulated mission's ``mission.toml`` (module docstring; docs/data-format.md)."""
    initial: dict[str, Any] = {
        "mode": "alignment",
        "alignment_s": static_end,
        "sigma_position_m": 3.0,
        "sigma_velocity_m_s": 0.05,
    }
    if heading_deg is not None and sc.initial_heading_sigma is not None:
        initial["rpy_deg"] = [0.0, 0.0, heading_deg]
        initial["sigma_attitude_deg"] = [0.1, 0.1, sc.initial_heading_sigma / DEG]
    doc: dict[str, Any] = {
        "mission": {"name": sc.name, "description": description},
        "imu": _imu_section(sc, imu),
        "sensors": _sensor_sections(sc, pendulum),
        "initial": initial,
        "truth": {"file": "truth.parquet"},
    }
    return parse_config(doc, f"{sc.name} (simulated)")


def _imu_section(sc: Scenario, imu: ImuErrorModel) -> dict[str, Any]:
    """``[imu]``: the increments table, the noise model and the turn-on σ the simulator applied
    (the in-run σ when it has none) as ``initial_bias_sigma``."""
    gyro_on = imu.gyro_turn_on_sigma or imu.gyro_bias_sigma
    accel_on = imu.accel_turn_on_sigma or imu.accel_bias_sigma
    return {
        "file": "imu.parquet",
        "format": "increments",
        "rate_hz": sc.imu_rate_hz,
        "noise": {k: list(v) for k, v in imu.config_noise().items()},
        "initial_bias_sigma": {
            "gyro": [gyro_on / (DEG / 3600.0), "deg/h"],
            "accel": [accel_on / (1e-3 * G0), "mg"],
        },
    }


def _sensor_sections(sc: Scenario, pendulum: bool) -> dict[str, Any]:
    """``[sensors.*]``: every simulated sensor with its table, nominal σ, rate and use."""
    return {
        "dvl": {
            "kind": "dvl",
            "file": "dvl.parquet",
            "sigma": [sc.dvl.nominal_sigma(sc.cruise_speed), "m/s"],
            "rate_hz": sc.dvl.rate_hz,
            "lever_arm_m": list(sc.dvl.lever_arm),
            "use": "aid",
        },
        "depth": {
            "kind": "depth",
            "file": "depth.parquet",
            "sigma": [sc.depth.sigma_nominal, "m"],
            "rate_hz": sc.depth.rate_hz,
            "lever_arm_m": list(sc.depth.lever_arm),
            "use": "aid",
        },
        "inclinometer": {
            "kind": "inclinometer",
            "file": "inclinometer.parquet",
            "sigma": [sc.inclinometer.sigma / DEG, "deg"],
            "rate_hz": sc.inclinometer.rate_hz,
            # what the simulated sensor reads: the apparent vertical, or the attitude itself
            "model": "pendulum" if pendulum else "attitude",
            "use": "aid",
        },
        "heading": {
            "kind": "heading",
            "file": "heading.parquet",
            "sigma": [sc.heading.sigma / DEG, "deg"],
            "rate_hz": sc.heading.rate_hz,
            "use": sc.heading.use,
        },
        "gps": {
            "kind": "gnss",
            "file": "gps.parquet",
            "sigma": [round(sc.gps.sigma, 3), "m"],
            "rate_hz": sc.gps.rate_hz,
            "lever_arm_m": list(sc.gps.lever_arm),
            "use": "init",
        },
        **{g.key: _generic_section(g) for g in sc.extra_sensors},
    }


def _generic_section(g: GenericSpec) -> dict[str, Any]:
    """``[sensors.<name>]`` of a kind simulated from its declaration: σ in its SI unit."""
    kind = KINDS[g.kind]
    section: dict[str, Any] = {
        "kind": g.kind,
        "file": f"{g.key}.parquet",
        "sigma": [g.sigma, si_unit(kind.sigma_kind)],
        "rate_hz": g.rate_hz,
        "use": "aid",
    }
    if kind.lever_arm:
        section["lever_arm_m"] = list(g.lever_arm)
    return section


def _streams(seed: int, extra: tuple[str, ...] = ()) -> dict[str, np.random.SeedSequence]:
    """The error sources' streams by name: :data:`_STREAMS`, then a clock and a noise stream
    per extra sensor (spawned after the fixed ones, which they leave unchanged)."""
    if seed < 0:
        raise ValueError(f"seed {seed}: a simulation seed is a non-negative integer")
    names = _STREAMS + tuple(f"{k}_{s}" for k in extra for s in ("clock", "noise"))
    return dict(zip(names, np.random.SeedSequence(seed).spawn(len(names)), strict=True))


def _extra_keys(sc: Scenario) -> tuple[str, ...]:
    """The extra sensors' names, refused if they repeat or take a table's name."""
    keys = tuple(g.key for g in sc.extra_sensors)
    taken = {"imu", "truth", "dvl", "depth", "inclinometer", "heading", "gps"}
    clash = sorted(k for k in set(keys) if keys.count(k) > 1 or k in taken)
    if clash:
        raise ValueError(f"extra sensors {clash}: each needs a name of its own")
    return keys


def sensor_tables(
    scenario: Scenario,
    trajectory: tr.Trajectory,
    seed: int,
    disturbances: Disturbances | None = None,
    calibration: Calibration | None = None,
) -> tuple[dict[str, pd.DataFrame], dict[str, Any]]:
    """The aiding sensors' tables (keyed dvl, depth, inclinometer, heading, gps and the extra
    sensors' names) of ``scenario`` on its built ``trajectory``, exactly as :func:`generate`
    makes them for this seed, and what was injected (``simulation.json``'s ``dvl`` and
    ``clock_first_sample_s``). ``calibration``: the sensors' true calibration errors (default
    none; docs/simulation.md, 'Calibration errors').
    """
    sc = scenario
    dist = disturbances if disturbances is not None else Disturbances()
    cal = calibration if calibration is not None else sensors.NO_CALIBRATION
    streams = _streams(seed, _extra_keys(sc))
    rngs = {k: np.random.default_rng(s) for k, s in streams.items() if k != "imu"}
    duration = trajectory.duration

    def clock(name: str, rate_hz: float, jitter: float) -> Truth:
        t = sensors.sample_times(
            duration, rate_hz, jitter, rngs[f"{name}_clock"], dist.clock_offsets, dist.clock_jitter
        )
        return _truth_at(trajectory, t, dist.waves)

    dvl_truth = clock("dvl", sc.dvl.rate_hz, sc.dvl.jitter)
    dvl_rng = {k: rngs[f"dvl_{k}"] for k in ("noise", "segments", "outliers", "dropouts")}
    dvl_df, dvl_info = sensors.dvl(sc.dvl, dvl_truth, trajectory.static_end, dvl_rng, dist, cal)
    depth_truth = clock("depth", sc.depth.rate_hz, sc.depth.jitter)
    incl_truth = clock("inclinometer", sc.inclinometer.rate_hz, sc.inclinometer.jitter)
    head_truth = clock("heading", sc.heading.rate_hz, sc.heading.jitter)
    gps_truth = clock("gps", sc.gps.rate_hz, sc.gps.jitter)
    tables = {
        "dvl": dvl_df,
        "depth": sensors.depth(sc.depth, depth_truth, rngs["depth_noise"], dist, cal),
        "inclinometer": sensors.inclinometer(
            sc.inclinometer, incl_truth, rngs["inclinometer_noise"], dist, cal
        ),
        "heading": sensors.heading(sc.heading, head_truth, rngs["heading_noise"], dist, cal),
        "gps": sensors.gps(sc.gps, gps_truth, rngs["gps_noise"], dist, cal),
        **{
            g.key: sensors.generic(
                g, clock(g.key, g.rate_hz, g.jitter), rngs[f"{g.key}_noise"], dist
            )
            for g in sc.extra_sensors
        },
    }
    info: dict[str, Any] = {
        "dvl": dvl_info,
        "clock_first_sample_s": {
            name: float(tb["t_s"].iloc[0]) if len(tb) else None for name, tb in tables.items()
        },
    }
    return tables, info


def generate(
    scenario: Scenario,
    seed: int,
    disturbances: Disturbances | None = None,
    calibration: Calibration | None = None,
) -> SimulatedMission:
    """Generate the mission of ``scenario`` in memory (see the module docstring), with the
    sensors' true ``calibration`` errors (default none)."""
    sc = scenario
    dist = disturbances if disturbances is not None else Disturbances()
    streams = _streams(seed)
    traj = tr.build(sc.trajectory, waves=dist.waves)
    _check_poles(sc, traj)
    model = sc.imu if dist.imu_uncalibrated_turn_on else sc.calibrated_imu
    imu_df, errs = _imu_table(sc, traj, model, streams["imu"], dist)
    truth_df = _truth_table(sc, traj, errs, dist)
    sensor_dfs, sensor_info = sensor_tables(sc, traj, seed, dist, calibration)
    heading_err, heading_deg = _initial_heading(
        sc, traj, np.random.default_rng(streams["initial_heading"]), dist
    )

    turn_on = "uncalibrated (Table 2)" if dist.imu_uncalibrated_turn_on else "calibrated residual"
    off = [k for k, v in dist.as_dict().items() if not v]
    description = (
        f"{sc.description}; simulated, seed {seed}; turn-on bias: {turn_on}; "
        f"switched off: {', '.join(off) if off else 'none'}"
    )
    config = _config(
        sc, model, traj.static_end, heading_deg, description, dist.inclinometer_pendulum
    )
    meta: dict[str, Any] = {
        "generator": "adaptnav.sim.scenarios",
        "preset": sc.name,
        "seed": seed,
        "disturbances": dist.as_dict(),
        "duration_s": traj.duration,
        "static_end_s": traj.static_end,
        "distance_m": traj.distance(),
        "imu": {
            "turn_on": turn_on,
            "gyro_turn_on_rad_s": errs.gyro_turn_on.tolist(),
            "accel_turn_on_m_s2": errs.accel_turn_on.tolist(),
            "gyro_scale": errs.gyro_scale.tolist(),
            "accel_scale": errs.accel_scale.tolist(),
            "gyro_turn_on_sigma_rad_s": model.gyro_turn_on_sigma,
            "accel_turn_on_sigma_m_s2": model.accel_turn_on_sigma,
        },
        "initial_heading_error_rad": heading_err if heading_deg is not None else None,
        **sensor_info,
        "segments": [[s.kind, s.start, s.end] for s in traj.spans],
    }
    if calibration is not None and calibration != sensors.NO_CALIBRATION:
        meta["calibration"] = calibration.as_dict()
    tables = {"imu": imu_df, **sensor_dfs, "truth": truth_df}
    return SimulatedMission(config, tables, errs, traj, meta)


POLE_CHECK_RATE_HZ = 10.0
"""Rate (Hz) of the instants, besides the truth's, at which :func:`_check_poles` evaluates the
latitude: 0.1 s apart, under 1e-5° of latitude at 10 m/s against the limit's 0.01° (1.1 km)."""
_POLE_CHUNK = 65536
"""Instants whose latitude :func:`_check_poles` evaluates at once (bounds its memory)."""


def _check_poles(sc: Scenario, traj: tr.Trajectory) -> None:
    """ValueError naming the first instant (s) and the latitude if the trajectory comes within
    0.01° of a pole or crosses one (``|lat| > earth.MAX_LAT_DEG``), and the farthest latitude
    it reaches, before anything else is computed or written: the latitude-longitude
    mechanization is singular there, and the alignment and the run refuse to start there
    (docs/conventions.md). Checked at every truth instant and every 1 /
    :data:`POLE_CHECK_RATE_HZ` s (the IMU's 100 Hz would cost a fifth of ``simulate paper-1``'s
    time)."""

    def grid(rate: float) -> Array:
        return np.arange(0, math.floor(traj.duration * rate + 1e-9) + 1) / rate

    t = np.union1d(grid(sc.truth_rate_hz), grid(POLE_CHECK_RATE_HZ))
    lat = np.concatenate(
        [traj.motion.position(t[a : a + _POLE_CHUNK])[:, 0] for a in range(0, t.size, _POLE_CHUNK)]
    )
    beyond = np.flatnonzero(~(np.abs(lat) <= earth.MAX_LAT_RAD))  # NaN too
    if not beyond.size:
        return
    k = int(beyond[0])
    limit = earth.MAX_LAT_DEG
    if not math.isfinite(lat[k]):
        raise ValueError(f"trajectory of {sc.name!r}: at {t[k]:.2f} s its latitude is not finite")
    far = int(np.nanargmax(np.abs(lat)))
    across = ", past 90°: it crosses the pole" if abs(lat[far]) > 0.5 * math.pi else ""
    raise ValueError(
        f"trajectory of {sc.name!r}: at {t[k]:.2f} s its latitude reaches "
        f"{math.degrees(lat[k]):.7f}°, within {90.0 - limit:g}° of the "
        f"{'north' if lat[k] > 0.0 else 'south'} pole (limit ±{limit:g}°; farthest "
        f"{math.degrees(lat[far]):.6f}° at {t[far]:.2f} s{across}), where the "
        "latitude-longitude mechanization is singular (docs/conventions.md)"
    )


def _imu_count(sc: Scenario, traj: tr.Trajectory) -> int:
    """Number of IMU intervals in the mission: t_k = k / rate for k = 0 .. n."""
    return math.floor(traj.duration * sc.imu_rate_hz + 1e-9)


def _imu_table(
    sc: Scenario,
    traj: tr.Trajectory,
    model: ImuErrorModel,
    stream: np.random.SeedSequence,
    dist: Disturbances,
) -> tuple[pd.DataFrame, ImuErrors]:
    """``imu.parquet``: the exact increments of the motion over (t_{k-1}, t_k], corrupted by
    ``model`` (docs/simulation.md), and the realised errors."""
    rate = sc.imu_rate_hz
    dt = 1.0 / rate
    t_imu = np.arange(0, _imu_count(sc, traj) + 1) / rate
    dtheta, dvel = kinematics.imu_increments(traj.motion, t_imu)
    th_m, dv_m, errs = imu_model.corrupt(
        dtheta, dvel, dt, model, imu_model.generators(stream),
        white=dist.imu_white_noise, in_run=dist.imu_in_run_bias,
        turn_on=dist.imu_turn_on_bias, scale=dist.imu_scale_factor,
    )  # fmt: skip
    del dtheta, dvel  # a long mission's exact increments: freed before the table is built
    imu_df = pd.DataFrame(
        {
            "t_s": t_imu[1:],
            "dtheta_x_rad": th_m[:, 0],
            "dtheta_y_rad": th_m[:, 1],
            "dtheta_z_rad": th_m[:, 2],
            "dvel_x_m_s": dv_m[:, 0],
            "dvel_y_m_s": dv_m[:, 1],
            "dvel_z_m_s": dv_m[:, 2],
        }
    )
    return imu_df, errs


def _truth_table(
    sc: Scenario, traj: tr.Trajectory, errs: ImuErrors, dist: Disturbances
) -> pd.DataFrame:
    """``truth.parquet`` at ``truth_rate_hz``, with the true biases of the IMU interval ending
    there and the sea-state level (docs/data-format.md); the longitude wrapped into [-π, π)
    (:func:`adaptnav.core.earth.wrap_longitude`: the trajectory's runs on past ±180°, which the
    loader refuses below -180°)."""
    rate = sc.imu_rate_hz
    n_imu = _imu_count(sc, traj)
    n_truth = math.floor(traj.duration * sc.truth_rate_hz + 1e-9)
    t_truth = np.arange(0, n_truth + 1) / sc.truth_rate_hz
    x = kinematics.true_states(traj.motion, t_truth)
    eul = traj.motion.euler(t_truth)
    k_imu = np.clip(np.round(t_truth * rate).astype(int) - 1, 0, n_imu - 1)
    return pd.DataFrame(
        {
            "t_s": t_truth,
            "lat_rad": x[:, 0],
            "lon_rad": earth.wrap_longitude(x[:, 1]),
            "h_m": x[:, 2],
            "vn_m_s": x[:, 3],
            "ve_m_s": x[:, 4],
            "vd_m_s": x[:, 5],
            "roll_rad": eul[:, 0],
            "pitch_rad": eul[:, 1],
            "yaw_rad": attitude.wrap_angle(eul[:, 2]),
            **{f"bg_{a}_rad_s": errs.gyro_bias[k_imu, i] for i, a in enumerate("xyz")},
            **{f"ba_{a}_m_s2": errs.accel_bias[k_imu, i] for i, a in enumerate("xyz")},
            "sea_state": traj.sea_state.value(t_truth) if dist.waves else 0.0 * t_truth,
        }
    )


def _initial_heading(
    sc: Scenario, traj: tr.Trajectory, rng: np.random.Generator, dist: Disturbances
) -> tuple[float, float | None]:
    """(error (rad), heading (deg) or None) for ``[initial]``: the quay's charted bearing, the
    true initial yaw plus N(0, ``initial_heading_sigma``²) (docs/simulation.md)."""
    if sc.initial_heading_sigma is None:
        return 0.0, None
    heading_err = float(rng.normal(0.0, sc.initial_heading_sigma))
    if not dist.sensor_noise:
        heading_err = 0.0
    yaw0 = float(traj.motion.euler(np.array([0.0]))[0, 2])
    return heading_err, math.degrees(math.remainder(yaw0 + heading_err, 2.0 * math.pi))


def simulate_scenario(
    scenario: Scenario,
    seed: int,
    out: Path,
    disturbances: Disturbances | None = None,
    calibration: Calibration | None = None,
) -> Path:
    """Generate ``scenario`` and write it to the folder ``out``; returns the folder."""
    sim = generate(scenario, seed, disturbances, calibration)
    root = Path(out)
    write_mission(root, sim.config, sim.tables, fmt="parquet")
    (root / SIMULATION_FILE).write_text(
        json.dumps(sim.meta, indent=2, sort_keys=True) + "\n", encoding="utf-8"
    )
    return root


def simulate(
    preset: str,
    seed: int,
    out: Path,
    disturbances: Disturbances | None = None,
    calibration: Calibration | None = None,
) -> Path:
    """Simulate the preset ``paper-1``, ``paper-2`` or ``demo`` with ``seed`` into ``out``
    (a mission folder, created if needed) and return it; ``disturbances`` default: all on;
    ``calibration`` (the sensors' true calibration errors) default: none."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r} (known: {', '.join(PRESETS)})")
    return simulate_scenario(PRESETS[preset](), seed, out, disturbances, calibration)


def table_hashes(folder: Path) -> dict[str, str]:
    """SHA-256 of every file of a mission folder (reproducibility checks)."""
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(Path(folder).iterdir())
        if p.is_file()
    }
