"""Running a sweep: one spec on a loaded mission, and many through the cache and a dask
cluster (issues 5 and 16; docs/scale-out.md).

:func:`run_sweep` runs every :class:`~adaptnav.experiments.spec.RunSpec` not yet in the cache
(:mod:`adaptnav.experiments.cache`) and returns all their metrics as a table
(:func:`adaptnav.experiments.stats.runs_table`). Runs go to a ``dask.distributed`` cluster
(:mod:`adaptnav.experiments.cluster`: a scheduler address or client, ``$ADAPTNAV_SCHEDULER``, or
a local cluster of single-threaded worker processes, one per core by default) in chunks of specs
of one mission, so a worker loads a mission once for many runs; at most one mission per worker
thread is being simulated at a time. One job and no scheduler runs everything in this process:
the reference the cluster's results equal exactly. Progress bars (rich) go to stderr.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import shutil
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import pandas as pd
from distributed import Client, Future, as_completed

from adaptnav.estimation.settings import FilterKind
from adaptnav.experiments.cache import (
    Alignment,
    cached_record,
    load_prepared,
    mission_dir,
    mission_ready,
    prepare_mission,
    run_record,
    store_record,
)
from adaptnav.experiments.cluster import LOCAL, SCHEDULER_ENV, Scheduler, connect, resolve
from adaptnav.experiments.spec import RunSpec, scale_gyro_bias_q
from adaptnav.experiments.stats import NEES_METRICS, runs_table
from adaptnav.mission import with_overrides

if TYPE_CHECKING:
    from adaptnav.mission import Mission

__all__ = ["CHUNK_SIZE", "SweepOutcome", "run_one", "run_sweep", "run_tasks"]

logger = logging.getLogger(__name__)

CHUNK_SIZE = 8
"""Specs per worker task (one mission each): progress granularity vs. per-task overhead."""

Reports = list[tuple[str, dict[str, Any] | str]]
"""What a worker task gives back per spec: (key, cached record) or (key, error text)."""

# --- one run -----------------------------------------------------------------------------------

_LOADED: dict[str, tuple[Mission, Alignment]] = {}
"""The worker's last loaded mission and alignment (reused by consecutive chunks)."""


def _loaded(cache: Path, name: str) -> tuple[Mission, Alignment]:
    tag = f"{cache.resolve()}::{name}"
    if tag not in _LOADED:
        _LOADED.clear()
        _LOADED[tag] = load_prepared(cache, name)
    return _LOADED[tag]


