"""15-state error model: layout, F, G, Q, discretization, closed-loop feedback.

Sign convention (docs/conventions.md): **dx = x_true ⊖ x_hat**, truth minus estimate, with
position error in NED metres at the estimate, ``dr = [(R_M + h) δL, (R_N + h) cos L δλ, -δh]``,
and the attitude error phi defined by ``C_nb_true = Exp(phi) C_nb_hat`` (resolved in n).

Continuous model ``dx' = F dx + G w`` with ``w = [w_a, w_g, w_ba, w_bg]`` (VRW, ARW, bias driving
noises; the paper's 12 noise inputs, its eq. (3); docs/filters.md, 'Error-state model'). Derived for
this convention from the full local-navigation-frame model of Groves (2013) §14.2.4 (his δψ = -phi
and δv = -dv), written with δL = dr_N / (R_M + h) and δh = -dr_D:

* position: ``dr_N' = dv_N - v_D dr_N/R_M' + v_N dr_D/R_M'`` (R_M' = R_M + h), ``dr_D' = dv_D``,
  ``dr_E' = dv_E + (...) dr_N + (...) dr_E + v_E dr_D / R_N'`` (see :func:`system_matrix`);
* velocity: ``dv' = -[f_n×] phi - C_nb db_a - [(2ω_ie + ω_en)×] dv
  + [v×] δ(2ω_ie + ω_en) + δg`` (Coriolis, transport and gravity-gradient terms);
* attitude: ``phi' = -[ω_in×] phi - C_nb db_g - δω_in`` (δω_in from dr and dv);
* biases: first-order Gauss-Markov ``db' = -db/τ + w_b`` (τ = inf: random walk).

Every block is checked against finite differences of the nonlinear mechanization
(tests/unit/test_errorstate.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core import attitude, earth
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.models.strapdown import NOM_ATT, NOM_BA, NOM_BG, NOM_SIZE, NOM_VEL

Array = NDArray[np.float64]

N_STATES = 15
N_NOISE = 12
POS = slice(0, 3)
VEL = slice(3, 6)
ATT = slice(6, 9)
BA = slice(9, 12)
BG = slice(12, 15)
STATE_NAMES: tuple[str, ...] = (
    "dr_N", "dr_E", "dr_D", "dv_N", "dv_E", "dv_D", "phi_N", "phi_E", "phi_D",
    "dba_x", "dba_y", "dba_z", "dbg_x", "dbg_y", "dbg_z",
)  # fmt: skip


@dataclass(frozen=True)
class StateBlock:
    """Error states beyond the core that a sensor or model declares (e.g. a DVL scale factor,
    an inclinometer bias): the block's name, its states' names, the PSD q driving each (state
    unit² / s) and, optionally, each state's inverse correlation time 1/τ (1/s). With 1/τ = 0
    (the default) a state is a random walk, ``b' = w`` (a constant for q = 0); else a first-order
    Gauss-Markov process ``b' = -b/τ + w``, whose variance settles at ``q τ / 2``
    (:func:`gauss_markov`). Their nominal values follow the core's 16 numbers in the nominal
    state; feedback adds their error estimate (docs/architecture.md, 'Adding a state
    block')."""

    name: str
    states: tuple[str, ...]
    psd: tuple[float, ...]
    inv_tau: tuple[float, ...] = ()
    """Per state 1/τ (1/s); empty: every state a random walk."""

    def __post_init__(self) -> None:
        if not self.states or len(self.psd) != len(self.states):
            raise ValueError(f"state block {self.name!r}: one PSD per state, at least one state")
        if not all(math.isfinite(q) and q >= 0.0 for q in self.psd):
            raise ValueError(f"state block {self.name!r}: PSDs must be finite and >= 0")
        if self.inv_tau and len(self.inv_tau) != len(self.states):
            raise ValueError(f"state block {self.name!r}: one 1/tau per state, or none")
        if not all(math.isfinite(r) and r >= 0.0 for r in self.inv_tau):
            raise ValueError(f"state block {self.name!r}: 1/tau must be finite and >= 0")

    @property
    def rates(self) -> tuple[float, ...]:
        """1/τ of each state (0: a random walk)."""
        return self.inv_tau or (0.0,) * len(self.states)


CORE_BLOCKS: dict[str, slice] = {
    "position": POS,
    "velocity": VEL,
    "attitude": ATT,
    "accel_bias": BA,
    "gyro_bias": BG,
}
"""The 15 core states by block (the names of :data:`STATE_NAMES`)."""


@dataclass(frozen=True)
class StateLayout:
    """The error state: the 15 core states, then the declared blocks in order, with named
    indices. The compiled kernels take their size from P (``adaptnav.compiled``): the core is
    propagated with its F, each declared state as a random walk or a Gauss-Markov process of its
    own (:func:`gauss_markov`: Φ diagonal), coupled to the core only through P and the
    measurements' H."""

    extra: tuple[StateBlock, ...] = ()

    def __post_init__(self) -> None:
        names = [*CORE_BLOCKS, *(b.name for b in self.extra)]
        states = [*STATE_NAMES, *(s for b in self.extra for s in b.states)]
        if len(set(names)) != len(names) or len(set(states)) != len(states):
            raise ValueError(f"state layout: block and state names must be unique, got {names}")

    @property
    def n(self) -> int:
        """Number of error states."""
        return N_STATES + sum(len(b.states) for b in self.extra)

    @property
    def nominal_size(self) -> int:
        """Length of the nominal state: the core's 16 numbers, then one per declared state."""
        return NOM_SIZE + self.n - N_STATES

    @property
    def names(self) -> tuple[str, ...]:
        return (*STATE_NAMES, *(s for b in self.extra for s in b.states))

    def slice(self, block: str) -> slice:
        """The indices of ``block`` (a core block of :data:`CORE_BLOCKS` or a declared one)."""
        if block in CORE_BLOCKS:
            return CORE_BLOCKS[block]
        start = N_STATES
        for b in self.extra:
            if b.name == block:
                return slice(start, start + len(b.states))
            start += len(b.states)
        raise KeyError(
            f"no state block {block!r} (have {[*CORE_BLOCKS, *(b.name for b in self.extra)]})"
        )

    def extra_psd(self) -> Array:
        """The declared states' random-walk PSDs, in order (appended to the 12 IMU PSDs of
        :func:`noise_psd` for the kernels)."""
        return np.array([q for b in self.extra for q in b.psd], dtype=float)

    def extra_inv_tau(self) -> Array:
        """The declared states' 1/τ (1/s; 0: a random walk), in order."""
        return np.array([r for b in self.extra for r in b.rates], dtype=float)

    def kernel_psd(self, core_psd: ArrayLike) -> Array:
        """What the propagation kernels take as ``q_psd``: the 12 IMU PSDs ``core_psd``
        (:func:`noise_psd`), then with m declared states their m PSDs and their m 1/τ
        (adaptnav.compiled.propagation, ``_extra_step``)."""
        core = np.asarray(core_psd, dtype=float)
        if not self.extra:
            return core.copy()
        return np.concatenate([core, self.extra_psd(), self.extra_inv_tau()])


CORE = StateLayout()
"""The paper's 15-state error model alone."""


def gauss_markov(psd: ArrayLike, inv_tau: ArrayLike, T: float) -> tuple[Array, Array]:
    """Each declared state over T: its transition ``d = exp(-T/τ)`` and the variance its driving
    noise adds, ``∫₀ᵀ e^(-2s/τ) q ds = (q τ / 2)(1 - e^(-2T/τ))``, exact for the first-order
    Gauss-Markov ``b' = -b/τ + w`` (Groves 2013, §14.2.7; Brown & Hwang, §4.2); ``d = 1`` and
    ``q T`` for 1/τ = 0 (a random walk)."""
    q = np.asarray(psd, dtype=float)
    r = np.asarray(inv_tau, dtype=float)
    gm = r > 0.0
    safe = np.where(gm, r, 1.0)
    d = np.where(gm, np.exp(-T * r), 1.0)
    qd = np.where(gm, -0.5 * q / safe * np.expm1(-2.0 * T * r), q * T)
    return d, qd


def augment(
    Phi: ArrayLike,
    Qd: ArrayLike,
    extra_psd: ArrayLike,
    dt: float,
    extra_inv_tau: ArrayLike | None = None,
) -> tuple[Array, Array]:
    """Φ and Qd of the whole layout from the core's: ``blockdiag(Φ, diag(d))`` and
    ``blockdiag(Qd, diag(q_d))`` with d and q_d of :func:`gauss_markov` (1/τ = 0 when
    ``extra_inv_tau`` is None: ``blockdiag(Φ, I)``, ``blockdiag(Qd, diag(q) dt)``)."""
    q = np.asarray(extra_psd, dtype=float)
    r = np.zeros(q.size) if extra_inv_tau is None else np.asarray(extra_inv_tau, dtype=float)
    d, qd = gauss_markov(q, r, dt)
    n = N_STATES + q.size
    Phi_n, Qd_n = np.zeros((n, n)), np.zeros((n, n))
    Phi_n[:N_STATES, :N_STATES] = Phi
    Phi_n[N_STATES:, N_STATES:] = np.diag(d)
    Qd_n[:N_STATES, :N_STATES] = Qd
    Qd_n[N_STATES:, N_STATES:] = np.diag(qd)
    return Phi_n, Qd_n


W_A = slice(0, 3)
W_G = slice(3, 6)
W_BA = slice(6, 9)
W_BG = slice(9, 12)


def _rate_sensitivities(lat: float, h: float, v_n: Array) -> tuple[Array, Array, Array, Array]:
    """Partials of ω_ie and ω_en: (dω_ie/dL, dω_en/dL, dω_en/dh, dω_en/dv (3×3))."""
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    drm = earth.meridian_radius_dlat(lat)
    drn = earth.transverse_radius_dlat(lat)
    s, c = np.sin(lat), np.cos(lat)
    t = s / c
    vn, ve = v_n[0], v_n[1]
    wie_L = np.array([-earth.OMEGA_IE * s, 0.0, -earth.OMEGA_IE * c])
    wen_L = np.array(
        [-ve * drn / rn**2, vn * drm / rm**2, -ve * (1.0 / (c * c * rn) - t * drn / rn**2)]
    )
    wen_h = np.array([-ve / rn**2, vn / rm**2, ve * t / rn**2])
    wen_v = np.array([[0.0, 1.0 / rn, 0.0], [-1.0 / rm, 0.0, 0.0], [0.0, -t / rn, 0.0]])
    return wie_L, wen_L, wen_h, wen_v


def system_matrix(
    lat: float,
    h: float,
    v_n: ArrayLike,
    C_nb: ArrayLike,
    f_n: ArrayLike,
    tau_a: float = np.inf,
    tau_g: float = np.inf,
) -> Array:
    """Continuous-time error dynamics matrix F (15×15) at a nominal point (docs/filters.md,
    'Error-state model'; paper eq. (3) in continuous form; Groves §14.2.4).

    ``f_n`` is the bias-corrected specific force resolved in n. Block rows follow the module
    docstring; the dr_E column is zero outside the position block (longitude drives nothing).
    """
    v = np.asarray(v_n, dtype=float)
    C = np.asarray(C_nb, dtype=float)
    f = np.asarray(f_n, dtype=float)
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    drn = earth.transverse_radius_dlat(lat)
    t = np.tan(lat)
    vn, ve, vd = v
    wie = earth.earth_rate_n(lat)
    wen = earth.transport_rate_n(lat, h, v)
    wie_L, wen_L, wen_h, wen_v = _rate_sensitivities(lat, h, v)
    g_L, g_h = earth.gravity_gradient(lat, h)

    F = np.zeros((N_STATES, N_STATES))
    F[POS, POS] = [
        [-vd / rm, 0.0, vn / rm],
        [ve * (t - drn / rn) / rm, (drn * vn / (rm * rn) - vd / rn - t * vn / rm), ve / rn],
        [0.0, 0.0, 0.0],
    ]
    F[POS, VEL] = np.eye(3)

    # d/d(dr) of a quantity with partials a_L, a_h: columns [a_L / R_M', 0, -a_h].
    def by_position(a_L: Array, a_h: Array) -> Array:
        return np.column_stack([a_L / rm, np.zeros(3), -a_h])

    d_cor = by_position(2.0 * wie_L + wen_L, wen_h)  # d(2ω_ie + ω_en)/d(dr)
    d_grav = by_position(np.array([0.0, 0.0, g_L]), np.array([0.0, 0.0, g_h]))
    F[VEL, POS] = attitude.skew(v) @ d_cor + d_grav
    F[VEL, VEL] = -attitude.skew(2.0 * wie + wen) + attitude.skew(v) @ wen_v
    F[VEL, ATT] = -attitude.skew(f)
    F[VEL, BA] = -C
    F[ATT, POS] = -by_position(wie_L + wen_L, wen_h)
    F[ATT, VEL] = -wen_v
    F[ATT, ATT] = -attitude.skew(wie + wen)
    F[ATT, BG] = -C
    F[BA, BA] = -np.eye(3) / tau_a
    F[BG, BG] = -np.eye(3) / tau_g
    return F


def noise_input_matrix(C_nb: ArrayLike) -> Array:
    """G (15×12): ``dv' ∋ -C_nb w_a``, ``phi' ∋ -C_nb w_g``, ``db' ∋ w_b``.

    docs/filters.md, 'Error-state model'.
    """
    C = np.asarray(C_nb, dtype=float)
    G = np.zeros((N_STATES, N_NOISE))
    G[VEL, W_A] = -C
    G[ATT, W_G] = -C
    G[BA, W_BA] = np.eye(3)
    G[BG, W_BG] = np.eye(3)
    return G


def noise_psd(noise: ImuNoise) -> Array:
    """Diagonal of the continuous noise PSD Q (12): [VRW², ARW², q_ba, q_bg].

    Gauss-Markov bias of steady-state σ and correlation time τ: ``q = 2 σ² / τ``; random walk
    (τ = inf): ``q`` = the rate-random-walk PSD (Groves 14.2.2, Maybeck).
    """
    return np.concatenate(
        [
            np.full(3, noise.vrw**2),
            np.full(3, noise.arw**2),
            np.full(3, noise.accel_bias_psd),
            np.full(3, noise.gyro_bias_psd),
        ]
    )


def transition(F: ArrayLike, dt: float) -> Array:
    """``Phi = I + F dt + (F dt)² / 2``, exp(F dt) to second order (docs/filters.md,
    'Propagation')."""
    A = np.asarray(F, dtype=float) * dt
    return np.asarray(np.eye(A.shape[0]) + A + 0.5 * (A @ A), dtype=float)


def discrete_noise(Phi: ArrayLike, G: ArrayLike, q_psd: ArrayLike, dt: float) -> Array:
    """``Qd = ½ (Phi G Q Gᵀ Phiᵀ + G Q Gᵀ) dt``, trapezoidal (docs/filters.md, 'Propagation')."""
    Gm = np.asarray(G, dtype=float)
    GQG = (Gm * np.asarray(q_psd, dtype=float)) @ Gm.T
    P = np.asarray(Phi, dtype=float)
    Qd = 0.5 * (P @ GQG @ P.T + GQG) * dt
    # Symmetric by construction; rounding in the triple product is not, and P inherits it.
    return np.asarray(0.5 * (Qd + Qd.T), dtype=float)


def predict_covariance(P: ArrayLike, Phi: ArrayLike, Qd: ArrayLike) -> Array:
    """``P⁻ = Phi P⁺ Phiᵀ + Qd`` (docs/filters.md, 'Propagation'; paper eq. (11))."""
    Pm = np.asarray(Phi, dtype=float)
    return np.asarray(
        Pm @ np.asarray(P, dtype=float) @ Pm.T + np.asarray(Qd, dtype=float), dtype=float
    )


def inject(x: ArrayLike, dx: ArrayLike) -> Array:
    """Closed-loop feedback ``x_hat ⊕ dx`` (docs/conventions.md, 'Error state'; docs/filters.md,
    'Feedback and reset').

    lat += dr_N/(R_M + h), lon += dr_E/((R_N + h) cos lat), h -= dr_D (radii at the estimate),
    v += dv, ``q ← Exp(phi) ⊗ q``, b += db.
    """
    xa = np.array(x, dtype=float)
    d = np.asarray(dx, dtype=float)
    m = d.size - N_STATES
    if m < 0 or xa.shape != (NOM_SIZE + m,) or d.ndim != 1:
        raise ValueError(
            f"inject needs shapes ({NOM_SIZE} + m,) and ({N_STATES} + m,) (m declared states), "
            f"got {xa.shape}, {d.shape}"
        )
    xa[NOM_SIZE:] += d[N_STATES:]  # declared states (StateLayout): plain addition
    lat, h = xa[0], xa[2]
    xa[0] = lat + d[0] / (earth.meridian_radius(lat) + h)
    xa[1] = xa[1] + d[1] / ((earth.transverse_radius(lat) + h) * np.cos(lat))
    xa[2] = h - d[2]
    xa[NOM_VEL] += d[VEL]
    xa[NOM_ATT] = attitude.quat_normalize(
        attitude.quat_mult(attitude.rotvec_to_quat(d[ATT]), xa[NOM_ATT])
    )
    xa[NOM_BA] += d[BA]
    xa[NOM_BG] += d[BG]
    return xa


def difference(x_true: ArrayLike, x_hat: ArrayLike) -> Array:
    """``x_true ⊖ x_hat``, the exact inverse of :func:`inject` (used by tests and metrics)."""
    xt = np.asarray(x_true, dtype=float)
    xh = np.asarray(x_hat, dtype=float)
    lat, h = xh[0], xh[2]
    dx = np.empty(N_STATES)
    dx[0] = (xt[0] - lat) * (earth.meridian_radius(lat) + h)
    dx[1] = (xt[1] - xh[1]) * (earth.transverse_radius(lat) + h) * np.cos(lat)
    dx[2] = -(xt[2] - h)
    dx[VEL] = xt[NOM_VEL] - xh[NOM_VEL]
    dx[ATT] = attitude.quat_to_rotvec(
        attitude.quat_mult(xt[NOM_ATT], attitude.quat_conj(xh[NOM_ATT]))
    )
    dx[BA] = xt[NOM_BA] - xh[NOM_BA]
    dx[BG] = xt[NOM_BG] - xh[NOM_BG]
    return dx


RESET_OFF = 0
"""P is not reset after feedback (the paper's filters read literally)."""
RESET_ATTITUDE = 1
"""The attitude block's reset only: ``G_r = I + ½ [phî×]`` there (Solà 2017 §6.3)."""
RESET_INVARIANT = 2
"""The attitude block's reset and the velocity-attitude term ``-[dv̂×]`` (:func:`reset_jacobian`;
docs/filters.md, 'Feedback and reset'): the default."""


def reset_jacobian(dx: ArrayLike, mode: int = RESET_INVARIANT) -> Array:
    """Jacobian of the error reset after feedback: ``P ← G_r P G_rᵀ`` (docs/filters.md,
    'Feedback and reset').

    Attitude (``mode >= RESET_ATTITUDE``; Solà 2017 §6.3): with the left (n-frame) attitude error,
    the new error after injecting phî is ``phi' = Log(Exp(phi) Exp(-phî)) ≈ phi - phî + ½ phî ×
    phi``, so the attitude block is ``I + ½ [phî×]``.

    Velocity (``mode == RESET_INVARIANT``): the velocity error seen in the frame of the attitude
    error, ``ξ = dv + [v̂×] phi`` (the invariant error of Barrau & Bonnabel 2017), is carried
    across the feedback unchanged instead of dv. With v̂ moved by dv̂ that makes the
    velocity-attitude block ``-[dv̂×]``: a rotation of the whole solution about the vertical,
    ``(dv, phi) = (e_D × v̂, e_D)``, which no DVL reading sees, stays unseen at the moved v̂.
    Without it the next update takes ``e_D × dv̂`` as information on yaw that it is not, and the
    filter claims a heading it does not have.

    Other blocks (and declared ones) are the identity to first order; RESET_OFF: the identity.
    """
    d = np.asarray(dx, dtype=float)
    G = np.eye(max(d.size, N_STATES))  # declared states (StateLayout): identity
    if mode >= RESET_ATTITUDE:
        G[ATT, ATT] += 0.5 * attitude.skew(d[ATT])
    if mode == RESET_INVARIANT:
        G[VEL, ATT] = -attitude.skew(d[VEL])
    return G
