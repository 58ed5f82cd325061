"""Measure RTS smoothing on the simulated sea trials and write docs/results-smoothing.md.

``make smoothing`` runs this with its defaults: for ``paper-1`` and ``paper-2`` (the paper's
configuration: DVL, depth and inclinometer aiding, no GNSS) and seeds 1..10, the mission is
simulated and aligned once (cached by :func:`adaptnav.experiments.cache.prepare_mission`; the
cache of ``make reproduce`` by default, so the missions are those of docs/results.md), then
VB-MAESKF, the robust filter, MESKF and MAESKF each run once with the RTS backward pass
(``adaptnav.api.run(..., smooth=True)``, docs/smoothing.md) from the mission's alignment. Each run
is scored twice by :func:`adaptnav.analysis.evaluate.evaluate` (docs/metrics.md): its forward
solution (``Result.forward``) and its smoothed one. The page gives, per preset and filter, the mean
relative RMSE forward and smoothed with their ratio against the issue's 0.6, the mean position and
attitude NEES of both against the χ²(3) band (:data:`adaptnav.analysis.evaluate.NEES_BAND`), the
smoother's store per hour of IMU and the run time, one figure and every run in an appendix. The
filters always run (only the missions are cached), so the page judges the code as it is.

Two cases of aiding per mission (``--cases``): ``paper``, as above, and ``surfacing``, the same
mission with its last GNSS fix used as well (:func:`surfacing`: a vehicle that surfaces at the end
of the dive). Beside each measured ratio the page gives the one the filter's own covariance
predicts, the RMS over the epochs and seeds of the smoothed position σ over the forward one
(:func:`rms_sigma`): what the smoother expects to gain from the information the mission holds.
``--surfacing-gnss-bias`` gives the surfacing's GNSS a bias state (docs/calibration.md, 'GNSS
bias'): ``constant``, or ``gauss-markov`` with the simulator's own σ and τ of the fixes' slow
error (adaptnav.sim.sensors.GpsSpec: 2.5 m, 120 s).

Smoke test: ``python scripts/smoothing_eval.py --presets demo --seeds 1 --filters vb --jobs 1
--cache /tmp/s-cache --out /tmp/s.md --figures /tmp/s``.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from adaptnav import __version__
from adaptnav.analysis.evaluate import NEES_BAND
from adaptnav.experiments.figures import LABELS
from adaptnav.experiments.runner import check_sweep_arguments, run_tasks, sweep_arguments
from adaptnav.mission.screening import thinned_mask
from adaptnav.viz.pages import fmt_number as _f
from adaptnav.viz.pages import git_revision, markdown_table

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_JOBS = 2
"""Workers: the machine this was written for has two cores, each worker runs one seed."""
DEFAULT_FILTERS = ("vb", "robust", "meskf", "maeskf")
TARGET_FILTERS = ("vb", "robust")
"""The filters the issue's targets name; the others are extra rows."""
RMSE_RATIO_TARGET = 0.6
"""Mean smoothed relative RMSE over the seeds ≤ 0.6 × the mean forward one."""
CASES = ("paper", "surfacing")
"""The aiding of each mission (module docstring; :func:`surfacing`)."""
GNSS_BIAS = ("none", "constant", "gauss-markov")
"""The surfacing GNSS's bias state (module docstring)."""


def case_label(case: str, fixes: int = 1, min_interval_s: float = 0.0, bias: str = "none") -> str:
    """How the page names a case: ``paper's aiding``, ``+ last GNSS fix`` (``+ last 120 GNSS
    fixes``, ``+ last 600 GNSS fixes, 240 s apart``, ``+ last 600 GNSS fixes, Gauss-Markov bias
    state``)."""
    if case == "paper":
        return "paper's aiding"
    label = "+ last GNSS fix" if fixes == 1 else f"+ last {fixes} GNSS fixes"
    label += f", {min_interval_s:g} s apart" if min_interval_s > 0.0 else ""
    return label + (f", {bias} bias state" if bias != "none" else "")


