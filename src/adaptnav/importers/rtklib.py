"""Importer of an RTKLIB-logged drive: a ``.pos`` solution, a raw IMU CSV and its time tag
(docs/rtklib.md).

The data of ``shared/data/rtklibexplorer-gnss-imu`` (repository ``rtklibexplorer/GNSS_IMU``) are
a car drive with a roof-mounted MEMS IMU and a u-blox receiver: an RTK solution
(``gnss_*.pos``, 4 Hz, 99.6 % fixed, σ about 1 cm), the raw IMU (``imu_*.csv``: accel in g,
gyro in deg/s, a millisecond counter; 100 Hz) and the logger's time tag of the IMU file
(``imu_*.csv.tag``). What the raw files need, each checked here against the data:

1. IMU time: the counter maps linearly onto ``[start, start + last_tick / 1000]`` of the tag
   (GPST), then the IMU time offset (published: -0.125 s) is added; it is **estimated** from
   the data (:func:`estimate_imu_time_offset`: the gyro's yaw increments against the GNSS
   course) and the published value is a check;
2. mounting: the sensor axes are turned into the vehicle's FRD body axes by roll/pitch/yaw
   ``[180, 0, 180]`` deg then ``[0, -6.79, 5.35]`` deg (:func:`mounting_dcm`); checked by the
   static specific force (level) and by the along-track acceleration, which must fall on the
   body x axis (:func:`forward_axis_angle`);
3. units: g and deg/s to m/s² and rad/s;
4. lever arm: the antenna sits at ``[0, -0.05, 0]`` m FRD from the IMU.

There is no attitude reference and no static gyrocompassing with a MEMS gyro, so the mission
starts (``[initial] mode = "state"``) at the first IMU sample, parked: roll and pitch by
levelling over the static window before the drive, heading carried back from the GNSS course
at the first fast epoch through the gyro's yaw increments (:func:`initial_heading`), the gyro
bias as the static mean (``[imu.initial_bias]``), position from the RTK solution.

A non-holonomic constraint stream (zero lateral and vertical velocity, 10 Hz,
:mod:`adaptnav.sensors.nhc`) is added by default: a model of the car, not a recorded sensor.
The RTK fixes are both the aiding and the reference: :func:`import_drive` withholds the fixes
inside **outage windows** from the GNSS stream (they stay in the truth table) so that the
inertial drift can be scored against them, as GNSS/INS papers do. Float solutions are not used
as aiding (recorded). The truth is the antenna's fixed solution moved to the IMU point.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import itertools
import json
import logging
import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid

from adaptnav.core import earth
from adaptnav.core.attitude import euler_to_dcm
from adaptnav.core.units import DEG, G0
from adaptnav.importers.timing import minimise_lag
from adaptnav.importers.tracks import (
    MAX_WRONG_FRACTION,
    TrackError,
    inconsistent_fixes,
    inconsistent_velocities,
)
from adaptnav.mission.config import DEFAULT_GAP_PERIODS, MissionConfig, MissionError, parse_config
from adaptnav.mission.loader import write_mission
from adaptnav.mission.tables import Repair

log = logging.getLogger("adaptnav.importers.rtklib")

Array = NDArray[np.float64]

__all__ = [
    "ANTENNA_LEVER_ARM_M",
    "DEFAULT_OUTAGES_S",
    "PUBLISHED_IMU_TIME_OFFSET_S",
    "PUBLISHED_MOUNTING_RPY_DEG",
    "PosSolution",
    "RawImu",
    "RtklibError",
    "TimeTag",
    "driving_imu_noise",
    "estimate_imu_time_offset",
    "forward_axis_angle",
    "import_drive",
    "imu_gpst",
    "initial_heading",
    "measured_imu_noise",
    "mounting_dcm",
    "read_imu_csv",
    "read_pos",
    "read_time_tag",
    "static_window",
]

GPS_EPOCH = dt.datetime(1980, 1, 6, tzinfo=dt.UTC)
PUBLISHED_MOUNTING_RPY_DEG: tuple[tuple[float, float, float], ...] = (
    (180.0, 0.0, 180.0),
    (0.0, -6.79, 5.35),
)
"""Roll/pitch/yaw (deg) turning the IMU's axes into the body's, applied in this order."""
PUBLISHED_IMU_TIME_OFFSET_S = -0.125
"""Published IMU time offset: true (GPST) time = tag time + this."""
ANTENNA_LEVER_ARM_M = (0.0, -0.05, 0.0)
"""Antenna from the IMU, body FRD (published: IMU at [0, 0, -0.65], antenna at
[0, -0.05, -0.65] m from the system origin)."""
PUBLISHED_NOISE = {
    "gyro_white_deg_s_rthz": 0.0038,
    "accel_white_ug_rthz": 70.0,
    "accel_bias_psd_ug_rthz": 7.0,
    "gyro_bias_psd_deg_s2_rthz": 3.8e-5,
}
"""The noise figures published with the data (README), kept in import.json as a check."""
DEFAULT_OUTAGES_S: tuple[tuple[float, float], ...] = (
    (60.0, 15.0),
    (100.0, 30.0),
    (210.0, 45.0),
    (300.0, 60.0),
    (440.0, 60.0),
)
"""(start, length) of the GNSS outages in s from the first IMU sample of ``drive_0708``: one
each of 15, 30 and 45 s and two of 60 s, all while driving (straights and turns), each after
at least 25 s of RTK fixes."""
GNSS_SIGMA_M = (0.02, 0.02, 0.04)
"""σ (N, E, D) given to the RTK fixes (assumed: twice the solution's own 1-cm σ, for the antenna
phase centre and multipath the solution's σ does not hold)."""
NHC_SIGMA_M_S = (0.2, 0.1)
"""σ (lateral, vertical) of the non-holonomic constraint (assumed: sideslip and the offset of
the IMU from the rear axle in turns, suspension travel); VB-MAESKF adapts it."""
NHC_RATE_HZ = 10.0
STATIC_SPEED_M_S = 0.2
"""The car is parked while the GNSS speed stays below this."""
STATIC_MARGIN_S = 2.0
"""The static window ends this long before the first GNSS epoch above STATIC_SPEED_M_S."""
HEADING_SPEED_M_S = 5.0
"""The GNSS course sets the heading at the first fixed epoch this fast."""
REVERSE_CHECK_S = 2.0
MOVING_SPEED_M_S = 3.0
"""The GNSS course is taken as the heading where the speed exceeds this."""
MIN_STATIC_S = 5.0
INITIAL_SIGMA_POSITION_M = 0.05
INITIAL_SIGMA_VELOCITY_M_S = 0.05
INITIAL_SIGMA_ATTITUDE_DEG = (0.5, 0.5, 3.0)
"""Assumed: levelling with a static-mean accelerometer bias of up to about 10 mg (0.5°); the
heading from the course through a sideslip and a mounting yaw known to about 2° (the measured
forward-axis residual, import.json) and the gyro integration."""
INITIAL_BIAS_SIGMA = {"gyro": (0.05, "deg/s"), "accel": (15.0, "mg")}
"""Assumed: the static mean leaves the gyro's in-run change; the accelerometer bias is not
separable from the tilt while parked, and the static |f| is 12 mg above g."""


class RtklibError(MissionError):
    """Bad RTKLIB input: a missing file or column, a malformed line, an unusable value.

    A :class:`~adaptnav.mission.MissionError` (``file``, ``line``, ``field``).
    """


# --- reading ------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PosSolution:
    """An RTKLIB ``.pos`` solution. ``gpst_s``: GPST as seconds since 1970-01-01 (RTKLIB's
    ``gtime_t``: the GPS calendar time counted like UTC, no leap seconds); ``q``: 1 fix,
    2 float, 4 DGPS, 5 single, ...; ``sd_neu``: σ north, east, up (m); ``v_ned``: velocity
    (NaN where the file has none); ``lines``: 1-based file line of each row."""

    path: Path
    gpst_s: Array
    lat_rad: Array
    lon_rad: Array
    h_m: Array
    q: NDArray[np.int64]
    ns: NDArray[np.int64]
    sd_neu: Array
    v_ned: Array
    lines: NDArray[np.int64]
    repairs: tuple[Repair, ...]
    velocity_lag_s: float | None = None
    """How late the file's velocity columns were against its positions (s), by which ``v_ned``
    was moved back (:func:`velocity_lag`); None without velocity columns or when not
    measurable."""

    @cached_property
    def speed(self) -> Array:
        return np.asarray(np.hypot(self.v_ned[:, 0], self.v_ned[:, 1]))

    @cached_property
    def course(self) -> Array:
        """atan2(v_E, v_N), unwrapped (rad)."""
        return np.asarray(np.unwrap(np.arctan2(self.v_ned[:, 1], self.v_ned[:, 0])))


POS_COLUMNS = ("latitude(deg)", "longitude(deg)", "height(m)", "Q", "ns", "sdn(m)", "sde(m)",
               "sdu(m)")  # fmt: skip
POS_VELOCITY_COLUMNS = ("vn(m/s)", "ve(m/s)", "vu(m/s)")


def _parse_gpst(tokens: Sequence[str]) -> float:
    """GPST seconds since 1970 of ``YYYY/MM/DD HH:MM:SS.sss`` or ``WEEK TOW``."""
    a, b = tokens
    if "/" in a:
        date = dt.datetime.strptime(a, "%Y/%m/%d").replace(tzinfo=dt.UTC)
        h, m, s = b.split(":")
        return date.timestamp() + 3600.0 * int(h) + 60.0 * int(m) + float(s)
    return GPS_EPOCH.timestamp() + 604800.0 * int(a) + float(b)


def _require_file(p: Path) -> None:
    """Refuse a path that is not a file (RtklibError naming the file and its folder)."""
    if not p.is_file():
        raise RtklibError(f"{p.name}: file not found in {p.parent}", file=str(p))


def _read_text(p: Path) -> str:
    """The UTF-8 text of ``p``; a missing file or one that is not UTF-8 text is an RtklibError
    naming the line and the byte (a binary file given for a text one, or a damaged line)."""
    _require_file(p)
    try:
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raw, at = exc.object, exc.start
        line = raw.count(b"\n", 0, at) + 1
        where = at - (raw.rfind(b"\n", 0, at) + 1) + 1
        raise RtklibError(
            f"{p.name} line {line}: not UTF-8 text (byte 0x{raw[at]:02x}, byte {where} of the "
            "line; a binary file, or a damaged line?)",
            file=p.name,
            line=line,
        ) from None


def _truncated_last_line(p: Path, line: int, detail: str) -> Repair:
    """The repair of a dropped truncated last line (docs/rtklib.md, "Inputs and what is
    refused"), logged as a warning."""
    log.warning("%s line %d: truncated last line dropped", p.name, line)
    return Repair(p.name, line, "(line)", "dropped truncated last line", detail)


def _split_pos_lines(p: Path, text: str) -> tuple[list[str], list[list[str]], list[int]]:
    """(column names, fields of each data line, 1-based line numbers) of a ``.pos`` text: the
    names from the last ``%`` header line that starts with a time system; blank lines skipped.
    Data before that header, or no header, is an RtklibError."""
    names: list[str] | None = None
    rows: list[list[str]] = []
    lines: list[int] = []
    for no, line in enumerate(text.removeprefix("\ufeff").splitlines(), start=1):
        if not line.strip():
            continue
        if line.startswith("%"):
            tokens = line[1:].split()
            if tokens and tokens[0] in ("GPST", "UTC", "JST"):
                names = tokens
            continue
        if names is None:
            raise RtklibError(
                f"{p.name} line {no}: data before the column header ('%  GPST  latitude(deg) ...')",
                file=p.name,
                line=no,
            )
        rows.append(line.split())
        lines.append(no)
    if names is None:
        raise RtklibError(f"{p.name}: no column header ('%  GPST  latitude(deg) ...')", file=p.name)
    return names, rows, lines


def _check_pos_header(p: Path, names: list[str]) -> list[str]:
    """The value columns after the time: the time system must be GPST and the columns
    :data:`POS_COLUMNS` present (lat/lon/height output), else an RtklibError."""
    if names[0] != "GPST":
        raise RtklibError(
            f"{p.name}: time system {names[0]}; only GPST solutions are supported (set "
            "'time format: gpst' in RTKLIB's solution options)",
            file=p.name,
            field=names[0],
        )
    cols = names[1:]
    missing = [c for c in POS_COLUMNS if c not in cols]
    if missing:
        raise RtklibError(
            f"{p.name}: missing column(s) {missing}; found {cols} (output lat/lon/height, "
            "not ECEF or ENU)",
            file=p.name,
            field=missing[0],
        )
    return cols


def _parse_pos_fields(
    p: Path, rows: list[list[str]], lines: list[int], cols: list[str]
) -> tuple[Array, Array]:
    """(GPST s since 1970 (n,), values (n, columns)) of the data lines; a line with another
    field count than the header, a bad time or a non-number is an RtklibError."""
    width = 2 + len(cols)
    values = np.full((len(rows), len(cols)), np.nan)
    t = np.empty(len(rows))
    for i, (r, no) in enumerate(zip(rows, lines, strict=True)):
        if len(r) != width:
            raise RtklibError(
                f"{p.name} line {no}: {len(r)} fields, the header has {width} (date and time "
                "count as two)",
                file=p.name,
                line=no,
            )
        try:
            t[i] = _parse_gpst(r[:2])
        except ValueError:
            raise RtklibError(
                f"{p.name} line {no}: time {' '.join(r[:2])!r} is not 'YYYY/MM/DD HH:MM:SS.s' "
                "or 'WEEK TOW'",
                file=p.name,
                line=no,
                field="GPST",
            ) from None
        for j, c in enumerate(cols):
            try:
                values[i, j] = float(r[2 + j])
            except ValueError:
                raise RtklibError(
                    f"{p.name} line {no}: {c} = {r[2 + j]!r} is not a number",
                    file=p.name,
                    line=no,
                    field=c,
                ) from None
    return t, values


POS_RANGES = {
    "height(m)": (-12_000.0, 100_000.0),
    "sdn(m)": (0.0, 1e6),
    "sde(m)": (0.0, 1e6),
    "sdu(m)": (0.0, 1e6),
}
"""Plausible ranges of a .pos file's height and σ columns (m): beyond, a damaged line (up to
0.4.4 a height of 1e300 was taken, and its neighbours left out as wrong fixes instead)."""


def _check_pos_values(p: Path, t: Array, col: dict[str, Array], lines: list[int]) -> None:
    """Refuse (RtklibError naming the line) a time that does not increase, a non-finite
    position, a height or σ outside :data:`POS_RANGES` or a latitude beyond ±90°."""
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        k = int(bad[0]) + 1
        raise RtklibError(
            f"{p.name} line {lines[k]}: time does not increase ({t[k] - t[k - 1]:+.3f} s after "
            f"line {lines[k - 1]})",
            file=p.name,
            line=lines[k],
            field="GPST",
        )
    for c in ("latitude(deg)", "longitude(deg)", "height(m)"):
        finite = np.isfinite(col[c])
        if not finite.all():
            k = int(np.flatnonzero(~finite)[0])
            raise RtklibError(
                f"{p.name} line {lines[k]}: {c} is not finite", file=p.name, line=lines[k], field=c
            )
    for c, (lo, hi) in POS_RANGES.items():
        out = ~((col[c] >= lo) & (col[c] <= hi))
        if out.any():
            k = int(np.flatnonzero(out)[0])
            raise RtklibError(
                f"{p.name} line {lines[k]}: {c} = {col[c][k]} is outside [{lo:g}, {hi:g}]",
                file=p.name,
                line=lines[k],
                field=c,
            )
    if np.any(np.abs(col["latitude(deg)"]) > 90.0):
        k = int(np.flatnonzero(np.abs(col["latitude(deg)"]) > 90.0)[0])
        raise RtklibError(
            f"{p.name} line {lines[k]}: latitude(deg) = {col['latitude(deg)'][k]} is beyond ±90",
            file=p.name,
            line=lines[k],
            field="latitude(deg)",
        )


def read_pos(path: str | Path) -> PosSolution:
    """Read an RTKLIB ``.pos`` file (header lines start with ``%``, the last one names the
    columns; time in GPST as a calendar date or GPS week and seconds).

    A truncated last line (fewer fields than the header) is dropped and recorded as a repair;
    any other malformed line, a non-number, an unknown time system or a time that does not
    increase is an :class:`RtklibError` naming the file, line and field.
    """
    p = Path(path)
    names, rows, lines = _split_pos_lines(p, _read_text(p))
    cols = _check_pos_header(p, names)
    width = 2 + len(cols)
    repairs: list[Repair] = []
    if rows and len(rows[-1]) < width:
        repairs.append(_truncated_last_line(p, lines[-1], f"{len(rows[-1])} of {width} fields"))
        rows, lines = rows[:-1], lines[:-1]
    if not rows:
        raise RtklibError(f"{p.name}: no solution lines", file=p.name)
    t, values = _parse_pos_fields(p, rows, lines, cols)
    col = {c: values[:, j] for j, c in enumerate(cols)}
    _check_pos_values(p, t, col, lines)
    if all(c in cols for c in POS_VELOCITY_COLUMNS):
        v = np.column_stack([col["vn(m/s)"], col["ve(m/s)"], -col["vu(m/s)"]])
    else:
        v = np.full((t.size, 3), np.nan)
    lat, lon = np.radians(col["latitude(deg)"]), np.radians(col["longitude(deg)"])
    keep = _wrong_fixes(p, t, lat, lon, col["height(m)"], col["Q"] == 1, v, lines, repairs)
    lag = None
    track = _track_velocity(t[keep], lat[keep], lon[keep], col["height(m)"][keep])
    if np.isnan(v).all():  # no velocity columns: the speed and course from the positions
        v = track
    else:
        v = v[keep]
        lag = velocity_lag(t[keep], v, track, col["Q"][keep] == 1)
        if lag is not None:
            v = np.column_stack([np.interp(t[keep] + lag, t[keep], v[:, j]) for j in range(3)])
            log.info("%s: velocity columns %.3f s late against the positions, moved back", p.name,
                     lag)  # fmt: skip
    return PosSolution(
        p, t[keep], lat[keep], lon[keep], col["height(m)"][keep],
        col["Q"][keep].astype(np.int64), col["ns"][keep].astype(np.int64),
        np.column_stack([col["sdn(m)"], col["sde(m)"], col["sdu(m)"]])[keep], v,
        np.asarray(lines, dtype=np.int64)[keep], tuple(repairs), lag,
    )  # fmt: skip


VELOCITY_LAG_MAX_S = 1.0
"""The lags :func:`velocity_lag` searches: [-VELOCITY_LAG_MAX_S / 2, VELOCITY_LAG_MAX_S]."""
VELOCITY_LAG_EPOCHS = 20
"""Fewest moving fixed epochs (with fixed neighbours) it measures the lag over."""
VELOCITY_LAG_MIN_S = 0.005
"""A lag smaller than this is left alone (None): the columns are the positions' rate."""


def velocity_lag(t: Array, v: Array, track: Array, fixed: NDArray[np.bool_]) -> float | None:
    """How late (s) a ``.pos`` file's velocity columns ``v`` are against the rate of its
    positions ``track`` (:func:`_track_velocity`): the lag τ minimising the mean squared
    horizontal misfit ``|v(t_k + τ) - track_k|²`` over the fixed epochs moving faster than
    1 m/s whose neighbours are fixed and evenly spaced (a central difference across a gap or a
    float solution is not the rate). RTKLIB's velocity is a state of its kinematic filter, which
    lags the positions under acceleration: on drive_0708 by 0.128 s (misfit 0.022 → 0.0007
    m²/s²), and a course taken from it put the IMU time offset at -0.071 s where the positions'
    course and the filter's own latency state give -0.20 s (docs/rtklib.md, 'IMU time'). None
    when it cannot be measured, or is below :data:`VELOCITY_LAG_MIN_S`."""
    if t.size < 3:
        return None
    ok = fixed.copy()
    ok[1:-1] &= fixed[:-2] & fixed[2:]
    ok[[0, -1]] = False
    span = np.full(t.size, np.inf)
    span[1:-1] = t[2:] - t[:-2]
    ok &= np.abs(span - 2.0 * float(np.median(np.diff(t)))) < 1e-3
    ok &= np.hypot(track[:, 0], track[:, 1]) > 1.0
    ok &= np.isfinite(v[:, :2]).all(axis=1)
    if int(ok.sum()) < VELOCITY_LAG_EPOCHS:
        return None

    def cost(lag: float) -> float:
        moved = np.column_stack([np.interp(t[ok] + lag, t, v[:, j]) for j in range(2)])
        return float(np.mean(np.sum((moved - track[ok, :2]) ** 2, axis=1)))

    try:
        lag = minimise_lag(cost, -0.5 * VELOCITY_LAG_MAX_S, VELOCITY_LAG_MAX_S, 0.01, 0.05)
    except ValueError:
        return None
    return lag if abs(lag) >= VELOCITY_LAG_MIN_S else None


def _track_velocity(t: Array, lat: Array, lon: Array, h: Array) -> Array:
    """NED velocity (m/s) of a track from its positions, for a ``.pos`` file written without
    RTKLIB's velocity columns (they are optional): central differences of the positions in the
    local north-east-down frame of each epoch (one-sided at the ends; NaN for one epoch).
    Up to 0.4.4 such a file was refused as 'the vehicle never moves'."""
    if t.size < 2:
        return np.full((t.size, 3), np.nan)
    r_e = earth.geodetic_to_ecef(lat, lon, h)
    v_e = np.gradient(r_e, t, axis=0)
    return np.asarray(np.einsum("nij,nj->ni", earth.C_ne(lat, lon), v_e))


WRONG_FIX = "wrong fix left out"
"""The repair of a fixed solution that disagrees with its neighbours (:func:`_wrong_fixes`)."""


def _wrong_fixes(
    p: Path,
    t: Array,
    lat: Array,
    lon: Array,
    h: Array,
    fixed: NDArray[np.bool_],
    v_ned: Array,
    lines: list[int],
    repairs: list[Repair],
) -> NDArray[np.bool_]:
    """The rows to keep: all but the fixed solutions whose position lies off the line through
    their neighbours (:func:`~.tracks.inconsistent_fixes`) or whose velocity disagrees with
    the positions around them (:func:`~.tracks.inconsistent_velocities`): a false RTK fix or a
    damaged line. Each one left out is a repair naming its line, logged (docs/rtklib.md,
    'Wrong fixes')."""
    r_e = earth.geodetic_to_ecef(lat, lon, h)
    try:
        jumped = inconsistent_fixes(t, r_e, fixed)
    except TrackError as exc:
        raise RtklibError(f"{p.name}: fixed solutions: {exc}", file=p.name) from None
    fast = inconsistent_velocities(t, r_e, earth.C_ne(lat, lon), v_ned, fixed & ~jumped)
    tested = int(np.count_nonzero(fixed & ~jumped & np.isfinite(v_ned).all(axis=1)))
    if int(fast.sum()) > max(10, MAX_WRONG_FRACTION * tested):
        # Not a few wrong fixes but columns that do not go together: a unit mix-up (latitude
        # in radians, velocities in km/h) makes most velocities disagree with the positions.
        raise RtklibError(
            f"{p.name}: the velocities of {int(fast.sum())} of {tested} fixed solutions disagree "
            "with the positions around them: not m/s and degrees (a unit mix-up in the "
            "latitude, longitude or velocity columns?)",
            file=p.name,
        )
    for k in np.flatnonzero(jumped | fast):
        if jumped[k]:
            what, detail = "(position)", "off the line through the neighbouring fixes"
        else:
            what, detail = "vn/ve/vu(m/s)", "velocity disagrees with the positions around it"
        repairs.append(Repair(p.name, lines[k], what, WRONG_FIX, detail))
        log.warning("%s line %d: %s (%s)", p.name, lines[k], WRONG_FIX, detail)
    return np.asarray(~(jumped | fast))


@dataclass(frozen=True, eq=False)
class TimeTag:
    """An RTKLIB time-tag file: the GPST start (s since 1970, :class:`PosSolution`) and
    (tick in ms after it, byte position in the tagged file) records."""

    path: Path
    start_gpst_s: float
    tick_f: int
    ticks_ms: NDArray[np.int64]
    positions: NDArray[np.int64]

    @property
    def span_s(self) -> float:
        return float(self.ticks_ms[-1]) / 1000.0


TAG_MAGIC = b"TIMETAG"
TAG_HEADER_BYTES = 60
TAG_RECORD = np.dtype([("tick", "<u4"), ("pos", "<u4")])


def read_time_tag(path: str | Path) -> TimeTag:
    """Read an RTKLIB ``.tag`` file: a 60-byte header starting ``TIMETAG``, then uint32
    tick_f, uint32 time (s), double fraction (the start, GPST), then (uint32 tick ms, uint32
    file position) records. A wrong header, a partial record or ticks that go back are an
    :class:`RtklibError`."""
    p = Path(path)
    _require_file(p)
    b = p.read_bytes()
    head = TAG_HEADER_BYTES + 16
    if len(b) < head or not b.startswith(TAG_MAGIC):
        raise RtklibError(
            f"{p.name}: not an RTKLIB time tag (no 'TIMETAG' header of {head} bytes)", file=p.name
        )
    tick_f, t_s = struct.unpack_from("<II", b, TAG_HEADER_BYTES)
    (frac,) = struct.unpack_from("<d", b, TAG_HEADER_BYTES + 8)
    body = len(b) - head
    if body % TAG_RECORD.itemsize:
        raise RtklibError(
            f"{p.name}: {body} bytes after the header is not a whole number of 8-byte records "
            "(a truncated file)",
            file=p.name,
        )
    rec = np.frombuffer(b, dtype=TAG_RECORD, offset=head)
    if rec.size < 2:
        raise RtklibError(f"{p.name}: {rec.size} record(s), at least 2 needed", file=p.name)
    ticks = rec["tick"].astype(np.int64)
    back = np.flatnonzero(np.diff(ticks) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise RtklibError(f"{p.name}: record {k}: tick {ticks[k]} ms goes back", file=p.name)
    if not (0.0 <= frac < 1.0):
        raise RtklibError(f"{p.name}: start fraction {frac} is not in [0, 1)", file=p.name)
    return TimeTag(p, float(t_s) + float(frac), int(tick_f), ticks, rec["pos"].astype(np.int64))


@dataclass(frozen=True, eq=False)
class RawImu:
    """The raw IMU CSV as read: sensor axes, accel in g, gyro in deg/s, the ms counter, and the
    1-based file line of each sample."""

    path: Path
    accel_g: Array
    gyro_deg_s: Array
    counter_ms: Array
    lines: NDArray[np.int64]
    repairs: tuple[Repair, ...]


IMU_FIELDS = ("acc_x_g", "acc_y_g", "acc_z_g", "gyro_x_deg_s", "gyro_y_deg_s", "gyro_z_deg_s",
              "counter_ms")  # fmt: skip
MAX_ACCEL_G = 16.0
MAX_GYRO_DEG_S = 2000.0
"""Beyond a MEMS IMU's range: an absurd value (or a unit mix-up) is an error."""
MIN_MEDIAN_G, MAX_MEDIAN_G = 0.5, 2.0
"""The median |acc| (g) of a drive must lie between these: a car senses gravity, about 1 g, plus
what it accelerates by (a file in m/s² reads about 9.8 here; up to 0.4.4 it was imported and the
run wrote NaN positions)."""
GYRO_GAIN_RANGE = (0.5, 2.0)
"""The ratio of the GNSS course's changes to the gyro's heading changes must lie in this range
(:func:`estimate_imu_time_offset`): 57 or 1/57 is a gyro in rad/s read as deg/s, or the other
way round."""


def _imu_sample_lines(p: Path, raw: list[str]) -> tuple[list[tuple[int, str]], list[Repair]]:
    """(1-based line number, text) of the sample lines, and the repairs: blank lines and a
    header line (one that is not all numbers) skipped, and a truncated last line (fewer
    fields, or a cut number, at the end of the file) dropped."""
    numbered = [(no, line) for no, line in enumerate(raw, start=1) if line.strip()]
    if numbered and not _numbers(numbered[0][1].split(",")):  # a header line
        numbered = numbered[1:]
    repairs: list[Repair] = []
    if numbered:
        no, last = numbered[-1]
        fields = last.split(",")
        cut = len(fields) != len(IMU_FIELDS) or not raw[-1:] or not _numbers(fields)
        if cut and no == len(raw):
            detail = f"{len(fields)} of {len(IMU_FIELDS)} fields: {last!r}"
            repairs.append(_truncated_last_line(p, no, detail))
            numbered = numbered[:-1]
    return numbered, repairs


def _parse_imu_fields(p: Path, numbered: list[tuple[int, str]]) -> Array:
    """The sample lines as numbers (n, 7), :data:`IMU_FIELDS`; a line with another field count
    or a non-number is an RtklibError naming the line and field."""
    data = np.empty((len(numbered), len(IMU_FIELDS)))
    for i, (no, line) in enumerate(numbered):
        fields = line.split(",")
        if len(fields) != len(IMU_FIELDS):
            raise RtklibError(
                f"{p.name} line {no}: {len(fields)} fields, expected {len(IMU_FIELDS)} "
                f"({', '.join(IMU_FIELDS)})",
                file=p.name,
                line=no,
            )
        for j, v in enumerate(fields):
            try:
                data[i, j] = float(v)
            except ValueError:
                raise RtklibError(
                    f"{p.name} line {no}: {IMU_FIELDS[j]} = {v.strip()!r} is not a number",
                    file=p.name,
                    line=no,
                    field=IMU_FIELDS[j],
                ) from None
    return data


def _check_imu_values(p: Path, data: Array, lines: NDArray[np.int64]) -> None:
    """Refuse (RtklibError naming the line and field) a value that is not finite or beyond
    :data:`MAX_ACCEL_G` / :data:`MAX_GYRO_DEG_S` (wrong units), and a counter that does not
    increase."""
    for j, limit in ((0, MAX_ACCEL_G), (3, MAX_GYRO_DEG_S)):
        block = data[:, j : j + 3]
        bad = ~np.isfinite(block) | (np.abs(block) > limit)
        if bad.any():
            i, k = (int(v[0]) for v in np.nonzero(bad))
            raise RtklibError(
                f"{p.name} line {lines[i]}: {IMU_FIELDS[j + k]} = {block[i, k]} is not finite or "
                f"beyond ±{limit:g} (units g and deg/s expected)",
                file=p.name,
                line=int(lines[i]),
                field=IMU_FIELDS[j + k],
            )
    mag = float(np.median(np.linalg.norm(data[:, :3], axis=1)))
    if not MIN_MEDIAN_G <= mag <= MAX_MEDIAN_G:
        raise RtklibError(
            f"{p.name}: the accelerometer's median |acc| is {mag:.4g} g, where a vehicle on "
            f"the ground senses about 1 g (acc_x/y/z in m/s², not g?)",
            file=p.name,
            field="acc_x_g",
        )
    c = data[:, 6]
    steps = np.diff(c)
    back = np.flatnonzero(~(steps > 0.0))
    if back.size:
        i = int(back[0]) + 1
        raise RtklibError(
            f"{p.name} line {lines[i]}: counter_ms {c[i]:.0f} does not increase (line "
            f"{lines[i - 1]}: {c[i - 1]:.0f})",
            file=p.name,
            line=int(lines[i]),
            field="counter_ms",
        )
    step = float(np.median(steps)) if steps.size else 0.0
    gap = np.flatnonzero(steps > DEFAULT_GAP_PERIODS * step)
    if gap.size:  # the mission would refuse it, naming a row of imu.parquet instead
        i = int(gap[0]) + 1
        raise RtklibError(
            f"{p.name} line {lines[i]}: counter_ms jumps {steps[i - 1]:.0f} ms after line "
            f"{lines[i - 1]}, where a step is {step:.0f} ms: a gap of samples (more than "
            f"{DEFAULT_GAP_PERIODS:g} steps; cut the drive there)",
            file=p.name,
            line=int(lines[i]),
            field="counter_ms",
        )


def read_imu_csv(path: str | Path) -> RawImu:
    """Read the raw IMU CSV: ``acc x, y, z (g), gyro x, y, z (deg/s), counter (ms)``, with or
    without one header line.

    A truncated last line (fewer fields, or a cut number) is dropped and recorded as a repair;
    any other malformed line, a value beyond the sensor's range, or a counter that does not
    increase is an :class:`RtklibError` naming the file, line and field.
    """
    p = Path(path)
    numbered, repairs = _imu_sample_lines(p, _read_text(p).splitlines())
    if len(numbered) < 2:
        raise RtklibError(f"{p.name}: {len(numbered)} sample line(s), at least 2", file=p.name)
    data = _parse_imu_fields(p, numbered)
    lines = np.array([no for no, _ in numbered], dtype=np.int64)
    _check_imu_values(p, data, lines)
    return RawImu(p, data[:, :3], data[:, 3:6], data[:, 6], lines, tuple(repairs))


def _numbers(fields: Sequence[str]) -> bool:
    try:
        [float(v) for v in fields]
    except ValueError:
        return False
    return True


def imu_gpst(imu: RawImu, tag: TimeTag) -> Array:
    """GPST (s since 1970) of each IMU sample before any offset: the counter mapped linearly
    onto ``[start, start + last tick / 1000]`` of the tag (the data README)."""
    c = imu.counter_ms
    return np.asarray(tag.start_gpst_s + (c - c[0]) / (c[-1] - c[0]) * tag.span_s)


# --- corrections and their checks ----------------------------------------------------------------


def mounting_dcm(steps: Sequence[Sequence[float]] = PUBLISHED_MOUNTING_RPY_DEG) -> Array:
    """``C_bs``, sensor axes to body axes: each roll/pitch/yaw step (deg) turns the axes
    further, ``C_bs = C(step_n) ... C(step_1)`` with ``C`` the ZYX Euler DCM of
    :func:`adaptnav.core.attitude.euler_to_dcm`."""
    C = np.eye(3)
    for r, p, y in steps:
        C = euler_to_dcm(math.radians(r), math.radians(p), math.radians(y)) @ C
    return C


def body_imu(imu: RawImu, C_bs: Array) -> tuple[Array, Array]:
    """(specific force m/s², angular rate rad/s) in body axes (corrections 2 and 3)."""
    return (imu.accel_g * G0) @ C_bs.T, np.radians(imu.gyro_deg_s) @ C_bs.T


def static_window(t_imu: Array, sol: PosSolution) -> tuple[float, float]:
    """(start, end) of the parked stretch at the start: from the first IMU sample to
    ``STATIC_MARGIN_S`` before the first GNSS epoch faster than ``STATIC_SPEED_M_S``."""
    after = sol.gpst_s >= t_imu[0]
    moving = after & (sol.speed > STATIC_SPEED_M_S)
    if not moving.any():
        raise RtklibError(f"{sol.path.name}: the vehicle never moves", file=sol.path.name)
    first = int(np.argmax(after))
    if moving[first]:  # what the IMU did before the GNSS's first fix is not known
        raise RtklibError(
            f"{sol.path.name} line {int(sol.lines[first])}: the first solution in the IMU's time "
            f"is moving ({float(sol.speed[first]):.1f} m/s): the drive must start parked and "
            "seen so by the GNSS, to level and take the gyro bias (a .pos that starts late?)",
            file=sol.path.name,
            line=int(sol.lines[first]),
        )
    end = float(sol.gpst_s[np.argmax(moving)]) - STATIC_MARGIN_S
    if end - t_imu[0] < MIN_STATIC_S:
        raise RtklibError(
            f"{sol.path.name}: only {end - t_imu[0]:.1f} s parked before the drive, at least "
            f"{MIN_STATIC_S:g} s needed to level and take the gyro bias",
            file=sol.path.name,
        )
    return float(t_imu[0]), end


def level(f_b: Array) -> tuple[float, float]:
    """Roll and pitch (rad) from a mean static specific force ``f_b`` (Groves 5.101)."""
    roll = math.atan2(-f_b[1], -f_b[2])
    pitch = math.atan2(f_b[0], math.hypot(f_b[1], f_b[2]))
    return roll, pitch


def _yaw_rate(gyro_b: Array, roll: float, pitch: float) -> Array:
    """Euler yaw rate of the body rates at a fixed roll and pitch (Groves 2.58)."""
    return np.asarray(
        (gyro_b[:, 1] * math.sin(roll) + gyro_b[:, 2] * math.cos(roll)) / math.cos(pitch)
    )


def _course_increments(
    sol: PosSolution, mask: NDArray[np.bool_], step: int
) -> tuple[Array, Array, Array]:
    """(t_a, t_b, Δcourse) from epoch k to k + step, both in ``mask``."""
    k = np.flatnonzero(mask[:-step] & mask[step:])
    crs = sol.course
    return sol.gpst_s[k], sol.gpst_s[k + step], crs[k + step] - crs[k]


OFFSET_SPEED_M_S = 5.0
"""The GNSS course enters the time-offset fit where the speed exceeds this."""
OFFSET_INCREMENT_S = 1.0
"""Course and yaw increments over this span: shorter ones carry more of the course noise."""


def estimate_imu_time_offset(
    t_imu: Array,
    gyro_b: Array,
    sol: PosSolution,
    *,
    static: NDArray[np.bool_] | None = None,
    roll_pitch: tuple[float, float] = (0.0, 0.0),
    max_lag_s: float = 0.5,
    step_s: float = 0.01,
) -> float:
    """The IMU time offset δ (s; true time = tag time + δ) that best fits the gyro's yaw
    increments to the GNSS course increments.

    Over ``OFFSET_INCREMENT_S`` between fixed GNSS epochs faster than ``OFFSET_SPEED_M_S`` the
    course change equals the heading change (a car's sideslip changes little), the integral of the
    Euler yaw rate (Groves 2.58) of the gyro less its ``static`` mean, at the parked ``roll_pitch``
    (the road is nearly level). The mean squared misfit is minimised over ``[-max_lag_s,
    max_lag_s]`` (:func:`~adaptnav.importers.timing.minimise_lag`). On drive_0708 this gives -0.071
    s (1-s increments, 5 m/s), and -0.04 to -0.08 s for increments of 0.5-2 s and speed floors of
    3-7 m/s (the published value is -0.125 s; docs/rtklib.md).
    """
    bias = gyro_b[static].mean(axis=0) if static is not None else np.zeros(3)
    rate = _yaw_rate(gyro_b - bias, *roll_pitch)
    psi = cumulative_trapezoid(rate, t_imu, initial=0.0)
    ok = (sol.q == 1) & (sol.speed > OFFSET_SPEED_M_S)
    period = float(np.median(np.diff(sol.gpst_s)))
    step = max(1, round(OFFSET_INCREMENT_S / period))
    ta, tb, dc = _course_increments(sol, ok, step)
    inside = (ta - max_lag_s > t_imu[0]) & (tb + max_lag_s < t_imu[-1])
    ta, tb, dc = ta[inside], tb[inside], dc[inside]
    if ta.size < 20:
        raise RtklibError(
            f"{sol.path.name}: {ta.size} moving fixed epoch pairs inside the IMU span, too few "
            "to estimate the IMU time offset",
            file=sol.path.name,
        )

    def turned(lag: float) -> Array:
        """The gyro's heading change over each pair's span, shifted by ``lag``."""
        return np.asarray(np.interp(tb - lag, t_imu, psi) - np.interp(ta - lag, t_imu, psi))

    def cost(lag: float) -> float:
        return float(np.mean((turned(lag) - dc) ** 2))

    what = f"the IMU against {sol.path.name}'s course, the IMU time offset"
    lag = minimise_lag(cost, -max_lag_s, max_lag_s, step_s, 0.05, what)
    d = turned(lag)
    gain = float(np.dot(d, dc) / np.dot(d, d)) if np.dot(d, d) > 0.0 else math.inf
    if not GYRO_GAIN_RANGE[0] <= gain <= GYRO_GAIN_RANGE[1]:
        raise RtklibError(
            f"{sol.path.name}: its course changes are {gain:.3g} times the gyro's heading "
            "changes over the same epochs, where they should agree (gyro_x/y/z not in deg/s, "
            "or the wrong IMU file?)",
            file=sol.path.name,
        )
    return lag


FORWARD_WINDOW_S = 0.5
STRAIGHT_RATE_RAD_S = math.radians(1.0)


def forward_axis_angle(t_imu: Array, f_b: Array, gyro_b: Array, sol: PosSolution) -> float:
    """Angle (rad, about body z) between the body x axis and the direction the along-track
    acceleration appears in: 0 when the mounting yaw is right.

    On straight stretches (|yaw rate| < 1 °/s, speed > ``MOVING_SPEED_M_S``) the GNSS speed's
    rate of change a is the along-track acceleration; the body specific force, averaged over
    ``FORWARD_WINDOW_S``, is regressed on it, ``f_x = k_x a + c_x``, ``f_y = k_y a + c_y`` (the
    constants take up gravity on the slope), and the angle is ``atan2(k_y, k_x)``.
    """
    w = max(1, round(FORWARD_WINDOW_S / float(np.median(np.diff(t_imu)))))
    kernel = np.ones(w) / w
    smooth = [np.convolve(f_b[:, i], kernel, mode="same") for i in range(2)]
    rate = np.convolve(gyro_b[:, 2], kernel, mode="same")
    t = sol.gpst_s
    a = np.gradient(sol.speed, t)
    inside = (t > t_imu[0] + 1.0) & (t < t_imu[-1] - 1.0)
    straight = (
        inside
        & (sol.q == 1)
        & (sol.speed > MOVING_SPEED_M_S)
        & (np.abs(np.interp(t, t_imu, rate)) < STRAIGHT_RATE_RAD_S)
    )
    if straight.sum() < 20:
        raise RtklibError(f"{sol.path.name}: too few straight epochs", file=sol.path.name)
    X = np.column_stack([a[straight], np.ones(int(straight.sum()))])
    kx = np.linalg.lstsq(X, np.interp(t[straight], t_imu, smooth[0]), rcond=None)[0][0]
    ky = np.linalg.lstsq(X, np.interp(t[straight], t_imu, smooth[1]), rcond=None)[0][0]
    return float(math.atan2(ky, kx))


def initial_heading(
    t_imu: Array, f_b: Array, gyro_b: Array, sol: PosSolution, window: tuple[float, float]
) -> tuple[float, dict[str, Any]]:
    """Heading (rad) at the first IMU sample, parked.

    At the first fixed epoch t1 after the static window faster than ``HEADING_SPEED_M_S`` the
    car's heading is its course (``+ π`` if it is reversing: within ``REVERSE_CHECK_S`` of t1
    the along-track acceleration then shows on the body's -x); the heading change from the static
    window's end to t1 is the integral of the Euler yaw rate of the bias-corrected gyro
    (static mean removed), with the parked roll and pitch; before that the car is parked.
    """
    t0, t_end = window
    static = (t_imu >= t0) & (t_imu <= t_end)
    roll, pitch = level(f_b[static].mean(axis=0))
    after = (sol.gpst_s > t_end) & (sol.q == 1) & (sol.speed > HEADING_SPEED_M_S)
    if not after.any():
        raise RtklibError(
            f"{sol.path.name}: no fixed epoch faster than {HEADING_SPEED_M_S} m/s after parking",
            file=sol.path.name,
        )
    k1 = int(np.argmax(after))
    t1 = float(sol.gpst_s[k1])
    rate = _yaw_rate(gyro_b - gyro_b[static].mean(axis=0), roll, pitch)
    span = (t_imu >= t_end) & (t_imu <= t1)
    turned = float(np.trapezoid(rate[span], t_imu[span])) if span.sum() > 1 else 0.0
    # Forward or reversing at t1: the along-track acceleration a around t1 appears on +x
    # forward, on -x reversing (f_x less its parked value, which holds the slope's gravity).
    near = (sol.gpst_s >= t1 - REVERSE_CHECK_S) & (sol.gpst_s <= t1 + REVERSE_CHECK_S)
    a = np.gradient(sol.speed, sol.gpst_s)[near]
    fx = np.interp(sol.gpst_s[near], t_imu, f_b[:, 0]) - f_b[static, 0].mean()
    f_forward = float(np.sum(fx * a) / max(float(np.sum(a * a)), 1e-12))
    reversing = f_forward < 0.0
    course = float(math.atan2(sol.v_ned[k1, 1], sol.v_ned[k1, 0]))
    heading_t1 = course + (math.pi if reversing else 0.0)
    yaw0 = math.remainder(heading_t1 - turned, 2.0 * math.pi)
    info = {
        "t1_gpst_s": t1,
        "speed_at_t1_m_s": float(sol.speed[k1]),
        "course_at_t1_deg": math.degrees(course),
        "turned_until_t1_deg": math.degrees(turned),
        "reversing": reversing,
        "forward_specific_force_per_along_track_acceleration": f_forward,
    }
    return yaw0, info


def measured_imu_noise(
    t_imu: Array, f_b: Array, gyro_b: Array, window: tuple[float, float], tau_s: float = 1.0
) -> tuple[float, float]:
    """(ARW rad/√s, VRW m/s/√s): the Allan deviation at ``tau_s`` times √τ over the static
    window, RMS over the three axes. Parked with the engine running, this holds the
    vibration the drive adds to the sensor's own white noise (the published figures are
    several times smaller; import.json keeps both)."""
    static = (t_imu >= window[0]) & (t_imu <= window[1])
    period = float(np.median(np.diff(t_imu)))
    m = max(1, round(tau_s / period))

    def allan(x: Array) -> float:
        n = x.shape[0] // m
        blocks = x[: n * m].reshape(n, m, 3).mean(axis=1)
        adev = np.sqrt(0.5 * np.mean(np.diff(blocks, axis=0) ** 2, axis=0))
        return float(np.sqrt(np.mean(adev**2)) * math.sqrt(m * period))

    return allan(gyro_b[static]), allan(f_b[static])


VIBRATION_WINDOW_S = 0.25
"""The high-pass of :func:`driving_imu_noise`: the signal less its moving mean over this."""


def driving_imu_noise(
    t_imu: Array, f_b: Array, gyro_b: Array, sol: PosSolution
) -> tuple[float, float]:
    """(ARW rad/√s, VRW m/s/√s) as if the vibration while driving were white: the standard
    deviation of the signal less its ``VIBRATION_WINDOW_S`` moving mean, over the samples where
    the GNSS speed exceeds ``MOVING_SPEED_M_S``, times √(sample period), RMS over the axes.

    An upper bound on what the drive adds to the integration error (real vibration that the
    100-Hz samples follow averages out); on drive_0708 it is about ten times the parked Allan
    figure, led by the pitch axis (docs/rtklib.md).
    """
    period = float(np.median(np.diff(t_imu)))
    w = max(3, round(VIBRATION_WINDOW_S / period))
    kernel = np.ones(w) / w
    moving = np.interp(t_imu, sol.gpst_s, sol.speed) > MOVING_SPEED_M_S
    moving[:w] = moving[-w:] = False

    def white(x: Array) -> float:
        hp = np.column_stack(
            [x[:, i] - np.convolve(x[:, i], kernel, mode="same") for i in range(3)]
        )
        sd = hp[moving].std(axis=0)
        return float(np.sqrt(np.mean(sd**2)) * math.sqrt(period))

    return white(gyro_b), white(f_b)


# --- the mission --------------------------------------------------------------------------------


def _heading_track(sol: PosSolution, yaw0: float) -> Array:
    """Heading (rad) at each solution epoch: the course where faster than MOVING_SPEED_M_S, the
    previous one held elsewhere (``yaw0`` before the first)."""
    crs = pd.Series(np.arctan2(sol.v_ned[:, 1], sol.v_ned[:, 0]))
    moving = (sol.speed > MOVING_SPEED_M_S) & np.isfinite(crs.to_numpy())
    return np.asarray(crs.where(moving).ffill().fillna(yaw0).to_numpy(), dtype=float)


def _move_to_imu(sol: PosSolution, heading: Array, lever_b: Array) -> tuple[Array, Array, Array]:
    """Antenna positions moved to the IMU: ``r_imu = r_ant - C_nb l_b`` with the heading only
    (roll and pitch of a car turn a 5-cm arm by millimetres)."""
    arm_n = np.column_stack(
        [
            np.cos(heading) * lever_b[0] - np.sin(heading) * lever_b[1],
            np.sin(heading) * lever_b[0] + np.cos(heading) * lever_b[1],
            np.full(heading.size, lever_b[2]),
        ]
    )
    return earth.ned_to_geodetic(-arm_n, sol.lat_rad, sol.lon_rad, sol.h_m)


def _check_outages(
    outages: Sequence[tuple[float, float]], t_end: float
) -> list[tuple[float, float]]:
    out = sorted((float(a), float(b)) for a, b in outages)
    for a, length in out:
        if not (math.isfinite(a) and math.isfinite(length) and a > 0.0 and length > 0.0):
            raise ValueError(f"outage ({a}, {length}): start and length must be > 0")
        if a + length > t_end:
            raise ValueError(f"outage ({a}, {length}) ends after the data ({t_end:.1f} s)")
    for (a1, l1), (a2, _) in itertools.pairwise(out):
        if a2 < a1 + l1:
            raise ValueError(f"outages at {a1} s and {a2} s overlap")
    return out


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# --- the import: check, estimate, build ---------------------------------------------------------


@dataclass(frozen=True, eq=False)
class DriveSettings:
    """The import's settings (:func:`check_settings`): the RTK fixes' σ (N, E, D) m, the
    non-holonomic constraint's σ (lateral, vertical) m/s or None for none, the IMU white-noise
    model (checked where the noise is written, :func:`_noise_section`) and the mounting steps
    (docs/rtklib.md, "The corrections")."""

    gnss_sigma_m: Array
    nhc_sigma_m_s: Array | None
    imu_noise: str
    mounting_rpy_deg: Sequence[Sequence[float]]


def check_settings(
    gnss_sigma_m: Sequence[float],
    nhc_sigma_m_s: Sequence[float] | None,
    imu_noise: str,
    mounting_rpy_deg: Sequence[Sequence[float]],
) -> DriveSettings:
    """The import's settings, the σ's refused (ValueError) unless three (GNSS) or two (NHC)
    finite numbers > 0."""
    sigma_g = np.asarray(gnss_sigma_m, dtype=float)
    if sigma_g.shape != (3,) or not np.all(np.isfinite(sigma_g) & (sigma_g > 0)):
        raise ValueError(f"gnss_sigma_m: {gnss_sigma_m!r} is not three numbers > 0")
    sigma_nhc = None if nhc_sigma_m_s is None else np.asarray(nhc_sigma_m_s, dtype=float)
    if sigma_nhc is not None and (
        sigma_nhc.shape != (2,) or not np.all(np.isfinite(sigma_nhc) & (sigma_nhc > 0))
    ):
        raise ValueError(f"nhc_sigma_m_s: {nhc_sigma_m_s!r} is not two numbers > 0")
    return DriveSettings(sigma_g, sigma_nhc, imu_noise, mounting_rpy_deg)


MAX_TIME_OFFSET_S = 5.0
"""A given IMU time offset must be within this (s): NaN, infinities and offsets of minutes are
refused (up to 0.4.4 NaN passed and was reported as 'the vehicle never moves')."""


@dataclass(frozen=True, eq=False)
class DriveClock:
    """The IMU in body axes on the GPST clock (docs/rtklib.md, corrections 1-3): ``C_bs``,
    specific force ``f_b`` (m/s²) and rate ``w_b`` (rad/s) (n, 3); the IMU time offset
    estimated and used (s); ``t_gps`` the GPST of each sample, ``origin`` the first, and the
    mission time ``t_imu = t_gps - origin``."""

    C_bs: Array
    f_b: Array
    w_b: Array
    offset_estimated: float
    offset: float
    t_gps: Array
    origin: float
    t_imu: Array


def estimate_clock(
    sol: PosSolution,
    raw: RawImu,
    tag: TimeTag,
    settings: DriveSettings,
    time_offset_s: float | None,
) -> DriveClock:
    """Turn the IMU into body axes (:func:`body_imu`), map its counter onto GPST
    (:func:`imu_gpst`) and estimate the IMU time offset (:func:`estimate_imu_time_offset`,
    docs/rtklib.md, correction 1); ``time_offset_s`` replaces the estimate."""
    C_bs = mounting_dcm(settings.mounting_rpy_deg)
    f_b, w_b = body_imu(raw, C_bs)
    t_tag = imu_gpst(raw, tag)
    # The parked stretch on the tag's clock (a tenth of a second does not move it): for the
    # offset fit's gyro bias and level.
    window_tag = static_window(t_tag, sol)
    static_tag = (t_tag >= window_tag[0]) & (t_tag <= window_tag[1])
    delta_est = estimate_imu_time_offset(
        t_tag, w_b, sol, static=static_tag, roll_pitch=level(f_b[static_tag].mean(axis=0))
    )
    delta = delta_est if time_offset_s is None else float(time_offset_s)
    t_gps = t_tag + delta
    origin = float(t_gps[0])
    return DriveClock(C_bs, f_b, w_b, delta_est, delta, t_gps, origin, t_gps - origin)


@dataclass(frozen=True, eq=False)
class DriveStart:
    """The parked start (docs/rtklib.md, "The start"): the static window (GPST s) and its mean
    specific force (m/s², body); roll, pitch and yaw (rad) and the heading's details; the gyro
    bias (rad/s); the forward-axis angle (rad) with and without the mounting's last yaw."""

    window: tuple[float, float]
    f_static: Array
    roll: float
    pitch: float
    yaw: float
    heading_info: dict[str, Any]
    gyro_bias: Array
    forward: float
    forward_without_last_yaw: float


def estimate_start(
    sol: PosSolution, raw: RawImu, clock: DriveClock, settings: DriveSettings
) -> DriveStart:
    """Level over the static window (:func:`static_window`, :func:`level`), carry the heading
    back from the first fast course (:func:`initial_heading`), take the gyro bias as the static
    mean less the earth rate, and check the mounting by the forward-axis angle
    (:func:`forward_axis_angle`) with and without its last yaw (docs/rtklib.md, correction 2
    and "The start")."""
    t_gps, f_b, w_b = clock.t_gps, clock.f_b, clock.w_b
    window = static_window(t_gps, sol)
    static = (t_gps >= window[0]) & (t_gps <= window[1])
    roll0, pitch0 = level(f_b[static].mean(axis=0))
    yaw0, heading_info = initial_heading(t_gps, f_b, w_b, sol, window)
    forward = forward_axis_angle(t_gps, f_b, w_b, sol)
    steps = [tuple(float(v) for v in s) for s in settings.mounting_rpy_deg]
    no_yaw = [*steps[:-1], (steps[-1][0], steps[-1][1], 0.0)] if steps else []
    forward_no_yaw = forward_axis_angle(t_gps, *body_imu(raw, mounting_dcm(no_yaw)), sol)
    lat_f = float(np.interp(t_gps[0], sol.gpst_s, sol.lat_rad))
    C_nb0 = euler_to_dcm(roll0, pitch0, yaw0)
    bias_g = w_b[static].mean(axis=0) - C_nb0.T @ earth.earth_rate_n(lat_f)
    return DriveStart(
        window,
        f_b[static].mean(axis=0),
        roll0,
        pitch0,
        yaw0,
        heading_info,
        bias_g,
        forward,
        forward_no_yaw,
    )


@dataclass(frozen=True)
class ImuNoise:
    """The IMU white noise estimated from the data (docs/rtklib.md, "IMU noise"): ARW (rad/√s)
    and VRW (m/s/√s) parked (:func:`measured_imu_noise`) and driving
    (:func:`driving_imu_noise`)."""

    arw: float
    vrw: float
    arw_driving: float
    vrw_driving: float


def estimate_imu_noise(
    sol: PosSolution, clock: DriveClock, window: tuple[float, float]
) -> ImuNoise:
    """The parked and the driving white-noise estimates (:class:`ImuNoise`)."""
    arw, vrw = measured_imu_noise(clock.t_gps, clock.f_b, clock.w_b, window)
    arw_drive, vrw_drive = driving_imu_noise(clock.t_gps, clock.f_b, clock.w_b, sol)
    return ImuNoise(arw, vrw, arw_drive, vrw_drive)


@dataclass(frozen=True, eq=False)
class FixSelection:
    """Where each solution epoch goes (docs/rtklib.md, "Inputs and what is refused"): its
    mission time ``t``; ``in_span`` (inside the IMU data), ``fixed`` (Q = 1), ``withheld`` (in
    an outage); the checked outage ``windows`` and the fixes withheld in each."""

    t: Array
    in_span: NDArray[np.bool_]
    fixed: NDArray[np.bool_]
    withheld: NDArray[np.bool_]
    windows: list[tuple[float, float]]
    per_outage: list[dict[str, Any]]

    @property
    def aid(self) -> NDArray[np.bool_]:
        """The fixes in the GNSS stream: fixed, in the span, not withheld."""
        return self.in_span & self.fixed & ~self.withheld

    @property
    def truth(self) -> NDArray[np.bool_]:
        """The fixes in the truth table: fixed and in the span (withheld ones too)."""
        return self.in_span & self.fixed


def _span(t: Array) -> str:
    return f"{t[0]:.1f} to {t[-1]:.1f} s" if t.size else "nowhere: none"


def select_fixes(
    sol: PosSolution, clock: DriveClock, outages: Sequence[tuple[float, float]]
) -> FixSelection:
    """Check the outage windows (:func:`_check_outages`) and sort the solution epochs: outside
    the IMU span, not fixed, withheld in an outage, or aiding."""
    in_span = (sol.gpst_s > clock.t_gps[0]) & (sol.gpst_s <= clock.t_gps[-1])
    fixed = sol.q == 1
    t_sol = sol.gpst_s - clock.origin
    windows = _check_outages(outages, float(clock.t_imu[-1]))
    withheld = np.zeros(sol.gpst_s.size, dtype=bool)
    per_outage = []
    for a, length in windows:
        w = in_span & fixed & (t_sol > a) & (t_sol <= a + length)
        if not w.any():  # nothing withheld: no drift to score, an outage only in name
            raise RtklibError(
                f"{sol.path.name}: outage {a:g}+{length:g} s holds no fixed solution to "
                f"withhold (fixes in the IMU's time from {_span(t_sol[in_span & fixed])}): "
                "give --outages where the drive has fixes",
                file=sol.path.name,
                field="outages",
            )
        withheld |= w
        per_outage.append({"start_s": a, "length_s": length, "fixes_withheld": int(w.sum())})
    return FixSelection(t_sol, in_span, fixed, withheld, windows, per_outage)


@dataclass(frozen=True, eq=False)
class Drive:
    """Everything an import reads and estimates: the three files, the clock, the start, the
    IMU noise, the fixes' selection, the fixes moved to the IMU point (lat, lon rad, h m) and
    the initial position there (lat, lon rad, h m)."""

    sol: PosSolution
    raw: RawImu
    tag: TimeTag
    clock: DriveClock
    start: DriveStart
    noise: ImuNoise
    fixes: FixSelection
    at_imu: tuple[Array, Array, Array]
    position0: tuple[float, float, float]


def estimate_drive(
    sol: PosSolution,
    raw: RawImu,
    tag: TimeTag,
    settings: DriveSettings,
    time_offset_s: float | None,
    outages: Sequence[tuple[float, float]],
) -> Drive:
    """The clock, the start, the IMU noise and the fixes' selection of the drive; the fixes
    moved to the IMU with the course heading (:func:`_heading_track`, :func:`_move_to_imu`) and
    the initial position interpolated from them at the first IMU sample."""
    clock = estimate_clock(sol, raw, tag, settings, time_offset_s)
    start = estimate_start(sol, raw, clock, settings)
    noise = estimate_imu_noise(sol, clock, start.window)
    fixes = select_fixes(sol, clock, outages)
    lever = np.asarray(ANTENNA_LEVER_ARM_M, dtype=float)
    lat_i, lon_i, h_i = _move_to_imu(sol, _heading_track(sol, start.yaw), lever)
    keep, t0 = fixes.truth, clock.t_gps[0]
    lat0 = float(np.interp(t0, sol.gpst_s[keep], lat_i[keep]))  # parked: no extrapolation
    lon0 = float(np.interp(t0, sol.gpst_s[keep], lon_i[keep]))
    h0 = float(np.interp(t0, sol.gpst_s[keep], h_i[keep]))
    return Drive(sol, raw, tag, clock, start, noise, fixes, (lat_i, lon_i, h_i), (lat0, lon0, h0))


def build_tables(drive: Drive, settings: DriveSettings) -> dict[str, pd.DataFrame]:
    """The ``imu`` (body axes, mission time, the counter), ``gnss`` (the aiding fixes),
    ``truth`` (the fixes in the span moved to the IMU, ``withheld`` marked, the antenna's
    values kept) and, with a constraint σ, ``nhc`` tables (docs/rtklib.md)."""
    sol, clock, sel = drive.sol, drive.clock, drive.fixes
    aid, keep = sel.aid, sel.truth
    lat_i, lon_i, h_i = drive.at_imu
    tables = {
        "imu": pd.DataFrame(
            {
                "t_s": clock.t_imu,
                **{f"gyro_{a}_rad_s": clock.w_b[:, i] for i, a in enumerate("xyz")},
                **{f"accel_{a}_m_s2": clock.f_b[:, i] for i, a in enumerate("xyz")},
                "counter_ms": drive.raw.counter_ms,
            }
        ),
        "gnss": pd.DataFrame(
            {
                "t_s": sel.t[aid],
                "lat_rad": sol.lat_rad[aid],
                "lon_rad": sol.lon_rad[aid],
                "h_m": sol.h_m[aid],
                "ns": sol.ns[aid],
                **{f"sd{c}_m": sol.sd_neu[aid, i] for i, c in enumerate("neu")},
                "pos_line": sol.lines[aid],
            }
        ),
        "truth": pd.DataFrame(
            {
                "t_s": sel.t[keep],
                "lat_rad": lat_i[keep],
                "lon_rad": lon_i[keep],
                "h_m": h_i[keep],
                **{f"v{c}_m_s": sol.v_ned[keep, i] for i, c in enumerate("ned")},
                "withheld": sel.withheld[keep],
                "antenna_lat_rad": sol.lat_rad[keep],
                "antenna_lon_rad": sol.lon_rad[keep],
                "antenna_h_m": sol.h_m[keep],
                "pos_line": sol.lines[keep],
            }
        ),
    }
    if settings.nhc_sigma_m_s is not None:
        # The constraint holds parked and driving alike, so the stream needs no motion
        # detection (and nothing from the withheld fixes).
        t_imu = clock.t_imu
        t_nhc = np.arange(t_imu[0] + 1.0 / NHC_RATE_HZ, t_imu[-1], 1.0 / NHC_RATE_HZ)
        tables["nhc"] = pd.DataFrame(
            {"t_s": t_nhc, "vy_m_s": np.zeros(t_nhc.size), "vz_m_s": np.zeros(t_nhc.size)}
        )
    return tables


def _noise_section(imu_noise: str, noise: ImuNoise) -> dict[str, list[Any]]:
    """``[imu.noise]``: the white noise of the chosen model (``measured``, ``driving`` or
    ``published``; another is a ValueError) and the published bias random walks
    (docs/rtklib.md, "IMU noise")."""
    if imu_noise == "measured":
        section: dict[str, list[Any]] = {
            "arw": [noise.arw / DEG, "deg/sqrt(s)"],
            "vrw": [noise.vrw, "m/s/sqrt(s)"],
        }
    elif imu_noise == "driving":
        section = {
            "arw": [noise.arw_driving / DEG, "deg/sqrt(s)"],
            "vrw": [noise.vrw_driving, "m/s/sqrt(s)"],
        }
    elif imu_noise == "published":
        section = {
            "arw": [PUBLISHED_NOISE["gyro_white_deg_s_rthz"], "deg/s/sqrt(Hz)"],
            "vrw": [PUBLISHED_NOISE["accel_white_ug_rthz"], "ug/sqrt(Hz)"],
        }
    else:
        raise ValueError(f"imu_noise: {imu_noise!r} must be 'measured', 'driving' or 'published'")
    rrw = PUBLISHED_NOISE["gyro_bias_psd_deg_s2_rthz"] * DEG
    section["gyro_bias_rrw"] = [rrw, "rad/s/sqrt(s)"]
    section["accel_bias_arw"] = [
        PUBLISHED_NOISE["accel_bias_psd_ug_rthz"] * 1e-6 * G0,
        "m/s^2/sqrt(s)",
    ]
    return section


def _description(drive: Drive, settings: DriveSettings) -> str:
    """The mission's description: real data, the fixes as truth and aiding, the outages, the
    time offset used and the constraint."""
    return (
        f"RTKLIB drive {drive.sol.path.stem}: real MEMS IMU ({drive.raw.path.name}) and u-blox "
        f"RTK solution ({drive.sol.path.name}); the fixed solution (moved to the IMU) is the "
        f"truth and the aiding, withheld in {len(drive.fixes.windows)} outage window(s); IMU time "
        f"offset {drive.clock.offset:+.3f} s (import.json)"
        + (
            "; a non-holonomic constraint (zero lateral and vertical velocity) aids as a "
            "pseudo-measurement"
            if settings.nhc_sigma_m_s is not None
            else ""
        )
    )


def _sensors_section(drive: Drive, settings: DriveSettings) -> dict[str, Any]:
    """``[sensors]``: the GNSS fixes with the antenna's lever arm and, with a constraint σ, the
    non-holonomic constraint in the vehicle frame turned by the forward-axis angle
    (docs/rtklib.md, "The non-holonomic constraint")."""
    g_period = float(np.median(np.diff(drive.sol.gpst_s)))
    sensors: dict[str, Any] = {
        "gnss": {
            "kind": "gnss",
            "file": "gnss.parquet",
            "sigma": [[float(v) for v in settings.gnss_sigma_m], "m"],
            "rate_hz": round(1.0 / g_period, 6),
            "lever_arm_m": [float(v) for v in ANTENNA_LEVER_ARM_M],
            "use_height": True,
            "use": "aid",
        },
    }
    if settings.nhc_sigma_m_s is not None:
        sensors["nhc"] = {
            "kind": "nhc",
            "file": "nhc.parquet",
            "sigma": [[float(v) for v in settings.nhc_sigma_m_s], "m/s"],
            "rate_hz": NHC_RATE_HZ,
            "mounting_rpy_deg": [0.0, 0.0, math.degrees(drive.start.forward)],
            "use": "aid",
        }
    return sensors


def build_config(drive: Drive, settings: DriveSettings) -> MissionConfig:
    """The mission configuration (docs/rtklib.md): the IMU as rates with the chosen noise
    (:func:`_noise_section`) and the parked gyro bias, the sensors, the parked initial state
    and the truth."""
    start, (lat0, lon0, h0) = drive.start, drive.position0
    noise = _noise_section(settings.imu_noise, drive.noise)
    period = float(np.median(np.diff(drive.clock.t_imu)))
    doc: dict[str, Any] = {
        "mission": {
            "name": f"rtklib-{drive.sol.path.stem}",
            "description": _description(drive, settings),
        },
        "imu": {
            "file": "imu.parquet",
            "format": "rates",
            "rate_hz": round(1.0 / period, 6),
            "noise": noise,
            "initial_bias_sigma": {k: list(v) for k, v in INITIAL_BIAS_SIGMA.items()},
            "initial_bias": {"gyro": [[float(v) for v in start.gyro_bias], "rad/s"]},
        },
        "sensors": _sensors_section(drive, settings),
        "initial": {
            "mode": "state",
            "lat_deg": math.degrees(lat0),
            "lon_deg": math.degrees(lon0),
            "h_m": h0,
            "v_ned_m_s": [0.0, 0.0, 0.0],
            "rpy_deg": [
                math.degrees(start.roll),
                math.degrees(start.pitch),
                math.degrees(start.yaw),
            ],
            "sigma_position_m": INITIAL_SIGMA_POSITION_M,
            "sigma_velocity_m_s": INITIAL_SIGMA_VELOCITY_M_S,
            "sigma_attitude_deg": list(INITIAL_SIGMA_ATTITUDE_DEG),
        },
        "truth": {"file": "truth.parquet"},
    }
    return parse_config(doc, f"RTKLIB drive {drive.sol.path.stem} (import)")


def _clock_record(drive: Drive, settings: DriveSettings) -> dict[str, Any]:
    """import.json's time offset (estimated, published, used) and mounting checks."""
    clock, start = drive.clock, drive.start
    return {
        "imu_time_offset_s": {
            "estimated": clock.offset_estimated,
            "published": PUBLISHED_IMU_TIME_OFFSET_S,
            "used": clock.offset,
            "meaning": "true (GPST) time = tag time + offset",
        },
        "mounting": {
            "rpy_deg_steps": [list(s) for s in settings.mounting_rpy_deg],
            "C_bs": clock.C_bs.tolist(),
            "static_specific_force_body_m_s2": start.f_static.tolist(),
            "forward_axis_angle_deg": math.degrees(start.forward),
            "forward_axis_angle_without_the_last_yaw_deg": math.degrees(
                start.forward_without_last_yaw
            ),
        },
    }


def _start_record(drive: Drive, imu_noise: str) -> dict[str, Any]:
    """import.json's static window, initial state and IMU noise estimates."""
    start, noise, origin = drive.start, drive.noise, drive.clock.origin
    lat0, _, h0 = drive.position0
    excess = float(np.linalg.norm(start.f_static)) - float(earth.gravity(lat0, h0))
    return {
        "static_window_s": [start.window[0] - origin, start.window[1] - origin],
        "initial": {
            "rpy_deg": [
                math.degrees(start.roll),
                math.degrees(start.pitch),
                math.degrees(start.yaw),
            ],
            "gyro_bias_deg_s": np.degrees(start.gyro_bias).tolist(),
            "static_specific_force_magnitude_minus_g_mg": excess / (1e-3 * G0),
            **{f"heading_{k}": v for k, v in start.heading_info.items()},
        },
        "imu_noise": {
            "used": imu_noise,
            "measured_arw_deg_sqrt_s": noise.arw / DEG,
            "measured_vrw_m_s_sqrt_s": noise.vrw,
            "driving_arw_deg_sqrt_s": noise.arw_driving / DEG,
            "driving_vrw_m_s_sqrt_s": noise.vrw_driving,
            "published": PUBLISHED_NOISE,
        },
    }


def _fixes_record(drive: Drive, settings: DriveSettings) -> dict[str, Any]:
    """import.json's GNSS counts (used and left out by reason), outages and constraint."""
    sol, sel, sigma_nhc = drive.sol, drive.fixes, settings.nhc_sigma_m_s
    return {
        "gnss": {
            "sigma_m": settings.gnss_sigma_m.tolist(),
            "epochs": int(sol.gpst_s.size),
            "used": int(sel.aid.sum()),
            "left_out": {
                "outside the IMU span": int((~sel.in_span).sum()),
                "not fixed (Q != 1)": int((sel.in_span & ~sel.fixed).sum()),
                "withheld in an outage": int(sel.withheld.sum()),
            },
            "first_fixed_line": int(sol.lines[int(np.argmax(sel.truth))]),
            "wrong_fix_lines": [r.line for r in sol.repairs if r.action == WRONG_FIX],
        },
        "outages": sel.per_outage,
        "nhc": None
        if sigma_nhc is None
        else {
            "sigma_m_s": sigma_nhc.tolist(),
            "rate_hz": NHC_RATE_HZ,
            "vehicle_yaw_from_body_deg": math.degrees(drive.start.forward),
            "lever_arm_m": [0.0, 0.0, 0.0],
            "meaning": "pseudo-measurement: zero lateral and vertical vehicle-frame velocity at "
            "the IMU point (semi-synthetic: a model of the car, not a sensor)",
        },
    }


def build_import_record(
    drive: Drive, settings: DriveSettings, written: MissionConfig
) -> dict[str, Any]:
    """import.json (docs/rtklib.md): the source files' SHA-256, the GPST origin of mission
    time, every estimate and check (:func:`_clock_record`, :func:`_start_record`), the fixes
    used and left out (:func:`_fixes_record`), the truth's origin, the corrections, the repairs
    and the tables written."""
    sol, raw, origin = drive.sol, drive.raw, drive.clock.origin
    steps = [list(s) for s in settings.mounting_rpy_deg]
    return {
        "importer": "adaptnav.importers.rtklib",
        "source": {p.name: _sha256(p) for p in (sol.path, raw.path, drive.tag.path)},
        "gpst_origin_s": origin,
        "gpst_origin": dt.datetime.fromtimestamp(origin, dt.UTC).isoformat() + " GPST",
        **_clock_record(drive, settings),
        **_start_record(drive, settings.imu_noise),
        **_fixes_record(drive, settings),
        "truth": "fixed solutions (Q = 1) in the IMU span, moved to the IMU point with the "
        "course heading; velocity from the solution; no attitude",
        "pos_velocity_lag_s": sol.velocity_lag_s,
        "corrections": [
            *(
                [f"velocity columns moved back by their lag {sol.velocity_lag_s:.3f} s"]
                if sol.velocity_lag_s is not None
                else []
            ),
            "IMU time: counter mapped linearly onto the tag's [start, start + last tick]",
            f"IMU time offset {drive.clock.offset:+.4f} s",
            f"mounting: roll/pitch/yaw steps {steps} deg",
            "units: g × 9.80665 → m/s², deg/s → rad/s",
            f"antenna lever arm {list(ANTENNA_LEVER_ARM_M)} m FRD from the IMU",
        ],
        "repairs": [r.__dict__ for r in (*sol.repairs, *raw.repairs)],
        "mission_files": {
            "imu": written.imu.file,
            **{k: s.file for k, s in written.sensors.items()},
            "truth": written.truth.file,
        },
    }


def import_drive(
    pos_path: str | Path,
    imu_path: str | Path,
    out_dir: str | Path,
    *,
    tag_path: str | Path | None = None,
    outages: Sequence[tuple[float, float]] = DEFAULT_OUTAGES_S,
    time_offset_s: float | None = None,
    mounting_rpy_deg: Sequence[Sequence[float]] = PUBLISHED_MOUNTING_RPY_DEG,
    imu_noise: Literal["measured", "driving", "published"] = "measured",
    gnss_sigma_m: Sequence[float] = GNSS_SIGMA_M,
    nhc_sigma_m_s: Sequence[float] | None = NHC_SIGMA_M_S,
    fmt: Literal["parquet", "csv"] = "parquet",
) -> Path:
    """Import an RTKLIB drive as a mission folder ``out_dir``.

    Args:
        pos_path, imu_path: the ``.pos`` solution and the raw IMU CSV; ``tag_path`` the IMU's
            time tag (default ``imu_path`` + ``.tag``).
        outages: (start, length) windows in s from the first IMU sample in which the fixes
            are withheld from the GNSS stream (kept in the truth); ``()`` for none.
        time_offset_s: the IMU time offset δ; None (default) estimates it
            (:func:`estimate_imu_time_offset`); the published value is
            :data:`PUBLISHED_IMU_TIME_OFFSET_S`.
        mounting_rpy_deg: the sensor-to-body steps (:func:`mounting_dcm`).
        imu_noise: ``measured`` (Allan deviation at 1 s parked, :func:`measured_imu_noise`),
            ``driving`` (the vibration while driving taken as white, :func:`driving_imu_noise`)
            or ``published`` (the data README's white-noise densities).
        gnss_sigma_m: σ (N, E, D) of the RTK fixes.
        nhc_sigma_m_s: σ (lateral, vertical) of a non-holonomic constraint stream
            (:mod:`adaptnav.sensors.nhc`, zeros at ``NHC_RATE_HZ`` over the whole drive, in the
            vehicle frame turned by the measured forward-axis angle); None: no constraint.

    Mission time ``t_s`` is GPST minus the IMU's first (offset-corrected) sample time, which is
    recorded in import.json with every estimate, check, correction, left-out reading and
    repair. Returns ``out_dir``.

    The steps: :func:`read_pos`, :func:`read_imu_csv`, :func:`read_time_tag`,
    :func:`check_settings`, :func:`estimate_drive` (:func:`estimate_clock`,
    :func:`estimate_start`, :func:`estimate_imu_noise`, :func:`select_fixes`),
    :func:`build_config`, :func:`build_tables` and :func:`build_import_record`.
    """
    if time_offset_s is not None and not abs(time_offset_s) <= MAX_TIME_OFFSET_S:
        raise RtklibError(
            f"--time-offset-s: {time_offset_s!r} is not a number within ±{MAX_TIME_OFFSET_S:g} "
            "s (the IMU's lag behind its time tag is a fraction of a second)",
            field="time_offset_s",
        )
    imu_p = Path(imu_path)
    tag_p = Path(tag_path) if tag_path is not None else imu_p.with_name(imu_p.name + ".tag")
    sol = read_pos(pos_path)
    raw = read_imu_csv(imu_p)
    tag = read_time_tag(tag_p)
    settings = check_settings(gnss_sigma_m, nhc_sigma_m_s, imu_noise, mounting_rpy_deg)
    drive = estimate_drive(sol, raw, tag, settings, time_offset_s, outages)
    config = build_config(drive, settings)
    root = Path(out_dir)
    written = write_mission(root, config, build_tables(drive, settings), fmt=fmt)
    meta = build_import_record(drive, settings, written)
    (root / "import.json").write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n",
                                      encoding="utf-8")  # fmt: skip
    aid, withheld = drive.fixes.aid, drive.fixes.withheld
    log.info(
        "RTKLIB drive %s -> %s: IMU time offset %+.3f s (published %+.3f), heading %.1f deg, "
        "%d of %d fixes aiding, %d withheld",
        sol.path.stem, root, drive.clock.offset, PUBLISHED_IMU_TIME_OFFSET_S,
        math.degrees(drive.start.yaw), int(aid.sum()), int(sol.gpst_s.size), int(withheld.sum()),
    )  # fmt: skip
    return root
