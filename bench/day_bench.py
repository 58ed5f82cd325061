"""A whole day in memory: ``.venv/bin/python bench/day_bench.py`` (issue 15's ``day:`` line).

Writes a 24-hour mission at 100 Hz (8.64 M IMU samples; DVL at 3 Hz, depth at 1 Hz, pendulum
inclinometer at 5 Hz) and runs ``adaptnav run`` on it end to end in a subprocess - loading,
static alignment, the filter, scoring-free results at 1 Hz, the run folder written - and prints
one line ``day: ...`` with the subprocess's peak resident memory, its wall time and the
filter's own time (``summary.json``'s ``meta.elapsed_s``), beside the same run on the first
hour of the mission (the baseline: what grows with the day). Targets (the issue's): peak
≤ 4 GB, the filter ≤ 60 s.

The vehicle is at rest, level and heading north at 45° N: its IMU reads the earth rate and
-g (plus white noise at the mission's ARW and VRW), its DVL zero velocity, its depth a
constant, its inclinometer a level attitude. The filter's cost does not depend on the motion
(every IMU step propagates the full covariance, every reading is an update), and at rest the
readings are exact to write without the simulator, whose own memory is not what is measured.
The mission is written in chunks (Parquet row groups) so that writing it stays small too.
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from adaptnav.core import earth
from adaptnav.mission import parse_config, write_config

IMU_HZ = 100.0
DAY_S = 86_400.0
HOUR_S = 3_600.0
LAT_DEG = 45.0
DEPTH_M = 50.0
ARW_RAD_SQRT_S = math.radians(0.0667) / 60.0  # 0.0667 °/√h, the paper's IMU
VRW_M_S_SQRT_S = 55e-6 * 9.80665  # 55 µg/√Hz
SIGMAS = {"dvl": 0.02, "depth": 0.1, "inclinometer": math.radians(0.1)}
RATES = {"dvl": 3.0, "depth": 1.0, "inclinometer": 5.0}
CHUNK_S = 3_600.0
"""Seconds of data generated and written at a time."""


def _config() -> dict[str, object]:
    return {
        "mission": {"name": "day-at-rest", "description": "bench/day_bench.py: 24 h at rest"},
        "imu": {
            "file": "imu.parquet",
            "format": "increments",
            "rate_hz": IMU_HZ,
            "noise": {
                "arw": [0.0667, "deg/sqrt(h)"],
                "vrw": [55, "ug/sqrt(Hz)"],
                "gyro_bias_sigma": [1.0, "deg/h"],
                "accel_bias_sigma": [0.25, "mg"],
            },
        },
        "sensors": {
            "dvl": {"kind": "dvl", "file": "dvl.parquet", "sigma": [0.02, "m/s"], "rate_hz": 3.0},
            "depth": {"kind": "depth", "file": "depth.parquet", "sigma": [0.1, "m"]},
            "inclinometer": {
                "kind": "inclinometer",
                "file": "inclinometer.parquet",
                "sigma": [0.1, "deg"],
                "rate_hz": 5.0,
            },
        },
        "initial": {
            "lat_deg": LAT_DEG,
            "lon_deg": 10.0,
            "h_m": -DEPTH_M,
            "alignment_s": 600.0,
            "rpy_deg": [0.0, 0.0, 0.0],  # heading given: gyrocompassing it takes time, not memory
        },
        "filter": {"output_rate_hz": 1.0},
    }


def _writer(path: Path, columns: list[str]) -> pq.ParquetWriter:
    return pq.ParquetWriter(path, pa.schema([(c, pa.float64()) for c in columns]))


def _imu_chunk(rng: np.random.Generator, t: np.ndarray) -> pa.Table:
    """Increments of a level, north-facing IMU at rest: ω_ib_b = (Ω cos L, 0, -Ω sin L),
    f_b = (0, 0, -g) (docs/mechanization.md), plus white noise of the mission's densities."""
    dt = 1.0 / IMU_HZ
    lat = math.radians(LAT_DEG)
    w = np.array([earth.OMEGA_IE * math.cos(lat), 0.0, -earth.OMEGA_IE * math.sin(lat)])
    g = float(earth.gravity_n(lat, -DEPTH_M)[2])
    n = t.size
    dth = w * dt + rng.normal(0.0, ARW_RAD_SQRT_S * math.sqrt(dt), (n, 3))
    dv = np.array([0.0, 0.0, -g]) * dt + rng.normal(0.0, VRW_M_S_SQRT_S * math.sqrt(dt), (n, 3))
    cols = {"t_s": t}
    for i, a in enumerate("xyz"):
        cols[f"dtheta_{a}_rad"] = dth[:, i]
    for i, a in enumerate("xyz"):
        cols[f"dvel_{a}_m_s"] = dv[:, i]
    return pa.table(cols)


