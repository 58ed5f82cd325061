"""Reading the mission's tables (CSV or Parquet, by extension) with file/line-precise errors.

A :class:`Table` keeps the whole DataFrame as read (extra columns included) and, per data row,
where it is in the file: the 1-based CSV line (header = line 1; blank lines are skipped but
counted) or the 0-based Parquet row. Values are turned into float arrays column by column, so
a bad cell is reported as ``imu.csv line 7, gyro_x_rad_s: 'abc' is not a number`` and never as
a traceback from NumPy or pandas. Policy (error or logged repair) is docs/data-format.md.

A CSV of numbers is streamed by pyarrow into NumPy columns (its peak memory a fraction of the
file); another CSV of plain lines (a text or date column, say) is parsed by pandas from the
file; any other, and any that has something to report, is read by the exact, text-based
reader, which locates every problem. All give the same table: docs/robustness.md, "Memory".
"""

from __future__ import annotations

import codecs
import csv
import io
import logging
import math
import re
import tempfile
from array import array
from collections import Counter, deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, BinaryIO, Literal, cast

import numpy as np
import pandas as pd
import pyarrow as pa  # type: ignore[import-untyped]
import pyarrow.csv as pa_csv  # type: ignore[import-untyped]
import pyarrow.parquet as pq  # type: ignore[import-untyped]
from numpy.typing import NDArray

from adaptnav.core.units import DEG
from adaptnav.mission.config import SENSOR_COLUMNS, MissionError

log = logging.getLogger("adaptnav.mission")

Array = NDArray[np.float64]
TableFormat = Literal["csv", "parquet"]

TIME_COLUMN = "t_s"
IMU_RATE_COLUMNS = (
    "gyro_x_rad_s",
    "gyro_y_rad_s",
    "gyro_z_rad_s",
    "accel_x_m_s2",
    "accel_y_m_s2",
    "accel_z_m_s2",
)
IMU_INCREMENT_COLUMNS = (
    "dtheta_x_rad",
    "dtheta_y_rad",
    "dtheta_z_rad",
    "dvel_x_m_s",
    "dvel_y_m_s",
    "dvel_z_m_s",
)


def imu_columns(fmt: str) -> tuple[str, ...]:
    """The measurement columns of an IMU table of ``imu.format`` ``fmt``."""
    return IMU_RATE_COLUMNS if fmt == "rates" else IMU_INCREMENT_COLUMNS


TRUTH_COLUMNS = (
    "lat_rad",
    "lon_rad",
    "h_m",
    "vn_m_s",
    "ve_m_s",
    "vd_m_s",
    "roll_rad",
    "pitch_rad",
    "yaw_rad",
)
STREAM_COLUMNS: dict[str, tuple[str, ...]] = {
    "imu (format = 'rates')": IMU_RATE_COLUMNS,
    "imu (format = 'increments')": IMU_INCREMENT_COLUMNS,
    "truth": TRUTH_COLUMNS,
    **{k: v[:2] if k == "gnss" else v for k, v in SENSOR_COLUMNS.items()},
}
"""Measurement columns (after ``t_s``) of every kind of table, to say what a table looks like."""
_OLD_PANDAS = int(pd.__version__.split(".")[0]) < 3
"""pandas < 3 parses floats exactly only when asked; pandas 3 always does (and deprecates it)."""
_PANDAS_OPTIONS: dict[str, Any] = {
    "low_memory": False,
    "skipinitialspace": True,
    **({"float_precision": "round_trip"} if _OLD_PANDAS else {}),
}
"""How both pandas-based CSV readers call ``pandas.read_csv`` (the same call: the same table)."""
_LOG_CAP = 10
"""Repairs of one kind logged one by one per file; the rest are summarised (all are recorded)."""
CUT_WINDOW = 100
"""Lines before the last whose last field's length is compared with the last one's, in a CSV
that does not end with a line break (a cut number is shorter)."""
CSV_BLOCK_BYTES = 1 << 18
"""CSV text pyarrow parses per batch. Its reader holds some twenty blocks in flight (read
ahead and parsed), so the block size sets a fixed part of the peak: measured above the
baseline, 4 MiB blocks took 213 MB on a 138 MB IMU file and 1 MiB (pyarrow's default) 100-114
MB, 256 KiB 80 MB, with no change in time (a 29 MB file of two columns: 95-101 MB at 1 MiB,
61 MB at 256 KiB; 128 KiB was slower)."""
SCAN_BYTES = 1 << 22
"""CSV bytes read at a time by the pass that finds the lines (then dropped)."""
BODY_LINES = 1 << 16
"""Lines the exact reader joins and writes to its body file at a time (:func:`_body_file`)."""
TAIL_BYTES = 1 << 16
"""CSV bytes read at a time, backwards from the end, for the last CUT_WINDOW + 1 lines."""
TAIL_MAX_BYTES = 1 << 22
"""A tail longer than this without CUT_WINDOW + 1 data lines (blank lines, very long lines)
is left to the exact reader."""
BINARY_PROBE = 1 << 16
"""A NUL in a CSV's first bytes this many marks it binary (the exact reader's check)."""
BOM = b"\xef\xbb\xbf"
"""UTF-8 byte-order mark (read as ``utf-8-sig``: ignored)."""
PANDAS_NA = (
    "", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN",
    "<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null",
)  # fmt: skip
"""Cells ``pandas.read_csv`` reads as missing (its default ``na_values``), given to pyarrow so
that both CSV readers read the same cells as NaN."""
PANDAS_TRUE, PANDAS_FALSE = ("True", "TRUE", "true"), ("False", "FALSE", "false")
"""The cells ``pandas.read_csv`` reads as booleans (a column of nothing else is a bool column);
given to pyarrow so that both readers agree."""
_NUMBER_BYTES = bytes(
    sorted(
        set(
            b"0123456789+-.eE ,\t\r\n"
            + b"infinityINFINITY"
            + "".join(PANDAS_NA + PANDAS_TRUE + PANDAS_FALSE).encode()
        )
    )
)
"""Bytes a CSV of numbers is made of: digits, signs, point, exponent, separators, infinity and
the missing-value spellings. A file with any other byte (a letter of a word, a quote, ``x`` of
a hexadecimal number, non-ASCII) goes to the streamed or the exact reader."""


@dataclass(frozen=True)
class Repair:
    """A documented change made to the input while loading it (also logged).

    ``line`` is the CSV line (1-based, header = line 1) or, for Parquet, the 0-based row;
    None when the repair concerns the whole table or sensor. ``field`` is the column or key.
    """

    file: str
    line: int | None
    field: str
    action: str
    detail: str

    def __str__(self) -> str:
        at = self.file if self.line is None else f"{self.file} {_unit(self.file)} {self.line}"
        return f"{at}{', ' + self.field if self.field else ''}: {self.action} ({self.detail})"


@dataclass(frozen=True)
class DroppedRow:
    """A sensor row removed at load (its fate for the engine's ledger): 0-based data row."""

    sensor: str
    row: int
    t: float
    reason: str


@dataclass
class Journal:
    """Collects repairs and dropped rows while loading, and logs them (logger
    ``adaptnav.mission``)."""

    repairs: list[Repair] = field(default_factory=list)
    dropped: list[DroppedRow] = field(default_factory=list)
    _counts: Counter[tuple[str, str]] = field(default_factory=Counter)

    def repair(
        self,
        file: str,
        line: int | None,
        fld: str,
        action: str,
        detail: str,
        level: int = logging.WARNING,
    ) -> None:
        r = Repair(file, line, fld, action, detail)
        self.repairs.append(r)
        self._note((file, action), level, str(r))

    def drop(self, file: str, where: str, row: DroppedRow, *, logged: bool = True) -> None:
        """Record a sensor row removed at load; ``logged=False`` when a repair already said so."""
        self.dropped.append(row)
        if logged:
            kind = row.reason.split(":", 1)[0]  # "implausible: <value>": one kind for the cap
            self._note((file, kind), logging.WARNING, f"{where}: dropped ({row.reason})")

    def _note(self, key: tuple[str, str], level: int, text: str) -> None:
        self._counts[key] += 1
        if self._counts[key] <= _LOG_CAP:
            log.log(level, "%s", text)

    def summarise(self) -> None:
        """Log how many of each repair were not logged one by one."""
        for (file, action), n in self._counts.items():
            if n > _LOG_CAP:
                log.warning("%s: %d more: %s (see Mission.repairs)", file, n - _LOG_CAP, action)


def show(value: object) -> str:
    """A cell or number for a message: ``10.05``, ``nan``, ``'abc'`` (no NumPy reprs)."""
    if isinstance(value, bool | np.bool_):
        return str(bool(value))
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        return repr(float(value))
    return repr(value)


def _unit(file: str) -> str:
    """``row`` (0-based data row) for a Parquet table, ``line`` (1-based) for a text file."""
    return "row" if file.lower().endswith((".parquet", ".pq")) else "line"


