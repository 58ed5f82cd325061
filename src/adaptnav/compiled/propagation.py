"""Compiled IMU-rate propagation: nominal state and 15×15 covariance.

Numba twins of :mod:`adaptnav.models.strapdown` (mechanization) and
:mod:`adaptnav.models.errorstate` (F, Φ = I + F T + (F T)²/2, Qd = ½ (Φ S Φᵀ + S) T with S = G Q Gᵀ,
P ← Φ P Φᵀ + Qd; docs/mechanization.md and docs/filters.md, 'Propagation', paper eqs. (10), (11));
:mod:`adaptnav.engine.propagation` holds the readable NumPy loop and copying wrappers, and
``tests/kernels/test_kernels.py`` holds the two equal to 1e-9. The same equations, no term dropped,
evaluated faster:

* 3-vectors, quaternions and 3×3 matrices are tuples of floats (registers, no allocation);
  the work arrays are allocated once per call, outside the sample loop;
* sin/cos of the latitudes inside a step come from those of a nearby reference latitude by
  the angle-addition formula and Taylor series of the offset, Exp and the rotation
  compensation from their Taylor series at small angles (libm beyond); all truncated below
  1e-17 relative, i.e. exact in double precision;
* F is written entry by entry, only its structural nonzeros; Φ (as Φᵀ, whose rows are then
  contiguous) sums only over F's nonzero 3×3 blocks, and rows 9-14 of F and Φ are diagonal;
* the covariance is ``Φ (P + ½ S T) Φᵀ + ½ S T`` (the same sum as Φ P Φᵀ + Qd): ``M = Φ P̃``
  for Φ's 9 non-diagonal rows, the lower triangle of ``M Φᵀ``, the bias columns and block from
  Φ's diagonal there, and a mirror, so P stays exactly symmetric;
* the dense loops run over columns padded to 16 with a run-time trip count, so LLVM
  vectorizes them (4 doubles per instruction; ``fastmath`` stays off, results are IEEE);
  the helpers that touch the work arrays are inlined by Numba (``inline="always"``).

Everything is ``numba.njit(cache=True, fastmath=False)``. Public compiled entry points:
:func:`propagate_run` and :func:`propagate_partial`; both update their arguments in place and
check no shapes (the wrappers in :mod:`adaptnav.engine.propagation` do).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

from adaptnav.core.earth import (
    E2,
    FLATTENING,
    G_EQUATOR,
    GM,
    K_SOMIGLIANA,
    OMEGA_IE,
    A,
    B,
)

Array = NDArray[np.float64]
Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Mat3 = tuple[float, float, float, float, float, float, float, float, float]  # row-major

_Fn = TypeVar("_Fn", bound=Callable[..., Any])


def jit(fn: _Fn) -> _Fn:
    """``numba.njit(cache=True, fastmath=False)``, typed for mypy."""
    return cast(_Fn, njit(cache=True, fastmath=False)(fn))


def jit_nogil(fn: _Fn) -> _Fn:
    """:func:`jit` that releases the GIL while it runs: for the engine's whole loop, so that
    another thread's Python goes on meanwhile (analysis.compare runs filters in threads)."""
    return cast(_Fn, njit(cache=True, fastmath=False, nogil=True)(fn))


def jit_inline(fn: _Fn) -> _Fn:
    """:func:`jit` inlined by Numba into its callers (no call, no array reference counting)."""
    return cast(_Fn, njit(cache=True, fastmath=False, inline="always")(fn))


# Note: numba freezes these module constants into its on-disk cache; the cache is keyed on this
# file, so touch it (or clear __pycache__) if the earth constants ever change.
_M_HEIGHT = OMEGA_IE**2 * A**2 * B / GM  # = earth._M_HEIGHT

_SERIES_LAT = 1e-4  # |Δlat| (rad) below which sin/cos(lat0 + Δ) use the series (err < Δ⁴/24)
_SERIES_ROT = 1e-2  # |angle|² (rad²) below which Exp and rotation compensation use series

# --- 3-vector, quaternion and DCM algebra (twins of adaptnav.core.attitude)
# --------------------------


@jit
def _add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@jit
def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@jit
def _scale(a: Vec3, s: float) -> Vec3:
    return (a[0] * s, a[1] * s, a[2] * s)


@jit
def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def _cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def _matvec(C: Mat3, v: Vec3) -> Vec3:
    return (
        C[0] * v[0] + C[1] * v[1] + C[2] * v[2],
        C[3] * v[0] + C[4] * v[1] + C[5] * v[2],
        C[6] * v[0] + C[7] * v[1] + C[8] * v[2],
    )


@jit
def _quat_mult(p: Quat, q: Quat) -> Quat:
    """Hamilton product ``p ⊗ q`` (twin of attitude.quat_mult)."""
    return (
        p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
        p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
        p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
        p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0],
    )


@jit
def _quat_to_dcm(q: Quat) -> Mat3:
    """Twin of attitude.quat_to_dcm (Groves 2.34)."""
    w, x, y, z = q
    return (
        w * w + x * x - y * y - z * z,
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        w * w - x * x + y * y - z * z,
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    )


