"""Static figures draw at most two points per pixel column of each panel (docs/report.md)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from adaptnav.analysis.compare import FIGURE_DPI
from adaptnav.viz.plots import pixel_points
from adaptnav.viz.series import MAX_POINTS, envelope


def test_pixel_points_is_twice_the_panel_width_in_pixels() -> None:
    fig = Figure(figsize=(15.0, 6.5))
    axes = fig.subplots(2, 3)
    # a third of 15 inches at 110 dpi: 550 columns at most, margins included
    assert FIGURE_DPI == 110
    assert {pixel_points(ax) for ax in axes.ravel()} == {1100}
    wide = Figure(figsize=(60.0, 4.0)).subplots()
    assert pixel_points(wide) == MAX_POINTS
    ratios = Figure(figsize=(10.0, 4.0)).subplots(1, 2, gridspec_kw={"width_ratios": [3, 1]})
    assert [pixel_points(ax) for ax in ratios] == [1650, 550]


def test_a_pixel_budget_envelope_keeps_every_spike() -> None:
    rng = np.random.default_rng(11)
    t = np.arange(50_000, dtype=float)
    y = rng.normal(size=t.size)
    spikes = rng.choice(t.size, 20, replace=False)
    y[spikes] = 100.0 + rng.uniform(size=20)
    te, ye = envelope(t, y, 1100)
    assert te.size <= 1100
    assert np.isin(t[spikes], te).all()
    assert ye.max() == y.max() and ye.min() == y.min()