@dataclass(frozen=True, eq=False)
class Table:
    """One table as read: the full DataFrame and each data row's place in the file."""

    label: str
    """The file as named in mission.toml (used in every message)."""
    path: Path
    fmt: TableFormat
    df: pd.DataFrame
    lines: NDArray[np.int64]
    """Per data row: CSV line (1-based, header = 1) or Parquet row (0-based)."""
    cut: tuple[int, float] | None = None
    """A truncated last line dropped while reading (a CSV cut short): its line and its ``t_s``
    (NaN if that was cut too). Its data row is ``len(self)``; a sensor's ledger gets it."""

    def __len__(self) -> int:
        return len(self.df)

    def where(self, row: int) -> str:
        """``"imu.csv line 7"`` or ``"imu.parquet row 5"`` for 0-based data row ``row``."""
        unit = "line" if self.fmt == "csv" else "row"
        return f"{self.label} {unit} {int(self.lines[row])}"

    def error(self, row: int, fld: str, message: str) -> MissionError:
        """A MissionError located at data row ``row`` and column ``fld``."""
        return MissionError(
            f"{self.where(row)}, {fld}: {message}",
            file=self.label,
            line=int(self.lines[row]),
            field=fld,
        )


def table_format(path: Path) -> TableFormat:
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return "csv"
    if suffix in (".parquet", ".pq"):
        return "parquet"
    raise MissionError(
        f"{path.name}: unknown table format {suffix!r} (use .csv, .parquet or .pq)", file=path.name
    )


def read_table(path: Path, label: str, journal: Journal) -> Table:
    """Read a CSV or Parquet table (by extension); structural problems are MissionErrors."""
    fmt = table_format(path)
    if not path.is_file():
        what = "is not a file" if path.exists() else "file not found"
        raise MissionError(f"{label}: {what} ({path})", file=label)
    if fmt == "csv":
        return _read_csv(path, label, journal)
    return _read_parquet(path, label)


def _read_parquet(path: Path, label: str) -> Table:
    try:
        # Column by column, each Arrow buffer freed as it is converted: a day of IMU is read
        # with one copy in memory at a time, not three (pd.read_parquet's consolidation).
        df = pq.read_table(path).to_pandas(self_destruct=True, split_blocks=True)
    except Exception as exc:  # pyarrow raises many kinds; all mean "not a readable Parquet file"
        raise MissionError(
            f"{label}: not a readable Parquet file ({type(exc).__name__}: {exc})", file=label
        ) from None
    if not isinstance(df.index, pd.RangeIndex):
        df = df.reset_index()  # an index written by pandas (e.g. t_s) becomes a column again
    df = df.reset_index(drop=True)
    df.columns = pd.Index([str(c).strip() for c in df.columns])
    _check_header(list(df.columns), label, None)
    return Table(label, path, "parquet", df, np.arange(len(df), dtype=np.int64))


def _check_header(names: list[str], label: str, line: int | None) -> None:
    at = label if line is None else f"{label} line {line}"
    for i, name in enumerate(names):
        if not name:
            raise MissionError(
                f"{at}: column {i + 1} has no name (a trailing separator?)", file=label, line=line
            )
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise MissionError(f"{at}: repeated column name(s) {dup}", file=label, line=line)


def _read_csv(path: Path, label: str, journal: Journal) -> Table:
    """A CSV table: typed and streamed when the file allows it, else parsed by pandas from the
    file when its lines are plain, else (a classic Mac OS file) either of those from an LF copy,
    else read exactly as text.

    The ways give the same DataFrame, lines, repairs and errors (docs/robustness.md, "Memory");
    each leaves to the next every file it cannot read the same way, and every file with an
    error to report (the typed reader repairs a cut last line itself, from the file's tail).
    """
    table = _read_csv_plain(path, label, journal)
    if table is None:
        table = _read_csv_cr(path, label, journal)
    if table is None:
        table = _read_csv_blanked(path, label, journal)
    if table is None and (error := _stray_cr(path, label)) is not None:
        raise error
    if table is None:
        table = _read_csv_lines(path, label, journal)
    return table if table is not None else _read_csv_exact(path, label, journal)


def _read_csv_plain(path: Path, label: str, journal: Journal) -> Table | None:
    """The typed reader's table, else the streamed reader's, else None."""
    table = _read_csv_typed(path, label, journal)
    return table if table is not None else _read_csv_streamed(path, label, journal)


def _read_csv_cr(path: Path, label: str, journal: Journal) -> Table | None:
    """A CSV whose every line break is a lone CR (classic Mac OS), read as the exact reader
    reads it (:func:`_line_breaks`: the CRs taken for line breaks, one repair for the whole
    file) without holding it in memory: copied piece by piece with LF for CR into a temporary
    file (``tempfile``'s folder, ``TMPDIR``) that the typed or the streamed reader reads, then
    deleted (with lines of other white space, :func:`_read_csv_blanked` reads it). None for any
    other file, or when every way declines the copy (the exact reader then reads the original
    and speaks)."""
    crs = _lone_crs(path)
    if crs == 0:
        return None
    scratch = Journal()
    try:
        with tempfile.TemporaryDirectory(prefix="adaptnav-cr-") as tmp:
            copy = Path(tmp) / path.name
            with path.open("rb") as src, copy.open("wb") as dst:
                while piece := src.read(SCAN_BYTES):
                    dst.write(piece.replace(b"\r", b"\n"))
            table = _read_csv_plain(copy, label, scratch)
            if table is None:  # lines of other white space too: their copy of this copy
                table = _read_csv_blanked(copy, label, scratch)
    except OSError:  # no room for the copy: the exact reader reads it in memory
        return None
    if table is None:
        return None
    _cr_repair(journal, label, crs)
    for r in scratch.repairs:
        journal.repair(r.file, r.line, r.field, r.action, r.detail)
    return replace(table, path=path)


def _lone_crs(path: Path) -> int:
    """The number of CRs in a file that has no LF, read piece by piece; 0 if it has an LF, no
    CR, or cannot be read."""
    crs = 0
    try:
        with path.open("rb") as f:
            while piece := f.read(SCAN_BYTES):
                if b"\n" in piece:
                    return 0
                crs += piece.count(b"\r")
    except OSError:
        return 0
    return crs


def _read_csv_blanked(path: Path, label: str, journal: Journal) -> Table | None:
    """A CSV with lines of other white space (a form feed, a vertical tab, a no-break space:
    blank to the exact reader's ``str.strip``, a data line to pandas and pyarrow), read as the
    exact reader reads it without holding it in memory: copied piece by piece into a temporary
    file with those lines emptied (their line breaks kept, so every line keeps its number),
    which the typed or the streamed reader reads, then deleted (a last line without a line
    break that is such a line is emptied too). None for any other file, one that is not UTF-8
    or has a lone CR, or when both decline the copy (the exact reader then reads the original
    and speaks)."""
    try:
        with path.open("rb") as src:
            if not _odd_blanks(src, None):
                return None
            src.seek(0)
            scratch = Journal()
            with tempfile.TemporaryDirectory(prefix="adaptnav-blank-") as tmp:
                copy = Path(tmp) / path.name
                with copy.open("wb") as dst:
                    _odd_blanks(src, dst)
                table = _read_csv_plain(copy, label, scratch)
    except OSError:  # no room for the copy: the exact reader reads it in memory
        return None
    if table is None:
        return None
    for r in scratch.repairs:
        journal.repair(r.file, r.line, r.field, r.action, r.detail)
    return replace(table, path=path)


def _odd_blanks(src: BinaryIO, dst: BinaryIO | None) -> int:
    """The lines of ``src`` that only ``str.strip`` finds blank (white space other than spaces
    and tabs on them), counted, and with ``dst`` written there emptied (the rest as it is);
    0 when the file is not one :func:`_read_csv_blanked` reads. Pieces are cut after a line
    break, so every line (and UTF-8 sequence) lies in one."""
    found = 0
    carry = b""
    while True:
        chunk = src.read(SCAN_BYTES)
        buf = carry + chunk
        cut = buf.rfind(b"\n") + 1 if chunk else len(buf)
        piece, carry = buf[:cut], buf[cut:]
        if b"\r" in piece.replace(b"\r\n", b""):
            return 0  # a lone CR: an error for the exact reader (_stray_cr)
        try:
            lines = piece.decode("utf-8").split("\n")
        except UnicodeDecodeError:
            return 0
        for i, line in enumerate(lines[:-1]):
            if not line.strip() and line.strip(" \t\r"):
                lines[i] = "\r" if line.endswith("\r") else ""
                found += 1
        if not chunk and lines[-1].strip(" \t\r") and not lines[-1].strip():
            lines[-1] = ""  # blank to the exact reader, the last data line kept whole
            found += 1
        if dst is not None:
            dst.write("\n".join(lines).encode("utf-8"))
        if not chunk:
            return found