SCORES = (
    "rmse_m", "relative_rmse_pct", "horizontal_rmse_m", "final_horizontal_error_m",
    "mean_nees_position", "mean_nees_velocity", "mean_nees_attitude", "nees_position_in_95",
    "nees_attitude_in_95", "yaw_rmse_rad",
)  # fmt: skip
"""The metrics of :class:`adaptnav.analysis.evaluate.Metrics` kept per solution, prefixed
``forward_`` and ``smoothed_`` in the table of runs."""


def _args(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sweep_arguments(p, DEFAULT_FILTERS, 10, min(DEFAULT_JOBS, os.cpu_count() or 1))
    p.add_argument("--cache", type=Path, default=ROOT / "runs" / "reproduce-cache")
    p.add_argument(
        "--cases", default=",".join(CASES), help=f"comma-separated cases [{','.join(CASES)}]"
    )
    p.add_argument(
        "--surfacing-fixes", type=int, default=1, help="GNSS fixes at the end, case surfacing [1]"
    )
    p.add_argument(
        "--surfacing-min-interval",
        type=float,
        default=0.0,
        help="thin those fixes to this many seconds apart (min_interval_s) [0: off]",
    )
    p.add_argument(
        "--surfacing-gnss-bias",
        choices=GNSS_BIAS,
        default="none",
        help="the GNSS's bias state in case surfacing (module docstring) [none]",
    )
    p.add_argument("--figure-seed", type=int, default=1, help="seed of the figure [1]")
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "results-smoothing.md")
    p.add_argument(
        "--figures",
        type=Path,
        default=ROOT / "docs" / "results-smoothing",
        help="folder of the figure and runs.csv (every run)",
    )
    a = p.parse_args(argv)
    check_sweep_arguments(p, a)
    a.case_list = list(dict.fromkeys(x.strip() for x in a.cases.split(",") if x.strip()))
    if not a.case_list or set(a.case_list) - set(CASES):
        p.error(f"--cases: {a.cases!r}; use {', '.join(CASES)}")
    if a.surfacing_fixes < 1:
        p.error(f"--surfacing-fixes: {a.surfacing_fixes} must be >= 1")
    if not a.surfacing_min_interval >= 0.0:
        p.error(f"--surfacing-min-interval: {a.surfacing_min_interval} must be >= 0")
    if not 1 <= a.figure_seed <= a.seeds:
        p.error(f"--figure-seed must be in 1..{a.seeds}")
    return a


# --- the runs ----------------------------------------------------------------------------------


def _trace(result: Any, truth: pd.DataFrame) -> pd.DataFrame:
    """Position errors of ``result`` at the truth times (docs/metrics.md) with the horizontal σ
    it claims there, ``sqrt(sd_N² + sd_E²)``: what the figure draws."""
    from adaptnav.analysis.evaluate import POSITION_SD, position_errors

    e = position_errors(result.solution, truth)
    t_sol = result.solution["t_s"].to_numpy(dtype=float)
    sd = [np.interp(e["t_s"], t_sol, result.solution[c].to_numpy(dtype=float))
          for c in POSITION_SD[:2]]  # fmt: skip
    return e[["t_s", "error_m", "horizontal_m"]].assign(sd_horizontal_m=np.hypot(*sd))


def rms_sigma(result: Any, truth: pd.DataFrame) -> float:
    """``sqrt(mean(sd_N² + sd_E² + sd_D²))`` (m) at the truth epochs the RMSE covers: the RMSE
    the filter expects of itself, which its RMSE matches on average when it is consistent."""
    from adaptnav.analysis.evaluate import POSITION_SD, position_errors

    e = position_errors(result.solution, truth)
    t_sol = result.solution["t_s"].to_numpy(dtype=float)
    var = sum(np.interp(e["t_s"], t_sol, result.solution[c].to_numpy(dtype=float) ** 2)
              for c in POSITION_SD)  # fmt: skip
    return float(np.sqrt(np.mean(var)))


