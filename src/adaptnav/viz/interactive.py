"""The comparison's time series as interactive figures (Plotly), which the HTML report embeds
so that a reader can zoom and pan them (docs/report.md):

* :func:`position_error`: 3-D and horizontal position error over time with each filter's
  claimed horizontal 2σ (dotted, ``2 √(σ_N² + σ_E²)``), as the paper's Fig. 9; for smoothed
  runs the forward solutions (left) beside the RTS-smoothed ones (right; docs/smoothing.md);
* :func:`noise_variance`: one aiding sensor's measurements per component (top) and the noise
  variance R̂ each adaptive filter used (bottom, log scale), as the paper's Fig. 10;
* :func:`nis`: running mean of the NIS per reading dimension, one panel per aided sensor
  (docs/metrics.md, 'NIS');
* :func:`calibration`: each calibration state's estimate ± 2σ over time (docs/calibration.md);
* :func:`comparison_figures`: those of a :class:`~adaptnav.analysis.compare.Comparison`,
  keyed by the same file stems as :func:`adaptnav.viz.plots.comparison_figures`.

They draw the same series as the static figures (:mod:`adaptnav.viz.series`) in the same
colours (:func:`adaptnav.analysis.compare.filter_colour`). All time axes of a figure are
linked: zooming one panel zooms the others. Long series keep their spikes, by the static
figures' rule: a series of more than :data:`~adaptnav.viz.series.MAX_POINTS` (4000) readings is
cut into ``MAX_POINTS // 2`` buckets of ``k`` consecutive readings and each bucket is drawn by
its minimum and its maximum in time order (:func:`adaptnav.viz.series.envelope`); a measured
series names its ``k`` in the legend. The numbers are stored as 32-bit floats, which halves the
page and loses nothing the eye can see (about 1 ms in 3 h).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
import plotly.graph_objects as go
from plotly.subplots import make_subplots

from adaptnav.analysis.compare import filter_colour
from adaptnav.analysis.evaluate import position_errors
from adaptnav.api.results import Result
from adaptnav.viz.series import (
    ADAPTIVE,
    DISPLAY,
    NIS_WINDOW,
    Array,
    actual_error2,
    aided_sensors,
    bucket_size,
    envelope,
    filter_label,
    minutes,
    nis_means,
    nominal_r,
    outliers,
    r_hat,
    start_time,
    true_sigma_column,
)

if TYPE_CHECKING:
    from adaptnav.analysis.compare import Comparison
    from adaptnav.mission import Mission

__all__ = [
    "calibration",
    "comparison_figures",
    "nis",
    "noise_variance",
    "position_error",
]

DASHES: dict[str, str] = {
    "meskf": "dash",
    "maeskf": "dashdot",
    "vb": "solid",
    "robust": "longdash",
    "oracle": "dot",
    "floor": "longdashdot",
}
"""Plotly's line dash per filter, close to the static figures' (``adaptnav.viz.plots``)."""
TIME_AXIS = "time since navigation start (min)"
_ROW_HEIGHT = 270


class _Legend:
    """Adds traces to a figure, each legend entry once: a filter's traces share one legend
    group, so a click on its name hides or shows all of them."""

    def __init__(self, fig: Any, start: float) -> None:
        self.fig = fig
        self.start = start
        self.shown: set[str] = set()

    def line(
        self, t: Array, y: Array, where: tuple[int, int], group: str, name: str, **style: Any
    ) -> None:
        """Add the series ``y(t)`` (t in s) to the panel ``where`` = (row, col); a series of
        one point gets a marker, as a line through one point is not drawn."""
        mode = style.pop("mode", "lines")
        self.fig.add_trace(
            go.Scatter(
                x=minutes(t, self.start).astype(np.float32),
                y=np.asarray(y, dtype=np.float32),
                mode=mode + "+markers" if mode == "lines" and np.size(t) == 1 else mode,
                name=name,
                legendgroup=group,
                showlegend=group not in self.shown,
                **style,
            ),
            row=where[0],
            col=where[1],
        )
        self.shown.add(group)

    def filter_line(
        self, t: Array, y: Array, where: tuple[int, int], filt: str, **style: Any
    ) -> None:
        """A filter's series, enveloped, in its colour and dash."""
        te, ye = envelope(t, y)
        line = {"color": filter_colour(filt), "dash": DASHES.get(filt, "solid"), "width": 1.4}
        line.update(style.pop("line", {}))
        self.line(te, ye, where, filt, filter_label(filt), line=line, **style)


