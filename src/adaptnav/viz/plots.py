"""The comparison's figures, after the paper's Figs. 7-10, as matplotlib Figures.

* :func:`trajectory`: estimated tracks over the reference, east vs north from the start, with a
  zoom on the end (Figs. 7, 8);
* :func:`position_error`: 3-D and horizontal position error over time (Fig. 9); for smoothed
  runs the forward solutions' (left) beside the RTS-smoothed ones (right; docs/smoothing.md);
* :func:`noise_variance`: one aiding sensor's measurements and, on a log scale, the noise
  variance R̂ each adaptive filter used at each reading (``Result.noise``), beside the nominal R
  and, for a simulated mission, the true σ² (Fig. 10);
* :func:`ledger_counts`: readings used, rejected (guard or gate) and dropped per sensor and filter;
* :func:`nis`: a running mean of the normalised innovation squared per reading dimension
  (about 1 for a consistent filter; docs/metrics.md, 'NIS');
* :func:`calibration`: each calibration state's estimate ± 2σ over time per filter, beside its
  true value when the simulator recorded it (docs/calibration.md, docs/metrics.md, 'Calibration');
* :func:`comparison_figures`: all of them for a :class:`~adaptnav.analysis.compare.Comparison`.

Figures are built as :class:`matplotlib.figure.Figure` objects without pyplot, so nothing is
registered in pyplot's global figure manager and nothing needs closing; ``fig.savefig`` renders
them with the Agg canvas. The series they draw come from :mod:`adaptnav.viz.series`, shared
with the report's interactive figures (:mod:`adaptnav.viz.interactive`); each filter's colour is
:func:`adaptnav.analysis.compare.filter_colour`. Long series are reduced by a min/max envelope
(:func:`envelope`), which keeps spikes (outliers, R̂ jumps) that plain striding would drop, to
one bucket per pixel column of their panel (:func:`pixel_points`). Times are minutes since the
shared navigation start; angles are shown in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

from adaptnav.analysis.compare import FIGURE_DPI, filter_colour
from adaptnav.analysis.evaluate import Metrics, position_errors
from adaptnav.api.results import Result
from adaptnav.viz.series import (
    ADAPTIVE,
    DISPLAY,
    MAX_POINTS,
    NIS_WINDOW,
    actual_error2,
    aided_sensors,
    envelope,
    filter_label,
    minutes,
    nis_means,
    nominal_r,
    outliers,
    r_hat,
    start_time,
    stride,
    true_sigma_column,
)

if TYPE_CHECKING:
    from adaptnav.analysis.compare import Comparison
    from adaptnav.mission import Mission

Array = NDArray[np.float64]

__all__ = [
    "MAX_POINTS",
    "NIS_WINDOW",
    "aided_sensors",
    "calibration",
    "comparison_figures",
    "envelope",
    "figure_makers",
    "ledger_counts",
    "nis",
    "noise_variance",
    "pixel_points",
    "position_error",
    "trajectory",
]

_DASHES: dict[str, Any] = {
    "meskf": "--",
    "maeskf": "-.",
    "vb": "-",
    "robust": (0, (8, 2)),
    "oracle": ":",
    "floor": (0, (6, 1.5, 1, 1.5, 1, 1.5)),
}
"""Line style per filter; its colour is :func:`adaptnav.analysis.compare.filter_colour`, read
at each drawing. Colours and dashes both differ, so the lines stay apart in grey print too.
The reference is always black."""
_OTHER_DASH = (0, (3, 1))
_HATCHES = ("", "//", "..", "xx", "\\\\", "oo")


def pixel_points(ax: Axes) -> int:
    """The most points worth drawing per time series on ``ax``: two per pixel column of the
    widest it can be at :data:`adaptnav.analysis.compare.FIGURE_DPI` (its share of the figure's
    width, margins included), at most :data:`MAX_POINTS`. An envelope (:func:`envelope`) of
    that many points keeps each column's minimum and maximum, which is what a line through
    every reading paints there; more points only cost drawing time (docs/report.md, 'Long
    series'). Not for :func:`stride`: a strided series keeps every k-th reading, not the
    column's range, and a wavy one thinned to the pixels would look thinner."""
    spec = ax.get_subplotspec()
    figure = ax.get_figure(root=True)
    if spec is None or not isinstance(figure, Figure):
        return MAX_POINTS
    grid = spec.get_gridspec()
    ratios = np.asarray(grid.get_width_ratios() or np.ones(grid.ncols), dtype=float)
    share = float(ratios[list(spec.colspan)].sum() / ratios.sum())
    return min(MAX_POINTS, 2 * math.ceil(share * figure.get_figwidth() * FIGURE_DPI))


def _style(name: str) -> tuple[str, Any]:
    return filter_colour(name), _DASHES.get(name, _OTHER_DASH)


def _ne(lat: Array, lon: Array, h: Array, origin: tuple[float, float, float]) -> Array:
    from adaptnav.core.earth import geodetic_to_ned

    return np.asarray(geodetic_to_ned(lat, lon, h, *origin), dtype=float)


def trajectory(
    results: Mapping[str, Result], truth: pd.DataFrame, *, t0: float | None = None
) -> Figure:
    """Figs. 7/8: each run's track (east, north from the reference's position at the start)
    over the reference, and a zoom on the end of the run, where the errors have grown."""
    start = start_time(results, t0)
    ref_ne, tracks = _tracks(results, truth, start)
    extent = float(np.ptp(ref_ne[:, :2], axis=0).max()) if len(ref_ne) > 1 else 0.0
    scale, unit = (1000.0, "km") if extent > 5000.0 else (1.0, "m")

    fig = Figure(figsize=(12, 5.6), layout="constrained")
    ax_all, ax_end = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.4, 1.0]})
    s = stride(len(ref_ne))
    for ax in (ax_all, ax_end):
        ax.plot(
            ref_ne[s, 1] / scale, ref_ne[s, 0] / scale, color="black", lw=2.4, label="reference"
        )
        for name, track in tracks.items():
            colour, dash = _style(name)
            ax.plot(
                track[:, 1] / scale, track[:, 0] / scale,
                color=colour, ls=dash, lw=1.4, label=filter_label(name),
            )  # fmt: skip
        ax.set_xlabel(f"east of the start ({unit})")
        ax.set_ylabel(f"north of the start ({unit})")
        ax.grid(True, alpha=0.3)
        ax.set_aspect("equal", adjustable="datalim")
    ax_all.plot(0.0, 0.0, "ko", ms=6, label="start")
    ax_all.set_title("estimated tracks over the reference")
    ax_all.legend(loc="best", fontsize=8)
    _zoom_on_end(ax_end, ref_ne, tracks, extent, scale)
    return fig


