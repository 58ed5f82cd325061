"""CSV tables: the typed, the streamed and the exact reader give the same table (issue 12).

docs/robustness.md, "Memory": a CSV of numbers is streamed by pyarrow into NumPy columns;
another CSV of plain lines (a text or date column) is parsed by pandas from the file; any
other, and any with something to report, is read by the exact, text-based reader. These tests
hold the first two to the exact one (values bit for bit, dtypes, lines, repairs, errors) and
check that a clean file takes the typed way, a plain one with text the streamed way. Most
shrink the block and scan sizes so that a few kilobytes cross several blocks; memory is
measured by ``make bench``, not here.
"""

from __future__ import annotations

import csv
import logging
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adaptnav.mission import MissionError
from adaptnav.mission import tables as tb

EXACT = tb._read_csv_exact
"""The exact reader, for comparison where :func:`typed_only` replaces it in the module."""
SMALL = {"CSV_BLOCK_BYTES": 4096, "SCAN_BYTES": 1000, "TAIL_BYTES": 300}
"""Block, scan and tail sizes that make a file of a few hundred lines cross several of each."""
PANDAS_LIKE = {"skipinitialspace": True, "low_memory": False}
"""How the exact reader calls pandas.read_csv (pandas 3 parses floats exactly by default)."""


@pytest.fixture()
def small(monkeypatch: pytest.MonkeyPatch) -> None:
    for name, value in SMALL.items():
        monkeypatch.setattr(tb, name, value)


@pytest.fixture()
def typed_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail if the exact reader runs: the file must be read by the typed one."""

    def refuse(*_args: Any) -> tb.Table:
        raise AssertionError("the exact reader was used")

    monkeypatch.setattr(tb, "_read_csv_exact", refuse)


@pytest.fixture()
def streamed_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail if the typed or the exact reader reads the file: it must be the streamed one."""

    def refuse(*_args: Any) -> tb.Table:
        raise AssertionError("the exact reader was used")

    typed = tb._read_csv_typed

    def must_decline(path: Path, label: str, journal: tb.Journal) -> tb.Table | None:
        table = typed(path, label, journal)
        assert table is None, "the typed reader read it"
        return table

    monkeypatch.setattr(tb, "_read_csv_exact", refuse)
    monkeypatch.setattr(tb, "_read_csv_typed", must_decline)


