"""compare(): several filters from one alignment, tabulated and saved; the `compare` and `demo`
commands, also RTS-smoothed (`compare --smooth`, docs/smoothing.md). One short simulated mission
(the ``demo`` preset, ≈ 3 s) serves the whole module."""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.analysis.compare import (
    COMPARISON_CSV,
    COMPARISON_JSON,
    FILTER_LABELS,
    NEES_BAND_TEXT,
    NEES_COLUMNS,
    PAPER_TABLE3,
    Comparison,
    compare,
    parse_filters,
)
from adaptnav.api import results
from adaptnav.cli import app
from adaptnav.cli.compare import comparison_table
from adaptnav.sim.scenarios import simulate
from adaptnav.viz import plots

runner = CliRunner()

FILTERS: tuple[str, ...] = ("meskf", "maeskf", "vb", "robust", "oracle")
SEED = 3


@pytest.fixture(scope="module")
def mission_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate("demo", SEED, tmp_path_factory.mktemp("compare") / "mission")


@pytest.fixture(scope="module")
def saved(mission_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Comparison, Path]:
    cmp = compare(mission_dir, FILTERS)
    out = tmp_path_factory.mktemp("compare-out")
    cmp.save(out, figures=plots.comparison_figures(cmp))
    return cmp, out


def test_table_has_one_row_per_filter_equal_to_evaluate_on_the_saved_runs(
    saved: tuple[Comparison, Path],
) -> None:
    cmp, out = saved
    table = cmp.table()
    assert list(table["filter"]) == list(FILTERS)
    for _, row in table.iterrows():
        run_dir = out / str(row["filter"])
        m = evaluate.evaluate(results.load(run_dir), pd.read_parquet(run_dir / "truth.parquet"))
        for col, value in (
            ("rmse_m", m.rmse_m),
            ("relative_rmse_pct", m.relative_rmse_pct),
            ("horizontal_rmse_m", m.horizontal_rmse_m),
            ("max_horizontal_error_m", m.max_horizontal_error_m),
            ("distance_m", m.distance_m),
            ("duration_min", m.duration_s / 60.0),
            *((c, getattr(m, c)) for c in NEES_COLUMNS),
        ):
            assert row[col] == pytest.approx(value, rel=1e-12), (row["filter"], col)
        for sensor, counts in m.counts.items():
            for fate, n in counts.items():
                assert row[f"{sensor}_{fate}"] == n, (row["filter"], sensor, fate)
    # The demo preset is not one of the paper's trajectories: no Table-3 figures beside it.
    assert table["paper_rmse_m"].isna().all()
    saved_csv = pd.read_csv(out / COMPARISON_CSV)
    assert list(saved_csv["filter"]) == list(FILTERS)
    np.testing.assert_allclose(saved_csv["rmse_m"], table["rmse_m"], rtol=1e-12)
    # not smoothed: no forward solution anywhere
    assert not cmp.forward and not [c for c in saved_csv.columns if "forward" in c]
    assert not [k for entry in cmp.to_json().values() for k in entry if "forward" in k]
    assert not list(out.glob("*/forward.parquet"))


def test_every_filter_starts_from_the_one_alignment(saved: tuple[Comparison, Path]) -> None:
    cmp, _ = saved
    t0 = cmp.initial["t0_s"]
    assert cmp.initial["initial"] == "alignment" and math.isfinite(t0)
    firsts = []
    for name in FILTERS:
        r = cmp.results[name]
        assert r.meta["initial"] == "given", name
        sol = r.solution
        assert sol["t_s"].iloc[0] == pytest.approx(t0, abs=1e-9), name
        firsts.append(sol.iloc[0][["lat_rad", "lon_rad", "h_m", "yaw_rad", "sd_dr_N", "sd_phi_D"]])
    for other in firsts[1:]:
        np.testing.assert_array_equal(other.to_numpy(), firsts[0].to_numpy())