def _layout(fig: Any, rows: int, title: str) -> Any:
    fig.update_layout(
        template="plotly_white",
        title={"text": title, "x": 0.01},
        height=_ROW_HEIGHT * rows + 130,
        margin={"l": 70, "r": 20, "t": 80, "b": 60},
        legend={"orientation": "h", "yanchor": "top", "y": -0.06 - 0.2 / rows},
        hovermode="closest",
    )
    fig.update_xaxes(showgrid=True)
    return fig


def position_error(
    results: Mapping[str, Result], truth: pd.DataFrame, *, t0: float | None = None
) -> Any:
    """Fig. 9 (3-D error on top, horizontal error and its claimed 2σ below), zoomable; with
    some run smoothed (``Result.forward``) the forward solutions left of the smoothed ones, on
    the same axes (a run that was not smoothed, the floor, alike in both)."""
    start = start_time(results, t0)
    smoothed = any(r.forward is not None for r in results.values())
    columns: list[tuple[str, dict[str, pd.DataFrame]]] = [
        ("", {n: r.solution for n, r in results.items()})
    ]
    if smoothed:
        forward = {n: r.solution if r.forward is None else r.forward for n, r in results.items()}
        columns = [("forward filter", forward), ("RTS-smoothed", columns[0][1])]
    fig = make_subplots(
        rows=2, cols=len(columns), shared_xaxes="all", shared_yaxes="rows",
        subplot_titles=[c[0] for c in columns] if smoothed else None, vertical_spacing=0.07,
        horizontal_spacing=0.04,
    )  # fmt: skip
    legend = _Legend(fig, start)
    for c, (_, solutions) in enumerate(columns, start=1):
        for name, solution in solutions.items():
            err = position_errors(solution, truth)
            t = err["t_s"].to_numpy(dtype=float)
            legend.filter_line(t, err["error_m"].to_numpy(dtype=float), (1, c), name)
            legend.filter_line(t, err["horizontal_m"].to_numpy(dtype=float), (2, c), name)
            sd_n, sd_e = (solution[k].to_numpy(dtype=float) for k in ("sd_dr_N", "sd_dr_E"))
            legend.filter_line(
                solution["t_s"].to_numpy(dtype=float), 2.0 * np.hypot(sd_n, sd_e), (2, c), name,
                line={"dash": "dot", "width": 1.0}, hovertemplate="claimed 2σ: %{y:.1f} m",
            )  # fmt: skip
    fig.update_yaxes(title_text="3-D position error (m)", rangemode="tozero", row=1, col=1)
    fig.update_yaxes(title_text="horizontal error, 2σ dotted (m)", rangemode="tozero", row=2, col=1)
    fig.update_xaxes(title_text=TIME_AXIS, row=2)
    what = "forward and smoothed" if smoothed else "estimate minus reference"
    return _layout(fig, 2, f"position error against the reference: {what}")


