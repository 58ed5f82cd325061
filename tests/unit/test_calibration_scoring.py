"""Calibration estimates scored against the simulator's true errors
(:mod:`adaptnav.analysis.calibration`; docs/metrics.md, 'Calibration'): a state is matched by its
sensor's kind, whatever the mission calls the sensor."""

from __future__ import annotations

import math
import re
from pathlib import Path
from types import SimpleNamespace
from typing import Any, cast

import numpy as np
import pytest

from adaptnav.analysis.calibration import (
    CalibrationTruthError,
    calibration_errors,
    run_surfaces,
    simulation_truth,
    true_values,
    units,
)
from adaptnav.api.results import Result
from adaptnav.mission import parse_config, write_config
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


def _known(**dvl: Any) -> Any:
    """A mission whose configuration compensates part of the simulated errors: a DVL latency,
    a DVL mounting, the depth meter's surface and the inclinometer's mounting roll."""
    sensors = {
        "doppler": {"kind": "dvl", "file": "d.csv", "sigma": [0.02, "m/s"],
                    "estimate": ["misalignment", "latency"], **dvl},
        "pressure": {"kind": "depth", "file": "p.csv", "sigma": [0.1, "m"], "estimate": ["bias"],
                     "surface_h_m": 0.25},
        "tilt": {"kind": "inclinometer", "file": "i.csv", "sigma": [0.1, "deg"],
                 "estimate": ["bias"], "mounting_rpy_deg": [0.15, 0.0, 0.0]},
        "gps": {"kind": "gnss", "file": "g.csv", "sigma": [3.0, "m"], "estimate": ["latency"],
                "latency_s": -0.05},
    }  # fmt: skip
    return parse_config(config_dict(sensors=sensors))


KNOWN_SIM = {
    "calibration": Calibration(
        dvl_misalignment=tuple(math.radians(a) for a in (0.5, -0.3, 2.0)),
        depth_bias=0.3,
        inclinometer_bias=(math.radians(0.2), math.radians(-0.1)),
        dvl_latency=0.2,
        gps_latency=0.1,
    ).as_dict()
}


def test_the_part_the_configuration_compensates_is_not_scored_as_an_error() -> None:
    """docs/calibration.md: a known latency goes in latency_s and the state estimates the rest;
    the same for the depth meter's surface_h_m and a mounting. Before 0.4.6 the state was
    scored against the whole simulated error (a right estimate of 0 ms at 'error/σ -15.7')."""
    truth = true_values(_known(latency_s=0.2, mounting_rpy_deg=[0.5, -0.3, 2.0]), KNOWN_SIM)
    assert truth["doppler.latency"] == pytest.approx(0.0, abs=1e-9)  # 200 ms - 200 ms
    for angle in ("roll", "pitch", "yaw"):  # the mounting is the simulated misalignment
        assert truth[f"doppler.misalignment_{angle}"] == pytest.approx(0.0, abs=1e-12)
    assert truth["pressure.bias"] == pytest.approx(0.3 - 0.25)  # reads h_s - h + b
    assert truth["tilt.bias_roll"] == pytest.approx(0.2 - 0.15)
    assert truth["tilt.bias_pitch"] == pytest.approx(-0.1)
    assert truth["gps.latency"] == pytest.approx(1e3 * (0.1 + 0.05))  # ms
    # a latency_s larger than the simulated one leaves a negative latency to estimate
    assert true_values(_known(latency_s=0.35), KNOWN_SIM)["doppler.latency"] == pytest.approx(
        -150.0
    )


@pytest.mark.parametrize("mounting", [[0.5, -0.3, 0.0], [1.0, 1.0, -1.0], [0.0, 0.0, 2.0]])
def test_the_misalignment_truth_is_the_rotation_from_the_configured_to_the_true_frame(
    mounting: list[float],
) -> None:
    """The model reads M(δ) C_sb v_b (sensors/dvl.py), the simulator M(δ_sim) v_b: with the true
    δ the two agree for any body velocity; the Euler angles' difference does not (it is off by
    more than the 0.001° evaluate shows)."""
    from adaptnav.core.attitude import euler_to_dcm
    from adaptnav.sensors.calibration import misalignment

    simulated = [math.radians(a) for a in (0.5, -0.3, 2.0)]
    truth = true_values(_known(mounting_rpy_deg=mounting), KNOWN_SIM)
    delta = [math.radians(truth[f"doppler.misalignment_{a}"]) for a in ("roll", "pitch", "yaw")]
    C_sb = euler_to_dcm(*(math.radians(a) for a in mounting)).T
    v_b = np.array([[2.0, 0.1, -0.05], [0.3, -1.5, 0.2], [-1.0, 0.4, 0.9]])
    model = v_b @ (misalignment(delta) @ C_sb).T
    simulator = v_b @ misalignment(simulated).T
    assert np.max(np.abs(model - simulator)) < 1e-14
    naive = np.degrees(simulated) - np.asarray(mounting)
    if mounting != [0.0, 0.0, 2.0]:  # a yaw alone commutes: there the difference is exact
        assert np.max(np.abs(np.degrees(delta) - naive)) > 0.005


