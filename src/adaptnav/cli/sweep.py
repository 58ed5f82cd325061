"""``adaptnav sweep``: the paper's sweeps and a Monte Carlo over seeds, cached and parallel.

* ``adaptnav sweep q PRESET...``: relative RMSE against the gate coefficient q (the paper's
  Fig. 4), every filter gated at every q, VB-MAESKF ungated and the oracle as references;
* ``adaptnav sweep process-noise PRESET...``: against a factor on the gyro-bias process noise
  (the paper's Fig. 6);
* ``adaptnav sweep seeds PRESET...``: each filter at its defaults over many seeds (Table 3 as
  a distribution), with VB-MAESKF's win rate against each other filter and each filter's
  consistency (mean NEES of position, velocity and attitude; docs/metrics.md).

Each writes ``runs.csv`` (every run), ``summary.csv`` and a figure to ``--out``, and prints a
table (or, with ``--json``, one JSON object). The runs go to a local dask cluster of ``--jobs``
workers (1: in this process), or to the cluster of ``--scheduler`` / ``$ADAPTNAV_SCHEDULER``
(docs/scale-out.md). The library is :mod:`adaptnav.experiments`.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from adaptnav.cli._app import FILTER_LABELS, PAPER_TABLE3, Force, Quiet, app, console, fail, output

if TYPE_CHECKING:
    import pandas as pd

    from adaptnav.experiments.runner import SweepOutcome
    from adaptnav.experiments.spec import RunSpec

sweep_app = typer.Typer(
    help="Sweeps (q, gyro-bias process noise) and Monte Carlo over seeds, cached and parallel.",
    no_args_is_help=True,
)
app.add_typer(sweep_app, name="sweep")

Presets = Annotated[list[str], typer.Argument(help="simulation presets: paper-1, paper-2, demo")]
Cache = Annotated[
    Path, typer.Option(help="cache folder: simulated missions and finished runs (resumable)")
]
Out = Annotated[
    Path | None,
    typer.Option(help="folder for runs.csv, summary.csv, the figure (default: CACHE/<sweep kind>)"),
]
Jobs = Annotated[
    int | None,
    typer.Option(
        "--jobs",
        "-j",
        help="worker processes of the local cluster (default: the number of cores; 1: in this "
        "process); ignored with a scheduler",
    ),
]
SchedulerOption = Annotated[
    str | None,
    typer.Option(
        help="dask scheduler address (tcp://host:8786) to run on an existing cluster, or "
        "'local'; default: $ADAPTNAV_SCHEDULER, else a local cluster (docs/scale-out.md)"
    ),
]
AsJson = Annotated[bool, typer.Option("--json", help="print one JSON object, no table")]
ShowProgress = Annotated[bool, typer.Option(help="progress bars on stderr")]
KeepMissions = Annotated[
    bool, typer.Option(help="keep simulated missions in the cache after their runs")
]
DEFAULT_CACHE = Path("runs/sweep-cache")


def _label(kind: str) -> str:
    return FILTER_LABELS.get(kind, kind)


def _floats(text: str, option: str, geometric: bool) -> list[float]:
    """``a,b,c`` or ``start:stop:count`` (linear for q, geometric for scales)."""
    import numpy as np

    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
            if n < 1 or (geometric and (a <= 0 or b <= 0)):
                raise ValueError
            space = np.geomspace if geometric else np.linspace
            values = [float(v) for v in space(a, b, n)]
        else:
            values = [float(v) for v in text.split(",")]
    except ValueError:
        what = "start:stop:count" + (" (start, stop > 0)" if geometric else "")
        fail(f"{option}: {text!r} is not a list a,b,c or {what}")
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        fail(f"{option}: {text!r}: every value must be a finite number > 0")
    return values


def _common(
    presets: list[str], seeds: str, filters: str, jobs: int | None
) -> tuple[list[int], tuple[str, ...]]:
    from adaptnav.experiments.spec import available_filters, parse_seeds
    from adaptnav.sim.scenarios import PRESETS

    for p in presets:
        if p not in PRESETS:
            fail(f"preset {p!r}: use one of {', '.join(PRESETS)}")
    if jobs is not None and jobs < 1:
        fail(f"--jobs: {jobs} must be >= 1")
    try:
        seed_list = parse_seeds(seeds)
    except ValueError as exc:
        fail(f"--seeds: {exc}")
    try:
        names = available_filters(f.strip() for f in filters.split(","))
    except ValueError as exc:
        fail(f"--filters: {exc}")
    if not names:
        fail("--filters: no filter to run")
    return seed_list, names


def _within(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or inside it."""
    return path == folder or folder in path.parents


