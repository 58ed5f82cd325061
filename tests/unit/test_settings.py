"""The one settings model (estimation/settings.py): ``mission.toml``'s ``[filter]`` is the filter's
settings plus three engine fields, each declared and defaulted once."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from adaptnav.engine.channels import build_channels
from adaptnav.estimation.noise.process import QAdaptation
from adaptnav.estimation.noise.vb import VariationalBayes
from adaptnav.estimation.settings import (
    DEFAULT_R_BOUNDS,
    DEFAULT_ROBUST_DOF,
    FilterSettings,
    SensorOverrides,
)
from adaptnav.mission import MissionError, parse_config
from adaptnav.mission.config import FilterConfig
from adaptnav.sensors import DVL, GNSS, Depth
from adaptnav.sensors.nhc import NonHolonomic
from helpers.missions import config_dict


def test_the_mission_section_is_the_settings_plus_the_engine_fields() -> None:
    settings, section = FilterSettings.model_fields, FilterConfig.model_fields
    assert set(section) - set(settings) == {
        "epoch_policy",
        "output_rate_hz",
        "specific_force_tau_s",
        "covariance_block_s",
        "invariant_reset",
    }
    for name, field in settings.items():
        # Inherited, not copied: one declaration, one default.
        assert section[name] is field or section[name].default == field.default, name
    defaults = parse_config(config_dict()).filter_settings()
    assert defaults == FilterSettings(gate_sensors=("dvl",))


def test_a_mission_value_reaches_the_settings() -> None:
    cfg = parse_config(config_dict(filter={"kind": "vb", "vb_rho": 0.95, "vb_dof": 4}))
    s = cfg.filter_settings()
    assert (s.kind, s.vb_rho, s.vb_dof) == ("vb", 0.95, 4.0)


@pytest.mark.parametrize(
    ("given", "expected"),
    [(True, QAdaptation()), (False, None), ({"gain": 0.2}, QAdaptation(gain=0.2))],
)
def test_q_adaptation_switch(given: object, expected: QAdaptation | None) -> None:
    cfg = parse_config(config_dict(filter={"q_adaptation": given}))
    assert cfg.filter_settings().q_adaptation == expected


def test_robust_dof_gives_robust_student_t_readings_and_leaves_the_paper_filter_alone() -> None:
    """robust's readings are weighted as Student-t with ν = robust_dof (R̂ learned as by the
    Gaussian update; 100 by default, 0 Gaussian), unless vb_dof (full Student-t) says otherwise;
    VB-MAESKF stays the paper's Gaussian update unless vb_dof is set."""

    def dof(**changes: float | str) -> tuple[float | None, bool]:
        strategy = FilterSettings.model_validate(changes).strategy()
        assert isinstance(strategy, VariationalBayes)
        return strategy.dof, strategy.weights_only

    assert DEFAULT_ROBUST_DOF == 100.0 and dof() == (100.0, True)
    assert dof(robust_dof=0.0) == (None, False)  # Gaussian readings, robust of 0.3.2
    assert dof(kind="vb") == (None, False)  # the paper's VB-MAESKF untouched by the default
    assert dof(robust_dof=60.0) == (60.0, True)  # weights; R̂ learned as by the Gaussian VB
    assert dof(kind="vb", robust_dof=60.0) == (None, False)
    assert dof(vb_dof=4.0, robust_dof=60.0) == (4.0, False) == dof(kind="vb", vb_dof=4.0)
    cfg = parse_config(config_dict(filter={"robust_dof": 60}))
    strategy = cfg.filter_settings().strategy()
    assert isinstance(strategy, VariationalBayes) and strategy.dof == 60.0 and strategy.weights_only
    with pytest.raises(MissionError, match=r"filter\.robust_dof"):
        parse_config(config_dict(filter={"robust_dof": -1}))


def test_bounds_for_one_kind_keep_the_others_defaults() -> None:
    s = FilterSettings(r_bounds={"vb": (0.5, 2.0)})
    assert s.r_bounds == {**DEFAULT_R_BOUNDS, "vb": (0.5, 2.0)}
    with pytest.raises(pydantic.ValidationError, match="floor < ceiling"):
        FilterSettings(r_bounds={"vb": (2.0, 1.0)})


