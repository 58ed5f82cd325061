"""Sweeps and Monte Carlo (adaptnav.experiments, `adaptnav sweep`): cache keys, resume,
q reaching the gate, the gyro-bias scale reaching Q, statistics by hand, the CLI.

One short ``demo`` mission (seed 1, every disturbance on: it has DVL outliers) is simulated
once for the module and shared through copies of its cache folder.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.cli import app
from adaptnav.experiments import runner as sweep_runner
from adaptnav.experiments.figures import plot_monte_carlo, plot_process_noise, plot_q_sweep
from adaptnav.experiments.runner import SweepOutcome, run_sweep
from adaptnav.experiments.spec import (
    Q_SCALES,
    Q_VALUES,
    RunSpec,
    available_filters,
    parse_seeds,
    process_noise_specs,
    q_sweep_specs,
    scale_gyro_bias_q,
)
from adaptnav.experiments.stats import (
    METRICS,
    NEES_METRICS,
    curve,
    curve_spread,
    paired_comparison,
    summarize,
)
from adaptnav.mission import MissionError, parse_config, with_overrides
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.sim.sensors import Disturbances
from helpers.missions import config_dict

runner = CliRunner()

SPECS = [
    RunSpec("demo", 1, "meskf", q=200.0),
    RunSpec("demo", 1, "meskf", q=2600.0),
    RunSpec("demo", 1, "vb", q=200.0),
    RunSpec("demo", 1, "vb"),
    RunSpec("demo", 1, "meskf", q_scale=0.01),
    RunSpec("demo", 1, "meskf", q_scale=100.0),
]


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, SweepOutcome]:
    cache = tmp_path_factory.mktemp("sweep") / "cache"
    return cache, run_sweep(SPECS, cache, jobs=1, progress=False)


def _copy_missions(cache: Path, to: Path) -> Path:
    shutil.copytree(cache / "missions", to / "missions")
    return to


def _metrics(table: pd.DataFrame) -> pd.DataFrame:
    cols = [c for c in METRICS if c != "elapsed_s"]
    return table.set_index("key")[cols].sort_index()


# --- specs and keys ----------------------------------------------------------------------------


def test_key_is_stable_and_normalised() -> None:
    spec = RunSpec("demo", 1, "vb")
    # The key is a content hash: a change here invalidates every cache (bump on purpose only).
    assert spec.key(version="test") == RunSpec("demo", 1, "vb").key(version="test")
    assert len(spec.key()) == 20 and spec.key() != spec.key(version="other")
    assert RunSpec("demo", 1, "vb", q_scale=1.0, disturbances=Disturbances()) == spec
    assert RunSpec("demo", 1, "vb", q_scale=1.0).key() == spec.key()
    assert RunSpec("demo", 1, "vb", q=600).key() != spec.key()
    assert RunSpec("demo", 2, "vb").key() != spec.key()
    off = RunSpec("demo", 1, "vb", disturbances=Disturbances(dvl_outliers=False))
    assert off.key() != spec.key() and off.mission_name.startswith("demo-s1-d")
    assert spec.mission_name == "demo-s1"
    assert spec.key(version="test") == "2a07df161c05292faf48"
    # Any filter parameter is a config override of the one settings model, e.g. VB's Student-t ν.
    t = RunSpec("demo", 1, "vb", config=(("filter.vb_dof", 4.0),))
    assert t.key() != spec.key() and t.as_dict()["config"] == {"filter.vb_dof": 4.0}


@pytest.mark.parametrize(
    "kwargs",
    [
        {"preset": "nope"},
        {"seed": -1},
        {"filter": "kalman"},
        {"q": 0.0},
        {"q": math.inf},
        {"q_scale": -1.0},
    ],
)
def test_bad_spec_raises(kwargs: dict[str, object]) -> None:
    args: dict[str, object] = {"preset": "demo", "seed": 1, "filter": "vb", **kwargs}
    with pytest.raises(ValueError):
        RunSpec(**args)  # type: ignore[arg-type]


def test_parse_seeds() -> None:
    assert parse_seeds("1-3,10,2") == [1, 2, 3, 10]
    assert parse_seeds("7") == [7]
    for bad in ("", "a", "5-1", "1,,2", "-3"):
        with pytest.raises(ValueError):
            parse_seeds(bad)
    assert len(parse_seeds("1-10000")) == 10_000
    with pytest.raises(ValueError, match="more than 10000 seeds"):  # up to 0.4.4: a hang
        parse_seeds("0-999999999999")


def test_a_sweep_whose_every_run_failed_is_an_error(
    serial: tuple[Path, SweepOutcome], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Exit 2 and no folder (up to 0.4.4: exit 0 and an empty table)."""
    from typer.testing import CliRunner

    from adaptnav.cli import app

    cache = _copy_missions(serial[0], tmp_path / "cache")

    def boom(*args: object) -> dict[str, float]:
        raise RuntimeError("diverged")

    monkeypatch.setattr(sweep_runner, "run_one", boom)
    res = CliRunner().invoke(
        app,
        ["sweep", "seeds", "demo", "--seeds", "1", "--filters", "maeskf", "--cache", str(cache),
         "--jobs", "1", "--out", str(tmp_path / "out"), "--quiet"],
    )  # fmt: skip
    assert res.exit_code == 2, res.output
    assert "every run failed (1), e.g.: " in res.output and "diverged" in res.output
    assert not (tmp_path / "out").exists()


