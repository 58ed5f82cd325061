"""Several filters on one mission, from one shared start, tabulated beside the paper's Table 3.

:func:`compare` aligns **once** (:func:`adaptnav.api.initial_state`, docs/alignment.md) and runs
every requested filter from that same ``(x0, P0, t0)``, so the filters differ only in how they
choose the measurement noise R (docs/filters.md, the sections on MESKF, MAESKF and VB-MAESKF)
and gate outliers (docs/filters.md, 'Gate'), never in their start:

* ``meskf``, ``maeskf``, ``vb``: the paper's three filters (MESKF, MAESKF, VB-MAESKF);
* ``oracle``: the same ESKF given the simulator's true per-reading σ and told which readings are
  outliers: the best any R strategy could do on the mission (needs the simulator's truth
  columns);
* ``floor``: not a filter, a baseline: dead reckoning of the DVL with the reference attitude
  (:func:`adaptnav.analysis.floor.run`; it does not start from the alignment, so its solution is cut
  to the filters' navigation start and every row is scored over the same stretch).

Each run is scored by :func:`adaptnav.analysis.evaluate.evaluate` against the mission's reference:
RMSE (paper eq. (32)), relative RMSE (paper eq. (33), over the horizontal length of the reference
track; both docs/metrics.md, 'Accuracy'), horizontal errors, the mean NEES of position, velocity and
attitude with the share of epochs inside the χ²(3) 95 % band (docs/metrics.md) and the ledger's
per-sensor counts. :meth:`Comparison.table` sets them beside the paper's Table 3
(:data:`PAPER_TABLE3`) when the mission is one of the paper presets (``paper-1``, ``paper-2``,
docs/simulation.md).

With ``smooth`` every filter's run is RTS-smoothed (docs/smoothing.md; the floor is not a
filter and is not): the metrics above are then the smoothed solution's, and the forward
solution's (:func:`adaptnav.analysis.evaluate.forward_metrics`) are kept in
:attr:`Comparison.forward` and shown beside them as ``forward_<key>``
(:data:`adaptnav.analysis.evaluate.FORWARD_KEYS`) in the table and the JSON.

:meth:`Comparison.save` writes a comparison folder::

    OUT/
      meskf/ maeskf/ vb/ ...   run folders (adaptnav.api.results.save) + truth.parquet each, so
                               ``adaptnav evaluate OUT/vb`` works
      comparison.csv           Comparison.table()
      comparison.json          format, mission (name, folder, preset, seed), the initial state,
                               the filters, the figures, and ``results`` = Comparison.to_json()
      figures/*.png            adaptnav.viz.plots (the paper's Figs. 7-10, ledger counts, NIS,
                               the calibration states when some run estimated them)
      figures/*.plotly.json    adaptnav.viz.interactive: the time series among them as
                               interactive figures (Plotly), listed under ``interactive``

which :func:`adaptnav.viz.report.write_report` turns into one HTML page.

This module imports only the standard library at import time (the command line reads
:data:`PAPER_TABLE3` from here on every start); NumPy, pandas, the engine and matplotlib are
imported where they are used.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

from adaptnav.core.formats import SIMULATION_FILE

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

    from adaptnav.analysis.evaluate import Metrics
    from adaptnav.api.results import Result
    from adaptnav.estimation.settings import FilterSettings
    from adaptnav.mission import Mission

__all__ = [
    "DEFAULT_FILTERS",
    "FILTER_COLOURS",
    "FILTER_LABELS",
    "FILTER_NAMES",
    "NEES_BAND_TEXT",
    "NEES_COLUMNS",
    "OTHER_COLOUR",
    "PAPER_TABLE3",
    "Comparison",
    "PendingFigures",
    "compare",
    "filter_colour",
    "parse_filters",
    "simulation_info",
    "write_png",
]

PAPER_TABLE3: dict[str, dict[str, tuple[float, float]]] = {
    "paper-1": {"vb": (46.0, 0.20), "maeskf": (80.0, 0.35), "meskf": (184.0, 0.80)},
    "paper-2": {"vb": (62.0, 0.65), "maeskf": (89.0, 0.91), "meskf": (102.0, 1.06)},
}
"""The paper's Table 3: RMSE (m) and relative RMSE (%) per trajectory (preset) and filter."""

