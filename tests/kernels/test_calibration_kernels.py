"""Calibration states of the aiding sensors (sensors/calibration.py, docs/calibration.md): H on
the declared states against finite differences, and the compiled linearisations against the
readable models with them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from adaptnav.compiled import update as uk
from adaptnav.core import attitude
from adaptnav.models import errorstate
from adaptnav.sensors.calibration import misalignment, misalignment_derivatives
from adaptnav.sensors.depth import Depth
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.inclinometer import Inclinometer, PendulumInclinometer

# Declared error states 15..20: DVL scale, DVL misalignment (3), two biases (the depth uses
# the first, the inclinometers both).
SCALE, MIS, BIAS = 15, 16, 19
N = 21


def _state(rng: np.random.Generator) -> np.ndarray:
    x = np.zeros(N + 1)
    x[0], x[1], x[2] = math.radians(rng.uniform(-70, 70)), rng.uniform(-3, 3), rng.normal(0, 50)
    x[3:6] = rng.uniform(-3, 3, 3)
    x[6:10] = attitude.rotvec_to_quat(rng.uniform(-1.2, 1.2, 3))
    x[10:13], x[13:16] = rng.normal(0, 0.02, 3), rng.normal(0, 1e-3, 3)
    x[SCALE + 1] = rng.normal(0.0, 0.02)
    x[MIS + 1 : MIS + 4] = rng.normal(0.0, 0.05, 3)
    x[BIAS + 1 : BIAS + 3] = rng.normal(0.0, 0.02, 2)
    return x


def _models(rng: np.random.Generator) -> list[Any]:
    lever, C = rng.uniform(-2, 2, 3), attitude.euler_to_dcm(*rng.uniform(-0.5, 0.5, 3))
    return [
        DVL(0.01, lever, C, cal_scale=SCALE, cal_misalignment=MIS),
        DVL(0.01, lever, C, cal_misalignment=MIS),
        DVL(0.01, lever, C, cal_scale=SCALE),
        DVL(0.01, lever, C),  # no calibration, on a state that has some: zero columns
        Depth(0.05, lever, cal_bias=BIAS),
        Inclinometer(0.002, C, cal_bias=BIAS),
        PendulumInclinometer(0.002, C, cal_bias=BIAS),
    ]


def _h(model: Any, x: np.ndarray, w: np.ndarray, f: np.ndarray) -> np.ndarray:
    if isinstance(model, DVL):
        return np.asarray(model.predict(x, w))
    if isinstance(model, PendulumInclinometer):
        return np.asarray(model.predict(x, f))
    return np.atleast_1d(np.asarray(model.predict(x)))


def _measurement(model: Any, x: np.ndarray, z: np.ndarray, w: np.ndarray, f: np.ndarray) -> Any:
    if isinstance(model, PendulumInclinometer):
        return model.evaluate(x, z, w, f)
    return model.evaluate(x, z, w)


def test_misalignment_derivatives_against_finite_differences() -> None:
    d = np.array([0.1, -0.2, 0.3])
    eps = 1e-6
    for i, dM in enumerate(misalignment_derivatives(d)):
        step = np.zeros(3)
        step[i] = eps
        fd = (misalignment(d + step) - misalignment(d - step)) / (2 * eps)
        np.testing.assert_allclose(dM, fd, atol=1e-9)
    np.testing.assert_allclose(misalignment(1e-4 * np.ones(3)),
                               np.eye(3) - attitude.skew(1e-4 * np.ones(3)), atol=1e-8)  # fmt: skip


def test_calibrated_h_against_finite_differences() -> None:
    rng = np.random.default_rng(8)
    w, f = rng.uniform(-0.3, 0.3, 3), np.array([0.3, -0.5, -9.7])
    for _ in range(5):
        x = _state(rng)
        for model in _models(rng):
            h0 = _h(model, x, w, f)
            m = _measurement(model, x, h0, w, f)
            assert m.H.shape == (h0.size, N)
            fd = np.zeros_like(m.H)
            for k in range(N):
                dx = np.zeros(N)
                dx[k] = 1e-6
                plus = _h(model, errorstate.inject(x, dx), w, f)
                minus = _h(model, errorstate.inject(x, -dx), w, f)
                fd[:, k] = (plus - minus) / 2e-6
            np.testing.assert_allclose(m.H, fd, atol=2e-6 * max(1.0, np.abs(fd).max()))
            if isinstance(model, DVL) and model.cal_scale < 0 and model.cal_misalignment < 0:
                assert np.all(m.H[:, 15:] == 0.0)


@pytest.mark.parametrize("row", [0, 2])
def test_compiled_linearisations_with_calibration_equal_evaluate(row: int) -> None:
    rng = np.random.default_rng(9)
    w, f = rng.uniform(-0.3, 0.3, 3), np.array([0.3, -0.5, -9.7])
    for _ in range(10):
        x = _state(rng)
        for model in _models(rng):
            z = _h(model, x, w, f) + rng.normal(0.0, 0.01, model.dim)
            m = _measurement(model, x, z, w, f)
            spec = uk.compiled_linearisation(model)
            assert spec is not None
            y, H = np.full(row + 4, 7.0), np.full((row + 4, N), 7.0)
            zz = np.zeros(3)
            zz[: z.size] = z
            uk.linearise(spec[0], spec[1], x, zz, w, f, y, H, row)
            np.testing.assert_allclose(y[row : row + model.dim], m.y, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(H[row : row + model.dim], m.H, rtol=1e-9, atol=1e-12)
            assert np.all(H[:row] == 7.0)
