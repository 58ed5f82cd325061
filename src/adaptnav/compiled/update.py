"""Compiled measurement epochs: linearisation, stacked update, gate, feedback.

The equations: docs/filters.md, from 'Measurement models' to 'VB-MAESKF: variational Bayes'.

Numba twins of the readable epoch pieces, in the style of :mod:`adaptnav.compiled.propagation`
(small ``@jit`` helpers, ``cache=True``, work in place on preallocated arrays, no shape checks):

=====================================  =====================================================
compiled                               readable twin
=====================================  =====================================================
:func:`linearise` (per sensor code)    ``evaluate`` of :mod:`adaptnav.sensors` (y = z - h(x),
                                       H): DVL, depth, inclinometer (attitude
                                       and pendulum), heading, GNSS, ZUPT, NHC
:func:`correct`                        :func:`adaptnav.estimation.kalman.correct` (x⁻ = 0,
                                       Joseph form)
:func:`stacked_update`                 ``update`` of :mod:`adaptnav.estimation.noise` (FixedNoise,
                                       CovarianceMatching IAE/RAE, VariationalBayes
                                       paper eqs. (23)-(28))
:func:`gate_statistic`                 :func:`adaptnav.estimation.gate.apply_gate`
:func:`inject`, :func:`reset`          :func:`adaptnav.models.errorstate.inject`, ``reset_jacobian``
:func:`epoch`                          one epoch of the engine (the strategies' ``predict``,
                                       ``current_R``, the gate, the update, the feedback, the
                                       ledger rows), as ``tests/helpers/engine_reference.py`` has it
:func:`step`                           one (sub)step of the propagation kernels' loop
=====================================  =====================================================

``tests/kernels/test_update_kernels.py`` holds each equal to its twin to 1e-9, and the engine
equal to the previous, readable one (``tests/helpers/engine_reference.py``). What happens when
(time ordering, epoch policy, propagation between epochs) stays in :mod:`adaptnav.engine.batch`.

The linear algebra is written out for the tiny stacked systems (D ≤ 3 per sensor): Cholesky of
S, K = P Hᵀ S⁻¹ by its triangular solves, the products with H summed over H's nonzero columns
only (a DVL touches 9 of the 15), Kᵀ and H P stored by rows so that the long loops run over the
15 states (and vectorize). The VB fixed point iterates in measurement space: with
W = H P⁻ Hᵀ and G = H K = W S⁻¹, ``y - H x⁺ = (I - G) y`` and
``H P⁺ Hᵀ = (I - G) W (I - G)ᵀ + G R Gᵀ`` (the Joseph form seen through H), so each
iteration costs O(D³); the 15-state K, x⁺ and P⁺ are formed once, with the final R̂.

Per-sensor settings and adaptation states live in packed tables whose columns are named by the
constants below (``S_*``, ``F_*``, ``X_*``); the engine fills them. Scratch arrays come from
:func:`workspace`, allocated once per navigator. A sensor class exposes its compiled
linearisation through :func:`compiled_linearisation` (by exact class, :data:`LINEARISED` with
each class's ``LIN_CODE``, or an optional ``compiled_linearisation()`` method of the model); the
readable ``evaluate`` stays the reference, and sensors without one are linearised by it.

Numba caches compiled code per file; the helpers imported from :mod:`adaptnav.compiled.propagation`
are compiled into these functions, so clear ``__pycache__`` if compiled/propagation.py changes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from adaptnav.compiled.propagation import (
    N_NOISE_ACC,
    LatRef,
    Mat3,
    State,
    Vec3,
    _add_half_noise,
    _cross,
    _fill_At,
    _gravity,
    _low_pass,
    _matvec,
    _quat_mult,
    _quat_to_dcm,
    _rotvec_to_quat,
    _strapdown,
    jit,
    jit_inline,
)
from adaptnav.core.earth import E2, A
from adaptnav.estimation.health import (
    EIG_FLOOR,
    MIN_LOCKOUT_FACTOR,
    STEP_PATIENCE,
    STEP_PERIODS,
    STEP_RATIO,
)
from adaptnav.estimation.noise.base import NoiseKind
from adaptnav.estimation.noise.process import EVENT_STEP, GAP_PERIODS
from adaptnav.models.errorstate import RESET_INVARIANT, RESET_OFF
from adaptnav.sensors import kind as sensor_kind
from adaptnav.sensors import registry
from adaptnav.sensors.depth import Depth
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.gnss import GNSS
from adaptnav.sensors.heading import Heading
from adaptnav.sensors.inclinometer import Inclinometer, PendulumInclinometer
from adaptnav.sensors.nhc import NonHolonomic
from adaptnav.sensors.zupt import ZeroVelocity

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

N_STATES = 15
MAX_DIM = 3
"""Largest sensor dimension the compiled epoch handles."""

# --- sensor codes and packed linearisation parameters ------------------------------------------

LIN_PYTHON = -1
"""No compiled linearisation: the engine calls the model's ``evaluate``."""
# Each model class declares its code (sensors/kind.py); Numba sees plain module-level ints.
LIN_DVL, LIN_DEPTH, LIN_NHC = DVL.LIN_CODE, Depth.LIN_CODE, NonHolonomic.LIN_CODE
LIN_INCLINOMETER, LIN_PENDULUM = Inclinometer.LIN_CODE, PendulumInclinometer.LIN_CODE
LIN_HEADING, LIN_GNSS, LIN_ZUPT = Heading.LIN_CODE, GNSS.LIN_CODE, ZeroVelocity.LIN_CODE
N_PAR = sensor_kind.N_PAR
"""Packed parameters (sensors/kind.py): ``[l_b (3) | C_sb (9, row-major) | flag | calibration
state indices (4)]``."""
PAR_LB, PAR_CSB, PAR_FLAG = sensor_kind.PAR_LB, sensor_kind.PAR_CSB, sensor_kind.PAR_FLAG
PAR_CAL = sensor_kind.PAR_CAL

# --- per-sensor tables (rows: sensors) ----------------------------------------------------------

# s_int: int64 settings and counters
S_CODE, S_DIM, S_GATE, S_ITER, S_WINDOW, S_COUNT, S_VERSION, S_GATE_REF = 0, 1, 2, 3, 4, 5, 6, 7
S_GUARD = 8  # 1: the nominal-R χ² guard is on (gate.Guard)
S_MIDPOINT = 9  # iterations of the midpoint linearisation (0: linearised at the prior; _midpoint)
N_SINT = 10
# s_flt: float64 settings; columns 0..N_PAR-1 are the linearisation parameters
_F = N_PAR  # the settings after the linearisation parameters
F_RNOM, F_GATE_Q, F_PERIOD = _F, _F + 9, _F + 10  # nominal R (3×3 row-major), gate q, period
F_RHO, F_TOL, F_IRREGULAR, F_FLOOR, F_RAE, F_DOF = range(_F + 11, _F + 17)  # strategy settings
F_RMIN, F_RMAX = _F + 17, _F + 18  # bounds on the adapted R̂ as factors of the nominal variance
F_GUARD_Q, F_LOCKOUT_S = _F + 19, _F + 20  # the guard's χ² threshold; lockout time (0: none)
F_DIV_NIS, F_DIV_WINDOW, F_INFLATE_MAX = range(_F + 21, _F + 24)  # windowed NIS (health.py)
F_GUARD_K, F_LOCKOUT_MAX = _F + 24, _F + 25  # the guard's headroom κ on the nominal R; cap
F_GAP = _F + 26  # matching: restart the window after a gap of this many periods (0: never)
F_QA_GAIN, F_QA_TARGET, F_QA_MAX, F_QA_WINDOW = range(_F + 27, _F + 31)  # Q adaptation
F_WEIGHTS_ONLY = _F + 31  # VB with dof: 1.0, β learns the whole residual (λ weights only)
N_SFLT = _F + 32
# s_state: float64 adaptation state: last epoch, VB α and β, matching R̂ (3×3 row-major)
X_LAST, X_ALPHA, X_BETA, X_MR = 0, 1, 4, 7
X_NIS, X_NIS_N, X_REJ_SINCE = 16, 17, 18  # mean NIS/d over the window, its count; lockout start
X_WC0, X_WC1, X_WPREV, X_WT, X_WN = 19, 20, 21, 24, 25  # whiteness: c0, c1, last ν̃, its t, pairs
X_PASSED, X_STEP, X_PASSED_STAT = 26, 27, 28  # the guard: last passed reading's time, its
# statistic; 1: the streak of rejections began with a step (health.is_step)
N_SSTATE = 29
# rings (sensors, 2, W_max, 3): [.., 0] squared innovations/residuals, [.., 1] diag(H P⁺ Hᵀ)

GATE_NONE, GATE_COMPONENT, GATE_CHI2 = 0, 1, 2
GATE_REF_ADAPTED, GATE_REF_NOMINAL = 0, 1
KIND_FIXED, KIND_MATCHING, KIND_VB = (int(k) for k in NoiseKind)  # Numba sees plain ints

# fallback rows (one per group member) for sensors linearised in Python: valid, y, H, R
FB_VALID, FB_Y, FB_H, FB_R = 0, 1, 4, 49
N_FB = 58

# --- ledger rows --------------------------------------------------------------------------------

L_STORE, L_CODE, L_ITER = 0, 1, 2
N_LINT = 3
L_T_EPOCH, L_STAT, L_THRESHOLD, L_NU, L_R, L_FACTOR = 0, 1, 2, 3, 6, 9
N_LFLT = 10
LEDGER_USED = 0
LEDGER_REJECTED_COMPONENT = GATE_COMPONENT
LEDGER_REJECTED_CHI2 = GATE_CHI2
LEDGER_DUPLICATE, LEDGER_INVALID, LEDGER_LATE, LEDGER_AFTER_IMU = 3, 4, 5, 6
LEDGER_REJECTED_GUARD, LEDGER_REJECTED_SINGULAR = 7, 8
EVENT_NIS, EVENT_LOCKOUT, EVENT_SINGULAR, EVENT_Q = 20, 21, 22, 23
"""Codes >= EVENT_NIS are filter events (estimation/health.py), not readings' fates: their row
holds the
reading that triggered them, the test statistic, its threshold and the factor P was inflated by."""

# --- the engine's propagation cursor (rates: previous and current interval's raw mean rates) ---

C_T, C_T_START, C_DT, C_OFFSET = 0, 1, 2, 3
C_BLOCK = 4
"""``cur[C_BLOCK]``: the time the open covariance block spans (docs/filters.md, 'Covariance
blocks'; 0: none open, P is current)."""
N_CUR = 5
R_W_PREV, R_F_PREV, R_W_CUR, R_F_CUR, R_F_LP = 0, 1, 2, 3, 4
R_Q = 5  # [β, β at the last EVENT_Q, -]: the scale of the white-noise PSDs in Q (noise/process)
N_RATES = 6
"""Rows of ``rates``: the raw mean rates, and the low-passed specific force of F."""


# --- scalar helpers -----------------------------------------------------------------------------


@jit
def _wrap(a: float) -> float:
    """Wrap to (-π, π], in-range angles unchanged (twin of attitude.wrap_angle)."""
    if -math.pi < a <= math.pi:
        return a
    # Python's float % and np.remainder agree: fmod, moved to the sign of the divisor
    m = (-a + math.pi) % (2.0 * math.pi)
    return -m + math.pi


