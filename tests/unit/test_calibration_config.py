"""Calibration states in mission.toml (docs/calibration.md): what may be estimated, priors in
datasheet units, their place in the error state, and nothing written when none is asked for."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from adaptnav.mission import MissionError, calibration, parse_config
from adaptnav.models.errorstate import N_STATES
from helpers.missions import config_dict


def _config(dvl: dict[str, Any], **more: dict[str, Any]) -> Any:
    sensors = {"dvl": {"kind": "dvl", "file": "dvl.csv", "sigma": [0.02, "m/s"], **dvl}, **more}
    return parse_config(config_dict(sensors=sensors))


def test_estimated_quantities_become_blocks_after_the_core_in_order() -> None:
    prior = {"bias": {"sigma": [20, "cm"], "random_walk": [0.6, "m/sqrt(h)"]}}
    depth = {"kind": "depth", "file": "d.csv", "sigma": [0.1, "m"], "estimate": ["bias"],
             "calibration": prior}  # fmt: skip
    off = {"kind": "depth", "file": "o.csv", "sigma": [0.1, "m"], "estimate": ["bias"],
           "use": "off"}  # fmt: skip
    cfg = _config(
        {"estimate": ["misalignment", "scale"],
         "calibration": {"scale": {"sigma": [0.5, "%"]}}},
        depth=depth, spare=off,
    )  # fmt: skip
    states = calibration.calibration_states(cfg)
    assert [(s.sensor, s.quantity.name, s.first) for s in states] == [
        ("dvl", "misalignment", 15),
        ("dvl", "scale", 18),
        ("depth", "bias", 19),
    ]  # fmt: skip  (a sensor switched off has no states)
    mis, scale, bias = states
    assert mis.sigma == pytest.approx(math.radians(2.0)) and mis.random_walk == 0.0
    assert scale.sigma == pytest.approx(0.005)
    assert bias.sigma == pytest.approx(0.2) and bias.random_walk == pytest.approx(0.01)
    layout = calibration.layout(states)
    assert layout.n == N_STATES + 5
    assert layout.names[15:] == (
        "dvl.misalignment_roll", "dvl.misalignment_pitch", "dvl.misalignment_yaw",
        "dvl.scale", "depth.bias",
    )  # fmt: skip
    assert layout.extra_psd()[-1] == pytest.approx(0.01**2)
    assert calibration.indices(states, "dvl") == {"misalignment": 15, "scale": 18}
    x, P = calibration.extend(np.arange(16.0), np.eye(15), states)
    assert x.shape == (21,) and np.all(x[16:] == 0.0) and np.all(x[:16] == np.arange(16.0))
    np.testing.assert_allclose(np.diag(P)[15:], [mis.sigma**2] * 3 + [0.005**2, 0.04])
    assert np.all(P[:15, 15:] == 0.0)


@pytest.mark.parametrize(
    ("dvl", "message"),
    [
        ({"estimate": ["offset"]}, "a dvl sensor cannot estimate 'offset' \\(scale, misal"),
        ({"estimate": ["scale", "scale"]}, "names a quantity twice"),
        ({"estimate": ["scale"], "calibration": {"misalignment": {}}},
         "calibration.misalignment: not in estimate"),
        ({"estimate": ["scale"], "calibration": {"scale": {"sigma": [1, "deg"]}}},
         "unknown unit 'deg' for ratio"),
        ({"estimate": ["scale"], "calibration": {"scale": {"sigma": [0, "%"]}}}, "must be > 0"),
        ({"estimate": ["scale"], "calibration": {"scale": {"tau": [0, "s"]}}},
         "calibration.scale.tau: must be > 0"),
        ({"estimate": ["scale"], "calibration": {"scale": {"tau": [10, "m"]}}},
         "unknown unit 'm' for time"),
        ({"estimate": ["scale"],
          "calibration": {"scale": {"tau": [60, "s"], "random_walk": [1, "%/sqrt(h)"]}}},
         "calibration.scale: give random_walk or tau"),
    ],
)  # fmt: skip
def test_what_cannot_be_estimated_is_an_error_naming_the_key(
    dvl: dict[str, Any], message: str
) -> None:
    with pytest.raises(MissionError, match=message):
        _config(dvl)


def test_a_correlation_time_makes_a_gauss_markov_state_that_keeps_its_sigma() -> None:
    gnss = {"kind": "gnss", "file": "g.csv", "sigma": [1.5, "m"], "estimate": ["bias"],
            "calibration": {"bias": {"sigma": [2.5, "m"], "tau": [2, "min"]}}}  # fmt: skip
    cfg = _config({"estimate": ["scale"], "calibration": {"scale": {"tau": ["inf", "s"]}}},
                  gps=gnss)  # fmt: skip
    scale, bias = calibration.calibration_states(cfg)
    assert math.isinf(scale.tau) and bias.tau == pytest.approx(120.0)
    layout = calibration.layout((scale, bias))
    # steady variance q τ / 2 = σ²
    np.testing.assert_allclose(layout.extra_psd(), [0.0, 2 * 2.5**2 / 120.0, 2 * 2.5**2 / 120.0])
    np.testing.assert_allclose(layout.extra_inv_tau(), [0.0, 1 / 120.0, 1 / 120.0])
    assert "tau" in cfg.dump_toml()


def test_a_mission_without_calibration_writes_no_keys_for_it() -> None:
    cfg = _config({})
    assert calibration.calibration_states(cfg) == ()
    assert "estimate" not in cfg.dump_toml() and "calibration" not in cfg.dump_toml()
    again = _config({"estimate": ["scale"]})
    assert 'estimate = ["scale"]' in again.dump_toml()
    assert parse_config(again.document()) == again
