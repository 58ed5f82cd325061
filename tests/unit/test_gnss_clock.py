"""A GNSS's stamps dated from its positions against the DVL's dead-reckoned track
(mission/gnss_clock.py) and the load error it gives: docs/robustness.md, 'Sensor clocks'.

Synthetic tracks with a known answer: a vessel alongside for two minutes, then under way at
1-2.5 m/s with slow turns and speed changes; its dead-reckoned track is the true one turned
by an unknown start heading, scaled as a DVL's few per cent off and given a random walk, and
its fixes the true positions at stamps moved by a known offset, with a white and a slow
Gauss-Markov error of metres (the paper's surface GPS). The loader-level test shifts the
simulated demo's GPS table."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from adaptnav.mission import MissionError, clocks, gnss_clock, load_mission
from helpers.missions import with_column

DURATION_S = 1500.0
STEP_S = 0.1


def _track(rng: np.random.Generator, turns: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Times and true positions (north + i east, m) of the vessel."""
    t = np.arange(0.0, DURATION_S + 1e-9, STEP_S)
    speed = np.clip((t - 120.0) / 30.0, 0.0, 1.0) * 2.0
    yaw = np.full_like(t, 0.4)
    if turns:
        for start in np.arange(200.0, DURATION_S - 100.0, 150.0):
            s = np.clip((t - start) / rng.uniform(30.0, 60.0), 0.0, 1.0)
            yaw += math.radians(rng.uniform(30.0, 90.0)) * rng.choice([-1.0, 1.0]) * s
            speed += rng.uniform(-0.5, 0.5) * np.clip((t - start) / 20.0, 0.0, 1.0) * (t > 150.0)
    v = speed * np.exp(1j * yaw)
    return t, np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * STEP_S)])


