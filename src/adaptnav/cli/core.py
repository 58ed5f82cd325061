"""The core commands: demo, run, evaluate, simulate, version."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import (
    FILTER_CHOICES,
    Force,
    Quiet,
    Smooth,
    Stages,
    app,
    console,
    freeze_heap,
    output,
    run_progress,
    warn,
    warn_compared,
    warn_sensors,
)
from adaptnav.cli._app import fail as _fail
from adaptnav.core.units import UnitError

if TYPE_CHECKING:
    import pandas as pd

    from adaptnav.analysis.evaluate import Metrics
    from adaptnav.api.results import Result
    from adaptnav.sim.sensors import Calibration


@app.command()
def demo(
    out: Annotated[
        Path, typer.Option(help="folder for the mission, runs, table, figures and report")
    ] = Path("runs/demo"),
    preset: Annotated[str, typer.Option(help="paper-1 | paper-2 | demo")] = "paper-1",
    seed: Annotated[int, typer.Option(help="simulation seed", min=0)] = 1,
    smooth: Smooth = False,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """The main job: simulate a paper trajectory, compare the filters, write the HTML report.

    Simulates the preset with every disturbance on (seeded) into --out/mission, aligns once
    over the static window and runs MESKF, MAESKF, VB-MAESKF, robust and the oracle from that
    same start (as adaptnav compare does), writes the comparison folder to --out (runs,
    comparison.csv/json, figures) and the HTML report --out/report.html, and prints the table
    beside the paper's Table 3 and the report's path. With --smooth each filter is
    RTS-smoothed and shown beside its forward solution (docs/smoothing.md).
    """
    from adaptnav.analysis.compare import compare
    from adaptnav.api.runner import heading_origin
    from adaptnav.cli.compare import comparison_table
    from adaptnav.mission import load_mission
    from adaptnav.sim.scenarios import PRESETS
    from adaptnav.sim.scenarios import simulate as run_simulation
    from adaptnav.viz import interactive
    from adaptnav.viz.pngs import PngJob, import_in_background
    from adaptnav.viz.report import write_report

    if preset not in PRESETS:
        _fail(f"preset {preset!r}: use one of {', '.join(PRESETS)}")
    filters = ["meskf", "maeskf", "vb", "robust", "oracle"]
    freeze_heap()
    with output(out, force) as tmp, Stages(quiet) as st:
        st.begin(f"simulating {preset} (seed {seed})")
        mission_dir = run_simulation(preset, seed, tmp / "mission")
        st.begin("loading the mission")
        mission = load_mission(mission_dir)
        plotting = import_in_background()
        cmp = compare(mission, filters, progress=st.compiling_step, smooth=smooth)
        plotting.join()
        freeze_heap()
        st.begin("drawing the figures")
        with PngJob(cmp, tmp) as pngs:
            zoomable = interactive.comparison_figures(cmp)
            st.begin(f"writing the runs, comparison and figures to {out}/")
            # Written in a temporary folder renamed to --out at the end: record the final paths.
            final_mission = out.absolute() / "mission"
            cmp.save(tmp, mission_dir=final_mission, figures=pngs, interactive=zoomable)
        st.begin("writing the report")
        write_report(tmp, shown_as=out.absolute())
    report = out / "report.html"
    console.print(comparison_table(cmp, f"{preset} (seed {seed})"))
    warn_compared(cmp.results)
    how = heading_origin(cmp.initial)
    console.print(f"static alignment: heading from {how}; every filter starts from it")
    console.print(f"report: {report}")


@app.command("run")
def run_cmd(
    mission_dir: Annotated[Path, typer.Argument(help="mission folder (mission.toml + tables)")],
    filter: Annotated[
        str | None,
        typer.Option(
            "--filter",
            "-f",
            help="robust | meskf | maeskf | vb | oracle (default: the mission's kind, robust)",
        ),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="run folder to write")] = Path(
        "runs/run"
    ),
    epoch_policy: Annotated[
        str, typer.Option(help="exact (default) | grid (the paper's); default: the mission's")
    ] = "",
    smooth: Smooth = False,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Run one filter on a mission; write the solution, every reading's fate and R to --out.

    The run folder holds the navigation solution with its standard deviations, one row per
    sensor reading saying whether it was used, rejected (and by which test) or dropped (and
    why), and the measurement noise variance R the filter used at each reading. With --smooth
    the solution is the RTS-smoothed one and the filter's own is kept beside it as
    forward.parquet (docs/smoothing.md). --out is written whole at the end (a temporary folder
    beside it renamed into place); a non-empty --out is refused unless --force, which replaces
    it."""
    from adaptnav import api
    from adaptnav.api import results
    from adaptnav.engine.align import AlignmentError
    from adaptnav.mission import MissionError, load_mission

    if filter is not None and filter not in FILTER_CHOICES:
        _fail(f"--filter: {filter!r} is not one of {', '.join(FILTER_CHOICES)}")
    if epoch_policy and epoch_policy not in ("exact", "grid"):
        _fail(f"--epoch-policy: {epoch_policy!r} is not 'exact' or 'grid'")
    with output(out, force, inputs=[mission_dir]) as tmp, Stages(quiet) as st:
        try:
            st.begin(f"loading {mission_dir}")
            mission = load_mission(mission_dir)
            result = api.run(
                mission, filter or None, epoch_policy=epoch_policy or None, smooth=smooth,  # type: ignore[arg-type]
                progress=run_progress(st, filter or mission.config.filter.kind),
            )  # fmt: skip
        except (MissionError, AlignmentError, UnitError, ValueError) as exc:
            # ValueError also covers the oracle on a mission without the simulator's truth.
            _fail(str(exc))
        st.begin(f"writing {out}/")
        results.save(result, tmp, truth=mission.truth)
    _print_run(result, out)


