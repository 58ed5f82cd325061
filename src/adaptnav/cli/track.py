"""``adaptnav export track``: a run's solution as CSV and KML (docs/export.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from adaptnav.cli._app import Force, Quiet, Stages, console, fail, output
from adaptnav.cli.rosbag import export_app


@export_app.command("track")
def export_track(
    run: Annotated[Path, typer.Argument(help="run folder (adaptnav run --out)")],
    out: Annotated[Path, typer.Option("--out", "-o", help="folder to write")],
    forward: Annotated[
        bool, typer.Option(help="the forward pass of a --smooth run, not its smoothed solution")
    ] = False,
    max_points: Annotated[int, typer.Option(help="most vertices of a KML line")] = 20000,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Write a run's track as track.csv (degrees, metres, the σ it claims) and track.kml.

    The KML holds the solution's line, its start and end, and the run folder's reference
    (truth.parquet) when it has one; docs/export.md.
    """
    from adaptnav.api.results import RunFolderError, load, load_truth
    from adaptnav.importers.track import write_track

    if max_points < 2:
        fail(f"--max-points: {max_points} must be >= 2")
    with output(out, force, inputs=[run]) as tmp, Stages(quiet) as st:
        st.begin(f"writing {out}")
        try:
            result = load(run)
            if forward and result.forward is None:
                fail(f"{run}: --forward: not a --smooth run (no forward solution)")
            solution = result.forward if forward and result.forward is not None else result.solution
            reference = load_truth(run)
            info = write_track(solution, tmp, run.resolve().name, reference, max_points)
        except (RunFolderError, ValueError, OSError) as exc:
            fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    console.print(
        f"{info['rows']} rows to track.csv, a line of {info['vertices']} vertices to track.kml"
        f"{' with the reference' if reference is not None else ''}; written to {out}"
    )
