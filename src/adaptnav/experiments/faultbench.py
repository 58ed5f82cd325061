"""The simulated-fault benchmark of issue 12: every filter on a clean mission and on faulted
copies of it (:mod:`adaptnav.sim.faults`), scored against the same truth (docs/faults.md).

Per run (:func:`score`): the RMSE (paper eq. (32); docs/metrics.md, 'Accuracy'), the mean position
NEES, the **footprint** of the fault, ``max_t |e_faulted(t) - e_clean(t)|`` (the two runs share
every random draw but the fault, so the difference is the fault's own effect, which the RMSE of a
run dominated by its heading error hides), the horizontal error at the end of the DVL dropout's
window over the horizontal σ the filter claims there
(:func:`adaptnav.analysis.evaluate.outage_drift`: ``sqrt(sd_N² + sd_E²)``), and the ledger fate of
every injected reading (used, rejected, dropped, with the reasons).

Per (preset, filter, fault) over seeds (:func:`summarize`): the ratio RMSE faulted / RMSE clean
paired by seed (mean and worst), the dropout ratio (mean and worst), the mean NEES and the
fates. The targets of the issue (:data:`RMSE_RATIO_TARGET`, :data:`DROPOUT_SIGMA_TARGET`) are
judged on the worst seed: "every filter's RMSE" means every run.

Every filter starts from one shared static alignment of the clean mission: the faults are
placed after the alignment window, so a faulted copy's alignment is the same.
"""

from __future__ import annotations

import math
import shutil
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.api.results import Result, covariance_block
from adaptnav.estimation.settings import FILTER_KINDS, FilterKind
from adaptnav.mission import load_mission
from adaptnav.sim.faults import (
    ALL,
    FAULT_KINDS,
    FaultLog,
    FaultParams,
    inject,
    plan,
)

__all__ = [
    "CASES",
    "CLEAN",
    "DROPOUT_SIGMA_TARGET",
    "FAULT_SEED_TAG",
    "RMSE_RATIO_TARGET",
    "evaluate_mission",
    "fault_rng",
    "merge_reasons",
    "run_seed",
    "score",
    "summarize",
]

CLEAN = "clean"
CASES: tuple[str, ...] = (CLEAN, *FAULT_KINDS, ALL)
"""Every case of the benchmark: the clean mission, each fault alone, all of them at once."""
RMSE_RATIO_TARGET = 1.2
"""Issue 12: every filter's RMSE on a faulted mission at most this times its clean RMSE."""
DROPOUT_SIGMA_TARGET = 3.0
"""Issue 12: the horizontal error at the end of the DVL dropout at most this times the
horizontal σ the filter claims there."""
FAULT_SEED_TAG = 12
"""Second word of the faults' seed (the issue's number): the mission seed alone seeds the
simulator's streams (``SeedSequence(seed).spawn``), so ``[seed, 12]`` is a stream of its own."""
_Initial = tuple[np.ndarray, np.ndarray, float]


def fault_rng(seed: int) -> np.random.Generator:
    """The faults' generator for the mission of simulation seed ``seed``."""
    return np.random.default_rng([seed, FAULT_SEED_TAG])


def _fates(result: Result | None, log: FaultLog | None) -> dict[str, Any]:
    """Per fault kind: readings injected (removed ones for a dropout) and the ledger fate of the
    changed ones, with the reasons (``reason ×n; ...``); NaN without a result."""
    out: dict[str, Any] = {}
    for kind in FAULT_KINDS:
        fault = None
        if log is not None:
            fault = next((f for f in log.faults if f.kind == kind), None)
        out[f"{kind}_n"] = math.nan if fault is None else len(fault.rows or fault.removed_rows)
        for fate in ("used", "rejected", "dropped"):
            out[f"{kind}_{fate}"] = math.nan if fault is None else 0
        out[f"{kind}_reasons"] = ""
        if result is None:
            for fate in ("used", "rejected", "dropped"):
                out[f"{kind}_{fate}"] = math.nan
        if result is None or fault is None or not fault.rows:
            continue
        ledger = result.ledger
        mine = ledger[(ledger["sensor"] == fault.sensor) & ledger["row"].isin(fault.rows)]
        for fate, n in Counter(mine["fate"].astype(str)).items():
            out[f"{kind}_{fate}"] = n
        reasons = Counter(
            f"{fate}: {reason}" if reason else str(fate)
            for fate, reason in zip(mine["fate"], mine["reason"], strict=True)
        )
        out[f"{kind}_reasons"] = "; ".join(f"{r} ×{n}" for r, n in sorted(reasons.items()))
    return out


