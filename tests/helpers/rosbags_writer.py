"""ROS 2 bags written with ``rosbags``' own writer for the bag importer's tests
(tests/integration/test_rosbag.py, docs/rosbag.md).

:func:`mission_to_bag` writes a simulated mission's tables as the messages a vehicle's ROS
drivers would publish. Its conversions are written out here from REP-103 and the message
definitions, independently of ``adaptnav.importers.rosmsg``: body FRD → FLU negates y and z;
an attitude (roll φ, pitch θ, yaw ψ) of C_nb is, in ENU/FLU, the ZYX Euler angles
(φ, -θ, π/2 - ψ) (T = Rz(π/2)·diag(1, -1, -1) takes NED to ENU, and a half turn about x
negates the y and z rotations), turned into a quaternion by the closed form.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
T = TYPESTORE.types
STAMP0_NS = 1_700_000_000 * 1_000_000_000
"""The stamp of mission time 0 (a whole second)."""
RHO, P_ATM, G = 1025.0, 101325.0, 9.80665
"""The depth meter's water density, atmospheric pressure and gravity (the importer's
defaults)."""
STORAGE = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}


def header(t_s: float, frame: str, origin_ns: int = STAMP0_NS) -> Any:
    ns = origin_ns + round(t_s * 1e9)
    return T["std_msgs/msg/Header"](
        T["builtin_interfaces/msg/Time"](ns // 10**9, ns % 10**9), frame
    )


def vec(x: float, y: float, z: float) -> Any:
    return T["geometry_msgs/msg/Vector3"](x, y, z)


def quat_zyx(roll: float, pitch: float, yaw: float) -> Any:
    """The quaternion of ZYX Euler angles, ``[x, y, z, w]`` message."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return T["geometry_msgs/msg/Quaternion"](
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def ros_quat(roll: float, pitch: float, yaw: float) -> Any:
    """``q_enu_flu`` of an adaptnav attitude (C_nb's ZYX angles)."""
    return quat_zyx(roll, -pitch, math.pi / 2 - yaw)


def diag(n: int, values: Iterable[float]) -> np.ndarray:
    m = np.zeros((n, n))
    np.fill_diagonal(m[:3, :3], list(values))
    return m.reshape(-1)


NO_COV = np.zeros(9)
NOT_PROVIDED = np.array([-1.0, 0, 0, 0, 0, 0, 0, 0, 0])


