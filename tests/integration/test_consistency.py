"""Consistency in the paper's configuration: a short seeded Monte Carlo of NEES (issue 11).

The paper's sea trial No. 2 (``paper-2``: no GNSS aiding, every disturbance of the simulator
on, the engine's defaults) is simulated for a few seeds; the oracle (true per-reading R, known
outliers dropped: :mod:`adaptnav.api.oracle`) runs from each mission's own static alignment. Its
mean position and attitude NEES over the seeds must lie in a band around the χ²(3) mean of 3
(docs/metrics.md). GNSS aiding would hide a heading the filter only claims to know, so there is
none.

The band is wide because a run's NEES is strongly correlated in time (a heading error lasts the
whole run), so three seeds are worth a few independent samples: [1.0, 4.5], the upper end the
issue's target (1.5 × 3). The old defaults (F from a 1-s low-passed specific force, the
inclinometer read as the attitude) gave an oracle attitude NEES of 16-31 on every seed; the last
test checks that this configuration still leaves the band, so the band has teeth.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import adaptnav.api as api
from adaptnav.analysis import evaluate
from adaptnav.mission import load_mission
from adaptnav.sim.scenarios import simulate

SEEDS = (31, 32, 33)
"""Seeds not used while choosing the models (docs/error-model.md used 1-3 and 7-9)."""
BAND = (1.0, 4.5)


def _nees(mission: Path, smooth: bool = False) -> tuple[float, float]:
    m = load_mission(mission)
    metrics = evaluate.evaluate(api.run(m, "oracle", smooth=smooth), m.truth)
    return metrics.mean_nees_position, metrics.mean_nees_attitude


@pytest.fixture(scope="module")
def missions(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    root = tmp_path_factory.mktemp("consistency")
    return {s: simulate("paper-2", s, root / f"paper-2-s{s}") for s in SEEDS}


def test_oracle_nees_in_band_in_the_papers_configuration(missions: dict[int, Path]) -> None:
    values = np.array([_nees(missions[s]) for s in SEEDS])
    position, attitude = values.mean(axis=0)
    detail = f"per seed (position, attitude): {values.round(2).tolist()}"
    assert BAND[0] <= position <= BAND[1], f"mean position NEES {position:.2f}; {detail}"
    assert BAND[0] <= attitude <= BAND[1], f"mean attitude NEES {attitude:.2f}; {detail}"


def test_smoothed_oracle_nees_in_band_in_the_papers_configuration(
    missions: dict[int, Path],
) -> None:
    """The RTS-smoothed solution (docs/smoothing.md) claims no more than it has either."""
    values = np.array([_nees(missions[s], smooth=True) for s in SEEDS])
    position, attitude = values.mean(axis=0)
    detail = f"per seed (position, attitude): {values.round(2).tolist()}"
    assert BAND[0] <= position <= BAND[1], f"mean position NEES {position:.2f}; {detail}"
    assert BAND[0] <= attitude <= BAND[1], f"mean attitude NEES {attitude:.2f}; {detail}"


def test_old_defaults_leave_the_band(missions: dict[int, Path]) -> None:
    """F from a 1-s low-passed specific force and the inclinometer read as the attitude: the
    oracle claims a tilt and heading it does not have."""
    toml = missions[SEEDS[0]] / "mission.toml"
    text = toml.read_text()
    old = text.replace('model = "pendulum"', 'model = "attitude"').replace(
        "[filter]\n", "[filter]\nspecific_force_tau_s = 1.0\n"
    )
    assert old.count('model = "attitude"') == 1 and "specific_force_tau_s" in old
    toml.write_text(old)
    try:
        _, attitude = _nees(missions[SEEDS[0]])
    finally:
        toml.write_text(text)
    assert attitude > BAND[1]
