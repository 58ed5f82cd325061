"""Heading sensor / gyrocompass / magnetic compass (after declination): yaw.

Model (docs/filters.md, 'Measurement models'; Groves (2013) ch. 16, heading aiding)::

    z = yaw of C_ns = C_nb C_sbᵀ    (ZYX, attitude.dcm_to_euler, true north),

with C_sb the mounting rotation (sensor from body). The residual ``y = wrap(z - ψ_hat)`` lies in
(-π, π], so a reading of +179° against a prediction of -179° is -2°, not +358°.

Linearisation for ``C_true = Exp(phi) C``: the yaw row of
:func:`adaptnav.sensors.base.euler_jacobian` of C_ns, ``H_phi = [cψ tθ, sψ tθ, 1]``; at level
attitude only phi_D is seen. Singular at pitch = ±90°.

With a latency state τ (docs/calibration.md, 'Heading latency': a reading stamped t is the
heading at t - τ) the reading is ``ψ - τ ψ̇`` with the heading's rate from the gyro,
``ψ̇ = E_ψ · u``, ``u = C_nb ω`` (ω = ω̃ - b_g; the earth and transport rates, ~1e-4 rad/s,
left out), ``E_ψ = [cψ tθ, sψ tθ, 1]`` and ``E_θ = [-sψ, cψ, 0]`` the yaw and pitch rows of
the Euler-angle Jacobian of C_ns. H gains ``-τ ∂ψ̇/∂dx`` and ``-ψ̇`` on τ::

    ∂ψ̇/∂phi  = (∂E_ψ/∂ψ · u) E_ψ + (∂E_ψ/∂θ · u) E_θ - E_ψ × u
    ∂ψ̇/∂db_g = -E_ψ C_nb
    ∂E_ψ/∂ψ = [-sψ tθ, cψ tθ, 0],   ∂E_ψ/∂θ = [cψ, sψ, 0] / c²θ
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, BG, N_STATES
from adaptnav.models.strapdown import NOM_ATT, NOM_BG, NOM_SIZE
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
    readings_rate,
)
from adaptnav.sensors.calibration import LATENCY, widen
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


def rate(x: ArrayLike, omega_ib_b: ArrayLike, C_sb: ArrayLike | None = None) -> float:
    """``ψ̇ = E_ψ · C_nb (ω̃ - b_g)``, the rate of the sensor's heading (rad/s; module
    docstring)."""
    xa = check_state(x)
    u = attitude.quat_to_dcm(xa[NOM_ATT]) @ (np.asarray(omega_ib_b, dtype=float) - xa[NOM_BG])
    return float(euler_jacobian(_C_ns(xa, C_sb))[2] @ u)


def rate_jacobian(x: ArrayLike, omega_ib_b: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """∂ψ̇/∂dx (1×15): on phi and db_g (module docstring)."""
    xa = check_state(x)
    C = attitude.quat_to_dcm(xa[NOM_ATT])
    u = C @ (np.asarray(omega_ib_b, dtype=float) - xa[NOM_BG])
    E = euler_jacobian(_C_ns(xa, C_sb))
    _, pitch, yaw = attitude.dcm_to_euler(_C_ns(xa, C_sb))
    sy, cy, tp, cp = math.sin(yaw), math.cos(yaw), math.tan(pitch), math.cos(pitch)
    d_yaw = np.array([-sy * tp, cy * tp, 0.0]) @ u
    d_pitch = np.array([cy, sy, 0.0]) @ u / (cp * cp)
    H = np.zeros((DIM, N_STATES))
    H[0, ATT] = d_yaw * E[2] + d_pitch * E[1] - np.cross(E[2], u)
    H[0, BG] = -E[2] @ C
    return H


@dataclass(frozen=True, eq=False)
class Heading(Components):
    """Heading (yaw) sensor.

    Attributes:
        sigma: nominal noise σ (rad).
        C_sb: mounting rotation, sensor frame from body frame.
        name: sensor name, also the component's name.
        cal_latency: error-state index of its latency state (s; module docstring); -1: none.
    """

    sigma: float
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "heading"
    cal_latency: int = -1

    LIN_CODE: ClassVar[int] = 3
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params(C_sb=self.C_sb, calibration=(-1, -1, -1, self.cal_latency))

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_scalar_sigma("sigma", self.sigma))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))

    @property
    def midpoint_update(self) -> bool:
        """With a latency state its reading multiplies τ with the turn rate: linearised at the
        midpoint of the update's step (docs/calibration.md)."""
        return self.cal_latency >= 0

    def _lag(self, x: Array, omega_ib_b: ArrayLike | None) -> float:
        """τ of ``x`` (0 without a latency state)."""
        if self.cal_latency < 0 or x.size == NOM_SIZE:
            return 0.0
        if omega_ib_b is None:
            raise ValueError("a heading sensor with a latency state needs the gyro rate omega_ib_b")
        return float(x[self.cal_latency + 1])

    def predict(self, x: ArrayLike, omega_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`predict`; with a latency state ``ψ - τ ψ̇`` (``omega_ib_b``, the raw gyro
        rate, needed then)."""
        xa = np.asarray(x, dtype=float)
        h = predict(xa[:NOM_SIZE], self.C_sb)
        lag = self._lag(xa, omega_ib_b)
        if lag != 0.0:
            assert omega_ib_b is not None
            h = attitude.wrap_angle(h - lag * rate(xa[:NOM_SIZE], omega_ib_b, self.C_sb))
        return np.asarray(h, dtype=float)

    def jacobian(self, x: ArrayLike, omega_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`jacobian` (a column per error state of x, 15 + m); with a latency state
        ``H - τ ∂ψ̇/∂dx`` and ``-ψ̇`` on τ."""
        xa = np.asarray(x, dtype=float)
        H = widen(xa, jacobian(xa[:NOM_SIZE], self.C_sb))
        lag = self._lag(xa, omega_ib_b)
        if self.cal_latency >= 0 and H.shape[1] > N_STATES:
            assert omega_ib_b is not None
            H[:, :N_STATES] -= lag * rate_jacobian(xa[:NOM_SIZE], omega_ib_b, self.C_sb)
            H[0, self.cal_latency] = -rate(xa[:NOM_SIZE], omega_ib_b, self.C_sb)
        return H

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual ``wrap(z - h(x))`` in (-π, π] (rad), H and R; None if z is NaN/inf.

        ``z`` is a scalar or shape (1,), any branch (it is wrapped); ``omega_ib_b`` (the raw
        gyro rate) is used only with a latency state.
        """
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        y = attitude.wrap_angle(zz - self.predict(x, omega_ib_b))
        return Measurement(y, self.jacobian(x, omega_ib_b), self.R, self.names)


def heading_rate(z: Array, t: Array) -> Array:
    """``dψ/dt`` of headings z (n, 1) at times t, across the ±π wrap (:func:`readings_rate`)."""
    return readings_rate(np.unwrap(np.asarray(z, dtype=float), axis=0), t)


def ideal(t: IdealInput) -> Array:
    """Error-free readings (N, 1): :func:`predict` at each true state, over all N at once (the
    yaw of ``C_nb C_sbᵀ``)."""
    return t.euler_ns[:, 2:]


KIND = SensorKind(
    name="heading",
    columns=("yaw_rad",),
    sigma_kind=Kind.ANGLE,
    build=lambda s: Heading(
        float(np.asarray(s.sigma).reshape(-1)[0]), s.C_sb, s.name, s.calibration.get("latency", -1)
    ),
    limits={"yaw_rad": (-2.0 * math.pi, 2.0 * math.pi)},
    stuck=StuckDefault(SLOW_STUCK_S, {"yaw_rad": ANGLE_RESOLUTION_RAD}),
    mounting=True,
    options=frozenset({"declination_deg"}),
    linearised=(Heading,),
    calibration={"latency": LATENCY},
    ideal_reading=ideal,
    reading_rate=heading_rate,
)
"""The heading sensor as a sensor kind (sensors/kind.py): heading within ±360°; stuck after
60 s within 1e-6 rad (docs/robustness.md)."""
