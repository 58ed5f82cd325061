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
from adaptnav.estimation import kalman
from adaptnav.models import errorstate
from adaptnav.sensors.calibration import misalignment, misalignment_derivatives
from adaptnav.sensors.depth import Depth
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.gnss import GNSS
from adaptnav.sensors.heading import Heading
from adaptnav.sensors.inclinometer import Inclinometer, PendulumInclinometer

# Declared error states 15..22: DVL scale, DVL misalignment (3), three biases (the depth uses
# the first, the inclinometers and the GNSS two, the DVL all three), the DVL's latency.
SCALE, MIS, BIAS, LAT = 15, 16, 19, 22
N = 23


def _state(rng: np.random.Generator) -> np.ndarray:
    x = np.zeros(N + 1)
    x[0], x[1], x[2] = math.radians(rng.uniform(-70, 70)), rng.uniform(-3, 3), rng.normal(0, 50)
    x[3:6] = rng.uniform(-3, 3, 3)
    x[6:10] = attitude.rotvec_to_quat(rng.uniform(-1.2, 1.2, 3))
    x[10:13], x[13:16] = rng.normal(0, 0.02, 3), rng.normal(0, 1e-3, 3)
    x[SCALE + 1] = rng.normal(0.0, 0.02)
    x[MIS + 1 : MIS + 4] = rng.normal(0.0, 0.05, 3)
    x[BIAS + 1 : BIAS + 4] = rng.normal(0.0, 0.02, 3)  # rad, m for the GNSS, m/s for the DVL
    x[LAT + 1] = rng.normal(0.0, 0.2)  # s
    return x


def _models(rng: np.random.Generator) -> list[Any]:
    lever, C = rng.uniform(-2, 2, 3), attitude.euler_to_dcm(*rng.uniform(-0.5, 0.5, 3))
    return [
        DVL(0.01, lever, C, cal_scale=SCALE, cal_misalignment=MIS),
        DVL(0.01, lever, C, cal_misalignment=MIS),
        DVL(0.01, lever, C, cal_scale=SCALE),
        DVL(0.01, lever, C, cal_scale=SCALE, cal_misalignment=MIS, cal_bias=BIAS),
        DVL(0.01, lever, C, cal_bias=BIAS),
        DVL(0.01, lever, C),  # no calibration, on a state that has some: zero columns
        DVL(0.01, lever, C, cal_latency=LAT),
        DVL(0.01, lever, C, "dvl", SCALE, MIS, BIAS, LAT),
        Depth(0.05, lever, cal_bias=BIAS),
        Inclinometer(0.002, C, cal_bias=BIAS),
        PendulumInclinometer(0.002, C, cal_bias=BIAS),
        GNSS(0.5, lever, True, cal_bias=BIAS),
        GNSS(0.5, lever, False, cal_bias=BIAS),
        GNSS(0.5, lever, True, cal_latency=LAT),
        GNSS(0.5, lever, False, "gnss", BIAS, LAT),
        Heading(0.01, C, cal_latency=LAT),
        Heading(0.01, C),  # no latency, on a state that has one: zero columns
    ]


def _h(model: Any, x: np.ndarray, w: np.ndarray, f: np.ndarray) -> np.ndarray:
    if isinstance(model, DVL):
        return np.asarray(model.predict(x, w, f))
    if isinstance(model, PendulumInclinometer):
        return np.asarray(model.predict(x, f))
    if isinstance(model, GNSS | Heading):
        return np.asarray(model.predict(x, w))
    return np.atleast_1d(np.asarray(model.predict(x)))


