"""Command line: the only place that knows files and human units (degrees, hours)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from adaptnav import errorstate, propagation
from adaptnav.imu_noise import ImuNoise
from adaptnav.sim import kinematics as kin

app = typer.Typer(
    help="adaptnav: asynchronous multirate multi-sensor inertial navigation.",
    no_args_is_help=True,
    add_completion=False,
)
console = Console()


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


@app.command()
def version() -> None:
    """Print the package version."""
    from adaptnav import __version__

    console.print(__version__)
