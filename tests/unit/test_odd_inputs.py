"""Odd but real inputs to the load-time cross-checks (loader.cross_check: mission/clocks.py,
axes.py, scales.py, dvl_axes.py), which the stream's window runs too (mission/live_cross.py):
each either decides rightly or says nothing, never a traceback or a NumPy warning
(docs/robustness.md, 'Odd inputs to the cross-checks').

The loader-level cases change the simulated demo's loaded arrays in memory and call
:func:`adaptnav.mission.loader.cross_check` on them, as the loader and the stream do."""

from __future__ import annotations

import dataclasses
import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from adaptnav.mission import MissionError, axes, load_mission, loader, scales
from adaptnav.mission.loader import Mission, SensorData


@pytest.fixture(scope="module")
def demo_aided(demo: Path, tmp_path_factory: pytest.TempPathFactory) -> Mission:
    """The demo with its heading sensor aiding (off as simulated), loaded once."""
    root = tmp_path_factory.mktemp("odd") / "demo"
    shutil.copytree(demo, root)
    text = (demo / "mission.toml").read_text()
    head, tail = text.split("[sensors.heading]", 1)
    (root / "mission.toml").write_text(
        head + "[sensors.heading]" + tail.replace('use = "off"', 'use = "aid"', 1)
    )
    return load_mission(root)


def _check(m: Mission, sensors: dict[str, SensorData], dtheta: np.ndarray | None = None) -> None:
    """The loader's cross-checks on ``sensors`` and the IMU (its Δθ replaced by ``dtheta``),
    with every warning an error."""
    imu = m.imu
    noise = m.config.imu.noise.to_imu_noise()
    d = imu.dtheta if dtheta is None else dtheta
    views = axes.ImuViews(imu.t, imu.dt, d, imu.dvel, (noise.arw, noise.vrw))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loader.cross_check(m.config, views, sensors)


def _with(
    m: Mission, name: str, keep: np.ndarray | None = None, z: np.ndarray | None = None
) -> dict[str, SensorData]:
    """The mission's sensors with ``name``'s readings cut to ``keep`` or values set to ``z``."""
    d = m.sensors[name]
    if keep is not None:
        d = dataclasses.replace(d, t=d.t[keep], z=d.z[keep], rows=d.rows[keep])
    if z is not None:
        d = dataclasses.replace(d, z=z)
    return {**m.sensors, name: d}


def test_the_demo_with_its_heading_is_silent(demo_aided: Mission) -> None:
    _check(demo_aided, demo_aided.sensors)


def test_a_depth_meter_with_one_reading_is_paired_with_the_fixes_near_it() -> None:
    # Up to 0.4.11 an IndexError: the neighbour above the only reading was looked up.
    at = scales.depth_at_fixes(
        np.array([100.5]), np.array([10.0]), 100.0 + 0.05 * np.arange(20), 0.5
    )
    assert at is not None and at.n == 20 and at.depth_m == 10.0 and at.under_m == 9.5
    assert scales.depth_at_fixes(np.array([5.0]), np.array([10.0]), np.arange(100.0), 0.0) is None


def test_a_depth_meter_with_one_reading_loads(demo_aided: Mission) -> None:
    _check(demo_aided, _with(demo_aided, "depth", keep=np.array([700])))


def test_a_dvl_reading_zeros_throughout_has_no_speed_to_judge(demo_aided: Mission) -> None:
    # Up to 0.4.11: 0/0 in the speed fit, a RuntimeWarning and a NaN fit.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert scales.through_origin(np.ones(30), np.zeros(30)) is None
        assert scales.through_origin(np.ones(30) + 1j, np.zeros(30, dtype=complex)) is None
    zeros = np.zeros_like(demo_aided.sensors["dvl"].z)
    _check(demo_aided, _with(demo_aided, "dvl", z=zeros))


def test_a_dvl_with_no_whole_reading_is_not_judged(demo_aided: Mission) -> None:
    # Every reading with a NaN axis (or dropped as lost lock): up to 0.4.11 an IndexError.
    z = demo_aided.sensors["dvl"].z.copy()
    z[:, 2] = math.nan
    _check(demo_aided, _with(demo_aided, "dvl", z=z))
    _check(demo_aided, _with(demo_aided, "dvl", keep=np.arange(0)))


