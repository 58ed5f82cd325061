"""Calibration estimates scored against the simulator's true errors
(:mod:`adaptnav.analysis.calibration`; docs/metrics.md, 'Calibration'): a state is matched by its
sensor's kind, whatever the mission calls the sensor."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any, cast

import pytest

from adaptnav.analysis.calibration import calibration_errors, true_values, units
from adaptnav.api.results import Result
from adaptnav.mission import parse_config
from adaptnav.sim.sensors import Calibration
from helpers.missions import config_dict

SIMULATED = {
    "seed": 1,
    "calibration": Calibration(
        0.98, (math.radians(0.5), 0.0, math.radians(-1.0)), 0.3, (math.radians(0.2), 0.0)
    ).as_dict(),
}


def _config() -> Any:
    """A mission whose sensors are not named after their kinds, estimating everything."""
    sensors = {
        "doppler": {"kind": "dvl", "file": "d.csv", "sigma": [0.02, "m/s"],
                    "estimate": ["misalignment", "scale"]},
        "pressure": {"kind": "depth", "file": "p.csv", "sigma": [0.1, "m"], "estimate": ["bias"]},
        "tilt": {"kind": "inclinometer", "file": "i.csv", "sigma": [0.1, "deg"],
                 "estimate": ["bias"]},
    }  # fmt: skip
    return parse_config(config_dict(sensors=sensors))


def test_true_values_match_each_state_by_its_sensors_kind_in_report_units() -> None:
    truth = true_values(_config(), SIMULATED)
    assert list(truth) == [
        "doppler.misalignment_roll", "doppler.misalignment_pitch", "doppler.misalignment_yaw",
        "doppler.scale", "pressure.bias", "tilt.bias_roll", "tilt.bias_pitch",
    ]  # fmt: skip
    expected = [0.5, 0.0, -1.0, -2.0, 0.3, 0.2, 0.0]  # deg, deg, deg, %, m, deg, deg
    assert list(truth.values()) == pytest.approx(expected, abs=1e-12)
    assert units(_config())["doppler.scale"] == (100.0, "%")


def test_without_the_simulators_record_no_state_has_a_true_value() -> None:
    cfg = _config()
    assert true_values(cfg, None) == {} and true_values(cfg, {"seed": 1}) == {}
    # a record of the depth bias alone gives that state only
    assert true_values(cfg, {"calibration": {"depth_bias_m": -0.2}}) == {"pressure.bias": -0.2}


def test_errors_are_estimate_minus_true_and_over_sigma_for_the_states_with_a_truth() -> None:
    meta = {
        "calibration": {
            "pressure.bias": {
                "estimate": 0.25,
                "sigma": 0.1,
                "sigma_long_run": 0.2,
                "prior_sigma": 0.5,
                "unit": "m",
            },
            "tilt.bias_roll": {"estimate": 0.1, "sigma": 0.0, "prior_sigma": 0.5, "unit": "deg"},
            "other.bias": {"estimate": 1.0, "sigma": 1.0, "prior_sigma": 1.0, "unit": "m"},
        }
    }
    result = cast(Result, SimpleNamespace(meta=meta))
    scored = calibration_errors(result, {"pressure.bias": 0.3, "tilt.bias_roll": 0.2})
    assert list(scored) == ["pressure.bias", "tilt.bias_roll"]
    bias = scored["pressure.bias"]
    assert bias["unit"] == "m" and bias["true"] == 0.3 and bias["estimate"] == 0.25
    assert bias["error"] == pytest.approx(-0.05) and bias["error_over_sigma"] == pytest.approx(-0.5)
    assert bias["error_over_sigma_long_run"] == pytest.approx(-0.25)
    assert math.isnan(cast(float, scored["tilt.bias_roll"]["error_over_sigma"]))
    # a run folder written before 0.3.9 has no long-run σ: no such ratio
    assert math.isnan(cast(float, scored["tilt.bias_roll"]["error_over_sigma_long_run"]))
    assert calibration_errors(cast(Result, SimpleNamespace(meta={})), {"pressure.bias": 0.3}) == {}
