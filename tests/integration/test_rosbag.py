"""ROS 2 bags: a simulated mission written as a bag by ``rosbags``' own writer imports back to
the same tables and the same run; frames on known motion; errors and repairs; the run's
solution exported as Odometry reads back (adaptnav.importers.rosbag, docs/rosbag.md)."""

from __future__ import annotations

import datetime as dt
import json
import logging
import math
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from rosbags.highlevel import AnyReader
from typer.testing import CliRunner

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.cli import app
from adaptnav.core import earth
from adaptnav.importers.rosbag import RosbagError, import_bag
from adaptnav.mission import load_mission
from adaptnav.sim.scenarios import simulate
from helpers import rosbags_writer as rw

SENSOR_TOPICS = {
    "dvl": "/dvl/twist",
    "depth": "/depth/pressure",
    "inclinometer": "/inclinometer",
    "heading": "/heading",
    "gnss": "/gps/fix",
}
COLUMNS = {
    "dvl": ["t_s", "vx_m_s", "vy_m_s", "vz_m_s"],
    "depth": ["t_s", "depth_m"],
    "inclinometer": ["t_s", "roll_rad", "pitch_rad"],
    "heading": ["t_s", "yaw_rad"],
    "gps": ["t_s", "lat_rad", "lon_rad"],
}
STAMP_TOL_S = 1e-9
"""Stamps are whole nanoseconds: mission time comes back to within 0.5 ns."""


class Trip:
    """The demo mission (seed 1), its sqlite3 bag and the bag's import, made once."""

    def __init__(self, root: Path) -> None:
        self.original = simulate("demo", 1, root / "original")
        self.bag = rw.mission_to_bag(self.original, root / "bag", "sqlite3")
        self.imported = import_bag(
            self.bag,
            root / "imported",
            topics=SENSOR_TOPICS | {"imu": "/imu"},
            config=self.original / "mission.toml",
        )
        self.root = root


@pytest.fixture(scope="module")
def trip(tmp_path_factory: pytest.TempPathFactory) -> Trip:
    return Trip(tmp_path_factory.mktemp("rosbag"))


def _assert_tables_equal(original: Path, imported: Path, t_max: float = math.inf) -> None:
    """Readings equal to float precision (the IMU through rate = increment / interval and
    back: 1e-9 relative), stamps to the nanosecond."""
    a = pd.read_parquet(original / "imu.parquet")
    a = a[a["t_s"] < t_max]
    b = pd.read_parquet(imported / "imu.parquet")
    np.testing.assert_allclose(b["t_s"], a["t_s"], rtol=0, atol=STAMP_TOL_S)
    np.testing.assert_allclose(b.iloc[:, 1:], a.iloc[:, 1:], rtol=1e-9, atol=1e-15)
    for table, cols in COLUMNS.items():
        a = pd.read_parquet(original / f"{table}.parquet")[cols]
        a = a[a["t_s"] < t_max]
        b = pd.read_parquet(imported / f"{table}.parquet")[cols]
        np.testing.assert_allclose(b["t_s"], a["t_s"], rtol=0, atol=STAMP_TOL_S)
        np.testing.assert_allclose(b.iloc[:, 1:], a.iloc[:, 1:], rtol=1e-12, atol=1e-12)


def test_sqlite3_round_trip_gives_the_original_tables(trip: Trip) -> None:
    _assert_tables_equal(trip.original, trip.imported)
    info = json.loads((trip.imported / "import.json").read_text())
    assert info["stamp_origin_ns"] == rw.STAMP0_NS and info["repairs"] == []
    assert info["roles"]["dvl"]["frame_ids"] == ["dvl_link"]
    assert info["roles"]["dvl"]["sigma_source"] == "config"


def test_imported_mission_runs_to_the_original_rmse(trip: Trip) -> None:
    """The issue's target: the run on the imported mission within 1 % of the original's
    RMSE (both scored against the simulator's truth, same filter, own alignment)."""
    original = load_mission(trip.original)
    rmse = []
    for mission in (original, load_mission(trip.imported)):
        result = api.run(mission, "robust")
        rmse.append(evaluate.rmse(evaluate.position_errors(result.solution, original.truth)))
    print(f"RMSE original {rmse[0]:.9f} m, imported {rmse[1]:.9f} m")
    assert abs(rmse[1] / rmse[0] - 1.0) < 0.01


def test_mcap_round_trip(trip: Trip, tmp_path: Path) -> None:
    """The MCAP storage: the first 60 s of the mission through a bag and back."""
    short = tmp_path / "short"
    short.mkdir()
    (short / "mission.toml").write_text((trip.original / "mission.toml").read_text())
    for f in ("imu", "dvl", "depth", "inclinometer", "heading", "gps"):
        t = pd.read_parquet(trip.original / f"{f}.parquet")
        t[t["t_s"] < 60.0].to_parquet(short / f"{f}.parquet")
    bag = rw.mission_to_bag(short, tmp_path / "bag", "mcap")
    assert next(bag.glob("*.mcap")).is_file()
    out = import_bag(bag, tmp_path / "m", topics=SENSOR_TOPICS, config=short / "mission.toml")
    _assert_tables_equal(trip.original, out, t_max=60.0)


# --- frames on known motion -------------------------------------------------------------------