def _stray_cr(path: Path, label: str) -> MissionError | None:
    """The exact reader's error for a file with a lone CR among LF line breaks, found piece by
    piece instead of in the whole text (docs/robustness.md, "Memory"), or None for any other
    file (the exact reader reads it, or gives its own error).

    The exact reader decodes the whole file first (:func:`_decode`), then looks for the lone
    CR (:func:`_line_breaks`): so the error is the first byte that is not UTF-8, if the file has
    one anywhere, else the line of the first lone CR (not the file's last byte: a CRLF file cut
    short). A file whose first :data:`BINARY_PROBE` bytes hold a NUL is the exact reader's, which
    refuses it after that probe. Pieces are cut after a line break, so a line's bytes (and every
    UTF-8 sequence) lie in one piece: the memory is a piece or the longest line."""
    names: list[str] | None = None
    cr_line = 0
    lines = 1  # the line the next piece starts on
    try:
        with path.open("rb") as f:
            if b"\x00" in f.read(BINARY_PROBE):
                return None
            f.seek(0)
            carry = f.read(len(BOM)).removeprefix(BOM)
            while True:
                chunk = f.read(SCAN_BYTES)
                buf = carry + chunk
                cut = buf.rfind(b"\n") + 1 if chunk else len(buf)
                piece, carry = buf[:cut], buf[cut:]
                if names is None and b"\n" in piece:
                    names = _header_names(piece[: piece.index(b"\n")])
                try:
                    piece.decode("utf-8")
                except UnicodeDecodeError as exc:
                    return _piece_not_utf8(piece, exc.start, lines, names or [], label)
                if not cr_line:
                    cr_line = _lone_cr_line(piece, lines, last=not chunk)
                lines += piece.count(b"\n")
                if not chunk:
                    break
    except OSError:
        return None
    if not cr_line or lines == 1:  # no lone CR; or no LF: classic Mac OS, not this error
        return None
    return MissionError(
        f"{label} line {cr_line}: a carriage return (CR) alone inside the line, among LF line "
        "breaks (a file joined from Mac and Unix parts?): save it with LF or CRLF line breaks",
        file=label,
        line=cr_line,
    )


def _read_csv_lines(path: Path, label: str, journal: Journal) -> Table | None:
    """The exact reader's table, errors and repairs (:func:`_read_csv_exact`), read line by
    line: the data lines written to a temporary file (``tempfile``'s folder, ``TMPDIR``) that
    pandas parses with the exact reader's call, their line numbers kept (8 bytes a line), and
    only the record under way and the last :data:`CUT_WINDOW` + 1 data lines held as text
    (docs/robustness.md, "Memory"). For a file the other ways declined that has neither a
    byte that is not UTF-8 nor a lone CR among LF breaks (:func:`_stray_cr` says so first).

    None, for the exact reader, on what it says in its own way: a NUL in the file's first
    :data:`BINARY_PROBE` bytes, a CR inside a line (a classic Mac OS file), a csv module error
    in a file without quotes (the exact reader counts commas there), no room for the file."""
    try:
        with path.open("rb") as f, tempfile.TemporaryFile(prefix="adaptnav-exact-") as body:
            if b"\x00" in f.read(BINARY_PROBE):
                return None
            f.seek(0)
            walk = _walk_lines(f, body, label)
            if walk is None:
                return None
            cut = _cut_last_line(walk, label, journal)
            rows = walk.rows
            if cut is not None:  # the last data line dropped: from the table and the body
                rows = rows[:-1]
                body.truncate(walk.tail[-1][2])
            body.seek(0)
            df = _parse_csv(cast(BinaryIO, body), label)
    except (OSError, UnicodeDecodeError, _CrInsideLineError):
        return None
    return _exact_table(path, label, df, walk.header, walk.head, rows, cut)


def _exact_table(
    path: Path,
    label: str,
    df: pd.DataFrame,
    header: list[str],
    head: int,
    rows: NDArray[np.int64],
    cut: tuple[int, float] | None,
) -> Table:
    """The exact reader's table of pandas' ``df`` of the data lines ``rows`` (file lines),
    the header on line ``head``; the error when pandas splits the header otherwise."""
    if len(df.columns) != len(header):
        raise MissionError(
            f"{label} line {head}: the header's quotes split it into {len(header)} names "
            f"for the csv module and {len(df.columns)} for pandas (a quote after a space?)",
            file=label,
            line=head,
        )
    df.columns = pd.Index(header)
    if len(df) != len(rows):  # pragma: no cover - guarded by the field count
        raise MissionError(f"{label}: CSV rows do not match its lines (quoted newlines?)")
    return Table(label, path, "csv", df, rows, cut)


class _CrInsideLineError(Exception):
    """A file :func:`_read_csv_lines` leaves to the exact reader (a CR inside a line)."""


@dataclass
class _Ends:
    """How the lines of :func:`_text_lines` ended: the number of the last one given, whether
    it had a line break, whether it ended in a CR without one (a CRLF file cut short)."""

    line: int = 0
    lf: bool = True
    cr: bool = False


def _text_lines(f: BinaryIO, ends: _Ends) -> Iterator[str]:
    """The file's lines as the exact reader splits them (at LF, a BOM dropped, trailing CRs
    stripped), ``ends`` kept up to date; :class:`_CrInsideLineError` for a CR left inside a
    line or a file without LF that has a CR (classic Mac OS), UnicodeDecodeError for bytes
    that are not UTF-8."""
    for k, raw in enumerate(f):
        ends.line, ends.lf = k + 1, raw.endswith(b"\n")
        line = (raw.removeprefix(BOM) if k == 0 else raw).removesuffix(b"\n").decode("utf-8")
        ends.cr = not ends.lf and line.endswith("\r")
        line = line.rstrip("\r")
        if "\r" in line or (ends.cr and k == 0):  # a lone CR; or no LF at all: classic Mac OS
            raise _CrInsideLineError
        yield line


@dataclass
class _Walk:
    """What :func:`_walk_lines` found: the header and its line, the data lines' numbers, the
    first with a wrong field count (line, count) and whether it is the last, whether the file
    has a quote, the last data lines (line, text, offset in the body file), and whether the
    last data line is the file's last, without a line break or a CR after it."""

    header: list[str]
    head: int
    rows: NDArray[np.int64]
    wrong: tuple[int, int] | None
    wrong_last: bool
    quoted: bool
    tail: deque[tuple[int, str, int]]
    open_end: bool


def _walk_lines(f: BinaryIO, body: Any, label: str) -> _Walk | None:
    """One pass over the lines of ``f``: the header and the data lines written to ``body``
    (UTF-8, one a line), the exact reader's errors at its lines raised in its order (no header
    line; a header it refuses; a quoted field not closed on its line, or the csv module's own
    error, before any wrong field count: the exact reader counts every line's fields first).
    None where the exact reader says it its own way (:func:`_read_csv_lines`)."""
    ends = _Ends()
    lines = _text_lines(f, ends)
    first = next((s for s in lines if s.strip()), None)
    if first is None:
        raise MissionError(f"{label}: empty file (no header line)", file=label)
    head = ends.line
    header = [h.strip() for h in next(csv.reader([first]))]
    _check_header(header, label, head)
    size = body.write(first.encode())  # bytes written
    rows = array("q")
    tail: deque[tuple[int, str, int]] = deque(maxlen=CUT_WINDOW + 1)
    starts: deque[int] = deque()  # the lines of the record under way
    quoted = '"' in first

    def data() -> Iterator[str]:
        nonlocal size, quoted
        for s in lines:
            if s.strip():
                starts.append(ends.line)
                quoted = quoted or '"' in s
                rows.append(ends.line)
                tail.append((ends.line, s, size))
                size += body.write(b"\n" + s.encode())
                yield s

    reader = csv.reader(data())
    wrong: tuple[int, int] | None = None
    wrong_last = True
    try:
        for n_rows, row in enumerate(reader, 1):
            if reader.line_num != n_rows:
                raise _quote_not_closed(label, starts[0])
            line = starts.popleft()
            wrong_last = wrong is None
            if wrong is None and len(row) != len(header):
                wrong = line, len(row)
    except csv.Error as exc:
        if not quoted and not _quote_after(f):
            return None
        raise MissionError(f"{label} line {starts[0]}: {exc}", file=label, line=starts[0]) from None
    open_end = bool(rows) and rows[-1] == ends.line and not ends.lf and not ends.cr
    rows_array = np.frombuffer(rows, dtype=np.int64).copy() if rows else np.zeros(0, np.int64)
    return _Walk(header, head, rows_array, wrong, wrong_last, quoted, tail, open_end)


def _quote_not_closed(label: str, line: int) -> MissionError:
    """The exact reader's error for a quoted field that runs over the end of ``line``."""
    return MissionError(
        f"{label} line {line}: a quoted field is not closed on its line (a line break inside "
        "quotes is not supported)",
        file=label,
        line=line,
    )


def _cut_last_line(walk: _Walk, label: str, journal: Journal) -> tuple[int, float] | None:
    """The exact reader's verdict after its field counts (:func:`_check_field_counts`,
    :func:`_drop_cut_last_line`) from what :func:`_walk_lines` kept: the wrong field count's
    error, or the last data line dropped as cut short (recorded; its line and ``t_s``), or
    None."""
    n = len(walk.header)
    if walk.wrong is not None:
        line, c = walk.wrong
        if not (c < n and walk.wrong_last):
            raise MissionError(
                f"{label} line {line}: {c} fields, the header (line {walk.head}) has {n}",
                file=label,
                line=line,
            )
        text = walk.tail[-1][1]
        journal.repair(label, line, "", "dropped truncated last line", _short_line(c, n, text))
        return line, _time_of(_fields(text, walk.quoted)[: c - 1], walk.header)
    if not walk.open_end:
        return None
    line, text = walk.tail[-1][:2]
    last = _fields(text, walk.quoted)
    before = [len(_fields(t, walk.quoted)[-1].strip()) for _, t, _ in list(walk.tail)[:-1]]
    detail = _cut_number(last[-1].strip(), before)
    if detail is None:
        return None
    journal.repair(label, line, walk.header[-1], "dropped truncated last line", detail)
    return line, _time_of(last[:-1], walk.header)


