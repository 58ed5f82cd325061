"""CSV memory benchmark: ``.venv/bin/python bench/csv_bench.py`` (part of ``make bench``).

Writes an IMU-like CSV (1 M rows at 200 Hz, ``t_s`` and six increment columns, as pandas
writes them: Python's shortest repr, about 140 MB) into a temporary folder and measures, each
in a fresh subprocess, the peak resident memory above that process's own baseline (interpreter
and imports, measured just before) and the wall time (best of :data:`REPEATS`) of:

- ``adaptnav.mission.tables.read_table`` (the typed, streaming reader for such a file);
- ``pandas.read_csv`` on the same file (the baseline the issue names);
- the exact, text-based reader (``_read_csv_exact``: how every CSV was read before the typed
  reader, now only for the files it declines);
- ``adaptnav.mission.load_mission`` on a mission whose ``imu.csv`` is that file (format
  ``increments``, plus a DVL table): reading, column checks and the IMU's intervals;
- ``read_table`` on the same table with a true/false column added (``flagged.csv``: a
  status column, as a DVL's bottom-lock flag);
- ``read_table`` on the same table with a text column added (``stamped.csv``: each sample's
  UTC time as ISO 8601 text, as loggers write it): the typed reader declines it, pandas reads
  it from the file (the streamed reader);
- the exact reader on that file, for comparison;
- ``read_table`` on that file with a status text that has a comma in it on every line
  (``quoted.csv``: ``"bottom lock, 4 beams"``, quoted by pandas): the streamed reader counts
  those lines' fields with the csv module (the worst case for it: every line);
- ``read_table`` on ``imu.csv`` with a blank first line (``blank-first.csv``: the header on
  line 2), which leaves it to the exact reader's rules: read line by line (up to 0.4.3, by the
  exact reader);
- ``read_table`` on ``quoted.csv`` with a line break inside the quotes of line
  :data:`DAMAGED_LINE` (``quoted-break.csv``), and on ``quoted.csv`` with that line cut after
  its fourth field (``quoted-damaged.csv``): the errors naming that line, found line by line
  (up to 0.4.3, by the exact reader);
- ``read_table`` on ``imu.csv`` with line :data:`DAMAGED_LINE` cut after its fourth field
  (``damaged.csv``: a logger that lost the end of a line and went on): the error naming that
  line, found by the streamed reader's scan (up to 0.3.5, by the exact reader);
- ``read_table`` on ``imu.csv`` with every line break a lone CR (``mac.csv``: classic Mac OS),
  read from a temporary LF copy (up to 0.3.7, by the exact reader);
- ``read_table`` on ``imu.csv`` with one lone CR inside line :data:`DAMAGED_LINE`
  (``stray.csv``: a file joined from Mac and Unix parts): the error naming that line, found
  piece by piece (up to 0.3.9, by the exact reader);
- ``read_table`` on ``imu.csv`` with a line holding a form feed inserted before line
  :data:`DAMAGED_LINE` (``formfeed.csv``: blank to the exact reader, a row to pandas), read
  from a temporary copy with that line emptied (up to 0.3.9, by the exact reader);
- ``read_table`` on the IMU table written as Parquet but named ``binary.csv``: the "not a CSV
  text file" error (up to 0.3.7 after reading the whole file into memory).

The file is written in a subprocess too, so that this process stays small: on Linux a child
inherits its parent's ``ru_maxrss``, hence the peak is read from ``VmHWM`` where there is one.

Issue 12 asks for a CSV's peak ≤ 3× its size. Figures: docs/robustness.md, "Memory".
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROWS = 1_000_000
"""IMU samples in the file: 83 min at 200 Hz, about 140 MB of CSV."""
RATE_HZ = 200.0
MB = 2**20
READERS = (
    "read_table",
    "pandas",
    "exact",
    "load_mission",
    "read_table_bool",
    "read_table_text",
    "exact_text",
    "read_table_quoted",
    "read_table_blank_first",
    "read_table_narrow",
    "read_table_quoted_break",
    "read_table_quoted_damaged",
    "read_table_damaged",
    "read_table_cr",
    "read_table_stray_cr",
    "read_table_formfeed",
    "read_table_binary",
)
"""What is measured, one subprocess each (see the module docstring)."""
DAMAGED_LINE = 900_001
"""The line of ``damaged.csv`` with 4 of its 7 fields."""
REPEATS = 2
"""Runs of each reader, round-robin: the shortest time is kept (the peak hardly varies: the
largest is kept)."""


def _peak_rss_mb() -> float:
    """This process's peak resident memory (MB): ``VmHWM`` (Linux), else ``ru_maxrss``."""
    status = Path("/proc/self/status")
    if status.is_file():
        for line in status.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 2**10  # kB
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / MB if sys.platform == "darwin" else rss / 2**10  # bytes on macOS, else KiB


