"""Doppler velocity log: velocity over ground of the DVL, resolved in the DVL frame.

Model (docs/filters.md, 'Measurement models'; Groves (2013) ch. 16, DVL aiding with lever
arm)::

    z = C_sb (C_nbᵀ v_n + ω_ib_b × l_b),    ω_ib_b = ω̃_ib_b - b_g,

with v_n the IMU's NED velocity, l_b the lever arm from the IMU to the DVL (body FRD, m), C_sb
the mounting rotation (DVL from body) and ω̃_ib_b the raw gyro rate. The earth-rate part of
ω_ib_b (Ω |l_b| ≈ 2e-4 m/s at 3 m) is kept, as that page states, rather than using ω_eb_b.

Linearisation for ``dx = x_true ⊖ x_hat``, ``C_true = Exp(phi) C`` so ``C_trueᵀ ≈ Cᵀ (I - [phi×])``,
and ``b_g,true = b_g + db_g``::

    H_dv   = C_sb Cᵀ
    H_phi  = C_sb Cᵀ [v_n×]              (-Cᵀ phi × v = Cᵀ v × phi)
    H_dbg  = C_sb [l_b×]                 (-(db_g × l) = l × db_g)

With its calibration states (docs/calibration.md), scale s, misalignment δ and bias b (DVL
frame), the DVL reads ``z = (1 + s) M(δ) h + b``, M of sensors/calibration.py: H becomes
``(1 + s) M H``, and its columns are ``M h`` on s, ``(1 + s) (∂M/∂δ_i) h`` on δ and the
identity on b (:func:`calibrate`, :func:`calibrate_jacobian`).

With a latency state τ_d (a reading stamped t taken at t - τ_d), h is first replaced by its
value τ_d earlier, to first order ``h - τ_d ḣ`` (docs/calibration.md, 'DVL latency'), with the
rate of the body velocity from the IMU (:func:`rate`)::

    ḣ ≈ C_sb (f̃ - b_a + C_nbᵀ g_n - ω × C_nbᵀ v_n),    ω = ω̃ - b_g

(``d/dt (C_nbᵀ v_n) = C_nbᵀ v̇_n - ω_nb × v_b`` with ``v̇_n = C_nb f + g_n``; the earth and
transport rates' terms, ~1e-4 m/s² at 2 m/s, and the lever arm's angular acceleration are
left out). Its H (:func:`rate_jacobian`): ``-C_sb [ω×] C_nbᵀ`` on dv,
``C_sb (C_nbᵀ [g_n×] - [ω×] C_nbᵀ [v_n×])`` on phi, ``-C_sb`` on db_a and ``-C_sb [v_b×]``
on db_g (gravity's change with position is left out: ~3e-6 /s² per m). H on the core becomes
``H - τ_d Ḣ``, and on τ_d it is ``-(1 + s) M ḣ``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude, earth
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, BA, BG, N_STATES, VEL
from adaptnav.models.strapdown import NOM_ATT, NOM_BA, NOM_BG, NOM_SIZE, NOM_VEL
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_rotation,
    check_sigma,
    check_state,
    check_vector3,
    need_force,
    readings_rate,
)
from adaptnav.sensors.calibration import (
    DVL_BIAS,
    LATENCY,
    MISALIGNMENT,
    SCALE,
    misalignment,
    misalignment_derivatives,
    widen,
)
from adaptnav.sensors.calibration import bias as nominal_bias
from adaptnav.sensors.kind import (
    MAX_SPEED_M_S,
    SPEED_RESOLUTION_M_S,
    IdealInput,
    SensorKind,
    StuckDefault,
    pack_params,
)

DIM = 3


def _rate(x: Array, omega_ib_b: ArrayLike | None, l_b: Array) -> Array:
    """Bias-corrected body rate; a missing rate is only acceptable without a lever arm."""
    if omega_ib_b is None:
        if np.any(l_b != 0.0):
            raise ValueError("a DVL with a non-zero lever arm needs the gyro rate omega_ib_b")
        return np.zeros(3)
    w = np.asarray(omega_ib_b, dtype=float)
    if w.shape != (3,):
        raise ValueError(f"omega_ib_b must have shape (3,), got {w.shape}")
    return np.asarray(w - x[NOM_BG], dtype=float)


def predict(
    x: ArrayLike,
    omega_ib_b: ArrayLike | None,
    l_b: ArrayLike = (0.0, 0.0, 0.0),
    C_sb: ArrayLike | None = None,
) -> Array:
    """h(x) = C_sb (C_nbᵀ v_n + (ω̃_ib_b - b_g) × l_b), the velocity the DVL should read (m/s)."""
    xa = check_state(x)
    lever = np.asarray(l_b, dtype=float)
    C = attitude.quat_to_dcm(xa[NOM_ATT])
    v_b = C.T @ xa[NOM_VEL] + np.cross(_rate(xa, omega_ib_b, lever), lever)
    C_s = np.eye(3) if C_sb is None else np.asarray(C_sb, dtype=float)
    return np.asarray(C_s @ v_b, dtype=float)


def jacobian(
    x: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0), C_sb: ArrayLike | None = None
) -> Array:
    """H (3×15): dv, phi and db_g blocks of the module docstring (independent of the rate)."""
    xa = check_state(x)
    C = attitude.quat_to_dcm(xa[NOM_ATT])
    C_s = np.eye(3) if C_sb is None else np.asarray(C_sb, dtype=float)
    C_sn = C_s @ C.T
    H = np.zeros((DIM, N_STATES))
    H[:, VEL] = C_sn
    H[:, ATT] = C_sn @ attitude.skew(xa[NOM_VEL])
    H[:, BG] = C_s @ attitude.skew(l_b)
    return H


def rate(
    x: ArrayLike, omega_ib_b: ArrayLike, f_ib_b: ArrayLike, C_sb: ArrayLike | None = None
) -> Array:
    """``ḣ ≈ C_sb (f̃ - b_a + C_nbᵀ g_n - ω × C_nbᵀ v_n)``, the rate of the error-free reading
    (m/s², module docstring), from the raw gyro rate and specific force."""
    xa = check_state(x)
    C = attitude.quat_to_dcm(xa[NOM_ATT])
    v_b = C.T @ xa[NOM_VEL]
    w = _rate(xa, omega_ib_b, np.zeros(3))
    f = need_force(f_ib_b, "a DVL's rate")
    acc = f - xa[NOM_BA] + C.T @ earth.gravity_n(xa[0], xa[2]) - np.cross(w, v_b)
    C_s = np.eye(3) if C_sb is None else np.asarray(C_sb, dtype=float)
    return np.asarray(C_s @ acc, dtype=float)


def rate_jacobian(x: ArrayLike, omega_ib_b: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """Ḣ (3×15), the error state's effect on :func:`rate` (module docstring)."""
    xa = check_state(x)
    C = attitude.quat_to_dcm(xa[NOM_ATT])
    C_s = np.eye(3) if C_sb is None else np.asarray(C_sb, dtype=float)
    W = attitude.skew(_rate(xa, omega_ib_b, np.zeros(3)))
    g = earth.gravity_n(xa[0], xa[2])
    H = np.zeros((DIM, N_STATES))
    H[:, VEL] = -C_s @ W @ C.T
    H[:, ATT] = C_s @ (C.T @ attitude.skew(g) - W @ C.T @ attitude.skew(xa[NOM_VEL]))
    H[:, BA] = -C_s
    H[:, BG] = -C_s @ attitude.skew(C.T @ xa[NOM_VEL])
    return H