@jit
def _radii(lat: float) -> tuple[float, float, float, float]:
    """R_M, R_N and their latitude derivatives (twins of earth.*_radius, *_radius_dlat)."""
    s, c = math.sin(lat), math.cos(lat)
    w = 1.0 - E2 * (s * s)
    return (
        A * (1.0 - E2) / w**1.5,
        A / math.sqrt(w),
        3.0 * A * (1.0 - E2) * E2 * s * c / w**2.5,
        A * E2 * s * c / w**1.5,
    )


@jit
def _dcm(x: Array) -> Mat3:
    return _quat_to_dcm((x[6], x[7], x[8], x[9]))


@jit
def _par_vec(par: Array, k: int) -> Vec3:
    return (par[k], par[k + 1], par[k + 2])


@jit
def _par_mat(par: Array, k: int) -> Mat3:
    return (
        par[k], par[k + 1], par[k + 2], par[k + 3], par[k + 4], par[k + 5],
        par[k + 6], par[k + 7], par[k + 8],
    )  # fmt: skip


@jit
def _mul_bt(C: Mat3, B: Mat3) -> Mat3:
    """``C Bᵀ`` (3×3 row-major): entry (r, c) is row r of C times row c of B. (Written out:
    an inlined row-times-row helper cost nine inlinings, a second of a cold start.)"""
    return (
        C[0] * B[0] + C[1] * B[1] + C[2] * B[2],
        C[0] * B[3] + C[1] * B[4] + C[2] * B[5],
        C[0] * B[6] + C[1] * B[7] + C[2] * B[8],
        C[3] * B[0] + C[4] * B[1] + C[5] * B[2],
        C[3] * B[3] + C[4] * B[4] + C[5] * B[5],
        C[3] * B[6] + C[4] * B[7] + C[5] * B[8],
        C[6] * B[0] + C[7] * B[1] + C[8] * B[2],
        C[6] * B[3] + C[7] * B[4] + C[8] * B[5],
        C[6] * B[6] + C[7] * B[7] + C[8] * B[8],
    )


@jit
def _euler(M: Mat3) -> tuple[float, float, float]:
    """ZYX [roll, pitch, yaw] of a DCM (twin of attitude.dcm_to_euler)."""
    return (
        math.atan2(M[7], M[8]),
        -math.asin(min(max(M[6], -1.0), 1.0)),
        math.atan2(M[3], M[0]),
    )


# --- linearisations: y = z - h(x), H = ∂h(x ⊕ dx)/∂dx (twins of the sensors' evaluate) ---------


@jit_inline
def _lin_dvl(
    par: Array, x: Array, z: Array, w: Array, f: Array, y: Array, H: Array, r: int, a0: int
) -> None:
    """DVL (sensors.dvl): ``h = C_sb (C_nbᵀ v_n + (ω̃ - b_g) × l_b)``; H on dv, phi, db_g.

    Components ``a0..2`` of the sensor-frame velocity: all three for the DVL (a0 = 0), the
    lateral and vertical ones for the non-holonomic constraint (a0 = 1, sensors.nhc).
    Row a of ``C_sn [v×]`` is ``(C_sn)_a × v``, of ``C_sb [l×]`` is ``(C_sb)_a × l``.
    """
    C = _dcm(x)
    v = (x[3], x[4], x[5])
    lever = _par_vec(par, PAR_LB)
    Cs = _par_mat(par, PAR_CSB)
    v_b = (
        C[0] * v[0] + C[3] * v[1] + C[6] * v[2],
        C[1] * v[0] + C[4] * v[1] + C[7] * v[2],
        C[2] * v[0] + C[5] * v[1] + C[8] * v[2],
    )
    rate = (w[0] - x[13], w[1] - x[14], w[2] - x[15])
    lw = _cross(rate, lever)
    pred = _matvec(Cs, (v_b[0] + lw[0], v_b[1] + lw[1], v_b[2] + lw[2]))
    Csn = _mul_bt(Cs, C)
    for a in range(a0, 3):
        k = r + a - a0
        y[k] = z[a - a0] - pred[a]
        row = (Csn[3 * a], Csn[3 * a + 1], Csn[3 * a + 2])
        h_phi = _cross(row, v)
        h_bg = _cross((Cs[3 * a], Cs[3 * a + 1], Cs[3 * a + 2]), lever)
        for c in range(3):
            H[k, 3 + c] = row[c]
            H[k, 6 + c] = h_phi[c]
            H[k, 12 + c] = h_bg[c]
    if a0 == 0 and (
        par[PAR_CAL] >= 0.0
        or par[PAR_CAL + 1] >= 0.0
        or par[PAR_CAL + 2] >= 0.0
        or par[PAR_CAL + 3] >= 0.0
    ):
        if par[PAR_CAL + 3] >= 0.0:
            pred = _delay_dvl(par, x, w, f, C, v_b, pred, H, r)
        _calibrate_dvl(par, x, z, pred, y, H, r)


@jit
def _normal_gravity(lat: float, h: float) -> float:
    """g(L, h) (twin of earth.gravity) from the latitude alone: compiled.propagation._gravity
    reads only sin L and 1/sqrt(1 - e² sin² L) of the Earth tuple it is given."""
    s = math.sin(lat)
    return _gravity((s, 0.0, 1.0 / math.sqrt(1.0 - E2 * s * s), 0.0, 0.0, 0.0, 0.0), h)


@jit
def _delay_dvl(
    par: Array, x: Array, w: Array, f: Array, C: Mat3, v_b: Vec3, p: Vec3, H: Array, r: int
) -> Vec3:
    """The DVL's reading τ_d earlier (twin: sensors.dvl.DVL._delayed, rate, rate_jacobian):
    returns ``p - τ_d ḣ``, ``ḣ = C_sb (f̃ - b_a + C_nbᵀ g_n - ω × v_b)``; H's core rows
    ``H - τ_d Ḣ`` and ``-ḣ`` on τ_d (mixed by the scale and misalignment after). ``C``:
    C_nb, ``v_b = C_nbᵀ v_n`` (:func:`_lin_dvl`'s). Row a of ``C_sb [ω×]`` is
    ``(C_sb)_a × ω`` and ``uᵀ C_nbᵀ = (C_nb u)ᵀ``."""
    kl = int(par[PAR_CAL + 3])
    delay = x[kl + 1]
    Cs = _par_mat(par, PAR_CSB)
    v = (x[3], x[4], x[5])
    g = _normal_gravity(x[0], x[2])
    rate = (w[0] - x[13], w[1] - x[14], w[2] - x[15])
    wv = _cross(rate, v_b)
    acc = (
        f[0] - x[10] + C[6] * g - wv[0],
        f[1] - x[11] + C[7] * g - wv[1],
        f[2] - x[12] + C[8] * g - wv[2],
    )
    h_dot = _matvec(Cs, acc)
    for a in range(3):
        k = r + a
        row = (Cs[3 * a], Cs[3 * a + 1], Cs[3 * a + 2])
        cq = _matvec(C, _cross(row, rate))
        h_att = _cross(_matvec(C, row), (0.0, 0.0, g))
        h_vv = _cross(cq, v)
        h_bg = _cross(row, v_b)
        for c in range(3):
            H[k, 3 + c] += delay * cq[c]
            H[k, 6 + c] -= delay * (h_att[c] - h_vv[c])
            H[k, 9 + c] += delay * row[c]
            H[k, 12 + c] += delay * h_bg[c]
        H[k, kl] = -h_dot[a]
    return (p[0] - delay * h_dot[0], p[1] - delay * h_dot[1], p[2] - delay * h_dot[2])


@jit
def _rot_x(r: float, d: bool) -> Mat3:
    """Rx(r) of attitude.euler_to_dcm, or its derivative (``d``), row-major."""
    s, c = math.sin(r), math.cos(r)
    if d:
        return (0.0, 0.0, 0.0, 0.0, -s, -c, 0.0, c, -s)
    return (1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)


@jit
def _rot_y(p: float, d: bool) -> Mat3:
    s, c = math.sin(p), math.cos(p)
    if d:
        return (-s, 0.0, c, 0.0, 0.0, 0.0, -c, 0.0, -s)
    return (c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)


@jit
def _rot_z(y: float, d: bool) -> Mat3:
    s, c = math.sin(y), math.cos(y)
    if d:
        return (-s, -c, 0.0, c, -s, 0.0, 0.0, 0.0, 0.0)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


@jit
def _t_vec(A: Mat3, v: Vec3) -> Vec3:
    """``Aᵀ v``."""
    return (
        A[0] * v[0] + A[3] * v[1] + A[6] * v[2],
        A[1] * v[0] + A[4] * v[1] + A[7] * v[2],
        A[2] * v[0] + A[5] * v[1] + A[8] * v[2],
    )


@jit_inline
def _misaligned(d: Vec3, which: int, v: Vec3) -> Vec3:
    """``M(δ) v = Rxᵀ Ryᵀ Rzᵀ v`` (sensors/calibration.misalignment), or ``(∂M/∂δ_which) v``
    (which = 0, 1, 2: roll, pitch, yaw; -1: M itself)."""
    w = _t_vec(_rot_z(d[2], which == 2), v)
    w = _t_vec(_rot_y(d[1], which == 1), w)
    return _t_vec(_rot_x(d[0], which == 0), w)


@jit
def _calibrate_dvl(par: Array, x: Array, z: Array, p: Vec3, y: Array, H: Array, r: int) -> None:
    """The DVL's calibration states (twin: sensors.dvl.calibrate, calibrate_jacobian):
    ``h = (1 + s) M(δ) p + b``, H's core rows (and its latency column) mixed by ``(1 + s) M``,
    ``M p`` on s, ``(1 + s) (∂M/∂δ_i) p`` on δ, 1 on each b. Called, not inlined (as are the
    rotations it uses): it is rare, and inlined it was a third of the linearisations' compile
    time."""
    ks, km, kl = int(par[PAR_CAL]), int(par[PAR_CAL + 1]), int(par[PAR_CAL + 3])
    g = 1.0 + x[ks + 1] if ks >= 0 else 1.0
    d = (x[km + 1], x[km + 2], x[km + 3]) if km >= 0 else (0.0, 0.0, 0.0)
    mp = _misaligned(d, -1, p)
    for cc in range(N_STATES + 1):
        c = kl if cc == N_STATES else cc
        if c < 0:
            continue
        col = _misaligned(d, -1, (H[r, c], H[r + 1, c], H[r + 2, c]))
        for a in range(3):
            H[r + a, c] = g * col[a]
    for a in range(3):
        y[r + a] = z[a] - g * mp[a]
        if ks >= 0:
            H[r + a, ks] = mp[a]
    if km >= 0:
        for i in range(3):
            dp = _misaligned(d, i, p)
            for a in range(3):
                H[r + a, km + i] = g * dp[a]
    _bias(par, x, y, H, r, 3, 2)


@jit_inline
def _lin_depth(par: Array, x: Array, z: Array, y: Array, H: Array, r: int) -> None:
    """Depth (sensors.depth): ``h = h_s - h + (C_nb l_b)_D``, h_s the water surface's height
    (``par[PAR_FLAG]``); H: 1 on dr_D, ``[a_E, -a_N, 0]`` on phi."""
    a = _matvec(_dcm(x), _par_vec(par, PAR_LB))
    y[r] = z[0] - (par[PAR_FLAG] - x[2] + a[2])
    H[r, 2] = 1.0
    H[r, 6] = a[1]
    H[r, 7] = -a[0]
    _bias(par, x, y, H, r, 1)


