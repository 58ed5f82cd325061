"""Importer of NMEA 0183 logs: GGA fixes and HDT/THS/HDG/HDM headings as GNSS and heading tables
(docs/nmea.md).

A log is text, one sentence a line (``$GPGGA,...*47``). Each line is framed and its checksum
checked by ``pynmea2.parse(line, check=True)``; the fields are then read here, one by one, so
that a bad field is a repair naming the file, line and field, never an exception:

* **GGA** (UTC time of day, position, fix quality, satellites, HDOP, altitude above the geoid
  and the geoid separation): the GNSS fixes, ``h = altitude + separation`` (ellipsoidal);
* **HDT** (true heading) and **THS** (true heading and mode, IEC 61162-1; pynmea2 does not know
  it, so its fields are split here after pynmea2's checksum check): the heading readings,
  THS of mode A only (E, dead reckoning, M, S are not measurements, V is void). A talker
  that sends both gives its THS where both have one time (those HDT are counted as ignored)
  and its HDT at the other times;
* **HDG** (a magnetic compass's sensor heading, deviation and variation, E positive): the
  heading readings only when the heading source sends no HDT or THS; true = sensor +
  deviation + variation. Without variation the true heading cannot be formed: refused, unless
  ``declination_deg`` (``--declination-deg``) is given, and then the table keeps the magnetic
  headings and the heading section gets ``declination_deg`` (docs/data-format.md, 'Magnetic
  headings'), which turns them at load; **HDM** (the magnetic heading alone) as an HDG
  without deviation and variation. Headings carry no time: they take the time of the last
  timed sentence (GGA, RMC or ZDA) before them in the same file;
* **RMC** (time, status, speed and course over ground, date) and **ZDA** (time and date): the
  UTC date, and with **VTG** (course and speed, no time: as HDT) the speed and course over
  ground, of one receiver (the GGA's talker choice, :data:`CHOOSER`). The project's GNSS kind
  measures position only, so these go to an extra table beside the mission that the filter
  does not read (``<gnss>_velocity``).

Time (docs/nmea.md, "Time"): UTC = date + time of day; the date comes from the RMC/ZDA
sentences (or ``date=`` when the log has none); the time of day going back by more than 12 h
is the day rolling over at midnight. Mission time is ``t_s = UTC - t0``.

σ model (docs/nmea.md, "σ model"): per fix, from its quality and HDOP,
``σ_N = σ_E = HDOP × UERE / √2`` (HDOP × UERE is the horizontal DRMS),
``σ_D = VDOP_PER_HDOP × HDOP × UERE``; fixed σ for RTK fixed and float fixes. The mission format
has one σ per sensor: the section gets the median of the used fixes' σ, and the per-fix σ are
kept as extra columns.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import itertools
import json
import logging
import math
import re
import shutil
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
import pynmea2

from adaptnav.mission.config import (
    MissionConfig,
    MissionError,
    dumps_toml,
    load_config,
    parse_config,
    parse_sensor,
    sensor_name_problem,
)
from adaptnav.mission.loader import CONFIG_NAME, OutsideImuSpanError, load_mission
from adaptnav.mission.tables import Journal, Repair, write_table

log = logging.getLogger("adaptnav.importers.nmea")

__all__ = [
    "KNOTS_M_S",
    "RTK_FIXED_SIGMA_M",
    "RTK_FLOAT_SIGMA_M",
    "UERE_M",
    "VDOP_PER_HDOP",
    "NmeaError",
    "NmeaLog",
    "Options",
    "fix_sigma",
    "import_nmea",
    "read_nmea",
]

KNOTS_M_S = 1852.0 / 3600.0
"""One knot in m/s."""
UERE_M = 3.0
"""Default σ of the user-equivalent range error of a standalone (SPS) fix (m); an assumption
for a single-frequency receiver in open sky; ``uere_m=`` (``--uere-m``) sets it."""
DGNSS_UERE_M = 1.0
"""σ of the range error of a differential (DGPS, SBAS) fix (m); assumed."""
VDOP_PER_HDOP = 1.5
"""VDOP / HDOP assumed for the vertical σ (GGA gives no VDOP; about 1.3-2 in open sky, where
there are no satellites below the horizon to fix the height)."""
RTK_FIXED_SIGMA_M = (0.02, 0.02, 0.04)
"""σ (N, E, D) of an RTK fixed fix (m): a few times the receiver's centimetre-level internal
σ, for multipath and the antenna's phase centre (as docs/rtklib.md)."""
RTK_FLOAT_SIGMA_M = (0.5, 0.5, 1.0)
"""σ (N, E, D) of an RTK float fix (m): decimetres to a metre while the ambiguities converge;
assumed."""
ASSUMED_HDOP = 2.0
"""HDOP taken for a fix whose HDOP field is empty or not positive (recorded as a repair)."""
HEADING_SIGMA_DEG = 0.5
"""Default σ of a true heading (HDT, THS) (deg) when neither the options nor the mission give
one; an assumption (a gyrocompass, a GNSS compass): use the device's datasheet."""
COMPASS_SIGMA_DEG = 2.0
"""Default σ of an HDG heading (deg), as :data:`HEADING_SIGMA_DEG`: a magnetic compass is good to
1-2° once calibrated, and its deviation, which changes with the heading and the ship's
magnetism, is not modelled (a gyro's 0.5° would make the filter trust it too much); an
assumption: use the datasheet."""
QUALITY_NAMES = {
    1: "GPS (SPS)", 2: "DGPS", 3: "PPS", 4: "RTK fixed", 5: "RTK float", 6: "dead reckoning",
    7: "manual input", 8: "simulator", 9: "SBAS",
}  # fmt: skip
"""GGA fix quality indicator (NMEA 0183 v4.x; 9 as u-blox and others output SBAS)."""
NOT_MEASURED = frozenset({6, 7, 8})
"""Qualities that are not measurements (an extrapolation, a typed-in or simulated position)."""
TALKERS = frozenset({"GP", "GL", "GA", "GB", "BD", "GQ", "GI", "GN", "HE", "HC", "IN", "II"})
"""Talkers accepted for the sentences used: GNSS constellations and combined (GN), north-seeking
gyro (HE), magnetic compass (HC), integrated navigation (IN) and instrumentation (II)."""
TRUE_HEADING = ("HDT", "THS")
"""Sentences of a heading against true north: HDT, and THS, its IEC 61162-1 successor with a
mode (gyrocompasses and GNSS compasses since about 2010 send it, often beside HDT)."""
MAGNETIC_HEADING = ("HDG", "HDM")
"""Sentences of a magnetic compass: HDG (sensor heading, deviation, variation) and HDM (the
magnetic heading alone, an older sentence; as an HDG without deviation and variation)."""
HEADING_KINDS = (*TRUE_HEADING, *MAGNETIC_HEADING)
"""The sentences that give the heading table: HDG and HDM (a magnetic compass) only when the
heading source sends no true heading (:func:`_heading_sentences`)."""
THS_MODES = {"A": "autonomous", "E": "estimated (dead reckoning)", "M": "manual input",
             "S": "simulator", "V": "data not valid"}  # fmt: skip
"""THS mode indicator (IEC 61162-1). Only A is a measurement (docs/nmea.md, 'THS')."""
USED = ("GGA", "RMC", "VTG", "HDT", "THS", "HDG", "HDM", "ZDA")
TIMED = frozenset({"GGA", "RMC", "ZDA"})
HALF_DAY_S = 43200.0
DAY_S = 86400.0
MAX_DISTINCT_PROBLEMS = 3
"""Problems quoted in the message of a file with no usable sentence."""


class NmeaError(MissionError):
    """An NMEA log that cannot be imported (no usable sentence, no date, a bad option): a
    :class:`~adaptnav.mission.MissionError` naming the file."""


class _LineError(Exception):
    """A sentence that is not used: the field and the reason, for the repair log."""

    def __init__(self, fld: str, action: str, detail: str = "") -> None:
        super().__init__(action)
        self.field, self.action, self.detail = fld, action, detail


