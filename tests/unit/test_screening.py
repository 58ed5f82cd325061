"""Stuck-reading detection at load (issue 12; docs/robustness.md, "Stuck readings").

The rule (:mod:`adaptnav.mission.screening`) on hand-built series and against a plain reference
walk, its settings in ``mission.toml``, and a run whose DVL freezes: the frozen readings are in
the ledger with their reason, the rest is used.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pydantic
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from adaptnav.cli import app
from adaptnav.mission import MissionError, load_mission, screening
from adaptnav.mission.config import SENSOR_KINDS, STUCK_DEFAULTS, SensorConfig, parse_config
from adaptnav.mission.screening import (
    AFTER_GAP_READINGS,
    SPIKE_HALF_WINDOW,
    STUCK_MIN_READINGS,
    after_gap_mask,
    spike_mask,
    stuck_mask,
    stuck_runs,
    thinned_mask,
)
from helpers import badinput

SEED = 12
DVL_COLUMNS = ["vx_m_s", "vy_m_s", "vz_m_s"]


def _reference_runs(
    t: np.ndarray, z: np.ndarray, res: np.ndarray, stuck_s: float, need: int
) -> list[tuple[int, int]]:
    """The rule walked reading by reading, as written in docs/robustness.md."""
    runs, a, n = [], 0, len(t)
    while a < n:
        if not np.all(np.isfinite(z[a])):
            a += 1
            continue
        b = a
        while (
            b + 1 < n and np.all(np.isfinite(z[b + 1])) and np.all(np.abs(z[b + 1] - z[a]) <= res)
        ):
            b += 1
        if b - a + 1 >= max(need, 2) and t[b] - t[a] >= stuck_s:
            runs.append((a, b))
        a = b + 1
    return runs


def _noisy(n: int, d: int = 3, sigma: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(SEED)
    return np.arange(n, dtype=float), rng.normal(0.0, sigma, (n, d))


# --- the rule ---------------------------------------------------------------------------------


def test_a_run_just_shorter_than_the_limit_is_not_caught_a_longer_one_is() -> None:
    t, z = _noisy(100)
    z[20:30] = z[20]  # 20..29: 9 s at 1 Hz
    assert not stuck_mask(t, z, 1e-5, 9.5).any()
    mask = stuck_mask(t, z, 1e-5, 9.0)  # the limit is inclusive
    assert np.flatnonzero(mask).tolist() == list(range(21, 30))
    assert stuck_runs(t, z, 1e-5, 9.0).tolist() == [[20, 29]]


def test_the_first_reading_of_a_run_is_kept() -> None:
    """The freeze repeats the last good value: that first one is genuine."""
    t, z = _noisy(50)
    z[10:40] = z[10]
    mask = stuck_mask(t, z, 1e-5, 10.0)
    assert not mask[10] and mask[11:40].all() and mask.sum() == 29


def test_a_nan_breaks_a_run() -> None:
    t, z = _noisy(60)
    z[10:40] = z[10]
    z[25, 1] = math.nan  # 29 s frozen, in two halves of 14 and 13 s
    assert stuck_runs(t, z, 1e-5, 13.0).tolist() == [[10, 24], [26, 39]]
    assert stuck_runs(t, z, 1e-5, 14.0).tolist() == [[10, 24]]
    assert not stuck_mask(t, z, 1e-5, 15.0).any()
    z[25, 1] = math.inf
    assert not stuck_mask(t, z, 1e-5, 15.0).any()


def test_the_resolution_is_per_column() -> None:
    t, z = _noisy(60, d=2)
    z[10:40, 0] = 5.0
    z[10:40, 1] = 2.0 + 0.009 * np.sin(np.arange(30))  # moves by < 0.01, > 0.001
    assert np.flatnonzero(stuck_mask(t, z, [1e-6, 0.01], 20.0)).tolist() == list(range(11, 40))
    assert not stuck_mask(t, z, [1e-6, 0.001], 20.0).any()
    assert not stuck_mask(t, z, 1e-6, 20.0).any()


def test_every_component_must_stay_put() -> None:
    t, z = _noisy(60)
    z[10:40, :2] = z[10, :2]  # x and y frozen, z still moving
    assert not stuck_mask(t, z, 1e-5, 10.0).any()


def test_the_run_is_anchored_at_its_first_reading_not_a_drift() -> None:
    """Steps within the resolution that add up beyond it are a slow change, not a freeze."""
    t = np.arange(100, dtype=float)
    z = (0.4 * np.arange(100))[:, None]  # 0.4 per step, resolution 1
    runs = stuck_runs(t, z, 1.0, 1.0, min_readings=2)
    assert runs.tolist() == [[3 * k, 3 * k + 2] for k in range(33)]
    assert not stuck_mask(t, z, 1.0, 3.0).any()


def test_too_few_readings_make_no_run() -> None:
    t = np.array([0.0, 100.0, 101.0, 300.0])
    z = np.array([[1.0], [1.0], [2.0], [2.0]])  # equal pairs across data gaps
    assert not stuck_mask(t, z, 0.0, 60.0).any()
    assert STUCK_MIN_READINGS == 3
    assert stuck_mask(t, z, 0.0, 60.0, min_readings=2).tolist() == [False, True, False, True]


def test_zero_duration_finds_nothing_and_bad_arguments_are_refused() -> None:
    t, z = _noisy(20)
    z[:] = 1.0
    assert not stuck_mask(t, z, 1e-5, 0.0).any()
    assert stuck_runs(t, z, 1e-5, 0.0).shape == (0, 2)
    with pytest.raises(ValueError, match="resolution"):
        stuck_runs(t, z, -1.0, 5.0)
    with pytest.raises(ValueError, match="increase"):
        stuck_runs(np.zeros(20), z, 1e-5, 5.0)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    st.integers(10, 400),
    st.integers(1, 3),
    st.floats(1e-4, 10.0),
    st.floats(0.1, 100.0),
    st.integers(0, 2**32 - 1),
)
def test_a_noisy_signal_is_never_caught(
    n: int, d: int, sigma: float, stuck_s: float, seed: int
) -> None:
    """Noise well above the resolution: no two readings stay within it for long."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 2.0, n))
    z = rng.normal(0.0, sigma, (n, d)) + rng.uniform(-100.0, 100.0, d)
    assert not stuck_mask(t, z, 1e-3 * sigma, stuck_s).any()