@pytest.fixture()
def declined(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Records, per read, whether the typed reader declined the file (left it to the exact)."""
    calls: list[bool] = []
    typed = tb._read_csv_typed

    def spy(path: Path, label: str, journal: tb.Journal) -> tb.Table | None:
        table = typed(path, label, journal)
        calls.append(table is None)
        return table

    monkeypatch.setattr(tb, "_read_csv_typed", spy)
    return calls


def read(path: Path) -> tuple[tb.Table, list[tb.Repair]]:
    journal = tb.Journal()
    return tb.read_table(path, path.name, journal), journal.repairs


def outcome(reader: Any, path: Path) -> tuple[tb.Table | None, list[tb.Repair], str | None]:
    journal = tb.Journal()
    try:
        return reader(path, path.name, journal), journal.repairs, None
    except MissionError as exc:
        return None, journal.repairs, str(exc)


def agrees_with_exact(reader: Any, path: Path) -> tuple[bool, str | None]:
    """(whether ``reader`` read the file or reported an error, its error): whenever it did,
    the exact reader gives the same error, or the same table and repairs."""
    a, repairs_a, error_a = outcome(reader, path)
    if a is None and error_a is None:
        return False, None
    b, repairs_b, error_b = outcome(EXACT, path)
    assert error_a == error_b, path.read_bytes()
    if a is not None:
        assert b is not None
        assert_same_table(a, b)
        assert repairs_a == repairs_b
    return True, error_a


def assert_same_table(a: tb.Table, b: tb.Table) -> None:
    """Same columns, dtypes and values (NaN where NaN, the sign of zero), lines and cut."""
    pd.testing.assert_frame_equal(a.df, b.df, check_exact=True)
    for c in a.df.columns:
        x, y = a.df[c].to_numpy(), b.df[c].to_numpy()
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(np.signbit(x), np.signbit(y), err_msg=c)
    np.testing.assert_array_equal(a.lines, b.lines)
    assert (a.cut is None) == (b.cut is None)
    if a.cut is not None and b.cut is not None:
        assert a.cut[0] == b.cut[0]
        assert a.cut[1] == b.cut[1] or (math.isnan(a.cut[1]) and math.isnan(b.cut[1]))


def test_missing_value_spellings_are_pandas_defaults() -> None:
    from pandas._libs.parsers import STR_NA_VALUES

    assert set(tb.PANDAS_NA) == set(STR_NA_VALUES)


# --- a clean file: the typed reader, values as pandas reads them ------------------------------


def _numbers(rng: np.random.Generator, n: int) -> list[str]:
    """Cells as writers write them: repr floats over 40 decades, negative zero, integers without
    a point, long and exponent forms, leading spaces, empty cells, infinities."""
    x = rng.normal(size=n) * 10.0 ** rng.integers(-20, 20, n)
    cells = [repr(float(v)) for v in x]
    kind = rng.integers(0, 20, n)
    for i in np.flatnonzero(kind == 0):
        cells[i] = "-0.0" if i % 2 else "-0"
    for i in np.flatnonzero(kind == 1):
        cells[i] = str(int(x[i] * 1e3) % 100000)
    for i in np.flatnonzero(kind == 2):
        cells[i] = f"{x[i]:.25e}" if i % 2 else f"{x[i]:.12E}"
    for i in np.flatnonzero(kind == 3):
        cells[i] = "  " + cells[i]
    for i in np.flatnonzero(kind == 4):
        cells[i] = ("", "NaN", "inf", "-inf", "nan", "NA")[i % 6]
    return cells


def test_a_clean_file_is_read_by_the_typed_reader_as_pandas_reads_it(
    tmp_path: Path, typed_only: None
) -> None:
    rng = np.random.default_rng(12)
    n = 200_000  # several blocks at the real sizes
    columns = {
        "t_s": [repr(float(v)) for v in 0.005 * np.arange(1, n + 1)],
        "gyro_x_rad_s": _numbers(rng, n),
        "accel_z_m_s2": _numbers(rng, n),
        "count": [str(v) for v in rng.integers(-(2**62), 2**62, n)],
        "bottom_lock": [("true", "False", "TRUE")[v] for v in rng.integers(0, 3, n)],
    }
    path = tmp_path / "imu.csv"
    rows = (",".join(cells) for cells in zip(*columns.values(), strict=True))
    path.write_text(", ".join(columns) + "\n" + "\n".join(rows) + "\n")
    table, repairs = read(path)
    assert repairs == [] and table.cut is None
    np.testing.assert_array_equal(table.lines, np.arange(2, n + 2))
    expected = pd.read_csv(path, **PANDAS_LIKE)
    expected.columns = pd.Index([c.strip() for c in expected.columns])
    pd.testing.assert_frame_equal(table.df, expected, check_exact=True)
    assert dict(table.df.dtypes) == {
        "t_s": np.float64,
        "gyro_x_rad_s": np.float64,
        "accel_z_m_s2": np.float64,
        "count": np.int64,
        "bottom_lock": np.bool_,
    }
    for c in ("gyro_x_rad_s", "accel_z_m_s2"):  # bit for bit, as Python reads each cell
        cells = [s.strip() for s in columns[c]]
        value = np.array([float(s) if s not in tb.PANDAS_NA else math.nan for s in cells])
        got = table.df[c].to_numpy()
        nan = np.isnan(value)
        np.testing.assert_array_equal(np.isnan(got), nan)
        np.testing.assert_array_equal(got[~nan].view(np.int64), value[~nan].view(np.int64))


def test_a_quoted_header_is_read_by_the_typed_reader(tmp_path: Path, typed_only: None) -> None:
    """Writers that quote every text cell (csv.QUOTE_NONNUMERIC) quote the header: its names
    are read as the exact reader reads them, the numbers still by pyarrow."""
    rng = np.random.default_rng(3)
    df = pd.DataFrame({"t_s": np.arange(50) / 10.0, "vx_m_s": rng.normal(size=50)})
    path = tmp_path / "dvl.csv"
    df.to_csv(path, index=False, quoting=csv.QUOTE_NONNUMERIC)
    assert path.read_text().startswith('"t_s","vx_m_s"\n')
    table, repairs = read(path)
    exact, _, error = outcome(EXACT, path)
    assert error is None and exact is not None and repairs == []
    assert_same_table(table, exact)
    assert list(table.df.columns) == ["t_s", "vx_m_s"] and len(table) == 50


def test_blank_lines_crlf_and_bom_keep_their_line_numbers(
    tmp_path: Path, small: None, typed_only: None
) -> None:
    lines = ["t_s,v_m_s"] + [f"{0.1 * k!r},{k / 7!r}" for k in range(1, 400)]
    for k in (350, 200, 199, 57, 1):  # two in a row too; 1: right after the header
        lines.insert(k, "")
    path = tmp_path / "dvl.csv"
    path.write_bytes(("\ufeff" + "\r\n".join(lines) + "\r\n\r\n").encode())
    table, _ = read(path)
    exact, _, _ = outcome(EXACT, path)
    assert exact is not None
    assert_same_table(table, exact)
    assert table.where(0) == "dvl.csv line 3" and len(table) == 399


STATUS = ("OK", "no lock", "é", "", "NaN", '"lock ""B"""', '"lost, 2 beams"')
"""A DVL's status column as a logger writes it: words, nothing, quoted texts with quotes and a
comma in them."""


def test_a_text_or_date_column_is_parsed_by_pandas_from_the_file(
    tmp_path: Path, small: None, streamed_only: None
) -> None:
    """A logger's ISO time and status text beside the numbers: not the typed reader's, but
    plain lines, so pandas reads the file itself (not a copy of it rebuilt as one string)."""
    rng = np.random.default_rng(5)
    n = 600
    lines = ["t_s, utc, vx_m_s, vy_m_s, status"] + [
        f"{0.3 * k!r},2026-12-03T07:{k // 200:02d}:{k % 60:02d}.{k % 10}Z,"
        f"{rng.normal()!r},{rng.normal()!r},{STATUS[k % len(STATUS)]}"
        for k in range(1, n + 1)
    ]
    for k in (400, 3, 1):
        lines.insert(k, "")
    path = tmp_path / "dvl.csv"
    path.write_bytes(("\ufeff" + "\r\n".join(lines) + "\r\n").encode())
    table, repairs = read(path)
    exact, _, error = outcome(EXACT, path)
    assert error is None and exact is not None
    assert_same_table(table, exact)
    assert repairs == [] and len(table) == n
    assert table.where(0) == "dvl.csv line 3" and table.where(n - 1) == f"dvl.csv line {n + 4}"
    assert table.df["status"].iloc[1] == "é" and table.df["vx_m_s"].dtype == np.float64
    assert table.df["status"].iloc[4] == 'lock "B"'  # quoted, its quotes doubled
    assert table.df["status"].iloc[5] == "lost, 2 beams"  # a quoted comma


@pytest.mark.parametrize(
    "body",
    [
        '1.0, "a,b"\n',  # a quote after a space: 3 fields to the csv module, 2 to pandas
        '1.0,"a\nb"\n',  # a line break inside quotes
        '1.0,"a,b\n2.0,c"\n',  # the same across a comma
        '1.0,x"a,"b\n2.0,c\n',  # a quote that opens a field and does not close on its line
        '1.0,ab"c\n2.0,d"e,\n',  # stray quotes around a comma (a long line to the exact reader)
        "1.0,abc\r3.0,4.0\n",  # a lone CR
        "1.0,abc\n \x0c\n2.0,x\n",  # a line of a form feed (blank to the exact reader only)
        "1.0,abc\n3.0\n",  # a short last line (a repair)
        "1.0,abc\n3.0\n  \n\n",  # the same, lines of spaces after it
        '1.0,abc\n3.0,4.0,5.0\n6.0,"x"\n',  # a long line, quotes after it
        "1.0,abc\n3.0,4.0,5.0\n6.0,\x00\n",  # a long line, NUL after it
        "1.0,abc\n2.0,xyz,7",  # no line break at the end, a long last line
        "1.0,abc\n\x00\n",  # binary
        "1.0,\xe9t\xe9\n" + "\x00" * 10,  # Latin-1, NUL in the first 64 KiB: binary
        "",  # no data line
    ],
)
def test_what_the_streamed_reader_leaves_to_the_exact_one(tmp_path: Path, body: str) -> None:
    path = tmp_path / "x.csv"
    path.write_bytes(b"t_s,v\n" + body.encode("latin-1"))
    assert tb._read_csv_streamed(path, "x.csv", tb.Journal()) is None


@pytest.mark.parametrize(
    ("body", "line", "fields"),
    [
        ("1.0,abc\n3.0,4.0,5.0\n", 3, 3),  # a long last line
        ("1.0,abc\n3.0\n4.0,x\n", 3, 1),  # a short line inside
        ("1.0,abc\n\n3.0\n   \n4.0,x", 4, 1),  # the same, blank lines around, no final break
        ("1.0,abc\n3.0\n\u00a0\n4.0,\u00e9\n", 3, 1),  # NBSP and UTF-8 text after it
        ('1.0,"a,b"\n' + "2.0,x\n" * 3000 + "3.0,4.0,5.0\r\n", 3003, 3),  # quotes pieces before
        ("\n  \r\n" * 3 + "1.0,abc\n3.0\n4.0,x\n", 9, 1),  # the header after blank lines
    ],
)
def test_the_streamed_reader_reports_a_wrong_field_count_in_the_exact_readers_words(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, body: str, line: int, fields: int
) -> None:
    """Without reading the file into memory: the exact reader (about 10× the file) must not
    run, and says the same of the same file."""
    path = tmp_path / "x.csv"
    lead = body[: len(body) - len(body.lstrip(" \r\n"))]  # blank lines before the header
    path.write_bytes((lead + "t_s,v\n" + body[len(lead) :]).encode())
    head = 1 + lead.count("\n")
    expected = f"x.csv line {line}: {fields} fields, the header (line {head}) has 2"
    assert outcome(EXACT, path)[2] == expected
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    with pytest.raises(MissionError) as err:
        read(path)
    assert str(err.value) == expected
    assert (err.value.file, err.value.line) == ("x.csv", line)


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ("1.0,\xe9t\xe9\n", "x.csv line 2, v: not UTF-8 text (byte 0xe9, byte 5 of the line"),
        (  # a long line before it: the decoding error comes first for the exact reader too
            "1.0,abc\n3.0,4.0,5.0\n6.0,\xe9\n",
            "x.csv line 4, v: not UTF-8 text (byte 0xe9, byte 5 of the line",
        ),
        (  # a short last line, then a lone Latin-1 NBSP: no field before it
            "1.0,abc\n3.0\n\u00a0\n",
            "x.csv line 4, t_s: not UTF-8 text (byte 0xa0, byte 1 of the line",
        ),
        (  # quotes before it on its line: no column named
            '1.0,abc\n"2,0",\xb0\n',
            "x.csv line 3: not UTF-8 text (byte 0xb0, byte 7 of the line",
        ),
        (  # in a later piece of the scan, after thousands of lines
            "1.0,abc\n" * 3000 + "2.0,deg\xb0\n",
            "x.csv line 3002, v: not UTF-8 text (byte 0xb0, byte 8 of the line",
        ),
    ],
)
def test_the_streamed_reader_reports_text_that_is_not_utf8_in_the_exact_readers_words(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, body: str, expected: str
) -> None:
    """A Latin-1 byte: the same error as the exact reader's, without the file in memory."""
    path = tmp_path / "x.csv"
    path.write_bytes(b"t_s,v\n" + body.encode("latin-1"))
    exact = outcome(EXACT, path)[2]
    assert exact.startswith(expected), exact
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    with pytest.raises(MissionError) as err:
        read(path)
    assert str(err.value) == exact
    assert err.value.line == int(expected.split(" line ")[1].split(",")[0].split(":")[0])


