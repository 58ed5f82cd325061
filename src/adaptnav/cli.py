"""Command line: the only place that knows files and human units (degrees, hours)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, NoReturn

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from adaptnav import errorstate, propagation
from adaptnav.imu_noise import ImuNoise
from adaptnav.sim import kinematics as kin
from adaptnav.units import UnitError

FILTER_CHOICES = ("meskf", "maeskf", "vb")

app = typer.Typer(
    help="adaptnav: asynchronous multirate multi-sensor inertial navigation.",
    no_args_is_help=True,
    add_completion=False,
)
console = Console()
err_console = Console(stderr=True)


def paper_imu() -> ImuNoise:
    """The IMU of the paper's Table 2 (in-run parts; turn-on offsets are the alignment's job)."""
    return ImuNoise.from_datasheet(
        arw=(0.0667, "deg/sqrt(h)"),
        vrw=(55, "ug/sqrt(Hz)"),
        gyro_bias_sigma=(1, "deg/h"),
        gyro_bias_tau=(1, "h"),
        accel_bias_sigma=(0.25, "mg"),
        accel_bias_tau=(1, "h"),
    )


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="folder for the demo's table and figure")] = Path(
        "runs/demo"
    ),
    minutes: Annotated[float, typer.Option(min=0.5, help="length of the run")] = 10.0,
    seed: Annotated[int, typer.Option(help="seed of the IMU noise")] = 1,
) -> None:
    """Interim demo: free-inertial navigation on a known-motion trajectory.

    A vessel turning at 2 m/s with wave-induced roll, pitch and heave at 26.8° N; its exact IMU
    signals are derived analytically and integrated back by the compiled mechanization, once
    perfect and once with the paper's IMU noise (ARW, VRW, in-run biases). The fusion filters
    and the paper's Table-3 comparison replace this once the engine and simulator land.
    """
    out.mkdir(parents=True, exist_ok=True)
    dt = 0.01
    n = round(minutes * 60.0 / dt)
    t = dt * np.arange(-1, n + 1)
    motion = kin.turn_with_waves()
    dtheta, dvel = kin.imu_increments(motion, t)
    truth = kin.true_states(motion, t[1:])
    noise = paper_imu()
    rng = np.random.default_rng(seed)
    b_g = rng.normal(0.0, noise.gyro_bias_sigma, 3)
    b_a = rng.normal(0.0, noise.accel_bias_sigma, 3)
    noisy_th = dtheta + b_g * dt + rng.normal(0.0, noise.arw * math.sqrt(dt), dtheta.shape)
    noisy_v = dvel + b_a * dt + rng.normal(0.0, noise.vrw * math.sqrt(dt), dvel.shape)

    every = 100
    rows = []
    errors: dict[str, list[float]] = {}
    for label, th, dv in (
        ("perfect IMU", dtheta, dvel),
        ("paper IMU (Table 2)", noisy_th, noisy_v),
    ):
        x, P = truth[0].copy(), np.zeros((15, 15))
        wp, fp = th[0] / dt, dv[0] / dt
        err = [0.0]
        for start in range(1, n + 1, every):
            j = min(n, start + every - 1)
            x, P, wp, fp = propagation.propagate(
                x, P, th[start : j + 1], dv[start : j + 1], dt, wp, fp, np.zeros(12)
            )
            err.append(float(np.linalg.norm(errorstate.difference(truth[j], x)[:2])))
        errors[label] = err
        att = np.degrees(np.abs(errorstate.difference(truth[n], x)[6:9]).max())
        rows.append((label, err[-1], max(err), att))

    table = Table(title=f"Free-inertial navigation, {minutes:g} min at 100 Hz (interim demo)")
    for col in ("IMU", "final horiz. error (m)", "max horiz. error (m)", "final att. error (deg)"):
        table.add_column(col)
    for label, fin, mx, att in rows:
        table.add_row(label, f"{fin:.3g}", f"{mx:.3g}", f"{att:.3g}")
    console.print(table)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    minutes_axis = np.arange(len(next(iter(errors.values())))) * every * dt / 60.0
    for (label, err), style in zip(errors.items(), ("-", "--"), strict=True):
        ax.semilogy(minutes_axis[1:], np.maximum(err[1:], 1e-9), style, label=label)
    ax.set_xlabel("time (min)")
    ax.set_ylabel("horizontal position error (m)")
    ax.set_title("Strapdown INS alone on a known trajectory")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "free_inertial_error.png", dpi=120)
    plt.close(fig)
    with (out / "free_inertial.csv").open("w") as fh:
        fh.write("imu,final_horizontal_error_m,max_horizontal_error_m,final_attitude_error_deg\n")
        for label, fin, mx, att in rows:
            fh.write(f"{label},{fin:.6g},{mx:.6g},{att:.6g}\n")
    console.print(f"Figure and table written to {out}/")
    console.print(
        "[yellow]Interim demo:[/] the three filters (MESKF, MAESKF, VB-MAESKF) on the paper's "
        "trajectory No. 1 replace this once the fusion engine and the simulator land."
    )


def _fail(message: str) -> NoReturn:
    """A user's mistake (bad file, bad config): one clear line, exit status 2, no traceback."""
    err_console.print(f"[bold red]error:[/] {message}")
    raise typer.Exit(2)