@settings(max_examples=150, deadline=None, derandomize=True)
@given(
    st.integers(1, 250),
    st.integers(1, 3),
    st.sampled_from([0.0, 0.5, 1.0]),
    st.sampled_from([0.0, 0.25, 1.0, 1.5, 2.5]),
    st.sampled_from([0.5, 3.0, 20.0]),
    st.integers(1, 5),
    st.integers(0, 2**32 - 1),
)
def test_the_vectorised_rule_is_the_plain_walk(
    n: int, d: int, level: float, res: float, stuck_s: float, need: int, seed: int
) -> None:
    """Piecewise-constant levels, jitter of about the resolution, NaNs, irregular times."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.1, 2.0, n))
    z = rng.integers(0, 4, (n, d)) * level
    for i in np.flatnonzero(rng.random(n) < rng.uniform(0.0, 0.95)):
        if i:
            z[i] = z[i - 1]
    z = z + rng.choice([0.0, 0.3 * res, 0.9 * res]) * rng.uniform(-1.0, 1.0, (n, d))
    z[rng.random(n) < 0.03] = math.nan
    resolution = np.full(d, res)
    got = stuck_runs(t, z, resolution, stuck_s, need)
    assert [tuple(r) for r in got.tolist()] == _reference_runs(t, z, resolution, stuck_s, need)
    mask = stuck_mask(t, z, resolution, stuck_s, need)
    expected = np.zeros(n, dtype=bool)
    for a, b in got.tolist():
        expected[a + 1 : b + 1] = True
    assert mask.tolist() == expected.tolist()


# --- settings ---------------------------------------------------------------------------------


def _sensor(**extra: Any) -> SensorConfig:
    return SensorConfig(kind="dvl", file="dvl.csv", sigma=(0.02, "m/s"), **extra)


def test_defaults_per_kind_and_overrides() -> None:
    assert set(STUCK_DEFAULTS) == set(SENSOR_KINDS)
    dvl = _sensor()
    assert dvl.stuck_duration_s() == STUCK_DEFAULTS["dvl"].stuck_s > 0.0
    default = STUCK_DEFAULTS["dvl"].resolution
    assert dvl.resolution_si().tolist() == [default[c] for c in DVL_COLUMNS]
    assert _sensor(stuck_s=0.0).stuck_duration_s() == 0.0
    assert _sensor(resolution=1e-3).resolution_si().tolist() == [1e-3] * 3
    per = _sensor(resolution={"vz_m_s": 0.01}).resolution_si()
    assert per.tolist() == [STUCK_DEFAULTS["dvl"].resolution["vx_m_s"]] * 2 + [0.01]
    for kind in ("gnss", "nhc"):  # off: legitimately constant (static hold; zero by design)
        assert STUCK_DEFAULTS[kind].stuck_s == 0.0
    for kind in SENSOR_KINDS:
        res = STUCK_DEFAULTS[kind].resolution
        assert all(0.0 < v < 1e-3 for v in res.values()), kind


def test_nhc_is_off_by_default_its_zeros_would_all_be_caught() -> None:
    cfg = SensorConfig(kind="nhc", file="nhc.csv", sigma=(0.1, "m/s"))
    assert cfg.stuck_duration_s() == 0.0
    t = np.arange(0.0, 600.0, 0.1)
    assert stuck_mask(t, np.zeros((t.size, 2)), cfg.resolution_si(), 60.0).sum() == t.size - 1


def _doc(**dvl: Any) -> dict[str, Any]:
    """A minimal mission.toml document with a DVL carrying ``dvl``'s keys."""
    return {
        "mission": {"name": "m"},
        "imu": {
            "file": "imu.csv",
            "rate_hz": 100.0,
            "noise": {"arw": [0.1, "deg/sqrt(h)"], "vrw": [50, "ug/sqrt(Hz)"]},
        },
        "sensors": {"dvl": {"kind": "dvl", "file": "dvl.csv", "sigma": [0.02, "m/s"], **dvl}},
        "initial": {"lat_deg": 26.8, "lon_deg": 56.0},
    }