def _tracks(
    results: Mapping[str, Result], truth: pd.DataFrame, start: float
) -> tuple[Array, dict[str, Array]]:
    """The reference's and each run's (strided) track from ``start`` on, as NED offsets (m)
    from the reference's position at the start (the whole reference if it ends before)."""
    tt = truth["t_s"].to_numpy(dtype=float)
    keep = tt >= start
    ref = truth[keep] if keep.any() else truth
    origin = (
        float(ref["lat_rad"].iloc[0]),
        float(ref["lon_rad"].iloc[0]),
        float(ref["h_m"].iloc[0]),
    )
    ref_ne = _ne(
        ref["lat_rad"].to_numpy(dtype=float),
        ref["lon_rad"].to_numpy(dtype=float),
        ref["h_m"].to_numpy(dtype=float),
        origin,
    )
    tracks: dict[str, Array] = {}
    for name, r in results.items():
        sol = r.solution
        sol = sol[sol["t_s"].to_numpy(dtype=float) >= start]
        s = stride(len(sol))
        tracks[name] = _ne(
            sol["lat_rad"].to_numpy(dtype=float)[s],
            sol["lon_rad"].to_numpy(dtype=float)[s],
            sol["h_m"].to_numpy(dtype=float)[s],
            origin,
        )
    return ref_ne, tracks


