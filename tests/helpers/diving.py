"""A vehicle under way that dives and climbs and turns, with a known answer, for the DVL and
depth scale checks (mission/scales.py): its IMU (rates), DVL, depth meter, GNSS and heading
tables in SI units, exact up to white noise."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from helpers.missions import config_dict, write_dir

RATE_HZ = 50.0
LAT0, LON0 = math.radians(26.8), math.radians(56.0)
R_EARTH = 6_371_000.0
G = 9.81


def tables(
    duration_s: float = 600.0, pitch_deg: float = 15.0, speed: float = 1.5, seed: int = 2
) -> dict[str, pd.DataFrame]:
    """IMU, DVL (2 Hz), depth (1 Hz), GNSS (1 Hz) and heading (1 Hz) tables of a vehicle at
    ``speed`` along its x axis, pitching ±``pitch_deg`` with a 120-s period (a yo-yo; 0: a
    surface vessel, its depth still) and turning ±60° with a 200-s period."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s + 1e-9, 1.0 / RATE_HZ)
    pitch = math.radians(pitch_deg) * np.sin(2 * math.pi * t / 120.0)
    yaw = math.radians(60.0) * np.sin(2 * math.pi * t / 200.0)
    vn = np.column_stack(
        [
            speed * np.cos(pitch) * np.cos(yaw),
            speed * np.cos(pitch) * np.sin(yaw),
            -speed * np.sin(pitch),
        ]
    )
    pos = np.vstack([np.zeros(3), np.cumsum(0.5 * (vn[1:] + vn[:-1]) / RATE_HZ, axis=0)])
    pos[:, 2] += 20.0
    imu = pd.DataFrame(
        {
            "t_s": t,
            "gyro_x_rad_s": rng.normal(0.0, 1e-4, t.size),
            "gyro_y_rad_s": np.gradient(pitch, t) + rng.normal(0.0, 1e-4, t.size),
            "gyro_z_rad_s": np.gradient(yaw, t) + rng.normal(0.0, 1e-4, t.size),
            "accel_x_m_s2": G * np.sin(pitch) + rng.normal(0.0, 1e-3, t.size),
            "accel_y_m_s2": rng.normal(0.0, 1e-3, t.size),
            "accel_z_m_s2": -G * np.cos(pitch) + rng.normal(0.0, 1e-3, t.size),
        }
    )

    def at(ts: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.interp(ts, t, v)

    td = np.arange(0.25, duration_s, 0.5)
    dvl = pd.DataFrame({"t_s": td, "vx_m_s": speed + rng.normal(0.0, 0.02, td.size)})
    dvl["vy_m_s"] = rng.normal(0.0, 0.02, td.size)
    dvl["vz_m_s"] = rng.normal(0.0, 0.02, td.size)
    ts = np.arange(0.5, duration_s, 1.0)
    depth = pd.DataFrame({"t_s": ts, "depth_m": at(ts, pos[:, 2]) + rng.normal(0, 0.05, ts.size)})
    lat = LAT0 + (at(ts, pos[:, 0]) + rng.normal(0.0, 2.0, ts.size)) / R_EARTH
    lon = LON0 + (at(ts, pos[:, 1]) + rng.normal(0.0, 2.0, ts.size)) / (R_EARTH * math.cos(LAT0))
    gnss = pd.DataFrame({"t_s": ts, "lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon)})
    heading = pd.DataFrame(
        {"t_s": ts, "yaw_deg": np.degrees(at(ts, yaw)) + rng.normal(0, 0.5, ts.size)}
    )
    return {"imu": imu, "dvl": dvl, "depth": depth, "gps": gnss, "heading": heading}


def mission(root: Path, tabs: dict[str, pd.DataFrame], **sensors: dict[str, Any]) -> Path:
    """A mission folder of ``tabs`` (:func:`tables`): the DVL and depth aiding, the GNSS and the
    heading sensor used to start (``sensors`` adds to or replaces their sections)."""
    s: dict[str, Any] = {
        "dvl": {"kind": "dvl", "file": "dvl.csv", "sigma": [0.02, "m/s"], "rate_hz": 2.0},
        "depth": {"kind": "depth", "file": "depth.csv", "sigma": [0.05, "m"], "rate_hz": 1.0},
        "gps": {"kind": "gnss", "file": "gps.csv", "sigma": [2.0, "m"], "use": "init"},
        "heading": {"kind": "heading", "file": "heading.csv", "sigma": [0.5, "deg"], "use": "init"},
    }
    for name, extra in sensors.items():
        s[name] = {**s.get(name, {}), **extra}
    cfg = config_dict(sensors=s)
    cfg["imu"]["rate_hz"] = RATE_HZ
    files = {f"{n}.csv": tabs[n] for n in s}
    files["imu.csv"] = tabs["imu"]
    return write_dir(root, cfg, files)
