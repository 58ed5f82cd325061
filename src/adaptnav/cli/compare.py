"""``adaptnav compare`` and ``adaptnav report``: several filters on one mission, and its page.

* ``adaptnav compare MISSION_DIR --filters meskf,maeskf,vb[,oracle][,floor] --out DIR``: one
  alignment, every filter from it (:func:`adaptnav.analysis.compare.compare`), the comparison folder
  written to ``--out`` (runs, ``comparison.csv/json``, figures) and a table of ours beside the
  paper's Table 3; with ``--json`` only one JSON object on stdout (filter → metrics), progress
  on stderr. With ``--smooth`` every filter is RTS-smoothed and its forward solution's RMSE is
  shown beside the smoothed one (docs/smoothing.md).
* ``adaptnav report COMPARE_DIR [--out FILE]``: the self-contained HTML report of a comparison
  folder (:func:`adaptnav.viz.report.write_report`); prints its path.

A user's mistake (unknown filter, a mission without a reference, a bad mission) exits with
status 2 and one line on stderr (:func:`adaptnav.cli._app.fail`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich import box
from rich.table import Table

from adaptnav.cli._app import (
    FILTER_LABELS,
    Force,
    Quiet,
    Smooth,
    Stages,
    app,
    console,
    fail,
    freeze_heap,
    output,
    warn_compared,
)

if TYPE_CHECKING:
    from adaptnav.analysis.compare import Comparison

DEFAULT_CLI_FILTERS = "meskf,maeskf,vb,robust"
"""The paper's three and the default one; ``oracle`` needs a simulated mission and ``floor`` a
reference attitude, so both are asked for by name."""


def comparison_table(cmp: Comparison, name: str | None = None) -> Table:
    """A rich table of a comparison that fits an 80-column terminal (smoothed and beside the
    paper's Table 3 too; the filter names wrap if they must): RMSE and relative RMSE, the
    paper's Table 3 beside them where it applies, the largest horizontal error, the mean NEES
    of position, velocity and attitude (docs/metrics.md), and the readings each gated sensor's
    gate rejected; the caption gives the horizontal distance and the duration scored and what
    a consistent filter's NEES does. ``name`` stands for the mission's name in the title. A
    smoothed comparison's numbers are the smoothed solutions', with the forward solutions'
    RMSE and relative RMSE beside them (docs/smoothing.md)."""
    from adaptnav.analysis.compare import NEES_BAND_TEXT, PAPER_TABLE3

    frame = cmp.table()
    paper = cmp.mission_name in PAPER_TABLE3
    gated = [s for s in cmp.sensors() if frame[f"{s}_rejected"].sum() > 0]
    beside = " beside the paper's Table 3" if paper else ""
    first = frame.iloc[0] if len(frame) else None
    caption = (
        None
        if first is None
        else f"{first['distance_m'] / 1000.0:.2f} km (horizontal) in "
        f"{first['duration_min']:.1f} min scored; NEES: mean over the epochs, for a "
        f"consistent filter {NEES_BAND_TEXT}"
    )
    smoothed = bool(cmp.forward)
    if smoothed and caption is not None:
        caption += "; RTS-smoothed solutions, fwd.: the forward ones'"
    title = f"{name or cmp.mission_name}: ours{' (RTS-smoothed)' if smoothed else ''}{beside}"
    # Two-line headers keep the columns as narrow as their numbers; no rules or padding but the
    # one space between columns, and filter names that may wrap, keep the table in 80 columns.
    table = Table(
        title=title, caption=caption, box=box.SIMPLE_HEAD, show_edge=False, padding=(0, 0)
    )
    columns = ["filter", "RMSE\nm", "rel.\n%"]
    if smoothed:
        columns += ["fwd.\nm", "fwd.\n%"]
    if paper:
        columns += ["paper\nm", "paper\n%"]
    columns += ["max h.\nm", "NEES\npos", "NEES\nvel", "NEES\natt"]
    columns += [f"{s}\nrej." for s in gated]
    for i, col in enumerate(columns):
        if i == 0:
            table.add_column(col, overflow="fold")
        else:
            table.add_column(col, justify="right", no_wrap=True)

    def f(value: float, fmt: str) -> str:
        return "-" if value is None or not math.isfinite(value) else fmt.format(value)

    for _, r in frame.iterrows():
        cells = [
            FILTER_LABELS.get(str(r["filter"]), str(r["filter"])),
            f(r["rmse_m"], "{:.1f}"),
            f(r["relative_rmse_pct"], "{:.3f}"),
        ]
        if smoothed:
            cells += [f(r["forward_rmse_m"], "{:.1f}"), f(r["forward_relative_rmse_pct"], "{:.3f}")]
        if paper:
            cells += [f(r["paper_rmse_m"], "{:.0f}"), f(r["paper_relative_rmse_pct"], "{:.2f}")]
        cells.append(f(r["max_horizontal_error_m"], "{:.1f}"))
        for block in ("position", "velocity", "attitude"):
            v = r[f"mean_nees_{block}"]
            cells.append(f(v, "{:.2f}" if abs(v) < 10 else "{:.1f}" if abs(v) < 100 else "{:.0f}"))
        cells += [str(int(r[f"{s}_rejected"])) for s in gated]
        table.add_row(*cells)
    return table


@app.command("compare")
def compare_cmd(
    mission_dir: Annotated[Path, typer.Argument(help="mission folder (mission.toml + tables)")],
    filters: Annotated[
        str,
        typer.Option(
            "--filters", "-f", help="comma-separated: meskf, maeskf, vb, robust, oracle, floor"
        ),
    ] = DEFAULT_CLI_FILTERS,
    out: Annotated[Path, typer.Option("--out", "-o", help="comparison folder to write")] = Path(
        "runs/compare"
    ),
    as_json: Annotated[
        bool, typer.Option("--json", help="print only one JSON object (filter → metrics)")
    ] = False,
    smooth: Smooth = False,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Run several filters on one mission from one shared alignment and compare them.

    Writes each run (adaptnav evaluate OUT/FILTER works), comparison.csv/json and the
    figures to --out, and prints RMSE and relative RMSE beside the paper's Table 3 when the
    mission is one of its trajectories (paper-1, paper-2). With --smooth each filter is
    RTS-smoothed: the metrics are the smoothed solutions' and the forward ones' RMSE and
    relative RMSE are shown beside them (forward_ columns; docs/smoothing.md). Make the HTML
    page with adaptnav report OUT.
    """
    from adaptnav.analysis.compare import compare, parse_filters
    from adaptnav.core.units import UnitError
    from adaptnav.mission import MissionError, load_mission
    from adaptnav.viz import interactive  # plotting: imported only when drawn
    from adaptnav.viz.pngs import PngJob

    try:
        names = parse_filters(filters)
    except ValueError as exc:
        fail(f"--filters: {exc}")
    with output(out, force, inputs=[mission_dir]) as tmp, Stages(quiet) as st:
        try:
            st.begin(f"loading {mission_dir}")
            mission = load_mission(mission_dir)
            cmp = compare(mission, names, progress=st.compiling_step, smooth=smooth)
        except (MissionError, UnitError, ValueError, OSError) as exc:
            # ValueError covers the alignment, the oracle's and floor's missing columns, and a
            # mission without a reference; OSError a missing or unreadable folder.
            fail(str(exc))
        freeze_heap()
        st.begin("drawing the figures")
        with PngJob(cmp, tmp) as pngs:  # the PNGs in child processes
            zoomable = interactive.comparison_figures(cmp)
            st.begin(f"writing {out}/")
            cmp.save(tmp, figures=pngs, interactive=zoomable)
    if as_json:
        typer.echo(json.dumps(cmp.to_json(), allow_nan=False))
        return
    console.print(comparison_table(cmp))
    console.print(f"runs, comparison.csv/json and figures in {out}/; `adaptnav report {out}`")
    warn_compared(cmp.results)


@app.command("report")
def report_cmd(
    compare_dir: Annotated[
        Path, typer.Argument(help="comparison folder written by adaptnav compare")
    ],
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="HTML file (default: COMPARE_DIR/report.html)"),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="replace an existing --out file")] = False,
    quiet: Quiet = False,
) -> None:
    """Write one self-contained HTML report of a comparison folder and print its path."""
    from adaptnav.viz.report import ReportError, write_report

    if out is not None:
        _check_report_out(out, force)
    with Stages(quiet) as st:
        st.begin(f"writing the report of {compare_dir}")
        try:
            path = write_report(compare_dir, out)
        except ReportError as exc:
            fail(str(exc))
        except OSError as exc:
            fail(f"--out {out}: cannot write ({exc.strerror or exc})")
    typer.echo(str(path))


def _check_report_out(out: Path, force: bool) -> None:
    """An explicit ``--out`` must name an .html file, not a folder, and replaces a file only
    with ``--force`` (up to 0.4.4 it wrote over any file, a mission.toml included)."""
    if out.suffix.lower() not in (".html", ".htm"):
        fail(f"--out {out}: not an .html file name (the report is one HTML page)")
    if out.is_dir():
        fail(f"--out {out}: is a folder; give the report's file name (e.g. {out / 'report.html'})")
    if out.exists() and not force:
        fail(f"--out {out}: exists; give --force to replace it")