@jit_inline
def _bias(par: Array, x: Array, y: Array, H: Array, r: int, d: int, slot: int = 0) -> None:
    """A reading plus its d bias states from error index ``par[PAR_CAL + slot]`` (-1: none):
    ``y -= b``, 1 on each bias (twin: sensors.calibration.bias, bias_jacobian)."""
    kb = int(par[PAR_CAL + slot])
    if kb >= 0:
        for a in range(d):
            y[r + a] -= x[kb + 1 + a]
            H[r + a, kb + a] = 1.0


@jit_inline
def _lin_attitude(
    par: Array, x: Array, z: Array, w: Array, y: Array, H: Array, r: int, heading: bool
) -> None:
    """Inclinometer (roll, pitch) or heading (yaw) of ``C_ns = C_nb C_sbᵀ``: wrapped residuals,
    H on phi from the Euler-angle Jacobian (sensors.inclinometer, sensors.heading,
    sensors.base.euler_jacobian); a heading's latency state, if any (:func:`_heading_latency`)."""
    M = _mul_bt(_dcm(x), _par_mat(par, PAR_CSB))
    roll, pitch, yaw = _euler(M)
    sy, cy = math.sin(yaw), math.cos(yaw)
    cp = math.cos(pitch)
    if heading:
        tp = math.tan(pitch)
        y[r] = _wrap(z[0] - yaw)
        H[r, 6] = cy * tp
        H[r, 7] = sy * tp
        H[r, 8] = 1.0
        if par[PAR_CAL + 3] >= 0.0:
            _heading_latency(par, x, w, sy, cy, tp, cp, y, H, r)
    else:
        kb = int(par[PAR_CAL])
        b0, b1 = (x[kb + 1], x[kb + 2]) if kb >= 0 else (0.0, 0.0)
        y[r] = _wrap(z[0] - (roll + b0))
        y[r + 1] = _wrap(z[1] - (pitch + b1))
        H[r, 6] = cy / cp
        H[r, 7] = sy / cp
        H[r + 1, 6] = -sy
        H[r + 1, 7] = cy
        if kb >= 0:
            H[r, kb], H[r + 1, kb + 1] = 1.0, 1.0


@jit
def _heading_latency(
    par: Array, x: Array, w: Array, sy: float, cy: float, tp: float, cp: float, y: Array,
    H: Array, r: int,
) -> None:  # fmt: skip
    """The heading τ earlier (twin: sensors.heading.Heading with ``cal_latency``): with
    ``u = C_nb (ω̃ - b_g)`` and the rows ``E_ψ``, ``E_θ`` of the Euler-angle Jacobian, the
    residual gains ``τ ψ̇`` (``ψ̇ = E_ψ · u``), H ``-τ ∂ψ̇/∂phi`` and ``τ E_ψ C_nb`` on db_g, and
    ``-ψ̇`` on τ. Called, not inlined: rare."""
    kl = int(par[PAR_CAL + 3])
    lag = x[kl + 1]
    C = _dcm(x)
    u = _matvec(C, (w[0] - x[13], w[1] - x[14], w[2] - x[15]))
    e_yaw, e_pitch = (cy * tp, sy * tp, 1.0), (-sy, cy, 0.0)
    turn = e_yaw[0] * u[0] + e_yaw[1] * u[1] + u[2]
    d_yaw = -sy * tp * u[0] + cy * tp * u[1]
    d_pitch = (cy * u[0] + sy * u[1]) / (cp * cp)
    eu = _cross(e_yaw, u)
    for c in range(3):
        H[r, 6 + c] -= lag * (d_yaw * e_yaw[c] + d_pitch * e_pitch[c] - eu[c])
        H[r, 12 + c] += lag * (e_yaw[0] * C[c] + e_yaw[1] * C[3 + c] + C[6 + c])
    H[r, kl] = -turn
    y[r] = _wrap(y[r] + lag * turn)


@jit_inline
def _lin_pendulum(par: Array, x: Array, z: Array, f: Array, y: Array, H: Array, r: int) -> None:
    """Pendulum inclinometer (sensors.inclinometer.PendulumInclinometer): the tilt of
    ``f_s = C_sb (f̃_b - b̂_a)``; H = ``-J(f_s) C_sb`` on db_a."""
    Cs = _par_mat(par, PAR_CSB)
    fs = _matvec(Cs, (f[0] - x[10], f[1] - x[11], f[2] - x[12]))
    rho2 = fs[1] * fs[1] + fs[2] * fs[2]
    rho = math.sqrt(rho2)
    n2 = rho2 + fs[0] * fs[0]
    kb = int(par[PAR_CAL])
    b0, b1 = (x[kb + 1], x[kb + 2]) if kb >= 0 else (0.0, 0.0)
    y[r] = _wrap(z[0] - (math.atan2(-fs[1], -fs[2]) + b0))
    y[r + 1] = _wrap(z[1] - (math.atan2(fs[0], rho) + b1))
    if kb >= 0:
        H[r, kb], H[r + 1, kb + 1] = 1.0, 1.0
    j_roll = (0.0, fs[2] / rho2, -fs[1] / rho2)
    j_pitch = (rho / n2, -fs[0] * fs[1] / (rho * n2), -fs[0] * fs[2] / (rho * n2))
    for c in range(3):
        H[r, 9 + c] = -(j_roll[0] * Cs[c] + j_roll[1] * Cs[3 + c] + j_roll[2] * Cs[6 + c])
        H[r + 1, 9 + c] = -(j_pitch[0] * Cs[c] + j_pitch[1] * Cs[3 + c] + j_pitch[2] * Cs[6 + c])


@jit_inline
def _lin_gnss(par: Array, x: Array, z: Array, w: Array, y: Array, H: Array, r: int) -> None:
    """GNSS (sensors.gnss): antenna lat, lon (, h) with lever arm; residual in NED metres; the
    horizontal bias states, if any, subtracted from its N and E components; a latency state,
    if any (:func:`_gnss_latency`)."""
    lat, lon, h = x[0], x[1], x[2]
    a = _matvec(_dcm(x), _par_vec(par, PAR_LB))
    RM, RN, dRM, dRN = _radii(lat)
    rm, rn = RM + h, RN + h
    cl = math.cos(lat)
    lat_a = lat + a[0] / rm
    lon_a = _wrap(lon + a[1] / (rn * cl))
    y[r] = (z[0] - lat_a) * rm
    y[r + 1] = _wrap(z[1] - lon_a) * rn * cl
    H[r, 0] = 1.0 - a[0] * dRM / rm**2
    H[r, 2] = a[0] / rm
    H[r + 1, 0] = a[1] * (math.tan(lat) - dRN / rn) / rm
    H[r + 1, 1] = 1.0
    H[r + 1, 2] = a[1] / rn
    H[r, 7], H[r, 8] = a[2], -a[1]
    H[r + 1, 6], H[r + 1, 8] = -a[2], a[0]
    if par[PAR_FLAG] != 0.0:  # use_height
        y[r + 2] = -(z[2] - (h - a[2]))
        H[r + 2, 2] = 1.0
        H[r + 2, 6], H[r + 2, 7] = a[1], -a[0]
    _bias(par, x, y, H, r, 2)  # horizontal bias states, if any (sensors.gnss.GNSS.cal_bias)
    if par[PAR_CAL + 3] >= 0.0:
        _gnss_latency(par, x, w, y, H, r, 3 if par[PAR_FLAG] != 0.0 else 2)


@jit
def _gnss_latency(par: Array, x: Array, w: Array, y: Array, H: Array, r: int, d: int) -> None:
    """The fix τ earlier (twin: sensors.gnss.GNSS with ``cal_latency``): with the antenna's
    velocity ``v_a = v_n + u``, ``u = C_nb ((ω̃ - b_g) × l_b)``, the residual gains ``τ v_a``,
    H ``-τ`` on dv, ``τ [u×]`` on phi, ``-τ C_nb [l_b×]`` on db_g (row k: ``(C_nb)_k × l_b``)
    and ``-v_a`` on τ. Called, not inlined: rare."""
    kl = int(par[PAR_CAL + 3])
    lag = x[kl + 1]
    C = _dcm(x)
    lever = _par_vec(par, PAR_LB)
    u = _matvec(C, _cross((w[0] - x[13], w[1] - x[14], w[2] - x[15]), lever))
    skew_u = (0.0, -u[2], u[1], u[2], 0.0, -u[0], -u[1], u[0], 0.0)
    for k in range(d):
        v_a = x[3 + k] + u[k]
        y[r + k] += lag * v_a
        H[r + k, 3 + k] -= lag
        c_l = _cross((C[3 * k], C[3 * k + 1], C[3 * k + 2]), lever)
        for c in range(3):
            H[r + k, 6 + c] += lag * skew_u[3 * k + c]
            H[r + k, 12 + c] -= lag * c_l[c]
        H[r + k, kl] = -v_a


@jit
def linearise(
    code: int, par: Array, x: Array, z: Array, w: Array, f: Array, y: Array, H: Array, row: int
) -> None:
    """Residual and H of sensor ``code`` into ``y[row:row+d]``, ``H[row:row+d]`` (zeroed first).

    ``par``: the packed parameters of :func:`compiled_linearisation`; ``z`` the reading (its
    finiteness is the caller's business); ``w`` the raw gyro rate ω̃_ib_b (the DVL's lever arm),
    ``f`` the raw specific force f̃_ib_b (the pendulum inclinometer), of the current IMU interval.
    Compiled twin of the sensors' ``evaluate``.
    """
    for a in range(MAX_DIM):
        if row + a < H.shape[0]:
            for c in range(H.shape[1]):
                H[row + a, c] = 0.0
    # One call site per inlined helper: each site is inlined and compiled anew (cold start)
    if code in (LIN_DVL, LIN_NHC):
        _lin_dvl(par, x, z, w, f, y, H, row, 1 if code == LIN_NHC else 0)
    elif code == LIN_DEPTH:
        _lin_depth(par, x, z, y, H, row)
    elif code in (LIN_INCLINOMETER, LIN_HEADING):
        _lin_attitude(par, x, z, w, y, H, row, code == LIN_HEADING)
    elif code == LIN_GNSS:
        _lin_gnss(par, x, z, w, y, H, row)
    elif code == LIN_PENDULUM:
        _lin_pendulum(par, x, z, f, y, H, row)
    elif code == LIN_ZUPT:
        for a in range(3):
            y[row + a] = z[a] - x[3 + a]
            H[row + a, 3 + a] = 1.0


# --- the registry: sensor class -> (code, packed parameters) -----------------------------------


LinearisationSpec = tuple[int, Array]
"""(sensor code, packed parameters (N_PAR,)) as :func:`linearise` takes them."""

LINEARISED: frozenset[type] = frozenset(registry.LINEARISED)
"""Sensor classes with a compiled linearisation, by exact class (a subclass may change
``evaluate``, so it is not matched)."""


def compiled_linearisation(model: object) -> LinearisationSpec | None:
    """The compiled linearisation of ``model``, or None (the engine then calls ``evaluate``).

    A model may offer one itself with a ``compiled_linearisation()`` method returning
    ``(code, params)`` for one of the codes of :func:`linearise`; otherwise a class of
    :data:`LINEARISED` gives its ``LIN_CODE`` and ``lin_params()``.
    """
    hook = getattr(model, "compiled_linearisation", None)
    if callable(hook):
        spec = hook()
        if spec is None:
            return None
        code, par = spec
        return int(code), np.asarray(par, dtype=float)
    if type(model) not in LINEARISED:
        return None
    return int(model.LIN_CODE), model.lin_params()  # type: ignore[attr-defined]