def _short_line(c: int, n: int, text: str) -> str:
    """The "dropped truncated last line" repair's detail for a last line ``text`` with ``c``
    of the header's ``n`` fields."""
    return f"{c} of {n} fields: {text[:60]!r}"


def _cut_number(value: str, before: list[int]) -> str | None:
    """The "dropped truncated last line" repair's detail for a last line without a line break
    whose last value is shorter than the longest of its column on the lines before (their
    lengths ``before``; none: cut too): a number cut short. None when it is as long (a
    fixed-width writer's line is whole)."""
    if before and len(value) >= max(before):
        return None
    return (
        f"the file ends without a line break and the last value {value!r} is shorter "
        f"than its column's ({max(before, default=0)} characters): cut mid-number?"
    )


def _quote_after(f: BinaryIO) -> bool:
    """Whether a quote follows in the rest of ``f``, read piece by piece."""
    while piece := f.read(SCAN_BYTES):
        if b'"' in piece:
            return True
    return False


def _header_names(raw: bytes) -> list[str]:
    """The header's names as :func:`_not_utf8` reads them (none if the header is odd)."""
    try:
        header = raw.decode("utf-8").rstrip("\r")
        return [h.strip() for h in _fields(header, '"' in header)]
    except (UnicodeDecodeError, csv.Error):
        return []


def _lone_cr_line(piece: bytes, first_line: int, last: bool) -> int:
    """The line of the first CR of ``piece`` (starting at line ``first_line``) not followed by
    LF, the file's very last byte excepted when ``last``; 0 if none."""
    body = piece[:-1] if last and piece.endswith(b"\r") else piece
    at = body.find(b"\r")
    while at >= 0 and body[at + 1 : at + 2] == b"\n":
        at = body.find(b"\r", at + 1)
    return 0 if at < 0 else first_line + body.count(b"\n", 0, at)


def _cr_repair(journal: Journal, label: str, crs: int) -> None:
    """The repair of a file whose line breaks are all a lone CR (:func:`_line_breaks`)."""
    journal.repair(
        label,
        None,
        "",
        "read CR line breaks as line breaks",
        f"{crs} line breaks are a carriage return alone (classic Mac OS), none LF",
    )


@dataclass(frozen=True)
class _Layout:
    """Where a CSV's lines are, from one pass over its bytes (nothing kept but this)."""

    header: list[str]
    head: int
    """The header's line (1-based): 1, or after blank lines."""
    header_start: int
    """Byte offset of the header line (after a BOM and blank lines)."""
    size: int
    """Bytes the scan read: the file's size then (a file still growing is read up to it)."""
    data_start: int
    """Byte offset of the line after the header."""
    n_lines: int
    """Lines as ``text.split("\\n")`` counts them (an empty one after a final line break)."""
    blank: NDArray[np.int64]
    """1-based numbers of the blank lines after the header (empty, or spaces and tabs; LF or
    CRLF: :func:`_blank_lines`)."""
    ends_with_break: bool


@dataclass(frozen=True)
class _Plan:
    """What to read of a CSV whose layout is known, and what to say about its last line."""

    limit: int
    """Bytes to parse: the whole file, or up to the start of a cut last line."""
    lines: NDArray[np.int64]
    """File line of each data row to read."""
    cut: tuple[int, float] | None
    repair: tuple[int, str, str] | None
    """(line, field, detail) of the "dropped truncated last line" repair."""


def _read_csv_typed(path: Path, label: str, journal: Journal) -> Table | None:
    """Read a CSV with pyarrow's streaming reader straight into NumPy columns, or None.

    One pass over the bytes finds the header, the blank lines (for the line numbers) and
    anything this reader would read differently from pandas (quotes, a lone CR, a character
    that cannot be part of a number or a missing-value spelling); the file's tail decides on a
    cut last line; then pyarrow parses the file (up to that line) in blocks of
    :data:`CSV_BLOCK_BYTES` into columns allocated once. None whenever another reader has
    to read it (:func:`_read_csv_streamed`: a cell that is not a number, a text, date or
    true/false column) or to speak (:func:`_read_csv_exact`: a wrong field count, an empty
    table).
    """
    try:
        with path.open("rb") as f:
            layout = _scan(f)
            if layout is None or not _header_ok(layout.header, label):
                return None
            plan = _plan_last_line(f, layout)
    except OSError:
        return None
    if plan is None:
        return None
    head = (path, layout.header_start, plan.limit)
    columns = _read_columns(head, layout.header, plan.lines.size)
    if columns is None:
        return None
    if plan.repair is not None:
        line, fld, detail = plan.repair
        journal.repair(label, line, fld, "dropped truncated last line", detail)
    # copy=False: one block per column, no consolidation into a second 2-D copy of the data.
    df = pd.DataFrame(dict(zip(layout.header, columns, strict=True)), copy=False)
    df.columns = pd.Index(layout.header)
    return Table(label, path, "csv", df, plan.lines, plan.cut)


def _header_ok(header: list[str], label: str) -> bool:
    """Whether the header passes :func:`_check_header` (the exact reader gives the error)."""
    try:
        _check_header(header, label, 1)
    except MissionError:
        return False
    return True


def _scan(f: BinaryIO, *, numbers_only: bool = True, label: str = "") -> _Layout | None:
    """The layout of an open CSV, or None if it is not a plain table (of numbers).

    Plain: a header with at least two names (quoted or not) on line 1 or after blank lines
    (empty, or spaces and tabs; a BOM first); after it, line breaks LF or
    CRLF (a lone CR is a line break to pyarrow and pandas, not to the exact reader) and at
    least one line; and either (``numbers_only``) only the bytes of :data:`_NUMBER_BYTES`, no
    ``+`` but an exponent's, or else UTF-8 text without NUL whose every line but the blank ones
    has the header's number of fields as the csv module counts them, none quoted across a line
    break (:func:`_fields_ok`). Read in pieces of
    :data:`SCAN_BYTES` cut at a line break, so a blank line is never split between two pieces.
    The size is what was read: a file still being written is read as it was then.

    With a ``label`` (not ``numbers_only``), a line with the wrong number of fields that the
    exact reader would report is reported here, in its words (:func:`_wrong_field_count`),
    without reading the file into memory; and so is a byte that is not UTF-8: the exact reader
    decodes the whole file first, so unless its first :data:`BINARY_PROBE` bytes hold a NUL
    (binary, its own error) the first such byte is its error (:func:`_piece_not_utf8`).
    """
    first = f.read(SCAN_BYTES)
    size = len(first)
    found = _header_line(first)
    if found is None:
        return None
    header, header_start, data_start = found
    head_line = 1 + first.count(b"\n", 0, header_start)
    blank: list[int] = []
    breaks = 0  # line breaks after the header's
    last = b"\n"  # the file's last byte so far: the header's line break
    carry = b""
    chunk = first[data_start:]
    while True:
        buf = carry + chunk  # carry: the start of a line, short
        cut = buf.rfind(b"\n") + 1 if chunk else len(buf)
        piece, carry = buf[:cut], buf[cut:]
        if piece:
            crs = piece.count(b"\r")
            if crs and crs != piece.count(b"\r\n"):
                return None
            if numbers_only:
                if piece.translate(None, _NUMBER_BYTES) or _leading_plus(piece):
                    return None
            elif not _text_piece(piece, first, head_line + 1 + breaks, header, label):
                return None
            before = len(blank)
            _blank_lines(piece, head_line + 1 + breaks, blank)
            if not numbers_only and not _fields_ok(piece, len(header), len(blank) - before):
                if label and _header_ok(header, label):
                    line = head_line + 1 + breaks
                    _wrong_field_count(f, piece, carry, line, head_line, len(header), label)
                return None
            breaks += piece.count(b"\n")
            last = piece[-1:]
        if not chunk:
            break
        chunk = f.read(SCAN_BYTES)
        size += len(chunk)
    n_lines = head_line + 1 + breaks
    ends_with_break = last == b"\n"
    if ends_with_break:
        blank.append(n_lines)  # the empty string after the final line break
    if n_lines - head_line - len(blank) < 1:
        return None  # no data line: the exact reader gives the table its empty columns
    blanks = np.asarray(blank, np.int64)
    return _Layout(
        header, head_line, header_start, size, data_start, n_lines, blanks, ends_with_break
    )


def _header_line(first: bytes) -> tuple[list[str], int, int] | None:
    """(names, the header line's offset, the next line's) in a CSV's first bytes: the first
    line after a BOM and blank lines (:data:`_LEADING_BLANKS`); None if there is none with a
    line break after it, or it is not a plain header of two names or more."""
    bom = len(BOM) if first.startswith(BOM) else 0
    header_start = _LEADING_BLANKS.match(first, bom).end()  # type: ignore[union-attr]
    end = first.find(b"\n", header_start)
    if end < 0:
        return None  # no line after the header, or a header (or blank lines) beyond a piece
    head = first[header_start:end].removesuffix(b"\r")
    if any(c in head for c in (b"\r", b"\x00")):
        return None
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return None
    # A quoted header ("t_s","vx_m_s", as csv writers quoting every cell give it) is read as
    # the exact reader reads it: by the csv module, names stripped; a quote left in a name is
    # its to report.
    header = [h.strip() for h in _fields(text, '"' in text)]
    if any('"' in h for h in header) or not text.strip() or len(header) < 2:
        return None
    return header, header_start, end + 1