def test_the_alignment_runs_once(mission_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls = []
    real = api.initial_state

    def counting(mission: Any) -> Any:
        calls.append(mission)
        return real(mission)

    monkeypatch.setattr(api, "initial_state", counting)
    cmp = compare(mission_dir, ("meskf", "vb"))
    assert len(calls) == 1
    assert set(cmp.results) == {"meskf", "vb"}


def test_threads_do_not_change_the_comparison(
    mission_dir: Path, saved: tuple[Comparison, Path]
) -> None:
    """compare() runs the filters two at a time by default; one at a time gives the same
    solutions, ledgers and table (each filter's run is its own: no state is shared)."""
    cmp, _ = saved
    alone = compare(mission_dir, FILTERS, threads=1)
    pd.testing.assert_frame_equal(alone.table(), cmp.table())
    for n in FILTERS:
        pd.testing.assert_frame_equal(alone.results[n].solution, cmp.results[n].solution)
        pd.testing.assert_frame_equal(alone.results[n].ledger, cmp.results[n].ledger)


def test_printed_table_shows_the_nees_within_100_columns(saved: tuple[Comparison, Path]) -> None:
    from rich.console import Console

    cmp, _ = saved
    for name in ("demo", "paper-1"):  # the paper's columns too
        console = Console(width=100, record=True)
        console.print(comparison_table(dataclasses.replace(cmp, mission_name=name)))
        text = console.export_text()
        assert max(len(line) for line in text.splitlines()) <= 100
        assert text.count("NEES") >= 3 and "(horizontal)" in text
        assert "mean 3" in text and "[0.216, 9.348]" in text
    for _, row in cmp.table().iterrows():  # the simulator's truth has every block
        assert all(math.isfinite(row[c]) for c in NEES_COLUMNS), row["filter"]
    lo, hi = evaluate.NEES_BAND
    assert f"[{lo:.3f}, {hi:.3f}]" in NEES_BAND_TEXT


@pytest.mark.parametrize("smoothed", [False, True])
def test_printed_table_3_is_whole_in_80_columns(
    saved: tuple[Comparison, Path], smoothed: bool
) -> None:
    """Beside the paper's Table 3 (and with the forward columns of a smoothed comparison) the
    table fits an 80-column terminal whole: no cell or header cut to an ellipsis, every
    filter's name and numbers there."""
    from rich.cells import cell_len
    from rich.console import Console

    cmp, _ = saved
    cmp = dataclasses.replace(
        cmp, mission_name="paper-1", forward=dict(cmp.metrics) if smoothed else {}
    )
    console = Console(width=80, record=True)
    console.print(comparison_table(cmp))
    text = console.export_text()
    assert "…" not in text
    assert max(cell_len(line) for line in text.splitlines()) <= 80  # R̂ is one cell wide
    assert text.split("─")[0].split().count("paper") == 2  # both paper headers whole
    words = text.split()
    for _, row in cmp.table().iterrows():
        assert all(w in words for w in FILTER_LABELS[row["filter"]].split()), row["filter"]
        assert f"{row['rmse_m']:.1f}" in words and f"{row['relative_rmse_pct']:.3f}" in words
        if smoothed:
            assert f"{row['forward_rmse_m']:.1f}" in words


def test_saved_folder_json_and_figures(saved: tuple[Comparison, Path]) -> None:
    cmp, out = saved
    doc = json.loads((out / COMPARISON_JSON).read_text())
    assert doc["format"] == "adaptnav-comparison"
    assert doc["mission"] == cmp.mission_name == "demo"
    assert doc["seed"] == SEED and doc["filters"] == list(FILTERS)
    assert doc["results"] == cmp.to_json()
    for name in FILTERS:
        entry = doc["results"][name]
        assert {"rmse_m", "relative_rmse_pct", "distance_m", "duration_s"} <= entry.keys()
        assert {"horizontal_rmse_m", "counts", *NEES_COLUMNS} <= entry.keys()
        assert entry["nees_uses_correlations"] is True
        assert entry["counts"]["dvl"]["used"] > 0
        assert (out / name / "truth.parquet").is_file()
    stems = {Path(f).stem for f in doc["figures"]}
    assert {"trajectory", "position_error", "ledger_counts", "nis"} <= stems
    assert {"noise_dvl", "noise_depth", "noise_inclinometer"} <= stems
    for f in doc["figures"]:
        assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_leave_no_pyplot_state(saved: tuple[Comparison, Path]) -> None:
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    figs = plots.comparison_figures(saved[0])
    assert figs and plt.get_fignums() == before


def test_paper_presets_get_table3_beside_ours(saved: tuple[Comparison, Path]) -> None:
    cmp, _ = saved
    as_paper = dataclasses.replace(cmp, mission_name="paper-2").table().set_index("filter")
    for name, (rmse, rel) in PAPER_TABLE3["paper-2"].items():
        assert as_paper.loc[name, "paper_rmse_m"] == rmse
        assert as_paper.loc[name, "paper_relative_rmse_pct"] == rel
    assert math.isnan(as_paper.loc["oracle", "paper_rmse_m"])


def test_oracle_is_a_row_of_its_own(saved: tuple[Comparison, Path]) -> None:
    cmp, _ = saved
    m = cmp.metrics["oracle"]
    assert math.isfinite(m.rmse_m) and m.rmse_m > 0.0
    assert cmp.results["oracle"].filter == "oracle"


def test_floor_baseline_is_scored_over_the_same_span(
    mission_dir: Path, saved: tuple[Comparison, Path]
) -> None:
    cmp = compare(mission_dir, ("vb", "floor"))
    floor = cmp.results["floor"]
    assert floor.solution["t_s"].iloc[0] >= cmp.t0
    assert cmp.metrics["floor"].duration_s == pytest.approx(cmp.metrics["vb"].duration_s, abs=1.0)
    assert list(cmp.table()["filter"]) == ["vb", "floor"]


@pytest.fixture(scope="module")
def smoothed(mission_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """(what `compare --smooth` printed, its comparison folder) of two filters and the floor."""
    out = tmp_path_factory.mktemp("smoothed") / "cmp"
    res = runner.invoke(
        app, ["compare", str(mission_dir), "-f", "meskf,vb,floor", "--smooth", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    return res.stdout, out


def test_compare_smooth_scores_the_smoothed_solutions_beside_the_forward_ones(
    smoothed: tuple[str, Path],
) -> None:
    printed, out = smoothed
    table = pd.read_csv(out / COMPARISON_CSV).set_index("filter")
    doc = json.loads((out / COMPARISON_JSON).read_text())["results"]
    for name in ("meskf", "vb"):
        # Scored here straight from the saved run folder's tables.
        r = results.load(out / name)
        truth = pd.read_parquet(out / name / "truth.parquet")
        assert r.forward is not None and r.meta["smoother"]["nodes"] > 0
        m_smoothed = evaluate.evaluate(r, truth)
        m_forward = evaluate.evaluate(dataclasses.replace(r, solution=r.forward), truth)
        for key in ("rmse_m", "relative_rmse_pct", "mean_nees_position"):
            for value, expected in (
                (table.loc[name, key], getattr(m_smoothed, key)),
                (doc[name][key], getattr(m_smoothed, key)),
                (table.loc[name, f"forward_{key}"], getattr(m_forward, key)),
                (doc[name][f"forward_{key}"], getattr(m_forward, key)),
            ):
                assert value == pytest.approx(expected, rel=1e-12), (name, key)
        assert abs(m_smoothed.rmse_m - m_forward.rmse_m) > 1e-3 * m_forward.rmse_m, name
    # The floor is not a filter: nothing smoothed, nothing forward.
    assert not (out / "floor" / "forward.parquet").exists()
    assert table.loc["floor", ["forward_rmse_m", "forward_relative_rmse_pct"]].isna().all()
    assert doc["floor"]["forward_rmse_m"] is None
    assert "RTS-smoothed" in printed and "fwd." in printed
    assert f"{table.loc['vb', 'forward_relative_rmse_pct']:.3f}" in printed


def test_smoothed_position_error_figure_shows_forward_beside_smoothed(
    smoothed: tuple[str, Path], saved: tuple[Comparison, Path]
) -> None:
    cmp = saved[0]
    assert len(plots.position_error(cmp.results, cmp.truth).axes) == 2
    out = smoothed[1]
    runs = {n: results.load(out / n) for n in ("meskf", "vb")}
    fig = plots.position_error(runs, cmp.truth)
    assert [ax.get_title() for ax in fig.axes[:2]] == ["forward filter", "RTS-smoothed"]
    for k, r in enumerate(runs.values()):
        for ax, solution in ((fig.axes[0], r.forward), (fig.axes[1], r.solution)):
            assert solution is not None
            err = evaluate.position_errors(solution, cmp.truth)
            t, e = err["t_s"].to_numpy(), err["error_m"].to_numpy()
            expected = plots.envelope(t, e, plots.pixel_points(ax))[1]
            np.testing.assert_array_equal(ax.lines[k].get_ydata(), expected)


def test_parse_filters() -> None:
    assert parse_filters("meskf, VB,floor") == ("meskf", "vb", "floor")
    for bad, word in (("meskf,kalman", "kalman"), ("vb,vb", "vb"), (" , ", "no filter")):
        with pytest.raises(ValueError, match=word):
            parse_filters(bad)


def test_envelope_keeps_a_single_spike_and_gaps() -> None:
    t = np.arange(100_000, dtype=float)
    y = np.zeros_like(t)
    y[54_321] = 7.0
    y[10_000:10_100] = np.nan
    y[90_000:] = np.nan
    te, ye = plots.envelope(t, y, max_points=1000)
    assert te.size <= 1000 and np.all(np.diff(te) >= 0)
    assert np.nanmax(ye) == 7.0 and te[np.nanargmax(ye)] == 54_321
    assert np.isnan(ye[te >= 90_000]).all()


def test_cli_compare_json_prints_one_object(mission_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    res = runner.invoke(
        app, ["compare", str(mission_dir), "--filters", "meskf,vb", "--out", str(out), "--json"]
    )
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)  # nothing else on stdout
    assert set(d) == {"meskf", "vb"}
    for entry in d.values():
        assert math.isfinite(entry["rmse_m"]) and math.isfinite(entry["relative_rmse_pct"])
    # A saved run is an ordinary run folder with its reference beside it.
    res = runner.invoke(app, ["evaluate", str(out / "vb"), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["rmse_m"] == pytest.approx(d["vb"]["rmse_m"], rel=1e-12)


@pytest.mark.parametrize(
    ("filters", "word"), [("meskf,kalman", "kalman"), ("vb,vb", "more than once")]
)
def test_cli_compare_bad_filter_exits_2(
    mission_dir: Path, tmp_path: Path, filters: str, word: str
) -> None:
    res = runner.invoke(
        app, ["compare", str(mission_dir), "--filters", filters, "-o", str(tmp_path)]
    )
    assert res.exit_code == 2
    assert word in res.output and "Traceback" not in res.output


def test_cli_compare_needs_a_reference_and_a_mission(mission_dir: Path, tmp_path: Path) -> None:
    copy = tmp_path / "no-truth"
    shutil.copytree(mission_dir, copy)
    toml = (copy / "mission.toml").read_text()
    (copy / "mission.toml").write_text(toml.replace('[truth]\nfile = "truth.parquet"\n', ""))
    res = runner.invoke(app, ["compare", str(copy), "--filters", "vb", "-o", str(tmp_path / "o")])
    assert res.exit_code == 2 and "reference" in res.output, res.output
    res = runner.invoke(app, ["compare", str(tmp_path / "nothing"), "-o", str(tmp_path / "o")])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output


def test_cli_demo_writes_the_comparison_and_the_report(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    res = runner.invoke(app, ["demo", "--preset", "demo", "--seed", "2", "--out", str(out)])
    assert res.exit_code == 0, res.output
    for f in ("mission/mission.toml", COMPARISON_CSV, COMPARISON_JSON, "report.html"):
        assert (out / f).is_file(), f
    table = pd.read_csv(out / COMPARISON_CSV)
    assert list(table["filter"]) == list(FILTERS)
    assert "report:" in res.stdout and "VB-MAESKF" in res.stdout
    assert "forward_rmse_m" not in table.columns and "smooth" not in res.stdout


def test_cli_demo_smooth_shows_forward_beside_smoothed(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    args = ["demo", "--preset", "demo", "--seed", "2", "--smooth", "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out / COMPARISON_CSV)
    assert list(table["filter"]) == list(FILTERS)
    assert table["forward_rmse_m"].notna().all() and "RTS-smoothed" in res.stdout
    assert all((out / name / "forward.parquet").is_file() for name in FILTERS)
    assert "RTS-smoothed (docs/smoothing.md)" in (out / "report.html").read_text(encoding="utf-8")


def test_figures_do_not_modify_the_mission_tables(saved: tuple[Comparison, Path]) -> None:
    """Fig. 10 marks outliers on the spiked axes only; that selection must not write into the
    mission's tables. With a bool ``is_outlier`` (as the A-KIT import writes it) pandas hands
    out a read-only view, and an in-place ``&=`` raised there."""
    cmp = saved[0]
    tables = dict(cmp.mission.tables)
    dvl = tables["dvl"].copy()
    dvl["is_outlier"] = dvl["is_outlier"].astype(bool)
    assert dvl["is_outlier"].any() and "spike_x_m_s" in dvl.columns
    tables["dvl"] = dvl
    mission = dataclasses.replace(cmp.mission, tables=tables)
    before = dvl.copy()
    figs = plots.comparison_figures(dataclasses.replace(cmp, mission=mission))
    assert "noise_dvl" in figs
    pd.testing.assert_frame_equal(mission.tables["dvl"], before)


def test_figures_of_a_mission_without_aiding_or_with_one_reading(
    mission: Path, tmp_path: Path
) -> None:
    """A pure-INS comparison (every aiding sensor off) draws no ledger figure, which had three
    empty panels; a sensor with one reading after the navigation start is drawn as a point,
    where a line through one point left its panels blank."""
    from helpers import badinput

    toml = mission / "mission.toml"
    aided = toml.read_text()
    toml.write_text(aided.replace('use = "aid"', 'use = "off"'))
    out = tmp_path / "ins"
    res = runner.invoke(app, ["compare", str(mission), "-f", "vb", "--out", str(out), "-q"])
    assert res.exit_code == 0, res.output
    assert json.loads((out / "comparison.json").read_text())["figures"] == [
        "figures/trajectory.png",
        "figures/position_error.png",
    ]
    toml.write_text(aided)
    depth = badinput.read(mission, "depth")
    badinput.write(mission, "depth", depth[(depth["t_s"] < 20.0) | (depth.index == 57)])
    cmp = compare(mission, filters=("vb",))
    makers = plots.figure_makers(cmp)
    for stem in ("noise_depth", "nis"):
        fig = makers[stem]()
        lone = [ln for ax in fig.axes for ln in ax.get_lines() if np.size(ln.get_xdata()) == 1]
        assert lone and all(ln.get_marker() == "o" for ln in lone), stem


def test_the_floor_on_a_dvl_with_one_reading_fails_first_and_says_why(
    mission: Path, tmp_path: Path
) -> None:
    """A DVL with one reading after the navigation start gives the floor a one-point track:
    up to 0.4.5 every filter ran first, then the comparison failed with 'no truth sample within
    the solution span of floor'. The floor runs first now and says what is wrong."""
    from helpers import badinput

    dvl = badinput.read(mission, "dvl")
    badinput.write(mission, "dvl", dvl[(dvl["t_s"] < 20.0) | (dvl.index == len(dvl) - 5)])
    out = tmp_path / "cmp"
    res = runner.invoke(app, ["compare", str(mission), "-f", "vb,floor", "--out", str(out)])
    assert (
        res.exit_code == 2
        and "floor: the DVL has 1 reading after the navigation start" in res.output
    )
    assert "running VB-MAESKF" not in res.output and not out.exists()