def _print_run(result: Result, out: Path) -> None:
    """What ``run`` prints: the ledger counts per sensor, the speed and, for a smoothed run, the
    smoother's nodes and the memory their store took (docs/smoothing.md)."""
    from adaptnav.api import results

    counts = results.ledger_counts(result.ledger)
    table = Table(title=f"{result.filter} on {result.mission}")
    for col in ("sensor", "used", "rejected", "dropped"):
        table.add_column(col)
    for sensor, c in counts.items():
        table.add_row(sensor, *(str(c.get(k, 0)) for k in ("used", "rejected", "dropped")))
    console.print(table)
    if result.meta.get("calibration"):
        console.print(_calibration_table(result.meta["calibration"], result.forward is not None))
    if result.meta.get("initial") == "alignment":
        from adaptnav.api.runner import heading_origin

        console.print(f"static alignment: heading from {heading_origin(result.meta)}")
    rate = result.meta.get("imu_samples_per_s", float("nan"))
    console.print(f"{result.meta['imu_samples']} IMU samples, {rate:,.0f} samples/s; run in {out}/")
    sm = result.meta.get("smoother")
    if sm is not None:
        console.print(
            f"RTS-smoothed: {sm['nodes']:,} nodes, {sm['update_nodes']:,} with an update, "
            f"{sm['failed_nodes']} failed; store {sm['store_bytes'] / 2**20:,.1f} MiB; "
            "forward solution in forward.parquet"
        )
    warn_sensors(result.meta)


def _calibration_table(found: dict[str, dict[str, Any]], smoothed: bool) -> Table:
    """The run's calibration states (``calibration.json``; docs/calibration.md): each final
    estimate ± σ (of a ``smoothed`` run, the smoothed one: the whole run's), its σ allowing for
    correlated readings ('Correlated readings'; - where the run could not tell) and the prior
    σ, in the state's report unit."""
    when = "RTS-smoothed over the run" if smoothed else "at the end of the run"
    table = Table(title=f"calibration states {when}")
    for col in ("state", "estimate ± σ", "σ, correlated readings", "prior σ"):
        table.add_column(col)
    for name, c in found.items():
        unit = c["unit"]
        long_run = c.get("sigma_long_run")
        table.add_row(
            name,
            f"{c['estimate']:.3f} ± {c['sigma']:.3f} {unit}",
            "-" if long_run is None else f"{long_run:.3f} {unit}",
            f"{c['prior_sigma']:.3f} {unit}",
        )
    return table


