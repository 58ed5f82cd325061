"""A plain dense Numba error-state Kalman filter: the baseline adaptnav's ``vb`` is timed against.

``.venv/bin/python bench/dense_eskf.py`` (issue 15: the ``vb`` filter at >= 3x a plain dense
Numba ESKF measured in the same run). This is what a competent engineer writes in an afternoon
from a textbook, deliberately without adaptnav's compiled kernels, doing the same kind of work as
adaptnav's ``vb`` filter on the mission of ``bench/run.py`` (1 h at 100 Hz, DVL 3 Hz, depth 1 Hz,
inclinometer 1 Hz):

* strapdown per IMU sample (docs/mechanization.md, first order, no coning/sculling):
  ``q_nb ← Exp(-ω_in dt) ⊗ q_nb ⊗ Exp(dθ - b_g dt)``,
  ``v += C_nb (I + ½[dθ×]) (dv - b_a dt) + (g_n - (2ω_ie + ω_en) × v) dt``,
  latitude, longitude, height from the mean velocity;
* the 15-state NED error model of docs/filters.md ('Error-state model'; Groves (2013) §14.2.4,
  adaptnav's state order and sign, dx = truth - estimate), F rebuilt dense every sample,
  ``Φ = I + F dt + (F dt)²/2``, ``Qd = G Q Gᵀ dt``, ``P = Φ P Φᵀ + Qd`` by dense ``np.dot``;
* at each reading (at the nearest IMU sample) a dense H (DVL with lever arm and mounting
  rotation, depth with lever arm, inclinometer roll/pitch; docs/filters.md, 'Measurement
  models'), ``K = P Hᵀ S⁻¹`` by ``np.linalg.solve``, the Joseph form, closed-loop feedback and
  reset dx = 0;
* R by the paper's variational Bayes per sensor (docs/filters.md, 'VB-MAESKF: variational
  Bayes'): inverse-gamma α, β per component, forgetting ρ at the sensor's epoch, at most N
  fixed-point iterations of ``R = diag(β / α)``, ``β = β⁻ + ½ (y - H dx)² + ½ diag(H P⁺ Hᵀ)``.

Not a competitor: adaptnav's ``vb`` adds the guard, Q adaptation and exact epochs on top.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from adaptnav.core import earth
from adaptnav.models import errorstate
from adaptnav.sensors import DVL, Depth, Inclinometer
from run import FILTER_NOISE, FilterMission, _filter_mission, _run_filter

Array = np.ndarray

A, E2, OMEGA = earth.A, earth.E2, earth.OMEGA_IE
G_E, K_SOM, FLAT = earth.G_EQUATOR, earth.K_SOMIGLIANA, earth.FLATTENING
M_H = OMEGA**2 * A**2 * earth.B / earth.GM
SENSORS = ("dvl", "depth", "inclinometer")
"""Sensor codes of the kernel: 0, 1, 2."""
VB_ALPHA0, VB_RHO, VB_ITERATIONS, VB_TOL = 1.0, 0.99, 5, 1e-6
"""adaptnav's ``vb`` defaults (estimation/noise/vb.py)."""
LOG_EVERY = 100
"""The kernel logs the nominal state every this many IMU samples (1 Hz)."""


@numba.njit(cache=True)
def _skew(v: Array) -> Array:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@numba.njit(cache=True)
def _qmul(p: Array, q: Array) -> Array:
    return np.array([
        p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
        p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
        p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
        p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0],
    ])  # fmt: skip


@numba.njit(cache=True)
def _exp(a: Array) -> Array:
    angle = math.sqrt(a[0] ** 2 + a[1] ** 2 + a[2] ** 2)
    s = 0.5 - angle**2 / 48.0 if angle < 1e-6 else math.sin(0.5 * angle) / angle
    return np.array([math.cos(0.5 * angle), s * a[0], s * a[1], s * a[2]])


