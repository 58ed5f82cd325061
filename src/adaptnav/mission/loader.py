"""A mission folder: ``mission.toml`` plus one table per stream, loaded into SI arrays.

:func:`load_mission` reads and checks everything once (docs/data-format.md gives the columns
and the bad-input policy: clear :class:`MissionError`, or a logged :class:`Repair`);
:func:`write_mission` writes a folder (the simulator's output); :func:`build_sensor_model` turns
a ``[sensors.<name>]`` section into the measurement model of :mod:`adaptnav.sensors`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.core import attitude
from adaptnav.core.units import G0
from adaptnav.mission import axes, clocks, dvl_axes, gnss_clock, gnss_mirror, scales
from adaptnav.mission import truth as reference
from adaptnav.mission.config import (
    SENSOR_LIMITS,
    MissionConfig,
    MissionError,
    SensorConfig,
    load_config,
    write_config,
)
from adaptnav.mission.imu_holes import (
    WIDE_HOLE_RAD,
    ImuHoles,
    find_holes,
    find_rate_holes,
    trapezoid,
)
from adaptnav.mission.imu_stamps import fit_stamp_grid
from adaptnav.mission.screening import (
    AFTER_GAP_MADS,
    after_gap_mask,
    spike_mask,
    stuck_runs,
    thinned_mask,
)
from adaptnav.mission.tables import (
    TIME_COLUMN,
    TRUTH_COLUMNS,
    DroppedRow,
    Journal,
    Repair,
    Table,
    check_order,
    flag,
    imu_columns,
    present,
    read_table,
    show,
    take_columns,
    write_table,
)
from adaptnav.models.strapdown import rates_to_increments
from adaptnav.sensors import MeasurementModel
from adaptnav.sensors.kind import SensorSetup
from adaptnav.sensors.registry import KINDS

log = logging.getLogger("adaptnav.mission")

Array = NDArray[np.float64]
CONFIG_NAME = "mission.toml"
LOST_LOCK_REASON = "all-zero DVL reading: bottom lock lost (zero_is_lost)"
TRUNCATED_REASON = "truncated last line of the file (cut short), not read"
OFF_UNREAD = "off sensor's table not read"
"""Repair action of a sensor with ``use = "off"`` whose table is there but cannot be read."""
MAX_GYRO_RAD_S = 20.0
"""|gyro| above this (rad/s, ≈ 1150 °/s) is taken as wrong units (deg/s given as rad/s)."""
MAX_ACCEL_M_S2 = 20.0 * G0
"""|accel| above this (m/s², 20 g) is taken as wrong units."""
RATE_MISMATCH = 0.1
"""Relative difference between the median IMU interval and 1/rate_hz that is warned about."""
SENSOR_RATE_FACTOR = 2.0
"""A sensor's median interval more than this factor from its ``1/rate_hz`` (either way) is
warned about: aiding sensors ping irregularly (a DVL's rate follows the range to the bottom),
so the band is wider than the IMU's :data:`RATE_MISMATCH`."""
LOST_SAMPLE_FACTOR = 1.5
"""An increments row whose interval exceeds this many local IMU periods is a candidate for
lost samples before it (:func:`_lost_samples`)."""
LOST_SAMPLE_WINDOW = 25
"""Rows either side whose median interval and specific force are the IMU's local ones."""
LOST_SAMPLE_BLOCK = 1 << 16
"""Candidate rows judged at a time by :func:`_lost_samples` (temporaries of ~40 MB)."""
SATURATION_PILEUP = 2
"""An IMU column's extreme value held on at least this many times as many rows as the next value
inward is a pile-up, the mark of clipping (:func:`_check_saturated`)."""
SATURATION_LEVELS = 4
"""A pile-up is judged only in a column that takes at least this many distinct values: an IMU at
rest whose noise is below its output step alternates between two or three steps, and may
pile up at the one farther from zero; clipping cuts off a motion that runs over many steps
(since 0.4.13). Four is the fewest a stream's watch can tell at no cost: the next values inward
of both extremes then differ (``live_imu.ImuWatch``)."""
CHECK_BLOCK = 1 << 20
"""IMU rows checked at a time for wrong units: temporaries of 48 MB, not of the whole table."""


@dataclass(frozen=True, eq=False)
class ImuData:
    """N IMU intervals ``(t_k - dt_k, t_k]`` with their increments (rad, m/s), as the engine
    consumes them (:meth:`adaptnav.engine.batch.Navigator.feed_imu`)."""

    t: Array
    dt: Array
    dtheta: Array
    dvel: Array
    holes: ImuHoles = field(default_factory=ImuHoles.none)
    """The intervals stretched over lost or dropped samples and what their motion can be
    (:mod:`adaptnav.mission.imu_holes`; docs/robustness.md, 'The σ over a hole')."""

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def start(self) -> float:
        """Start of the first interval, ``t_0 - dt_0`` (s)."""
        return float(self.t[0] - self.dt[0])


@dataclass(frozen=True, eq=False)
class SensorData:
    """One sensor's readings: times (n,), values (n, d) in SI units, and the 0-based data rows
    of the file they came from (rows removed at load are in :attr:`Mission.dropped`)."""

    name: str
    kind: str
    t: Array
    z: Array
    rows: NDArray[np.int64]
    period: float = math.nan
    """Nominal sampling period (s): 1/rate_hz, else the median interval of the table."""


@dataclass(frozen=True, eq=False)
class Mission:
    """A loaded mission: config, IMU, sensors with ``use`` aid or init, optional truth, every
    table as read (keyed "imu", sensor names, "truth"), what was repaired or dropped, and the
    readings of the sensors that are off (for the ledger)."""

    root: Path
    config: MissionConfig
    imu: ImuData
    sensors: dict[str, SensorData]
    truth: pd.DataFrame | None
    tables: dict[str, pd.DataFrame]
    repairs: tuple[Repair, ...]
    dropped: tuple[DroppedRow, ...]
    off: dict[str, SensorData] = field(default_factory=dict)
    """Sensors with ``use = "off"`` whose table could be read: never used, in the ledger as
    "sensor off" (a missing or bad table of an off sensor is skipped, logged)."""

    def readings(self, use: tuple[str, ...] = ("aid",)) -> dict[str, tuple[Array, Array]]:
        """``{name: (t, z)}`` of the sensors whose ``use`` is in ``use`` (for the engine);
        array position i is file row ``sensors[name].rows[i]``."""
        return {n: (s.t, s.z) for n, s in self.sensors.items() if self.config.sensors[n].use in use}


# --- loading ------------------------------------------------------------------------------------


def load_mission(path: str | Path) -> Mission:
    """Load the mission folder ``path`` (or its ``mission.toml``); see docs/data-format.md."""
    root = Path(path)
    if root.is_file():
        root = root.parent
    config = load_config(root / CONFIG_NAME)
    journal = Journal()
    cache: dict[Path, Table] = {}
    inside = _resolve(root, root.name or str(root))

    def table(file: str) -> Table:
        p = _resolve(root / file, file)
        if not p.is_relative_to(inside):
            raise MissionError(
                f"{file}: leads to {p}, outside the mission folder {inside} (a symbolic link out "
                "of it?); tables live inside the mission folder",
                file=file,
            )
        if p not in cache:
            cache[p] = read_table(p, file, journal)
        return cache[p]

    imu_table = table(config.imu.file)
    tables: dict[str, pd.DataFrame] = {"imu": imu_table.df}
    imu = _load_imu(imu_table, config, journal)
    sensors: dict[str, SensorData] = {}
    off: dict[str, SensorData] = {}
    for name, cfg in config.sensors.items():
        if cfg.use == "off":
            data = _load_off_sensor(table, name, cfg, journal, root)
            if data is not None:
                off[name] = data
            continue
        tb = table(cfg.file)
        tables[name] = tb.df
        data = _load_sensor(tb, name, cfg, journal)
        if data is not None:
            _check_time_span(imu, data, cfg)
            sensors[name] = data
    noise = config.imu.noise.to_imu_noise()
    views = axes.ImuViews(imu.t, imu.dt, imu.dtheta, imu.dvel, (noise.arw, noise.vrw))
    cross_check(config, views, sensors, off)
    truth = None
    if config.truth.file is not None:
        tb = table(config.truth.file)
        tables["truth"] = tb.df
        truth = _load_truth(tb, journal)
    journal.summarise()
    return Mission(
        root,
        config,
        imu,
        sensors,
        truth,
        tables,
        tuple(journal.repairs),
        tuple(journal.dropped),
        off,
    )


class OutsideImuSpanError(MissionError):
    """A sensor none of whose readings lies within the IMU's time span ``imu_span`` (s):
    :func:`_check_time_span`."""

    def __init__(self, message: str, *, file: str, imu_span: tuple[float, float]) -> None:
        super().__init__(message, file=file, field="t_s")
        self.imu_span = imu_span


SPAN_UNIT_SHARE = 0.1
SPAN_UNIT_RATIO = 100.0
"""A sensor with fewer than this share of its readings within the IMU's time span, its stamps
spanning more than this many times the IMU's, is an error (:func:`_check_time_span`)."""


def _check_time_span(imu: ImuData, data: SensorData, cfg: SensorConfig) -> None:
    """A sensor none of whose readings lies within the IMU's time span is an error naming its
    file: its times are in another unit (ms, µs) or from another origin (Unix time beside
    mission time), and every reading would go to the ledger as outside the IMU's span while
    the run went on without the sensor. So is one with fewer than :data:`SPAN_UNIT_SHARE` of its
    readings within, the first of them, whose stamps span more than :data:`SPAN_UNIT_RATIO` ×
    the IMU's and lie more than :data:`SPAN_UNIT_RATIO` × its period (``rate_hz``) apart: ms
    from the same origin keep the readings of the first second within (since 0.4.10; up to
    0.4.9 the demo's DVL in ms kept 2 readings, 141 m RMSE, exit 0, a warning). A sensor
    without ``rate_hz`` takes its median interval as its period and is not judged so."""
    if data.t.size == 0:
        return
    within = int(np.count_nonzero((data.t >= imu.start) & (data.t <= imu.t[-1])))
    ratio = float(data.t[-1] - data.t[0]) / max(float(imu.t[-1] - imu.start), 1e-9)
    late = data.t[0] >= imu.start  # from the IMU's origin, not a longer log around it
    # In ms the readings' spacing is a thousand of their periods too; a log that only runs on
    # past a short IMU (at its own rate) is not refused.
    spacing = float(np.median(np.diff(data.t))) if data.t.size > 1 else 0.0
    stretched = spacing >= SPAN_UNIT_RATIO * data.period
    if within and (
        within >= SPAN_UNIT_SHARE * data.t.size or ratio <= SPAN_UNIT_RATIO or not late
        or not stretched
    ):  # fmt: skip
        return
    which = f"only {within}" if within else "none"
    verb = "lie" if within > 1 else "lies"
    raise OutsideImuSpanError(
        f"{cfg.file}: {which} of the {data.t.size} readings of sensor {data.name!r} {verb} "
        f"within the IMU's time span ({imu.start:.6g} .. {imu.t[-1]:.6g} s); its t_s runs from "
        f"{data.t[0]:.6g} to {data.t[-1]:.6g} s: another time unit (ms, µs?) or another origin "
        "(Unix time beside mission time?)",
        file=cfg.file,
        imu_span=(imu.start, float(imu.t[-1])),
    )


def cross_check(
    config: MissionConfig,
    views: axes.ImuViews,
    sensors: dict[str, SensorData],
    off: dict[str, SensorData] | None = None,
) -> None:
    """The cross-checks of the IMU's axes (unless ``imu.axis_check = false``) and of the DVL's
    and depth's scales (per sensor ``scale_check``) against the aiding sensors: a MissionError
    naming the file and column of the first finding (docs/robustness.md, 'IMU axes', 'DVL and
    depth scales'); then the warning of a depth read under water at GNSS fixes, whose fixes
    count from ``off`` sensors too ('A depth offset at the surface'). :func:`load_mission`
    calls it on the whole mission; a stream on its first window (mission/live_cross.py,
    docs/streaming.md, 'Cross-checks'), ``views`` then built from 0.1-s block sums of the
    IMU."""
    if config.imu.check_axes:
        _check_axes(config, views, sensors)
    dvls = _judged_dvls(config, views, sensors)
    for name, (readings, blocks, dvl) in dvls.items():
        _check_dvl_clocks(config, sensors, name, readings, blocks, dvl, views)
    if config.imu.check_axes:
        # The track's shape before its clock: a mirrored track dated against the DVL's would
        # give an offset of no meaning. A mirror is told by the gyro's turns, so only with the
        # IMU's axes checked (a gyro's z negated mirrors the dead reckoning instead).
        _check_gnss_mirror(config, views, sensors)
        # After the DVL's clock: the GNSS is dated against the DVL's track, which a DVL seconds
        # off moves (the demo's DVL 10 s early made its right GPS "4.9 s late").
        for f in gnss_clock.check(config, views, sensors):
            _clock_verdict(
                config, f.name, f.words, f.found.beyond(f.period), "imu.axis_check = false"
            )
    for name, judged in dvls.items():
        _check_scales(config, views, sensors, name, judged)
    _check_depth_at_fixes(config, {**sensors, **(off or {})})


def _check_gnss_mirror(
    config: MissionConfig, views: axes.ImuViews, sensors: dict[str, SensorData]
) -> None:
    """A MissionError naming the GNSS's file and its lat_rad, lon_rad columns when its track is
    the mirror image of the DVL's dead reckoning (:func:`gnss_mirror.check`; since 0.4.13, up to
    0.4.12 the demo so ran 3 933 km off, exit 0; docs/robustness.md, 'A GNSS track mirrored').
    ``scale_check = false`` on the receiver skips it."""
    for f in gnss_mirror.check(config, views, sensors):
        file, m = config.sensors[f.name].file, f.mirror
        if f.earth is not None and f.earth.flipped():
            _gyro_or_latitude(config, f)
        raise MissionError(
            f"{file}: the GNSS track is the mirror image of the DVL's dead reckoning: latitude "
            f"and longitude swapped, or a hemisphere's sign (E/W, N/S) lost? The changes of the "
            f"fixes of sensor {f.name!r} (lat_rad, lon_rad) over {m.n // 2} windows from t = "
            f"{m.t_from:.1f} to {m.t_to:.1f} s follow the track dead-reckoned from DVL "
            f"{f.dvl!r} ({config.sensors[f.dvl].file}), turned by the gyro, mirrored (scale "
            f"{m.k:.3g}) with {m.ratio:.3g} times less residual variance than as they are "
            f"(scale {m.k_direct:.3g}; likelihood ratio {m.log_lr:.0f}, "
            f"{gnss_mirror.MIN_LOG_LR:g} asked). Fix the table (or the gyro's z axis, if "
            f"negated), or, if it is right, set [sensors.{f.name}] scale_check = false "
            "(docs/robustness.md, 'A GNSS track mirrored')",
            file=file,
            field="lat_rad",
        )


def _gyro_or_latitude(config: MissionConfig, f: gnss_mirror.Finding) -> None:
    """The MissionError naming the gyro's z column when GNSS ``f.name``'s track is the mirror
    image of the DVL's dead reckoning and the gyro's earth rate at rest has the sign of the
    other hemisphere: its z axis negated (which mirrors the dead reckoning) or the fixes'
    latitude negated (which moves the earth rate expected) tell the same at load."""
    assert f.earth is not None
    e, column = f.earth, imu_columns(config.imu.format)[2]
    gnss = config.sensors[f.name].file
    raise MissionError(
        f"{config.imu.file}: the gyro's z axis ({column}) or the latitude of sensor "
        f"{f.name!r} ({gnss}, lat_rad): over the alignment's first {e.span_s:g} s at rest the "
        f"gyros measure a vertical (down) earth rate of {e.rate:.3e} rad/s where "
        f"{e.expected:.3e} ± {e.sigma:.1e} is expected at the fixes' latitude, and the fixes' "
        f"track is the mirror image of the DVL's dead reckoning, turned by the gyro (likelihood "
        f"ratio {f.mirror.log_lr:.0f}): is the gyro's z axis negated, or the latitude's sign "
        "lost (S written as N)? Fix the table, or, if it is right, set imu.axis_check = false "
        "(docs/robustness.md, 'A GNSS track mirrored')",
        file=config.imu.file,
        field=column,
    )


def _axis_references(config: MissionConfig, sensors: dict[str, SensorData]) -> list[axes.Reference]:
    """The angles of the aiding sensors that see rotation (mission/axes.py): a heading sensor's
    yaw, an inclinometer's roll and pitch, a GNSS receiver's course."""
    refs: list[axes.Reference] = []
    for name, data in sensors.items():
        cfg = config.sensors[name]
        c_sb = cfg.sensor_from_body() if KINDS[cfg.kind].mounting else None
        if data.kind == "heading":
            refs.append(axes.Reference(name, "yaw", 2, data.t, data.z[:, 0], c_sb))
        elif data.kind == "inclinometer":
            refs.append(axes.Reference(name, "roll", 0, data.t, data.z[:, 0], c_sb, tilt=0))
            refs.append(axes.Reference(name, "pitch", 1, data.t, data.z[:, 1], c_sb, tilt=1))
        elif data.kind == "gnss":
            sigma = float(np.atleast_1d(cfg.sigma_si())[0])
            t, chi = axes.course(data.t, data.z[:, 0], data.z[:, 1], sigma)
            refs.append(axes.Reference(name, "course", 2, t, chi))
    return refs


def _check_clocks(
    config: MissionConfig,
    views: axes.ImuViews,
    sensors: dict[str, SensorData],
    refs: list[axes.Reference],
) -> None:
    """A MissionError naming the sensor's file and t_s when its angle follows the gyro's
    decisively better at an offset beyond max(1 s, two of its periods) than at its stamps as
    they are (mission/clocks.py; docs/robustness.md, 'Sensor clocks'); a logged warning when
    the offset lies beyond 1 s but within two periods. Since 0.4.11."""
    for ref in refs:
        found = clocks.clock_offset(views.gyro(ref.c_sb), ref.axis, ref.t, ref.value)
        if found is None:  # too few readings (none, at times) or a vehicle that does not turn
            continue
        what = (f"its {ref.angle} follows the gyro's {'xyz'[ref.axis]} axis", "rotation")
        span = (float(ref.t[0]), float(ref.t[-1]))
        period = sensors[ref.name].period
        _judge_clock(config, ref.name, period, found, what, span, "imu.axis_check = false")


def _judge_clock(
    config: MissionConfig,
    name: str,
    period: float,
    found: clocks.ClockOffset | None,
    what: tuple[str, str],
    span: tuple[float, float],
    switch: str,
) -> None:
    """The MissionError naming sensor ``name``'s file and t_s for an offset ``found`` beyond
    max(1 s, two of its ``period``s), decisive (:meth:`clocks.ClockOffset.decisive`); the
    logged warning for one beyond 1 s within two periods. ``what``: the sensor's series and
    what it follows, and the motion whose variance the share counts; ``span``: the readings'
    first and last time; ``switch``: what turns the check off."""
    if found is None or not found.decisive() or abs(found.offset_s) <= axes.MAX_LAG_S:
        return
    words = _offset_words(name, what, found, config.sensors[name].latency_s or 0.0, span)
    _clock_verdict(config, name, words, found.beyond(period), switch)


def _clock_verdict(config: MissionConfig, name: str, words: str, beyond: bool, switch: str) -> None:
    """Sensor ``name``'s clock offset, said in ``words``: the MissionError naming its file and
    t_s when the offset lies ``beyond`` max(1 s, two of its periods), else a logged warning;
    ``switch``: what turns the check off."""
    cfg = config.sensors[name]
    if not beyond:
        log.warning("%s: %s", cfg.file, words)
        return
    raise MissionError(
        f"{cfg.file}: {words} If the stamps are right, set {switch} "
        "(docs/robustness.md, 'Sensor clocks')",
        file=cfg.file,
        field=TIME_COLUMN,
    )


def _offset_words(
    name: str,
    what: tuple[str, str],
    found: clocks.ClockOffset,
    latency_s: float,
    span: tuple[float, float],
) -> str:
    """What :func:`_judge_clock` says of sensor ``name``'s offset, and the fix."""
    tau = found.offset_s
    when = "after" if tau > 0.0 else "before"
    doubt = (
        " The slope's distance from 1 says this lag may be an alias of the true offset (a wave "
        f"period away, or beyond ±{clocks.MAX_OFFSET_S:g} s): check the logger's clock."
        if found.alias
        else ""
    )
    t0, t1 = span
    return (
        f"the stamps of sensor {name!r} lie {abs(tau):.1f} ± {found.se_s:.1f} s {when} its "
        f"readings were taken: {what[0]} at that offset "
        f"(slope {found.k:.3g}, 1 expected); at its stamps as they are, with that slope, the "
        f"residual variance is {found.ratio:.3g} times as large, {found.share:.2g} × the "
        f"{what[1]}'s variance more (likelihood ratio {found.log_lr:.0f}; the slope fitted there "
        f"{found.k_zero:.3g}), from t = {t0:.1f} to {t1:.1f} s. Set latency_s = "
        f"{latency_s + tau:.1f} in [sensors.{name}] (now {latency_s:g}), or set the "
        f"logger's clock right.{doubt}"
    )


def _check_axes(
    config: MissionConfig, views: axes.ImuViews, sensors: dict[str, SensorData]
) -> None:
    """A MissionError naming the IMU file and column (or the aiding sensor's, when the gyro and
    the accelerometers agree against it) if a gyro axis, or the accelerometers' levelling, does
    not turn with an aiding sensor's angle (mission/axes.py; docs/robustness.md, 'IMU axes').
    The sensors' clocks first (:func:`_check_clocks`): an angle that follows the gyro's seconds
    late is not a swapped axis."""
    refs = _axis_references(config, sensors)
    _check_clocks(config, views, sensors, refs)
    if not refs:
        return
    _check_dead_gyro(config, views, refs)
    found = next(axes.check_axes(views, refs), None)
    if found is None:
        _check_segments(config, views, refs)
        return
    columns = imu_columns(config.imu.format)
    s, sensor = found.at_zero, config.sensors[found.reference]
    if found.instrument == "reference":
        file, column = sensor.file, KINDS[sensor.kind].columns[found.axis]
        what = f"the {found.angle} of sensor {found.reference!r} ({column})"
        against = "the gyro's and the accelerometers' over the same intervals"
    else:
        gyro = found.instrument == "gyro"
        file = config.imu.file
        # The levelled roll, atan2(-f_y, -f_z), turns the other way with y's sign or z's.
        tilt = f"{columns[4]}, {columns[5]}" if found.angle == "roll" else columns[3]
        column = columns[found.axis] if gyro else tilt
        what = "the gyro's " + "xyz"[found.axis] if gyro else f"the accelerometers' {found.angle}"
        what += f" axis ({column})" if gyro else f" ({column})"
        against = f"the {found.angle} of sensor {found.reference!r} ({sensor.file})"
    raise MissionError(
        f"{file}: {what} against {against} from t = {found.t_from:.1f} to {found.t_to:.1f} s: "
        f"{s.k:.3g} ± {s.se:.2g} rad of the sensor's per rad of the IMU's (1 expected; below "
        f"{axes.MIN_SLOPE:g} even {axes.CONFIDENCE:g} σ up, with the sensor taken up to "
        f"{axes.MAX_LAG_S:g} s late or early): {found.cause()} Fix the table, or, if it is "
        "right, set imu.axis_check = false (docs/robustness.md, 'IMU axes')",
        file=file,
        field=column,
    )


def _reference_sigma(config: MissionConfig, ref: axes.Reference) -> float | None:
    """A heading's or an inclinometer's σ (rad) for its angle; None for a GNSS course (its
    noise is the chords', not the configured σ)."""
    if ref.angle == "course":
        return None
    sigmas = np.atleast_1d(config.sensors[ref.name].sigma_si())
    return float(sigmas[min(ref.tilt or 0, sigmas.size - 1)])


def _check_segments(
    config: MissionConfig, views: axes.ImuViews, refs: list[axes.Reference]
) -> None:
    """A MissionError naming the IMU file and column (a gyro axis, the accelerometers' levelled
    roll or pitch) or, when both disagree with it, the sensor's, and the span where it stops
    following an aiding sensor's angle that the whole mission's fit passed
    (:func:`axes.segment_finding`; docs/robustness.md, 'An IMU axis that fails mid-mission').
    Since 0.4.13."""
    for ref in refs:
        found = axes.segment_finding(views, ref, _reference_sigma(config, ref))
        if found is None:
            continue
        file, what, column = _segment_words(config, found)
        other = _segment_other(config, found)
        follows = (
            f"does not follow {other}"
            if found.follows_to is None
            else f"follows {other} up to t = {found.follows_to:.1f} s, but not"
        )
        raise MissionError(
            f"{file}: {what} {follows} from t = {found.t_from:.1f} to {found.t_to:.1f} s: "
            f"{found.words()} (1 expected, below "
            f"{axes.MIN_SLOPE:g}), in spans of {axes.SEGMENT_S:g} s: "
            + (
                "is the sensor's angle right?"
                if found.instrument == "reference"
                else "an axis that failed (dead, or reading only its noise)? Or the sensor's "
                "readings wrong there (a compass disturbed by steel nearby)?"
            )
            + " Remove those rows, or cut the mission before them; if the tables are right, set "
            "imu.axis_check = false (docs/robustness.md, 'An IMU axis that fails mid-mission')",
            file=file,
            field=column,
        )


def _segment_words(config: MissionConfig, found: axes.SegmentFinding) -> tuple[str, str, str]:
    """(file, what, column) of the instrument a span finding blames."""
    columns = imu_columns(config.imu.format)
    if found.instrument == "gyro":
        column = columns[found.axis]
        return config.imu.file, f"the gyro's {'xyz'[found.axis]} axis ({column})", column
    if found.instrument == "accelerometer":
        # The levelled roll, atan2(-f_y, -f_z), moves with y or z; the pitch with x.
        column = f"{columns[4]}, {columns[5]}" if found.angle == "roll" else columns[3]
        return config.imu.file, f"the accelerometers' {found.angle} ({column})", column
    sensor = config.sensors[found.reference]
    column = KINDS[sensor.kind].columns[found.axis]
    return sensor.file, f"the {found.angle} of sensor {found.reference!r} ({column})", column


def _segment_other(config: MissionConfig, found: axes.SegmentFinding) -> str:
    """What a span finding's instrument is judged against, in words."""
    if found.instrument == "reference":
        return "the gyro's and the accelerometers'"
    sensor = config.sensors[found.reference]
    return f"the {found.angle} of sensor {found.reference!r} ({sensor.file})"


def _check_dead_gyro(
    config: MissionConfig, views: axes.ImuViews, refs: list[axes.Reference]
) -> None:
    """A MissionError naming the IMU file and gyro column that reads one constant rate on every
    sample while a heading sensor's yaw or an inclinometer's roll or pitch, mounted on the
    body's axes, turns (:func:`axes.dead_axis`; docs/robustness.md, 'A dead gyro axis'). Since
    0.4.12."""
    for ref in refs:
        if ref.angle == "course" or not (ref.c_sb is None or np.allclose(ref.c_sb, np.eye(3))):
            continue
        cfg = config.sensors[ref.name]
        sigma = _reference_sigma(config, ref)
        assert sigma is not None  # not a course
        found = axes.dead_axis(views.gyro(), ref.axis, ref.t, ref.value, sigma)
        if found is None:
            continue
        column = imu_columns(config.imu.format)[ref.axis]
        raise MissionError(
            f"{config.imu.file}: the gyro's {'xyz'[ref.axis]} axis ({column}) reads one "
            f"constant rate, {found.rate:.3g} rad/s, on every sample, while the {ref.angle} of "
            f"sensor {ref.name!r} ({cfg.file}) turns through {math.degrees(found.turn):.1f}° "
            f"(1st to 99th percentile) from t = {ref.t[0]:.1f} to {ref.t[-1]:.1f} s: a dead "
            "axis, or a column not logged (filled with a constant)? Fix the table, or, if it "
            "is right, set imu.axis_check = false (docs/robustness.md, 'A dead gyro axis')",
            file=config.imu.file,
            field=column,
        )


def _judged_dvls(
    config: MissionConfig, views: axes.ImuViews, sensors: dict[str, SensorData]
) -> dict[str, tuple[dvl_axes.Readings, dvl_axes.Blocks, scales.Dvl]]:
    """The DVLs whose ``scale_check`` is on and that have two whole readings or more, by name:
    their finite readings in their own axes, the IMU's 0.1-s block sums (made once, for every
    DVL) and their :class:`scales.Dvl`."""
    out: dict[str, tuple[dvl_axes.Readings, dvl_axes.Blocks, scales.Dvl]] = {}
    blocks: dvl_axes.Blocks | None = None
    for name, d in sensors.items():
        cfg = config.sensors[name]
        if d.kind != "dvl" or not cfg.check_scale:
            continue
        ok = np.isfinite(d.t) & np.all(np.isfinite(d.z[:, :3]), axis=1)
        if np.count_nonzero(ok) < 2:
            # No velocity to integrate (every reading NaN in some axis, or dropped as lost
            # lock): nothing to judge; up to 0.4.11 an IndexError.
            continue
        period = d.period if math.isfinite(d.period) else float(np.median(np.diff(d.t[ok])))
        sigma = float(np.atleast_1d(cfg.sigma_si())[0])
        dvl = scales.Dvl.of(d.t, d.z[:, :3], cfg.sensor_from_body(), period, sigma)
        if blocks is None:
            blocks = dvl_axes.Blocks.of(*views.samples)
        out[name] = (_dvl_readings(cfg, d, period), blocks, dvl)
    return out


def _check_scales(
    config: MissionConfig,
    views: axes.ImuViews,
    sensors: dict[str, SensorData],
    name: str,
    judged: tuple[dvl_axes.Readings, dvl_axes.Blocks, scales.Dvl],
) -> None:
    """A MissionError naming the file and column if DVL ``name``'s speed or direction does not
    follow a GNSS track's, or a depth's changes its vertical velocity (mission/scales.py;
    docs/robustness.md, 'DVL and depth scales'), or its axes the accelerometers (since
    0.4.11: :func:`_check_dvl_axes`); ``judged``: from :func:`_judged_dvls` and the IMU's
    blocks. Its clock and the depths' (:func:`_check_dvl_clocks`) are judged before, and
    before the GNSS's (mission/gnss_clock.py). ``scale_check = false`` on a sensor skips it."""
    readings, blocks, dvl = judged
    _check_dvl_track(config, sensors, name, dvl, views)
    _check_depth_scale(config, sensors, name, dvl, views)
    _check_dvl_axes(config, name, readings, blocks, views.noise[1])


def _dvl_readings(cfg: SensorConfig, d: SensorData, period: float) -> dvl_axes.Readings:
    """The DVL's finite readings in its own axes, its mounting and lever arm."""
    ok = np.isfinite(d.t) & np.all(np.isfinite(d.z[:, :3]), axis=1)
    return dvl_axes.Readings(d.t[ok], d.z[ok, :3], cfg.sensor_from_body(), cfg.lever_arm(), period)


def _check_dvl_clocks(
    config: MissionConfig,
    sensors: dict[str, SensorData],
    name: str,
    readings: dvl_axes.Readings,
    blocks: dvl_axes.Blocks,
    dvl: scales.Dvl,
    views: axes.ImuViews,
) -> None:
    """Since 0.4.12, the clocks of the DVL ``name`` and of each depth meter (its
    ``scale_check`` on) before the other checks of the DVL, as :func:`_check_clocks` dates the
    angles: the DVL's velocity against the changes the IMU predicts for it
    (:func:`clocks.dvl_offset`), then a depth against the DVL's vertical displacement, on a
    vehicle that dives (:func:`clocks.depth_offset`; docs/robustness.md, 'Sensor clocks'),
    the DVL's readings taken at its stamps less its offset where one was found (a DVL 2 s
    late, a warning, would otherwise date a right depth on A-KIT 7 2.1 s early)."""
    found = clocks.dvl_offset(blocks, readings, views.noise[1])
    what = ("its velocity follows the changes the accelerometers and the gyro predict", "motion")
    span = (float(readings.t[0]), float(readings.t[-1])) if readings.t.size else (0.0, 0.0)
    switch = f"[sensors.{name}] scale_check = false"
    _judge_clock(config, name, readings.period, found, what, span, switch)
    if found is not None and found.decisive():
        dvl = replace(dvl, t=dvl.t - found.offset_s)
    dcfg = config.sensors[name]
    for dname, d in sensors.items():
        cfg = config.sensors[dname]
        if d.kind != "depth" or not cfg.check_scale or d.t.size == 0:
            continue
        lever = cfg.lever_arm() - dcfg.lever_arm()
        found = clocks.depth_offset(d.t, d.z[:, 0], dvl, views.tilt(), lever)
        follows = f"its depth follows the vertical displacement of DVL {name!r} ({dcfg.file})"
        what = (follows, "depth change")
        period = d.period if math.isfinite(d.period) else float(np.median(np.diff(d.t)))
        span = (float(d.t[0]), float(d.t[-1]))
        switch = f"[sensors.{dname}] scale_check = false"
        _judge_clock(config, dname, period, found, what, span, switch)


def _check_dvl_axes(
    config: MissionConfig,
    name: str,
    readings: dvl_axes.Readings,
    blocks: dvl_axes.Blocks,
    vrw: float,
) -> None:
    """The DVL ``name``'s velocity changes against the accelerometers' in its own axes, with
    no heading needed (:func:`dvl_axes.check_dvl_axes`; docs/robustness.md, 'DVL axes against
    the accelerometers')."""
    cfg = config.sensors[name]
    found = dvl_axes.check_dvl_axes(blocks, readings, vrw)
    if found is None:
        return
    column = ("vx_m_s", "vy_m_s", "vz_m_s")[found.axis]
    lo, n = dvl_axes.MIN_SLOPE, dvl_axes.CONFIDENCE
    rule = "" if found.slip else f"; below {lo:g} even {n:g} σ up"
    fit = "undecided as declared"
    if found.fit is not None:
        s = found.fit.slope
        fit = (
            f"{s.k:.3g} ± {s.se:.2g} m/s of the DVL's per m/s of the IMU's velocity change "
            f"over {s.n} windows of {dvl_axes.WINDOW_S:g} s"
        )
    raise MissionError(
        f"{cfg.file}: the {'xyz'[found.axis]} axis of DVL {name!r} ({column}) against the "
        f"accelerometers and the gyro from t = {found.t_from:.1f} to {found.t_to:.1f} s: "
        f"{fit} (1 expected{rule}): {found.cause()} "
        f"{SCALE_FIX.format(name)} (docs/robustness.md, 'DVL axes against the accelerometers')",
        file=cfg.file,
        field=column,
    )


def _check_depth_at_fixes(config: MissionConfig, sensors: dict[str, SensorData]) -> None:
    """Warn when a depth meter's readings at a GNSS receiver's fixes put its antenna more than
    :data:`scales.AIR_MARGIN_M` under water (:func:`scales.depth_at_fixes`): an absolute
    pressure (10 m), or a pressure unit, read as a depth; up to 0.4.10 nothing was said
    (docs/robustness.md, 'A depth offset at the surface'). A warning, not an error: a USBL
    configured as a ``gnss`` sensor fixes under water. ``scale_check = false`` skips it."""
    for name, d in sensors.items():
        cfg = config.sensors[name]
        if d.kind != "depth" or not cfg.check_scale:
            continue
        for gname, g in sensors.items():
            if g.kind != "gnss":
                continue
            above = float(cfg.lever_arm()[2] - config.sensors[gname].lever_arm()[2])
            at = scales.depth_at_fixes(d.t, d.z[:, 0], g.t, above)
            if at is None or at.under_m <= scales.AIR_MARGIN_M:
                continue
            log.warning(
                "%s: sensor %r reads %.3g m (median) at %d fixes of sensor %r (%s) from t = "
                "%.1f to %.1f s, which puts its antenna %.3g m under water by the lever arms; a "
                "GNSS receiver fixes only above it: %s If %r is a USBL, or the depth right, "
                "set [sensors.%s] scale_check = false (docs/robustness.md, 'A depth offset at "
                "the surface')",
                cfg.file, name, at.depth_m, at.n, gname, config.sensors[gname].file,
                at.t_from, at.t_to, at.under_m, scales.surface_cause(at), gname, name,
            )  # fmt: skip


SCALE_FIX = "Fix the table, or, if it is right, set [sensors.{}] scale_check = false"
SCALE_DOC = "(docs/robustness.md, 'DVL and depth scales')"


def _check_dvl_track(
    config: MissionConfig,
    sensors: dict[str, SensorData],
    name: str,
    dvl: scales.Dvl,
    views: axes.ImuViews,
) -> None:
    """The DVL ``name`` against each GNSS track (its speed) and, with a heading (a heading
    sensor's, or the start's carried by the gyro: :func:`_dvl_heading`), the track's course
    (its direction): :func:`scales.dvl_track`."""
    file = config.sensors[name].file
    heading: tuple[Array, Array] | scales.Heading | None = None
    for gname, g in sensors.items():
        if g.kind != "gnss":
            continue
        if heading is None:
            heading, by = _dvl_heading(config, sensors, views, float(np.nanmedian(g.z[:, 0])))
        gcfg = config.sensors[gname]
        sigma = float(np.atleast_1d(gcfg.sigma_si())[0])
        track = scales.Track.of(g.t, g.z[:, 0], g.z[:, 1], sigma)
        speed, turn = scales.dvl_track(track, dvl, views.tilt(), views.gyro(), heading)
        against = f"the track of sensor {gname!r} ({gcfg.file})"
        if speed is not None and speed.outside(scales.SPEED_BAND):
            lo, hi = scales.SPEED_BAND
            raise MissionError(
                f"{file}: the speed of DVL {name!r} (vx_m_s, vy_m_s) against {against} from "
                f"t = {speed.t_from:.1f} to {speed.t_to:.1f} s: {speed.k:.3g} ± {speed.se:.2g} m "
                f"of the DVL's per m of the track's over {speed.n} chords of "
                f"{scales.SPEED_CHORD_S:g} s (1 expected; outside {lo:g}-{hi:g} even "
                f"{scales.CONFIDENCE:g} σ in): {scales.speed_cause(speed)} "
                f"{SCALE_FIX.format(name)} {SCALE_DOC}",
                file=file,
                field="vx_m_s",
            )
        if turn is not None and turn.turned():
            carried = isinstance(heading, scales.Heading)
            raise MissionError(
                f"{file}: the direction of DVL {name!r} (vx_m_s, vy_m_s), turned by {by}, "
                f"against the course of {against} from t = "
                f"{turn.t_from:.1f} to {turn.t_to:.1f} s: {turn.angle_deg:+.1f}° ± "
                f"{turn.angle_se_deg:.2g}° off over {turn.n} chords (0 expected; beyond "
                f"{scales.MAX_TURN_DEG:g}° even {scales.CONFIDENCE:g} σ in): "
                f"{scales.turn_cause(turn, carried)} {SCALE_FIX.format(name)} {SCALE_DOC}",
                file=file,
                field="vx_m_s",
            )
        if turn is not None and turn.off_course():
            _warn_off_course(config, sensors, name, (against, by), turn)


def _warn_off_course(
    config: MissionConfig,
    sensors: dict[str, SensorData],
    name: str,
    words: tuple[str, str],
    turn: scales.Fit,
) -> None:
    """Warn that DVL ``name``'s direction, turned by the heading (``words``: the GNSS track it
    is judged against, and the heading), lies a few degrees off the GNSS course, decided
    (:meth:`scales.Fit.off_course`; since 0.4.13, up to 0.4.12 a 5° declination not set on the
    demo ran 17.8 m RMS against 3.5 m right, silent): a heading sensor's ``declination_deg`` or
    ``initial.rpy_deg``'s yaw, and the DVL's ``mounting_rpy_deg`` yaw, named with the value
    that would take the angle off (each the value now plus the angle: the heading, or the
    DVL's body direction, is that much short). Not an error: a water-track DVL's drift angle
    in a current gives a few degrees too (docs/robustness.md, 'A heading a few degrees off the
    GNSS course')."""
    against, by = words
    a, dcfg = turn.angle_deg, config.sensors[name]
    mount = dcfg.mounting_rpy_deg[2] if dcfg.mounting_rpy_deg is not None else 0.0
    sensor = next((d for d in sensors.values() if d.kind == "heading"), None)
    if sensor is not None:
        hcfg = config.sensors[sensor.name]
        now = hcfg.declination_deg or 0.0
        heading = (
            f"a magnetic heading whose declination is not set: declination_deg = {now + a:.1f} in "
            f"[sensors.{sensor.name}] (now {now:g}; the readings are taken as true headings "
            "less it)"
        )
    else:
        rpy = config.initial.rpy_deg
        yaw = rpy[2] if rpy is not None else 0.0
        heading = f"initial.rpy_deg's yaw off: {yaw + a:.1f}° (now {yaw:.1f}°)"
    log.warning(
        "%s: the direction of DVL %r (vx_m_s, vy_m_s), turned by %s, against the course of %s "
        "from t = %.1f to %.1f s: %+.1f° ± %.2g° off over %d chords (0 expected; beyond %g° and "
        "%g σ): %s, or the DVL's mounting_rpy_deg yaw not set: %.1f° in [sensors.%s] (now %g)? "
        "A water-track DVL's drift angle in a current gives a few degrees too. If it is "
        "right, set [sensors.%s] scale_check = false (docs/robustness.md, 'A heading a few "
        "degrees off the GNSS course')",
        dcfg.file, name, by, against, turn.t_from, turn.t_to, a, turn.angle_se_deg, turn.n,
        scales.WARN_TURN_DEG, scales.CONFIDENCE, heading, mount + a, name, mount, name,
    )  # fmt: skip


def _dvl_heading(
    config: MissionConfig,
    sensors: dict[str, SensorData],
    views: axes.ImuViews,
    lat: float,
) -> tuple[tuple[Array, Array] | scales.Heading | None, str]:
    """The heading the DVL's direction is judged by, and its words: the first heading sensor's
    readings (``use`` aid or init); else ``initial.rpy_deg``'s yaw with its σ
    (``sigma_attitude_deg``) carried from the IMU's start by the gyro at latitude ``lat``
    (rad), drifting by the gyro's bias σ (``imu.initial_bias_sigma``) and ARW
    (:func:`scales.carried_yaw`; since 0.4.10); else none (a gyrocompass's heading is not
    known at load): nothing is said."""
    sensor = next((d for d in sensors.values() if d.kind == "heading"), None)
    if sensor is not None:
        return (sensor.t, sensor.z[:, 0]), f"the heading of sensor {sensor.name!r}"
    rpy = config.initial.rpy_deg
    if rpy is None or not math.isfinite(lat):
        return None, ""
    noise = config.imu.noise.to_imu_noise()
    sigma = float(config.initial.sigma_attitude_rad()[2])
    start = scales.StartYaw(
        math.radians(rpy[2]), sigma, config.imu.initial_bias_sigma.si(noise)[0], noise.arw
    )
    words = (
        f"the start's heading (initial.rpy_deg's yaw {rpy[2]:.1f}° ± {math.degrees(sigma):.2g}°) "
        "carried by the gyro"
    )
    return scales.carried_yaw(views.gyro(), views.tilt(), lat, start), words


def _check_depth_scale(
    config: MissionConfig,
    sensors: dict[str, SensorData],
    name: str,
    dvl: scales.Dvl,
    views: axes.ImuViews,
) -> None:
    """Each depth meter against the DVL ``name``'s vertical velocity: :func:`scales.depth_scale`."""
    dcfg = config.sensors[name]
    for dname, d in sensors.items():
        cfg = config.sensors[dname]
        if d.kind != "depth" or not cfg.check_scale:
            continue
        fit = scales.depth_scale(
            d.t, d.z[:, 0], dvl, views.tilt(), cfg.lever_arm() - dcfg.lever_arm()
        )
        if fit is None or not fit.outside(scales.DEPTH_BAND):
            continue
        cause = scales.depth_cause(fit)
        on_dvl = fit.k < 0.0 or cause.startswith("the DVL in")
        file, column, fix = (dcfg.file, "vx_m_s", name) if on_dvl else (cfg.file, "depth_m", dname)
        lo, hi = scales.DEPTH_BAND
        raise MissionError(
            f"{file}: the depth of sensor {dname!r} ({cfg.file}, depth_m) against the vertical "
            f"velocity of DVL {name!r} ({dcfg.file}) from t = {fit.t_from:.1f} to "
            f"{fit.t_to:.1f} s: {fit.k:.3g} ± {fit.se:.2g} m of depth per m the DVL moves down "
            f"over {fit.n} intervals of {scales.DEPTH_INTERVAL_S:g} s (1 expected; outside "
            f"{lo:g}-{hi:g} even {scales.CONFIDENCE:g} σ in): {cause} "
            f"{SCALE_FIX.format(fix)} {SCALE_DOC}",
            file=file,
            field=column,
        )


def _load_off_sensor(
    table: Callable[[str], Table], name: str, cfg: SensorConfig, journal: Journal, root: Path
) -> SensorData | None:
    """A sensor with ``use = "off"``: its readings are read only to give each its fate in the
    ledger ("sensor off"); a table that is missing or bad is skipped, not an error. A missing
    one is logged; a bad one is a repair (:data:`OFF_UNREAD`), since its readings get no ledger
    row (up to 0.4.8 only an INFO line said so: the run's output had no trace of them)."""
    scratch = Journal()
    try:
        data = _load_sensor(table(cfg.file), name, cfg, scratch)
    except MissionError as exc:
        if not (root / cfg.file).exists():
            log.info("sensor %r: use = 'off', its table not read (%s)", name, exc)
        else:
            why = f"sensor {name!r} (use = 'off'): its readings are in no ledger: {exc}"
            journal.repair(exc.file or cfg.file, exc.line, exc.field or "", OFF_UNREAD, why)
        return None
    journal.repairs.extend(scratch.repairs)
    journal.dropped.extend(scratch.dropped)
    if data is None:  # an optional sensor with no rows
        return None
    log.info("sensor %r: use = 'off', %d reading(s) read, not used", name, len(data.t))
    return data


def _resolve(path: Path, label: str) -> Path:
    """``path`` with every symbolic link followed; a loop (or a path the system cannot
    follow) is a MissionError naming ``label``."""
    try:
        return path.resolve()
    except (RuntimeError, OSError) as exc:  # RuntimeError: Python < 3.13's symlink loop
        why = "a symbolic link loop" if "loop" in str(exc).lower() else str(exc)
        raise MissionError(f"{label}: cannot follow the path ({why})", file=label) from None


def _rows_equal(a: Array, b: Array) -> bool:
    return bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def _load_imu(table: Table, config: MissionConfig, journal: Journal) -> ImuData:
    """IMU table → intervals, with the checks and repairs of docs/data-format.md."""
    cfg = config.imu
    rates = cfg.format == "rates"
    if len(table) == 0:
        raise MissionError(f"{table.label} (imu): no data rows", file=table.label)
    t, v, used = take_columns(table, imu_columns(cfg.format), "imu", journal)
    check_order(table, t)
    rows = np.flatnonzero(_drop_duplicate_rows(table, t, v, journal))
    if not rates:
        t = _jittered_stamps(table, t, v, rows, cfg.restamp_jitter, journal)
    # Increments: each row's own interval, before rows with NaN are removed (see below).
    own_dt = np.diff(t[rows], prepend=t[rows[0]] - 1.0 / cfg.rate_hz)
    if not rates:
        _lost_samples(table, v, rows, own_dt, journal)
    finite = _finite_rows(table, v, rows, used, journal)
    rows, own_dt = rows[finite], own_dt[finite]
    need = 2 if rates else 1
    if rows.size < need:
        raise MissionError(
            f"{table.label} (imu): {rows.size} valid sample(s), at least {need} needed",
            file=table.label,
        )
    v = _kept(v, rows)
    _check_magnitudes(table, v, own_dt, rows, used, rates)
    tk = t[rows]
    gaps = np.diff(tk)
    _check_gaps(table, tk, gaps, rows, cfg.gap_limit_s)
    _check_frozen(table, tk, v, rows, used, cfg.stuck_limit_s)
    _check_channel_stuck(table, tk, v, rows, used, cfg.channel_stuck_limit_s)
    _check_saturated(table, tk, v, rows, used, cfg.saturation_limit)
    med = float(np.median(gaps)) if gaps.size else 1.0 / cfg.rate_hz
    if abs(med * cfg.rate_hz - 1.0) > RATE_MISMATCH:
        log.warning(
            "%s: median IMU interval %.6g s does not match imu.rate_hz = %g (%.6g s)",
            table.label,
            med,
            cfg.rate_hz,
            1.0 / cfg.rate_hz,
        )
    if rates:
        # A hole (samples lost or dropped) is integrated by the trapezoid of the rates either
        # side; since 0.4.13 P grows over it by what that misses (up to 0.4.12: white noise).
        holes = find_rate_holes(v[:, :3], v[:, 3:], gaps, rows, med)
        _warn_wide_holes(table, holes, gaps)
        _journal_rate_holes(table, holes, gaps, journal)
        dtheta, dvel = rates_to_increments(v[:, :3], v[:, 3:], gaps)
        return ImuData(tk[1:].copy(), gaps, dtheta, dvel, holes)
    # A row dropped for NaN leaves a hole: the next interval is stretched back to the previous
    # kept sample and the hole filled (_filled), so that gravity and the measured specific
    # force stay integrated over the same time.
    dt = np.concatenate([own_dt[:1], gaps])
    holes = find_holes(v[:, :3], v[:, 3:], own_dt, dt, rows, med)
    _warn_wide_holes(table, holes, dt)
    dtheta, dvel = _filled(v, own_dt, dt, holes)
    return ImuData(tk.copy(), dt, dtheta, dvel, holes)


def _filled(v: Array, own_dt: Array, dt: Array, holes: ImuHoles) -> tuple[Array, Array]:
    """The increments over the intervals ``dt``: a row's own over its own interval, scaled by
    the ratio of the two (1 but at the holes: the row's rate over the hole, a constant rate);
    at a hole beyond the default ``imu.max_gap_s`` (imu_holes.trapezoid), the row's own
    increments plus the lost time at the mean of the rates of the rows either side, the
    trapezoid of rates (docs/robustness.md, 'The σ over a hole'). Since 0.4.13; up to 0.4.12
    every hole was stretched at the row's rate, 1.3 (60 s lost) to 6 (1 s) times the RMS error
    of the trapezoid on the demo's and paper-1's own IMU."""
    scale = (dt / own_dt)[:, None]
    out = v[:, :3] * scale, v[:, 3:] * scale
    long = np.array([trapezoid(int(m)) for m in holes.periods.tolist()], dtype=bool)
    j = holes.index[long & (holes.index > 0)]
    lost = (dt[j] - own_dt[j])[:, None]
    for c, x in enumerate(out):
        cols = slice(3 * c, 3 * c + 3)
        mean = 0.5 * (v[j - 1, cols] / own_dt[j - 1, None] + v[j, cols] / own_dt[j, None])
        x[j] = v[j, cols] + lost * mean
    return out


def _journal_rate_holes(table: Table, holes: ImuHoles, gaps: Array, journal: Journal) -> None:
    """A repair for each hole of an IMU in rates, on the row after it: the hole integrated by
    the trapezoid of the rates either side, with the σ the engine adds to P over it
    (docs/robustness.md, 'The σ over a hole'). Since 0.4.13; up to 0.4.12 such a hole was
    integrated the same way, but silently and with P grown by the white noise alone."""
    sd = np.sqrt(holes.var)
    for j in range(len(holes)):
        r = int(holes.row[j])
        att = ", ".join(f"{math.degrees(float(x)):.3g}" for x in sd[j, 3:])
        vel = ", ".join(f"{float(x):.3g}" for x in sd[j, :3])
        journal.repair(
            table.label,
            int(table.lines[r]),
            TIME_COLUMN,
            "hole filled by the trapezoid of rates",
            f"{float(gaps[holes.index[j]]):.6g} s since the previous sample, about "
            f"{int(holes.periods[j]) - 1:d} sample(s) lost or dropped: the rates either side "
            f"integrated across it, its error's σ (body x, y, z) added to P: attitude {att}°, "
            f"velocity {vel} m/s",
        )


def _warn_wide_holes(table: Table, holes: ImuHoles, dt: Array) -> None:
    """A warning for each hole whose motion leaves the attitude unknown beyond
    :data:`~adaptnav.mission.imu_holes.WIDE_HOLE_RAD` on an axis: the engine adds it to P, but
    the filter's error model is linear in small angles (docs/robustness.md, 'The σ over a
    hole')."""
    sd = np.sqrt(holes.var[:, 3:].max(axis=1)) if len(holes) else np.zeros(0)
    for j in np.flatnonzero(sd > WIDE_HOLE_RAD).tolist():
        r = int(holes.row[j])
        log.warning(
            "%s: %.6g s of IMU samples lost before %s: the motion in such a hole, by the "
            "mission's own IMU, leaves the attitude unknown by %.3g° (σ), beyond the small "
            "angles of the filter's error model: the run after it may be far off its σ "
            "(lower imu.max_gap_s to refuse such holes); docs/robustness.md, 'The σ over a hole'",
            table.label,
            float(dt[holes.index[j]]),
            table.where(r),
            math.degrees(float(sd[j])),
        )


def _jittered_stamps(
    table: Table, t: Array, v: Array, rows: NDArray[np.int64], restamp: bool, journal: Journal
) -> Array:
    """``t`` with the kept ``rows`` re-stamped on the grid their stamps scatter about, when the
    increments are one period each whatever the stamps say (:mod:`adaptnav.mission.imu_stamps`):
    a repair, "re-stamped on the fitted grid", unless ``imu.restamp = false`` or a row's count
    of periods is uncertain, when it is a warning (docs/robustness.md, 'Jittered IMU stamps').
    Up to 0.4.8 the stamps were taken as they were. ``t`` itself when nothing is done."""
    fit = fit_stamp_grid(t[rows], v[rows, 3:])
    if fit is None or not fit.jitter:
        return t
    first = int(table.lines[rows[0]])
    what = (
        f"stamps scattered by σ = {fit.sigma * 1e3:.3g} ms (up to {fit.worst * 1e3:.3g} ms) about "
        f"a grid of {fit.period:.6g} s while the increments are one period each (|Δv| does not "
        f"follow the stamped interval: slope {fit.follow:.2f}, 1 if it did)"
    )
    error = G0 * fit.sigma
    if restamp and fit.certain:
        journal.repair(
            table.label,
            first,
            TIME_COLUMN,
            "re-stamped on the fitted grid",
            f"{what}; taken as they were, gravity would be integrated over the stamped intervals:"
            f" a vertical velocity error of about {error:.2g} m/s (g σ) at every row",
        )
        out = t.copy()
        out[rows] = fit.stamps
        return out
    why = (
        "imu.restamp = false"
        if not restamp
        else "the count of periods per row is uncertain: the stamps' offset from the grid steps by "
        "half a period or more where no row's count explains it (jitter near half a period, or "
        "a clock that jumps)"
    )
    log.warning(
        "%s: %s; not re-stamped (%s): the engine integrates gravity over the stamped intervals, "
        "a vertical velocity error of about %.2g m/s (g σ) at every row that its σ does not hold; "
        "docs/robustness.md, 'Jittered IMU stamps'",
        table.label,
        what,
        why,
        error,
    )
    return t


def _kept(v: Array, rows: NDArray[np.int64]) -> Array:
    """``v[rows]`` for the sorted, unique ``rows`` the checks kept; ``v`` itself when they kept
    every row (the usual case: no copy of a day of IMU, docs/robustness.md 'Memory')."""
    return v if rows.size == len(v) else v[rows]


def _drop_duplicate_rows(table: Table, t: Array, v: Array, journal: Journal) -> NDArray[np.bool_]:
    """Rows to keep: a row repeating the previous one's time and values is dropped (a
    repair); the same time with other values is a MissionError (docs/data-format.md)."""
    keep = np.ones(t.size, dtype=bool)
    for k in np.flatnonzero(np.diff(t) == 0.0):
        if _rows_equal(v[k], v[k + 1]):
            journal.repair(
                table.label,
                int(table.lines[k + 1]),
                TIME_COLUMN,
                "dropped duplicate row",
                f"same time and values as {table.where(int(k))}",
            )
            keep[k + 1] = False
        else:
            raise table.error(
                int(k + 1),
                TIME_COLUMN,
                f"repeated time t = {show(t[k])} s (also at {table.where(int(k))}) with different "
                "values",
            )
    return keep


def _lost_samples(
    table: Table, v: Array, rows: NDArray[np.int64], own_dt: Array, journal: Journal
) -> None:
    """Increments after lost samples: a row whose interval is more than
    :data:`LOST_SAMPLE_FACTOR` times the IMU's local period p (the median over its
    :data:`LOST_SAMPLE_WINDOW` neighbours either side), a whole number m of them, holds the
    increments of ``k = round(|dv| / (f p))`` periods (f the local specific force, the median of
    ``|dv| / dt`` over the same rows), between 1 and m; when ``k < m`` the samples before were
    lost. Its ``own_dt`` is set to ``k p`` in place, so that its increments are scaled over the
    hole as a row after a dropped NaN row's (docs/data-format.md); each is a repair. A longer
    interval whose increments span it (k = m: an IMU that accumulates until it is read) is left
    as it is, and so are one beside a short interval and one that is not within a quarter
    period of a whole number of periods (jittered stamps, not lost samples). Up to 0.4.8 no
    such row was repaired; the first 0.4.9 version knew only k = 1 or k = m, and a row of two
    periods' increments over three was taken as three (a 0.1-m/s down-velocity step). Up to
    0.4.9 the last row was never a candidate (its own interval stood for the one after it) and
    the window near an end repeated the end row; since 0.4.10 an end row's neighbour is the one
    it has, and the window slides inside the table."""
    n = own_dt.size
    # an end row's missing neighbour is its other one (the last row's, the one before it)
    before = np.concatenate([own_dt[1:2], own_dt[:-1]]) if n > 1 else own_dt
    after = np.concatenate([own_dt[1:], own_dt[-2:-1]]) if n > 1 else own_dt
    shortest = np.minimum(before, after)
    cand = np.flatnonzero(own_dt > LOST_SAMPLE_FACTOR * shortest)
    found: list[tuple[int, float, float]] = []
    reach = np.arange(2 * LOST_SAMPLE_WINDOW + 1)
    # In blocks: each candidate takes 2 W + 1 rows of temporaries, and bursty stamps can make
    # every other row a candidate (a day at 100 Hz would otherwise need gigabytes).
    for c in np.array_split(cand, max(1, cand.size // LOST_SAMPLE_BLOCK + 1)):
        if not c.size:
            continue
        # near an end the window slides inside the table (not the end row repeated)
        start = np.clip(c - LOST_SAMPLE_WINDOW, 0, max(n - reach.size, 0))
        near = np.minimum(start[:, None] + reach, n - 1)
        period = np.median(own_dt[near], axis=1)
        force = np.linalg.norm(v[rows[near], 3:], axis=2) / own_dt[near]
        ratio = own_dt[c] / period
        m = np.rint(ratio)  # the whole periods of the interval
        lost = (ratio > LOST_SAMPLE_FACTOR) & (np.abs(ratio - m) < 0.25)
        lost &= shortest[c] > 0.75 * period  # regular either side
        # the periods the increments cover: |Δv| against the local specific force's per period
        covered = np.linalg.norm(v[rows[c], 3:], axis=1) / (np.nanmedian(force, axis=1) * period)
        held = np.clip(np.rint(covered), 1.0, m)
        lost &= held < m
        found += zip(
            c[lost].tolist(), (held * period)[lost].tolist(), period[lost].tolist(), strict=True
        )
    for k, p, local in found:
        r = int(rows[k])
        journal.repair(
            table.label,
            int(table.lines[r]),
            TIME_COLUMN,
            "stretched increments over lost samples",
            f"{own_dt[k]:.6g} s since the previous row, and increments of {p:.6g} s: about "
            f"{round((own_dt[k] - p) / local):d} sample(s) lost, the row's increments scaled "
            f"by {own_dt[k] / p:.4g} (constant rate over the hole)"
            + (
                " or, beyond the default max_gap_s, the hole filled at the mean of the rates "
                "either side"
                if trapezoid(round(own_dt[k] / local))
                else ""
            ),
        )
        own_dt[k] = p


def _finite_rows(
    table: Table, v: Array, rows: NDArray[np.int64], used: list[str], journal: Journal
) -> NDArray[np.bool_]:
    """Which of ``rows`` have every IMU value finite; the others are dropped, each a repair
    naming its first non-finite column (docs/data-format.md)."""
    finite = np.all(np.isfinite(_kept(v, rows)), axis=1)
    for j in np.flatnonzero(~finite):
        r = int(rows[j])
        bad = used[1 + int(np.flatnonzero(~np.isfinite(v[r]))[0])]
        journal.repair(
            table.label,
            int(table.lines[r]),
            bad,
            "dropped row with non-finite value",
            f"{bad} = {show(table.df[bad].iloc[r])}",
        )
    return np.asarray(finite, dtype=bool)


def _check_magnitudes(
    table: Table,
    v: Array,
    own_dt: Array,
    rows: NDArray[np.int64],
    used: list[str],
    rates: bool,
) -> None:
    """|gyro| <= 20 rad/s and |accel| <= 20 g per component, else (probably) wrong units; and
    the specific force's median near gravity (:func:`_check_gravity`)."""
    found = _first_over(v, own_dt, rates)
    if found is None:
        _check_gravity(table, v, own_dt, rates, used)
        return
    j, c = found
    w = v[j, c] if rates else v[j, c] / own_dt[j]
    r = int(rows[j])
    col = used[1 + c]
    gyro = c < 3
    limit = "20 rad/s" if gyro else f"20 g = {MAX_ACCEL_M_S2:.1f} m/s²"
    hint = "deg/s (or deg) given as rad/s (rad)?" if gyro else "not m/s² (m/s), e.g. mm/s² or ft?"
    what = (
        f"value {show(v[j, c])}"
        if rates
        else f"value {show(v[j, c])} over dt = {own_dt[j]:.6g} s is a rate of {w:.6g}"
    )
    raise table.error(r, col, f"{what} exceeds {limit}: wrong units? ({hint})")


GRAVITY_BAND = (0.5, 1.5)
"""The median |specific force| over an IMU table must lie within these multiples of g
(:func:`_check_gravity`)."""
GRAVITY_SAMPLES = 1 << 20
"""Rows, evenly spread, whose |specific force| give the median (:func:`_check_gravity`)."""


def _check_gravity(table: Table, v: Array, own_dt: Array, rates: bool, used: list[str]) -> None:
    """A MissionError when the median |specific force| of the IMU's rows is outside
    :data:`GRAVITY_BAND` × g: a vehicle that floats, drives or flies spends its time near
    1 g, so the table's accelerations are in another unit (g: a median of 1.0 "m/s²"; mg) or
    have gravity taken out (an AHRS's "free" or "linear" acceleration, which an INS cannot
    use: it needs the specific force). Up to 0.4.8 such tables were integrated: in g, the
    alignment said only "not static", and a state start diverged minutes later."""
    step = max(1, len(v) // GRAVITY_SAMPLES)
    w = v[::step, 3:] if rates else v[::step, 3:] / own_dt[::step, None]
    med = float(np.median(np.linalg.norm(w, axis=1)))
    lo, hi = GRAVITY_BAND
    if lo * G0 <= med <= hi * G0:
        return
    raise MissionError(
        f"{table.label}, {', '.join(used[4:7])}: {specific_force_words(med, 'the table')}",
        file=table.label,
        field=used[4],
    )


def specific_force_words(median: float, over: str) -> str:
    """What a median |specific force| (m/s²) ``over`` some IMU samples outside
    :data:`GRAVITY_BAND` says (the loader's error, and a stream's: mission/live_imu.py)."""
    return (
        f"the median |specific force| over {over} is {median:.4g} m/s², where a vehicle's is "
        f"near gravity ({G0:.4g} m/s²): the accelerations not in m/s² (in g: × {G0}), or "
        "gravity taken out (a 'free' or 'linear' acceleration: the INS needs the specific "
        "force, gravity included)?"
    )


def _first_over(v: Array, own_dt: Array, rates: bool) -> tuple[int, int] | None:
    """The first (row, column) of ``v`` whose rate exceeds :data:`MAX_GYRO_RAD_S` or
    :data:`MAX_ACCEL_M_S2`, checked a block of rows at a time: a day of IMU needs no
    full-size temporaries."""
    limits = np.array([MAX_GYRO_RAD_S] * 3 + [MAX_ACCEL_M_S2] * 3)
    for start in range(0, len(v), CHECK_BLOCK):
        block = slice(start, start + CHECK_BLOCK)
        w = v[block] if rates else v[block] / own_dt[block, None]
        over = np.argwhere(np.abs(w) > limits)
        if over.size:
            return start + int(over[0, 0]), int(over[0, 1])
    return None


def _check_gaps(
    table: Table, tk: Array, gaps: Array, rows: NDArray[np.int64], limit: float
) -> None:
    big = np.flatnonzero(gaps > limit)
    if not big.size:
        return
    k = int(big[0])
    r0, r1 = int(rows[k]), int(rows[k + 1])
    dropped = r1 - r0 - 1
    why = f" ({dropped} row(s) between them were dropped, see the log)" if dropped else ""
    raise MissionError(
        f"{table.label}: IMU gap of {gaps[k]:.6g} s between {table.where(r0)} "
        f"(t = {show(tk[k])} s) and {table.where(r1)} (t = {show(tk[k + 1])} s) exceeds "
        f"imu.max_gap_s = {limit:.6g} s{why}",
        file=table.label,
        line=int(table.lines[r1]),
        field=TIME_COLUMN,
    )


def _check_frozen(
    table: Table, tk: Array, v: Array, rows: NDArray[np.int64], used: list[str], limit: float
) -> None:
    """A MissionError if every IMU value stays unchanged for ``limit`` seconds or longer (a
    frozen IMU, or a driver repeating its last sample): a real IMU's noise moves some value at
    every sample (docs/robustness.md, 'A frozen IMU'). ``limit`` 0: not checked."""
    if limit <= 0.0 or len(v) < 2:
        return
    same = np.empty(len(v), dtype=bool)
    same[0] = False
    for start in range(1, len(v), CHECK_BLOCK):
        block = slice(start, start + CHECK_BLOCK)
        prev = slice(start - 1, start - 1 + CHECK_BLOCK)
        same[block] = np.all(v[block] == v[prev][: len(same[block])], axis=1)
    edge = np.diff(same.view(np.int8), append=np.int8(0))  # repeats are rare: few edges
    first = np.flatnonzero(edge == 1)  # the row before each run of repeated rows
    last = np.flatnonzero(edge == -1)  # each run's last repeat
    long = np.flatnonzero(tk[last] - tk[first] >= limit)
    if not long.size:
        return
    a, b = int(first[long[0]]), int(last[long[0]])
    raise table.error(
        int(rows[a + 1]),
        ", ".join(used[1:]),
        f"every IMU value unchanged for {tk[b] - tk[a]:.6g} s, from {table.where(int(rows[a]))} "
        f"(t = {show(tk[a])} s) to {table.where(int(rows[b]))} (t = {show(tk[b])} s): a frozen "
        "IMU or driver repeating its last sample? Remove those rows (a gap, imu.max_gap_s) or, "
        f"if they are right, set imu.stuck_s above {tk[b] - tk[a]:.6g} s (0: not checked)",
    )


CHANNEL_QUANTISED_SHARE = 0.5
"""A channel that repeats its value on this share of its samples or more is coarse against its
noise (a quantised output), not stuck; so is a span in which the other channels of its triad do
(:func:`_check_channel_stuck`). The A-KIT gyros repeat on at most 22 % of their samples."""
CHANNEL_MIN_ELSEWHERE = 100
"""Fewest samples outside a channel's long runs for its repeats elsewhere to be judged: a
column constant throughout is not this check's (a dead gyro axis: ``axes.dead_axis``)."""


@dataclass(frozen=True)
class StuckChannel:
    """Column ``column`` of an IMU table unchanged on rows ``a``..``b`` (0-based, of the kept
    rows) while its triad's other channels change on ``others`` of those samples (share, the
    most changing of the two) and it repeats on ``elsewhere`` of its samples outside its long
    runs (share)."""

    column: int
    a: int
    b: int
    others: float
    elsewhere: float


def _repeats(x: Array) -> NDArray[np.bool_]:
    """``x[k] == x[k - 1]`` for each k (False for the first)."""
    same = np.zeros(x.size, dtype=bool)
    np.equal(x[1:], x[:-1], out=same[1:])
    return same


def stuck_channel(tk: Array, v: Array, limit: float) -> StuckChannel | None:
    """The first IMU channel (column of ``v``, six: Δθ or ω, then Δv or f) unchanged for
    ``limit`` seconds or longer while another channel of its triad changes on more than
    :data:`CHANNEL_QUANTISED_SHARE` of those samples and the channel itself repeats on less
    than that share of its samples elsewhere (docs/robustness.md, 'One IMU channel stuck')."""
    found: list[StuckChannel] = []
    for c in range(v.shape[1]):
        same = _repeats(v[:, c])
        edge = np.diff(same.view(np.int8), append=np.int8(0))
        first, last = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)
        long = np.flatnonzero(tk[last] - tk[first] >= limit)
        if not long.size:
            continue
        held = int(sum(int(last[i] - first[i]) for i in long))  # repeats in the long runs
        outside = same.size - 1 - held
        if outside < CHANNEL_MIN_ELSEWHERE:
            continue
        elsewhere = (int(np.count_nonzero(same)) - held) / outside
        if elsewhere >= CHANNEL_QUANTISED_SHARE:
            continue
        triad = [d for d in range(3 * (c // 3), 3 * (c // 3) + 3) if d != c]
        for i in long:
            a, b = int(first[i]), int(last[i])
            moving = max(1.0 - float(np.mean(_repeats(v[a : b + 1, d])[1:])) for d in triad)
            if moving > 1.0 - CHANNEL_QUANTISED_SHARE:
                found.append(StuckChannel(c, a, b, moving, elsewhere))
                break
    return min(found, key=lambda f: f.a) if found else None


def _check_channel_stuck(
    table: Table, tk: Array, v: Array, rows: NDArray[np.int64], used: list[str], limit: float
) -> None:
    """A MissionError naming the column and the first and last rows of one IMU channel stuck
    (:func:`stuck_channel`): a real IMU's noise moves every channel at every sample unless its
    output step is coarse against it (docs/robustness.md, 'One IMU channel stuck'). Up to 0.4.12
    only every value frozen at once was refused (:func:`_check_frozen`). ``limit`` 0: not
    checked."""
    if limit <= 0.0 or len(v) < 3:
        return
    found = stuck_channel(tk, v, limit)
    if found is None:
        return
    a, b, c = found.a, found.b, found.column
    col = used[1 + c]
    triad = [used[1 + d] for d in range(3 * (c // 3), 3 * (c // 3) + 3) if d != c]
    span = tk[b] - tk[a]
    raise table.error(
        int(rows[a + 1]),
        col,
        f"unchanged at {show(v[a, c])} for {span:.6g} s, from {table.where(int(rows[a]))} (t = "
        f"{show(tk[a])} s) to {table.where(int(rows[b]))} (t = {show(tk[b])} s), while "
        f"{' or '.join(triad)} changed on {found.others:.0%} of those samples and {col} itself "
        f"repeats on {found.elsewhere:.1%} of its samples elsewhere: a channel stuck or dead "
        "(its last value, or 0, repeated)? Remove those rows, or cut the mission before them; "
        f"if they are right (an output step coarse against the noise), set imu.channel_stuck_s "
        f"above {span:.6g} s (0: not checked)",
    )


def _check_saturated(
    table: Table, tk: Array, v: Array, rows: NDArray[np.int64], used: list[str], limit: int
) -> None:
    """A MissionError if some IMU column holds its largest or smallest value (not 0) on
    ``limit`` rows or more, piled up there: at least :data:`SATURATION_PILEUP` times as many
    rows as hold the next value inward. Clipped at the IMU's range, the motion beyond it lost
    (docs/robustness.md, 'A saturated IMU'). A quantized IMU at rest also repeats its extreme
    values, but fewer times than the values next to them (a tail: since 0.4.9 not refused, as
    the check's first version did); one whose noise is below its step may pile up at the step
    farther from zero, in a column of fewer than :data:`SATURATION_LEVELS` values (since 0.4.13
    not refused). ``limit`` 0: not checked."""
    if limit <= 0:
        return
    for c in range(v.shape[1]):
        col = v[:, c]
        for side, value in (("largest", float(col.max())), ("smallest", float(col.min()))):
            at = col == value
            n = int(np.count_nonzero(at))
            if value == 0.0 or n < limit or n == col.size:
                continue
            if side == "largest":  # the next value inward, without a copy of the column
                nxt = float(np.max(col, where=col < value, initial=-np.inf))
            else:
                nxt = float(np.min(col, where=col > value, initial=np.inf))
            if n < SATURATION_PILEUP * int(np.count_nonzero(col == nxt)):
                continue
            if not _levels_at_least(col, SATURATION_LEVELS):
                continue  # an IMU at rest, its noise below its step
            where = np.flatnonzero(at)
            a, b = int(where[0]), int(where[-1])
            raise table.error(
                int(rows[a]),
                used[1 + c],
                f"{n} rows, the first here (t = {show(tk[a])} s) and the last at "
                f"{table.where(int(rows[b]))} (t = {show(tk[b])} s), hold the column's {side} "
                f"value, {show(value)}: clipped "
                "at the IMU's range (saturated)? The motion beyond it is lost and the navigation "
                "through it wrong; if the values are right, set imu.saturation_rows above "
                f"{n} (0: not checked)",
            )


def _levels_at_least(col: Array, k: int) -> bool:
    """Whether ``col`` takes ``k`` distinct values or more: the few values at each end are
    stepped over first (a pile-up is rare: one pass per value, no sort of a day of IMU)."""
    hi = np.inf
    for _ in range(k - 1):
        below = col < hi
        if not below.any():
            return False
        hi = float(np.max(col, where=below, initial=-np.inf))
    return bool(np.any(col < hi))


def _load_sensor(table: Table, name: str, cfg: SensorConfig, journal: Journal) -> SensorData | None:
    """A sensor table → readings; NaN readings are kept (the engine drops them, logged)."""
    if table.cut is not None:
        line, t_cut = table.cut
        journal.drop(
            table.label,
            f"{table.label} line {line}",
            DroppedRow(name, len(table), t_cut - (cfg.latency_s or 0.0), TRUNCATED_REASON),
            logged=False,
        )
    if len(table) == 0:
        if cfg.optional:
            journal.repair(
                table.label, None, "", "disabled sensor", f"sensor {name!r}: no rows (optional)"
            )
            return None
        raise MissionError(
            f"sensor {name!r} ({table.label}): no samples (set optional = true to run without it)",
            file=table.label,
        )
    t, z, used = take_columns(table, cfg.columns, f"sensor {name!r}", journal)
    check_order(table, t)
    if cfg.latency_s:  # the readings' own times (docs/data-format.md, 'Latency')
        t = t - cfg.latency_s
        log.info("sensor %r: readings taken %g s before their stamps (latency_s)", name,
                 cfg.latency_s)  # fmt: skip
    limits = cfg.limits_si()
    outside = _check_plausible(table, name, z, limits, used[1:])
    if declination := cfg.declination_rad():
        z = true_north(z, declination)
        log.info("sensor %r: magnetic headings turned to true north by %+g° (declination_deg)",
                 name, cfg.declination_deg)  # fmt: skip
    if cfg.limits is None:
        _check_kind_units(table, name, cfg, z, outside, used[1:])
    keep = np.ones(t.size, dtype=bool)
    for r in np.flatnonzero(np.diff(t) == 0.0) + 1:
        keep[r] = False
        journal.drop(
            table.label,
            table.where(int(r)),
            DroppedRow(name, int(r), float(t[r]), "duplicate timestamp"),
        )
    _drop_lost_lock(table, name, cfg, t, z, keep, journal)
    for r in np.flatnonzero(keep & outside.any(axis=1)):
        keep[r] = False
        c = int(np.flatnonzero(outside[r])[0])
        reason = implausible_reason(cfg, c, float(z[r, c]), limits)
        journal.drop(
            table.label, table.where(int(r)), DroppedRow(name, int(r), float(t[r]), reason)
        )
    _drop_screened(table, name, cfg, t, z, keep, journal)
    rows = np.flatnonzero(keep).astype(np.int64)
    tk = t[rows]
    if cfg.rate_hz is not None:
        period = 1.0 / cfg.rate_hz
        _check_rate(table, name, tk, period)
    elif tk.size >= 2:
        period = float(np.median(np.diff(tk)))
    else:
        period = math.nan
    return SensorData(name, cfg.kind, tk, z[rows], rows, period)


def _check_rate(table: Table, name: str, t: Array, period: float) -> None:
    """Warn when the median interval of a sensor's kept readings ``t`` is more than
    :data:`SENSOR_RATE_FACTOR` from its configured period ``1/rate_hz``: the configured one is
    what the spike screen's reach, Q adaptation's pairing of readings and MAESKF's restart
    after a gap take (up to 0.4.8 a DVL at 3 Hz set to 0.001 Hz ran without a word)."""
    if t.size < 3:
        return
    med = float(np.median(np.diff(t)))
    if med > 0.0 and max(med / period, period / med) > SENSOR_RATE_FACTOR:
        log.warning(
            "%s: sensor %r's median interval %.6g s is not its rate_hz = %g (%.6g s): the "
            "configured rate is the one used (spike screen, Q adaptation, gap restart); "
            "remove rate_hz to take the table's",
            table.label, name, med, 1.0 / period, period,
        )  # fmt: skip


def true_north(z: Array, declination: float) -> Array:
    """Headings ``z`` (rad) of a magnetic compass as true ones, ``wrap(z + D)`` in (-π, π]
    for the declination D (rad, east positive; ``declination_deg``, docs/data-format.md); NaN
    stays NaN, ±inf ±inf (up to the audit of 0.4.13 a RuntimeWarning). ``-D`` turns true
    headings back into the compass's."""
    z = np.asarray(z, dtype=float)
    # ±inf stays as it is, the engine's to drop as non-finite (np.remainder of inf warns).
    turned = attitude.wrap_angle(np.where(np.isfinite(z), z, 0.0) + declination)
    return np.asarray(np.where(np.isfinite(z), turned, z), dtype=float)


def _drop_lost_lock(
    table: Table,
    name: str,
    cfg: SensorConfig,
    t: Array,
    z: Array,
    keep: NDArray[np.bool_],
    journal: Journal,
) -> None:
    """Drop (``keep`` set False, ledger) the readings still kept that report a lost bottom
    lock: the ``status_column`` flag 0, or (``zero_is_lost``) all zeros (docs/data-format.md)."""
    if cfg.status_column is not None:
        lost = ~flag(table, cfg.status_column)
        reason = lost_status_reason(cfg.status_column)
        for r in np.flatnonzero(keep & lost):
            keep[r] = False
            journal.drop(
                table.label, table.where(int(r)), DroppedRow(name, int(r), float(t[r]), reason)
            )
    if cfg.zero_is_lost:
        for r in np.flatnonzero(keep & np.all(z == 0.0, axis=1)):
            keep[r] = False
            journal.drop(
                table.label,
                table.where(int(r)),
                DroppedRow(name, int(r), float(t[r]), LOST_LOCK_REASON),
            )


_UNIT = {"s": "m/s", "m": "m", "rad": "rad"}
"""Unit of a column by its name's last part (``vx_m_s`` → m/s, ``depth_m`` → m)."""


def _drop_screened(
    table: Table,
    name: str,
    cfg: SensorConfig,
    t: Array,
    z: Array,
    keep: NDArray[np.bool_],
    journal: Journal,
) -> None:
    """Drop (``keep`` set False, ledger) the readings still kept that the screening catches
    (:mod:`adaptnav.mission.screening`; docs/robustness.md): stuck runs, then isolated
    spikes, then the readings closer than ``min_interval_s`` to the last one kept."""
    for caught in (_stuck_caught, _spikes_caught, _thinned_caught):
        kept = np.flatnonzero(keep)
        for i, reason in caught(cfg, t[kept], z[kept]):
            r = int(kept[i])
            keep[r] = False
            journal.drop(table.label, table.where(r), DroppedRow(name, r, float(t[r]), reason))


def _stuck_caught(cfg: SensorConfig, t: Array, z: Array) -> list[tuple[int, str]]:
    """(index, "stuck: ...") of the readings ``t``, ``z`` that
    :func:`adaptnav.mission.screening.stuck_runs` catches: a run unchanged within
    ``resolution`` for ``stuck_s`` or longer, all but its first reading."""
    stuck_s = cfg.stuck_duration_s()
    if stuck_s <= 0.0:
        return []
    if cfg.kind == "dvl":
        # An all-zero vector is zero_is_lost's business (a lost bottom lock, or a vehicle
        # resting on the bottom: the user says which), so it breaks a run, like NaN.
        z = np.where(np.all(z == 0.0, axis=1)[:, None], np.nan, z)
    resolution = cfg.resolution_si()
    out = []
    for a, b in stuck_runs(t, z, resolution, stuck_s).tolist():
        reason = stuck_reason(cfg, resolution, float(t[a]), float(t[b]))
        out += [(i, reason) for i in range(a + 1, b + 1)]
    return out


def _spikes_caught(cfg: SensorConfig, t: Array, z: Array) -> list[tuple[int, str]]:
    """(index, "spike: ...") of the readings ``t``, ``z`` that
    :func:`adaptnav.mission.screening.spike_mask` finds: every reading when ``spike_mads`` is
    set, and the first readings after a gap of ``after_gap_s`` (a DVL's default) at
    :data:`~adaptnav.mission.screening.AFTER_GAP_MADS`."""
    mads, gap_s = cfg.spike_mads or 0.0, cfg.after_gap_duration_s()
    if not (mads > 0.0 or gap_s > 0.0) or t.size < 2:
        return []
    period = 1.0 / cfg.rate_hz if cfg.rate_hz is not None else float(np.median(np.diff(t)))
    floor = np.broadcast_to(np.asarray(cfg.sigma_si(), dtype=float), (z.shape[1],))
    # A reading with no finite value is no neighbour and no reading: a DVL that reports a
    # lost lock as NaN rows leaves a gap as one whose rows are missing does.
    rows = np.flatnonzero(np.any(np.isfinite(z), axis=1))
    t, z = t[rows], z[rows]
    caught = spike_mask(t, z, mads, floor, period)
    out = [(int(rows[i]), spike_reason(mads)) for i in np.flatnonzero(caught).tolist()]
    after = after_gap_mask(t, gap_s) & ~caught
    if after.any():
        found = spike_mask(t, z, AFTER_GAP_MADS, floor, period, judge=after)
        starts = np.flatnonzero(np.diff(t) >= gap_s) + 1
        for i in np.flatnonzero(found).tolist():
            a = int(starts[np.searchsorted(starts, i, side="right") - 1])
            out.append((int(rows[i]), after_gap_reason(float(t[a] - t[a - 1]), i - a + 1)))
    return sorted(out)


def _thinned_caught(cfg: SensorConfig, t: Array, z: Array) -> list[tuple[int, str]]:
    """(index, "thinned: ...") of the readings ``t``, ``z`` that
    :func:`adaptnav.mission.screening.thinned_mask` drops for ``min_interval_s`` (readings
    without a finite value do not count)."""
    gap = cfg.min_interval_s or 0.0
    if not gap > 0.0:
        return []
    usable = np.any(np.isfinite(z), axis=1)
    thin = thinned_mask(t, gap, usable)
    caught, anchors = np.flatnonzero(thin), np.flatnonzero(usable & ~thin)
    if caught.size == 0:
        return []
    last = anchors[np.searchsorted(anchors, caught) - 1]
    return [(int(i), thinned_reason(float(t[i] - t[a]), gap))
            for i, a in zip(caught.tolist(), last.tolist(), strict=True)]  # fmt: skip


def thinned_reason(after: float, min_interval_s: float) -> str:
    """The ledger reason of a reading dropped by ``min_interval_s``."""
    return (
        f"thinned: {after:.3f} s after the last reading kept, less than min_interval_s = "
        f"{min_interval_s:g} s"
    )


def spike_reason(mads: float) -> str:
    """The ledger reason of an isolated spike (``spike_mads``)."""
    return f"spike: more than {mads:g} MADs from the median of its neighbours (spike_mads)"


def after_gap_reason(gap: float, k: int) -> str:
    """The ledger reason of a spike among the first readings after a gap (``after_gap_s``)."""
    return (
        f"spike after a gap: reading {k} after {gap:.1f} s without one, more than "
        f"{AFTER_GAP_MADS:g} MADs from the median of the readings around it (after_gap_s)"
    )


def implausible_reason(cfg: SensorConfig, c: int, value: float, limits: Array) -> str:
    """The ledger reason of a reading whose column ``c`` is outside its plausible range."""
    lo, hi = limits[c]
    return (
        f"implausible: {cfg.columns[c]} = {value:.6g} outside [{lo:.6g}, {hi:.6g}] "
        f"{_UNIT[cfg.columns[c].rsplit('_', 1)[-1]]}"
    )


def lost_status_reason(column: str) -> str:
    """The ledger reason of a DVL reading whose ``status_column`` flag says no bottom lock."""
    return f"DVL bottom lock lost: {column} = 0 (status_column)"


def stuck_reason(cfg: SensorConfig, resolution: Array, t_a: float, t_b: float) -> str:
    """The ledger reason of the readings of a stuck run from ``t_a`` to ``t_b`` after its
    first (docs/robustness.md, 'Stuck readings')."""
    return (
        f"stuck: {', '.join(cfg.columns)} unchanged within {_within(cfg, resolution)} for "
        f"{t_b - t_a:.1f} s (t = {t_a:.3f} .. {t_b:.3f} s)"
    )


def _within(cfg: SensorConfig, resolution: Array) -> str:
    """``1e-05 m/s`` if every column has the same resolution and unit, else one per column."""
    parts = [
        f"{v:g} {_UNIT[c.rsplit('_', 1)[-1]]}"
        for v, c in zip(resolution.tolist(), cfg.columns, strict=True)
    ]
    return parts[0] if len(set(parts)) == 1 else "(" + ", ".join(parts) + ")"


ANGLE_MAJORITY = 0.5
"""Share of an angle column's values outside its limits above which the column is an error
(:func:`_check_plausible`)."""


def _check_plausible(
    table: Table, name: str, z: Array, limits: Array, columns: list[str]
) -> NDArray[np.bool_]:
    """Which finite values lie outside ``limits`` (n, d). A column whose every finite value
    does is an error (wrong units, or the wrong column): the readings are not just bad. So is an
    angle column (``_rad``) more than :data:`ANGLE_MAJORITY` of whose values do: degrees in a
    radians column put every heading above 6.28° outside, and the readings left (the ones
    near north) pass as radians, 57 times too large (up to 0.4.5: two thirds of a heading
    sensor dropped, one reading 25° off used, exit 0)."""
    finite = np.isfinite(z)
    outside = finite & ((z < limits[:, 0]) | (z > limits[:, 1]))
    for c in range(z.shape[1]):
        n_finite = int(finite[:, c].sum())
        n_out = int(outside[:, c].sum())
        col = columns[c]
        if not n_finite or not (
            n_out == n_finite or (col.endswith("_rad") and n_out > ANGLE_MAJORITY * n_finite)
        ):
            continue
        r = int(np.flatnonzero(outside[:, c])[0])
        lo, hi = limits[c]
        converted = " (after × π/180)" if "_deg" in col else ""
        which = "every value" if n_out == n_finite else f"{n_out} of its {n_finite} values"
        raise table.error(
            r,
            col,
            f"{which} of the column {'is' if n_out == n_finite else 'are'} outside the plausible "
            f"range [{lo:.6g}, {hi:.6g}]{converted} (e.g. {show(table.df[col].iloc[r])} here): "
            f"wrong units (degrees in a radians column?) or the wrong column? If the range is "
            f"wrong, set [sensors.{name}] limits (docs/robustness.md)",
        )
    return outside


ABOVE_SURFACE_M = -1.0
"""A depth meter whose median reading is below this (m, more than 1 m above the water
surface) is an error (:func:`_check_depth_sign`)."""


def _check_depth_sign(table: Table, name: str, depth: Array, column: str) -> None:
    """A depth column whose median finite reading is below :data:`ABOVE_SURFACE_M` is an error
    naming the file, line and column: depth is positive down, and a pressure meter out of the
    water reads about zero (1 hPa of weather is 1 cm), so a meter above the surface most of the
    time is a height written as a depth, or a sign slip. Each reading alone is plausible
    ([-100, 12000] m), and the guard took them: up to 0.4.6 a meter at 1.2 m logged as -1.2 m
    pulled the height 2.4 m up, exit 0. Configured ``limits`` (the user's own range for the
    meter) skip the check."""
    finite = np.isfinite(depth)
    if not np.any(finite):
        return
    median = float(np.median(depth[finite]))
    if median >= ABOVE_SURFACE_M:
        return
    r = int(np.flatnonzero(finite & (depth < ABOVE_SURFACE_M))[0])
    raise table.error(
        r,
        column,
        f"the median reading is {median:.4g} m, {-median:.3g} m above the water surface most of "
        f"the time (e.g. {show(table.df[column].iloc[r])} here): depth is positive down, a "
        f"height or a sign slip? If the readings are right, set [sensors.{name}] limits "
        "(docs/robustness.md)",
    )


def _check_kind_units(
    table: Table,
    name: str,
    cfg: SensorConfig,
    z: Array,
    outside: NDArray[np.bool_],
    used: list[str],
) -> None:
    """The checks of one kind's readings for a unit or sign slip (a sensor without configured
    ``limits``): a depth's sign, a DVL's mm/s."""
    if cfg.kind == "depth":
        _check_depth_sign(table, name, z[:, 0], used[0])
    elif cfg.kind == "dvl":
        _check_speed_units(table, name, z, outside, used)
    elif cfg.kind == "gnss" and used[0].endswith("_deg") and used[1].endswith("_deg"):
        _check_radians_as_degrees(table, name, z, used)


def _check_radians_as_degrees(table: Table, name: str, z: Array, columns: list[str]) -> None:
    """A GNSS whose degree columns (``lat_deg``, ``lon_deg``) hold only values a radian could
    hold, every latitude within ±π/2 = ±1.571 and every longitude within ±π = ±3.142, is an
    error naming the file and the first line: radians in a degrees column. Such a track lies
    in the open Gulf of Guinea, within 175 km of the equator and 350 km of Greenwich, where no
    coast is (since 0.4.10; up to 0.4.9 the demo with GNSS aiding ran 6 270 km RMS off, exit
    0, robust with an 'at odds' warning, MESKF with a 'correlated' one). A mission that is
    there sets ``limits`` (the check is then skipped)."""
    finite = np.all(np.isfinite(z[:, :2]), axis=1)
    if not np.any(finite):
        return
    lat, lon = np.degrees(z[finite, 0]), np.degrees(z[finite, 1])
    if np.max(np.abs(lat)) > math.pi / 2 or np.max(np.abs(lon)) > math.pi:
        return
    r = int(np.flatnonzero(finite)[0])
    raise table.error(
        r,
        columns[0],
        f"every fix lies within ±{math.pi / 2:.4g}° latitude and ±{math.pi:.4g}° longitude "
        f"(e.g. {show(table.df[columns[0]].iloc[r])}, {show(table.df[columns[1]].iloc[r])} "
        "here), the ranges of radians: radians in a degrees column? If the mission is in the "
        f"Gulf of Guinea near 0° N 0° E, set [sensors.{name}] limits (docs/robustness.md)",
    )


SPEED_UNITS_SHARE = 0.2
SPEED_UNITS_VALUES = 10
"""A DVL column with more than this share of its finite values outside its limits, taking at
least this many distinct values there, is an error (:func:`_check_speed_units`)."""


def _check_speed_units(
    table: Table, name: str, z: Array, outside: NDArray[np.bool_], columns: list[str]
) -> None:
    """A DVL velocity column more than :data:`SPEED_UNITS_SHARE` of whose finite values lie
    outside its limits (±20 m/s), at least :data:`SPEED_UNITS_VALUES` distinct values among
    them, is an error naming the file, the first such line and the column: mm/s or cm/s in a
    m/s column (a Teledyne PD0 record's velocities are mm/s). The readings at rest stay small
    in any unit and pass, so the every-value rule of :func:`_check_plausible` does not fire:
    up to 0.4.9 the demo's DVL in mm/s had its 1800 readings under way dropped as implausible,
    the 37 at rest or slow reached the filter, 21.5 m RMSE against 2.6 m, exit 0. A driver's
    fill value (one value, -32.768 m/s) over most of a dive is a lost bottom, not a unit, and
    stays a ledger matter. Configured ``limits`` skip the check."""
    finite = np.isfinite(z)
    for c in range(z.shape[1]):
        out = z[outside[:, c], c]
        if out.size <= SPEED_UNITS_SHARE * int(finite[:, c].sum()):
            continue
        if np.unique(out).size < SPEED_UNITS_VALUES:
            continue
        r = int(np.flatnonzero(outside[:, c])[0])
        col = columns[c]
        raise table.error(
            r,
            col,
            f"{out.size} of its {int(finite[:, c].sum())} values are outside the plausible "
            f"range of a DVL (e.g. {show(table.df[col].iloc[r])} here; median "
            f"|value| {float(np.median(np.abs(out))):.4g}): mm/s or cm/s in a m/s column (a "
            f"PD0 record's velocities are mm/s)? If the range is wrong, set [sensors.{name}] "
            "limits (docs/robustness.md)",
        )


TRUTH_OPTIONAL_GROUPS = (TRUTH_COLUMNS[3:6], TRUTH_COLUMNS[6:9])
"""Velocity and attitude: each group all or none (a GNSS reference has no attitude)."""


def _truth_columns(table: Table) -> list[str]:
    """Position, plus each optional group whose columns are all present; a partial group is an
    error naming the missing columns."""
    names = list(table.df.columns)
    columns = list(TRUTH_COLUMNS[:3])
    for group in TRUTH_OPTIONAL_GROUPS:
        have = [c for c in group if present(names, c)]
        if have and len(have) < len(group):
            missing = [c for c in group if c not in have]
            raise MissionError(
                f"{table.label} (truth): has {have} but not {missing}; give all of {list(group)} "
                "or none",
                file=table.label,
                field=missing[0],
            )
        if have:
            columns += group
    return columns


def _load_truth(table: Table, journal: Journal) -> pd.DataFrame:
    """The reference table with its SI columns as floats (degrees converted), extras kept:
    position always, velocity and attitude where the table has them (all three or none).
    Values that cannot be a reference are errors (:mod:`adaptnav.mission.truth`)."""
    if len(table) == 0:
        raise MissionError(f"{table.label} (truth): no data rows", file=table.label)
    columns = _truth_columns(table)
    t, z, used = take_columns(table, columns, "truth", journal)
    check_order(table, t)
    # The reference is not filtered: a position that cannot be one is an error (a wrong
    # reference would score every run wrongly, without a word).
    for i, c in enumerate(columns[:3]):
        lo, hi = SENSOR_LIMITS["gnss"][c]
        bad = np.flatnonzero(np.isfinite(z[:, i]) & ((z[:, i] < lo) | (z[:, i] > hi)))
        if bad.size:
            r = int(bad[0])
            raise table.error(
                r,
                used[1 + i],
                f"value {show(table.df[used[1 + i]].iloc[r])} is outside [{lo:.6g}, {hi:.6g}] "
                f"{_UNIT[c.rsplit('_', 1)[-1]]}, not a position (wrong units?; "
                f"{bad.size} row(s))",
            )
    same = np.flatnonzero(np.diff(t) == 0.0)
    if same.size:
        k = int(same[0])
        raise table.error(
            k + 1, TIME_COLUMN, f"repeated time t = {show(t[k])} s (also at {table.where(k)})"
        )
    reference.check_values(table, columns, z, used)
    reference.check_velocity(table, t, columns, z, used)
    out = table.df.copy()
    out[TIME_COLUMN] = t
    for i, c in enumerate(columns):
        out[c] = z[:, i]
    return out


# --- sensor models ------------------------------------------------------------------------------


def build_sensor_model(
    name: str, cfg: SensorConfig, calibration: Mapping[str, int] | None = None
) -> MeasurementModel:
    """The measurement model of ``[sensors.<name>]``, built by its kind (``KIND.build`` in
    ``sensors/<kind>.py``): σ in SI, l_b, C_sb = C_bsᵀ where
    ``C_bs = euler_to_dcm(mounting_rpy_deg)`` rotates sensor axes into body axes;
    ``calibration``: the error-state index of each calibration quantity it estimates
    (mission/calibration.py)."""
    setup = SensorSetup(
        name,
        cfg.sigma_si(),
        cfg.lever_arm(),
        cfg.sensor_from_body(),
        bool(cfg.use_height),
        cfg.model,
        dict(calibration or {}),
        cfg.surface_h(),
    )
    return KINDS[cfg.kind].build(setup)


# --- writing ------------------------------------------------------------------------------------


def write_mission(
    path: str | Path,
    config: MissionConfig,
    tables: Mapping[str, pd.DataFrame],
    fmt: Literal["parquet", "csv"] | None = "parquet",
) -> MissionConfig:
    """Write a mission folder: ``mission.toml`` and one table per stream.

    ``tables`` is keyed "imu", sensor names and "truth" (sensors with ``use = "off"`` may be
    left out). ``fmt`` sets every table's extension (file names in the config are changed to
    match); None keeps the config's names. Returns the configuration as written.
    """
    root = Path(path)
    if fmt is not None:
        config = _with_format(config, "." + fmt)
    targets: dict[str, str] = {"imu": config.imu.file}
    for n, s in config.sensors.items():
        if s.use != "off" or n in tables:
            targets[n] = s.file
    if config.truth.file is not None:
        targets["truth"] = config.truth.file
    unknown = sorted(set(tables) - set(targets))
    if unknown:
        raise MissionError(f"tables {unknown} name no stream of the config ({list(targets)})")
    missing = sorted(set(targets) - set(tables))
    if missing:
        raise MissionError(f"no table given for {missing}")
    root.mkdir(parents=True, exist_ok=True)
    written: dict[str, pd.DataFrame] = {}
    for key, file in targets.items():
        df = tables[key]
        if file in written:
            if written[file] is not df:
                raise MissionError(f"{file}: two different tables for one file ({key!r})")
            continue
        write_table(df, root / file)
        written[file] = df
    write_config(config, root / CONFIG_NAME)
    return config


def _with_format(config: MissionConfig, suffix: str) -> MissionConfig:
    def rename(file: str) -> str:
        return str(Path(file).with_suffix(suffix))

    sensors = {n: s.model_copy(update={"file": rename(s.file)}) for n, s in config.sensors.items()}
    truth = config.truth
    if truth.file is not None:
        truth = truth.model_copy(update={"file": rename(truth.file)})
    return config.model_copy(
        update={
            "imu": config.imu.model_copy(update={"file": rename(config.imu.file)}),
            "sensors": sensors,
            "truth": truth,
        }
    )