@jit
def _rotvec_to_quat(a: Vec3) -> Quat:
    """``Exp(a) = [cos(|a|/2), sin(|a|/2) a/|a|]`` (twin of attitude.rotvec_to_quat).

    Below |a|² = 1e-2 the Taylor series in u = |a|²/4, truncated after u⁴ (remainder < 3e-20).
    """
    a2 = _dot(a, a)
    if a2 < _SERIES_ROT:
        u = 0.25 * a2
        cw = 1.0 - u * (1.0 / 2.0 - u * (1.0 / 24.0 - u * (1.0 / 720.0 - u * (1.0 / 40320.0))))
        sv = 0.5 - u * (1.0 / 12.0 - u * (1.0 / 240.0 - u * (1.0 / 10080.0 - u * (1.0 / 725760.0))))
    else:
        angle = math.sqrt(a2)
        cw = math.cos(0.5 * angle)
        sv = math.sin(0.5 * angle) / angle
    return (cw, a[0] * sv, a[1] * sv, a[2] * sv)


# --- earth model (twins of adaptnav.core.earth)
# ------------------------------------------------------

LatRef = tuple[float, float, float]
"""(lat, sin lat, cos lat) by libm at a reference latitude within 1e-4 rad of the step."""
Earth = tuple[float, float, float, float, float, float, float]
"""Earth terms at (lat, h): sin L, cos L, 1/sqrt(1 - e² sin² L), R_M, R_N, 1/(R_M+h), 1/(R_N+h)."""


@jit
def _lat_ref(lat: float) -> LatRef:
    """A new reference latitude for :func:`_sincos` (libm)."""
    return (lat, math.sin(lat), math.cos(lat))


@jit
def _sincos(ref: LatRef, lat: float) -> tuple[float, float]:
    """sin and cos of ``lat`` from those of the reference latitude (exact to double precision).

    ``sin(L0 + d) = sin L0 cos d + cos L0 sin d``; for |d| < 1e-4 rad the series of cos d and
    sin d to d⁴ and d³ leave < 1e-17 relative; farther away, libm.
    """
    d = lat - ref[0]
    if abs(d) >= _SERIES_LAT:
        return math.sin(lat), math.cos(lat)
    d2 = d * d
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0))
    sd = d - d * d2 * (1.0 / 6.0)
    return ref[1] * cd + ref[2] * sd, ref[2] * cd - ref[1] * sd


@jit
def _earth(ref: LatRef, lat: float, h: float) -> Earth:
    """Radii of curvature and reciprocals at (lat, h) (earth.meridian_/transverse_radius)."""
    s, c = _sincos(ref, lat)
    isq = 1.0 / math.sqrt(1.0 - E2 * s * s)
    RM = A * (1.0 - E2) * (isq * isq * isq)
    RN = A * isq
    return s, c, isq, RM, RN, 1.0 / (RM + h), 1.0 / (RN + h)


@jit
def _rates(e: Earth, v: Vec3) -> tuple[Vec3, Vec3]:
    """ω_ie and ω_en in NED (twins of earth.earth_rate_n, earth.transport_rate_n)."""
    s, c, _, _, _, irm, irn = e
    return (OMEGA_IE * c, 0.0, -OMEGA_IE * s), (v[1] * irn, -v[0] * irm, -v[1] * (s / c) * irn)


@jit
def _gravity(e: Earth, h: float) -> float:
    """Normal gravity g(L, h) (twin of earth.gravity: Somigliana + height correction)."""
    s2 = e[0] * e[0]
    g0 = G_EQUATOR * (1.0 + K_SOMIGLIANA * s2) * e[2]
    k_h = 1.0 + FLATTENING + _M_HEIGHT - 2.0 * FLATTENING * s2
    return g0 * (1.0 - 2.0 * h * k_h * (1.0 / A) + 3.0 * (h * h) * (1.0 / (A * A)))


# --- strapdown mechanization (twin of strapdown.compensate / mechanize / propagate) -------------


@jit
def _rotation_compensation(alpha: Vec3, dv: Vec3) -> Vec3:
    """``ν = Δv + c1 α×Δv + c2 α×(α×Δv)`` (twin of strapdown._rotation_compensation).

    c1 = (1 - cos a)/a², c2 = (1 - sin a/a)/a²; below a² = 1e-2 their Taylor series to a⁸
    (remainder < 3e-19).
    """
    a2 = _dot(alpha, alpha)
    if a2 < _SERIES_ROT:
        c1 = 0.5 - a2 * (
            1.0 / 24.0 - a2 * (1.0 / 720.0 - a2 * (1.0 / 40320.0 - a2 * (1.0 / 3628800.0)))
        )
        c2 = 1.0 / 6.0 - a2 * (
            1.0 / 120.0 - a2 * (1.0 / 5040.0 - a2 * (1.0 / 362880.0 - a2 * (1.0 / 39916800.0)))
        )
    else:
        a = math.sqrt(a2)
        c1 = (1.0 - math.cos(a)) / a2
        c2 = (1.0 - math.sin(a) / a) / a2
    ax = _cross(alpha, dv)
    return _add(_add(dv, _scale(ax, c1)), _scale(_cross(alpha, ax), c2))