FILTER_NAMES: tuple[str, ...] = ("meskf", "maeskf", "vb", "robust", "oracle", "floor")
"""Every name :func:`compare` accepts, in the order tables and figures list them."""
DEFAULT_FILTERS: tuple[str, ...] = ("meskf", "maeskf", "vb", "robust", "oracle")
NEES_COLUMNS: tuple[str, ...] = (
    "mean_nees_position",
    "mean_nees_velocity",
    "mean_nees_attitude",
    "nees_position_in_95",
    "nees_velocity_in_95",
    "nees_attitude_in_95",
)
"""The consistency metrics (:class:`adaptnav.analysis.evaluate.Metrics`) a comparison shows per
filter:
mean NEES (3 for a consistent filter) and the share of epochs inside the χ²(3) 95 % band."""
NEES_BAND_TEXT = "χ²(3): mean 3, 95 % of epochs in [0.216, 9.348]"
"""What a consistent filter's NEES does, for captions (:data:`adaptnav.analysis.evaluate.NEES_BAND`;
written out so that this module need not import SciPy at start-up)."""
FILTER_LABELS: dict[str, str] = {
    "meskf": "MESKF",
    "maeskf": "MAESKF",
    "vb": "VB-MAESKF",
    "robust": "robust (VB, Student-t, bounded R̂)",
    "oracle": "oracle ESKF (true R)",
    "floor": "DVL dead reckoning",
}
FILTER_COLOURS: dict[str, str] = {
    "meskf": "#d62728",
    "maeskf": "#1f77b4",
    "vb": "#2ca02c",
    "robust": "#bcbd22",
    "oracle": "#9467bd",
    "floor": "#ff7f0e",
}
"""The one colour of each filter in every figure: the report's static (matplotlib) and
interactive (Plotly) figures, the sweep figures (:mod:`adaptnav.experiments.figures`) and the
results pages' scripts all take it from here (:func:`filter_colour`; docs/report.md). Hex codes
of matplotlib's tab10 palette, which both libraries read; black is kept for the reference."""
OTHER_COLOUR = "#8c564b"
"""The colour of a name outside :data:`FILTER_COLOURS` (tab10's brown)."""

FORMAT_NAME = "adaptnav-comparison"
FORMAT_VERSION = 1
COMPARISON_CSV = "comparison.csv"
COMPARISON_JSON = "comparison.json"
FIGURES_DIR = "figures"
TRUTH_FILE = "truth.parquet"
FIGURE_DPI = 110
INTERACTIVE_SUFFIX = ".plotly.json"
"""File ending of an interactive figure's specification (Plotly's JSON) in ``figures/``."""


class SupportsToJson(Protocol):
    """An interactive figure: anything that writes its specification as JSON text (a Plotly
    figure)."""

    def to_json(self) -> str:
        """The figure's specification."""
        ...


class PendingFigures(Protocol):
    """PNGs being drawn into a comparison folder's ``figures/`` elsewhere, e.g. in a child
    process (:class:`adaptnav.viz.pngs.PngJob`), while :meth:`Comparison.save` writes the rest."""

    def wait(self) -> list[str]:
        """Block until every PNG is written; their file stems, in drawing order."""
        ...


Progress = Callable[[str], None]


def write_png(figure: Figure, path: Path) -> None:
    """One figure as a PNG at :data:`FIGURE_DPI`. zlib level 3: the same pixels as the default
    6, files within a few %, encoded in about half the time."""
    figure.savefig(path, dpi=FIGURE_DPI, pil_kwargs={"compress_level": 3})


def filter_colour(name: str) -> str:
    """The colour of filter ``name`` in every figure (:data:`FILTER_COLOURS`)."""
    return FILTER_COLOURS.get(name, OTHER_COLOUR)


