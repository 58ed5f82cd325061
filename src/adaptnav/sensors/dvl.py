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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, BG, N_STATES, VEL
from adaptnav.models.strapdown import NOM_ATT, NOM_BG, NOM_VEL
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
)
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


@dataclass(frozen=True, eq=False)
class DVL(Components):
    """DVL bottom-track velocity sensor.

    Attributes:
        sigma: nominal noise σ per DVL axis (m/s); a scalar applies to all three.
        l_b: lever arm from the IMU to the DVL, body FRD (m).
        C_sb: mounting rotation, DVL frame from body frame (identity: DVL axes = body axes).
        name: sensor name; components are named ``{name}_x``, ``_y``, ``_z``.
    """

    COMPONENTS: ClassVar[tuple[str, ...]] = ("x", "y", "z")

    LIN_CODE: ClassVar[int] = 0
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    sigma: float | Array
    l_b: Array = field(default_factory=lambda: np.zeros(3))
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "dvl"

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_sigma("sigma", self.sigma, DIM))
        object.__setattr__(self, "l_b", check_vector3("l_b", self.l_b))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params(self.l_b, self.C_sb)

    def predict(self, x: ArrayLike, omega_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`predict`; ``omega_ib_b`` is the raw gyro rate (rad/s)."""
        return predict(x, omega_ib_b, self.l_b, self.C_sb)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`."""
        return jacobian(x, self.l_b, self.C_sb)

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual ``z - h(x)``, H and R; None if the reading has a NaN/inf (lost bottom lock).

        ``omega_ib_b`` (raw gyro rate, rad/s) is required when the lever arm is non-zero.
        """
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        y = zz - self.predict(x, omega_ib_b)
        return Measurement(y, self.jacobian(x), self.R, self.names)


DVL_STUCK_S = 10.0
"""A DVL's noise (mm/s per ping, even at rest) spans its output step, so ten seconds of one
vector is a frozen driver; it is longer than a ping interval, even in deep water (a driver that
holds the last ping until the next one repeats it that long)."""
COLUMNS = ("vx_m_s", "vy_m_s", "vz_m_s")


def ideal(t: IdealInput) -> Array:
    """Error-free readings (N, 3): :func:`predict` at each true state and body rate."""
    return t.each(lambda i: predict(t.x[i], t.omega_ib_b[i], t.l_b, t.C_sb), DIM)


KIND = SensorKind(
    name="dvl",
    columns=COLUMNS,
    sigma_kind=Kind.SPEED,
    build=lambda s: DVL(s.sigma, s.l_b, s.C_sb, s.name),
    limits={c: (-MAX_SPEED_M_S, MAX_SPEED_M_S) for c in COLUMNS},
    stuck=StuckDefault(DVL_STUCK_S, {c: SPEED_RESOLUTION_M_S for c in COLUMNS}),
    lever_arm=True,
    mounting=True,
    options=frozenset({"zero_is_lost", "status_column"}),
    linearised=(DVL,),
    ideal_reading=ideal,
)
"""The DVL as a sensor kind (sensors/kind.py): |velocity| <= 20 m/s per axis; stuck after 10 s
within 0.01 mm/s (docs/robustness.md)."""