@jit
def _compensate(
    w_prev: Vec3, f_prev: Vec3, w_cur: Vec3, f_cur: Vec3, dt: float, ta: float, tb: float
) -> tuple[Vec3, Vec3]:
    """α and ν over [ta, tb] under the linear-rate model (twin of strapdown.compensate)."""
    T = tb - ta
    inv_dt = 1.0 / dt
    b = _scale(_sub(w_cur, w_prev), inv_dt)
    d = _scale(_sub(f_cur, f_prev), inv_dt)
    mid_offset = 0.5 * (ta + tb) - 0.5 * dt
    dtheta = _scale(_add(w_cur, _scale(b, mid_offset)), T)
    dvel = _scale(_add(f_cur, _scale(d, mid_offset)), T)
    a = _add(w_cur, _scale(b, ta - 0.5 * dt))
    c = _add(f_cur, _scale(d, ta - 0.5 * dt))
    T3 = T * T * T * (1.0 / 12.0)
    alpha = _add(dtheta, _scale(_cross(a, b), T3))
    sculling = _scale(_add(_cross(a, d), _cross(c, b)), T3)
    return alpha, _add(_rotation_compensation(dtheta, dvel), sculling)


@jit
def _velocity(v0: Vec3, dv_n: Vec3, T: float, e: Earth, h: float, v: Vec3) -> Vec3:
    """``v1 = v0 + C ν - ½ (ω_in × C ν) T + (g - (2ω_ie + ω_en) × v) T`` (strapdown.mechanize).

    The earth terms are taken at (lat, h, v) with ``e = _earth(ref, lat, h)``.
    """
    wie, wen = _rates(e, v)
    dv_f = _sub(dv_n, _scale(_cross(_add(wie, wen), dv_n), 0.5 * T))
    cor = _cross(_add(_scale(wie, 2.0), wen), v)
    return _add(_add(v0, dv_f), _scale((-cor[0], -cor[1], _gravity(e, h) - cor[2]), T))


State = tuple[float, float, float, Vec3, Quat, Vec3, Vec3]
"""The nominal state as tuples: (lat, lon, h, v_n, q_nb, b_a, b_g)."""


@jit
def _load(x: Array) -> State:
    return (
        x[0],
        x[1],
        x[2],
        (x[3], x[4], x[5]),
        (x[6], x[7], x[8], x[9]),
        (x[10], x[11], x[12]),
        (x[13], x[14], x[15]),
    )


@jit
def _store(x: Array, s: State) -> None:
    x[0], x[1], x[2] = s[0], s[1], s[2]
    x[3], x[4], x[5] = s[3]
    x[6], x[7], x[8], x[9] = s[4]
    x[10], x[11], x[12] = s[5]
    x[13], x[14], x[15] = s[6]


@jit
def _strapdown(
    state: State,
    ref: LatRef,
    w_prev: Vec3,
    f_prev: Vec3,
    w_cur: Vec3,
    f_cur: Vec3,
    dt: float,
    ta: float,
    tb: float,
    decay_a: float,
    decay_g: float,
) -> tuple[State, Earth, float, Vec3, Mat3, Vec3]:
    """Propagate the nominal state over [ta, tb] (twin of strapdown.propagate).

    Rates are raw; biases decay by the factors ``decay_* = exp(-T/τ_*)``. Velocity and position
    by one predictor-corrector pass with the earth terms at the interval's midpoint, position by
    the trapezoid (Groves 5.56), ``q⁺ = Exp(-ω_in T) ⊗ q⁻ ⊗ Exp(α)``. Returns the new state and
    the midpoint values for F: (earth terms, h, v_n, C_nb = C(q⁻ ⊗ Exp(α/2)), f_n = C_nb⁻ ν/T).
    """
    T = tb - ta
    lat0, lon0, h0, v0, q0, b_a, b_g = state
    alpha, nu = _compensate(
        _sub(w_prev, b_g), _sub(f_prev, b_a), _sub(w_cur, b_g), _sub(f_cur, b_a), dt, ta, tb
    )
    dv_n = _matvec(_quat_to_dcm(q0), nu)

    e0 = _earth(ref, lat0, h0)
    v1 = _velocity(v0, dv_n, T, e0, h0, v0)  # predictor, earth terms at the start
    for corrector in (True, False):
        h1 = h0 - 0.5 * (v0[2] + v1[2]) * T
        lat1 = lat0 + 0.5 * (v0[0] * e0[5] + v1[0] / (e0[3] + h1)) * T
        latm, hm, vm = 0.5 * (lat0 + lat1), 0.5 * (h0 + h1), _scale(_add(v0, v1), 0.5)
        em = _earth(ref, latm, hm)
        if corrector:  # velocity again with the earth terms at the midpoint
            v1 = _velocity(v0, dv_n, T, em, hm, vm)
    s1, c1 = _sincos(ref, lat1)
    RN1 = A / math.sqrt(1.0 - E2 * s1 * s1)
    lon1 = lon0 + 0.5 * (v0[1] / ((e0[4] + h0) * e0[1]) + v1[1] / ((RN1 + h1) * c1)) * T

    wie, wen = _rates(em, vm)
    w_in = _add(wie, wen)
    q1 = _quat_mult(_quat_mult(_rotvec_to_quat(_scale(w_in, -T)), q0), _rotvec_to_quat(alpha))
    inv_n = 1.0 / math.sqrt(q1[0] * q1[0] + q1[1] * q1[1] + q1[2] * q1[2] + q1[3] * q1[3])
    q1 = (q1[0] * inv_n, q1[1] * inv_n, q1[2] * inv_n, q1[3] * inv_n)
    new = (lat1, lon1, h1, v1, q1, _scale(b_a, decay_a), _scale(b_g, decay_g))
    Cm = _quat_to_dcm(_quat_mult(q0, _rotvec_to_quat(_scale(alpha, 0.5))))
    return new, em, hm, vm, Cm, _scale(dv_n, 1.0 / T)