def _calibration(x: Array, scale: int, mis: int) -> tuple[float, Array]:
    """``(1 + s, δ)`` of the state x, for the error-state indices ``scale``, ``mis`` of the
    scale and the first misalignment state (-1: not estimated, 0 and zeros; nominal values at
    index + 1)."""
    gain = 1.0 + x[scale + 1] if scale >= 0 else 1.0
    return gain, (x[mis + 1 : mis + 4] if mis >= 0 else np.zeros(3))


def calibrate(x: ArrayLike, h: Array, scale: int, mis: int, bias: int = -1) -> Array:
    """The calibrated reading ``(1 + s) M(δ) h + b`` of the error-free ``h`` (module
    docstring; ``bias``: the error-state index of b_x, -1: none)."""
    xa = np.asarray(x, dtype=float)
    gain, d = _calibration(xa, scale, mis)
    return np.asarray(gain * misalignment(d) @ h + nominal_bias(xa, bias, DIM), dtype=float)


def calibrate_jacobian(
    x: ArrayLike, h: Array, H: Array, scale: int, mis: int, bias: int = -1
) -> Array:
    """H of the calibrated reading (module docstring) from the error-free ``h`` and the core's
    ``H`` (3×15): a column per error state of x (15 + m)."""
    xa = np.asarray(x, dtype=float)
    gain, d = _calibration(xa, scale, mis)
    M = misalignment(d)
    out = widen(xa, gain * M @ H)
    if scale >= 0:
        out[:, scale] = M @ h
    if mis >= 0:
        for i, dM in enumerate(misalignment_derivatives(d)):
            out[:, mis + i] = gain * dM @ h
    if bias >= 0:
        out[:, bias : bias + 3] += np.eye(3)
    return out


