"""A stream's cross-checks of the IMU's axes and the DVL's scale over its first window
(mission/live_cross.py; docs/streaming.md, 'Cross-checks'), on the simulated demo (906 s: 600 s
alongside, then under way).

The reference is the batch loader: its error for a table with the same fault (a gyro axis
negated, the DVL in knots), read from the mission folder by :func:`load_mission`. Up to 0.4.10
a stream made only the checks at rest of its alignment, and a stream started from a given
state with its gyro x negated, or aligning with its DVL in knots, ran to the end without a word.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav import api
from adaptnav.api.stream import IMU, Stream, replay
from adaptnav.mission import ImuData, Mission, MissionError, axes, load_mission
from adaptnav.mission.live import Reading
from adaptnav.mission.live_cross import CrossWatch
from adaptnav.mission.loader import cross_check

KNOTS = 1.943844
V = ["vx_m_s", "vy_m_s", "vz_m_s"]


@pytest.fixture(scope="module")
def right(demo: Path) -> Mission:
    return load_mission(demo)


def _gyro_negated(m: Mission, axis: int) -> Mission:
    dth = m.imu.dtheta.copy()
    dth[:, axis] *= -1.0
    return replace(m, imu=ImuData(m.imu.t, m.imu.dt, dth, m.imu.dvel))


def _dvl_in_knots(m: Mission) -> Mission:
    d = m.sensors["dvl"]
    z = d.z.copy()
    z[:, :3] *= KNOTS
    return replace(m, sensors={**m.sensors, "dvl": replace(d, z=z)})


def _dvl_late(m: Mission, late_s: float) -> Mission:
    d = m.sensors["dvl"]
    return replace(m, sensors={**m.sensors, "dvl": replace(d, t=d.t + late_s)})


def _batch_error(demo: Path, tmp_path: Path, table: str, columns: list[str], factor: float) -> str:
    """The loader's error for the demo folder with ``columns`` of ``table`` scaled."""
    root = tmp_path / "faulted"
    shutil.copytree(demo, root)
    df = pd.read_parquet(root / table)
    df[columns] = df[columns] * factor
    df.to_parquet(root / table)
    with pytest.raises(MissionError) as err:
        load_mission(root)
    return str(err.value)


def _watched(m: Mission, window_s: float) -> CrossWatch:
    """A CrossWatch fed the whole mission (IMU, then each sensor's readings), no filter run."""
    watch = CrossWatch(m.config, {n: d.period for n, d in m.sensors.items()}, window_s)
    imu = m.imu
    for k in range(imu.t.size):
        watch.imu(float(imu.t[k]), float(imu.dt[k]), imu.dtheta[k], imu.dvel[k])
    for name, d in m.sensors.items():
        for k in range(d.t.size):
            watch.reading(name, Reading(float(d.t[k]), d.z[k], int(d.rows[k])))
    return watch


def test_a_negated_gyro_x_is_refused_once_the_window_has_passed(
    demo: Path, right: Mission, tmp_path: Path
) -> None:
    """Started from a given state (no alignment, so no check at rest), with cross_check_s = 900:
    the first IMU sample past the window's end and the lags' second (901 s) is refused with the
    loader's words for the same data, the stream unchanged; every push after it is refused too,
    and close() gives the run so far. Up to 0.4.10 the stream ran on to the end."""
    faulted = _gyro_negated(right, 0)
    stream = Stream(faulted, "meskf", initial=api.initial_state(right)[:3], cross_check_s=900.0)
    items = replay(faulted)
    with pytest.raises(MissionError) as err:
        for item in items:
            stream.push_item(item)
    assert item.sensor == IMU and 901.0 < item.t <= 901.0 + 0.011, item
    words = str(err.value)
    assert words.startswith(f"IMU sample t = {item.t!r} s: the cross-checks over the stream's")
    assert "the gyro's x axis (dtheta_x_rad) against the roll of sensor 'inclinometer'" in words
    assert "it turns the opposite way" in words and "imu.axis_check = false" in words
    now = stream.t
    for again in (item, next(items)):
        with pytest.raises(MissionError) as err2:
            stream.push_item(again)
        assert str(err2.value) == words
    assert stream.t == now
    result = stream.close()
    assert result.solution["t_s"].iloc[-1] <= 901.0
    # The whole mission's batch verdict names the same axis (the window's slope differs).
    batch = _batch_error(demo, tmp_path, "imu.parquet", ["dtheta_x_rad"], -1.0)
    assert batch.split(" from t = ")[0] in words


def test_a_dvl_in_knots_is_refused_at_close_with_the_loaders_words(
    demo: Path, right: Mission, tmp_path: Path
) -> None:
    """Aligning, the default window (the 600-s alignment + 600 s) outlasts the 906-s demo: the
    checks are made at close() on everything pushed, which is the batch loader's mission, and
    give its error word for word (the block sums interpolate the gyro at 0.1 s: the same
    figures to their printed digits here). A second close() gives the run."""
    faulted = _dvl_in_knots(right)
    stream = Stream(faulted, "meskf")
    for item in replay(faulted):
        stream.push_item(item)
    with pytest.raises(MissionError) as err:
        stream.close()
    batch = _batch_error(demo, tmp_path, "dvl.parquet", V, KNOTS)
    words = str(err.value)
    assert words.startswith("the stream's close(): the cross-checks over the stream's first 906")
    assert f": {batch} Refused, and so is every push after it" in words
    assert "in knots" in batch and err.value.file == "dvl.parquet"
    assert err.value.field == "vx_m_s"
    assert stream.result is None
    assert len(stream.close().solution) > 0


