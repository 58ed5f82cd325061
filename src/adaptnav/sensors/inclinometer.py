"""Inclinometer: what a two-axis tilt sensor reads, in two models (docs/inclinometer.md).

**Attitude model** (:class:`Inclinometer`, ``model = "attitude"``): roll and pitch of the sensor's
axes, ZYX Euler angles (Groves (2013) ch. 16, attitude aiding), with white noise. It is right for
a sensor that measures the attitude itself (a gyro-stabilised reference, an INS's output); a
pendulum read so is trusted in turns and waves where it is wrong.

**Pendulum model** (:class:`PendulumInclinometer`, ``model = "pendulum"``): a pendulum or
electrolytic tilt sensor hangs along the *apparent* vertical, the direction of the specific force
at the sensor, so it reads the tilt of ``f_s = C_sb f_b``::

    roll = atan2(-f_y, -f_z),    pitch = atan2(f_x, √(f_y² + f_z²)),

exact at rest (``f_b = C_bn [0, 0, -g]`` gives the Euler roll and pitch) and tilted by
``atan(a/g)`` by a horizontal acceleration a. The filter's best knowledge of ``f_b`` is the
INS's own, the raw accelerometer reading of the current IMU interval less the estimated bias,
``f̂_b = f̃_b - b̂_a``; with ``f_b = f̂_b - db_a`` (error = truth - estimate)::

    y = z - tilt(C_sb f̂_b),    H_db_a = -J(f̂_s) C_sb,    H on every other state = 0,

with J the 2×3 Jacobian of the tilt::

    ∂roll/∂f = [0, f_z, -f_y] / (f_y² + f_z²),
    ∂pitch/∂f = [ρ², -f_x f_y, -f_x f_z] / (ρ |f|²),    ρ = √(f_y² + f_z²).

The pendulum does not see the attitude error: it tells the filter the horizontal accelerometer
bias, which otherwise hides behind the tilt error, and the velocity aiding then fixes the tilt
(the tilt/bias separation of docs/inclinometer.md). The sensor is taken at the IMU (no lever arm:
``ω̇ × l`` is not known) and ideal (no swing dynamics). σ is the instrument's own noise; the
accelerometer's noise over one IMU interval adds ``VRW² / T / g²`` per axis (0.03° for the
paper's IMU at 100 Hz), small beside 0.1° and not added.

Attitude model (docs/filters.md, 'Measurement models')::

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
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, BA, N_STATES
from adaptnav.models.strapdown import NOM_ATT, NOM_BA, NOM_SIZE
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_rotation,
    check_sigma,
    check_state,
    euler_jacobian,
    need_force,
)
from adaptnav.sensors.calibration import TILT_BIAS, bias, bias_jacobian
from adaptnav.sensors.kind import (
    ANGLE_RESOLUTION_RAD,
    HALF_PI,
    SLOW_STUCK_S,
    IdealInput,
    SensorKind,
    SensorSetup,
    StuckDefault,
    pack_params,
)

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
class _TwoAxis(Components):
    """Settings shared by both inclinometer models.

    Attributes:
        sigma: nominal noise σ of [roll, pitch] (rad); a scalar applies to both.
        C_sb: mounting rotation, sensor frame from body frame.
        name: sensor name; components are ``{name}_roll``, ``{name}_pitch``.
        cal_bias: error-state index of its roll bias state, the pitch bias's next
            (docs/calibration.md: it reads the angles plus the biases); -1: none.
    """

    COMPONENTS: ClassVar[tuple[str, ...]] = ("roll", "pitch")

    sigma: float | Array
    C_sb: Array = field(default_factory=lambda: np.eye(3))
    name: str = "inclinometer"
    cal_bias: int = -1

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        return pack_params(C_sb=self.C_sb, calibration=(self.cal_bias, -1))

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", check_sigma("sigma", self.sigma, DIM))
        object.__setattr__(self, "C_sb", check_rotation("C_sb", self.C_sb))
        object.__setattr__(self, "name", check_name("name", self.name))


@dataclass(frozen=True, eq=False)
class Inclinometer(_TwoAxis):
    """Two-axis inclinometer read as the attitude's roll and pitch (the attitude model)."""

    LIN_CODE: ClassVar[int] = 2
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def predict(self, x: ArrayLike) -> Array:
        """See :func:`predict` (plus the bias states, if any)."""
        xa = np.asarray(x, dtype=float)
        return predict(xa[:NOM_SIZE], self.C_sb) + bias(xa, self.cal_bias, DIM)

    def jacobian(self, x: ArrayLike) -> Array:
        """See :func:`jacobian`; a column per error state of x (15 + m)."""
        xa = np.asarray(x, dtype=float)
        return bias_jacobian(xa, jacobian(xa[:NOM_SIZE], self.C_sb), self.cal_bias)

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


def tilt(f_s: ArrayLike) -> Array:
    """[roll, pitch] (rad) of the apparent vertical of a specific force ``f_s`` (3,) or (N, 3):
    ``roll = atan2(-f_y, -f_z)``, ``pitch = atan2(f_x, √(f_y² + f_z²))``."""
    f = np.asarray(f_s, dtype=float)
    roll = np.arctan2(-f[..., 1], -f[..., 2])
    pitch = np.arctan2(f[..., 0], np.hypot(f[..., 1], f[..., 2]))
    return np.stack([roll, pitch], axis=-1)


