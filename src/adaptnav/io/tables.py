"""Reading the mission's tables (CSV or Parquet, by extension) with file/line-precise errors.

A :class:`Table` keeps the whole DataFrame as read (extra columns included) and, per data row,
where it is in the file: the 1-based CSV line (header = line 1; blank lines are skipped but
counted) or the 0-based Parquet row. Values are turned into float arrays column by column, so
a bad cell is reported as ``imu.csv line 7, gyro_x_rad_s: 'abc' is not a number`` and never as
a traceback from NumPy or pandas. Policy (error or logged repair) is docs/data-format.md.
"""

from __future__ import annotations

import csv
import io
import logging
import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.io.config import SENSOR_COLUMNS, MissionError
from adaptnav.units import DEG

log = logging.getLogger("adaptnav.io")

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
_LOG_CAP = 10
"""Repairs of one kind logged one by one per file; the rest are summarised (all are recorded)."""
CUT_WINDOW = 100
"""Lines before the last whose last field's length is compared with the last one's, in a CSV
that does not end with a line break (a cut number is shorter)."""


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
    """Collects repairs and dropped rows while loading, and logs them (logger ``adaptnav.io``)."""

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
    return "line" if file.lower().endswith(".csv") else "row"


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
        df = pd.read_parquet(path)
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
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MissionError(f"{label}: cannot read ({exc.strerror})", file=label) from None
    if b"\x00" in raw[:65536]:
        raise MissionError(
            f"{label}: not a CSV text file (binary content; a Parquet file named .csv?)", file=label
        )
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise MissionError(
            f"{label}: not UTF-8 text (bad byte at offset {exc.start}); not a CSV file?", file=label
        ) from None
    lines = [s.rstrip("\r") for s in text.split("\n")]
    keep = [i for i, s in enumerate(lines) if s.strip()]
    if not keep:
        raise MissionError(f"{label}: empty file (no header line)", file=label)
    head = keep[0]
    header = [h.strip() for h in next(csv.reader([lines[head]]))]
    _check_header(header, label, head + 1)
    data = keep[1:]
    quoted = '"' in text

    def fields(i: int) -> list[str]:
        return next(csv.reader([lines[i]])) if quoted else lines[i].split(",")

    if quoted:
        counts = [len(r) for r in csv.reader(lines[i] for i in data)]
    else:
        counts = [lines[i].count(",") + 1 for i in data]
    n = len(header)
    cut: tuple[int, float] | None = None
    for j, (i, c) in enumerate(zip(data, counts, strict=True)):
        if c == n:
            continue
        if c < n and j == len(data) - 1:
            journal.repair(
                label,
                i + 1,
                "",
                "dropped truncated last line",
                f"{c} of {n} fields: {lines[i][:60]!r}",
            )
            cut = (i + 1, _time_of(fields(i)[: c - 1], header))
            data = data[:-1]
            break
        raise MissionError(
            f"{label} line {i + 1}: {c} fields, the header (line {head + 1}) has {n}",
            file=label,
            line=i + 1,
        )
    if cut is None and data and not text.endswith(("\n", "\r")):
        # No line break at the end: the file may have been cut inside the last line's last
        # field (-0.0979034 → -0.0979). Kept only if that field is as long as the longest of
        # its column on the lines before (a fixed-width writer); otherwise dropped.
        last = fields(data[-1])
        before = [len(fields(i)[-1].strip()) for i in data[-1 - CUT_WINDOW : -1]]
        value = last[-1].strip()
        if not before or len(value) < max(before):
            journal.repair(
                label,
                data[-1] + 1,
                header[-1],
                "dropped truncated last line",
                f"the file ends without a line break and the last value {value!r} is shorter "
                f"than its column's ({max(before, default=0)} characters): cut mid-number?",
            )
            cut = (data[-1] + 1, _time_of(last[:-1], header))
            data = data[:-1]
    body = "\n".join([lines[head], *(lines[i] for i in data)])
    try:
        if _OLD_PANDAS:
            df = pd.read_csv(
                io.StringIO(body),
                low_memory=False,
                skipinitialspace=True,
                float_precision="round_trip",
            )
        else:
            df = pd.read_csv(io.StringIO(body), low_memory=False, skipinitialspace=True)
    except (pd.errors.ParserError, ValueError, csv.Error) as exc:
        raise MissionError(f"{label}: cannot parse as CSV ({exc})", file=label) from None
    df.columns = pd.Index(header)
    if len(df) != len(data):  # pragma: no cover - guarded by the field count above
        raise MissionError(f"{label}: CSV rows do not match its lines (quoted newlines?)")
    return Table(label, path, "csv", df, np.asarray(data, dtype=np.int64) + 1, cut)


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
        return np.asarray(s.to_numpy(dtype=float, na_value=np.nan), dtype=float)
    text = s.astype("string").str.strip()
    text = text.where(text != "")
    conv = pd.to_numeric(text, errors="coerce")
    bad = np.flatnonzero((conv.isna() & text.notna() & (text != "")).to_numpy(dtype=bool))
    if bad.size:
        r = int(bad[0])
        raise table.error(r, column, f"value {show(s.iloc[r])} is not a number")
    return np.asarray(conv.to_numpy(dtype=float, na_value=np.nan), dtype=float)


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
    """Write ``df`` as CSV or Parquet (by extension), without the index."""
    if table_format(path) == "csv":
        df.to_csv(path, index=False)
    else:
        df.to_parquet(path, index=False)