@dataclass(frozen=True)
class _Record:
    """What one sentence says: its type, where it is, its UTC time of day (None: untimed),
    its date (RMC, ZDA) and values; ``unused`` is why a timed sentence gives no reading (its
    time still counts, e.g. a GGA of fix quality 0); ``talker`` its talker (GP, HE ...)."""

    kind: str
    file: int
    line: int
    tod_s: float | None
    date: dt.date | None = None
    values: Mapping[str, float] = field(default_factory=dict)
    unused: tuple[str, str, str] | None = None
    talker: str = ""


# --- fields -------------------------------------------------------------------------------------


def _field(msg: pynmea2.TalkerSentence, name: str) -> str:
    """The raw text of field ``name``; a sentence cut short before it is a :class:`_LineError`."""
    idx = msg.name_to_idx[name]
    if idx >= len(msg.data):
        raise _LineError(name, "sentence cut short", f"{len(msg.data)} fields, no {name}")
    return str(msg.data[idx]).strip()


def _required(msg: pynmea2.TalkerSentence, name: str) -> str:
    text = _field(msg, name)
    if not text:
        raise _LineError(name, "empty field", f"{msg.sentence_type} without {name}")
    return text


_NMEA_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")
"""A number as NMEA 0183 writes one: digits, a point, a sign; no exponent, no ``inf``, no
``1_000`` (all of which Python's ``float`` would take)."""


def _number(
    msg: pynmea2.TalkerSentence,
    name: str,
    *,
    optional: bool = False,
    low: float = -math.inf,
    high: float = math.inf,
) -> float:
    """A number in ``[low, high]``; an empty optional field is NaN."""
    text = _field(msg, name) if optional else _required(msg, name)
    if not text:
        return math.nan
    if not _NMEA_NUMBER.fullmatch(text):
        raise _LineError(name, "bad field", f"{name} = {text!r} is not a number")
    value = float(text)
    if not low <= value <= high:
        raise _LineError(name, "bad field", f"{name} = {text!r} outside [{low:g}, {high:g}]")
    return value


def _metres(msg: pynmea2.TalkerSentence, name: str) -> None:
    """A GGA's height unit must be M (metres): a receiver set to feet says F."""
    idx = msg.name_to_idx[name]
    unit = str(msg.data[idx]).strip().upper() if idx < len(msg.data) else ""
    if unit not in ("M", ""):
        raise _LineError(name, "bad field", f"{name} = {unit!r}: heights in metres (M) only")


def _time_of_day(msg: pynmea2.TalkerSentence) -> float:
    """``hhmmss(.ss)`` → seconds of the UTC day (a leap second 60 allowed)."""
    text = _required(msg, "timestamp")
    head, _, frac = text.partition(".")
    if len(head) != 6 or not head.isdigit() or not (frac == "" or frac.isdigit()):
        raise _LineError("timestamp", "bad field", f"time {text!r} is not hhmmss.ss")
    h, m, s = int(head[:2]), int(head[2:4]), float(head[4:] + "." + (frac or "0"))
    if h > 23 or m > 59 or s >= 61.0:
        raise _LineError("timestamp", "bad field", f"time {text!r} out of range")
    return 3600.0 * h + 60.0 * m + s


def _angle(msg: pynmea2.TalkerSentence, name: str, hemispheres: str, limit: float) -> float:
    """``(d)ddmm.mmmm`` with its hemisphere letter → signed degrees; minutes < 60."""
    text, hemi = _required(msg, name), _required(msg, name + "_dir").upper()
    head, _, frac = text.partition(".")
    if len(head) < 3 or not head.isdigit() or not (frac == "" or frac.isdigit()):
        raise _LineError(name, "bad field", f"{name} = {text!r} is not (d)ddmm.mmmm")
    minutes = float(head[-2:] + "." + (frac or "0"))
    deg = int(head[:-2]) + minutes / 60.0
    if minutes >= 60.0 or deg > limit or hemi not in hemispheres:
        raise _LineError(name, "bad field", f"{name} = {text!r} {hemi!r} out of range")
    return -deg if hemi == hemispheres[1] else deg


def _day(year: int, month: int, day: int, fld: str, text: str) -> dt.date:
    try:
        return dt.date(year, month, day)
    except ValueError:
        raise _LineError(fld, "bad field", f"date {text!r} is not a calendar date") from None


# --- sentences ----------------------------------------------------------------------------------