def noise_variance(
    results: Mapping[str, Result],
    mission: Mission,
    sensor: str,
    *,
    t0: float | None = None,
    filters: Sequence[str] = ADAPTIVE,
) -> Any:
    """Fig. 10 for one aiding sensor, zoomable: its measurements per component (top; the
    simulator's true value in black and its injected outliers as red crosses when the table
    has them) and the R̂ each of ``filters`` used at each reading (bottom, log scale) with the
    nominal R (grey dashes), the true σ² and the actual squared error when known (black)."""
    cfg = mission.config.sensors[sensor]
    scale, unit, names = DISPLAY.get(cfg.kind, (1.0, "SI", ()))
    start = start_time(results, t0)
    table = mission.tables.get(sensor)
    if table is not None:
        table = table[table["t_s"].to_numpy(dtype=float) > start]
    nominal = nominal_r(mission, sensor, len(cfg.columns))
    titles = [f"{sensor}: {names[j] if j < len(names) else c}" for j, c in enumerate(cfg.columns)]
    fig = make_subplots(
        rows=2, cols=len(cfg.columns), shared_xaxes="all", subplot_titles=titles,
        vertical_spacing=0.08, horizontal_spacing=0.06,
    )  # fmt: skip
    legend = _Legend(fig, start)
    for j, col in enumerate(cfg.columns, start=1):
        if table is not None and col in table.columns and cfg.kind != "gnss":
            _measurements(legend, table, col, scale, j)
        for name in filters:
            found = r_hat(results[name], sensor, j - 1) if name in results else None
            if found is not None:
                legend.filter_line(found[0], found[1] * scale**2, (2, j), name)
        if table is not None:
            _noise_references(legend, table, col, scale, j)
        fig.add_hline(
            y=nominal[j - 1] * scale**2, line={"color": "#737373", "dash": "dash", "width": 1.2},
            row=2, col=j,
        )  # fmt: skip
    fig.update_yaxes(title_text=f"measurement ({unit})", row=1, col=1)
    fig.update_yaxes(type="log", exponentformat="power", row=2)
    fig.update_yaxes(title_text=f"noise variance ({unit})², nominal R dashed", row=2, col=1)
    fig.update_xaxes(title_text=TIME_AXIS, row=2)
    what = sensor if sensor == cfg.kind else f"{sensor} ({cfg.kind})"
    title = f"{what}: measurements (top) and noise variance R̂ used by the filters (bottom)"
    return _layout(fig, 2, title)


def _measurements(legend: _Legend, table: pd.DataFrame, col: str, scale: float, j: int) -> None:
    """Fig. 10's top panel for component ``j``: the measured series and the simulator's true
    value, both enveloped (the legend says how many readings, and about how many seconds, each
    min/max pair stands for: a zoom shows each bucket's range, not single readings), and the
    injected outliers, every one of them."""
    t = table["t_s"].to_numpy(dtype=float)
    z = table[col].to_numpy(dtype=float) * scale
    k = bucket_size(len(t))
    name = "measured"
    if k > 1:
        seconds = k * float(np.median(np.diff(t)))
        name += f" (min and max of every {k} readings, ≈{seconds:.2g} s)"
    te, ze = envelope(t, z)
    legend.line(te, ze, (1, j), "measured", name, line={"color": "#8c8c8c", "width": 0.8})
    if f"true_{col}" in table.columns:
        te, ye = envelope(t, table[f"true_{col}"].to_numpy(dtype=float) * scale)
        legend.line(te, ye, (1, j), "true", "true", line={"color": "black", "width": 0.9})
    out = outliers(table, col)
    if out is not None and out.any():
        legend.line(
            t[out], z[out], (1, j), "outlier", "injected outlier", mode="markers",
            marker={"symbol": "x", "color": "#d62728", "size": 6},
        )  # fmt: skip


def _noise_references(legend: _Legend, table: pd.DataFrame, col: str, scale: float, j: int) -> None:
    """Fig. 10's bottom-panel references of a simulated mission: the true σ² the simulator
    applied and the actual squared error (running mean), when the table has them."""
    sigma_col = true_sigma_column(table)
    if sigma_col is not None:
        t = table["t_s"].to_numpy(dtype=float)
        te, se = envelope(t, (table[sigma_col].to_numpy(dtype=float) * scale) ** 2)
        legend.line(te, se, (2, j), "true σ²", "true σ²", line={"color": "black", "width": 1.0})
    if col in table.columns and f"true_{col}" in table.columns:
        window, t, err2 = actual_error2(table, col, scale)
        te, ee = envelope(t, err2)
        name = f"actual error², mean of {window}"
        legend.line(te, ee, (2, j), "actual", name, line={"color": "black", "dash": "dot"})