# --- error-state transition and covariance (twins of errorstate) --------------------------------
# Work arrays are flat, row-major with the fixed row stride _W = 16 (15 states + 1 pad). Column
# loops run to a width n known only at run time, so that LLVM vectorizes them (4 doubles per
# instruction) instead of unrolling them.

_W = 16


@jit_inline
def _set(At: Array, i: int, j: int, value: float) -> None:
    """Add ``F[i, j] T`` (value) to ``A[i, j]`` in the transposed flat array At. (Inlined:
    called, it was compiled once for each pair of literal indices, 16 times.)"""
    At[j * _W + i] += value


@jit_inline
def _fill_At(
    At: Array,
    e: Earth,
    h: float,
    v: Vec3,
    C: Mat3,
    f: Vec3,
    inv_tau_a: float,
    inv_tau_g: float,
    T: float,
) -> None:
    """``Aᵀ += (F T)ᵀ`` in At, F as errorstate.system_matrix at the step's midpoint.

    Only F's structural nonzeros are touched, so At holds the sum ``A = Σ F_k T_k`` of the steps
    since it was last zeroed (:func:`_flush`): one step's A when the covariance is propagated
    every step, a block's otherwise (docs/filters.md, 'Covariance blocks').
    """
    s, c, isq, _, _, irm, irn = e
    ic = 1.0 / c
    t = s * ic
    sc = s * c
    isq3 = isq * isq * isq
    drn = A * E2 * sc * isq3  # dR_N/dL
    drm = 3.0 * A * (1.0 - E2) * E2 * sc * (isq3 * isq * isq)  # dR_M/dL
    vn, ve, vd = v
    irm2, irn2 = irm * irm, irn * irn
    # earth and transport rates and their partials (errorstate._rate_sensitivities)
    wie, wen = _rates(e, v)
    wie_L = (-OMEGA_IE * s, 0.0, -OMEGA_IE * c)
    wen_L = (-ve * drn * irn2, vn * drm * irm2, -ve * (ic * ic * irn - t * drn * irn2))
    wen_h = (-ve * irn2, vn * irm2, ve * t * irn2)
    # gravity gradient (earth.gravity_gradient)
    s2 = s * s
    g0 = G_EQUATOR * (1.0 + K_SOMIGLIANA * s2) * isq
    dg0 = G_EQUATOR * (2.0 * K_SOMIGLIANA * sc * isq + (1.0 + K_SOMIGLIANA * s2) * E2 * sc * isq3)
    k_h = 1.0 + FLATTENING + _M_HEIGHT - 2.0 * FLATTENING * s2
    corr = 1.0 - 2.0 * h * k_h * (1.0 / A) + 3.0 * (h * h) * (1.0 / (A * A))
    g_L = dg0 * corr + g0 * (8.0 * FLATTENING * h * sc * (1.0 / A))
    g_h = g0 * (-2.0 * k_h * (1.0 / A) + 6.0 * h * (1.0 / (A * A)))

    # position rows: F_rr, I
    _set(At, 0, 0, -vd * irm * T)
    _set(At, 0, 2, vn * irm * T)
    _set(At, 1, 0, ve * (t - drn * irn) * irm * T)
    _set(At, 1, 1, (drn * vn * irm * irn - vd * irn - t * vn * irm) * T)
    _set(At, 1, 2, ve * irn * T)
    for i in range(3):
        _set(At, i, 3 + i, T)
    # velocity rows: [v×] d(2ω_ie + ω_en)/d(dr) + dg/d(dr) (columns dr_N, dr_D; dr_E is zero),
    # -[(2ω_ie + ω_en)×] + [v×] dω_en/dv, -[f×], -C_nb
    cor_N = _cross(v, _scale(_add(_scale(wie_L, 2.0), wen_L), irm))
    cor_D = _cross(v, _scale(wen_h, -1.0))
    w2 = _add(_scale(wie, 2.0), wen)
    sv_N = _cross(v, (0.0, -irm, 0.0))
    sv_E = _cross(v, (irn, 0.0, -t * irn))
    skew_w2 = ((0.0, w2[2], -w2[1]), (-w2[2], 0.0, w2[0]), (w2[1], -w2[0], 0.0))
    skew_f = ((0.0, f[2], -f[1]), (-f[2], 0.0, f[0]), (f[1], -f[0], 0.0))
    for i in range(2):  # row 5 adds the gravity gradient below
        _set(At, 3 + i, 0, cor_N[i] * T)
        _set(At, 3 + i, 2, cor_D[i] * T)
    for i in range(3):
        _set(At, 3 + i, 3, (sv_N[i] + skew_w2[i][0]) * T)
        _set(At, 3 + i, 4, (sv_E[i] + skew_w2[i][1]) * T)
        _set(At, 3 + i, 5, skew_w2[i][2] * T)
        for j in range(3):
            _set(At, 3 + i, 6 + j, skew_f[i][j] * T)
            _set(At, 3 + i, 9 + j, -C[3 * i + j] * T)
    _set(At, 5, 0, (cor_N[2] + g_L * irm) * T)
    _set(At, 5, 2, (cor_D[2] - g_h) * T)
    # attitude rows: -d(ω_ie + ω_en)/d(dr), -dω_en/dv, -[ω_in×], -C_nb
    win = _add(wie, wen)
    skew_win = ((0.0, win[2], -win[1]), (-win[2], 0.0, win[0]), (win[1], -win[0], 0.0))
    for i in range(3):
        _set(At, 6 + i, 0, -(wie_L[i] + wen_L[i]) * irm * T)
        _set(At, 6 + i, 2, wen_h[i] * T)
        for j in range(3):
            _set(At, 6 + i, 6 + j, skew_win[i][j] * T)
            _set(At, 6 + i, 12 + j, -C[3 * i + j] * T)
    _set(At, 6, 4, -irn * T)
    _set(At, 7, 3, irm * T)
    _set(At, 8, 4, t * irn * T)
    # Gauss-Markov biases
    for i in range(3):
        _set(At, 9 + i, 9 + i, -inv_tau_a * T)
        _set(At, 12 + i, 12 + i, -inv_tau_g * T)