def tilt_jacobian(f_s: ArrayLike) -> Array:
    """∂[roll, pitch]/∂f (2×3) of :func:`tilt` at ``f_s`` (module docstring)."""
    fx, fy, fz = (float(v) for v in np.asarray(f_s, dtype=float))
    rho2 = fy * fy + fz * fz
    rho = np.sqrt(rho2)
    n2 = rho2 + fx * fx
    return np.array(
        [
            [0.0, fz / rho2, -fy / rho2],
            [rho / n2, -fx * fy / (rho * n2), -fx * fz / (rho * n2)],
        ]
    )


def pendulum_predict(x: ArrayLike, f_ib_b: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """h(x) = tilt(C_sb (f̃_b - b̂_a)) (rad): what a pendulum reads (module docstring)."""
    f_b = _need_force(f_ib_b) - check_state(x)[NOM_BA]
    C = np.eye(3) if C_sb is None else np.asarray(C_sb, dtype=float)
    return tilt(C @ f_b)


def pendulum_jacobian(x: ArrayLike, f_ib_b: ArrayLike, C_sb: ArrayLike | None = None) -> Array:
    """H (2×15): ``-J(f̂_s) C_sb`` on db_a, zero elsewhere."""
    f_b = _need_force(f_ib_b) - check_state(x)[NOM_BA]
    C = np.eye(3) if C_sb is None else np.asarray(C_sb, dtype=float)
    H = np.zeros((DIM, N_STATES))
    H[:, BA] = -tilt_jacobian(C @ f_b) @ C
    return H


@dataclass(frozen=True, eq=False)
class PendulumInclinometer(_TwoAxis):
    """Pendulum inclinometer: reads the tilt of the apparent gravity (module docstring).

    ``evaluate`` needs the raw accelerometer reading ``f_ib_b`` of the IMU interval the reading
    falls in (the engine passes it; the compiled twin is ``compiled.update._lin_pendulum``).
    """

    LIN_CODE: ClassVar[int] = 6
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def predict(self, x: ArrayLike, f_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`pendulum_predict` (plus the bias states, if any)."""
        xa = np.asarray(x, dtype=float)
        h = pendulum_predict(xa[:NOM_SIZE], _need_force(f_ib_b), self.C_sb)
        return h + bias(xa, self.cal_bias, DIM)

    def jacobian(self, x: ArrayLike, f_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`pendulum_jacobian`; a column per error state of x (15 + m)."""
        xa = np.asarray(x, dtype=float)
        H = pendulum_jacobian(xa[:NOM_SIZE], _need_force(f_ib_b), self.C_sb)
        return bias_jacobian(xa, H, self.cal_bias)

    def evaluate(
        self,
        x: Array,
        z: ArrayLike,
        omega_ib_b: ArrayLike | None = None,
        f_ib_b: ArrayLike | None = None,
    ) -> Measurement | None:
        """Wrapped residual ``z - tilt(C_sb (f̃_b - b̂_a))`` (rad), H and R; None if the
        reading has a NaN/inf. ``omega_ib_b`` is not used."""
        zz = check_reading(self.name, z, DIM)
        if zz is None:
            return None
        y = attitude.wrap_angle(zz - self.predict(x, f_ib_b))
        return Measurement(y, self.jacobian(x, f_ib_b), self.R, self.names)


def _need_force(f_ib_b: ArrayLike | None) -> Array:
    return need_force(f_ib_b, "a pendulum inclinometer")


def _build(s: SensorSetup) -> Inclinometer | PendulumInclinometer:
    """``model = "attitude"``: it reads roll and pitch; else (the default) a pendulum."""
    bias = s.calibration.get("bias", -1)
    if s.model == "attitude":
        return Inclinometer(s.sigma, s.C_sb, s.name, bias)
    return PendulumInclinometer(s.sigma, s.C_sb, s.name, bias)


def ideal(t: IdealInput) -> Array:
    """Error-free readings (N, 2) of the ``model`` :func:`_build` would make, over all N at
    once: the attitude's roll and pitch (:func:`predict`) for ``"attitude"``, else the
    pendulum's tilt of the specific force at the sensor, ``tilt(C_sb (f_b - b_a))``
    (:func:`pendulum_predict`; the true states' bias is zero)."""
    if t.model == "attitude":
        return t.euler_ns[:, :2]
    return tilt(t.to_sensor(t.f_b - t.x[:, NOM_BA]))


KIND = SensorKind(
    name="inclinometer",
    columns=("roll_rad", "pitch_rad"),
    sigma_kind=Kind.ANGLE,
    build=_build,
    limits={"roll_rad": (-HALF_PI, HALF_PI), "pitch_rad": (-HALF_PI, HALF_PI)},
    stuck=StuckDefault(SLOW_STUCK_S, {c: ANGLE_RESOLUTION_RAD for c in ("roll_rad", "pitch_rad")}),
    mounting=True,
    options=frozenset({"model"}),
    linearised=(Inclinometer, PendulumInclinometer),
    calibration={"bias": TILT_BIAS},
    ideal_reading=ideal,
)
"""The inclinometer as a sensor kind (sensors/kind.py): angles within ±90°; stuck after 60 s
within 1e-6 rad (docs/robustness.md); ``model``: docs/inclinometer.md."""