def test_an_inclinometer_pegged_at_90_degrees_at_the_end_is_not_dated_off(
    demo_aided: Mission,
) -> None:
    # Its last 10 s at exactly 90° pitch. Up to 0.4.11 lag 0 was judged with that step and
    # lag -18 s without it (the IMU no longer covers it there): "the stamps lie 18.3 s before
    # its readings were taken", exit 2. Now both on the same intervals: nothing to date.
    z = demo_aided.sensors["inclinometer"].z.copy()
    z[-50:, 1] = math.pi / 2.0
    _check(demo_aided, _with(demo_aided, "inclinometer", z=z))


@pytest.mark.parametrize(
    ("axis", "reference"), [(0, "'inclinometer'"), (1, "'inclinometer'"), (2, "'heading'")]
)
def test_a_dead_gyro_axis_is_named_not_the_dvl(
    demo_aided: Mission, axis: int, reference: str
) -> None:
    # Up to 0.4.11 x and y were blamed on the DVL ("is the y axis negated?"), z was silent.
    dtheta = demo_aided.imu.dtheta.copy()
    dtheta[:, axis] = 0.0
    with pytest.raises(MissionError) as err:
        _check(demo_aided, demo_aided.sensors, dtheta)
    column = f"dtheta_{'xyz'[axis]}_rad"
    assert err.value.field == column and err.value.file == "imu.parquet"
    assert f"({column}) reads one constant rate" in str(err.value) and reference in str(err.value)


def test_a_gyro_that_reads_a_constant_against_a_still_reference_is_not_called_dead() -> None:
    t = np.arange(0.0, 100.0, 0.01)
    gyro = axes.Gyro.of(t[1:], np.full(t.size - 1, 0.01), np.zeros((t.size - 1, 3)))
    ts = np.arange(0.5, 99.0, 1.0)
    still = np.random.default_rng(3).normal(0.0, math.radians(0.5), ts.size)
    assert axes.dead_axis(gyro, 2, ts, still, math.radians(0.5)) is None
    turning = np.radians(np.linspace(0.0, 90.0, ts.size))
    found = axes.dead_axis(gyro, 2, ts, turning, math.radians(0.5))
    assert found is not None and found.rate == 0.0 and 85.0 < math.degrees(found.turn) < 90.0


def test_a_two_hour_hole_in_the_imu_and_the_sensors_is_left_out_of_the_axis_fits(
    demo_aided: Mission,
) -> None:
    # The loader stretches the row after lost samples over the hole (×720 001 for 2 h, with
    # imu.max_gap_s raised): one interval of each reference then held a rotation that large,
    # and its leverage set the fit's slope to 0 (up to 0.4.11: "the gyro's x axis ... does
    # not turn with the roll of sensor 'inclinometer'", exit 2).
    m, hole, k = demo_aided, 7200.0, 70_000
    imu = m.imu
    t, dt = imu.t.copy(), imu.dt.copy()
    t[k:] += hole
    dt[k] += hole
    scale = np.ones((t.size, 1))
    scale[k] = dt[k] / imu.dt[k]
    moved = {
        n: dataclasses.replace(d, t=np.where(d.t > imu.t[k - 1], d.t + hole, d.t))
        for n, d in m.sensors.items()
    }
    noise = m.config.imu.noise.to_imu_noise()
    views = axes.ImuViews(t, dt, imu.dtheta * scale, imu.dvel * scale, (noise.arw, noise.vrw))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loader.cross_check(m.config, views, moved)


