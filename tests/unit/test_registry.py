"""The sensor registry (sensors/kind.py, sensors/registry.py): each kind declared once, and the
mission format, the loader, the compiled epoch and the simulator all read it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from adaptnav.compiled import update as uk
from adaptnav.core import attitude
from adaptnav.core.units import G0, Kind
from adaptnav.mission import MissionError, build_sensor_model, load_mission, parse_config
from adaptnav.mission import write_mission as write_mission_folder
from adaptnav.sensors import Depth, PendulumInclinometer, depth
from adaptnav.sensors.kind import (
    N_PAR,
    IdealInput,
    SensorKind,
    SensorSetup,
    StuckDefault,
    pack_params,
)
from adaptnav.sensors.registry import KINDS, LINEARISED
from adaptnav.sim import kinematics, scenarios
from adaptnav.sim import trajectory as tr
from adaptnav.sim.sensors import GenericSpec
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


def _true_motion(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n true states (biases zero) of random attitude and velocity, body rates and specific
    forces near -g along z."""
    rng = np.random.default_rng(4)
    x = np.zeros((n, 16))
    x[:, 0], x[:, 1], x[:, 2] = 0.5, 1.0, rng.uniform(-50.0, 0.0, n)
    x[:, 3:6] = rng.normal(0.0, 2.0, (n, 3))
    for i in range(n):
        roll, pitch = rng.uniform(-0.3, 0.3, 2)
        x[i, 6:10] = attitude.euler_to_quat(roll, pitch, rng.uniform(-3.0, 3.0))
    f_b = rng.normal(0.0, 0.5, (n, 3)) + np.array([0.0, 0.0, -G0])
    return x, rng.normal(0.0, 0.05, (n, 3)), f_b


SIMULATED = [(k, None) for k in sorted(KINDS) if k != "nhc"] + [("inclinometer", "attitude")]


@pytest.mark.parametrize(("name", "model"), SIMULATED)
def test_a_kind_ideal_reading_is_what_its_model_predicts(name: str, model: str | None) -> None:
    kind = KINDS[name]
    assert kind.ideal_reading is not None
    x, w, f = _true_motion(6)
    l_b, C_sb = np.array([0.8, -0.3, 1.2]), attitude.euler_to_dcm(0.02, -0.01, 0.05).T
    setup = SensorSetup(name, 0.1, l_b, C_sb, use_height=True, model=model)
    sensor = kind.build(setup)
    z = kind.ideal_reading(IdealInput(x, w, f, l_b, C_sb, model))
    assert z.shape == (6, len(kind.columns))
    for i in range(6):
        extra = {"f_ib_b": f[i]} if isinstance(sensor, PendulumInclinometer) else {}
        meas = sensor.evaluate(x[i], z[i], w[i], **extra)
        assert meas is not None
        np.testing.assert_allclose(meas.y, 0.0, atol=1e-9)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        (GenericSpec("nhc", 1.0, 0.1), "'nhc' declares no ideal_reading"),
        (GenericSpec("gnss", 1.0, 2.0), r"columns \('lat_rad', 'lon_rad'\) are not all in m"),
        (GenericSpec("depth", 1.0, 0.1), r"extra sensors \['depth'\]: each needs a name"),
    ],
    ids=["no ideal reading", "columns not in the unit of sigma", "a taken name"],
)
def test_what_the_generic_simulation_cannot_make_is_refused(
    spec: GenericSpec, message: str
) -> None:
    assert KINDS["nhc"].ideal_reading is None
    sc = dataclasses.replace(scenarios.demo(), extra_sensors=(spec,))
    with pytest.raises(ValueError, match=message):
        scenarios.sensor_tables(sc, tr.build(sc.trajectory), 1)


def test_linearisation_codes_are_unique_and_packed() -> None:
    codes = [cls.LIN_CODE for cls in LINEARISED]  # type: ignore[attr-defined]
    assert len(set(codes)) == len(codes) and uk.LIN_PYTHON not in codes
    spec = uk.compiled_linearisation(Depth(0.1, (1.0, 2.0, 3.0)))
    assert spec is not None and spec[0] == uk.LIN_DEPTH == Depth.LIN_CODE
    assert spec[1].tolist() == pack_params((1.0, 2.0, 3.0)).tolist()


def test_a_new_kind_is_its_declaration_and_one_registry_entry(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
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
        ideal_reading=depth.ideal,
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
    _simulate_the_altimeter(tmp_path)


def _simulate_the_altimeter(tmp_path: Path) -> None:
    """The simulator makes the registered altimeter from its declaration alone (its
    ``ideal_reading`` plus white noise), writes it into the mission, and the loader reads it;
    the other sensors' tables are those of the scenario without it."""
    spec = GenericSpec("altimeter", 2.0, 0.05, lever_arm=(0.0, 0.0, 1.0), name="alt")
    sc = dataclasses.replace(scenarios.demo(), extra_sensors=(spec,))
    sim = scenarios.generate(sc, 3)
    write_mission_folder(tmp_path, sim.config, sim.tables)
    m = load_mission(tmp_path)
    section = m.config.sensors["alt"]
    assert section.kind == "altimeter" and section.use == "aid"
    assert section.sigma_si() == pytest.approx(0.05) and section.rate_hz == 2.0
    table = m.tables["alt"]
    assert len(table) == pytest.approx(sim.trajectory.duration * 2.0, abs=2)
    err = table.depth_m - table.true_depth_m
    assert abs(err.mean()) < 0.01 and err.std() == pytest.approx(0.05, rel=0.1)
    x = kinematics.true_states(sim.trajectory.motion, table.t_s.to_numpy())
    expected = [Depth(0.05, np.array([0.0, 0.0, 1.0])).predict(xi)[0] for xi in x]
    np.testing.assert_allclose(table.true_depth_m, expected, rtol=0.0, atol=1e-12)
    alone, _ = scenarios.sensor_tables(scenarios.demo(), sim.trajectory, 3)
    for name, df in alone.items():
        assert df.equals(sim.tables[name]), name


def test_options_belong_to_their_kinds() -> None:
    d = config_dict()
    d["sensors"]["dvl"]["use_height"] = True
    with pytest.raises(MissionError, match="use_height: only for gnss sensors, not a dvl"):
        parse_config(d)
    params = KINDS["dvl"].build(SensorSetup("dvl", 0.01, np.ones(3), np.eye(3)))
    assert params.lin_params().shape == (N_PAR,)  # type: ignore[attr-defined]
