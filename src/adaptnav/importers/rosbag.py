"""ROS 2 bags (sqlite3 ``.db3`` or MCAP, read and written with ``rosbags``) ↔ missions and
runs (docs/rosbag.md).

:func:`import_bag` turns chosen topics of a bag into a mission folder: one role per topic
(:data:`ROLE_TYPES`: the IMU, a DVL, a depth meter, a GNSS receiver, an inclinometer, a heading
sensor), the messages converted to adaptnav's frames and units by :mod:`.rosmsg`, mission time
= header stamp minus a whole-second origin (recorded in import.json). A bag holds data, not
datasheets: the IMU noise, each sensor's σ, rate, lever arm and mounting, the initial state and
the filter settings come from an existing ``mission.toml`` (``config``, its sensors matched by
kind); where it has none, σ (and the IMU's white noise) comes from the messages' covariances,
otherwise the import is refused. :func:`export_run` writes a run's solution back as
``nav_msgs/msg/Odometry``.
"""

from __future__ import annotations

import datetime as dt
import json
import logging
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.importers import rosmsg, timing
from adaptnav.importers.rosmsg import Converted, DepthParameters
from adaptnav.mission.config import MissionConfig, MissionError, load_config, parse_config
from adaptnav.mission.loader import write_mission
from adaptnav.mission.tables import IMU_INCREMENT_COLUMNS, IMU_RATE_COLUMNS, Repair

log = logging.getLogger("adaptnav.importers.rosbag")

Array = NDArray[np.float64]
Storage = Literal["sqlite3", "mcap"]
ImuSample = Literal["mean", "instant"]

__all__ = [
    "ROLE_TYPES",
    "Bag",
    "RosbagError",
    "Stream",
    "import_bag",
    "read_bag",
]

IMU = "sensor_msgs/msg/Imu"
TWIST = "geometry_msgs/msg/TwistWithCovarianceStamped"
PRESSURE = "sensor_msgs/msg/FluidPressure"
POSE = "geometry_msgs/msg/PoseWithCovarianceStamped"
NAVSATFIX = "sensor_msgs/msg/NavSatFix"
QUATERNION = "geometry_msgs/msg/QuaternionStamped"
ODOMETRY = "nav_msgs/msg/Odometry"

ROLE_TYPES: dict[str, tuple[str, ...]] = {
    "imu": (IMU,),
    "dvl": (TWIST,),
    "depth": (PRESSURE, POSE),
    "gnss": (NAVSATFIX,),
    "inclinometer": (IMU, QUATERNION),
    "heading": (IMU, QUATERNION),
}
"""The message types each role takes; a sensor role's name is its sensor kind."""
COLUMNS: dict[str, tuple[str, ...]] = {
    "dvl": ("vx_m_s", "vy_m_s", "vz_m_s"),
    "depth": ("depth_m",),
    "gnss": ("lat_rad", "lon_rad", "h_m"),
    "inclinometer": ("roll_rad", "pitch_rad"),
    "heading": ("yaw_rad",),
}
"""The table columns (docs/data-format.md) of each sensor role."""
SIGMA_UNIT = {"dvl": "m/s", "depth": "m", "gnss": "m", "inclinometer": "rad", "heading": "rad"}
IMU_COLUMNS = {"mean": IMU_INCREMENT_COLUMNS, "instant": IMU_RATE_COLUMNS}
"""The IMU table's columns: increments (``mean``: each message's rates are the mean over the
interval that ends at its stamp) or rates (``instant``: sampled at the stamp)."""
NS = 1_000_000_000
STAMP_TOLERANCE_S = 10.0
"""How far (s) a header stamp may stray from its topic's clock (:func:`far_stamps`), and a
topic's clock from the IMU's (:func:`check_clocks`), a clock being read from the stamps'
offsets to the bag's log times (:func:`running_clock`)."""
CLOCK_WINDOW = 101
"""Messages (in log order) over which a topic's running median clock offset is taken."""
DEFAULT_DEPTH = DepthParameters()
"""Seawater, standard atmosphere and gravity (:class:`~.rosmsg.DepthParameters`)."""


class RosbagError(MissionError):
    """A bag that cannot be imported as asked: unreadable, a missing topic, a message type a
    role does not take, a topic with no messages, no σ for a sensor. ``file`` is the bag,
    ``field`` the topic."""


# --- reading ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag: its message type and count."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True, eq=False)
class Bag:
    """The topics of a bag and the messages of the chosen ones (in bag order, with their
    log times in ns)."""

    path: Path
    topics: dict[str, TopicInfo]
    messages: dict[str, list[Any]]
    log_ns: dict[str, NDArray[np.int64]]


def describe_topics(topics: Mapping[str, TopicInfo]) -> str:
    """``/imu (sensor_msgs/msg/Imu, 9000), ...`` or ``no topics``: what an error lists."""
    if not topics:
        return "no topics"
    return ", ".join(f"{t.name} ({t.msgtype}, {t.count})" for t in topics.values())


@contextmanager
def _reader(path: Path) -> Iterator[Any]:
    """An open ``rosbags`` AnyReader (ROS 2 message definitions of Humble for bags that do
    not carry their own); an unreadable bag is a :class:`RosbagError`."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag2 import ReaderError
    from rosbags.typesys import Stores, get_typestore

    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except (AnyReaderError, ReaderError, OSError, ValueError, KeyError) as exc:
        raise RosbagError(f"{path}: not a readable ROS 2 bag ({exc})", file=str(path)) from None
    try:
        yield reader
    finally:
        reader.close()


def resolve_roles(
    path: Path, topics: Mapping[str, TopicInfo], wanted: Mapping[str, str | None]
) -> dict[str, str]:
    """Role → topic for the roles given a topic (``imu`` None: the bag's one Imu topic, not
    counting those given to other roles);
    a missing topic, a type the role does not take or an IMU not found is an error listing
    the bag's topics."""
    chosen: dict[str, str] = {}
    others = {t for r, t in wanted.items() if r != "imu"}
    for role, topic in wanted.items():
        if topic is None and role == "imu":
            imus = [t.name for t in topics.values() if t.msgtype == IMU]
            imus = [t for t in imus if t not in others] or imus
            if len(imus) != 1:
                what = "no" if not imus else f"{len(imus)}"
                raise RosbagError(
                    f"{path}: {what} {IMU} topics, give the IMU with --imu; the bag has "
                    f"{describe_topics(topics)}",
                    file=str(path),
                )
            topic = imus[0]
        if topic is None:
            continue
        if topic not in topics:
            raise RosbagError(
                f"{path}: no topic {topic} (--{role}); the bag has {describe_topics(topics)}",
                file=str(path),
                field=topic,
            )
        info = topics[topic]
        if info.msgtype not in ROLE_TYPES[role]:
            raise RosbagError(
                f"{path}: topic {topic} is {info.msgtype}, --{role} takes "
                f"{' or '.join(ROLE_TYPES[role])}; the bag has {describe_topics(topics)}",
                file=str(path),
                field=topic,
            )
        if info.count == 0:
            raise RosbagError(
                f"{path}: topic {topic} (--{role}) has no messages", file=str(path), field=topic
            )
        chosen[role] = topic
    return chosen