@settings(max_examples=400, deadline=None, derandomize=True)
@given(
    st.lists(
        st.lists(st.sampled_from(["a", ",", '"', " ", '""', "1", '"x,y"', ',"', '",']), max_size=8),
        min_size=1,
        max_size=3,
    ),
    st.integers(2, 4),
)
def test_the_streamed_field_count_is_the_csv_modules(tokens: list[list[str]], n: int) -> None:
    """Whatever the quotes, the streamed reader's NumPy field count accepts lines only when the
    csv module (the exact reader's count) reads each as one record of ``n`` fields."""
    lines = ["".join(t) for t in tokens]
    if not tb._fields_ok(("\n".join(lines) + "\n").encode(), n, 0):
        return
    reader = csv.reader(lines)
    counts = []
    for row in reader:
        assert reader.line_num == len(counts) + 1, lines  # no record over two lines
        counts.append(len(row))
    assert counts == [n] * len(lines), lines


def test_a_quoted_line_break_is_an_error_naming_the_line(tmp_path: Path) -> None:
    """A quoted cell that runs over a line break would make one row of two lines; every reader
    refuses it with the line named (it was a ValueError from zip in the exact reader)."""
    path = tmp_path / "dvl.csv"
    path.write_bytes(b't_s,vx_m_s,status\n0.0,1.0,ok\n0.1,1.1,"lost\nlock"\n0.2,1.2,ok\n')
    with pytest.raises(MissionError, match=r"dvl\.csv line 3: a quoted field is not closed"):
        read(path)


@pytest.mark.parametrize(
    ("last", "kept"),
    [
        ("9.9,2026-12-03T07:00:09Z,lost", True),  # as long as its column's: whole
        ("9.9,2026-12-03T07:00:09Z,lo", False),  # shorter: cut mid-word, dropped, recorded
        ("9.9,2026-12-03T07:00:09Z", False),  # a field short
        ('9.9,2026-12-03T07:00:09Z,"lost, 2"', True),  # quoted, with a comma: whole
    ],
)
def test_a_text_file_without_final_line_break_is_streamed(
    tmp_path: Path, small: None, streamed_only: None, last: str, kept: bool
) -> None:
    """A logger stopped mid-write: the streamed reader judges the last line from the file's
    tail as the exact reader does (its page size of bytes, not the whole file in memory)."""
    lines = ["t_s,utc,status"] + [
        f"{0.1 * k!r},2026-12-03T07:00:0{k % 10}Z,okay" for k in range(300)
    ]
    path = tmp_path / "dvl.csv"
    path.write_bytes(("\n".join([*lines, last])).encode())
    table, repairs = read(path)
    assert len(table) == 300 + kept
    assert [r.line for r in repairs] == ([] if kept else [302])
    assert (table.cut is None) == kept
    exact, exact_repairs, error = outcome(EXACT, path)
    assert error is None and exact is not None
    assert_same_table(table, exact)
    assert repairs == exact_repairs


# --- errors: the typed reader declines, the exact one locates ----------------------------------


def _clean_lines(n: int) -> list[str]:
    return ["t_s,vx_m_s,vy_m_s,vz_m_s"] + [
        f"{0.3 * k!r},{math.sin(k)!r},{math.cos(k)!r},{k / 9!r}" for k in range(1, n + 1)
    ]


