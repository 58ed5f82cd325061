"""Inclinometer: roll and pitch of the sensor's axes, ZYX Euler angles (spec §4).

Model (spec §4 table; Groves (2013) ch. 16, attitude aiding)::

    z = [roll, pitch] of C_ns = C_nb C_sbᵀ    (attitude.dcm_to_euler, ZYX),

with C_sb the mounting rotation (sensor from body; identity when the inclinometer is aligned with
the IMU). A lever arm does not matter: every point of a rigid body has the same attitude.

Linearisation for ``C_true = Exp(phi) C`` (so ``C_ns,true = Exp(phi) C_ns``, same phi): the roll
and pitch rows of :func:`adaptnav.sensors.base.euler_jacobian` of C_ns::

    H_phi = [[cψ/cθ, sψ/cθ, 0], [-sψ, cψ, 0]]    (ψ, θ the yaw and pitch of C_ns).

Residuals are in rad and wrapped to (-π, π]. The model is singular at pitch = ±90°.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from adaptnav import attitude
from adaptnav.errorstate import ATT, N_STATES
from adaptnav.sensors.base import (
    Array,
    Measurement,
    check_name,
    check_reading,
    check_rotation,
    check_sigma,
    check_state,
    euler_jacobian,
)
from adaptnav.strapdown import NOM_ATT

DIM = 2


def _C_ns(x: Array, C_sb: ArrayLike | None) -> Array:
    C = attitude.quat_to_dcm(x[NOM_ATT])
    if C_sb is None:
        return C
    return np.asarray(C @ np.asarray(C_sb, dtype=float).T, dtype=float)


def predict(x: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """h(x) = [roll, pitch] of ``C_nb C_sbᵀ`` (rad)."""
    return attitude.dcm_to_euler(_C_ns(check_state(x), C_sb))[:2]


def jacobian(x: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """H (2×15): the roll and pitch rows of the Euler-angle Jacobian on phi."""
    H = np.zeros((DIM, N_STATES))
    H[:, ATT] = euler_jacobian(_C_ns(check_state(x), C_sb))[:2]
    return H


@dataclass(frozen=True, eq=False)
class Inclinometer:
    """Two-axis inclinometer (roll, pitch).

    Attributes:
        sigma: nominal noise σ of [roll, pitch] (rad); a scalar applies to both.
        C_sb: mounting rotation, sensor frame from body frame.
        name: sensor name; components are ``{name}_roll``, ``{name}_pitch``.
    """

    sigma: float | Array
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "inclinometer"

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_sigma("sigma", self.sigma, DIM))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))

    @property
    def dim(self) -> int:
        return DIM

    @property
    def names(self) -> tuple[str, ...]:
        return (f"{self.name}_roll", f"{self.name}_pitch")

    @property
    def R(self) -> Array:
        return np.diag(np.asarray(self.sigma, dtype=float) ** 2)

    def predict(self, x: ArrayLike) -> Array:
        """See :func:`predict`."""
        return predict(x, self.C_sb)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`."""
        return jacobian(x, self.C_sb)

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Wrapped residual ``z - h(x)`` (rad), H and R; None if the reading has a NaN/inf.

        ``omega_ib_b`` is not used.
        """
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        y = attitude.wrap_angle(zz - self.predict(x))
        return Measurement(y, self.jacobian(x), self.R, self.names)