def _horizontal_mahalanobis(solution: pd.DataFrame, t: float, e_ne: np.ndarray) -> float:
    """``sqrt(e_hᵀ P_h⁻¹ e_h)`` at time ``t``: the horizontal error against P's north-east
    block with its correlation (``cov_dr_N_dr_E``, docs/metrics.md), each element interpolated
    linearly in time as the metrics do. A 2-D Gaussian error exceeds 3 of these with
    probability exp(-9/2) ≈ 1 %."""
    block = covariance_block(solution, ("dr_N", "dr_E"))
    t_sol = solution["t_s"].to_numpy(dtype=float)
    P = np.array([[np.interp(t, t_sol, block[:, i, j]) for j in range(2)] for i in range(2)])
    return float(np.sqrt(evaluate.nees_from(e_ne[None, :], P[None])[0]))


def _warned(warning: dict[str, Any]) -> str:
    """A run's warning (api/diagnosis.py) as ``warned`` names it: the sensor, with
    ``:correlated`` for correlated innovations."""
    kind = warning.get("kind")
    return str(warning["sensor"]) + (f":{kind}" if kind else "")


def score(
    result: Result,
    truth: pd.DataFrame,
    log: FaultLog | None,
    dropout_window_s: tuple[float, float],
    clean_errors: pd.DataFrame | None = None,
) -> dict[str, Any]:
    """One run's figures (module docstring): ``rmse_m``, ``horizontal_rmse_m``,
    ``mean_nees_position``, ``delta_max_m`` (NaN without ``clean_errors``, the clean run's
    :func:`adaptnav.analysis.evaluate.position_errors`), ``dropout_end_m``, ``dropout_sigma_m``,
    ``dropout_ratio`` and ``dropout_mahalanobis`` (:func:`_horizontal_mahalanobis`) at the end
    of ``dropout_window_s`` (scored on every run, the clean one too, as a reference), ``warned``
    (the sensors the run warned of, space-separated, those with correlated innovations as
    ``dvl:correlated``: api/diagnosis.py), and the fates of the injected readings of ``log``."""
    m = evaluate.evaluate(result, truth)
    errors = evaluate.position_errors(result.solution, truth)
    delta = math.nan
    if clean_errors is not None:
        t, i, j = np.intersect1d(
            errors["t_s"].to_numpy(), clean_errors["t_s"].to_numpy(), return_indices=True
        )
        cols = ["dN_m", "dE_m", "dD_m"]
        d = errors[cols].to_numpy()[i] - clean_errors[cols].to_numpy()[j]
        delta = float(np.max(np.linalg.norm(d, axis=1))) if t.size else math.nan
    start, end = dropout_window_s
    drift = evaluate.outage_drift(result.solution, truth, [(start, end - start)]).iloc[0]
    sigma = float(drift["claimed_sd_horizontal_m"])
    end_m = float(drift["end_horizontal_m"])
    t_err = errors["t_s"].to_numpy(dtype=float)
    k = int(np.flatnonzero((t_err > start) & (t_err <= end))[-1])  # outage_drift's sample
    mahalanobis = _horizontal_mahalanobis(
        result.solution, float(t_err[k]), errors[["dN_m", "dE_m"]].to_numpy(dtype=float)[k]
    )
    return {
        "rmse_m": m.rmse_m,
        "horizontal_rmse_m": m.horizontal_rmse_m,
        "max_error_m": m.max_error_m,
        "mean_nees_position": m.mean_nees_position,
        "delta_max_m": delta,
        "dropout_end_m": end_m,
        "dropout_sigma_m": sigma,
        "dropout_ratio": end_m / sigma if sigma > 0.0 else math.nan,
        "dropout_mahalanobis": mahalanobis,
        "warned": " ".join(_warned(w) for w in result.meta.get("warnings", [])),
        **_fates(result, log),
    }