@pytest.mark.parametrize(
    ("section", "words"),
    [
        ({"kind": "oracle"}, "filter.kind: 'oracle' is a baseline"),
        ({"vb_rho": 1.5}, "filter.vb_rho"),
        ({"q_adaptation": {"gain": -1}}, "filter.q_adaptation"),
        ({"divergence": {"vb": {"nis_ratio": 0.5}}}, "filter.divergence.vb"),
    ],
)
def test_bad_values_name_the_key(section: dict[str, object], words: str) -> None:
    with pytest.raises(MissionError, match=words.replace("(", r"\(")):
        parse_config(config_dict(filter=section))


def test_settings_are_frozen_and_changes_are_checked() -> None:
    with pytest.raises(pydantic.ValidationError):
        FilterSettings().vb_rho = 0.5  # type: ignore[misc]
    assert FilterSettings().updated(vb_rho=0.5).vb_rho == 0.5
    with pytest.raises(pydantic.ValidationError, match="vb_rho"):
        FilterSettings().updated(vb_rho=5.0)


def test_without_gate_sensors_every_dvl_is_gated_whatever_its_name() -> None:
    s = FilterSettings(kind="meskf")
    sensors = [
        (DVL(np.full(3, 0.02), name="bottom_tracker"), 1 / 3),
        (Depth(0.1, name="dvl"), 1.0),  # named like a DVL, but a depth sensor
    ]
    gates = [ch.gate for ch in build_channels(s, sensors)]
    assert gates[0] is not None and gates[0].q == 600.0
    assert gates[1] is None
    named = build_channels(s.updated(gate_sensors=("dvl",)), sensors)
    assert named[0].gate is None and named[1].gate is not None


def test_under_bounded_r_a_constraint_or_a_gnss_never_goes_below_its_nominal_r() -> None:
    """A motion constraint's residuals are what the filter made of it, and a GNSS position's
    error is correlated over minutes: robust (bounded R̂) keeps the NHC's and the GNSS's R̂ at
    their nominal R or above, a DVL beside them at the kind's floor, and the paper's
    VB-MAESKF (no bounds) stays as the paper has it."""
    sensors = [(NonHolonomic(0.2), 0.1), (DVL(0.01), 0.2), (GNSS(0.02, name="rtk"), 0.25)]
    robust = FilterSettings(kind="robust")
    nhc, dvl, gnss = (c.strategy for c in build_channels(robust, sensors))
    assert isinstance(nhc, VariationalBayes) and isinstance(dvl, VariationalBayes)
    assert isinstance(gnss, VariationalBayes)
    assert nhc.r_floor == gnss.r_floor == 1.0
    assert nhc.r_ceiling == dvl.r_ceiling == gnss.r_ceiling == DEFAULT_R_BOUNDS["robust"][1]
    assert dvl.r_floor == DEFAULT_R_BOUNDS["robust"][0] < 1.0
    paper = [c.strategy for c in build_channels(robust.with_kind("vb"), sensors)]
    assert all(isinstance(s, VariationalBayes) and s.r_floor == 0.0 for s in paper)


def test_under_robust_a_gnss_position_forgets_faster_unless_its_sensor_says() -> None:
    """A receiver's accuracy changes within seconds: robust's GNSS R̂ forgets at
    ``robust_gnss_rho`` per fix (0.95, docs/robustness.md 'GNSS R̂ memory'), every other sensor
    at ``vb_rho``; a sensor's own ``vb_rho`` wins, and the paper's VB-MAESKF keeps 0.99."""
    sensors = [(NonHolonomic(0.2), 0.1), (DVL(0.01), 0.2), (GNSS(0.02, name="rtk"), 0.25)]
    robust = FilterSettings(kind="robust")
    nhc, dvl, gnss = (c.strategy for c in build_channels(robust, sensors))
    assert isinstance(nhc, VariationalBayes) and isinstance(dvl, VariationalBayes)
    assert isinstance(gnss, VariationalBayes)
    assert nhc.rho == dvl.rho == 0.99 and gnss.rho == 0.95
    own = build_channels(robust, sensors, {"rtk": SensorOverrides(vb_rho=0.98)})
    assert [c.strategy.rho for c in own] == [0.99, 0.99, 0.98]  # type: ignore[attr-defined]
    set_ = build_channels(robust.updated(robust_gnss_rho=0.9), sensors)
    assert set_[2].strategy.rho == 0.9  # type: ignore[attr-defined]
    paper = build_channels(robust.with_kind("vb"), sensors)
    assert [c.strategy.rho for c in paper] == [0.99, 0.99, 0.99]  # type: ignore[attr-defined]
    with pytest.raises(pydantic.ValidationError, match="robust_gnss_rho"):
        FilterSettings(robust_gnss_rho=1.5)