def write_mission(root: Path, rows: int = ROWS, seed: int = 0) -> Path:
    """A mission folder: ``imu.csv`` (``rows`` increments of a vessel at rest, with noise), a
    3 Hz ``dvl.csv`` over the same time and ``mission.toml``; returns the IMU file."""
    import numpy as np
    import pandas as pd

    from adaptnav.mission import parse_config, write_config

    rng = np.random.default_rng(seed)
    dt = 1.0 / RATE_HZ
    t = dt * np.arange(1, rows + 1)
    imu = pd.DataFrame(
        {
            "t_s": t,
            **{f"dtheta_{a}_rad": rng.normal(0.0, 1e-5, rows) for a in "xyz"},
            "dvel_x_m_s": rng.normal(0.0, 1e-3, rows),
            "dvel_y_m_s": rng.normal(0.0, 1e-3, rows),
            "dvel_z_m_s": -9.81 * dt + rng.normal(0.0, 1e-3, rows),
        }
    )
    root.mkdir(parents=True, exist_ok=True)
    imu.to_csv(root / "imu.csv", index=False)
    text = (root / "imu.csv").read_bytes()
    start, line = _line_at(text, DAMAGED_LINE)
    (root / "damaged.csv").write_bytes(
        text[:start] + b",".join(line.split(b",")[:4]) + text[start + len(line) :]
    )
    (root / "stray.csv").write_bytes(
        text[:start] + line.replace(b",", b"\r", 1) + text[start + len(line) :]
    )
    (root / "formfeed.csv").write_bytes(text[:start] + b"\x0c\n" + text[start:])
    (root / "blank-first.csv").write_bytes(b"\n" + text)
    (root / "mac.csv").write_bytes(text.replace(b"\n", b"\r"))
    del text
    imu.to_parquet(root / "binary.csv")
    imu["valid"] = rng.random(rows) > 0.01
    imu.to_csv(root / "flagged.csv", index=False)
    imu = imu.drop(columns="valid")
    start = pd.Timestamp("2026-12-03T07:00:00", tz="UTC")
    imu.insert(1, "utc", (start + pd.to_timedelta(t, unit="s")).strftime("%Y-%m-%dT%H:%M:%S.%fZ"))
    imu.to_csv(root / "stamped.csv", index=False)
    imu["status"] = np.where(rng.random(rows) < 0.99, "bottom lock, 4 beams", "lost, 0 beams")
    imu.to_csv(root / "quoted.csv", index=False)
    text = (root / "quoted.csv").read_bytes()
    start, line = _line_at(text, DAMAGED_LINE)
    (root / "quoted-break.csv").write_bytes(
        text[:start] + line.replace(b", ", b"\n", 1) + text[start + len(line) :]
    )
    (root / "quoted-damaged.csv").write_bytes(
        text[:start] + b",".join(line.split(b",")[:4]) + text[start + len(line) :]
    )
    del text
    imu = imu.drop(columns="status")
    n_dvl = int(t[-1] * 3.0)
    dvl = pd.DataFrame(
        {
            "t_s": np.arange(1, n_dvl + 1) / 3.0,
            "vx_m_s": rng.normal(0.0, 0.01, n_dvl),
            "vy_m_s": rng.normal(0.0, 0.01, n_dvl),
            "vz_m_s": rng.normal(0.0, 0.01, n_dvl),
        }
    )
    dvl.to_csv(root / "dvl.csv", index=False)
    n_depth = 2 * rows  # a depth meter's two short columns: 15 bytes a line
    depth = pd.DataFrame(
        {"t_s": np.arange(1, n_depth + 1) / RATE_HZ, "depth_m": rng.normal(10.0, 1.0, n_depth)}
    )
    depth.to_csv(root / "narrow.csv", index=False, float_format="%.3f")
    config = {
        "mission": {"name": "csv-bench"},
        "imu": {
            "file": "imu.csv",
            "format": "increments",
            "rate_hz": RATE_HZ,
            "noise": {"arw": [0.0667, "deg/sqrt(h)"], "vrw": [55, "ug/sqrt(Hz)"]},
        },
        "sensors": {"dvl": {"kind": "dvl", "file": "dvl.csv", "sigma": [0.02, "m/s"]}},
        "initial": {"lat_deg": 26.8, "lon_deg": 56.0},
    }
    write_config(parse_config(config), root / "mission.toml")
    return root / "imu.csv"


