"""A sensor's stamps against the IMU's over a wide range of lags (mission/clocks.py) and the
load error or warning it gives (mission/loader.py ``_check_clocks``): docs/robustness.md,
'Sensor clocks'.

Synthetic motion with a known answer: a vehicle on a random sea (roll and pitch a sum of wave
components with random phases, so no lag but the right one repeats them) that turns slowly and
irregularly, its exact gyro increments, and a heading sensor and an inclinometer that read its
true angles plus noise at stamps moved by a known offset. The loader-level tests shift a
table's stamps on the simulated demo."""

from __future__ import annotations

import dataclasses
import logging
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav.mission import MissionError, axes, clocks, load_mission, scales
from helpers import diving
from helpers.missions import with_column

RATE_HZ = 100.0
DURATION_S = 900.0
ARW = 1e-6 * math.sqrt(RATE_HZ)
"""The gyro increments' noise as an angle random walk (rad/√s)."""


def _waves(t: np.ndarray, rng: np.random.Generator, amp_deg: float) -> np.ndarray:
    """A random sea's angle: 12 components with periods 5-12 s and random phases, amp_deg RMS."""
    periods = rng.uniform(5.0, 12.0, 12)
    phases = rng.uniform(0.0, 2.0 * math.pi, 12)
    wave = np.sin(2.0 * math.pi * t[:, None] / periods + phases).sum(axis=1)
    return math.radians(amp_deg) * wave / math.sqrt(6.0)


def _turns(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A yaw that turns slowly and irregularly: a few turns of 20-90° over 20-60 s each."""
    yaw = np.zeros_like(t)
    for start in np.arange(60.0, DURATION_S - 100.0, 110.0):
        angle = math.radians(rng.uniform(20.0, 90.0)) * rng.choice([-1.0, 1.0])
        length = rng.uniform(20.0, 60.0)
        s = np.clip((t - start) / length, 0.0, 1.0)
        yaw += angle * (s - np.sin(2.0 * math.pi * s) / (2.0 * math.pi))
    return yaw


def _motion(seed: int = 5) -> dict[str, np.ndarray]:
    """The IMU's times and exact increments (roll, pitch, yaw changes: small angles, the rule's
    Euler rates) of the random sea and turns, plus gyro noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION_S + 1e-9, 1.0 / RATE_HZ)
    ang = np.column_stack([_waves(t, rng, 3.0), _waves(t, rng, 2.0), _turns(t, rng)])
    dtheta = np.diff(ang, axis=0) + rng.normal(0.0, 1e-6, (t.size - 1, 3))
    return {"t": t, "ang": ang, "dtheta": dtheta}


def _gyro(m: dict[str, np.ndarray], sign: float = 1.0) -> axes.Gyro:
    dt = np.full(m["t"].size - 1, 1.0 / RATE_HZ)
    return axes.Gyro.of(m["t"][1:], dt, sign * m["dtheta"], arw=ARW)


