"""Synthetic missions made from known motion for the filter tests (not the simulator's).

The IMU error model is the filter's own (white noise of the configured PSDs, first-order
Gauss-Markov biases with their σ and τ, turn-on biases and the initial error drawn from P0),
so with R_true = R_nominal the filter should be consistent (NEES/NIS; docs/filters.md,
'Verification').
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptnav.core import earth
from adaptnav.models import errorstate
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.sensors.depth import Depth
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.gnss import GNSS
from adaptnav.sim import kinematics as kin

Array = NDArray[np.float64]

NOISE = ImuNoise(
    arw=math.radians(0.0667) / 60.0,
    vrw=55e-6 * 9.80665,
    gyro_bias_sigma=math.radians(1.0) / 3600.0,
    gyro_bias_tau=3600.0,
    accel_bias_sigma=0.25e-3 * 9.80665,
    accel_bias_tau=3600.0,
)
P0_SIGMA = np.array(
    [2.0] * 3 + [0.05] * 3 + [1e-3, 1e-3, 5e-3] + [NOISE.accel_bias_sigma] * 3
    + [NOISE.gyro_bias_sigma] * 3
)  # fmt: skip


@dataclass(frozen=True)
class Dataset:
    t0: float
    imu_t: Array
    dt: float
    dtheta: Array
    dvel: Array
    x0_hat: Array
    P0: Array
    readings: dict[str, tuple[Array, Array]]
    truth_t: Array
    truth: Array  # (N, 16) with true biases, at truth_t (the IMU epochs)
    models: dict[str, object]
    sigma: dict[str, Array]
    outlier: dict[str, Array]  # per reading: True where an outlier was injected


def make(
    seed: int,
    duration: float = 60.0,
    dt: float = 0.01,
    sensors: tuple[str, ...] = ("dvl", "depth", "gnss"),
    dvl_sigma: float = 0.02,
    dvl_sigma_factor_after: tuple[float, float] | None = None,
    dvl_outlier_rate: float = 0.0,
    dvl_outlier_size: float = 20.0,
) -> Dataset:
    """One seeded mission on `kinematics.turn_with_waves`, sensors stamped asynchronously.

    ``dvl_sigma_factor_after = (t_jump, factor)`` multiplies the DVL σ after t_jump;
    outliers add ``dvl_outlier_size`` × nominal σ on one random axis with random sign.
    """
    rng = np.random.default_rng(seed)
    motion = kin.turn_with_waves()
    n = round(duration / dt)
    t = dt * np.arange(n + 1)
    dth, dv = kin.imu_increments(motion, t)
    truth = kin.true_states(motion, t)

    # Gauss-Markov biases, exact discretisation, turn-on values from P0.
    ba = np.empty((n + 1, 3))
    bg = np.empty((n + 1, 3))
    ba[0] = rng.normal(0.0, P0_SIGMA[9:12])
    bg[0] = rng.normal(0.0, P0_SIGMA[12:15])
    pa, pg = math.exp(-dt / NOISE.accel_bias_tau), math.exp(-dt / NOISE.gyro_bias_tau)
    wa = rng.normal(0.0, NOISE.accel_bias_sigma * math.sqrt(1 - pa * pa), (n, 3))
    wg = rng.normal(0.0, NOISE.gyro_bias_sigma * math.sqrt(1 - pg * pg), (n, 3))
    for k in range(n):
        ba[k + 1] = pa * ba[k] + wa[k]
        bg[k + 1] = pg * bg[k] + wg[k]
    bias_a = 0.5 * (ba[:-1] + ba[1:])
    bias_g = 0.5 * (bg[:-1] + bg[1:])
    dth_raw = dth + bias_g * dt + rng.normal(0.0, NOISE.arw * math.sqrt(dt), dth.shape)
    dv_raw = dv + bias_a * dt + rng.normal(0.0, NOISE.vrw * math.sqrt(dt), dv.shape)
    truth[:, 10:13] = ba
    truth[:, 13:16] = bg

    P0 = np.diag(P0_SIGMA**2)
    dx0 = rng.normal(0.0, P0_SIGMA)
    x0_hat = errorstate.inject(truth[0], -dx0)
    x0_hat[10:16] = truth[0, 10:16] - dx0[9:15]

    models: dict[str, object] = {
        "dvl": DVL(sigma=dvl_sigma),
        "depth": Depth(sigma=0.1),
        "gnss": GNSS(sigma=2.0),
    }
    periods = {"dvl": 1 / 3, "depth": 1.0, "gnss": 1.0}
    offsets = {"dvl": 0.0137, "depth": 0.271, "gnss": 0.5003}
    readings: dict[str, tuple[Array, Array]] = {}
    sigma: dict[str, Array] = {}
    outlier: dict[str, Array] = {}
    for name in sensors:
        ts = np.arange(offsets[name], duration - 1e-9, periods[name])
        ts = ts + rng.uniform(-1e-3, 1e-3, ts.size)  # clock jitter
        kin_s = kin.true_kinematics(motion, ts)
        xs = kin.true_states(motion, ts)
        model = models[name]
        clean = np.array(
            [_predict(name, model, xs[i], kin_s.omega_ib_b[i]) for i in range(ts.size)]
        )
        if name == "dvl":
            sig = np.full(ts.size, dvl_sigma)
            if dvl_sigma_factor_after is not None:
                sig[ts >= dvl_sigma_factor_after[0]] *= dvl_sigma_factor_after[1]
            z = clean + rng.normal(0.0, 1.0, clean.shape) * sig[:, None]
            out = rng.random(ts.size) < dvl_outlier_rate
            axis = rng.integers(0, 3, ts.size)
            sign = rng.choice([-1.0, 1.0], ts.size)
            z[out, axis[out]] += sign[out] * dvl_outlier_size * dvl_sigma
            sigma[name], outlier[name] = sig, out
        elif name == "depth":
            z = clean + rng.normal(0.0, 0.1, clean.shape)
            sigma[name], outlier[name] = np.full(ts.size, 0.1), np.zeros(ts.size, bool)
        else:
            lat = xs[:, 0]
            rm = earth.meridian_radius(lat) + xs[:, 2]
            rn = earth.transverse_radius(lat) + xs[:, 2]
            e = rng.normal(0.0, 2.0, (ts.size, 3))
            z = clean + np.column_stack([e[:, 0] / rm, e[:, 1] / (rn * np.cos(lat)), -e[:, 2]])
            sigma[name], outlier[name] = np.full(ts.size, 2.0), np.zeros(ts.size, bool)
        readings[name] = (ts, z)
    return Dataset(
        0.0, t[1:], dt, dth_raw, dv_raw, x0_hat, P0, readings, t, truth, models, sigma, outlier
    )


def _predict(name: str, model: object, x: Array, w: Array) -> Array:
    if name == "dvl":
        return np.asarray(model.predict(x, w))  # type: ignore[attr-defined]
    return np.atleast_1d(np.asarray(model.predict(x), dtype=float))  # type: ignore[attr-defined]


def periods() -> dict[str, float]:
    return {"dvl": 1 / 3, "depth": 1.0, "gnss": 1.0}