@pytest.mark.parametrize("cell", ["abc", "1.2.3", "NAN", "0x1F", "+nan", "True", "--"])
@pytest.mark.parametrize("row", [3, 700])  # in the first block (type inference), or far after
def test_a_bad_cell_anywhere_is_an_error_naming_file_line_and_field(
    tmp_path: Path, small: None, declined: list[bool], cell: str, row: int
) -> None:
    lines = _clean_lines(800)
    lines.insert(100, "")  # a blank line before: counted
    k = row + (row >= 100)
    fields = lines[k].split(",")
    fields[2] = cell
    lines[k] = ",".join(fields)
    path = tmp_path / "dvl.csv"
    path.write_text("\n".join(lines) + "\n")
    table, _ = read(path)
    assert declined == [True]
    with pytest.raises(MissionError) as err:
        tb.numeric(table, "vy_m_s")
    line = k + 1
    assert str(err.value).startswith(f"dvl.csv line {line}, vy_m_s: value {cell!r} is not a")
    assert (err.value.file, err.value.line, err.value.field) == ("dvl.csv", line, "vy_m_s")


@pytest.mark.parametrize("fields", [2, 5])
def test_a_wrong_field_count_inside_is_an_error_naming_the_line(
    tmp_path: Path, small: None, declined: list[bool], fields: int
) -> None:
    lines = _clean_lines(800)
    lines[600] = ",".join([*lines[600].split(","), "1.0"][:fields])
    path = tmp_path / "dvl.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MissionError) as err:
        read(path)
    assert str(err.value) == f"dvl.csv line 601: {fields} fields, the header (line 1) has 4"
    assert declined == [True]


def test_a_line_of_spaces_is_a_blank_line(
    tmp_path: Path, small: None, declined: list[bool], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Skipped and counted, as by the exact reader; pyarrow would see a row of one field, so
    the typed reader declines it and pandas reads it from the file (which skips such lines)."""
    lines = _clean_lines(800)
    lines[600] = "   "
    lines[700] = " \t "
    path = tmp_path / "dvl.csv"
    path.write_text("\n".join(lines) + "\n")
    expected, _, _ = outcome(EXACT, path)
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    table, _ = read(path)
    assert table.where(598) == "dvl.csv line 600" and table.where(599) == "dvl.csv line 602"
    assert table.where(697) == "dvl.csv line 700" and table.where(698) == "dvl.csv line 702"
    assert expected is not None
    assert_same_table(table, expected)
    assert declined == [True]


@pytest.mark.parametrize(
    ("odd", "case"),
    [
        ("\x0c", "middle"),  # a form feed
        ("\x0b \t", "middle"),  # a vertical tab among spaces
        ("\u00a0", "middle"),  # a no-break space (two bytes in UTF-8)
        ("\x1c\u3000", "crlf"),  # a file separator and an ideographic space, CRLF breaks
        ("\x0c", "wrong count after"),
        ("\x0c", "cut last line"),
        ("\x0c", "last line"),  # the file's last line, without a line break (since 0.4.1)
        ("\u00a0", "last line"),
    ],
)
def test_a_line_of_other_white_space_is_a_blank_line_without_the_exact_reader(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, odd: str, case: str
) -> None:
    """A line of white space other than spaces and tabs is blank to the exact reader, a data
    line to pandas and pyarrow: read from a copy with it emptied, the same table, lines,
    repairs and errors as the exact reader's, without the exact reader (up to 0.3.9 it read
    such a file, at about 10× its size)."""
    lines = _clean_lines(800)
    lines[3] = lines[601] = odd
    if case == "wrong count after":
        lines[700] += ",1.0"
    if case == "cut last line":
        lines[-1] = lines[-1][:5]
    end = "" if case in ("cut last line", "last line") else "\n"
    if case == "last line":
        lines.append(odd)
    newline = "\r\n" if case == "crlf" else "\n"
    path = tmp_path / "dvl.csv"
    path.write_bytes((newline.join(lines) + end.replace("\n", newline)).encode())
    expected, repairs, error = outcome(EXACT, path)
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    got, got_repairs, got_error = outcome(tb.read_table, path)
    assert got_error == error
    assert [str(r) for r in got_repairs] == [str(r) for r in repairs]
    if expected is None:
        assert error is not None and error.startswith("dvl.csv line 701: 5 fields")
        return
    assert got is not None
    assert_same_table(got, expected)
    assert got.where(1) == "dvl.csv line 3" and got.where(2) == "dvl.csv line 5"
    assert len(got.df) == 798 - (case == "cut last line")


def test_classic_mac_line_breaks_are_read_as_line_breaks_with_a_repair(tmp_path: Path) -> None:
    """A file whose every line break is a lone CR: read as the same file with LF (until 0.3.5 a
    csv.Error traceback from the exact reader's header)."""
    lines = _clean_lines(50)
    lf, cr = tmp_path / "lf.csv", tmp_path / "dvl.csv"
    lf.write_text("\n".join(lines) + "\n")
    cr.write_bytes(("\r".join(lines) + "\r").encode())
    table, repairs = read(cr)
    assert_same_table(table, read(lf)[0])
    (r,) = repairs
    assert (r.file, r.line, r.action) == ("dvl.csv", None, "read CR line breaks as line breaks")


@pytest.mark.parametrize(
    "case",
    ["numbers", "text column", "cut last line", "blank lines", "wrong field count", "form feed"],
)
def test_classic_mac_files_are_read_as_the_exact_reader_reads_them_without_it(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, case: str
) -> None:
    """A CR-only file of any size is read by the typed or the streamed reader from a
    temporary LF copy (until 0.3.8 by the exact reader, at ~10× the file in memory): the same
    table, repairs in the same order and the same errors as the exact reader's; the copy is
    gone afterwards."""
    lines = _clean_lines(800)
    if case == "text column":
        lines = [
            f"{ln},{'status' if i == 0 else 'lock ' + str(i % 3)}" for i, ln in enumerate(lines)
        ]
    elif case == "blank lines":
        lines[300:300] = ["", "  "]
    elif case == "form feed":  # its LF copy is read from a blanked copy (since 0.4.1)
        lines[300:300] = ["\x0c", "\u00a0"]
    elif case == "wrong field count":
        lines[500] += ",7.0"
    text = "\r".join(lines) + ("" if case == "cut last line" else "\r")
    if case == "cut last line":
        text = text[: text.rindex(",") + 3]  # the last number cut short
    path = tmp_path / "dvl.csv"
    path.write_bytes(text.encode())
    expected, expected_repairs, expected_error = outcome(EXACT, path)
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    got, repairs, error = outcome(tb.read_table, path)
    assert error == expected_error
    if expected_error is None:
        assert got is not None and expected is not None
        assert_same_table(got, expected)
        assert got.path == path
        assert repairs == expected_repairs
        assert repairs[0].action == "read CR line breaks as line breaks"
        assert len(repairs) == (2 if case == "cut last line" else 1)
    else:
        assert error.startswith("dvl.csv line 501: 5 fields")
    assert list(temp.iterdir()) == []


@pytest.mark.parametrize("at", [2, 30, 51])
def test_a_lone_cr_among_lf_line_breaks_is_an_error_naming_its_line(
    tmp_path: Path, at: int
) -> None:
    lines = _clean_lines(50)
    lines[at - 1] += "\r" + lines[at - 1].split(",", 1)[1]
    path = tmp_path / "dvl.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MissionError) as err:
        read(path)
    assert str(err.value).startswith(f"dvl.csv line {at}: a carriage return (CR) alone inside")
    assert err.value.line == at


STRAY_TOKENS = (
    b"1.0", b",", b"\n", b"\r\n", b"\r", b"\xe9", b"\xc3\xa9", b"\xef\xbb\xbf", b" ", b'"', b"\x00",
)  # fmt: skip
"""Pieces of the random files of :func:`test_the_stray_cr_error_is_the_exact_readers`."""


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ("1.0,2.0\n3.0\r4.0\n5.0,6.0\n", "line 3: a carriage return (CR) alone"),
        ("1.0,2.0\r\n" * 3000 + "3.0\r4.0\r\n", "line 3002: a carriage return (CR) alone"),
        ("1.0,2.0\n3.0\r\r\n", "line 3: a carriage return (CR) alone"),  # CR, then CRLF
        ("1.0,2.0\n\r", None),  # the very last byte: a CRLF file cut short, no error here
        ("1.0,2.0\n3.0\r4.0\n" + "5.0,\xb0\n", "line 4, v: not UTF-8 text"),  # decoded first
        ("1.0,2.0\n3.0\r4.0\n" + "5.0,6.0\n" * 3000 + "\xe9,1\n", "line 3004, t_s: not UTF-8"),
        ("1.0,2.0\n1.0,2.0,3.0\n" + "5.0,6.0\n" * 3000 + "7\r8\n", "line 3004: a carriage"),
    ],
    ids=[
        "numbers",
        "crlf-far",
        "cr-crlf",
        "final-cr",
        "latin1-after",
        "latin1-far",
        "fields-first",
    ],
)
def test_a_lone_cr_among_lf_is_found_without_the_file_in_memory(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, body: str, expected: str | None
) -> None:
    """The exact reader's error for a file with a lone CR among LF line breaks (or, first, its
    error for a byte that is not UTF-8 anywhere in the file), found piece by piece: the exact
    reader, which holds the file's text about ten times over, does not run (up to 0.3.9 it
    did). The last case has a wrong field count on line 3 and the lone CR in a later piece:
    the exact reader reports the CR (it looks for it before counting fields), and so must the
    streamed scan, which reported the field count up to 0.3.9."""
    path = tmp_path / "x.csv"
    path.write_bytes(b"t_s,v\n" + body.encode("latin-1"))
    exact = outcome(EXACT, path)[2]
    if expected is None:
        assert tb._stray_cr(path, "x.csv") is None
        return
    assert exact is not None and f"x.csv {expected}" in exact, exact
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    with pytest.raises(MissionError) as err:
        read(path)
    assert str(err.value) == exact
    assert err.value.line == int(expected.split("line ")[1].split(",")[0].split(":")[0])


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(st.sampled_from(STRAY_TOKENS), max_size=60), st.booleans())
def test_the_stray_cr_error_is_the_exact_readers(tokens: list[bytes], bom: bool) -> None:
    """On random files of numbers, commas, quotes, line breaks of every kind, Latin-1 and UTF-8
    bytes and NUL: whenever the piecewise pass gives an error it is the exact reader's, and it
    gives one whenever the exact reader reports a lone CR."""
    raw = (tb.BOM if bom else b"") + b"t_s,v\n" + b"".join(tokens)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.csv"
        path.write_bytes(raw)
        exact = outcome(EXACT, path)[2]
        mine = tb._stray_cr(path, "x.csv")
    if mine is not None:
        assert str(mine) == exact
    if exact is not None and "carriage return (CR) alone" in exact:
        assert mine is not None


