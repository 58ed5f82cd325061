"""The core commands: demo, run, evaluate, simulate, version."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import (
    FILTER_CHOICES,
    FILTER_LABELS,
    PAPER_TABLE3,
    app,
    console,
)
from adaptnav.cli._app import fail as _fail
from adaptnav.units import UnitError


@app.command()
def demo(
    out: Annotated[
        Path, typer.Option(help="folder for the mission, runs, table and figure")
    ] = Path("runs/demo"),
    preset: Annotated[str, typer.Option(help="paper-1 | paper-2 | demo")] = "paper-1",
    seed: Annotated[int, typer.Option(help="simulation seed")] = 1,
) -> None:
    """The main job: simulate the paper's trajectory, run MESKF, MAESKF and VB-MAESKF, compare.

    Simulates the preset with every disturbance on (seeded), aligns once over the static
    window and gives all three filters that same start, then prints a Table-3-style
    comparison next to the paper's figures and writes the runs, the table (CSV, JSON) and a
    figure of the position error over time to --out.
    """
    import json

    import pandas as pd

    from adaptnav import api, evaluate, results
    from adaptnav.io import load_mission
    from adaptnav.sim.scenarios import PRESETS
    from adaptnav.sim.scenarios import simulate as run_simulation

    if preset not in PRESETS:
        _fail(f"preset {preset!r}: use one of {', '.join(PRESETS)}")
    out.mkdir(parents=True, exist_ok=True)
    console.print(f"simulating {preset} (seed {seed}) ...")
    mission_dir = run_simulation(preset, seed, out / "mission")
    mission = load_mission(mission_dir)
    assert mission.truth is not None
    console.print("aligning over the static window ...")
    x0, P0, t0, info = api.initial_state(mission)
    rows: list[dict[str, Any]] = []
    errors = {}
    for kind in ("meskf", "maeskf", "vb"):
        console.print(f"running {FILTER_LABELS[kind]} ...")
        result = api.run(mission, kind, initial=(x0, P0, t0))
        results.save(result, out / kind)
        mission.truth.to_parquet(out / kind / "truth.parquet", index=False)
        m = evaluate.evaluate(result, mission.truth)
        errors[kind] = evaluate.position_errors(result.solution, mission.truth)
        counts = m.counts.get("dvl", {})
        rows.append(
            {
                "filter": FILTER_LABELS[kind],
                "rmse_m": m.rmse_m,
                "relative_rmse_pct": m.relative_rmse_pct,
                "distance_m": m.distance_m,
                "duration_min": m.duration_s / 60.0,
                "dvl_used": counts.get("used", 0),
                "dvl_rejected": counts.get("rejected", 0),
                "paper_rmse_m": PAPER_TABLE3.get(preset, {}).get(kind, (None, None))[0],
                "paper_relative_rmse_pct": PAPER_TABLE3.get(preset, {}).get(kind, (None, None))[1],
                "imu_samples_per_s": result.meta.get("imu_samples_per_s"),
            }
        )
    frame = pd.DataFrame(rows)
    frame.to_csv(out / "comparison.csv", index=False)
    (out / "comparison.json").write_text(
        json.dumps({"preset": preset, "seed": seed, "rows": rows}, indent=2)
    )

    table = Table(title=f"{preset} (seed {seed}): ours beside the paper's Table 3")
    for col in ("filter", "RMSE m", "rel. %", "paper m", "paper %", "km", "min", "DVL used/rej."):
        table.add_column(col)
    for r in rows:
        table.add_row(
            r["filter"], f"{r['rmse_m']:.1f}", f"{r['relative_rmse_pct']:.3f}",
            "-" if r["paper_rmse_m"] is None else f"{r['paper_rmse_m']:.0f}",
            "-" if r["paper_relative_rmse_pct"] is None else f"{r['paper_relative_rmse_pct']:.2f}",
            f"{r['distance_m'] / 1000:.2f}", f"{r['duration_min']:.1f}",
            f"{r['dvl_used']} / {r['dvl_rejected']}",
        )  # fmt: skip
    console.print(table)
    source = {"gyrocompass": "gyrocompassing", "heading": "the mission's given heading"}
    how = source.get(str(info.get("heading_source")), str(info.get("initial")))
    console.print(f"static alignment: heading from {how}; all three filters start from it")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5))
    for (kind, err), style in zip(errors.items(), ("-", "--", "-."), strict=True):
        ax.plot((err["t_s"] - t0) / 60.0, err["error_m"], style, label=FILTER_LABELS[kind])
    ax.set_xlabel("time since navigation start (min)")
    ax.set_ylabel("3-D position error (m)")
    ax.set_title(f"Position error, {preset} simulation (seed {seed})")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "position_error.png", dpi=120)
    plt.close(fig)
    console.print(f"runs, comparison.csv/json and position_error.png written to {out}/")
    console.print(
        "[yellow]Not yet:[/] the HTML report, q and process-noise sweeps and the oracle "
        "baseline (issue 5)."
    )


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
