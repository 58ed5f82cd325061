"""``adaptnav import nmea``: NMEA 0183 logs to GNSS and heading tables (docs/nmea.md)."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import Force, Quiet, Stages, console, fail, output
from adaptnav.cli.importers import _first_line, import_app

SHOWN_REPAIRS = 5
"""Repairs printed one by one; the rest are counted (all are in import.json)."""


def _floats(option: str, text: str | None, sizes: tuple[int, ...]) -> tuple[float, ...] | None:
    """``"1.5,1.5,3"`` → (1.5, 1.5, 3.0); a count not in ``sizes`` or a non-number fails."""
    if text is None:
        return None
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        fail(f"{option}: {text!r} is not comma-separated numbers")
    if len(values) not in sizes:
        expected = " or ".join(map(str, sizes))
        fail(f"{option}: {text!r} has {len(values)} value(s), expected {expected}")
    return values


def _utc(text: str | None) -> dt.datetime | None:
    """An ISO 8601 time; without a zone it is UTC."""
    if text is None:
        return None
    try:
        t = dt.datetime.fromisoformat(text)
    except ValueError:
        fail(f"--t0-utc: {text!r} is not an ISO 8601 time (e.g. 2024-03-10T23:59:30Z)")
    return t.replace(tzinfo=dt.UTC) if t.tzinfo is None else t


def _date(text: str | None) -> dt.date | None:
    if text is None:
        return None
    try:
        return dt.date.fromisoformat(text)
    except ValueError:
        fail(f"--date: {text!r} is not a date YYYY-MM-DD")


@import_app.command("nmea")
def nmea(
    logs: Annotated[
        list[Path], typer.Argument(help="NMEA 0183 log(s), read in this order as one stream")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="folder to write")],
    mission: Annotated[
        Path | None,
        typer.Option(help="mission folder to copy with the GNSS/heading sensors added or replaced"),
    ] = None,
    t0_utc: Annotated[
        str | None,
        typer.Option(
            help="UTC time of t_s = 0, ISO 8601, needed with --mission "
            "(default: the first reading's)"
        ),
    ] = None,
    date: Annotated[
        str | None, typer.Option(help="UTC date of the first sentence, for logs without RMC/ZDA")
    ] = None,
    gnss_name: Annotated[str, typer.Option(help="GNSS sensor name")] = "gnss",
    heading_name: Annotated[str, typer.Option(help="heading sensor name")] = "heading",
    uere_m: Annotated[
        float | None,
        typer.Option(
            help="UERE σ (m) of a standalone fix: σ_N = HDOP × UERE / √2 (default: 3, "
            "importers.nmea.UERE_M)"
        ),
    ] = None,
    sigma_m: Annotated[
        str | None,
        typer.Option(help="GNSS σ (m), one or N,E,D (default: median of the per-fix model)"),
    ] = None,
    heading_sigma_deg: Annotated[
        float | None,
        typer.Option(help="heading σ (deg) (default: the mission's, else 0.5; HDG compass 2)"),
    ] = None,
    lever_arm_m: Annotated[
        str | None,
        typer.Option(help="antenna from the IMU, X,Y,Z m body FRD (default: mission's, 0)"),
    ] = None,
    use_height: Annotated[
        bool | None,
        typer.Option(
            "--use-height/--no-use-height", help="aid with the height (default: mission's, no)"
        ),
    ] = None,
    min_interval_s: Annotated[
        float | None,
        typer.Option(
            help="keep GNSS fixes at least this far apart, s (their errors are correlated: "
            "docs/nmea.md) (default: the mission's, else all)"
        ),
    ] = None,
    gnss_talker: Annotated[
        str | None,
        typer.Option(
            help="take the GGA, RMC and VTG of this talker only (GP, GN ...): two receivers in "
            "a log"
        ),
    ] = None,
    heading_talker: Annotated[
        str | None,
        typer.Option(
            help="take the headings (HDT, THS, HDG, HDM) of this talker only (HE, GP, HC ...): two "
            "headings in a log"
        ),
    ] = None,
    declination_deg: Annotated[
        float | None,
        typer.Option(
            help="declination (deg, east positive) for HDG compass headings without variation: "
            "the table keeps them magnetic and the heading section gets declination_deg"
        ),
    ] = None,
    csv: Annotated[bool, typer.Option("--csv", help="write CSV tables (default Parquet)")] = False,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Import NMEA 0183 GGA/HDT/THS/HDG/HDM (and RMC/VTG/ZDA) logs as GNSS and heading tables.

    With --mission: a copy of that mission with the sensors added or replaced (--t0-utc
    required). Without: the tables and sensors.toml, the sections for a mission.toml. Every
    line not used is in import.json's repair log with its reason (docs/nmea.md).
    """
    # Imported here, not at the top: the importer pulls in the mission format (pandas,
    # SciPy), which every other command's start-up need not pay for.
    from adaptnav.importers.nmea import UERE_M, Options, import_nmea
    from adaptnav.mission import MissionError

    lever = _floats("--lever-arm-m", lever_arm_m, (3,))
    t0, day = _utc(t0_utc), _date(date)
    inputs = [*logs, *([mission] if mission else [])]
    with output(out, force, inputs=inputs) as tmp, Stages(quiet) as st:
        st.begin(f"reading {len(logs)} NMEA log(s)")
        try:
            opts = Options(
                gnss_name, heading_name, _floats("--sigma-m", sigma_m, (1, 3)),
                heading_sigma_deg, (lever[0], lever[1], lever[2]) if lever else None,
                use_height, "csv" if csv else "parquet", min_interval_s,
            )  # fmt: skip
            talkers = {k: v for k, v in (("GGA", gnss_talker), ("HDT", heading_talker)) if v}
            import_nmea(logs, tmp, mission=mission, t0_utc=t0, date=day,
                        uere_m=UERE_M if uere_m is None else uere_m,
                        options=opts, talkers=talkers,
                        declination_deg=declination_deg)  # fmt: skip
        except (MissionError, ValueError, OSError) as exc:  # NmeaError is a MissionError
            fail(_first_line(exc))
    _report(out, mission is not None)