def surfacing(mission: Any, fixes: int = 1, min_interval_s: float = 0.0, bias: str = "none") -> Any:
    """``mission`` with its (first) GNSS sensor aiding at its last ``fixes`` fixes as well: a
    vehicle that surfaces at the end of the dive. None if it has no GNSS fix. One fix by
    default, not the minutes of 1-Hz fixes a surfacing gives: the simulated GNSS error has a
    2.5-m Gauss-Markov part with a 120-s correlation time (docs/simulation.md) and the filter
    takes fixes as white, so a run of fixes within one correlation time is trusted as if their
    errors averaged out (measured with the last 120 fixes: docs/smoothing.md, 'What smoothing
    can and cannot do'), unless they are thinned to one per correlation time: ``min_interval_s``,
    the sensor setting of that name (:func:`adaptnav.mission.screening.thinned_mask`), or the
    GNSS is given a ``bias`` state (:data:`GNSS_BIAS`)."""
    have = mission.sensors
    names = [n for n, c in mission.config.sensors.items()
             if c.kind == "gnss" and n in have and have[n].t.size]  # fmt: skip
    if not names:
        return None
    g = mission.sensors[names[0]]
    last = np.arange(max(g.t.size - fixes, 0), g.t.size)
    last = last[~thinned_mask(g.t[last], min_interval_s)]
    fix = dataclasses.replace(g, t=g.t[last], z=g.z[last], rows=g.rows[last])
    config = mission.config.model_copy(deep=True)
    config.sensors[names[0]] = config.sensors[names[0]].model_copy(update={"use": "aid"})
    if bias != "none":
        from adaptnav.mission.config import with_overrides
        from adaptnav.sim.sensors import GpsSpec

        spec = GpsSpec()
        prior = {"sigma": [spec.sigma_gm, "m"]}
        if bias == "gauss-markov":
            prior["tau"] = [spec.tau_gm, "s"]
        at = f"sensors.{names[0]}"
        config = with_overrides(
            config, [(f"{at}.estimate", ["bias"]), (f"{at}.calibration", {"bias": prior})]
        )
    return dataclasses.replace(mission, sensors={**mission.sensors, names[0]: fix}, config=config)


def _run_filter(mission: Any, initial: Any, kind: str, trace: bool) -> dict[str, Any]:
    """One smoothed run of ``kind`` scored forward and smoothed; with ``trace`` also both
    solutions' error traces (key ``traces``)."""
    from adaptnav import api
    from adaptnav.analysis import evaluate

    started = time.perf_counter()
    smoothed = api.run(mission, kind, initial=initial, smooth=True)  # type: ignore[arg-type]
    run_s = time.perf_counter() - started
    forward = dataclasses.replace(smoothed, solution=smoothed.forward, forward=None)
    row: dict[str, Any] = {}
    for name, result in (("forward", forward), ("smoothed", smoothed)):
        m = evaluate.evaluate(result, mission.truth)
        row |= {f"{name}_{k}": float(getattr(m, k)) for k in SCORES}
        row[f"{name}_rms_sigma_m"] = rms_sigma(result, mission.truth)
    row["relative_rmse_ratio"] = (
        row["smoothed_relative_rmse_pct"] / row["forward_relative_rmse_pct"]
    )
    store = smoothed.meta["smoother"]
    hours = smoothed.meta["imu_samples"] / mission.config.imu.rate_hz / 3600.0
    row |= {
        "distance_m": m.distance_m,
        "duration_s": m.duration_s,
        "imu_hours": hours,
        "nodes": store["nodes"],
        "update_nodes": store["update_nodes"],
        "failed_nodes": store["failed_nodes"],
        "store_mb_per_h": store["store_bytes"] / 1e6 / hours,
        "run_s": run_s,
        "elapsed_s": time.perf_counter() - started,
    }
    if trace:
        pairs = (("forward", forward), ("smoothed", smoothed))
        row["traces"] = {n: _trace(r, mission.truth) for n, r in pairs}
    return row


def _plain_rmse(cache: Path, preset: str, seed: int, kind: str) -> float:
    """The relative RMSE of the plain (unsmoothed) run of this spec in ``cache`` (the sweep of
    ``make reproduce``), NaN if it is not there: the forward solution must equal it."""
    from adaptnav.experiments.cache import cached_record
    from adaptnav.experiments.spec import RunSpec

    record = cached_record(cache, RunSpec(preset, seed, kind).key())
    value = (record or {}).get("metrics", {}).get("relative_rmse_pct")
    return math.nan if value is None else float(value)