def run_one(mission: Mission, initial: Alignment, spec: RunSpec) -> dict[str, float]:
    """Run ``spec``'s filter on a loaded ``mission`` from the shared ``initial`` state and
    evaluate it against the mission's truth (docs/metrics.md): the
    :data:`~adaptnav.experiments.stats.METRICS`, ``gate_q`` the q the first DVL's gate used. A
    swept ``q`` on a mission whose DVL has its own ``gate_q`` is a ValueError: that q would win
    (up to 0.4.7 the run used it while its row said the swept one)."""
    from adaptnav import api
    from adaptnav.analysis import evaluate

    if spec.config:
        mission = replace(mission, config=with_overrides(mission.config, spec.config))
    if mission.truth is None:
        raise ValueError(f"{mission.root}: no truth table to evaluate against")
    started = time.perf_counter()
    cfg = mission.config
    kind = cast(FilterKind, spec.filter)
    settings = cfg.filter_settings().with_kind(kind)
    dvl = [n for n, s in cfg.sensors.items() if s.kind == "dvl"]
    own = {n: q for n in dvl if (q := cfg.sensors[n].gate_q) is not None}
    if spec.q is not None:
        if own:  # the DVL's own q wins over the filter's (FilterSettings.gate)
            n = next(iter(own))
            raise ValueError(f"q = {spec.q:g}: the mission's sensors.{n}.gate_q = {own[n]:g} "
                             "overrides it for that DVL; remove it to sweep q")  # fmt: skip
        settings = settings.updated(gate_q={**settings.gate_q, kind: spec.q})
    noise = None
    if spec.q_scale is not None:
        noise = scale_gyro_bias_q(cfg.imu.noise.to_imu_noise(), spec.q_scale)
    result = api.run(mission, settings=settings, initial=initial, imu_noise=noise)
    m = evaluate.evaluate(result, mission.truth)
    counts = {f: sum(m.counts.get(n, {}).get(f, 0) for n in dvl) for f in ("used", "rejected")}
    dropped = sum(m.counts.get(n, {}).get("dropped", 0) for n in dvl)
    kind_q = settings.kind_gate_q()
    gated = kind_q is not None and any(settings.gated(n, is_dvl=True) for n in dvl)
    return {
        "rmse_m": m.rmse_m,
        "relative_rmse_pct": m.relative_rmse_pct,
        "horizontal_rmse_m": m.horizontal_rmse_m,
        "final_horizontal_error_m": m.final_horizontal_error_m,
        "distance_m": m.distance_m,
        "duration_s": m.duration_s,
        **{k: float(getattr(m, k)) for k in NEES_METRICS},
        "dvl_used": float(counts["used"]),
        "dvl_rejected": float(counts["rejected"]),
        "dvl_dropped": float(dropped),
        "gate_q": float(own.get(dvl[0], kind_q)) if gated and kind_q is not None else math.nan,
        "elapsed_s": time.perf_counter() - started,
    }


def _failures(specs: Iterable[RunSpec], exc: BaseException) -> Reports:
    text = f"{type(exc).__name__}: {exc}"
    return [(s.key(), text) for s in specs]


def _run_chunk(cache: str, specs: Sequence[RunSpec]) -> Reports:
    """Worker task: run ``specs`` (one mission) and store each finished run; returns (key,
    record) or (key, error text) per spec."""
    root = Path(cache)
    out: Reports = []
    try:
        mission, initial = _loaded(root, specs[0].mission_name)
    except Exception as exc:  # reported per spec, the sweep goes on
        return _failures(specs, exc)
    for spec in specs:
        try:
            record = run_record(spec, run_one(mission, initial, spec))
        except Exception as exc:
            out += _failures([spec], exc)
            continue
        store_record(root, record)
        out.append((spec.key(), record))
    return out


def _prepare(cache: str, spec: RunSpec) -> str:
    """Worker task: :func:`~adaptnav.experiments.cache.prepare_mission`; returns the mission
    name."""
    prepare_mission(Path(cache), spec)
    return spec.mission_name