@jit_inline
def _fill_PhiT(PhiT: Array, At: Array, n: int) -> None:
    """``Φᵀ = I + Aᵀ + (Aᵀ)²/2`` (twin of errorstate.transition); n = 12 (columns 0-11).

    Row k of (Aᵀ)² sums over the l where A[l, k] ≠ 0: rows 0-8 for the r and v columns, 3-8
    for phi, 3-5 (+ the diagonal) for b_a, 6-8 (+ diagonal) for b_g. Columns 12-14 of Φᵀ hold
    only its diagonal (rows 12-14 of Φ are diagonal), set at the end.
    """
    for k in range(6):
        for j in range(n):
            s = 0.0
            for m in range(9):
                s += At[k * _W + m] * At[m * _W + j]
            PhiT[k * _W + j] = At[k * _W + j] + 0.5 * s
    for k in range(6, 9):
        for j in range(n):
            s = 0.0
            for m in range(3, 9):
                s += At[k * _W + m] * At[m * _W + j]
            PhiT[k * _W + j] = At[k * _W + j] + 0.5 * s
    for k in range(9, 12):
        for j in range(n):
            s = At[k * _W + k] * At[k * _W + j]
            for m in range(3, 6):
                s += At[k * _W + m] * At[m * _W + j]
            PhiT[k * _W + j] = At[k * _W + j] + 0.5 * s
    for k in range(12, 15):
        for j in range(n):
            s = At[k * _W + k] * At[k * _W + j]
            for m in range(6, 9):
                s += At[k * _W + m] * At[m * _W + j]
            PhiT[k * _W + j] = At[k * _W + j] + 0.5 * s
    for k in range(12):
        PhiT[k * _W + k] += 1.0
    for k in range(12, 15):
        a = At[k * _W + k]
        PhiT[k * _W + k] = 1.0 + a + 0.5 * (a * a)


N_NOISE_ACC = 24
"""Length of a noise accumulator: ``½ Σ S_k T_k`` by blocks, velocity (9, row-major), attitude (9),
the biases' diagonal (6)."""