_FIGURES = (
    "rmse_m", "horizontal_rmse_m", "max_error_m", "mean_nees_position", "delta_max_m",
    "dropout_end_m", "dropout_sigma_m", "dropout_ratio", "dropout_mahalanobis",
)  # fmt: skip


def _failed() -> dict[str, Any]:
    """The figures of a run that raised: NaN, no fates."""
    out: dict[str, Any] = dict.fromkeys(_FIGURES, math.nan)
    out.update(warned="", **_fates(None, None))
    return out


def evaluate_mission(
    clean: str | Path,
    work: str | Path,
    seed: int,
    *,
    filters: Sequence[str] = FILTER_KINDS,
    cases: Sequence[str] = CASES,
    params: FaultParams | None = None,
    initial: _Initial | None = None,
    keep: bool = False,
) -> list[dict[str, Any]]:
    """Run every filter of ``filters`` on the mission ``clean`` and on its faulted copies
    (written to ``work/<case>``, seeded by :func:`fault_rng` ``(seed)``, removed after their runs
    unless ``keep``), and :func:`score` each run. ``initial``: the shared start (x0, P0, t0);
    default: the clean mission's alignment. Returns one dict per run (``seed, case, filter``
    and the figures), clean runs first.
    """
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        raise ValueError(f"cases {unknown}: use {', '.join(CASES)}")
    bad = [f for f in filters if f not in FILTER_KINDS]
    if bad:
        raise ValueError(f"filters {bad}: use {', '.join(FILTER_KINDS)}")
    clean_root, work_root = Path(clean), Path(work)
    mission = load_mission(clean_root)
    if mission.truth is None:
        raise ValueError(f"{clean_root}: no truth table to score against")
    start = initial if initial is not None else api.initial_state(mission)[:3]
    p = params if params is not None else FaultParams()
    dropout = plan(clean_root, fault_rng(seed), p)["dvl_dropout"]
    ordered = [CLEAN] + [c for c in cases if c != CLEAN]  # clean first: the footprints need it
    clean_errors: dict[str, pd.DataFrame] = {}
    rows: list[dict[str, Any]] = []
    for case in ordered:
        log: FaultLog | None = None
        root = clean_root
        if case != CLEAN:
            root = work_root / case
            shutil.rmtree(root, ignore_errors=True)
            log = inject(clean_root, root, case, fault_rng(seed), p)
        m = mission if case == CLEAN else load_mission(root)
        assert m.truth is not None  # the copy keeps the clean mission's truth
        for f in filters:
            started = time.perf_counter()
            error = None
            try:
                result = api.run(m, cast(FilterKind, f), initial=start)
                figures = score(result, m.truth, log, dropout, clean_errors.get(f))
            except Exception as exc:  # a filter that breaks down fails its run, not the bench
                error = f"{type(exc).__name__}: {exc}"
                figures = _failed()
            if case == CLEAN and error is None:
                clean_errors[f] = evaluate.position_errors(result.solution, m.truth)
                figures["delta_max_m"] = 0.0
            if case in cases:
                elapsed = time.perf_counter() - started
                rows.append({"seed": seed, "case": case, "filter": f, **figures,
                             "elapsed_s": elapsed, "error": error})  # fmt: skip
        if case != CLEAN and not keep:
            shutil.rmtree(root, ignore_errors=True)
    return rows


def run_seed(
    cache: str | Path,
    preset: str,
    seed: int,
    filters: Sequence[str] = FILTER_KINDS,
    cases: Sequence[str] = CASES,
    keep: bool = False,
) -> list[dict[str, Any]]:
    """Worker task of ``scripts/faults_eval.py``: simulate ``preset`` with ``seed`` and align it
    once into the sweep cache ``cache`` (:func:`adaptnav.experiments.cache.prepare_mission`, reused
    when there), then :func:`evaluate_mission` with the faulted copies under
    ``cache/faulted/<preset>-s<seed>``. Rows carry ``preset`` too."""
    from adaptnav.experiments.cache import prepare_mission
    from adaptnav.experiments.spec import RunSpec

    root = Path(cache)
    spec = RunSpec(preset, seed, FILTER_KINDS[0])
    folder = prepare_mission(root, spec)
    with np.load(root / "missions" / f"{spec.mission_name}.alignment.npz") as z:
        initial = (np.array(z["x0"]), np.array(z["P0"]), float(z["t0"]))
    work = root / "faulted" / spec.mission_name
    rows = evaluate_mission(
        folder, work, seed, filters=filters, cases=cases, initial=initial, keep=keep
    )
    return [{"preset": preset, **r} for r in rows]


