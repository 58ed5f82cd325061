"""IMU noise specification: white noise and bias processes, SI inside, datasheet units at the edge.

The error model (docs/filters.md, 'Error-state model') needs, per sensor triad: white-noise
root-PSD (ARW for gyros, VRW for accelerometers) and a first-order Gauss-Markov bias with
steady-state σ and correlation time τ (τ = inf makes it a random walk with the given
rate-random-walk root-PSD instead).
Datasheet "bias stability/instability" is taken as the Gauss-Markov σ (Groves §4.4.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from adaptnav.core.units import Kind, UnitError, to_si

FIELD_KINDS: dict[str, Kind] = {
    "arw": Kind.ANGLE_RANDOM_WALK,
    "vrw": Kind.VELOCITY_RANDOM_WALK,
    "gyro_bias_sigma": Kind.ANGULAR_RATE,
    "gyro_bias_tau": Kind.TIME,
    "accel_bias_sigma": Kind.ACCELERATION,
    "accel_bias_tau": Kind.TIME,
    "gyro_bias_rrw": Kind.RATE_RANDOM_WALK,
    "accel_bias_arw": Kind.ACCEL_RANDOM_WALK,
}
"""The quantity kind (hence the accepted datasheet units) of each :class:`ImuNoise` field."""


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

    arw: float
    vrw: float
    gyro_bias_sigma: float = 0.0
    gyro_bias_tau: float = math.inf
    accel_bias_sigma: float = 0.0
    accel_bias_tau: float = math.inf
    gyro_bias_rrw: float = 0.0
    accel_bias_arw: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "arw",
            "vrw",
            "gyro_bias_sigma",
            "accel_bias_sigma",
            "gyro_bias_rrw",
            "accel_bias_arw",
        ):
            v = getattr(self, name)
            if not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
                raise UnitError(f"{name}: value {v!r} must be a finite number >= 0")
        for name in ("gyro_bias_tau", "accel_bias_tau"):
            v = getattr(self, name)
            if not isinstance(v, int | float) or math.isnan(v) or v <= 0:
                raise UnitError(f"{name}: value {v!r} must be > 0 (inf for a random walk)")

    @property
    def gyro_bias_psd(self) -> float:
        """Driving-noise PSD of the gyro bias: 2σ²/τ (Gauss-Markov) or RRW² (random walk)."""
        return _bias_psd(self.gyro_bias_sigma, self.gyro_bias_tau, self.gyro_bias_rrw)

    @property
    def accel_bias_psd(self) -> float:
        return _bias_psd(self.accel_bias_sigma, self.accel_bias_tau, self.accel_bias_arw)

    @classmethod
    def from_datasheet(cls, **fields: tuple[float, str]) -> ImuNoise:
        """Build from ``name=(value, unit)`` pairs in datasheet units.

        Example (the paper's Table 2 IMU)::

            ImuNoise.from_datasheet(arw=(0.0667, "deg/sqrt(h)"), vrw=(55, "ug/sqrt(Hz)"),
                                    gyro_bias_sigma=(1, "deg/h"), gyro_bias_tau=(1, "h"),
                                    accel_bias_sigma=(0.25, "mg"), accel_bias_tau=(1, "h"))
        """
        kinds = FIELD_KINDS
        si: dict[str, Any] = {}
        for name, pair in fields.items():
            if name not in kinds:
                raise UnitError(f"{name}: unknown IMU noise field (known: {', '.join(kinds)})")
            if not isinstance(pair, tuple | list) or len(pair) != 2:
                raise UnitError(f"{name}: expected (value, unit), got {pair!r}")
            value, unit = pair
            if (
                kinds[name] is Kind.TIME
                and isinstance(value, str)
                and value.strip().lower() == "inf"
            ):
                si[name] = math.inf
                continue
            si[name] = to_si(value, unit, kinds[name], field=name)
        return cls(**si)


def _bias_psd(sigma: float, tau: float, rw: float) -> float:
    if math.isinf(tau):
        return rw * rw
    return 2.0 * sigma * sigma / tau
