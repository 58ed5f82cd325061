"""scripts/smoothing_eval.py (make smoothing): the page of forward against RTS-smoothed runs on
the simulated sea trials, on the short demo mission, and its verdicts (docs/smoothing.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from adaptnav.analysis.evaluate import NEES_BAND
from helpers.script_loader import load_script

SCRIPT = load_script("smoothing_eval")


def test_smoothing_evaluation_script_writes_the_results_page(tmp_path: Path) -> None:
    mod = SCRIPT
    out, figs = tmp_path / "s.md", tmp_path / "figs"
    args = ["--presets", "demo", "--seeds", "1", "--filters", "vb,meskf", "--jobs", "1", "--cache",
            str(tmp_path / "cache"), "--out", str(out), "--figures", str(figs)]  # fmt: skip
    assert mod.main(args) == 0
    text = out.read_text()
    for heading in ("## Targets", "## Every filter", "## Appendix: every run",
                    "position_error.png", "runs.csv"):  # fmt: skip
        assert heading in text
    runs = pd.read_csv(figs / "runs.csv")
    assert list(runs["filter"]) == ["vb", "meskf"] * 2 and runs["error"].isna().all()
    assert list(runs["case"]) == ["paper"] * 2 + ["surfacing"] * 2
    # the forward pass is the same until the last fix, the one epoch where the cases differ
    paper, surfaced = (runs[runs["case"] == c].reset_index() for c in ("paper", "surfacing"))
    np.testing.assert_allclose(
        surfaced["forward_relative_rmse_pct"], paper["forward_relative_rmse_pct"], rtol=0.05
    )
    assert (surfaced["smoothed_rms_sigma_m"] < paper["smoothed_rms_sigma_m"]).all()
    assert (runs["smoothed_rms_sigma_m"] < runs["forward_rms_sigma_m"]).all()
    assert (runs["failed_nodes"] == 0).all() and (runs["store_mb_per_h"] > 0).all()
    ratio = runs["smoothed_relative_rmse_pct"] / runs["forward_relative_rmse_pct"]
    np.testing.assert_allclose(runs["relative_rmse_ratio"], ratio, rtol=1e-5)  # CSV: 6 digits
    assert (figs / "position_error.png").stat().st_size > 10_000
    # only VB-MAESKF is a target filter: one verdict line per case, both verdicts on it
    for case in ("paper's aiding", "+ last GNSS fix"):
        assert text.count(f"- demo VB-MAESKF, {case}: smoothed / forward relative RMSE") == 1
    assert "demo MESKF: smoothed" not in text
    # the surfacing GNSS's bias state: the simulator's slow error as a Gauss-Markov state
    from adaptnav.experiments.cache import load_prepared
    from adaptnav.experiments.spec import RunSpec

    mission, _ = load_prepared(tmp_path / "cache", RunSpec("demo", 1, "vb").mission_name)
    for bias, tau in (("constant", math.inf), ("gauss-markov", 120.0)):
        m = mod.surfacing(mission, 5, 0.0, bias)
        (gnss,) = (c for c in m.config.sensors.values() if c.kind == "gnss")
        assert gnss.use == "aid" and gnss.calibration_si()["bias"] == (2.5, 0.0, tau)
    assert mod.case_label("surfacing", 600, 0.0, "gauss-markov") == (
        "+ last 600 GNSS fixes, gauss-markov bias state"
    )


def _row(
    seed: int, forward: float, smoothed: float, nees: tuple[float, float]
) -> dict[str, object]:
    """One run of the table of runs: relative RMSE forward and smoothed, position NEES both."""
    row: dict[str, object] = {"case": "paper", "aiding": "paper's aiding", "preset": "p",
                              "filter": "vb", "seed": seed, "error": None}  # fmt: skip
    for name in ("forward", "smoothed"):
        row |= {f"{name}_{k}": 1.0 for k in (*SCRIPT.SCORES, "rms_sigma_m")}
    row |= {
        "forward_relative_rmse_pct": forward,
        "smoothed_relative_rmse_pct": smoothed,
        "relative_rmse_ratio": smoothed / forward,
        "forward_mean_nees_position": nees[0],
        "smoothed_mean_nees_position": nees[1],
        "store_mb_per_h": 1.0, "run_s": 1.0, "imu_hours": 1.0, "failed_nodes": 0,
    }  # fmt: skip
    return row


def test_the_verdicts_are_on_the_ratio_of_the_means_and_the_nees_band() -> None:
    mod = SCRIPT
    assert [mod.nees_class(x) for x in (0.1, 3.0, 20.0, math.nan)] == [
        "below", "inside", "above", "-",
    ]  # fmt: skip
    assert mod.nees_class(NEES_BAND[0]) == mod.nees_class(NEES_BAND[1]) == "inside"
    # per-seed ratios 0.2 and 0.9 (mean 0.55), ratio of the means 2.0 / 3.0: judged on the latter
    table = pd.DataFrame([_row(1, 1.0, 0.2, (3.0, 2.0)), _row(2, 2.0, 1.8, (3.0, 4.0))])
    (row,) = mod.summarize(table).to_dict("records")
    assert math.isclose(row["ratio_mean"], 0.55) and math.isclose(row["ratio_of_means"], 2 / 3)
    assert not row["rmse_ok"] and row["nees_ok"]
    table = pd.DataFrame([_row(1, 1.0, 0.5, (3.0, 12.0))])
    (row,) = mod.summarize(table).to_dict("records")
    assert row["rmse_ok"] and not row["nees_ok"]  # consistent forward, overconfident smoothed
    failed = pd.DataFrame([_row(1, 1.0, 0.5, (3.0, 3.0)), {**_row(2, 1.0, 0.5, (3.0, 3.0)),
                                                           "error": "ValueError: x"}])  # fmt: skip
    (row,) = mod.summarize(failed).to_dict("records")
    assert row["seeds"] == 1 and row["failed"] == 1 and not row["rmse_ok"] and not row["nees_ok"]


def test_the_rms_ratios_are_taken_over_the_seeds_as_mean_squares() -> None:
    """``rms_ratio`` = sqrt(mean RMSE_s² / mean RMSE_f²) and ``sigma_ratio`` the same of the
    filter's RMS σ: numbers worked by hand (sqrt(2.5 / 12.5) and sqrt(1 / 4))."""
    rows = []
    for seed, (f, s) in enumerate(((3.0, 1.0), (4.0, 2.0)), start=1):
        row = _row(seed, 1.0, 0.5, (3.0, 3.0))
        row |= {"forward_rmse_m": f, "smoothed_rmse_m": s,
                "forward_rms_sigma_m": 2.0, "smoothed_rms_sigma_m": 1.0}  # fmt: skip
        rows.append(row)
    (row,) = SCRIPT.summarize(pd.DataFrame(rows)).to_dict("records")
    assert math.isclose(row["rms_ratio"], math.sqrt(2.5 / 12.5))
    assert math.isclose(row["sigma_ratio"], 0.5)
    assert row["case"] == "paper"
