"""The sensor registry (sensors/kind.py, sensors/registry.py): each kind declared once, and the
mission format, the loader and the compiled epoch all read it."""

from __future__ import annotations

import numpy as np
import pytest

from adaptnav.compiled import update as uk
from adaptnav.core.units import Kind
from adaptnav.mission import MissionError, build_sensor_model, parse_config
from adaptnav.sensors import Depth
from adaptnav.sensors.kind import N_PAR, SensorKind, SensorSetup, StuckDefault, pack_params
from adaptnav.sensors.registry import KINDS, LINEARISED
from helpers.missions import config_dict


@pytest.mark.parametrize("name", sorted(KINDS))
def test_a_kind_declares_every_column_once(name: str) -> None:
    kind = KINDS[name]
    assert kind.name == name
    assert set(kind.limits) == set(kind.columns) == set(kind.stuck.resolution)
    for lo, hi in kind.limits.values():
        assert lo < hi
    assert kind.dims()[-1] == len(kind.columns)


@pytest.mark.parametrize("name", sorted(KINDS))
def test_a_kind_builds_its_model(name: str) -> None:
    kind = KINDS[name]
    use_height = bool(kind.optional_columns)
    setup = SensorSetup(name, 0.5, np.full(3, 0.1), np.eye(3), use_height=use_height)
    model = kind.build(setup)
    assert model.name == name and model.dim == kind.dim(use_height)
    assert type(model) in kind.linearised  # every mission kind runs compiled


def test_linearisation_codes_are_unique_and_packed() -> None:
    codes = [cls.LIN_CODE for cls in LINEARISED]  # type: ignore[attr-defined]
    assert len(set(codes)) == len(codes) and uk.LIN_PYTHON not in codes
    spec = uk.compiled_linearisation(Depth(0.1, (1.0, 2.0, 3.0)))
    assert spec is not None and spec[0] == uk.LIN_DEPTH == Depth.LIN_CODE
    assert spec[1].tolist() == pack_params((1.0, 2.0, 3.0)).tolist()


def test_a_new_kind_is_its_declaration_and_one_registry_entry(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A bathymetric altimeter as a second depth-like kind: nothing else is edited.
    altimeter = SensorKind(
        name="altimeter",
        columns=("depth_m",),
        sigma_kind=Kind.LENGTH,
        build=lambda s: Depth(float(np.asarray(s.sigma).reshape(-1)[0]), s.l_b, s.name),
        limits={"depth_m": (-100.0, 12000.0)},
        stuck=StuckDefault(0.0, {"depth_m": 1e-3}),
        lever_arm=True,
    )
    section = {"kind": "altimeter", "file": "a.csv", "sigma": [5, "cm"], "lever_arm_m": [0, 0, 1]}
    with pytest.raises(MissionError, match="'altimeter' is not a sensor kind"):
        parse_config(config_dict(sensors={"alt": section}))
    monkeypatch.setitem(KINDS, "altimeter", altimeter)
    cfg = parse_config(config_dict(sensors={"alt": section}))
    model = build_sensor_model("alt", cfg.sensors["alt"])
    assert isinstance(model, Depth) and model.sigma == pytest.approx(0.05)
    assert cfg.sensors["alt"].columns == ("depth_m",)
    assert cfg.sensors["alt"].limits_si().tolist() == [[-100.0, 12000.0]]


def test_options_belong_to_their_kinds() -> None:
    d = config_dict()
    d["sensors"]["dvl"]["use_height"] = True
    with pytest.raises(MissionError, match="use_height: only for gnss sensors, not a dvl"):
        parse_config(d)
    params = KINDS["dvl"].build(SensorSetup("dvl", 0.01, np.ones(3), np.eye(3)))
    assert params.lin_params().shape == (N_PAR,)  # type: ignore[attr-defined]
