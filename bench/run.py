"""Speed benchmarks, measured in one run: ``.venv/bin/python bench/run.py``.

Each benchmark is a function returning the lines it prints; add new ones (filters, simulator)
to ``BENCHMARKS``. Times are wall clock, best of several repeats after a warm-up (JIT compile
excluded), on one core.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from adaptnav.compiled import propagation as kernels
from adaptnav.core import attitude
from adaptnav.engine import batch as engine
from adaptnav.engine.channels import build_channels
from adaptnav.engine.propagation import propagate_numpy
from adaptnav.estimation.settings import FilterKind, FilterSettings
from adaptnav.models import errorstate, strapdown
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.sensors import DVL, Depth, Inclinometer, MeasurementModel
from adaptnav.sim import kinematics as kin

PAPER_KINDS: tuple[FilterKind, ...] = ("meskf", "maeskf", "vb", "robust")
"""The paper's filters and the default one (the oracle is MESKF with known R: no speed of its
own)."""
TAU_F = engine.EngineConfig.specific_force_tau_s
"""F's specific-force low-pass, as the engine runs it."""

MEASURED: dict[str, float] = {}
"""Figures shared between benchmarks of one run (the propagation-only rate)."""


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
            x.copy(), P.copy(), dth, dv, dts, w0.copy(), f0.copy(), q, tau_a, tau_g,
            np.full(3, np.nan), TAU_F, 0.0,
        )  # fmt: skip

    def twin() -> None:
        propagate_numpy(x, P, dth[:n_slow], dv[:n_slow], dt, w0, f0, q, tau_a, tau_g, tau_f=TAU_F)

    kernels.propagate_run(x.copy(), P.copy(), dth[:10], dv[:10], dts[:10], w0.copy(),
                          f0.copy(), q, tau_a, tau_g, np.full(3, np.nan), TAU_F, 0.0)  # fmt: skip
    rate_fast = n_fast / best_time(compiled, 5)
    rate_slow = n_slow / best_time(twin, 2)
    MEASURED["propagation"] = rate_fast
    return [
        f"propagation: {rate_fast:.0f} IMU samples/s (compiled)",
        f"propagation: {rate_slow:.0f} IMU samples/s (numpy twin)",
        f"propagation: ratio compiled/numpy = {rate_fast / rate_slow:.1f}x",
    ]


FILTER_NOISE = ImuNoise(
    arw=math.radians(0.0667) / 60.0,
    vrw=55e-6 * 9.80665,
    gyro_bias_sigma=math.radians(1.0) / 3600.0,
    gyro_bias_tau=3600.0,
    accel_bias_sigma=0.25e-3 * 9.80665,
    accel_bias_tau=3600.0,
)


@dataclass(frozen=True)
class FilterMission:
    """Inputs of :func:`adaptnav.engine.batch.run_batch` for one mission."""

    x0: np.ndarray
    P0: np.ndarray
    imu_t: np.ndarray
    dt: float
    dtheta: np.ndarray
    dvel: np.ndarray
    readings: dict[str, tuple[np.ndarray, np.ndarray]]
    sensors: list[tuple[MeasurementModel, float]]


def _filter_mission(n: int, dt: float = 0.01, seed: int = 1) -> FilterMission:
    """n IMU intervals of a vessel holding station at 45° N (roll, pitch, heading set), IMU
    increments and aiding readings from that known state plus white noise.

    DVL 3 Hz (lever arm, mounting rotated 45°), depth 1 Hz (lever arm), inclinometer 1 Hz,
    stamped asynchronously (offsets 0.0137, 0.271, 0.6203 s): 5 epochs per second, none shared.
    """
    rng = np.random.default_rng(seed)
    motion = kin.stationary(math.radians(45.0), 0.2, -20.0, 0.02, -0.01, 1.0)
    x = kin.true_states(motion, [0.0])[0]
    k = kin.true_kinematics(motion, [0.0])
    w, f = k.omega_ib_b[0], k.f_b[0]
    t = dt * np.arange(1, n + 1)
    dth = w * dt + rng.normal(0.0, FILTER_NOISE.arw * math.sqrt(dt), (n, 3))
    dv = f * dt + rng.normal(0.0, FILTER_NOISE.vrw * math.sqrt(dt), (n, 3))
    dvl = DVL(0.01, np.array([1.0, 0.2, 0.5]), attitude.euler_to_dcm(0.0, 0.0, math.pi / 4))
    depth = Depth(0.05, np.array([0.3, 0.0, 0.2]))
    inclinometer = Inclinometer(0.002)
    clean = {
        "dvl": dvl.predict(x, w),
        "depth": depth.predict(x),
        "inclinometer": inclinometer.predict(x),
    }
    sigma = {"dvl": [0.01] * 3, "depth": [0.05], "inclinometer": [0.002] * 2}
    periods = {"dvl": 1 / 3, "depth": 1.0, "inclinometer": 1.0}
    offsets = {"dvl": 0.0137, "depth": 0.271, "inclinometer": 0.6203}
    readings = {}
    for name, z in clean.items():
        ts = np.arange(offsets[name], n * dt - 1e-9, periods[name])
        noise = rng.normal(0.0, 1.0, (ts.size, z.size)) * np.asarray(sigma[name])
        readings[name] = (ts, z + noise)
    sd = np.array(
        [1.0] * 3 + [0.05] * 3 + [1e-3] * 3 + [FILTER_NOISE.accel_bias_sigma] * 3
        + [FILTER_NOISE.gyro_bias_sigma] * 3
    )  # fmt: skip
    sensors: list[tuple[MeasurementModel, float]] = [
        (dvl, periods["dvl"]),
        (depth, periods["depth"]),
        (inclinometer, periods["inclinometer"]),
    ]
    return FilterMission(x, np.diag(sd**2), t, dt, dth, dv, readings, sensors)


