"""Streaming benchmark: ``.venv/bin/python bench/stream_bench.py``.

A seeded 10-minute mission (the simulator's demo scenario, every disturbance on, shortened to
60 s alongside and 9 minutes under way) is run by the batch engine and then pushed one reading
at a time through :class:`adaptnav.api.stream.Stream` (robust filter, one alignment shared):
the wall-clock time of each ``push_imu`` and each ``push`` (median and 99th percentile, µs)
beside the batch engine's time per IMU sample on the same mission in the same process, the
baseline. Kernels are compiled (and the run warmed) before anything is timed; one core.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from adaptnav import api
from adaptnav.api.stream import IMU, Stream, replay
from adaptnav.core.units import DEG
from adaptnav.mission import Mission, load_mission, write_mission
from adaptnav.sim import scenarios
from adaptnav.sim import trajectory as tr

SEED = 7
KIND = "robust"


def ten_minutes(root: Path) -> Mission:
    """The demo scenario on a 10-minute track: 60 s alongside, 4 min straight at 2 m/s, a
    90° turn, 4 min straight; seeded."""
    base = scenarios.demo()
    segments = (tr.Static(60.0), tr.Straight(240.0, 2.0), tr.Turn(90 * DEG, rate=1.5 * DEG))
    spec = replace(base.trajectory, segments=(*segments, tr.Straight(240.0)))
    sim = scenarios.generate(replace(base, name="stream-bench", trajectory=spec), SEED)
    write_mission(root, sim.config, sim.tables)
    return load_mission(root)


def stream_latencies(m: Mission, start: tuple[np.ndarray, np.ndarray, float]) -> dict[str, list]:
    """Each push's wall-clock time (s), IMU and aiding readings apart."""
    times: dict[str, list[float]] = {"imu": [], "reading": []}
    with Stream(m, KIND, initial=start) as s:
        for item in replay(m):
            t0 = time.perf_counter()
            s.push_item(item)
            times["imu" if item.sensor == IMU else "reading"].append(time.perf_counter() - t0)
    return times


def bench_stream() -> list[str]:
    """Print and return the ``stream:`` line."""
    with tempfile.TemporaryDirectory() as tmp:
        m = ten_minutes(Path(tmp) / "mission")
    start = api.initial_state(m)[:3]
    api.run(m, KIND, initial=start)  # compile and warm
    batch = max(api.run(m, KIND, initial=start).meta["imu_samples_per_s"] for _ in range(3))
    stream_latencies(m, start)
    times = stream_latencies(m, start)
    us = {k: 1e6 * np.asarray(v) for k, v in times.items()}
    line = (
        f"stream: push_imu median {np.median(us['imu']):.1f} µs, p99 "
        f"{np.percentile(us['imu'], 99):.1f} µs; push (aiding reading) median "
        f"{np.median(us['reading']):.1f} µs, p99 {np.percentile(us['reading'], 99):.1f} µs "
        f"({len(us['imu'])} IMU samples, {len(us['reading'])} readings, {KIND}); batch engine "
        f"{1e6 / batch:.2f} µs per IMU sample"
    )
    print(line, flush=True)
    return [line]


if __name__ == "__main__":
    bench_stream()
