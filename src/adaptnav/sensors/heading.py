"""Heading sensor / gyrocompass / magnetic compass (after declination): yaw.

Model (docs/filters.md, 'Measurement models'; Groves (2013) ch. 16, heading aiding)::

    z = yaw of C_ns = C_nb C_sbᵀ    (ZYX, attitude.dcm_to_euler, true north),

with C_sb the mounting rotation (sensor from body). The residual ``y = wrap(z - ψ_hat)`` lies in
(-π, π], so a reading of +179° against a prediction of -179° is -2°, not +358°.

Linearisation for ``C_true = Exp(phi) C``: the yaw row of
:func:`adaptnav.sensors.base.euler_jacobian` of C_ns, ``H_phi = [cψ tθ, sψ tθ, 1]``; at level
attitude only phi_D is seen. Singular at pitch = ±90°.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, N_STATES
from adaptnav.models.strapdown import NOM_ATT
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_rotation,
    check_scalar_sigma,
    check_state,
    euler_jacobian,
)
from adaptnav.sensors.kind import (
    ANGLE_RESOLUTION_RAD,
    SLOW_STUCK_S,
    IdealInput,
    SensorKind,
    StuckDefault,
    pack_params,
)

DIM = 1


def _C_ns(x: Array, C_sb: ArrayLike | None) -> Array:
    C = attitude.quat_to_dcm(x[NOM_ATT])
    if C_sb is None:
        return C
    return np.asarray(C @ np.asarray(C_sb, dtype=float).T, dtype=float)


def predict(x: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """h(x) = [yaw of ``C_nb C_sbᵀ``] in (-π, π] (rad, shape (1,))."""
    return attitude.dcm_to_euler(_C_ns(check_state(x), C_sb))[2:]


def jacobian(x: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """H (1×15): ``[cψ tθ, sψ tθ, 1]`` on phi."""
    H = np.zeros((DIM, N_STATES))
    H[:, ATT] = euler_jacobian(_C_ns(check_state(x), C_sb))[2:]
    return H


@dataclass(frozen=True, eq=False)
class Heading(Components):
    """Heading (yaw) sensor.

    Attributes:
        sigma: nominal noise σ (rad).
        C_sb: mounting rotation, sensor frame from body frame.
        name: sensor name, also the component's name.
    """

    sigma: float
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "heading"

    LIN_CODE: ClassVar[int] = 3
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params(C_sb=self.C_sb)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_scalar_sigma("sigma", self.sigma))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))

    def predict(self, x: ArrayLike) -> Array:
        """See :func:`predict`."""
        return predict(x, self.C_sb)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`."""
        return jacobian(x, self.C_sb)

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual ``wrap(z - h(x))`` in (-π, π] (rad), H and R; None if z is NaN/inf.

        ``z`` is a scalar or shape (1,), any branch (it is wrapped); ``omega_ib_b`` is not used.
        """
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        y = attitude.wrap_angle(zz - self.predict(x))
        return Measurement(y, self.jacobian(x), self.R, self.names)


def ideal(t: IdealInput) -> Array:
    """Error-free readings (N, 1): :func:`predict` at each true state, over all N at once (the
    yaw of ``C_nb C_sbᵀ``)."""
    return t.euler_ns[:, 2:]


KIND = SensorKind(
    name="heading",
    columns=("yaw_rad",),
    sigma_kind=Kind.ANGLE,
    build=lambda s: Heading(float(np.asarray(s.sigma).reshape(-1)[0]), s.C_sb, s.name),
    limits={"yaw_rad": (-2.0 * math.pi, 2.0 * math.pi)},
    stuck=StuckDefault(SLOW_STUCK_S, {"yaw_rad": ANGLE_RESOLUTION_RAD}),
    mounting=True,
    linearised=(Heading,),
    ideal_reading=ideal,
)
"""The heading sensor as a sensor kind (sensors/kind.py): heading within ±360°; stuck after
60 s within 1e-6 rad (docs/robustness.md)."""
