"""The filter behaves as its linearisation: errors scale with the noise (docs/filters.md,
'Feedback and reset').

With every error source of a simulated mission scaled by s (the IMU's white noise and in-run
biases, the DVL's noise, the initial heading error and the configured σ's) and the filter told
so, a linear Kalman filter's errors and σ's scale by exactly s. So do an EKF's while its
linearisation holds; what is left is the price of linearising. At s = 0.1 the errors are small
enough for that price to vanish (s = 0.01 scales like s = 0.1: docs/error-model.md), so the
run at s = 1, started from ten times the s = 0.1 run's starting error and P0, must match ten
times the run at s = 0.1: on average over seeds, since a run's second-order terms move it by up
to a quarter either way.

The missions are the paper's trajectory No. 1 with the filter's model exactly the simulator's
(only the modelled errors, the in-run biases from 0, DVL only: scripts/r_scale_probe.py). Up to
0.3.10 the reset left the velocity-attitude term out and the yaw lost it. Ratios on seeds 1
and 2 (yaw RMSE, relative position RMSE, RMS yaw σ): 0.3.10 1.48 / 1.47 / 0.95 and 0.93 / 1.15
/ 0.95 (means 1.20 and 1.31: this test fails with ``invariant_reset = false``); now 1.07 / 1.07
/ 0.99 and 0.85 / 0.80 / 0.99 (means 0.96 and 0.94).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.mission import Mission, load_mission, with_overrides
from adaptnav.models import errorstate
from adaptnav.models.strapdown import NavState
from adaptnav.sim import scenarios
from adaptnav.sim.sensors import Disturbances

SEEDS = (1, 2)
RATIO_BAND = (0.85, 1.15)
"""Mean over the seeds of (error at s = 1) / (10 × error at s = 0.1)."""
SIGMA_BAND = (0.98, 1.02)
"""(yaw σ at s = 1) / (10 × yaw σ at s = 0.1): σ's do not depend on the noise's draw."""


def _scenario(s: float) -> scenarios.Scenario:
    base = scenarios.paper_1()
    imu = replace(
        base.imu, arw=base.imu.arw * s, vrw=base.imu.vrw * s,
        gyro_bias_sigma=base.imu.gyro_bias_sigma * s,
        accel_bias_sigma=base.imu.accel_bias_sigma * s,
    )  # fmt: skip
    assert base.initial_heading_sigma is not None
    return replace(
        base, imu=imu, calibrated_imu=imu.calibrated(),
        dvl=replace(base.dvl, sigma_scale=base.dvl.sigma_scale * s,
                    sigma_floor=base.dvl.sigma_floor * s),
        gps=replace(base.gps, sigma_white=base.gps.sigma_white * s,
                    sigma_gm=base.gps.sigma_gm * s),
        initial_heading_sigma=base.initial_heading_sigma * s,
    )  # fmt: skip


def _mission(folder: Path, s: float) -> Mission:
    """The mission in ``folder`` with the filter told its errors' scale s, DVL only."""
    m = load_mission(folder)
    overrides = (
        ("imu.initial_bias_sigma.gyro", [0.01 * s, "deg/h"]),  # the truth's bias starts at 0
        ("imu.initial_bias_sigma.accel", [0.0025 * s, "mg"]),
        ("sensors.inclinometer.use", "off"),
        ("sensors.depth.use", "off"),
        ("initial.sigma_position_m", 3.0 * s),
        ("initial.sigma_velocity_m_s", 0.05 * s),
    )
    return replace(m, config=with_overrides(m.config, overrides))


def _truth_state(m: Mission, t0: float) -> np.ndarray:
    """The true nominal state at ``t0`` (a sample of the truth table)."""
    assert m.truth is not None
    r = m.truth.iloc[int(np.argmin(np.abs(m.truth["t_s"].to_numpy() - t0)))]
    return NavState.from_euler(
        r.lat_rad, r.lon_rad, r.h_m, (r.vn_m_s, r.ve_m_s, r.vd_m_s),
        r.roll_rad, r.pitch_rad, r.yaw_rad,
        (r.ba_x_m_s2, r.ba_y_m_s2, r.ba_z_m_s2), (r.bg_x_rad_s, r.bg_y_rad_s, r.bg_z_rad_s),
    ).to_array()  # fmt: skip


def _metrics(m: Mission, start: tuple[np.ndarray, np.ndarray, float]) -> np.ndarray:
    """(yaw RMSE, relative RMSE, RMS yaw σ) of MESKF on ``m`` from ``start``."""
    result = api.run(m, "meskf", initial=start)
    assert m.truth is not None
    e = evaluate.evaluate(result, m.truth)
    sd_yaw = float(np.sqrt(np.mean(result.solution["sd_phi_D"].to_numpy() ** 2)))
    return np.array([e.yaw_rmse_rad, e.relative_rmse_pct, sd_yaw])


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[int, float], np.ndarray]:
    """Per seed, both runs from one start: the s = 0.1 mission's own alignment, and for s = 1
    its error and P0 times ten (the alignment itself is not scale-invariant: its zero-velocity
    σ is the same at every s)."""
    root = tmp_path_factory.mktemp("linear-regime")
    clean = replace(Disturbances.clean(), imu_turn_on_bias=False)
    out = {}
    for seed in SEEDS:
        small, big = (
            _mission(
                scenarios.simulate_scenario(_scenario(s), seed, root / f"{s:g}-{seed}", clean), s
            )
            for s in (0.1, 1.0)
        )
        x0, P0, t0 = api.initial_state(small)[:3]
        error = errorstate.difference(_truth_state(small, t0), x0)
        x0_big = errorstate.inject(_truth_state(big, t0), -10.0 * error)
        out[seed, 0.1] = _metrics(small, (x0, P0, t0))
        out[seed, 1.0] = _metrics(big, (x0_big, 100.0 * P0, t0))
    return out


def test_errors_and_sigmas_scale_with_the_noise(
    runs: dict[tuple[int, float], np.ndarray],
) -> None:
    ratios = np.array([runs[seed, 1.0] / (10.0 * runs[seed, 0.1]) for seed in SEEDS])
    yaw, relative = ratios[:, 0].mean(), ratios[:, 1].mean()
    detail = f"per seed (yaw, relative RMSE, yaw σ): {ratios.round(3).tolist()}"
    assert RATIO_BAND[0] <= yaw <= RATIO_BAND[1], f"yaw RMSE ratio {yaw:.3f}; {detail}"
    assert RATIO_BAND[0] <= relative <= RATIO_BAND[1], f"RMSE ratio {relative:.3f}; {detail}"
    for sigma in ratios[:, 2]:
        assert SIGMA_BAND[0] <= sigma <= SIGMA_BAND[1], f"yaw σ ratio {sigma:.3f}; {detail}"