def parse_filters(spec: str | Iterable[str]) -> tuple[str, ...]:
    """Filter names from ``"meskf,vb"`` or a sequence; ValueError for an unknown, repeated or
    empty list (the message names the offending entry and the known names)."""
    if not isinstance(spec, str | Iterable):
        raise TypeError(f"filters: names or 'meskf,vb', not {type(spec).__name__}")
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    odd = [s for s in items if not isinstance(s, str)]
    if odd:
        raise TypeError(f"filters: {odd[0]!r} is not a filter name (use {', '.join(FILTER_NAMES)})")
    names = tuple(s.strip().lower() for s in items if s.strip())
    if not names:
        raise ValueError(f"no filter given (use {', '.join(FILTER_NAMES)})")
    for name in names:
        if name not in FILTER_NAMES:
            raise ValueError(f"unknown filter {name!r} (use {', '.join(FILTER_NAMES)})")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"filter {repeated[0]!r} is given more than once")
    return names


def simulation_info(root: Path) -> dict[str, Any] | None:
    """The simulator's ``simulation.json`` of a mission folder, or None (a real mission)."""
    path = root / SIMULATION_FILE
    if not path.is_file():
        return None
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return info if isinstance(info, dict) else None


@dataclass(frozen=True, eq=False)
class Comparison:
    """Several runs on one mission from one shared start, with their metrics.

    ``results`` and ``metrics`` are keyed by filter name (:data:`FILTER_NAMES`) in the order
    run; ``initial`` is the shared start: ``t0_s``, position and attitude, the alignment's
    report (heading source, σ's). ``mission`` is the loaded mission (its tables feed Fig. 10).
    ``forward``: for the smoothed runs, the metrics of their forward solution (``metrics`` are
    then the smoothed ones; docs/smoothing.md); empty when nothing was smoothed.
    """

    mission_name: str
    mission: Mission
    results: dict[str, Result]
    metrics: dict[str, Metrics]
    initial: dict[str, Any] = field(default_factory=dict)
    forward: dict[str, Metrics] = field(default_factory=dict)

    @property
    def filters(self) -> tuple[str, ...]:
        return tuple(self.results)

    @property
    def truth(self) -> pd.DataFrame:
        if self.mission.truth is None:  # compare() refuses such a mission
            raise ValueError(f"mission {self.mission_name!r} has no reference (truth)")
        return self.mission.truth

    @property
    def t0(self) -> float:
        """Navigation start shared by the filters (s, the mission's clock)."""
        return float(self.initial.get("t0_s", math.nan))

    def paper(self, name: str) -> tuple[float, float]:
        """The paper's (RMSE m, relative RMSE %) for filter ``name`` on this mission, or NaNs."""
        return PAPER_TABLE3.get(self.mission_name, {}).get(name, (math.nan, math.nan))

    def forward_columns(self, name: str) -> dict[str, float]:
        """``forward_<key>`` of filter ``name``'s forward solution
        (:func:`adaptnav.analysis.evaluate.forward_columns`): NaN for a run that was not
        smoothed (the floor) in a smoothed comparison, nothing when none was smoothed."""
        from adaptnav.analysis.evaluate import FORWARD_KEYS, forward_columns

        if not self.forward:
            return {}
        if name not in self.forward:
            return {f"forward_{key}": math.nan for key in FORWARD_KEYS}
        return forward_columns(self.forward[name])

    def sensors(self) -> list[str]:
        """Every sensor in any run's ledger, sorted."""
        return sorted({s for m in self.metrics.values() for s in m.counts})

    def table(self) -> pd.DataFrame:
        """One row per filter: ``filter, label, rmse_m, relative_rmse_pct, horizontal_rmse_m,
        max_horizontal_error_m, distance_m, duration_min``, the consistency
        :data:`NEES_COLUMNS` (``mean_nees_<block>``, ``nees_<block>_in_95`` for position,
        velocity, attitude; NaN where the reference lacks the block), for a smoothed comparison
        the forward solution's :meth:`forward_columns`, then ``<sensor>_used``,
        ``<sensor>_rejected``, ``<sensor>_dropped`` per sensor, then ``paper_rmse_m,
        paper_relative_rmse_pct`` (NaN where the paper has no figure)."""
        import pandas as pd

        sensors = self.sensors()
        rows = []
        for name, m in self.metrics.items():
            row: dict[str, Any] = {
                "filter": name,
                "label": FILTER_LABELS.get(name, name),
                "rmse_m": m.rmse_m,
                "relative_rmse_pct": m.relative_rmse_pct,
                "horizontal_rmse_m": m.horizontal_rmse_m,
                "max_horizontal_error_m": m.max_horizontal_error_m,
                "distance_m": m.distance_m,
                "duration_min": m.duration_s / 60.0,
                **{c: getattr(m, c) for c in NEES_COLUMNS},
                **self.forward_columns(name),
            }
            for sensor in sensors:
                counts = m.counts.get(sensor, {})
                for fate in ("used", "rejected", "dropped"):
                    row[f"{sensor}_{fate}"] = int(counts.get(fate, 0))
            row["paper_rmse_m"], row["paper_relative_rmse_pct"] = self.paper(name)
            rows.append(row)
        return pd.DataFrame(rows)

    def to_json(self) -> dict[str, Any]:
        """``{filter: {label, rmse_m, relative_rmse_pct, distance_m, duration_s,
        horizontal_rmse_m, max_horizontal_error_m, final_horizontal_error_m, mean_nees_position,
        mean_nees_velocity, mean_nees_attitude, nees_position_in_95, nees_velocity_in_95,
        nees_attitude_in_95, nees_uses_correlations, counts, mean_nis, paper_rmse_m,
        paper_relative_rmse_pct}}`` and, for a smoothed comparison, the forward solution's
        :meth:`forward_columns`; plain JSON types (NaN → None)."""
        from adaptnav.api.results import jsonable

        out: dict[str, Any] = {}
        for name, m in self.metrics.items():
            paper_rmse, paper_rel = self.paper(name)
            out[name] = {
                "label": FILTER_LABELS.get(name, name),
                "rmse_m": m.rmse_m,
                "relative_rmse_pct": m.relative_rmse_pct,
                "distance_m": m.distance_m,
                "duration_s": m.duration_s,
                "horizontal_rmse_m": m.horizontal_rmse_m,
                "max_horizontal_error_m": m.max_horizontal_error_m,
                "final_horizontal_error_m": m.final_horizontal_error_m,
                **{c: getattr(m, c) for c in NEES_COLUMNS},
                "nees_uses_correlations": m.nees_uses_correlations,
                "counts": m.counts,
                "mean_nis": m.mean_nis,
                "paper_rmse_m": paper_rmse,
                "paper_relative_rmse_pct": paper_rel,
                **self.forward_columns(name),
            }
        result: dict[str, Any] = jsonable(out, "comparison")
        return result

    def _save_runs(self, out: Path, mission_dir: str | Path | None) -> None:
        """Each run's folder (api.results.save) with the reference, and comparison.csv."""
        from dataclasses import replace

        from adaptnav.api import results as results_mod

        truth: pd.DataFrame | Path = self.truth
        for name, result in self.results.items():
            if mission_dir is not None:
                result = replace(result, meta={**result.meta, "mission_dir": str(mission_dir)})
            # Every run folder gets the same reference, its digest in the run's summary.json:
            # encoded once, then copied byte for byte.
            run_dir = results_mod.save(result, out / name, truth=truth)
            truth = run_dir / TRUTH_FILE
        self.table().to_csv(out / COMPARISON_CSV, index=False)

    def _save_runs_and_pngs(
        self,
        out: Path,
        mission_dir: str | Path | None,
        figures: Mapping[str, Figure] | PendingFigures | None,
    ) -> list[str]:
        """The run folders and the PNGs, at once; the PNGs' stems."""
        if figures is not None and not isinstance(figures, Mapping):
            # Drawn in another process: the run folders are written here meanwhile.
            self._save_runs(out, mission_dir)
            return figures.wait()
        # The run folders (Parquet, mostly outside the GIL) are written in a thread while the
        # PNGs are drawn here (matplotlib, Python): the two overlap on two cores. plots builds
        # Figures without pyplot: nothing to close, they go with their references.
        with ThreadPoolExecutor(1) as pool:
            runs = pool.submit(self._save_runs, out, mission_dir)
            for stem, fig in (figures or {}).items():
                write_png(fig, out / FIGURES_DIR / f"{stem}.png")
            runs.result()
        return list(figures or {})

    def save(
        self,
        out_dir: str | Path,
        *,
        mission_dir: str | Path | None = None,
        figures: Mapping[str, Figure] | PendingFigures | None = None,
        interactive: Mapping[str, SupportsToJson] | None = None,
    ) -> Path:
        """Write the comparison folder (see the module docstring); returns it.

        ``figures``: the figures to write into ``figures/`` by file stem
        (``adaptnav.viz.plots.comparison_figures(self)``; the analysis layer draws nothing), or
        PNGs being written there elsewhere (:class:`PendingFigures`), waited for once the run
        folders are written.
        ``interactive``: interactive versions of some of them, by the same stems
        (``adaptnav.viz.interactive.comparison_figures(self)``), written as
        ``figures/<stem>.plotly.json`` for the report to embed (docs/report.md).

        ``mission_dir``: the mission folder to record in comparison.json and in each run's
        meta instead of the mission's root, e.g. where a mission written into a temporary
        output folder will be once that is renamed into place (``adaptnav demo``).
        """
        from adaptnav.api.results import jsonable

        out = Path(out_dir)
        fig_dir = out / FIGURES_DIR
        fig_dir.mkdir(parents=True, exist_ok=True)
        interactive_files = {}
        for stem, spec in (interactive or {}).items():
            (fig_dir / f"{stem}{INTERACTIVE_SUFFIX}").write_text(spec.to_json(), encoding="utf-8")
            interactive_files[stem] = f"{FIGURES_DIR}/{stem}{INTERACTIVE_SUFFIX}"
        stems = self._save_runs_and_pngs(out, mission_dir, figures)
        figure_files = [f"{FIGURES_DIR}/{stem}.png" for stem in stems]

        root = Path(self.mission.root).resolve()
        sim = simulation_info(root)
        doc = {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "mission": self.mission_name,
            "mission_dir": str(root if mission_dir is None else mission_dir),
            "preset": None if sim is None else sim.get("preset"),
            "seed": None if sim is None else sim.get("seed"),
            "paper_table3": self.mission_name in PAPER_TABLE3,
            "filters": list(self.results),
            "labels": {n: FILTER_LABELS.get(n, n) for n in self.results},
            "initial": self.initial,
            "figures": figure_files,
            "interactive": interactive_files,
            "results": self.to_json(),
        }
        text = json.dumps(jsonable(doc, "comparison.json"), indent=2, allow_nan=False)
        (out / COMPARISON_JSON).write_text(text + "\n", encoding="utf-8")
        return out