def _out_folder(out: Path | None, cache: Path, kind: str) -> Path:
    """The sweep's output folder: ``--out``, else ``CACHE/<kind>``. An ``--out`` that is the
    cache, holds it, or is (inside) its ``runs`` or ``missions`` folder is refused before any
    work: the runs and missions are written there while the output waits in a temporary
    folder, so at the end the output could not be renamed onto a folder that now had them in
    it (up to 0.4.7: exit 2 after the whole sweep, the output left in a hidden temporary), and
    with ``--force`` it replaced that folder whole, the cache with it (exit 0, every cached
    run and mission deleted)."""
    folder = out if out is not None else cache / kind
    target, held = Path(os.path.abspath(folder)), Path(os.path.abspath(cache))
    for a, b in ((target, held), (target.resolve(), held.resolve())):
        if _within(b, a) or _within(a, b / "runs") or _within(a, b / "missions"):
            fail(
                f"--out {folder}: is or holds the cache {cache} (--cache) or its runs or "
                "missions, which the sweep writes into and replacing --out would delete: "
                "choose an --out outside the cache (the default is CACHE/<sweep kind>) or a "
                "--cache outside --out"
            )
    return folder


def _execute(
    specs: list[RunSpec],
    cache: Path,
    jobs: int | None,
    scheduler: str | None,
    progress: bool,
    keep: bool,
) -> SweepOutcome:
    from adaptnav.experiments.cluster import SchedulerError
    from adaptnav.experiments.runner import run_sweep

    try:
        outcome = run_sweep(
            specs, cache, jobs=jobs, progress=progress, keep_missions=keep, scheduler=scheduler
        )
    except SchedulerError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"{cache}: {exc}")
    if outcome.failed and outcome.failed >= len(outcome.table):  # nothing to show: an error
        fail(f"every run failed ({outcome.failed}), e.g.: {next(iter(outcome.errors.values()))}")
    return outcome


def _records(frame: pd.DataFrame) -> list[dict[str, Any]]:
    from adaptnav.api.results import jsonable

    records: list[dict[str, Any]] = jsonable(frame.to_dict(orient="records"), "table")
    return records


def _write(outcome: SweepOutcome, tmp: Path, tables: dict[str, pd.DataFrame]) -> None:
    """``runs.csv`` and one CSV per table into the (temporary) output folder."""
    outcome.table.to_csv(tmp / "runs.csv", index=False)
    for name, frame in tables.items():
        frame.to_csv(tmp / f"{name}.csv", index=False)


def _finish(
    kind: str,
    outcome: SweepOutcome,
    out: Path,
    figure: str,
    tables: dict[str, pd.DataFrame],
    as_json: bool,
    extra: dict[str, Any],
) -> None:
    """Print what was written to ``out`` (a table, or one JSON object)."""
    files = {"runs": out / "runs.csv", "figure": out / figure}
    for name in tables:
        files[name] = out / f"{name}.csv"
    if outcome.failed:
        first = next(iter(outcome.errors.values()))
        console.print(f"[yellow]{outcome.failed} run(s) failed[/] (not cached), e.g.: {first}")
    if as_json:
        doc = {
            "sweep": kind,
            **extra,
            "runs": len(outcome.table),
            "ran": outcome.ran,
            "reused": outcome.reused,
            "failed": outcome.failed,
            "wall_s": outcome.wall_s,
            "files": {k: str(v) for k, v in files.items()},
            **{name: _records(frame) for name, frame in tables.items()},
        }
        typer.echo(json.dumps(doc))
        return
    console.print(
        f"{len(outcome.table)} runs: {outcome.ran} run now, {outcome.reused} from the cache, "
        f"{outcome.failed} failed, {outcome.wall_s:.0f} s; written to {out}/ "
        f"({', '.join(p.name for p in files.values())})"
    )


def _spread_table(title: str, spread: pd.DataFrame, parameter: str) -> Table:
    table = Table(title=title)
    for col in ("preset", "filter", "values", f"best at {parameter}", "best %",
                f"worst at {parameter}", "worst %", "worst/best"):  # fmt: skip
        table.add_column(col)
    for r in spread.itertuples(index=False):
        table.add_row(
            str(r.preset), _label(str(r.filter)), str(r.values), f"{r.best_at:g}",
            f"{r.best:.3f}", f"{r.worst_at:g}", f"{r.worst:.3f}", f"{r.worst_over_best:.2f}",
        )  # fmt: skip
    return table


