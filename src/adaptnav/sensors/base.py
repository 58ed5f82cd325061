"""The contract between a sensor and the filter: one residual, its H and its nominal R.

Every aiding sensor is linearised as (paper eq. (4), with M_i = I; docs/filters.md,
'Measurement models')

    y_i = z_i - h_i(x_hat) ≈ H_i dx + r_i,    r_i ~ N(0, R_i),
    H_i = ∂h_i(x_hat ⊕ dx) / ∂dx at dx = 0,

with the error state ``dx = x_true ⊖ x_hat`` and the attitude error
``C_nb_true = Exp(phi) C_nb_hat`` of ``docs/conventions.md``. A sensor model answers
"residual, H, R at this state, or nothing" (:class:`MeasurementModel`); what is done with R
afterwards (fixed, matched, VB) is the noise strategies' business, not the sensor's.

This module also holds the validation helpers shared by the sensor configs and the Euler-angle
Jacobian used by the inclinometer and the heading sensor.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.models.errorstate import N_STATES
from adaptnav.models.strapdown import NOM_SIZE

Array = NDArray[np.float64]

_ROTATION_TOL = 1e-9
"""How far from orthonormal (max-abs of C Cᵀ - I) a mounting DCM may be: rounding, not error."""


@dataclass(frozen=True, eq=False)
class Measurement:
    """One linearised measurement: residual y (d,), H (d, 15 + m), nominal R (d, d), names (d).

    ``y = z - h(x_hat)`` in the sensor's residual units (m, m/s, rad), ``H = ∂h(x_hat ⊕ dx)/∂dx``
    (15 columns, or one per error state with m declared states: errorstate.StateLayout) and
    ``R`` the sensor's nominal (configured) noise covariance. ``names`` label the components
    (``"dvl_x"``, ``"gnss_N"``...) for logs and per-component adaptation.
    """

    y: Array
    H: Array
    R: Array
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        d = len(self.names)
        H_ok = self.H.ndim == 2 and self.H.shape[0] == d and self.H.shape[1] >= N_STATES
        if self.y.shape != (d,) or not H_ok or self.R.shape != (d, d):
            raise ValueError(
                f"Measurement with {d} names needs y ({d},), H ({d}, {N_STATES} + m), "
                f"R ({d}, {d}); "
                f"got y {self.y.shape}, H {self.H.shape}, R {self.R.shape}"
            )

    @property
    def dim(self) -> int:
        return len(self.names)


@runtime_checkable
class MeasurementModel(Protocol):
    """What the engine needs from a sensor.

    ``evaluate(x, z, omega_ib_b)`` linearises the sensor at the nominal 16-state ``x`` for the
    reading ``z``; it returns ``None`` when the reading carries no measurement (any non-finite
    component: a dropout logged as NaN). ``omega_ib_b`` is the *raw* gyro rate ω̃_ib_b (rad/s)
    at the measurement time; sensors that do not need it ignore it.
    """

    @property
    def name(self) -> str: ...

    @property
    def dim(self) -> int: ...

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None: ...


class Components:
    """Component names, their count and the nominal R of a sensor model, from its ``name``, its
    ``sigma`` (σ per component, or one for all) and the class's component suffixes: one
    definition for every model here. ``COMPONENTS = ()``: a one-component sensor, named by its
    name."""

    COMPONENTS: ClassVar[tuple[str, ...]] = ()
    CONSTRAINT: ClassVar[bool] = False
    """A pseudo-measurement of a motion model (the NHC, ZUPT), not a sensor: its σ is how well
    the modeller says the model holds, and its residuals are what the filter made of it, so a
    filter that bounds R̂ keeps this one's at its nominal R or above (docs/robustness.md,
    'Bounded R̂')."""
    name: str
    sigma: float | Array

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_{c}" for c in self.COMPONENTS) or (self.name,)

    @property
    def dim(self) -> int:
        return len(self.names)

    @property
    def midpoint_update(self) -> bool:
        """Linearise this sensor's updates at the midpoint of their step (compiled.update.
        _midpoint; docs/calibration.md, 'The midpoint update'): a model whose reading multiplies
        its declared states with the core's says so (the calibrated DVL); others are linearised
        at the prior. The engine reads it where a model has it."""
        return False

    @property
    def R(self) -> Array:
        """``diag(σ²)``: the nominal measurement noise covariance."""
        var = np.asarray(self.sigma, dtype=float) ** 2
        return np.diag(np.broadcast_to(var, (self.dim,)).copy())


# --- validation (configs are checked once, at construction) -------------------------------------


def _as_float_array(field: str, value: object) -> Array:
    try:
        return np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{field} must be numeric, got {value!r}") from exc


def _frozen(a: Array) -> Array:
    # The configs are frozen dataclasses; a writable array inside would make that a promise only.
    a.flags.writeable = False
    return a


def check_name(field: str, value: object) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{field} must be a non-empty string, got {value!r}")
    return value


def check_sigma(field: str, value: object, dim: int) -> Array:
    """A per-component standard deviation: a scalar (broadcast) or shape (dim,), finite, > 0."""
    a = _as_float_array(field, value)
    if a.ndim == 0:
        a = np.full(dim, float(a))
    if a.shape != (dim,):
        raise ValueError(
            f"{field} must be a scalar or have shape ({dim},), got shape {a.shape}: {value!r}"
        )
    if not (np.all(np.isfinite(a)) and np.all(a > 0.0)):
        raise ValueError(f"{field} must be finite and > 0, got {value!r}")
    return _frozen(a)


def check_scalar_sigma(field: str, value: object) -> float:
    """A scalar standard deviation, finite and > 0."""
    a = _as_float_array(field, value)
    if a.size != 1:
        raise ValueError(f"{field} must be a scalar, got shape {a.shape}: {value!r}")
    s = float(a.reshape(()))
    if not (np.isfinite(s) and s > 0.0):
        raise ValueError(f"{field} must be finite and > 0, got {value!r}")
    return s


def check_vector3(field: str, value: object) -> Array:
    """A finite 3-vector (lever arm, m)."""
    a = _as_float_array(field, value)
    if a.shape != (3,):
        raise ValueError(f"{field} must have shape (3,), got shape {a.shape}: {value!r}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{field} must be finite, got {value!r}")
    return _frozen(a)


def readings_rate(z: ArrayLike, t: ArrayLike) -> Array:
    """``dz/dt`` of readings z (n, d) at times t (n,), central differences (one-sided at the
    ends; a kind's ``reading_rate``); NaN throughout unless the times strictly increase."""
    za = np.atleast_2d(np.asarray(z, dtype=float))
    ta = np.asarray(t, dtype=float)
    if ta.size < 2 or not np.all(np.diff(ta) > 0.0):
        return np.full(za.shape, np.nan)
    return np.asarray(np.gradient(za, ta, axis=0), dtype=float)


def need_force(f_ib_b: ArrayLike | None, who: str) -> Array:
    """The raw specific force f̃_ib_b (m/s², shape (3,)) a model needs (``who``: "a pendulum
    inclinometer"); a ValueError naming it when it is missing or of the wrong shape."""
    if f_ib_b is None:
        raise ValueError(f"{who} needs the accelerometer's specific force f_ib_b")
    f = np.asarray(f_ib_b, dtype=float)
    if f.shape != (3,):
        raise ValueError(f"f_ib_b must have shape (3,), got {f.shape}")
    return f


def check_rotation(field: str, value: object) -> Array:
    """A proper rotation matrix (3×3, orthonormal to rounding, det = +1)."""
    a = _as_float_array(field, value)
    if a.shape != (3, 3):
        raise ValueError(f"{field} must have shape (3, 3), got shape {a.shape}: {value!r}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{field} must be finite, got {value!r}")
    if np.abs(a @ a.T - np.eye(3)).max() > _ROTATION_TOL or np.linalg.det(a) <= 0.0:
        raise ValueError(f"{field} must be a rotation (orthonormal, det +1), got {value!r}")
    return _frozen(a)


def check_state(x: ArrayLike) -> Array:
    """The nominal 16-state as a float array (a wrong shape is a programming error)."""
    a = np.asarray(x, dtype=float)
    if a.shape != (NOM_SIZE,):
        raise ValueError(f"nominal state must have shape ({NOM_SIZE},), got {a.shape}")
    return a


def check_reading(name: str, z: ArrayLike, dim: int) -> Array | None:
    """The reading as a (dim,) array, or None if any component is NaN/inf (no measurement)."""
    a = np.atleast_1d(np.asarray(z, dtype=float))
    if a.shape != (dim,):
        raise ValueError(f"{name} reading must have shape ({dim},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        return None
    return a


# --- shared geometry ---------------------------------------------------------------------------


def euler_jacobian(C_nb: ArrayLike) -> Array:
    """∂[roll, pitch, yaw] / ∂phi (3×3) of ``C_nb`` for the left error ``C_true = Exp(phi) C_hat``.

    With ``C = Rz(ψ) Ry(θ) Rx(φ)`` a rotation by the n-resolved vector δphi changes the Euler
    angles as ``δphi = ψ̇ e_D + θ̇ Rz(ψ) e_E + φ̇ Rz(ψ) Ry(θ) e_N`` (the axes of the three
    elementary rotations, in n), i.e. ``δphi = M δe`` with columns
    ``[cθ cψ, cθ sψ, -sθ]``, ``[-sψ, cψ, 0]``, ``[0, 0, 1]``. Inverting M::

        roll  [cψ/cθ,   sψ/cθ,   0]
        pitch [-sψ,     cψ,      0]
        yaw   [cψ tθ,   sψ tθ,   1]

    Singular at pitch = ±90° (gimbal lock), where roll and yaw are not defined.
    """
    C = np.asarray(C_nb, dtype=float)
    pitch = -np.arcsin(np.clip(C[2, 0], -1.0, 1.0))
    yaw = np.arctan2(C[1, 0], C[0, 0])
    sy, cy = np.sin(yaw), np.cos(yaw)
    cp, tp = np.cos(pitch), np.tan(pitch)
    return np.array(
        [
            [cy / cp, sy / cp, 0.0],
            [-sy, cy, 0.0],
            [cy * tp, sy * tp, 1.0],
        ]
    )