_LEADING_BLANKS = re.compile(rb"(?:[ \t]*\r?\n)*")
"""Blank lines before the header: empty, or spaces and tabs (LF or CRLF), as
:data:`_BLANK_AFTER` finds them after it."""
_NOT_TEXT = b" \t\n\r\x0b\x0c\x1c\x1d\x1e\x1f" + bytes(range(128, 256))
"""The bytes that are white space to ``str.strip`` (the exact reader's blank lines) and every
non-ASCII byte (NBSP and other Unicode white space are made of these): a byte not among them
is a character that makes its line a data line."""


def _wrong_field_count(
    f: BinaryIO, piece: bytes, carry: bytes, first_line: int, head: int, n: int, label: str
) -> None:
    """Raise the exact reader's error for the first line of ``piece`` (which starts at line
    ``first_line``; earlier lines were all right) with other than ``n`` fields, when the exact
    reader would raise it: MissionError ``"{label} line {i}: {c} fields, the header (line
    {head}) has {n}"`` (:func:`_check_field_counts`). Returns, leaving the file to the exact reader,
    whenever that is not certain: quotes in this piece or after it (the csv module counts
    them, and may find an unclosed one first), no such line (a line of other white space, a
    form feed say: blank to the exact reader), a short line with nothing but white space after
    it (the file's cut last line, a repair), or the rest of the file (read on from ``carry``
    and ``f`` piece by piece, nothing kept) not UTF-8, with NUL or with a lone CR (the exact
    reader's own errors come first)."""
    if b'"' in piece:
        return
    lines = piece.split(b"\n")
    found = None
    for j, raw in enumerate(lines[:-1]):  # the lines ended by a line break, as _fields_ok
        text = raw.decode("utf-8").removesuffix("\r")
        c = text.count(",") + 1
        if c != n and text.strip():
            found = j, c
            break
    if found is None:
        return
    k, c = found
    decoder = codecs.getincrementaldecoder("utf-8")()
    more = False  # a character after the line that is surely not white space (ASCII)
    rest = b"\n".join(lines[k + 1 :]) + carry
    held = b""  # a CR that ended the bytes before: a CRLF's, or lone?
    while True:
        if b'"' in rest or b"\x00" in rest:
            return
        both = held + rest
        held = b"\r" if both.endswith(b"\r") else b""
        if b"\r" in both[: len(both) - len(held)].replace(b"\r\n", b""):
            return  # a lone CR after it: the exact reader's error comes first (_stray_cr)
        try:
            decoder.decode(rest, final=not rest)
        except UnicodeDecodeError:
            return
        if not rest:
            break
        more = more or bool(rest.translate(None, _NOT_TEXT))
        rest = f.read(SCAN_BYTES)
    if c < n and not more:
        return  # the last data line cut short (or a line of Unicode white space after it?)
    line = first_line + k
    raise MissionError(
        f"{label} line {line}: {c} fields, the header (line {head}) has {n}",
        file=label,
        line=line,
    )


def _text_piece(piece: bytes, first: bytes, first_line: int, header: list[str], label: str) -> bool:
    """Whether ``piece`` (line ``first_line`` on) is UTF-8 text without NUL. A byte that is
    not UTF-8 is, with a ``label``, the exact reader's error (:func:`_piece_not_utf8`), raised,
    unless the file's ``first`` bytes hold a NUL within :data:`BINARY_PROBE` (binary: its own
    error)."""
    if b"\x00" in piece:
        return False
    at = _not_utf8_offset(piece)
    if at is None:
        return True
    if label and b"\x00" not in first[:BINARY_PROBE]:
        raise _piece_not_utf8(piece, at, first_line, header, label)
    return False


def _not_utf8_offset(piece: bytes) -> int | None:
    """The offset of the first byte of ``piece`` (cut at a line break: no character is split)
    that is not UTF-8, None if it is all UTF-8 text."""
    try:
        piece.decode("utf-8")
    except UnicodeDecodeError as exc:
        return int(exc.start)
    return None


def _fields_ok(piece: bytes, n_fields: int, n_blank: int) -> bool:
    """Whether every line of ``piece`` (which starts a line) ended by a line break has
    ``n_fields`` fields, as the exact reader (the csv module) counts them, but its ``n_blank``
    blank lines (no comma: ``n_fields`` ≥ 2 tells them apart), and an even number of ``"``, so
    that no line break is inside quotes.

    Counted with NumPy: a comma after an odd number of quotes on its line is inside quotes
    (``"a,b"``; the doubled ``""`` of a quote in a quoted text counts twice). That is how the
    csv module reads them when each quote that opens a quoted field (the 1st, 3rd, ... of a
    line) starts its field: after a comma or at the line's start, or right after a quote (a
    doubled one). A line with a quote elsewhere (``x"y``, ``, "a"``: a character to the csv
    module) is counted by the csv module itself, and declined if it leaves a quoted field open
    (it would take in the next line). Lines of other white space, short and long lines, quoted line
    breaks are the exact reader's to see and report."""
    a = np.frombuffer(piece, np.uint8)
    ends = np.flatnonzero(a == ord("\n"))
    commas = np.flatnonzero(a == ord(","))
    quotes = np.flatnonzero(a == ord('"'))
    if quotes.size and np.any(np.searchsorted(quotes, ends) % 2):
        return False
    free = commas[np.searchsorted(quotes, commas) % 2 == 0] if quotes.size else commas
    per_line = np.diff(np.searchsorted(free, ends), prepend=0)
    opening = quotes[0::2]
    before = np.full(opening.size, -2)
    before[1:] = quotes[1::2][: opening.size - 1]  # the quote before each opening one
    prev = a[np.maximum(opening - 1, 0)]
    starts_field = (opening == 0) | (prev == ord(",")) | (prev == ord("\n"))
    stray = opening[~(starts_field | (before == opening - 1))]
    rows = np.unique(np.searchsorted(ends, stray))
    rows = rows[rows < ends.size]
    if rows.size:
        lines = piece.decode("utf-8").split("\n")
        reader = csv.reader([*(lines[k].removesuffix("\r") for k in rows.tolist()), ""])
        for j, k in enumerate(rows.tolist()):
            fields = next(reader)
            if reader.line_num != j + 1:
                return False  # a quoted field open at its line's end joined the next
            per_line[k] = len(fields) - 1
    return int(np.count_nonzero(per_line != n_fields - 1)) == n_blank


def _leading_plus(piece: bytes) -> bool:
    """Whether a ``+`` of ``piece`` starts a number (``+7``) rather than an exponent
    (``1e+16``): pandas reads ``+7`` as an integer, pyarrow only as a float."""
    pluses = piece.count(b"+")
    return pluses > 0 and pluses != piece.count(b"e+") + piece.count(b"E+")


def _blank_lines(piece: bytes, first_line: int, out: list[int]) -> None:
    """Append to ``out`` the numbers of the blank lines of ``piece``, which starts at the start
    of line ``first_line``: those ended by a line break with nothing but spaces and tabs before
    it (and the CR of a CRLF), which the exact reader (``str.strip``) and pandas both skip."""
    first = _BLANK_START.match(piece)
    starts = [0] if first else []
    starts.extend(m.start() + 1 for m in _BLANK_AFTER.finditer(piece))
    line, at = first_line, 0
    for q in starts:
        line += piece.count(b"\n", at, q)
        at = q
        out.append(line)


_BLANK_START = re.compile(rb"[ \t]*\r?\n")
"""A blank line at the start of a piece."""
_BLANK_AFTER = re.compile(rb"\n[ \t]*\r?(?=\n)")
"""A line break followed by a blank line (its start is the match's start + 1)."""


def _data_lines(layout: _Layout) -> NDArray[np.int64]:
    """The file line of every data line: those after the header but the blank ones."""
    first = layout.head + 1
    lines = np.arange(first, layout.n_lines + 1, dtype=np.int64)
    if layout.blank.size == 1 and layout.blank[0] == layout.n_lines:
        return lines[:-1]  # only the empty string after the final line break: no copy
    return np.delete(lines, layout.blank - first) if layout.blank.size else lines


def _plan_last_line(f: BinaryIO, layout: _Layout) -> _Plan | None:
    """Rows to read and what to do with the last line, as the exact reader decides it.

    Only the tail is read: the last data line and the :data:`CUT_WINDOW` before it. A last
    line with fewer fields, or cut inside its last number (docs/robustness.md), is left out
    and reported; more fields, or nothing left to read, is the exact reader's to report.
    """
    tail = _tail_lines(f, layout)
    if not tail:  # None, or only blank lines (a form feed: blank to the exact reader only)
        return None
    lines = _data_lines(layout)
    (line, offset, text) = tail[-1]
    if int(lines[-1]) != line:  # a form feed line at the end: blank to the exact reader only
        return None
    header = layout.header
    n = len(header)
    fields = _fields(text, '"' in text)  # as the exact reader splits it (csv if quoted)
    c = len(fields)
    if c > n:
        return None
    repair: tuple[int, str, str] | None = None
    cut: tuple[int, float] | None = None
    if c < n:
        repair = (line, "", _short_line(c, n, text))
        cut = (line, _time_of(fields[: c - 1], header))
    elif line == layout.n_lines:  # the file's last line, no line break after it
        before = [len(_fields(t, '"' in t)[-1].strip()) for _, _, t in tail[-1 - CUT_WINDOW : -1]]
        detail = _cut_number(fields[-1].strip(), before)
        if detail is not None:
            repair = (line, header[-1], detail)
            cut = (line, _time_of(fields[:-1], header))
    if cut is None:
        return _Plan(layout.size, lines, None, None)
    if lines.size < 2:
        return None
    return _Plan(offset, lines[:-1], cut, repair)