def _zoom_on_end(
    ax: Axes, ref_ne: Array, tracks: Mapping[str, Array], extent: float, scale: float
) -> None:
    """The zoom panel: a window centred on the reference's end, wide enough for every run's
    end point (markers), at least 1 % of the track's extent and ±10 m."""
    end_ref = ref_ne[-1, :2]
    ends = [track[-1, :2] for track in tracks.values() if len(track)]
    spread = max((float(np.max(np.abs(e - end_ref))) for e in ends), default=0.0)
    half = max(1.5 * spread, 0.01 * extent, 10.0)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim((end_ref[1] - half) / scale, (end_ref[1] + half) / scale)
    ax.set_ylim((end_ref[0] - half) / scale, (end_ref[0] + half) / scale)
    for name, track in tracks.items():
        if len(track):
            colour, _ = _style(name)
            ax.plot(track[-1, 1] / scale, track[-1, 0] / scale, "o", color=colour, ms=6)
    ax.plot(end_ref[1] / scale, end_ref[0] / scale, "ks", ms=7)
    ax.set_title(f"zoom on the end (±{half:.0f} m; markers: end points)")


def position_error(
    results: Mapping[str, Result], truth: pd.DataFrame, *, t0: float | None = None
) -> Figure:
    """Fig. 9: 3-D and horizontal position error (estimate minus reference) over time.

    When some run is smoothed (``Result.forward``, docs/smoothing.md) two columns of panels on
    the same axes: the forward solutions (left) and the RTS-smoothed ones (right), each
    horizontal error with the claimed 2σ (dotted, ``2 √(σ_N² + σ_E²)``); a run that was not
    smoothed (the floor) is drawn alike in both."""
    start = start_time(results, t0)
    if all(r.forward is None for r in results.values()):
        fig = Figure(figsize=(11, 6.5), layout="constrained")
        ax3, axh = fig.subplots(2, 1, sharex=True)
        _error_panels(ax3, axh, {n: r.solution for n, r in results.items()}, truth, start)
        ax3.set_title("position error against the reference")
        return fig
    fig = Figure(figsize=(14, 6.5), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True, sharey="row")
    forward = {n: r.solution if r.forward is None else r.forward for n, r in results.items()}
    _error_panels(axes[0, 0], axes[1, 0], forward, truth, start, sigma=True)
    smoothed = {n: r.solution for n, r in results.items()}
    _error_panels(axes[0, 1], axes[1, 1], smoothed, truth, start, outer=False, sigma=True)
    axes[0, 0].set_title("forward filter")
    axes[0, 1].set_title("RTS-smoothed")
    fig.suptitle("position error against the reference: forward and smoothed")
    return fig


def _error_panels(
    ax3: Axes,
    axh: Axes,
    solutions: Mapping[str, pd.DataFrame],
    truth: pd.DataFrame,
    start: float,
    *,
    outer: bool = True,
    sigma: bool = False,
) -> None:
    """Fig. 9's 3-D (``ax3``) and horizontal (``axh``) error panels of the ``solutions``, by
    filter name; the y labels and the legend only on the ``outer`` (left) column; ``sigma``:
    the claimed horizontal 2σ, dotted, in the horizontal panel."""
    for name, solution in solutions.items():
        err = position_errors(solution, truth)
        colour, dash = _style(name)
        t = err["t_s"].to_numpy(dtype=float)
        for ax, col in ((ax3, "error_m"), (axh, "horizontal_m")):
            te, ye = envelope(t, err[col].to_numpy(dtype=float), pixel_points(ax))
            ax.plot(minutes(te, start), ye, color=colour, ls=dash, lw=1.3, label=filter_label(name))
        if sigma:
            t_sol = solution["t_s"].to_numpy(dtype=float)
            sd_n, sd_e = (solution[c].to_numpy(dtype=float) for c in ("sd_dr_N", "sd_dr_E"))
            two_sd = 2.0 * np.hypot(sd_n, sd_e)
            ts, ys = envelope(t_sol, two_sd, pixel_points(axh))
            axh.plot(minutes(ts, start), ys, color=colour, ls=":", lw=0.9)
    axh.set_xlabel("time since navigation start (min)")
    for ax in (ax3, axh):
        ax.grid(True, alpha=0.3)
        ax.set_ylim(bottom=0.0)
    if outer:
        ax3.set_ylabel("3-D position error (m)")
        axh.set_ylabel("horizontal position error (m)")
        ax3.legend(loc="upper left", fontsize=8)