def run_seed(
    cache: str, preset: str, seed: int, filters: Sequence[str], traced: Sequence[str],
    cases: Sequence[str] = CASES[:1], fixes: int = 1, min_interval_s: float = 0.0,
    bias: str = "none",
) -> list[dict[str, Any]]:  # fmt: skip
    """Every filter of ``filters`` smoothed on mission (preset, seed), prepared in ``cache``
    once, in each of ``cases`` (:data:`CASES`; a mission without a GNSS fix has no
    ``surfacing`` rows): one row per case and filter (``error`` says why a run failed; its
    numbers are then NaN); the first case's rows of the filters in ``traced`` keep their error
    traces."""
    from adaptnav.experiments.cache import load_prepared, prepare_mission
    from adaptnav.experiments.spec import RunSpec

    root = Path(cache)
    spec = RunSpec(preset, seed, filters[0])
    prepare_mission(root, spec)
    paper, initial = load_prepared(root, spec.mission_name)
    missions = {"paper": paper,
                "surfacing": surfacing(paper, fixes, min_interval_s, bias)
                if "surfacing" in cases else None}  # fmt: skip
    rows = []
    for case in (c for c in cases if missions[c] is not None):
        for kind in filters:
            plain = _plain_rmse(root, preset, seed, kind) if case == "paper" else math.nan
            label = case_label(case, fixes, min_interval_s, bias)
            base = {"case": case, "aiding": label, "preset": preset, "seed": seed,
                    "filter": kind, "plain_relative_rmse_pct": plain}  # fmt: skip
            try:
                traces = case == cases[0] and kind in traced
                row = _run_filter(missions[case], initial, kind, traces)
                rows.append({**base, **row, "error": None})
            except Exception as exc:  # reported on the page, the other runs go on
                rows.append({**base, "error": f"{type(exc).__name__}: {exc}"})
    return rows


def run_all(
    cache: Path, tasks: Sequence[tuple[str, int]], filters: Sequence[str], jobs: int,
    traced: tuple[str, int], scheduler: str | None = None, cases: Sequence[str] = CASES[:1],
    fixes: int = 1, min_interval_s: float = 0.0, bias: str = "none",
) -> list[dict[str, Any]]:  # fmt: skip
    """Every (preset, seed) task through :func:`run_seed` on a dask cluster (``scheduler``, else
    ``$ADAPTNAV_SCHEDULER``, else ``jobs`` local workers; 1: in this process); on the ``traced``
    task the filters of :func:`_figure_filters` keep their error traces. Progress on stderr."""
    rows: list[dict[str, Any]] = []
    started = time.perf_counter()

    def report(task: tuple[Any, ...], out: list[dict[str, Any]]) -> None:
        runs = sum(r.get("run_s", 0.0) for r in out)
        print(f"{task[1]} seed {task[2]}: {len(out)} runs ({runs:.0f} s of runs) done at "
              f"{time.perf_counter() - started:.0f} s", file=sys.stderr)  # fmt: skip
        rows.extend(out)

    def trace(task: tuple[str, int]) -> list[str]:
        return _figure_filters(filters) if task == traced else []

    # jobs = 1 runs in this process (no pickling: also when this file is loaded by path)
    work = [(str(cache.resolve()), p, s, list(filters), trace((p, s)), list(cases), fixes,
             min_interval_s, bias)
            for p, s in tasks]  # fmt: skip
    run_tasks(run_seed, work, jobs, report, scheduler)
    return rows


def _figure_filters(filters: Sequence[str]) -> list[str]:
    """The filters the figure draws: those of the targets that ran, else the first."""
    return [f for f in filters if f in TARGET_FILTERS] or list(filters[:1])


# --- the summary -------------------------------------------------------------------------------


def nees_class(value: float) -> str:
    """Where a mean NEES lies against the χ²(3) 95 % band (docs/metrics.md):
    ``below``, ``inside`` or ``above`` :data:`adaptnav.analysis.evaluate.NEES_BAND`."""
    if not math.isfinite(value):
        return "-"
    return "below" if value < NEES_BAND[0] else "above" if value > NEES_BAND[1] else "inside"