def _tail_lines(f: BinaryIO, layout: _Layout) -> list[tuple[int, int, str]] | None:
    """(line, byte offset, text without CR) of the last data lines, up to CUT_WINDOW + 1,
    oldest first; read backwards from the end in steps of :data:`TAIL_BYTES`."""
    want = CUT_WINDOW + 1
    pos = layout.size
    buf = b""
    while True:
        step = min(TAIL_BYTES, pos - layout.data_start)
        pos -= step
        f.seek(pos)
        buf = f.read(step) + buf
        parts = buf.split(b"\n")
        whole = 0 if pos == layout.data_start else 1  # the first part may be a line's end
        if sum(1 for p in parts[whole:] if not _blank(p)) >= want or pos == layout.data_start:
            break
        if len(buf) > TAIL_MAX_BYTES:
            return None  # a tail of blank lines: not worth a special case
    found: list[tuple[int, int, str]] = []
    offset = pos + len(buf)
    line = layout.n_lines
    for part in reversed(parts[whole:]):
        offset -= len(part)
        if not _blank(part):
            found.append((line, offset, part.decode("utf-8").rstrip("\r")))
            if len(found) == want:
                break
        offset -= 1  # its line break
        line -= 1
    return found[::-1]


def _blank(line: bytes) -> bool:
    """Whether a line is blank to the exact reader (``str.strip``: a form feed or a no-break
    space is white space too); an undecodable byte is not."""
    return not line.decode("utf-8", "replace").strip()


_Span = tuple[Path, int, int]
"""A CSV's bytes from its header line to a limit: (path, start, limit)."""


def _read_columns(span: _Span, header: list[str], rows: int) -> list[NDArray[Any]] | None:
    """A CSV's ``span`` (its header line first) parsed into one array per column, or None.

    Types as pandas would infer them: pyarrow's inference on the first block says int64
    (kept, float64 once a cell is missing, as in pandas) or float64 (also for a block of
    missing cells); any other type is the exact reader's. An int64 column that turns out to
    hold non-integers later is read again as float64.
    """
    types = _probe_types(span, header)
    if types is None:
        return None
    for _ in range(len(header) + 1):  # each retry turns one int64 column into float64
        try:
            return _convert(span, header, types, rows)
        except pa.ArrowInvalid as exc:
            name = _widened(str(exc), types)
            if name is None:
                return None
            types[name] = pa.float64()
        except (pa.ArrowException, OSError):
            return None
    return None  # pragma: no cover - every column widened at most once


def _open_csv(src: _Head, header: list[str], types: dict[str, Any] | None) -> Any:
    """pyarrow's streaming CSV reader over ``src``: the header line skipped (its names are
    ours, stripped), pandas' missing-value spellings, ``types`` or inference from block 1."""
    return pa_csv.open_csv(
        src,
        read_options=pa_csv.ReadOptions(
            skip_rows=1, column_names=header, block_size=CSV_BLOCK_BYTES
        ),
        convert_options=pa_csv.ConvertOptions(
            column_types=types,
            null_values=list(PANDAS_NA),
            true_values=list(PANDAS_TRUE),
            false_values=list(PANDAS_FALSE),
        ),
        # The default pool (mimalloc) keeps what the batches freed, some 10 MB more at the
        # peak on a 29 MB file; malloc gives it back and was no slower.
        memory_pool=pa.system_memory_pool(),
    )


def _probe_types(span: _Span, header: list[str]) -> dict[str, Any] | None:
    """Per column, pa.int64(), pa.float64() or pa.bool_() from the first block; None for
    another type."""
    try:
        with _Head(*span) as src:
            reader = _open_csv(src, header, None)
            schema = reader.schema
            reader.close()
    except (pa.ArrowException, OSError):
        return None
    types: dict[str, Any] = {}
    for name, kind in zip(header, schema.types, strict=True):
        if pa.types.is_int64(kind):
            types[name] = pa.int64()
        elif pa.types.is_float64(kind) or pa.types.is_null(kind):
            types[name] = pa.float64()
        elif pa.types.is_boolean(kind):
            types[name] = pa.bool_()
        else:
            return None
    return types


def _convert(
    span: _Span, header: list[str], types: dict[str, Any], rows: int
) -> list[NDArray[Any]] | None:
    """Stream the batches into columns of ``rows`` values; None if the count differs, if a
    cell reads as NaN that pandas would not (``NAN``, ``+nan``: not missing-value spellings), or
    if a float column may be integers beyond int64 (pandas: uint64 or text, pyarrow: float)."""
    dtypes = {"int64": np.int64, "bool": np.bool_}
    out: list[NDArray[Any]] = [
        np.empty(rows, dtypes.get(str(types[h]), np.float64)) for h in header
    ]
    huge = [False] * len(header)
    at = 0
    with _Head(*span) as src:
        reader = _open_csv(src, header, types)
        try:
            for batch in reader:
                m = int(batch.num_rows)
                if at + m > rows:
                    return None
                for i, column in enumerate(batch.columns):
                    if out[i].dtype == np.bool_ and column.null_count:
                        return None  # pandas: an object column of bools and NaN
                    values = column.to_numpy(zero_copy_only=False)  # missing → NaN (float64)
                    if values.dtype.kind == "f":
                        if int(np.count_nonzero(np.isnan(values))) != column.null_count:
                            return None
                        huge[i] = huge[i] or bool(np.any(np.abs(values) >= _INT64_END))
                        if out[i].dtype != np.float64:  # an int64 column with a missing cell
                            out[i] = out[i].astype(np.float64)
                    out[i][at : at + m] = values
                at += m
        finally:
            reader.close()
    if at != rows:
        return None
    for column, big in zip(out, huge, strict=True):
        # Every double beyond 2**63 is a whole number; the column could be integers only if
        # every other value is one too (no NaN: a missing cell makes pandas read floats).
        if big and np.all(np.isfinite(column)) and np.all(column == np.trunc(column)):
            return None
    return out


_INT64_END = 2.0**63
"""Magnitude from which an integer no longer fits an int64 (inf included: it rules nothing
out, the whole column is looked at)."""
_INT_FAILED = re.compile(
    r"In CSV column #(\d+): (?:Row #\d+: )?CSV conversion error to int64: invalid value '(.*)'$",
    re.DOTALL,
)
_INT_TEXT = re.compile(r"\s*[+-]?\d+\s*")


def _widened(message: str, types: dict[str, Any]) -> str | None:
    """The int64 column to read as float64 after pyarrow's conversion error ``message``, or
    None: another error, or an integer pyarrow refuses and pandas reads (``+7``, 2**63)."""
    m = _INT_FAILED.match(message)
    if m is None or _INT_TEXT.fullmatch(m.group(2)):
        return None
    names = list(types)
    k = int(m.group(1))
    if k >= len(names) or not pa.types.is_int64(types[names[k]]):
        return None  # pragma: no cover - pyarrow names the int64 column it was converting
    return names[k]


class _Head(io.RawIOBase):
    """A file's bytes from ``start`` up to ``limit``, as pyarrow or pandas reads a Python file
    object."""

    def __init__(self, path: Path, start: int, limit: int) -> None:
        super().__init__()
        self._file = path.open("rb", buffering=0)
        self._file.seek(start)
        self._left = limit - start

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        n = min(len(buffer), self._left)
        if n <= 0:
            return 0
        got = self._file.readinto(memoryview(buffer)[:n]) or 0
        self._left -= got
        return got

    def close(self) -> None:
        self._file.close()
        super().close()


def _read_csv_streamed(path: Path, label: str, journal: Journal) -> Table | None:
    """A CSV of plain lines parsed by pandas straight from the file, or None.

    For what the typed reader declines but whose lines need no care (:func:`_scan` with
    ``numbers_only=False``: UTF-8, every line but the empty ones with the header's number of
    fields, no line break inside quotes): a text, date or true/false column, quoted or not
    (commas inside quotes too), a cell that is not a number. A file that ends without a line
    break has its last line judged from the file's tail as the exact reader judges it (kept,
    or dropped as cut short and recorded in ``journal``: :func:`_plan_last_line`). The exact
    reader hands the same lines to the same pandas call, only as one string rebuilt in memory;
    here pandas reads the file (about twice its size at the peak, plus the text cells'
    objects). None, for the exact reader, on anything else or a parse pandas refuses (the exact
    reader words the error).
    """
    try:
        with path.open("rb") as f:
            layout = _scan(f, numbers_only=False, label=label)
            if layout is None or not _header_ok(layout.header, label):
                return None
            if layout.ends_with_break:
                plan: _Plan | None = _Plan(layout.size, _data_lines(layout), None, None)
            else:
                plan = _plan_last_line(f, layout)
    except (OSError, UnicodeDecodeError):
        return None
    if plan is None:
        return None
    try:
        with io.BufferedReader(_Head(path, layout.header_start, plan.limit)) as src:
            df: pd.DataFrame = pd.read_csv(src, encoding="utf-8-sig", **_PANDAS_OPTIONS)
    except (pd.errors.ParserError, ValueError, csv.Error, OSError):
        return None
    if len(df) != plan.lines.size or len(df.columns) != len(layout.header):
        return None
    if plan.repair is not None:
        line, fld, detail = plan.repair
        journal.repair(label, line, fld, "dropped truncated last line", detail)
    df.columns = pd.Index(layout.header)
    return Table(label, path, "csv", df, plan.lines, plan.cut)