def _readings(
    m: dict[str, np.ndarray], axis: int, rate_hz: float, sigma_deg: float, late_s: float, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """A sensor reading the true angle ``axis`` with noise every 1/rate_hz s, its stamps
    ``late_s`` after the readings were taken."""
    rng = np.random.default_rng(seed)
    taken = np.arange(0.5, DURATION_S - 0.5, 1.0 / rate_hz)
    value = np.interp(taken, m["t"], m["ang"][:, axis])
    return taken + late_s, value + rng.normal(0.0, math.radians(sigma_deg), taken.size)


def _offset(
    m: dict[str, np.ndarray], axis: int, late_s: float, rate_hz: float = 1.0, seed: int = 1
) -> clocks.ClockOffset:
    sigma = 0.5 if axis == 2 else 0.1
    t, value = _readings(m, axis, rate_hz, sigma, late_s, seed)
    found = clocks.clock_offset(_gyro(m), axis, t, value)
    assert found is not None
    return found


@pytest.fixture(scope="module")
def motion() -> dict[str, np.ndarray]:
    return _motion()


def test_right_stamps_give_an_offset_of_zero_within_its_sigma(
    motion: dict[str, np.ndarray],
) -> None:
    for axis, rate in ((2, 1.0), (0, 5.0), (1, 5.0), (2, 20.0)):
        found = _offset(motion, axis, 0.0, rate)
        assert abs(found.offset_s) < 4.0 * found.se_s + 1e-9, (axis, found)
        assert abs(found.k - 1.0) < 0.05, (axis, found)
        assert not found.decisive(), (axis, found)


CASES = [(2, 1.0, 18.0), (2, 1.0, -10.0), (0, 5.0, 5.0), (1, 5.0, -10.0), (0, 5.0, 45.0)]
"""Axis, the sensor's rate and how late its stamps are (s); a 20-Hz heading below."""


@pytest.mark.parametrize(("axis", "rate_hz", "late_s"), [*CASES, (2, 20.0, 18.0)])
def test_a_sensor_stamped_seconds_late_or_early_is_dated_to_its_offset(
    motion: dict[str, np.ndarray], axis: int, rate_hz: float, late_s: float
) -> None:
    found = _offset(motion, axis, late_s, rate_hz)
    assert abs(found.offset_s - late_s) < max(4.0 * found.se_s, 0.1), found
    assert found.se_s < 0.5, found
    assert found.decisive() and found.beyond(1.0 / rate_hz), found
    assert abs(found.k - 1.0) < 0.05, found


def test_stamps_off_beyond_the_scanned_range_are_refused_with_a_doubt(
    motion: dict[str, np.ndarray],
) -> None:
    # 90 s late, beyond ±60 s: the random sea's components repeat well enough that a lag within
    # the range fits far better than lag 0, only with a slope well below 1 (0.81), which marks
    # the offset as a possible alias; the stamps are refused all the same.
    t, value = _readings(motion, 0, 5.0, 0.1, 90.0, 1)
    found = clocks.clock_offset(_gyro(motion), 0, t, value)
    assert found is not None and found.decisive() and found.alias, found
    assert not _offset(motion, 0, 45.0, 5.0).alias


def test_a_flipped_gyro_is_the_axis_checks_finding_not_a_clocks(
    motion: dict[str, np.ndarray],
) -> None:
    t, value = _readings(motion, 2, 1.0, 0.5, 18.0, 1)
    found = clocks.clock_offset(_gyro(motion, -1.0), 2, t, value)
    assert found is not None and not found.decisive(), found


def test_a_still_vehicle_has_no_clock_to_read() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 600.0, 0.01)
    dtheta = rng.normal(0.0, 1e-6, (t.size - 1, 3))
    gyro = axes.Gyro.of(t[1:], np.full(t.size - 1, 0.01), dtheta, arw=ARW)
    ts = np.arange(1.0, 599.0, 1.0)
    assert clocks.clock_offset(gyro, 2, ts, rng.normal(0.0, 0.01, ts.size)) is None


@pytest.mark.parametrize("late_s", [0.0, 8.0])
def test_a_pure_wave_that_repeats_each_period_is_never_dated_off_its_stamps(late_s: float) -> None:
    # A single 8-s roll: every lag a whole period away fits as well as lag 0, so no lag can beat
    # it decisively; stamps off by exactly a period cannot be told from right ones (a limit).
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 600.0 + 1e-9, 0.01)
    roll = math.radians(3.0) * np.sin(2.0 * math.pi * t / 8.0)
    dtheta = np.zeros((t.size - 1, 3))
    dtheta[:, 0] = np.diff(roll) + rng.normal(0.0, 1e-6, t.size - 1)
    gyro = axes.Gyro.of(t[1:], np.full(t.size - 1, 0.01), dtheta, arw=ARW)
    taken = np.arange(0.5, 599.5, 0.2)
    value = np.interp(taken, t, roll) + rng.normal(0.0, math.radians(0.1), taken.size)
    found = clocks.clock_offset(gyro, 0, taken + late_s, value)
    assert found is not None and not found.decisive(), found