def _initial_info(x0: Any, P0: Any, t0: float, info: Mapping[str, Any]) -> dict[str, Any]:
    """JSON-ready description of the shared start (position in degrees, attitude in degrees,
    σ's from P0's diagonal), with the alignment's own report merged in."""
    import numpy as np

    from adaptnav.api.results import jsonable
    from adaptnav.core import attitude
    from adaptnav.models.errorstate import ATT, POS, VEL

    x = np.asarray(x0, dtype=float)
    sd = np.sqrt(np.clip(np.diag(np.asarray(P0, dtype=float)), 0.0, None))
    start = {
        "t0_s": float(t0),
        "lat_deg": math.degrees(float(x[0])),
        "lon_deg": math.degrees(float(x[1])),
        "h_m": float(x[2]),
        "v_ned_m_s": x[3:6].tolist(),
        "rpy_deg": np.degrees(attitude.quat_to_euler(x[6:10])).tolist(),
        "sigma_position_m": sd[POS].tolist(),
        "sigma_velocity_m_s": sd[VEL].tolist(),
        "sigma_attitude_deg": np.degrees(sd[ATT]).tolist(),
    }
    merged: dict[str, Any] = jsonable({**dict(info), **start}, "initial")
    return merged


def compare(
    mission: Mission | str | Path,
    filters: Iterable[str] = DEFAULT_FILTERS,
    *,
    settings: FilterSettings | None = None,
    progress: Progress | None = None,
    smooth: bool = False,
    threads: int = 2,
) -> Comparison:
    """Run ``filters`` on ``mission`` from one shared alignment and score each run.

    Args:
        mission: a loaded :class:`~adaptnav.mission.Mission` or its folder.
        filters: names from :data:`FILTER_NAMES` (``meskf, maeskf, vb, oracle, floor``).
        settings: filter settings overriding the mission's ``[filter]`` section (each filter
            gets them with its own kind); ``floor`` ignores them.
        progress: called with the name of each step as it begins (the alignment, each
            filter, each RTS backward pass), e.g. to print it to stderr.
        smooth: RTS-smooth every filter's run (not the floor's): ``metrics`` score the smoothed
            solutions and ``forward`` the forward ones (docs/smoothing.md).
        threads: filters run and scored at once, in threads (the engine's compiled loop
            releases the GIL, so one filter's loop runs while another's Python builds and scores
            its tables; docs/performance.md). The results do not depend on it; 1: one by one.

    Raises:
        ValueError: an unknown or repeated filter name, a mission without a reference, or
            (from the runs) a bad mission, e.g. ``oracle`` on a mission lacking the
            simulator's truth columns.
    """
    from adaptnav import api
    from adaptnav.analysis import evaluate
    from adaptnav.api.runner import check_arguments
    from adaptnav.estimation.settings import FilterKind
    from adaptnav.mission import load_mission

    check_arguments(mission, smooth=smooth)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads: a whole number from 1, not {threads!r}")
    say = progress or (lambda _message: None)
    names = parse_filters(filters)
    m = mission if not isinstance(mission, str | Path) else load_mission(mission)
    name = m.config.mission.name
    if m.truth is None:
        raise ValueError(
            f"mission {name!r} ({m.root}) has no reference: add a [truth] table to compare filters"
        )
    truth = m.truth

    initial: dict[str, Any] = {}
    start: tuple[Any, Any, float] | None = None
    if any(n != "floor" for n in names):
        say("aligning once over the static window")
        x0, P0, t0, info = api.initial_state(m)
        start = (x0, P0, t0)
        initial = _initial_info(x0, P0, t0, info)

    # The floor first: it is cheap, and a mission it cannot run fails before the filters run.
    floor_run = _run_floor(m, None if start is None else start[2]) if "floor" in names else None

    def scored(n: str) -> tuple[Result, Metrics, Metrics | None]:
        if n == "floor" and floor_run is not None:
            result = floor_run
        else:
            kind = cast("FilterKind", n)
            result = api.run(
                m, kind, settings=settings, initial=start, smooth=smooth,
                progress=_backward_pass_said(say, FILTER_LABELS[n]) if threads == 1 else None,
            )  # fmt: skip
        return result, evaluate.evaluate(result, truth), evaluate.forward_metrics(result, truth)

    results: dict[str, Result] = {}
    metrics: dict[str, Metrics] = {}
    forward: dict[str, Metrics] = {}
    with ThreadPoolExecutor(max(1, threads)) as pool:
        jobs = [pool.submit(scored, n) for n in names] if threads > 1 else []
        for i, n in enumerate(names):
            # Said as the comparison waits for it, in order: with threads, "running" may
            # cover a filter that finished while the one before it ran.
            say(f"running {FILTER_LABELS[n]}")
            results[n], metrics[n], fwd = jobs[i].result() if jobs else scored(n)
            if fwd is not None:
                forward[n] = fwd
    return Comparison(name, m, results, metrics, initial, forward)