def _read_csv_exact(path: Path, label: str, journal: Journal) -> Table:
    """The whole file as text, line by line: every error and repair located exactly.

    Slow and memory-hungry (about 2.5× the file at its peak, more for short lines,
    docs/robustness.md, "Memory"): only for the few files the other ways leave to it
    (:func:`_read_csv_lines` reads most of those it used to). The text is let go once split
    into lines, and the lines once written to the file pandas parses (:func:`_body_file`).
    """
    text = _line_breaks(_decode(path, label), label, journal)
    quoted, ends_cr = '"' in text, text.endswith("\r")
    lines = [s.rstrip("\r") for s in text.split("\n")]
    del text
    keep = [i for i, s in enumerate(lines) if s.strip()]
    if not keep:
        raise MissionError(f"{label}: empty file (no header line)", file=label)
    head = keep[0]
    header = [h.strip() for h in next(csv.reader([lines[head]]))]
    _check_header(header, label, head + 1)
    data, cut = _check_field_counts(lines, keep[1:], header, head, quoted, label, journal)
    del keep
    if cut is None and data and data[-1] == len(lines) - 1 and not ends_cr:
        data, cut = _drop_cut_last_line(lines, data, header, quoted, label, journal)
    parsed = [head, *data]
    try:
        body = _body_file(lines, parsed)
    except OSError:  # no room for the temporary file: the body in memory
        body = io.BytesIO("\n".join(lines[i] for i in parsed).encode())
    del lines
    with body:
        df = _parse_csv(body, label)
    rows = np.asarray(data, dtype=np.int64) + 1
    return _exact_table(path, label, df, header, head + 1, rows, cut)


def _line_breaks(text: str, label: str, journal: Journal) -> str:
    """The text with LF or CRLF line breaks as it is. A file whose every line break is a lone
    CR (classic Mac OS) is read with them as line breaks, a repair recorded for the whole
    file; a lone CR among LF line breaks (a CR at the very end excepted: a CRLF file cut short)
    is an error naming its line (docs/robustness.md): pandas and pyarrow would take it for a
    line break, and the lines would no longer be the ones every message names."""
    lone = text.count("\r") - text.count("\r\n")
    if lone == 0:
        return text
    if "\n" not in text:
        _cr_repair(journal, label, lone)
        return text.replace("\r", "\n")
    found = re.search("\r(?!\n)", text.removesuffix("\r"))
    if found is None:
        return text
    line = text.count("\n", 0, found.start()) + 1
    raise MissionError(
        f"{label} line {line}: a carriage return (CR) alone inside the line, among LF line "
        "breaks (a file joined from Mac and Unix parts?): save it with LF or CRLF line breaks",
        file=label,
        line=line,
    )


def _decode(path: Path, label: str) -> str:
    """The file's text (UTF-8, a BOM dropped); MissionError for an unreadable file, binary
    content or another encoding."""
    try:
        with path.open("rb") as f:
            # the probe first: a large binary file is refused without being read whole
            if b"\x00" in f.read(BINARY_PROBE):
                raise MissionError(
                    f"{label}: not a CSV text file (binary content; a Parquet file named .csv?)",
                    file=label,
                )
            f.seek(0)
            raw = f.read()
    except OSError as exc:
        raise MissionError(f"{label}: cannot read ({exc.strerror})", file=label) from None
    raw = raw.removeprefix(BOM)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _not_utf8(raw, exc.start, label) from None


def _not_utf8(raw: bytes, at: int, label: str) -> MissionError:
    """The error for the byte at offset ``at`` of ``raw`` that is not UTF-8: its line, the
    column's name when the header before it reads, the byte and where in the line it is (a
    Latin-1 or Windows-1252 file, most often: a degree sign or an accent in a text cell)."""
    line = raw.count(b"\n", 0, at) + 1
    start = raw.rfind(b"\n", 0, at) + 1
    names: list[str] = []
    if line > 1:
        try:
            header = raw[: raw.index(b"\n")].decode("utf-8").rstrip("\r")
            names = [h.strip() for h in _fields(header, '"' in header)]
        except (UnicodeDecodeError, csv.Error):  # a header that is itself odd: no name
            pass
    return _not_utf8_at(label, line, names, raw[start:at], raw[at])


def _not_utf8_at(label: str, line: int, names: list[str], prefix: bytes, byte: int) -> MissionError:
    """:func:`_not_utf8`'s error for ``byte`` on ``line`` after the line's bytes ``prefix``,
    ``names`` the header's (the column is named when no quote comes before it on the line)."""
    k = prefix.count(b",")
    name = names[k] if line > 1 and k < len(names) and b'"' not in prefix else None
    where = f"{label} line {line}" + (f", {name}" if name else "")
    return MissionError(
        f"{where}: not UTF-8 text (byte 0x{byte:02x}, byte {len(prefix) + 1} of the line; "
        "a Latin-1 or Windows-1252 file? save it as UTF-8)",
        file=label,
        line=line,
        field=name,
    )


def _piece_not_utf8(
    piece: bytes, at: int, first_line: int, names: list[str], label: str
) -> MissionError:
    """:func:`_not_utf8`'s error for the byte at offset ``at`` of ``piece`` (which starts line
    ``first_line``, cut at a line break): the scan's, without the file in memory."""
    start = piece.rfind(b"\n", 0, at) + 1
    line = first_line + piece.count(b"\n", 0, at)
    return _not_utf8_at(label, line, names, piece[start:at], piece[at])


def _fields(line: str, quoted: bool) -> list[str]:
    """The fields of one CSV line (the csv module only when the file has quotes: faster)."""
    return next(csv.reader([line])) if quoted else line.split(",")


def _check_field_counts(
    lines: list[str],
    data: list[int],
    header: list[str],
    head: int,
    quoted: bool,
    label: str,
    journal: Journal,
) -> tuple[list[int], tuple[int, float] | None]:
    """(data line indices, cut): every data line must have the header's number of fields,
    MissionError otherwise, except a short last line (the file cut short), which is dropped
    and recorded (docs/robustness.md)."""
    if quoted:
        counts = _quoted_field_counts(lines, data, label)
    else:
        counts = [lines[i].count(",") + 1 for i in data]
    n = len(header)
    for j, (i, c) in enumerate(zip(data, counts, strict=True)):
        if c == n:
            continue
        if c < n and j == len(data) - 1:
            journal.repair(
                label, i + 1, "", "dropped truncated last line", _short_line(c, n, lines[i])
            )
            return data[:-1], (i + 1, _time_of(_fields(lines[i], quoted)[: c - 1], header))
        raise MissionError(
            f"{label} line {i + 1}: {c} fields, the header (line {head + 1}) has {n}",
            file=label,
            line=i + 1,
        )
    return data, None


def _quoted_field_counts(lines: list[str], data: list[int], label: str) -> list[int]:
    """The number of fields of each data line of a file with quotes, as the csv module reads
    them; MissionError at the first line whose quoted field does not close on it (the csv
    module would join the next line to it, pandas too: the rows would no longer be the lines,
    and a reading's line is what every later message names)."""
    reader = csv.reader(lines[i] for i in data)
    counts: list[int] = []
    try:
        for row in reader:
            if reader.line_num != len(counts) + 1:
                line = data[len(counts)] + 1
                raise MissionError(
                    f"{label} line {line}: a quoted field is not closed on its line (a line "
                    "break inside quotes is not supported)",
                    file=label,
                    line=line,
                )
            counts.append(len(row))
    except csv.Error as exc:  # pragma: no cover - the csv module is lenient by default
        line = data[min(len(counts), len(data) - 1)] + 1
        raise MissionError(f"{label} line {line}: {exc}", file=label, line=line) from None
    return counts


def _drop_cut_last_line(
    lines: list[str],
    data: list[int],
    header: list[str],
    quoted: bool,
    label: str,
    journal: Journal,
) -> tuple[list[int], tuple[int, float] | None]:
    """(data line indices, cut) of a file whose last data line is its last line, without a
    line break after it: it may have been cut inside that line's last field (-0.0979034 →
    -0.0979); blank lines after a data line's line break (spaces, a form feed) leave it whole.
    That line is kept only if the field is as long as the longest of its column on the lines
    before (a fixed-width writer); otherwise dropped and recorded (docs/robustness.md)."""
    last = _fields(lines[data[-1]], quoted)
    before = [len(_fields(lines[i], quoted)[-1].strip()) for i in data[-1 - CUT_WINDOW : -1]]
    detail = _cut_number(last[-1].strip(), before)
    if detail is None:
        return data, None
    journal.repair(label, data[-1] + 1, header[-1], "dropped truncated last line", detail)
    return data[:-1], (data[-1] + 1, _time_of(last[:-1], header))


