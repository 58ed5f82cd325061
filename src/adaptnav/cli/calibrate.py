"""``adaptnav fit-dvl``: a DVL's scale and misalignment fitted against a mission's reference
(:mod:`adaptnav.analysis.dvl_fit`; docs/calibration.md, 'Against a reference')."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from adaptnav.cli._app import Quiet, Stages, app, console
from adaptnav.cli._app import fail as _fail
from adaptnav.core.units import UnitError


@app.command("fit-dvl")
def fit_dvl_cmd(
    mission_dir: Annotated[Path, typer.Argument(help="mission folder with a reference (truth)")],
    sensor: Annotated[
        str | None, typer.Option(help="the DVL's sensor name (default: the first DVL)")
    ] = None,
    source: Annotated[
        str,
        typer.Option(help="reference velocity: velocity (its columns) | position (its rate)"),
    ] = "velocity",
    as_json: Annotated[bool, typer.Option("--json", help="print one JSON object")] = False,
    quiet: Quiet = False,
) -> None:
    """Fit a DVL's scale factor and mounting misalignment to the mission's reference.

    No filter: at each reading the reference's velocity and attitude give the velocity an
    error-free DVL would read, and the readings are fitted to (1 + scale) M(misalignment) times
    it by least squares, in the conventions of the filter's calibration states (scale in %,
    roll, pitch, yaw in degrees; docs/calibration.md), so the numbers can be set in
    mission.toml (mounting_rpy_deg) or compared with a run's calibration.json. The σ allows for
    readings correlated from one to the next. --source position takes the reference's
    velocity from the rate of change of its positions instead of its velocity columns (they
    differ where a reference's velocity is not the derivative of its positions).
    """
    from adaptnav.analysis.dvl_fit import fit_dvl
    from adaptnav.mission import MissionError, load_mission

    if source not in ("velocity", "position"):
        _fail(f"--source {source!r}: use velocity or position")
    with Stages(quiet) as st:
        st.begin(f"loading {mission_dir}")
        try:
            mission = load_mission(mission_dir)
            st.begin("fitting the DVL to the reference")
            fit = fit_dvl(mission, sensor, "velocity" if source == "velocity" else "position")
        except (MissionError, UnitError, ValueError) as exc:
            _fail(f"{mission_dir}: {exc}")
    if as_json:
        typer.echo(
            json.dumps(
                {
                    "sensor": fit.sensor,
                    "source": fit.source,
                    "estimate": fit.estimate,
                    "sigma": fit.sigma,
                    "readings": fit.readings,
                    "used": fit.used,
                    "in_gaps": fit.in_gaps,
                    "outside_reference": fit.outside,
                    "residual_rms_m_s": list(fit.residual_rms_m_s),
                    "rho": fit.rho,
                    "bandwidth": fit.bandwidth,
                }
            )
        )
        return
    table = Table(title=f"{fit.sensor} against the reference's {fit.source}")
    for col in ("quantity", "estimate ± σ"):
        table.add_column(col)
    for name, value in fit.estimate.items():
        unit = "%" if name == "scale" else "deg"
        table.add_row(f"{fit.sensor}.{name}", f"{value:+.3f} ± {fit.sigma[name]:.3f} {unit}")
    console.print(table)
    rms = ", ".join(f"{v:.4f}" for v in fit.residual_rms_m_s)
    # Readings without reference either side are said, not silently fewer.
    gaps = f" ({fit.in_gaps} more in reference gaps, left out)" if fit.in_gaps else ""
    if fit.outside:
        gaps += f" ({fit.outside} more outside the time the reference and the IMU cover, left out)"
    console.print(
        f"{fit.used} of {fit.readings} readings used{gaps} (the rest more than 5 σ off); "
        f"residual RMS x, y, z {rms} m/s; lag-1 correlation {fit.rho:.2f}, allowed for in σ"
    )