SOUP = (
    b"1", b"2.5", b"-0", b",", b",", b"\n", b"\n", b"\r\n", b"\r", b'"', b" ", b"\t", b"abc",
    b"nan", b"\x00", b"\xe9", b"\xef\xbb\xbf", b"e5", b"+", b"inf", b"True", b"\x0c", b"1e999",
    b"\xc3\xa9",
)  # fmt: skip
"""Pieces of CSV text and of what goes wrong with it, for the byte-soup test."""
SOUP_HEADERS = (
    b"t_s,v\n", b"t_s,vx_m_s,vy_m_s\n", b'"t_s","v"\n', b"t_s\n", b"", b"t_s,v\r\n",
    b"\n\nt_s,v\n", b"t_s,,v\n", b" t_s , v \n", b"\xef\xbb\xbft_s,v\n",
)  # fmt: skip


@pytest.mark.parametrize(
    "data",
    [
        b'nan\r, "\x0c\n1e999\xc3\xa9,\xe9e5\x0c\xc3\xa9\r\n',  # not UTF-8, CR in the header
        b' "2.5,"+abc"\xc3\xa9\n \n\n+abc',  # a quote after a space in the header
        None,  # 1500 seeded random files of SOUP
    ],
    ids=["cr-header-latin1", "header-quote-after-space", "random"],
)
def test_byte_soup_is_a_table_or_an_error(tmp_path: Path, small: None, data: bytes | None) -> None:
    """Whatever the bytes, reading a table and its columns gives a table or a MissionError,
    never another exception (the first two cases raised csv.Error and ValueError up to
    0.3.5)."""
    rng = np.random.default_rng(12)
    path = tmp_path / "x.csv"
    files = [data] if data is not None else [
        bytes(rng.choice(SOUP_HEADERS)) + b"".join(rng.choice(SOUP, int(rng.integers(0, 80))))
        for _ in range(1500)
    ]  # fmt: skip
    logging.disable(logging.WARNING)
    try:
        for raw in files:
            path.write_bytes(raw)
            try:
                table = tb.read_table(path, "x.csv", tb.Journal())
                for column in table.df.columns:
                    tb.numeric(table, column)
            except MissionError:
                pass
    finally:
        logging.disable(logging.NOTSET)


# --- the last line cut short: repaired from the tail ------------------------------------------


@pytest.mark.parametrize("keep", [5, 25, -3])  # fewer fields (t_s cut or whole); last number cut
def test_a_cut_last_line_is_dropped_by_the_typed_reader(
    tmp_path: Path, small: None, typed_only: None, keep: int
) -> None:
    lines = _clean_lines(800)
    text = "\n".join(lines)
    last = lines[-1]
    path = tmp_path / "dvl.csv"
    path.write_text(text[: len(text) - len(last) + keep] if keep > 0 else text[:keep])
    table, repairs = read(path)
    assert len(table) == 799 and table.cut is not None and table.cut[0] == 801
    (r,) = repairs
    assert (r.line, r.action) == (801, "dropped truncated last line")
    if keep == 25:  # t_s whole
        assert table.cut[1] == 0.3 * 800
    exact, exact_repairs, _ = outcome(EXACT, tmp_path / "dvl.csv")
    assert exact is not None
    assert_same_table(table, exact)
    assert repairs == exact_repairs