def test_right_stamps_are_silent_over_many_seas() -> None:
    # The rule's false alarms on right data: 12 seeds of sea and turns, three angles each.
    for seed in range(12):
        m = _motion(100 + seed)
        for axis, rate in ((2, 1.0), (0, 5.0), (1, 5.0)):
            found = _offset(m, axis, 0.0, rate, seed)
            assert not found.decisive(), (seed, axis, found)
            assert abs(found.offset_s) < 1.0, (seed, axis, found)


def test_the_rule_asks_for_a_right_slope_a_decisive_ratio_and_four_sigma() -> None:
    right = clocks.ClockOffset(18.0, 0.3, 1.0, 0.66, 1.25, 0.69, 900, 900.0)
    assert right.log_lr == pytest.approx(900.0 * math.log(1.25))
    assert right.decisive() and right.beyond(1.0)
    assert not clocks.ClockOffset(18.0, 0.3, 0.5, 0.3, 1.25, 0.69, 900, 900.0).decisive()
    assert not clocks.ClockOffset(18.0, 0.3, 1.0, 0.9, 1.25, 0.1, 900, 900.0).decisive()
    assert not clocks.ClockOffset(18.0, 0.3, 1.0, 0.66, 1.02, 0.69, 900, 900.0).decisive()
    assert not clocks.ClockOffset(1.0, 0.3, 1.0, 0.66, 1.25, 0.69, 900, 900.0).decisive()
    # Within max(1 s, two periods): a 1-Hz sensor 1.5 s late is a warning, not an error.
    assert not right.beyond(10.0)
    assert clocks.ClockOffset(1.5, 0.1, 1.0, 0.9, 1.25, 0.69, 900, 900.0).beyond(0.2)
    assert not clocks.ClockOffset(1.5, 0.1, 1.0, 0.9, 1.25, 0.69, 900, 900.0).beyond(1.0)


# --- at load, on the simulated demo ---------------------------------------------------------------


def _shifted(
    demo: Path, tmp_path: Path, table: str, late_s: float, axis_check: bool = True
) -> Path:
    """The demo with its heading sensor aiding and ``table``'s stamps ``late_s`` later."""
    root = with_column(demo, tmp_path / "mission", table, "t_s", lambda t: t + late_s)
    toml = root / "mission.toml"
    text = toml.read_text()
    heading = text.index("[sensors.heading]")
    text = text[:heading] + text[heading:].replace('use = "off"', 'use = "aid"', 1)
    if not axis_check:
        text = text.replace("[imu]\n", "[imu]\naxis_check = false\n", 1)
    toml.write_text(text)
    return root


@pytest.mark.parametrize(
    ("table", "late_s", "expect"),
    [
        ("heading.parquet", 18.0, "the stamps of sensor 'heading' lie 18."),
        ("heading.parquet", -10.0, "the stamps of sensor 'heading' lie 9.9"),
        ("inclinometer.parquet", 5.0, "the stamps of sensor 'inclinometer' lie 5.0"),
    ],
)
def test_a_table_stamped_seconds_off_is_refused_at_load_naming_the_latency(
    demo: Path, tmp_path: Path, table: str, late_s: float, expect: str
) -> None:
    with pytest.raises(MissionError) as err:
        load_mission(_shifted(demo, tmp_path, table, late_s))
    text = str(err.value)
    assert text.startswith(f"{table}: {expect}"), text
    name = table.split(".")[0]
    # The fix: the offset as latency_s (the demo's own clock offset of about 0.1 s included).
    fix = float(text.split("Set latency_s = ")[1].split(" ")[0])
    assert abs(fix - late_s) < 0.5 and f"in [sensors.{name}]" in text, text
    assert err.value.field == "t_s" and err.value.file == table


def test_right_stamps_and_axis_check_false_load(demo: Path, tmp_path: Path) -> None:
    assert load_mission(_shifted(demo, tmp_path / "a", "heading.parquet", 0.0)).sensors
    assert load_mission(_shifted(demo, tmp_path / "b", "heading.parquet", 18.0, False)).sensors