# --- the sweep ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did.

    ``table``: one row per distinct spec, in the order given
    (:func:`adaptnav.experiments.stats.runs_table`: the spec's columns, then the metrics, then
    ``error``: None, or why the run failed: its metrics are NaN). ``ran``: runs computed now;
    ``reused``: runs read from the cache; ``failed``: runs that raised (not cached: a rerun
    retries them).
    """

    table: pd.DataFrame
    ran: int
    reused: int
    failed: int
    wall_s: float
    errors: dict[str, str] = field(default_factory=dict)

    def rows(self, specs: Iterable[RunSpec]) -> pd.DataFrame:
        """The table's rows of ``specs`` (each must have been in the sweep), in their order,
        duplicates dropped."""
        keys = list(dict.fromkeys(s.key() for s in specs))
        return self.table.set_index("key").loc[keys].reset_index()


@dataclass
class _Sweep:
    """A sweep while it runs: the cache, the runs still to do by mission, the progress bars
    (missions, runs) and what the runs gave back, by key."""

    root: Path
    groups: dict[str, list[RunSpec]]
    chunk_size: int
    keep_missions: bool
    bars: Any
    missions_task: Any
    runs_task: Any
    records: dict[str, dict[str, Any]]
    errors: dict[str, str] = field(default_factory=dict)

    def take(self, results: Reports) -> None:
        for key, value in results:
            if isinstance(value, str):
                self.errors[key] = value
                logger.warning("run %s failed: %s", key, value)
            else:
                self.records[key] = value

    def mission_failed(self, name: str, exc: BaseException) -> None:
        """Every run of mission ``name`` failed with ``exc`` (simulating or aligning it)."""
        self.take(_failures(self.groups[name], exc))
        self.bars.advance(self.runs_task, len(self.groups[name]))

    def chunks(self, name: str) -> list[list[RunSpec]]:
        group = self.groups[name]
        return [group[i : i + self.chunk_size] for i in range(0, len(group), self.chunk_size)]

    def done_with(self, name: str) -> None:
        """All runs of mission ``name`` are finished: drop its folder unless it is kept."""
        if not self.keep_missions:
            shutil.rmtree(mission_dir(self.root, name), ignore_errors=True)


def run_tasks(
    fn: Callable[..., Any],
    tasks: Sequence[tuple[Any, ...]],
    jobs: int,
    on_done: Callable[[tuple[Any, ...], Any], None],
    scheduler: Scheduler = None,
) -> None:
    """``fn(*task)`` for every task on a dask cluster (:mod:`adaptnav.experiments.cluster`:
    ``scheduler``, else ``$ADAPTNAV_SCHEDULER``, else a local cluster of ``jobs`` single-threaded
    workers; with neither a scheduler nor more than one job: in this process, in order), and
    ``on_done(task, result)`` as each one finishes: the loop of the results scripts
    (``scripts/faults_eval.py``, ``scripts/smoothing_eval.py``, ``scripts/akit_eval.py``)."""
    target = resolve(scheduler)
    if target is None and (jobs == 1 or len(tasks) <= 1):
        for task in tasks:
            on_done(task, fn(*task))
        return
    with connect(target, min(jobs, len(tasks))) as client:
        futures = {client.submit(fn, *task, pure=False): task for task in tasks}
        try:
            # the client is not the default one (cluster.connect): as_completed gets its loop
            for fut in as_completed(list(futures), loop=client.loop):
                on_done(futures[fut], fut.result())
        except BaseException:
            client.cancel(list(futures))
            raise


def scheduler_argument(p: argparse.ArgumentParser) -> None:
    """``--scheduler``: where the runs go (:func:`adaptnav.experiments.cluster.resolve`)."""
    p.add_argument(
        "--scheduler",
        default=None,
        help=f"dask scheduler address (tcp://host:8786) or {LOCAL!r} (a local cluster of --jobs "
        f"workers) [${SCHEDULER_ENV}, else local]; docs/scale-out.md",
    )


def sweep_arguments(
    p: argparse.ArgumentParser, filters: Sequence[str], seeds: int, jobs: int
) -> None:
    """The options the results scripts share: ``--presets``, ``--seeds``, ``--filters``,
    ``--jobs``, ``--scheduler``; :func:`check_sweep_arguments` reads them."""
    p.add_argument("--presets", default="paper-1,paper-2", help="comma-separated presets")
    p.add_argument("--seeds", type=int, default=seeds, help=f"simulation seeds 1..N [{seeds}]")
    p.add_argument(
        "--filters",
        default=",".join(filters),
        help=f"comma-separated filter kinds [{','.join(filters)}]",
    )
    p.add_argument("--jobs", type=int, default=jobs, help=f"local workers, 1: in process [{jobs}]")
    scheduler_argument(p)


def check_sweep_arguments(p: argparse.ArgumentParser, a: argparse.Namespace) -> None:
    """``a.preset_list`` and ``a.filter_list`` (each once, in order) from :func:`sweep_arguments`'
    options, or the parser's error naming the option."""
    from adaptnav.estimation.settings import FILTER_KINDS
    from adaptnav.sim.scenarios import PRESETS

    a.preset_list = list(dict.fromkeys(x.strip() for x in a.presets.split(",") if x.strip()))
    unknown = [x for x in a.preset_list if x not in PRESETS]
    if unknown or not a.preset_list:
        p.error(f"--presets: {unknown or a.presets!r}; use {', '.join(PRESETS)}")
    a.filter_list = list(dict.fromkeys(x.strip() for x in a.filters.split(",") if x.strip()))
    bad = [f for f in a.filter_list if f not in FILTER_KINDS]
    if bad or not a.filter_list:
        p.error(f"--filters: {bad or a.filters!r}; use {', '.join(FILTER_KINDS)}")
    if a.seeds < 1:
        p.error("--seeds must be >= 1")
    if a.jobs < 1:
        p.error("--jobs must be >= 1")