def test_a_whole_fixed_width_last_line_without_line_break_is_kept(
    tmp_path: Path, small: None, typed_only: None
) -> None:
    lines = ["t_s,depth_m"] + [f"{k:.3f},{1 + math.sin(k):.6f}" for k in range(1, 500)]
    path = tmp_path / "depth.csv"
    path.write_text("\n".join(lines))
    table, repairs = read(path)
    assert len(table) == 499 and table.cut is None and repairs == []


# --- dtypes: as pandas infers them over the whole column ---------------------------------------


@pytest.mark.parametrize(
    ("late", "dtype"),
    [("7", np.int64), ("7.5", np.float64), ("", np.float64), ("1e3", np.float64)],
)
def test_an_integer_column_keeps_the_dtype_pandas_gives_it(
    tmp_path: Path, small: None, typed_only: None, late: str, dtype: Any
) -> None:
    """Integers in the first block, ``late`` in a later one (0/1 flags, counters)."""
    rows = [f"{0.2 * k!r},{k % 2},{k}" for k in range(1, 1000)]
    rows[900] = rows[900].rsplit(",", 1)[0] + "," + late
    path = tmp_path / "dvl.csv"
    path.write_text("t_s,is_outlier,count\n" + "\n".join(rows) + "\n")
    table, _ = read(path)
    assert table.df["is_outlier"].dtype == np.int64
    assert table.df["count"].dtype == dtype
    pd.testing.assert_frame_equal(table.df, pd.read_csv(path, **PANDAS_LIKE), check_exact=True)


@pytest.mark.parametrize(
    "body",
    [
        '1.0,"2.5"\n',  # quotes
        "1.0,True\n2.0,\n",  # a true/false column with a missing cell (pandas: object)
        "1.0,True\n2.0,1\n",  # true/false and a number (pandas: text)
        "1.0,yes\n2.0,no\n",  # not pandas' spellings of true/false
        "1.0,abc\n",  # a text column
        "1.0,2.0\r3.0,4.0\n",  # a lone CR: a line break to pyarrow only
        "1.0,+7\n",  # pandas: an integer
        "1.0,0x1F\n",  # pyarrow: an integer
        "1.0,NAN\n",  # pyarrow: NaN; pandas: text
        "1.0,12345678901234567890\n",  # pandas: uint64
        "1.0,2.0\n3.0,4.0,5.0\n",  # a long last line
        "1.0,2.0\n\x00\n",  # binary
        "1.0,2.5 \u00b0\n",  # not ASCII
        "",  # no data line
        "   \n",  # only a line of spaces
    ],
)
def test_what_the_typed_reader_leaves_to_the_exact_one(tmp_path: Path, body: str) -> None:
    path = tmp_path / "x.csv"
    path.write_bytes(("t_s,v\n" + body).encode())
    assert tb._read_csv_typed(path, "x.csv", tb.Journal()) is None


# --- the two readers agree, on files of every shape -------------------------------------------


CELLS = (
    "1.5", "-0", "-0.0", "0", "7", " 1.5", "1.5 ", "\t2", "1e5", "1E-3", "inf", "-Infinity",
    "nan", "NaN", "NAN", "NA", " NA", "", "  ", "None", "<NA>", "#N/A", "abc", "True", "1.",
    ".5", "1,5", "1.2.3", "+7", "1e400", "4.9e-324", "12345678901234567890", "1d5",
)  # fmt: skip
"""Cells dropped here and there into numeric columns: fine, missing, or not numbers."""


TEXTS = (
    "OK", "no lock", "2026-12-03", "07:01:42.5", "é", "1", "-", "a b", "True", "NA", '"OK"',
    '"say ""hi"""', ' "x"', 'ab"c', '"a,b"', '""', '"1.5"', ' "a,b"', '"x, ""y"", z"',
)  # fmt: skip
"""Cells of a text column (a status, a date, a time), among them numbers and NaN spellings."""
QUOTED = ("OK", '"a,b"', '"x, ""y"", z"', '","', '"lost, 2 beams"', '"say ""hi"""', "NA", "")
"""Text cells with quoted commas, which the streamed reader counts with the csv module."""


def _random_csv(
    rng: np.random.Generator, *, text: bool = False, texts: tuple[str, ...] = TEXTS
) -> bytes:
    """A small CSV of random shape: columns of floats, integers, integers turning into floats,
    odd cells (and, if ``text``, text); blank lines and lines of spaces; CRLF; a BOM; a short
    line; a cut end."""
    n_cols = int(rng.choice([2, 3, 5]))
    n_rows = int(rng.choice([1, 2, 3, 40, 300]))
    kinds = rng.choice(["float", "int", "int then float", "odd", "bool", *["text"] * text], n_cols)
    body: list[str] = []
    for r in range(n_rows):
        row = []
        for kind in kinds:
            if kind == "float":
                row.append(repr(float(rng.normal() * 10.0 ** rng.integers(-8, 8))))
            elif kind == "int" or (kind == "int then float" and r < n_rows - 3):
                row.append(str(int(rng.integers(-100, 100))))
            elif kind == "odd" and rng.random() < 0.1:
                row.append(str(rng.choice(CELLS)))
            elif kind == "text":
                row.append(str(rng.choice(texts)))
            elif kind == "bool":  # pandas' spellings, now and then another cell
                cells = ("True", "false", "TRUE", "False", "true", "FALSE")
                row.append(str(rng.choice(CELLS if rng.random() < 0.02 else cells)))
            else:
                row.append(repr(float(rng.random())))
        body.append(",".join(row))
    quote = '"' if rng.random() < 0.2 else ""  # a header as csv writers quoting all give it
    sep = "," if quote else ", "  # after ', ' a quote is a character to the csv module
    lines = [sep.join(f"{quote}c{i}{quote}" for i in range(n_cols)), *body]
    for _ in range(int(rng.choice([0, 0, 1, 3]))):  # before the header too
        lines.insert(int(rng.integers(0, len(lines) + 1)), str(rng.choice(["", "", "  "])))
    if rng.random() < 0.15 and len(lines) > 2:
        k = int(rng.integers(1, len(lines)))
        lines[k] = ",".join(lines[k].split(",")[:-1])
    newline = "\r\n" if rng.random() < 0.3 else "\n"
    text = newline.join(lines) + (newline if rng.random() < 0.6 else "")
    if rng.random() < 0.3:
        text = text[: len(text) - int(rng.integers(1, 9))]
    return (("\ufeff" if rng.random() < 0.1 else "") + text).encode()


