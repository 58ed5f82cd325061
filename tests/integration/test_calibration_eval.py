"""scripts/calibration_eval.py (make calibration): the page on the short demo mission, its
'What limits the estimates' section, and the A-KIT section's agreement arithmetic."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from helpers.script_loader import load_script

SCRIPT = load_script("calibration_eval")


def test_the_script_writes_the_page_with_the_limits_and_the_truth_fit(tmp_path: Path) -> None:
    out = tmp_path / "c.md"
    args = ["--preset", "demo", "--seeds", "1", "--no-akit", "--cache", str(tmp_path / "cache"),
            "--out", str(out)]  # fmt: skip
    assert SCRIPT.main(args) == 0
    text = out.read_text()
    for part in ("## Means and the issue's targets", "## Every run", "truth fit: yaw (°)",
                 "## What limits the estimates", "robust + a heading sensor (0.5°)",
                 "robust + GNSS positions (2.9 m)", "truth fit (no filter)",
                 "## DVL latency on simulated missions", "(estimate - 100) / σ"):  # fmt: skip
        assert part in text, part
    assert "## A-KIT" not in text
    # the aided missions are the estimating one with one sensor's use changed, nothing else
    est = next((tmp_path / "cache").glob("demo-s1-scale*-estimate"))
    gnss = est.with_name(est.name + "-gps")
    assert 'use = "aid"' in (gnss / "mission.toml").read_text()
    assert 'use = "init"' in (est / "mission.toml").read_text()
    assert (gnss / "dvl.parquet").stat().st_ino == (est / "dvl.parquet").stat().st_ino


def _segment(n: int, scale: float, sd: float) -> dict[str, Any]:
    one = {k: 0.0 for k in SCRIPT.AKIT_STATES} | {f"sd_{k}": 1.0 for k in SCRIPT.AKIT_STATES}
    one |= {"dvl.scale": scale, "sd_dvl.scale": sd}
    est = one | {"rel_without_pct": 0.2, "rel_with_pct": 0.2, "rel_smoothed_pct": 0.1}
    # a filter's σ allowing for correlated readings: twice its σ here
    est |= {f"sdl_{k}": 2.0 * est[f"sd_{k}"] for k in SCRIPT.AKIT_STATES}
    fit = one | {"residual_mm_s": 10.0 + n}  # the last segment's DVL fits the reference worst
    return {"segment": n, "reference_scale_pct": 0.0, "reference_p95": 5.0, "vb": est,
            "robust": est, "fit_velocity": fit, "fit_position": one}  # fmt: skip


def test_agreement_is_the_weighted_mean_and_the_chi_square_of_the_spread() -> None:
    """Three segments 0, 0, 4.5 with σ 1: mean 1.5, χ² 2.25 + 2.25 + 9 = 13.5 on 2, the third
    3σ off the mean, and with the filter's long-run σ of 2 a quarter of it, 3.4; with σ 1, 1, 2
    it counts a quarter: mean 0.5, χ² 0.25 + 0.25 + 4, all three within 2σ (a fit: no long-run
    column, its σ allows for correlated readings already)."""
    rows = [_segment(1, 0.0, 1.0), _segment(2, 0.0, 1.0), _segment(3, 4.5, 1.0)]
    assert SCRIPT._agreement(rows, "vb", "dvl.scale") == [
        "scale, VB-MAESKF", "1.500", "13.5 on 2", "2/3", "3.4 on 2",
    ]  # fmt: skip
    rows[2] = _segment(3, 4.5, 2.0)
    label, mean, chi2, inside, long_run = SCRIPT._agreement(rows, "fit_position", "dvl.scale")
    assert label == "scale, fit to the reference's positions" and long_run == "-"
    assert float(mean) == pytest.approx(0.5) and chi2 == "4.5 on 2" and inside == "3/3"
    text = SCRIPT.akit_section(rows)
    assert "smoothed / forward 0.500 and 0.500" in text and text.count("**PASS**") == 4
    # without segment 3 (the largest residual against the reference's velocity, 13 mm/s): the
    # two left agree exactly (χ² 0 on 1)
    assert "segment 3: the residual of the fit to it 13.0 mm/s" in text
    assert "| scale, VB-MAESKF | 0.500 | 4.5 on 2 | 3/3 | 1.1 on 2 | 0.0 on 1 |" in text


def test_the_timing_table_gives_means_spreads_and_the_named_segments_roll() -> None:
    """Two shifts of three segments: the means of the error and the NEES, each estimate's χ²
    about its weighted mean (roll 0, 0, 0.3 with σ 0.1: mean 0.1, χ² 1 + 1 + 4 = 6 on 2), and
    the roll of the segments the table names."""

    def rows(roll: float) -> list[dict[str, Any]]:
        out = []
        for n, r in zip((7, 8, 9), (0.0, 0.0, roll), strict=True):
            one = {k: 0.0 for k in SCRIPT.AKIT_STATES} | {
                f"sd_{k}": 0.1 for k in SCRIPT.AKIT_STATES
            }
            out.append(one | {"segment": n, "rel_pct": 0.1 * n, "nees": 3.0,
                              "dvl.misalignment_roll": r})  # fmt: skip
        return out

    text = SCRIPT.timing_section({0.0: rows(0.3), 0.1: rows(0.0)})
    lines = [
        line
        for line in text.splitlines()
        if line.startswith("| 0 (as") or line.startswith("| +0.1")
    ]
    assert lines[0] == "| 0 (as recorded) | 0.800 | 3.00 | 0.0 | 6.0 | 0.0 | 0.0 | +0.00°, +0.30° |"
    assert lines[1] == "| +0.1 | 0.800 | 3.00 | 0.0 | 0.0 | 0.0 | 0.0 | +0.00°, +0.00° |"
    assert "on 2 degrees of freedom" in text


def test_the_akit_latency_table_sets_the_latency_runs_beside_the_plain_ones() -> None:
    """Three segments: latencies -10, -20, -30 ms with σ 5 (weighted mean -20, χ² 4 + 0 + 4 = 8
    on 2), their relative RMSE means forward and smoothed; the plain runs' row has no latency
    and takes its forward error from ``rel_with_pct``."""
    rows, plain = [], []
    for n, lat in zip((1, 2, 3), (-10.0, -20.0, -30.0), strict=True):
        one = {k: 0.0 for k in SCRIPT.AKIT_STATES} | {f"sd_{k}": 0.1 for k in SCRIPT.AKIT_STATES}
        rows.append(one | {"segment": n, "dvl.latency": lat, "sd_dvl.latency": 5.0,
                           "sdl_dvl.latency": 10.0, "rel_pct": 0.2,
                           "rel_smoothed_pct": 0.1})  # fmt: skip
        plain.append({"robust": one | {"rel_with_pct": 0.4, "rel_smoothed_pct": 0.3}})
    text = SCRIPT.akit_latency_section(rows, plain)
    assert "| 2 | -20.0 ± 5.0 | +0.000 ± 0.100 | +0.000 ± 0.100 | 10.0 | 0.200 | 0.100 |" in text
    assert "with the latency's σ allowing for correlated readings its χ² is 2.0" in text
    assert "| + latency | -20.0, 8.0 | +0.000, 0.0 | +0.000, 0.0 | 0.200 | 0.100 | 0.500 |" in text
    assert "| scale, misalignment | - | +0.000, 0.0 | +0.000, 0.0 | 0.400 | 0.300 | 0.750 |" in text