@jit
def _congruence(C: Mat3, d0: float, d1: float, d2: float) -> Mat3:
    """``C diag(d) Cᵀ`` (symmetric)."""
    m00 = C[0] * C[0] * d0 + C[1] * C[1] * d1 + C[2] * C[2] * d2
    m10 = C[3] * C[0] * d0 + C[4] * C[1] * d1 + C[5] * C[2] * d2
    m11 = C[3] * C[3] * d0 + C[4] * C[4] * d1 + C[5] * C[5] * d2
    m20 = C[6] * C[0] * d0 + C[7] * C[1] * d1 + C[8] * C[2] * d2
    m21 = C[6] * C[3] * d0 + C[7] * C[4] * d1 + C[8] * C[5] * d2
    m22 = C[6] * C[6] * d0 + C[7] * C[7] * d1 + C[8] * C[8] * d2
    return (m00, m10, m20, m10, m11, m21, m20, m21, m22)


@jit_inline
def _add_half_noise(N: Array, C: Mat3, q: Array, T: float) -> None:
    """``N += ½ S T`` with S = G Q Gᵀ (errorstate.noise_input_matrix) at the step's attitude:
    its blocks C diag(q_a) Cᵀ (velocity), C diag(q_g) Cᵀ (attitude) and diag(q_ba, q_bg)
    (biases), in the layout of :data:`N_NOISE_ACC`."""
    hT = 0.5 * T
    a = _congruence(C, q[0] * hT, q[1] * hT, q[2] * hT)
    g = _congruence(C, q[3] * hT, q[4] * hT, q[5] * hT)
    for k in range(9):
        N[k] += a[k]
        N[9 + k] += g[k]
    for k in range(6):
        N[18 + k] += q[6 + k] * hT


@jit_inline
def _add_noise(Pw: Array, N: Array) -> None:
    """``P += N`` for the block-diagonal N of :func:`_add_half_noise`."""
    for i in range(3):
        for j in range(3):
            Pw[(3 + i) * _W + 3 + j] += N[3 * i + j]
            Pw[(6 + i) * _W + 6 + j] += N[9 + 3 * i + j]
    for a in range(6):
        Pw[(9 + a) * _W + 9 + a] += N[18 + a]