def _holed(demo: Path, root: Path, t0: float, length: float) -> Path:
    """The demo with its IMU rows in (t0, t0 + length] lost and ``imu.max_gap_s`` above it."""
    shutil.copytree(demo, root)
    toml = root / "mission.toml"
    toml.write_text(toml.read_text().replace("[imu]\n", f"[imu]\nmax_gap_s = {length + 1}\n", 1))
    imu = pd.read_parquet(root / "imu.parquet")
    keep = (imu.t_s <= t0 + 1e-9) | (imu.t_s > t0 + length + 1e-9)
    imu[keep].reset_index(drop=True).to_parquet(root / "imu.parquet", index=False)
    return root


@pytest.mark.parametrize(("table", "late_s"), [(None, 0.0), ("inclinometer", 18.0), ("dvl", 18.0)])
def test_an_imu_hole_is_left_out_of_the_clocks_fits(
    demo: Path, tmp_path: Path, table: str | None, late_s: float
) -> None:
    """60 s of the demo's IMU lost at 830 s (``max_gap_s`` raised): the gyro's integral is a
    ramp across the hole, and up to 0.4.12 the right inclinometer was refused as "stamped 54.9
    s after its readings". The intervals whose lags reach the hole are left out
    (clocks.Reference.without_holes): the right mission loads, and stamps 18 s late are still
    dated."""
    root = _holed(demo, tmp_path / "m", 830.0, 60.0)
    if table is None:
        assert load_mission(root).sensors
        return
    df = pd.read_parquet(root / f"{table}.parquet")
    df["t_s"] += late_s
    df.to_parquet(root / f"{table}.parquet", index=False)
    with pytest.raises(MissionError, match=f"'{table}' lie 18.0 ± 0.1 s after"):
        load_mission(root)