@dataclass(frozen=True, eq=False)
class DVL(Components):
    """DVL bottom-track velocity sensor.

    Attributes:
        sigma: nominal noise σ per DVL axis (m/s); a scalar applies to all three.
        l_b: lever arm from the IMU to the DVL, body FRD (m).
        C_sb: mounting rotation, DVL frame from body frame (identity: DVL axes = body axes).
        name: sensor name; components are named ``{name}_x``, ``_y``, ``_z``.
        cal_scale, cal_misalignment, cal_bias, cal_latency: error-state indices of its scale
            state, its first misalignment state, its first bias state and its latency state
            (docs/calibration.md); -1: not estimated.
    """

    COMPONENTS: ClassVar[tuple[str, ...]] = ("x", "y", "z")

    LIN_CODE: ClassVar[int] = 0
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    sigma: float | Array
    l_b: Array = field(default_factory=lambda: np.zeros(3))
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "dvl"
    cal_scale: int = -1
    cal_misalignment: int = -1
    cal_bias: int = -1
    cal_latency: int = -1

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_sigma("sigma", self.sigma, DIM))
        object.__setattr__(self, "l_b", check_vector3("l_b", self.l_b))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        cal = (self.cal_scale, self.cal_misalignment, self.cal_bias, self.cal_latency)
        return pack_params(self.l_b, self.C_sb, calibration=cal)

    @property
    def midpoint_update(self) -> bool:
        """Its reading multiplies declared states with the core's (the scale times the velocity,
        the misalignment rotating it): the engine linearises its updates at the midpoint of
        their step (compiled.update._midpoint; docs/calibration.md, 'The midpoint update')."""
        return self.cal_scale >= 0 or self.cal_misalignment >= 0 or self.cal_latency >= 0

    def _delayed(
        self, x: Array, omega_ib_b: ArrayLike | None, f_ib_b: ArrayLike | None, with_H: bool
    ) -> tuple[Array, Array | None, Array | None]:
        """The error-free h of ``x``'s core, τ_d earlier with a latency state (``h - τ_d ḣ``),
        its H on the core when ``with_H`` (``H - τ_d Ḣ``), and ḣ (None without a latency
        state; module docstring)."""
        core = x[:NOM_SIZE]
        h = predict(core, omega_ib_b, self.l_b, self.C_sb)
        H = jacobian(core, self.l_b, self.C_sb) if with_H else None
        if self.cal_latency < 0 or x.size == NOM_SIZE:
            return h, H, None
        if omega_ib_b is None:
            raise ValueError("a DVL with a latency state needs the gyro rate omega_ib_b")
        w = omega_ib_b
        delay = x[self.cal_latency + 1]
        h_dot = rate(core, w, need_force(f_ib_b, "a DVL with a latency state"), self.C_sb)
        if H is not None:
            H = H - delay * rate_jacobian(core, w, self.C_sb)
        return h - delay * h_dot, H, h_dot

    def _calibrated(
        self, x: Array, omega_ib_b: ArrayLike | None, f_ib_b: ArrayLike | None
    ) -> tuple[Array, Array]:
        """The (delayed) error-free h of ``x``'s core and H (:func:`calibrate_jacobian`; 3 × 15
        on the core alone; ``-(1 + s) M ḣ`` on the latency)."""
        h, H, h_dot = self._delayed(x, omega_ib_b, f_ib_b, True)
        assert H is not None
        if x.size == NOM_SIZE:
            return h, H
        cal = (self.cal_scale, self.cal_misalignment, self.cal_bias)
        out = calibrate_jacobian(x, h, H, *cal)
        if h_dot is not None:
            gain, d = _calibration(x, self.cal_scale, self.cal_misalignment)
            out[:, self.cal_latency] = -gain * misalignment(d) @ h_dot
        return h, out

    def predict(
        self, x: ArrayLike, omega_ib_b: ArrayLike | None = None, f_ib_b: ArrayLike | None = None
    ) -> Array:
        """See :func:`predict` (and :func:`calibrate` for a state with declared states);
        ``omega_ib_b`` is the raw gyro rate (rad/s), ``f_ib_b`` the raw specific force (m/s²,
        needed with a latency state)."""
        xa = np.asarray(x, dtype=float)
        h = self._delayed(xa, omega_ib_b, f_ib_b, False)[0]
        if xa.size == NOM_SIZE:
            return h
        return calibrate(xa, h, self.cal_scale, self.cal_misalignment, self.cal_bias)

    def jacobian(
        self, x: ArrayLike, omega_ib_b: ArrayLike | None = None, f_ib_b: ArrayLike | None = None
    ) -> Array:
        """See :func:`jacobian` (and :func:`calibrate_jacobian`: 3 × (15 + m) for a state with
        m declared states; it needs the rate then, for the lever arm's part of h, and with a
        latency state the specific force)."""
        xa = np.asarray(x, dtype=float)
        if xa.size == NOM_SIZE:
            return jacobian(xa, self.l_b, self.C_sb)
        return self._calibrated(xa, omega_ib_b, f_ib_b)[1]

    def evaluate(
        self,
        x: Array,
        z: ArrayLike,
        omega_ib_b: ArrayLike | None = None,
        f_ib_b: ArrayLike | None = None,
    ) -> Measurement | None:
        """Residual ``z - h(x)``, H and R; None if the reading has a NaN/inf (lost bottom lock).

        ``omega_ib_b`` (raw gyro rate, rad/s) is required when the lever arm is non-zero,
        ``f_ib_b`` (raw specific force, m/s²) with a latency state.
        """
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        xa = np.asarray(x, dtype=float)
        h, H = self._calibrated(xa, omega_ib_b, f_ib_b)
        if xa.size > NOM_SIZE:
            h = calibrate(xa, h, self.cal_scale, self.cal_misalignment, self.cal_bias)
        return Measurement(zz - h, H, self.R, self.names)


