"""Datasheet unit conversion against hand-worked values, and refusal of bad specs."""

from __future__ import annotations

import math

import pytest

from adaptnav.core.units import Kind, UnitError, to_si
from adaptnav.models.imu_noise import ImuNoise


@pytest.mark.parametrize(
    ("value", "unit", "kind", "expected"),
    [
        # 0.0667 deg/√h · (π/180) / 60 s^½ = 1.9402e-5 rad/√s
        (0.0667, "deg/sqrt(h)", Kind.ANGLE_RANDOM_WALK, 1.9402e-5),
        (0.0667, "deg/√h", Kind.ANGLE_RANDOM_WALK, 1.9402e-5),
        # 55 µg/√Hz · 9.80665e-6 = 5.3937e-4 m/s²/√Hz
        (55, "µg/√Hz", Kind.VELOCITY_RANDOM_WALK, 5.3937e-4),
        (55, "ug/sqrt(Hz)", Kind.VELOCITY_RANDOM_WALK, 5.3937e-4),
        # 1 deg/h = 0.0174533 / 3600 = 4.8481e-6 rad/s
        (1, "deg/h", Kind.ANGULAR_RATE, 4.8481e-6),
        (20, "deg/hr", Kind.ANGULAR_RATE, 9.6963e-5),
        # 50 mg = 0.4903 m/s²; 0.25 mg = 2.4517e-3 m/s²
        (50, "mg", Kind.ACCELERATION, 0.49033),
        (0.25, "mg", Kind.ACCELERATION, 2.4517e-3),
        (0.6, "m/s/√h", Kind.VELOCITY_RANDOM_WALK, 0.01),
        (1, "h", Kind.TIME, 3600.0),
        (2, "kn", Kind.SPEED, 1.02889),
    ],
)
def test_hand_worked_values(value: float, unit: str, kind: Kind, expected: float) -> None:
    assert to_si(value, unit, kind) == pytest.approx(expected, rel=1e-4)


def test_paper_imu_from_datasheet() -> None:
    n = ImuNoise.from_datasheet(
        arw=(0.0667, "deg/sqrt(h)"),
        vrw=(55, "ug/sqrt(Hz)"),
        gyro_bias_sigma=(1, "deg/h"),
        gyro_bias_tau=(1, "h"),
        accel_bias_sigma=(0.25, "mg"),
        accel_bias_tau=("inf", "s"),
    )
    assert n.arw == pytest.approx(1.9402e-5, rel=1e-4)
    assert n.vrw == pytest.approx(5.3937e-4, rel=1e-4)
    assert n.gyro_bias_psd == pytest.approx(2 * 4.8481e-6**2 / 3600, rel=1e-4)
    assert math.isinf(n.accel_bias_tau)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"arw": (-0.1, "deg/sqrt(h)")}, r"arw: value -0\.1 must not be negative"),
        ({"arw": (float("nan"), "deg/sqrt(h)")}, r"arw: value nan is not finite"),
        ({"vrw": (55, "furlongs")}, r"vrw: unknown unit 'furlongs' for velocity random walk"),
        ({"vrw": ("abc", "ug/sqrt(Hz)")}, r"vrw: value 'abc' is not a number"),
        ({"gyro_bias_tau": (0, "s")}, r"gyro_bias_tau: value 0\.0 must be > 0"),
        ({"bias": (1, "deg/h")}, r"bias: unknown IMU noise field"),
        ({"arw": 0.1}, r"arw: expected \(value, unit\)"),
    ],
)
def test_bad_specs_are_refused_naming_field_and_value(fields: dict, message: str) -> None:
    base = {"arw": (0.1, "deg/sqrt(h)"), "vrw": (50, "ug/sqrt(Hz)")}
    with pytest.raises(UnitError, match=message):
        ImuNoise.from_datasheet(**{**base, **fields})


def test_si_constructor_validates() -> None:
    with pytest.raises(UnitError, match="vrw"):
        ImuNoise(arw=1e-5, vrw=float("nan"))


def test_a_latency_prior_takes_milliseconds_and_its_random_walk_per_root_hour() -> None:
    """The DVL latency state's units (sensors/calibration.LATENCY, 0.4.3): ``ms`` is a time,
    ``ms/sqrt(h)`` a time random walk; neither existed before."""
    assert to_si(50.0, "ms", Kind.TIME, "sigma") == pytest.approx(0.05)
    assert to_si(60.0, "ms/sqrt(h)", Kind.TIME_RANDOM_WALK, "rw") == pytest.approx(1e-3)
    assert to_si(1.0, "s/sqrt(s)", Kind.TIME_RANDOM_WALK, "rw") == 1.0