@numba.njit(cache=True)
def _dcm(q: Array) -> Array:
    w, x, y, z = q[0], q[1], q[2], q[3]
    return np.array([
        [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
    ])  # fmt: skip


@numba.njit(cache=True)
def _earth(lat: float, h: float, v: Array) -> tuple[float, float, float, Array, Array]:
    """R_M + h, R_N + h, normal gravity (earth.gravity), ω_ie_n, ω_en_n (Groves 2.105-2.139)."""
    s2 = math.sin(lat) ** 2
    rm = A * (1.0 - E2) / (1.0 - E2 * s2) ** 1.5 + h
    rn = A / math.sqrt(1.0 - E2 * s2) + h
    g0 = G_E * (1.0 + K_SOM * s2) / math.sqrt(1.0 - E2 * s2)
    g = g0 * (1.0 - 2.0 * h * (1.0 + FLAT + M_H - 2.0 * FLAT * s2) / A + 3.0 * h * h / A**2)
    wie = np.array([OMEGA * math.cos(lat), 0.0, -OMEGA * math.sin(lat)])
    wen = np.array([v[1] / rn, -v[0] / rm, -v[1] * math.tan(lat) / rn])
    return rm, rn, g, wie, wen


@numba.njit(cache=True)
def _strapdown(x: Array, dth: Array, dv: Array, dt: float) -> Array:
    """Advance the nominal state x (16) in place by one IMU interval; return f_n (m/s²)."""
    rm, rn, g, wie, wen = _earth(x[0], x[2], x[3:6])
    C = _dcm(x[6:10])
    dth_c = dth - x[13:16] * dt
    dv_n = C @ (dv - x[10:13] * dt + 0.5 * np.cross(dth_c, dv - x[10:13] * dt))
    q = _qmul(_exp(-(wie + wen) * dt), _qmul(x[6:10], _exp(dth_c)))
    x[6:10] = q / math.sqrt(q @ q)
    v_old = x[3:6].copy()
    x[3:6] += dv_n + (np.array([0.0, 0.0, g]) - np.cross(2.0 * wie + wen, v_old)) * dt
    v_mid = 0.5 * (v_old + x[3:6])
    x[0] += v_mid[0] / rm * dt
    x[1] += v_mid[1] / (rn * math.cos(x[0])) * dt
    x[2] -= v_mid[2] * dt
    return dv_n / dt


@numba.njit(cache=True)
def _system(x: Array, f_n: Array, tau_a: float, tau_g: float) -> tuple[Array, Array]:
    """F (15×15) and G (15×12) of the NED error model (errorstate.system_matrix's main terms:
    Coriolis/transport, vertical gravity gradient, earth-rate latitude term)."""
    lat, h, v = x[0], x[2], x[3:6]
    rm, rn, g, wie, wen = _earth(lat, h, v)
    C = _dcm(x[6:10])
    t = math.tan(lat)
    wen_v = np.array([[0.0, 1.0 / rn, 0.0], [-1.0 / rm, 0.0, 0.0], [0.0, -t / rn, 0.0]])
    F = np.zeros((15, 15))
    F[0:3, 3:6] = np.eye(3)
    F[3:6, 3:6] = -_skew(2.0 * wie + wen) + _skew(v) @ wen_v
    F[5, 2] = 2.0 * g / math.sqrt(rm * rn)
    F[3:6, 6:9] = -_skew(f_n)
    F[3:6, 9:12] = -C
    F[6, 0] = OMEGA * math.sin(lat) / rm
    F[8, 0] = OMEGA * math.cos(lat) / rm
    F[6:9, 3:6] = -wen_v
    F[6:9, 6:9] = -_skew(wie + wen)
    F[6:9, 12:15] = -C
    F[9:12, 9:12] = -np.eye(3) / tau_a
    F[12:15, 12:15] = -np.eye(3) / tau_g
    G = np.zeros((15, 12))
    G[3:6, 0:3] = -C
    G[6:9, 3:6] = -C
    G[9:15, 6:12] = np.eye(6)
    return F, G


@numba.njit(cache=True)
def _measure(
    code: int, x: Array, z: Array, w_b: Array, l_dvl: Array, C_sb: Array, l_depth: Array
) -> tuple[Array, Array]:
    """Residual y = z - h(x) and dense H of sensor ``code`` (SENSORS; docs/filters.md)."""
    C = _dcm(x[6:10])
    if code == 0:
        C_sn = C_sb @ C.T
        H = np.zeros((3, 15))
        H[:, 3:6] = C_sn
        H[:, 6:9] = C_sn @ _skew(x[3:6])
        H[:, 12:15] = C_sb @ _skew(l_dvl)
        return z[:3] - (C_sn @ x[3:6] + C_sb @ np.cross(w_b - x[13:16], l_dvl)), H
    if code == 1:
        a = C @ l_depth
        H = np.zeros((1, 15))
        H[0, 2], H[0, 6], H[0, 7] = 1.0, a[1], -a[0]
        return z[:1] - np.array([-x[2] + a[2]]), H
    roll, pitch = math.atan2(C[2, 1], C[2, 2]), -math.asin(C[2, 0])
    yaw = math.atan2(C[1, 0], C[0, 0])
    H = np.zeros((2, 15))
    H[0, 6], H[0, 7] = math.cos(yaw) / math.cos(pitch), math.sin(yaw) / math.cos(pitch)
    H[1, 6], H[1, 7] = -math.sin(yaw), math.cos(yaw)
    y = z[:2] - np.array([roll, pitch])
    return (y + math.pi) % (2.0 * math.pi) - math.pi, H


@numba.njit(cache=True)
def _vb_update(P: Array, y: Array, H: Array, alpha: Array, beta: Array) -> tuple[Array, Array]:
    """VB correction (module docstring): returns dx and P⁺; α, β (this sensor's) in place."""
    m = y.size
    a = VB_RHO * alpha[:m] + 0.5
    b_prior = VB_RHO * beta[:m]
    r = b_prior / a
    eye = np.eye(15)
    for _ in range(VB_ITERATIONS):
        R = np.diag(r)
        PHt = np.dot(P, H.T.copy())
        S = np.dot(H, PHt) + R
        K = np.linalg.solve(S, PHt.T.copy()).T.copy()
        dx = np.dot(K, y)
        IKH = eye - np.dot(K, H)
        P_new = np.dot(np.dot(IKH, P), IKH.T.copy()) + np.dot(np.dot(K, R), K.T.copy())
        e = y - np.dot(H, dx)
        b = b_prior + 0.5 * (e * e + np.diag(np.dot(np.dot(H, P_new), H.T.copy())))
        r_next = b / a
        done = np.all(np.abs(r_next - r) <= VB_TOL * r)
        r = r_next
        if done:
            break
    alpha[:m] = a
    beta[:m] = b
    return dx, 0.5 * (P_new + P_new.T)


@numba.njit(cache=True)
def _inject(x: Array, dx: Array) -> None:
    """Closed-loop feedback x ⊕ dx (errorstate.inject), in place."""
    rm, rn, _, _, _ = _earth(x[0], x[2], x[3:6])
    x[1] += dx[1] / (rn * math.cos(x[0]))
    x[0] += dx[0] / rm
    x[2] -= dx[2]
    x[3:6] += dx[3:6]
    q = _qmul(_exp(dx[6:9]), x[6:10])
    x[6:10] = q / math.sqrt(q @ q)
    x[10:16] += dx[9:15]


@numba.njit(cache=True)
def run_kernel(
    x0: Array, P0: Array, dtheta: Array, dvel: Array, dt: float, q_psd: Array, tau: Array,
    ev_step: Array, ev_code: Array, ev_z: Array, alpha: Array, beta: Array,
    l_dvl: Array, C_sb: Array, l_depth: Array,
) -> tuple[Array, Array, Array]:  # fmt: skip
    """The whole filter: per IMU sample strapdown and dense covariance propagation, then the
    readings stamped at that sample (ev_* sorted by step). Returns (x log, x, P)."""
    x, P = x0.copy(), P0.copy()
    n = dtheta.shape[0]
    log = np.empty((n // LOG_EVERY, 16))
    eye = np.eye(15)
    e = 0
    for k in range(n):
        xk = x.copy()
        f_n = _strapdown(x, dtheta[k], dvel[k], dt)
        F, G = _system(xk, f_n, tau[0], tau[1])
        Fdt = F * dt
        Phi = eye + Fdt + 0.5 * np.dot(Fdt, Fdt)
        Qd = np.dot(G * q_psd, G.T.copy()) * dt
        P = np.dot(np.dot(Phi, P), Phi.T.copy()) + Qd
        while e < ev_step.size and ev_step[e] == k:
            c = ev_code[e]
            y, H = _measure(c, x, ev_z[e], dtheta[k] / dt, l_dvl, C_sb, l_depth)
            dx, P = _vb_update(P, y, H, alpha[c], beta[c])
            _inject(x, dx)
            e += 1
        if (k + 1) % LOG_EVERY == 0:
            log[k // LOG_EVERY] = x
    return log, x, P


@dataclass(frozen=True)
class DenseRun:
    """The baseline's output: nominal state logged at 1 Hz, final state and covariance."""

    x_log: Array
    x: Array
    P: Array


def _schedule(m: FilterMission) -> tuple[Array, Array, Array]:
    """Every reading at its nearest IMU sample (sample k ends at (k + 1) dt), in time order:
    step, sensor code, reading (padded to 3)."""
    t, code, z = [], [], []
    for c, name in enumerate(SENSORS):
        ts, zs = m.readings[name]
        t.append(ts)
        code.append(np.full(ts.size, c))
        z.append(np.pad(zs, ((0, 0), (0, 3 - zs.shape[1]))))
    order = np.argsort(np.concatenate(t), kind="stable")
    n = m.dtheta.shape[0]
    step = np.clip(np.rint(np.concatenate(t) / m.dt).astype(np.int64) - 1, 0, n - 1)
    return step[order], np.concatenate(code)[order], np.concatenate(z)[order]


def _sensors(m: FilterMission) -> tuple[Array, Array, Array, Array]:
    """DVL lever arm and mounting, depth lever arm, and each sensor's nominal variances (3×3,
    padded), from the mission's sensor models."""
    models = {s.name: s for s, _ in m.sensors}
    dvl, depth, incl = (models[name] for name in SENSORS)
    assert isinstance(dvl, DVL) and isinstance(depth, Depth) and isinstance(incl, Inclinometer)
    assert np.allclose(incl.C_sb, np.eye(3)), "the baseline's inclinometer is aligned with the IMU"
    var = np.ones((3, 3))
    for c, sensor in enumerate((dvl, depth, incl)):
        sigma = np.atleast_1d(np.asarray(sensor.sigma, dtype=float))
        var[c, : sigma.size] = sigma**2
    return dvl.l_b, dvl.C_sb, depth.l_b, var


def run_dense(m: FilterMission) -> DenseRun:
    """Run the baseline over the mission (VB prior α = α0, β = α0 σ²_nominal)."""
    step, code, z = _schedule(m)
    l_dvl, C_sb, l_depth, var = _sensors(m)
    q = errorstate.noise_psd(FILTER_NOISE)
    tau = np.array([FILTER_NOISE.accel_bias_tau, FILTER_NOISE.gyro_bias_tau])
    alpha = np.full((3, 3), VB_ALPHA0)
    log, x, P = run_kernel(
        m.x0, m.P0, m.dtheta, m.dvel, m.dt, q, tau, step, code, z, alpha, VB_ALPHA0 * var,
        l_dvl, C_sb, l_depth,
    )  # fmt: skip
    return DenseRun(log, x, P)


def errors(m: FilterMission, x: Array) -> tuple[float, float]:
    """Horizontal+vertical position error (m) and velocity error (m/s) of x against the true,
    stationary state m.x0."""
    dx = errorstate.difference(m.x0, x)
    return float(np.linalg.norm(dx[errorstate.POS])), float(np.linalg.norm(dx[errorstate.VEL]))


def bench_dense(n: int = 360_000, repeats: int = 3) -> list[str]:
    """Time the baseline and adaptnav's ``vb`` round-robin on the mission of ``bench/run.py``
    (best of ``repeats`` each after a warm-up, wall clock), with both final errors."""
    mission = _filter_mission(n)
    warm = _filter_mission(500)
    run_dense(warm)
    _run_filter("vb", warm)
    best = {"dense": math.inf, "vb": math.inf}
    final: dict[str, Array] = {}
    for _ in range(repeats):
        for name in best:
            t0 = time.perf_counter()
            final[name] = (
                run_dense(mission).x if name == "dense" else _run_filter("vb", mission).x_final
            )
            best[name] = min(best[name], time.perf_counter() - t0)
    dense, vb = n / best["dense"], n / best["vb"]
    (r_d, v_d), (r_v, v_v) = errors(mission, final["dense"]), errors(mission, final["vb"])
    hours = n * mission.dt / 3600.0
    return [
        f"filter baseline: plain dense Numba ESKF (VB DVL + depth + inclinometer) "
        f"{dense / 1e6:.2f} M IMU samples/s; adaptnav vb {vb / 1e6:.2f} M/s = "
        f"{vb / dense:.1f}x the baseline",
        f"filter baseline: final errors after {hours:g} h, baseline {r_d:.2f} m {v_d:.4f} m/s; "
        f"adaptnav vb {r_v:.2f} m {v_v:.4f} m/s",
    ]


if __name__ == "__main__":
    for line in bench_dense():
        print(line, flush=True)
