"""Importers of external recordings into mission folders: ``adaptnav import akit``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import app, console, fail

import_app = typer.Typer(
    help="Import external recordings as mission folders (docs/akit.md).",
    no_args_is_help=True,
)
app.add_typer(import_app, name="import")


def _fmt(value: Any, spec: str) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return "[" + ", ".join(format(v, spec) for v in value) + "]"
    return format(value, spec)


@import_app.command("akit")
def akit(
    trajectory: Annotated[int, typer.Option("--trajectory", "-n", help="segment number N")],
    src: Annotated[
        Path, typer.Option(help="folder with IMU/DVL/GT_trajectoryN.csv (the A-KIT recordings)")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="mission folder to write")],
    faults: Annotated[
        bool,
        typer.Option(
            "--faults", help="inject DVL faults: 1 % spikes, a 20-s lock loss, 60 s of 5× noise"
        ),
    ] = False,
    seed: Annotated[int, typer.Option(help="seed of the depth noise and the faults")] = 0,
    depth_sigma_m: Annotated[
        float, typer.Option(help="σ (m) of the semi-synthetic depth's noise")
    ] = 0.05,
    csv: Annotated[bool, typer.Option("--csv", help="write CSV tables (default Parquet)")] = False,
) -> None:
    """Import one Snapir AUV (A-KIT) segment as a mission folder.

    Applies the data README's corrections (index time, IMU y axis, reference and DVL time
    offsets, DVL lever arm), estimating the reference offset L and the IMU's position from the
    data, adds a semi-synthetic depth sensor (reference depth plus seeded noise) and, with
    --faults, seeded DVL faults. Prints the estimated offsets beside the README's values;
    import.json in the mission folder records them.
    """
    from adaptnav.io import MissionError
    from adaptnav.io.akit import import_segment

    if not depth_sigma_m > 0.0:
        fail(f"--depth-sigma-m: {depth_sigma_m} must be > 0")
    try:
        root = import_segment(
            src,
            trajectory,
            out,
            seed=seed,
            faults=faults,
            depth_sigma_m=depth_sigma_m,
            fmt="csv" if csv else "parquet",
        )
    except (MissionError, ValueError, OSError) as exc:  # AkitError is a MissionError
        fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    info = json.loads((root / "import.json").read_text(encoding="utf-8"))
    table = Table(title=f"A-KIT segment {trajectory}: offsets (estimated from the data)")
    for col in ("quantity", "estimated", "README", "used"):
        table.add_column(col)
    ref, dvl, arm = info["reference_offset_s"], info["dvl_offset_s"], info["imu_lever_arm_m"]
    table.add_row(
        "reference offset L (s)",
        _fmt(ref["estimated"], "+.3f"),
        _fmt(ref["readme"], "+.2f"),
        _fmt(ref["used"], "+.3f"),
    )
    table.add_row(
        "DVL offset (s)",
        _fmt(dvl["estimated"], "+.3f"),
        _fmt(dvl["readme"], "+.2f"),
        _fmt(dvl["used"], "+.3f"),
    )
    table.add_row(
        "IMU from reference point (m)",
        _fmt(arm["estimated"], "+.3f"),
        _fmt(arm["readme"], "+.1f"),
        _fmt(arm["used"], "+.3f"),
    )
    console.print(table)
    for repair in info["repairs"]:
        console.print(
            f"[yellow]repaired:[/] {repair['file']} line {repair['line']}: {repair['action']} "
            f"({repair['detail']})"
        )
    if faults:
        f = info["fault_injection"]
        console.print(
            f"DVL faults (seed {seed}): {len(f['spike_rows'])} spikes, lock loss "
            f"{f['lock_loss_window_s'][0]:.1f}-{f['lock_loss_window_s'][1]:.1f} s, "
            f"×{f['noise_factor']:g} noise {f['noisy_window_s'][0]:.1f}-"
            f"{f['noisy_window_s'][1]:.1f} s"
        )
    console.print(f"mission akit-{trajectory} written to {root} (depth is semi-synthetic)")