def _measurement(model: Any, x: np.ndarray, z: np.ndarray, w: np.ndarray, f: np.ndarray) -> Any:
    if isinstance(model, PendulumInclinometer | DVL):
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
                eps = 1e-6
                if isinstance(model, GNSS):  # 1 cm, 1 mrad: 1 µm is near a latitude's spacing
                    eps = 1e-2 if k < 3 or k >= BIAS else 1e-3
                dx[k] = eps
                if isinstance(model, GNSS):  # its residual is in metres: H = -dy/ddx at z = h(x)
                    plus = -model.evaluate(errorstate.inject(x, dx), h0, w).y
                    minus = -model.evaluate(errorstate.inject(x, -dx), h0, w).y
                else:
                    plus = _h(model, errorstate.inject(x, dx), w, f)
                    minus = _h(model, errorstate.inject(x, -dx), w, f)
                fd[:, k] = (plus - minus) / (2 * eps)
            np.testing.assert_allclose(m.H, fd, atol=2e-6 * max(1.0, np.abs(fd).max()))
            if isinstance(model, DVL) and max(model.cal_scale, model.cal_misalignment) < 0:
                assert np.all(m.H[:, 15:BIAS] == 0.0)  # a bias alone: only its own columns
                np.testing.assert_array_equal(
                    m.H[:, BIAS:LAT], np.eye(3) if model.cal_bias >= 0 else np.zeros((3, 3))
                )
            if isinstance(model, DVL):  # the latency's column: -ḣ, nonzero when it is a state
                assert np.any(m.H[:, LAT] != 0.0) == (model.cal_latency >= 0)


@pytest.mark.parametrize("row", [0, 2])
def test_compiled_linearisations_with_calibration_equal_evaluate(row: int) -> None:
    rng = np.random.default_rng(9)
    w, f = rng.uniform(-0.3, 0.3, 3), np.array([0.3, -0.5, -9.7])
    for _ in range(10):
        x = _state(rng)
        for model in _models(rng):
            noise = 1e-7 if isinstance(model, GNSS) else 0.01  # rad: 0.6 m of a GNSS fix
            z = _h(model, x, w, f) + rng.normal(0.0, noise, model.dim)
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


def _step(rng: np.random.Generator) -> np.ndarray:
    """An update's step dx of a realistic size: velocity, attitude, scale, misalignment."""
    dx = np.zeros(N)
    dx[3:6], dx[6:9] = rng.normal(0.0, 0.05, 3), rng.normal(0.0, 0.005, 3)
    dx[SCALE], dx[MIS : MIS + 3] = rng.normal(0.0, 0.005), rng.normal(0.0, 0.01, 3)
    return dx


def test_the_midpoint_jacobian_is_a_secant_of_the_calibrated_dvl() -> None:
    """What the midpoint update rests on (docs/calibration.md, 'The midpoint update'): along a
    step dx, ``h(x ⊕ dx) - h(x)`` is ``H(x ⊕ ½ dx) dx`` to third order in dx (the midpoint
    rule on a path that ⊕ makes straight: additive states and a rotation about a fixed axis),
    where the tangent ``H(x) dx`` is off at second order: the product of the scale and the
    velocity, the rotations by the misalignment and the attitude."""
    rng = np.random.default_rng(12)
    w = rng.uniform(-0.3, 0.3, 3)
    for _ in range(20):
        lever, C = rng.uniform(-2, 2, 3), attitude.euler_to_dcm(*rng.uniform(-0.5, 0.5, 3))
        model = DVL(0.01, lever, C, cal_scale=SCALE, cal_misalignment=MIS)
        x, dx = _state(rng), _step(rng)
        change = model.predict(errorstate.inject(x, dx), w) - model.predict(x, w)
        tangent = change - model.jacobian(x, w) @ dx
        secant = change - model.jacobian(errorstate.inject(x, 0.5 * dx), w) @ dx
        assert np.linalg.norm(secant) < 0.03 * np.linalg.norm(tangent)


def _P(rng: np.random.Generator) -> np.ndarray:
    sig = np.r_[[3.0] * 3, [0.1] * 3, [0.01] * 3, [0.01] * 3, [1e-4] * 3, 0.01, [0.03] * 3, 0.02,
                0.02, 0.02, 0.05]  # fmt: skip
    L = np.tril(rng.normal(0.0, 0.3, (N, N)), -1) + np.eye(N)
    P = (sig[:, None] * (L @ L.T)) * sig[None, :]
    return 0.5 * (P + P.T)