def _backward_pass_said(say: Progress, label: str) -> Callable[[str], None]:
    """The progress of one filter's run in a comparison: of its steps (``api.run``'s
    ``progress``) only the RTS backward pass is a step of its own; its start was said."""
    return lambda phase: say(f"RTS smoothing {label}") if phase == "smoothing" else None


def _run_floor(mission: Mission, t0: float | None) -> Result:
    """The DVL dead-reckoning baseline (``adaptnav.analysis.floor``).

    It dead-reckons from the first DVL reading, not from the alignment; its solution is cut
    to start at the filters' navigation start ``t0`` (when there is one) so that every row of
    the comparison is scored over the same stretch of the reference.
    """
    from dataclasses import replace

    from adaptnav.analysis import floor

    result = floor.run(mission)
    if t0 is None:
        return result
    sol = result.solution
    kept = sol[sol["t_s"].to_numpy() >= t0].reset_index(drop=True)
    if kept.empty:
        return result
    if len(kept) < 2:  # one point spans no time: nothing of the reference to score it on
        raise ValueError(
            f"floor: the DVL has {len(kept)} reading after the navigation start (t = {t0:.6g} s): "
            "too few to dead-reckon a track from; leave floor out of --filters"
        )
    return replace(result, solution=kept, meta={**result.meta, "scored_from_s": t0})