def _dead_reckoned(
    t: np.ndarray, p: np.ndarray, rng: np.random.Generator, drift_deg: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """The track a DVL gives: turned by -0.5 rad (and ``drift_deg`` more over the run: a
    gyro's bias), 3 % long, plus a random walk of 0.02 m/√s."""
    turn = np.exp(-1j * (0.5 + math.radians(drift_deg) * t / t[-1]))
    dp = np.diff(p) * turn[1:] * 1.03
    walk = np.array([1.0, 1j]) @ rng.normal(0.0, 0.02 * math.sqrt(STEP_S), (2, dp.size))
    return t, np.concatenate([[0.0], np.cumsum(dp + walk)])


def _fixes(
    t: np.ndarray, p: np.ndarray, rng: np.random.Generator, late_s: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """1-Hz fixes taken at 0.3 + k s, stamped ``late_s`` later: 1.5 m white and 2.5 m / 120 s
    Gauss-Markov error per axis."""
    taken = np.arange(0.3, DURATION_S - 0.5, 1.0)
    at = np.interp(taken, t, p.real) + 1j * np.interp(taken, t, p.imag)
    phi = math.exp(-1.0 / 120.0)
    gm = np.zeros((taken.size, 2))
    kick = rng.normal(0.0, 2.5 * math.sqrt(1.0 - phi**2), gm.shape)
    for k in range(1, taken.size):
        gm[k] = phi * gm[k - 1] + kick[k]
    err = gm + rng.normal(0.0, 1.5, gm.shape)
    return taken + late_s, at.real + err[:, 0], at.imag + err[:, 1]


def _offset(
    seed: int, late_s: float, drift_deg: float = 0.0, outage: bool = False
) -> clocks.ClockOffset | None:
    rng = np.random.default_rng(seed)
    t, p = _track(rng)
    track = _dead_reckoned(t, p, rng, drift_deg)
    stamps, north, east = _fixes(t, p, rng, late_s)
    if outage:  # two minutes without fixes in the middle of a turn's run
        keep = np.abs(stamps - late_s - 700.0) > 60.0
        stamps, north, east = stamps[keep], north[keep], east[keep]
    return gnss_clock.gnss_offset(stamps, north, east, 1.0, track)


@pytest.mark.parametrize(("seed", "outage"), [(1, False), (2, False), (3, True)])
def test_right_stamps_are_silent_even_with_a_drifting_heading(seed: int, outage: bool) -> None:
    # 5° of heading drift over the run and a 3 % scale: the changes between windows barely feel
    # them, and a lag cannot take them up. k: the fixes' metres per metre of the track. An
    # outage of the fixes is left out, not bridged by a ramp.
    found = _offset(seed, 0.0, drift_deg=5.0, outage=outage)
    assert found is not None and not found.decisive(), found
    assert abs(found.offset_s) < 4.0 * found.se_s and abs(found.k * 1.03 - 1.0) < 0.02, found


@pytest.mark.parametrize(
    ("seed", "late_s", "outage"), [(1, 18.0, False), (2, -10.0, True), (3, 6.0, False)]
)
def test_fixes_stamped_seconds_off_are_dated_to_their_offset(
    seed: int, late_s: float, outage: bool
) -> None:
    found = _offset(seed, late_s, outage=outage)
    assert found is not None and found.decisive(), found
    assert abs(found.offset_s - late_s) < max(3.0 * found.se_s, 1.0), found
    assert found.beyond(1.0)


def test_a_straight_track_at_a_steady_speed_dates_nothing() -> None:
    # Alongside, then under way on one course: only the start dates the fixes, so half an hour
    # of straight running alone gives the same changes at every lag.
    rng = np.random.default_rng(4)
    t, p = _track(rng, turns=False)
    under_way = t >= 200.0
    track = _dead_reckoned(t[under_way], p[under_way], rng)
    stamps, north, east = _fixes(t, p, rng, 18.0)
    keep = stamps >= 220.0
    found = gnss_clock.gnss_offset(stamps[keep], north[keep], east[keep], 1.0, track)
    assert found is None or not found.decisive(), found


@pytest.mark.parametrize("keep", ["three readings", "last 26 s"])
def test_a_dvl_track_too_short_for_the_fixes_dates_nothing(keep: str) -> None:
    """A DVL left with three readings (the rest NaN) or only its last 26 s beside 25 min of
    fixes: too short a track for a fit, nothing said. Up to 0.4.12 an IndexError in the scan
    (three readings: no window of the track) or a RuntimeWarning of NaN sums (26 s), found by
    scripts/odd_inputs_eval.py's dvl-nan-but-3 and dvl-last-26s-only."""
    rng = np.random.default_rng(5)
    t, p = _track(rng)
    stamps, north, east = _fixes(t, p, rng, 0.0)
    tt, pp = _dead_reckoned(t, p, rng)
    short = slice(11000, 11003) if keep == "three readings" else slice(-260, None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        found = gnss_clock.gnss_offset(stamps, north, east, 1.0, (tt[short], pp[short]))
    assert found is None


def test_window_means_are_exact_across_a_long_sample_interval() -> None:
    # A DVL dropout of 25 s: the track's integral is quadratic within it, so the window means
    # are taken on the fine grid (a linear interpolation of the integral was 12 m off).
    t = np.array([0.0, 10.0, 35.0, 60.0])
    x = np.array([0.0, 10.0, 35.0, 60.0]) * (1.0 + 0.5j)
    s, mean = gnss_clock.boxed(t, x, 10.0)
    # x is linear in t, so its mean over a window is its value at the window's middle.
    assert np.allclose(mean, s * (1.0 + 0.5j), atol=1e-9)


def test_gnss_stamped_seconds_late_is_refused_at_load_naming_the_latency(
    demo: Path, tmp_path: Path
) -> None:
    # Up to 0.4.11 the demo's GPS 18 s late loaded: its course is undecided at 2.9 m σ.
    root = with_column(demo, tmp_path / "mission", "gps.parquet", "t_s", lambda t: t + 18.0)
    with pytest.raises(MissionError) as err:
        load_mission(root)
    text = str(err.value)
    assert text.startswith("gps.parquet: the stamps of sensor 'gps' (lat_rad, lon_rad) lie 1")
    assert "after its fixes were taken" in text and "DVL 'dvl'" in text, text
    fix = float(text.split("Set latency_s = ")[1].split(" ")[0])
    assert abs(fix - 18.0) < 2.0 and "in [sensors.gps]" in text, text
    assert err.value.field == "t_s" and err.value.file == "gps.parquet"


def test_a_dvl_seconds_off_is_named_before_the_gnss_is_dated_against_its_track(
    demo: Path, tmp_path: Path
) -> None:
    # The GNSS is dated against the DVL's track: the demo's DVL 10 s early moved that track,
    # and the right GPS was refused as "4.9 s late" before the DVL's own clock was judged.
    root = with_column(demo, tmp_path / "mission", "dvl.parquet", "t_s", lambda t: t - 10.0)
    with pytest.raises(MissionError) as err:
        load_mission(root)
    text = str(err.value)
    assert text.startswith("dvl.parquet: the stamps of sensor 'dvl' lie "), text
    assert "before its readings were taken" in text and err.value.field == "t_s", text
    fix = float(text.split("Set latency_s = ")[1].split(" ")[0])
    assert abs(fix + 10.0) < 0.3, text