def write_mission(root: Path, duration_s: float, seed: int = 0) -> Path:
    """The mission at rest of ``duration_s`` seconds into ``root`` (module docstring)."""
    root.mkdir(parents=True, exist_ok=True)
    write_config(parse_config(_config()), root / "mission.toml")
    rng = np.random.default_rng(seed)
    columns = {
        "dvl": ["t_s", "vx_m_s", "vy_m_s", "vz_m_s"],
        "depth": ["t_s", "depth_m"],
        "inclinometer": ["t_s", "roll_rad", "pitch_rad"],
    }
    imu = _writer(root / "imu.parquet", list(_imu_chunk(rng, np.zeros(1)).column_names))
    writers = {k: _writer(root / f"{k}.parquet", c) for k, c in columns.items()}
    for start in np.arange(0.0, duration_s, CHUNK_S):
        end = min(start + CHUNK_S, duration_s)
        imu.write_table(_imu_chunk(rng, np.arange(start * IMU_HZ, end * IMU_HZ) / IMU_HZ))
        for k, cols in columns.items():
            t = np.arange(start * RATES[k] + 0.5, end * RATES[k]) / RATES[k]
            z = rng.normal(0.0, SIGMAS[k], (t.size, len(cols) - 1))
            if k == "depth":
                z += DEPTH_M
            writers[k].write_table(pa.table({"t_s": t, **dict(zip(cols[1:], z.T, strict=True))}))
    imu.close()
    for w in writers.values():
        w.close()
    return root


def run_once(mission: Path, out: Path) -> tuple[float, float, float]:
    """Peak RSS (GB), wall time (s) and the filter's own time (s) of ``adaptnav run``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "adaptnav.cli", "run", str(mission), "--filter", "vb"]
    subprocess.run(
        [*cmd, "--out", str(out), "--force", "--quiet"], check=True, stdout=subprocess.DEVNULL
    )
    wall = time.perf_counter() - t0
    peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if peak_kb <= before:  # ru_maxrss is the largest child so far: a smaller one is hidden
        raise RuntimeError("run the larger mission first: its peak must be the new maximum")
    summary = json.loads((out / "summary.json").read_text())
    return peak_kb / 2**20, wall, float(summary["meta"]["elapsed_s"])


def bench_day() -> list[str]:
    """Print and return the ``day:`` line (module docstring)."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        day = write_mission(root / "day", DAY_S)
        hour = write_mission(root / "hour", HOUR_S)
        _wall(hour, root / "warm")  # loads the Numba cache before anything is timed
        d_peak, d_wall, d_filter = run_once(day, root / "run-day")
        samples = int(DAY_S * IMU_HZ)
        h_wall = _wall(hour, root / "run-hour")
    line = (
        f"day: 24 h at 100 Hz ({samples / 1e6:.2f} M IMU samples, DVL, depth, inclinometer; "
        f"VB-MAESKF, output 1 Hz), adaptnav run end to end: peak RSS {d_peak:.2f} GB "
        f"(target <= 4), wall {d_wall:.0f} s, filter {d_filter:.1f} s (target <= 60; "
        f"{samples / d_filter / 1e6:.2f} M samples/s); the first hour alone: wall {h_wall:.1f} s"
    )
    print(line, flush=True)
    return [line]


def _wall(mission: Path, out: Path) -> float:
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "adaptnav.cli", "run", str(mission), "--filter", "vb"]
    subprocess.run(
        [*cmd, "--out", str(out), "--force", "--quiet"], check=True, stdout=subprocess.DEVNULL
    )
    return time.perf_counter() - t0


if __name__ == "__main__":
    bench_day()