def test_specs_of_the_paper_sweeps() -> None:
    assert len(Q_VALUES) == 25 and Q_VALUES[0] == 200.0 and Q_VALUES[-1] == 2600.0
    assert len(Q_SCALES) == 9 and math.isclose(Q_SCALES[4], 1.0)
    q = q_sweep_specs(["demo"], [1, 2])
    gated = [s for s in q if s.q is not None]
    assert len(gated) == 2 * 3 * 25 and {s.filter for s in gated} == {"meskf", "maeskf", "vb"}
    assert {(s.filter, s.q) for s in q if s.q is None} <= {("vb", None), ("oracle", None)}
    pn = process_noise_specs(["demo"], [1])
    assert len(pn) == 27 and all(s.q is None for s in pn)
    assert sum(s.q_scale is None for s in pn) == 3  # factor 1: the default run, one cache entry


def test_available_filters_dedupes_and_names_the_known_ones() -> None:
    assert available_filters(["vb", "oracle", "vb", "meskf"]) == ("vb", "oracle", "meskf")
    with pytest.raises(ValueError, match="'kalman': use one of meskf, maeskf, vb, robust, oracle"):
        available_filters(["kalman"])


def test_scale_gyro_bias_q_scales_the_psd_only() -> None:
    gm = ImuNoise(1e-4, 1e-3, gyro_bias_sigma=5e-6, gyro_bias_tau=3600.0, accel_bias_sigma=2e-3)
    scaled = scale_gyro_bias_q(gm, 100.0)
    assert math.isclose(scaled.gyro_bias_psd, 100.0 * gm.gyro_bias_psd)
    assert scaled.gyro_bias_tau == gm.gyro_bias_tau and scaled.accel_bias_psd == gm.accel_bias_psd
    rw = ImuNoise(1e-4, 1e-3, gyro_bias_rrw=1e-7)
    assert math.isclose(scale_gyro_bias_q(rw, 0.01).gyro_bias_psd, 0.01 * rw.gyro_bias_psd)


# --- running -----------------------------------------------------------------------------------


def test_sweep_runs_and_caches(serial: tuple[Path, SweepOutcome]) -> None:
    cache, out = serial
    assert (out.ran, out.reused, out.failed) == (len(SPECS), 0, 0)
    assert list(out.table["key"]) == [s.key() for s in SPECS]
    assert (cache / "missions" / "demo-s1" / "mission.toml").is_file()
    assert (cache / "missions" / "demo-s1.alignment.npz").is_file()
    for s in SPECS:
        record = json.loads((cache / "runs" / f"{s.key()}.json").read_text())
        assert record["spec"] == s.as_dict() and record["key"] == s.key()
    t = out.table
    assert np.all(t["rmse_m"] > 0) and np.all(t["relative_rmse_pct"] > 0)
    assert np.all(t["distance_m"] > 400) and np.all(t["dvl_used"] > 0)
    for m in NEES_METRICS:  # the simulator's truth has position, velocity and attitude
        assert np.all(np.isfinite(t[m])) and np.all(t[m] > 0), m
        assert all(record_has(cache, s, m) for s in SPECS), m


def record_has(cache: Path, spec: RunSpec, metric: str) -> bool:
    record = json.loads((cache / "runs" / f"{spec.key()}.json").read_text())
    return isinstance(record["metrics"].get(metric), float)


def test_second_sweep_runs_nothing(serial: tuple[Path, SweepOutcome]) -> None:
    cache, first = serial
    files = sorted((cache / "runs").iterdir())
    mtimes = [p.stat().st_mtime_ns for p in files]
    again = run_sweep([*SPECS, SPECS[0]], cache, jobs=1, progress=False)
    assert (again.ran, again.reused, again.failed) == (0, len(SPECS), 0)
    assert sorted((cache / "runs").iterdir()) == files
    assert [p.stat().st_mtime_ns for p in files] == mtimes
    pd.testing.assert_frame_equal(_metrics(again.table), _metrics(first.table))