def summarize(table: pd.DataFrame) -> pd.DataFrame:
    """Per (preset, filter, case) of the faulted cases, over the seeds: ``n``, ``failed``
    (runs that raised, or whose clean run did: left out of the figures, and a failed target),
    ``rmse_clean_m`` and ``rmse_m`` (means), ``ratio_mean`` and ``ratio_worst`` of RMSE faulted
    / clean paired by seed, ``delta_max_m`` (mean), ``nees_clean`` and ``nees`` (mean position
    NEES), ``dropout_ratio_mean``/``_worst`` and ``dropout_ratio_clean`` (the clean runs at
    the same window), ``dropout_mahalanobis_mean``/``_worst``, and the fates summed over
    seeds (``<kind>_used``... of the case's kinds, ``<kind>_reasons`` joined). Groups in
    order of appearance."""
    key = ["preset", "seed", "filter"]
    clean = table[table["case"] == CLEAN].set_index(key)
    rows: list[dict[str, Any]] = []
    faulted = table[table["case"] != CLEAN]
    for (preset, filt, case), g in faulted.groupby(["preset", "filter", "case"], sort=False):
        base = clean.reindex(pd.MultiIndex.from_frame(g[key]))
        ok = g["error"].isna().to_numpy() & base["error"].isna().to_numpy()
        ok &= np.isfinite(base["rmse_m"].to_numpy(dtype=float))
        g_ok, base_ok = g[ok], base[ok]
        ratio = g_ok["rmse_m"].to_numpy(dtype=float) / base_ok["rmse_m"].to_numpy(dtype=float)
        row: dict[str, Any] = {
            "preset": preset,
            "filter": filt,
            "case": case,
            "n": len(g),
            "failed": int(np.count_nonzero(~ok)),
            "rmse_clean_m": _mean(base_ok["rmse_m"]),
            "rmse_m": _mean(g_ok["rmse_m"]),
            "ratio_mean": _mean(ratio),
            "ratio_worst": _max(ratio),
            "delta_max_m": _mean(g_ok["delta_max_m"]),
            "nees_clean": _mean(base_ok["mean_nees_position"]),
            "nees": _mean(g_ok["mean_nees_position"]),
            "dropout_ratio_mean": _mean(g_ok["dropout_ratio"]),
            "dropout_ratio_worst": _max(g_ok["dropout_ratio"]),
            "dropout_ratio_clean": _mean(base_ok["dropout_ratio"]),
            "dropout_mahalanobis_mean": _mean(g_ok["dropout_mahalanobis"]),
            "dropout_mahalanobis_worst": _max(g_ok["dropout_mahalanobis"]),
        }
        kinds = FAULT_KINDS if case == ALL else (case,)
        for kind in kinds:
            for what in ("n", "used", "rejected", "dropped"):
                row[f"{kind}_{what}"] = int(np.nansum(g[f"{kind}_{what}"].to_numpy(dtype=float)))
            row[f"{kind}_reasons"] = merge_reasons(g[f"{kind}_reasons"])
        rows.append(row)
    return pd.DataFrame(rows)


def _mean(values: Any) -> float:
    v = np.asarray(values, dtype=float)
    return float(np.mean(v)) if v.size else math.nan


def _max(values: Any) -> float:
    v = np.asarray(values, dtype=float)
    return float(np.max(v)) if v.size else math.nan


def merge_reasons(texts: Iterable[str]) -> str:
    """Sum ``reason ×n; ...`` strings (the ``<kind>_reasons`` of runs) into one."""
    total: Counter[str] = Counter()
    for text in texts:
        for part in str(text).split("; ") if text else ():
            reason, _, n = part.rpartition(" ×")
            total[reason] += int(n)
    return "; ".join(f"{r} ×{n}" for r, n in sorted(total.items()))
