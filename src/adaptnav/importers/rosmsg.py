"""ROS 2 messages ↔ adaptnav readings: frames, units, stamps and covariances (docs/rosbag.md).

ROS (REP-103, REP-105) resolves body vectors in FLU (x forward, y left, z up), world vectors
in ENU and writes quaternions ``[x, y, z, w]``; adaptnav (docs/conventions.md) uses body FRD,
navigation NED and ``[w, x, y, z]``. Both changes are a fixed rotation applied once here:

* FLU → FRD: ``C_FRD_FLU = diag(1, -1, -1)``, a half turn about x (its own inverse);
* ENU → NED: ``C_NED_ENU = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` (its own inverse);
* attitude: ``C_nb = C_NED_ENU · C_enu_flu · C_FLU_FRD``, so a level vehicle heading east
  (ROS yaw 0) has yaw π/2, and ROS roll, pitch, yaw = roll, -pitch, π/2 - yaw for small tilts.

A covariance is *unknown* where the message marks it so: every element zero, or the first -1
(sensor_msgs' convention for "no estimate"). Variances stay variances through the sign flips.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptnav.core.attitude import dcm_to_euler, quat_to_dcm
from adaptnav.core.units import DEG, G0

Array = NDArray[np.float64]

__all__ = [
    "C_FRD_FLU",
    "C_NED_ENU",
    "Converted",
    "DepthParameters",
    "attitude",
    "enu_to_ned",
    "flu_to_frd",
    "imu_rates",
    "navsatfix",
    "pose_depth",
    "pressure_depth",
    "provided",
    "ros_to_nav_attitude",
    "stamps_ns",
    "twist_velocity",
]

C_FRD_FLU: Array = np.diag([1.0, -1.0, -1.0])
"""Body FLU (ROS) → FRD (adaptnav): a half turn about x; also FRD → FLU."""
C_NED_ENU: Array = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""World ENU (ROS) → NED (adaptnav); also NED → ENU."""


def flu_to_frd(v: Array) -> Array:
    """Vectors (..., 3) in FLU resolved in FRD (and back: the map is its own inverse). A NaN
    or an infinity in a message stays one (inf times the zeros of the map is NaN), for the
    loader to drop and record, without NumPy's warning on stderr."""
    with np.errstate(invalid="ignore"):
        return np.asarray(v, dtype=float) @ C_FRD_FLU.T


def enu_to_ned(v: Array) -> Array:
    """Vectors (..., 3) in ENU resolved in NED (and back); NaN and inf as :func:`flu_to_frd`."""
    with np.errstate(invalid="ignore"):
        return np.asarray(v, dtype=float) @ C_NED_ENU.T


def ros_to_nav_attitude(q_xyzw: Array) -> Array:
    """ZYX roll, pitch, yaw (n, 3) of ``C_nb = C_NED_ENU · C(q) · C_FLU_FRD`` for ROS
    quaternions ``q_enu_flu`` (n, 4) ``[x, y, z, w]`` (normalised here: a driver's rounding
    must not tilt the result); yaw is the heading from true north, in (-π, π]."""
    q = np.asarray(q_xyzw, dtype=float).reshape(-1, 4)
    with np.errstate(invalid="ignore", divide="ignore"):  # a zero quaternion: NaN angles,
        wxyz = q[:, [3, 0, 1, 2]] / np.linalg.norm(q, axis=1, keepdims=True)  # dropped at load
    rows = [dcm_to_euler(C_NED_ENU @ quat_to_dcm(w) @ C_FRD_FLU) for w in wxyz]
    return np.array(rows, dtype=float).reshape(-1, 3)


def stamps_ns(msgs: Sequence[Any]) -> NDArray[np.int64]:
    """Header stamps as integer nanoseconds (float seconds would lose 0.2 µs at 1.7e9 s)."""
    return np.array(
        [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in msgs],
        dtype=np.int64,
    )


NOT_PROVIDED = -1.0
"""sensor_msgs/msg/Imu's mark, in a covariance's first element, of a quantity the message does
not carry (its values are then placeholders, typically zero or the identity)."""


def provided(covariances: Array) -> NDArray[np.bool_]:
    """Per message (n,): False where the covariance's first element is :data:`NOT_PROVIDED`."""
    first = np.asarray(covariances, dtype=float).reshape(len(covariances), -1)[:, 0]
    return np.asarray(first != NOT_PROVIDED)


def _diagonal(covariances: Array, indices: Sequence[int]) -> Array:
    """The elements ``indices`` (n, k) of flattened covariances (n, m), NaN in the rows that
    mark the covariance unknown (all zero, or the first element -1)."""
    c = np.asarray(covariances, dtype=float)
    unknown = np.all(c == 0.0, axis=1) | (c[:, 0] == -1.0)
    out = c[:, list(indices)].copy()
    out[unknown] = np.nan
    return out


@dataclass(frozen=True, eq=False)
class Converted:
    """Readings of one topic in adaptnav's frames and SI units (docs/data-format.md).

    ``z`` (n, k): the table's columns; ``var`` (n, j): each message's variance of each σ
    component (the kind's σ order, e.g. N, E, D for a GNSS fix), NaN where it has none;
    ``keep`` (n,): False for messages that carry no reading (a fix with no fix, an Imu whose
    covariance marks the quantity read not provided)."""

    z: Array
    var: Array
    keep: NDArray[np.bool_]


def _vectors(vs: Sequence[Any]) -> Array:
    return np.array([(v.x, v.y, v.z) for v in vs], dtype=float).reshape(-1, 3)


