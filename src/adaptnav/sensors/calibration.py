"""What an aiding sensor can estimate about itself: its calibration (docs/calibration.md).

A kind declares its quantities (``SensorKind.calibration``): the DVL its scale factor and its
mounting misalignment, the depth meter a bias, the inclinometer roll and pitch biases. A mission
asks for them per sensor (``[sensors.<name>] estimate = ["scale", "misalignment"]``); each becomes
a block of random-walk states of the error state (models/errorstate.StateLayout) with a prior σ
and a random-walk density, in datasheet units, the defaults below. The sensor's model reads the
block's nominal values from the state and its H has columns for them.

Conventions (the simulator's, docs/simulation.md, 'Calibration errors'):

* scale ``s``: the sensor reads ``(1 + s)`` times the true value (0.01: 1 % high);
* misalignment ``δ = (roll, pitch, yaw)``: the true sensor frame is the configured one rotated by
  the ZYX Euler angles δ, so a reading is ``M(δ) z_nominal``, ``M = euler_to_dcm(δ)ᵀ``
  (``≈ I - [δ×]``);
* bias ``b``: the sensor reads the true value plus b (a DVL's after its scale and
  misalignment: ``(1 + s) M(δ) h + b``, b in the DVL's frame);
* latency ``δ``: a reading stamped t was taken at ``t - δ`` (``latency_s``'s sign,
  docs/data-format.md 'Latency'), so to first order it reads ``h - δ ḣ``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import N_STATES
from adaptnav.models.strapdown import NOM_SIZE

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Quantity:
    """One calibration quantity of a sensor kind: its states, default prior σ and random walk
    (SI), their unit kinds (for ``mission.toml``), and the unit it is reported in."""

    name: str
    states: tuple[str, ...]
    """Names of its states after the sensor's name: ``dvl.scale``, ``dvl.misalignment_yaw``."""
    sigma: float
    random_walk: float
    """Random-walk density (SI per √s); 0: a constant."""
    sigma_kind: Kind
    random_walk_kind: Kind
    unit: str
    """Unit of ``calibration.json`` and the report."""
    factor: float
    """SI → :attr:`unit`."""


SCALE = Quantity("scale", ("scale",), 0.01, 0.0, Kind.RATIO, Kind.RATIO_RANDOM_WALK, "%", 100.0)
"""A DVL's scale factor: 1 % a priori (datasheets give 0.2-1 %), constant."""
MISALIGNMENT = Quantity(
    "misalignment",
    ("misalignment_roll", "misalignment_pitch", "misalignment_yaw"),
    math.radians(2.0),
    0.0,
    Kind.ANGLE,
    Kind.ANGLE_RANDOM_WALK,
    "deg",
    180.0 / math.pi,
)
"""A mounting misalignment: 2° per angle a priori (a bracket measured with a tape), constant."""
DEPTH_BIAS = Quantity("bias", ("bias",), 0.5, 0.0, Kind.LENGTH, Kind.LENGTH_RANDOM_WALK, "m", 1.0)
"""A depth meter's bias (atmospheric pressure, density, the transducer's zero): 0.5 m."""
TILT_BIAS = Quantity(
    "bias",
    ("bias_roll", "bias_pitch"),
    math.radians(0.5),
    0.0,
    Kind.ANGLE,
    Kind.ANGLE_RANDOM_WALK,
    "deg",
    180.0 / math.pi,
)
"""An inclinometer's roll and pitch biases (its mounting and zero): 0.5° each."""
DVL_BIAS = Quantity(
    "bias",
    ("bias_x", "bias_y", "bias_z"),
    0.005,
    0.0,
    Kind.SPEED,
    Kind.VELOCITY_RANDOM_WALK,
    "mm/s",
    1000.0,
)
"""A DVL's velocity bias in its own frame (the transducers' beam geometry and electronics, a
bottom that moves with the water, sound speed over the beams): 5 mm/s per axis a priori (a
datasheet's "± 2-5 mm/s" beside its scale term), constant by default; with a correlation time
it follows an error that wanders (docs/calibration.md, 'DVL bias')."""
LATENCY = Quantity(
    "latency", ("latency",), 0.1, 0.0, Kind.TIME, Kind.TIME_RANDOM_WALK, "ms", 1000.0
)
"""A sensor's latency that its stamps do not account for (a DVL's ping-to-output time, a
logger's clock): 100 ms a priori, constant by default (docs/calibration.md, 'DVL latency')."""
GNSS_BIAS = Quantity(
    "bias", ("bias_N", "bias_E"), 2.5, 0.0, Kind.LENGTH, Kind.LENGTH_RANDOM_WALK, "m", 1.0
)
"""A GNSS receiver's horizontal position error that lasts (multipath, atmosphere): 2.5 m north
and east, constant by default. Over a burst of fixes shorter than its correlation time (a
surfacing's few minutes) it holds the fixes' common error in a state instead of letting the
filter average it away as white noise (docs/calibration.md, 'GNSS bias')."""