def noise_variance(
    results: Mapping[str, Result],
    mission: Mission,
    sensor: str,
    *,
    t0: float | None = None,
    filters: Sequence[str] = ADAPTIVE,
) -> Figure:
    """Fig. 10 for one aiding sensor: its measurements per component (top; the simulator's
    true value in black and its injected outliers as red crosses when the table has them) and
    the R̂ that each of ``filters`` used at each reading (bottom, log scale), with the nominal
    R (grey dashes) and, for a simulated mission, the true σ² (black)."""
    cfg = mission.config.sensors[sensor]
    scale, unit, comp_names = DISPLAY.get(cfg.kind, (1.0, "SI", ()))
    columns = cfg.columns
    dim = len(columns)
    start = start_time(results, t0)
    table = mission.tables.get(sensor)
    if table is not None:
        table = table[table["t_s"].to_numpy(dtype=float) > start]
    nominal = nominal_r(mission, sensor, dim)
    sigma_col = None if table is None else true_sigma_column(table)

    fig = Figure(figsize=(max(5.0 * dim, 7.0), 6.5), layout="constrained")
    axes = np.asarray(fig.subplots(2, dim, sharex=True, squeeze=False))
    for j, col in enumerate(columns):
        comp = comp_names[j] if j < len(comp_names) else col
        ax_z: Axes = axes[0, j]
        ax_r: Axes = axes[1, j]
        if table is not None and col in table.columns and cfg.kind != "gnss":
            _measurements(ax_z, table, col, scale, start)
        else:
            ax_z.text(0.5, 0.5, "measurements not shown", ha="center", transform=ax_z.transAxes)
        ax_z.set_title(f"{sensor}: {comp}")
        ax_z.set_ylabel(f"measurement ({unit})")
        ax_z.grid(True, alpha=0.3)

        _filter_variances(ax_r, results, filters, sensor, j, scale, start)
        if table is not None and col in table.columns and f"true_{col}" in table.columns:
            _actual_error(ax_r, table, col, scale, start)
        if sigma_col is not None and table is not None:
            te, se = envelope(
                table["t_s"].to_numpy(dtype=float),
                (table[sigma_col].to_numpy(dtype=float) * scale) ** 2,
                pixel_points(ax_r),
            )
            ax_r.plot(minutes(te, start), se, color="black", lw=1.0, zorder=4, label="true σ²")
        ax_r.axhline(
            nominal[j] * scale**2, color="0.45", ls=(0, (4, 2)), lw=1.2, zorder=4,
            label="nominal R",
        )  # fmt: skip
        ax_r.set_yscale("log")
        ax_r.set_ylabel(f"noise variance ({unit}²)")
        ax_r.set_xlabel("time since navigation start (min)")
        ax_r.grid(True, which="major", alpha=0.3)
    handles: list[Any] = []
    labels: list[str] = []
    for ax in (axes[0, 0], axes[1, 0]):
        h, lab = ax.get_legend_handles_labels()
        handles += h
        labels += lab
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 4), fontsize=8)
    what = sensor if sensor == cfg.kind else f"{sensor} ({cfg.kind})"
    fig.suptitle(f"{what}: measurements (top) and noise variance R̂ used by the filters (bottom)")
    return fig


