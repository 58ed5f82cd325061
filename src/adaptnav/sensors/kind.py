"""A kind of aiding sensor as a whole: what the mission format, the loader and the engine's
compiled epoch need to know about it, declared once in the sensor's own module.

Each sensor module (``sensors/dvl.py``, ...) ends with ``KIND = SensorKind(...)``: its table
columns, the unit of its σ, whether it has a lever arm and a mounting rotation, its plausible
ranges and stuck-reading defaults (docs/robustness.md), the kind-specific options of its
``[sensors.<name>]`` section, how to build its measurement model from them, and
``ideal_reading``: its error-free readings of the true motion, which the simulator
(``adaptnav.sim.sensors``) starts every reading of the kind from before adding the kind's
disturbances (docs/simulation.md). :mod:`adaptnav.sensors.registry` lists the kinds;
docs/architecture.md, 'Adding a sensor'.

A model class with a compiled linearisation declares ``LIN_CODE`` (its branch in the kernel's
``linearise``, ``adaptnav.compiled.update``) and ``lin_params()``, its parameters packed as
:func:`pack_params` lays them out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core import attitude
from adaptnav.core.units import Kind
from adaptnav.models.strapdown import NOM_ATT
from adaptnav.sensors.base import MeasurementModel
from adaptnav.sensors.calibration import Quantity

Array = NDArray[np.float64]

N_PAR = 17
"""Packed linearisation parameters: ``[l_b (3) | C_sb (9, row-major) | flag | calibration
state indices (4)]``; ``flag`` is a kind's one scalar (GNSS: use_height; depth: the water
surface's height)."""
PAR_LB, PAR_CSB, PAR_FLAG, PAR_CAL = 0, 3, 12, 13
"""``par[PAR_CAL]`` to ``par[PAR_CAL + 3]``: error-state indices of the
model's calibration blocks (sensors/calibration.py; -1: none), as the model's class defines
them."""


def pack_params(
    l_b: ArrayLike | None = None,
    C_sb: ArrayLike | None = None,
    flag: float = 0.0,
    calibration: tuple[int, ...] = (-1, -1, -1),
) -> Array:
    """A model's parameters as the compiled ``linearise`` reads them (:data:`N_PAR`); up to four
    calibration indices, the rest -1."""
    if len(calibration) > N_PAR - PAR_CAL:
        raise ValueError(f"at most {N_PAR - PAR_CAL} calibration blocks, got {calibration}")
    par = np.zeros(N_PAR)
    par[PAR_CAL:] = -1.0
    par[PAR_CAL : PAR_CAL + len(calibration)] = calibration
    par[PAR_CSB : PAR_CSB + 9] = np.eye(3).ravel()
    if l_b is not None:
        par[PAR_LB : PAR_LB + 3] = np.asarray(l_b, dtype=float)
    if C_sb is not None:
        par[PAR_CSB : PAR_CSB + 9] = np.asarray(C_sb, dtype=float).ravel()
    par[PAR_FLAG] = flag
    return par


class StuckDefault(NamedTuple):
    """A kind's default stuck-reading settings (``[sensors.<name>] stuck_s`` and
    ``resolution``; docs/robustness.md, 'Stuck readings')."""

    stuck_s: float
    """Minimum duration (s) of a stuck run; 0: no detection."""
    resolution: dict[str, float]
    """Per column, in its SI unit: a tenth or less of the finest output step of that kind of
    sensor, so that two readings one step apart never count as unchanged."""


MAX_SPEED_M_S = 20.0
"""|DVL velocity| (and NHC) above this (m/s, ~39 kn) per component is implausible."""
SLOW_STUCK_S = 60.0
"""Depth, roll, pitch and heading can be still for a while legitimately (a vessel alongside in
a calm harbour, a parked vehicle): a minute unchanged, not less, is taken as stuck."""
SPEED_RESOLUTION_M_S = 1e-5
"""0.01 mm/s: a hundredth of the 1 mm/s step of a Teledyne DVL's PD0 record, a tenth of the
0.1 mm/s of finer outputs; far above float32 round-off at DVL speeds (1e-6 m/s at 20 m/s)."""
ANGLE_RESOLUTION_RAD = 1e-6
"""0.00006°: below the finest step of inclinometer and heading outputs, 0.001° (1.7e-5 rad)."""
HALF_PI = math.pi / 2


@dataclass(frozen=True)
class SensorSetup:
    """One configured sensor in SI units, what a kind's ``build`` makes its model from."""

    name: str
    sigma: float | Array
    """σ per component (or one for all), in the unit of :attr:`SensorKind.sigma_kind`."""
    l_b: Array
    """Lever arm from the IMU, body FRD (m); zeros for a kind without one."""
    C_sb: Array
    """Sensor frame from body frame; identity for a kind without a mounting rotation."""
    use_height: bool = False
    model: str | None = None
    calibration: Mapping[str, int] = field(default_factory=dict)
    """Error-state index of the first state of each calibration quantity estimated
    (:attr:`SensorKind.calibration`; docs/calibration.md)."""
    surface_h: float = 0.0
    """Depth meter: the height of the water surface, where it reads zero (m)."""