def regressors(
    quantity: Quantity, z: ArrayLike, rate: ArrayLike | None = None
) -> tuple[Array, ...] | None:
    """Per state of ``quantity``, how it moves each reading (n, d) of the sensor's readings z
    (n, d), to first order and up to a constant factor: ``∂z/∂state`` near zero calibration
    (module docstring's conventions). Scale: z itself; misalignment angle a: ``e_a × z``
    (``M(δ) z ≈ z - δ × z``); a bias: its component's unit vector; a latency: ``-ż``, from
    ``rate`` (the readings' rate in the residual's units, the kind's ``reading_rate``). None
    for a quantity this function does not know or a latency without ``rate`` (the long-run σ
    of docs/calibration.md, 'Correlated readings', is then not given)."""
    za = np.atleast_2d(np.asarray(z, dtype=float))
    if quantity == LATENCY:
        return None if rate is None else (-np.atleast_2d(np.asarray(rate, dtype=float)),)
    if quantity == SCALE:
        return (za,)
    if quantity == MISALIGNMENT and za.shape[1] == 3:
        return tuple(np.cross(np.eye(3)[a], za) for a in range(3))
    biases = (DEPTH_BIAS, TILT_BIAS, GNSS_BIAS, DVL_BIAS)
    if quantity in biases and za.shape[1] >= len(quantity.states):
        return tuple(
            np.tile(np.eye(za.shape[1])[j], (len(za), 1)) for j in range(len(quantity.states))
        )
    return None


def misalignment(d: ArrayLike) -> Array:
    """``M(δ) = euler_to_dcm(δ)ᵀ`` (module docstring)."""
    a = np.asarray(d, dtype=float)
    return np.asarray(attitude.euler_to_dcm(a[0], a[1], a[2]).T, dtype=float)


def misalignment_derivatives(d: ArrayLike) -> Array:
    """``∂M/∂δ_i`` (3, 3, 3), i = roll, pitch, yaw: with ``euler_to_dcm = Rz Ry Rx``,
    ``M = Rxᵀ Ryᵀ Rzᵀ`` and each derivative replaces one factor by its own derivative."""
    r, p, y = np.asarray(d, dtype=float)
    sr, cr, sp, cp, sy, cy = np.sin(r), np.cos(r), np.sin(p), np.cos(p), np.sin(y), np.cos(y)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    dRx = np.array([[0.0, 0.0, 0.0], [0.0, -sr, -cr], [0.0, cr, -sr]])
    dRy = np.array([[-sp, 0.0, cp], [0.0, 0.0, 0.0], [-cp, 0.0, -sp]])
    dRz = np.array([[-sy, -cy, 0.0], [cy, -sy, 0.0], [0.0, 0.0, 0.0]])
    return np.array([dRx.T @ Ry.T @ Rz.T, Rx.T @ dRy.T @ Rz.T, Rx.T @ Ry.T @ dRz.T])


def widen(x: ArrayLike, H: Array) -> Array:
    """H (d×15) with a zero column per declared state of ``x`` (16 + m: 15 + m columns)."""
    n = np.asarray(x).size - NOM_SIZE + N_STATES
    out = np.zeros((H.shape[0], n))
    out[:, :N_STATES] = H
    return out


def bias(x: ArrayLike, first: int, d: int) -> Array:
    """``b`` of ``z = h + b``: the nominal values of the d bias states whose error states start
    at index ``first`` (their nominal values at index + 1); zeros for ``first`` = -1 or a state
    without declared states."""
    xa = np.asarray(x, dtype=float)
    if first < 0 or xa.size == NOM_SIZE:
        return np.zeros(d)
    return np.asarray(xa[first + 1 : first + 1 + d], dtype=float)


def bias_jacobian(x: ArrayLike, H: Array, first: int) -> Array:
    """H of ``z = h + b`` from the core's ``H`` (d×15): widened to x's error states, 1 on each
    bias (from error index ``first``; -1: none)."""
    out = widen(x, H)
    if first >= 0 and out.shape[1] > N_STATES:
        d = H.shape[0]
        out[:, first : first + d] += np.eye(d)
    return out