def _measurements(ax: Axes, table: pd.DataFrame, col: str, scale: float, start: float) -> None:
    """Fig. 10's top panel for one component: the measured series, the simulator's true value
    and its injected outliers when the table has them."""
    t = table["t_s"].to_numpy(dtype=float)
    te, ze = envelope(t, table[col].to_numpy(dtype=float) * scale, pixel_points(ax))
    ax.plot(minutes(te, start), ze, color="tab:gray", lw=0.8, label="measured")
    if f"true_{col}" in table.columns:
        s = stride(len(table))
        truth = table[f"true_{col}"].to_numpy(dtype=float) * scale
        ax.plot(minutes(t[s], start), truth[s], color="black", lw=0.7, label="true")
    out = outliers(table, col)
    if out is not None and out.any():
        ax.plot(
            minutes(t[out], start), table[col].to_numpy(dtype=float)[out] * scale,
            "x", color="tab:red", ms=4, label="injected outlier",
        )  # fmt: skip


def _filter_variances(
    ax: Axes,
    results: Mapping[str, Result],
    filters: Sequence[str],
    sensor: str,
    component: int,
    scale: float,
    start: float,
) -> None:
    """Fig. 10's bottom panel: the R̂ each of ``filters`` used for ``component`` of
    ``sensor`` at each reading (``Result.noise``), the last of ``filters`` on top."""
    for name in filters:
        if name not in results:
            continue
        found = r_hat(results[name], sensor, component)
        if found is None:
            continue
        colour, dash = _style(name)
        te, re = envelope(found[0], found[1] * scale**2, pixel_points(ax))
        # Layers: the noisy matching estimate (MAESKF) translucent at the bottom, the
        # references over it, VB-MAESKF's smooth estimate on top.
        last = name == filters[-1]
        ax.plot(
            minutes(te, start), re, color=colour, ls=dash, lw=1.2, label=filter_label(name),
            zorder=5 if last else 2, alpha=1.0 if last else 0.55,
        )  # fmt: skip


def _actual_error(ax: Axes, table: pd.DataFrame, col: str, scale: float, start: float) -> None:
    """A running mean of the squared measurement error (measured minus the simulator's true
    value) over :data:`ERROR_WINDOW` readings or more, on Fig. 10's bottom panel."""
    window, t, err2 = actual_error2(table, col, scale)
    te, ee = envelope(t, err2, pixel_points(ax))
    ax.plot(
        minutes(te, start), ee, color="black", ls=":", lw=1.1, zorder=4,
        label=f"actual error², mean of {window}",
    )  # fmt: skip


def _navigation_counts(
    results: Mapping[str, Result], t0: float
) -> tuple[list[str], dict[str, dict[str, dict[str, int]]]]:
    """Aided sensors (used or rejected by some run) and, per filter and sensor, the readings
    used, rejected and dropped after the navigation start."""
    sensors: set[str] = set()
    counts: dict[str, dict[str, dict[str, int]]] = {}
    for name, r in results.items():
        ledger = r.ledger
        fate = ledger["fate"].astype(str)
        aided = set(ledger.loc[fate.isin(("used", "rejected")), "sensor"].astype(str).unique())
        sensors |= aided
        late = ledger["t"].to_numpy(dtype=float) > t0
        per: dict[str, dict[str, int]] = {}
        for sensor in aided:
            mine = (ledger["sensor"].astype(str) == sensor).to_numpy()
            per[sensor] = {
                "used": int(((fate == "used").to_numpy() & mine).sum()),
                "rejected": int(((fate == "rejected").to_numpy() & mine).sum()),
                "dropped": int(((fate == "dropped").to_numpy() & mine & late).sum()),
            }
        counts[name] = per
    return sorted(sensors), counts