@pytest.mark.parametrize(
    ("table", "column", "declared"),
    [("gps", "lon_rad", False), ("gps", "lat_rad", False), ("heading", "yaw_rad", True),
     ("heading", "yaw_rad", False)],
)  # fmt: skip
def test_a_reading_of_inf_is_left_to_the_engine_by_the_checks(
    demo: Path, tmp_path: Path, table: str, column: str, declared: bool
) -> None:
    # ±inf is kept by the loader for the engine to drop as non-finite (tests/unit/
    # test_live_screen.py). Up to the audit of 0.4.13 the checks met it: a GNSS fix of inf was
    # a RuntimeWarning in geodetic_to_ecef (the GNSS clock check), a heading of inf in the
    # direction fit's unwrap, with declination_deg set in true_north (odd_inputs_eval's
    # gps-one-lon-inf, heading-one-inf, heading-one-inf-declination; helper aud2).
    import pandas as pd

    root = tmp_path / "demo"
    shutil.copytree(demo, root)
    toml = root / "mission.toml"
    head, tail = toml.read_text().split("[sensors.heading]", 1)
    if declared:
        tail = "\ndeclination_deg = 2.0" + tail
    toml.write_text(head + "[sensors.heading]" + tail.replace('use = "off"', 'use = "aid"', 1))
    df = pd.read_parquet(root / f"{table}.parquet")
    df.loc[700, column] = math.inf
    df.to_parquet(root / f"{table}.parquet", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mission(root)
    k = int(np.flatnonzero(m.sensors[table].rows == 700)[0])
    assert np.isinf(m.sensors[table].z[k]).any()


@pytest.mark.parametrize(("start", "length"), [(700.0, 100.0), (650.0, 150.0)])
def test_a_long_imu_hole_under_way_blames_no_right_sensor(
    demo: Path, tmp_path: Path, start: float, length: float
) -> None:
    # The demo (heading aiding) with its IMU rows of a long hole lost, imu.max_gap_s raised:
    # the gyro's angle over the hole is the repair's line, and the yaw after it is turned by
    # the rotation lost. Up to the first 0.4.13 version: 100 s at 700 s refused the right GPS
    # as "the mirror image of the DVL's dead reckoning" (the track across the hole), 150 s at
    # 650 s the right inclinometer ("does not follow the gyro's and the accelerometers'": its
    # readings inside the hole). Now the loader warns of the hole only (helper aud2's audit).
    import pandas as pd

    root = tmp_path / "demo"
    shutil.copytree(demo, root)
    toml = root / "mission.toml"
    head, tail = toml.read_text().split("[sensors.heading]", 1)
    text = head + "[sensors.heading]" + tail.replace('use = "off"', 'use = "aid"', 1)
    toml.write_text(text.replace("rate_hz = 100.0\n", "rate_hz = 100.0\nmax_gap_s = 400.0\n", 1))
    imu = pd.read_parquet(root / "imu.parquet")
    keep = (imu["t_s"] <= start) | (imu["t_s"] > start + length)
    imu[keep].reset_index(drop=True).to_parquet(root / "imu.parquet", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mission(root)
    assert len(m.imu.holes) == 1


def test_the_dead_reckoned_track_is_its_longest_part_between_imu_holes() -> None:
    from adaptnav.mission import gnss_clock

    t = np.arange(0.0, 100.0, 1.0)
    p = (t + 0j).astype(complex)
    # holes 20-30 s and 70-75 s: the parts 0-20, 30-70, 75-99; the longest is 30-70 s
    kt, kp = gnss_clock.unbroken((t, p), np.array([20.0, 70.0]), np.array([30.0, 75.0]))
    assert kt[0] == 30.0 and kt[-1] == 70.0 and np.array_equal(kp.real, kt)
    same = gnss_clock.unbroken((t, p), np.zeros(0), np.zeros(0))
    assert same[0] is t


def test_a_heading_carried_across_an_imu_hole_is_not_off_the_course(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # The demo (heading sensor off: the start's yaw carried by the gyro) with 60 s of IMU lost
    # at 700 s, imu.max_gap_s raised: the yaw carried after the hole misses the turn lost in
    # it. Up to the first 0.4.13 version the load warned of the DVL's direction off the GNSS
    # course ('initial.rpy_deg's yaw off', 'A heading a few degrees off the GNSS course'); the
    # carried yaw now ends at the IMU's first hole (helper aud2's audit).
    import logging

    import pandas as pd

    root = tmp_path / "demo"
    shutil.copytree(demo, root)
    toml = root / "mission.toml"
    toml.write_text(
        toml.read_text().replace("rate_hz = 100.0\n", "rate_hz = 100.0\nmax_gap_s = 400.0\n", 1)
    )
    imu = pd.read_parquet(root / "imu.parquet")
    keep = (imu["t_s"] <= 700.0) | (imu["t_s"] > 760.0)
    imu[keep].reset_index(drop=True).to_parquet(root / "imu.parquet", index=False)
    with caplog.at_level(logging.WARNING, logger="adaptnav"):
        load_mission(root)
    assert "samples lost" in caplog.text
    assert "off the course" not in caplog.text and "the direction of DVL" not in caplog.text
