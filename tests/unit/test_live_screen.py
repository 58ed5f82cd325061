"""Screening one reading at a time (mission/live.py) against the loader screening the table.

A DVL table with every defect the loader screens (a repeated stamp, all-zero readings with
``zero_is_lost``, an implausible value, a NaN, ±inf, a stuck run and a quiet run too short to be
stuck) is loaded; pushed row by row, :class:`LiveScreen` must release exactly the readings the
loader kept and drop exactly its rows with its reasons: the loader is the reference.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav.mission import Mission, load_mission
from adaptnav.mission.live import OUT_OF_ORDER_REASON, LiveScreen, Reading
from adaptnav.mission.tables import DroppedRow
from helpers.missions import config_dict, imu_rates, write_dir


def _dvl(seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    n = 400
    t = 10.0 + 0.5 * np.arange(n)
    z = 1.0 + 0.05 * rng.standard_normal((n, 3))
    t[20] = t[19]  # repeated stamp
    z[30] = z[31] = 0.0  # lost bottom lock
    z[40, 0] = 50.0  # implausible speed
    z[50, 1] = math.nan
    z[60, 2] = math.inf  # ±inf are kept by the loader (the engine's), not implausible
    z[70, 0] = -math.inf
    z[100:250] = z[100]  # stuck for 74.5 s (the DVL's stuck_s: 10 s): 101..249 dropped
    z[300:316] = z[300] + 1e-6  # quiet for 7.5 s: too short, kept
    z[250] = z[100] + 1e-6  # within the resolution of the stuck run's first: one more
    return pd.DataFrame({"t_s": t, "vx_m_s": z[:, 0], "vy_m_s": z[:, 1], "vz_m_s": z[:, 2]})


def _as_the_loader(screen: LiveScreen, dvl: pd.DataFrame, m: Mission) -> list[DroppedRow]:
    """Push the table ``dvl`` row by row and close: the readings released must be the ones
    the loader kept of mission ``m``, the rows dropped its drops; returns them."""
    released: list[Reading] = []
    dropped: list[DroppedRow] = []
    for r, row in enumerate(dvl.to_numpy()):
        out, drops = screen.push(Reading(float(row[0]), row[1:].copy(), r))
        released += out
        dropped += drops
    out, drops = screen.close()
    released += out
    dropped += drops
    kept = m.sensors["dvl"]
    assert [r.row for r in released] == kept.rows.tolist()
    np.testing.assert_array_equal(np.array([r.z for r in released]), kept.z)
    expected = sorted((d.row, d.t, d.reason) for d in m.dropped)
    assert sorted((d.row, d.t, d.reason) for d in dropped) == expected
    return dropped


@pytest.mark.parametrize("seed", [1, 2])
def test_a_live_screen_keeps_and_drops_what_the_loader_does(tmp_path: Path, seed: int) -> None:
    cfg = config_dict()
    cfg["sensors"]["dvl"]["zero_is_lost"] = True
    dvl = _dvl(seed)
    m = load_mission(write_dir(tmp_path, cfg, {"imu.csv": imu_rates(), "dvl.csv": dvl}))
    screen = LiveScreen("dvl", m.config.sensors["dvl"])
    dropped = _as_the_loader(screen, dvl, m)
    expected = sorted((d.row, d.t, d.reason) for d in m.dropped)
    reasons = {d.reason.split(":")[0] for d in dropped}
    assert {"duplicate timestamp", "implausible", "stuck"} <= reasons
    assert len(expected) == 1 + 2 + 1 + 149 + 1


def test_a_run_of_unchanged_readings_is_held_until_it_ends(tmp_path: Path) -> None:
    m = load_mission(
        write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": _dvl(1)})
    )
    screen = LiveScreen("dvl", m.config.sensors["dvl"])
    v = np.array([1.0, 0.1, 0.0])
    out, _ = screen.push(Reading(1.0, v, 0))
    assert [r.row for r in out] == [0]  # a run's first reading is released at once
    assert screen.push(Reading(2.0, v.copy(), 1)) == ([], [])
    assert screen.held_from == 2.0
    out, drops = screen.push(Reading(3.0, v + 0.01, 2))  # the run ends, not stuck
    assert [r.row for r in out] == [1, 2] and drops == [] and screen.held_from == math.inf
    out, drops = screen.push(Reading(2.5, v, 3))
    assert out == [] and [d.reason for d in drops] == [OUT_OF_ORDER_REASON]


def _dvl_with_gaps(seed: int) -> pd.DataFrame:
    """600 readings at 2 Hz with a gap of rows removed, a gap of NaN rows and a short one,
    spikes just after each and mid-stream, and a stuck run just after the first gap."""
    rng = np.random.default_rng(seed)
    n = 600
    t = 10.0 + 0.5 * np.arange(n)
    z = 1.0 + 0.05 * rng.standard_normal((n, 3))
    z[:, 1] += np.linspace(0.0, 2.0, n)  # the vehicle speeding up sideways
    z[140] += [2.0, 0.0, 0.0]  # first after the removed rows (100..139)
    z[142, 2] -= 1.5  # third after it
    z[150:180] = z[150]  # stuck for 14.5 s
    z[300:330] = math.nan  # lost lock reported as NaN: a 15.5-s gap in the finite readings
    z[330, 1] += 3.0
    z[400, 0] += 2.0  # after 4.5 s without a reading: no gap (after_gap_s is 10 s)
    z[[250, 501, 555], 0] -= 2.0  # mid-stream spikes
    keep = np.ones(n, dtype=bool)
    keep[100:140] = False
    keep[395:400] = False
    return pd.DataFrame(
        {"t_s": t[keep], "vx_m_s": z[keep, 0], "vy_m_s": z[keep, 1], "vz_m_s": z[keep, 2]}
    )


@pytest.mark.parametrize(("seed", "mads"), [(1, None), (2, None), (1, 10.0), (3, 6.0)])
def test_the_spike_screens_live_drop_what_the_loader_does(
    tmp_path: Path, seed: int, mads: float | None
) -> None:
    """The first readings after a gap (by default) and, with ``spike_mads``, every reading,
    judged one at a time as the loader judges the table: the same verdicts, reasons and
    readings released."""
    cfg = config_dict()
    cfg["sensors"]["dvl"]["rate_hz"] = 2.0
    if mads is not None:
        cfg["sensors"]["dvl"]["spike_mads"] = mads
    dvl = _dvl_with_gaps(seed)
    m = load_mission(write_dir(tmp_path, cfg, {"imu.csv": imu_rates(), "dvl.csv": dvl}))
    screen = LiveScreen("dvl", m.config.sensors["dvl"], m.sensors["dvl"].period)
    dropped = _as_the_loader(screen, dvl, m)
    assert any(d.reason.startswith("stuck") for d in dropped)
    spikes = sum(d.reason.startswith("spike:") for d in dropped)
    after = sum(d.reason.startswith("spike after a gap") for d in dropped)
    assert (spikes, after >= 3) == (0, True) if mads is None else spikes >= 6


def test_a_spike_after_a_gap_is_held_then_dropped(tmp_path: Path) -> None:
    """A reading to be judged is held until the 7 readings after it have come (3.5 s at
    2 Hz), the readings behind it too; the stream's end judges what is left."""
    cfg = config_dict()
    m = load_mission(write_dir(tmp_path, cfg, {"imu.csv": imu_rates(), "dvl.csv": _dvl(1)}))
    screen = LiveScreen("dvl", m.config.sensors["dvl"], 0.5)
    v = np.array([1.0, 0.1, 0.0])
    for k in range(5):
        assert [r.row for r in screen.push(Reading(k * 0.5, v + 0.01 * k, k))[0]] == [k]
    assert screen.held_from == math.inf
    out, drops = screen.push(Reading(30.0, v + 2.0, 5))  # after 28 s: held
    assert (out, drops, screen.held_from) == ([], [], 30.0)
    for k in range(6, 13):
        out, drops = screen.push(Reading(30.0 + 0.5 * (k - 5), v + 0.01 * k, k))
    assert [d.row for d in drops] == [5] and drops[0].reason.startswith("spike after a gap")
    assert out == []  # the next six after the gap are judged too: each waits for its window
    out, drops = screen.close()
    assert [r.row for r in out] == list(range(6, 13)) and drops == []


@pytest.mark.parametrize(("seed", "gap"), [(1, 1.2), (2, 0.9), (3, 5.0)])
def test_thinning_live_drops_what_the_loader_does(tmp_path: Path, seed: int, gap: float) -> None:
    """``min_interval_s`` after the other screens, the first reading of a stretch kept: the
    same readings released and the same reasons, on the table with gaps, NaN, spikes and a
    stuck run (the stuck and spike screens decide first, so their drops are no anchors)."""
    cfg = config_dict()
    cfg["sensors"]["dvl"] |= {"rate_hz": 2.0, "min_interval_s": gap}
    dvl = _dvl_with_gaps(seed)
    m = load_mission(write_dir(tmp_path, cfg, {"imu.csv": imu_rates(), "dvl.csv": dvl}))
    screen = LiveScreen("dvl", m.config.sensors["dvl"], m.sensors["dvl"].period)
    dropped = _as_the_loader(screen, dvl, m)
    thinned = [d for d in dropped if d.reason.startswith("thinned: ")]
    assert thinned and any(d.reason.startswith("stuck") for d in dropped)
    kept = m.sensors["dvl"]
    finite = np.any(np.isfinite(kept.z), axis=1)
    assert np.diff(kept.t[finite]).min() >= gap