def test_settings_are_written_and_read_back() -> None:
    cfg = parse_config(_doc(stuck_s=20.0, resolution={"vz_m_s": 1e-3}))
    assert parse_config(tomllib.loads(cfg.dump_toml())) == cfg
    dvl = cfg.sensors["dvl"]
    assert dvl.stuck_duration_s() == 20.0
    assert dvl.resolution_si().tolist() == [STUCK_DEFAULTS["dvl"].resolution["vx_m_s"]] * 2 + [1e-3]


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        ({"stuck_s": -1.0}, "sensors.dvl.stuck_s"),
        ({"stuck_s": math.nan}, "sensors.dvl.stuck_s"),
        ({"resolution": -0.1}, "sensors.dvl.resolution"),
        ({"resolution": {"depth_m": 0.01}}, "resolution.depth_m: not a column of a dvl sensor"),
        ({"resolution": {"vx_m_s": -0.01}}, "sensors.dvl.resolution.vx_m_s"),
        ({"resolution": "fine"}, "sensors.dvl.resolution"),
    ],
)
def test_bad_settings_are_errors_naming_the_key(extra: dict[str, Any], words: str) -> None:
    with pytest.raises(MissionError) as err:
        parse_config(_doc(**extra))
    assert words in str(err.value)


# --- a run whose DVL freezes --------------------------------------------------------------------

runner = CliRunner()


FREEZE_FROM_S = 35.0
"""Under way (the alignment ends at 20 s), DVL at 3 Hz."""
FROZEN = 45
"""DVL readings frozen: about 15 s, longer than the DVL default."""


