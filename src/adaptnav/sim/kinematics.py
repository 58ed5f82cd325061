"""Exact IMU signals of an analytically defined motion (inverse strapdown).

They test the mechanization (docs/mechanization.md, 'Verification').

A :class:`Motion` gives, as vectorised closed-form functions of time t (s), the geodetic
position ``p = [L, λ, h]`` (rad, rad, m) with ``ṗ`` and ``p̈``, and the ZYX Euler angles
``e = [φ, θ, ψ]`` (roll, pitch, yaw) with ``ė``. Everything else follows exactly, with the WGS84
model of :mod:`adaptnav.core.earth` (conventions: ``docs/conventions.md``):

1. NED velocity from the curvilinear position rates (Groves 2013 §2.4.3; the continuous form
   of the position update, Groves 5.56)::

       v_n = [(R_M + h) L̇,  (R_N + h) cos L λ̇,  -ḣ]

   and its time derivative by the product rule, ``Ṙ_M = (dR_M/dL) L̇``, ``Ṙ_N = (dR_N/dL) L̇``::

       v̇_N = (Ṙ_M + ḣ) L̇ + (R_M + h) L̈
       v̇_E = (Ṙ_N + ḣ) cos L λ̇ - (R_N + h) sin L L̇ λ̇ + (R_N + h) cos L λ̈
       v̇_D = -ḧ

2. Attitude ``C_nb = Rz(ψ) Ry(θ) Rx(φ)`` and the body rate relative to n. Differentiating
   ``C_nb`` gives ``Ċ_nb = C_nb [ω_nb^b ×]`` with
   ``ω_nb^b = e_x φ̇ + Rx(φ)ᵀ e_y θ̇ + Rx(φ)ᵀ Ry(θ)ᵀ e_z ψ̇``, i.e.::

       ω_nb^b = [φ̇ - sin θ ψ̇,  cos φ θ̇ + sin φ cos θ ψ̇,  -sin φ θ̇ + cos φ cos θ ψ̇]

3. The local-navigation-frame mechanization equations (Groves 2013 §5.4: attitude
   ``Ċ_nb = C_nb [ω_ib^b×] - [ω_in^n×] C_nb``, velocity 5.54
   ``v̇_n = C_nb f^b + g_n - (2 ω_ie^n + ω_en^n) × v_n``) solved for the sensor outputs::

       ω_ib^b = ω_nb^b + C_nbᵀ (ω_ie^n + ω_en^n)
       f^b    = C_nbᵀ (v̇_n - g_n + (2 ω_ie^n + ω_en^n) × v_n)

   with ``ω_ie^n`` (Groves 2.123), ``ω_en^n`` (Groves 5.44) and normal gravity ``g_n`` (which
   contains the centrifugal term) exactly as :mod:`adaptnav.core.earth` defines them, so a perfect
   mechanization fed with these signals reproduces the motion up to its integration error.

IMU model (``adaptnav.models.strapdown``): interval k = (t_{k-1}, t_k] carries the raw body-frame
increments ``Δθ_k = ∫ ω_ib^b dt`` and ``Δv_k = ∫ f^b dt`` (no coning or sculling applied, as a
real IMU outputs them). :func:`imu_increments` integrates them exactly to double precision
(docs/simulation.md, 'Exact increments'):

* on a uniform grid, by the *grid rule*: interval k is the integral of the degree-9 polynomial
  through the signals at the ten instants t_{k-5} .. t_{k+4} around it, ``h Σ_j w_j g(t_{k+j})``
  (:data:`GRID_WEIGHTS`), so the motion is evaluated once per instant, shared by ten intervals.
  Its error is ``h^11 g^(10)(ξ) c`` with ``c = ∫_0^1 |Π_j (s - j)| ds / 10! = 1.5e-4``: relative
  ``1.5e-4 (Ω h)^10`` for a signal of angular frequency Ω, 7e-24 for the shortest wave period
  of the presets (5.4 s) at 100 Hz, 1.5e-17 even at Ω = 5 rad/s;
* elsewhere (the first and last intervals, an irregular grid, and every interval whose ten
  instants span a joint of the motion, :attr:`Motion.breakpoints`) by m-point Gauss-Legendre
  quadrature on each smooth piece of the interval (cut at the joints), whose error is
  ``h^{2m+1} (m!)^4 / ((2m+1) ((2m)!)^3) g^{(2m)}(ξ)`` (Abramowitz & Stegun 25.4.30):
  relative ``≈ 2e-23 (Ω h)^{16}`` at m = 8.

Both rules need the signal smooth over what they integrate: a polynomial rule across a joint
where a derivative of order r jumps by J errs by ``~J h^{r+1}`` instead.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core import earth

Array = NDArray[np.float64]

TimeFunction = Callable[[Array], Array]
"""Maps times of shape (N,) to values of shape (N, 3)."""

GAUSS_NODES = 8
"""Gauss-Legendre nodes per smooth piece of an interval that :func:`imu_increments` does not
integrate by the grid rule (module docstring)."""

GRID_SAMPLES = 10
"""Instants of the grid rule: an interval's increment from the signals at the ten around it."""

