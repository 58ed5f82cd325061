"""Zero-velocity update (ZUPT): a stationary vehicle's NED velocity is zero.

A pseudo-measurement used during static alignment (docs/alignment.md, 'Fine alignment'; Groves
(2013) §15.3.1 zero-velocity update, §14.4 fine alignment): the vehicle is known to be at rest,
so its velocity "reads" z = 0. The model is more generally a direct NED velocity observation of
the IMU point::

    h(x) = v_n,    z = 0 (at rest),    y = z - h(x_hat) = -v_n_hat.

Linearisation for ``dx = x_true ⊖ x_hat`` (``v_true = v_hat + dv``): ``h(x_hat ⊕ dx) = v_hat + dv``
exactly, so ``H = [0 I 0 0 0]`` (identity on the dv block). No lever arm: at rest every point of
the body moves only with the earth, whose rotation the n-frame already carries.

σ is the velocity noise the rest assumption allows for (a moored vessel sways): 0.01 m/s by
default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.models.errorstate import N_STATES, VEL
from adaptnav.models.strapdown import NOM_VEL
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_scalar_sigma,
    check_state,
)
from adaptnav.sensors.kind import pack_params

DIM = 3


def predict(x: ArrayLike) -> Array:
    """h(x) = v_n, the NED velocity of the IMU (m/s, shape (3,))."""
    return np.array(check_state(x)[NOM_VEL], dtype=float)


def jacobian(x: ArrayLike) -> Array:
    """H (3×15): identity on dv, zero elsewhere."""
    check_state(x)
    H = np.zeros((DIM, N_STATES))
    H[:, VEL] = np.eye(3)
    return H


@dataclass(frozen=True, eq=False)
class ZeroVelocity(Components):
    """Zero-velocity pseudo-measurement for a stationary vehicle.

    Attributes:
        sigma: noise σ of each NED velocity component (m/s).
        name: sensor name; components are ``{name}_N``, ``{name}_E``, ``{name}_D``.
    """

    COMPONENTS: ClassVar[tuple[str, ...]] = ("N", "E", "D")
    CONSTRAINT: ClassVar[bool] = True

    sigma: float = 0.01
    name: str = "zupt"

    LIN_CODE: ClassVar[int] = 5
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params()

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_scalar_sigma("sigma", self.sigma))
        object.__setattr__(self, "name", check_name("name", self.name))

    def predict(self, x: ArrayLike) -> Array:
        """See :func:`predict`."""
        return predict(x)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`."""
        return jacobian(x)

    def evaluate(
        self, x: Array, z: ArrayLike = (0.0, 0.0, 0.0), omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual ``z - v_n`` (m/s; ``-v_n`` for the usual z = 0), H and R; None if z has a
        NaN/inf. ``z`` has shape (3,); ``omega_ib_b`` is not used."""
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        return Measurement(zz - self.predict(x), self.jacobian(x), self.R, self.names)
