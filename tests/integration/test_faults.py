"""Injected sensor faults (adaptnav.sim.faults) and the fault benchmark
(adaptnav.experiments.faultbench, scripts/faults_eval.py): each injector changes its rows and
nothing else, writes faults.json, is seeded and deterministic, `all` keeps its windows disjoint; one
tiny end-to-end run.

The tiny simulated mission of :mod:`helpers.badinput` (20 s alignment, then about 40 s under
way) with every fault shrunk to fit it (:data:`SMALL`)."""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from adaptnav.experiments import faultbench as fb
from adaptnav.importers import akit
from adaptnav.mission import load_mission
from adaptnav.sim import faults
from helpers.badinput import read, tiny_mission
from helpers.script_loader import load_script

SMALL = faults.FaultParams(
    depth_offset_s=3.0,
    dvl_stuck_s=4.0,
    dvl_dropout_s=6.0,
    dvl_spike_fraction=0.05,
    settle_s=2.0,
    end_margin_s=2.0,
    gap_s=2.0,
)
"""The issue's faults scaled to a 40-s navigation: same sizes, shorter windows, more spikes."""
SEED = 5
NAV_START_S = 20.0
"""The tiny mission's alignment window ends here (its ``initial.alignment_s``)."""
DVL = ["vx_m_s", "vy_m_s", "vz_m_s"]


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_mission(tmp_path_factory.mktemp("faults") / "clean")


@pytest.fixture(scope="module")
def source_parquet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_mission(tmp_path_factory.mktemp("faults-pq") / "clean", fmt="parquet")


def _hashes(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()}


def _inject(source: Path, out: Path, case: str, seed: int = SEED) -> faults.FaultLog:
    return faults.inject(source, out, case, np.random.default_rng(seed), SMALL)


def _unchanged_files(source: Path, out: Path, changed: set[str]) -> None:
    """Every file but ``changed`` is copied byte for byte; faults.json is the only new one."""
    a, b = _hashes(source), _hashes(out)
    assert set(b) == set(a) | {faults.FAULTS_FILE}
    assert {n for n in a if a[n] != b[n]} == changed


def _same_except(a: pd.DataFrame, b: pd.DataFrame, rows: np.ndarray, cols: list[str]) -> None:
    """``b`` equals ``a`` everywhere but ``cols`` at ``rows`` (and the outlier flag there)."""
    keep = np.setdiff1d(np.arange(len(a)), rows)
    pd.testing.assert_frame_equal(
        a.iloc[keep].reset_index(drop=True),
        b.iloc[keep][a.columns].reset_index(drop=True),
        check_dtype=False,
    )
    others = [c for c in a.columns if c not in cols and c != faults.OUTLIER_COLUMN]
    pd.testing.assert_frame_equal(
        a.iloc[rows][others].reset_index(drop=True), b.iloc[rows][others].reset_index(drop=True)
    )
    flags = b[faults.OUTLIER_COLUMN].to_numpy()
    assert np.all(flags[rows] == 1)
    before = (
        a[faults.OUTLIER_COLUMN].to_numpy() if faults.OUTLIER_COLUMN in a.columns else 0 * flags
    )
    np.testing.assert_array_equal(flags[keep], before[keep])


def _check_window(log: faults.FaultLog, fault: faults.Injected) -> tuple[float, float]:
    """The fault's window, checked inside the span where faults may go."""
    lo, hi = log.span_s
    assert lo == pytest.approx(NAV_START_S + SMALL.settle_s)
    assert fault.window_s is not None
    assert lo <= fault.window_s[0] <= fault.window_s[1] <= hi
    return fault.window_s


# --- each injector -----------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_depth_spike_changes_one_reading(
    source: Path, source_parquet: Path, tmp_path: Path, fmt: str
) -> None:
    src = source if fmt == "csv" else source_parquet
    log = _inject(src, tmp_path / "f", "depth_spike")
    fault = log.of("depth_spike")
    assert len(fault.rows) == 1 and fault.sensor == "depth"
    w = _check_window(log, fault)
    a, b = read(src, "depth"), read(tmp_path / "f", "depth")
    rows = np.array(fault.rows)
    _same_except(a, b, rows, ["depth_m"])
    np.testing.assert_allclose(
        b["depth_m"].to_numpy()[rows] - a["depth_m"].to_numpy()[rows], 1000.0
    )
    assert b["t_s"].to_numpy()[rows[0]] == w[0]
    _unchanged_files(src, tmp_path / "f", {f"depth.{fmt}"})