def run_sweep(
    specs: Iterable[RunSpec],
    cache: str | Path,
    *,
    jobs: int | None = None,
    progress: bool = True,
    keep_missions: bool = True,
    chunk_size: int = CHUNK_SIZE,
    scheduler: Scheduler = None,
) -> SweepOutcome:
    """Run every spec not yet in ``cache`` and return all their metrics (see
    :mod:`adaptnav.experiments.cache` for the cache).

    Args:
        specs: the runs; duplicates (equal keys) run once.
        cache: the cache folder (created); workers of a remote cluster must see it at the
            same absolute path.
        jobs: worker processes of the local cluster (default ``os.cpu_count()``); 1 (and no
            scheduler) runs in this process. Local workers are spawned, so a script calling
            this with jobs > 1 needs the ``if __name__ == "__main__":`` guard. Ignored with a
            scheduler.
        progress: rich progress bars on stderr.
        keep_missions: False deletes a mission's folder once all its runs of this sweep are
            finished (its alignment file stays); a later sweep needing it simulates it again.
        chunk_size: specs per worker task.
        scheduler: a :class:`distributed.Client` (left open), a scheduler address, ``"local"``,
            or None: ``$ADAPTNAV_SCHEDULER``, else the local cluster
            (:func:`adaptnav.experiments.cluster.resolve`). An unreachable scheduler raises
            :class:`~adaptnav.experiments.cluster.SchedulerError`.
    """
    started = time.perf_counter()
    root = Path(cache).resolve()  # workers may run elsewhere: give them the absolute path
    (root / "runs").mkdir(parents=True, exist_ok=True)
    (root / "missions").mkdir(parents=True, exist_ok=True)
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs: {jobs} must be >= 1")
    if chunk_size < 1:
        raise ValueError(f"chunk_size: {chunk_size} must be >= 1")
    unique = list({s.key(): s for s in specs}.values())
    cached = {s.key(): cached_record(root, s.key()) for s in unique}
    records = {key: rec for key, rec in cached.items() if rec is not None}
    reused = len(records)
    todo = [s for s in unique if s.key() not in records]
    groups: dict[str, list[RunSpec]] = {}
    for s in todo:
        groups.setdefault(s.mission_name, []).append(s)
    n_tasks = sum(math.ceil(len(g) / chunk_size) for g in groups.values())
    workers = max(1, min(jobs or os.cpu_count() or 1, n_tasks))
    target = resolve(scheduler) if n_tasks else None
    in_process = target is None and workers == 1
    # Connected before the progress bars start: an unreachable scheduler is one error line.
    cluster = nullcontext() if in_process else connect(target, workers, root)
    with cluster as client, _progress(progress) as bars:
        t_missions = bars.add_task("missions", total=len(groups))
        t_runs = bars.add_task("runs", total=len(todo))
        sweep = _Sweep(root, groups, chunk_size, keep_missions, bars, t_missions, t_runs, records)
        if client is None:
            _run_serial(sweep)
        else:
            _run_parallel(sweep, client)
    return SweepOutcome(
        table=runs_table(unique, sweep.records, sweep.errors),
        ran=len(todo) - len(sweep.errors),
        reused=reused,
        failed=len(sweep.errors),
        wall_s=time.perf_counter() - started,
        errors=sweep.errors,
    )


