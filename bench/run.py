"""Speed benchmarks, measured in one run: ``.venv/bin/python bench/run.py``.

Each benchmark is a function returning the lines it prints; add new ones (filters, simulator)
to ``BENCHMARKS``. Times are wall clock, best of several repeats after a warm-up (JIT compile
excluded), on one core.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from adaptnav import kernels, strapdown
from adaptnav.propagation import propagate_numpy


def best_time(fn: Callable[[], object], repeats: int) -> float:
    """Shortest wall-clock time of ``repeats`` calls (s)."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _imu_scenario(n: int, dt: float, seed: int = 0) -> tuple[np.ndarray, ...]:
    """A moving, turning vehicle at 45° N: state, covariance, increments, noise PSDs."""
    rng = np.random.default_rng(seed)
    x = strapdown.NavState.from_euler(
        math.radians(45.0), 0.1, -20.0, (2.0, 1.0, 0.1), 0.05, -0.02, 1.0, (0.01,) * 3, (1e-5,) * 3
    ).to_array()
    P = np.diag([1.0] * 3 + [0.01] * 3 + [1e-4] * 3 + [1e-4] * 3 + [1e-8] * 3)
    t = np.arange(n) * dt
    w = np.column_stack([0.2 * np.sin(0.5 * t), 0.1 * np.cos(0.3 * t), 0.05 + 0.0 * t])
    w += rng.normal(0.0, 1e-3, (n, 3))
    f = np.array([0.0, 0.0, -9.81]) + rng.normal(0.0, 0.3, (n, 3))
    q = np.array([1e-6] * 3 + [1e-9] * 3 + [1e-10] * 3 + [1e-14] * 3)
    return x, P, w * dt, f * dt, np.full(n, dt), q


def bench_propagation() -> list[str]:
    """Strapdown + full 15×15 covariance propagation per IMU sample: compiled vs NumPy twin."""
    dt, tau_a, tau_g = 0.01, 3600.0, 3600.0
    n_fast, n_slow = 360_000, 1_000  # 1 h at 100 Hz; 10 s for the twin
    x, P, dth, dv, dts, q = _imu_scenario(n_fast, dt)
    w0, f0 = dth[0] / dt, dv[0] / dt

    def compiled() -> None:
        kernels.propagate_run(
            x.copy(), P.copy(), dth, dv, dts, w0.copy(), f0.copy(), q, tau_a, tau_g
        )

    def twin() -> None:
        propagate_numpy(x, P, dth[:n_slow], dv[:n_slow], dt, w0, f0, q, tau_a, tau_g)

    kernels.propagate_run(x.copy(), P.copy(), dth[:10], dv[:10], dts[:10], w0.copy(),
                          f0.copy(), q, tau_a, tau_g)  # fmt: skip  # JIT warm-up
    rate_fast = n_fast / best_time(compiled, 5)
    rate_slow = n_slow / best_time(twin, 2)
    return [
        f"propagation: {rate_fast:.0f} IMU samples/s (compiled)",
        f"propagation: {rate_slow:.0f} IMU samples/s (numpy twin)",
        f"propagation: ratio compiled/numpy = {rate_fast / rate_slow:.1f}x",
    ]


BENCHMARKS: list[Callable[[], list[str]]] = [bench_propagation]


def main() -> None:
    for bench in BENCHMARKS:
        for line in bench():
            print(line, flush=True)


if __name__ == "__main__":
    main()