def _nees_table(summary: pd.DataFrame) -> Table:
    """Mean over the runs of each filter's mean NEES and share of epochs in the band."""
    from adaptnav.analysis.compare import NEES_BAND_TEXT

    table = Table(
        title="Consistency: NEES, mean over the runs",
        caption=f"a consistent filter's NEES is {NEES_BAND_TEXT}",
    )
    blocks = ("position", "velocity", "attitude")
    for col in ("preset", "filter", *(f"NEES {b[:3]}" for b in blocks),
                *(f"{b[:3]} % in band" for b in blocks)):  # fmt: skip
        table.add_column(col, justify="left" if col in ("preset", "filter") else "right")

    def cell(r: Mapping[Any, Any], key: str, scale: float, fmt: str) -> str:
        v = r.get(key)
        return "-" if v is None or not math.isfinite(v) else fmt.format(scale * v)

    for r in summary.to_dict(orient="records"):
        table.add_row(
            str(r["preset"]),
            _label(str(r["filter"])),
            *(cell(r, f"mean_nees_{b}_mean", 1.0, "{:.2f}") for b in blocks),
            *(cell(r, f"nees_{b}_in_95_mean", 100.0, "{:.0f}") for b in blocks),
        )
    return table


@sweep_app.command("q")
def q_cmd(
    presets: Presets,
    seeds: Annotated[str, typer.Option(help="seeds: 1-5, 1,3,8 or 1-3,10")] = "1-5",
    q: Annotated[str, typer.Option("--q", help="q values: a,b,c or start:stop:count")] = (
        "200:2600:25"
    ),
    filters: Annotated[str, typer.Option(help="gated filters, comma-separated")] = (
        "meskf,maeskf,vb"
    ),
    cache: Cache = DEFAULT_CACHE,
    out: Out = None,
    jobs: Jobs = None,
    scheduler: SchedulerOption = None,
    as_json: AsJson = False,
    progress: ShowProgress = True,
    quiet: Quiet = False,
    keep_missions: KeepMissions = True,
    force: Force = False,
) -> None:
    """Relative RMSE against the gate coefficient q (the paper's Fig. 4).

    Every filter runs with the DVL gate on at each q (a DVL reading is rejected when the square
    of any of its innovation's components exceeds q times that component's predicted variance;
    VB-MAESKF gated too), plus VB-MAESKF ungated and the oracle at their defaults as
    reference lines. Prints each filter's spread over q (best, worst, worst/best of the mean
    over seeds).
    """
    from adaptnav.experiments.figures import plot_q_sweep
    from adaptnav.experiments.spec import q_sweep_specs
    from adaptnav.experiments.stats import curve, curve_spread, summarize

    seed_list, names = _common(presets, seeds, filters, jobs)
    q_values = _floats(q, "--q", geometric=False)
    specs = q_sweep_specs(presets, seed_list, q_values, names)
    folder = _out_folder(out, cache, "q")
    with output(folder, force) as tmp:
        outcome = _execute(specs, cache, jobs, scheduler, progress and not quiet, keep_missions)
        figure = plot_q_sweep(outcome.table, tmp / "q_sweep.png").name
        c = curve(outcome.table, "q")
        spread = curve_spread(c, "q")
        refs = summarize(outcome.table[outcome.table["q"].isna()])
        tables = {"summary": c, "spread": spread, "references": refs}
        _write(outcome, tmp, tables)
    extra = {"presets": presets, "seeds": seed_list, "q": q_values, "filters": list(names)}
    _finish("q", outcome, folder, figure, tables, as_json, extra)
    if not as_json:
        console.print(_spread_table("Relative RMSE (%) over q, mean over seeds", spread, "q"))
        for r in refs.itertuples(index=False):
            name = _label(str(r.filter)) + (", no gate" if r.filter == "vb" else "")
            console.print(f"reference {r.preset} {name}: {r.relative_rmse_pct_mean:.3f} %")


@sweep_app.command("process-noise")
def process_noise_cmd(
    presets: Presets,
    seeds: Annotated[str, typer.Option(help="seeds: 1-5, 1,3,8 or 1-3,10")] = "1-5",
    scales: Annotated[
        str, typer.Option(help="factors on the gyro-bias Q: a,b,c or start:stop:count (geometric)")
    ] = "0.01:100:9",
    filters: Annotated[str, typer.Option(help="filters, comma-separated")] = "meskf,maeskf,vb",
    cache: Cache = DEFAULT_CACHE,
    out: Out = None,
    jobs: Jobs = None,
    scheduler: SchedulerOption = None,
    as_json: AsJson = False,
    progress: ShowProgress = True,
    quiet: Quiet = False,
    keep_missions: KeepMissions = True,
    force: Force = False,
) -> None:
    """Relative RMSE against the gyro-bias process noise (the paper's Fig. 6).

    The gyro bias's driving-noise PSD in the filter's Q is multiplied by each factor (the
    mission and its alignment are unchanged); every filter at its default q.
    """
    from adaptnav.experiments.figures import plot_process_noise
    from adaptnav.experiments.spec import process_noise_specs
    from adaptnav.experiments.stats import curve, curve_spread

    seed_list, names = _common(presets, seeds, filters, jobs)
    scale_values = _floats(scales, "--scales", geometric=True)
    specs = process_noise_specs(presets, seed_list, scale_values, names)
    folder = _out_folder(out, cache, "process-noise")
    with output(folder, force) as tmp:
        outcome = _execute(specs, cache, jobs, scheduler, progress and not quiet, keep_missions)
        figure = plot_process_noise(outcome.table, tmp / "process_noise.png").name
        c = curve(outcome.table, "q_scale")
        spread = curve_spread(c, "q_scale")
        tables = {"summary": c, "spread": spread}
        _write(outcome, tmp, tables)
    extra = {"presets": presets, "seeds": seed_list, "scales": scale_values, "filters": list(names)}
    _finish("process-noise", outcome, folder, figure, tables, as_json, extra)
    if not as_json:
        title = "Relative RMSE (%) over the gyro-bias Q scale, mean over seeds"
        console.print(_spread_table(title, spread, "scale"))