@dataclass(frozen=True, eq=False)
class IdealInput:
    """The truth a kind's ``ideal_reading`` reads, at N sampling instants, and the sensor's
    installation (what the simulator hands it; docs/simulation.md, 'Aiding sensors').

    The derived quantities below (attitude matrices, Euler angles, the lever arm in NED) are
    computed once for all N instants by the same :mod:`adaptnav.core.attitude` functions the
    readable one-state ``predict`` functions use, so a kind's ``ideal_reading`` is its
    ``predict`` formula over arrays (``tests/unit/test_ideal_readings.py`` holds the two equal).
    """

    x: Array
    """True nominal states (N, 16), laid out as models/strapdown.py (biases zero)."""
    omega_ib_b: Array
    """True body rate (N, 3), rad/s."""
    f_b: Array
    """True specific force at the IMU (N, 3), m/s²."""
    l_b: Array = field(default_factory=lambda: np.zeros(3))
    """Lever arm from the IMU to the sensor, body FRD (m)."""
    C_sb: Array | None = None
    """Mounting rotation, sensor frame from body frame; None: aligned with the body."""
    model: str | None = None
    """The kind's ``model`` option, for a kind with several (the inclinometer's)."""

    @cached_property
    def C_nb(self) -> Array:
        """Body-to-NED DCMs (N, 3, 3) of the states' quaternions: :func:`attitude.quat_to_dcm`
        (Groves 2.34) of all N at once (the batch on its last axis, then moved first)."""
        return np.moveaxis(attitude.quat_to_dcm(self.x[:, NOM_ATT].T), -1, 0)

    @cached_property
    def C_ns(self) -> Array:
        """Sensor-to-NED DCMs ``C_nb C_sbᵀ`` (N, 3, 3); ``C_nb`` for a sensor aligned with the
        body."""
        if self.C_sb is None:
            return self.C_nb
        return np.asarray(self.C_nb @ np.asarray(self.C_sb, dtype=float).T, dtype=float)

    @cached_property
    def euler_ns(self) -> Array:
        """ZYX Euler angles ``[roll, pitch, yaw]`` (N, 3) of :attr:`C_ns`:
        :func:`attitude.dcm_to_euler` of all N at once (yaw in (-π, π])."""
        return np.asarray(attitude.dcm_to_euler(np.moveaxis(self.C_ns, 0, -1)).T, dtype=float)

    @cached_property
    def lever_n(self) -> Array:
        """The lever arm resolved in NED, ``C_nb l_b`` (N, 3), m."""
        return np.asarray(self.C_nb @ np.asarray(self.l_b, dtype=float), dtype=float)

    def to_sensor(self, v_b: Array) -> Array:
        """Body-frame vectors (N, 3) resolved in the sensor frame, ``C_sb v_b`` row by row."""
        if self.C_sb is None:
            return v_b
        return np.asarray(v_b @ np.asarray(self.C_sb, dtype=float).T, dtype=float)


@dataclass(frozen=True)
class SensorKind:
    """One kind of aiding sensor (module docstring)."""

    name: str
    columns: tuple[str, ...]
    """Measurement columns of its table after ``t_s``, SI names."""
    sigma_kind: Kind
    """Unit kind of its σ (and of its residual)."""
    build: Callable[[SensorSetup], MeasurementModel]
    limits: Mapping[str, tuple[float, float]]
    """Default plausible range of each column, SI (``[sensors.<name>] limits`` overrides)."""
    stuck: StuckDefault
    lever_arm: bool = False
    mounting: bool = False
    options: frozenset[str] = frozenset()
    """Kind-specific keys of its ``[sensors.<name>]`` section (e.g. ``use_height``)."""
    optional_columns: int = 0
    """Trailing columns present only with an option (the GNSS height, with ``use_height``)."""
    linearised: tuple[type, ...] = field(default=())
    """Its model classes that have a compiled linearisation (``LIN_CODE``, ``lin_params``)."""
    calibration: Mapping[str, Quantity] = field(default_factory=dict)
    """What it can estimate about itself (``[sensors.<name>] estimate``), by name
    (sensors/calibration.py)."""
    ideal_reading: Callable[[IdealInput], Array] | None = None
    """Its error-free readings (N, len(columns)) of the true motion, in the SI units of
    :attr:`columns` (optional ones included): the filter's own ``predict`` at the truth, so that
    the simulator and the filter share every convention. None: the simulator cannot make it."""
    reading_rate: Callable[[Array, Array], Array] | None = None
    """The rate of change of its readings z (n, d) at their times t (n,), in the units of its
    residual (a GNSS's in NED m/s): the regressor of its latency state for the long-run σ
    (docs/calibration.md, 'Correlated readings'). None: not given."""

    def dims(self) -> tuple[int, ...]:
        """The numbers of components it can have (with and without its optional columns)."""
        full = len(self.columns)
        return tuple(range(full - self.optional_columns, full + 1))

    def dim(self, use_height: bool) -> int:
        """Its number of components (all columns with ``use_height``, else without the
        optional ones)."""
        return len(self.columns) - (0 if use_height else self.optional_columns)
