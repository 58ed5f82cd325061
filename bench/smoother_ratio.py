"""The ratio of `make bench`'s `smoother:` line, measured repeatedly (docs/smoothing.md, 'Speed').

The mission and runs of bench/run.py's ``bench_smoother`` (1 h of 100-Hz IMU, 54 001 nodes),
the forward pass alone and the smoothed run alternating in one process (the order swapped every
round) so that a slow spell of a shared machine hits both alike. Per round the ratio of the two
times; the median over the rounds, and the bench's own figure (best forward time over best
smoothed time); and the ratio of the process's CPU times (all its threads), which a loaded
machine moves less than the wall-clock one. The smoothed run's phases come from run_batch's
progress calls: the forward pass with its store ("filtering" to "smoothing") and the rest
(backward pass, gather, output).

    .venv/bin/python bench/smoother_ratio.py [--rounds 7] [--kinds vb,robust] [--tag NAME]

To set two versions of the code against each other, run it alternately under each one's
``PYTHONPATH`` (``git archive REV src | tar -x -C DIR``), each with its own ``--tag``.
"""

from __future__ import annotations

import argparse
import statistics
import time

from adaptnav.engine import batch as engine
from adaptnav.engine.channels import build_channels
from adaptnav.estimation.settings import FilterKind, FilterSettings
from run import FILTER_NOISE, FilterMission, _filter_mission  # bench/run.py, beside this file


def _timed(kind: FilterKind, m: FilterMission, smooth: bool) -> tuple[float, float, float]:
    """Wall time of one run as bench/run.py's ``_run_filter`` makes it, when smoothed that of
    its part after the forward pass (from the "smoothing" progress call on), and the CPU time
    of the process's threads over the run (less dependent on what else the machine runs)."""
    marks: dict[str, float] = {}

    def hear(phase: str) -> None:
        marks[phase] = time.perf_counter()

    c0, t0 = time.process_time(), time.perf_counter()
    channels = build_channels(FilterSettings(kind=kind), m.sensors)
    config = engine.EngineConfig(FILTER_NOISE, smooth=smooth)
    engine.run_batch(
        config, channels, m.x0, m.P0, 0.0, m.imu_t, m.dt, m.dtheta, m.dvel, m.readings,
        progress=hear,
    )  # fmt: skip
    t1 = time.perf_counter()
    return t1 - t0, (t1 - marks["smoothing"]) if smooth else 0.0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--kinds", default="vb,robust")
    ap.add_argument("--tag", default="")
    args = ap.parse_args()
    n = 360_000
    mission = _filter_mission(n)
    warm = _filter_mission(500)
    for kind in args.kinds.split(","):  # FilterKind names
        _timed(kind, warm, True)  # JIT warm-up (or loading the compiled code from the cache)
        _timed(kind, warm, False)
        fwd, smo, tail, cpu_f, cpu_s = [], [], [], [], []
        for r in range(args.rounds):
            order = (False, True) if r % 2 == 0 else (True, False)
            for smooth in order:
                total, rest, cpu = _timed(kind, mission, smooth)
                (smo if smooth else fwd).append(total)
                (cpu_s if smooth else cpu_f).append(cpu)
                if smooth:
                    tail.append(rest)
        ratios = [f / s for f, s in zip(fwd, smo, strict=True)]
        cpu = [f / s for f, s in zip(cpu_f, cpu_s, strict=True)]
        print(
            f"{args.tag} {kind}: ratio median {statistics.median(ratios):.3f} "
            f"(min {min(ratios):.3f}, max {max(ratios):.3f}, {args.rounds} rounds); "
            f"best/best {min(fwd) / min(smo):.3f}; forward {min(fwd):.3f} s "
            f"(median {statistics.median(fwd):.3f}), smoothed {min(smo):.3f} s "
            f"(median {statistics.median(smo):.3f}), of which after the forward pass "
            f"{min(tail):.3f} s (median {statistics.median(tail):.3f}); CPU ratio median "
            f"{statistics.median(cpu):.3f} (forward {min(cpu_f):.3f} s, smoothed "
            f"{min(cpu_s):.3f} s, best of each)",
            flush=True,
        )


if __name__ == "__main__":
    main()
