"""Simulator benchmark: ``.venv/bin/python bench/sim_bench.py``.

Times :func:`adaptnav.sim.scenarios.simulate` on the ``paper-1`` preset (183 min, 1.04 M IMU
intervals at 100 Hz, every disturbance on, Parquet written to a temporary folder), best of
three wall-clock runs, with the part of it that writes the tables, and reports the process's
peak resident memory (``ru_maxrss``: everything the process ever held, interpreter and imports
included, so an upper bound for the simulation itself). Issue 4 asks for < 60 s and < 2 GB,
issue 15 for <= 2.5 s.

Baseline, measured in the same run: the exact IMU increments of the same trajectory by
8-point Gauss-Legendre quadrature on every interval (how the simulator integrated them before
issue 15: eight evaluations of the motion per interval) against the grid rule it uses now (one
per instant; docs/simulation.md, 'Exact increments'), best of three each, round-robin, so that
a slower spell of the machine hits both.
"""

from __future__ import annotations

import math
import resource
import sys
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np

from adaptnav.mission import write_mission
from adaptnav.sim import kinematics, scenarios
from adaptnav.sim import trajectory as tr
from adaptnav.sim.sensors import Disturbances

REPEATS = 3


def _peak_rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 2**20 if sys.platform == "darwin" else rss / 2**10  # bytes on macOS, else KiB


def _seconds(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def bench_simulate(preset: str = "paper-1", seed: int = 1) -> list[str]:
    """``simulate`` of ``preset``, best of :data:`REPEATS`, and the time of writing its tables."""
    with tempfile.TemporaryDirectory() as tmp:
        folders = [Path(tmp) / f"run{i}" for i in range(REPEATS)]
        best = min(
            _seconds(partial(scenarios.simulate, preset, seed, f, Disturbances())) for f in folders
        )
        peak = _peak_rss_mb()  # before the mission is held here to time the writing
        sim = scenarios.generate(scenarios.PRESETS[preset](), seed, Disturbances())
        write = min(
            _seconds(partial(write_mission, Path(tmp) / f"write{i}", sim.config, sim.tables))
            for i in range(REPEATS)
        )
    return [
        f"simulate {preset}: {best:.2f} s (best of {REPEATS}; writing the tables "
        f"{write:.2f} s of it), peak memory {peak:.0f} MB"
    ]


def bench_increments(preset: str = "paper-1") -> list[str]:
    """The exact increments of ``preset`` by the grid rule and by 8-point Gauss-Legendre on
    every interval (the baseline), round-robin, best of :data:`REPEATS` each."""
    sc = scenarios.PRESETS[preset]()
    traj = tr.build(sc.trajectory)
    n = math.floor(traj.duration * sc.imu_rate_hz + 1e-9)
    t = np.arange(0, n + 1) / sc.imu_rate_hz
    grid, gauss = math.inf, math.inf
    for _ in range(REPEATS):
        grid = min(grid, _seconds(partial(kinematics.imu_increments, traj.motion, t)))
        gauss = min(gauss, _seconds(partial(kinematics.imu_increments, traj.motion, t, 8)))
    return [
        f"increments {preset} ({n:,} intervals): grid rule {grid:.2f} s; baseline 8-node "
        f"Gauss-Legendre {gauss:.2f} s (same run): {gauss / grid:.1f}x"
    ]


if __name__ == "__main__":
    for bench in (bench_simulate, bench_increments):
        for line in bench():
            print(line, flush=True)