@app.command("evaluate")
def evaluate_cmd(
    run_dir: Annotated[Path, typer.Argument(help="run folder written by adaptnav run")],
    as_json: Annotated[bool, typer.Option("--json", help="print one JSON object")] = False,
    mission: Annotated[
        Path | None, typer.Option(help="mission folder to take the reference from")
    ] = None,
    quiet: Quiet = False,
) -> None:
    """RMSE, relative RMSE, distance, NEES and reading counts of a run against the reference.

    RMSE is the root mean square of the 3-D position error over the reference samples, as in
    the paper (over the run's own rows when the reference is denser than they are: scored_at
    in --json). The distance is the horizontal length of the reference track (its N, E steps),
    so heave does not lengthen it; relative RMSE = 100 RMSE / distance. NEES (normalised
    estimation error squared) of position, velocity and attitude, with the full 3x3
    covariance blocks: its mean is 3 for a filter whose covariance matches its errors, and
    95 % of the epochs should lie in [0.216, 9.348]; velocity and attitude need them in the
    reference. Definitions: docs/metrics.md. A smoothed run (adaptnav run --smooth) is scored
    on its RTS-smoothed solution, and its forward one beside it (the forward_ keys of --json;
    docs/smoothing.md). A run with calibration states on a simulated mission whose
    simulation.json has the true calibration errors (--mission, else the mission folder the run
    records) has each state's true value, estimate, error and error/σ too (the calibration key
    of --json; docs/metrics.md, 'Calibration'). It warns (stderr, and the warnings of --json)
    when the reference covers less than 95 % of the run, when its stamps look offset from the
    run's (reference_lag_s, from the velocities), and when a mean NEES leaves epochs out
    (docs/metrics.md, 'What is scored').
    """
    from adaptnav.analysis import evaluate
    from adaptnav.api.results import jsonable

    with Stages(quiet) as st:
        st.begin(f"loading {run_dir} and its reference")
        result, truth, source = _run_and_reference(run_dir, mission)
        st.begin("scoring against the reference")
        try:
            metrics = evaluate.evaluate(result, truth)
        except ValueError as exc:  # a reference without the columns or times it needs
            _fail(f"{run_dir if str(exc).startswith('solution ') else source}: {exc}")
        try:
            forward = evaluate.forward_metrics(result, truth)
        except ValueError as exc:
            # The reference passed with the smoothed solution, at the same times
            # (results.check_forward): what fails now is forward.parquet's.
            _fail(f"{run_dir / 'forward.parquet'}: {exc}")
        cal = _calibration_errors(result, mission)
    d = metrics.to_dict()
    scored = _scoring_warnings(metrics, forward)
    if as_json:
        import json

        extra: dict[str, Any] = {} if forward is None else evaluate.forward_columns(forward)
        if forward is not None:
            extra["forward_nees_position_epochs"] = forward.nees_position_epochs
        if cal:
            extra["calibration"] = cal
        extra["warnings"] = [w["message"] for w in result.meta.get("warnings", [])] + scored
        typer.echo(json.dumps({"filter": result.filter, **d, **jsonable(extra)}, default=str))
        return
    console.print(_metrics_table(result, metrics, d, forward))
    console.print(_ledger_table(metrics))
    if cal:
        console.print(_calibration_errors_table(cal))
    warn_sensors(result.meta)
    for message in scored:
        warn(message)


def _scoring_warnings(metrics: Metrics, forward: Metrics | None) -> list[str]:
    """What ``evaluate`` warns of the scoring itself (docs/metrics.md): a reference covering
    part of the run, and mean NEES over part of the epochs (the forward solution's too)."""
    from adaptnav.analysis import evaluate

    found = (evaluate.coverage_warning(metrics), evaluate.lag_warning(metrics))
    out = [w for w in (*found, evaluate.nees_warning(metrics)) if w]
    ahead = evaluate.nees_warning(forward) if forward is not None else None
    if ahead:
        out.append(f"forward solution: {ahead}")
    return out


def _calibration_errors(result: Result, mission: Path | None) -> dict[str, dict[str, Any]]:
    """The run's calibration estimates against the simulator's true values
    (:func:`adaptnav.analysis.calibration.calibration_errors`), from ``--mission`` or else the
    mission folder the run records (``meta.mission_dir``); empty when the run has no
    calibration states or that folder no true calibration errors; a failure naming the file
    and key when its ``simulation.json`` is damaged."""
    from adaptnav.analysis.calibration import (
        CalibrationTruthError,
        calibration_errors,
        mission_truth,
        run_surfaces,
    )

    folder = mission if mission is not None else result.meta.get("mission_dir")
    if not result.meta.get("calibration") or folder is None:
        return {}
    try:
        digest = result.meta.get("simulation_sha256")  # since 0.4.9: the run's simulation
        sha = digest if isinstance(digest, str) else None
        truth = mission_truth(folder, run_surfaces(result.meta), sha)
    except CalibrationTruthError as exc:  # a truth read in part would score silently wrong
        _fail(str(exc))
    return calibration_errors(result, truth)