def _freeze_dvl(mission: Path, value: list[float] | None = None) -> list[int]:
    """Repeat one DVL reading (or ``value``) FROZEN times; returns the frozen rows."""
    dvl = badinput.read(mission, "dvl")
    k = int(np.flatnonzero(dvl["t_s"].to_numpy() > FREEZE_FROM_S)[0])
    rows = list(range(k, k + FROZEN))
    dvl.loc[rows, DVL_COLUMNS] = value if value is not None else dvl.loc[k, DVL_COLUMNS].to_numpy()
    badinput.write(mission, "dvl", dvl)
    return rows


def _set(mission: Path, line: str) -> None:
    """Set ``key = value`` in ``[sensors.dvl]`` (replacing the key's line if it has one)."""
    toml = (mission / "mission.toml").read_text()
    section = '[sensors.dvl]\nkind = "dvl"\n'
    assert section in toml
    head, _, rest = toml.partition(section)
    body, sep, tail = rest.partition("\n\n")
    key = line.split("=")[0].strip()
    body = "\n".join(k for k in body.splitlines() if k.split("=")[0].strip() != key)
    (mission / "mission.toml").write_text(f"{head}{section}{line}\n{body}{sep}{tail}")


def _run(mission: Path, out: Path) -> pd.DataFrame:
    res = runner.invoke(app, ["run", str(mission), "--out", str(out)])
    assert res.exit_code == 0, res.output
    ledger = pd.read_parquet(out / "ledger.parquet")
    return ledger[ledger["sensor"] == "dvl"].set_index("row")