def _gga(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """A GGA fix; a quality that is not a measurement keeps the time only (``unused``)."""
    tod = _time_of_day(msg)
    q_text = _required(msg, "gps_qual")
    if not q_text.isdigit():
        raise _LineError("gps_qual", "bad field", f"fix quality {q_text!r} is not a number")
    quality = int(q_text)
    if quality == 0:
        return _Record("GGA", *where, tod, unused=("gps_qual", "fix invalid", "quality 0"))
    if quality in NOT_MEASURED or quality not in QUALITY_NAMES:
        name = QUALITY_NAMES.get(quality, "unknown")
        why = ("gps_qual", "not a measurement", f"quality {quality} ({name})")
        return _Record("GGA", *where, tod, unused=why)
    alt, sep = _number(msg, "altitude"), _number(msg, "geo_sep", optional=True)
    _metres(msg, "altitude_units")
    _metres(msg, "geo_sep_units")
    n_sats = _number(msg, "num_sats", optional=True, low=0.0)
    if not (math.isnan(n_sats) or n_sats.is_integer()):
        raise _LineError("num_sats", "bad field", f"num_sats = {n_sats} is not a count")
    values = {
        "lat_deg": _angle(msg, "lat", "NS", 90.0),
        "lon_deg": _angle(msg, "lon", "EW", 180.0),
        "h_m": alt + (0.0 if math.isnan(sep) else sep),
        "geoid_separation_m": sep,
        "quality": float(quality),
        "hdop": _number(msg, "horizontal_dil", optional=True, low=0.0),
        "n_sats": n_sats,
    }
    return _Record("GGA", *where, tod, values=values)


def _rmc(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """An RMC: time, date, speed and course; status V (void) is not used at all."""
    status = _field(msg, "status").upper()
    if status != "A":
        raise _LineError("status", "void", f"RMC status {status!r}, not A (valid)")
    tod = _time_of_day(msg)
    text = _required(msg, "datestamp")
    if len(text) != 6 or not text.isdigit():
        raise _LineError("datestamp", "bad field", f"date {text!r} is not ddmmyy")
    yy = int(text[4:])
    date = _day(2000 + yy if yy < 80 else 1900 + yy, int(text[2:4]), int(text[:2]), "datestamp",
                text)  # fmt: skip
    values = {
        "sog_m_s": _number(msg, "spd_over_grnd", low=0.0) * KNOTS_M_S,
        "cog_deg": _number(msg, "true_course", optional=True, low=0.0, high=360.0),
    }
    return _Record("RMC", *where, tod, date, values)


def _vtg(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """A VTG: speed (km/h field, else knots) and true course (empty when slow)."""
    kmph = _number(msg, "spd_over_grnd_kmph", optional=True, low=0.0)
    speed = (
        kmph / 3.6
        if math.isfinite(kmph)
        else _number(msg, "spd_over_grnd_kts", low=0.0) * KNOTS_M_S
    )
    course = _number(msg, "true_track", optional=True, low=0.0, high=360.0)
    values = {"sog_m_s": speed, "cog_deg": course}
    return _Record("VTG", *where, None, values=values)


def _hdt(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """An HDT true heading in [0, 360] deg."""
    heading = _number(msg, "heading")
    if _field(msg, "hdg_true").upper() != "T":
        raise _LineError("hdg_true", "bad field", "HDT heading not marked T (true)")
    if not 0.0 <= heading <= 360.0:
        raise _LineError("heading", "bad field", f"heading {heading} outside [0, 360] deg")
    return _Record("HDT", *where, None, values={"heading_deg": heading})


def _ths(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """A THS true heading (IEC 61162-1 ``$--THS,x.x,a``) of mode A (autonomous). E (estimated:
    e.g. a GNSS compass that lost its baseline, coasting on its backup gyro) is an
    extrapolation, as GGA's dead reckoning, whose error grows while the filter's own gyros
    already propagate the yaw: not a measurement, as M (typed in) and S (simulated); V is
    void. Those keep their record, unused: the talker sends THS, so its HDT are copies
    (:func:`_heading_sentences`), and an HDT must not stand in for a THS that says V."""
    mode = _required(msg, "mode").upper()
    if mode not in THS_MODES:
        raise _LineError("mode", "bad field", f"THS mode {mode!r} is not one of A, E, M, S, V")
    if mode != "A":
        action = "void" if mode == "V" else "not a measurement"
        why = ("mode", action, f"THS mode {mode} ({THS_MODES[mode]})")
        return _Record("THS", *where, None, unused=why)
    heading = _number(msg, "heading", low=0.0, high=360.0)
    return _Record("THS", *where, None, values={"heading_deg": heading})


def _signed(msg: pynmea2.TalkerSentence, name: str, side: str) -> float:
    """An HDG deviation or variation: degrees in [0, 180] with ``E`` (+) or ``W`` (-) in field
    ``side``; empty: NaN."""
    value = _number(msg, name, optional=True, low=0.0, high=180.0)
    if math.isnan(value):
        return value
    letter = _field(msg, side).upper()
    if letter not in ("E", "W"):
        raise _LineError(side, "bad field", f"{name} {value:g} with {side} {letter!r}, not E or W")
    return value if letter == "E" else -value


def _hdg(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """An HDG (``$--HDG,heading,dev,E/W,var,E/W``): a magnetic compass's sensor heading, its
    deviation and the variation (declination), each E positive. Sensor heading + deviation is
    the magnetic heading, + variation the true one (NMEA 0183; docs/nmea.md, 'HDG'). Gives
    the magnetic heading in [0, 360) and the variation (NaN when empty: :func:`_true_north`
    decides); an empty deviation is 0 (none given: a compass compensated, or not told its
    deviation table)."""
    sensor = _number(msg, "heading", low=0.0, high=360.0)
    deviation = _signed(msg, "deviation", "dev_dir")
    variation = _signed(msg, "variation", "var_dir")
    magnetic = (sensor + (0.0 if math.isnan(deviation) else deviation)) % 360.0
    return _Record("HDG", *where, None,
                   values={"heading_deg": magnetic, "variation_deg": variation})  # fmt: skip


def _hdm(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """An HDM (``$--HDM,heading,M``): a magnetic heading in [0, 360) with no variation, so
    true north needs ``--declination-deg`` (:func:`_true_north`); up to 0.4.7 ignored."""
    if _field(msg, "magnetic").upper() != "M":
        raise _LineError("magnetic", "bad field", "HDM heading not marked M (magnetic)")
    heading = _number(msg, "heading", low=0.0, high=360.0) % 360.0
    return _Record("HDM", *where, None, values={"heading_deg": heading, "variation_deg": math.nan})


def _zda(msg: pynmea2.TalkerSentence, where: tuple[int, int]) -> _Record:
    """A ZDA: UTC time and date."""
    tod = _time_of_day(msg)
    parts = [_required(msg, k) for k in ("year", "month", "day")]
    if not all(p.isdigit() for p in parts):
        raise _LineError("day", "bad field", f"date {'-'.join(parts)!r} is not numeric")
    if len(parts[0]) != 4:  # ZDA's year has four digits; "24" is not 2024 to this reader
        raise _LineError("year", "bad field", f"year {parts[0]!r} is not four digits")
    date = _day(int(parts[0]), int(parts[1]), int(parts[2]), "day", "-".join(parts))
    return _Record("ZDA", *where, tod, date)


_READERS = {"GGA": _gga, "RMC": _rmc, "VTG": _vtg, "HDT": _hdt, "THS": _ths, "HDG": _hdg,
            "HDM": _hdm, "ZDA": _zda}  # fmt: skip
OWN_FIELDS = {"THS": ("heading", "mode")}
"""Sentences pynmea2 (1.19) does not know, and their fields: framed and checksum-checked by
``pynmea2.parse``, then split here (:class:`_Own`)."""


@dataclass(frozen=True)
class _Own:
    """A talker sentence of :data:`OWN_FIELDS`, with the attributes of a
    ``pynmea2.TalkerSentence`` that :func:`_field` reads (``data``, ``name_to_idx``)."""

    talker: str
    sentence_type: str
    data: list[str]

    @property
    def name_to_idx(self) -> dict[str, int]:
        return {name: i for i, name in enumerate(OWN_FIELDS[self.sentence_type])}


def _own(text: str) -> _Own | None:
    """``text`` (its checksum already checked) as an :class:`_Own` sentence, None if it is not
    of :data:`OWN_FIELDS`. Split as pynmea2 splits: the fields between the address and ``*``."""
    address, *data = text[1:].partition("*")[0].split(",")
    address = address.upper()  # pynmea2 takes lower-case addresses too
    if len(address) != 5 or address[2:] not in OWN_FIELDS:
        return None
    return _Own(address[:2], address[2:], data)


def _message(exc: ValueError) -> str:
    """The message of a pynmea2 error (its first argument is a (message, data) pair)."""
    first = exc.args[0] if exc.args else ""
    return str(first[0] if isinstance(first, tuple) and first else first)


def _sentence(text: str) -> pynmea2.NMEASentence | _Own | str:
    """The framed, checksum-checked sentence, or the name of an ignored kind of line."""
    if text.startswith("!"):
        return "encapsulated (!)"
    if not text.startswith("$"):
        raise _LineError("(line)", "not an NMEA sentence", f"does not start with $: {text[:20]!r}")
    try:
        msg = pynmea2.parse(text, check=True)
    except pynmea2.ChecksumError as exc:
        message = _message(exc)
        if "missing" in message:
            raise _LineError("(checksum)", "no checksum", "no *hh at the end: truncated?") from None
        given, _, computed = message.rpartition(": ")[2].partition(" != ")
        raise _LineError(
            "(checksum)", "checksum mismatch", f"*{given} given, *{computed} computed"
        ) from None
    except pynmea2.SentenceTypeError:
        # raised after the checksum check: a sentence pynmea2 does not know may be ours
        own = _own(text)
        if own is None:
            address = text.split(",", 1)[0][:12]
            raise _LineError("(type)", "unknown sentence type", address) from None
        return own
    except (pynmea2.ParseError, ValueError) as exc:
        raise _LineError("(line)", "not an NMEA sentence", _message(exc)[:60]) from None
    if not isinstance(msg, pynmea2.TalkerSentence):
        return "proprietary" if isinstance(msg, pynmea2.ProprietarySentence) else "query"
    if msg.sentence_type in OWN_FIELDS:  # a later pynmea2 that knows it: our field names still
        return _Own(msg.talker, msg.sentence_type, [str(d) for d in msg.data])
    return msg


def _record(text: str, where: tuple[int, int], ignored: Counter[str]) -> _Record | None:
    """The record of one line; None for a sentence that is read but not used (counted in
    ``ignored``); a :class:`_LineError` for a line that goes to the repair log."""
    msg = _sentence(text)
    if isinstance(msg, str):
        ignored[msg] += 1
        return None
    if msg.sentence_type not in _READERS:
        ignored[msg.sentence_type] += 1
        return None
    if msg.talker not in TALKERS:
        raise _LineError("(talker)", "unknown talker", f"{msg.talker}{msg.sentence_type}")
    try:
        return replace(_READERS[msg.sentence_type](msg, where), talker=msg.talker)
    except _LineError as bad:
        if msg.sentence_type not in TIMED or bad.field in ("timestamp", "status"):
            raise
        # A field other than the time is bad: the sentence gives no reading, but its time
        # still counts, for the HDT and VTG after it (up to 0.4.4 they took an older one).
        unused = (bad.field, bad.action, bad.detail)
        tod = _time_of_day(msg)
        return _Record(msg.sentence_type, *where, tod, unused=unused, talker=msg.talker)


TALKER_OPTIONS = {"GGA": "--gnss-talker", "HDT": "--heading-talker"}
"""The talker choices (keys of ``talkers``) and their options: ``"GGA"`` chooses the GNSS
receiver (its GGA, RMC and VTG), ``"HDT"`` the heading source (every heading sentence)."""
SOURCE_KINDS = {"GGA": ("GGA",), "HDT": HEADING_KINDS, "RMC": ("RMC",), "VTG": ("VTG",)}
"""The sentences of each source, each of one talker: the fixes, the headings, and the speed and
course over ground of the RMC and of the VTG (the velocity table). The RMC and the VTG are two
sources, each its own series in the table (its ``sentence`` column): one receiver may send them
under two talkers (``GNRMC`` beside ``GPVTG``), which is not two receivers."""
CHOOSER = {"GGA": "GGA", "HDT": "HDT", "RMC": "GGA", "VTG": "GGA"}
"""The key of :data:`TALKER_OPTIONS` that chooses each source's talker: the velocity is the
receiver's, chosen with its fixes by ``--gnss-talker`` (up to 0.4.8 the RMC and VTG of every
talker were read, and two receivers' rows interleaved in the velocity table)."""


def _source(kind: str) -> str | None:
    """The key of :data:`SOURCE_KINDS` whose source sentence ``kind`` is; None: no source."""
    return next((k for k, kinds in SOURCE_KINDS.items() if kind in kinds), None)


def _checked_talkers(talkers: Mapping[str, str]) -> dict[str, str]:
    """``talkers`` upper-cased; a sentence not in :data:`TALKER_OPTIONS` or a talker not in
    :data:`TALKERS` is an :class:`NmeaError`."""
    out = {k.upper(): v.upper() for k, v in talkers.items()}
    for kind, talker in out.items():
        if kind not in TALKER_OPTIONS or talker not in TALKERS:
            option = TALKER_OPTIONS.get(kind, f"talkers[{kind!r}]")
            raise NmeaError(f"{option} {talker!r}: one of {', '.join(sorted(TALKERS))}",
                            field=option.removeprefix("--"))  # fmt: skip
    return out


def _heading_sentences(
    records: Sequence[_Record], chosen: str | None, ignored: Counter[str]
) -> list[_Record]:
    """The records without the magnetic headings that a true one stands for, counted in
    ``ignored``: HDG and HDM when the heading source sends a true heading (HDT, THS: a gyro
    beside a magnetic compass, or a gyro's own HDG; the true heading is read, as before
    0.4.8). ``chosen``: the ``--heading-talker``, whose sentences decide (None: all
    talkers'). An HDT beside its talker's THS is left to :func:`_ths_preferred`, once the
    sentences have their times."""
    mine = [r for r in records if r.kind in HEADING_KINDS and chosen in (None, r.talker)]
    true = any(r.kind in TRUE_HEADING for r in mine)
    out = []
    for r in records:
        if r.kind in MAGNETIC_HEADING and true:
            ignored[f"{r.kind} (a true heading, HDT or THS, is read)"] += 1
        else:
            out.append(r)
    return out


HDT_BESIDE_THS = "HDT (its talker's THS at that time is read)"
"""The ``sentences_ignored`` key of an HDT that a THS of its talker at its time stands for."""


def _ths_preferred(
    stamped: Sequence[tuple[_Record, float]], ignored: Counter[str]
) -> list[tuple[_Record, float]]:
    """The stamped records without the HDT that a THS of the same talker at the same time
    stands for (a gyro sends both, HDT for older listeners), counted in ``ignored``
    (:data:`HDT_BESIDE_THS`): the THS gives the same heading and a mode that says whether it
    is valid (an HDT beside a THS of mode V or E is not a measurement either). An HDT at a time
    with no THS of its talker is kept: a talker sending HDT at a higher rate than THS gives
    every heading once. Up to 0.4.8 every HDT of a talker that sent any THS was ignored, and
    the headings between its THS were lost. An HDT of another talker than the
    ``--heading-talker`` (unused) is left to the repair log."""
    ths = {(r.talker, t) for r, t in stamped if r.kind == "THS"}
    out = []
    for r, t in stamped:
        if r.kind == "HDT" and r.unused is None and (r.talker, t) in ths:
            ignored[HDT_BESIDE_THS] += 1
        else:
            out.append((r, t))
    return out


def _talker_spans(records: Sequence[_Record], kinds: Sequence[str]) -> dict[str, tuple[int, int]]:
    """Per talker, the positions in the stream of its first and last sentence of ``kinds``."""
    spans: dict[str, tuple[int, int]] = {}
    for i, r in enumerate(records):
        if r.kind in kinds:
            spans[r.talker] = (spans.get(r.talker, (i, i))[0], i)
    return spans


def _interleaved(records: Sequence[_Record], key: str, names: Sequence[str]) -> None:
    """An :class:`NmeaError` if the sentences of source ``key`` (:data:`SOURCE_KINDS`) of two
    talkers interleave in the stream: two sources (two receivers, a GNSS compass beside a
    gyro) whose readings would alternate in one table (up to 0.4.7: fixes of two antennas
    20 m apart, 0.5 s apart, read as one track; up to 0.4.8 two receivers' speeds and courses
    in the velocity table). A talker that follows another (a receiver that switched from GP
    to GN) is one source."""
    spans = sorted(_talker_spans(records, SOURCE_KINDS[key]).items(), key=lambda kv: kv[1])
    # sorted by their first sentences, two spans overlap only if two neighbours do
    if any(b[1][0] < a[1][1] for a, b in itertools.pairwise(spans)):
        said = ", ".join(f"{t or '?'} {records[i].kind} from line {records[i].line} of "
                         f"{names[records[i].file]}" for t, (i, _) in spans)  # fmt: skip
        kinds = "/".join(k for k in SOURCE_KINDS[key] if any(r.kind == k for r in records))
        raise NmeaError(
            f"{kinds} sentences of {len(spans)} talkers interleave ({said}): two sources in "
            f"one log, whose readings would alternate; choose one with "
            f"{TALKER_OPTIONS[CHOOSER[key]]}",
            file=names[records[spans[0][1][0]].file],
        )


def _one_source(
    records: Sequence[_Record],
    talkers: Mapping[str, str],
    names: Sequence[str],
    ignored: Counter[str],
) -> list[_Record]:
    """The records of one source per table: the heading sentences that repeat another left
    out (:func:`_heading_sentences`), and the sentences of a source of talkers other than the
    one ``talkers`` chooses (e.g. ``{"GGA": "GP"}``: GP's GGA, RMC and VTG, :data:`CHOOSER`)
    marked unused, "another talker" (their time and date still count). Without a choice,
    talkers whose sentences of a source interleave are an :class:`NmeaError`
    (:func:`_interleaved`)."""
    kept = _heading_sentences(records, talkers.get("HDT"), ignored)
    for key in SOURCE_KINDS:
        if CHOOSER[key] not in talkers:
            _interleaved(kept, key, names)
    out = []
    for r in kept:
        source = _source(r.kind)
        option = CHOOSER[source] if source is not None else ""
        chosen = talkers.get(option)
        if chosen is not None and r.talker != chosen:
            why = f"{r.talker}{r.kind}, not the {TALKER_OPTIONS[option]} {chosen}"
            r = replace(r, unused=("(talker)", "another talker", why))
        out.append(r)
    return out


# --- files --------------------------------------------------------------------------------------


def _lines(path: Path) -> Iterator[tuple[int, bytes]]:
    """(1-based line number, bytes without the line end) of each non-blank line."""
    try:
        data = path.read_bytes()
    except IsADirectoryError:
        raise NmeaError(f"{path}: is a folder, not an NMEA log", file=str(path)) from None
    except OSError as exc:
        raise NmeaError(f"{path}: cannot read ({exc.strerror})", file=str(path)) from None
    for no, raw in enumerate(data.split(b"\n"), start=1):
        if raw.strip():
            yield no, raw.rstrip(b"\r")


def _read_file(index: int, path: Path, journal: Journal, ignored: Counter[str]) -> list[_Record]:
    """The records of one log; every line not used goes to the repair log or ``ignored``. A
    file without a single usable sentence is an :class:`NmeaError`."""
    records: list[_Record] = []
    problems: Counter[str] = Counter()
    n_lines = 0
    for no, raw in _lines(path):
        n_lines += 1
        try:
            try:
                text = raw.decode("ascii").strip()
            except UnicodeDecodeError:
                raise _LineError("(line)", "not ASCII text", f"{len(raw)} bytes, binary?") from None
            rec = _record(text, (index, no), ignored)
        except _LineError as bad:
            journal.repair(path.name, no, bad.field, bad.action, bad.detail)
            problems[bad.action] += 1
            continue
        if rec is not None:
            records.append(rec)
    if not records:
        seen = ", ".join(f"{a}: {n}" for a, n in problems.most_common(MAX_DISTINCT_PROBLEMS))
        raise NmeaError(
            f"{path.name}: no usable NMEA sentence ({', '.join(USED)}) in {n_lines} line(s)"
            + (f" ({seen})" if seen else ""),
            file=path.name,
        )
    return records


# --- time ---------------------------------------------------------------------------------------


def _days(
    records: Sequence[_Record], names: Sequence[str], journal: Journal
) -> tuple[list[tuple[_Record, int, float]], int]:
    """(record, day index, UTC time of day) of each record with a time, and the number of
    midnight roll-overs. An untimed sentence (VTG, HDT, THS) takes the last timed sentence's time in
    its file, none before the first (repair). The time of day going back by more than 12 h
    is a new day (forward by more than 12 h: the day before)."""
    out: list[tuple[_Record, int, float]] = []
    day, rollovers = 0, 0
    last_tod: float | None = None
    context: tuple[int, float] | None = None
    last_file = -1
    for r in records:
        if r.file != last_file:
            context, last_file = None, r.file
        if r.tod_s is None:
            if context is None:
                why = f"{r.kind} before any timed sentence (GGA, RMC, ZDA) in the file"
                journal.repair(names[r.file], r.line, "(time)", "no time", why)
            else:
                out.append((r, *context))
            continue
        if last_tod is not None and r.tod_s < last_tod - HALF_DAY_S:
            day, rollovers = day + 1, rollovers + 1
        elif last_tod is not None and r.tod_s > last_tod + HALF_DAY_S:
            day -= 1
        last_tod, context = r.tod_s, (day, r.tod_s)
        out.append((r, day, r.tod_s))
    return out, rollovers


def _midnight_s(day: dt.date) -> float:
    return dt.datetime(day.year, day.month, day.day, tzinfo=dt.UTC).timestamp()


def _utc(
    timed: Sequence[tuple[_Record, int, float]],
    date: dt.date | None,
    names: Sequence[str],
    journal: Journal,
) -> tuple[list[float], str]:
    """UTC (s since 1970) of each timed record and where the date came from. The date of day
    index d is ``base + d`` with ``base`` from the first RMC/ZDA date (re-anchored at every
    later one, so a log with gaps of days stays right: each re-anchoring is in the repair
    log, since a wrong date moves every later time by whole days), else ``date`` (the date of
    the first timed sentence); with both, they must agree."""
    dated = [(r, d) for r, d, _ in timed if r.date is not None]
    if dated:
        first, d0 = dated[0]
        assert first.date is not None
        base = first.date - dt.timedelta(days=d0)
        source = f"{first.kind} ({names[first.file]} line {first.line})"
        if date is not None and date != base:
            raise NmeaError(
                f"--date {date.isoformat()} disagrees with {names[first.file]} line {first.line}: "
                f"{first.kind} gives {base.isoformat()} for the first timed sentence",
                file=names[first.file],
                line=first.line,
            )
    elif date is not None:
        base, source = date, "--date"
    else:
        raise NmeaError(
            f"{', '.join(sorted(set(names)))}: no date (no valid RMC or ZDA sentence); give the "
            "UTC date of the first sentence with --date YYYY-MM-DD",
            file=names[0],
        )
    utc = []
    for r, d, tod in timed:
        if r.date is not None and r.date != base + dt.timedelta(days=d):
            days = (r.date - base - dt.timedelta(days=d)).days
            why = (f"{r.kind} date {r.date.isoformat()} where the times of day before give "
                   f"{(base + dt.timedelta(days=d)).isoformat()}: later times move {days:+d} "
                   "day(s) (a gap of days in the log, or a wrong date?)")  # fmt: skip
            journal.repair(names[r.file], r.line, "(date)", "date re-anchored", why)
            base = r.date - dt.timedelta(days=d)
        utc.append(_midnight_s(base + dt.timedelta(days=d)) + tod)
    return utc, source


def _increasing(
    rows: Sequence[tuple[_Record, float]], names: Sequence[str], journal: Journal
) -> list[tuple[_Record, float]]:
    """The rows whose time increases; a row not later than the last kept one, or later than
    the next row while the next is later than the last kept (a time that jumps ahead), goes
    to the repair log."""
    kept: list[tuple[_Record, float]] = []
    for i, (r, t) in enumerate(rows):
        last = kept[-1] if kept else None
        nxt = rows[i + 1][1] if i + 1 < len(rows) else math.inf
        if last is not None and t <= last[1]:
            detail = f"{r.kind} {t - last[1]:+.3f} s after line {last[0].line}"
            journal.repair(names[r.file], r.line, "(time)", "time does not increase", detail)
        elif nxt < t and (last is None or nxt > last[1]):
            detail = f"{r.kind} {t - nxt:+.3f} s after the next one, line {rows[i + 1][0].line}"
            journal.repair(names[r.file], r.line, "(time)", "time jumps ahead", detail)
        else:
            kept.append((r, t))
    return kept


# --- σ model and tables -------------------------------------------------------------------------


def fix_sigma(quality: int, hdop: float, uere_m: float = UERE_M) -> tuple[float, float, float]:
    """σ (N, E, D) in m of a GGA fix (docs/nmea.md, "σ model"): RTK fixed and float get
    :data:`RTK_FIXED_SIGMA_M`, :data:`RTK_FLOAT_SIGMA_M`; the others
    ``σ_N = σ_E = HDOP·U/√2``, ``σ_D = VDOP_PER_HDOP·HDOP·U`` with U = ``uere_m`` (GPS, PPS)
    or :data:`DGNSS_UERE_M` (DGPS, SBAS): HDOP·U is the horizontal DRMS,
    ``√(σ_N² + σ_E²)``."""
    if quality == 4:
        return RTK_FIXED_SIGMA_M
    if quality == 5:
        return RTK_FLOAT_SIGMA_M
    u = DGNSS_UERE_M if quality in (2, 9) else uere_m
    horizontal = hdop * u / math.sqrt(2.0)
    return horizontal, horizontal, VDOP_PER_HDOP * hdop * u


def _gnss_rows(
    rows: Sequence[tuple[_Record, float]], uere_m: float, names: Sequence[str], journal: Journal
) -> pd.DataFrame:
    """The GNSS table (``utc_s``, ``lat_rad``, ``lon_rad``, ``h_m`` and the extra columns
    ``quality, hdop, n_sats, sigma_n_m, sigma_e_m, sigma_d_m, nmea_file, nmea_line``)."""
    out = []
    for r, t in rows:
        v, name = r.values, names[r.file]
        quality, hdop = int(v["quality"]), v["hdop"]
        if quality not in (4, 5) and not hdop > 0.0:
            journal.repair(name, r.line, "horizontal_dil", "assumed HDOP",
                           f"HDOP {hdop} taken as {ASSUMED_HDOP}")  # fmt: skip
            hdop = ASSUMED_HDOP
        if math.isnan(v["geoid_separation_m"]):
            why = "h_m is the altitude above the geoid (separation taken as 0)"
            journal.repair(name, r.line, "geo_sep", "no geoid separation", why)
        sn, se, sd = fix_sigma(quality, hdop, uere_m)
        out.append({
            "utc_s": t, "lat_rad": math.radians(v["lat_deg"]),
            "lon_rad": math.radians(v["lon_deg"]), "h_m": v["h_m"], "quality": quality,
            "hdop": v["hdop"], "n_sats": v["n_sats"], "sigma_n_m": sn, "sigma_e_m": se,
            "sigma_d_m": sd, "nmea_file": r.file, "nmea_line": r.line,
        })  # fmt: skip
    return pd.DataFrame(out, columns=list(GNSS_COLUMNS))


GNSS_COLUMNS = ("utc_s", "lat_rad", "lon_rad", "h_m", "quality", "hdop", "n_sats", "sigma_n_m",
                "sigma_e_m", "sigma_d_m", "nmea_file", "nmea_line")  # fmt: skip
HEADING_COLUMNS = ("utc_s", "yaw_rad", "nmea_file", "nmea_line")
VELOCITY_COLUMNS = ("utc_s", "sog_m_s", "cog_rad", "sentence", "nmea_file", "nmea_line")


def _table(rows: Sequence[tuple[_Record, float]], columns: Sequence[str]) -> pd.DataFrame:
    """The heading or velocity table of stamped heading, or RMC and VTG, records."""
    out = []
    for r, t in rows:
        v = r.values
        if "heading_deg" in v:
            values: dict[str, Any] = {"yaw_rad": math.radians(v["heading_deg"])}
        else:
            values = {"sog_m_s": v["sog_m_s"], "cog_rad": math.radians(v["cog_deg"]),
                      "sentence": r.kind}  # fmt: skip
        out.append({"utc_s": t, **values, "nmea_file": r.file, "nmea_line": r.line})
    return pd.DataFrame(out, columns=list(columns))


VARIATION_TOLERANCE_DEG = 1.0
"""HDG variations that differ from ``--declination-deg`` by more than this are warned of."""


def _true_north(
    rows: Sequence[tuple[_Record, float]],
    declination_deg: float | None,
    names: Sequence[str],
    journal: Journal,
) -> list[tuple[_Record, float]]:
    """The heading rows with the HDG ones turned to true north by their variation (E +).

    An HDG without variation (a compass not told its place) is a repair, "no variation", and
    when none has one an :class:`NmeaError` naming ``--declination-deg``: a heading off by the
    declination would aid the yaw off by it. With ``declination_deg`` every HDG stays
    magnetic (sensor heading + deviation), their variations unused (one declination for the
    sensor, as the mission format has: docs/data-format.md, 'Magnetic headings'), and the
    section's ``declination_deg`` turns them at load; with HDT or THS headings (true already)
    or none, that option is an :class:`NmeaError`.
    """
    hdg = [r for r, _ in rows if r.kind in MAGNETIC_HEADING]
    if declination_deg is not None:
        if not hdg or len(hdg) != len(rows):
            raise NmeaError(f"--declination-deg {declination_deg:g}: no HDG heading read (HDT "
                            "and THS are true already; it is for an HDG compass without "
                            "variation)", field="declination_deg")  # fmt: skip
        given = [v for r in hdg if math.isfinite(v := r.values["variation_deg"])]
        if given and max(abs(v - declination_deg) for v in given) > VARIATION_TOLERANCE_DEG:
            log.warning("HDG variations %.1f..%.1f° in the log, --declination-deg %g° used",
                        min(given), max(given), declination_deg)  # fmt: skip
        return list(rows)
    if hdg and all(math.isnan(r.values["variation_deg"]) for r in hdg):
        raise NmeaError(
            f"{names[hdg[0].file]}: the {hdg[0].kind} headings ({len(hdg)}, from line "
            f"{hdg[0].line}) give no variation, so no true heading: give the compass's "
            "declination with "
            "--declination-deg D (east positive; the table keeps the magnetic headings and the "
            "heading section gets declination_deg = D)", file=names[hdg[0].file],
        )  # fmt: skip
    out = []
    for r, t in rows:
        variation = r.values.get("variation_deg", 0.0)  # HDT, THS: none, true already
        if math.isnan(variation):
            journal.repair(names[r.file], r.line, "variation", "no variation",
                           f"{r.kind} without variation: no true heading")  # fmt: skip
            continue
        magnetic = r.kind in MAGNETIC_HEADING
        true = (r.values["heading_deg"] + variation) % 360.0 if magnetic else None
        out.append((r if true is None else replace(r, values={"heading_deg": true}), t))
    return out


# --- reading a log ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class NmeaLog:
    """What :func:`read_nmea` read. Tables have ``utc_s`` (UTC, s since 1970) first:
    ``gnss`` (:data:`GNSS_COLUMNS`: the used GGA fixes and their σ model), ``heading``
    (:data:`HEADING_COLUMNS`), ``velocity`` (:data:`VELOCITY_COLUMNS`: speed and course over
    ground of RMC and VTG); ``nmea_file`` indexes ``files``. ``sentences``: records read per
    sentence type; ``ignored``: well-formed lines of other types, by type; ``repairs``: every
    line not used (or used with an assumption) with its reason."""

    files: tuple[Path, ...]
    gnss: pd.DataFrame
    heading: pd.DataFrame
    velocity: pd.DataFrame
    repairs: tuple[Repair, ...]
    sentences: dict[str, int]
    ignored: dict[str, int]
    date_source: str
    rollovers: int
    uere_m: float
    declination_deg: float | None = None
    """None: ``heading`` is against true north; else it holds an HDG compass's magnetic
    headings, and this is the declination the section turns them by (:func:`_true_north`)."""
    heading_sentences: tuple[str, ...] = ()
    """The sentences the ``heading`` table comes from (HDT, THS or HDG)."""


def read_nmea(
    paths: Sequence[str | Path],
    *,
    date: dt.date | None = None,
    uere_m: float = UERE_M,
    talkers: Mapping[str, str] | None = None,
    declination_deg: float | None = None,
) -> NmeaLog:
    """Read NMEA 0183 logs, in the order given, as one stream (docs/nmea.md).

    Args:
        paths: the log files; each must hold at least one usable sentence.
        date: the UTC date of the first timed sentence, for logs without RMC/ZDA dates.
        uere_m: σ of the user-equivalent range error of a standalone fix (:func:`fix_sigma`).
        talkers: the talker whose GGA (and RMC, VTG), whose headings (key ``"HDT"``: HDT,
            THS, HDG, HDM), give the readings (``{"GGA": "GP"}``); needed when two talkers'
            sentences of one source interleave (:func:`_one_source`).
        declination_deg: the declination (deg, east positive) of an HDG compass's place: the
            heading table then holds its magnetic headings, to be turned at load by the
            section's ``declination_deg`` (:func:`_true_north`).

    Raises :class:`NmeaError` for a file without a usable sentence, no date, a log with
    neither a GNSS fix nor a heading, HDG headings that cannot be made true; every other
    problem is a repair (:attr:`NmeaLog.repairs`, logged).
    """
    if not (math.isfinite(uere_m) and uere_m > 0.0):
        raise NmeaError(f"--uere-m: {uere_m} must be finite and > 0", field="uere_m")
    if declination_deg is not None and not -90.0 <= declination_deg <= 90.0:  # NaN too
        raise NmeaError(f"--declination-deg {declination_deg}: must be within [-90, 90] "
                        "(east positive)", field="declination_deg")  # fmt: skip
    files = tuple(Path(p) for p in paths)
    short = [p.name for p in files]
    names = [n if short.count(n) == 1 else str(p) for n, p in zip(short, files, strict=True)]
    journal, ignored = Journal(), Counter[str]()
    records = [r for i, p in enumerate(files) for r in _read_file(i, p, journal, ignored)]
    records = _one_source(records, _checked_talkers(talkers or {}), names, ignored)
    timed, rollovers = _days(records, names, journal)
    utc, source = _utc(timed, date, names, journal)
    stamped = _ths_preferred([(r, t) for (r, _, _), t in zip(timed, utc, strict=True)], ignored)
    for r, _ in stamped:
        if r.unused is not None:
            journal.repair(names[r.file], r.line, *r.unused)

    def select(*kinds: str) -> list[tuple[_Record, float]]:
        return [(r, t) for r, t in stamped if r.kind in kinds and r.unused is None]

    def increasing(rows: Sequence[tuple[_Record, float]]) -> list[tuple[_Record, float]]:
        return _increasing(rows, names, journal)

    headings = _true_north(select(*HEADING_KINDS), declination_deg, names, journal)
    velocity = _table(sorted(increasing(select("RMC")) + increasing(select("VTG")),
                             key=lambda rt: rt[1]), VELOCITY_COLUMNS)  # fmt: skip
    log_ = NmeaLog(
        files, _gnss_rows(increasing(select("GGA")), uere_m, names, journal),
        _table(increasing(headings), HEADING_COLUMNS), velocity,
        tuple(sorted(journal.repairs, key=lambda r: (names.index(r.file), r.line or 0))),
        dict(Counter(r.kind for r in records)), dict(ignored), source, rollovers, uere_m,
        declination_deg, tuple(sorted({r.kind for r, _ in headings})),
    )  # fmt: skip
    journal.summarise()
    if log_.gnss.empty and log_.heading.empty:
        raise NmeaError(
            f"{', '.join(names)}: no GNSS fix (GGA of a measured quality) and no heading "
            f"(HDT, THS, HDG, HDM) ({len(journal.repairs)} line(s) in the repair log)",
            file=names[0],
        )
    return log_


# --- sections and folders -----------------------------------------------------------------------


@dataclass(frozen=True)
class Options:
    """The sensor sections' choices of :func:`import_nmea` (docs/nmea.md, "Usage"); None:
    the replaced section's value, else the default."""

    gnss_name: str = "gnss"
    heading_name: str = "heading"
    sigma_m: tuple[float, ...] | None = None
    """σ (N, E, D) or one for all, m, instead of the median of the per-fix model."""
    heading_sigma_deg: float | None = None
    lever_arm_m: tuple[float, float, float] | None = None
    use_height: bool | None = None
    fmt: Literal["parquet", "csv"] = "parquet"
    min_interval_s: float | None = None
    """The GNSS section's ``min_interval_s`` (docs/robustness.md, 'Correlated readings'); None:
    the replaced section's, else none."""

    def __post_init__(self) -> None:
        sigmas = (*(self.sigma_m or ()), *((self.heading_sigma_deg,) if self.heading_sigma_deg
                                           is not None else ()))  # fmt: skip
        if not all(math.isfinite(v) and v > 0.0 for v in sigmas):
            raise NmeaError(f"σ {list(sigmas)}: every σ must be finite and > 0", field="sigma")
        if self.sigma_m is not None and len(self.sigma_m) not in (1, 3):
            raise NmeaError(f"--sigma-m {list(self.sigma_m)}: give one σ or three (N, E, D)")
        if self.min_interval_s is not None and not (
            math.isfinite(self.min_interval_s) and self.min_interval_s >= 0.0
        ):
            raise NmeaError(
                f"--min-interval-s {self.min_interval_s}: must be finite and >= 0",
                field="min_interval_s",
            )
        for option, name in (
            ("--gnss-name", self.gnss_name),
            ("--heading-name", self.heading_name),
        ):
            problem = sensor_name_problem(name)
            if problem is not None:
                raise NmeaError(f"{option}: {problem}", field=option.removeprefix("--"))
        if self.heading_name in (self.gnss_name, f"{self.gnss_name}_velocity"):
            raise NmeaError(
                f"--heading-name {self.heading_name!r}: the GNSS's table is {self.gnss_name!r} "
                f"and its speed and course {self.gnss_name + '_velocity'!r}: name the heading "
                "otherwise"
            )


def _old_section(config: MissionConfig | None, name: str, kind: str) -> dict[str, Any] | None:
    """The mission's ``[sensors.<name>]`` as data (None if absent); another kind is an error."""
    if config is None or name not in config.sensors:
        return None
    old = config.sensors[name]
    if old.kind != kind:
        raise NmeaError(
            f"sensors.{name} of the mission is a {old.kind} sensor, not {kind}: choose another "
            f"--{kind}-name",
            field=f"sensors.{name}",
        )
    # the NMEA rate is not the replaced table's: it is taken from the new table's intervals
    return {k: v for k, v in old.model_dump(mode="python", exclude_none=True).items()
            if k != "rate_hz"}  # fmt: skip


def _gnss_section(
    old: dict[str, Any] | None, gnss: pd.DataFrame, opts: Options
) -> tuple[dict[str, Any], str]:
    """``[sensors.<gnss>]``: the replaced one's keys, or a new ``use = "aid"`` section, with
    the new file and σ (``opts.sigma_m``, else the median per-fix σ); and σ's source."""
    doc: dict[str, Any] = dict(old) if old is not None else {"kind": "gnss", "use": "aid"}
    height = opts.use_height if opts.use_height is not None else bool(doc.get("use_height"))
    if opts.sigma_m is not None:
        sigma = list(opts.sigma_m) * (3 if len(opts.sigma_m) == 1 else 1)
        source = "--sigma-m"
    else:
        cols = ("sigma_n_m", "sigma_e_m", "sigma_d_m")
        sigma = [round(float(np.median(gnss[c])), 4) for c in cols]
        source = "median of the per-fix σ model"
    doc.update(file=f"{opts.gnss_name}.{opts.fmt}", sigma=[sigma[: 3 if height else 2], "m"],
               use_height=height)  # fmt: skip
    if opts.lever_arm_m is not None:
        doc["lever_arm_m"] = list(opts.lever_arm_m)
    if opts.min_interval_s is not None:
        doc["min_interval_s"] = opts.min_interval_s
    return doc, source


def _heading_section(
    old: dict[str, Any] | None, opts: Options, nmea: NmeaLog
) -> tuple[dict[str, Any], str]:
    """``[sensors.<heading>]``: the replaced one's keys, or a new ``use = "aid"`` section, with
    the new file, σ (``opts.heading_sigma_deg``, the replaced σ, else
    :data:`HEADING_SIGMA_DEG`, :data:`COMPASS_SIGMA_DEG` for HDG) and ``declination_deg``
    (:attr:`NmeaLog.declination_deg`: none for true headings); and σ's source."""
    doc: dict[str, Any] = dict(old) if old is not None else {"kind": "heading", "use": "aid"}
    doc["file"] = f"{opts.heading_name}.{opts.fmt}"
    # the replaced sensor may have been a magnetic compass: its declination would turn these
    # true headings once more at load
    doc.pop("declination_deg", None)
    if nmea.declination_deg is not None:  # an HDG compass's magnetic headings (_true_north)
        doc["declination_deg"] = nmea.declination_deg
    if opts.heading_sigma_deg is not None:
        doc["sigma"], source = [opts.heading_sigma_deg, "deg"], "--heading-sigma-deg"
    elif old is not None:
        source = "the mission's"
    else:
        compass = any(k in nmea.heading_sentences for k in MAGNETIC_HEADING)
        doc["sigma"] = [COMPASS_SIGMA_DEG if compass else HEADING_SIGMA_DEG, "deg"]
        source = "default for a magnetic compass (assumed)" if compass else "default (assumed)"
    return doc, source


def _mission_time(df: pd.DataFrame, t0: float) -> pd.DataFrame:
    """``t_s = utc_s - t0`` as the first column; ``utc_s`` kept as an extra column."""
    return pd.concat([pd.DataFrame({"t_s": df["utc_s"] - t0}), df], axis=1)


def _copy_mission_tables(source: Path, config: MissionConfig, out: Path, skip: set[str]) -> None:
    """Copy the tables ``config`` names from ``source`` to ``out``, except ``skip``."""
    files = {config.imu.file, *(s.file for s in config.sensors.values())}
    if config.truth.file is not None:
        files.add(config.truth.file)
    for file in sorted(files - skip):
        src = source / file
        if not src.is_file():
            raise NmeaError(f"{src}: table of the mission not found", file=str(src))
        (out / file).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, out / file)


def _merged_config(
    config: MissionConfig, sections: Mapping[str, dict[str, Any]], written: set[str]
) -> MissionConfig:
    """The mission's configuration with ``sections`` added or replaced; a file we write that
    another stream of the mission reads is an error."""
    doc = config.document()
    doc["sensors"] = {**doc.get("sensors", {}), **sections}
    merged = parse_config(doc, "mission.toml (with the NMEA sensors)")
    for name, s in merged.sensors.items():
        if name not in sections and s.file in written:
            raise NmeaError(
                f"{s.file}: also the table of sensors.{name} in the mission; choose another "
                "--gnss-name / --heading-name",
                field=f"sensors.{name}.file",
            )
    if merged.imu.file in written or merged.truth.file in written:
        raise NmeaError(f"{sorted(written)}: a table name of the mission's IMU or truth")
    return merged


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _quantiles(values: pd.Series) -> list[float]:
    return [round(float(q), 4) for q in np.quantile(values, (0.1, 0.5, 0.9))] if len(values) else []


def _record_of(
    nmea: NmeaLog,
    t0: float,
    t0_source: str,
    sections: Mapping[str, dict[str, Any]],
    sources: Mapping[str, str],
) -> dict[str, Any]:
    """import.json: the files, the time mapping, what was used and how, the σ model and every
    repair (docs/nmea.md, "import.json")."""
    g, v = nmea.gnss, nmea.velocity
    return {
        "importer": "nmea",
        "files": [{"path": str(p), "sha256": _sha256(p)} for p in nmea.files],
        "sentences_used": nmea.sentences,
        "sentences_ignored": nmea.ignored,
        "time": {
            "t0_utc": dt.datetime.fromtimestamp(t0, dt.UTC).isoformat(),
            "t0_source": t0_source, "date_source": nmea.date_source,
            "midnight_rollovers": nmea.rollovers,
            "rule": "t_s = UTC - t0_utc; HDT, THS, HDG and VTG take the time of the last "
                    "timed sentence",
        },
        "gnss": {
            "fixes": len(g),
            "by_quality": {QUALITY_NAMES[q]: n for q, n in
                           sorted(Counter(g["quality"].astype(int).tolist()).items())},
            "sigma_model": {"uere_m": nmea.uere_m,
                            "dgnss_uere_m": DGNSS_UERE_M, "vdop_per_hdop": VDOP_PER_HDOP,
                            "rtk_fixed_m": RTK_FIXED_SIGMA_M, "rtk_float_m": RTK_FLOAT_SIGMA_M,
                            "assumed_hdop": ASSUMED_HDOP},
            "per_fix_sigma_n_m_p10_p50_p90": _quantiles(g["sigma_n_m"]),
            "per_fix_sigma_d_m_p10_p50_p90": _quantiles(g["sigma_d_m"]),
            "sigma_source": sources.get("gnss"),
        },
        "heading": {"readings": len(nmea.heading), "sigma_source": sources.get("heading"),
                    "sentences": list(nmea.heading_sentences),
                    "north": "true north" if nmea.declination_deg is None else
                    f"magnetic north, declination_deg {nmea.declination_deg:g} in the section"},
        "velocity": {
            "rows": len(v), "by_sentence": {str(k): int(n) for k, n in
                                            v["sentence"].value_counts().items()},
            "sog_m_s_p10_p50_p90": _quantiles(v["sog_m_s"]),
            "max_sog_m_s": round(float(v["sog_m_s"].max()), 3) if len(v) else None,
            "note": "not used by the filter: the GNSS kind measures position only",
        },
        "sections": dict(sections),
        "repairs": [r.__dict__ for r in nmea.repairs],
        "repairs_by_action": dict(Counter(r.action for r in nmea.repairs)),
    }  # fmt: skip


def _tables(nmea: NmeaLog, t0: float, opts: Options) -> dict[str, tuple[str, pd.DataFrame]]:
    """The tables to write, keyed gnss / heading / velocity: (file name, table in mission
    time); an empty one is left out."""
    named = {
        "gnss": (f"{opts.gnss_name}.{opts.fmt}", nmea.gnss),
        "heading": (f"{opts.heading_name}.{opts.fmt}", nmea.heading),
        "velocity": (f"{opts.gnss_name}_velocity.{opts.fmt}", nmea.velocity),
    }
    return {k: (f, _mission_time(df, t0)) for k, (f, df) in named.items() if not df.empty}


def _sections(
    nmea: NmeaLog, config: MissionConfig | None, opts: Options
) -> tuple[dict[str, dict[str, Any]], dict[str, str]]:
    """The ``[sensors.*]`` sections to add or replace, by sensor name, and each σ's source."""
    sections: dict[str, dict[str, Any]] = {}
    sources: dict[str, str] = {}
    if not nmea.gnss.empty:
        old = _old_section(config, opts.gnss_name, "gnss")
        sections[opts.gnss_name], sources["gnss"] = _gnss_section(old, nmea.gnss, opts)
    if not nmea.heading.empty:
        old = _old_section(config, opts.heading_name, "heading")
        doc, sources["heading"] = _heading_section(old, opts, nmea)
        sections[opts.heading_name] = doc
    return sections, sources


def _check_span(out: Path, tables: Mapping[str, tuple[str, pd.DataFrame]]) -> dict[str, Any]:
    """Load the written mission (its own checks) and count the readings inside the IMU's time
    span; none inside is an :class:`NmeaError` (a wrong t0)."""
    spans = {k: [round(float(df["t_s"].min()), 3), round(float(df["t_s"].max()), 3)]
             for k, (_, df) in tables.items()}  # fmt: skip
    try:
        m = load_mission(out)
    except OutsideImuSpanError as exc:  # the loader refuses a sensor wholly outside
        (lo, hi), what = exc.imu_span, f"of {exc.file} "
    else:
        lo, hi, what = float(m.imu.start), float(m.imu.t[-1]), ""
    inside = {k: int(((df["t_s"] >= lo) & (df["t_s"] <= hi)).sum()) for k, (_, df) in
              tables.items() if k != "velocity"}  # fmt: skip
    if what or not any(inside.values()):
        raise NmeaError(
            f"no NMEA reading {what}inside the mission's IMU time [{lo:.3f}, {hi:.3f}] s "
            f"(readings at t_s {spans}): check --t0-utc, the UTC time of the mission's t_s = 0"
        )
    return {"imu_span_s": [lo, hi], "readings_in_span": inside}


def import_nmea(
    paths: Sequence[str | Path],
    out_dir: str | Path,
    *,
    mission: str | Path | None = None,
    t0_utc: dt.datetime | None = None,
    date: dt.date | None = None,
    uere_m: float = UERE_M,
    options: Options = Options(),
    talkers: Mapping[str, str] | None = None,
    declination_deg: float | None = None,
) -> Path:
    """Import NMEA logs (docs/nmea.md) into ``out_dir``.

    With ``mission``: a copy of that mission (``mission.toml`` and the tables it names) with
    the GNSS and heading sections added or replaced (``options.gnss_name``,
    ``heading_name``); ``t0_utc``, the UTC time of the mission's ``t_s = 0``, is required
    (missions carry no epoch; without a zone it is UTC) and the result is loaded to check
    it. Without: the tables and ``sensors.toml``, the sections to paste into a
    ``mission.toml``; ``t0_utc`` defaults to the first reading's time. Both write
    ``<gnss>_velocity`` (speed and course over ground, not read by the filter) and
    ``import.json`` (:func:`_record_of`). ``talkers``, ``declination_deg``: as
    :func:`read_nmea`'s. Returns ``out_dir``.
    """
    if mission is not None and t0_utc is None:
        raise NmeaError("--t0-utc is required with --mission: a mission's t_s has no epoch; "
                        "give the UTC time of its t_s = 0", field="t0_utc")  # fmt: skip
    config = load_config(Path(mission) / CONFIG_NAME) if mission is not None else None
    nmea = read_nmea(paths, date=date, uere_m=uere_m, talkers=talkers,
                     declination_deg=declination_deg)  # fmt: skip
    first = min(float(df["utc_s"].min()) for df in (nmea.gnss, nmea.heading) if not df.empty)
    if t0_utc is not None and t0_utc.tzinfo is None:  # as the CLI's: a naive time is UTC, not
        t0_utc = t0_utc.replace(tzinfo=dt.UTC)  # the machine's zone (.timestamp()'s, to 0.4.7)
    t0 = t0_utc.timestamp() if t0_utc is not None else first
    sections, sources = _sections(nmea, config, options)
    for name, doc in sections.items():  # before anything is written (docs/nmea.md, 'Usage')
        parse_sensor(name, doc, "the import's options")
    tables = _tables(nmea, t0, options)
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    for file, df in tables.values():
        write_table(df, root / file)
    record = _record_of(nmea, t0, "--t0-utc" if t0_utc else "first reading", sections, sources)
    if config is not None and mission is not None:
        written = {f for f, _ in tables.values()}
        merged = _merged_config(config, sections, written)
        _copy_mission_tables(Path(mission), merged, root, written)
        (root / CONFIG_NAME).write_text(merged.dump_toml(), encoding="utf-8")
        record["mission"] = {"source": str(mission), **_check_span(root, tables)}
    else:
        head = f"# NMEA import: t_s = UTC - {record['time']['t0_utc']} (import.json)\n"
        text = dumps_toml({"sensors": sections})
        (root / "sensors.toml").write_text(head + text, encoding="utf-8")
    (root / "import.json").write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    log.info("NMEA %s -> %s: %d fixes, %d headings, %d repairs", [p.name for p in nmea.files],
             root, len(nmea.gnss), len(nmea.heading), len(nmea.repairs))  # fmt: skip
    return root