_CHUNK = 65536
"""Instants evaluated at once by :func:`imu_increments` (bounds the memory of long runs)."""


def _grid_weights(samples: int) -> Array:
    """``w_j = ∫_0^1 L_j(s) ds`` for j = 1 - p .. p (p = samples / 2): the integral over the
    middle unit interval of the Lagrange basis polynomials ``L_j(s) = Π_{i≠j} (s - i) / (j - i)``
    on the nodes 1 - p .. p, in exact rational arithmetic, then rounded once."""
    nodes = range(1 - samples // 2, samples // 2 + 1)
    weights = []
    for j in nodes:
        coef = [Fraction(1)]  # of Π_{i≠j} (s - i), lowest power first
        for i in nodes:
            if i != j:
                coef = [
                    -i * a + b
                    for a, b in zip([*coef, Fraction(0)], [Fraction(0), *coef], strict=True)
                ]
        denominator = math.prod(Fraction(j - i) for i in nodes if i != j)
        weights.append(sum(a / (k + 1) for k, a in enumerate(coef)) / denominator)
    return np.array([float(w) for w in weights])


GRID_WEIGHTS = _grid_weights(GRID_SAMPLES)
"""Weights of the grid rule (module docstring): interval (t_k, t_{k+1}) gets
``(t_{k+1} - t_k) Σ_j GRID_WEIGHTS[j] g(t_{k-4+j})``; symmetric, summing to 1."""


@dataclass(frozen=True)
class Motion:
    """An analytically defined motion: closed-form functions of time, vectorised over t.

    Each field maps times (N,) to an (N, 3) array:

    * ``position``: geodetic ``[lat, lon, h]`` (rad, rad, m, ellipsoidal height);
    * ``position_rate``, ``position_accel``: its first and second time derivatives;
    * ``euler``: ZYX Euler angles ``[roll, pitch, yaw]`` of ``C_nb`` (rad);
    * ``euler_rate``: their time derivatives (rad/s).

    The derivatives must be the exact derivatives of the values: nothing checks it here
    (``tests/unit/test_mechanization.py`` checks the ready-made motions against finite differences).

    ``breakpoints``: the joints of a piecewise-defined motion, the instants (s) where some
    derivative of the values jumps (the ends of the smooth steps of :mod:`adaptnav.sim.trajectory`);
    :func:`imu_increments` integrates each side of a joint on its own. Empty for an analytic one.
    """

    position: TimeFunction
    position_rate: TimeFunction
    position_accel: TimeFunction
    euler: TimeFunction
    euler_rate: TimeFunction
    breakpoints: tuple[float, ...] = ()


class Kinematics(NamedTuple):
    """True kinematic quantities at N instants (all arrays have leading dimension N)."""

    position: Array
    """``[lat, lon, h]`` (N, 3)."""
    v_n: Array
    """NED velocity (N, 3)."""
    v_n_rate: Array
    """Time derivative of the NED velocity, ``v̇_n`` (N, 3)."""
    C_nb: Array
    """Body-to-NED DCM (N, 3, 3)."""
    omega_nb_b: Array
    """Body rate relative to the NED frame, resolved in b (N, 3)."""
    omega_ib_b: Array
    """Body rate relative to inertial space, resolved in b: the gyro output (N, 3)."""
    f_b: Array
    """Specific force resolved in b: the accelerometer output (N, 3)."""


def _times(t: ArrayLike) -> Array:
    ta = np.atleast_1d(np.asarray(t, dtype=float))
    if ta.ndim != 1:
        raise ValueError(f"times must be a scalar or a 1-D array, got shape {ta.shape}")
    return ta


def _euler_to_dcm(sin_e: list[Array], cos_e: list[Array]) -> list[list[Array]]:
    """The entries (rows of columns, each (N,)) of ``C_nb = Rz(ψ) Ry(θ) Rx(φ)`` from the sines
    and cosines of ``[φ, θ, ψ]`` (columns; the caller needs them again): the vectorised twin of
    :func:`adaptnav.core.attitude.euler_to_dcm`."""
    sr, sp, sy = sin_e
    cr, cp, cy = cos_e
    return [
        [cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
        [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
        [-sp, sr * cp, cr * cp],
    ]


def _euler_to_quat(e: Array) -> Array:
    """``q_nb = q_z(ψ) ⊗ q_y(θ) ⊗ q_x(φ)`` for (N, 3) Euler angles → (N, 4), w ≥ 0.

    Half-angle closed form; the sign is chosen as :func:`adaptnav.core.attitude.euler_to_quat`
    (``dcm_to_quat``) chooses it, so the two agree to rounding.
    """
    sr, cr = np.sin(0.5 * e[:, 0]), np.cos(0.5 * e[:, 0])
    sp, cp = np.sin(0.5 * e[:, 1]), np.cos(0.5 * e[:, 1])
    sy, cy = np.sin(0.5 * e[:, 2]), np.cos(0.5 * e[:, 2])
    q = np.stack(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ],
        axis=-1,
    )
    result: Array = np.where(q[:, :1] < 0.0, -q, q)
    return result


class _Signals(NamedTuple):
    """:class:`Kinematics` as columns, each (N,) (``C`` by rows), before any is stacked."""

    v_n: tuple[Array, Array, Array]
    v_n_rate: tuple[Array, Array, Array]
    C: list[list[Array]]
    omega_nb_b: tuple[Array, Array, Array]
    omega_ib_b: tuple[Array, Array, Array]
    f_b: tuple[Array, Array, Array]


def _signals(p: Array, pd: Array, pdd: Array, e: Array, ed: Array) -> _Signals:
    """Items 1-3 of the module docstring, column by column, from the motion's values at N
    instants. Earth rate, transport rate and gravity are the vectorised forms of
    :func:`adaptnav.core.earth.earth_rate_n`, :func:`~adaptnav.core.earth.transport_rate_n` and
    :func:`~adaptnav.core.earth.gravity_n` (``tan L`` as ``sin L / cos L``)."""
    lat, h = p[:, 0], p[:, 2]
    dlat, dlon, dh = pd[:, 0], pd[:, 1], pd[:, 2]
    sl, cl = np.sin(lat), np.cos(lat)
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    drm = earth.meridian_radius_dlat(lat) * dlat + dh
    drn = earth.transverse_radius_dlat(lat) * dlat + dh
    v = (rm * dlat, rn * cl * dlon, -dh)
    a = (
        drm * dlat + rm * pdd[:, 0],
        drn * cl * dlon - rn * sl * dlat * dlon + rn * cl * pdd[:, 1],
        -pdd[:, 2],
    )
    sin_e = [np.sin(e[:, i]) for i in range(3)]
    cos_e = [np.cos(e[:, i]) for i in range(3)]
    C = _euler_to_dcm(sin_e, cos_e)
    (s_r, s_p, _), (c_r, c_p, _) = sin_e, cos_e
    omega_nb_b = (
        ed[:, 0] - s_p * ed[:, 2],
        c_r * ed[:, 1] + s_r * c_p * ed[:, 2],
        -s_r * ed[:, 1] + c_r * c_p * ed[:, 2],
    )
    # ω_ie^n + ω_en^n, and 2 ω_ie^n + ω_en^n for the Coriolis term
    w_e = v[1] / rn
    w_n, w_d = -v[0] / rm, -w_e * (sl / cl)
    ie_n, ie_d = earth.OMEGA_IE * cl, -earth.OMEGA_IE * sl
    w_in = (ie_n + w_e, w_n, ie_d + w_d)
    u = (2.0 * ie_n + w_e, w_n, 2.0 * ie_d + w_d)
    f_n = (
        a[0] + (u[1] * v[2] - u[2] * v[1]),
        a[1] + (u[2] * v[0] - u[0] * v[2]),
        a[2] - earth.gravity(lat, h) + (u[0] * v[1] - u[1] * v[0]),
    )
    gyro = [omega_nb_b[i] + _column_dot(C, i, w_in) for i in range(3)]
    accel = [_column_dot(C, i, f_n) for i in range(3)]
    return _Signals(
        v, a, C, omega_nb_b, (gyro[0], gyro[1], gyro[2]), (accel[0], accel[1], accel[2])
    )


def _column_dot(C: list[list[Array]], i: int, x: tuple[Array, Array, Array]) -> Array:
    """Component i of ``C_nbᵀ x``: column i of C (rows of columns) dotted with x."""
    return C[0][i] * x[0] + C[1][i] * x[1] + C[2][i] * x[2]


def _evaluate(motion: Motion, tt: Array) -> tuple[Array, Array, _Signals]:
    """The motion's position and Euler angles at the instants, and every signal."""
    p, e = motion.position(tt), motion.euler(tt)
    pd, pdd, ed = motion.position_rate(tt), motion.position_accel(tt), motion.euler_rate(tt)
    return p, e, _signals(p, pd, pdd, e, ed)


def true_kinematics(motion: Motion, t: ArrayLike) -> Kinematics:
    """All true kinematic quantities of ``motion`` at the instants ``t`` (module docstring)."""
    p, _, s = _evaluate(motion, _times(t))
    C_nb = np.stack([np.stack(row, axis=-1) for row in s.C], axis=-2)
    k = [np.stack(c, axis=-1) for c in (s.v_n, s.v_n_rate, s.omega_nb_b, s.omega_ib_b, s.f_b)]
    return Kinematics(p, k[0], k[1], C_nb, k[2], k[3], k[4])


def imu_rates(motion: Motion, t: ArrayLike) -> tuple[Array, Array]:
    """Error-free gyro and accelerometer outputs sampled at the instants t.

    Returns ``(ω_ib^b, f^b)``, each (N, 3), in rad/s and m/s² (module docstring, item 3).
    """
    _, _, s = _evaluate(motion, _times(t))
    return np.stack(s.omega_ib_b, axis=-1), np.stack(s.f_b, axis=-1)


def imu_increments(motion: Motion, t: ArrayLike, nodes: int | None = None) -> tuple[Array, Array]:
    """Exact IMU increments over the intervals (t_{k-1}, t_k] of the instants t.

    ``Δθ_k = ∫ ω_ib^b dt`` (rad) and ``Δv_k = ∫ f^b dt`` (m/s), the raw body-frame integrals,
    exact to double precision (module docstring): by the grid rule where the instants are
    evenly spaced and no joint of the motion lies among the ten around the interval, else by
    :data:`GAUSS_NODES`-point Gauss-Legendre quadrature on each smooth piece; ``nodes`` given:
    by ``nodes``-point Gauss-Legendre everywhere. N instants give N-1 increments, like
    :func:`adaptnav.models.strapdown.rates_to_increments`.
    """
    tt = _times(t)
    if tt.size < 2:
        raise ValueError("need at least two instants to form an interval")
    joints = np.unique(np.asarray(motion.breakpoints, dtype=float))
    grid = _grid_intervals(tt, joints) if nodes is None else np.zeros(tt.size - 1, dtype=bool)
    dtheta = np.empty((tt.size - 1, 3))
    dvel = np.empty((tt.size - 1, 3))
    if grid.any():
        _grid_rule(motion, tt, grid, dtheta, dvel)
    rest = np.flatnonzero(~grid)
    if rest.size:
        m = GAUSS_NODES if nodes is None else nodes
        dtheta[rest], dvel[rest] = _gauss(motion, tt[rest], tt[rest + 1], joints, m)
    return dtheta, dvel


def _grid_intervals(t: Array, joints: Array) -> NDArray[np.bool_]:
    """Which intervals (t_k, t_{k+1}) the grid rule integrates: those whose ten instants
    t_{k-4} .. t_{k+5} exist, are evenly spaced to a few ulps of t and have no joint between
    the first and the last."""
    p = GRID_SAMPLES // 2
    n = t.size - 1
    ok = np.zeros(n, dtype=bool)
    d = np.diff(t)
    if n < GRID_SAMPLES - 1 or not np.all(d > 0.0):
        return ok
    tol = 8.0 * float(np.spacing(max(abs(t[0]), abs(t[-1]))))
    # uneven[m]: how many spacing pairs (i, i + 1), i < m, differ by more than tol; the window
    # of interval k holds the pairs k-4 .. k+3.
    uneven = np.concatenate([[0], np.cumsum(np.abs(np.diff(d)) > tol)])
    ok[p - 1 : n - p + 1] = uneven[2 * p - 2 :] == uneven[: n - 2 * p + 2]
    # A joint c strictly inside (t_{k-4}, t_{k+5}): k - 4 <= last index before c and
    # k + 5 >= first index after c.
    before = np.searchsorted(t, joints, side="left") - 1
    after = np.searchsorted(t, joints, side="right")
    marks = np.zeros(n + 1, dtype=np.int64)
    lo, hi = np.maximum(after - p, 0), np.minimum(before + p - 1, n - 1)
    np.add.at(marks, lo[lo <= hi], 1)
    np.add.at(marks, hi[lo <= hi] + 1, -1)
    return np.asarray(ok & (np.cumsum(marks[:-1]) == 0), dtype=bool)


def _grid_rule(
    motion: Motion, t: Array, grid: NDArray[np.bool_], dtheta: Array, dvel: Array
) -> None:
    """Fill the rows of ``dtheta`` and ``dvel`` from the first to the last interval of ``grid``
    by the grid rule (module docstring), chunk by chunk; the rows between them outside ``grid``
    are for the caller to overwrite.

    The weights apply to the interval's own length ``t_{k+1} - t_k`` (exact in floating point):
    the instants ``t = k / rate`` are evenly spaced only to rounding, and a shared mean spacing
    would put that rounding, times gravity, into every Δv."""
    p = GRID_SAMPLES // 2
    first, last = np.flatnonzero(grid)[[0, -1]]
    for k0 in range(first, last + 1, _CHUNK):
        k1 = min(last + 1, k0 + _CHUNK)
        gyro, accel = imu_rates(motion, t[k0 - p + 1 : k1 + p])
        h = t[k0 + 1 : k1 + 1] - t[k0:k1]
        dtheta[k0:k1] = _stencil(gyro, h)
        dvel[k0:k1] = _stencil(accel, h)


def _stencil(g: Array, h: Array) -> Array:
    """``h_k Σ_j w_j g_{k+j}`` (M, 3) from the signals at M + 9 instants (:data:`GRID_WEIGHTS`,
    symmetric: taken in pairs ``w_j (g_j + g_{9-j})``)."""
    m, span = h.size, GRID_SAMPLES - 1
    acc: Array = GRID_WEIGHTS[0] * (g[:m] + g[span : span + m])
    for j in range(1, GRID_SAMPLES // 2):
        acc += GRID_WEIGHTS[j] * (g[j : j + m] + g[span - j : span - j + m])
    acc *= h[:, None]
    return acc


def _pieces(a: Array, b: Array, joints: Array) -> tuple[Array, Array, NDArray[np.intp]]:
    """The smooth pieces (lo, hi, index of their interval) of the intervals (a, b): each cut
    at the joints strictly inside it."""
    first = np.searchsorted(joints, a, side="right")  # the first joint after a
    cuts = np.maximum(np.searchsorted(joints, b, side="left") - first, 0)
    owner = np.repeat(np.arange(a.size), cuts + 1)
    if owner.size == a.size:
        return a, b, owner
    r = np.arange(owner.size) - np.repeat(np.cumsum(cuts + 1) - (cuts + 1), cuts + 1)
    top = max(joints.size - 1, 0)
    lo = np.where(r == 0, a[owner], joints[np.clip(first[owner] + r - 1, 0, top)])
    hi = np.where(r == cuts[owner], b[owner], joints[np.clip(first[owner] + r, 0, top)])
    return lo, hi, owner


def _gauss(motion: Motion, a: Array, b: Array, joints: Array, nodes: int) -> tuple[Array, Array]:
    """``nodes``-point Gauss-Legendre increments over the intervals (a, b), each the sum over
    its smooth pieces (:func:`_pieces`)."""
    lo, hi, owner = _pieces(a, b, joints)
    x, w = np.polynomial.legendre.leggauss(nodes)
    out = np.zeros((a.size, 6))
    per = max(1, _CHUNK // nodes)
    for start in range(0, lo.size, per):
        pa, pb = lo[start : start + per], hi[start : start + per]
        half = 0.5 * (pb - pa)
        tau = (0.5 * (pa + pb))[:, None] + half[:, None] * x[None, :]
        gyro, accel = imu_rates(motion, tau.ravel())
        weights = (half[:, None] * w[None, :])[:, :, None]
        part = np.concatenate(
            [
                np.sum(gyro.reshape(pa.size, nodes, 3) * weights, axis=1),
                np.sum(accel.reshape(pa.size, nodes, 3) * weights, axis=1),
            ],
            axis=1,
        )
        np.add.at(out, owner[start : start + per], part)
    return out[:, :3], out[:, 3:]


def true_states(motion: Motion, t: ArrayLike) -> Array:
    """True nominal states (N, 16) at the instants t: ``[lat, lon, h, v_n, q_nb, 0 (6)]``.

    Layout of :mod:`adaptnav.models.strapdown` (``NOM_*``); the bias slots are zero (a perfect IMU).
    ``q_nb`` equals :func:`adaptnav.core.attitude.euler_to_quat` of the Euler angles (w ≥ 0).
    """
    tt = _times(t)
    k = true_kinematics(motion, tt)
    q = _euler_to_quat(motion.euler(tt))
    return np.concatenate([k.position, k.v_n, q, np.zeros((tt.size, 6))], axis=1)


# --- ready-made motions ---------------------------------------------------------------------


def _constant(value: ArrayLike) -> TimeFunction:
    v = np.asarray(value, dtype=float)

    def f(t: Array) -> Array:
        return np.tile(v, (np.shape(t)[0], 1))

    return f


def stationary(
    lat: float,
    lon: float,
    h: float = 0.0,
    roll: float = 0.0,
    pitch: float = 0.0,
    yaw: float = 0.0,
) -> Motion:
    """A body at rest on the rotating Earth with a fixed attitude (angles in rad).

    Its IMU senses only earth rate and gravity: ``ω_ib^b = C_nbᵀ ω_ie^n``,
    ``f^b = -C_nbᵀ g_n``.
    """
    zero = np.zeros(3)
    return Motion(
        position=_constant([lat, lon, h]),
        position_rate=_constant(zero),
        position_accel=_constant(zero),
        euler=_constant([roll, pitch, yaw]),
        euler_rate=_constant(zero),
    )


def turn_with_waves(
    lat0: float = np.deg2rad(26.8),
    lon0: float = np.deg2rad(56.3),
    h0: float = 0.0,
    speed: float = 2.0,
    radius: float = 300.0,
    course0: float = 0.0,
    heave_amplitude: float = 0.5,
    heave_period: float = 8.0,
    roll_amplitude: float = np.deg2rad(5.0),
    roll_period: float = 7.0,
    pitch_amplitude: float = np.deg2rad(3.0),
    pitch_period: float = 9.0,
    phases: tuple[float, float, float] = (0.0, 0.5, 1.0),
) -> Motion:
    """A vessel in a steady turn in waves, every derivative in closed form.

    Course ``χ(t) = χ0 + Ω t`` with ``Ω = speed / radius`` (Ω > 0 turns to starboard, i.e.
    clockwise seen from above), on a circle through the start point; local offsets from it::

        n(t) = R (sin χ - sin χ0),   e(t) = -R (cos χ - cos χ0),
        u(t) = A_h sin(2π t / T_h + φ_h)       (heave, up positive)

    so that ``[ṅ, ė] = speed [cos χ, sin χ]``. They become geodetic coordinates with the
    *constant* scale factors of the start point (the motion is defined this way, it is not an
    approximation of anything)::

        L = L0 + n / (R_M(L0) + h0),   λ = λ0 + e / ((R_N(L0) + h0) cos L0),   h = h0 + u.

    Attitude: yaw = course (no crab), roll ``A_r sin(2π t / T_r + φ_r)``, pitch
    ``A_p sin(2π t / T_p + φ_p)``; ``phases = (φ_h, φ_r, φ_p)`` in rad. Defaults: 2 m/s on a
    300 m radius at 26.8° N, 0.5 m heave at 8 s, 5° roll at 7 s, 3° pitch at 9 s.
    """
    rate = speed / radius
    k_lat = 1.0 / (float(earth.meridian_radius(lat0)) + h0)
    k_lon = 1.0 / ((float(earth.transverse_radius(lat0)) + h0) * np.cos(lat0))
    w_h, w_r, w_p = (
        2.0 * np.pi / heave_period,
        2.0 * np.pi / roll_period,
        2.0 * np.pi / pitch_period,
    )
    ph_h, ph_r, ph_p = phases
    s0, c0 = np.sin(course0), np.cos(course0)

    def position(t: Array) -> Array:
        chi = course0 + rate * t
        n = radius * (np.sin(chi) - s0)
        e = -radius * (np.cos(chi) - c0)
        u = heave_amplitude * np.sin(w_h * t + ph_h)
        return np.stack([lat0 + k_lat * n, lon0 + k_lon * e, h0 + u], axis=-1)

    def position_rate(t: Array) -> Array:
        chi = course0 + rate * t
        dn = speed * np.cos(chi)
        de = speed * np.sin(chi)
        du = heave_amplitude * w_h * np.cos(w_h * t + ph_h)
        return np.stack([k_lat * dn, k_lon * de, du], axis=-1)

    def position_accel(t: Array) -> Array:
        chi = course0 + rate * t
        ddn = -speed * rate * np.sin(chi)
        dde = speed * rate * np.cos(chi)
        ddu = -heave_amplitude * w_h**2 * np.sin(w_h * t + ph_h)
        return np.stack([k_lat * ddn, k_lon * dde, ddu], axis=-1)

    def euler(t: Array) -> Array:
        roll = roll_amplitude * np.sin(w_r * t + ph_r)
        pitch = pitch_amplitude * np.sin(w_p * t + ph_p)
        return np.stack([roll, pitch, course0 + rate * t], axis=-1)

    def euler_rate(t: Array) -> Array:
        droll = roll_amplitude * w_r * np.cos(w_r * t + ph_r)
        dpitch = pitch_amplitude * w_p * np.cos(w_p * t + ph_p)
        return np.stack([droll, dpitch, np.full_like(t, rate)], axis=-1)

    return Motion(position, position_rate, position_accel, euler, euler_rate)