def test_a_frozen_dvl_is_dropped_with_its_reason_and_the_rest_used(
    mission: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """On the code before the detection every frozen reading was used."""
    rows = _freeze_dvl(mission)
    dvl = _run(mission, tmp_path / "run")
    t = badinput.read(mission, "dvl")["t_s"]
    stuck = dvl["reason"].fillna("").str.startswith("stuck: ")
    assert sorted(dvl.index[stuck]) == rows[1:]  # the first of the run is kept
    span = t[rows[-1]] - t[rows[0]]
    assert set(dvl.loc[rows[1:], "reason"]) == {
        f"stuck: vx_m_s, vy_m_s, vz_m_s unchanged within 1e-05 m/s for {span:.1f} s "
        f"(t = {t[rows[0]]:.3f} .. {t[rows[-1]]:.3f} s)"
    }
    assert (dvl.loc[rows[1:], "fate"] == "dropped").all()
    assert dvl.loc[rows[0], "fate"] == "used"
    others = dvl[(dvl["t"] > 20.5) & ~dvl.index.isin(rows[1:])]  # under way: used
    fates = set(others["fate"] + ": " + others["reason"].fillna(""))
    # a simulated dropout; the simulator's outliers the guard rejects (docs/robustness.md)
    assert "used: " in fates
    assert fates <= {
        "used: ",
        "dropped: invalid reading (non-finite)",
        "rejected: guard chi2 (nominal R)",
    }
    assert sorted(dvl.index) == list(range(len(t)))  # every reading has one fate
    assert "dropped (stuck: vx_m_s" in caplog.text
    assert f"{len(rows) - 1 - 10} more: stuck" in caplog.text  # 10 logged, then a summary


def test_stuck_s_zero_switches_the_detection_off(mission: Path, tmp_path: Path) -> None:
    rows = _freeze_dvl(mission)
    _set(mission, "stuck_s = 0.0")
    dvl = _run(mission, tmp_path / "run")
    assert not dvl["reason"].fillna("").str.startswith("stuck").any()
    assert (dvl.loc[rows, "fate"] == "used").all()


def test_stuck_settings_from_mission_toml(mission: Path) -> None:
    rows = _freeze_dvl(mission)
    _set(mission, "stuck_s = 30.0")  # longer than the freeze
    assert not any(d.reason.startswith("stuck") for d in load_mission(mission).dropped)
    _set(mission, "resolution = { vx_m_s = 0.5 }")  # toml now has both keys
    dropped = [d for d in load_mission(mission).dropped if d.reason.startswith("stuck")]
    assert not dropped
    toml = (mission / "mission.toml").read_text().replace("stuck_s = 30.0\n", "")
    (mission / "mission.toml").write_text(toml)
    dropped = [d for d in load_mission(mission).dropped if d.reason.startswith("stuck")]
    assert [d.row for d in dropped] == rows[1:]
    assert "within (0.5 m/s, 1e-05 m/s, 1e-05 m/s)" in dropped[0].reason


def test_an_all_zero_dvl_is_left_to_zero_is_lost(mission: Path) -> None:
    """Zeros on every axis are a lost lock or a vehicle resting on the bottom: the user says
    which with ``zero_is_lost``, the stuck rule does not decide it."""
    rows = _freeze_dvl(mission, [0.0, 0.0, 0.0])
    assert not any(d.reason.startswith("stuck") for d in load_mission(mission).dropped)
    _set(mission, "zero_is_lost = true")
    lost = [d.row for d in load_mission(mission).dropped if "bottom lock lost" in d.reason]
    assert lost == rows


# --- isolated spikes (docs/robustness.md, 'Spikes') ----------------------------------------


def _smooth_dvl(n: int, seed: int, sigma: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """n readings at 3 Hz of a vehicle speeding up and turning, with white noise ``sigma``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 3.0
    z = np.column_stack([1.0 + 0.5 * np.tanh((t - t[-1] / 2) / 20), 0.2 * np.sin(t / 15), 0 * t])
    return t, z + rng.normal(0.0, sigma, (n, 3))


def test_isolated_spikes_are_caught_and_nothing_else() -> None:
    t, z = _smooth_dvl(3000, SEED)
    spikes = [100, 777, 1501, 2999]  # the last reading has neighbours on one side only
    z[spikes[0], 0] += 1.0
    z[spikes[1], 1] -= 2.0
    z[spikes[2]] += [1.5, -1.5, 3.0]
    z[spikes[3], 2] += 1.2
    got = spike_mask(t, z, 10.0, np.full(3, 0.048), 1 / 3)
    assert np.flatnonzero(got).tolist() == spikes


def test_a_step_or_a_burst_is_not_an_isolated_spike() -> None:
    """A step in speed is a change, not a spike: monotonic within the window, each reading is
    its window's median. A burst as long as the half window is no isolated spike either: it is
    the guard's (and the filter's) to judge."""
    t, z = _smooth_dvl(600, SEED)
    z[300:, 0] += 1.0
    burst = slice(100, 100 + SPIKE_HALF_WINDOW + 1)
    z[burst, 1] += 2.0
    assert not spike_mask(t, z, 10.0, np.full(3, 0.048), 1 / 3).any()


def test_a_spike_just_after_a_gap_is_judged_by_the_readings_after_the_gap() -> None:
    """The readings on the far side of a gap are no neighbours: 300 s apart, the vehicle's
    velocity has changed (here by 1 m/s), and the first reading after the gap, a spike, is
    judged by the ones after it (robust's worst faulted run, docs/robustness.md)."""
    t, z = _smooth_dvl(3000, SEED)
    keep = np.ones(3000, dtype=bool)
    keep[1000:1900] = False
    z[1900:, 0] += 1.0
    z[1900, 1] += 1.5
    got = spike_mask(t[keep], z[keep], 10.0, np.full(3, 0.048), 1 / 3)
    assert np.flatnonzero(keep)[got].tolist() == [1900]


def test_gaussian_noise_is_left_alone() -> None:
    """60 000 readings of white noise 10× the floor (the simulated trials' noisy segments):
    at 10 MADs fewer than 3 in 10 000 are flagged (7e-5 measured; with 7 readings in the
    window instead of 15: 7e-3)."""
    rng = np.random.default_rng(SEED)
    t = np.arange(60_000) / 3.0
    z = rng.normal(0.0, 0.1, (60_000, 3))
    assert spike_mask(t, z, 10.0, np.full(3, 0.01), 1 / 3).mean() < 3e-4


def test_spikes_off_short_or_unknown() -> None:
    t, z = _smooth_dvl(50, SEED)
    z[20, 0] += 3.0
    floor = np.full(3, 0.048)
    assert not spike_mask(t, z, 0.0, floor, 1 / 3).any()  # off
    assert not spike_mask(t[:3], z[:3], 10.0, floor, 1 / 3).any()  # too few neighbours
    z[20, 1] = np.nan  # the other components are still evidence
    assert np.flatnonzero(spike_mask(t, z, 10.0, floor, 1 / 3)).tolist() == [20]
    z[20] = np.nan  # a reading with nothing finite is not a spike (the loader drops it)
    assert not spike_mask(t, z, 10.0, floor, 1 / 3).any()


def test_spikes_dropped_at_load_with_their_reason_when_asked(mission: Path) -> None:
    """Off by default: a spike reaches the filter; with ``spike_mads = 10`` in the DVL's section
    it is dropped at load with its reason (and so has its fate in the ledger)."""
    dvl = badinput.read(mission, "dvl")
    k = int(np.flatnonzero(dvl["t_s"].to_numpy() > FREEZE_FROM_S)[0])
    dvl.loc[k, "vy_m_s"] += 2.0
    badinput.write(mission, "dvl", dvl)
    assert not any(d.reason.startswith("spike:") for d in load_mission(mission).dropped)
    _set(mission, "spike_mads = 10.0")
    spikes = [d for d in load_mission(mission).dropped if d.reason.startswith("spike")]
    reasons = {d.reason for d in spikes if not d.reason.startswith("spike after a gap")}
    assert reasons == {"spike: more than 10 MADs from the median of its neighbours (spike_mads)"}
    # ours, and the simulator's own DVL outliers (the oracle's known outliers)
    outliers = set(np.flatnonzero(dvl["is_outlier"].to_numpy() != 0).tolist())
    found = {d.row for d in spikes}
    assert k in found and found - {k} <= outliers and found - {k}


def test_spike_mads_is_a_dvl_setting() -> None:
    base = {"kind": "depth", "file": "depth.csv", "sigma": [0.1, "m"]}
    with pytest.raises(pydantic.ValidationError, match="spike_mads: only for dvl sensors"):
        SensorConfig.model_validate({**base, "spike_mads": 10.0})
    with pytest.raises(pydantic.ValidationError, match="spike_mads"):
        SensorConfig.model_validate(
            {"kind": "dvl", "file": "dvl.csv", "sigma": [0.01, "m/s"], "spike_mads": -1.0}
        )


def test_spikes_are_judged_the_same_across_block_seams(monkeypatch: pytest.MonkeyPatch) -> None:
    """The readings are judged in blocks (memory): every block sees its neighbours across the
    seams, so the answer is the one-block answer."""
    t, z = _smooth_dvl(2000, SEED)
    rng = np.random.default_rng(SEED)
    z[rng.choice(2000, 40, replace=False), 1] += 2.0
    floor = np.full(3, 0.048)
    whole = spike_mask(t, z, 10.0, floor, 1 / 3)
    assert whole.sum() >= 38
    monkeypatch.setattr(screening, "_SPIKE_BLOCK", 7)
    np.testing.assert_array_equal(spike_mask(t, z, 10.0, floor, 1 / 3), whole)


# --- the first readings after a gap (docs/robustness.md, 'After a gap') ----------------------


def test_after_gap_marks_the_first_readings_after_each_long_gap() -> None:
    t = np.concatenate([np.arange(30.0), 50.0 + np.arange(3.0), 100.0 + np.arange(30.0)])
    got = np.flatnonzero(after_gap_mask(t, 10.0)).tolist()
    # 20 s after reading 29: readings 30-32, then 47 s after 32: the next seven
    assert got == [30, 31, 32, *range(33, 33 + AFTER_GAP_READINGS)]
    assert not after_gap_mask(t, 50.0).any()  # no gap that long
    assert not after_gap_mask(t, 0.0).any()  # off
    assert not after_gap_mask(t[:1], 1.0).any()


def test_judging_some_readings_gives_the_whole_tests_answer_for_them() -> None:
    """``judge`` only limits which readings are judged: each against the same neighbours."""
    t, z = _smooth_dvl(3000, SEED)
    rng = np.random.default_rng(SEED)
    keep = np.ones(3000, dtype=bool)
    for a in rng.choice(2900, 12, replace=False):
        keep[a : a + 40] = False  # gaps of about 13 s
    z[rng.choice(3000, 60, replace=False), 0] += 2.0
    t, z = t[keep], z[keep]
    floor = np.full(3, 0.048)
    whole = spike_mask(t, z, 10.0, floor, 1 / 3)
    after = after_gap_mask(t, 10.0)
    some = spike_mask(t, z, 10.0, floor, 1 / 3, judge=after)
    np.testing.assert_array_equal(some, whole & after)
    assert after.sum() >= 50 and whole.sum() >= 40 and some.sum() >= 1  # the case is exercised


GAP_S = 15.0
"""A DVL gap longer than the default ``after_gap_s`` (10 s), within the tiny mission."""


def _gap_and_spike(mission: Path, spike: float) -> int:
    """Remove 15 s of the DVL's readings under way and add ``spike`` m/s to the first
    reading after the gap; returns that reading's row in the (shortened) table."""
    dvl = badinput.read(mission, "dvl")
    t = dvl["t_s"].to_numpy()
    gone = (t > FREEZE_FROM_S) & (t < FREEZE_FROM_S + GAP_S)
    dvl = dvl[~gone].reset_index(drop=True)
    k = int(np.flatnonzero(dvl["t_s"].to_numpy() >= FREEZE_FROM_S + GAP_S)[0])
    dvl.loc[k, "vx_m_s"] += spike
    badinput.write(mission, "dvl", dvl)
    return k


def test_a_spike_after_a_gap_is_dropped_by_default(mission: Path, tmp_path: Path) -> None:
    """The DVL back after 15 s with a spike of 1.5 m/s on its first reading: dropped at load
    with its reason, by default; with ``after_gap_s = 0`` the filter takes it."""
    k = _gap_and_spike(mission, 1.5)
    dvl = _run(mission, tmp_path / "on")
    assert dvl.loc[k, "fate"] == "dropped"
    assert dvl.loc[k, "reason"] == (
        "spike after a gap: reading 1 after 15.3 s without one, more than 10 MADs from the "
        "median of the readings around it (after_gap_s)"
    )
    after = dvl.loc[k + 1 : k + AFTER_GAP_READINGS, "reason"].fillna("")
    assert not after.str.startswith("spike").any()  # (two are the simulator's NaN dropout)
    _set(mission, "after_gap_s = 0.0")
    assert _run(mission, tmp_path / "off").loc[k, "fate"] == "used"


def test_a_good_reading_after_a_gap_is_kept(mission: Path) -> None:
    """Without the spike nothing after the gap is dropped (the vehicle's own change of
    velocity over the gap is no spike: the readings after it agree)."""
    _gap_and_spike(mission, 0.0)
    assert not any(d.reason.startswith("spike") for d in load_mission(mission).dropped)


def test_after_gap_s_is_a_dvl_setting() -> None:
    base = {"kind": "depth", "file": "depth.csv", "sigma": [0.1, "m"]}
    with pytest.raises(pydantic.ValidationError, match="after_gap_s: only for dvl sensors"):
        SensorConfig.model_validate({**base, "after_gap_s": 10.0})
    cfg = SensorConfig.model_validate({"kind": "dvl", "file": "dvl.csv", "sigma": [0.01, "m/s"]})
    assert cfg.after_gap_duration_s() == 10.0
    assert SensorConfig.model_validate({**base}).after_gap_duration_s() == 0.0


# --- thinning (min_interval_s) ---------------------------------------------------------------


def test_thinning_keeps_the_first_of_each_stretch_and_readings_the_interval_apart() -> None:
    """Worked by hand, interval 1 s: 0 kept; 0.5 too soon; 1.0 kept (exactly 1 s); 2.0 kept;
    2.4 too soon; 3.1 kept. A reading that does not count (no finite value) is neither an
    anchor nor dropped: without 1.0 as an anchor, 2.0 is still 2 s after 0 and kept."""
    t = np.array([0.0, 0.5, 1.0, 2.0, 2.4, 3.1])
    assert np.flatnonzero(thinned_mask(t, 1.0)).tolist() == [1, 4]
    usable = np.array([True, True, False, True, True, True])
    assert np.flatnonzero(thinned_mask(t, 1.0, usable)).tolist() == [1, 4]
    # 1.5 s: 0 kept, 0.5 and 1.0 too soon, 2.0 kept, 2.4 and 3.1 (1.1 s after 2.0) too soon
    assert np.flatnonzero(thinned_mask(t, 1.5)).tolist() == [1, 2, 4, 5]
    assert not thinned_mask(t, 0.0).any() and not thinned_mask(t, math.nan).any()
    assert not thinned_mask(np.array([]), 1.0).any()


def _set_gps(mission: Path, line: str) -> None:
    toml = (mission / "mission.toml").read_text()
    section = '[sensors.gps]\nkind = "gnss"\n'
    assert section in toml
    (mission / "mission.toml").write_text(toml.replace(section, f"{section}{line}\n"))


def test_gnss_fixes_closer_than_min_interval_are_dropped_with_their_reason(
    mission: Path, tmp_path: Path
) -> None:
    """On the code before ``min_interval_s`` every fix was kept. The tiny mission's fixes
    come at 1 Hz: with 5 s, the fixes kept are 5 s apart or more, each dropped fix names its
    distance to the last one kept, and every fix has its fate in the run's ledger."""
    t = badinput.read(mission, "gps")["t_s"].to_numpy()
    assert not load_mission(mission).dropped
    _set_gps(mission, "min_interval_s = 5.0")
    m = load_mission(mission)
    kept = m.sensors["gps"].t
    assert kept[0] == t[0] and np.diff(kept).min() >= 5.0 and np.diff(kept).max() < 7.0
    thinned = {d.row: d.reason for d in m.dropped}
    assert len(thinned) == t.size - kept.size
    assert thinned[1] == (
        f"thinned: {t[1] - t[0]:.3f} s after the last reading kept, less than min_interval_s = 5 s"
    )
    res = runner.invoke(app, ["run", str(mission), "--out", str(tmp_path / "run")])
    assert res.exit_code == 0, res.output
    ledger = pd.read_parquet(tmp_path / "run" / "ledger.parquet")
    gps = ledger[ledger["sensor"] == "gps"].set_index("row")
    assert sorted(gps.index) == list(range(t.size))
    assert (gps.loc[sorted(thinned), "fate"] == "dropped").all()
    assert set(gps.loc[sorted(thinned), "reason"]) == set(thinned.values())


def test_min_interval_s_must_not_be_negative() -> None:
    base = {"kind": "gnss", "file": "gps.csv", "sigma": [2.0, "m"]}
    with pytest.raises(pydantic.ValidationError, match="min_interval_s"):
        SensorConfig.model_validate({**base, "min_interval_s": -1.0})
    assert SensorConfig.model_validate({**base, "min_interval_s": 120.0}).min_interval_s == 120.0


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    gaps=st.lists(st.floats(0.0, 5.0, allow_nan=False), min_size=1, max_size=60),
    interval=st.floats(0.1, 10.0, allow_nan=False),
    unusable=st.lists(st.booleans(), min_size=60, max_size=60),
)
def test_thinning_is_the_greedy_walk(
    gaps: list[float], interval: float, unusable: list[bool]
) -> None:
    """For any times and unusable readings: the kept usable readings are at least the interval
    apart, each dropped one is closer than that to the last kept before it, the first usable
    reading is kept, and an unusable one is never dropped."""
    t = np.cumsum(gaps)
    usable = ~np.array(unusable[: t.size])
    drop = thinned_mask(t, interval, usable)
    assert not np.any(drop & ~usable)
    kept = np.flatnonzero(usable & ~drop)
    assert np.all(np.diff(t[kept]) >= interval)
    if usable.any():
        assert kept.size and kept[0] == np.flatnonzero(usable)[0]
    for i in np.flatnonzero(drop).tolist():
        before = kept[kept < i]
        assert before.size and t[i] - t[before[-1]] < interval