def _report(out: Path, merged: bool) -> None:
    """Print what import.json records: readings, time mapping, σ, repairs."""
    info = json.loads((out / "import.json").read_text(encoding="utf-8"))
    console.print(_summary(info))
    repairs = info["repairs"]
    for r in repairs[:SHOWN_REPAIRS]:
        console.print(f"[yellow]repaired:[/] {r['file']} line {r['line']}: {r['action']} "
                      f"({r['detail']})")  # fmt: skip
    if len(repairs) > SHOWN_REPAIRS:
        counts = ", ".join(f"{a}: {n}" for a, n in info["repairs_by_action"].items())
        console.print(f"[yellow]{len(repairs)} line(s) in the repair log[/] ({counts}; all in "
                      f"{out / 'import.json'})")  # fmt: skip
    what = "mission" if merged else "tables and sensors.toml"
    console.print(f"NMEA {what} written to {out}")


def _summary(info: dict[str, Any]) -> Table:
    table = Table(title="NMEA import")
    table.add_column("quantity")
    table.add_column("value")
    time = info["time"]
    table.add_row("t_s = 0 at (UTC)", f"{time['t0_utc']} ({time['t0_source']})")
    table.add_row("date from", f"{time['date_source']}, {time['midnight_rollovers']} roll-over(s)")
    g = info["gnss"]
    quality = ", ".join(f"{k} {n}" for k, n in g["by_quality"].items())
    table.add_row("GNSS fixes", f"{g['fixes']} ({quality})" if g["fixes"] else "0")
    for name, s in info["sections"].items():
        table.add_row(f"σ of sensors.{name}", f"{s['sigma'][0]} {s['sigma'][1]}")
    heading = info["heading"]
    table.add_row("headings", f"{heading['readings']} ({heading['north']})"
                  if heading["readings"] else "0")  # fmt: skip
    v = info["velocity"]
    if v["rows"]:
        median = v["sog_m_s_p10_p50_p90"][1]
        speeds = f"{v['rows']} rows, median {median:.2f} m/s, max {v['max_sog_m_s']:.2f}"
        table.add_row("speed over ground (not aiding)", speeds)
    if "mission" in info:
        span = info["mission"]["imu_span_s"]
        inside = ", ".join(f"{k} {n}" for k, n in info["mission"]["readings_in_span"].items())
        table.add_row("inside the IMU time", f"{inside} (IMU {span[0]:.1f} .. {span[1]:.1f} s)")
    return table