# --- small dense linear algebra (D ≤ 3 per sensor, stacked) ------------------------------------


@jit_inline
def _active_columns(H: Array, D: int, cols: IntArray) -> int:
    """Indices of the columns of ``H[:D]`` with a nonzero entry, into cols; their count."""
    n = 0
    for c in range(H.shape[1]):
        for r in range(D):
            if H[r, c] != 0.0:
                cols[n] = c
                n += 1
                break
    return n


@jit_inline
def _h_p(P: Array, H: Array, D: int, cols: IntArray, nc: int, Ut: Array) -> None:
    """``Uᵀ = H P`` (D×15; ``U = P Hᵀ`` as P is symmetric), over H's nonzero columns.

    The inner loops run over the 15 states with a run-time trip count (P's size), so that LLVM
    vectorizes them (as in :mod:`adaptnav.compiled.propagation`); likewise below.
    """
    ns = P.shape[0]
    for r in range(D):
        for j in range(ns):
            Ut[r, j] = 0.0
        for m in range(nc):
            c = cols[m]
            h = H[r, c]
            for j in range(ns):
                Ut[r, j] += h * P[c, j]


@jit_inline
def _h_p_ht(H: Array, Ut: Array, D: int, cols: IntArray, nc: int, W: Array) -> None:
    """``W = H P Hᵀ`` (D×D) from ``Uᵀ = H P``, symmetrised."""
    for r in range(D):
        for c2 in range(D):
            acc = 0.0
            for m in range(nc):
                c = cols[m]
                acc += H[r, c] * Ut[c2, c]
            W[r, c2] = acc
    for r in range(D):
        for c2 in range(r):
            avg = 0.5 * (W[r, c2] + W[c2, r])
            W[r, c2] = avg
            W[c2, r] = avg


