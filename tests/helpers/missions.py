"""Minimal mission folders for the input-format tests (and others that need a mission.toml).

``config_dict`` is a small valid ``mission.toml`` as a dict; ``imu_rates`` and ``dvl_table`` are
short IMU (rates, 100 Hz) and DVL (3 Hz) tables; ``write_dir`` writes a mission folder from them.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from adaptnav.core.units import G0
from adaptnav.mission import parse_config, write_config

RATE = 100.0
"""The IMU rate of ``config_dict`` and ``imu_rates`` (Hz)."""
T = 1.0 / RATE
"""The IMU interval (s)."""


def config_dict(**sections: Any) -> dict[str, Any]:
    """A minimal valid mission.toml as a dict; ``sections`` replace or add top-level tables."""
    d: dict[str, Any] = {
        "mission": {"name": "test"},
        "imu": {
            "file": "imu.csv",
            "rate_hz": RATE,
            "noise": {"arw": [0.0667, "deg/sqrt(h)"], "vrw": [55, "ug/sqrt(Hz)"]},
        },
        "sensors": {
            "dvl": {"kind": "dvl", "file": "dvl.csv", "sigma": [0.02, "m/s"], "rate_hz": 3.0},
        },
        "initial": {"lat_deg": 26.8, "lon_deg": 56.0},
    }
    d.update(sections)
    return d


def imu_rates(n: int = 50, t0: float = 10.0) -> pd.DataFrame:
    t = t0 + T * np.arange(n)
    return pd.DataFrame(
        {
            "t_s": t,
            "gyro_x_rad_s": 1e-3 * t,
            "gyro_y_rad_s": 0.0,
            "gyro_z_rad_s": 2e-3,
            "accel_x_m_s2": 0.1,
            "accel_y_m_s2": 0.0,
            "accel_z_m_s2": -G0,
        }
    )


def dvl_table(n: int = 5, t0: float = 10.05) -> pd.DataFrame:
    t = t0 + np.arange(n) / 3.0
    return pd.DataFrame(
        {"t_s": t, "vx_m_s": 1.0 + 0.01 * t, "vy_m_s": 0.1, "vz_m_s": -0.01 * np.arange(n)}
    )


def write_dir(root: Path, cfg: dict[str, Any], files: dict[str, pd.DataFrame | str]) -> Path:
    """A mission folder with ``cfg`` and files given as DataFrames (by extension) or CSV text."""
    root.mkdir(parents=True, exist_ok=True)
    write_config(parse_config(cfg), root / "mission.toml")
    for name, content in files.items():
        if isinstance(content, str):
            (root / name).write_text(content)
        elif name.endswith(".csv"):
            content.to_csv(root / name, index=False)
        else:
            content.to_parquet(root / name, index=False)
    return root


def csv_text(df: pd.DataFrame) -> str:
    return str(df.to_csv(index=False))


def with_column(
    source: Path, root: Path, table: str, column: str, value: Callable[[pd.Series], pd.Series]
) -> Path:
    """A copy of mission folder ``source`` at ``root`` whose Parquet ``table``'s ``column`` is
    ``value`` of what it was (stamps moved, a column scaled or negated)."""
    shutil.copytree(source, root)
    df = pd.read_parquet(root / table)
    df[column] = value(df[column])
    df.to_parquet(root / table)
    return root