@app.command("run")
def run_cmd(
    mission_dir: Annotated[Path, typer.Argument(help="mission folder (mission.toml + tables)")],
    filter: Annotated[
        str, typer.Option("--filter", "-f", help="meskf | maeskf | vb (default: the mission's)")
    ] = "",
    out: Annotated[Path, typer.Option("--out", "-o", help="run folder to write")] = Path(
        "runs/run"
    ),
    epoch_policy: Annotated[
        str, typer.Option(help="exact (default) | grid (the paper's); default: the mission's")
    ] = "",
) -> None:
    """Run one filter on a mission; write the solution, ledger and R-hat record to --out."""
    from adaptnav import api, results
    from adaptnav.align import AlignmentError
    from adaptnav.io import MissionError, load_mission

    if filter and filter not in FILTER_CHOICES:
        _fail(f"--filter: {filter!r} is not one of {', '.join(FILTER_CHOICES)}")
    if epoch_policy and epoch_policy not in ("exact", "grid"):
        _fail(f"--epoch-policy: {epoch_policy!r} is not 'exact' or 'grid'")
    try:
        mission = load_mission(mission_dir)
        result = api.run(mission, filter or None, epoch_policy=epoch_policy or None)  # type: ignore[arg-type]
    except (MissionError, AlignmentError, UnitError) as exc:
        _fail(str(exc))
    results.save(result, out)
    if mission.truth is not None:
        mission.truth.to_parquet(out / "truth.parquet", index=False)
    counts = results.ledger_counts(result.ledger)
    table = Table(title=f"{result.filter} on {result.mission}")
    for col in ("sensor", "used", "rejected", "dropped"):
        table.add_column(col)
    for sensor, c in counts.items():
        table.add_row(sensor, *(str(c.get(k, 0)) for k in ("used", "rejected", "dropped")))
    console.print(table)
    rate = result.meta.get("imu_samples_per_s", float("nan"))
    console.print(f"{result.meta['imu_samples']} IMU samples, {rate:,.0f} samples/s; run in {out}/")