def summarize(table: pd.DataFrame) -> pd.DataFrame:
    """Per case, preset and filter, over the seeds that ran: means of the forward and smoothed
    metrics, the ratio of the mean relative RMSEs and the mean and worst per-seed ratio, the
    RMS over the seeds of the smoothed RMSE over the forward one (``rms_ratio``) and of the
    filter's own σ (``sigma_ratio``, :func:`rms_sigma`: the ratio the filter predicts), the
    store per hour and the run time, and both verdicts (``rmse_ok``: ratio of the means ≤
    :data:`RMSE_RATIO_TARGET`; ``nees_ok``: the smoothed mean position NEES in the same place
    against the χ²(3) band as the forward one, :func:`nees_class`)."""
    out = []
    for (case, preset, kind), g in table.groupby(["case", "preset", "filter"], sort=False):
        ok = g[g["error"].isna()]
        row: dict[str, Any] = {"case": case, "aiding": g["aiding"].iloc[0], "preset": preset,
                               "filter": kind, "seeds": len(ok),
                               "failed": len(g) - len(ok)}  # fmt: skip
        for name in ("forward", "smoothed"):
            row |= {f"{name}_{k}": ok[f"{name}_{k}"].mean() for k in (*SCORES, "rms_sigma_m")}

        def rms_ratio(key: str, ok: pd.DataFrame = ok) -> float:
            return float(np.sqrt(np.mean(ok[f"smoothed_{key}"] ** 2)
                                 / np.mean(ok[f"forward_{key}"] ** 2)))  # fmt: skip

        row |= {
            "rms_ratio": rms_ratio("rmse_m"),
            "sigma_ratio": rms_ratio("rms_sigma_m"),
            "ratio_of_means": row["smoothed_relative_rmse_pct"] / row["forward_relative_rmse_pct"],
            "ratio_mean": ok["relative_rmse_ratio"].mean(),
            "ratio_worst": ok["relative_rmse_ratio"].max(),
            "store_mb_per_h": ok["store_mb_per_h"].mean(),
            "run_s": ok["run_s"].mean(),
            "imu_hours": ok["imu_hours"].mean(),
            "failed_nodes": ok["failed_nodes"].sum(),
        }
        row["rmse_ok"] = bool(row["ratio_of_means"] <= RMSE_RATIO_TARGET and not row["failed"])
        fwd, sm = (
            nees_class(row["forward_mean_nees_position"]),
            nees_class(row["smoothed_mean_nees_position"]),
        )
        row["nees_ok"] = bool(fwd == sm != "-" and not row["failed"])
        out.append(row)
    return pd.DataFrame(out)


# --- the page ----------------------------------------------------------------------------------


def _label(kind: str) -> str:
    return LABELS.get(kind, kind)


def _verdict(ok: bool) -> str:
    return "PASS" if ok else "**FAIL**"


def _targets_table(summary: pd.DataFrame) -> str:
    header = ["aiding", "preset", "filter", "relative RMSE % forward → smoothed",
              "ratio of the means (mean / worst per seed)", f"≤ {RMSE_RATIO_TARGET:g}",
              "RMS ratio smoothed / forward: of the RMSE / of the σ",
              "position NEES forward → smoothed", "same band"]  # fmt: skip
    rows = []
    for r in summary[summary["filter"].isin(TARGET_FILTERS)].itertuples():
        rows.append([
            str(r.aiding), str(r.preset), _label(str(r.filter)),
            f"{_f(r.forward_relative_rmse_pct, '.3f')} → {_f(r.smoothed_relative_rmse_pct, '.3f')}",
            f"{_f(r.ratio_of_means, '.3f')} ({_f(r.ratio_mean, '.3f')} / "
            f"{_f(r.ratio_worst, '.3f')})",
            _verdict(bool(r.rmse_ok)),
            f"{_f(r.rms_ratio, '.3f')} / {_f(r.sigma_ratio, '.3f')}",
            " → ".join(f"{_f(v, '.2f')} ({nees_class(v)})" for v in (
                r.forward_mean_nees_position, r.smoothed_mean_nees_position)),
            _verdict(bool(r.nees_ok)),
        ])  # fmt: skip
    return markdown_table(header, rows)


def _pair(r: Any, key: str, fmt: str, scale: float = 1.0) -> str:
    fwd, sm = getattr(r, f"forward_{key}") * scale, getattr(r, f"smoothed_{key}") * scale
    return f"{_f(fwd, fmt)} / {_f(sm, fmt)}"