def _calibration_errors_table(cal: dict[str, dict[str, Any]]) -> Table:
    """Each calibration state's true value, estimate ± σ, error, error/σ and error over the σ
    allowing for correlated readings (docs/metrics.md, 'Calibration')."""
    table = Table(title="calibration states against the simulator's true errors")
    for col in ("state", "true", "estimate ± σ", "error", "error / σ", "error / long-run σ"):
        table.add_column(col)
    for name, c in cal.items():
        unit = c["unit"]
        table.add_row(
            name,
            f"{c['true']:.3f} {unit}",
            f"{c['estimate']:.3f} ± {c['sigma']:.3f} {unit}",
            f"{c['error']:+.3f} {unit}",
            f"{c['error_over_sigma']:+.2f}",
            f"{c['error_over_sigma_long_run']:+.2f}",
        )
    return table


def _run_and_reference(run_dir: Path, mission: Path | None) -> tuple[Result, pd.DataFrame, Path]:
    """(the run, its reference, where the reference came from) for ``evaluate``: the
    ``--mission``'s truth table, else the run folder's ``truth.parquet``; a clear error
    (:func:`_fail`) when either cannot be read or there is none."""
    from adaptnav.api import results
    from adaptnav.mission import MissionError, load_mission

    source = mission if mission is not None else run_dir / results.TRUTH_FILE
    try:
        result = results.load(run_dir)
        if mission is not None:
            reference = load_mission(mission)
            name = reference.config.mission.name
            if name != result.mission:  # another mission's truth would score it, silently
                _fail(
                    f"--mission {mission}: mission {name!r}, and the run is of {result.mission!r} "
                    "(give the run's own mission folder)"
                )
            truth = reference.truth
        else:  # the run's own: checked against its summary.json (results.check_files)
            truth = results.load_truth(run_dir)
    except (results.RunFolderError, MissionError) as exc:
        _fail(str(exc))
    if truth is None:
        _fail(f"{run_dir}: no reference (truth.parquet) and no --mission with a [truth] table")
    return result, truth, source


def _metrics_table(
    result: Result, metrics: Metrics, d: dict[str, Any], forward: Metrics | None = None
) -> Table:
    """The ``evaluate`` table: RMSE, relative RMSE, distance and NEES (docs/metrics.md) from
    ``d``, the metrics as a dict; for a smoothed run (``forward``: the metrics of its forward
    solution) a column of the smoothed values and one of the forward ones (docs/smoothing.md)."""
    from adaptnav.analysis import evaluate

    lo, hi = evaluate.NEES_BAND
    n = metrics.samples
    smoothed = "" if forward is None else "RTS-smoothed, "
    table = Table(title=f"{result.filter} on {result.mission} ({smoothed}against the reference)")
    table.add_column("metric")
    columns = [d] if forward is None else [d, forward.to_dict()]
    for name in ["value"] if forward is None else ["smoothed", "forward"]:
        table.add_column(name)
    for key, label, fmt in (
        ("rmse_m", "RMSE (m)", "{:.3f}"),
        ("relative_rmse_pct", "relative RMSE (%)", "{:.3f}"),
        ("horizontal_rmse_m", "horizontal RMSE (m)", "{:.3f}"),
        ("max_horizontal_error_m", "max horizontal error (m)", "{:.3f}"),
        ("distance_m", "horizontal distance travelled (m)", "{:.1f}"),
        ("duration_s", "duration (s)", "{:.1f}"),
        ("reference_coverage", "share of the run the reference covers", "{:.3f}"),
        *(
            row
            for block in evaluate.NEES_BLOCKS
            for row in (
                (f"mean_nees_{block}", f"mean NEES, {block} (χ²(3): 3)", "{:.2f}"),
                (
                    f"nees_{block}_in_95",
                    f"NEES {block}, share in [{lo:.3f}, {hi:.3f}] (0.95)",
                    "{:.3f}",
                ),
                (f"nees_{block}_epochs", f"NEES {block}, epochs in the mean (of {n})", "{}"),
            )
        ),
    ):
        values = [c.get(key) for c in columns]
        table.add_row(label, *("n/a" if v is None else fmt.format(v) for v in values))
    notes = []
    if metrics.scored_at == "solution":
        notes.append("scored at the solution's rows, the reference (denser) interpolated to them")
    if not metrics.nees_uses_correlations:
        notes.append("NEES from P's diagonal only: the run folder has no cov_ columns")
    if notes:
        table.caption = "; ".join(notes)
    return table