def test_an_auto_surface_is_the_one_the_run_measured() -> None:
    cfg_dict = config_dict(
        sensors={"pressure": {"kind": "depth", "file": "p.csv", "sigma": [0.1, "m"],
                              "estimate": ["bias"], "surface_h_m": "auto"}}
    )  # fmt: skip
    cfg = parse_config(cfg_dict)
    assert true_values(cfg, KNOWN_SIM) == {}  # not measured: no truth, rather than a wrong one
    measured = run_surfaces({"surface_h_m": {"pressure": 30.12345}})
    assert true_values(cfg, KNOWN_SIM, measured)["pressure.bias"] == pytest.approx(0.3 - 30.123)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{not json", "not readable JSON"),
        ("[1, 2]", "not a JSON object"),
        ('{"calibration": "x"}', "calibration: 'x' is not an object"),
        ('{"calibration": {"dvl_misalignment_rad": [0.01]}}',
         "calibration.dvl_misalignment_rad: [0.01] is not a list of 3 numbers"),
        ('{"calibration": {"dvl_scale_factor": "1.02"}}',
         "calibration.dvl_scale_factor: '1.02' is not a number"),
        ('{"calibration": {"dvl_scale_factor": NaN}}',
         "calibration.dvl_scale_factor: nan is not finite"),
        ('{"calibration": {"depth_bias_m": true}}', "calibration.depth_bias_m: True is not"),
        ('{"calibration": {"dvl_misalignment_deg": [0.5, 0, 0]}}',
         "dvl_misalignment_deg without dvl_misalignment_rad"),
    ],
)  # fmt: skip
def test_a_damaged_simulation_json_is_an_error_naming_the_file_and_key(
    tmp_path: Path, text: str, message: str
) -> None:
    """Before 0.4.6 it gave no truth (unreadable) or part of it: a misalignment list of one
    angle scored the roll against 0.573° and dropped the pitch and yaw rows."""
    (tmp_path / "simulation.json").write_text(text, encoding="utf-8")
    with pytest.raises(CalibrationTruthError, match=re.escape(message)) as err:
        simulation_truth(_config(), tmp_path)
    assert str(err.value).startswith(str(tmp_path / "simulation.json"))


def test_a_missing_simulation_json_or_section_is_no_truth(tmp_path: Path) -> None:
    assert simulation_truth(_config(), tmp_path) == {}  # a real mission
    (tmp_path / "simulation.json").write_text('{"seed": 1, "calibration": null}', "utf-8")
    assert simulation_truth(_config(), tmp_path) == {}


def test_evaluate_fails_with_the_file_and_key_of_a_damaged_simulation_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`adaptnav evaluate RUN --mission M` with M's simulation.json damaged: exit 2, the file and
    the key named, no traceback (cli/core.py `_calibration_errors`)."""
    import typer

    from adaptnav.cli.core import _calibration_errors

    folder = tmp_path / "m"
    folder.mkdir()
    write_config(_config(), folder / "mission.toml")
    (folder / "simulation.json").write_text(
        '{"calibration": {"dvl_misalignment_rad": [0.01]}}', encoding="utf-8"
    )
    meta = {"calibration": {"doppler.scale": {"estimate": 1.0, "sigma": 0.5, "unit": "%"}}}
    result = cast(Result, SimpleNamespace(meta=meta))
    with pytest.raises(typer.Exit) as stop:
        _calibration_errors(result, folder)
    assert stop.value.exit_code == 2
    err = capsys.readouterr().err
    assert "simulation.json" in err and "calibration.dvl_misalignment_rad" in err
