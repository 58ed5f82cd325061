"""The sweeps' figures (matplotlib, Agg): relative RMSE against the gate coefficient q (the
paper's Fig. 4), against the gyro-bias process-noise scale (Fig. 6) and over seeds (Table 3 as
a distribution); docs/metrics.md for the relative RMSE.

They draw a sweep's table (:func:`adaptnav.experiments.stats.runs_table`) through its
statistics (:func:`adaptnav.experiments.stats.curve`), so they live beside them in
``experiments`` rather than in ``viz``, which may not import this layer.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from adaptnav.analysis.compare import filter_colour
from adaptnav.experiments.stats import curve, finished

__all__ = ["LABELS", "plot_monte_carlo", "plot_process_noise", "plot_q_sweep"]

LABELS = {
    "meskf": "MESKF", "maeskf": "MAESKF", "vb": "VB-MAESKF", "robust": "robust", "oracle": "oracle",
}  # fmt: skip
"""Display names of the filters in the figures (short: the sweep legends are narrow). Their
colours are the report's (:func:`adaptnav.analysis.compare.filter_colour`)."""


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
    ok = finished(table)
    for ax, preset in zip(axes, presets, strict=False):
        for filt, g in c[c["preset"] == preset].groupby("filter", sort=False):
            color = filter_colour(str(filt))
            x = g[parameter].to_numpy(dtype=float)
            ax.plot(x, g["mean"], "o-", ms=3, color=color, label=f"{LABELS.get(str(filt), filt)}")
            ax.fill_between(x, g["min"], g["max"], color=color, alpha=0.15, lw=0)
        if parameter == "q":  # references at their defaults (VB ungated, oracle)
            refs = ok[(ok["preset"] == preset) & ~np.isfinite(ok["q"].astype(float))]
            for filt, g in refs.groupby("filter", sort=False):
                mean = float(g["relative_rmse_pct"].mean())
                style = "--" if filt == "vb" else ":"
                name = f"{LABELS.get(str(filt), filt)}{', no gate' if filt == 'vb' else ''}"
                ax.axhline(mean, ls=style, color=filter_colour(str(filt)), label=name)
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
    ok = finished(table)
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
            ax.plot(x, v, "o", ms=3, alpha=0.6, color=filter_colour(f))
        ax.set_title(f"{preset} ({g['seed'].nunique()} seeds)")
        ax.set_ylabel("relative RMSE (%)")
        ax.grid(True, axis="y", alpha=0.3)
    return _save(fig, path, dpi)