def _summary_table(summary: pd.DataFrame) -> str:
    header = ["aiding", "preset", "filter", "seeds", "relative RMSE %", "RMSE m",
              "ratio of means", "mean ratio", "RMS σ m", "NEES pos", "NEES att",
              "% epochs in band pos", "yaw RMSE °",
              "final horiz. error m", "store MB per h of IMU",
              "run s (forward + backward)"]  # fmt: skip
    rows = []
    for r in summary.itertuples():
        rows.append([
            str(r.aiding), str(r.preset), _label(str(r.filter)),
            str(r.seeds) + (f" ({r.failed} failed)" if r.failed else ""),
            _pair(r, "relative_rmse_pct", ".3f"), _pair(r, "rmse_m", ".1f"),
            _f(r.ratio_of_means, ".3f"), _f(r.ratio_mean, ".3f"), _pair(r, "rms_sigma_m", ".1f"),
            _pair(r, "mean_nees_position", ".2f"), _pair(r, "mean_nees_attitude", ".2f"),
            _pair(r, "nees_position_in_95", ".0f", 100.0),
            _pair(r, "yaw_rmse_rad", ".3f", 180.0 / math.pi),
            _pair(r, "final_horizontal_error_m", ".1f"),
            _f(r.store_mb_per_h, ".0f"), _f(r.run_s, ".1f"),
        ])  # fmt: skip
    return markdown_table(header, rows)


def _seed_table(table: pd.DataFrame) -> str:
    header = ["aiding", "preset", "seed", "filter", "relative RMSE % forward / smoothed", "ratio",
              "NEES pos forward / smoothed", "NEES att forward / smoothed",
              "yaw RMSE ° forward / smoothed", "plain run's relative RMSE %", "failed nodes",
              "run s"]  # fmt: skip
    rows = []
    for r in table[table["error"].isna()].itertuples():
        rows.append([
            str(r.aiding), str(r.preset), str(r.seed), _label(str(r.filter)),
            _pair(r, "relative_rmse_pct", ".3f"), _f(r.relative_rmse_ratio, ".3f"),
            _pair(r, "mean_nees_position", ".2f"), _pair(r, "mean_nees_attitude", ".2f"),
            _pair(r, "yaw_rmse_rad", ".3f", 180.0 / math.pi),
            _f(r.plain_relative_rmse_pct, ".3f"), str(int(r.failed_nodes)), _f(r.run_s, ".1f"),
        ])  # fmt: skip
    return markdown_table(header, rows)


def _plain_check(table: pd.DataFrame) -> str:
    """How the forward solutions compare with the plain runs of the cache (same spec)."""
    ok = table[table["error"].isna()]
    both = ok[np.isfinite(ok["plain_relative_rmse_pct"])]
    if both.empty:
        return "No plain run of these specs is in the cache to compare the forward solutions with."
    diff = (both["forward_relative_rmse_pct"] - both["plain_relative_rmse_pct"]).abs().max()
    same = "are equal" if diff == 0.0 else f"differ by at most {diff:.1e} %"
    return (
        f"The forward solution of a smoothed run is the filter's own: on the {len(both)} runs "
        f"whose plain (unsmoothed) run is in the cache (docs/results.md's Monte Carlo), the "
        f"relative RMSEs {same}."
    )


def _verdict_lines(summary: pd.DataFrame) -> list[str]:
    lines = []
    for r in summary[summary["filter"].isin(TARGET_FILTERS)].itertuples():
        lines.append(
            f"{r.preset} {_label(str(r.filter))}, {r.aiding}: smoothed / "
            "forward relative RMSE "
            f"{_f(r.ratio_of_means, '.3f')} (target ≤ {RMSE_RATIO_TARGET:g}) "
            f"{_verdict(bool(r.rmse_ok)).strip('*')}; position NEES "
            f"{_f(r.forward_mean_nees_position, '.2f')} → "
            f"{_f(r.smoothed_mean_nees_position, '.2f')} {_verdict(bool(r.nees_ok)).strip('*')}"
        )
    return lines