def _all(n: int) -> NDArray[np.bool_]:
    return np.ones(n, dtype=bool)


def imu_rates(msgs: Sequence[Any]) -> Converted:
    """``sensor_msgs/msg/Imu`` → gyro (rad/s) and specific force (m/s²) in FRD (n, 6), with
    the variances of the three gyro then the three accelerometer axes; ``keep`` False where
    either covariance marks its quantity not provided (:func:`provided`)."""
    gyro = flu_to_frd(_vectors([m.angular_velocity for m in msgs]))
    accel = flu_to_frd(_vectors([m.linear_acceleration for m in msgs]))
    gyro_cov = np.array([m.angular_velocity_covariance for m in msgs]).reshape(-1, 9)
    accel_cov = np.array([m.linear_acceleration_covariance for m in msgs]).reshape(-1, 9)
    var = np.hstack([_diagonal(gyro_cov, (0, 4, 8)), _diagonal(accel_cov, (0, 4, 8))])
    return Converted(np.hstack([gyro, accel]), var, provided(gyro_cov) & provided(accel_cov))


def attitude(msgs: Sequence[Any], msgtype: str) -> Converted:
    """``sensor_msgs/msg/Imu`` orientation or ``geometry_msgs/msg/QuaternionStamped`` → roll,
    pitch, yaw (rad, n × 3) of ``C_nb`` (:func:`ros_to_nav_attitude`), with the Imu's
    orientation variances (about x, y, z: roll, pitch, yaw); a QuaternionStamped has none.
    ``keep`` is False for an Imu message whose orientation covariance marks it not provided
    (:func:`provided`): an AHRS before its filter converged sends the identity quaternion, a
    level vehicle heading east, which read as a heading of 90° (up to 0.4.7)."""
    if msgtype == "sensor_msgs/msg/Imu":
        q = np.array(
            [(m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w) for m in msgs],
            dtype=float,
        )
        cov = np.array([m.orientation_covariance for m in msgs]).reshape(-1, 9)
        var, keep = _diagonal(cov, (0, 4, 8)), provided(cov)
    else:
        q = np.array(
            [(m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w) for m in msgs],
            dtype=float,
        )
        var, keep = np.full((len(msgs), 3), np.nan), _all(len(msgs))
    return Converted(ros_to_nav_attitude(q), var, keep)


def twist_velocity(msgs: Sequence[Any]) -> Converted:
    """``geometry_msgs/msg/TwistWithCovarianceStamped`` → the linear velocity (m/s) in the
    sensor's axes turned FLU → FRD (n, 3), with the variances of its covariance's linear
    block."""
    v = flu_to_frd(_vectors([m.twist.twist.linear for m in msgs]))
    var = _diagonal(np.array([m.twist.covariance for m in msgs]), (0, 7, 14))
    return Converted(v, var, _all(len(msgs)))


@dataclass(frozen=True)
class DepthParameters:
    """Depth from pressure: ``depth = (p - atmospheric_pa) / (density · gravity)``
    (hydrostatic; seawater 1025 kg/m³, standard atmosphere and gravity by default)."""

    density_kg_m3: float = 1025.0
    atmospheric_pa: float = 101325.0
    gravity_m_s2: float = G0

    @property
    def pa_per_m(self) -> float:
        return self.density_kg_m3 * self.gravity_m_s2


def pressure_depth(msgs: Sequence[Any], params: DepthParameters) -> Converted:
    """``sensor_msgs/msg/FluidPressure`` (Pa) → depth (m, positive down, n × 1) by
    :class:`DepthParameters`; the message's ``variance`` (Pa², 0 unknown) scaled by
    ``1 / (ρ g)²``."""
    p = np.array([m.fluid_pressure for m in msgs], dtype=float)
    var = np.array([m.variance for m in msgs], dtype=float)
    var = np.where(var > 0.0, var, np.nan) / params.pa_per_m**2
    depth = (p - params.atmospheric_pa) / params.pa_per_m
    return Converted(depth[:, None], var[:, None], _all(len(msgs)))


def pose_depth(msgs: Sequence[Any]) -> Converted:
    """``geometry_msgs/msg/PoseWithCovarianceStamped`` → depth = -z (m, n × 1): z is up in a
    REP-105 world frame; the variance of z."""
    z = np.array([m.pose.pose.position.z for m in msgs], dtype=float)
    var = _diagonal(np.array([m.pose.covariance for m in msgs]), (14,))
    return Converted(-z[:, None], var, _all(len(msgs)))


NAVSAT_NO_FIX = -1
"""``sensor_msgs/msg/NavSatStatus.STATUS_NO_FIX``."""


def navsatfix(msgs: Sequence[Any]) -> Converted:
    """``sensor_msgs/msg/NavSatFix`` → latitude, longitude (rad) and ellipsoidal height (m)
    (n, 3); variances N, E, D from the ENU ``position_covariance`` (unknown where
    ``position_covariance_type`` is 0); ``keep`` False where ``status`` is no fix."""
    z = np.array([(m.latitude * DEG, m.longitude * DEG, m.altitude) for m in msgs], dtype=float)
    cov = np.array([m.position_covariance for m in msgs], dtype=float).reshape(-1, 9)
    known = np.array([m.position_covariance_type for m in msgs]) > 0
    var = np.where(known[:, None], cov[:, [4, 0, 8]], np.nan)
    keep = np.array([m.status.status for m in msgs]) > NAVSAT_NO_FIX
    return Converted(z.reshape(-1, 3), var, keep)
