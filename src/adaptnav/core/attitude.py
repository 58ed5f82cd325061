"""Attitude algebra: quaternions [w, x, y, z] (Hamilton), DCMs, ZYX Euler angles, rotation vectors.

Conventions in ``docs/conventions.md``; formulas from Groves (2013) §2.2 and appendix E.
These are the readable versions; ``adaptnav.compiled.propagation`` holds compiled scalar twins.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def skew(v: ArrayLike) -> Array:
    """Cross-product matrix ``[v×]`` such that ``[v×] u = v × u``."""
    x, y, z = np.asarray(v, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def cross(a: Array, b: Array) -> Array:
    """``a × b`` for 3-vectors (np.cross costs ~25 µs a call; this is the IMU-rate path)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def quat_mult(p: ArrayLike, q: ArrayLike) -> Array:
    """Hamilton product ``p ⊗ q``; of each pair of rows for arrays of quaternions (n, 4)."""
    pw, px, py, pz = np.asarray(p, dtype=float).T
    qw, qx, qy, qz = np.asarray(q, dtype=float).T
    return np.array(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ]
    ).T


def quat_conj(q: ArrayLike) -> Array:
    """Conjugate (inverse of a unit quaternion)."""
    w, x, y, z = np.asarray(q, dtype=float)
    return np.array([w, -x, -y, -z])


def quat_normalize(q: ArrayLike) -> Array:
    qa = np.asarray(q, dtype=float)
    return qa / float(np.linalg.norm(qa))


def rotvec_to_quat(a: ArrayLike) -> Array:
    """``q = Exp(a) = [cos(|a|/2), sin(|a|/2) a/|a|]``; series form near zero for accuracy."""
    av = np.asarray(a, dtype=float)
    angle2 = float(av @ av)
    if angle2 < 1e-12:
        # cos(x/2) and sin(x/2)/x to O(x^4): exact to double precision below 1e-6 rad.
        return np.concatenate([[1.0 - angle2 / 8.0], av * (0.5 - angle2 / 48.0)])
    angle = np.sqrt(angle2)
    return np.concatenate([[np.cos(angle / 2.0)], av * (np.sin(angle / 2.0) / angle)])


def quat_to_rotvec(q: ArrayLike) -> Array:
    """``a = Log(q)``, the rotation vector of the shortest rotation equal to q."""
    qa = np.asarray(q, dtype=float)
    if qa[0] < 0.0:
        qa = -qa
    vn = float(np.linalg.norm(qa[1:]))
    if vn < 1e-12:
        return qa[1:] * (2.0 / float(qa[0]))
    return qa[1:] * (2.0 * float(np.arctan2(vn, qa[0])) / vn)


def quat_to_dcm(q: ArrayLike) -> Array:
    """DCM of a unit quaternion (Groves 2.34): ``C_nb`` from ``q_nb``."""
    w, x, y, z = np.asarray(q, dtype=float)
    return np.array(
        [
            [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
        ]
    )


def dcm_to_quat(C: ArrayLike) -> Array:
    """Unit quaternion of a DCM (Shepperd's method: pick the largest pivot for accuracy)."""
    M = np.asarray(C, dtype=float)
    tr = M[0, 0] + M[1, 1] + M[2, 2]
    pivots = [tr, M[0, 0], M[1, 1], M[2, 2]]
    k = int(np.argmax(pivots))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + tr)
        q = [
            w,
            (M[2, 1] - M[1, 2]) / (4 * w),
            (M[0, 2] - M[2, 0]) / (4 * w),
            (M[1, 0] - M[0, 1]) / (4 * w),
        ]
    elif k == 1:
        x = 0.5 * np.sqrt(1.0 + 2 * M[0, 0] - tr)
        q = [
            (M[2, 1] - M[1, 2]) / (4 * x),
            x,
            (M[0, 1] + M[1, 0]) / (4 * x),
            (M[0, 2] + M[2, 0]) / (4 * x),
        ]
    elif k == 2:
        y = 0.5 * np.sqrt(1.0 + 2 * M[1, 1] - tr)
        q = [
            (M[0, 2] - M[2, 0]) / (4 * y),
            (M[0, 1] + M[1, 0]) / (4 * y),
            y,
            (M[1, 2] + M[2, 1]) / (4 * y),
        ]
    else:
        z = 0.5 * np.sqrt(1.0 + 2 * M[2, 2] - tr)
        q = [
            (M[1, 0] - M[0, 1]) / (4 * z),
            (M[0, 2] + M[2, 0]) / (4 * z),
            (M[1, 2] + M[2, 1]) / (4 * z),
            z,
        ]
    qa = np.array(q)
    return qa if qa[0] >= 0 else -qa


def euler_to_dcm(roll: float, pitch: float, yaw: float) -> Array:
    """``C_nb = Rz(yaw) Ry(pitch) Rx(roll)`` (ZYX, Groves 2.22 transposed)."""
    sr, cr = np.sin(roll), np.cos(roll)
    sp, cp = np.sin(pitch), np.cos(pitch)
    sy, cy = np.sin(yaw), np.cos(yaw)
    return np.array(
        [
            [cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
            [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
            [-sp, sr * cp, cr * cp],
        ]
    )


def dcm_to_euler(C: ArrayLike) -> Array:
    """``[roll, pitch, yaw]`` of ``C_nb`` (ZYX); yaw in (-π, π]."""
    M = np.asarray(C, dtype=float)
    roll = np.arctan2(M[2, 1], M[2, 2])
    pitch = -np.arcsin(np.clip(M[2, 0], -1.0, 1.0))
    yaw = np.arctan2(M[1, 0], M[0, 0])
    return np.array([roll, pitch, yaw])


def euler_to_quat(roll: float, pitch: float, yaw: float) -> Array:
    return dcm_to_quat(euler_to_dcm(roll, pitch, yaw))


def quat_to_euler(q: ArrayLike) -> Array:
    return dcm_to_euler(quat_to_dcm(q))


def wrap_angle(a: ArrayLike) -> Array:
    """Wrap angles to (-π, π]; angles already in range come back bit-for-bit unchanged.

    (Going through ``a + π`` for every angle would round a small angle to ~4e-16 rad absolute,
    which times the earth's radius is nm-level noise in a GNSS longitude residual.)
    """
    arr = np.asarray(a, dtype=float)
    wrapped = -np.remainder(-arr + np.pi, 2.0 * np.pi) + np.pi
    return np.asarray(np.where((arr > -np.pi) & (arr <= np.pi), arr, wrapped), dtype=float)