def _known_motion_bag(path: Path) -> Path:
    """A level vehicle heading east (ROS yaw 0), nose up 0.1 rad (ROS pitch -0.1), turning
    left at 0.1 rad/s (ROS +z), at rest in gravity (ROS +z up 9.8 m/s²), DVL 1 m/s forward
    and 0.5 m/s to the left, 10 m of water, a fix with ENU variances (1, 4, 9) m²."""
    n, q_east = 5, rw.quat_zyx(0.0, -0.1, 0.0)
    imu = [
        (
            0.01 * k,
            rw.T["sensor_msgs/msg/Imu"](
                rw.header(0.01 * k, "base_link"),
                q_east,
                rw.diag(3, [1e-4] * 3),
                rw.vec(0.0, 0.0, 0.1),
                rw.diag(3, [1e-6] * 3),
                rw.vec(0.0, 0.0, 9.8),
                rw.diag(3, [4e-4] * 3),
            ),
        )
        for k in range(1, 101)
    ]
    tw = rw.T["geometry_msgs/msg/Twist"](rw.vec(1.0, 0.5, 0.0), rw.vec(0.0, 0.0, 0.0))
    cov = np.zeros(36)
    cov[[0, 7, 14]] = 0.01**2
    dvl = [
        (
            0.2 * k,
            rw.T["geometry_msgs/msg/TwistWithCovarianceStamped"](
                rw.header(0.2 * k, "dvl_link"),
                rw.T["geometry_msgs/msg/TwistWithCovariance"](tw, cov),
            ),
        )
        for k in range(1, n)
    ]
    pressure = [
        (
            0.2 * k,
            rw.T["sensor_msgs/msg/FluidPressure"](
                rw.header(0.2 * k, "p"), rw.P_ATM + rw.RHO * rw.G * 10.0, (rw.RHO * rw.G * 0.1) ** 2
            ),
        )
        for k in range(1, n)
    ]
    fix = [
        (
            0.2 * k,
            rw.T["sensor_msgs/msg/NavSatFix"](
                rw.header(0.2 * k, "gps"),
                rw.T["sensor_msgs/msg/NavSatStatus"](0, 1),
                26.8,
                56.0,
                3.0,
                rw.diag(3, [1.0, 4.0, 9.0]),
                2,
            ),
        )
        for k in range(1, n)
    ]
    return rw.write_bag(
        path,
        {
            "/imu": ("sensor_msgs/msg/Imu", imu),
            "/dvl": ("geometry_msgs/msg/TwistWithCovarianceStamped", dvl),
            "/p": ("sensor_msgs/msg/FluidPressure", pressure),
            "/fix": ("sensor_msgs/msg/NavSatFix", fix),
            "/q": (
                "geometry_msgs/msg/QuaternionStamped",
                [(0.1, rw.T["geometry_msgs/msg/QuaternionStamped"](rw.header(0.1, "q"), q_east))],
            ),
        },
    )