def _streamed(path: Path, label: str, journal: tb.Journal) -> tb.Table | None:
    return tb._read_csv_streamed(path, label, journal)


@pytest.mark.parametrize(
    ("reader", "seed", "texts", "least"),
    [
        (tb._read_csv_typed, 2024, (), 100),
        (_streamed, 2025, TEXTS, 60),
        (_streamed, 2026, QUOTED, 60),
    ],
    ids=["typed", "streamed", "streamed-quoted-commas"],
)
def test_a_reader_and_the_exact_one_agree(
    tmp_path: Path, small: None, reader: Any, seed: int, texts: tuple[str, ...], least: int
) -> None:
    """Whenever the typed or the streamed reader reads a file, the exact one reads the same
    table, with the same repairs (the streamed reader makes none); each reads a fair share of
    these odd files (text columns among them for the streamed one, with quoted commas in the
    third case), not none."""
    rng = np.random.default_rng(seed)
    path = tmp_path / "x.csv"
    read_by_it = reported = 0
    logging.disable(logging.WARNING)
    try:
        for _ in range(400):
            path.write_bytes(_random_csv(rng, text=bool(texts), texts=texts or TEXTS))
            a, repairs_a, error_a = outcome(reader, path)
            if a is None and error_a is None:
                continue
            read_by_it += 1
            b, repairs_b, error = outcome(EXACT, path)
            if error_a is not None:
                assert error == error_a, path.read_bytes()
                reported += 1
                continue
            assert error is None and b is not None, (path.read_bytes(), error)
            assert_same_table(a, b)
            assert repairs_a == repairs_b
    finally:
        logging.disable(logging.NOTSET)
    assert read_by_it >= least, read_by_it
    print(f"{read_by_it} read, {reported} of them an error")


ODD_BLANKS = ("\x0c", "\x0b", "\u00a0", " \x0c\t", "\x1c", "\u2003")
"""Lines blank to ``str.strip`` (the exact reader) but not to pandas or pyarrow."""


def test_the_blanked_copy_and_the_exact_reader_agree(tmp_path: Path, small: None) -> None:
    """400 random files (:func:`_random_csv`, text columns among them) with 1-3 lines of other
    white space inserted after a line break: whenever the blanked copy is read it is the exact
    reader's table, repairs and error; most are."""
    rng = np.random.default_rng(2027)
    path = tmp_path / "x.csv"
    read_by_it = 0
    logging.disable(logging.WARNING)
    try:
        for _ in range(400):
            raw = _random_csv(rng, text=bool(rng.random() < 0.5))
            crlf = b"\r\n" in raw
            for _ in range(int(rng.integers(1, 4))):
                breaks = [i + 1 for i in range(len(raw)) if raw[i : i + 1] == b"\n"]
                if not breaks:
                    break
                at = int(rng.choice(breaks))
                line = str(rng.choice(ODD_BLANKS)).encode() + (b"\r\n" if crlf else b"\n")
                raw = raw[:at] + line + raw[at:]
            if rng.random() < 0.3 and raw.endswith(b"\n"):  # one more, without a line break
                raw += str(rng.choice(ODD_BLANKS)).encode()
            path.write_bytes(raw)
            read_by_it += agrees_with_exact(tb._read_csv_blanked, path)[0]
    finally:
        logging.disable(logging.NOTSET)
    assert read_by_it >= 250, read_by_it


@pytest.mark.parametrize(
    "tail",
    ["   ", "\t", "\x0c", "\u00a0", "\n\x0c", " \x0b\u2003"],
    ids=["spaces", "tab", "form-feed", "nbsp", "blank-line-then-form-feed", "mixed"],
)
@pytest.mark.parametrize("newline", ["\n", "\r\n"], ids=["lf", "crlf"])
def test_white_space_after_the_last_line_break_leaves_the_last_line_whole(
    tmp_path: Path, tail: str, newline: str
) -> None:
    """A file that ends in white space without a line break was not cut inside its last data
    line, which has its line break: every reader keeps that line, with no repair. Up to 0.4.0
    each took the file's missing final line break for a cut and dropped the line when its last
    value was shorter than the column's ('6' after '4.5'); the typed reader instead dropped a
    last no-break space as a line of 1 of 2 fields and kept the line: the two disagreed."""
    path = tmp_path / "dvl.csv"
    body = newline.join(["t_s,vx_m_s", "1,2.5", "3,4.5", "5,6"])
    path.write_bytes((body + newline + tail.replace("\n", newline)).encode())
    for reader in (EXACT, tb.read_table):
        table, repairs, error = outcome(reader, path)
        assert error is None and table is not None, error
        assert table.df["vx_m_s"].tolist() == [2.5, 4.5, 6.0]
        assert [table.where(i) for i in range(3)] == [f"dvl.csv line {k}" for k in (2, 3, 4)]
        assert repairs == []
    path.write_bytes(body.encode())  # ends inside its last line: that line may be cut
    for reader in (EXACT, tb.read_table):
        table, repairs, error = outcome(reader, path)
        assert table is not None and table.df["vx_m_s"].tolist() == [2.5, 4.5]
        assert [r.action for r in repairs] == ["dropped truncated last line"]


# --- the line-by-line reader: the exact reader's rules without the text in memory ---------------


QUOTED_ROWS = '0.0,1.0,"a,b"\n' * 3000
"""Lines of a file with quotes: the streamed reader's scan leaves its field counts to the csv
module, and a wrong one to the exact reader's order of errors."""


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        (QUOTED_ROWS + '0.1,1.1,"lost\nlock"\n' + QUOTED_ROWS, "line 3002: a quoted field is not"),
        (QUOTED_ROWS + "0.2,1.2\n" + QUOTED_ROWS, "line 3002: 2 fields, the header (line 1)"),
        ("0.0,1.0,x\n0.5\n" + QUOTED_ROWS, "line 3: 1 fields, the header (line 1) has 3"),
        (QUOTED_ROWS + '0.1,1.1,"open\n' + "0.2,1.2,x\n" * 20_000, "line 3002: field larger than"),
        ("0.0,1.0\n" + QUOTED_ROWS + '0.1,"a\nb",c\n', "line 3003: a quoted field is not closed"),
    ],
    ids=["line-break-in-quotes", "count-then-quotes", "short-line-not-last", "never-closed",
         "break-after-count"],
)  # fmt: skip
def test_the_exact_readers_line_errors_are_found_without_the_file_in_memory(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, body: str, expected: str
) -> None:
    """A file with quotes whose lines the exact reader refuses - a line break inside quotes, a
    wrong field count, a quote never closed (the csv module's field limit) - gets the exact
    reader's error, found line by line (tables._read_csv_lines) without the exact reader,
    which holds the whole file as text and as lines (about 2.6× a wide file for such an
    error; up to 0.4.3 it read these). In the last case a wrong field count comes first and a
    line break inside quotes after it: the exact reader counts the fields of every line
    before it compares them, so the quote is its error."""
    path = tmp_path / "x.csv"
    path.write_bytes(b"t_s,v,note\n" + body.encode())
    exact = outcome(EXACT, path)[2]
    assert exact is not None and exact.startswith(f"x.csv {expected}"), exact
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    with pytest.raises(MissionError) as err:
        read(path)
    assert str(err.value) == exact
    assert err.value.line == int(expected.split("line ")[1].split(":")[0])