def read_bag(path: str | Path, wanted: Mapping[str, str | None]) -> tuple[Bag, dict[str, str]]:
    """Open a bag (a rosbag2 folder, or its ``.db3`` / ``.mcap`` file), check the roles'
    topics (:func:`resolve_roles`) and read their messages, each topic once."""
    p = Path(path)
    with _reader(p) as reader:
        topics = {
            name: TopicInfo(name, info.msgtype or "", int(info.msgcount))
            for name, info in sorted(reader.topics.items())
        }
        roles = resolve_roles(p, topics, wanted)
        names = set(roles.values())
        messages: dict[str, list[Any]] = {n: [] for n in names}
        log_ns: dict[str, list[int]] = {n: [] for n in names}
        connections = [c for c in reader.connections if c.topic in names]
        try:
            for con, stamp, raw in reader.messages(connections=connections):
                messages[con.topic].append(reader.deserialize(raw, con.msgtype))
                log_ns[con.topic].append(int(stamp))
        except Exception as exc:  # a damaged storage file fails in rosbags' own ways
            raise RosbagError(
                f"{p}: cannot read messages ({type(exc).__name__}: {exc})", file=str(p)
            ) from None
    stamps = {n: np.array(v, dtype=np.int64) for n, v in log_ns.items()}
    return Bag(p, topics, messages, stamps), roles


# --- one topic to one stream --------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Stream:
    """One role's readings after conversion and ordering: stamps (ns), readings
    (:class:`~.rosmsg.Converted`, rows in stamp order), the frame ids seen, the repairs."""

    role: str
    topic: str
    msgtype: str
    t_ns: NDArray[np.int64]
    data: Converted
    frame_ids: tuple[str, ...]
    messages: int
    repairs: tuple[Repair, ...]
    clock: Array
    """Per message kept, in log order: its log time and its header stamp minus log time (s;
    :func:`check_clocks`)."""


def _convert(role: str, msgtype: str, msgs: Sequence[Any], depth: DepthParameters) -> Converted:
    """The readings of one topic in its role (:mod:`.rosmsg`)."""
    if role == "imu":
        return rosmsg.imu_rates(msgs)
    if msgtype in (IMU, QUATERNION):
        return rosmsg.attitude(msgs, msgtype)
    if msgtype == TWIST:
        return rosmsg.twist_velocity(msgs)
    if msgtype == PRESSURE:
        return rosmsg.pressure_depth(msgs, depth)
    if msgtype == POSE:
        return rosmsg.pose_depth(msgs)
    return rosmsg.navsatfix(msgs)


def _imu_fields(role: str) -> tuple[str, ...]:
    """The covariances of an Imu message whose quantities ``role`` reads."""
    if role == "imu":
        return ("angular_velocity_covariance", "linear_acceleration_covariance")
    return ("orientation_covariance",)


def _check_present(bag: Bag, role: str, topic: str, msgs: Sequence[Any]) -> None:
    """An Imu topic must carry what its role reads in some message: -1 in the first element
    of a covariance is sensor_msgs' mark of a quantity not provided. The messages without it
    are left out (:func:`_no_reading`); up to 0.4.7 only the first message was looked at,
    and later ones without it were read (an AHRS's identity quaternion as heading 90°)."""
    if bag.topics[topic].msgtype != IMU:
        return
    for name in _imu_fields(role):
        if not rosmsg.provided(np.array([getattr(m, name) for m in msgs])).any():
            raise RosbagError(
                f"{bag.path}: topic {topic} (--{role}): its Imu messages carry no "
                f"{name.removesuffix('_covariance')} ({name}[0] = -1)",
                file=str(bag.path),
                field=topic,
            )


def _no_reading(topic: str, role: str, msgtype: str, keep: NDArray[np.bool_]) -> Repair:
    """The repair that records the messages without a reading (``keep`` False): a fix with no
    fix, an Imu message that marks what its role reads not provided."""
    n, first = int((~keep).sum()), int(np.flatnonzero(~keep)[0])
    detail = f"{n} messages, the first at message {first} (--{role})"
    if msgtype == IMU:
        fld = " / ".join(_imu_fields(role))
        return Repair(topic, None, fld, "not provided (covariance[0] = -1): left out", detail)
    return Repair(topic, None, "status.status", "no fix: left out", detail)


def _stamps(
    bag: Bag, topic: str, msgs: Sequence[Any], log_time: bool
) -> tuple[NDArray[np.int64], list[Repair]]:
    """Header stamps (ns); a zero stamp (not set by the driver) is replaced by the bag's log
    time, recorded; with ``log_time`` (``--log-time``) every stamp is."""
    if log_time:
        detail = f"{len(msgs)} messages (--log-time)"
        return bag.log_ns[topic].copy(), [
            Repair(topic, None, "header.stamp", "bag log time used", detail)
        ]
    t = rosmsg.stamps_ns(msgs)
    unset = np.flatnonzero(t == 0)
    if unset.size == 0:
        return t, []
    t[unset] = bag.log_ns[topic][unset]
    detail = f"{unset.size} messages, the first at message {int(unset[0])}"
    return t, [Repair(topic, None, "header.stamp", "zero stamp: bag log time used", detail)]


def clock_offsets_s(t_ns: NDArray[np.int64], log_ns: NDArray[np.int64]) -> Array:
    """Each message's header stamp minus its log time (s): the topic's clock against the
    recorder's, plus the transport delay."""
    return np.asarray((t_ns - log_ns).astype(np.float64) / NS)


def running_clock(offsets_s: Array) -> Array:
    """The running median of clock offsets (in log order) over the :data:`CLOCK_WINDOW`
    messages around each (fewer for a shorter topic): the topic's clock, robust to a few
    stamps far off, following a drift."""
    from scipy.ndimage import median_filter

    if offsets_s.size == 0:
        return offsets_s.copy()
    size = min(CLOCK_WINDOW, offsets_s.size)
    return np.asarray(median_filter(offsets_s, size=size, mode="nearest"), dtype=float)