def test_depth_offset_changes_its_window(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "f", "depth_offset")
    fault = log.of("depth_offset")
    a0, a1 = _check_window(log, fault)
    a, b = read(source, "depth"), read(tmp_path / "f", "depth")
    t = a["t_s"].to_numpy()
    rows = np.flatnonzero((t >= a0) & (t < a1))
    assert fault.rows == tuple(rows) and rows.size >= SMALL.depth_offset_s - 1
    _same_except(a, b, rows, ["depth_m"])
    np.testing.assert_allclose(
        b["depth_m"].to_numpy()[rows] - a["depth_m"].to_numpy()[rows], 1000.0
    )
    _unchanged_files(source, tmp_path / "f", {"depth.csv"})


def test_dvl_stuck_repeats_the_first_reading(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "f", "dvl_stuck")
    fault = log.of("dvl_stuck")
    w = _check_window(log, fault)
    a, b = read(source, "dvl"), read(tmp_path / "f", "dvl")
    rows = np.array(fault.rows)
    first = int(fault.detail["stuck_row"])
    t = a["t_s"].to_numpy()
    # every reading of the window after its first one, and only those
    in_window = np.flatnonzero((t > t[first]) & (t < w[1]))
    np.testing.assert_array_equal(rows, in_window)
    assert t[first] >= w[0]
    _same_except(a, b, rows, DVL)
    stuck = a.loc[first, DVL].to_numpy(dtype=float)
    np.testing.assert_array_equal(
        b.loc[rows, DVL].to_numpy(dtype=float), np.tile(stuck, (rows.size, 1))
    )
    np.testing.assert_array_equal(fault.detail["value_m_s"], stuck)
    _unchanged_files(source, tmp_path / "f", {"dvl.csv"})


def test_dvl_dropout_removes_its_rows(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "f", "dvl_dropout")
    fault = log.of("dvl_dropout")
    a0, a1 = _check_window(log, fault)
    a, b = read(source, "dvl"), read(tmp_path / "f", "dvl")
    t = a["t_s"].to_numpy()
    removed = np.flatnonzero((t >= a0) & (t < a1))
    assert fault.rows == () and fault.removed_rows == tuple(removed)
    assert removed.size >= 3 * SMALL.dvl_dropout_s - 1  # the DVL's 3 Hz
    pd.testing.assert_frame_equal(a.drop(index=removed).reset_index(drop=True), b)
    _unchanged_files(source, tmp_path / "f", {"dvl.csv"})


def test_dvl_spikes(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "f", "dvl_spikes")
    fault = log.of("dvl_spikes")
    a, b = read(source, "dvl"), read(tmp_path / "f", "dvl")
    rows = np.array(fault.rows)
    t = a["t_s"].to_numpy()
    assert rows.size == max(1, round(SMALL.dvl_spike_fraction * np.sum(t > NAV_START_S)))
    assert np.all((t[rows] >= log.span_s[0]) & (t[rows] < log.span_s[1]))
    assert np.all(a["is_outlier"].to_numpy()[rows] == 0)  # not on the simulator's own spikes
    _same_except(a, b, rows, DVL)
    diff = b.loc[rows, DVL].to_numpy(dtype=float) - a.loc[rows, DVL].to_numpy(dtype=float)
    np.testing.assert_allclose(diff, fault.detail["spikes_m_s"], atol=1e-12)
    on = diff != 0.0
    assert np.all(on.any(axis=1))
    assert np.all((np.abs(diff[on]) >= 1.0 - 1e-12) & (np.abs(diff[on]) <= 3.0 + 1e-12))
    _unchanged_files(source, tmp_path / "f", {"dvl.csv"})


