"""The "floor" baseline: DVL dead reckoning with the reference's own attitude.

No filter and no IMU integration: the DVL velocity, corrected for its lever arm, is rotated
into NED with the *reference* attitude and integrated. With a perfect attitude the only
errors left are the DVL's (noise, bias, scale, timing) and the integration's, so it is the
accuracy that any DVL-aided INS that does not also estimate DVL errors should hardly beat:
a floor under the filters' errors, not a competitor (it needs the reference).

At each DVL reading time t_k (readings ``z_k``, DVL frame):

    v_b,k = C_bs z_k - ω_ib_b(t_k) × l_b                 (inverse of adaptnav.sensors.dvl)
    v_n,k = C_nb(roll, pitch, yaw of the reference at t_k) v_b,k
    L_k = L_0 + Σ ½ (v_N,k-1 / (R_M + h) + v_N,k / (R_M + h)) Δt     (trapezoid)
    λ_k = λ_0 + Σ ½ (v_E / ((R_N + h) cos L) at k-1 and k) Δt
    h_k = h_0 - Σ ½ (v_D,k-1 + v_D,k) Δt

(Groves 2013, eq. 5.56: the curvilinear position rates; R_M, R_N from :mod:`adaptnav.core.earth`
at the dead-reckoned point). ``C_bs = C_sbᵀ`` and ``l_b`` are the DVL sensor's mounting and
lever arm from ``mission.toml``; ω_ib_b is the IMU's mean rate ``Δθ / Δt`` interpolated at t_k
from the interval mid-times; the reference's roll, pitch and (unwrapped) yaw are interpolated
linearly at t_k. The start is the reference position interpolated at the first valid DVL
time. A reading with a non-finite component is skipped: the last valid body velocity is held
(and turned with the current attitude).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid
from scipy.spatial.transform import Rotation

from adaptnav.api.results import (
    COV_COLUMNS,
    SD_COLUMNS,
    SOLUTION_COLUMNS,
    Result,
    ledger_frame,
    noise_frame,
    repairs_frame,
)
from adaptnav.core import earth
from adaptnav.core.attitude import wrap_angle
from adaptnav.mission import Mission

Array = NDArray[np.float64]

__all__ = ["FILTER_NAME", "dead_reckon", "dvl_readings", "dvl_sensor", "imu_rate_at", "run"]

FILTER_NAME = "floor"
_ATTITUDE = ("roll_rad", "pitch_rad", "yaw_rad")
_POSITION = ("lat_rad", "lon_rad", "h_m")


def _interp(t: Array, tp: Array, fp: Array) -> Array:
    return np.asarray(np.interp(t, tp, fp), dtype=float)


def dead_reckon(t: Array, v_n: Array, lat0: float, lon0: float, h0: float) -> Array:
    """Positions (n, 3) lat, lon (rad), h (m) from NED velocities ``v_n`` (n, 3) at times ``t``
    by the trapezoid rule on the curvilinear rates (module docstring), starting at
    (lat0, lon0, h0) at ``t[0]``.

    The radii are evaluated at the dead-reckoned point: a first pass at the start point, a
    second at the first pass's positions (over a few kilometres R_M and R_N change by parts
    in 10⁶, so two passes reach the fixed point to well below a millimetre).
    """
    h = h0 - cumulative_trapezoid(v_n[:, 2], t, initial=0.0)
    lat = np.full(t.size, lat0)
    for _ in range(2):
        rate_lat = v_n[:, 0] / (earth.meridian_radius(lat) + h)
        lat = lat0 + cumulative_trapezoid(rate_lat, t, initial=0.0)
    rate_lon = v_n[:, 1] / ((earth.transverse_radius(lat) + h) * np.cos(lat))
    lon = lon0 + cumulative_trapezoid(rate_lon, t, initial=0.0)
    return np.column_stack([lat, lon, h])


def dvl_sensor(mission: Mission, sensor: str | None, who: str = FILTER_NAME) -> str:
    """``sensor`` if it is a loaded sensor of kind "dvl", else the first such; ValueError
    (its message starting with ``who``) if there is none or ``sensor`` is not one."""
    dvls = [n for n, s in mission.sensors.items() if s.kind == "dvl"]
    if sensor is not None:
        if sensor not in dvls:
            raise ValueError(f"{who}: {sensor!r} is not a loaded dvl sensor (dvl sensors: {dvls})")
        return sensor
    if not dvls:
        raise ValueError(f"{who}: the mission has no loaded sensor of kind 'dvl'")
    return dvls[0]


def run(mission: Mission, sensor: str | None = None) -> Result:
    """The floor baseline on ``mission`` (module docstring) as a :class:`Result` named "floor".

    ``sensor`` picks the DVL (default: the first loaded sensor of kind "dvl"). The mission
    needs a truth table with position and attitude columns. The solution has one row per DVL
    reading inside the IMU and truth spans, from the first finite one: every column of
    ``SOLUTION_COLUMNS``, the velocity the dead-reckoned NED velocity, the attitude the
    reference's, biases 0 and the ``sd_*`` columns NaN (no covariance). Ledger and noise
    tables are empty (no filter, no update).
    """
    truth = _reference(mission)
    name = dvl_sensor(mission, sensor)
    cfg = mission.config.sensors[name]
    t_ref = truth["t_s"].to_numpy(dtype=float)
    t, z, valid = dvl_readings(mission, name, t_ref)

    # Hold the last valid reading over non-finite ones (index of the last valid so far).
    held = np.maximum.accumulate(np.where(valid, np.arange(t.size), 0))
    omega = imu_rate_at(mission, t)
    C_bs = cfg.sensor_from_body().T
    v_b = z @ C_bs.T - np.cross(omega, cfg.lever_arm())
    v_b = v_b[held]

    rpy = np.column_stack(
        [
            _interp(t, t_ref, truth["roll_rad"].to_numpy(dtype=float)),
            _interp(t, t_ref, truth["pitch_rad"].to_numpy(dtype=float)),
            _interp(t, t_ref, np.unwrap(truth["yaw_rad"].to_numpy(dtype=float))),
        ]
    )
    v_n = Rotation.from_euler("ZYX", rpy[:, ::-1]).apply(v_b)
    start = [_interp(t[:1], t_ref, truth[c].to_numpy(dtype=float))[0] for c in _POSITION]
    pos = dead_reckon(t, v_n, start[0], start[1], start[2])

    ledger = ledger_frame([])
    meta: dict[str, Any] = {
        "baseline": "floor",
        "description": (
            "DVL dead reckoning: lever-arm-corrected DVL velocity rotated to NED by the "
            "reference attitude, trapezoid-integrated from the reference position"
        ),
        "mission_dir": str(mission.root),
        "sensor": name,
        "lever_arm_m": cfg.lever_arm().tolist(),
        "readings": int(t.size),
        "readings_held": int(np.count_nonzero(~valid)),
        "start_s": float(t[0]),
        "end_s": float(t[-1]),
    }
    return Result(
        filter=FILTER_NAME,
        mission=mission.config.mission.name,
        solution=_solution(t, pos, v_n, rpy),
        ledger=ledger,
        noise=noise_frame(ledger),
        meta=meta,
        repairs=repairs_frame([r.__dict__ for r in mission.repairs]),
    )


def imu_rate_at(mission: Mission, t: Array) -> Array:
    """The IMU's mean rate ``Δθ / Δt`` (n, 3; rad/s) interpolated at times t from the intervals'
    mid-times (module docstring)."""
    imu = mission.imu
    t_mid = imu.t - 0.5 * imu.dt
    rates = imu.dtheta / imu.dt[:, None]
    return np.column_stack([_interp(t, t_mid, rates[:, i]) for i in range(3)])


def _reference(mission: Mission) -> pd.DataFrame:
    """The mission's truth table; ValueError without one or without the position and
    attitude columns the floor needs."""
    truth = mission.truth
    if truth is None:
        raise ValueError("floor: the mission has no truth table (it uses the reference attitude)")
    missing = [c for c in ("t_s", *_POSITION, *_ATTITUDE) if c not in truth.columns]
    if missing:
        raise ValueError(f"floor: the truth table lacks columns {missing}")
    return truth


def dvl_readings(
    mission: Mission, name: str, t_ref: Array, who: str = FILTER_NAME
) -> tuple[Array, Array, NDArray[np.bool_]]:
    """(t, z, finite) of the DVL ``name``'s readings inside the IMU and truth spans, from the
    first finite one on; ValueError (its message starting with ``who``) if there is none."""
    data = mission.sensors[name]
    imu = mission.imu
    lo = max(float(imu.t[0] - imu.dt[0]), float(t_ref[0]))
    hi = min(float(imu.t[-1]), float(t_ref[-1]))
    inside = (data.t >= lo) & (data.t <= hi)
    t, z = data.t[inside], data.z[inside]
    valid = np.all(np.isfinite(z), axis=1)
    if not valid.any():
        span = (
            f"inside [{lo:.6g}, {hi:.6g}] s, where the IMU and the reference overlap"
            if lo <= hi
            else f"to score: the reference ({float(t_ref[0]):.6g} to {float(t_ref[-1]):.6g} s) "
            f"and the IMU ({float(imu.t[0] - imu.dt[0]):.6g} to {float(imu.t[-1]):.6g} s) "
            "do not overlap"
        )
        raise ValueError(f"{who}: sensor {name!r} has no finite reading {span}")
    first = int(np.argmax(valid))
    return t[first:], z[first:], valid[first:]


def _solution(t: Array, pos: Array, v_n: Array, rpy: Array) -> pd.DataFrame:
    """The floor's solution in ``SOLUTION_COLUMNS``: the dead-reckoned position and velocity,
    the reference's attitude, biases 0, no covariance (NaN ``sd_*`` and ``cov_*``)."""
    n = t.size
    zeros = np.zeros(n)
    columns: dict[str, Any] = {
        "t_s": t,
        "lat_rad": pos[:, 0],
        "lon_rad": pos[:, 1],
        "h_m": pos[:, 2],
        "vn_m_s": v_n[:, 0],
        "ve_m_s": v_n[:, 1],
        "vd_m_s": v_n[:, 2],
        "roll_rad": rpy[:, 0],
        "pitch_rad": rpy[:, 1],
        "yaw_rad": wrap_angle(rpy[:, 2]),
        **{c: zeros for c in SOLUTION_COLUMNS if c.startswith(("ba_", "bg_"))},
        **{c: np.full(n, np.nan) for c in (*SD_COLUMNS, *COV_COLUMNS)},
    }
    return pd.DataFrame({c: columns[c] for c in SOLUTION_COLUMNS})
