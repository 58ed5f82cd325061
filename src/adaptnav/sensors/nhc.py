"""Non-holonomic constraint (NHC): a land vehicle's wheels do not slip sideways or leave the road.

A pseudo-measurement (Groves (2013) §13.1.2 "land-vehicle motion constraints"; Shin 2001): at a
point of the vehicle on the rear axle the velocity has no lateral and no vertical component in
the vehicle frame, so those two components "read" z = 0. The model is the DVL's body velocity
of a point (:mod:`adaptnav.sensors.dvl`) without its forward component::

    h(x) = P C_sb (C_nbᵀ v_n + ω_ib_b × l_b),    P = [[0, 1, 0], [0, 0, 1]],

with l_b the lever arm from the IMU to the constrained point (body FRD, m), C_sb the vehicle
frame from the body frame (the IMU's residual mounting yaw, say) and ω_ib_b = ω̃_ib_b - b_g. Its
Jacobian is the DVL's last two rows. σ (m/s, lateral and vertical) is what the constraint
allows for: sideslip in turns, suspension travel, a lever arm known only roughly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core.units import Kind
from adaptnav.sensors import dvl
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_rotation,
    check_sigma,
    check_vector3,
)
from adaptnav.sensors.kind import (
    MAX_SPEED_M_S,
    SPEED_RESOLUTION_M_S,
    SensorKind,
    StuckDefault,
    pack_params,
)

DIM = 2
ROWS = slice(1, 3)
"""The lateral (y) and vertical (z) components of the vehicle-frame velocity."""


def predict(
    x: ArrayLike,
    omega_ib_b: ArrayLike | None,
    l_b: ArrayLike = (0.0, 0.0, 0.0),
    C_sb: ArrayLike | None = None,
) -> Array:
    """h(x): the lateral and vertical velocity of the constrained point (m/s, shape (2,))."""
    return np.asarray(dvl.predict(x, omega_ib_b, l_b, C_sb)[ROWS], dtype=float)


def jacobian(
    x: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0), C_sb: ArrayLike | None = None
) -> Array:
    """H (2×15): rows y and z of :func:`adaptnav.sensors.dvl.jacobian`."""
    return np.asarray(dvl.jacobian(x, l_b, C_sb)[ROWS], dtype=float)


@dataclass(frozen=True, eq=False)
class NonHolonomic(Components):
    """Non-holonomic constraint of a land vehicle.

    Attributes:
        sigma: σ of the lateral and vertical velocity the constraint allows (m/s); a scalar
            applies to both.
        l_b: lever arm from the IMU to the constrained point (rear axle), body FRD (m).
        C_sb: vehicle frame from body frame (identity: the IMU's axes are the vehicle's).
        name: sensor name; components are ``{name}_y``, ``{name}_z``.
    """

    COMPONENTS: ClassVar[tuple[str, ...]] = ("y", "z")
    CONSTRAINT: ClassVar[bool] = True

    sigma: float | Array
    l_b: Array = field(default_factory=lambda: np.zeros(3))
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "nhc"

    LIN_CODE: ClassVar[int] = 7
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params(self.l_b, self.C_sb)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_sigma("sigma", self.sigma, DIM))
        object.__setattr__(self, "l_b", check_vector3("l_b", self.l_b))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))

    def predict(self, x: ArrayLike, omega_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`predict`; ``omega_ib_b`` is the raw gyro rate (rad/s)."""
        return predict(x, omega_ib_b, self.l_b, self.C_sb)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`."""
        return jacobian(x, self.l_b, self.C_sb)

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual ``z - h(x)`` (z is normally 0), H and R; None for a NaN/inf reading (the
        constraint does not hold then, e.g. on a ferry)."""
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        y = zz - self.predict(x, omega_ib_b)
        return Measurement(y, self.jacobian(x), self.R, self.names)


KIND = SensorKind(
    name="nhc",
    columns=("vy_m_s", "vz_m_s"),
    sigma_kind=Kind.SPEED,
    build=lambda s: NonHolonomic(s.sigma, s.l_b, s.C_sb, s.name),
    limits={c: (-MAX_SPEED_M_S, MAX_SPEED_M_S) for c in ("vy_m_s", "vz_m_s")},
    # Off: the constraint's readings are zero by construction, every one "unchanged".
    stuck=StuckDefault(0.0, {c: SPEED_RESOLUTION_M_S for c in ("vy_m_s", "vz_m_s")}),
    lever_arm=True,
    mounting=True,
    linearised=(NonHolonomic,),
)
"""The non-holonomic constraint as a sensor kind (sensors/kind.py); its readings are zeros
(the RTKLIB importer writes them, docs/rtklib.md), so it has no ``ideal_reading``: the simulator
does not make it."""