def test_spike_vectors() -> None:
    """Non-empty axis sets, each of the seven about equally often, sizes in the range; the A-KIT
    injector's spikes (the same function) too."""
    s = faults.spike_vectors(np.random.default_rng(9), 500, (1.0, 3.0))
    on = s != 0.0
    assert np.all(np.abs(s[on]) >= 1.0) and np.all(np.abs(s) <= 3.0)
    counts = np.bincount(on @ np.array([1, 2, 4]), minlength=8)
    assert counts[0] == 0 and counts[1:].min() > 40  # seven axis sets, each ≈ 500 / 7
    t = np.arange(0.0, 400.0)
    _, truth, info = akit.inject_dvl_faults(
        t, np.zeros((t.size, 3)), 0.02, np.random.default_rng(3)
    )
    spikes = truth[[f"spike_{x}_m_s" for x in "xyz"]].to_numpy()[info["spike_rows"]]
    assert np.all((spikes != 0.0).any(axis=1)) and np.all(np.abs(spikes) <= 3.0)


# --- faults.json, seeds, all -------------------------------------------------------------------


def test_faults_json_round_trip(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "f", faults.ALL)
    doc = json.loads((tmp_path / "f" / faults.FAULTS_FILE).read_text())
    assert doc["format"] == "adaptnav-faults" and doc["case"] == "all"
    assert [f["kind"] for f in doc["faults"]] == list(faults.FAULT_KINDS)
    assert doc["seed"] == SEED
    assert faults.read_faults(tmp_path / "f") == log


def test_seeded_and_deterministic(source: Path, tmp_path: Path) -> None:
    a = _inject(source, tmp_path / "a", faults.ALL)
    b = _inject(source, tmp_path / "b", faults.ALL)
    c = _inject(source, tmp_path / "c", faults.ALL, seed=SEED + 1)
    assert _hashes(tmp_path / "a") == _hashes(tmp_path / "b")
    assert a.faults == b.faults and a.layout_s == b.layout_s
    assert c.layout_s != a.layout_s


def test_all_windows_disjoint_and_as_alone(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "all", faults.ALL)
    windows = sorted(log.layout_s.values())
    assert len(windows) == len(faults.WINDOW_KINDS)
    for (_, end), (start, _) in itertools.pairwise(windows):
        assert start >= end + SMALL.gap_s - 1e-9
    a, b = read(source, "dvl"), read(tmp_path / "all", "dvl")
    t_b = b["t_s"].to_numpy()
    for kind in faults.FAULT_KINDS:
        alone = _inject(source, tmp_path / kind, kind)
        assert alone.layout_s == log.layout_s
        if kind not in ("dvl_stuck", "dvl_spikes"):
            assert alone.of(kind) == log.of(kind)
            continue
        # DVL rows behind the dropout moved up: same readings (by time), other row numbers
        t_alone = read(tmp_path / kind, "dvl")["t_s"].to_numpy()
        np.testing.assert_array_equal(
            t_b[list(log.of(kind).rows)], t_alone[list(alone.of(kind).rows)]
        )
    spikes = t_b[list(log.of("dvl_spikes").rows)]
    for kind in ("dvl_stuck", "dvl_dropout"):
        w0, w1 = log.layout_s[kind]
        assert not np.any((spikes >= w0) & (spikes < w1))
    # faulted DVL readings = source minus the dropout, with stuck values and spikes on their rows
    kept = a.drop(index=list(log.of("dvl_dropout").removed_rows)).reset_index(drop=True)
    changed = np.r_[log.of("dvl_stuck").rows, log.of("dvl_spikes").rows].astype(int)
    _same_except(kept, b, changed, DVL)
    _unchanged_files(source, tmp_path / "all", {"dvl.csv", "depth.csv"})


