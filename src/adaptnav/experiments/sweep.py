"""Parameter sweeps and Monte Carlo over simulated missions: cached, resumable, parallel (issue 5).

A sweep is a list of :class:`RunSpec` (preset, seed, filter, gate coefficient q or None,
gyro-bias process-noise scale or None, disturbances) and gives one row of metrics per spec
(docs/metrics.md: RMSE and relative RMSE, paper eqs. (32), (33), horizontal distance travelled,
duration, the mean NEES of position, velocity and attitude and the share of epochs inside the
χ²(3) 95 % band, DVL used / rejected counts). Three sweeps of the paper are prepared here:

* **q sweep** (the paper's Fig. 4; docs/filters.md, 'Gate'): 25 rejection coefficients ``q`` in
  [200, 2600] (:data:`Q_VALUES`), each filter with the gate **on** at that q with the paper's
  per-component rule ``nu_j² > q S_jj`` (VB-MAESKF too: the paper says it is "not sensitive
  to q"), plus VB-MAESKF ungated (its default) and the oracle as reference lines
  (:func:`q_sweep_specs`);
* **gyro-bias process-noise sweep** (the paper's Fig. 6): the driving-noise PSD of the gyro
  bias in the filter's Q (:attr:`adaptnav.models.imu_noise.ImuNoise.gyro_bias_psd`; docs/filters.md,
  'Error-state model') times a factor in 10^[-2, 2] (:data:`Q_SCALES`), each filter at its
  default q (:func:`process_noise_specs`, :func:`scale_gyro_bias_q`);
* **Monte Carlo over seeds** (the paper's Table 3 as a distribution): each filter at its
  defaults on many seeded missions (:func:`monte_carlo_specs`), summarised by
  :func:`summarize` (mean, std, median, min, max, of the NEES too) and
  :func:`paired_comparison` (VB-MAESKF's
  win rate against each other filter, paired by seed, and its RMSE ratio, e.g. to the oracle).

Cache layout (``cache`` folder)::

    missions/<preset>-s<seed>/            the simulated mission (adaptnav.sim.scenarios.simulate)
    missions/<preset>-s<seed>.alignment.npz   its static alignment (x0, P0, t0), computed once
    runs/<key>.json                       one finished run: spec, version, metrics

A mission is simulated once per (preset, seed[, disturbances]) and its alignment
(:func:`adaptnav.api.initial_state`) computed once and shared by every filter and parameter
on it, as the paper's comparison does. ``key`` is a SHA-256 of the spec and the package
version (:meth:`RunSpec.key`); a finished run is never rerun, so an interrupted sweep resumes.
Files are written atomically (temporary file + ``os.replace``). The cache does not notice code
changes within one package version: use a fresh cache folder after changing the code.

Runs go to a :class:`concurrent.futures.ProcessPoolExecutor` (spawned workers, one per core by
default) in chunks of specs of one mission, so a worker loads a mission once for many runs;
progress bars (rich) go to stderr.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import logging
import math
import multiprocessing
import os
import shutil
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pandas as pd

from adaptnav import __version__
from adaptnav.analysis.compare import NEES_COLUMNS
from adaptnav.estimation.settings import FILTER_KINDS, FilterKind
from adaptnav.mission import with_overrides
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.sim.scenarios import PRESETS
from adaptnav.sim.sensors import Disturbances

if TYPE_CHECKING:
    from adaptnav.mission import Mission

__all__ = [
    "DEFAULT_FILTERS",
    "LABELS",
    "METRICS",
    "NEES_METRICS",
    "PAPER_FILTERS",
    "Q_SCALES",
    "Q_VALUES",
    "RunSpec",
    "SweepOutcome",
    "available_filters",
    "curve",
    "curve_spread",
    "monte_carlo_specs",
    "paired_comparison",
    "parse_seeds",
    "plot_monte_carlo",
    "plot_process_noise",
    "plot_q_sweep",
    "prepare_mission",
    "process_noise_specs",
    "q_sweep_specs",
    "run_one",
    "run_sweep",
    "scale_gyro_bias_q",
    "summarize",
]

logger = logging.getLogger(__name__)

PAPER_FILTERS: tuple[str, ...] = ("meskf", "maeskf", "vb")
"""The paper's three filters (docs/filters.md: MESKF, MAESKF, VB-MAESKF)."""
DEFAULT_FILTERS: tuple[str, ...] = (*PAPER_FILTERS, "robust", "oracle")
"""The paper's filters, the recommended ``robust`` one (docs/robustness.md) and the oracle
baseline (:mod:`adaptnav.api.oracle`), where available."""
Q_VALUES: tuple[float, ...] = tuple(float(v) for v in np.linspace(200.0, 2600.0, 25))
"""The paper's Fig. 4: 25 rejection coefficients in [200, 2600] (step 100)."""
Q_SCALES: tuple[float, ...] = tuple(float(v) for v in np.logspace(-2.0, 2.0, 9))
"""Factors on the gyro-bias process-noise PSD, 10^[-2, 2] in 9 steps (the paper's Fig. 6)."""
METRICS: tuple[str, ...] = (
    "rmse_m",
    "relative_rmse_pct",
    "horizontal_rmse_m",
    "final_horizontal_error_m",
    "distance_m",
    "duration_s",
    *NEES_COLUMNS,
    "dvl_used",
    "dvl_rejected",
    "dvl_dropped",
    "gate_q",
    "elapsed_s",
)
"""Metric columns of a sweep's table (docs/metrics.md; :class:`adaptnav.analysis.evaluate.Metrics`;
``gate_q``: the DVL gate's q, NaN ungated; ``elapsed_s``: wall time of the run and its
evaluation). Runs cached before a metric existed have NaN for it."""
NEES_METRICS: tuple[str, ...] = NEES_COLUMNS
"""The consistency metrics among :data:`METRICS`: mean NEES per block (3 for a consistent
filter) and the share of epochs inside the χ²(3) 95 % band (0.95); docs/metrics.md."""
SUMMARY_METRICS: tuple[str, ...] = ("rmse_m", "relative_rmse_pct", *NEES_METRICS)
"""What :func:`summarize` summarises by default (those of them the table has)."""
SPEC_COLUMNS: tuple[str, ...] = (
    "key", "preset", "seed", "filter", "q", "q_scale", "config", "disturbances",
    "gated",
)  # fmt: skip
CHUNK_SIZE = 8
"""Specs per worker task (one mission each): progress granularity vs. per-task overhead."""
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