@pytest.mark.parametrize("window", [300.0, math.inf])
def test_the_right_demo_streams_without_a_word(right: Mission, window: float) -> None:
    """The demo as simulated, aligning: judged at 901 s (300 s after the alignment) or at
    close() on everything; nothing found, and the rows are those of a stream without the
    checks (cross_check_s = 0)."""
    rows = []
    for after in (window, 0.0):
        with Stream(right, "meskf", cross_check_s=after) as stream:
            for item in replay(right):
                stream.push_item(item)
        assert stream.result is not None
        rows.append(stream.result.solution.to_numpy())
    np.testing.assert_array_equal(rows[0], rows[1])


@pytest.mark.parametrize("fault", ["right", "gyro x", "gyro y", "gyro z", "knots", "dvl late"])
def test_the_watch_gives_the_batch_verdict_on_the_whole_mission(right: Mission, fault: str) -> None:
    """Fed the whole mission, the stream's block sums give the loader's verdict on the loader's
    own per-sample views, word for word (None: both silent; a DVL stamped 18 s late since
    0.4.12; gyro z since 0.4.13, by the GNSS track mirrored against the DVL's dead reckoning
    and the earth rate at rest: up to 0.4.12 seen by neither on the demo, which has no heading
    sensor aiding)."""
    m = {
        "right": right,
        "gyro x": _gyro_negated(right, 0),
        "gyro y": _gyro_negated(right, 1),
        "gyro z": _gyro_negated(right, 2),
        "knots": _dvl_in_knots(right),
        "dvl late": _dvl_late(right, 18.0),
    }[fault]
    noise = m.config.imu.noise.to_imu_noise()
    views = axes.ImuViews(m.imu.t, m.imu.dt, m.imu.dtheta, m.imu.dvel, (noise.arw, noise.vrw))
    batch = None
    try:
        cross_check(m.config, views, dict(m.sensors))
    except MissionError as exc:
        batch = str(exc)
    found = _watched(m, math.inf).verdict()
    assert (None if found is None else str(found)) == batch
    assert (batch is None) == (fault == "right")


def test_block_sums_are_the_loaders_tilt_and_gyro_integral(right: Mission) -> None:
    """The identity the watch rests on: the accelerometers' 0.1-s block means of AccelTilt from
    the block sums are those from the samples (same blocks), and the gyro's integral at the
    blocks' ends is the per-sample integral there."""
    imu = right.imu
    watch = _watched(right, math.inf)
    views = watch.views()
    assert views is not None
    noise = right.config.imu.noise.to_imu_noise()
    full = axes.ImuViews(imu.t, imu.dt, imu.dtheta, imu.dvel, (noise.arw, noise.vrw))
    a, b = views.tilt(), full.tilt()
    np.testing.assert_allclose(a.t, b.t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.angles, b.angles, rtol=0, atol=1e-12)
    assert a.block_sigma == pytest.approx(b.block_sigma, rel=1e-9)
    g, h = views.gyro(), full.gyro()
    for axis in range(3):
        at = np.interp(g.t, h.t, h.theta[:, axis])
        np.testing.assert_allclose(g.theta[:, axis], at, rtol=0, atol=1e-12)


def test_the_switches_and_a_zero_window_leave_nothing_to_watch(right: Mission) -> None:
    """imu.axis_check = false with every DVL's and depth meter's scale_check = false, or
    cross_check_s = 0: the watch keeps nothing; either switch alone leaves the other check's
    sensors."""
    cfg = right.config
    no_axes = cfg.model_copy(update={"imu": cfg.imu.model_copy(update={"axis_check": False})})
    sensors = {
        n: s.model_copy(update={"scale_check": False}) if s.kind in ("dvl", "depth") else s
        for n, s in cfg.sensors.items()
    }
    no_scale = cfg.model_copy(update={"sensors": sensors})
    both = no_axes.model_copy(update={"sensors": sensors})
    assert CrossWatch(both, {}, 600.0).done
    for bad in (-1.0, math.nan):
        with pytest.raises(ValueError, match="cross_check_s"):
            Stream(right, cross_check_s=bad)
    assert CrossWatch(cfg, {}, 0.0).done
    assert not CrossWatch(no_axes, {}, 600.0).done and not CrossWatch(no_scale, {}, 600.0).done
    knots = _dvl_in_knots(right)
    assert _watched(replace(knots, config=no_scale), math.inf).verdict() is None
    gyro_x = _gyro_negated(right, 0)
    assert _watched(replace(gyro_x, config=no_axes), math.inf).verdict() is None


def test_the_watch_keeps_its_window_only(right: Mission) -> None:
    """Memory: 8 doubles per 0.1-s block of the window (and a second past it), nothing of the
    samples or readings after; 600 s of the demo's 100-Hz IMU hold 48 kB of blocks."""
    watch = _watched(right, 600.0)
    assert watch.nbytes == pytest.approx(8 * 8 * 6010, abs=8 * 8 * 2)
    assert max(r.t for rs in watch._readings.values() for r in rs) <= watch.end