@app.command("evaluate")
def evaluate_cmd(
    run_dir: Annotated[Path, typer.Argument(help="run folder written by `adaptnav run`")],
    as_json: Annotated[bool, typer.Option("--json", help="print one JSON object")] = False,
    mission: Annotated[
        Path | None, typer.Option(help="mission folder to take the reference from")
    ] = None,
) -> None:
    """RMSE, relative RMSE, distance, duration, ledger counts vs the reference (P-32, P-33)."""
    import json

    import pandas as pd

    from adaptnav import evaluate, results
    from adaptnav.io import MissionError, load_mission

    try:
        result = results.load(run_dir)
        if mission is not None:
            truth = load_mission(mission).truth
        elif (run_dir / "truth.parquet").is_file():
            truth = pd.read_parquet(run_dir / "truth.parquet")
        else:
            truth = None
    except (results.RunFolderError, MissionError) as exc:
        _fail(str(exc))
    if truth is None:
        _fail(f"{run_dir}: no reference (truth.parquet) and no --mission with a [truth] table")
    metrics = evaluate.evaluate(result, truth)
    d = metrics.to_dict()
    if as_json:
        typer.echo(json.dumps({"filter": result.filter, **d}, default=str))
        return
    table = Table(title=f"{result.filter} on {result.mission} (against the reference)")
    table.add_column("metric")
    table.add_column("value")
    for key, label, fmt in (
        ("rmse_m", "RMSE (m)", "{:.3f}"),
        ("relative_rmse_pct", "relative RMSE (%)", "{:.3f}"),
        ("horizontal_rmse_m", "horizontal RMSE (m)", "{:.3f}"),
        ("max_horizontal_error_m", "max horizontal error (m)", "{:.3f}"),
        ("distance_m", "travelled distance (m)", "{:.1f}"),
        ("duration_s", "duration (s)", "{:.1f}"),
    ):
        value = d.get(key)
        table.add_row(label, "n/a" if value is None else fmt.format(value))
    console.print(table)
    counts = Table(title="ledger")
    for col in ("sensor", "used", "rejected", "dropped", "mean NIS"):
        counts.add_column(col)
    for sensor, c in metrics.counts.items():
        nis = metrics.mean_nis.get(sensor)
        counts.add_row(
            sensor, *(str(c.get(k, 0)) for k in ("used", "rejected", "dropped")),
            "n/a" if nis is None or nis != nis else f"{nis:.2f}",
        )  # fmt: skip
    console.print(counts)


@app.command()
def simulate(
    preset: Annotated[str, typer.Argument(help="paper-1 | paper-2 | demo")],
    out: Annotated[Path, typer.Option("--out", "-o", help="mission folder to write")],
    seed: Annotated[int, typer.Option(help="seed of every random stream")] = 1,
    clean: Annotated[
        bool,
        typer.Option(
            "--clean",
            help="only what the filter models: no outliers, dropouts, "
            "noise segments, sea-state depth noise, pendulum errors or jitter",
        ),
    ] = False,
    perfect: Annotated[
        bool, typer.Option("--perfect", help="no sensor or IMU error at all (waves kept)")
    ] = False,
    enable: Annotated[
        list[str] | None, typer.Option("--enable", help="turn a disturbance on (repeatable)")
    ] = None,
    disable: Annotated[
        list[str] | None, typer.Option("--disable", help="turn a disturbance off (repeatable)")
    ] = None,
) -> None:
    """Simulate one of the paper's sea trials (or a short demo) as a mission folder.

    The vessel is alongside for 10 minutes (alignment), then under way at about 2 m/s near
    Qeshm island with the paper's IMU (Table 2), DVL (3 Hz), depth meter and pendulum
    inclinometer (1 Hz) and GPS (1 Hz, initialisation and reference). Every disturbance is on
    by default and can be switched; what was injected is saved with the mission as truth.
    Disturbance names: waves, imu_white_noise, imu_in_run_bias, imu_turn_on_bias,
    imu_uncalibrated_turn_on, imu_scale_factor, sensor_noise, dvl_noise_segments,
    dvl_outliers, dvl_dropouts, depth_sea_state, inclinometer_pendulum, clock_offsets,
    clock_jitter (see docs/simulation.md).
    """
    from dataclasses import fields, replace

    from adaptnav.sim.scenarios import PRESETS
    from adaptnav.sim.scenarios import simulate as run_simulation
    from adaptnav.sim.sensors import Disturbances

    if preset not in PRESETS:
        _fail(f"preset {preset!r}: use one of {', '.join(PRESETS)}")
    if clean and perfect:
        _fail("--clean and --perfect exclude each other")
    d = Disturbances.clean() if clean else Disturbances.perfect() if perfect else Disturbances()
    known = {f.name for f in fields(Disturbances)}
    for names, value in ((enable or [], True), (disable or [], False)):
        for name in names:
            if name not in known:
                _fail(f"unknown disturbance {name!r}; known: {', '.join(sorted(known))}")
            d = replace(d, **{name: value})
    path = run_simulation(preset, seed, out, d)
    on = [k for k, v in d.as_dict().items() if v]
    console.print(f"mission {preset} (seed {seed}) written to {path}")
    console.print(f"disturbances on: {', '.join(on) or 'none'}")


@app.command()
def version() -> None:
    """Print the package version."""
    from adaptnav import __version__

    console.print(__version__)
