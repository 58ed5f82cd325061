"""Calibration states end to end (docs/calibration.md): a simulated mission with known sensor
calibration errors (docs/simulation.md, 'Calibration errors'), estimated by the filter and
scored against the truth; the run folder's calibration.json."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import adaptnav.api as api
from adaptnav.analysis import evaluate
from adaptnav.api.results import CALIBRATION_FILE, load, save
from adaptnav.mission import load_mission
from adaptnav.sim.scenarios import simulate
from adaptnav.sim.sensors import Calibration

TRUTH = {
    "dvl.scale": 0.01,
    "dvl.misalignment_roll": 0.0,
    "dvl.misalignment_pitch": 0.0,
    "dvl.misalignment_yaw": math.radians(1.0),
    "depth.bias": 0.3,
    "inclinometer.bias_roll": math.radians(0.3),
    "inclinometer.bias_pitch": math.radians(-0.2),
}
ESTIMATE = {"dvl": '["scale", "misalignment"]', "depth": '["bias"]', "inclinometer": '["bias"]'}


@pytest.fixture(scope="module")
def missions(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The demo mission with the calibration errors of TRUTH, as simulated (nothing estimated)
    and with every quantity estimated."""
    root = tmp_path_factory.mktemp("calibration")
    cal = Calibration(1.01, (0.0, 0.0, math.radians(1.0)), 0.3,
                      (math.radians(0.3), math.radians(-0.2)))  # fmt: skip
    plain = simulate("demo", 4, root / "plain", calibration=cal)
    est = simulate("demo", 4, root / "est", calibration=cal)
    toml = est / "mission.toml"
    text = toml.read_text()
    for sensor, quantities in ESTIMATE.items():
        head = f'[sensors.{sensor}]\nkind = "{sensor}"\n'
        assert head in text
        text = text.replace(head, f"{head}estimate = {quantities}\n")
    toml.write_text(text)
    return plain, est


def test_estimates_cover_the_true_calibration_and_improve_the_solution(
    missions: tuple[Path, Path], tmp_path: Path
) -> None:
    plain, est = (load_mission(m) for m in missions)
    without, with_cal = api.run(plain, "vb"), api.run(est, "vb")
    assert "calibration" not in without.meta and not any("." in c for c in without.solution)
    found = with_cal.meta["calibration"]
    assert set(found) == set(TRUTH)
    for name, truth in TRUTH.items():
        f = 100.0 if name == "dvl.scale" else (1.0 if name == "depth.bias" else 180 / math.pi)
        value, sd, prior = (found[name][k] for k in ("estimate", "sigma", "prior_sigma"))
        assert abs(value - truth * f) < 3.0 * sd, (
            f"{name}: {value:.4g} ± {sd:.3g}, true {truth * f:.4g}"
        )
        assert sd <= prior * (1.0 + 1e-9), name
    # the DVL's yaw misalignment and scale are learnt from the manoeuvres, not just kept
    assert (
        found["dvl.misalignment_yaw"]["sigma"] < 0.5 * found["dvl.misalignment_yaw"]["prior_sigma"]
    )
    rmse = [evaluate.evaluate(r, plain.truth).rmse_m for r in (without, with_cal)]
    assert rmse[1] < 0.85 * rmse[0], rmse
    # the solution carries each state and its σ over time; the run folder, calibration.json
    assert with_cal.solution["dvl.scale"].iloc[0] == 0.0
    assert with_cal.solution["sd_dvl.scale"].iloc[-1] == pytest.approx(
        found["dvl.scale"]["sigma"] / 100
    )
    folder = save(with_cal, tmp_path / "run")
    assert json.loads((folder / CALIBRATION_FILE).read_text()) == found
    assert load(folder).meta["calibration"] == found
    save(without, folder)
    assert not (folder / CALIBRATION_FILE).exists()


def test_a_smoothed_run_estimates_them_too(missions: tuple[Path, Path]) -> None:
    m = load_mission(missions[1])
    r = api.run(m, "robust", smooth=True)
    assert r.forward is not None
    for name in TRUTH:
        assert name in r.solution and name in r.forward and f"sd_{name}" in r.solution
    # the states are constants: the smoothed value everywhere is the forward one at the end
    np.testing.assert_allclose(r.solution["dvl.scale"], r.forward["dvl.scale"].iloc[-1], atol=1e-9)
    assert r.solution["sd_dvl.scale"].iloc[0] < r.forward["sd_dvl.scale"].iloc[0]