def nis(results: Mapping[str, Result], *, t0: float | None = None) -> Any:
    """Running mean (over :data:`adaptnav.viz.series.NIS_WINDOW` used readings) of each
    reading's NIS per dimension, one panel per aided sensor (log scale); 1, the black line, is
    what a consistent filter gives (docs/metrics.md, 'NIS')."""
    start = start_time(results, t0)
    per_sensor = nis_means(results)
    sensors = sorted(per_sensor) or ["(none)"]
    fig = make_subplots(rows=len(sensors), cols=1, shared_xaxes="all", vertical_spacing=0.05)
    legend = _Legend(fig, start)
    for row, sensor in enumerate(sensors, start=1):
        for name, (t, mean) in per_sensor.get(sensor, {}).items():
            legend.filter_line(t, mean, (row, 1), name)
        fig.add_hline(y=1.0, line={"color": "black", "width": 1.0}, row=row, col=1)
        fig.update_yaxes(
            type="log", exponentformat="power", title_text=f"{sensor}: NIS / dim", row=row, col=1
        )
    fig.update_xaxes(title_text=TIME_AXIS, row=len(sensors))
    title = f"normalised innovation squared per component, running mean of {NIS_WINDOW}"
    return _layout(fig, len(sensors), title)


def calibration(
    results: Mapping[str, Result],
    units: Mapping[str, tuple[float, str]],
    truth: Mapping[str, float] | None = None,
    *,
    t0: float | None = None,
) -> Any:
    """One panel per calibration state (``units``: state → (factor from SI, unit)): each
    filter's estimate and ±2σ (dotted) over time, the true value in black where ``truth`` has
    it; a smoothed run as its forward solution, the filter learning as it ran
    (docs/calibration.md, docs/smoothing.md)."""
    start = start_time(results, t0)
    states = list(units)
    ncols = min(len(states), 3)
    nrows = math.ceil(len(states) / ncols)
    fig = make_subplots(
        rows=nrows, cols=ncols, shared_xaxes="all", subplot_titles=states,
        vertical_spacing=0.12 / nrows + 0.04, horizontal_spacing=0.07,
    )  # fmt: skip
    legend = _Legend(fig, start)
    for k, state in enumerate(states):
        where = (k // ncols + 1, k % ncols + 1)
        factor, unit = units[state]
        for name, r in results.items():
            sol = r.solution if r.forward is None else r.forward
            if state not in sol.columns:
                continue
            t = sol["t_s"].to_numpy(dtype=float)
            est = sol[state].to_numpy(dtype=float) * factor
            two_sd = 2.0 * sol[f"sd_{state}"].to_numpy(dtype=float) * factor
            legend.filter_line(t, est, where, name)
            for band in (est - two_sd, est + two_sd):
                legend.filter_line(t, band, where, name, line={"dash": "dot", "width": 0.9})
        if truth is not None and state in truth:
            fig.add_hline(y=truth[state], line={"color": "black", "width": 1.4}, row=where[0],
                          col=where[1])  # fmt: skip
        fig.update_yaxes(title_text=unit, row=where[0], col=where[1])
    fig.update_xaxes(title_text=TIME_AXIS, row=nrows)
    title = "calibration states: estimate and ±2σ (dotted) over time; true value black"
    return _layout(fig, nrows, title)


def comparison_figures(cmp: Comparison) -> dict[str, Any]:
    """The interactive figures of a comparison, keyed by file stem: ``position_error``,
    ``noise_<sensor>`` per aided sensor, ``nis`` when some run used a reading and
    ``calibration`` when some run estimated calibration states (true values from the
    mission's ``simulation.json`` when it has them). The trajectory and the ledger counts stay
    static figures (:mod:`adaptnav.viz.plots`)."""
    from adaptnav.analysis import calibration as cal

    t0 = cmp.t0
    figs = {"position_error": position_error(cmp.results, cmp.truth, t0=t0)}
    for sensor in aided_sensors(cmp.mission):
        figs[f"noise_{sensor}"] = noise_variance(cmp.results, cmp.mission, sensor, t0=t0)
    if any((r.ledger["fate"] == "used").any() for r in cmp.results.values()):
        figs["nis"] = nis(cmp.results, t0=t0)
    if any(r.meta.get("calibration") for r in cmp.results.values()):
        units = cal.units(cmp.mission.config)
        truth = cal.comparison_truth(cmp.mission.config, cmp.mission.root, cmp.results)
        figs["calibration"] = calibration(cmp.results, units, truth, t0=t0)
    return figs
