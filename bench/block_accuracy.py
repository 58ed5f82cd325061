"""The accuracy cost of covariance blocks (docs/filters.md, 'Covariance blocks'), measured:
``.venv/bin/python bench/block_accuracy.py [--seeds N] [--block S]``.

Every filter (the paper's three, ``robust`` and the oracle) runs on the paper's two sea trials
(``paper-1``, ``paper-2``: no GNSS, every disturbance on) for seeds 1..N, once with the
covariance propagated every IMU step (``covariance_block_s = 0``) and once in blocks of S
seconds, from the same alignment. Printed per filter: the Monte Carlo means of the relative RMSE
and of the position, velocity and attitude NEES for both, and their relative difference (issue
15 asks for at most 0.1 %, or the blocks stay off by default). Missions are simulated into
``runs/block-accuracy/`` (ignored by git) and reused.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

import adaptnav.api as api
from adaptnav.analysis import evaluate
from adaptnav.mission import load_mission
from adaptnav.mission.config import with_overrides
from adaptnav.sim.scenarios import simulate

FILTERS = ("meskf", "maeskf", "vb", "robust", "oracle")
METRICS = ("relative_rmse_pct", "mean_nees_position", "mean_nees_velocity", "mean_nees_attitude")
ROOT = Path("runs/block-accuracy")


def _mission(preset: str, seed: int) -> Path:
    path = ROOT / f"{preset}-s{seed}"
    if not (path / "mission.toml").exists():
        simulate(preset, seed, path)
    return path


def _scores(folder: Path, block_s: float) -> dict[str, tuple[float, ...]]:
    m = load_mission(folder)
    m = dataclasses.replace(
        m, config=with_overrides(m.config, [("filter.covariance_block_s", block_s)])
    )
    initial = api.initial_state(m)[:3]
    out = {}
    for kind in FILTERS:
        metrics = evaluate.evaluate(api.run(m, kind, initial=initial), m.truth)
        out[kind] = tuple(float(getattr(metrics, k)) for k in METRICS)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--block", type=float, default=0.1)
    args = parser.parse_args()
    for preset in ("paper-1", "paper-2"):
        exact: dict[str, list[tuple[float, ...]]] = {k: [] for k in FILTERS}
        block: dict[str, list[tuple[float, ...]]] = {k: [] for k in FILTERS}
        for seed in range(1, args.seeds + 1):
            folder = _mission(preset, seed)
            for kind, values in _scores(folder, 0.0).items():
                exact[kind].append(values)
            for kind, values in _scores(folder, args.block).items():
                block[kind].append(values)
        print(f"{preset}, seeds 1-{args.seeds}: every step | blocks of {args.block:g} s "
              f"(relative difference of the Monte Carlo means)")  # fmt: skip
        worst = 0.0
        for kind in FILTERS:
            a, b = np.mean(exact[kind], axis=0), np.mean(block[kind], axis=0)
            rel = (b - a) / a
            worst = max(worst, float(np.max(np.abs(rel))))
            cells = "  ".join(
                f"{name.removeprefix('mean_')} {x:.4g} | {y:.4g} ({100 * r:+.1e} %)"
                for name, x, y, r in zip(METRICS, a, b, rel, strict=True)
            )
            print(f"  {kind:7s} {cells}")
        print(f"block accuracy {preset}: largest relative difference {100 * worst:.1e} %")


if __name__ == "__main__":
    main()