def test_q_reaches_the_gate(serial: tuple[Path, SweepOutcome]) -> None:
    t = serial[1].table.set_index("key")
    low, high, vb_gated, vb = (t.loc[s.key()] for s in SPECS[:4])
    assert low["gate_q"] == 200.0 and high["gate_q"] == 2600.0
    assert low["dvl_rejected"] > high["dvl_rejected"] > 0
    assert vb_gated["gated"] and vb_gated["dvl_rejected"] > 0
    assert not vb["gated"] and math.isnan(vb["gate_q"])
    # Ungated VB's only rejections are the guard's (gross errors: 100 × the nominal R).
    assert vb["dvl_rejected"] < vb_gated["dvl_rejected"]


def test_process_noise_scale_reaches_q(serial: tuple[Path, SweepOutcome]) -> None:
    t = serial[1].table.set_index("key")
    small, large = (t.loc[s.key()] for s in SPECS[4:])
    assert small["q_scale"] == 0.01 and large["q_scale"] == 100.0
    assert small["gate_q"] == large["gate_q"] == 600.0  # MESKF's default q
    assert abs(small["rmse_m"] - large["rmse_m"]) > 1e-3 * small["rmse_m"]


def test_failed_run_is_reported_not_cached(
    serial: tuple[Path, SweepOutcome], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = _copy_missions(serial[0], tmp_path / "cache")
    spec = RunSpec("demo", 1, "maeskf")

    def boom(*args: object) -> dict[str, float]:
        raise RuntimeError("diverged")

    monkeypatch.setattr(sweep_runner, "run_one", boom)
    out = run_sweep([spec], cache, jobs=1, progress=False, keep_missions=False)
    assert (out.ran, out.failed) == (0, 1) and "diverged" in out.errors[spec.key()]
    assert out.table["error"].iloc[0].startswith("RuntimeError") and out.table["rmse_m"].isna()[0]
    assert not (cache / "runs" / f"{spec.key()}.json").exists()
    assert not (cache / "missions" / "demo-s1").exists()  # keep_missions=False
    assert (cache / "missions" / "demo-s1.alignment.npz").is_file()


# --- statistics --------------------------------------------------------------------------------


def _hand_table() -> pd.DataFrame:
    rows = []
    values = {"meskf": [4.0, 6.0, 8.0], "vb": [2.0, 6.0, 5.0], "oracle": [1.0, 3.0, 5.0]}
    for f, v in values.items():
        for seed, r in enumerate(v, start=1):
            rows.append({"preset": "p", "seed": seed, "filter": f, "rmse_m": r,
                         "relative_rmse_pct": r / 10.0, "error": None})  # fmt: skip
    rows.append({"preset": "p", "seed": 4, "filter": "vb", "rmse_m": math.nan,
                 "relative_rmse_pct": math.nan, "error": "boom"})  # fmt: skip
    return pd.DataFrame(rows)


def test_summarize_by_hand() -> None:
    s = summarize(_hand_table()).set_index("filter")
    assert "mean_nees_position_mean" not in s.columns  # the table has no NEES
    assert s.loc["meskf", "n"] == 3 and s.loc["vb", "n"] == 3  # the failed run left out
    assert s.loc["meskf", "rmse_m_mean"] == pytest.approx(6.0)
    assert s.loc["meskf", "rmse_m_std"] == pytest.approx(2.0)  # sample std of 4, 6, 8
    assert s.loc["vb", "rmse_m_median"] == 5.0
    assert (s.loc["vb", "rmse_m_min"], s.loc["vb", "rmse_m_max"]) == (2.0, 6.0)
    assert s.loc["vb", "relative_rmse_pct_mean"] == pytest.approx(13.0 / 30.0)


def test_summarize_nees_by_hand() -> None:
    t = _hand_table()
    t["mean_nees_position"] = [3.0, 4.0, 5.0, 1.0, 2.0, 3.0, 30.0, 40.0, 50.0, math.nan]
    t["nees_attitude_in_95"] = [0.9, 0.8, 0.7, 1.0, 1.0, 1.0, math.nan, 0.5, 0.5, math.nan]
    s = summarize(t).set_index("filter")
    assert s.loc["meskf", "mean_nees_position_mean"] == pytest.approx(4.0)
    assert s.loc["vb", "mean_nees_position_median"] == pytest.approx(2.0)
    assert s.loc["meskf", "nees_attitude_in_95_mean"] == pytest.approx(0.8)
    assert math.isnan(s.loc["oracle", "nees_attitude_in_95_mean"])  # a run without it
    assert s.loc["vb", "rmse_m_mean"] == pytest.approx(13.0 / 3.0)  # unchanged


def test_paired_comparison_by_hand() -> None:
    c = paired_comparison(_hand_table(), "vb").set_index("other")
    # vb vs meskf: 2<4 win, 6=6 tie (½), 5<8 win
    assert c.loc["meskf", "n"] == 3 and c.loc["meskf", "wins"] == 2.5
    assert c.loc["meskf", "win_rate"] == pytest.approx(2.5 / 3)
    assert c.loc["meskf", "ratio_mean"] == pytest.approx((0.5 + 1.0 + 5.0 / 8.0) / 3)
    assert c.loc["meskf", "ratio_median"] == pytest.approx(5.0 / 8.0)
    # vb vs oracle: 2>1, 6>3, 5=5 (½)
    assert c.loc["oracle", "wins"] == 0.5
    assert c.loc["oracle", "ratio_of_means"] == pytest.approx(13.0 / 9.0)
    with pytest.raises(ValueError):
        paired_comparison(pd.concat([_hand_table(), _hand_table()]))


def test_curve_and_spread_by_hand() -> None:
    t = pd.DataFrame(
        {
            "preset": "p",
            "seed": [1, 2, 1, 2, 1],
            "filter": "meskf",
            "q": [200.0, 200.0, 400.0, 400.0, math.nan],
            "rmse_m": 1.0,
            "relative_rmse_pct": [1.0, 3.0, 0.5, 0.5, 9.0],
            "error": None,
        }
    )
    c = curve(t, "q")
    assert c["q"].tolist() == [200.0, 400.0] and c["mean"].tolist() == [2.0, 0.5]
    assert c["min"].tolist() == [1.0, 0.5] and c["max"].tolist() == [3.0, 0.5]
    s = curve_spread(c, "q").iloc[0]
    assert (s["best_at"], s["worst_at"], s["worst_over_best"]) == (400.0, 200.0, 4.0)


def test_figures(serial: tuple[Path, SweepOutcome], tmp_path: Path) -> None:
    t = serial[1].table
    for plot in (plot_q_sweep, plot_process_noise, plot_monte_carlo):
        path = plot(t, tmp_path / f"{plot.__name__}.png")
        assert path.stat().st_size > 1000


# --- CLI ---------------------------------------------------------------------------------------


def test_cli_json_prints_one_object(serial: tuple[Path, SweepOutcome], tmp_path: Path) -> None:
    cache = _copy_missions(serial[0], tmp_path / "cache")
    args = ["sweep", "seeds", "demo", "--seeds", "1", "--filters", "meskf,vb", "--cache",
            str(cache), "--jobs", "1", "--json", "--no-progress"]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["sweep"] == "seeds" and doc["runs"] == 2 and doc["failed"] == 0
    assert {r["filter"] for r in doc["summary"]} == {"meskf", "vb"}
    for r in doc["summary"]:
        assert r["mean_nees_position_mean"] > 0 and 0 <= r["nees_attitude_in_95_mean"] <= 1
    assert doc["comparison"][0]["other"] == "meskf"
    for f in doc["files"].values():
        assert Path(f).is_file()
    # The output folder is written whole: a second sweep into it needs --force.
    refused = runner.invoke(app, args)
    assert refused.exit_code == 2 and "--force" in refused.output
    again = runner.invoke(app, [*args, "--force"])
    assert json.loads(again.stdout)["reused"] == 2
    table = runner.invoke(app, [*(a for a in args if a != "--json"), "--force"])
    assert table.exit_code == 0, table.output
    assert "Consistency: NEES" in table.stdout and "[0.216, 9.348]" in table.stdout


@pytest.mark.parametrize(
    "args",
    [
        ["seeds", "atlantis"],
        ["seeds", "demo", "--seeds", "5-1"],
        ["seeds", "demo", "--jobs", "0"],
        ["seeds", "demo", "--filters", "kalman"],
        ["q", "demo", "--q", "abc"],
        ["q", "demo", "--q", "200:2600"],
        ["process-noise", "demo", "--scales", "0:10:3"],
    ],
)
def test_cli_bad_arguments_exit_2(args: list[str], tmp_path: Path) -> None:
    result = runner.invoke(app, ["sweep", *args, "--cache", str(tmp_path / "c")])
    assert result.exit_code == 2, result.output
    assert "error" in result.output
    assert not (tmp_path / "c").exists()


def test_config_overrides_are_part_of_the_spec_and_applied() -> None:
    """A run's mission-config overrides change its key (not the paper's runs' keys) and reach
    the mission the filter runs on."""
    plain = RunSpec("demo", 1, "vb")
    over = RunSpec("demo", 1, "vb", config=(("filter.vb_rho", 0.5),))
    assert "config" not in plain.as_dict() and over.as_dict()["config"] == {"filter.vb_rho": 0.5}
    assert over.key() != plain.key()
    assert RunSpec("demo", 1, "vb", config=(("b.x", 1), ("a.y", 2))).config == (
        ("a.y", 2),
        ("b.x", 1),
    )
    cfg = parse_config(config_dict())
    assert with_overrides(cfg, over.config).filter.vb_rho == 0.5
    with pytest.raises(MissionError, match="nowhere"):
        with_overrides(cfg, [("nowhere.x", 1)])
    with pytest.raises(MissionError):
        with_overrides(cfg, [("filter.vb_rho", 2.0)])  # validated again: rho <= 1


def test_a_dvls_own_gate_q_is_reported_and_not_swept_over(
    serial: tuple[Path, SweepOutcome],
) -> None:
    """The DVL's own ``gate_q`` wins over the filter's q (FilterSettings.gate): a run with it
    reports that q, and a swept q beside it is refused (up to 0.4.7 the run gated at the DVL's
    900 while its row said the swept 200)."""
    from adaptnav.experiments.cache import load_prepared

    mission, initial = load_prepared(serial[0], "demo-s1")
    own = (("sensors.dvl.gate_q", 900.0),)
    row = sweep_runner.run_one(mission, initial, RunSpec("demo", 1, "meskf", config=own))
    assert row["gate_q"] == 900.0
    with pytest.raises(ValueError, match=r"q = 200: the mission's sensors\.dvl\.gate_q = 900"):
        sweep_runner.run_one(mission, initial, RunSpec("demo", 1, "meskf", q=200.0, config=own))


def test_an_out_folder_holding_the_cache_is_refused_before_any_work(
    serial: tuple[Path, SweepOutcome], tmp_path: Path
) -> None:
    """The sweep writes its runs into the cache while --out waits in a temporary folder: with
    the cache inside --out, --force replaced --out whole and the cache with it (up to 0.4.7:
    exit 0, every cached run and mission gone), and without it the sweep ran to the end and
    failed there (exit 2, the output left in a hidden temporary)."""
    out = tmp_path / "results"
    cache = _copy_missions(serial[0], out / "cache")
    args = ["sweep", "seeds", "demo", "--seeds", "1", "--filters", "meskf", "--jobs", "1",
            "--no-progress", "--quiet"]  # fmt: skip
    # the cache inside --out, --out the cache itself, --out its folder of runs
    for where in (cache, out, cache / "runs", cache / "missions" / "x"):
        res = runner.invoke(app, [*args, "--cache", str(cache), "--out", str(where), "--force"])
        assert res.exit_code == 2, res.output
        assert "is or holds the cache" in res.output
        assert (cache / "missions" / "demo-s1" / "mission.toml").is_file()
        assert not (cache / "runs").exists()  # refused before any run
    fresh = tmp_path / "fresh"
    res = runner.invoke(app, [*args, "--cache", str(fresh / "c"), "--out", str(fresh)])
    assert res.exit_code == 2 and "is or holds the cache" in res.output
    assert not fresh.exists() and not list(tmp_path.glob(".*tmp*"))


def test_a_mission_aligned_by_another_version_is_made_again(
    serial: tuple[Path, SweepOutcome], tmp_path: Path
) -> None:
    """The runs' keys hold the package version, the missions and their alignments did not: a
    cache left by another version gave this version's runs its simulated mission and its
    alignment (up to 0.4.7), filed as this version's. Here an alignment without a version (as
    every earlier one was written), its start moved 60 m north, stands for another version's."""
    from adaptnav.experiments.cache import mission_ready

    cache = _copy_missions(serial[0], tmp_path / "cache")
    path = cache / "missions" / "demo-s1.alignment.npz"
    assert mission_ready(cache, "demo-s1")
    with np.load(path) as z:
        x0, P0, t0 = np.array(z["x0"]), np.array(z["P0"]), np.array(z["t0"])
    x0[0] += 60.0 / 6.4e6
    np.savez(path, x0=x0, P0=P0, t0=t0)
    assert not mission_ready(cache, "demo-s1")
    spec = SPECS[3]  # VB-MAESKF at its defaults
    again = run_sweep([spec], cache, jobs=1, progress=False)
    assert mission_ready(cache, "demo-s1")
    pd.testing.assert_frame_equal(_metrics(again.table), _metrics(serial[1].rows([spec])))
