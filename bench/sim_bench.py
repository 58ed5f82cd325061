"""Simulator benchmark: ``.venv/bin/python bench/sim_bench.py``.

Times :func:`adaptnav.sim.scenarios.simulate` on the ``paper-1`` preset (183 min, 1.1 M IMU
samples at 100 Hz, every disturbance on, Parquet written to a temporary folder) and reports the
process's peak resident memory (``ru_maxrss``: everything the process ever held, interpreter
and imports included, so an upper bound for the simulation itself). Issue 4 asks for < 60 s and
< 2 GB.
"""

from __future__ import annotations

import resource
import sys
import tempfile
import time
from pathlib import Path

from adaptnav.sim.scenarios import simulate
from adaptnav.sim.sensors import Disturbances


def _peak_rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 2**20 if sys.platform == "darwin" else rss / 2**10  # bytes on macOS, else KiB


def bench_simulate(preset: str = "paper-1", seed: int = 1) -> list[str]:
    """Simulate ``preset`` once; print and return ``simulate <preset>: X s, peak memory Y MB``."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        simulate(preset, seed, Path(tmp) / preset, Disturbances())
        elapsed = time.perf_counter() - t0
    line = f"simulate {preset}: {elapsed:.1f} s, peak memory {_peak_rss_mb():.0f} MB"
    print(line, flush=True)
    return [line]


if __name__ == "__main__":
    bench_simulate()
