"""Depth meter (pressure sensor): depth of the sensor point below the water surface.

Model (docs/filters.md, 'Measurement models'; Groves (2013) ch. 16, height/depth aiding with
lever arm)::

    z = h_s - h + (C_nb l_b)_D,

the sensor sitting at ``r_n + C_nb l_b`` (NED) with l_b the lever arm from the IMU (body FRD, m),
and ``h_s`` the height of the water surface, where the meter reads zero, in the frame of the
navigation's heights (``[sensors.<name>] surface_h_m``, default 0: heights measured from the
surface). GNSS heights are ellipsoidal, and the sea surface lies near the geoid, tens of metres
off the ellipsoid: docs/filters.md, 'Depth and the water surface'. Conversion of pressure to
depth (water density, atmospheric pressure) happens before this model.

Linearisation for ``dx = x_true ⊖ x_hat`` (``h_true = h - dr_D``, ``C_true = Exp(phi) C``), with
``a = C_nb l_b``: ``-h_true = -h + dr_D`` and ``(Exp(phi) a)_D ≈ a_D + (phi × a)_D``, so::

    H_drD = 1,    H_phi = -[a×]_(D row) = [a_E, -a_N, 0].

With its bias state b (docs/calibration.md) it reads ``z + b``; H has 1 on b.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, N_STATES, POS
from adaptnav.models.strapdown import NOM_ATT, NOM_SIZE
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_scalar_sigma,
    check_state,
    check_vector3,
)
from adaptnav.sensors.calibration import DEPTH_BIAS, bias, bias_jacobian
from adaptnav.sensors.kind import (
    SLOW_STUCK_S,
    IdealInput,
    SensorKind,
    StuckDefault,
    pack_params,
)

DIM = 1


def predict(x: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0), surface_h: float = 0.0) -> Array:
    """h(x) = [h_s - h + (C_nb l_b)_D], the depth the sensor should read (m, shape (1,))."""
    xa = check_state(x)
    a = attitude.quat_to_dcm(xa[NOM_ATT]) @ np.asarray(l_b, dtype=float)
    return np.array([surface_h - xa[2] + a[2]])


def jacobian(x: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0)) -> Array:
    """H (1×15): 1 on dr_D, ``[a_E, -a_N, 0]`` on phi (a = C_nb l_b)."""
    xa = check_state(x)
    a = attitude.quat_to_dcm(xa[NOM_ATT]) @ np.asarray(l_b, dtype=float)
    H = np.zeros((DIM, N_STATES))
    H[0, POS] = (0.0, 0.0, 1.0)
    H[0, ATT] = -attitude.skew(a)[2]
    return H


@dataclass(frozen=True, eq=False)
class Depth(Components):
    """Depth sensor.

    Attributes:
        sigma: nominal noise σ (m).
        l_b: lever arm from the IMU to the pressure port, body FRD (m).
        name: sensor name, also the component's name.
        cal_bias: error-state index of its bias state (docs/calibration.md); -1: none.
        surface_h: height of the water surface, where it reads zero (m, in the navigation
            heights' frame: ellipsoidal when they come from GNSS).
    """

    sigma: float
    l_b: Array = field(default_factory=lambda: np.zeros(3))
    name: str = "depth"
    cal_bias: int = -1
    surface_h: float = 0.0

    LIN_CODE: ClassVar[int] = 1
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params(self.l_b, flag=self.surface_h, calibration=(self.cal_bias, -1))

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_scalar_sigma("sigma", self.sigma))
        object.__setattr__(self, "l_b", check_vector3("l_b", self.l_b))
        object.__setattr__(self, "name", check_name("name", self.name))
        if not math.isfinite(self.surface_h):
            raise ValueError(f"surface_h: value {self.surface_h!r} must be finite")

    def predict(self, x: ArrayLike) -> Array:
        """See :func:`predict` (plus the bias state, if any: sensors/calibration.py)."""
        xa = np.asarray(x, dtype=float)
        return predict(xa[:NOM_SIZE], self.l_b, self.surface_h) + bias(xa, self.cal_bias, DIM)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`; a column per error state of x (15 + m)."""
        xa = np.asarray(x, dtype=float)
        return bias_jacobian(xa, jacobian(xa[:NOM_SIZE], self.l_b), self.cal_bias)

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual ``z - h(x)`` (m), H and R; None if the reading is NaN/inf.

        ``z`` is a scalar or shape (1,); ``omega_ib_b`` is not used.
        """
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        return Measurement(zz - self.predict(x), self.jacobian(x), self.R, self.names)


def ideal(t: IdealInput) -> Array:
    """Error-free readings (N, 1): :func:`predict` at each true state, over all N at once,
    ``-h + (C_nb l_b)_D``."""
    return (t.lever_n[:, 2] - t.x[:, 2])[:, None]


DEPTH_RESOLUTION_M = 1e-4
"""0.1 mm: a tenth of the 1 mm step of a fine depth meter's output."""

KIND = SensorKind(
    name="depth",
    columns=("depth_m",),
    sigma_kind=Kind.LENGTH,
    build=lambda s: Depth(
        float(np.asarray(s.sigma).reshape(-1)[0]),
        s.l_b,
        s.name,
        s.calibration.get("bias", -1),
        s.surface_h,
    ),
    limits={"depth_m": (-100.0, 12000.0)},
    stuck=StuckDefault(SLOW_STUCK_S, {"depth_m": DEPTH_RESOLUTION_M}),
    lever_arm=True,
    linearised=(Depth,),
    options=frozenset({"surface_h_m", "scale_check"}),
    calibration={"bias": DEPTH_BIAS},
    ideal_reading=ideal,
)
"""The depth meter as a sensor kind (sensors/kind.py): depth in [-100, 12000] m (above the
surface / below the deepest trench); stuck after 60 s within 0.1 mm (docs/robustness.md)."""