def _ledger_table(metrics: Metrics) -> Table:
    """Readings used, rejected and dropped per sensor, with the mean NIS (docs/metrics.md)."""
    counts = Table(title="ledger")
    for col in ("sensor", "used", "rejected", "dropped", "mean NIS"):
        counts.add_column(col)
    for sensor, c in metrics.counts.items():
        nis = metrics.mean_nis.get(sensor)
        counts.add_row(
            sensor, *(str(c.get(k, 0)) for k in ("used", "rejected", "dropped")),
            "n/a" if nis is None or nis != nis else f"{nis:.2f}",
        )  # fmt: skip
    return counts


DvlScale = Annotated[
    str | None,
    typer.Option("--dvl-scale", metavar="S", help="true DVL scale factor (1.01: reads 1 % high)"),
]
DvlMisalignment = Annotated[
    str | None,
    typer.Option(
        "--dvl-misalignment-deg",
        metavar="ROLL,PITCH,YAW",
        help="true DVL misalignment (deg): ZYX Euler angles of the true DVL frame from the "
        "nominal one",
    ),
]
DepthBias = Annotated[
    str | None, typer.Option("--depth-bias-m", metavar="B", help="true depth-meter bias (m)")
]


def _latency_option(sensor: str, label: str) -> Any:
    """The ``simulate`` flag of one sensor's true latency (ms), ``--<sensor>-latency-ms``."""
    return typer.Option(
        f"--{sensor}-latency-ms",
        metavar="MS",
        help=f"true {label} latency (ms): each reading stamped this much after it was taken",
    )


DvlLatency = Annotated[str | None, _latency_option("dvl", "DVL")]
GpsLatency = Annotated[str | None, _latency_option("gps", "GPS")]
HeadingLatency = Annotated[str | None, _latency_option("heading", "heading")]
InclinometerBias = Annotated[
    str | None,
    typer.Option(
        "--inclinometer-bias-deg", metavar="ROLL,PITCH", help="true inclinometer biases (deg)"
    ),
]
"""The ``simulate`` flags of the sensors' true calibration errors (docs/simulation.md,
'Calibration errors'), parsed by :func:`_calibration`."""