def figure(traces: dict[str, dict[str, pd.DataFrame]], path: Path, title: str) -> None:
    """3-D position error forward and smoothed of each traced filter over time (top), and the
    first filter's horizontal error with the horizontal σ it claims (bottom)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from adaptnav.analysis.compare import filter_colour
    from adaptnav.viz.plots import envelope

    fig, (ax3, axh) = plt.subplots(2, 1, figsize=(11, 7), sharex=True, constrained_layout=True)
    t0 = min(float(tr["forward"]["t_s"].iloc[0]) for tr in traces.values())
    first = next(iter(traces))
    for kind, tr in traces.items():
        colour = filter_colour(kind)
        for name, dash, lw in (("forward", "--", 1.0), ("smoothed", "-", 1.4)):
            e = tr[name]
            t = e["t_s"].to_numpy(dtype=float)
            te, ye = envelope(t, e["error_m"].to_numpy(dtype=float))
            ax3.plot((te - t0) / 60.0, ye, color=colour, ls=dash, lw=lw,
                     label=f"{_label(kind)} {name}")  # fmt: skip
            if kind == first:
                th, yh = envelope(t, e["horizontal_m"].to_numpy(dtype=float))
                ts, ys = envelope(t, e["sd_horizontal_m"].to_numpy(dtype=float))
                grey = "0.2" if name == "smoothed" else "0.55"
                axh.plot((th - t0) / 60.0, yh, color=grey, ls=dash, lw=lw,
                         label=f"{name}: horizontal error")  # fmt: skip
                axh.plot((ts - t0) / 60.0, ys, color=colour, ls=dash, lw=0.9,
                         label=f"{name}: claimed horizontal σ")  # fmt: skip
    ax3.set_ylabel("3-D position error (m)")
    ax3.set_title(title)
    axh.set_ylabel("horizontal (m)")
    axh.set_title(f"{_label(first)}: horizontal error and the σ it claims")
    axh.set_xlabel("time since navigation start (min)")
    for ax in (ax3, axh):
        ax.grid(True, alpha=0.3)
        ax.set_ylim(bottom=0.0)
        ax.legend(fontsize=8, loc="upper left")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def page(
    table: pd.DataFrame, summary: pd.DataFrame, header_line: str, fig_rel: str, figure_name: str
) -> str:
    """The Markdown of docs/results-smoothing.md."""
    lines = [
        "# Results: RTS smoothing on the simulated sea trials",
        "",
        header_line,
        "",
        "What was run (the smoother: [`smoothing.md`](smoothing.md); the metrics: "
        "[`metrics.md`](metrics.md)):",
        "",
        "- missions: the simulated sea trials of docs/results.md (`adaptnav simulate`, every "
        "disturbance on; DVL, depth and inclinometer aiding, GNSS only to initialise: the "
        "paper's configuration), one per preset and seed, each with its static alignment;",
        "- aiding: *paper's aiding* as simulated; *+ last GNSS fix*: the same mission with its "
        "last GNSS fix, at its very end, used as well (a vehicle that surfaces at the end of the "
        "dive and takes one fix; one, not minutes of fixes, because the simulated fixes' errors "
        "are correlated over 120 s and the filter takes them as white: docs/smoothing.md);",
        "- each filter at its defaults, run once from that alignment with the RTS backward "
        "pass (`adaptnav.api.run(..., smooth=True)`); the run's forward solution and its "
        "smoothed one are scored against the truth over the same span;",
        f"- relative RMSE: `100 RMSE / D` (%); target: the mean smoothed relative RMSE over the "
        f"seeds ≤ {RMSE_RATIO_TARGET:g} × the mean forward one (judged on the ratio of the "
        "means; the mean and worst of the per-seed ratios beside it);",
        f"- consistency: each run's mean position NEES (P's full 3×3 block), averaged over the "
        f"seeds; target: the smoothed one in the same place as the forward one against the "
        f"χ²(3) 95 % band [{NEES_BAND[0]:.3f}, {NEES_BAND[1]:.3f}] (below, inside or above; "
        "mean 3 for a consistent filter);",
        "- RMS ratio: `sqrt(mean RMSE_smoothed² / mean RMSE_forward²)` over the seeds, beside "
        "the same ratio of the RMS position σ each solution claims (`sd_N² + sd_E² + sd_D²` at "
        "the truth epochs): the gain the filter's own model expects from the information the "
        "mission holds, which a consistent smoother's measured ratio matches on average;",
        "- store: the bytes the forward pass keeps for the backward one, per hour of 100-Hz "
        "IMU; run s: `api.run` with the backward pass (forward, store, backward, tables).",
        "",
        _plain_check(table),
        "",
        f"Every run: [`{fig_rel}/runs.csv`]({fig_rel}/runs.csv).",
        "",
        "## Targets (VB-MAESKF and robust)",
        "",
        _targets_table(summary),
        "",
        *[f"- {line}" for line in _verdict_lines(summary)],
        "",
        "## Every filter: forward / smoothed, means over the seeds",
        "",
        _summary_table(summary),
        "",
        "## Figure",
        "",
        f"![position error, forward and smoothed]({fig_rel}/{figure_name})",
        "",
        "## Appendix: every run",
        "",
        _seed_table(table),
        "",
    ]
    failed = table[table["error"].notna()]
    if len(failed):
        lines += ["## Runs that failed", "", markdown_table(
            ["preset", "seed", "filter", "error"],
            [[str(r.preset), str(r.seed), _label(str(r.filter)), str(r.error)]
             for r in failed.itertuples()],
        ), ""]  # fmt: skip
    return "\n".join(lines)


def _sorted(
    rows: list[dict[str, Any]], presets: Sequence[str], filters: Sequence[str]
) -> pd.DataFrame:
    """The runs in page order (preset, seed, filter as given); the traces left out."""
    table = pd.DataFrame([{k: v for k, v in r.items() if k != "traces"} for r in rows])
    keys = pd.DataFrame({
        "case": table["case"].map({c: i for i, c in enumerate(CASES)}),
        "preset": table["preset"].map({p: i for i, p in enumerate(presets)}),
        "seed": table["seed"],
        "filter": table["filter"].map({f: i for i, f in enumerate(filters)}),
    })  # fmt: skip
    order = keys.sort_values(["case", "preset", "seed", "filter"]).index
    return table.loc[order].reset_index(drop=True)


def main(argv: Sequence[str] | None = None) -> int:
    args = _args(argv)
    revision = git_revision(ROOT)  # before this run writes its own outputs
    started = time.perf_counter()
    # paper-1 first: the longest tasks start first, so neither worker idles at the end.
    by_length = sorted(args.preset_list, key=lambda p: p != "paper-1")
    tasks = [(p, s) for p in by_length for s in range(1, args.seeds + 1)]
    traced = (args.preset_list[0], args.figure_seed)
    cases = (
        args.case_list, args.surfacing_fixes, args.surfacing_min_interval,
        args.surfacing_gnss_bias,
    )  # fmt: skip
    rows = run_all(args.cache, tasks, args.filter_list, args.jobs, traced, args.scheduler, *cases)
    wall = time.perf_counter() - started
    table = _sorted(rows, args.preset_list, args.filter_list)
    summary = summarize(table)
    args.figures.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.figures / "runs.csv", index=False, float_format="%.6g")
    traces = {r["filter"]: r["traces"] for r in rows if "traces" in r}
    figure_name = "position_error.png"
    figure(traces, args.figures / figure_name, f"{traced[0]}, seed {traced[1]}: 3-D position "
           "error, forward (dashed) and smoothed (solid)")  # fmt: skip
    runs_min = float(table["run_s"].sum()) / 60.0
    cmd = "make smoothing" if not argv else "python scripts/smoothing_eval.py " + " ".join(argv)
    header = (
        f"Written by `{cmd}` (scripts/smoothing_eval.py) on "
        f"{dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}, adaptnav {__version__}, "
        f"commit {revision}: {len(table)} smoothed runs ({', '.join(args.preset_list)}; seeds "
        f"1-{args.seeds}; filters {', '.join(_label(f) for f in args.filter_list)}) in "
        f"**{wall / 60:.1f} min** wall on {args.jobs} worker(s) ({runs_min:.1f} min of runs; "
        "scoring and loading the missions besides)."
    )
    fig_rel = os.path.relpath(args.figures, args.out.parent)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(page(table, summary, header, fig_rel, figure_name), encoding="utf-8")
    print(f"wrote {args.out} ({len(table)} runs, {wall:.0f} s wall)")
    for line in _verdict_lines(summary):
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:] or None))
