"""The RTS backward pass alone (compiled.smoother.backward) on the store of `make bench`'s
smoother mission (bench/run.py ``bench_smoother``: 1 h of 100-Hz IMU, 54 001 nodes, 18 000 with
an update): the forward pass stores its nodes once, then each repeat smooths a fresh copy, in
one thread (that thread's CPU time) and in two (wall clock and the process's CPU time), as the
engine runs it (``full=False``). docs/smoothing.md, 'Speed'.

    .venv/bin/python bench/smoother_backward.py [--kind vb] [--repeats 6]

Run it alternately under two versions' ``PYTHONPATH`` to compare them (bench/smoother_ratio.py).
"""

from __future__ import annotations

import argparse
import statistics
import time

from adaptnav.compiled import smoother as smk
from adaptnav.engine import batch as engine
from adaptnav.engine.channels import build_channels
from adaptnav.estimation.settings import FilterKind, FilterSettings
from run import FILTER_NOISE, FilterMission, _filter_mission  # bench/run.py, beside this file


def _store(kind: FilterKind, m: FilterMission) -> tuple[smk.Store, int]:
    """The forward pass's store of the mission, and the filter's reset mode."""
    channels = build_channels(FilterSettings(kind=kind), m.sensors)
    nav = engine.Navigator(
        engine.EngineConfig(FILTER_NOISE, smooth=True), channels, m.x0, m.P0, 0.0
    )
    for name, (t, z) in m.readings.items():
        nav.feed_measurements(name, t, z)
    nav.feed_imu(m.imu_t, m.dt, m.dtheta, m.dvel)
    nav.flush()
    assert nav._sm is not None  # the store, before smooth() smooths it in place
    return tuple(a.copy() for a in nav._sm), nav.config.reset_mode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", default="vb")
    ap.add_argument("--repeats", type=int, default=6)
    args = ap.parse_args()
    warm, reset = _store(args.kind, _filter_mission(500))
    smk.backward(warm, reset, 2, full=False)  # compiled, or loaded from the cache
    store, reset = _store(args.kind, _filter_mission(360_000))
    one, two_wall, two_cpu = [], [], []
    for _ in range(args.repeats):
        sm = tuple(a.copy() for a in store)
        c0 = time.thread_time()
        smk.backward(sm, reset, 1, full=False)
        one.append(time.thread_time() - c0)
        sm = tuple(a.copy() for a in store)
        c0, t0 = time.process_time(), time.perf_counter()
        smk.backward(sm, reset, 2, full=False)
        two_wall.append(time.perf_counter() - t0)
        two_cpu.append(time.process_time() - c0)
    print(
        f"backward {args.kind}: one thread CPU {min(one):.4f} s (median "
        f"{statistics.median(one):.4f}); two threads wall {min(two_wall):.4f} s (median "
        f"{statistics.median(two_wall):.4f}), CPU {min(two_cpu):.4f} s (median "
        f"{statistics.median(two_cpu):.4f}); best of {args.repeats}",
        flush=True,
    )


if __name__ == "__main__":
    main()