@app.command()
def simulate(
    preset: Annotated[str, typer.Argument(help="paper-1 | paper-2 | demo")],
    out: Annotated[Path, typer.Option("--out", "-o", help="mission folder to write")],
    seed: Annotated[int, typer.Option(help="seed of every random stream", min=0)] = 1,
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
    dvl_scale: DvlScale = None,
    dvl_misalignment_deg: DvlMisalignment = None,
    depth_bias_m: DepthBias = None,
    inclinometer_bias_deg: InclinometerBias = None,
    dvl_latency_ms: DvlLatency = None,
    gps_latency_ms: GpsLatency = None,
    heading_latency_ms: HeadingLatency = None,
    force: Force = False,
    quiet: Quiet = False,
) -> None:
    """Simulate one of the paper's sea trials (or a short demo) as a mission folder.

    The vessel is alongside for 10 minutes (alignment), then under way at about 2 m/s near
    Qeshm island with the paper's IMU (Table 2), DVL (3 Hz), depth meter (1 Hz), pendulum
    inclinometer (5 Hz) and GPS (1 Hz, initialisation and reference). Every disturbance is on
    by default and can be switched; what was injected is saved with the mission as truth.
    Disturbance names: waves, imu_white_noise, imu_in_run_bias, imu_turn_on_bias,
    imu_uncalibrated_turn_on, imu_scale_factor, sensor_noise, dvl_noise_segments,
    dvl_outliers, dvl_dropouts, depth_sea_state, inclinometer_pendulum, clock_offsets,
    clock_jitter (see docs/simulation.md). The sensors are perfectly calibrated unless
    --dvl-scale, --dvl-misalignment-deg, --depth-bias-m, --inclinometer-bias-deg,
    --dvl-latency-ms, --gps-latency-ms or --heading-latency-ms give them true calibration
    errors (saved in simulation.json; docs/simulation.md, 'Calibration errors'); e.g.
    --dvl-misalignment-deg 0,0,1 --inclinometer-bias-deg=-0.2,0.1.
    """
    from dataclasses import fields, replace

    from adaptnav.sim.scenarios import PRESETS
    from adaptnav.sim.scenarios import simulate as run_simulation
    from adaptnav.sim.sensors import NO_CALIBRATION, Disturbances

    if preset not in PRESETS:
        _fail(f"preset {preset!r}: use one of {', '.join(PRESETS)}")
    if clean and perfect:
        _fail("--clean and --perfect exclude each other")
    d = Disturbances.clean() if clean else Disturbances.perfect() if perfect else Disturbances()
    both = sorted(set(enable or []) & set(disable or []))
    if both:
        _fail(f"--enable {both[0]} and --disable {both[0]} exclude each other")
    known = {f.name for f in fields(Disturbances)}
    for names, value in ((enable or [], True), (disable or [], False)):
        for name in names:
            if name not in known:
                _fail(f"unknown disturbance {name!r}; known: {', '.join(sorted(known))}")
            d = replace(d, **{name: value})
    latencies = (dvl_latency_ms, gps_latency_ms, heading_latency_ms)
    cal = _calibration(
        dvl_scale, dvl_misalignment_deg, depth_bias_m, inclinometer_bias_deg, latencies
    )
    with output(out, force) as tmp, Stages(quiet) as st:
        st.begin(f"simulating {preset} (seed {seed})")
        run_simulation(preset, seed, tmp, d, cal)
    on = [k for k, v in d.as_dict().items() if v]
    console.print(f"mission {preset} (seed {seed}) written to {out}")
    console.print(f"disturbances on: {', '.join(on) or 'none'}")
    if cal != NO_CALIBRATION:
        console.print("true calibration errors: in simulation.json")


def _calibration(
    dvl_scale: str | None,
    dvl_misalignment_deg: str | None,
    depth_bias_m: str | None,
    inclinometer_bias_deg: str | None,
    latencies_ms: tuple[str | None, str | None, str | None] = (None, None, None),
) -> Calibration:
    """The sensors' true calibration errors from ``simulate``'s flags (degrees to rad); a bad
    value fails naming its flag (docs/simulation.md, 'Calibration errors')."""
    from dataclasses import replace

    from adaptnav.core.units import DEG
    from adaptnav.sim.sensors import NO_CALIBRATION

    given = (
        ("--dvl-scale", dvl_scale, "dvl_scale", 1, 1.0),
        ("--dvl-misalignment-deg", dvl_misalignment_deg, "dvl_misalignment", 3, DEG),
        ("--depth-bias-m", depth_bias_m, "depth_bias", 1, 1.0),
        ("--inclinometer-bias-deg", inclinometer_bias_deg, "inclinometer_bias", 2, DEG),
        ("--dvl-latency-ms", latencies_ms[0], "dvl_latency", 1, 1e-3),
        ("--gps-latency-ms", latencies_ms[1], "gps_latency", 1, 1e-3),
        ("--heading-latency-ms", latencies_ms[2], "heading_latency", 1, 1e-3),
    )
    cal = NO_CALIBRATION
    for flag, text, name, count, unit in given:
        if text is None:
            continue
        values = tuple(v * unit for v in _numbers(flag, text, count))
        value: Any = values if count > 1 else values[0]
        try:
            cal = replace(cal, **{name: value})
        except ValueError as exc:
            _fail(f"{flag}: {exc}")
    return cal


def _numbers(flag: str, text: str, count: int) -> tuple[float, ...]:
    """``count`` comma-separated numbers of ``flag``'s value ``text``, or a failure naming it."""
    parts = text.split(",")
    wanted = "a number" if count == 1 else f"{count} comma-separated numbers"
    if len(parts) != count:
        _fail(f"{flag}: {text!r} is not {wanted} (got {len(parts)} values)")
    try:
        return tuple(float(p) for p in parts)
    except ValueError:
        _fail(f"{flag}: {text!r} is not {wanted}")


@app.command()
def version() -> None:
    """Print the package version."""
    from adaptnav import __version__

    console.print(__version__)