@sweep_app.command("seeds")
def seeds_cmd(
    presets: Presets,
    seeds: Annotated[str, typer.Option(help="seeds: 1-20, 1,3,8 or 1-3,10")] = "1-20",
    filters: Annotated[
        str, typer.Option(help="filters, comma-separated (oracle: where available)")
    ] = "meskf,maeskf,vb,robust,oracle",
    cache: Cache = DEFAULT_CACHE,
    out: Out = None,
    jobs: Jobs = None,
    scheduler: SchedulerOption = None,
    as_json: AsJson = False,
    progress: ShowProgress = True,
    quiet: Quiet = False,
    keep_missions: KeepMissions = True,
    force: Force = False,
) -> None:
    """Monte Carlo over seeds: each filter at its defaults (Table 3 as a distribution).

    Prints mean ± std, median and range of RMSE and relative RMSE (over the horizontal track
    length) per filter beside the paper's Table 3, VB-MAESKF's win rate (paired by seed) and
    RMSE ratio against each other filter, and each filter's mean NEES of position, velocity
    and attitude with the share of epochs inside the band a consistent filter's NEES stays in
    95 % of the time (mean 3 and 95 % when the filter's covariance matches its errors).
    """
    from adaptnav.experiments.figures import plot_monte_carlo
    from adaptnav.experiments.spec import monte_carlo_specs
    from adaptnav.experiments.stats import paired_comparison, summarize

    seed_list, names = _common(presets, seeds, filters, jobs)
    specs = monte_carlo_specs(presets, seed_list, names)
    folder = _out_folder(out, cache, "seeds")
    with output(folder, force) as tmp:
        outcome = _execute(specs, cache, jobs, scheduler, progress and not quiet, keep_missions)
        figure = plot_monte_carlo(outcome.table, tmp / "monte_carlo.png").name
        summary = summarize(outcome.table)
        comparison = paired_comparison(outcome.table, "vb")
        tables = {"summary": summary, "comparison": comparison}
        _write(outcome, tmp, tables)
    extra = {"presets": presets, "seeds": seed_list, "filters": list(names)}
    _finish("seeds", outcome, folder, figure, tables, as_json, extra)
    if as_json:
        return
    table = Table(title=f"Monte Carlo over {len(seed_list)} seed(s), beside the paper's Table 3")
    for col in ("preset", "filter", "n", "RMSE m (mean ± std)", "median", "min-max",
                "rel. % (mean ± std)", "paper m", "paper %"):  # fmt: skip
        table.add_column(col)
    for r in summary.itertuples(index=False):
        paper = PAPER_TABLE3.get(str(r.preset), {}).get(str(r.filter))
        table.add_row(
            str(r.preset), _label(str(r.filter)), str(r.n),
            f"{r.rmse_m_mean:.1f} ± {r.rmse_m_std:.1f}", f"{r.rmse_m_median:.1f}",
            f"{r.rmse_m_min:.1f}-{r.rmse_m_max:.1f}",
            f"{r.relative_rmse_pct_mean:.3f} ± {r.relative_rmse_pct_std:.3f}",
            "-" if paper is None else f"{paper[0]:.0f}",
            "-" if paper is None else f"{paper[1]:.2f}",
        )  # fmt: skip
    console.print(table)
    console.print(_nees_table(summary))
    for c in _records(comparison):
        if not c["n"]:
            continue
        console.print(
            f"{c['preset']}: VB-MAESKF beats {_label(c['other'])} on {c['wins']:g} of {c['n']} "
            f"seeds ({100 * c['win_rate']:.0f} %); RMSE ratio median {c['ratio_median']:.2f}, "
            f"ratio of means {c['ratio_of_means']:.2f}"
        )