def _run_serial(sweep: _Sweep) -> None:
    """Each mission in turn in this process: prepare it, then run its chunks."""
    for name, group in sweep.groups.items():
        try:
            prepare_mission(sweep.root, group[0])
        except Exception as exc:
            sweep.bars.advance(sweep.missions_task)
            sweep.mission_failed(name, exc)
            continue
        sweep.bars.advance(sweep.missions_task)
        for chunk in sweep.chunks(name):
            sweep.take(_run_chunk(str(sweep.root), chunk))
            sweep.bars.advance(sweep.runs_task, len(chunk))
        sweep.done_with(name)


def _run_parallel(sweep: _Sweep, client: Client) -> None:
    """Prepare at most one mission per worker thread at a time; as each is ready, queue its
    chunks; take results as they come."""
    queue = _Queue(sweep, client)
    try:
        queue.next_missions()
        for fut in queue.done:  # grows as missions are ready
            queue.finish(fut)
            queue.next_missions()
    except BaseException:
        client.cancel(list(queue.pending))
        raise


class _Queue:
    """The cluster's pending tasks: missions being prepared (at most one per worker thread) and
    chunks of runs, each with its kind (``"mission"`` or ``"runs"``), mission name and chunk;
    ``done`` yields each as it finishes."""

    def __init__(self, sweep: _Sweep, client: Client) -> None:
        self.sweep = sweep
        self.client = client
        self.waiting = list(sweep.groups)
        self.left = {name: len(g) for name, g in sweep.groups.items()}
        self.pending: dict[Future[Any], tuple[str, str, list[RunSpec]]] = {}
        self.done = as_completed(loop=client.loop)

    def _submit(self, kind: str, name: str, chunk: list[RunSpec], fn: Any, *args: Any) -> None:
        fut = self.client.submit(fn, *args, pure=False)  # state on disk: never deduplicate
        self.pending[fut] = (kind, name, chunk)
        self.done.add(fut)

    def runs(self, name: str) -> None:
        root = str(self.sweep.root)
        for chunk in self.sweep.chunks(name):
            self._submit("runs", name, chunk, _run_chunk, root, chunk)

    def next_missions(self) -> None:
        s = self.sweep
        preparing = sum(1 for kind, _, _ in self.pending.values() if kind == "mission")
        # Read each time: an adaptive cluster's workers come and go.
        threads = max(1, sum(self.client.nthreads().values()))
        while self.waiting and preparing < threads:
            name = self.waiting.pop(0)
            if mission_ready(s.root, name):
                s.bars.advance(s.missions_task)
                self.runs(name)
                continue
            self._submit("mission", name, [], _prepare, str(s.root), s.groups[name][0])
            preparing += 1

    def finish(self, fut: Future[Any]) -> None:
        """Take a done task's results; a prepared mission's runs are queued."""
        s = self.sweep
        kind, name, chunk = self.pending.pop(fut)
        if kind == "mission":
            s.bars.advance(s.missions_task)
            try:
                fut.result()
            except Exception as exc:
                s.mission_failed(name, exc)
                return
            self.runs(name)
            return
        try:
            s.take(fut.result())
        except Exception as exc:  # a worker died (dask's KilledWorker) or the task was lost
            s.take(_failures(chunk, exc))
        s.bars.advance(s.runs_task, len(chunk))
        self.left[name] -= len(chunk)
        if self.left[name] <= 0:
            s.done_with(name)


# --- progress ----------------------------------------------------------------------------------


class _NoProgress:
    def add_task(self, *args: Any, **kwargs: Any) -> int:
        return 0

    def advance(self, *args: Any, **kwargs: Any) -> None:
        return None

    def update(self, *args: Any, **kwargs: Any) -> None:
        return None


@contextmanager
def _progress(enabled: bool) -> Iterator[Any]:
    if not enabled:
        yield _NoProgress()
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bars = Progress(
        TextColumn("{task.description:>8}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=False,
    )
    with bars:
        yield bars