def far_stamps(offsets_s: Array, tolerance_s: float = STAMP_TOLERANCE_S) -> NDArray[np.bool_]:
    """The messages whose clock offset (:func:`clock_offsets_s`, in log order) lies more than
    ``tolerance_s`` from the topic's :func:`running_clock`: a stamp of 1970, or of a clock that
    stepped for a few messages. A clock that drifts against the recorder's (simulated time at
    another rate than real time) moves the median with it, and a whole topic on another clock
    is :func:`check_clocks`' to find."""
    return np.asarray(np.abs(offsets_s - running_clock(offsets_s)) > tolerance_s)


def _order(
    topic: str, t: NDArray[np.int64], index: NDArray[np.int64], drop_repeats: bool
) -> tuple[NDArray[np.int64], list[Repair]]:
    """The messages ``index`` in stamp order (stable: bag order among equal stamps), with the
    repairs: messages recorded out of stamp order are sorted; with ``drop_repeats`` (the IMU,
    whose increments need a positive interval) a repeated stamp's later messages are dropped.
    A sensor's repeated stamps are left to the mission loader, which keeps the first and
    drops the rest to the ledger (docs/data-format.md)."""
    repairs: list[Repair] = []
    ti = t[index]
    late = np.flatnonzero(np.diff(ti) < 0)
    order = index[np.argsort(ti, kind="stable")]
    if late.size:
        back = _step_back(topic, ti, index, imu=drop_repeats)
        detail = (
            f"{late.size} messages stamped before their predecessor, the first at "
            f"message {int(index[late[0] + 1])}; {back}"
        )
        repairs.append(Repair(topic, None, "header.stamp", "sorted by header stamp", detail))
    if drop_repeats:
        repeat = np.flatnonzero(np.diff(t[order]) == 0) + 1
        if repeat.size:
            detail = f"{repeat.size} messages, the first at message {int(order[repeat[0]])}"
            repairs.append(
                Repair(topic, None, "header.stamp", "repeated stamp: later message dropped", detail)
            )
            order = np.delete(order, repeat)
    return order, repairs


IMU_STEP_BACK_PERIODS = 2.0
"""Largest step back of an IMU's stamps, in its median sampling periods, that sorting
repairs: beyond, its clock stepped (two stretches of the IMU would be interleaved, each
increment over a wrong interval), an error (:func:`_step_back`)."""


def _step_back(topic: str, ti: NDArray[np.int64], index: NDArray[np.int64], imu: bool) -> str:
    """How far the stamps ``ti`` (ns, bag order) step back at most, as the repair's detail
    says it; for the IMU a step back beyond :data:`IMU_STEP_BACK_PERIODS` of its median
    period is a :class:`RosbagError` naming the message."""
    steps = np.diff(ti).astype(np.float64) / NS
    k = int(np.argmin(steps))
    forward = steps[steps > 0]
    period = float(np.median(forward)) if forward.size else math.nan
    said = f"the largest step back {-steps[k]:.6g} s at message {int(index[k + 1])}"
    if not imu:
        return said
    if not -steps[k] <= IMU_STEP_BACK_PERIODS * period:
        raise RosbagError(
            f"{topic}: the IMU's header stamps step back {-steps[k]:.6g} s "
            f"({-steps[k] / period:.1f} sampling periods of {period:.6g} s) at message "
            f"{int(index[k + 1])}: its clock stepped, and sorting would interleave two "
            "stretches of the IMU; time it by the bag's log time (--log-time "
            f"{topic}) or fix the stamps (docs/rosbag.md, 'Clocks')",
            field=topic,
        )
    return f"{said} ({-steps[k] / period:.2f} sampling periods)"