def ledger_counts(
    results: Mapping[str, Result],
    metrics: Mapping[str, Metrics] | None = None,
    *,
    t0: float | None = None,
) -> Figure:
    """Readings per aided sensor and filter: used, rejected by the outlier gate (docs/filters.md,
    'Gate'), and dropped after the navigation start (invalid or missing readings; the alignment
    window and initialisation-only sensors are left out). ``metrics`` is accepted for symmetry and
    unused: its counts are totals over the whole mission, alignment window included."""
    del metrics
    start = start_time(results, t0)
    # A baseline without a ledger (the DVL dead reckoning) has no readings to count.
    results = {n: r for n, r in results.items() if not r.ledger.empty}
    sensors, counts = _navigation_counts(results, start)
    names = list(results)
    fig = Figure(figsize=(12, 4.4), layout="constrained")
    axes = fig.subplots(1, 3)
    width = 0.8 / max(len(names), 1)
    x = np.arange(len(sensors), dtype=float)
    for ax, fate, title in zip(
        axes,
        ("used", "rejected", "dropped"),
        ("used", "rejected (guard or gate)", "dropped while navigating"),
        strict=True,
    ):
        top = 0
        for i, name in enumerate(names):
            colour, _ = _style(name)
            values = [counts[name].get(s, {}).get(fate, 0) for s in sensors]
            bars = ax.bar(
                x + (i - (len(names) - 1) / 2) * width, values, width,
                color=colour, hatch=_HATCHES[i % len(_HATCHES)], edgecolor="black", lw=0.5,
                label=filter_label(name),
            )  # fmt: skip
            ax.bar_label(bars, fontsize=7, rotation=90, padding=2)
            top = max(top, *values, 0)
        ax.set_xticks(x, sensors)
        ax.set_title(title)
        ax.set_ylabel("readings")
        # Headroom for the rotated value labels above the tallest bar.
        ax.set_ylim(0.0, 1.45 * top + 1.0)
        ax.grid(True, axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=8)
    fig.suptitle("ledger: the fate of each aiding reading after the navigation start")
    return fig


def nis(results: Mapping[str, Result], *, t0: float | None = None) -> Figure:
    """Running mean (over :data:`NIS_WINDOW` used readings) of each reading's NIS divided by
    its dimension, per aided sensor and filter; 1 is what a consistent filter gives
    (docs/metrics.md, 'NIS')."""
    start = start_time(results, t0)
    per_sensor = nis_means(results)
    sensors = sorted(per_sensor)
    fig = Figure(figsize=(11, 2.6 * max(len(sensors), 1) + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(max(len(sensors), 1), 1, sharex=True, squeeze=False)[:, 0])
    for ax, sensor in zip(axes, sensors, strict=False):
        for name, (t, mean) in per_sensor[sensor].items():
            colour, dash = _style(name)
            te, me = envelope(t, mean, pixel_points(ax))
            ax.plot(minutes(te, start), me, color=colour, ls=dash, lw=1.2, label=filter_label(name))
        ax.axhline(1.0, color="black", lw=1.0, label="consistent (1)")
        ax.set_yscale("log")
        ax.set_ylabel(f"{sensor}: NIS / dim")
        ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=8)
    axes[-1].set_xlabel("time since navigation start (min)")
    fig.suptitle(f"normalised innovation squared per component, running mean of {NIS_WINDOW}")
    return fig