def _line_at(text: bytes, number: int) -> tuple[int, bytes]:
    """Where line ``number`` of ``text`` starts, and the line (without its line break)."""
    start = 0
    for _ in range(number - 1):
        start = text.index(b"\n", start) + 1
    return start, text[start : text.index(b"\n", start)]


def measure(reader: str, imu_csv: Path) -> dict[str, float]:
    """Peak RSS above this process's baseline (MB) and seconds of one ``reader`` run."""
    import pandas as pd

    from adaptnav.mission import load_mission
    from adaptnav.mission import tables as tb

    base = _peak_rss_mb()
    t0 = time.perf_counter()
    if reader == "read_table":
        tb.read_table(imu_csv, imu_csv.name, tb.Journal())
    elif reader == "read_table_bool":
        flagged = imu_csv.parent / "flagged.csv"
        tb.read_table(flagged, flagged.name, tb.Journal())
    elif reader == "read_table_text":
        stamped = imu_csv.parent / "stamped.csv"
        tb.read_table(stamped, stamped.name, tb.Journal())
    elif reader == "read_table_quoted":
        quoted = imu_csv.parent / "quoted.csv"
        tb.read_table(quoted, quoted.name, tb.Journal())
    elif reader == "read_table_blank_first":
        blank = imu_csv.parent / "blank-first.csv"
        table = tb.read_table(blank, blank.name, tb.Journal())
        assert len(table.df) == ROWS and int(table.lines[0]) == 3, table.lines[:1]
    elif reader == "read_table_narrow":
        narrow = imu_csv.parent / "narrow.csv"
        table = tb.read_table(narrow, narrow.name, tb.Journal())
        assert len(table.df) == 2 * ROWS, len(table.df)
    elif reader == "read_table_quoted_break":
        _refused(imu_csv.parent / "quoted-break.csv", f" line {DAMAGED_LINE}: a quoted field")
    elif reader == "read_table_quoted_damaged":
        _refused(imu_csv.parent / "quoted-damaged.csv", f" line {DAMAGED_LINE}: 4 fields")
    elif reader == "read_table_damaged":
        _refused(imu_csv.parent / "damaged.csv", f" line {DAMAGED_LINE}: 4 fields")
    elif reader == "read_table_cr":
        mac = imu_csv.parent / "mac.csv"
        journal = tb.Journal()
        tb.read_table(mac, mac.name, journal)
        assert journal.repairs[0].action == "read CR line breaks as line breaks"
    elif reader == "read_table_stray_cr":
        _refused(imu_csv.parent / "stray.csv", f" line {DAMAGED_LINE}: a carriage return")
    elif reader == "read_table_formfeed":
        formfeed = imu_csv.parent / "formfeed.csv"
        table = tb.read_table(formfeed, formfeed.name, tb.Journal())
        assert len(table.df) == ROWS and table.where(DAMAGED_LINE - 2) == (
            f"formfeed.csv line {DAMAGED_LINE + 1}"
        ), table.where(DAMAGED_LINE - 2)
    elif reader == "read_table_binary":
        _refused(imu_csv.parent / "binary.csv", ": not a CSV text file")
    elif reader == "exact_text":
        stamped = imu_csv.parent / "stamped.csv"
        tb._read_csv_exact(stamped, stamped.name, tb.Journal())
    elif reader == "pandas":
        pd.read_csv(imu_csv)
    elif reader == "exact":
        tb._read_csv_exact(imu_csv, imu_csv.name, tb.Journal())
    else:
        load_mission(imu_csv.parent)
    return {"peak_mb": _peak_rss_mb() - base, "seconds": time.perf_counter() - t0}


def _refused(path: Path, error: str) -> None:
    """``read_table`` of ``path`` must be refused with a MissionError that starts with the
    file's name and then ``error``."""
    from adaptnav.mission import MissionError
    from adaptnav.mission import tables as tb

    try:
        tb.read_table(path, path.name, tb.Journal())
    except MissionError as exc:
        assert str(exc).startswith(path.name + error), exc
    else:
        raise AssertionError(f"{path.name} was read")


def _in_subprocess(*args: str) -> dict[str, float]:
    """Run this file with ``args`` in a fresh interpreter; its last output line, as JSON."""
    out = subprocess.run(
        [sys.executable, __file__, *args], check=True, capture_output=True, text=True
    ).stdout
    return dict(json.loads(out.strip().splitlines()[-1]))