def _far_repair(
    topic: str, far: NDArray[np.bool_], offsets_s: Array, t_ns: NDArray[np.int64]
) -> Repair:
    """The repair that records the messages :func:`far_stamps` left out."""
    first = int(np.flatnonzero(far)[0])
    clock = float(np.median(offsets_s[~far]))
    when = dt.datetime.fromtimestamp(int(t_ns[first]) // NS, dt.UTC).isoformat()
    detail = (
        f"{int(far.sum())} messages, the first at message {first} (stamped {when}, "
        f"{offsets_s[first] - clock:+.6g} s from the topic's clock)"
    )
    return Repair(topic, None, "header.stamp", "stamp far from the topic's clock: left out", detail)


def build_stream(
    bag: Bag,
    role: str,
    topic: str,
    depth: DepthParameters,
    log_time: bool = False,
    tolerance_s: float = STAMP_TOLERANCE_S,
) -> Stream:
    """Convert, stamp and order one topic in its role; messages stamped far from the topic's
    clock (:func:`far_stamps`) and messages without a reading (a GNSS fix with no fix) are
    left out, recorded."""
    msgs = bag.messages[topic]
    msgtype = bag.topics[topic].msgtype
    _check_present(bag, role, topic, msgs)
    data = _convert(role, msgtype, msgs, depth)
    t, repairs = _stamps(bag, topic, msgs, log_time)
    offsets = clock_offsets_s(t, bag.log_ns[topic])
    far = far_stamps(offsets, tolerance_s)
    if far.any():
        repairs.append(_far_repair(topic, far, offsets, t))
    try:
        order, more = _order(topic, t, np.flatnonzero(~far), drop_repeats=role == "imu")
    except RosbagError as exc:
        raise RosbagError(f"{bag.path}: {exc}", file=str(bag.path), field=topic) from None
    repairs += more
    order = order[data.keep[order]]
    if not data.keep.all():
        repairs.append(_no_reading(topic, role, msgtype, data.keep))
    for r in repairs:
        log.warning("%s: %s (%s)", r.file, r.action, r.detail)
    frames = tuple(sorted({m.header.frame_id for m in msgs}))
    if len(frames) > 1:
        log.warning(
            "%s: messages in %d frames %s (no TF lookup: docs/rosbag.md)",
            topic,
            len(frames),
            list(frames),
        )
    kept = Converted(data.z[order], data.var[order], data.keep[order])
    log_s = bag.log_ns[topic][order].astype(np.float64) / NS
    by_log = np.argsort(log_s, kind="stable")
    clock = np.column_stack([log_s[by_log], offsets[order][by_log]])
    return Stream(role, topic, msgtype, t[order], kept, frames, len(msgs), tuple(repairs), clock)


# --- the mission configuration ------------------------------------------------------------------


def sigma_components(role: str, use_height: bool) -> tuple[int, ...]:
    """Which of a stream's variance columns (:class:`~.rosmsg.Converted`) give the kind's σ
    components (docs/data-format.md, ``sigma``)."""
    if role == "gnss":
        return (0, 1, 2) if use_height else (0, 1)
    return {"dvl": (0, 1, 2), "depth": (0,), "inclinometer": (0, 1), "heading": (2,)}[role]


def message_sigma(var: Array, components: Sequence[int]) -> dict[str, list[float]] | None:
    """Median, least and largest σ of each component over the messages whose covariance
    gives them all (None: no message does). A variance not > 0 gives none: no sensor reads
    without error, and a driver that fills a covariance with zeros until it has one (or
    fills only the angular block) does not know it. Up to 0.4.7 such zeros were σ = 0 and
    pulled the median down: half the fixes with zeros gave half the fixes' σ."""
    v = var[:, list(components)]
    v = v[np.isfinite(v).all(axis=1) & (v > 0.0).all(axis=1)]
    if v.shape[0] == 0:
        return None
    s = np.sqrt(v)
    return {
        k: [float(x) for x in f(s, axis=0)]
        for k, f in (("median", np.median), ("min", np.min), ("max", np.max))
    }


def _rate_hz(t_ns: NDArray[np.int64]) -> float | None:
    """1 / the median stamp interval (None for fewer than two stamps or no interval)."""
    dt = np.diff(t_ns) / NS
    period = float(np.median(dt)) if dt.size else 0.0
    return round(1.0 / period, 6) if period > 0.0 else None


def config_sensor(
    base: MissionConfig | None, kind: str, source: str
) -> tuple[str, dict[str, Any] | None]:
    """The sensor name and ``[sensors.<name>]`` section of ``base`` of this kind (matched by
    kind; two of one kind are an error), or (the role, None) when it has none."""
    if base is None:
        return kind, None
    names = [n for n, s in base.sensors.items() if s.kind == kind]
    if len(names) > 1:
        raise RosbagError(
            f"{source}: {len(names)} sensors of kind {kind} {names}; the import "
            "matches a topic to the config's one sensor of its kind",
            file=source,
        )
    if not names:
        return kind, None
    return names[0], base.sensors[names[0]].model_dump(exclude_none=True)


def sensor_section(
    stream: Stream, name: str, section: dict[str, Any] | None, use_height: bool
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``[sensors.<name>]`` section of one stream and its import.json record.

    Precedence (docs/rosbag.md): the config's section whole (σ, rate, lever arm, mounting,
    options; a ``status_column`` is dropped, a bag has none); else σ from the messages'
    covariances (median per component), the rate from the stamps and the schema's defaults;
    else an error."""
    role, comps = stream.role, sigma_components(stream.role, use_height)
    from_messages = message_sigma(stream.data.var, comps)
    if section is not None:
        sec = {k: v for k, v in section.items() if k != "status_column"}
        source = "config"
    elif from_messages is None:
        raise RosbagError(
            f"topic {stream.topic} (--{role}): its messages carry no covariance, so no σ; "
            "give the sensor's σ with --config MISSION.toml (a [sensors.*] of kind "
            f"{role})",
            field=stream.topic,
        )
    else:
        sec = {"kind": role, "sigma": [from_messages["median"], SIGMA_UNIT[role]]}
        if (rate := _rate_hz(stream.t_ns)) is not None:
            sec["rate_hz"] = rate
        if role == "gnss":
            sec["use_height"] = use_height
        if role == "inclinometer":
            # An orientation (an AHRS's or another navigator's) is an attitude output, not a
            # pendulum's reading (docs/inclinometer.md; the pendulum model, the kind's default,
            # took it for one: attitude NEES 51 against 2.2 on the simulated demo).
            sec["model"] = "attitude"
        source = "messages"
    sec["file"] = f"{name}.parquet"
    record = {
        **_stream_record(stream),
        "sensor": name,
        "sigma_source": source,
        "message_sigma": from_messages,
    }
    return sec, record


def _stream_record(stream: Stream) -> dict[str, Any]:
    """What import.json records of every topic read: its name, type, counts and frame ids."""
    return {
        "topic": stream.topic,
        "type": stream.msgtype,
        "messages": stream.messages,
        "rows": int(stream.t_ns.size),
        "frame_ids": list(stream.frame_ids),
    }


def imu_section(
    stream: Stream, base: MissionConfig | None, sample: ImuSample
) -> tuple[dict[str, Any], dict[str, Any]]:
    """``[imu]`` and its record: the config's (noise, rate, initial bias) or, without one,
    the white noise from the messages' covariances, ``arw = σ_ω √T``, ``vrw = σ_f √T`` (a
    sample's variance of white noise of density N over the period T is N²/T), and the rate
    from the stamps."""
    period = float(np.median(np.diff(stream.t_ns))) / NS if stream.t_ns.size > 1 else math.nan
    sigma = message_sigma(stream.data.var, range(6))
    noise = None
    if sigma is not None and period > 0.0:
        m = np.asarray(sigma["median"])
        noise = {
            "arw": [float(np.median(m[:3]) * math.sqrt(period)), "rad/sqrt(s)"],
            "vrw": [float(np.median(m[3:]) * math.sqrt(period)), "m/s/sqrt(s)"],
        }
    if base is not None:
        sec = base.imu.model_dump(exclude_none=True)
        source = "config"
    elif noise is None or not period > 0.0:
        raise RosbagError(
            f"topic {stream.topic} (--imu): its messages carry no angular velocity and linear "
            "acceleration covariances, so no IMU noise; give it with --config MISSION.toml",
            field=stream.topic,
        )
    else:
        sec = {"noise": noise, "rate_hz": round(1.0 / period, 6)}
        source = "messages"
    sec.update(file="imu.parquet", format="increments" if sample == "mean" else "rates")
    record = {
        **_stream_record(stream),
        "sample": sample,
        "noise_source": source,
        "message_noise": noise,
    }
    return sec, record


@dataclass(frozen=True)
class Built:
    """A bag's mission: its configuration, the sensor name of each role, and the records of
    the IMU, the sensors and the config's sections left out."""

    config: MissionConfig
    names: dict[str, str]
    records: dict[str, Any]
    notes: tuple[str, ...]


def build_config(
    bag: Bag,
    streams: Mapping[str, Stream],
    base: MissionConfig | None,
    source: str | None,
    sample: ImuSample,
) -> Built:
    """The mission configuration of the streams (docs/rosbag.md, 'Configuration'): the IMU
    (:func:`imu_section`), each sensor (:func:`sensor_section`, matched to the config's by
    kind), the config's ``[initial]`` and ``[filter]`` (else the schema's defaults), no
    truth. A config sensor of a kind no topic was given for is left out, noted."""
    where = source or str(bag.path)
    imu, imu_record = imu_section(streams["imu"], base, sample)
    sensors: dict[str, Any] = {}
    records: dict[str, Any] = {"imu": imu_record}
    names: dict[str, str] = {}
    # NavSatFix's altitude is NaN where the receiver gives none (its definition): aiding with
    # such heights would make every fix non-finite, dropped (up to 0.4.7 the run then found
    # no fix to align at, "none finite and plausible")
    gnss = streams.get("gnss")
    has_heights = gnss is None or bool(np.isfinite(gnss.data.z[:, 2]).any())
    use_height = "depth" not in streams and has_heights
    for role, stream in streams.items():
        if role == "imu":
            continue
        name, section = config_sensor(base, role, where)
        sensors[name], records[role] = sensor_section(stream, name, section, use_height)
        names[role] = name
    notes = (
        []
        if base is None
        else [
            f"[sensors.{n}] (kind {s.kind}) of {source}: no topic given, left out"
            for n, s in base.sensors.items()
            if n not in sensors
        ]
    )
    doc: dict[str, Any] = {
        "mission": {
            "name": bag.path.name.removesuffix(".mcap").removesuffix(".db3") or "rosbag",
            "description": f"imported from the ROS 2 bag {bag.path.name}"
            + (f" with the settings of {source}" if source else ""),
        },
        "imu": imu,
        "sensors": sensors,
    }
    if base is not None:
        doc["initial"] = base.initial.model_dump(exclude_none=True)
        doc["filter"] = base.filter.model_dump(exclude_none=True)
    config = parse_config(doc, f"{bag.path.name} (import)")
    return Built(config, names, records, tuple(notes))


def _mission_time(t_ns: NDArray[np.int64], origin_ns: int) -> Array:
    """Mission seconds: the stamp minus the origin, in integers first (exact to 1 ns)."""
    return np.asarray((t_ns - origin_ns).astype(np.float64) / NS)


def build_tables(
    streams: Mapping[str, Stream], built: Built, origin_ns: int, sample: ImuSample
) -> dict[str, pd.DataFrame]:
    """One table per stream (docs/data-format.md). The IMU: ``mean``, increments
    ``Δθ_k = ω_k (t_k - t_{k-1})`` (the first interval 1/rate_hz, the loader's rule);
    ``instant``, the rates as they are."""
    imu = streams["imu"]
    t = _mission_time(imu.t_ns, origin_ns)
    values = imu.data.z
    if sample == "mean":
        dt = np.diff(imu.t_ns, prepend=0).astype(np.float64) / NS
        dt[0] = 1.0 / built.config.imu.rate_hz
        values = values * dt[:, None]
    tables = {
        "imu": pd.DataFrame(np.column_stack([t, values]), columns=["t_s", *IMU_COLUMNS[sample]])
    }
    for role, name in built.names.items():
        s = streams[role]
        z = (
            s.data.z[:, :2]
            if role == "inclinometer"
            else s.data.z[:, 2:]
            if role == "heading"
            else s.data.z
        )
        tables[name] = pd.DataFrame(
            np.column_stack([_mission_time(s.t_ns, origin_ns), z]),
            columns=["t_s", *COLUMNS[role]],
        )
    return tables


def check_clocks(
    path: Path, streams: Mapping[str, Stream], tolerance_s: float = STAMP_TOLERANCE_S
) -> None:
    """Every topic's clock within ``tolerance_s`` of the IMU's, else a :class:`RosbagError`
    naming the topic (the IMU when two or more topics, all of them, agree with each other and
    not with it): a driver that stamps with its own clock (time since boot, a GNSS time
    not set) puts its readings where no IMU sample is, and mission time would start at the
    earliest of the clocks. A topic's clock is read against the IMU's at the same log times
    (the median over its messages of its offset less the IMU's running median offset there,
    :attr:`Stream.clock`), so that clocks drifting together against the recorder's (simulated
    time at another rate than real time) agree."""
    imu = streams["imu"]
    if imu.clock.shape[0] == 0:
        return
    imu_clock = running_clock(imu.clock[:, 1])
    gaps = {
        role: float(np.median(s.clock[:, 1] - np.interp(s.clock[:, 0], imu.clock[:, 0], imu_clock)))
        for role, s in streams.items()
        if role != "imu" and s.clock.shape[0]
    }
    off = [role for role, gap in gaps.items() if abs(gap) > tolerance_s]
    if not off:
        return
    values = [gaps[r] for r in off]
    if len(off) >= 2 and len(off) == len(gaps) and max(values) - min(values) <= tolerance_s:
        raise RosbagError(
            f"{path}: the IMU {imu.topic} is stamped on another clock than every other topic "
            f"({', '.join(streams[r].topic for r in off)}): against the bag's log times their "
            f"header stamps are {float(np.median(values)):+.6g} s from the IMU's (a driver "
            f"stamping with its own clock?); --log-time {imu.topic} takes its log times "
            "instead (with the transport delay's jitter in every increment)",
            file=str(path),
            field=imu.topic,
        )
    s = streams[off[0]]
    raise RosbagError(
        f"{path}: topic {s.topic} (--{off[0]}) is stamped on another clock than the IMU "
        f"{imu.topic}: against the bag's log times its header stamps are {gaps[off[0]]:+.6g} s "
        f"from the IMU's (a driver stamping with its own clock?); --log-time {s.topic} takes "
        "its log times instead",
        file=str(path),
        field=s.topic,
    )


def stamp_origin(streams: Mapping[str, Stream]) -> int:
    """The mission clock's origin (ns): the earliest stamp, down to a whole second, so that
    mission time and stamps share their fractions of a second."""
    first = min(int(s.t_ns[0]) for s in streams.values() if s.t_ns.size)
    return (first // NS) * NS


def import_record(
    bag: Bag,
    streams: Mapping[str, Stream],
    built: Built,
    origin_ns: int,
    depth: DepthParameters,
    source: str | None,
) -> dict[str, Any]:
    """import.json (docs/rosbag.md): the bag and its topics, the stamp origin, per role its
    topic, type, counts, frame ids, where σ came from and the messages' σ, the depth
    conversion, the config used and what of it was left out, the repairs."""
    origin_s = origin_ns // NS
    return {
        "importer": "adaptnav.importers.rosbag",
        "bag": str(bag.path),
        "topics": {t.name: {"type": t.msgtype, "messages": t.count} for t in bag.topics.values()},
        "stamp_origin_ns": origin_ns,
        "stamp_origin": dt.datetime.fromtimestamp(origin_s, dt.UTC).isoformat(),
        "frames": "body FLU -> FRD, world ENU -> NED (docs/rosbag.md)",
        "roles": built.records,
        "depth_from_pressure": {
            "density_kg_m3": depth.density_kg_m3,
            "atmospheric_pa": depth.atmospheric_pa,
            "gravity_m_s2": depth.gravity_m_s2,
        }
        if streams.get("depth", None) and streams["depth"].msgtype == PRESSURE
        else None,
        "config": source,
        "notes": list(built.notes),
        "repairs": [r.__dict__ for s in streams.values() for r in s.repairs],
    }


def import_bag(
    bag_path: str | Path,
    out_dir: str | Path,
    *,
    topics: Mapping[str, str | None],
    config: str | Path | None = None,
    depth: DepthParameters = DEFAULT_DEPTH,
    imu_sample: ImuSample = "mean",
    fmt: Literal["parquet", "csv"] = "parquet",
    log_time: Sequence[str] = (),
    stamp_tolerance_s: float = STAMP_TOLERANCE_S,
) -> Path:
    """Import a ROS 2 bag as a mission folder ``out_dir`` (docs/rosbag.md).

    Args:
        bag_path: a rosbag2 folder (sqlite3 or MCAP storage) or its storage file.
        topics: role → topic for the roles of :data:`ROLE_TYPES` (``imu`` None or absent:
            the bag's one ``sensor_msgs/msg/Imu`` topic).
        config: a ``mission.toml`` whose IMU noise, sensors (matched by kind), initial state
            and filter settings the mission takes (:func:`build_config`).
        depth: the pressure → depth conversion of a FluidPressure depth topic.
        imu_sample: ``mean`` (the default: each Imu message's rates are the mean over the
            interval ending at its stamp; written as increments) or ``instant`` (sampled at
            the stamp; written as rates, integrated by the trapezoid rule).
        log_time: topics whose messages are timed by the bag's log time, not their header
            stamps (a driver on its own clock: :func:`check_clocks`).
        stamp_tolerance_s: how far a stamp may stray from its topic's clock
            (:func:`far_stamps`) and a topic's clock from the IMU's.

    Returns ``out_dir``; import.json in it records everything (:func:`import_record`).
    """
    wanted = {"imu": None, **topics}
    bag, roles = read_bag(bag_path, wanted)
    unknown = sorted(set(log_time) - set(roles.values()))
    if unknown:
        raise RosbagError(
            f"{bag.path}: --log-time {unknown[0]} is not an imported topic (they are "
            f"{', '.join(sorted(roles.values()))})",
            file=str(bag.path),
            field=unknown[0],
        )
    streams = {
        role: build_stream(bag, role, topic, depth, topic in log_time, stamp_tolerance_s)
        for role, topic in roles.items()
    }
    check_clocks(bag.path, streams, stamp_tolerance_s)
    base = load_config(config) if config is not None else None
    source = str(config) if config is not None else None
    built = build_config(bag, streams, base, source, imu_sample)
    origin = stamp_origin(streams)
    root = Path(out_dir)
    write_mission(root, built.config, build_tables(streams, built, origin, imu_sample), fmt=fmt)
    record = import_record(bag, streams, built, origin, depth, source)
    (root / "import.json").write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    for note in built.notes:
        log.info("%s", note)
    return root


# --- export -------------------------------------------------------------------------------------

POSITION = ("dr_N", "dr_E", "dr_D")
VELOCITY = ("dv_N", "dv_E", "dv_D")
ATTITUDE = ("phi_N", "phi_E", "phi_D")
UNKNOWN_ANGULAR_VARIANCE = 1.0e6
"""The twist's angular-rate variances ((rad/s)²; σ = 1000 rad/s, 160 turns a second, beyond any
vehicle): the solution has no angular rate, so the angular twist is written as 0 with this
variance, which any consumer takes as unknown (a fusing filter gives it no weight) and which
keeps the 6×6 covariance positive definite. nav_msgs/Odometry defines no "not provided" mark;
up to 0.4.8 these were -1, sensor_msgs/Imu's mark, which an Odometry consumer
(robot_localization) may read as a negative variance (docs/rosbag.md, 'Export'). 1e6 and not
1e12: beside the velocity's variances (1e-6 (m/s)² for a good DVL) it leaves the matrix a
condition number of 1e12, well inside double precision."""


def run_stamp_origin(meta: Mapping[str, Any]) -> int:
    """The stamp of mission time 0 for a run (ns): :func:`mission_stamp_origin`, 0 (stamps are
    mission seconds) for a mission without one."""
    origin, _ = mission_stamp_origin(meta)
    return 0 if origin is None else origin


def mission_stamp_origin(meta: Mapping[str, Any]) -> tuple[int | None, str]:
    """The stamp of mission time 0 for a run (ns), and what the run's mission is: the stamp
    origin of its mission's import.json when the mission came from a bag (:func:`import_bag`),
    its ``t0_utc`` when it came from an NMEA log (``adaptnav import nmea``), its
    ``gpst_origin_s`` as UTC when it came from an RTKLIB drive (:func:`timing.gpst_to_utc_ns`;
    up to 0.4.7 0); None for a mission with no absolute time (simulated, an A-KIT segment:
    its import.json's ``time.note`` says why, or a run that records no mission folder).
    ValueError when the run records a mission folder (``meta.mission_dir``: absolute since
    0.4.8, as given to ``run`` before, relative to where it ran) that is not found: whether
    its mission came from a bag cannot be told, and up to 0.4.7 the origin was then 0,
    silently (a bag's run exported from another folder was stamped in 1970, not at the bag's
    time)."""
    folder = meta.get("mission_dir")
    if not isinstance(folder, str):
        return None, "the run records no mission folder (summary.json, meta.mission_dir)"
    root = Path(folder)
    if not root.is_dir():
        raise ValueError(
            f"the run's mission folder {folder} (summary.json, meta.mission_dir) is not found "
            "from here, so whether its stamps had an origin (a mission imported from a bag or "
            "an NMEA log) is unknown: give --stamp-origin-ns (0: stamps are mission seconds)"
        )
    record = root / "import.json"
    if not record.is_file():
        return None, f"the mission {folder} was not imported (simulated?)"
    info = json.loads(record.read_text(encoding="utf-8"))
    importer = info.get("importer")
    if importer == "nmea":  # UTC of t_s = 0 (docs/nmea.md); up to 0.4.7 ignored
        return _utc_ns(info["time"]["t0_utc"]), "nmea"
    if importer == "adaptnav.importers.rtklib":  # GPST of t_s = 0; to 0.4.7 ignored
        return timing.gpst_to_utc_ns(float(info["gpst_origin_s"])), "rtklib"
    if importer == "adaptnav.importers.rosbag":
        return int(info["stamp_origin_ns"]), "rosbag"
    note = info.get("time", {}).get("note") if isinstance(info.get("time"), dict) else None
    return None, f"the mission {folder} ({importer}{': ' + note if note else ''})"


def export_stamp_origin(meta: Mapping[str, Any], given_ns: int | None) -> int:
    """The export's stamp origin (ns): ``given_ns`` (``--stamp-origin-ns``), else the mission's
    (:func:`mission_stamp_origin`); a mission without one gives 0, the stamps mission seconds
    from 1970-01-01, with a warning naming ``--stamp-origin-ns`` (up to 0.4.8 silent: an
    A-KIT segment's or a simulated mission's Odometry was dated 1970 without a word)."""
    if given_ns is not None:
        return given_ns
    origin, what = mission_stamp_origin(meta)
    if origin is not None:
        return origin
    log.warning(
        "%s has no absolute time: the stamps are mission seconds from 1970-01-01 00:00 UTC; "
        "give --stamp-origin-ns (ns since 1970, UTC, of its t_s = 0) to date them",
        what[0].upper() + what[1:],
    )
    return 0


def _utc_ns(iso: str) -> int:
    """Nanoseconds since 1970 (UTC, as ROS time) of an ISO 8601 time with a zone, in integers:
    a float timestamp of 1.7e9 s holds only 0.2 µs."""
    since = dt.datetime.fromisoformat(iso) - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
    return (since.days * 86400 + since.seconds) * NS + since.microseconds * 1000


@dataclass(frozen=True, eq=False)
class OdometryRows:
    """A solution in ROS terms (docs/rosbag.md, 'Export'): stamps (ns), position in the map
    frame, the ENU tangent plane at the datum (m), ``q_map_flu`` ``[x, y, z, w]`` (the body's
    FLU axes in the map frame), velocity in body FLU,
    and the 6×6 pose and twist covariances (row-major, 36 numbers)."""

    t_ns: NDArray[np.int64]
    datum: tuple[float, float, float]
    r_enu: Array
    q_xyzw: Array
    v_flu: Array
    pose_cov: Array
    twist_cov: Array


def map_from_ned(lat: Array, lon: Array, datum: tuple[float, float, float]) -> Array:
    """Rotations (n, 3, 3) from each row's local NED frame into the map frame, the ENU tangent
    plane at the datum: ``C_NED_ENU C_ne(datum) C_ne(row)ᵀ`` (NED at the row → ECEF → NED at
    the datum → ENU). The two frames part by the angle the Earth's surface turns between them,
    about 0.9° per 100 km, plus the meridians' convergence: 1.6° of heading 100 km east at
    60° N."""
    from adaptnav.core import earth

    return rosmsg.C_NED_ENU @ earth.C_ne(datum[0], datum[1]) @ earth.C_ne(lat, lon).swapaxes(-1, -2)


def odometry_rows(solution: pd.DataFrame, origin_ns: int) -> OdometryRows:
    """Convert a run's solution table (docs/data-format.md, run folder) to ROS frames: the
    datum is the first row's position, the map frame the ENU tangent plane there. The position
    is exact through ECEF; the attitude, and P's NED position and attitude blocks (``M P Mᵀ``:
    the attitude error φ is a world-frame rotation), are turned from each row's local NED into
    the map frame by ``M`` (:func:`map_from_ned`); up to 0.4.7 they stayed in each row's own
    ENU, whose axes part from the map's with distance (1.6° of heading 100 km east of the datum
    at 60° N). The velocity block into FLU (``C_FRD_FLU C_bn P_v C_nb C_FRD_FLU``); no
    position-attitude correlation is kept in a solution table, so that block is zero. The
    angular twist is zero with :data:`UNKNOWN_ANGULAR_VARIANCE` (the solution has no rate)."""
    from adaptnav.api.results import check_finite, covariance_block
    from adaptnav.core import earth
    from adaptnav.core.attitude import dcm_to_quat, euler_to_dcm

    check_finite(solution, _exported_columns(solution), "solution")
    t_ns = origin_ns + np.round(solution["t_s"].to_numpy(dtype=float) * NS).astype(np.int64)
    check_stamps(int(t_ns[0]), int(t_ns[-1]))
    lat, lon, h = (solution[c].to_numpy(dtype=float) for c in ("lat_rad", "lon_rad", "h_m"))
    datum = (float(lat[0]), float(lon[0]), float(h[0]))
    r_enu = rosmsg.enu_to_ned(earth.geodetic_to_ned(lat, lon, h, *datum))
    rpy = solution[["roll_rad", "pitch_rad", "yaw_rad"]].to_numpy(dtype=float)
    C_nb = np.array([euler_to_dcm(*a) for a in rpy]).reshape(-1, 3, 3)
    M = map_from_ned(lat, lon, datum)
    q_wxyz = np.array([dcm_to_quat(C) for C in M @ C_nb @ rosmsg.C_FRD_FLU]).reshape(-1, 4)
    to_flu = rosmsg.C_FRD_FLU @ C_nb.transpose(0, 2, 1)
    v_n = solution[["vn_m_s", "ve_m_s", "vd_m_s"]].to_numpy(dtype=float)
    n = len(solution)
    pose = np.zeros((n, 6, 6))
    pose[:, :3, :3] = M @ covariance_block(solution, POSITION) @ M.transpose(0, 2, 1)
    pose[:, 3:, 3:] = M @ covariance_block(solution, ATTITUDE) @ M.transpose(0, 2, 1)
    twist = np.zeros((n, 6, 6))
    twist[:, :3, :3] = to_flu @ covariance_block(solution, VELOCITY) @ to_flu.transpose(0, 2, 1)
    twist[:, [3, 4, 5], [3, 4, 5]] = UNKNOWN_ANGULAR_VARIANCE
    return OdometryRows(
        t_ns,
        datum,
        r_enu,
        q_wxyz[:, [1, 2, 3, 0]],
        np.einsum("nij,nj->ni", to_flu, v_n),
        pose.reshape(n, 36),
        twist.reshape(n, 36),
    )


def _exported_columns(solution: pd.DataFrame) -> list[str]:
    """The solution columns an Odometry message carries: position, velocity, attitude, their
    σ and (when the table has them) their covariances."""
    from adaptnav.api.results import STATE_COLUMNS, cov_column, has_covariances

    columns = list(STATE_COLUMNS[:9])
    for block in (POSITION, VELOCITY, ATTITUDE):
        columns += [f"sd_{a}" for a in block]
        if has_covariances(solution, block):
            columns += [cov_column(a, b) for i, a in enumerate(block) for b in block[i + 1 :]]
    return columns


ROS_TIME_END_S = 2**31
"""A ROS 2 stamp's seconds are an int32 (``builtin_interfaces/msg/Time``): from 0 (ROS time is
not negative) to 2³¹ s, early 2038."""


def check_stamps(first_ns: int, last_ns: int) -> None:
    """The export's first and last stamps (ns) must lie in ROS 2's time range
    (:data:`ROS_TIME_END_S`); ValueError naming them otherwise (a wrong --stamp-origin-ns)."""
    if first_ns < 0 or last_ns >= ROS_TIME_END_S * NS:
        raise ValueError(
            f"stamps {first_ns} to {last_ns} ns: outside ROS 2's time range, 0 to 2^31 s "
            "(1970 to 2038; a stamp's seconds are an int32): check --stamp-origin-ns"
        )


_ROS_NAME = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")
"""A fully qualified ROS 2 topic name: ``/`` then tokens of letters, digits and underscores,
none starting with a digit, separated by single ``/`` (no ``~`` or ``{}`` substitutions: a
bag holds names resolved)."""
_FRAME_ID = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_./-]*")
"""A tf2 frame id: no leading ``/`` (tf2 refuses it), no spaces."""


def check_topics(names: ExportTopics) -> None:
    """ValueError naming the option whose value ROS 2 tools would refuse: a topic that is not
    a fully qualified name, the odometry topic equal to the datum's (one topic, two types), a
    frame id that is empty, starts with ``/`` or holds a space, or the two frames the same."""
    if not _ROS_NAME.fullmatch(names.odometry):
        raise ValueError(
            f"--topic: {names.odometry!r} is not a ROS 2 topic name (/ then letters, digits "
            "and _, e.g. /adaptnav/odometry)"
        )
    if names.odometry == names.datum:
        raise ValueError(f"--topic: {names.odometry!r} is the datum's topic (a NavSatFix)")
    frames = (("--frame-id", names.frame_id), ("--child-frame-id", names.child_frame_id))
    for option, frame in frames:
        if not _FRAME_ID.fullmatch(frame):
            raise ValueError(
                f"{option}: {frame!r} is not a frame id (letters, digits, _ . / -; no leading /)"
            )
    if names.frame_id == names.child_frame_id:
        raise ValueError(f"--child-frame-id: {names.child_frame_id!r} is the world frame too")


@dataclass(frozen=True)
class ExportTopics:
    """Where :func:`export_run` writes: the odometry and datum topics, the world frame (a
    local ENU tangent plane at the datum) and the body frame (FLU)."""

    odometry: str = "/adaptnav/odometry"
    datum: str = "/adaptnav/datum"
    frame_id: str = "map"
    child_frame_id: str = "base_link"


DEFAULT_TOPICS = ExportTopics()


def _odometry_messages(rows: OdometryRows, names: ExportTopics, store: Any) -> Iterator[Any]:
    T = store.types
    for k in range(rows.t_ns.size):
        ns = int(rows.t_ns[k])
        head = T["std_msgs/msg/Header"](
            T["builtin_interfaces/msg/Time"](ns // NS, ns % NS), names.frame_id
        )
        pose = T["geometry_msgs/msg/Pose"](
            T["geometry_msgs/msg/Point"](*rows.r_enu[k]),
            T["geometry_msgs/msg/Quaternion"](*rows.q_xyzw[k]),
        )
        twist = T["geometry_msgs/msg/Twist"](
            T["geometry_msgs/msg/Vector3"](*rows.v_flu[k]),
            T["geometry_msgs/msg/Vector3"](0.0, 0.0, 0.0),
        )
        yield T[ODOMETRY](
            head,
            names.child_frame_id,
            T["geometry_msgs/msg/PoseWithCovariance"](pose, rows.pose_cov[k]),
            T["geometry_msgs/msg/TwistWithCovariance"](twist, rows.twist_cov[k]),
        )


def _datum_message(rows: OdometryRows, names: ExportTopics, store: Any) -> Any:
    """The datum as one NavSatFix (degrees, ellipsoidal height; covariance unknown)."""
    T = store.types
    ns = int(rows.t_ns[0])
    lat, lon, h = rows.datum
    return T[NAVSATFIX](
        T["std_msgs/msg/Header"](
            T["builtin_interfaces/msg/Time"](ns // NS, ns % NS), names.frame_id
        ),
        T["sensor_msgs/msg/NavSatStatus"](0, 1),
        math.degrees(lat),
        math.degrees(lon),
        h,
        np.zeros(9),
        0,
    )


def write_odometry(
    rows: OdometryRows, folder: Path, name: str, storage: Storage, names: ExportTopics
) -> None:
    """Write the odometry and the datum as a rosbag2 bag into the existing, empty
    ``folder``; its storage file is named after ``name`` (the bag's final folder name)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
    staging = folder / name
    with Writer(staging, version=9, storage_plugin=plugin) as w:
        datum = w.add_connection(names.datum, NAVSATFIX, typestore=store)
        w.write(
            datum,
            int(rows.t_ns[0]),
            store.serialize_cdr(_datum_message(rows, names, store), NAVSATFIX),
        )
        odo = w.add_connection(names.odometry, ODOMETRY, typestore=store)
        for t, msg in zip(rows.t_ns, _odometry_messages(rows, names, store), strict=True):
            w.write(odo, int(t), store.serialize_cdr(msg, ODOMETRY))
    for item in staging.iterdir():  # metadata.yaml names the storage file relative to it
        item.rename(folder / item.name)
    staging.rmdir()


def export_run(
    run_dir: str | Path,
    folder: str | Path,
    *,
    name: str | None = None,
    storage: Storage = "sqlite3",
    names: ExportTopics = DEFAULT_TOPICS,
    stamp_origin_ns: int | None = None,
) -> dict[str, Any]:
    """Write a run's solution as a ROS 2 bag (docs/rosbag.md, 'Export') into ``folder``
    (existing and empty, or new): ``nav_msgs/msg/Odometry`` on ``names.odometry`` (pose in
    ``names.frame_id``, a local ENU frame at the datum, twist in ``names.child_frame_id``,
    FLU) and the datum as one NavSatFix on ``names.datum``. Stamps are mission time plus
    ``stamp_origin_ns`` (default the mission's, with a warning where it has none:
    :func:`export_stamp_origin`). Returns what was written."""
    from adaptnav.api.results import load

    check_topics(names)
    result = load(run_dir)
    origin = export_stamp_origin(result.meta, stamp_origin_ns)
    rows = odometry_rows(result.solution, origin)
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    write_odometry(rows, out, name or out.name, storage, names)
    lat, lon, h = rows.datum
    return {
        "messages": int(rows.t_ns.size),
        "storage": storage,
        "stamp_origin_ns": origin,
        "datum_deg_m": [math.degrees(lat), math.degrees(lon), h],
        "topics": [names.odometry, names.datum],
        "frames": [names.frame_id, names.child_frame_id],
    }
