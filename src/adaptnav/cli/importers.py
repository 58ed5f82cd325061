"""Importers of external recordings into mission folders: ``adaptnav import akit``, ``rtklib``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import Force, Quiet, Stages, app, console, fail, output

import_app = typer.Typer(
    help="Import external recordings as mission folders (docs/akit.md, docs/rtklib.md).",
    no_args_is_help=True,
)
app.add_typer(import_app, name="import")


def _fmt(value: Any, spec: str) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return "[" + ", ".join(format(v, spec) for v in value) + "]"
    return format(value, spec)


def _first_line(exc: Exception) -> str:
    """The one line the command prints for a refused input: the message's first line, or the
    exception's type when it has no message."""
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def _print_repairs(info: dict[str, Any]) -> None:
    """One line per repair recorded in an import.json (a dropped truncated line, ...)."""
    for repair in info["repairs"]:
        line = repair.get("line")
        at = repair["file"] if line is None else f"{repair['file']} line {line}"  # None: whole file
        console.print(f"[yellow]repaired:[/] {at}: {repair['action']} ({repair['detail']})")


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
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Import one Snapir AUV (A-KIT) segment as a mission folder.

    Applies the data README's corrections (index time, IMU y axis, reference and DVL time
    offsets, DVL lever arm), estimating the reference offset L and the IMU's position from the
    data, adds a semi-synthetic depth sensor (reference depth plus seeded noise) and, with
    --faults, seeded DVL faults. Prints the estimated offsets beside the README's values;
    import.json in the mission folder records them.
    """
    from adaptnav.importers.akit import import_segment
    from adaptnav.mission import MissionError

    if not depth_sigma_m > 0.0:
        fail(f"--depth-sigma-m: {depth_sigma_m} must be > 0")
    with output(out, force, inputs=[src]) as tmp, Stages(quiet) as st:
        st.begin(f"importing A-KIT segment {trajectory} from {src}")
        try:
            import_segment(
                src,
                trajectory,
                tmp,
                seed=seed,
                faults=faults,
                depth_sigma_m=depth_sigma_m,
                fmt="csv" if csv else "parquet",
            )
        except (MissionError, ValueError, OSError) as exc:  # AkitError is a MissionError
            fail(_first_line(exc))
    _report_akit(out, trajectory, faults, seed)


def _report_akit(out: Path, trajectory: int, faults: bool, seed: int) -> None:
    """Print what the import of ``out`` recorded in import.json: the offsets, the repairs and
    the injected faults."""
    info = json.loads((out / "import.json").read_text(encoding="utf-8"))
    console.print(_akit_offsets(info, trajectory))
    _print_repairs(info)
    if faults:
        f = info["fault_injection"]
        console.print(
            f"DVL faults (seed {seed}): {len(f['spike_rows'])} spikes, lock loss "
            f"{f['lock_loss_window_s'][0]:.1f}-{f['lock_loss_window_s'][1]:.1f} s, "
            f"×{f['noise_factor']:g} noise {f['noisy_window_s'][0]:.1f}-"
            f"{f['noisy_window_s'][1]:.1f} s"
        )
    console.print(f"mission akit-{trajectory} written to {out} (depth is semi-synthetic)")


def _akit_offsets(info: dict[str, Any], trajectory: int) -> Table:
    """The offsets and the IMU's position of an A-KIT import.json: estimated, README and used
    (docs/akit.md, "The corrections")."""
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
    return table


def _parse_outages(spec: str) -> list[tuple[float, float]]:
    """``"60+15,100+30"`` → [(60, 15), (100, 30)]; ``""`` or ``"none"`` → []."""
    if spec.strip().lower() in ("", "none"):
        return []
    out = []
    for part in spec.split(","):
        start, plus, length = part.strip().partition("+")
        try:
            out.append((float(start), float(length if plus else "")))
        except ValueError:
            fail(f"--outages: {part.strip()!r} is not START+LENGTH in seconds (e.g. 60+15)")
    return out


@import_app.command("rtklib")
def rtklib(
    pos: Annotated[Path, typer.Option(help="RTKLIB .pos solution (GPST, lat/lon/height)")],
    imu: Annotated[Path, typer.Option(help="raw IMU CSV: acc (g), gyro (deg/s), counter (ms)")],
    out: Annotated[Path, typer.Option("--out", "-o", help="mission folder to write")],
    tag: Annotated[
        Path | None,
        typer.Option(help="the IMU file's RTKLIB time tag (default: the IMU file + .tag)"),
    ] = None,
    outages: Annotated[
        str,
        typer.Option(
            help="GNSS outages START+LENGTH (s from the first IMU sample), comma-separated, or "
            "'none' (default: the five of docs/rtklib.md)",
            show_default=False,
        ),
    ] = "default",
    time_offset_s: Annotated[
        float | None,
        typer.Option(
            help="IMU time offset (s; true = tag + offset) (default: estimated from the data)"
        ),
    ] = None,
    imu_noise: Annotated[
        str, typer.Option(help="IMU white noise: measured (parked), driving or published")
    ] = "measured",
    nhc: Annotated[
        bool,
        typer.Option(
            "--nhc/--no-nhc",
            help="add a non-holonomic constraint (zero lateral and vertical velocity) stream",
        ),
    ] = True,
    csv: Annotated[bool, typer.Option("--csv", help="write CSV tables (default Parquet)")] = False,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Import an RTKLIB-logged GNSS + IMU drive as a mission folder.

    Maps the IMU counter onto GPST through the time tag, estimates the IMU time offset from the
    gyro's yaw against the GNSS course, turns the IMU into the vehicle's axes, levels and takes
    the gyro bias while parked, carries the heading back from the first fast GNSS course, and
    withholds the RTK fixes in the outage windows (they stay in the truth, to score the drift).
    import.json in the mission folder records every estimate, check and left-out fix.
    """
    from adaptnav.importers.rtklib import DEFAULT_OUTAGES_S, NHC_SIGMA_M_S, import_drive
    from adaptnav.mission import MissionError

    if imu_noise not in ("measured", "driving", "published"):
        fail(f"--imu-noise: {imu_noise!r} must be measured, driving or published")
    windows = list(DEFAULT_OUTAGES_S) if outages == "default" else _parse_outages(outages)
    with output(out, force, inputs=[pos, imu]) as tmp, Stages(quiet) as st:
        st.begin(f"importing the drive {pos.name} + {imu.name}")
        try:
            import_drive(
                pos,
                imu,
                tmp,
                tag_path=tag,
                outages=windows,
                time_offset_s=time_offset_s,
                imu_noise=imu_noise,  # type: ignore[arg-type]
                nhc_sigma_m_s=NHC_SIGMA_M_S if nhc else None,
                fmt="csv" if csv else "parquet",
            )
        except (MissionError, ValueError, OSError) as exc:  # RtklibError is a MissionError
            fail(_first_line(exc))
    _report_rtklib(out, len(windows), nhc)