def calibration(
    results: Mapping[str, Result],
    units: Mapping[str, tuple[float, str]],
    truth: Mapping[str, float] | None = None,
    *,
    t0: float | None = None,
) -> Figure:
    """One panel per calibration state (``units``: state → (factor from SI, unit), e.g.
    :func:`adaptnav.analysis.calibration.units`): each filter's estimate (its line style) and
    ±2σ (dotted) over time, and the true value in black where ``truth`` has it (report units,
    :func:`adaptnav.analysis.calibration.true_values`). A smoothed run is drawn as its forward
    solution, the filter learning the state as it ran (docs/smoothing.md)."""
    start = start_time(results, t0)
    states = list(units)
    ncols = min(len(states), 3)
    nrows = math.ceil(len(states) / ncols)
    fig = Figure(figsize=(4.6 * ncols, 2.7 * nrows + 0.8), layout="constrained")
    axes = np.asarray(fig.subplots(nrows, ncols, sharex=True, squeeze=False)).reshape(-1)
    for ax, state in zip(axes, states, strict=False):
        factor, unit = units[state]
        for name, r in results.items():
            sol = r.solution if r.forward is None else r.forward
            if state not in sol.columns:
                continue
            colour, dash = _style(name)
            s = stride(len(sol))
            t = minutes(sol["t_s"].to_numpy(dtype=float)[s], start)
            est = sol[state].to_numpy(dtype=float)[s] * factor
            two_sd = 2.0 * sol[f"sd_{state}"].to_numpy(dtype=float)[s] * factor
            ax.plot(t, est, color=colour, ls=dash, lw=1.3, label=filter_label(name))
            for band in (est - two_sd, est + two_sd):
                ax.plot(t, band, color=colour, ls=":", lw=0.9)
        if truth is not None and state in truth:
            ax.axhline(truth[state], color="black", lw=1.4, label="true value")
        ax.set_title(state)
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
    for ax in axes[len(states) :]:
        ax.set_visible(False)
    for ax in axes[max(len(states) - ncols, 0) : len(states)]:
        # the bottom panel of each column, above a hidden one in a short last row
        ax.xaxis.set_tick_params(labelbottom=True)
        ax.set_xlabel("time since navigation start (min)")
    legend: dict[str, Any] = {}  # one entry per label, whichever panel drew it first
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    fig.legend(
        list(legend.values()), list(legend), loc="outside lower center", ncols=len(legend),
        fontsize=8,
    )  # fmt: skip
    fig.suptitle("calibration states: estimate and ±2σ (dotted) over time")
    return fig


def lone_points_marked(figure: Figure) -> Figure:
    """``figure`` with a marker on every line of one point, which matplotlib does not draw
    (a sensor with one reading after the navigation start left its panels blank)."""
    for ax in figure.axes:
        for line in ax.get_lines():
            if np.size(line.get_xdata()) == 1 and line.get_marker() in ("None", "", None):
                line.set_marker("o")
                line.set_markersize(4.0)
    return figure


def _marked(make: Callable[[], Figure]) -> Figure:
    return lone_points_marked(make())


def comparison_figures(cmp: Comparison) -> dict[str, Figure]:
    """Every figure of a comparison, keyed by file stem: ``trajectory``, ``position_error``,
    ``noise_<sensor>`` per aided sensor, ``ledger_counts``, ``nis`` and, when some run
    estimates calibration states, ``calibration`` (true values from the mission's
    ``simulation.json`` when it has them)."""
    return {stem: make() for stem, make in figure_makers(cmp).items()}


def figure_makers(cmp: Comparison) -> dict[str, Callable[[], Figure]]:
    """What :func:`comparison_figures` draws, each figure not yet drawn: a function per file
    stem, so that a subset can be drawn (:mod:`adaptnav.viz.pngs` splits them between
    processes)."""
    from adaptnav.analysis import calibration as cal

    t0 = cmp.t0
    makers: dict[str, Callable[[], Figure]] = {
        "trajectory": partial(trajectory, cmp.results, cmp.truth, t0=t0),
        "position_error": partial(position_error, cmp.results, cmp.truth, t0=t0),
    }
    for sensor in aided_sensors(cmp.mission):
        makers[f"noise_{sensor}"] = partial(noise_variance, cmp.results, cmp.mission, sensor, t0=t0)
    # A ledger of readings all dropped before navigation (sensors off, alignment) has no bar.
    if any(r.ledger["fate"].isin(("used", "rejected")).any() for r in cmp.results.values()):
        makers["ledger_counts"] = partial(ledger_counts, cmp.results, cmp.metrics, t0=t0)
    if any((r.ledger["fate"] == "used").any() for r in cmp.results.values()):
        makers["nis"] = partial(nis, cmp.results, t0=t0)
    if any(r.meta.get("calibration") for r in cmp.results.values()):
        units = cal.units(cmp.mission.config)
        truth = cal.comparison_truth(cmp.mission.config, cmp.mission.root, cmp.results)
        makers["calibration"] = partial(calibration, cmp.results, units, truth, t0=t0)
    return {stem: partial(_marked, make) for stem, make in makers.items()}