def imu_messages(imu: pd.DataFrame, rate_hz: float, cov: bool) -> list[tuple[float, Any]]:
    """Increments → the mean rates over each interval (the first 1/rate_hz long), FLU."""
    t = imu["t_s"].to_numpy()
    dt = np.diff(t, prepend=t[0] - 1.0 / rate_hz)
    g = imu[["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]].to_numpy() / dt[:, None]
    f = imu[["dvel_x_m_s", "dvel_y_m_s", "dvel_z_m_s"]].to_numpy() / dt[:, None]
    gc = diag(3, [1e-6] * 3) if cov else NO_COV
    fc = diag(3, [4e-4] * 3) if cov else NO_COV
    q0 = T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)
    return [
        (
            tk,
            T["sensor_msgs/msg/Imu"](
                header(tk, "base_link"),
                q0,
                NOT_PROVIDED,
                vec(gk[0], -gk[1], -gk[2]),
                gc,
                vec(fk[0], -fk[1], -fk[2]),
                fc,
            ),
        )
        for tk, gk, fk in zip(t, g, f, strict=True)
    ]


def dvl_messages(dvl: pd.DataFrame) -> list[tuple[float, Any]]:
    twist = T["geometry_msgs/msg/Twist"]
    out = []
    for r in dvl.itertuples():
        cov = np.zeros((6, 6))
        np.fill_diagonal(cov, [r.sigma_m_s**2] * 3 + [0.0] * 3)
        body = twist(vec(r.vx_m_s, -r.vy_m_s, -r.vz_m_s), vec(0.0, 0.0, 0.0))
        tw = T["geometry_msgs/msg/TwistWithCovariance"](body, cov.reshape(-1))
        out.append(
            (
                r.t_s,
                T["geometry_msgs/msg/TwistWithCovarianceStamped"](header(r.t_s, "dvl_link"), tw),
            )
        )
    return out


def depth_messages(depth: pd.DataFrame) -> list[tuple[float, Any]]:
    return [
        (
            r.t_s,
            T["sensor_msgs/msg/FluidPressure"](
                header(r.t_s, "pressure_link"),
                P_ATM + RHO * G * r.depth_m,
                (RHO * G * r.sigma_m) ** 2,
            ),
        )
        for r in depth.itertuples()
    ]


def inclinometer_messages(incl: pd.DataFrame) -> list[tuple[float, Any]]:
    """Roll and pitch as an Imu's orientation (yaw 0: the inclinometer has none)."""
    return [
        (
            r.t_s,
            T["sensor_msgs/msg/Imu"](
                header(r.t_s, "incl_link"),
                ros_quat(r.roll_rad, r.pitch_rad, 0.0),
                diag(3, [r.sigma_rad**2, r.sigma_rad**2, 1.0]),
                vec(0, 0, 0),
                NOT_PROVIDED,
                vec(0, 0, 0),
                NOT_PROVIDED,
            ),
        )
        for r in incl.itertuples()
    ]


def heading_messages(heading: pd.DataFrame) -> list[tuple[float, Any]]:
    return [
        (
            r.t_s,
            T["geometry_msgs/msg/QuaternionStamped"](
                header(r.t_s, "compass_link"), ros_quat(0.0, 0.0, r.yaw_rad)
            ),
        )
        for r in heading.itertuples()
    ]


def gnss_messages(gps: pd.DataFrame) -> list[tuple[float, Any]]:
    status = T["sensor_msgs/msg/NavSatStatus"](0, 1)
    return [
        (
            r.t_s,
            T["sensor_msgs/msg/NavSatFix"](
                header(r.t_s, "gps_link"),
                status,
                math.degrees(r.lat_rad),
                math.degrees(r.lon_rad),
                0.0,
                diag(3, [r.sigma_m**2, r.sigma_m**2, 100.0]),
                2,
            ),
        )
        for r in gps.itertuples()
    ]


TOPICS: dict[str, tuple[str, str, Callable[[pd.DataFrame], list[tuple[float, Any]]]]] = {
    "dvl": ("/dvl/twist", "geometry_msgs/msg/TwistWithCovarianceStamped", dvl_messages),
    "depth": ("/depth/pressure", "sensor_msgs/msg/FluidPressure", depth_messages),
    "inclinometer": ("/inclinometer", "sensor_msgs/msg/Imu", inclinometer_messages),
    "heading": ("/heading", "geometry_msgs/msg/QuaternionStamped", heading_messages),
    "gps": ("/gps/fix", "sensor_msgs/msg/NavSatFix", gnss_messages),
}
"""Table → (topic, message type, messages) of a simulated mission's sensors."""


def write_bag(
    path: Path, topics: dict[str, tuple[str, list[tuple[float, Any]]]], storage: str = "sqlite3"
) -> Path:
    """Write topic → (type, [(t, message)]) with log time = the message's t (ns after
    STAMP0); the bag is written topic after topic (readers order by log time)."""
    with Writer(path, version=9, storage_plugin=STORAGE[storage]) as w:
        for topic, (msgtype, msgs) in topics.items():
            con = w.add_connection(topic, msgtype, typestore=TYPESTORE)
            for t, m in msgs:
                w.write(con, STAMP0_NS + round(t * 1e9), TYPESTORE.serialize_cdr(m, msgtype))
    return path


def mission_to_bag(
    mission: Path, path: Path, storage: str = "sqlite3", imu_cov: bool = False
) -> Path:
    """A simulated mission (increments IMU) as a bag: ``/imu`` and :data:`TOPICS`."""
    cfg = tomllib.loads((mission / "mission.toml").read_text(encoding="utf-8"))
    imu = pd.read_parquet(mission / cfg["imu"]["file"])
    topics = {"/imu": ("sensor_msgs/msg/Imu", imu_messages(imu, cfg["imu"]["rate_hz"], imu_cov))}
    for table, (topic, msgtype, convert) in TOPICS.items():
        topics[topic] = (msgtype, convert(pd.read_parquet(mission / f"{table}.parquet")))
    return write_bag(path, topics, storage)