def _run_filter(kind: FilterKind, m: FilterMission, smooth: bool = False) -> engine.EngineOutput:
    channels = build_channels(FilterSettings(kind=kind), m.sensors)
    config = engine.EngineConfig(FILTER_NOISE, smooth=smooth)
    return engine.run_batch(
        config, channels, m.x0, m.P0, 0.0, m.imu_t, m.dt, m.dtheta, m.dvel, m.readings
    )


def bench_filters() -> list[str]:
    """The three filters end to end (engine.run_batch, 15 states): 1 h at 100 Hz with DVL 3 Hz,
    depth 1 Hz and inclinometer 1 Hz (18 000 epochs), against propagation only.

    The filters and propagation only (kernels.propagate_run over the same IMU data) are timed
    round-robin, best of 5 each, so that a slower spell of the machine hits all of them; the
    propagation-only rate is the best of this and :func:`bench_propagation`'s.
    """
    n = 360_000
    mission = _filter_mission(n)
    warm = _filter_mission(500)
    q = errorstate.noise_psd(FILTER_NOISE)
    tau_a, tau_g = FILTER_NOISE.accel_bias_tau, FILTER_NOISE.gyro_bias_tau
    dts = np.full(n, mission.dt)
    w0, f0 = mission.dtheta[0] / mission.dt, mission.dvel[0] / mission.dt

    def propagation_only() -> None:
        kernels.propagate_run(
            mission.x0.copy(), mission.P0.copy(), mission.dtheta, mission.dvel, dts, w0.copy(),
            f0.copy(), q, tau_a, tau_g, np.full(3, np.nan), TAU_F, 0.0,
        )  # fmt: skip

    runs: dict[str, Callable[[], object]] = {"propagation": propagation_only}
    for kind in PAPER_KINDS:
        _run_filter(kind, warm)  # JIT warm-up (or loading the compiled code from the cache)
        runs[kind] = partial(_run_filter, kind, mission)
    best = dict.fromkeys(runs, math.inf)
    for _ in range(5):
        for name, fn in runs.items():
            best[name] = min(best[name], best_time(fn, 1))
    propagation = max(n / best["propagation"], MEASURED.get("propagation", 0.0))
    lines = [f"filters: propagation-only reference {propagation:.0f} IMU samples/s (best this run)"]
    for kind in PAPER_KINDS:
        rate = n / best[kind]
        lines.append(
            f"filter {kind}: {rate:.0f} IMU samples/s "
            f"(ratio to propagation-only: {rate / propagation:.2f})"
        )
    return lines


def bench_smoother() -> list[str]:
    """RTS smoothing (docs/smoothing.md) on the mission of :func:`bench_filters`: the forward
    pass that stores its nodes plus the backward pass, against the forward pass alone, round-robin,
    best of 3 each; and the memory the store took per hour of 100-Hz IMU."""
    n = 360_000
    mission = _filter_mission(n)
    warm = _filter_mission(500)
    lines = []
    for kind in ("vb", "robust"):
        _run_filter(kind, warm, smooth=True)
        forward, smoothed = (
            partial(_run_filter, kind, mission),
            partial(_run_filter, kind, mission, True),
        )
        best = [math.inf, math.inf]
        for _ in range(3):
            best[0] = min(best[0], best_time(forward, 1))
            best[1] = min(best[1], best_time(smoothed, 1))
        out = smoothed()
        assert out.smoothed is not None
        hours = n * mission.dt / 3600.0
        lines.append(
            f"smoother {kind}: {n / best[1]:.0f} IMU samples/s forward + backward (ratio to the "
            f"forward pass alone, {n / best[0]:.0f}/s: {best[0] / best[1]:.2f}); store "
            f"{out.smoothed.store_bytes / hours / 1e6:.0f} MB per hour of 100-Hz IMU "
            f"({out.smoothed.nodes} nodes, {out.smoothed.update_nodes} with an update)"
        )
    return lines


def bench_dense_baseline() -> list[str]:
    """The filters' baseline of issue 15: a plain dense Numba ESKF against ``vb``
    (bench/dense_eskf.py)."""
    from dense_eskf import bench_dense  # imported here: that module imports this one

    return bench_dense()


BENCHMARKS: list[Callable[[], list[str]]] = [
    bench_propagation,
    bench_filters,
    bench_dense_baseline,
    bench_smoother,
]


def main() -> None:
    for bench in BENCHMARKS:
        for line in bench():
            print(line, flush=True)


if __name__ == "__main__":
    main()