def test_an_offset_within_two_periods_of_a_slow_sensor_is_a_warning(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # The 1-Hz heading 1.8 s late: beyond the axis check's ±1 s, within two of its periods.
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(_shifted(demo, tmp_path, "heading.parquet", 1.8))
    said = [
        r.getMessage() for r in caplog.records if "stamps of sensor 'heading'" in r.getMessage()
    ]
    assert len(said) == 1 and "Set latency_s = 1." in said[0], said


def test_the_error_doubts_an_offset_found_with_a_slope_far_from_one() -> None:
    from adaptnav.mission import loader

    ref = axes.Reference("incl", "roll", 0, np.array([0.0, 900.0]), np.zeros(2))
    sure = clocks.ClockOffset(18.0, 0.1, 0.99, -0.85, 9.5, 3.7, 4500, 4500.0)
    doubtful = clocks.ClockOffset(4.5, 0.1, 0.81, 0.02, 4.1, 1.95, 4070, 629.0)
    what, span = ("its roll follows the gyro's x axis", "rotation"), (0.0, 900.0)
    assert "alias" not in loader._offset_words(ref.name, what, sure, 0.0, span)
    words = loader._offset_words(ref.name, what, doubtful, 0.2, span)
    assert "Set latency_s = 4.7 in [sensors.incl] (now 0.2)" in words and "alias" in words


@pytest.mark.parametrize("late_s", [-60.0, 60.0])
def test_an_offset_of_the_whole_latency_bound_is_dated(
    motion: dict[str, np.ndarray], late_s: float
) -> None:
    # latency_s = 60 on right stamps: the offset lies on the ±60-s bound, where up to 0.4.11 the
    # scan ended and its σ was infinite (the axis check then blamed the gyro).
    found = _offset(motion, 2, late_s, 1.0)
    assert abs(found.offset_s - late_s) < max(4.0 * found.se_s, 0.5), found
    assert found.decisive() and abs(found.k - 1.0) < 0.05, found


# --- a depth meter against the DVL's vertical displacement (depth_offset) -------------------------


def _depth_offset(
    tabs: dict[str, pd.DataFrame], late_s: float, lever_x: float = 0.0
) -> clocks.ClockOffset | None:
    """The depth of ``diving.tables`` stamped ``late_s`` late against its DVL (2 Hz, 0.02 m/s)
    turned down by the accelerometers' levelled tilt; the depth meter ``lever_x`` (m) ahead of
    the DVL, so reading ``lever_x sin θ`` less as the bow pitches up by θ."""
    imu, dvl, depth = tabs["imu"], tabs["dvl"], tabs["depth"]
    t = imu["t_s"].to_numpy()
    dt = np.full(t.size, 1.0 / diving.RATE_HZ)
    f = imu[[f"accel_{a}_m_s2" for a in "xyz"]].to_numpy()
    tilt = axes.AccelTilt.of(t + dt, dt, f * dt[:, None])
    v_s = dvl[["vx_m_s", "vy_m_s", "vz_m_s"]].to_numpy()
    v = scales.Dvl.of(dvl["t_s"].to_numpy(), v_s, None, 0.5, 0.02)
    td = depth["t_s"].to_numpy()
    pitch = math.radians(15.0) * np.sin(2.0 * math.pi * td / 120.0)  # diving.tables' yo-yo
    d = depth["depth_m"].to_numpy() - lever_x * np.sin(pitch)
    lever = np.array([lever_x, 0.0, 0.0])
    return clocks.depth_offset(td + late_s, d, v, tilt, lever)


@pytest.fixture(scope="module")
def dive() -> dict[str, pd.DataFrame]:
    return diving.tables()


@pytest.mark.parametrize("late_s", [18.0, -10.0])
def test_a_depth_stamped_seconds_off_is_dated_against_the_dvl(
    dive: dict[str, pd.DataFrame], late_s: float
) -> None:
    """Up to 0.4.11 a depth seconds off was not dated. The yo-yo's depth (±7.4 m over 120 s)
    against the DVL's velocity turned down by the pitch: its offset, with the slope 1."""
    found = _depth_offset(dive, late_s)
    assert found is not None and found.decisive() and found.beyond(1.0), found
    assert abs(found.offset_s - late_s) < max(4.0 * found.se_s, 0.3), found
    assert abs(found.k - 1.0) < 0.1, found
    right = _depth_offset(dive, 0.0)
    assert right is not None and not right.decisive() and abs(right.offset_s) < 0.3, right


@pytest.mark.parametrize("late_s", [0.0, 18.0, -10.0])
def test_a_depth_meter_s_lever_arm_moves_with_the_lag(
    dive: dict[str, pd.DataFrame], late_s: float
) -> None:
    """A depth meter 10 m ahead of the DVL on the yo-yo (±2.6 m of its own as the bow pitches):
    the lever arm's share is the attitude's at the lagged instant, so the offset found is the
    stamps' (taken off the readings at their stamps, it biased the offsets of stamps that are
    off: A-KIT 9's 18 s late read 17.7 s)."""
    found = _depth_offset(dive, late_s, lever_x=10.0)
    assert found is not None and abs(found.offset_s - late_s) < max(4.0 * found.se_s, 0.3), found
    assert abs(found.k - 1.0) < 0.1, found


def test_a_vehicle_that_does_not_dive_has_no_depth_clock() -> None:
    """A surface vessel's depth is its waves and noise: undecided, however its stamps lie."""
    flat = diving.tables(duration_s=300.0, pitch_deg=0.0)
    assert _depth_offset(flat, 18.0) is None and _depth_offset(flat, 0.0) is None


def test_a_depth_offset_is_material_by_its_ratio_whatever_its_share() -> None:
    """A steady dive's changes are its rate, which 5 s hardly moves: A-KIT 9's depth 5 s late
    (4.6 s found, a share of 0.12 and a ratio of 4.3; the run 1745 m off up to 0.4.11)."""
    steep = clocks.ClockOffset(4.62, 0.29, 0.995, 0.931, 4.29, 0.122, 276, 276.0)
    assert not steep.decisive()
    assert dataclasses.replace(steep, min_ratio=clocks.DEPTH_RATIO).decisive()
    right = clocks.ClockOffset(0.03, 0.29, 0.99, 0.99, 0.996, -8e-5, 276, 276.0, 2.0)
    assert not right.decisive()
