"""Datasheet units to SI, by quantity kind (docs/conventions.md: SI inside, radians).

Each kind accepts a fixed table of spellings; anything else is refused with the field and the
unit named. ``µ``/``u``, ``√``/``sqrt()``, ``²``/``^2`` and spaces are normalised first.
"""

from __future__ import annotations

import math
from enum import StrEnum

G0 = 9.80665
"""Standard gravity (m/s²), the g of datasheets' mg and µg."""
DEG = math.pi / 180.0


class Kind(StrEnum):
    ANGLE_RANDOM_WALK = "angle random walk"  # → rad/√s
    VELOCITY_RANDOM_WALK = "velocity random walk"  # → m/s/√s = m/s²/√Hz
    ANGULAR_RATE = "angular rate"  # → rad/s (gyro bias)
    ACCELERATION = "acceleration"  # → m/s² (accelerometer bias)
    TIME = "time"  # → s
    ANGLE = "angle"  # → rad
    SPEED = "speed"  # → m/s
    LENGTH = "length"  # → m
    RATE_RANDOM_WALK = "rate random walk"  # → rad/s/√s
    ACCEL_RANDOM_WALK = "acceleration random walk"  # → m/s²/√s
    RATIO = "ratio"  # → 1 (a scale-factor error)
    RATIO_RANDOM_WALK = "ratio random walk"  # → 1/√s
    LENGTH_RANDOM_WALK = "length random walk"  # → m/√s
    TIME_RANDOM_WALK = "time random walk"  # → s/√s (a clock offset that wanders)


_FACTORS: dict[Kind, dict[str, float]] = {
    Kind.ANGLE_RANDOM_WALK: {
        "rad/sqrt(s)": 1.0,
        "rad/s/sqrt(hz)": 1.0,
        "deg/sqrt(h)": DEG / 60.0,
        "deg/sqrt(hr)": DEG / 60.0,
        "deg/h/sqrt(hz)": DEG / 3600.0,
        "deg/hr/sqrt(hz)": DEG / 3600.0,
        "deg/s/sqrt(hz)": DEG,
        "deg/sqrt(s)": DEG,
    },
    Kind.VELOCITY_RANDOM_WALK: {
        "m/s/sqrt(s)": 1.0,
        "m/s^2/sqrt(hz)": 1.0,
        "m/s/sqrt(h)": 1.0 / 60.0,
        "m/s/sqrt(hr)": 1.0 / 60.0,
        "ug/sqrt(hz)": 1e-6 * G0,
        "mg/sqrt(hz)": 1e-3 * G0,
        "g/sqrt(hz)": G0,
    },
    Kind.ANGULAR_RATE: {
        "rad/s": 1.0,
        "deg/s": DEG,
        "deg/h": DEG / 3600.0,
        "deg/hr": DEG / 3600.0,
    },
    Kind.ACCELERATION: {"m/s^2": 1.0, "g": G0, "mg": 1e-3 * G0, "ug": 1e-6 * G0},
    Kind.TIME: {"s": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0, "hr": 3600.0},
    Kind.ANGLE: {"rad": 1.0, "deg": DEG},
    Kind.SPEED: {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2, "kn": 1852.0 / 3600.0},
    Kind.LENGTH: {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "km": 1e3},
    Kind.RATE_RANDOM_WALK: {
        "rad/s/sqrt(s)": 1.0,
        "rad/s^2/sqrt(hz)": 1.0,
        "deg/h/sqrt(h)": DEG / 3600.0 / 60.0,
        "deg/hr/sqrt(hr)": DEG / 3600.0 / 60.0,
    },
    Kind.ACCEL_RANDOM_WALK: {
        "m/s^2/sqrt(s)": 1.0,
        "m/s^3/sqrt(hz)": 1.0,
        "ug/sqrt(h)": 1e-6 * G0 / 60.0,
        "mg/sqrt(h)": 1e-3 * G0 / 60.0,
    },
    Kind.RATIO: {"1": 1.0, "%": 1e-2, "ppm": 1e-6},
    Kind.RATIO_RANDOM_WALK: {
        "1/sqrt(s)": 1.0,
        "%/sqrt(h)": 1e-2 / 60.0,
        "ppm/sqrt(h)": 1e-6 / 60.0,
    },
    Kind.LENGTH_RANDOM_WALK: {"m/sqrt(s)": 1.0, "m/sqrt(h)": 1.0 / 60.0, "cm/sqrt(h)": 1e-2 / 60.0},
    Kind.TIME_RANDOM_WALK: {"s/sqrt(s)": 1.0, "ms/sqrt(s)": 1e-3, "ms/sqrt(h)": 1e-3 / 60.0},
}


class UnitError(ValueError):
    """A value or unit that cannot be converted; the message names the field."""


def normalize_unit(unit: str) -> str:
    """Canonical spelling: lower case, no spaces, µ→u, √x→sqrt(x), ²→^2."""
    u = unit.strip().lower().replace(" ", "").replace("µ", "u").replace("μ", "u").replace("²", "^2")
    if "√" in u:
        head, _, tail = u.partition("√")
        u = f"{head}sqrt({tail})" if not tail.startswith("(") else f"{head}sqrt{tail}"
    return u


def factor(unit: str, kind: Kind, field: str = "value") -> float:
    """SI factor of ``unit`` for a quantity of ``kind``; refuses unknown units naming ``field``."""
    table = _FACTORS[kind]
    key = normalize_unit(unit)
    if key not in table:
        known = ", ".join(sorted(table))
        raise UnitError(f"{field}: unknown unit {unit!r} for {kind.value} (known: {known})")
    return table[key]


SIGMA_RANGE_SI = (1e-12, 1e7)
"""Smallest and largest standard deviation or noise density accepted from a user, in SI units
of its kind: far beyond any real sensor both ways (a navigation-grade gyro's angle random walk
is 3e-7 rad/√s, the Earth's radius 6.4e6 m), and the squares stay ordinary floats. Outside,
the value is a typo or a wrong unit; a variance of 1e-600 or 1e600 would be 0 or inf and end
the run in a division by zero or an overflow (docs/data-format.md)."""


def check_sigma(field: str, si: float, unit: str, *, zero_ok: bool = False) -> None:
    """Refuse a standard deviation (or noise density) ``si`` outside :data:`SIGMA_RANGE_SI`;
    with ``zero_ok`` (a bias term, where 0 is no bias and a tiny one is as good as none) only
    above it. ``unit``: the SI unit, for the message."""
    lo, hi = SIGMA_RANGE_SI
    if not (0.0 if zero_ok else lo) <= si <= hi:
        u = "" if unit == "1" else f" {unit}"  # a ratio has no unit to print
        raise UnitError(
            f"{field}: {si:.3g}{u} is not a plausible standard deviation (accepted: "
            f"{lo:g} to {hi:g}{u}; a typo, or the wrong unit?)"
        )


def si_unit(kind: Kind) -> str:
    """The SI spelling of a quantity of ``kind`` (its unit of factor 1): ``"m/s"``, ``"rad"``."""
    return next(u for u, f in _FACTORS[kind].items() if f == 1.0)


def to_si(
    value: float, unit: str, kind: Kind, field: str = "value", allow_negative: bool = False
) -> float:
    """Convert ``value`` in ``unit`` to SI; refuses NaN, infinities and (by default) negatives."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UnitError(f"{field}: value {value!r} is not a number") from None
    if not math.isfinite(v):
        raise UnitError(f"{field}: value {value!r} is not finite")
    if v < 0 and not allow_negative:
        raise UnitError(f"{field}: value {value!r} must not be negative")
    return v * factor(unit, kind, field)