@pytest.mark.parametrize("kind", [uk.KIND_FIXED, uk.KIND_VB])
@pytest.mark.parametrize("iterations", [0, 1, 3])
def test_compiled_midpoint_equals_midpoint_jacobian(kind: int, iterations: int) -> None:
    """compiled.update._midpoint (the epoch's re-linearisation of a calibrated DVL and a depth
    meter read at the same epoch) == kalman.midpoint_jacobian with their ``evaluate``, the R
    each sensor's strategy has now (fixed: nominal; VB: β/α), and the residuals left at x; a
    DVL with a latency state as well (its H needs the specific force)."""
    rng = np.random.default_rng(13)
    w, f = rng.uniform(-0.3, 0.3, 3), np.array([0.4, -0.2, -9.9])
    for trial in range(6):
        lever, C = rng.uniform(-2, 2, 3), attitude.euler_to_dcm(*rng.uniform(-0.5, 0.5, 3))
        latency = LAT if trial % 2 else -1
        models = [DVL(0.02, lever, C, "dvl", SCALE, MIS, cal_latency=latency),
                  Depth(0.05, lever, cal_bias=BIAS)]  # fmt: skip
        x, P = _state(rng), _P(rng)
        zs = [_h(m, x, w, f) + rng.normal(0.0, 0.05, m.dim) for m in models]
        n = len(models)
        ws = uk.workspace(n, N)
        H, y, Rb, blk = ws[uk.WS_H], ws[uk.WS_Y], ws[uk.WS_RB], ws[uk.WS_BLK]
        s_int = np.zeros((n, uk.N_SINT), dtype=np.int64)
        s_flt, s_state = np.zeros((n, uk.N_SFLT)), np.zeros((n, uk.N_SSTATE))
        st_z, rates = np.zeros((n, 3)), np.zeros((uk.N_RATES, 3))
        rates[uk.R_W_CUR], rates[uk.R_F_CUR] = w, f
        Rs = []
        for i, (m, z) in enumerate(zip(models, zs, strict=True)):
            spec = uk.compiled_linearisation(m)
            assert spec is not None
            s_int[i, uk.S_CODE], s_int[i, uk.S_DIM] = spec[0], m.dim
            s_int[i, uk.S_MIDPOINT] = iterations if m.midpoint_update else 0
            s_flt[i, : uk.N_PAR] = spec[1]
            alpha, beta = rng.uniform(2.0, 20.0, m.dim), rng.uniform(1e-4, 1e-2, m.dim)
            s_state[i, uk.X_ALPHA : uk.X_ALPHA + m.dim] = alpha
            s_state[i, uk.X_BETA : uk.X_BETA + m.dim] = beta
            Rs.append(m.R if kind == uk.KIND_FIXED else np.diag(beta / alpha))
            st_z[i, : m.dim] = z
            blk[0, i], blk[1, i], blk[2, i + 1] = i, i, blk[2, i] + m.dim
            Rb[i, : m.dim, : m.dim] = m.R
            uk.linearise(spec[0], spec[1], x, st_z[i], w, f, y, H, blk[2, i])
        D = int(blk[2, n])
        pairs = list(zip(models, zs, strict=True))
        y0 = np.concatenate([_measurement(m, x, z, w, f).y for m, z in pairs])

        def jacobian(xx: np.ndarray, pairs: list[Any] = pairs) -> np.ndarray:
            return np.vstack([_measurement(m, xx, z, w, f).H for m, z in pairs])

        R = np.zeros((D, D))
        R[:3, :3], R[3:, 3:] = Rs
        expected = kalman.midpoint_jacobian(x, P, y0, R, jacobian, iterations)
        x_before, P_before = x.copy(), P.copy()
        uk._midpoint(x, P, rates, D, n, blk, st_z, s_int, s_flt, s_state, kind, ws)
        np.testing.assert_allclose(H[:D], expected, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(y[:D], y0, rtol=1e-9, atol=1e-12)
        assert np.array_equal(x, x_before) and np.array_equal(P, P_before)
        if iterations > 0:  # the step moved H: not a comparison of two unchanged copies
            assert not np.allclose(expected, jacobian(x), rtol=1e-6, atol=1e-9)