def test_refusals(source: Path, tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="use one of"):
        faults.inject(source, tmp_path / "x", "gremlins", rng, SMALL)
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "a").write_text("")
    with pytest.raises(ValueError, match="not an empty folder"):
        faults.inject(source, tmp_path / "full", "depth_spike", rng, SMALL)
    _inject(source, tmp_path / "once", "depth_spike")
    with pytest.raises(ValueError, match="already a faulted mission"):
        faults.inject(tmp_path / "once", tmp_path / "twice", "depth_spike", rng, SMALL)
    with pytest.raises(ValueError, match="do not fit"):
        faults.inject(source, tmp_path / "long", "dvl_dropout", rng)  # the issue's 300 s in 40 s
    with pytest.raises(ValueError, match="must be a finite number > 0"):
        faults.FaultParams(dvl_stuck_s=0.0)
    assert not (tmp_path / "x").exists() and not (tmp_path / "long").exists()


def test_the_oracle_drops_the_injected_readings(source: Path, tmp_path: Path) -> None:
    log = _inject(source, tmp_path / "f", faults.ALL)
    m = load_mission(tmp_path / "f")
    from adaptnav.api import oracle

    known = oracle.mission_noise(m, ["dvl", "depth"])
    for fault in log.faults:
        if fault.rows:
            flags = known[fault.sensor].outlier[
                np.searchsorted(m.sensors[fault.sensor].rows, fault.rows)
            ]
            assert flags.all(), fault.kind


# --- the benchmark -----------------------------------------------------------------------------


def test_benchmark_end_to_end(source: Path, tmp_path: Path) -> None:
    rows = fb.evaluate_mission(
        source, tmp_path / "work", SEED, filters=("meskf",), cases=("clean", "dvl_dropout"),
        params=SMALL,
    )  # fmt: skip
    assert [(r["case"], r["filter"]) for r in rows] == [
        ("clean", "meskf"),
        ("dvl_dropout", "meskf"),
    ]
    assert not (tmp_path / "work" / "dvl_dropout").exists()  # removed after its runs
    table = pd.DataFrame(rows).assign(preset="tiny")
    summary = fb.summarize(table)
    (row,) = summary.to_dict("records")
    assert math.isfinite(row["ratio_mean"]) and row["ratio_mean"] > 0.0
    assert math.isfinite(row["dropout_ratio_worst"]) and row["dvl_dropout_n"] > 0
    assert math.isfinite(row["dropout_mahalanobis_worst"])
    assert row["delta_max_m"] > 0.0  # the dropout moves the solution
    text = load_script("faults_eval").page(
        table, summary, ["tiny"], ["clean", "dvl_dropout"], "header", "x"
    )
    assert "RMSE faulted / RMSE clean" in text and "End of the DVL dropout" in text


def test_a_run_that_raises_fails_its_target_only(
    source: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = fb.api.run

    def breaks_on_faults(mission: Any, *args: Any, **kwargs: Any) -> Any:
        if mission.root.name != source.name:
            raise ValueError("the filter broke down")
        return real(mission, *args, **kwargs)

    monkeypatch.setattr(fb.api, "run", breaks_on_faults)
    rows = fb.evaluate_mission(
        source, tmp_path / "work", SEED, filters=("meskf",), cases=("clean", "depth_spike"),
        params=SMALL,
    )  # fmt: skip
    assert rows[0]["error"] is None and rows[1]["error"] == "ValueError: the filter broke down"
    table = pd.DataFrame(rows).assign(preset="tiny")
    (row,) = fb.summarize(table).to_dict("records")
    assert row["failed"] == 1 and math.isnan(row["ratio_mean"])
    text = load_script("faults_eval").page(
        table, fb.summarize(table), ["tiny"], ["clean", "depth_spike"], "header", "x"
    )
    assert "**no** (1 failed)" in text and "the filter broke down" in text


def test_a_runs_warnings_are_named_with_their_kind() -> None:
    """``warned`` names a sensor at odds by its name and one with correlated innovations as
    ``name:correlated`` (api/diagnosis.py's two warnings), so the page tells them apart."""
    assert fb._warned({"sensor": "dvl", "message": "dvl: at odds"}) == "dvl"
    correlated = {"sensor": "depth", "kind": "correlated", "message": "depth: ..."}
    assert fb._warned(correlated) == "depth:correlated"