def _report_rtklib(out: Path, n_windows: int, nhc: bool) -> None:
    """Print what the import of ``out`` recorded in import.json: the estimates and checks, the
    repairs and the GNSS fixes left out by reason."""
    info = json.loads((out / "import.json").read_text(encoding="utf-8"))
    console.print(_rtklib_checks(info))
    _print_repairs(info)
    for reason, n in info["gnss"]["left_out"].items():
        if n:
            console.print(f"GNSS left out: {n} ({reason})")
    extra = ", non-holonomic constraint" if nhc else ""
    console.print(f"mission written to {out} ({n_windows} outage window(s){extra})")


def _rtklib_checks(info: dict[str, Any]) -> Table:
    """The estimates and checks of an RTKLIB import.json beside the published or expected
    values (docs/rtklib.md, "The corrections" and "The start")."""
    table = Table(title="RTKLIB drive: estimates and checks")
    for col in ("quantity", "value", "published / expected"):
        table.add_column(col)
    off = info["imu_time_offset_s"]
    table.add_row("IMU time offset (s)", f"{off['used']:+.3f}", f"{off['published']:+.3f}")
    mnt = info["mounting"]
    table.add_row(
        "forward-axis angle (deg)",
        f"{mnt['forward_axis_angle_deg']:+.1f}",
        f"0 (without the mounting yaw: {mnt['forward_axis_angle_without_the_last_yaw_deg']:+.1f})",
    )
    ini = info["initial"]
    table.add_row("initial roll, pitch, yaw (deg)", _fmt(ini["rpy_deg"], "+.1f"), "-")
    table.add_row("gyro bias, parked (deg/s)", _fmt(ini["gyro_bias_deg_s"], "+.3f"), "-")
    g = info["gnss"]
    table.add_row("GNSS fixes aiding / epochs", f"{g['used']} / {g['epochs']}", "-")
    return table