@jit_inline
def _cholesky(S: Array, D: int, L: Array) -> bool:
    """Lower Cholesky factor of S (D×D) into L; False if S is not positive definite."""
    for j in range(D):
        s = S[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, D):
            t = S[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
        for i in range(j):
            L[i, j] = 0.0
    return True


@jit_inline
def _cho_solve(L: Array, D: int, B: Array, X: Array, ns: int) -> None:
    """``X = S⁻¹ B`` for B (D×ns), ``S = L Lᵀ``, column by column (X may be B)."""
    for a in range(D):
        for j in range(ns):
            X[a, j] = B[a, j]
        for k in range(a):
            f = L[a, k]
            for j in range(ns):
                X[a, j] -= f * X[k, j]
        d = L[a, a]
        for j in range(ns):
            X[a, j] /= d
    for a in range(D - 1, -1, -1):
        for k in range(a + 1, D):
            f = L[k, a]
            for j in range(ns):
                X[a, j] -= f * X[k, j]
        d = L[a, a]
        for j in range(ns):
            X[a, j] /= d


@jit_inline
def _quad_solve(S: Array, o: int, d: int, nu: Array, n0: int, M: Array, b: Array) -> float:
    """``νᵀ S⁻¹ ν`` for the block ``S[o:o+d, o:o+d]`` and ``ν = nu[n0:n0+d]``, by Gaussian
    elimination with partial pivoting (as np.linalg.solve) in the scratch M (3×3), b (3); NaN
    if singular."""
    for i in range(d):
        b[i] = nu[n0 + i]
        for j in range(d):
            M[i, j] = S[o + i, o + j]
    for k in range(d):
        p = k
        for i in range(k + 1, d):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        if M[p, k] == 0.0:
            return math.nan
        if p != k:
            for j in range(d):
                M[k, j], M[p, j] = M[p, j], M[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, d):
            f = M[i, k] / M[k, k]
            for j in range(k, d):
                M[i, j] -= f * M[k, j]
            b[i] -= f * b[k]
    s = 0.0
    for i in range(d - 1, -1, -1):
        t = b[i]
        for j in range(i + 1, d):
            t -= M[i, j] * b[j]
        b[i] = t / M[i, i]
        s += nu[n0 + i] * b[i]
    return s


@jit_inline
def _gate_statistic(rule: int, nu: Array, n0: int, S: Array, d: int, M: Array, b: Array) -> float:
    if rule == GATE_COMPONENT:
        stat = -math.inf
        for j in range(d):
            v = nu[n0 + j] * nu[n0 + j] / S[j, j]
            if math.isnan(v):
                return math.nan
            stat = max(stat, v)
        return stat
    return _quad_solve(S, 0, d, nu, n0, M, b)


@jit
def gate_statistic(rule: int, nu: Array, S: Array) -> float:
    """Gate statistic of innovation ``nu`` (d) with covariance ``S`` (d×d) (twin of
    gate.apply_gate): ``component``: max_j ν_j²/S_jj (NaN if any is NaN); ``chi2``: νᵀ S⁻¹ ν.
    The reading is accepted iff the statistic is <= q."""
    d = nu.shape[0]
    return _gate_statistic(rule, nu, 0, S, d, np.empty((d, d)), np.empty(d))


# --- the work arrays of an epoch ----------------------------------------------------------------

Workspace = tuple[NDArray[Any], ...]
"""Scratch arrays for :func:`epoch` and :func:`stacked_update`, from :func:`workspace`."""
WS_H, WS_Y, WS_RB, WS_UT, WS_KT, WS_ET, WS_W, WS_S, WS_L, WS_GT, WS_R_USED = range(11)
WS_VEC, WS_DX, WS_P_NEW, WS_R_NOW, WS_ROWS3, WS_SMALL3, WS_M3, WS_B3 = range(11, 19)
WS_COLS, WS_BLK, WS_SEEN = range(19, 22)
WS_PRIOR = 22
"""``ws[WS_PRIOR]``: P as the epoch's update starts from it, for the smoother (n×n; 0×0 when
smoothing is off; ``[0, 0]`` NaN after an epoch without an update)."""
WS_PROP, WS_NOISE = 23, 24
"""``ws[WS_PROP]``: the propagation's flat work arrays as rows (compiled.propagation._work): Aᵀ,
the sum over the open covariance block; Φᵀ; M; the padded core of P. ``ws[WS_NOISE]``: the
block's ``½ Σ S_k T_k`` (compiled.propagation.N_NOISE_ACC). Both carry an open block from one
call of the engine's loop to the next (docs/filters.md, 'Covariance blocks')."""
WS_XMID, WS_Y0 = 25, 26
"""``ws[WS_XMID]``: the nominal state at the midpoint of an update's step; ``ws[WS_Y0]``: the
residuals at the prior while the readings are linearised there (:func:`_midpoint`)."""
WS_NODE_P = 27
"""``ws[WS_NODE_P]``: for the smoother, P after the epoch's update (its reset and any repair)
and before the windowed NIS test could inflate it (n×n; 0×0 when smoothing is off): the P of
the epoch's node, the inflation after it left to the next interval as process noise
(:func:`node_P`; docs/smoothing.md, 'Inflations of P')."""
V_ALPHA, V_BETA_PRIOR, V_BETA, V_R_HAT, V_HPH, V_GY, V_EPS, V_HPH_POST, V_LAM, V_B = range(10)
V_LO, V_HI = 10, 11  # bounds on R̂ per component (variances)
N_VEC = 12
"""Rows of ``ws[WS_VEC]``."""


def workspace(n_sensors: int, n_states: int = N_STATES, smooth: bool = False) -> Workspace:
    """Scratch arrays for epochs of up to ``n_sensors`` stacked sensors (D ≤ 3 n_sensors):
    stacked H, y, nominal R blocks, ``H P``, Kᵀ, Eᵀ (D×15), W, S, L, Gᵀ, R used (D×D), VB and
    matching vectors (N_VEC×D), dx, P⁺, and small scratch; allocated once, reused every epoch.
    ``smooth``: also the P before each update (:data:`WS_PRIOR`) and the one the update left
    (:data:`WS_NODE_P`); then the propagation's (:data:`WS_PROP`, :data:`WS_NOISE`)."""
    n = max(n_sensors, 1)
    Dm = MAX_DIM * n
    ns = n_states
    f = [(Dm, ns), (Dm,), (n, MAX_DIM, MAX_DIM), (Dm, ns), (Dm, ns), (Dm, ns), (Dm, Dm),
         (Dm, Dm), (Dm, Dm), (Dm, Dm), (Dm, Dm), (N_VEC, Dm), (ns,), (ns, ns), (3, 3), (3, ns),
         (3, 3), (3, 3), (3,)]  # fmt: skip
    ints = [(ns,), (3, n + 1), (n,)]
    return (
        *(np.zeros(shape) for shape in f),
        *(np.zeros(shape, dtype=np.int64) for shape in ints),
        np.full((ns, ns) if smooth else (0, 0), math.nan),
        np.zeros((4, 15 * 16)),
        np.zeros(N_NOISE_ACC),
        np.zeros(ns + 1),
        np.zeros(Dm),
        np.zeros((ns, ns) if smooth else (0, 0)),
    )


# --- the Kalman correction (twin of kalman.correct) ---------------------------------------------


@jit
def _correct(
    P: Array,
    H: Array,
    y: Array,
    R: Array,
    D: int,
    Ut: Array,
    W: Array,
    S: Array,
    L: Array,
    Kt: Array,
    Ft: Array,
    dx: Array,
    P_out: Array,
) -> bool:
    """x⁻ = 0 update: ``S = H P Hᵀ + R``, ``K = P Hᵀ S⁻¹``, ``dx = K y`` and the Joseph form
    ``P⁺ = (I - K H) P (I - K H)ᵀ + K R Kᵀ``, symmetrised, given ``Ut = H P`` (= Uᵀ with
    ``U = P Hᵀ``) and ``W = H P Hᵀ`` (symmetrised). False (dx, P_out not written) if S is not
    positive definite.

    For any K the Joseph form is ``P - K Uᵀ - U Kᵀ + K S Kᵀ`` (expand it with H P = Uᵀ and
    H P Hᵀ + R = S); it is evaluated as ``P + ½ (F Kᵀ + K Fᵀ)`` with ``F = K S - 2 U``, which
    is symmetric term by term. Kᵀ and Fᵀ are stored by rows (the long loops run over states).
    """
    ns = P.shape[0]
    for r in range(D):
        for c2 in range(D):
            S[r, c2] = W[r, c2] + 0.5 * (R[r, c2] + R[c2, r])
    if not _cholesky(S, D, L):
        return False
    _cho_solve(L, D, Ut, Kt, ns)
    for j in range(ns):
        dx[j] = 0.0
    for r in range(D):
        yr = y[r]
        for j in range(ns):
            dx[j] += Kt[r, j] * yr
    for r in range(D):  # Fᵀ = S Kᵀ - 2 Uᵀ
        for i in range(ns):
            Ft[r, i] = -2.0 * Ut[r, i]
        for a in range(D):
            f = S[r, a]
            for i in range(ns):
                Ft[r, i] += f * Kt[a, i]
    for i in range(ns):
        for j in range(ns):
            P_out[i, j] = P[i, j]
        for r in range(D):
            a, b = 0.5 * Ft[r, i], 0.5 * Kt[r, i]
            for j in range(ns):
                P_out[i, j] += a * Kt[r, j] + b * Ft[r, j]
    for i in range(ns):  # the terms are symmetric already; make it exact
        for j in range(i):
            P_out[j, i] = P_out[i, j]
    return True


@jit
def correct(P: Array, H: Array, y: Array, R: Array, dx: Array, P_out: Array) -> bool:
    """Compiled twin of :func:`adaptnav.estimation.kalman.correct`: dx (15) and P⁺ (15×15) into the
    output arrays for the stacked ``H`` (D×15), ``y`` (D), ``R`` (D×D); False if S is not
    positive definite."""
    D = y.shape[0]
    ns = P.shape[0]
    cols = np.empty(ns, np.int64)
    nc = _active_columns(H, D, cols)
    Ut = np.empty((D, ns))
    W = np.empty((D, D))
    _h_p(P, H, D, cols, nc, Ut)
    _h_p_ht(H, Ut, D, cols, nc, W)
    return _correct(
        P, H, y, R, D, Ut, W, np.empty((D, D)), np.empty((D, D)), np.empty((D, ns)),
        np.empty((D, ns)), dx, P_out,
    )  # fmt: skip


# --- the noise strategies' stacked updates (twins of adaptnav.estimation.noise)
# ----------------------------


@jit
def _vb_iterate(
    W: Array,
    y: Array,
    D: int,
    V: Array,
    iterations: int,
    tol: float,
    S: Array,
    L: Array,
    Gt: Array,
    nb: int,
    blk_off: IntArray,
    dof: float,
    weights_only: bool,
) -> int:
    """VB fixed point (paper eqs. (24)-(28); docs/filters.md, 'VB update') in measurement space,
    on the rows of V: α (already α⁻ + ½) and β⁻ given; leaves in R̂ the R of the last correction
    and in β its β. With ``dof`` > 0, each block's reading has a Student-t scale λ (twin of
    VariationalBayes.update with its ``dof`` and ``weights_only``: then β learns ½ B, not
    ½ λ B; ``dof`` <= 0: λ = 1, the paper's update). Returns the iterations done, -1 if an S
    was not positive definite."""
    alpha, beta_prior, beta, r_hat, Gy = V[V_ALPHA], V[V_BETA_PRIOR], V[V_BETA], V[V_R_HAT], V[V_GY]
    lam, B, lo, hi = V[V_LAM], V[V_B], V[V_LO], V[V_HI]
    for j in range(D):
        beta[j] = beta_prior[j]
        lam[j] = 1.0
        r_hat[j] = min(max(beta[j] / alpha[j], lo[j]), hi[j])
    done = 0
    while True:
        done += 1
        for r in range(D):
            for c2 in range(D):
                S[r, c2] = W[r, c2]
            S[r, r] += r_hat[r]
        if not _cholesky(S, D, L):
            return -1
        _cho_solve(L, D, W, Gt, D)  # Gᵀ = S⁻¹ W (G = W S⁻¹, W and S symmetric)
        for r in range(D):
            s = 0.0
            for a in range(D):
                s += Gt[a, r] * y[a]
            Gy[r] = s
        converged = True
        for j in range(D):
            resid = y[j] - Gy[j]
            hph = 0.0  # [(I - G) W (I - G)ᵀ + G R̂ Gᵀ]_jj
            for a in range(D):
                ia = (1.0 if a == j else 0.0) - Gt[a, j]
                t = 0.0
                for b in range(D):
                    t += W[a, b] * ((1.0 if b == j else 0.0) - Gt[b, j])
                hph += ia * t + Gt[a, j] * Gt[a, j] * r_hat[a]
            B[j] = resid * resid + hph
        if dof > 0.0:
            for b in range(nb):
                s = 0.0
                for j in range(blk_off[b], blk_off[b + 1]):
                    s += B[j] * alpha[j] / beta[j]
                lb = (dof + (blk_off[b + 1] - blk_off[b])) / (dof + s)
                for j in range(blk_off[b], blk_off[b + 1]):
                    lam[j] = lb
        for j in range(D):
            beta[j] = beta_prior[j] + 0.5 * (B[j] if weights_only else lam[j] * B[j])
            r_next = min(max(beta[j] / alpha[j] / lam[j], lo[j]), hi[j])
            if not abs(r_next - r_hat[j]) <= tol * r_hat[j]:
                converged = False
        if done >= iterations or converged:
            for j in range(D):  # the state's R̂ = β/α within its bounds too
                beta[j] = min(max(beta[j], lo[j] * alpha[j]), hi[j] * alpha[j])
            return done
        for j in range(D):
            r_hat[j] = min(max(beta[j] / alpha[j] / lam[j], lo[j]), hi[j])


@jit
def _matching_r(
    ring: Array,
    W_i: int,
    d: int,
    push: Array,
    p0: int,
    hph_ring: Array,
    hph_now: Array,
    h0: int,
    count: int,
    full: bool,
    refill: bool,
    residual_based: bool,
    floor: float,
    ceiling: float,
    Rnom: Array,
    R: Array,
    o: int,
) -> None:
    """One sensor's R̂ into ``R[o:o+d, o:o+d]`` (twin of CovarianceMatching._estimate).

    IAE: the mean over the window that ends with the new ``ν² = push[p0:p0+d]²`` (ring rows
    1..W-1, then the new one), minus ``diag(H P⁻ Hᵀ) = hph_now[h0:h0+d]``; RAE: mean of the
    ring plus mean of the hph ring. Floored at ``floor * diag(R_nominal)``, capped at
    ``ceiling * diag(R_nominal)`` (inf: none, the paper); the nominal R (full) until the
    window is full, or with ``refill`` (a gap restart is on, CovarianceMatching._window_R)
    each variance raised to the estimate from the ``count`` rows so far where larger.
    """
    for a in range(d):
        for b in range(d):
            R[o + a, o + b] = 0.0 if full else Rnom[a, b]
    if residual_based:
        rows = W_i if full else count
        n = rows
    else:
        rows = W_i - 1 if full else count
        n = rows + 1
    if not full and (not refill or n == 0):
        return
    for j in range(d):
        s = 0.0
        for k in range(W_i - rows, W_i):
            s += ring[k, j]
        if residual_based:
            s2 = 0.0
            for k in range(W_i - rows, W_i):
                s2 += hph_ring[k, j]
            r = s / n + s2 / n
        else:
            s += push[p0 + j] * push[p0 + j]
            r = s / n - hph_now[h0 + j]
        v = min(max(r, floor * Rnom[j, j]), ceiling * Rnom[j, j])
        R[o + j, o + j] = v if full else max(v, Rnom[j, j])


@jit_inline
def _push(ring: Array, W_i: int, d: int, values: Array, v0: int, square: bool) -> None:
    """Drop the oldest row of the ring, append ``values[v0:v0+d]`` (squared if asked)."""
    for k in range(W_i - 1):
        for j in range(d):
            ring[k, j] = ring[k + 1, j]
    for j in range(d):
        v = values[v0 + j]
        ring[W_i - 1, j] = v * v if square else v


@jit
def stacked_update(
    kind: int,
    P: Array,
    H: Array,
    y: Array,
    D: int,
    nb: int,
    blk_sensor: IntArray,
    blk_off: IntArray,
    Rb: Array,
    s_int: IntArray,
    s_flt: Array,
    s_state: Array,
    rings: Array,
    ws: Workspace,
) -> int:
    """Stacked measurement update over nb received blocks (twin of the strategies' ``update``).

    Block b is sensor ``blk_sensor[b]`` at rows ``blk_off[b]:blk_off[b+1]`` of H (D×15) and
    y, with nominal R ``Rb[b]``. ``kind``: KIND_FIXED (R = blockdiag(R_nominal)),
    KIND_MATCHING (innovation- or residual-based covariance matching) or KIND_VB (variational
    Bayes, paper eqs. (23)-(28)); the settings that shape the stacked update (VB N and tol;
    matching window, floor, IAE/RAE) are the first block's sensor's, as in the readable
    strategies. Writes dx, P⁺ (before reset), the stacked R used and ``W = H P⁻ Hᵀ`` into
    ``ws`` (WS_DX, WS_P_NEW, WS_R_USED, WS_W) and the blocks' new adaptation states into the
    tables; returns the iterations, -1 if S was not positive definite (states then unchanged).
    """
    cols, Ut, W, R_used, V = ws[WS_COLS], ws[WS_UT], ws[WS_W], ws[WS_R_USED], ws[WS_VEC]
    dx, P_out = ws[WS_DX], ws[WS_P_NEW]
    nc = _active_columns(H, D, cols)
    _h_p(P, H, D, cols, nc, Ut)
    _h_p_ht(H, Ut, D, cols, nc, W)
    for r in range(D):
        for c2 in range(D):
            R_used[r, c2] = 0.0
    first = blk_sensor[0]
    iterations = 1
    rae = s_flt[first, F_RAE] != 0.0
    if kind == KIND_VB:
        for b in range(nb):
            i, o = blk_sensor[b], blk_off[b]
            for j in range(blk_off[b + 1] - o):
                V[V_ALPHA, o + j] = s_state[i, X_ALPHA + j] + 0.5
                V[V_BETA_PRIOR, o + j] = s_state[i, X_BETA + j]
                V[V_LO, o + j] = s_flt[first, F_RMIN] * Rb[b, j, j]
                V[V_HI, o + j] = s_flt[first, F_RMAX] * Rb[b, j, j]
        iterations = _vb_iterate(
            W, y, D, V, s_int[first, S_ITER], s_flt[first, F_TOL], ws[WS_S], ws[WS_L],
            ws[WS_GT], nb, blk_off, s_flt[first, F_DOF], s_flt[first, F_WEIGHTS_ONLY] != 0.0,
        )  # fmt: skip
        if iterations < 0:
            return -1
        for j in range(D):
            R_used[j, j] = V[V_R_HAT, j]
    elif kind == KIND_MATCHING:
        window = s_int[first, S_WINDOW]
        for j in range(D):
            V[V_HPH, j] = W[j, j]
        for b in range(nb):
            i, o = blk_sensor[b], blk_off[b]
            count = s_int[i, S_COUNT]
            full = count >= window if rae else min(count + 1, window) >= window
            _matching_r(
                rings[i, 0], s_int[i, S_WINDOW], blk_off[b + 1] - o, y, o, rings[i, 1],
                V[V_HPH], o, count, full, s_flt[i, F_GAP] > 0.0, rae, s_flt[first, F_FLOOR],
                s_flt[first, F_RMAX], Rb[b], R_used, o,
            )  # fmt: skip
    else:
        for b in range(nb):
            o = blk_off[b]
            for a in range(blk_off[b + 1] - o):
                for c in range(blk_off[b + 1] - o):
                    R_used[o + a, o + c] = Rb[b, a, c]
    if not _correct(P, H, y, R_used, D, Ut, W, ws[WS_S], ws[WS_L], ws[WS_KT], ws[WS_ET], dx, P_out):
        return -1
    if kind == KIND_VB:
        for b in range(nb):
            i, o = blk_sensor[b], blk_off[b]
            for j in range(blk_off[b + 1] - o):
                s_state[i, X_ALPHA + j] = V[V_ALPHA, o + j]
                s_state[i, X_BETA + j] = V[V_BETA, o + j]
            s_int[i, S_VERSION] += 1
    elif kind == KIND_MATCHING:
        window = s_int[first, S_WINDOW]
        if rae:  # ε = y - H dx⁺ and diag(H P⁺ Hᵀ)
            for r in range(D):
                s = y[r]
                hp = 0.0
                for m in range(nc):
                    c = cols[m]
                    s -= H[r, c] * dx[c]
                    t = 0.0
                    for m2 in range(nc):
                        t += P_out[c, cols[m2]] * H[r, cols[m2]]
                    hp += H[r, c] * t
                V[V_EPS, r] = s
                V[V_HPH_POST, r] = hp
        for b in range(nb):
            i, o = blk_sensor[b], blk_off[b]
            d = blk_off[b + 1] - o
            W_i = s_int[i, S_WINDOW]
            if rae:
                _push(rings[i, 0], W_i, d, V[V_EPS], o, True)
                _push(rings[i, 1], W_i, d, V[V_HPH_POST], o, False)
            else:
                _push(rings[i, 0], W_i, d, y, o, True)
            s_int[i, S_COUNT] = min(s_int[i, S_COUNT] + 1, window)
            s_int[i, S_VERSION] += 1
            for a in range(3):
                for c in range(3):
                    s_state[i, X_MR + 3 * a + c] = R_used[o + a, o + c] if a < d and c < d else 0.0
    return iterations


# --- closed-loop feedback (twins of errorstate.inject, reset_jacobian) --------------------------


@jit_inline
def inject(x: Array, dx: Array) -> None:
    """``x ← x ⊕ dx`` in place (twin of errorstate.inject): position through the radii at the
    estimate, ``q ← Exp(phi) ⊗ q`` normalised, velocity and biases added."""
    lat, h = x[0], x[2]
    RM, RN, _, _ = _radii(lat)
    x[0] = lat + dx[0] / (RM + h)
    x[1] = x[1] + dx[1] / ((RN + h) * math.cos(lat))
    x[2] = h - dx[2]
    for k in range(3):
        x[3 + k] += dx[3 + k]
    q = _quat_mult(_rotvec_to_quat((dx[6], dx[7], dx[8])), (x[6], x[7], x[8], x[9]))
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for k in range(4):
        x[6 + k] = q[k] / n
    for k in range(6):
        x[10 + k] += dx[9 + k]
    for k in range(15, dx.shape[0]):  # declared states (errorstate.StateLayout)
        x[k + 1] += dx[k]


@jit_inline
def reset_velocity(P: Array, d0: float, d1: float, d2: float, rows: Array) -> None:
    """``P ← J P Jᵀ`` in place, J = I except the velocity-attitude block ``-[d×]`` (with d = dv̂,
    the invariant term of errorstate.reset_jacobian; J's inverse is the same with -d): rows 3-5
    of ``J P`` into ``rows`` (3, ≥ n; scratch), mirrored into the columns outside the velocity
    block, whose ``(J P Jᵀ)`` is symmetrised, so P stays exactly symmetric."""
    J = (0.0, d2, -d1, -d2, 0.0, d0, d1, -d0, 0.0)  # -[d×], row-major
    n = P.shape[0]
    for a in range(3):
        j0, j1, j2 = J[3 * a], J[3 * a + 1], J[3 * a + 2]
        for j in range(n):
            rows[a, j] = P[3 + a, j] + j0 * P[6, j] + j1 * P[7, j] + j2 * P[8, j]
    for a in range(3):
        for j in range(n):
            if j < 3 or j > 5:
                P[3 + a, j] = rows[a, j]
                P[j, 3 + a] = rows[a, j]
    for a in range(3):
        for b in range(a, 3):
            ab = rows[a, 3 + b] + J[3 * b] * rows[a, 6] + J[3 * b + 1] * rows[a, 7]
            ab += J[3 * b + 2] * rows[a, 8]
            ba = rows[b, 3 + a] + J[3 * a] * rows[b, 6] + J[3 * a + 1] * rows[b, 7]
            ba += J[3 * a + 2] * rows[b, 8]
            P[3 + a, 3 + b] = 0.5 * (ab + ba)
            P[3 + b, 3 + a] = P[3 + a, 3 + b]


@jit_inline
def _reset(P: Array, dx: Array, rows: Array, blk: Array, mode: int) -> None:
    """``P ← G P Gᵀ`` in place for errorstate.reset_jacobian's ``mode`` (≥ RESET_ATTITUDE):
    the velocity term first (it reads the attitude rows before their reset; the two commute
    to first order), then the attitude block, symmetrised."""
    if mode == RESET_INVARIANT:
        reset_velocity(P, dx[3], dx[4], dx[5], rows)
    h0, h1, h2 = 0.5 * dx[6], 0.5 * dx[7], 0.5 * dx[8]
    Gs = (1.0, -h2, h1, h2, 1.0, -h0, -h1, h0, 1.0)
    for a in range(3):
        for j in range(P.shape[0]):
            rows[a, j] = Gs[3 * a] * P[6, j] + Gs[3 * a + 1] * P[7, j] + Gs[3 * a + 2] * P[8, j]
    for a in range(3):
        for j in range(P.shape[0]):
            if j < 6 or j > 8:
                P[6 + a, j] = rows[a, j]
                P[j, 6 + a] = rows[a, j]
    for a in range(3):
        for b in range(3):
            blk[a, b] = (
                rows[a, 6] * Gs[3 * b] + rows[a, 7] * Gs[3 * b + 1] + rows[a, 8] * Gs[3 * b + 2]
            )
    for a in range(3):
        for b in range(3):
            P[6 + a, 6 + b] = 0.5 * (blk[a, b] + blk[b, a])


@jit
def reset(P: Array, dx: Array, mode: int = RESET_INVARIANT) -> None:
    """``P ← G P Gᵀ`` in place for ``mode`` RESET_ATTITUDE or RESET_INVARIANT (twin of
    errorstate.reset_jacobian), then symmetrised; P symmetric on entry."""
    _reset(P, dx, np.empty((3, P.shape[0])), np.empty((3, 3)), mode)


# --- one measurement epoch ----------------------------------------------------------------------


@jit_inline
def _ledger(
    lg_int: IntArray,
    lg_flt: Array,
    n: int,
    idx: int,
    code: int,
    t_epoch: float,
    stat: float,
    threshold: float,
    iterations: int,
    nu: Array,
    n0: int,
    R: Array,
    o: int,
    d: int,
) -> None:
    """Ledger row n: reading ``idx``, fate code, statistic, threshold, innovation
    ``nu[n0:n0+d]`` and ``diag(R[o:o+d, o:o+d])`` (d = 0: none; NaN pads)."""
    lg_int[n, L_STORE] = idx
    lg_int[n, L_CODE] = code
    lg_int[n, L_ITER] = iterations
    lg_flt[n, L_T_EPOCH] = t_epoch
    lg_flt[n, L_STAT] = stat
    lg_flt[n, L_THRESHOLD] = threshold
    lg_flt[n, L_FACTOR] = math.nan
    for j in range(MAX_DIM):
        lg_flt[n, L_NU + j] = nu[n0 + j] if j < d else math.nan
        lg_flt[n, L_R + j] = R[o + j, o + j] if j < d else math.nan


@jit_inline
def _event(
    lg_int: IntArray,
    lg_flt: Array,
    n: int,
    idx: int,
    code: int,
    t: float,
    stat: float,
    threshold: float,
    factor: float,
) -> None:
    """Ledger row n for a filter event (``code`` >= EVENT_NIS) triggered by reading ``idx``:
    the test statistic, its threshold and the factor P was inflated by (estimation/health.py)."""
    _ledger(lg_int, lg_flt, n, idx, code, t, stat, threshold, 0, lg_flt[n], 0, lg_flt, 0, 0)
    lg_flt[n, L_FACTOR] = factor


@jit_inline
def _inflate(P: Array, k: float) -> None:
    """P ← k P (k >= 1): every variance and covariance scaled, so P stays positive definite
    and its correlations are kept (docs/robustness.md, divergence guard)."""
    for a in range(P.shape[0]):
        for c in range(P.shape[0]):
            P[a, c] *= k


@jit_inline
def ledger_drop(lg_int: IntArray, lg_flt: Array, n: int, idx: int, code: int, t: float) -> None:
    """Ledger row n for reading ``idx`` dropped (``code``) at time t: no statistic, ν or R."""
    _ledger(lg_int, lg_flt, n, idx, code, t, math.nan, math.nan, 0, lg_flt[n], 0, lg_flt, 0, 0)


@jit_inline
def _reading_R(st_z: Array, idx: int, d: int, Rb: Array, nb: int) -> None:
    """A reading's own nominal R, where it carries one: store columns MAX_DIM.. of its row hold
    the diagonal ``r_diag`` (NaN: none), which replaces the sensor's nominal R (off-diagonal
    terms zero). Used by the oracle baseline, which knows each reading's true variance."""
    if st_z.shape[1] <= MAX_DIM or not math.isfinite(st_z[idx, MAX_DIM]):
        return
    for a in range(d):
        for c in range(d):
            Rb[nb, a, c] = st_z[idx, MAX_DIM + a] if a == c else 0.0


@jit_inline
def _current_R(kind: int, sx: Array, Rb: Array, d: int, R: Array, o: int) -> None:
    """The sensor's R as its adaptation state has it now (twin of the strategies'
    ``current_R``) into ``R[o:o+d, o:o+d]``: the nominal ``Rb`` (fixed), the matched R̂
    (matching), ``diag(β / α)`` (VB)."""
    for a in range(d):
        for c in range(d):
            if kind == KIND_MATCHING:
                R[o + a, o + c] = sx[X_MR + 3 * a + c]
            elif kind == KIND_VB:
                R[o + a, o + c] = sx[X_BETA + a] / sx[X_ALPHA + a] if a == c else 0.0
            else:
                R[o + a, o + c] = Rb[a, c]


@jit
def _midpoint(
    x: Array,
    P: Array,
    rates: Array,
    D: int,
    nb: int,
    blk: IntArray,
    st_z: Array,
    s_int: IntArray,
    s_flt: Array,
    s_state: Array,
    kind: int,
    ws: Workspace,
) -> None:
    """Re-linearise the epoch's stacked readings at the midpoint of the update's step
    (docs/calibration.md, 'The midpoint update'): ``H`` at ``x ⊕ ½ dx``, the residuals ``y``
    kept at the prior x. For a reading that is a product of states (a DVL's scale times the
    velocity) ``h(x ⊕ dx) - h(x) = H(x ⊕ ½ dx) dx`` exactly (a secant; to third order in dx in
    general), where the tangent at x is off at second order and leaves a bias along the
    directions the reading cannot tell apart.

    ``dx`` is found by iterating ``S_MIDPOINT`` times (the most any block asks for): ``dx``
    from the Kalman correction with the current H and each sensor's current R
    (:func:`_current_R`), then H at ``x ⊕ ½ dx``. The stacked update that follows uses the last
    H with the sensors' own R strategies. Readings linearised in Python keep their H.
    """
    n_iter = 0
    for b in range(nb):
        n_iter = max(n_iter, s_int[blk[0, b], S_MIDPOINT])
    if n_iter == 0:
        return
    H, y, Rb, y0, xm = ws[WS_H], ws[WS_Y], ws[WS_RB], ws[WS_Y0], ws[WS_XMID]
    cols, Ut, W, R = ws[WS_COLS], ws[WS_UT], ws[WS_W], ws[WS_R_USED]
    dx = ws[WS_DX]
    for r in range(D):
        y0[r] = y[r]
        for c in range(D):
            R[r, c] = 0.0
    for b in range(nb):
        o = blk[2, b]
        _current_R(kind, s_state[blk[0, b]], Rb[b], blk[2, b + 1] - o, R, o)
    for _ in range(n_iter):
        nc = _active_columns(H, D, cols)
        _h_p(P, H, D, cols, nc, Ut)
        _h_p_ht(H, Ut, D, cols, nc, W)
        if not _correct(P, H, y0, R, D, Ut, W, ws[WS_S], ws[WS_L], ws[WS_KT], ws[WS_ET], dx,
                        ws[WS_P_NEW]):  # fmt: skip
            break  # the update itself finds S singular
        for k in range(x.shape[0]):
            xm[k] = x[k]
        for k in range(dx.shape[0]):
            dx[k] *= 0.5
        inject(xm, dx)
        for b in range(nb):
            i = blk[0, b]
            code = s_int[i, S_CODE]
            if code >= 0:
                linearise(code, s_flt[i], xm, st_z[blk[1, b]], rates[R_W_CUR], rates[R_F_CUR],
                          y, H, blk[2, b])  # fmt: skip
    for r in range(D):
        y[r] = y0[r]


@jit
def epoch(
    x: Array,
    P: Array,
    rates: Array,
    t_epoch: float,
    queue: IntArray,
    head: int,
    g: int,
    st_sensor: IntArray,
    st_z: Array,
    fb: Array,
    s_int: IntArray,
    s_flt: Array,
    s_state: Array,
    rings: Array,
    kind: int,
    reset: int,
    lg_int: IntArray,
    lg_flt: Array,
    n_ledger: int,
    ws: Workspace,
) -> int:
    """One stacked update at ``t_epoch`` with the g readings ``queue[head:head+g]`` (in queue
    order), in place.

    Per reading, in order (docs/filters.md, 'Epochs' to 'Gate'): a second reading of a sensor
    already at this epoch is dropped (duplicate); the reading is linearised at x (compiled, or
    the Python ``evaluate`` result in ``fb[k]``) and dropped if non-finite; its nominal R is the
    sensor's, or its own where the store row carries one (:func:`_reading_R`); the sensor's
    adaptation state is predicted over the time since its previous epoch (VB: ``ρ`` or
    ``ρ^(dt/T)``, paper eqs. (12), (13)); the gate, if any, tests it against
    ``S = H P Hᵀ + R_now``. The accepted blocks are stacked into one
    update (:func:`stacked_update`); x ← x ⊕ dx, P ← G P⁺ Gᵀ (``reset``: errorstate.RESET_*),
    symmetrised. Every reading's fate goes to the ledger tables from row ``n_ledger`` on
    (dropped and rejected as met, then the used ones with their NIS ``yᵀ S_i⁻¹ y``, S_i with
    the prior P and the R used). ``ws``: :func:`workspace` for at least ``len(s_int)``
    sensors.

    The divergence guard (docs/robustness.md; readable twin in :mod:`adaptnav.estimation.health`):
    before the gate, the guard (if on) tests the reading against ``S = H P Hᵀ + κ R_nominal`` and
    rejects it above its χ² threshold; a sensor rejected by it for ``F_LOCKOUT_S`` inflates P
    (:func:`_lockout`); each used reading feeds its sensor's windowed NIS test
    (:func:`_nis_window`); an S that is not positive definite rejects the epoch's readings and
    repairs P (:func:`_repair`), as does a non-positive variance after the update. Each of these
    writes an event row (code >= EVENT_NIS). Returns the new ledger length, or ``-(length + 1)`` if
    P was not finite (x and P then unchanged).
    """
    H, y, Rb, R_now, Ut3, S3 = (
        ws[WS_H],
        ws[WS_Y],
        ws[WS_RB],
        ws[WS_R_NOW],
        ws[WS_ROWS3],
        ws[WS_SMALL3],
    )
    M3, b3, cols, blk, seen = ws[WS_M3], ws[WS_B3], ws[WS_COLS], ws[WS_BLK], ws[WS_SEEN]
    prior = ws[WS_PRIOR]
    smooth = prior.shape[0] > 0
    if smooth:
        prior[0, 0] = math.nan
    for i in range(s_int.shape[0]):
        seen[i] = 0
    blk[2, 0] = 0
    # Read back, not the literal 0: typed from a literal, Numba would compile linearise and
    # stacked_update (and what they call) a second time for Literal[int](0) while it infers
    # this function's types, about a fifth of a cold start (bench/cold_bench.py).
    D = blk[2, 0]
    nb = D
    for k in range(g):
        idx = queue[head + k]
        i = st_sensor[idx]
        if seen[i] != 0:
            _ledger(lg_int, lg_flt, n_ledger, idx, LEDGER_DUPLICATE, t_epoch, math.nan,
                    math.nan, 0, y, 0, R_now, 0, 0)  # fmt: skip
            n_ledger += 1
            continue
        d = s_int[i, S_DIM]
        code = s_int[i, S_CODE]
        valid = True
        if code >= 0:
            for j in range(d):
                if not math.isfinite(st_z[idx, j]):
                    valid = False
            if valid:
                linearise(code, s_flt[i], x, st_z[idx], rates[R_W_CUR], rates[R_F_CUR], y, H, D)
                for a in range(d):
                    for c in range(d):
                        Rb[nb, a, c] = s_flt[i, F_RNOM + 3 * a + c]
                _reading_R(st_z, idx, d, Rb, nb)
        else:
            valid = fb[k, FB_VALID] != 0.0
            if valid:
                for a in range(d):
                    y[D + a] = fb[k, FB_Y + a]
                    for c in range(N_STATES):
                        H[D + a, c] = fb[k, FB_H + N_STATES * a + c]
                    for c in range(N_STATES, H.shape[1]):  # a Python model's H is the core's
                        H[D + a, c] = 0.0
                    for c in range(d):
                        Rb[nb, a, c] = fb[k, FB_R + 3 * a + c]
                _reading_R(st_z, idx, d, Rb, nb)
        if not valid:
            _ledger(lg_int, lg_flt, n_ledger, idx, LEDGER_INVALID, t_epoch, math.nan,
                    math.nan, 0, y, 0, R_now, 0, 0)  # fmt: skip
            n_ledger += 1
            continue
        seen[i] = 1
        last = s_state[i, X_LAST]
        if kind == KIND_VB:  # paper eqs. (12), (13) at the sensor's own epoch
            period = s_flt[i, F_PERIOD]
            dt_i = period if math.isnan(last) else t_epoch - last
            rho = s_flt[i, F_RHO]
            if s_flt[i, F_IRREGULAR] != 0.0 and period > 0:
                rho = rho ** (dt_i / period)
            for j in range(d):
                s_state[i, X_ALPHA + j] *= rho
                s_state[i, X_BETA + j] *= rho
            s_int[i, S_VERSION] += 1
        elif kind == KIND_MATCHING and not math.isnan(last):  # CovarianceMatching.predict
            period = s_flt[i, F_PERIOD]
            gap = s_flt[i, F_GAP]
            if gap > 0.0 and period > 0.0 and t_epoch - last > gap * period:
                s_int[i, S_COUNT] = 0
                s_int[i, S_VERSION] += 1
        s_state[i, X_LAST] = t_epoch
        if s_int[i, S_GUARD] != 0:  # χ² on S = H P Hᵀ + κ R_nominal: adaptation cannot open it
            Hb = H[D : D + d]
            nc = _active_columns(Hb, d, cols)
            _h_p(P, Hb, d, cols, nc, Ut3)
            _h_p_ht(Hb, Ut3, d, cols, nc, S3)
            kappa = s_flt[i, F_GUARD_K]
            w_tr = 0.0
            r_tr = 0.0
            for a in range(d):
                w_tr += S3[a, a]
                r_tr += kappa * Rb[nb, a, a]
                for c in range(d):
                    S3[a, c] += 0.5 * kappa * (Rb[nb, a, c] + Rb[nb, c, a])
            stat = _gate_statistic(GATE_CHI2, y, D, S3, d, M3, b3)
            q = s_flt[i, F_GUARD_Q]
            if not stat <= q:
                _ledger(lg_int, lg_flt, n_ledger, idx, LEDGER_REJECTED_GUARD, t_epoch, stat, q,
                        0, y, D, Rb[nb], 0, d)  # fmt: skip
                n_ledger += 1
                n_ledger = _lockout(P, s_flt[i], s_state[i], t_epoch, stat, q, w_tr, r_tr,
                                    lg_int, lg_flt, n_ledger, idx)  # fmt: skip
                continue
            s_state[i, X_REJ_SINCE] = math.nan
            s_state[i, X_PASSED] = t_epoch
            s_state[i, X_PASSED_STAT] = stat
        rule = s_int[i, S_GATE]
        if rule != GATE_NONE:
            nominal = kind == KIND_FIXED or s_int[i, S_GATE_REF] == GATE_REF_NOMINAL
            _current_R(KIND_FIXED if nominal else kind, s_state[i], Rb[nb], d, R_now, 0)
            Hb = H[D : D + d]  # S = H P Hᵀ + R_now of this block
            nc = _active_columns(Hb, d, cols)
            _h_p(P, Hb, d, cols, nc, Ut3)
            _h_p_ht(Hb, Ut3, d, cols, nc, S3)
            for a in range(d):
                for c in range(d):
                    S3[a, c] += 0.5 * (R_now[a, c] + R_now[c, a])
            stat = _gate_statistic(rule, y, D, S3, d, M3, b3)
            q = s_flt[i, F_GATE_Q]
            if not stat <= q:
                _ledger(lg_int, lg_flt, n_ledger, idx, rule, t_epoch, stat, q, 0, y, D,
                        R_now, 0, d)  # fmt: skip
                n_ledger += 1
                continue
        blk[0, nb] = i
        blk[1, nb] = idx
        D += d
        nb += 1
        blk[2, nb] = D
    if nb == 0:
        return n_ledger
    _midpoint(x, P, rates, D, nb, blk, st_z, s_int, s_flt, s_state, kind, ws)
    if smooth:  # the smoother's P⁻: after any inflation of this epoch, before the update
        for i in range(P.shape[0]):
            for j in range(P.shape[0]):
                prior[i, j] = P[i, j]
    iterations = stacked_update(
        kind, P, H, y, D, nb, blk[0], blk[2], Rb, s_int, s_flt, s_state, rings, ws
    )
    if iterations < 0:  # P has lost positive definiteness: no update, P repaired
        if smooth:
            prior[0, 0] = math.nan
        for b in range(nb):
            _ledger(lg_int, lg_flt, n_ledger, blk[1, b], LEDGER_REJECTED_SINGULAR, t_epoch,
                    math.nan, math.nan, 0, y, 0, R_now, 0, 0)  # fmt: skip
            n_ledger += 1
        if not _repair(P):
            return -(n_ledger + 1)
        _event(lg_int, lg_flt, n_ledger, blk[1, 0], EVENT_SINGULAR, t_epoch, math.nan,
               math.nan, 1.0)  # fmt: skip
        return n_ledger + 1
    dx, P_new, R_used, W = ws[WS_DX], ws[WS_P_NEW], ws[WS_R_USED], ws[WS_W]
    inject(x, dx)
    if reset != RESET_OFF:
        _reset(P_new, dx, Ut3, S3, reset)
    for i in range(P.shape[0]):  # P⁺ and its reset are exactly symmetric
        for j in range(P.shape[0]):
            P[i, j] = P_new[i, j]
    healthy = True
    for i in range(P.shape[0]):  # the Joseph form keeps P PD; rounding at extreme ranges may not
        if not P[i, i] > 0.0:
            healthy = False
    if not healthy:
        if not _repair(P):
            return -(n_ledger + 1)
        _event(lg_int, lg_flt, n_ledger, blk[1, 0], EVENT_SINGULAR, t_epoch, math.nan,
               math.nan, 1.0)  # fmt: skip
        n_ledger += 1
    if smooth:  # the node's P: before the windowed NIS test's inflation, if any (node_P)
        node = ws[WS_NODE_P]
        for i in range(P.shape[0]):
            for j in range(P.shape[0]):
                node[i, j] = P[i, j]
    for r in range(D):  # S with the prior P and the R used, for the NIS
        for c in range(D):
            W[r, c] += 0.5 * (R_used[r, c] + R_used[c, r])
    for b in range(nb):
        o = blk[2, b]
        d = blk[2, b + 1] - o
        nis = _quad_solve(W, o, d, y, o, M3, b3)
        _ledger(lg_int, lg_flt, n_ledger, blk[1, b], LEDGER_USED, t_epoch, nis, math.nan,
                iterations, y, o, R_used, o, d)  # fmt: skip
        n_ledger += 1
        i = blk[0, b]
        n_ledger = _nis_window(P, s_flt[i], s_state[i], t_epoch, nis / d, lg_int, lg_flt,
                               n_ledger, blk[1, b])  # fmt: skip
        if s_flt[i, F_QA_GAIN] > 0.0:
            n_ledger = _whiteness(rates, s_flt[i], s_state[i], t_epoch, W, y, o, d, lg_int,
                                  lg_flt, n_ledger, blk[1, b])  # fmt: skip
    return n_ledger


@jit
def node_P(P: Array, ws: Workspace) -> Array:
    """The P the smoother stores at an epoch's node (docs/smoothing.md, 'Inflations of P'):
    after an update, the P it left (:data:`WS_NODE_P`), so that an inflation by the windowed
    NIS test after it reaches the backward pass as process noise of the next interval,
    ``P⁻_{j+1} = Φ (k P_j) Φᵀ + Q``, not as the filtered covariance at the node (RTS, Särkkä
    2013 eq. 8.6, holds only for the P its update left); else (no update) the current P, with
    a lockout's inflation in it, which the interval before carries the same way."""
    prior = ws[WS_PRIOR]
    if prior.shape[0] > 0 and not math.isnan(prior[0, 0]):
        return ws[WS_NODE_P]
    return P


# --- the divergence guard (twins in adaptnav.estimation.health)
# --------------------------------------------


@jit
def _repair(P: Array) -> bool:
    """P ← the nearest symmetric positive definite matrix by eigenvalues clipped at
    ``EIG_FLOOR`` × the largest (twin of health.repair); False if P is not finite."""
    n = P.shape[0]
    for a in range(n):
        for c in range(n):
            if not math.isfinite(P[a, c]):
                return False
    Ps = 0.5 * (P + P.T)
    w, V = np.linalg.eigh(Ps)
    floor = max(w[-1], 0.0) * EIG_FLOOR
    if not floor > 0.0:
        return False
    for k in range(n):
        w[k] = max(w[k], floor)
    for a in range(n):
        for c in range(n):
            t = 0.0
            for k in range(n):
                t += V[a, k] * w[k] * V[c, k]
            P[a, c] = t
    for a in range(n):
        for c in range(a + 1, n):
            P[c, a] = P[a, c]
    return True


@jit_inline
def lockout_factor(stat: float, q: float, w_tr: float, r_tr: float, k_max: float) -> float:
    """The factor k of P that brings a reading rejected with statistic ``stat`` > q back to
    the threshold, with S's traces W = tr(H P Hᵀ), R = tr(R) standing for its size
    (``stat (W + R) / (k W + R) = q``), at least MIN_LOCKOUT_FACTOR and at most ``k_max`` (twin of
    health.lockout_factor; docs/robustness.md)."""
    k = (stat * (w_tr + r_tr) / q - r_tr) / max(w_tr, 1e-300)
    return min(max(k, MIN_LOCKOUT_FACTOR), k_max)


@jit_inline
def _lockout(
    P: Array,
    sf: Array,
    sx: Array,
    t: float,
    stat: float,
    q: float,
    w_tr: float,
    r_tr: float,
    lg_int: IntArray,
    lg_flt: Array,
    n_ledger: int,
    idx: int,
) -> int:
    """After a guard rejection: a sensor rejected at every epoch for ``F_LOCKOUT_S`` or more
    means the filter, not the sensor, has most likely gone wrong (a sensor fault that long is
    what stuck-reading and plausibility checks catch): P is inflated so that this reading
    would pass (:func:`lockout_factor`) and an EVENT_LOCKOUT row written. The sensor stays
    locked out until one of its readings passes (which clears ``X_REJ_SINCE``): each further
    rejection inflates P again, so a divergence larger than one step's cap is caught up at the
    sensor's rate, not one cap per ``F_LOCKOUT_S``. Returns the ledger length."""
    since = sx[X_REJ_SINCE]
    if math.isnan(since):  # the streak's first rejection: a step? (twin: health.is_step)
        sx[X_REJ_SINCE] = t
        passed = sx[X_PASSED]
        recent = not math.isnan(passed) and t - passed <= STEP_PERIODS * sf[F_PERIOD]
        sx[X_STEP] = 1.0 if recent and stat > STEP_RATIO * sx[X_PASSED_STAT] else 0.0
        return n_ledger
    lockout = sf[F_LOCKOUT_S]
    wait = lockout * (STEP_PATIENCE if sx[X_STEP] > 0.0 else 1.0)  # health.lockout_wait
    if not (lockout > 0.0 and t - since >= wait):
        return n_ledger
    k = lockout_factor(stat, q, w_tr, r_tr, sf[F_LOCKOUT_MAX])
    _inflate(P, k)
    _event(lg_int, lg_flt, n_ledger, idx, EVENT_LOCKOUT, t, t - since, lockout, k)
    return n_ledger + 1


@jit_inline
def _nis_window(
    P: Array,
    sf: Array,
    sx: Array,
    t: float,
    ratio: float,
    lg_int: IntArray,
    lg_flt: Array,
    n_ledger: int,
    idx: int,
) -> int:
    """The windowed NIS test after a used reading with ``ratio = NIS/d``: the mean of the
    ratios over the sensor's last ``F_DIV_WINDOW`` used readings (a running mean until the
    window is full, then an exponential one of that length) above ``F_DIV_NIS`` means P is too
    small for what the sensor sees: P ← k P with k the mean ratio (at most ``F_INFLATE_MAX``),
    an EVENT_NIS row, the window restarted (twin of health.NisWindow). Returns the ledger
    length."""
    threshold = sf[F_DIV_NIS]
    if not threshold > 0.0:
        return n_ledger
    count = sx[X_NIS_N] + 1.0
    sx[X_NIS] += (ratio - sx[X_NIS]) / min(count, sf[F_DIV_WINDOW])
    sx[X_NIS_N] = count
    if count < sf[F_DIV_WINDOW] or not sx[X_NIS] > threshold:
        return n_ledger
    k = min(sx[X_NIS], sf[F_INFLATE_MAX])
    _inflate(P, k)
    _event(lg_int, lg_flt, n_ledger, idx, EVENT_NIS, t, sx[X_NIS], threshold, k)
    sx[X_NIS] = 0.0
    sx[X_NIS_N] = 0.0
    return n_ledger + 1


@jit_inline
def _whiteness(
    rates: Array,
    sf: Array,
    sx: Array,
    t: float,
    W: Array,
    y: Array,
    o: int,
    d: int,
    lg_int: IntArray,
    lg_flt: Array,
    n_ledger: int,
    idx: int,
) -> int:
    """Q adaptation after a used reading (twin of noise.process.whiteness_step): the running
    means c0 (of ``(ν̃_j(k)² + ν̃_j(k-1)²)/2``) and c1 (of ``ν̃_j(k) ν̃_j(k-1)``), summed over j,
    of the normalised innovation ``ν̃_j = y_j / sqrt(W_jj)`` (W: S with the prior P and the R
    used, rows ``o..o+d``) over consecutive readings, then ``β ← clip(β exp(g (c1/c0 -
    ρ₀)), 1, β_max)`` in ``rates[R_Q, 0]``; an EVENT_Q row when β has moved by EVENT_STEP
    since the last one. Returns the ledger length."""
    paired = not math.isnan(sx[X_WT]) and t - sx[X_WT] <= GAP_PERIODS * sf[F_PERIOD]
    c0 = 0.0
    c1 = 0.0
    for j in range(d):
        v = y[o + j] / math.sqrt(W[o + j, o + j])
        prev = sx[X_WPREV + j]
        c0 += 0.5 * (v * v + prev * prev)
        c1 += v * prev
        sx[X_WPREV + j] = v
    sx[X_WT] = t
    if not paired:
        return n_ledger
    pairs = sx[X_WN] + 1.0
    sx[X_WN] = pairs
    m = min(pairs, sf[F_QA_WINDOW])
    sx[X_WC0] += (c0 - sx[X_WC0]) / m
    sx[X_WC1] += (c1 - sx[X_WC1]) / m
    if pairs < sf[F_QA_WINDOW] or not sx[X_WC0] > 0.0:
        return n_ledger
    rho = sx[X_WC1] / sx[X_WC0]
    beta = rates[R_Q, 0] * math.exp(sf[F_QA_GAIN] * (rho - sf[F_QA_TARGET]))
    beta = min(max(beta, 1.0), sf[F_QA_MAX])
    rates[R_Q, 0] = beta
    last = rates[R_Q, 1]
    if beta >= EVENT_STEP * last or beta * EVENT_STEP <= last:
        rates[R_Q, 1] = beta
        _event(lg_int, lg_flt, n_ledger, idx, EVENT_Q, t, rho, sf[F_QA_TARGET], beta)
        return n_ledger + 1
    return n_ledger


# --- one propagation (sub)step, for the engine's compiled loop --------------------------------

Work = tuple[Array, Array, Array, Array, int]
"""The work arrays of compiled.propagation._work: Aᵀ (the block's sum), Φᵀ, M, padded P (rows
of 16), n = 16."""


@jit_inline
def step(
    state: State,
    ref: LatRef,
    wk: Work,
    wp: Vec3,
    fp: Vec3,
    wc: Vec3,
    fc: Vec3,
    dt: float,
    ta: float,
    tb: float,
    decay: tuple[float, float, float],
    inv_tau: tuple[float, float],
    q_psd: Array,
    f_lp: Array,
    N: Array,
) -> State:
    """Propagate over [ta, tb] of an interval of length dt: the body of the loop of
    compiled.propagation._propagate (``propagate_run``: ta = 0, tb = dt; ``propagate_partial``)
    on the state tuple, the step's ``F T`` added to the block's sum in ``wk`` and its ``½ S T``
    to ``N``; the covariance itself moves when the caller closes the block
    (compiled.propagation._flush; docs/filters.md, 'Covariance blocks'). ``wp``, ``fp`` / ``wc``,
    ``fc``: raw mean rates of the previous / current interval; ``decay = (exp(-T/τ_a),
    exp(-T/τ_g), exp(-T/τ_f))`` for ``T = tb - ta`` (the last 0 when τ_f = 0); ``inv_tau =
    (1/τ_a, 1/τ_g)``; ``f_lp``: the low-passed specific force of F
    (compiled.propagation._low_pass), in place."""
    At = wk[0]
    T = tb - ta
    state, e, h, v, C, f = _strapdown(state, ref, wp, fp, wc, fc, dt, ta, tb, decay[0], decay[1])
    f = _low_pass(f_lp, f, decay[2])
    _fill_At(At, e, h, v, C, f, inv_tau[0], inv_tau[1], T)
    _add_half_noise(N, C, q_psd, T)
    return state