# --- specs -----------------------------------------------------------------------------------


def _disturbance_tag(d: Disturbances) -> str:
    text = json.dumps(d.as_dict(), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def config_tag(config: Iterable[tuple[str, Any]]) -> str:
    """``path=value`` pairs of a run's config overrides, ``;``-joined ("" for none)."""
    return ";".join(f"{k}={v}" for k, v in config)


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: which mission, which filter, which parameter.

    Attributes:
        preset: simulation preset (``adaptnav.sim.scenarios.PRESETS``).
        seed: simulation seed (every error source's random stream).
        filter: a kind of :data:`adaptnav.estimation.settings.FILTER_KINDS`.
        q: DVL gate coefficient: the gate is **on** for this filter with this q (docs/filters.md,
            'Gate'; the mission's gate rule, by default per component); None: the filter's
            default (MESKF 600, MAESKF 1800 gated; VB-MAESKF and the oracle ungated).
        q_scale: factor on the gyro-bias process-noise PSD in the filter's Q
            (:func:`scale_gyro_bias_q`); None (or 1): the mission's Q.
        disturbances: the simulator's switches; None (or the default): all on.
        config: mission-config overrides ``(dotted.path, value)`` applied before the run
            (:func:`adaptnav.mission.with_overrides`), e.g. ``(("filter.specific_force_tau_s",
            1.0),)``; sorted by path. The alignment stays the mission's own.

    Equal runs are equal specs: ``q_scale=1`` is stored as None and the default disturbances
    as None, so they share one cache entry.
    """

    preset: str
    seed: int
    filter: str
    q: float | None = None
    q_scale: float | None = None
    disturbances: Disturbances | None = None
    config: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            raise ValueError(f"preset: {self.preset!r} is not one of {', '.join(PRESETS)}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            raise ValueError(f"seed: {self.seed!r} must be an integer")
        if self.seed < 0:
            raise ValueError(f"seed: {self.seed} must be >= 0")
        object.__setattr__(self, "seed", int(self.seed))
        if self.filter not in FILTER_KINDS:
            raise ValueError(f"filter: {self.filter!r} is not one of {', '.join(FILTER_KINDS)}")
        for name in ("q", "q_scale"):
            v = getattr(self, name)
            if v is None:
                continue
            if not isinstance(v, int | float | np.floating) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: {v!r} must be a finite number > 0")
            object.__setattr__(self, name, float(v))
        if self.q_scale == 1.0:
            object.__setattr__(self, "q_scale", None)
        object.__setattr__(self, "config", tuple(sorted((str(k), v) for k, v in self.config)))
        if self.disturbances == Disturbances():
            object.__setattr__(self, "disturbances", None)

    @property
    def mission_name(self) -> str:
        """``<preset>-s<seed>``, with ``-d<hash>`` of non-default disturbances."""
        base = f"{self.preset}-s{self.seed}"
        return (
            base if self.disturbances is None else f"{base}-d{_disturbance_tag(self.disturbances)}"
        )

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-able fields (disturbances as their switch dict, None for the default)."""
        return {
            "preset": self.preset,
            "seed": self.seed,
            "filter": self.filter,
            "q": self.q,
            "q_scale": self.q_scale,
            "disturbances": None if self.disturbances is None else self.disturbances.as_dict(),
            # Only when set, so the keys of the paper's runs stay as they were.
            **({"config": dict(self.config)} if self.config else {}),
        }

    def key(self, version: str = __version__) -> str:
        """Stable cache key: the first 20 hex digits of SHA-256 of the canonical JSON of
        :meth:`as_dict` and the package ``version``."""
        text = json.dumps({"spec": self.as_dict(), "version": version}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:20]


def available_filters(filters: Iterable[str]) -> tuple[str, ...]:
    """``filters`` in order without duplicates; ValueError for a name that is not one of
    ``adaptnav.estimation.settings.FILTER_KINDS``."""
    out: list[str] = []
    for f in filters:
        if f not in FILTER_KINDS:
            raise ValueError(f"filter {f!r}: use one of {', '.join(FILTER_KINDS)}")
        if f not in out:
            out.append(f)
    return tuple(out)


def parse_seeds(text: str) -> list[int]:
    """Seeds from ``"1-5"``, ``"1,3,8"`` or ``"1-3,10"`` (a single number is that one seed).
    Ranges are inclusive; order kept, duplicates dropped. Raises ValueError for anything else
    (empty item, negative, reversed range)."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise ValueError(f"seeds {text!r}: empty item")
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise ValueError(f"seeds {text!r}: {part!r} is not N or N-M") from None
        if a < 0 or b < a:
            raise ValueError(f"seeds {text!r}: {part!r} must be N-M with 0 <= N <= M")
        seeds += [s for s in range(a, b + 1) if s not in seeds]
    return seeds


def monte_carlo_specs(
    presets: Sequence[str], seeds: Sequence[int], filters: Sequence[str] = DEFAULT_FILTERS
) -> list[RunSpec]:
    """Each filter at its defaults on every (preset, seed): the Monte Carlo of Table 3."""
    fs = available_filters(filters)
    return [RunSpec(p, s, f) for p in presets for s in seeds for f in fs]


def q_sweep_specs(
    presets: Sequence[str],
    seeds: Sequence[int],
    q_values: Sequence[float] = Q_VALUES,
    filters: Sequence[str] = PAPER_FILTERS,
    references: Sequence[str] = ("vb", "oracle"),
) -> list[RunSpec]:
    """The paper's Fig. 4: every filter gated at every q, plus ``references`` at their
    defaults (VB-MAESKF ungated, the oracle) as the lines to compare with."""
    fs = available_filters(filters)
    refs = available_filters(references)
    out = [RunSpec(p, s, f, q=q) for p in presets for s in seeds for f in fs for q in q_values]
    out += [RunSpec(p, s, f) for p in presets for s in seeds for f in refs]
    return out


def process_noise_specs(
    presets: Sequence[str],
    seeds: Sequence[int],
    scales: Sequence[float] = Q_SCALES,
    filters: Sequence[str] = PAPER_FILTERS,
) -> list[RunSpec]:
    """The paper's Fig. 6: every filter at its default q with the gyro-bias Q times each
    factor of ``scales``."""
    fs = available_filters(filters)
    return [RunSpec(p, s, f, q_scale=k) for p in presets for s in seeds for f in fs for k in scales]


def scale_gyro_bias_q(noise: ImuNoise, scale: float) -> ImuNoise:
    """``noise`` with the gyro-bias driving-noise PSD (the Q block of ``db_g``; docs/filters.md,
    'Error-state model') times ``scale``: the Gauss-Markov σ times √scale at the same τ
    (PSD = 2σ²/τ), or, for a random walk (τ = inf), the rate random walk times √scale
    (PSD = RRW²). Nothing else changes."""
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale: {scale!r} must be a finite number > 0")
    root = math.sqrt(scale)
    if math.isinf(noise.gyro_bias_tau):
        return replace(noise, gyro_bias_rrw=noise.gyro_bias_rrw * root)
    return replace(noise, gyro_bias_sigma=noise.gyro_bias_sigma * root)


# --- cache -------------------------------------------------------------------------------------


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _mission_dir(cache: Path, name: str) -> Path:
    return cache / "missions" / name


def _alignment_path(cache: Path, name: str) -> Path:
    return cache / "missions" / f"{name}.alignment.npz"


def _run_path(cache: Path, key: str) -> Path:
    return cache / "runs" / f"{key}.json"


def _mission_ready(cache: Path, name: str) -> bool:
    return (_mission_dir(cache, name) / "mission.toml").is_file() and _alignment_path(
        cache, name
    ).is_file()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


def _remove_stale_tmp(root: Path) -> None:
    """Remove temporary files and folders (``.<name>.tmp-<pid>``) left by killed processes."""
    for folder in (root / "missions", root / "runs"):
        for p in folder.glob(".*.tmp-*"):
            pid = p.name.rpartition(".tmp-")[2]
            if pid.isdigit() and not _pid_alive(int(pid)):
                if p.is_dir():
                    shutil.rmtree(p, ignore_errors=True)
                else:
                    p.unlink(missing_ok=True)


def _load_record(path: Path) -> dict[str, Any] | None:
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and isinstance(record.get("metrics"), dict) else None


def prepare_mission(cache: Path, spec: RunSpec) -> Path:
    """Simulate ``spec``'s mission into the cache (unless there) and compute its static
    alignment once (unless there); returns the mission folder. Both are written atomically."""
    from adaptnav import api
    from adaptnav.mission import load_mission
    from adaptnav.sim.scenarios import simulate

    name = spec.mission_name
    folder = _mission_dir(cache, name)
    folder.parent.mkdir(parents=True, exist_ok=True)
    if not (folder / "mission.toml").is_file():
        shutil.rmtree(folder, ignore_errors=True)
        tmp = folder.with_name(f".{name}.tmp-{os.getpid()}")
        shutil.rmtree(tmp, ignore_errors=True)
        simulate(spec.preset, spec.seed, tmp, spec.disturbances)
        try:
            os.replace(tmp, folder)
        except OSError:
            if not (folder / "mission.toml").is_file():
                raise
            shutil.rmtree(tmp, ignore_errors=True)
    align_path = _alignment_path(cache, name)
    if not align_path.is_file():
        x0, P0, t0, _ = api.initial_state(load_mission(folder))
        tmp_align = align_path.with_name(f".{align_path.name}.tmp-{os.getpid()}")
        with tmp_align.open("wb") as fh:
            np.savez(fh, x0=x0, P0=P0, t0=np.array(t0))
        os.replace(tmp_align, align_path)
    return folder


# --- one run -----------------------------------------------------------------------------------

_LOADED: dict[str, tuple[Mission, tuple[np.ndarray, np.ndarray, float]]] = {}
"""The worker's last loaded mission and alignment (reused by consecutive chunks)."""


def _loaded(cache: Path, name: str) -> tuple[Mission, tuple[np.ndarray, np.ndarray, float]]:
    from adaptnav.mission import load_mission

    tag = f"{cache.resolve()}::{name}"
    if tag not in _LOADED:
        _LOADED.clear()
        mission = load_mission(_mission_dir(cache, name))
        with np.load(_alignment_path(cache, name)) as z:
            initial = (np.array(z["x0"]), np.array(z["P0"]), float(z["t0"]))
        _LOADED[tag] = (mission, initial)
    return _LOADED[tag]


def run_one(
    mission: Mission, initial: tuple[np.ndarray, np.ndarray, float], spec: RunSpec
) -> dict[str, float]:
    """Run ``spec``'s filter on a loaded ``mission`` from the shared ``initial`` state and
    evaluate it against the mission's truth (docs/metrics.md): the :data:`METRICS`."""
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
    if spec.q is not None:
        settings = settings.updated(gate_q={**settings.gate_q, kind: spec.q})
    noise = None
    if spec.q_scale is not None:
        noise = scale_gyro_bias_q(cfg.imu.noise.to_imu_noise(), spec.q_scale)
    result = api.run(mission, settings=settings, initial=initial, imu_noise=noise)
    m = evaluate.evaluate(result, mission.truth)
    dvl = [n for n, s in cfg.sensors.items() if s.kind == "dvl"]
    counts = {f: sum(m.counts.get(n, {}).get(f, 0) for n in dvl) for f in ("used", "rejected")}
    dropped = sum(m.counts.get(n, {}).get("dropped", 0) for n in dvl)
    gated = kind in settings.gate_q and any(settings.gated(n, is_dvl=True) for n in dvl)
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
        "gate_q": float(settings.gate_q[kind]) if gated else math.nan,
        "elapsed_s": time.perf_counter() - started,
    }


def _record(spec: RunSpec, metrics: Mapping[str, float]) -> dict[str, Any]:
    return {
        "key": spec.key(),
        "version": __version__,
        "spec": spec.as_dict(),
        "metrics": {k: (v if math.isfinite(v) else None) for k, v in metrics.items()},
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def _run_chunk(cache: str, specs: Sequence[RunSpec]) -> list[tuple[str, dict[str, Any] | str]]:
    """Worker task: run ``specs`` (one mission) and store each finished run; returns (key,
    record) or (key, error text) per spec."""
    root = Path(cache)
    out: list[tuple[str, dict[str, Any] | str]] = []
    try:
        mission, initial = _loaded(root, specs[0].mission_name)
    except Exception as exc:  # reported per spec, the sweep goes on
        return [(s.key(), f"{type(exc).__name__}: {exc}") for s in specs]
    for spec in specs:
        try:
            record = _record(spec, run_one(mission, initial, spec))
        except Exception as exc:
            out.append((spec.key(), f"{type(exc).__name__}: {exc}"))
            continue
        _write_atomic(_run_path(root, spec.key()), json.dumps(record, indent=1, sort_keys=True))
        out.append((spec.key(), record))
    return out


def _prepare(cache: str, spec: RunSpec) -> str:
    """Worker task: :func:`prepare_mission`; returns the mission name."""
    prepare_mission(Path(cache), spec)
    return spec.mission_name


# --- the sweep ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did.

    ``table``: one row per distinct spec, in the order given: :data:`SPEC_COLUMNS`, then
    :data:`METRICS`, then ``error`` (None, or why the run failed: its metrics are NaN).
    ``q`` is NaN for a filter's default, ``q_scale`` 1.0 for the mission's Q, ``disturbances``
    ``"default"`` or the tag of the mission name. ``ran``: runs computed now; ``reused``: runs
    read from the cache; ``failed``: runs that raised (not cached: a rerun retries them).
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


def _row(spec: RunSpec, record: Mapping[str, Any] | None, error: str | None) -> dict[str, Any]:
    metrics = record["metrics"] if record is not None else {}
    row: dict[str, Any] = {
        "key": spec.key(),
        "preset": spec.preset,
        "seed": spec.seed,
        "filter": spec.filter,
        "q": math.nan if spec.q is None else spec.q,
        "q_scale": 1.0 if spec.q_scale is None else spec.q_scale,
        "config": config_tag(spec.config),
        "disturbances": "default"
        if spec.disturbances is None
        else _disturbance_tag(spec.disturbances),
        "gated": False,
    }
    for name in METRICS:
        v = metrics.get(name)
        row[name] = math.nan if v is None else float(v)
    row["gated"] = bool(math.isfinite(row["gate_q"]))
    row["error"] = error
    return row


def _chunks(specs: Sequence[RunSpec], size: int) -> list[list[RunSpec]]:
    return [list(specs[i : i + size]) for i in range(0, len(specs), size)]


@contextmanager
def single_threaded_children() -> Iterator[None]:
    """Children inherit one-thread settings for BLAS/OpenMP/Numba (one worker per core)."""
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    for k in _THREAD_VARS:
        os.environ.setdefault(k, "1")
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def run_sweep(
    specs: Iterable[RunSpec],
    cache: str | Path,
    *,
    jobs: int | None = None,
    progress: bool = True,
    keep_missions: bool = True,
    chunk_size: int = CHUNK_SIZE,
) -> SweepOutcome:
    """Run every spec not yet in ``cache`` and return all their metrics (see the module
    docstring for the cache).

    Args:
        specs: the runs; duplicates (equal keys) run once.
        cache: the cache folder (created).
        jobs: worker processes (default ``os.cpu_count()``); 1 runs in this process. Workers
            are spawned, so a script calling this with jobs > 1 needs the
            ``if __name__ == "__main__":`` guard.
        progress: rich progress bars on stderr.
        keep_missions: False deletes a mission's folder once all its runs of this sweep are
            finished (its alignment file stays); a later sweep needing it simulates it again.
        chunk_size: specs per worker task.
    """
    started = time.perf_counter()
    root = Path(cache)
    (root / "runs").mkdir(parents=True, exist_ok=True)
    (root / "missions").mkdir(parents=True, exist_ok=True)
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs: {jobs} must be >= 1")
    if chunk_size < 1:
        raise ValueError(f"chunk_size: {chunk_size} must be >= 1")
    _remove_stale_tmp(root)
    unique = list({s.key(): s for s in specs}.values())
    records: dict[str, dict[str, Any]] = {}
    for s in unique:
        rec = _load_record(_run_path(root, s.key()))
        if rec is not None:
            records[s.key()] = rec
    reused = len(records)
    todo = [s for s in unique if s.key() not in records]
    groups: dict[str, list[RunSpec]] = {}
    for s in todo:
        groups.setdefault(s.mission_name, []).append(s)
    errors: dict[str, str] = {}

    def take(results: list[tuple[str, dict[str, Any] | str]]) -> None:
        for key, value in results:
            if isinstance(value, str):
                errors[key] = value
                logger.warning("run %s failed: %s", key, value)
            else:
                records[key] = value

    n_tasks = sum(math.ceil(len(g) / chunk_size) for g in groups.values())
    workers = max(1, min(jobs or os.cpu_count() or 1, n_tasks))
    with _progress(progress) as bars:
        t_missions = bars.add_task("missions", total=len(groups))
        t_runs = bars.add_task("runs", total=len(todo))
        if workers == 1:
            for name, group in groups.items():
                try:
                    prepare_mission(root, group[0])
                except Exception as exc:
                    take([(s.key(), f"{type(exc).__name__}: {exc}") for s in group])
                    bars.advance(t_missions)
                    bars.advance(t_runs, len(group))
                    continue
                bars.advance(t_missions)
                for chunk in _chunks(group, chunk_size):
                    take(_run_chunk(str(root), chunk))
                    bars.advance(t_runs, len(chunk))
                if not keep_missions:
                    shutil.rmtree(_mission_dir(root, name), ignore_errors=True)
        else:
            tasks = (t_missions, t_runs)
            _run_parallel(root, groups, workers, chunk_size, keep_missions, take, bars, tasks)

    table = pd.DataFrame(
        [_row(s, records.get(s.key()), errors.get(s.key())) for s in unique],
        columns=[*SPEC_COLUMNS, *METRICS, "error"],
    )
    return SweepOutcome(
        table=table,
        ran=len(todo) - len(errors),
        reused=reused,
        failed=len(errors),
        wall_s=time.perf_counter() - started,
        errors=errors,
    )


def _run_parallel(
    root: Path,
    groups: Mapping[str, list[RunSpec]],
    workers: int,
    chunk_size: int,
    keep_missions: bool,
    take: Any,
    bars: Any,
    tasks: tuple[Any, Any],
) -> None:
    """Prepare at most ``workers`` missions at a time; as each is ready, queue its chunks."""
    t_missions, t_runs = tasks
    waiting = list(groups)
    left = {name: len(g) for name, g in groups.items()}
    ctx = multiprocessing.get_context("spawn")
    with single_threaded_children(), cf.ProcessPoolExecutor(workers, mp_context=ctx) as pool:
        pending: dict[cf.Future[Any], tuple[str, str, list[RunSpec]]] = {}

        def queue_runs(name: str) -> None:
            for chunk in _chunks(groups[name], chunk_size):
                pending[pool.submit(_run_chunk, str(root), chunk)] = ("runs", name, chunk)

        def queue_next_missions() -> None:
            preparing = sum(1 for kind, _, _ in pending.values() if kind == "mission")
            while waiting and preparing < workers:
                name = waiting.pop(0)
                if _mission_ready(root, name):
                    bars.advance(t_missions)
                    queue_runs(name)
                    continue
                fut = pool.submit(_prepare, str(root), groups[name][0])
                pending[fut] = ("mission", name, [])
                preparing += 1

        try:
            queue_next_missions()
            while pending:
                done, _ = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    kind, name, chunk = pending.pop(fut)
                    if kind == "mission":
                        bars.advance(t_missions)
                        try:
                            fut.result()
                        except Exception as exc:
                            text = f"{type(exc).__name__}: {exc}"
                            take([(s.key(), text) for s in groups[name]])
                            bars.advance(t_runs, len(groups[name]))
                            continue
                        queue_runs(name)
                        continue
                    try:
                        take(fut.result())
                    except Exception as exc:  # a worker died
                        text = f"{type(exc).__name__}: {exc}"
                        take([(s.key(), text) for s in chunk])
                    bars.advance(t_runs, len(chunk))
                    left[name] -= len(chunk)
                    if left[name] <= 0 and not keep_missions:
                        shutil.rmtree(_mission_dir(root, name), ignore_errors=True)
                queue_next_missions()
        except BaseException:
            for fut in pending:
                fut.cancel()
            raise


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


# --- statistics --------------------------------------------------------------------------------


def _ok(table: pd.DataFrame) -> pd.DataFrame:
    keep = table["error"].isna() if "error" in table.columns else True
    return table[keep & np.isfinite(table["rmse_m"].astype(float))]


def summarize(
    table: pd.DataFrame,
    by: Sequence[str] = ("preset", "filter"),
    metrics: Sequence[str] | None = None,
) -> pd.DataFrame:
    """Monte Carlo statistics per group (Table 3 over seeds): ``n`` and, per metric,
    ``<metric>_mean``, ``_std`` (sample, ddof = 1; NaN for one run), ``_median``, ``_min``,
    ``_max``. Failed runs (error or NaN RMSE) are left out. Groups in order of appearance.

    ``metrics`` defaults to those of :data:`SUMMARY_METRICS` that ``table`` has: RMSE,
    relative RMSE, and the mean NEES of position, velocity and attitude and their shares of
    epochs in the χ²(3) 95 % band (a statistic is NaN if any run of the group lacks the metric,
    e.g. a reference without attitude, or a run cached before the metric existed)."""
    if metrics is None:
        metrics = [m for m in SUMMARY_METRICS if m in table.columns]
    ok = _ok(table)
    rows = []
    for keys, g in ok.groupby(list(by), sort=False):
        row: dict[str, Any] = dict(
            zip(by, keys if isinstance(keys, tuple) else (keys,), strict=True)
        )
        row["n"] = len(g)
        for m in metrics:
            v = g[m].to_numpy(dtype=float)
            row[f"{m}_mean"] = float(np.mean(v))
            row[f"{m}_std"] = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
            row[f"{m}_median"] = float(np.median(v))
            row[f"{m}_min"] = float(np.min(v))
            row[f"{m}_max"] = float(np.max(v))
        rows.append(row)
    cols = [
        *by,
        "n",
        *(f"{m}_{s}" for m in metrics for s in ("mean", "std", "median", "min", "max")),
    ]
    return pd.DataFrame(rows, columns=cols)


def paired_comparison(
    table: pd.DataFrame, filter: str = "vb", metric: str = "rmse_m"
) -> pd.DataFrame:
    """``filter`` against every other filter of ``table``, per preset, paired by seed.

    Columns: ``preset, filter, other, n`` (seeds with both), ``wins`` (seeds where
    ``filter``'s metric is lower; a tie counts ½), ``win_rate = wins / n``, ``ratio_mean`` and
    ``ratio_median`` of the per-seed ratio ``filter / other``, ``ratio_of_means``. Each (preset,
    seed, filter) must appear once (one configuration per filter, e.g. a Monte Carlo table):
    ValueError otherwise."""
    ok = _ok(table)
    if ok.duplicated(["preset", "seed", "filter"]).any():
        raise ValueError("paired_comparison: a (preset, seed, filter) appears more than once")
    rows = []
    for preset, g in ok.groupby("preset", sort=False):
        wide = g.pivot(index="seed", columns="filter", values=metric)
        if filter not in wide.columns:
            continue
        for other in [f for f in dict.fromkeys(g["filter"]) if f != filter]:
            pair = wide[[filter, other]].dropna()
            a = pair[filter].to_numpy(dtype=float)
            b = pair[other].to_numpy(dtype=float)
            wins = float(np.sum(a < b) + 0.5 * np.sum(a == b))
            n = int(a.size)
            ratio = a / b
            rows.append(
                {
                    "preset": preset,
                    "filter": filter,
                    "other": other,
                    "n": n,
                    "wins": wins,
                    "win_rate": wins / n if n else math.nan,
                    "ratio_mean": float(np.mean(ratio)) if n else math.nan,
                    "ratio_median": float(np.median(ratio)) if n else math.nan,
                    "ratio_of_means": float(np.mean(a) / np.mean(b)) if n else math.nan,
                }
            )
    cols = ["preset", "filter", "other", "n", "wins", "win_rate", "ratio_mean", "ratio_median",
            "ratio_of_means"]  # fmt: skip
    return pd.DataFrame(rows, columns=cols)


def curve(table: pd.DataFrame, parameter: str, metric: str = "relative_rmse_pct") -> pd.DataFrame:
    """``metric`` against ``parameter`` (``"q"`` or ``"q_scale"``) per (preset, filter): for
    each value, ``n``, ``mean``, ``std`` (ddof = 1), ``min``, ``max`` over seeds (the paper's
    Figs. 4 and 6 with the seed spread). Rows with a NaN parameter (a filter's default q) are
    left out; sorted by preset, filter (order of appearance) and parameter."""
    ok = _ok(table)
    ok = ok[np.isfinite(ok[parameter].astype(float))]
    rows = []
    for (preset, filt), g in ok.groupby(["preset", "filter"], sort=False):
        values = g[parameter].to_numpy(dtype=float)
        for value in np.unique(values):
            v = g[metric].to_numpy(dtype=float)[values == value]
            rows.append(
                {
                    "preset": preset,
                    "filter": filt,
                    parameter: float(value),
                    "n": int(v.size),
                    "mean": float(np.mean(v)),
                    "std": float(np.std(v, ddof=1)) if v.size > 1 else math.nan,
                    "min": float(np.min(v)),
                    "max": float(np.max(v)),
                }
            )
    return pd.DataFrame(rows, columns=["preset", "filter", parameter, "n", "mean", "std", "min",
                                       "max"])  # fmt: skip


def curve_spread(curve_table: pd.DataFrame, parameter: str) -> pd.DataFrame:
    """How much each filter's mean moves over the parameter (sensitivity, Figs. 4 and 6): per
    (preset, filter) ``values`` (count), ``best`` (lowest mean) at ``best_at``, ``worst`` at
    ``worst_at``, ``worst_over_best = worst / best``."""
    rows = []
    for (preset, filt), g in curve_table.groupby(["preset", "filter"], sort=False):
        i_best = int(np.argmin(g["mean"].to_numpy(dtype=float)))
        i_worst = int(np.argmax(g["mean"].to_numpy(dtype=float)))
        best = float(g["mean"].iloc[i_best])
        worst = float(g["mean"].iloc[i_worst])
        rows.append(
            {
                "preset": preset,
                "filter": filt,
                "values": len(g),
                "best": best,
                "best_at": float(g[parameter].iloc[i_best]),
                "worst": worst,
                "worst_at": float(g[parameter].iloc[i_worst]),
                "worst_over_best": worst / best if best > 0 else math.nan,
            }
        )
    return pd.DataFrame(rows, columns=["preset", "filter", "values", "best", "best_at", "worst",
                                       "worst_at", "worst_over_best"])  # fmt: skip


# --- figures -----------------------------------------------------------------------------------

LABELS = {
    "meskf": "MESKF", "maeskf": "MAESKF", "vb": "VB-MAESKF", "robust": "robust", "oracle": "oracle",
}  # fmt: skip
_COLORS = {
    "meskf": "tab:red", "maeskf": "tab:orange", "vb": "tab:blue", "robust": "tab:olive",
    "oracle": "tab:gray",
}  # fmt: skip


def _axes(n: int, title: str) -> tuple[Any, list[Any]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 3.9), squeeze=False)
    fig.suptitle(title)
    return fig, list(axes[0])


def _save(fig: Any, path: Path, dpi: int) -> Path:
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def _curve_plot(
    table: pd.DataFrame, parameter: str, path: Path, title: str, xlabel: str, dpi: int
) -> Path:
    c = curve(table, parameter)
    presets = list(dict.fromkeys(table["preset"]))
    fig, axes = _axes(max(1, len(presets)), title)
    ok = _ok(table)
    for ax, preset in zip(axes, presets, strict=False):
        for filt, g in c[c["preset"] == preset].groupby("filter", sort=False):
            color = _COLORS.get(str(filt))
            x = g[parameter].to_numpy(dtype=float)
            ax.plot(x, g["mean"], "o-", ms=3, color=color, label=f"{LABELS.get(str(filt), filt)}")
            ax.fill_between(x, g["min"], g["max"], color=color, alpha=0.15, lw=0)
        if parameter == "q":  # references at their defaults (VB ungated, oracle)
            refs = ok[(ok["preset"] == preset) & ~np.isfinite(ok["q"].astype(float))]
            for filt, g in refs.groupby("filter", sort=False):
                mean = float(g["relative_rmse_pct"].mean())
                style = "--" if filt == "vb" else ":"
                name = f"{LABELS.get(str(filt), filt)}{', no gate' if filt == 'vb' else ''}"
                ax.axhline(mean, ls=style, color=_COLORS.get(str(filt)), label=name)
        n_seeds = ok[ok["preset"] == preset]["seed"].nunique()
        ax.set_title(f"{preset} ({n_seeds} seed{'s' if n_seeds != 1 else ''}; band: min-max)")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("relative RMSE (%)")
        if parameter == "q_scale":
            ax.set_xscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    return _save(fig, path, dpi)


def plot_q_sweep(table: pd.DataFrame, path: Path, dpi: int = 100) -> Path:
    """Relative RMSE against the rejection coefficient q per filter (mean over seeds, band:
    min-max), VB-MAESKF ungated and the oracle as lines: the paper's Fig. 4."""
    title = "Relative RMSE vs gate coefficient q (paper Fig. 4)"
    return _curve_plot(table, "q", path, title, "rejection coefficient q", dpi)


def plot_process_noise(table: pd.DataFrame, path: Path, dpi: int = 100) -> Path:
    """Relative RMSE against the gyro-bias process-noise scale per filter (mean over seeds,
    band: min-max): the paper's Fig. 6."""
    title = "Relative RMSE vs gyro-bias process noise (paper Fig. 6)"
    return _curve_plot(table, "q_scale", path, title, "gyro-bias Q scale (× mission's)", dpi)


def plot_monte_carlo(table: pd.DataFrame, path: Path, dpi: int = 100) -> Path:
    """Relative RMSE per filter over seeds: box plot with every seed as a point (Table 3 as
    a distribution)."""
    ok = _ok(table)
    presets = list(dict.fromkeys(table["preset"]))
    fig, axes = _axes(max(1, len(presets)), "Monte Carlo over seeds: relative RMSE")
    rng = np.random.default_rng(0)  # jitter only
    for ax, preset in zip(axes, presets, strict=False):
        g = ok[ok["preset"] == preset]
        filters = list(dict.fromkeys(g["filter"]))
        data = [g[g["filter"] == f]["relative_rmse_pct"].to_numpy(dtype=float) for f in filters]
        if filters:
            ax.boxplot(data, showfliers=False, medianprops={"color": "black"})
            ax.set_xticks(range(1, len(filters) + 1), [LABELS.get(f, f) for f in filters])
        for i, (f, v) in enumerate(zip(filters, data, strict=True), start=1):
            x = i + rng.uniform(-0.12, 0.12, v.size)
            ax.plot(x, v, "o", ms=3, alpha=0.6, color=_COLORS.get(f))
        ax.set_title(f"{preset} ({g['seed'].nunique()} seeds)")
        ax.set_ylabel("relative RMSE (%)")
        ax.grid(True, axis="y", alpha=0.3)
    return _save(fig, path, dpi)
