"""IMU noise specification: white noise and bias processes, SI inside, datasheet units at the edge.

The error model (docs/filters.md, 'Error-state model') needs, per sensor triad: white-noise
root-PSD (ARW for gyros, VRW for accelerometers) and a first-order Gauss-Markov bias with
steady-state σ and correlation time τ (τ = inf makes it a random walk with the given
rate-random-walk root-PSD instead).
Datasheet "bias stability/instability" is taken as the Gauss-Markov σ (Groves §4.4.3).

The fields of :class:`ImuNoise` are the one declaration of the noise terms: each carries its
quantity kind (hence its accepted datasheet units, :mod:`adaptnav.core.units`) and its default,
and :func:`noise_fields` reads them back as a table. The range checks (:func:`check_value`), the
datasheet conversion (:func:`pair_si`), the mission's ``[imu.noise]`` section
(docs/data-format.md) and the simulator's error model (a subclass adding its own terms) all work
from that table, so a new noise term is one new field here.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, ClassVar, NamedTuple, Self

from adaptnav.core.units import Kind, UnitError, factor, to_si

KIND_KEY = "kind"
"""Key of a noise-model field's quantity kind in its metadata; a field without it (a scale
factor) is a plain number."""


class NoiseField(NamedTuple):
    """One field of a noise model: its name, the quantity kind of its datasheet unit (None: a
    plain number, e.g. a scale factor) and its SI default (None: required)."""

    name: str
    kind: Kind | None
    default: float | None


@dataclass(frozen=True)
class ImuNoise:
    """IMU noise in SI units.

    Attributes:
        arw: gyro angle random walk, root-PSD (rad/√s).
        vrw: accelerometer velocity random walk, root-PSD (m/s/√s).
        gyro_bias_sigma: in-run gyro bias σ (rad/s), Gauss-Markov steady state.
        gyro_bias_tau: its correlation time (s); ``inf`` → random walk of root-PSD
            ``gyro_bias_rrw`` (rad/s/√s).
        accel_bias_sigma, accel_bias_tau, accel_bias_arw: the same for accelerometers (m/s², s,
            m/s²/√s).
    """

    arw: float = field(metadata={KIND_KEY: Kind.ANGLE_RANDOM_WALK})
    vrw: float = field(metadata={KIND_KEY: Kind.VELOCITY_RANDOM_WALK})
    gyro_bias_sigma: float = field(default=0.0, metadata={KIND_KEY: Kind.ANGULAR_RATE})
    gyro_bias_tau: float = field(default=math.inf, metadata={KIND_KEY: Kind.TIME})
    accel_bias_sigma: float = field(default=0.0, metadata={KIND_KEY: Kind.ACCELERATION})
    accel_bias_tau: float = field(default=math.inf, metadata={KIND_KEY: Kind.TIME})
    gyro_bias_rrw: float = field(default=0.0, metadata={KIND_KEY: Kind.RATE_RANDOM_WALK})
    accel_bias_arw: float = field(default=0.0, metadata={KIND_KEY: Kind.ACCEL_RANDOM_WALK})

    _MODEL_NAME: ClassVar[str] = "IMU noise"
    """The model's name in :meth:`from_datasheet`'s error for an unknown field."""

    def __post_init__(self) -> None:
        for f in noise_fields(type(self)):
            check_value(f.name, f.kind, getattr(self, f.name))

    @property
    def gyro_bias_psd(self) -> float:
        """Driving-noise PSD of the gyro bias: 2σ²/τ (Gauss-Markov) or RRW² (random walk)."""
        return _bias_psd(self.gyro_bias_sigma, self.gyro_bias_tau, self.gyro_bias_rrw)

    @property
    def accel_bias_psd(self) -> float:
        return _bias_psd(self.accel_bias_sigma, self.accel_bias_tau, self.accel_bias_arw)

    @classmethod
    def from_datasheet(cls, **given: tuple[float | str, str] | float) -> Self:
        """Build from ``name=(value, unit)`` pairs in datasheet units (:func:`pair_si`); a field
        without a unit kind (a subclass's scale factor) is a plain number.

        Example (the paper's Table 2 IMU)::

            ImuNoise.from_datasheet(arw=(0.0667, "deg/sqrt(h)"), vrw=(55, "ug/sqrt(Hz)"),
                                    gyro_bias_sigma=(1, "deg/h"), gyro_bias_tau=(1, "h"),
                                    accel_bias_sigma=(0.25, "mg"), accel_bias_tau=(1, "h"))
        """
        table = {f.name: f for f in noise_fields(cls)}
        si: dict[str, Any] = {}
        for name, value in given.items():
            f = table.get(name)
            if f is None:
                known = ", ".join(k for k, g in table.items() if g.kind is not None)
                raise UnitError(f"{name}: unknown {cls._MODEL_NAME} field (known: {known})")
            si[name] = value if f.kind is None else pair_si(name, f.kind, value)
        return cls(**si)


def noise_fields(model: type[ImuNoise]) -> tuple[NoiseField, ...]:
    """The field table of a noise model (:class:`ImuNoise` or a subclass), in field order."""
    return tuple(
        NoiseField(f.name, f.metadata.get(KIND_KEY), None if f.default is MISSING else f.default)
        for f in fields(model)
    )


NOISE_FIELDS = noise_fields(ImuNoise)
"""The noise terms: name, quantity kind and default of each field of :class:`ImuNoise`."""


def check_value(name: str, kind: Kind | None, value: object) -> None:
    """Refuse the SI value of field ``name`` out of its range: a correlation time (kind TIME) is
    > 0, inf for a random walk; anything else is a finite number >= 0."""
    # Written so that NaN fails each comparison.
    if kind is Kind.TIME:
        if not (isinstance(value, int | float) and value > 0):
            raise UnitError(f"{name}: value {value!r} must be > 0 (inf for a random walk)")
    elif not (isinstance(value, int | float) and 0 <= value < math.inf):
        raise UnitError(f"{name}: value {value!r} must be a finite number >= 0")


def pair_si(name: str, kind: Kind, pair: object) -> float:
    """SI value of the ``(value, unit)`` pair of field ``name``: a number in one of ``kind``'s
    units, or for a time ``"inf"`` (or inf): the correlation time of a random walk."""
    if not isinstance(pair, tuple | list) or len(pair) != 2:
        raise UnitError(f"{name}: expected (value, unit), got {pair!r}")
    value, unit = pair
    if kind is Kind.TIME and (
        (isinstance(value, str) and value.strip().lower() == "inf") or value == math.inf
    ):
        factor(unit, kind, name)  # the unit must still be a time
        return math.inf
    if isinstance(value, str):
        raise UnitError(f"{name}: value {value!r} is not a number")
    return to_si(value, unit, kind, name)


def _bias_psd(sigma: float, tau: float, rw: float) -> float:
    if math.isinf(tau):
        return rw * rw
    return 2.0 * sigma * sigma / tau