def test_frames_units_and_covariances_on_known_motion(tmp_path: Path) -> None:
    bag = _known_motion_bag(tmp_path / "bag")
    out = import_bag(
        bag,
        tmp_path / "m",
        topics={"dvl": "/dvl", "gnss": "/fix", "heading": "/imu", "inclinometer": "/imu"},
    )
    imu = pd.read_parquet(out / "imu.parquet")
    np.testing.assert_allclose(
        imu[["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]].iloc[1:],
        [[0.0, 0.0, -0.1 * 0.01]] * 99,
        atol=1e-15,
    )  # FRD z is down
    np.testing.assert_allclose(imu["dvel_z_m_s"], -9.8 * 0.01, rtol=1e-9)
    heading = pd.read_parquet(out / "heading.parquet")
    np.testing.assert_allclose(heading["yaw_rad"], math.pi / 2, atol=1e-12)  # east
    incl = pd.read_parquet(out / "inclinometer.parquet")
    np.testing.assert_allclose(incl[["roll_rad", "pitch_rad"]], [[0.0, 0.1]] * 100, atol=1e-12)
    dvl = pd.read_parquet(out / "dvl.parquet")
    np.testing.assert_allclose(dvl[["vx_m_s", "vy_m_s", "vz_m_s"]], [[1.0, -0.5, 0.0]] * 4)
    gps = pd.read_parquet(out / "gnss.parquet")
    np.testing.assert_allclose(
        gps[["lat_rad", "lon_rad", "h_m"]], [[math.radians(26.8), math.radians(56.0), 3.0]] * 4
    )
    cfg = load_mission(out).config
    assert cfg.sensors["gnss"].use_height is True  # no depth topic: the fix's height is used
    assert cfg.sensors["gnss"].sigma == ([2.0, 1.0, 3.0], "m")  # N, E, D from ENU (1, 4, 9)
    assert cfg.sensors["dvl"].sigma == ([0.01, 0.01, 0.01], "m/s")
    assert cfg.sensors["heading"].sigma[0] == pytest.approx([0.01])
    # An orientation is an attitude output: up to 0.4.6 it was modelled as a pendulum.
    assert cfg.sensors["inclinometer"].model == "attitude"
    arw = cfg.imu.noise.arw
    assert arw[1] == "rad/sqrt(s)" and arw[0] == pytest.approx(1e-3 * math.sqrt(0.01))
    assert cfg.imu.rate_hz == pytest.approx(100.0)
    depth = import_bag(bag, tmp_path / "d", topics={"depth": "/p", "gnss": "/fix"})
    np.testing.assert_allclose(pd.read_parquet(depth / "depth.parquet")["depth_m"], 10.0)
    assert load_mission(depth).config.sensors["depth"].sigma[0] == pytest.approx([0.1])


# --- errors and repairs -----------------------------------------------------------------------


def _cli(*args: str) -> tuple[int, str]:
    res = CliRunner().invoke(app, list(args))
    return res.exit_code, res.output


def test_bad_bags_and_topics_exit_2(tmp_path: Path) -> None:
    bag = _known_motion_bag(tmp_path / "bag")
    out = str(tmp_path / "m")
    code, text = _cli("import", "rosbag", str(bag), "--out", out, "--dvl", "/nope")
    assert (
        code == 2 and "no topic /nope (--dvl)" in text and "/fix (sensor_msgs/msg/NavSatFix" in text
    )
    code, text = _cli("import", "rosbag", str(bag), "--out", out, "--dvl", "/fix")
    assert (
        code == 2
        and "/fix is sensor_msgs/msg/NavSatFix, --dvl takes geometry_msgs/msg/Twist" in text
    )
    code, text = _cli("import", "rosbag", str(tmp_path), "--out", out)
    assert code == 2 and "not a readable ROS 2 bag" in text and "Traceback" not in text
    no_imu = rw.write_bag(tmp_path / "no-imu", {"/fix": ("sensor_msgs/msg/NavSatFix", [])})
    code, text = _cli("import", "rosbag", str(no_imu), "--out", out)
    assert code == 2 and "no sensor_msgs/msg/Imu topics" in text
    code, text = _cli("import", "rosbag", str(bag), "--out", out, "--heading", "/dvl")
    assert code == 2 and "--heading takes" in text
    assert not Path(out).exists()


def test_no_covariance_and_no_config_is_an_error(tmp_path: Path) -> None:
    imu = pd.DataFrame(
        {
            "t_s": [0.01, 0.02],
            **dict.fromkeys(
                ["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dvel_x_m_s", "dvel_y_m_s"], 0.0
            ),
            "dvel_z_m_s": -0.098,
        }
    )
    plain = rw.write_bag(
        tmp_path / "plain",
        {"/imu": ("sensor_msgs/msg/Imu", rw.imu_messages(imu, 100.0, cov=False))},
    )
    with pytest.raises(RosbagError, match=r"topic /imu \(--imu\).*--config"):
        import_bag(plain, tmp_path / "m", topics={})
    bag = _known_motion_bag(tmp_path / "bag")
    with pytest.raises(RosbagError, match=r"/q \(--heading\): its messages carry no covariance"):
        import_bag(bag, tmp_path / "m", topics={"gnss": "/fix", "heading": "/q"})


def test_imu_messages_without_an_orientation_are_left_out(tmp_path: Path) -> None:
    """An AHRS whose filter has not converged marks its orientation not provided
    (orientation_covariance[0] = -1) and sends the identity quaternion: those messages are
    left out, recorded, and the rest read. Up to 0.4.7 only the first message was checked:
    with it valid, 199 identity quaternions came in as a heading of 90° and a roll of 0 (the
    vehicle heading 30°, rolled 5°); with it not valid, the topic was refused whole."""
    q = rw.ros_quat(math.radians(5.0), 0.0, math.radians(30.0))
    identity = rw.T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)
    imu = []
    for k in range(1, 501):
        valid = k > 200  # the first message is set below
        m = _level_imu(0.01 * k)
        m.orientation, m.orientation_covariance = (
            (q, rw.diag(3, [1e-4] * 3)) if valid else (identity, rw.NOT_PROVIDED)
        )
        imu.append((0.01 * k, m))
    status = rw.T["sensor_msgs/msg/NavSatStatus"](0, 1)
    fix = rw.T["sensor_msgs/msg/NavSatFix"]
    fixes = [
        (t, fix(rw.header(t, "gps"), status, 26.8, 56.0, 0.0, rw.diag(3, [1.0] * 3), 2))
        for t in np.arange(1, 50) / 10.0
    ]
    topics = {"gnss": "/fix", "heading": "/imu", "inclinometer": "/imu"}
    for first_valid in (True, False):
        imu[0][1].orientation, imu[0][1].orientation_covariance = (
            (q, rw.diag(3, [1e-4] * 3)) if first_valid else (identity, rw.NOT_PROVIDED)
        )
        bag = rw.write_bag(
            tmp_path / f"bag{first_valid}",
            {"/imu": ("sensor_msgs/msg/Imu", imu), "/fix": ("sensor_msgs/msg/NavSatFix", fixes)},
        )
        out = import_bag(bag, tmp_path / f"m{first_valid}", topics=topics)
        heading = pd.read_parquet(out / "heading.parquet")
        incl = pd.read_parquet(out / "inclinometer.parquet")
        assert len(heading) == len(incl) == 300 + first_valid
        np.testing.assert_allclose(heading["yaw_rad"], math.radians(30.0), atol=1e-12)
        np.testing.assert_allclose(incl["roll_rad"], math.radians(5.0), atol=1e-12)
        repairs = json.loads((out / "import.json").read_text())["repairs"]
        left = [r for r in repairs if r["field"] == "orientation_covariance"]
        assert [r["action"] for r in left] == ["not provided (covariance[0] = -1): left out"] * 2
        assert left[0]["detail"].startswith(f"{200 - first_valid} messages")
    for _, m in imu:
        m.orientation_covariance = rw.NOT_PROVIDED
    bag = rw.write_bag(tmp_path / "none", {"/imu": ("sensor_msgs/msg/Imu", imu)})
    with pytest.raises(RosbagError, match=r"carry no orientation"):
        import_bag(bag, tmp_path / "none-m", topics={"heading": "/imu"})


def test_fixes_without_altitude_do_not_aid_the_height(tmp_path: Path) -> None:
    """NavSatFix's altitude is NaN where the receiver gives none: without a depth topic and
    --config, the GNSS section's use_height is false and its σ (N, E). Up to 0.4.7 it was
    true, and every fix was dropped at the run as non-finite ("no valid fix ... to align
    at")."""
    status = rw.T["sensor_msgs/msg/NavSatStatus"](0, 1)
    fix = rw.T["sensor_msgs/msg/NavSatFix"]
    fixes = [
        (t, fix(rw.header(t, "gps"), status, 26.8, 56.0, math.nan, rw.diag(3, [1.0, 4.0, 9.0]), 2))
        for t in np.arange(1, 50) / 10.0
    ]
    imu = [(0.01 * k, _level_imu(0.01 * k)) for k in range(1, 501)]
    bag = rw.write_bag(
        tmp_path / "bag",
        {"/imu": ("sensor_msgs/msg/Imu", imu), "/fix": ("sensor_msgs/msg/NavSatFix", fixes)},
    )
    m = load_mission(import_bag(bag, tmp_path / "m", topics={"gnss": "/fix"}))
    assert m.config.sensors["gnss"].use_height is False
    assert m.config.sensors["gnss"].sigma == ([2.0, 1.0], "m")
    assert m.sensors["gnss"].z.shape == (49, 2) and np.isfinite(m.sensors["gnss"].z).all()


def test_zero_variances_give_no_sigma(tmp_path: Path) -> None:
    """Fixes whose covariance (type 2, diagonal known) is all zero, half of them, the rest
    with ENU variances (1, 4, 9) m²: σ (N, E, D) = (2, 1, 3) m from the others. Up to 0.4.7
    the zeros were σ = 0: the median gave (1, 0.5, 1.5) m, exit 0; with more than half of
    them, σ = 0 and a refusal that named no covariance."""
    status = rw.T["sensor_msgs/msg/NavSatStatus"](0, 1)
    fix = rw.T["sensor_msgs/msg/NavSatFix"]
    fixes = [
        (t, fix(rw.header(t, "gps"), status, 26.8, 56.0, 3.0,
                rw.diag(3, [0.0] * 3 if k % 2 else [1.0, 4.0, 9.0]), 2))
        for k, t in enumerate(np.arange(1, 49) / 10.0)
    ]  # fmt: skip
    imu = [(0.01 * k, _level_imu(0.01 * k)) for k in range(1, 501)]
    bag = rw.write_bag(
        tmp_path / "bag",
        {"/imu": ("sensor_msgs/msg/Imu", imu), "/fix": ("sensor_msgs/msg/NavSatFix", fixes)},
    )
    m = load_mission(import_bag(bag, tmp_path / "m", topics={"gnss": "/fix"}))
    assert m.config.sensors["gnss"].sigma == ([2.0, 1.0, 3.0], "m")


def _level_imu(stamp_s: float, yaw_rate: float = 0.0) -> Any:
    """A level IMU's message at ``stamp_s`` (s after STAMP0): turning at ``yaw_rate`` (rad/s,
    ROS +z), gravity on +z, no orientation; its z acceleration moves by a µm/s² from message to
    message, as a real IMU's noise does (since 0.4.9 six values unchanged for a second are a
    frozen IMU: imu.stuck_s)."""
    return rw.T["sensor_msgs/msg/Imu"](
        rw.header(stamp_s, "b"),
        rw.quat_zyx(0, 0, 0),
        rw.NOT_PROVIDED,
        rw.vec(0, 0, yaw_rate),
        rw.diag(3, [1e-6] * 3),
        rw.vec(0, 0, 9.8 + 1e-6 * math.sin(1e3 * stamp_s)),
        rw.diag(3, [1e-4] * 3),
    )


def test_out_of_order_repeated_and_unset_stamps_are_repaired(tmp_path: Path) -> None:
    """Bag order is arrival order: a message stamped before its predecessor is sorted, a
    repeated IMU stamp dropped, an unset (zero) stamp replaced by the log time, a fix with
    no fix left out; each recorded in import.json, and the mission loads."""
    ts = [0.01 * k for k in range(1, 51)]
    order = [*ts[:10], ts[11], ts[10], *ts[12:20], ts[19], *ts[20:]]
    imu = []
    for t in order:
        m = _level_imu(t, yaw_rate=0.1)
        imu.append((0.01 * (len(imu) + 1) + 0.001, m))  # arrival order, 1 ms late
    imu[30][1].header.stamp = rw.T["builtin_interfaces/msg/Time"](0, 0)
    fixes = [
        (
            t,
            rw.T["sensor_msgs/msg/NavSatFix"](
                rw.header(t, "gps"),
                rw.T["sensor_msgs/msg/NavSatStatus"](-1 if k == 2 else 0, 1),
                26.8,
                56.0,
                0.0,
                rw.diag(3, [1.0, 1.0, 1.0]),
                2,
            ),
        )
        for k, t in enumerate(ts[::5])
    ]
    bag = rw.write_bag(
        tmp_path / "bag",
        {"/imu": ("sensor_msgs/msg/Imu", imu), "/fix": ("sensor_msgs/msg/NavSatFix", fixes)},
    )
    out = import_bag(bag, tmp_path / "m", topics={"gnss": "/fix"})
    actions = [r["action"] for r in json.loads((out / "import.json").read_text())["repairs"]]
    assert actions == [
        "zero stamp: bag log time used",
        "sorted by header stamp",
        "repeated stamp: later message dropped",
        "no fix: left out",
    ]
    m = load_mission(out)
    stamps = sorted({*ts[:29], 0.311, *ts[30:]})  # order[30] = ts[29]: log time 0.311 instead
    np.testing.assert_allclose(m.imu.t, np.array(stamps), atol=STAMP_TOL_S)
    assert m.sensors["gnss"].t.size == 9


def test_an_imu_clock_that_steps_back_is_an_error_not_a_sort(tmp_path: Path) -> None:
    """IMU stamps that step back 0.29 s (29 periods) and go on from there are a clock step:
    sorting interleaved two stretches of the IMU (each increment over a wrong interval) and
    logged it as a sort. It is an error naming the message and --log-time; a swap of two
    neighbours is still sorted, and its repair says how far the stamps stepped back."""
    ts = [0.01 * k for k in range(1, 201)]
    stepped = [t - 0.3 if k >= 100 else t for k, t in enumerate(ts)]
    imu = [(0.01 * (k + 1) + 0.001, _level_imu(t, yaw_rate=0.1)) for k, t in enumerate(stepped)]
    bag = rw.write_bag(tmp_path / "bag", {"/imu": ("sensor_msgs/msg/Imu", imu)})
    with pytest.raises(RosbagError, match=r"step back 0\.29 s .* at message 100.*--log-time /imu"):
        import_bag(bag, tmp_path / "m", topics={})
    res = CliRunner().invoke(app, ["import", "rosbag", str(bag), "--out", str(tmp_path / "c")])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    swapped = [*ts[:10], ts[11], ts[10], *ts[12:]]
    imu = [(0.01 * (k + 1) + 0.001, _level_imu(t, yaw_rate=0.1)) for k, t in enumerate(swapped)]
    fix = rw.T["sensor_msgs/msg/NavSatFix"]
    status = rw.T["sensor_msgs/msg/NavSatStatus"](0, 1)
    fixes = [
        (t, fix(rw.header(t, "gps"), status, 26.8, 56.0, 0.0, rw.diag(3, [1.0] * 3), 2))
        for t in ts[::10]
    ]
    bag = rw.write_bag(
        tmp_path / "bag2",
        {"/imu": ("sensor_msgs/msg/Imu", imu), "/fix": ("sensor_msgs/msg/NavSatFix", fixes)},
    )
    out = import_bag(bag, tmp_path / "m2", topics={"gnss": "/fix"})
    (r,) = json.loads((out / "import.json").read_text())["repairs"]
    assert r["action"] == "sorted by header stamp"
    assert "largest step back 0.01 s at message 11 (1.00 sampling periods)" in r["detail"]


FAR = "stamp far from the topic's clock: left out"


def _clocked_bag(
    path: Path,
    imu_stamp: Callable[[float], float] = lambda t: t,
    dvl_stamp: Callable[[float], float] = lambda t: t,
    seconds: float = 60.0,
    dvl_from_s: float = 0.0,
    fix_stamp: Callable[[float], float] | None = None,
) -> Path:
    """A resting IMU at 100 Hz, a GNSS fix at 1 Hz and a DVL at 5 Hz whose header stamps are
    ``imu_stamp(t)``, ``fix_stamp(t)`` (default: the IMU's) and ``dvl_stamp(t)`` (s after
    STAMP0) for the log time t, 2 ms after it."""
    imu = [
        (
            t + 0.002,
            _level_imu(imu_stamp(t)),
        )
        for t in np.arange(1, round(100 * seconds)) / 100.0
    ]
    twist = rw.T["geometry_msgs/msg/Twist"](rw.vec(0.0, 0.0, 0.0), rw.vec(0.0, 0.0, 0.0))
    cov = np.zeros(36)
    cov[[0, 7, 14]] = 0.01**2
    dvl = [
        (
            t + 0.002,
            rw.T["geometry_msgs/msg/TwistWithCovarianceStamped"](
                rw.header(dvl_stamp(t), "d"),
                rw.T["geometry_msgs/msg/TwistWithCovariance"](twist, cov),
            ),
        )
        for t in np.arange(round(5 * dvl_from_s) + 1, round(5 * seconds)) / 5.0
    ]
    fixes = [
        (
            t + 0.002,
            rw.T["sensor_msgs/msg/NavSatFix"](
                rw.header((fix_stamp or imu_stamp)(t), "gps"),
                rw.T["sensor_msgs/msg/NavSatStatus"](0, 1),
                26.8,
                56.0,
                0.0,
                rw.diag(3, [1.0, 1.0, 1.0]),
                2,
            ),
        )
        for t in np.arange(1, round(seconds))
    ]
    topics = {
        "/imu": ("sensor_msgs/msg/Imu", imu),
        "/dvl": ("geometry_msgs/msg/TwistWithCovarianceStamped", dvl),
        "/fix": ("sensor_msgs/msg/NavSatFix", fixes),
    }
    return rw.write_bag(path, topics)


def test_stamps_far_from_their_topics_clock_are_left_out(tmp_path: Path) -> None:
    """Five IMU messages stamped in 1970 (a driver's clock reset) among good ones: left out
    and recorded, and mission time starts at the good stamps (before, the origin went to
    1970 and every other reading to 1.7e9 s)."""
    bad = {3000, 3001, 4500, 5000, 5001}
    bag = _clocked_bag(
        tmp_path / "bag",
        imu_stamp=lambda t: t - 1.7e9 if round(100 * t) in bad else t,
    )
    out = import_bag(bag, tmp_path / "m", topics={"dvl": "/dvl", "gnss": "/fix"})
    info = json.loads((out / "import.json").read_text())
    far = {r["file"]: r for r in info["repairs"] if r["action"] == FAR}
    assert set(far) == {"/imu", "/fix"}  # the fixes at 30, 45 and 50 s share the IMU clock
    assert far["/imu"]["detail"].startswith("5 messages, the first at message 2999")
    assert far["/fix"]["detail"].startswith("3 messages, the first at message 29")
    assert "(stamped 1970-01-01T00:00:30+00:00, -1.7e+09 s from" in far["/imu"]["detail"]
    assert info["stamp_origin_ns"] == rw.STAMP0_NS
    m = load_mission(out)
    assert m.imu.t.size == 5999 - 5 and m.imu.t.max() < 60.0
    assert m.sensors["gnss"].t.size == 59 - 3 and m.sensors["dvl"].t.size == 299


def test_a_topic_on_its_own_clock_is_an_error_naming_it_or_timed_by_its_log_times(
    tmp_path: Path,
) -> None:
    """A DVL driver stamping with time since its boot: refused, naming the topic and
    --log-time; with --log-time the DVL is timed by the bag's log times."""
    bag = _clocked_bag(tmp_path / "bag", dvl_stamp=lambda t: t - 1.7e9 + 300.0)
    with pytest.raises(RosbagError, match=r"topic /dvl \(--dvl\) is stamped on another clock"):
        import_bag(bag, tmp_path / "m", topics={"dvl": "/dvl", "gnss": "/fix"})
    code, text = _cli(
        "import",
        "rosbag",
        str(bag),
        "--out",
        str(tmp_path / "m"),
        "--dvl",
        "/dvl",
        "--gnss",
        "/fix",
    )
    assert code == 2 and "--log-time /dvl takes its log times" in text
    code, text = _cli(
        "import", "rosbag", str(bag), "--out", str(tmp_path / "m"), "--dvl", "/dvl",
        "--gnss", "/fix", "--log-time", "/dvl",
    )  # fmt: skip
    assert code == 0, text
    info = json.loads((tmp_path / "m" / "import.json").read_text())
    repair = {"file": "/dvl", "line": None, "field": "header.stamp",
              "action": "bag log time used", "detail": "299 messages (--log-time)"}  # fmt: skip
    assert repair in info["repairs"]
    dvl = load_mission(tmp_path / "m").sensors["dvl"].t
    np.testing.assert_allclose(dvl, np.arange(1, 300) / 5.0 + 0.002, atol=STAMP_TOL_S)
    code, text = _cli(
        "import", "rosbag", str(bag), "--out", str(tmp_path / "m2"), "--dvl", "/dvl",
        "--gnss", "/fix", "--log-time", "/nope",
    )  # fmt: skip
    assert code == 2 and "--log-time /nope is not an imported topic" in text


def test_an_imu_on_its_own_clock_is_named_as_the_odd_one(tmp_path: Path) -> None:
    """The IMU on time since boot, the DVL and the fixes on the recorder's clock: the error
    names the IMU, not the topics that agree with each other."""
    bag = _clocked_bag(
        tmp_path / "bag", imu_stamp=lambda t: t - 1.7e9 + 300.0, fix_stamp=lambda t: t
    )
    topics = {"dvl": "/dvl", "gnss": "/fix"}
    with pytest.raises(RosbagError, match=r"the IMU /imu is stamped on another clock than every"):
        import_bag(bag, tmp_path / "m", topics=topics)
    out = import_bag(bag, tmp_path / "m", topics=topics, log_time=["/imu"])
    assert load_mission(out).imu.t.size == 5999


def test_clocks_drifting_together_are_one_clock(tmp_path: Path) -> None:
    """Simulated time at half the speed of the recorder's: the stamps' offsets to the log
    times drift by 30 s over the bag, for the DVL (from 50 s only) as for the IMU; nothing is
    left out and nothing refused."""
    bag = _clocked_bag(
        tmp_path / "bag", imu_stamp=lambda t: t / 2, dvl_stamp=lambda t: t / 2, dvl_from_s=50.0
    )
    out = import_bag(bag, tmp_path / "m", topics={"dvl": "/dvl", "gnss": "/fix"})
    assert json.loads((out / "import.json").read_text())["repairs"] == []
    m = load_mission(out)
    assert m.imu.t.size == 5999 and m.sensors["dvl"].t.size == 49


# --- export ----------------------------------------------------------------------------------


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_export_odometry_reads_back(trip: Trip, tmp_path: Path, storage: str) -> None:
    run = tmp_path / "run"
    api.results.save(api.run(load_mission(trip.imported), "meskf"), run)
    code, text = _cli(
        "export", "rosbag", str(run), "--out", str(tmp_path / "odo"), "--storage", storage
    )
    assert code == 0, text
    sol = api.results.load(run).solution
    with AnyReader([tmp_path / "odo"], default_typestore=rw.TYPESTORE) as r:
        assert {c.topic: c.msgtype for c in r.connections} == {
            "/adaptnav/odometry": "nav_msgs/msg/Odometry",
            "/adaptnav/datum": "sensor_msgs/msg/NavSatFix",
        }
        msgs = {
            c.topic: [r.deserialize(raw, c.msgtype) for c, _, raw in r.messages([c])]
            for c in r.connections
        }
    odo, (datum,) = msgs["/adaptnav/odometry"], msgs["/adaptnav/datum"]
    assert len(odo) == len(sol) and odo[0].header.frame_id == "map"
    k = len(sol) // 2
    stamp = odo[k].header.stamp
    assert stamp.sec * 10**9 + stamp.nanosec - rw.STAMP0_NS == round(sol["t_s"].iloc[k] * 1e9)
    ned = earth.geodetic_to_ned(
        sol["lat_rad"].iloc[k],
        sol["lon_rad"].iloc[k],
        sol["h_m"].iloc[k],
        math.radians(datum.latitude),
        math.radians(datum.longitude),
        datum.altitude,
    )
    p = odo[k].pose.pose.position
    np.testing.assert_allclose([p.y, p.x, -p.z], ned, atol=1e-6)  # ENU
    # the map frame (ENU at the datum) ← the row's local ENU, through ECEF
    M = _geodetic_axes(math.radians(datum.latitude), math.radians(datum.longitude)) @ (
        _geodetic_axes(sol["lat_rad"].iloc[k], sol["lon_rad"].iloc[k]).T
    )
    cov = odo[k].pose.covariance.reshape(6, 6)
    sd = sol[["sd_dr_E", "sd_dr_N", "sd_dr_D"]].iloc[k].to_numpy()
    P = np.diag(sd**2)
    P[0, 1] = P[1, 0] = sol["cov_dr_N_dr_E"].iloc[k]
    P[0, 2] = P[2, 0] = -sol["cov_dr_E_dr_D"].iloc[k]
    P[1, 2] = P[2, 1] = -sol["cov_dr_N_dr_D"].iloc[k]  # (E, N, U) of the row
    np.testing.assert_allclose(cov[:3, :3], M @ P @ M.T, rtol=1e-9, atol=1e-12)
    q = odo[k].pose.pose.orientation
    e = rw.ros_quat(*sol[["roll_rad", "pitch_rad", "yaw_rad"]].iloc[k])  # in the local ENU
    expect = M @ _quat_matrix(e.x, e.y, e.z, e.w)
    np.testing.assert_allclose(_quat_matrix(q.x, q.y, q.z, q.w), expect, atol=1e-12)
    speed = np.hypot(*sol[["vn_m_s", "ve_m_s", "vd_m_s"]].iloc[k].to_numpy()[:2])
    v = odo[k].twist.twist.linear
    assert math.hypot(v.x, v.y, v.z) == pytest.approx(
        np.linalg.norm(sol[["vn_m_s", "ve_m_s", "vd_m_s"]].iloc[k]), rel=1e-9
    )
    assert speed > 0.1 and v.x > 0.9 * speed  # under way, mostly forward in FLU


def _geodetic_axes(lat: float, lon: float) -> np.ndarray:
    """East, north and up at (lat, lon) as ECEF unit vectors (rows), from the ellipsoid's
    normal: up = (cos L cos λ, cos L sin λ, sin L)."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])


def _quat_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """The rotation matrix of a unit quaternion given [x, y, z, w] (ROS's order)."""
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def test_far_from_the_datum_the_pose_is_in_the_map_frame() -> None:
    """A level vehicle heading east along 60° N, 100 km east of the datum: its forward, left
    and up axes are the local east, north and up, which in the map frame (the ENU tangent
    plane at the datum, where the position is) are turned by the Earth's curvature. Up to
    0.4.7 the orientation and the pose covariance were those of the local ENU: the
    orientation said yaw 0°, pitch 0° where the body's axes in the map frame have yaw 1.56°
    and pitch 0.90° (the track's own direction at that point)."""
    from adaptnav.importers.rosbag import odometry_rows

    n, lat = 3, math.radians(60.0)
    lon = math.radians(10.0) + np.radians([0.0, 0.9, 1.8])
    cols: dict[str, Any] = {
        "t_s": np.arange(n, dtype=float), "lat_rad": np.full(n, lat), "lon_rad": lon,
        "h_m": np.zeros(n), "vn_m_s": np.zeros(n), "ve_m_s": np.full(n, 2.0),
        "vd_m_s": np.zeros(n), "roll_rad": np.zeros(n), "pitch_rad": np.zeros(n),
        "yaw_rad": np.full(n, math.pi / 2),
    }  # fmt: skip
    for c in ("dr_N", "dr_E", "dr_D", "dv_N", "dv_E", "dv_D", "phi_N", "phi_E", "phi_D"):
        cols[f"sd_{c}"] = np.full(n, 3.0 if c in ("dr_N", "phi_N") else 0.01)
    rows = odometry_rows(pd.DataFrame(cols), 0)
    datum_axes = _geodetic_axes(lat, float(lon[0]))
    for k in range(n):
        expect = datum_axes @ _geodetic_axes(lat, float(lon[k])).T  # map ← (east, north, up)
        R = _quat_matrix(*rows.q_xyzw[k])
        np.testing.assert_allclose(R, expect, atol=1e-12)  # forward east, left north, up up
        north = expect[:, 1]  # the σ of 3 m (and 3 rad) lies along the local north
        cov = rows.pose_cov[k].reshape(6, 6)
        for block in (cov[:3, :3], cov[3:, 3:]):
            np.testing.assert_allclose(block @ north, 9.0 * north, atol=1e-12)
    assert math.degrees(math.atan2(R[1, 0], R[0, 0])) == pytest.approx(1.559, abs=1e-3)
    v = rows.v_flu[-1]
    np.testing.assert_allclose(v, [2.0, 0.0, 0.0], atol=1e-12)  # the twist is in the body


def test_the_angular_twist_is_unknown_by_a_large_variance_not_minus_one() -> None:
    """nav_msgs/Odometry has no "not provided" mark: the angular twist (the solution has no
    rate) is 0 with variance 1e6 (rad/s)², so the twist covariance stays positive definite
    and a consumer such as robot_localization gives it no weight. Up to 0.4.8 its variances
    were -1 (sensor_msgs/Imu's mark), a negative variance to an Odometry consumer."""
    from adaptnav.importers.rosbag import odometry_rows

    n = 2
    cols: dict[str, Any] = {
        "t_s": np.arange(n, dtype=float), "lat_rad": np.full(n, 0.7), "lon_rad": np.full(n, 0.2),
        "h_m": np.zeros(n), "vn_m_s": np.full(n, 1.5), "ve_m_s": np.zeros(n),
        "vd_m_s": np.zeros(n), "roll_rad": np.zeros(n), "pitch_rad": np.zeros(n),
        "yaw_rad": np.zeros(n),
    }  # fmt: skip
    for c in ("dr_N", "dr_E", "dr_D", "dv_N", "dv_E", "dv_D", "phi_N", "phi_E", "phi_D"):
        cols[f"sd_{c}"] = np.full(n, 1e-3)
    rows = odometry_rows(pd.DataFrame(cols), 0)
    for cov in rows.twist_cov.reshape(n, 6, 6):
        np.testing.assert_array_equal(np.diag(cov)[3:], [1e6, 1e6, 1e6])
        assert not cov[3:, :3].any() and not cov[:3, 3:].any()
        assert np.linalg.eigvalsh(cov).min() > 0.0  # positive definite
    np.testing.assert_allclose(rows.v_flu[0], [1.5, 0.0, 0.0], atol=1e-12)


def test_a_run_whose_mission_folder_is_not_found_needs_the_origin(
    trip: Trip, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A run records its mission folder absolute (since 0.4.8; as given before, relative to
    where it ran): exported from another folder, the stamps are still the bag's (origin
    1.7e18 ns). When the folder is not found (the mission moved), whether it came from a bag
    cannot be told: exit 2 asking for --stamp-origin-ns. Up to 0.4.7 the origin was then 0,
    exit 0: every stamp in 1970, 1.7e9 s before the bag's."""
    shutil.copytree(trip.root / "imported", tmp_path / "m" / "imported")
    monkeypatch.chdir(tmp_path / "m")
    run = tmp_path / "run"
    api.results.save(api.run(load_mission(Path("imported")), "meskf"), run)
    monkeypatch.chdir(tmp_path)
    code, text = _cli("export", "rosbag", str(run), "--out", str(tmp_path / "here"), "-q")
    assert code == 0 and f"stamp origin {rw.STAMP0_NS} ns" in " ".join(text.split()), text
    (tmp_path / "m" / "imported").rename(tmp_path / "m" / "moved")
    code, text = _cli("export", "rosbag", str(run), "--out", str(tmp_path / "there"), "-q")
    assert code == 2, text
    assert "imported (summary.json, meta.mission_dir) is not found" in " ".join(text.split())
    assert not (tmp_path / "there").exists()
    code, text = _cli(
        "export", "rosbag", str(run), "--out", str(tmp_path / "given"), "-q",
        "--stamp-origin-ns", str(rw.STAMP0_NS),
    )  # fmt: skip
    assert code == 0, text


def test_an_nmea_missions_stamps_start_at_its_t0_utc(tmp_path: Path) -> None:
    """A mission imported from NMEA has its t_s = 0 at import.json's t0_utc (docs/nmea.md):
    the export's stamps start there, in integer ns (2024-03-01T12:00:00.25 UTC is
    1709294400.25 s). Up to 0.4.7 only a bag's origin was read: such stamps were from 1970."""
    from adaptnav.importers.rosbag import run_stamp_origin

    mission = tmp_path / "m"
    mission.mkdir()
    record = {"importer": "nmea", "time": {"t0_utc": "2024-03-01T12:00:00.250000+00:00"}}
    (mission / "import.json").write_text(json.dumps(record), encoding="utf-8")
    assert run_stamp_origin({"mission_dir": str(mission)}) == 1_709_294_400_250_000_000
    (mission / "import.json").unlink()
    assert run_stamp_origin({"mission_dir": str(mission)}) == 0  # simulated: mission seconds


def test_a_mission_without_an_absolute_time_is_exported_with_a_warning(
    mission: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A simulated mission (no import.json) has no absolute time: its export's stamps are
    mission seconds from 1970, said by a warning naming --stamp-origin-ns; given, no warning.
    An A-KIT segment's import.json says why it has none (recorded 2022-06-08, no time of
    day), and the warning quotes it. Up to 0.4.8 both were stamped in 1970 without a word."""
    run = tmp_path / "run"
    api.results.save(api.run(load_mission(mission), "meskf"), run)
    with caplog.at_level(logging.WARNING, logger="adaptnav.importers.rosbag"):
        code, text = _cli("export", "rosbag", str(run), "--out", str(tmp_path / "o1"), "-q")
    assert code == 0 and "stamp origin 0 ns" in " ".join(text.split()), text
    said = " ".join(caplog.text.split())
    assert "was not imported (simulated?) has no absolute time" in said
    assert "mission seconds from 1970-01-01 00:00 UTC; give --stamp-origin-ns" in said
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="adaptnav.importers.rosbag"):
        given = ("--stamp-origin-ns", str(rw.STAMP0_NS))
        code, text = _cli("export", "rosbag", str(run), "--out", str(tmp_path / "o2"), *given)
    assert code == 0 and caplog.text == "", text
    record = {
        "importer": "adaptnav.importers.akit",
        "time": {"stamp_origin_ns": None, "note": "recorded on 2022-06-08 (data README)"},
    }
    (mission / "import.json").write_text(json.dumps(record), encoding="utf-8")
    from adaptnav.importers.rosbag import export_stamp_origin

    with caplog.at_level(logging.WARNING, logger="adaptnav.importers.rosbag"):
        assert export_stamp_origin({"mission_dir": str(mission)}, None) == 0
    assert "(adaptnav.importers.akit: recorded on 2022-06-08 (data README)) has no" in " ".join(
        caplog.text.split()
    )


def test_an_rtklib_missions_stamps_are_its_gpst_origin_in_utc(tmp_path: Path) -> None:
    """An RTKLIB drive's t_s = 0 is import.json's gpst_origin_s, GPST counted like UTC since
    1970 (RTKLIB's gtime_t): the stamps are UTC, 18 s earlier since 2017 (IERS; 17 in 2016).
    Up to 0.4.7 such a run was stamped from 1970."""
    from adaptnav.importers.rosbag import run_stamp_origin

    mission = tmp_path / "m"
    mission.mkdir()
    for gpst, leap in (("2021-07-08T12:00:00.5", 18), ("2016-03-01T00:00:10", 17)):
        t = dt.datetime.fromisoformat(gpst).replace(tzinfo=dt.UTC)
        record = {"importer": "adaptnav.importers.rtklib", "gpst_origin_s": t.timestamp()}
        (mission / "import.json").write_text(json.dumps(record), encoding="utf-8")
        utc = t - dt.timedelta(seconds=leap) - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
        expected = (utc.days * 86400 + utc.seconds) * 10**9 + utc.microseconds * 1000
        assert run_stamp_origin({"mission_dir": str(mission)}) == expected