def bench_csv_memory() -> list[str]:
    """Print and return the ``csv memory:`` lines."""
    with tempfile.TemporaryDirectory() as tmp:
        imu_csv = Path(tmp) / "mission" / "imu.csv"
        written = _in_subprocess("write", str(imu_csv.parent))["seconds"]
        os.sync()  # the file's pages written out now, not while a reader is timed
        size = imu_csv.stat().st_size / MB
        size_flagged = (imu_csv.parent / "flagged.csv").stat().st_size / MB
        size_stamped = (imu_csv.parent / "stamped.csv").stat().st_size / MB
        size_quoted = (imu_csv.parent / "quoted.csv").stat().st_size / MB
        size_binary = (imu_csv.parent / "binary.csv").stat().st_size / MB
        size_narrow = (imu_csv.parent / "narrow.csv").stat().st_size / MB
        got = {r: {"peak_mb": 0.0, "seconds": math.inf} for r in READERS}
        for _ in range(REPEATS):
            for r in READERS:
                run = _in_subprocess("measure", r, str(imu_csv))
                got[r]["peak_mb"] = max(got[r]["peak_mb"], run["peak_mb"])
                got[r]["seconds"] = min(got[r]["seconds"], run["seconds"])

    def peak(r: str, of: float = size) -> str:
        mb, seconds = got[r]["peak_mb"], got[r]["seconds"]
        return f"{mb:.0f} MB above baseline ({mb / of:.2f}× the file), {seconds:.1f} s"

    lines = [
        f"csv memory: {size:.0f} MB file ({ROWS:,} rows × 7, written in {written:.0f} s) → "
        f"read_table peak {peak('read_table')}; pandas.read_csv {peak('pandas')}",
        f"csv memory: exact reader (the reference; now only for the few files every other way "
        f"declines) "
        f"peak {peak('exact')}",
        f"csv memory: load_mission with that imu.csv (increments) peak {peak('load_mission')}",
        f"csv memory: the same with a true/false column ({size_flagged:.0f} MB) → read_table "
        f"peak {peak('read_table_bool', size_flagged)}",
        f"csv memory: the same with an ISO 8601 time column ({size_stamped:.0f} MB) → read_table "
        f"peak {peak('read_table_text', size_stamped)}; exact reader "
        f"{peak('exact_text', size_stamped)}",
        f"csv memory: the same with a quoted status text with a comma on every line "
        f"({size_quoted:.0f} MB) → read_table peak {peak('read_table_quoted', size_quoted)}",
        f"csv memory: that imu.csv with a blank first line → read_table peak "
        f"{peak('read_table_blank_first')}",
        f"csv memory: a depth table of {2 * ROWS:,} lines t_s,depth_m ({size_narrow:.0f} MB, "
        f"15 bytes a line) → read_table peak {peak('read_table_narrow', size_narrow)}",
        f"csv memory: the quoted file with a line break inside the quotes of line "
        f"{DAMAGED_LINE:,} → read_table's error naming it, peak "
        f"{peak('read_table_quoted_break', size_quoted)}; with that line cut after 4 fields, "
        f"{peak('read_table_quoted_damaged', size_quoted)}",
        f"csv memory: that imu.csv with line {DAMAGED_LINE:,} cut after 4 fields → read_table's "
        f"error naming it, peak {peak('read_table_damaged')}",
        f"csv memory: that imu.csv with lone-CR line breaks (classic Mac OS) → read_table peak "
        f"{peak('read_table_cr')}",
        f"csv memory: that imu.csv with a lone CR inside line {DAMAGED_LINE:,} → read_table's "
        f"error naming it, peak {peak('read_table_stray_cr')}",
        f"csv memory: that imu.csv with a form-feed line before line {DAMAGED_LINE:,} → "
        f"read_table peak {peak('read_table_formfeed')}",
        f"csv memory: the IMU table as Parquet named binary.csv ({size_binary:.0f} MB) → "
        f"read_table's error, peak {peak('read_table_binary', size_binary)}",
    ]
    for line in lines:
        print(line, flush=True)
    return lines


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "measure":
        print(json.dumps(measure(sys.argv[2], Path(sys.argv[3]))))
    elif len(sys.argv) == 3 and sys.argv[1] == "write":
        t0 = time.perf_counter()
        write_mission(Path(sys.argv[2]))
        print(json.dumps({"seconds": time.perf_counter() - t0}))
    else:
        bench_csv_memory()