def _body_file(lines: list[str], rows: list[int]) -> BinaryIO:
    """The lines ``rows`` (the header's first) as UTF-8, one a line, in a temporary file
    (``tempfile``'s folder, ``TMPDIR``) written :data:`BODY_LINES` lines at a time and
    rewound; the caller closes it (which deletes it)."""
    f = tempfile.TemporaryFile(prefix="adaptnav-exact-")  # noqa: SIM115 - the caller's to close
    try:
        for k in range(0, len(rows), BODY_LINES):
            part = "\n".join(lines[i] for i in rows[k : k + BODY_LINES])
            f.write((b"\n" if k else b"") + part.encode())
        f.seek(0)
    except BaseException:
        f.close()
        raise
    return cast(BinaryIO, f)


def _parse_csv(body: BinaryIO, label: str) -> pd.DataFrame:
    """pandas' parse of the checked lines, UTF-8 (floats read exactly: round_trip before
    pandas 3)."""
    try:
        df: pd.DataFrame = pd.read_csv(body, encoding="utf-8", **_PANDAS_OPTIONS)
    except (pd.errors.ParserError, ValueError, csv.Error) as exc:
        raise MissionError(f"{label}: cannot parse as CSV ({exc})", file=label) from None
    return df


def _time_of(complete: list[str], header: list[str]) -> float:
    """``t_s`` of a truncated line from its complete fields (NaN if it is not among them)."""
    if TIME_COLUMN not in header:
        return math.nan
    k = header.index(TIME_COLUMN)
    try:
        return float(complete[k]) if k < len(complete) else math.nan
    except ValueError:
        return math.nan


# --- columns ------------------------------------------------------------------------------------


def deg_variant(column: str) -> str | None:
    """The degree spelling of an angle column (``lat_rad`` → ``lat_deg``), or None."""
    return column.replace("_rad", "_deg", 1) if "_rad" in column else None


def present(df_columns: Sequence[str], column: str) -> bool:
    """Whether ``column`` or its degree variant (``*_deg*``) is among ``df_columns``."""
    alt = deg_variant(column)
    return column in df_columns or (alt is not None and alt in df_columns)


def looks_like(columns: Sequence[str]) -> list[str]:
    """The kinds of table whose measurement columns are all in ``columns``."""
    return [k for k, cols in STREAM_COLUMNS.items() if all(present(columns, c) for c in cols)]


def numeric(table: Table, column: str) -> Array:
    """A column as float64; a cell that is not a number is an error naming line and field.

    Empty cells (and NA spellings) become NaN; what NaN means is the caller's policy.
    """
    s = table.df[column]
    if pd.api.types.is_datetime64_any_dtype(s) or pd.api.types.is_timedelta64_dtype(s):
        raise MissionError(
            f"{table.label}, {column}: a date/time column; give plain float seconds",
            file=table.label,
            field=column,
        )
    if pd.api.types.is_bool_dtype(s) or _all_bool(s):
        raise MissionError(
            f"{table.label}, {column}: a true/false column where a number is expected (it would "
            "read as 0 and 1); wrong column?",
            file=table.label,
            field=column,
        )
    if pd.api.types.is_complex_dtype(s):
        raise MissionError(
            f"{table.label}, {column}: a complex-number column where a real number is expected",
            file=table.label,
            field=column,
        )
    if pd.api.types.is_numeric_dtype(s):
        values = np.asarray(s.to_numpy(dtype=float, na_value=np.nan), dtype=float)
        if column == TIME_COLUMN and s.dtype == np.float32:
            _check_float32_time(table, values)
        return values
    text = s.astype("string").str.strip()
    text = text.where(text != "")
    conv = pd.to_numeric(text, errors="coerce")
    bad = np.flatnonzero((conv.isna() & text.notna() & (text != "")).to_numpy(dtype=bool))
    if bad.size:
        r = int(bad[0])
        raise table.error(r, column, f"value {show(s.iloc[r])} is not a number")
    return np.asarray(conv.to_numpy(dtype=float, na_value=np.nan), dtype=float)


FLOAT32_TIME_STEP_S = 1e-3
"""A float32 time column is refused when its spacing near the largest time exceeds this."""


def _check_float32_time(table: Table, t: Array) -> None:
    """A time column stored as float32 holds 24 bits: near 1.7e9 s (Unix time) its values are
    128 s apart. Beyond :data:`FLOAT32_TIME_STEP_S` of spacing it is an error naming the file
    (up to 0.4.4 read as it was: readings rounded onto one another dropped as duplicates, the
    rest stamped a minute off)."""
    top = float(np.nanmax(np.abs(t))) if np.isfinite(t).any() else 0.0
    step = float(np.spacing(np.float32(top)))
    if step > FLOAT32_TIME_STEP_S:
        raise MissionError(
            f"{table.label}, {TIME_COLUMN}: stored as float32, whose values near {top:.6g} s are "
            f"{step:.3g} s apart: store the times as float64",
            file=table.label,
            field=TIME_COLUMN,
        )


def flag(table: Table, column: str) -> NDArray[np.bool_]:
    """A status column as booleans: true/false, or the numbers 1 and 0; anything else (a
    missing cell too: a status the driver did not give is not a "locked") is an error naming
    line and field."""
    if column not in table.df.columns:
        raise MissionError(
            f"{table.label}: status column {column!r} not found; found {list(table.df.columns)}",
            file=table.label,
            field=column,
        )
    s = table.df[column]
    if pd.api.types.is_bool_dtype(s) or _all_bool(s):
        missing = np.flatnonzero(s.isna().to_numpy(dtype=bool))
        if missing.size:
            raise table.error(int(missing[0]), column, "status missing (not 1/0 or true/false)")
        return np.asarray(s.to_numpy(dtype=bool))
    text = s.astype("string").str.strip().str.lower()
    ok = text.isin(["1", "0", "1.0", "0.0", "true", "false"]).to_numpy(dtype=bool)
    if not ok.all():
        r = int(np.flatnonzero(~ok)[0])
        raise table.error(r, column, f"status {show(s.iloc[r])} is not 1/0 or true/false")
    return np.asarray(text.isin(["1", "1.0", "true"]).to_numpy(dtype=bool))


def _all_bool(s: pd.Series) -> bool:
    """An object column whose non-missing cells are all Python/NumPy bools (nullable bools)."""
    if s.dtype != object:
        return False
    cells = s.dropna()
    return len(cells) > 0 and all(isinstance(v, bool | np.bool_) for v in cells)


def take_columns(
    table: Table, columns: Sequence[str], stream: str, journal: Journal
) -> tuple[Array, Array, list[str]]:
    """``t_s`` (n,), the measurement ``columns`` (n, d) in SI units (degrees → radians) and the
    names of the file's columns they came from.

    A missing column is an error listing the missing and the found columns (and what the table
    looks like, if it matches another kind); columns not used are logged once and kept in the
    DataFrame.
    """
    names = list(table.df.columns)
    wanted = [TIME_COLUMN, *columns]
    missing = [c for c in wanted if not present(names, c)]
    if missing:
        hint = looks_like(names)
        extra = f"; it looks like a {' / '.join(hint)} table" if hint else ""
        if len(names) == 1 and any(sep in names[0] for sep in ";\t"):
            extra = "; the separator must be a comma"
        raise MissionError(
            f"{table.label} ({stream}): missing column(s) {missing}; found {names}{extra}",
            file=table.label,
            field=missing[0],
        )
    used: list[str] = []
    values: list[Array] = []
    for c in wanted:
        if c in names:
            values.append(numeric(table, c))
            used.append(c)
            continue
        alt = deg_variant(c)
        assert alt is not None
        values.append(numeric(table, alt) * DEG)
        used.append(alt)
        journal.repair(
            table.label, None, alt, "converted degrees", f"{alt} → {c} (× π/180)", logging.INFO
        )
    extra_cols = [c for c in names if c not in used]
    if extra_cols:
        log.info("%s (%s): extra columns kept, not used: %s", table.label, stream, extra_cols)
    t = values[0]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        r = int(bad[0])
        raise table.error(r, TIME_COLUMN, f"time {show(table.df[used[0]].iloc[r])} is not finite")
    z = np.column_stack(values[1:]) if len(values) > 1 else np.empty((t.size, 0))
    return t, z, used


def check_order(table: Table, t: Array, rows: NDArray[np.int64] | None = None) -> None:
    """Timestamps must not decrease; the error names the first offending line and both times."""
    back = np.flatnonzero(np.diff(t) < 0.0)
    if back.size:
        k = int(back[0])
        r0, r1 = (k, k + 1) if rows is None else (int(rows[k]), int(rows[k + 1]))
        raise table.error(
            r1,
            TIME_COLUMN,
            f"time goes backwards: t = {show(t[k + 1])} s after t = {show(t[k])} s at "
            f"{table.where(r0)} (timestamps must be in increasing order)",
        )


def write_table(df: pd.DataFrame, path: Path) -> None:
    """Write ``df`` as CSV or Parquet (by extension, :func:`write_parquet`), without the index."""
    if table_format(path) == "csv":
        df.to_csv(path, index=False)
    else:
        write_parquet(df, path)


def write_parquet(table: pd.DataFrame, path: Path) -> None:
    """Write ``table`` as Parquet (snappy, no index) with a dictionary for its text columns
    only: names (sensor, fate, reason) repeat and shrink by one, but measured numbers rarely
    repeat, and trying a dictionary on each float column took half to two thirds of the
    writing time and left the files larger. The table reads back the same."""
    text = [str(c) for c in table.columns if not pd.api.types.is_numeric_dtype(table[c])]
    table.to_parquet(path, index=False, use_dictionary=text)