DVL_STUCK_S = 10.0
"""A DVL's noise (mm/s per ping, even at rest) spans its output step, so ten seconds of one
vector is a frozen driver; it is longer than a ping interval, even in deep water (a driver that
holds the last ping until the next one repeats it that long)."""
DVL_AFTER_GAP_S = 10.0
"""A gap in the DVL's readings after which its first readings are screened against the ones
after them (``after_gap_s``, docs/robustness.md 'After a gap'): by then the velocity the
filter carries is no better than one reading (a tactical IMU's 0.25-mg accelerometer bias
alone gives 2.5 cm/s in 10 s, a DVL's σ at 2 m/s is 4 cm/s), so the innovation can no longer
tell a spike from the drift."""
COLUMNS = ("vx_m_s", "vy_m_s", "vz_m_s")


def ideal(t: IdealInput) -> Array:
    """Error-free readings (N, 3): :func:`predict` at each true state and body rate, over all N
    at once, ``C_sb (C_nbᵀ v_n + (ω_ib_b - b_g) × l_b)``."""
    v_b = np.einsum("nji,nj->ni", t.C_nb, t.x[:, NOM_VEL])
    v_b += np.cross(t.omega_ib_b - t.x[:, NOM_BG], np.asarray(t.l_b, dtype=float))
    return t.to_sensor(v_b)


KIND = SensorKind(
    name="dvl",
    columns=COLUMNS,
    sigma_kind=Kind.SPEED,
    build=lambda s: DVL(
        s.sigma,
        s.l_b,
        s.C_sb,
        s.name,
        s.calibration.get("scale", -1),
        s.calibration.get("misalignment", -1),
        s.calibration.get("bias", -1),
        s.calibration.get("latency", -1),
    ),
    limits={c: (-MAX_SPEED_M_S, MAX_SPEED_M_S) for c in COLUMNS},
    stuck=StuckDefault(DVL_STUCK_S, {c: SPEED_RESOLUTION_M_S for c in COLUMNS}),
    lever_arm=True,
    mounting=True,
    options=frozenset(
        {"zero_is_lost", "status_column", "spike_mads", "after_gap_s", "scale_check"}
    ),
    linearised=(DVL,),
    calibration={q.name: q for q in (SCALE, MISALIGNMENT, DVL_BIAS, LATENCY)},
    ideal_reading=ideal,
    reading_rate=readings_rate,
)
"""The DVL as a sensor kind (sensors/kind.py): |velocity| <= 20 m/s per axis; stuck after 10 s
within 0.01 mm/s (docs/robustness.md)."""