LINE_TEXTS = ("OK", '"a,b"', '"x, ""y"", z"', 'say "hi"', '"open', 'close"', '"two\nlines"', "")
"""Cells of :func:`_quoted_csv`'s files: quoted commas, quotes that do not open a field, a
quote left open, a line break inside quotes."""


def _quoted_csv(rng: np.random.Generator) -> bytes:
    """A small CSV with quotes of every kind (:data:`LINE_TEXTS`), now and then a short or a
    long line, a header with a trailing comma, blank lines (a form feed too), CRLF, a BOM, a
    cut end."""
    n_cols = int(rng.choice([1, 2, 3, 5]))
    lines = [",".join(('"c%d"' if rng.random() < 0.2 else "c%d") % i for i in range(n_cols))]
    if rng.random() < 0.05:
        lines[0] += ","
    for _ in range(int(rng.choice([0, 1, 2, 3, 40]))):
        row = [
            str(rng.choice(LINE_TEXTS)) if rng.random() < 0.3 else repr(float(rng.normal()))
            for _ in range(n_cols)
        ]
        row = row[:-1] if rng.random() < 0.05 else row + ["1"] * (rng.random() < 0.03)
        lines.append(",".join(row))
    for _ in range(int(rng.choice([0, 1, 3]))):
        lines.insert(int(rng.integers(0, len(lines) + 1)), str(rng.choice(["", "  ", "\x0c"])))
    newline = "\r\n" if rng.random() < 0.3 else "\n"
    text = newline.join(lines) + (newline if rng.random() < 0.6 else "")
    if rng.random() < 0.3:
        text = text[: max(len(text) - int(rng.integers(1, 4)), 1)]
    return (("\ufeff" if rng.random() < 0.1 else "") + text).encode()


def _lines_only(path: Path, label: str, journal: tb.Journal) -> tb.Table | None:
    return tb._read_csv_lines(path, label, journal)


@pytest.mark.parametrize(
    ("make", "seed"),
    [
        (_quoted_csv, 31),
        (lambda rng: _random_csv(rng, text=True, texts=QUOTED), 32),
        (lambda rng: _random_csv(rng, text=True), 33),
        (_random_csv, 34),
    ],
    ids=["quotes", "quoted-commas", "text", "numbers"],
)
def test_the_line_by_line_reader_is_the_exact_one(
    tmp_path: Path, small: None, make: Any, seed: int
) -> None:
    """On seeded files of every shape - quotes of every kind, quoted commas, text columns,
    numbers; short, long and cut lines, blank lines, CRLF, a BOM - the line-by-line reader
    (tables._read_csv_lines) gives the exact reader's table, repairs or error, file by file,
    and declines none of them but a file whose line breaks are all a lone CR (classic Mac OS:
    the exact reader's own repair)."""
    rng = np.random.default_rng(seed)
    path = tmp_path / "x.csv"
    errors = 0
    logging.disable(logging.WARNING)
    try:
        for _ in range(400):
            raw = make(rng)
            path.write_bytes(raw)
            read_it, error = agrees_with_exact(_lines_only, path)
            # declined: only classic Mac OS line breaks
            assert read_it or (b"\n" not in raw and b"\r" in raw), raw
            errors += error is not None
    finally:
        logging.disable(logging.NOTSET)
    assert errors >= 10, errors


@pytest.mark.parametrize(
    "blank", ["\n", "  \r\n", "\n\x0c\n"], ids=["empty", "spaces", "form-feed"]
)
def test_a_header_after_blank_lines_is_read_by_the_typed_reader(
    tmp_path: Path, small: None, monkeypatch: pytest.MonkeyPatch, blank: str
) -> None:
    """Blank lines before the header (a logger's empty first line) are skipped as the exact
    reader skips them, by the typed reader, which starts pyarrow at the header (up to 0.4.3
    the exact reader read such a file, about 9x a narrow file's size; in 0.4.4 the
    line-by-line reader, 4.75x and ten times slower)."""
    path = tmp_path / "depth.csv"
    path.write_text(
        blank + "t_s,depth_m\n" + "".join(f"{k / 10:.1f},{10 + k % 7}.5\n" for k in range(900))
    )
    expected = outcome(EXACT, path)
    monkeypatch.setattr(tb, "_read_csv_exact", lambda *_: pytest.fail("the exact reader ran"))
    monkeypatch.setattr(tb, "_read_csv_lines", lambda *_: pytest.fail("read line by line"))
    typed = tb._read_csv_typed
    tables: list[tb.Table | None] = []
    monkeypatch.setattr(tb, "_read_csv_typed", lambda *a: tables.append(typed(*a)) or tables[-1])
    table, repairs = read(path)
    last = tables[-1]  # of the file, or of its blanked copy (a form feed)
    assert last is not None and last.df is table.df
    assert expected[0] is not None and expected[1] == repairs == []
    assert_same_table(table, expected[0])
    first = 2 + blank.count("\n")
    assert table.lines[0] == first and table.lines[-1] == first + 899
    assert table.df["depth_m"].iloc[1] == 11.5


def test_the_exact_reader_parses_in_memory_without_room_for_its_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The exact reader hands pandas its lines in a temporary file (tables._body_file); with
    no room for it (a full TMPDIR) it hands them over in memory, the same table."""
    path = tmp_path / "x.csv"
    path.write_text('\nt_s,v,note\n0.0,1.5,"a,b"\n0.1,2.5,ok\n0.2,-3.5e-3,\n')
    expected, repairs, error = outcome(EXACT, path)
    assert expected is not None and error is None and repairs == []

    def full(*_args: Any) -> Any:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(tb, "_body_file", full)
    table, _, error = outcome(EXACT, path)
    assert table is not None and error is None
    assert_same_table(table, expected)
    assert table.df["v"].tolist() == [1.5, 2.5, -3.5e-3]
    assert table.lines.tolist() == [3, 4, 5]