@jit_inline
def _covariance_step(Pw: Array, PhiT: Array, M: Array, N: Array, n: int) -> None:
    """``P ← Φ P Φᵀ + ½ (Φ S Φᵀ + S) T`` in place (twin of discrete_noise, predict_covariance),
    ``N = ½ S T`` (:func:`_add_half_noise`).

    Evaluated as ``Φ P̃ Φᵀ + N`` with ``P̃ = P + N``: ``M = Φ_{0:9} P̃`` (row block r
    of Φ is zero in the b_g columns); the lower triangle of rows 0-8 of ``M Φᵀ`` in column
    blocks of n/4 = 4; the bias columns ``M D`` and the bias block ``D P̃ D`` (Φ = D there,
    diagonal); then mirrored. n = 16.
    """
    _add_noise(Pw, N)
    for i in range(3):
        for j in range(n):
            s = 0.0
            for k in range(12):
                s += PhiT[k * _W + i] * Pw[k * _W + j]
            M[i * _W + j] = s
    for i in range(3, 9):
        for j in range(n):
            s = 0.0
            for k in range(15):
                s += PhiT[k * _W + i] * Pw[k * _W + j]
            M[i * _W + j] = s
    block = n // 4
    for i in range(9):
        for j in range(block * (i // 4 + 1)):
            s = 0.0
            for k in range(15):
                s += M[i * _W + k] * PhiT[k * _W + j]
            Pw[i * _W + j] = s
        for j in range(i):
            Pw[j * _W + i] = Pw[i * _W + j]
    for a in range(9, 15):
        d = PhiT[a * _W + a]
        for i in range(9):
            Pw[i * _W + a] = M[i * _W + a] * d
            Pw[a * _W + i] = Pw[i * _W + a]
        for b in range(9, a + 1):
            Pw[a * _W + b] = d * Pw[a * _W + b] * PhiT[b * _W + b]
            Pw[b * _W + a] = Pw[a * _W + b]
    _add_noise(Pw, N)


@jit_inline
def _flush(Pw: Array, At: Array, PhiT: Array, M: Array, N: Array, n: int) -> None:
    """The covariance over the steps accumulated in At (``A = Σ F_k T_k``) and N (``½ Σ S_k
    T_k``): ``Φ = I + A + A²/2``, ``P ← Φ (P + N) Φᵀ + N``; then At and N zeroed for the next
    block (docs/filters.md, 'Covariance blocks'; one step: exactly the per-step propagation)."""
    _fill_PhiT(PhiT, At, n - 4)
    _covariance_step(Pw, PhiT, M, N, n)
    for k in range(15 * _W):
        At[k] = 0.0
    for k in range(N_NOISE_ACC):
        N[k] = 0.0


BLOCK_TOL_S = 1e-9
"""A block is full within this much of its length (sums of IMU intervals round)."""


@jit_inline
def block_full(T_block: float, block_s: float) -> bool:
    """Whether the steps accumulated over ``T_block`` make a full covariance block of
    ``block_s`` (docs/filters.md, 'Covariance blocks'; 0: every step is one)."""
    return T_block >= block_s - BLOCK_TOL_S


@jit_inline
def _work(P: Array, q_psd: Array) -> tuple[Array, Array, Array, Array, int]:
    """Zeroed flat work arrays Aᵀ, Φᵀ, M, the core of P copied into the padded flat layout, and
    n = 16.

    n comes from the sizes of P (15 + m) and q_psd (12, or 12 + 2m with m declared states) at
    run time on purpose: a compile-time 16 would let LLVM unroll the column loops instead of
    vectorizing them, and so would a bound it can see (``min(P.shape[0], 15) + 1`` costs a fifth
    of the propagation's speed). Shapes are not checked in the compiled functions;
    :mod:`adaptnav.engine.propagation` and the engine do that.
    """
    n = _width(P, q_psd)
    Pw = np.zeros(15 * _W)
    _pad(P, Pw)
    return np.zeros(15 * _W), np.zeros(15 * _W), np.zeros(9 * _W), Pw, n


@jit_inline
def _width(P: Array, q_psd: Array) -> int:
    """16, from the sizes of P (15 + m) and q_psd (12 + 2m; 12 for m = 0) (:func:`_work`)."""
    m: int = P.shape[0] - 15
    n: int = P.shape[0] + m + 13 - q_psd.shape[0]  # (15 + m) + m + 13 - (12 + 2m)
    return n


@jit_inline
def _extra_step(x: Array, P: Array, PhiT: Array, tmp: Array, q_psd: Array, T: float) -> None:
    """The declared states beyond the core (errorstate.StateLayout) over a block of span T, in
    place: with each state's transition d and noise q_d (errorstate.gauss_markov: ``d =
    exp(-T/τ)``, ``q_d = (q τ/2)(1 - d²)``; ``d = 1``, ``q_d = q T`` for 1/τ = 0), ``P_ce ← Φ
    P_ce D``, ``P_ee ← D P_ee D + diag(q_d)`` and the nominal values ``x_e ← D x_e``; q =
    ``q_psd[12:12 + m]``, 1/τ = ``q_psd[12 + m:]`` (twin: errorstate.augment and
    adaptnav.engine.propagation.CovarianceBlock.close). Nothing for the core alone; ``tmp`` (15)
    is scratch."""
    m = P.shape[0] - 15
    for j in range(15, P.shape[0]):
        e = j - 15
        r = q_psd[12 + m + e]
        d = math.exp(-T * r) if r > 0.0 else 1.0
        for k in range(15):
            tmp[k] = P[k, j]
        for i in range(15):
            s = 0.0
            for k in range(15):
                s += PhiT[k * _W + i] * tmp[k]
            P[i, j] = s * d
            P[j, i] = s * d
        if r > 0.0:
            for k in range(15, P.shape[0]):
                P[j, k] *= d
                P[k, j] *= d
            P[j, j] += -0.5 * q_psd[12 + e] / r * math.expm1(-2.0 * T * r)
            x[16 + e] *= d
        else:
            P[j, j] += q_psd[12 + e] * T


@jit_inline
def _pad(P: Array, Pw: Array) -> None:
    """The core of P into the padded flat layout of :func:`_work` (the inverse of
    :func:`_unpad`)."""
    for i in range(15):
        for j in range(15):
            Pw[i * _W + j] = P[i, j]


@jit_inline
def _unpad(Pw: Array, P: Array) -> None:
    for i in range(15):
        for j in range(15):
            P[i, j] = Pw[i * _W + j]


@jit_inline
def _low_pass(f_lp: Array, f: Vec3, decay: float) -> Vec3:
    """The specific force F is evaluated with, in place: ``f_lp ← decay f_lp + (1 - decay) f``
    with ``decay = exp(-T/τ_f)`` (0: f itself, bit for bit); NaN f_lp starts at f.

    Why: F multiplies the attitude error by ``[f_n×]`` (Groves 14.64). With the *measured* f,
    its white noise makes the heading error look observable at rest (the filter then claims a
    heading σ it does not have; tests/unit/test_align.py); the motion F must see is slow, the noise
    is not. Twin: :func:`adaptnav.engine.propagation.low_pass`.
    """
    if math.isnan(f_lp[0]):
        f_lp[0], f_lp[1], f_lp[2] = f
    else:
        for c in range(3):
            f_lp[c] = decay * f_lp[c] + (1.0 - decay) * f[c]
    return (f_lp[0], f_lp[1], f_lp[2])


@jit
def _propagate(
    x: Array,
    P: Array,
    rot: Array,
    vel: Array,
    dt: Array,
    w_prev: Array,
    f_prev: Array,
    q_psd: Array,
    tau_a: float,
    tau_g: float,
    f_lp: Array,
    tau_f: float,
    ta: float,
    tb: float,
    block_s: float,
) -> None:
    """The one compiled loop behind both public kernels (x, P, w_prev, f_prev, f_lp in place).

    ``tb < 0``: ``rot``, ``vel`` are the increments of N whole intervals of lengths ``dt``.
    Otherwise one interval, ``rot``, ``vel`` (1, 3) are its mean rates, propagated over
    [ta, tb] only. (A flag argument would be compiled once per value; one compilation serves
    both.) The covariance goes in blocks of at least ``block_s`` (:func:`block_full`; 0: every
    step) and a last, shorter one.
    """
    partial = tb >= 0.0
    At, PhiT, M, Pw, n = _work(P, q_psd)
    N = np.zeros(N_NOISE_ACC)
    T_block = 0.0
    extra = P.shape[0] > 15  # declared state blocks (errorstate.StateLayout)
    wp = (w_prev[0], w_prev[1], w_prev[2])
    fp = (f_prev[0], f_prev[1], f_prev[2])
    inv_tau_a, inv_tau_g = 1.0 / tau_a, 1.0 / tau_g
    T_last, decay_a, decay_g, decay_f = -1.0, 1.0, 1.0, 0.0
    state = _load(x)
    ref = _lat_ref(state[0])
    for k in range(rot.shape[0]):
        dt_k = dt[k]
        a, b = (ta, tb) if partial else (0.0, dt_k)
        T = b - a
        if T_last != T:
            decay_a, decay_g, T_last = math.exp(-T / tau_a), math.exp(-T / tau_g), T
            decay_f = math.exp(-T / tau_f) if tau_f > 0.0 else 0.0
        if abs(state[0] - ref[0]) >= 0.5 * _SERIES_LAT:
            ref = _lat_ref(state[0])
        d = 1.0 if partial else dt_k
        wc = (rot[k, 0] / d, rot[k, 1] / d, rot[k, 2] / d)
        fc = (vel[k, 0] / d, vel[k, 1] / d, vel[k, 2] / d)
        state, e, h, v, C, f = _strapdown(state, ref, wp, fp, wc, fc, dt_k, a, b, decay_a, decay_g)
        f = _low_pass(f_lp, f, decay_f)
        _fill_At(At, e, h, v, C, f, inv_tau_a, inv_tau_g, T)
        _add_half_noise(N, C, q_psd, T)
        T_block += T
        if block_full(T_block, block_s) or k == rot.shape[0] - 1:
            _flush(Pw, At, PhiT, M, N, n)
            if extra:
                _extra_step(x, P, PhiT, M, q_psd, T_block)
            T_block = 0.0
        wp, fp = wc, fc
    _store(x, state)
    _unpad(Pw, P)
    w_prev[0], w_prev[1], w_prev[2] = wp
    f_prev[0], f_prev[1], f_prev[2] = fp


@jit
def propagate_run(
    x: Array,
    P: Array,
    dtheta: Array,
    dvel: Array,
    dt: Array,
    w_prev: Array,
    f_prev: Array,
    q_psd: Array,
    tau_a: float,
    tau_g: float,
    f_lp: Array,
    tau_f: float,
    block_s: float,
) -> None:
    """Propagate x (16 + m) and P ((15 + m)², m declared states) over N IMU increments,
    **in place**; the covariance every step (``block_s = 0``) or in blocks of ``block_s``
    (docs/filters.md, 'Covariance blocks').

    Compiled twin of :func:`adaptnav.engine.propagation.propagate_numpy` (use
    :func:`adaptnav.engine.propagation.propagate` for a copying, shape-checking wrapper).
    ``dtheta``, ``dvel``: (N, 3) C-contiguous; ``dt``: (N,). ``x`` and ``P`` are overwritten with
    the propagated values and ``w_prev``, ``f_prev`` (3) with the last interval's raw mean rates
    ``dtheta[-1]/dt[-1]``, ready for the next call, and ``f_lp`` (3) with the low-passed specific
    force of F (:func:`_low_pass`, time constant ``tau_f``). P leaves exactly symmetric.
    """
    _propagate(
        x, P, dtheta, dvel, dt, w_prev, f_prev, q_psd, tau_a, tau_g, f_lp, tau_f, 0.0, -1.0,
        block_s,
    )  # fmt: skip


@jit
def propagate_partial(
    x: Array,
    P: Array,
    w_prev: Array,
    f_prev: Array,
    w_cur: Array,
    f_cur: Array,
    dt: float,
    ta: float,
    tb: float,
    q_psd: Array,
    tau_a: float,
    tau_g: float,
    f_lp: Array,
    tau_f: float,
) -> None:
    """Propagate x and P over [ta, tb] of one interval of length dt, **in place**.

    Compiled twin of :func:`adaptnav.engine.propagation.propagate_partial_numpy` (copying wrapper:
    :func:`adaptnav.engine.propagation.propagate_partial`). Rates are the raw mean rates of the
    previous and current interval (not modified); Φ and Qd are taken over T = tb - ta;
    ``f_lp`` (in place) as in :func:`propagate_run`.
    """
    _propagate(
        x, P, w_cur.reshape(1, 3), f_cur.reshape(1, 3), np.full(1, dt), w_prev.copy(),
        f_prev.copy(), q_psd, tau_a, tau_g, f_lp, tau_f, ta, tb, 0.0,
    )  # fmt: skip
