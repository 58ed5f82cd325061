"""The plain dense ESKF of bench/dense_eskf.py, the baseline ``make bench`` times adaptnav's ``vb``
against: its measurement Jacobians against finite differences of its own h(x), and 60 s of the
benchmark mission staying on the true (stationary) state within its covariance.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import dense_eskf as dense
from adaptnav.core import attitude
from adaptnav.models import errorstate
from run import _filter_mission


@pytest.fixture(scope="module")
def mission() -> dense.FilterMission:
    return _filter_mission(6000)  # 60 s at 100 Hz, seeded


@pytest.mark.parametrize("code", [0, 1, 2])
def test_jacobian_matches_finite_differences(code: int) -> None:
    """y(x ⊕ δ) - y(x) = -H δ to first order, δ along each error state (dx = truth - estimate)."""
    rng = np.random.default_rng(15)
    x = errorstate.inject(_filter_mission(1).x0, rng.normal(0.0, 0.05, 15))
    x[3:6] = [1.5, -0.7, 0.2]  # moving, so the attitude columns of the DVL's H are not zero
    l_dvl, l_depth = np.array([1.0, 0.2, 0.5]), np.array([0.3, 0.0, 0.2])
    C_sb = attitude.euler_to_dcm(0.1, -0.2, 0.7)
    w_b, z = np.array([0.01, -0.02, 0.03]), np.zeros(3)
    y0, H = dense._measure(code, x, z, w_b, l_dvl, C_sb, l_depth)
    eps = 1e-6
    for j in range(15):
        d = np.zeros(15)
        d[j] = eps
        y1, _ = dense._measure(code, errorstate.inject(x, d), z, w_b, l_dvl, C_sb, l_depth)
        np.testing.assert_allclose((y0 - y1) / eps, H[:, j], atol=1e-5, err_msg=f"column {j}")


def test_sixty_seconds_stay_on_the_true_state(mission: dense.FilterMission) -> None:
    """Started on the truth, after 60 s the velocity error is within 4σ of P per axis and the
    position error well under the initial 1 m σ (DVL 0.01 m/s, so a few mm/s is expected)."""
    out = dense.run_dense(mission)
    assert np.all(np.isfinite(out.x_log)) and np.allclose(out.P, out.P.T)
    dx = errorstate.difference(mission.x0, out.x)
    sd = np.sqrt(np.diag(out.P))
    assert np.all(np.abs(dx[errorstate.VEL]) < 4.0 * sd[errorstate.VEL])
    assert np.linalg.norm(dx[errorstate.VEL]) < 0.02
    assert np.linalg.norm(dx[errorstate.POS]) < 0.5
    assert np.all(np.abs(dx[errorstate.ATT]) < 4.0 * sd[errorstate.ATT])
