"""Mission input format (adaptnav.mission): round trips, conversions and every bad-input case."""

from __future__ import annotations

import logging
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from adaptnav import api
from adaptnav.core.attitude import euler_to_dcm
from adaptnav.core.units import DEG, G0, UnitError
from adaptnav.mission import (
    Mission,
    MissionConfig,
    MissionError,
    build_sensor_model,
    load_config,
    load_mission,
    parse_config,
    write_mission,
)
from adaptnav.sensors import DVL, GNSS, Depth, Heading, Inclinometer, PendulumInclinometer
from helpers import DATA as TEST_DATA
from helpers import REPO
from helpers.missions import T, config_dict, csv_text, dvl_table, imu_rates, write_dir

DATA = TEST_DATA / "io"


# --- builders (mission folders: helpers.missions) -------------------------------------------------


def load_error(root: Path) -> str:
    with pytest.raises(MissionError) as info:
        load_mission(root)
    return str(info.value)


# --- configuration ------------------------------------------------------------------------------


def test_example_config_round_trips() -> None:
    cfg = load_config(DATA / "mission.toml")
    assert cfg.mission.name == "paper-1"
    assert cfg.sensors["gnss"].use == "init" and cfg.sensors["gnss"].dim == 2
    assert math.isinf(cfg.imu.noise.to_imu_noise().accel_bias_tau)
    assert cfg.imu.noise.to_imu_noise().arw == pytest.approx(0.0667 * DEG / 60.0)
    again = parse_config(tomllib.loads(cfg.dump_toml()))
    assert again == cfg
    # imu.restamp (since 0.4.9) is on unless set, and not written: 0.4.8 reads the file
    assert cfg.imu.restamp is None and cfg.imu.restamp_jitter
    assert "restamp" not in cfg.dump_toml()
    settings = cfg.filter_settings()
    assert settings.gate_sensors == ("dvl",) and settings.gate_q["maeskf"] == 1800.0
    assert cfg.output_every() == 10


def test_initial_bias_starts_a_state_mode_mission(tmp_path: Path) -> None:
    d = config_dict()
    d["initial"] = {"mode": "state", "lat_deg": 10.0, "lon_deg": 20.0, "rpy_deg": [0, 0, 30]}
    d["imu"]["initial_bias"] = {"gyro": [[0.1, -0.2, 0.3], "deg/s"], "accel": [[1, 2, 3], "mg"]}
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), "dvl.csv": dvl_table()})
    x0, _, _, _ = api.initial_state(load_mission(root))
    np.testing.assert_allclose(x0[13:16], np.radians([0.1, -0.2, 0.3]))
    np.testing.assert_allclose(x0[10:13], 1e-3 * G0 * np.array([1.0, 2.0, 3.0]))
    d["imu"]["initial_bias"] = {"gyro": [[0.1, 0.2], "deg/s"]}
    assert "three values" in str(_config_error(lambda c: c.update(d)))
    d["imu"]["initial_bias"] = {"gyro": [[0.1, 0.2, 0.3], "deg/s"]}
    d["initial"] = {"mode": "alignment", "lat_deg": 10.0, "lon_deg": 20.0}
    assert "mode = 'state' only" in str(_config_error(lambda c: c.update(d)))


def test_gate_reference_reaches_every_gate() -> None:
    d = config_dict()
    d["filter"] = {"kind": "vb", "gate_q": {"vb": 2600.0}, "gate_reference": "nominal"}
    settings = parse_config(d).filter_settings()
    gate = settings.gate("dvl", is_dvl=True)
    assert gate is not None and gate.q == 2600.0 and gate.reference == "nominal"


def test_a_partial_gate_q_keeps_the_other_kinds_defaults() -> None:
    """``gate_q = {meskf = 300}`` sets MESKF's q and leaves MAESKF its default 1800, as a
    partial ``r_bounds`` does (up to 0.4.8 the table replaced the defaults and MAESKF ran
    ungated); ``maeskf = 0`` is how a kind runs ungated; vb has no default gate."""
    d = config_dict()
    d["filter"] = {"gate_q": {"meskf": 300.0}}
    settings = parse_config(d).filter_settings()

    def q(kind: str) -> float | None:
        gate = settings.with_kind(kind).gate("dvl", is_dvl=True)  # type: ignore[arg-type]
        return None if gate is None else gate.q

    assert (q("meskf"), q("maeskf"), q("vb")) == (300.0, 1800.0, None)
    d["filter"] = {"gate_q": {"maeskf": 0.0}}
    settings = parse_config(d).filter_settings()
    assert (q("meskf"), q("maeskf")) == (600.0, None)
    assert settings.with_kind("maeskf").updated(vb_rho=0.9).kind_gate_q() is None  # stays off


def test_docs_example_is_valid() -> None:
    text = (REPO / "docs" / "data-format.md").read_text()
    block = text.split("```toml\n", 1)[1].split("```", 1)[0]
    cfg = parse_config(tomllib.loads(block))
    assert cfg.mission.name == "paper-1" and cfg.gated_sensors() == ("dvl",)
    assert parse_config(tomllib.loads(cfg.dump_toml())) == cfg


def test_defaults_of_a_minimal_config() -> None:
    cfg = parse_config(config_dict())
    assert cfg.imu.format == "rates" and cfg.imu.gap_limit_s == pytest.approx(0.05)
    assert cfg.filter.kind == "robust" and cfg.initial.mode == "alignment"
    assert cfg.gated_sensors() == ("dvl",)
    assert cfg.filter_settings().gate_reference == "adapted"  # the paper's gate
    assert cfg.truth.file is None
    noise = cfg.imu.noise.to_imu_noise()
    g, a = cfg.imu.initial_bias_sigma.si(noise)
    assert g == pytest.approx(10 * DEG / 3600) and a == pytest.approx(1e-3 * G0)
    assert parse_config(tomllib.loads(cfg.dump_toml())) == cfg


def _config_error(mutate: Any) -> MissionError:
    d = config_dict()
    mutate(d)
    with pytest.raises(MissionError) as info:
        parse_config(d)
    return info.value


@pytest.mark.parametrize(
    ("mutate", "path", "words"),
    [
        (lambda d: d["imu"].update(rte_hz=1.0), "imu.rte_hz", "unknown key"),
        (lambda d: d["sensors"]["dvl"].update(gateq=1.0), "sensors.dvl.gateq", "unknown key"),
        (lambda d: d.update(extra={"a": 1}), "extra", "unknown key"),
        (lambda d: d["imu"].update(rate_hz=0.0), "imu.rate_hz", "greater than 0 (got 0.0)"),
        (lambda d: d["imu"].update(rate_hz=math.nan), "imu.rate_hz", "finite"),
        (lambda d: d["imu"].update(rate_hz=1e300), "imu.rate_hz", "less than or equal to 100000"),
        (lambda d: d["sensors"]["dvl"].update(rate_hz=1e6), "sensors.dvl.rate_hz", "100000"),
        (lambda d: d["sensors"]["dvl"].update(sigma=[-0.02, "m/s"]), "sensors.dvl.sigma", "-0.02"),
        (lambda d: d["sensors"]["dvl"].update(sigma=[math.nan, "m/s"]), "sensors.dvl.sigma", "nan"),
        (lambda d: d["sensors"]["dvl"].update(kind="usbl"), "sensors.dvl.kind", "'usbl'"),
        (lambda d: d["sensors"]["dvl"].pop("file"), "sensors.dvl.file", "missing required"),
        (lambda d: d["mission"].pop("name"), "mission.name", "missing required"),
        (lambda d: d["imu"]["noise"].pop("vrw"), "imu.noise.vrw", "missing required"),
        (lambda d: d["imu"].update(file="imu.txt"), "imu.file", "unknown table format"),
        (lambda d: d.update(filter={"gate_q": {"ekf": 1.0}}), "filter.gate_q.ekf", "(got 'ekf')"),
        (lambda d: d.update(filter={"gate_sensors": ["dv"]}), "filter.gate_sensors", "'dv'"),
        (lambda d: d.update(filter={"gate_reference": "R"}), "filter.gate_reference", "'R'"),
        (lambda d: d["sensors"]["dvl"].update(use_height=True), "sensors.dvl.use_height", "gnss"),
        (lambda d: d["sensors"]["dvl"].update(optional="yes"), "sensors.dvl.optional", "bool"),
        (lambda d: d["sensors"].update(imu=d["sensors"]["dvl"]), "sensors", "reserved"),
        (lambda d: d["initial"].pop("lat_deg"), "initial.lat_deg", "required for alignment"),
        (lambda d: d["initial"].update(lat_deg=95.0), "initial.lat_deg", "95"),
        (
            lambda d: d["sensors"].update(d={"kind": "depth", "file": "d.csv", "sigma": [1, "m"],
                                             "mounting_rpy_deg": [0, 0, 1]}),
            "sensors.d.mounting_rpy_deg",
            "no mounting rotation",
        ),
        (
            lambda d: d.update(initial={"mode": "state", "lat_deg": 1.0, "lon_deg": 2.0}),
            "initial.rpy_deg",
            "required when mode = 'state'",
        ),
        (
            lambda d: d["sensors"].update(g={"kind": "gnss", "file": "g.csv",
                                             "sigma": [[1, 1, 2], "m"]}),
            "sensors.g.sigma",
            "use_height = false has 2 components",
        ),
    ],
)  # fmt: skip
def test_config_errors_name_the_key(mutate: Any, path: str, words: str) -> None:
    err = _config_error(mutate)
    assert f"{path}: " in str(err) and words in str(err), str(err)
    assert str(err).startswith("mission.toml: ")


def _dvl(**extra: Any) -> dict[str, Any]:
    return {"kind": "dvl", "file": "dvl.csv", "sigma": [0.02, "m/s"], **extra}


@pytest.mark.parametrize(
    ("mutate", "path", "words"),
    [
        (lambda d: d["sensors"].update(dvl2=_dvl()), "sensors.dvl2",
         "reads dvl.csv as sensors.dvl does, both dvl"),
        (lambda d: d["sensors"]["dvl"].update(use="init"), "sensors.dvl.use",
         "'init' is for a GNSS"),
        (lambda d: d["sensors"]["dvl"].update(matching_window=10**9), "sensors.dvl.matching_window",
         "less than or equal to 100000"),
        (lambda d: d.update(filter={"matching_window": 10**9}), "filter.matching_window",
         "less than or equal to 100000"),
        (lambda d: d.update(filter={"specific_force_tau_s": math.inf}),
         "filter.specific_force_tau_s", "finite"),
        (lambda d: d.update(filter={"r_bounds": {"meskf": [50, 100]}}), "filter.r_bounds.meskf",
         "its R is fixed"),
        (lambda d: d.update(filter={"vb_iterations": 10**8}), "filter.vb_iterations",
         "less than or equal to 1000"),
        (lambda d: d.update(filter={"vb_tol": 1e-300}), "filter.vb_tol", "greater than or equal"),
        (lambda d: d["initial"].update(v_ned_m_s=[1000.0, 0, 0]), "initial.v_ned_m_s",
         "with mode = 'alignment', which starts at rest"),
        (lambda d: d.update(filter={"output_rate_hz": 0.01}), "filter.output_rate_hz",
         "between 1 Hz and the IMU's"),
        (lambda d: d.update(filter={"output_rate_hz": 1000.0}), "filter.output_rate_hz",
         "between 1 Hz and the IMU's"),
        (lambda d: d.update(filter={"output_rate_hz": 40.0}), "filter.output_rate_hz",
         "40 Hz is not the IMU's 100 Hz over a whole number of intervals"),
        (lambda d: (d["sensors"].update(g={"kind": "gnss", "file": "g.csv", "sigma": [3, "m"],
                                           "use": "init"}),
                    d["initial"].update(mode="state", rpy_deg=[0, 0, 0])),
         "sensors.g.use", "'init' with initial.mode = 'state'"),
        (lambda d: d["initial"].update(mode="state", rpy_deg=[0, 0, 0], alignment_s=300.0),
         "initial.alignment_s", "with mode = 'state', which starts from the given state"),
        (lambda d: d["sensors"].update(g={"kind": "gnss", "file": "g.csv", "sigma": [3, "m"],
                                          "use": "init", "estimate": ["bias"]}),
         "sensors.g.estimate", "on a sensor with use = 'init'"),
        (lambda d: d["sensors"]["dvl"].update(
            estimate=["misalignment"], calibration={"misalignment": {"sigma": [1000, "deg"]}}),
         "sensors.dvl.calibration.misalignment.sigma", "the largest prior σ"),
        (lambda d: d["sensors"]["dvl"].update(
            estimate=["scale"], calibration={"scale": {"sigma": [-1, "%"]}}),
         "sensors.dvl.calibration.scale.sigma", "negative"),
        (lambda d: d["sensors"]["dvl"].update(mounting_rpy_deg=[0, 0, 1e300]),
         "sensors.dvl.mounting_rpy_deg", "outside roll and yaw ±360°, pitch ±90°"),
        (lambda d: d["initial"].update(rpy_deg=[0, 100, 0]), "initial.rpy_deg",
         "outside roll and yaw ±360°, pitch ±90°"),
        (lambda d: d["sensors"]["dvl"].update(
            estimate=["scale"], calibration={"scale": {"random_walk": [1e9, "1/sqrt(s)"]}}),
         "sensors.dvl.calibration.scale.random_walk", "plausible"),
    ],
)  # fmt: skip
def test_settings_that_cannot_be_meant_are_refused(mutate: Any, path: str, words: str) -> None:
    """Found by a search of odd settings (2026-12-04): each ran before, to a wrong answer with
    exit 0 (a DVL twice in one file counted each reading twice; 'init' on a DVL used it for
    nothing; a random walk of 1e9 /√s ended 1400 km off; a pitch of 100° or a mounting yaw of
    1e300 ran far off), or to a MemoryError traceback (a matching window of 1e9)."""
    err = _config_error(mutate)
    assert f"{path}: " in str(err) and words in str(err), str(err)
    assert str(err).startswith("mission.toml: ")
    d = config_dict()
    d["sensors"]["dvl2"] = _dvl(use="off")  # a second section on the file, left aside: fine
    d["initial"]["rpy_deg"] = [-180.0, 90.0, 359.0]
    assert parse_config(d).sensors["dvl2"].use == "off"


PLAUSIBLE = "is not a plausible standard deviation"


@pytest.mark.parametrize(
    ("mutate", "path", "words"),
    [
        (lambda d: d["imu"]["noise"].update(arw=[1e300, "deg/sqrt(h)"]), "imu.noise.arw",
         PLAUSIBLE),
        (lambda d: d["imu"]["noise"].update(vrw=[1e-300, "ug/sqrt(Hz)"]), "imu.noise.vrw",
         PLAUSIBLE),
        (lambda d: d["imu"]["noise"].update(gyro_bias_sigma=[1e300, "deg/h"]),
         "imu.noise.gyro_bias_sigma", PLAUSIBLE),
        (lambda d: d["imu"].update(initial_bias_sigma={"gyro": [1e300, "deg/h"]}),
         "imu.initial_bias_sigma.gyro", PLAUSIBLE),
        (lambda d: d["sensors"]["dvl"].update(sigma=[1e-300, "m/s"]), "sensors.dvl.sigma",
         PLAUSIBLE),
        (lambda d: d["sensors"]["dvl"].update(sigma=[[0.01, 0.01, 1e9], "m/s"]),
         "sensors.dvl.sigma", "1e+09 m/s"),
        (lambda d: d["initial"].update(h_m=1e300), "initial.h_m", "less than or equal to 100000"),
        (lambda d: d["initial"].update(h_m=-2e4), "initial.h_m", "greater than or equal to -12000"),
        (lambda d: d["initial"].update(sigma_position_m=1e300), "initial.sigma_position_m",
         "less than or equal to 10000000"),
        (lambda d: d["initial"].update(sigma_velocity_m_s=1e-300), "initial.sigma_velocity_m_s",
         "(got 1e-300)"),
        (lambda d: d["initial"].update(sigma_attitude_deg=500.0), "initial.sigma_attitude_deg",
         "180"),
        (lambda d: d["sensors"]["dvl"].update(latency_s=1000.0), "sensors.dvl.latency_s",
         "less than or equal to 60"),
        (lambda d: d["sensors"]["dvl"].update(latency_s=float("nan")), "sensors.dvl.latency_s",
         "finite"),
    ],
)  # fmt: skip
def test_absurd_sigmas_and_heights_are_errors_naming_the_key(
    mutate: Any, path: str, words: str
) -> None:
    """Values whose squares overflow or underflow (up to 0.3.5 an OverflowError or a
    ZeroDivisionError deep in the run, exit 1) or beyond any real sensor or prior."""
    err = _config_error(mutate)
    assert f"{path}: " in str(err) and words in str(err), str(err)


def test_tiny_bias_terms_are_fine() -> None:
    """A navigation-grade rate random walk is ~1e-13 rad/s/√s: no lower bound on bias terms."""
    d = config_dict()
    d["imu"]["noise"].update(gyro_bias_rrw=[1e-6, "deg/h/sqrt(h)"], gyro_bias_sigma=[0, "deg/h"])
    parse_config(d)


@pytest.mark.parametrize(
    ("mutate", "path"),
    [
        (lambda d: d["imu"]["noise"].update(arw=[0.1, "deg/h"]), "imu.noise.arw"),
        (lambda d: d["sensors"]["dvl"].update(sigma=[0.02, "m"]), "sensors.dvl.sigma"),
        (lambda d: d["imu"]["noise"].update(gyro_bias_tau=[1, "deg"]), "imu.noise.gyro_bias_tau"),
        (
            lambda d: d["imu"].update(initial_bias_sigma={"accel": [1, "deg/h"]}),
            "imu.initial_bias_sigma.accel",
        ),
    ],
)
def test_wrong_units_are_unit_errors(mutate: Any, path: str) -> None:
    err = _config_error(mutate)
    assert isinstance(err, UnitError)
    assert f"{path}: unknown unit" in str(err)
    assert err.field == path


def test_load_config_file_errors(tmp_path: Path) -> None:
    with pytest.raises(MissionError, match="file not found"):
        load_config(tmp_path / "mission.toml")
    (tmp_path / "mission.toml").write_text("[mission]\nname = 'x'\n[imu\n")
    with pytest.raises(MissionError, match=r"mission.toml: invalid TOML.*line 3"):
        load_config(tmp_path / "mission.toml")
    (tmp_path / "mission.toml").write_text("[mission]\nname = 'x'\n")
    with pytest.raises(MissionError, match=r"imu: missing required key"):
        load_config(tmp_path / "mission.toml")


def test_taus_accept_inf() -> None:
    d = config_dict()
    d["imu"]["noise"].update(gyro_bias_tau=["inf", "s"], accel_bias_tau=[math.inf, "h"])
    noise = parse_config(d).imu.noise.to_imu_noise()
    assert math.isinf(noise.gyro_bias_tau) and math.isinf(noise.accel_bias_tau)


# --- sensor models ------------------------------------------------------------------------------


def test_build_sensor_models() -> None:
    d = config_dict()
    d["sensors"] = {
        "dvl": {
            "kind": "dvl",
            "file": "dvl.csv",
            "sigma": [[2, 2, 3], "cm/s"],
            "lever_arm_m": [1.0, 0.5, 0.2],
            "mounting_rpy_deg": [10.0, -5.0, 45.0],
        },
        "dep": {"kind": "depth", "file": "d.csv", "sigma": [5, "cm"], "lever_arm_m": [0, 0, 1]},
        "inc": {"kind": "inclinometer", "file": "i.csv", "sigma": [0.05, "deg"]},
        "att": {
            "kind": "inclinometer",
            "file": "a.csv",
            "sigma": [0.05, "deg"],
            "model": "attitude",
        },
        "hdg": {"kind": "heading", "file": "h.csv", "sigma": [0.5, "deg"]},
        "gps": {"kind": "gnss", "file": "g.csv", "sigma": [[2, 3, 5], "m"], "use_height": True},
    }
    cfg = parse_config(d)
    dvl = build_sensor_model("dvl", cfg.sensors["dvl"])
    assert isinstance(dvl, DVL) and dvl.name == "dvl"
    np.testing.assert_allclose(dvl.sigma, [0.02, 0.02, 0.03])
    np.testing.assert_allclose(dvl.l_b, [1.0, 0.5, 0.2])
    C_bs = euler_to_dcm(10 * DEG, -5 * DEG, 45 * DEG)
    np.testing.assert_allclose(dvl.C_sb, C_bs.T)
    # a vector along the DVL's x axis is C_bs[:, 0] in body axes and reads back as x
    np.testing.assert_allclose(dvl.C_sb @ C_bs[:, 0], [1.0, 0.0, 0.0], atol=1e-15)
    dep = build_sensor_model("dep", cfg.sensors["dep"])
    assert isinstance(dep, Depth) and dep.sigma == pytest.approx(0.05)
    inc = build_sensor_model("inc", cfg.sensors["inc"])
    assert isinstance(inc, PendulumInclinometer)  # the default: it reads the apparent vertical
    np.testing.assert_allclose(inc.sigma, [0.05 * DEG] * 2)
    att = build_sensor_model("att", cfg.sensors["att"])
    assert isinstance(att, Inclinometer)
    np.testing.assert_allclose(att.sigma, [0.05 * DEG] * 2)
    with pytest.raises(MissionError, match="model"):
        parse_config({**d, "sensors": {"x": {**d["sensors"]["dep"], "model": "pendulum"}}})
    hdg = build_sensor_model("hdg", cfg.sensors["hdg"])
    assert isinstance(hdg, Heading) and hdg.sigma == pytest.approx(0.5 * DEG)
    gps = build_sensor_model("gps", cfg.sensors["gps"])
    assert isinstance(gps, GNSS) and gps.dim == 3
    np.testing.assert_allclose(gps.sigma, [2.0, 3.0, 5.0])


# --- round trips and conversions ----------------------------------------------------------------


def _full_mission() -> tuple[dict[str, Any], dict[str, pd.DataFrame]]:
    d = config_dict(truth={"file": "truth.parquet"})
    d["sensors"] = {
        "dvl": {"kind": "dvl", "file": "dvl.parquet", "sigma": [0.02, "m/s"]},
        "depth": {"kind": "depth", "file": "depth.parquet", "sigma": [0.1, "m"]},
        "incl": {"kind": "inclinometer", "file": "incl.parquet", "sigma": [0.1, "deg"]},
        "hdg": {"kind": "heading", "file": "hdg.parquet", "sigma": [1, "deg"]},
        "gnss": {"kind": "gnss", "file": "gnss.parquet", "sigma": [3, "m"], "use": "init"},
    }
    rng = np.random.default_rng(1)
    t = 10.0 + np.arange(6) * 0.123456789
    dvl = dvl_table()
    dvl["is_outlier"] = [False, True, False, False, False]
    tables = {
        "imu": imu_rates(),
        "dvl": dvl,
        "depth": pd.DataFrame({"t_s": t, "depth_m": rng.normal(5, 1, 6)}),
        "incl": pd.DataFrame({"t_s": t, "roll_rad": rng.normal(0, 0.1, 6), "pitch_rad": 0.01}),
        "hdg": pd.DataFrame({"t_s": t, "yaw_rad": rng.uniform(-3, 3, 6)}),
        "gnss": pd.DataFrame(
            {"t_s": t, "lat_rad": 0.46 + 1e-7 * t, "lon_rad": 0.97, "h_m": rng.normal(0, 1, 6)}
        ),
        "truth": pd.DataFrame(
            {
                "t_s": t,
                **{c: rng.normal(size=6) for c in ("lat_rad", "lon_rad", "h_m", "vn_m_s")},
                **{c: rng.normal(size=6) for c in ("ve_m_s", "vd_m_s", "roll_rad", "pitch_rad")},
                "yaw_rad": rng.normal(size=6),
                "sigma_dvl_m_s": 0.02,
            }
        ),
    }
    truth = tables["truth"]
    truth["lat_rad"] = 0.46 + 0.01 * truth["lat_rad"]  # a latitude (|lat| <= pi/2 is checked)
    truth["pitch_rad"] *= 0.1  # a pitch (|pitch| <= pi/2 is checked)
    return d, tables


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_write_then_load_round_trip(tmp_path: Path, fmt: str) -> None:
    d, tables = _full_mission()
    written = write_mission(tmp_path, parse_config(d), tables, fmt=fmt)  # type: ignore[arg-type]
    assert written.imu.file == f"imu.{fmt}" and (tmp_path / f"dvl.{fmt}").is_file()
    m = load_mission(tmp_path)
    assert m.config == written and m.repairs == () and m.dropped == ()
    imu = tables["imu"]
    t = imu["t_s"].to_numpy()
    np.testing.assert_array_equal(m.imu.t, t[1:])
    np.testing.assert_array_equal(m.imu.dt, np.diff(t))
    for name, cols in [
        ("dvl", ["vx_m_s", "vy_m_s", "vz_m_s"]),
        ("depth", ["depth_m"]),
        ("incl", ["roll_rad", "pitch_rad"]),
        ("hdg", ["yaw_rad"]),
        ("gnss", ["lat_rad", "lon_rad"]),
    ]:
        s = m.sensors[name]
        np.testing.assert_array_equal(s.t, tables[name]["t_s"].to_numpy())
        np.testing.assert_array_equal(s.z, tables[name][cols].to_numpy())
        np.testing.assert_array_equal(s.rows, np.arange(len(tables[name])))
    assert m.sensors["gnss"].kind == "gnss" and m.sensors["gnss"].z.shape == (6, 2)
    assert m.sensors["dvl"].period == pytest.approx(1 / 3)  # median interval (no rate_hz)
    assert list(m.readings()) == ["dvl", "depth", "incl", "hdg"]  # gnss is use = "init"
    assert m.truth is not None
    pd.testing.assert_frame_equal(m.truth, tables["truth"], check_dtype=False)
    assert list(m.tables["dvl"]["is_outlier"]) == [False, True, False, False, False]


def test_truth_velocity_and_attitude_are_optional_groups(tmp_path: Path) -> None:
    d, tables = _full_mission()
    truth = tables["truth"].drop(columns=["roll_rad", "pitch_rad", "yaw_rad"])
    write_mission(tmp_path, parse_config(d), {**tables, "truth": truth})
    m = load_mission(tmp_path)
    assert m.truth is not None and "yaw_rad" not in m.truth.columns
    np.testing.assert_array_equal(m.truth["vn_m_s"], truth["vn_m_s"])
    partial = truth.drop(columns=["vd_m_s"])
    partial.to_parquet(tmp_path / "truth.parquet", index=False)
    err = load_error(tmp_path)
    assert "truth.parquet (truth)" in err and "['vd_m_s']" in err and "or none" in err


def test_rates_are_integrated_by_the_cubic_through_four_samples(tmp_path: Path) -> None:
    # Since 0.4.10 each interval is the integral of the cubic through the samples about it
    # (the quadratic through three at the ends); up to 0.4.9 the trapezoid, off by -(h³/12) ω̈.
    imu = imu_rates(n=11)
    imu.loc[5:, "t_s"] += 0.004  # one interval of 1.4 periods: the weights of an irregular grid
    t = imu["t_s"].to_numpy()
    s = t - t[0]
    imu["gyro_x_rad_s"] = 0.1 + 2.0 * s - 30.0 * s**2  # every interval exact, the ends' too
    imu["gyro_y_rad_s"] = 5e3 * s**3  # exact but at the ends
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    m = load_mission(root)
    assert len(m.imu) == 10 and m.imu.start == t[0]
    np.testing.assert_allclose(m.imu.dt, np.diff(t), rtol=0, atol=0)
    quadratic = np.diff(0.1 * s + s**2 - 10.0 * s**3)
    np.testing.assert_allclose(m.imu.dtheta[:, 0], quadratic, rtol=1e-12)
    cubic = np.diff(1.25e3 * s**4)
    np.testing.assert_allclose(m.imu.dtheta[1:-1, 1], cubic[1:-1], rtol=1e-11)
    assert abs(m.imu.dtheta[0, 1] / cubic[0] - 1.0) > 1e-3  # the ends' quadratic
    np.testing.assert_allclose(m.imu.dtheta[:, 2], 2e-3 * np.diff(t))
    np.testing.assert_allclose(m.imu.dvel[:, 2], -G0 * np.diff(t))


@pytest.mark.parametrize("lost", [[6], [6, 7]])
def test_rates_across_a_hole(tmp_path: Path, lost: list[int]) -> None:
    # One or two samples lost (an interval of 2 or 3 periods, over NEIGHBOUR_RATIO times its
    # neighbours'): no sample across the hole enters an integral, the hole itself by the
    # trapezoid (-(h³/12) ω̈ off, as up to 0.4.9), its neighbours by the quadratic (exact here).
    imu = imu_rates(n=12).drop(index=lost).reset_index(drop=True)
    t = imu["t_s"].to_numpy()
    s = t - t[0]
    imu["gyro_x_rad_s"] = 0.1 + 2.0 * s - 30.0 * s**2
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    m = load_mission(root)
    w = imu["gyro_x_rad_s"].to_numpy()
    exact = np.diff(0.1 * s + s**2 - 10.0 * s**3)
    h = t[6] - t[5]
    assert m.imu.dtheta[5, 0] == pytest.approx((w[5] + w[6]) / 2 * h, rel=1e-12)
    assert m.imu.dtheta[5, 0] == pytest.approx(exact[5] - 60.0 * h**3 / 12, rel=1e-12)
    np.testing.assert_allclose(np.delete(m.imu.dtheta[:, 0], 5), np.delete(exact, 5), rtol=1e-12)


def _increments(n: int = 8, t0: float = 10.0) -> pd.DataFrame:
    t = t0 + T * np.arange(n)  # from 10 s: dvl_table's first reading (10.05 s) falls inside
    return pd.DataFrame(
        {
            "t_s": t,
            "dtheta_x_rad": 1e-5,
            "dtheta_y_rad": 0.0,
            "dtheta_z_rad": 2e-5,
            "dvel_x_m_s": 1e-3,
            "dvel_y_m_s": 0.0,
            "dvel_z_m_s": -G0 * T,
        }
    )


def test_increments_format(tmp_path: Path) -> None:
    d = config_dict()
    d["imu"]["format"] = "increments"
    inc = _increments()
    root = write_dir(tmp_path, d, {"imu.csv": inc, "dvl.csv": dvl_table()})
    m = load_mission(root)
    np.testing.assert_array_equal(m.imu.t, inc["t_s"].to_numpy())
    assert m.imu.dt[0] == pytest.approx(T)  # the first interval gets 1/rate_hz
    np.testing.assert_allclose(m.imu.dt[1:], np.diff(inc["t_s"].to_numpy()))
    cols = ["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]
    np.testing.assert_array_equal(m.imu.dtheta, inc[cols].to_numpy())
    assert m.imu.dvel[0, 2] == -G0 * T


def test_increment_row_with_nan_is_dropped_and_next_interval_stretched(tmp_path: Path) -> None:
    d = config_dict()
    d["imu"]["format"] = "increments"
    inc = _increments()
    inc.loc[3, "dvel_y_m_s"] = np.nan
    root = write_dir(tmp_path, d, {"imu.csv": inc, "dvl.csv": dvl_table()})
    m = load_mission(root)
    assert len(m.imu) == 7
    assert m.imu.dt[3] == pytest.approx(2 * T)  # line 6 now covers (t_2, t_4]
    assert m.imu.dvel[3, 2] == pytest.approx(-2 * G0 * T)  # constant rate over the hole
    (r,) = m.repairs
    assert (r.file, r.line, r.field) == ("imu.csv", 5, "dvel_y_m_s")
    assert r.action == "dropped row with non-finite value"


def _noisy_increments(n: int = 80, seed: int = 7) -> pd.DataFrame:
    inc = _increments(n)
    rng = np.random.default_rng(seed)
    cols = [c for c in inc.columns if c != "t_s"]
    inc[cols] = inc[cols].to_numpy() + rng.normal(0.0, 1e-4 * T, (n, len(cols)))
    return inc


def _increments_mission(tmp_path: Path, inc: pd.DataFrame, **imu: Any) -> Path:
    """A mission of the increments table ``inc`` beside :func:`dvl_table`, with ``imu`` keys
    added to its ``[imu]``."""
    d = config_dict()
    d["imu"].update(format="increments", **imu)
    return write_dir(tmp_path, d, {"imu.csv": inc, "dvl.csv": dvl_table()})


def test_increments_after_lost_samples_are_stretched(tmp_path: Path) -> None:
    # Two samples lost (rows 40, 41): row 42's increments cover its own T, not the 3 T since
    # row 39. Up to 0.4.8 they were taken over 3 T (gravity integrated over 3 T against a
    # specific force of one: 0.2 m/s down), since 0.4.9 scaled by 3, as after a NaN row.
    inc = _noisy_increments()
    root = _increments_mission(tmp_path, inc.drop(index=[40, 41]))
    m = load_mission(root)
    assert len(m.imu) == 78
    assert m.imu.dt[40] == pytest.approx(3 * T)
    np.testing.assert_allclose(m.imu.dvel[40], 3 * inc.iloc[42, 4:].to_numpy(), rtol=1e-12)
    np.testing.assert_allclose(m.imu.dtheta[40], 3 * inc.iloc[42, 1:4].to_numpy(), rtol=1e-12)
    (r,) = m.repairs
    assert (r.file, r.line, r.field) == ("imu.csv", 42, "t_s")
    assert r.action == "stretched increments over lost samples"
    assert "about 2 sample(s) lost" in r.detail


def test_a_hole_beyond_the_default_gap_is_filled_with_the_trapezoid(tmp_path: Path) -> None:
    # Rows 30-39 lost (10 T, max_gap_s raised to 20 T): since 0.4.13 the 10 T are filled at
    # the mean of the rates of rows 29 and 40, the trapezoid of rates (row 40's own increments
    # plus 5 times rows 29's and 40's); up to 0.4.12 row 40's increments times 11 (its rate
    # over the whole hole). A hole within the default max_gap_s is stretched as before (the
    # tests above).
    inc = _noisy_increments()
    root = _increments_mission(tmp_path, inc.drop(index=range(30, 40)), max_gap_s=20 * T)
    m = load_mission(root)
    assert m.imu.dt[30] == pytest.approx(11 * T)
    for got, cols in ((m.imu.dvel[30], slice(4, 7)), (m.imu.dtheta[30], slice(1, 4))):
        want = 6 * inc.iloc[40, cols].to_numpy() + 5 * inc.iloc[29, cols].to_numpy()
        np.testing.assert_allclose(got, want, rtol=1e-9)
    (r,) = m.repairs
    assert "filled at the mean of the rates either side" in r.detail


@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_increments_after_a_sample_lost_before_the_last_row(tmp_path: Path, jitter: float) -> None:
    # Row 78 (or 398, jittered by up to 0.2 T) lost: the last row holds one period's increments
    # over two. Since 0.4.10 stretched as any other; up to 0.4.9 the last row was never a
    # candidate (its own interval stood for the next one): gravity over 2 T against one
    # period's specific force, a 0.1-m/s down-velocity step at the end.
    inc, _ = _jittered(jitter, n=80 if jitter == 0.0 else 400)
    root = _increments_mission(tmp_path, inc.drop(index=[len(inc) - 2]))
    m = load_mission(root)
    r = m.repairs[-1]
    assert (r.line, r.action) == (len(inc), "stretched increments over lost samples")  # CSV line
    assert "about 1 sample(s) lost" in r.detail
    assert m.imu.dt[-1] == pytest.approx(2 * T, rel=0.02)
    np.testing.assert_allclose(m.imu.dvel[-1], 2 * inc.iloc[-1, 4:].to_numpy(), rtol=0.02)


def _rows_40_41_lost(
    tmp_path: Path, accumulated_from: int
) -> tuple[pd.DataFrame, list[str], Mission]:
    """Noisy increments with rows 40 and 41 missing and row 42 holding the increments of rows
    ``accumulated_from``..42 (an IMU that accumulates until read), loaded."""
    inc = _noisy_increments()
    cols = list(inc.columns[1:])
    inc.loc[42, cols] = inc.loc[accumulated_from:42, cols].sum().to_numpy()
    return inc, cols, load_mission(_increments_mission(tmp_path, inc.drop(index=[40, 41])))


def test_increments_of_part_of_a_hole_are_stretched_over_it(tmp_path: Path) -> None:
    # Row 40 lost, row 41's increments added to row 42 (an IMU that accumulates until read,
    # after a lost sample): row 42 holds 2 T of increments over the 3 T since row 39. Since
    # 0.4.9 (second version) taken as 2 T and scaled by 3/2; the first version knew only 1 T
    # or the whole interval and kept 3 T (a 0.1-m/s down-velocity step on the demo).
    inc, cols, m = _rows_40_41_lost(tmp_path, accumulated_from=41)
    assert m.imu.dt[40] == pytest.approx(3 * T)
    np.testing.assert_allclose(m.imu.dvel[40], 1.5 * inc.loc[42, cols[3:]].to_numpy(), rtol=1e-12)
    (r,) = m.repairs
    assert r.action == "stretched increments over lost samples"
    assert "about 1 sample(s) lost" in r.detail and "scaled by 1.5" in r.detail


def test_increments_that_span_a_longer_interval_are_kept(tmp_path: Path) -> None:
    # An IMU that accumulates until read: rows missing, but row 42 holds the 3 T since row 39.
    inc, cols, m = _rows_40_41_lost(tmp_path, accumulated_from=40)
    assert m.imu.dt[40] == pytest.approx(3 * T)
    np.testing.assert_allclose(m.imu.dvel[40], inc.loc[42, cols[3:]].to_numpy(), rtol=1e-12)
    assert not m.repairs


def test_jittered_increment_stamps_are_not_lost_samples(tmp_path: Path) -> None:
    # Stamps jittered by up to 0.3 T around a regular clock: intervals up to 1.6 T, none lost.
    inc = _noisy_increments(400)
    inc["t_s"] += np.random.default_rng(3).uniform(-0.3 * T, 0.3 * T, len(inc))
    root = _increments_mission(tmp_path, inc)
    # since 0.4.9 re-stamped on their grid (below), and still no lost sample
    assert [r.action for r in load_mission(root).repairs] == ["re-stamped on the fitted grid"]
    root = _increments_mission(tmp_path, inc, restamp=False)
    assert not load_mission(root).repairs


def _jittered(amplitude: float, n: int = 400, seed: int = 5) -> tuple[pd.DataFrame, np.ndarray]:
    """Noisy increments of one period each, stamped ``amplitude`` periods either side of their
    grid; and the grid."""
    inc = _noisy_increments(n)
    grid = inc["t_s"].to_numpy().copy()
    inc["t_s"] += np.random.default_rng(seed).uniform(-amplitude * T, amplitude * T, n)
    return inc, grid


def test_jittered_increment_stamps_are_restamped(tmp_path: Path) -> None:
    # Stamps jittered by up to 0.2 T, the increments one period each: up to 0.4.8 each row's
    # increments were taken over its stamped interval (gravity over T + e_k - e_{k-1}: a down
    # velocity error g e_k); since 0.4.9 the rows are re-stamped on the fitted grid.
    inc, grid = _jittered(0.2)
    root = _increments_mission(tmp_path, inc)
    m = load_mission(root)
    (r,) = m.repairs
    assert (r.file, r.field, r.action) == ("imu.csv", "t_s", "re-stamped on the fitted grid")
    assert "the increments are one period each" in r.detail
    assert np.max(np.abs(m.imu.t - grid)) < 0.05 * T  # the stamps were up to 0.2 T off
    np.testing.assert_allclose(m.imu.dt, T, rtol=0.02)
    np.testing.assert_allclose(m.imu.dvel, inc.iloc[:, 4:].to_numpy(), rtol=0.02)


def test_jittered_increment_stamps_kept_when_asked_or_uncertain(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # imu.restamp = false: a warning, the stamps as they are; jittered by up to 0.4 T, the
    # count of periods of some rows is uncertain: a warning too.
    for amplitude, restamp, why in ((0.2, False, "imu.restamp = false"), (0.4, True, "uncertain")):
        inc, _ = _jittered(amplitude)
        root = _increments_mission(tmp_path, inc, restamp=restamp)
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
            m = load_mission(root)
        assert "re-stamped on the fitted grid" not in [r.action for r in m.repairs]
        np.testing.assert_array_equal(m.imu.t, inc["t_s"].to_numpy())
        assert "not re-stamped" in caplog.text and why in caplog.text
        assert "'Jittered IMU stamps'" in caplog.text


def test_jittered_stamps_with_counts_resolved_by_the_grid(tmp_path: Path) -> None:
    # Jittered by up to 0.3 T: some rows are stamped 1.5-1.6 T after the one before, nearer two
    # periods than one; the offsets from the grid either side of them tell that they are one
    # period late, not two, so every interval is re-stamped to about T.
    inc, grid = _jittered(0.3, seed=6)
    assert np.max(np.diff(inc["t_s"].to_numpy())) > 1.5 * T
    root = _increments_mission(tmp_path, inc)
    m = load_mission(root)
    assert [r.action for r in m.repairs] == ["re-stamped on the fitted grid"]
    np.testing.assert_allclose(m.imu.dt, T, rtol=0.05)
    assert np.max(np.abs(m.imu.t - grid)) < 0.1 * T


@pytest.mark.parametrize("rows", [[0, 1], [-2, -1]], ids=["first", "last"])
def test_jittered_stamps_with_an_end_interval_past_one_and_a_half_periods(
    tmp_path: Path, rows: list[int]
) -> None:
    # Jittered by up to 0.3 T, the first (or last) interval stamped 1.56 T: one period late, as
    # within the table. Up to 0.4.9 the median offsets past the end were the rows before it
    # mirrored, so the count stayed 2: the last row re-stamped a period late (a period's
    # increments over two: a 0.1-m/s down-velocity step), or the first a period early and the
    # second row "stretched over lost samples" (its increments doubled).
    inc, grid = _jittered(0.3)
    t = inc["t_s"].to_numpy().copy()
    t[rows] = grid[rows] + np.array([-0.28, 0.28]) * T
    inc["t_s"] = t
    root = _increments_mission(tmp_path, inc)
    m = load_mission(root)
    assert [r.action for r in m.repairs] == ["re-stamped on the fitted grid"]
    np.testing.assert_allclose(m.imu.dt, T, rtol=0.05)
    assert np.max(np.abs(m.imu.t - grid)) < 0.1 * T
    np.testing.assert_array_equal(m.imu.dvel, inc.iloc[:, 4:].to_numpy())


def test_irregular_stamps_whose_increments_follow_them_are_kept(tmp_path: Path) -> None:
    # Irregular sampling whose increments do cover each stamped interval: nothing to repair.
    inc, _ = _jittered(0.2)
    own = np.diff(inc["t_s"].to_numpy(), prepend=inc["t_s"].iloc[0] - T)
    inc[inc.columns[1:]] = inc[inc.columns[1:]].to_numpy() * (own / T)[:, None]
    root = _increments_mission(tmp_path, inc)
    m = load_mission(root)
    assert not m.repairs
    np.testing.assert_array_equal(m.imu.t, inc["t_s"].to_numpy())


def test_jittered_stamps_with_lost_samples(tmp_path: Path) -> None:
    # Jittered by up to 0.2 T and rows 200, 201 lost: re-stamped, then row 202 stretched over
    # the 3 T of the grid (up to 0.4.8: the stamps as they were, and no stretch).
    inc, grid = _jittered(0.2)
    root = _increments_mission(tmp_path, inc.drop(index=[200, 201]))
    m = load_mission(root)
    assert [r.action for r in m.repairs] == [
        "re-stamped on the fitted grid",
        "stretched increments over lost samples",
    ]
    assert m.imu.dt[200] == pytest.approx(3 * T, rel=0.02)
    np.testing.assert_allclose(m.imu.dvel[200], 3 * inc.iloc[202, 4:].to_numpy(), rtol=0.02)
    assert np.max(np.abs(m.imu.t - np.delete(grid, [200, 201]))) < 0.05 * T


def test_frozen_imu_is_an_error(tmp_path: Path) -> None:
    # Every value of rows 100-220 repeats row 99's: an IMU frozen for 1.21 s (up to 0.4.8 taken
    # as it was: the demo frozen for 10 s under way ran 696 km off with exit 0).
    d = config_dict()
    d["imu"]["format"] = "increments"
    inc = _noisy_increments(300)
    cols = list(inc.columns[1:])
    inc.loc[100:220, cols] = inc.loc[99, cols].to_numpy()
    root = write_dir(tmp_path, d, {"imu.csv": inc, "dvl.csv": dvl_table()})
    msg = load_error(root)
    assert msg.startswith("imu.csv line 102, dtheta_x_rad, ")
    assert "every IMU value unchanged for 1.21 s, from imu.csv line 101 (t = 10.99 s)" in msg
    assert "set imu.stuck_s above 1.21 s (0: not checked)" in msg
    d["imu"]["stuck_s"] = 0.0
    root = write_dir(tmp_path, d, {"imu.csv": inc, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == 300
    d["imu"]["stuck_s"] = 2.0
    d["imu"]["format"] = "rates"
    rates = imu_rates(300)
    rates.loc[100:220, rates.columns[1:]] = rates.loc[99, rates.columns[1:]].to_numpy()
    root = write_dir(tmp_path, d, {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == 299
    del d["imu"]["stuck_s"]
    root = write_dir(tmp_path, d, {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert "every IMU value unchanged for 1.21 s" in load_error(root)


@pytest.mark.parametrize(
    ("column", "held"),
    [("dtheta_z_rad", "zero"), ("dtheta_x_rad", "last"), ("dvel_x_m_s", "last")],
)
def test_one_stuck_imu_channel_is_an_error(tmp_path: Path, column: str, held: str) -> None:
    """One channel of a noisy increments table held (at 0, or at row 399's value) from row 400
    to the end, 6 s, while the other five move: refused naming the column, its first repeated
    line and the span (up to 0.4.12 only all six frozen at once were: the demo with its gyro x
    zero from 750 s ran with exit 0). ``imu.channel_stuck_s`` above the span, or ``stuck_s = 0``
    (the default is tied to it), takes it."""
    inc = _noisy_increments(1000)
    value = 0.0 if held == "zero" else float(inc.loc[399, column])
    inc.loc[400:, column] = value
    first = 402 if held == "zero" else 401  # CSV line of the value's first row (row 0: line 2)
    root = _increments_mission(tmp_path, inc)
    msg = load_error(root)
    assert msg.startswith(f"imu.csv line {first + 1}, {column}: unchanged at "), msg
    t0 = 10.0 + (first - 2) * T
    assert f"for {19.99 - t0:.6g} s, from imu.csv line {first} (t = {t0:.2f}".rstrip("0") in msg
    assert "to imu.csv line 1001 (t = 19.99" in msg
    assert "changed on 100% of those samples" in msg and "a channel stuck or dead" in msg
    assert f"set imu.channel_stuck_s above {19.99 - t0:.6g} s" in msg
    assert len(load_mission(_increments_mission(tmp_path, inc, channel_stuck_s=7.0)).imu) == 1000
    assert len(load_mission(_increments_mission(tmp_path, inc, stuck_s=0.0)).imu) == 1000


def test_a_channel_stuck_shorter_than_the_limit_is_taken(tmp_path: Path) -> None:
    # 4.99 s held, the default limit 5 s (5 × stuck_s); and with stuck_s = 0.5, 2.5 s: refused.
    inc = _noisy_increments(1000)
    inc.loc[500:, "dvel_z_m_s"] = -G0 * T
    assert len(load_mission(_increments_mission(tmp_path, inc)).imu) == 1000
    msg = load_error(_increments_mission(tmp_path, inc, stuck_s=0.5))
    assert msg.startswith("imu.csv line 503, dvel_z_m_s: unchanged at "), msg


def test_a_quantized_imu_at_rest_is_not_a_stuck_channel(tmp_path: Path) -> None:
    """Gyros quantized at 1e-3 rad/s, ten times their noise: at rest (8 s) each reads 0 on every
    sample, then turning they change on most samples; the accelerometers (fine steps) move
    throughout. Each gyro is unchanged for 8 s, but so are the others of its triad: coarse
    steps, not a stuck channel. A gyro whose steps are that coarse throughout (it repeats on
    most samples elsewhere too) is not one either."""
    n, q = 1500, 1e-3
    rates = imu_rates(n)
    rng = np.random.default_rng(17)
    t = rates["t_s"].to_numpy() - 10.0
    moving = t >= 8.0
    for j, c in enumerate(["gyro_x_rad_s", "gyro_y_rad_s", "gyro_z_rad_s"]):
        true = np.where(moving, 0.05 * np.sin(2.0 * np.pi * 0.5 * t + j), 0.0)
        rates[c] = q * np.round((true + rng.normal(0.0, 1e-4, n)) / q)
    acc = ["accel_x_m_s2", "accel_y_m_s2", "accel_z_m_s2"]
    rates[acc] = rates[acc].to_numpy() + rng.normal(0.0, 1e-2, (n, 3))
    root = write_dir(tmp_path, config_dict(), {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == n - 1
    # gyro x quantized throughout (it repeats on about 60 % of its samples), 0 on rows
    # 200-1199, beside y and z with fine steps
    rates["gyro_x_rad_s"] = q * np.round(rng.normal(0.0, 4e-4, n) / q)
    rates.loc[200:1199, "gyro_x_rad_s"] = 0.0
    fine = ["gyro_y_rad_s", "gyro_z_rad_s"]
    rates[fine] = rates[fine].to_numpy() + rng.normal(0.0, 1e-4, (n, 2))
    root = write_dir(tmp_path, config_dict(), {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == n - 1


def test_saturated_imu_column_is_an_error(tmp_path: Path) -> None:
    # gyro_z clipped at 0.3 rad/s on 12 rows of a seeded noisy rate table (up to 0.4.8 taken
    # as it was: the demo's gyros clipped at 0.05 rad/s gave an attitude NEES of 636, exit 0).
    d = config_dict()
    rates = imu_rates(300)
    rng = np.random.default_rng(11)
    cols = list(rates.columns[1:])
    rates[cols] = rates[cols].to_numpy() + rng.normal(0.0, 1e-3, (300, 6))
    rates.loc[150:161, "gyro_z_rad_s"] = 0.3
    root = write_dir(tmp_path, d, {"imu.csv": rates, "dvl.csv": dvl_table()})
    msg = load_error(root)
    assert msg.startswith("imu.csv line 152, gyro_z_rad_s: 12 rows, the first here (t = 11.5 s)")
    assert "hold the column's largest value, 0.3: clipped at the IMU's range (saturated)?" in msg
    assert "set imu.saturation_rows above 12 (0: not checked)" in msg
    rates.loc[150:152, "gyro_z_rad_s"] = -0.3
    rates.loc[153:161, "gyro_z_rad_s"] = rng.normal(0.0, 1e-3, 9)
    root = write_dir(tmp_path, d, {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == 299  # an extreme on 3 rows is a peak
    d["imu"]["saturation_rows"] = 0
    rates.loc[150:170, "gyro_z_rad_s"] = 0.3
    root = write_dir(tmp_path, d, {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == 299


def test_a_quantized_imu_at_rest_is_not_saturated(tmp_path: Path) -> None:
    """An IMU quantized at 0.01 m/s² whose accel_x sits at rest within ±2 steps: its extremes
    repeat (15 rows each) but fewer times than the steps next to them (300), a tail, not a
    pile-up; the check's first version refused it ("clipped at the IMU's range")."""
    n = 2630
    rates = imu_rates(n)
    levels = np.repeat([-0.02, -0.01, 0.0, 0.01, 0.02], [15, 300, 2000, 300, 15])
    rates["accel_x_m_s2"] = np.random.default_rng(3).permutation(levels)
    root = write_dir(tmp_path, config_dict(), {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == n - 1


@pytest.mark.parametrize("column", ["accel_z_m_s2", "gyro_y_rad_s"])
def test_an_imu_at_rest_below_its_step_is_not_saturated(tmp_path: Path, column: str) -> None:
    """An IMU at rest whose noise is below its output step (0.01 m/s², 1e-4 rad/s): the column
    alternates between two steps, the one farther from zero on two rows in three, a pile-up by
    count at a step next to the rest, not at the end of a range. Up to 0.4.12 refused ("clipped
    at the IMU's range"); a column clipped in motion still is (the next test)."""
    n, step = 2631, (0.01 if column.startswith("accel") else 1e-4)
    rates = imu_rates(n)
    base = -G0 if column.startswith("accel") else 0.0
    far = -step if column.startswith("accel") else step  # away from zero
    rates[column] = base + np.resize([far, far, 0.0], n)
    root = write_dir(tmp_path, config_dict(), {"imu.csv": rates, "dvl.csv": dvl_table()})
    assert len(load_mission(root).imu) == n - 1


def test_a_quantized_gyro_clipped_in_motion_is_still_saturated(tmp_path: Path) -> None:
    """A gyro quantized at 1e-4 rad/s swinging ±0.2 rad/s (2000 steps each way) clipped at
    +0.1 rad/s: its values span 3000 steps, the pile-up at the clip is refused."""
    n = 2000
    rates = imu_rates(n)
    swing = np.round(0.2 * np.sin(np.arange(n) * 0.05) / 1e-4) * 1e-4
    rates["gyro_y_rad_s"] = np.minimum(swing, 0.1)
    root = write_dir(tmp_path, config_dict(), {"imu.csv": rates, "dvl.csv": dvl_table()})
    msg = load_error(root)
    assert "gyro_y_rad_s: " in msg and "hold the column's largest value, 0.1: clipped" in msg


@pytest.mark.parametrize(
    ("scale", "gravity", "refused"),
    [(1.0 / G0, 1.0, True), (1.0, 0.0, True), (1.0e3, 1.0, True), (1.0, 1.0, False)],
)
def test_accelerations_far_from_gravity_name_their_units(
    tmp_path: Path, scale: float, gravity: float, refused: bool
) -> None:
    """The median |specific force| of an IMU table must be near g: in g (÷ 9.80665) or with
    gravity taken out (an AHRS's free acceleration) it is refused, naming the accelerometer
    columns and both causes; in mm/s² the 20-g limit per component refuses it first; in m/s²
    it loads. Up to 0.4.8 the first two were integrated (in g: "not static" at the
    alignment, or a diverged state start)."""
    rates = imu_rates(200)
    acc = ["accel_x_m_s2", "accel_y_m_s2", "accel_z_m_s2"]
    rates["accel_z_m_s2"] = -G0 * gravity
    rates[acc] = rates[acc].to_numpy() * scale
    root = write_dir(tmp_path, config_dict(), {"imu.csv": rates, "dvl.csv": dvl_table()})
    if not refused:
        assert len(load_mission(root).imu) == 199
        return
    msg = load_error(root)
    assert msg.startswith("imu.csv"), msg
    if scale < 1e3:
        assert "the median |specific force| over the table is" in msg
        assert "in g: × 9.80665" in msg and "gravity taken out" in msg
    else:
        assert "wrong units?" in msg


# --- structure of the files ---------------------------------------------------------------------


def test_missing_file(tmp_path: Path) -> None:
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates()})
    msg = load_error(root)
    assert msg.startswith("dvl.csv: file not found")
    with pytest.raises(MissionError, match=r"mission\.toml: file not found"):
        load_mission(tmp_path / "nowhere")


def test_file_that_is_not_csv_or_parquet(tmp_path: Path) -> None:
    imu = imu_rates()
    root = write_dir(tmp_path, config_dict(), {"dvl.csv": dvl_table()})
    imu.to_parquet(root / "imu.csv")  # a Parquet file named .csv
    assert "imu.csv: not a CSV text file" in load_error(root)
    (root / "imu.csv").write_bytes(b"t_s,\xff\xfe\n")
    assert "imu.csv line 1: not UTF-8 text (byte 0xff, byte 5 of the line;" in load_error(root)
    (root / "imu.csv").write_bytes(b"t_s,gyro_x,status\n1,2,ok\n2,3,45\xb0 heel\n")
    assert load_error(root).startswith(
        "imu.csv line 3, status: not UTF-8 text (byte 0xb0, byte 7 of the line; "
        "a Latin-1 or Windows-1252 file? save it as UTF-8)"
    )
    d = config_dict()
    d["imu"]["file"] = "imu.parquet"
    write_dir(root, d, {"imu.parquet": "t_s,gyro_x\n1,2\n"})  # CSV text named .parquet
    assert "imu.parquet: not a readable Parquet file" in load_error(root)


def test_empty_tables(tmp_path: Path) -> None:
    root = write_dir(tmp_path, config_dict(), {"imu.csv": "", "dvl.csv": dvl_table()})
    assert "imu.csv: empty file (no header line)" in load_error(root)
    header = ",".join(imu_rates().columns) + "\n"
    (root / "imu.csv").write_text(header)
    assert "imu.csv (imu): no data rows" in load_error(root)


def test_truncated_last_line_is_dropped(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    text = csv_text(imu_rates(n=20))
    text = text[: text.rstrip("\n").rfind(",")]  # cut the last row in its last field
    root = write_dir(tmp_path, config_dict(), {"imu.csv": text, "dvl.csv": dvl_table()})
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        m = load_mission(root)
    assert len(m.imu) == 18  # 19 complete samples → 18 intervals
    (r,) = m.repairs
    assert (r.file, r.line, r.action) == ("imu.csv", 21, "dropped truncated last line")
    assert "imu.csv line 21" in caplog.text


def test_short_line_in_the_middle_is_an_error(tmp_path: Path) -> None:
    lines = csv_text(imu_rates()).splitlines()
    lines[4] = ",".join(lines[4].split(",")[:3])
    root = write_dir(
        tmp_path, config_dict(), {"imu.csv": "\n".join(lines) + "\n", "dvl.csv": dvl_table()}
    )
    assert "imu.csv line 5: 3 fields, the header (line 1) has 7" in load_error(root)


def test_columns_in_another_order_and_blank_lines(tmp_path: Path) -> None:
    imu = imu_rates()
    shuffled = imu[list(reversed(imu.columns))]
    lines = csv_text(shuffled).splitlines()
    lines.insert(3, "")  # a blank line: skipped, but line numbers still count it
    lines[7] = lines[7].replace(lines[7].split(",")[0], "oops", 1)
    files: dict[str, pd.DataFrame | str] = {"imu.csv": "\n".join(lines), "dvl.csv": dvl_table()}
    root = write_dir(tmp_path, config_dict(), files)
    assert "imu.csv line 8, accel_z_m_s2: value 'oops' is not a number" in load_error(root)
    root = write_dir(tmp_path, config_dict(), {"imu.csv": csv_text(shuffled)})
    m = load_mission(root)
    np.testing.assert_array_equal(m.imu.t, imu["t_s"].to_numpy()[1:])


def test_missing_column_lists_missing_and_found(tmp_path: Path) -> None:
    dvl = dvl_table().drop(columns=["vy_m_s"])
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl})
    msg = load_error(root)
    assert "dvl.csv (sensor 'dvl'): missing column(s) ['vy_m_s']" in msg
    assert "found ['t_s', 'vx_m_s', 'vz_m_s']" in msg


def test_table_of_the_wrong_kind(tmp_path: Path) -> None:
    gnss = pd.DataFrame({"t_s": [1.0, 2.0], "lat_deg": [26.8, 26.8], "lon_deg": [56.0, 56.0]})
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": gnss})
    msg = load_error(root)
    assert "missing column(s) ['vx_m_s', 'vy_m_s', 'vz_m_s']" in msg
    assert "looks like a gnss table" in msg
    d = config_dict()
    d["imu"]["format"] = "increments"
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), "dvl.csv": dvl_table()})
    assert "looks like a imu (format = 'rates') table" in load_error(root)


def test_non_numeric_value_names_line_and_field(tmp_path: Path) -> None:
    dvl = dvl_table().astype({"vy_m_s": object})
    dvl.loc[2, "vy_m_s"] = "1.2.3"
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl})
    assert "dvl.csv line 4, vy_m_s: value '1.2.3' is not a number" in load_error(root)


def test_parquet_errors_name_the_row(tmp_path: Path) -> None:
    d = config_dict()
    d["sensors"]["dvl"]["file"] = "dvl.parquet"
    dvl = dvl_table()
    dvl["vx_m_s"] = dvl["vx_m_s"].astype(str)  # a text column, as a bad exporter writes it
    dvl.loc[3, "vx_m_s"] = "fast"
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), "dvl.parquet": dvl})
    assert "dvl.parquet row 3, vx_m_s: value 'fast' is not a number" in load_error(root)


# --- values -------------------------------------------------------------------------------------


def test_imu_nan_row_dropped_then_gap_checked(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    imu = imu_rates()
    imu.loc[7, "gyro_y_rad_s"] = np.nan
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        m = load_mission(root)
    assert len(m.imu) == 48 and m.imu.dt[6] == pytest.approx(2 * T)
    r, hole = m.repairs
    assert (r.line, r.field, r.action) == (9, "gyro_y_rad_s", "dropped row with non-finite value")
    assert "imu.csv line 9, gyro_y_rad_s: dropped row" in caplog.text
    # since 0.4.13 the hole it leaves in an IMU in rates is a repair too, on the row after it
    assert (hole.line, hole.action) == (10, "hole filled by the trapezoid of rates")
    assert "about 1 sample(s) lost or dropped" in hole.detail
    imu.loc[8:12, "accel_x_m_s2"] = np.nan  # now 6 rows in a row: a 70 ms hole
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu})
    msg = load_error(root)
    assert "IMU gap of 0.07 s between imu.csv line 8 (t = 10.06 s)" in msg
    assert "line 15 (t = 10.13" in msg and "6 row(s) between them were dropped" in msg


def test_sensor_nan_row_is_kept(tmp_path: Path) -> None:
    dvl = dvl_table()
    dvl.loc[1, "vz_m_s"] = np.nan
    dvl_csv = csv_text(dvl).replace(",,", ",,", 1)
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl_csv})
    m = load_mission(root)
    assert m.sensors["dvl"].z.shape == (5, 3) and np.isnan(m.sensors["dvl"].z[1, 2])
    assert m.repairs == () and m.dropped == ()


def test_time_must_be_finite(tmp_path: Path) -> None:
    imu = imu_rates()
    imu.loc[4, "t_s"] = np.inf
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    assert "imu.csv line 6, t_s: time inf is not finite" in load_error(root)


def test_out_of_order_names_first_line_and_both_times(tmp_path: Path) -> None:
    imu = imu_rates()
    imu.loc[10, "t_s"] = 9.0
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    msg = load_error(root)
    assert "imu.csv line 12, t_s: time goes backwards: t = 9.0 s after t = 10.09 s" in msg
    assert "at imu.csv line 11" in msg
    dvl = dvl_table()
    dvl.loc[3, "t_s"] = 10.0
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl})
    assert "dvl.csv line 5, t_s: time goes backwards: t = 10.0 s" in load_error(root)


def test_imu_duplicates(tmp_path: Path) -> None:
    imu = imu_rates()
    dup = pd.concat([imu.iloc[:6], imu.iloc[5:]], ignore_index=True)  # row 5 twice
    root = write_dir(tmp_path, config_dict(), {"imu.csv": dup, "dvl.csv": dvl_table()})
    m = load_mission(root)
    np.testing.assert_array_equal(m.imu.t, imu["t_s"].to_numpy()[1:])
    (r,) = m.repairs
    assert (r.line, r.action) == (8, "dropped duplicate row") and "imu.csv line 7" in r.detail
    dup.loc[6, "accel_x_m_s2"] = 0.2
    root = write_dir(tmp_path, config_dict(), {"imu.csv": dup})
    msg = load_error(root)
    assert "imu.csv line 8, t_s: repeated time t = 10.05 s (also at imu.csv line 7)" in msg


def test_sensor_duplicate_timestamp_goes_to_dropped(tmp_path: Path) -> None:
    dvl = dvl_table()
    t1 = float(dvl["t_s"].iloc[1])
    dvl.loc[2, "t_s"] = t1
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl})
    m = load_mission(root)
    s = m.sensors["dvl"]
    np.testing.assert_array_equal(s.rows, [0, 1, 3, 4])
    np.testing.assert_array_equal(s.z[1], dvl.loc[1, ["vx_m_s", "vy_m_s", "vz_m_s"]])
    (d,) = m.dropped
    assert (d.sensor, d.row, d.t, d.reason) == ("dvl", 2, t1, "duplicate timestamp")


def test_dvl_zero_reading_is_a_lost_lock_when_asked(tmp_path: Path) -> None:
    """Off by default (a zero is a reading); with zero_is_lost only the all-zero row goes, and
    its fate reaches the run's ledger."""
    dvl = dvl_table()
    dvl.loc[3, ["vx_m_s", "vy_m_s", "vz_m_s"]] = 0.0
    dvl.loc[1, "vy_m_s"] = 0.0  # one zero axis is not a lost lock
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl})
    assert load_mission(root).dropped == ()
    d = config_dict()
    d["sensors"]["dvl"]["zero_is_lost"] = True
    d["initial"] = {"mode": "state", "lat_deg": 10.0, "lon_deg": 20.0, "rpy_deg": [0, 0, 0]}
    root = write_dir(tmp_path, d, {})
    m = load_mission(root)
    np.testing.assert_array_equal(m.sensors["dvl"].rows, [0, 1, 2, 4])
    (drop,) = m.dropped
    assert (drop.sensor, drop.row) == ("dvl", 3) and "bottom lock lost" in drop.reason
    ledger = api.run(m, "meskf").ledger
    rows = ledger[(ledger["sensor"] == "dvl") & (ledger["row"] == 3)]
    assert list(zip(rows["fate"], rows["reason"], strict=True)) == [("dropped", drop.reason)]
    d["sensors"]["gnss"] = {"kind": "gnss", "file": "g.csv", "sigma": [1, "m"],
                            "zero_is_lost": True}  # fmt: skip
    assert "only for dvl" in str(_config_error(lambda c: c.update(d)))


@pytest.mark.parametrize(
    ("cells", "fmt"),
    [([1, 1, 0, 1, 0], "csv"), (["true", "true", "false", "true", "false"], "csv"),
     ([True, True, False, True, False], "parquet"), ([1.0, 1.0, 0.0, 1.0, 0.0], "parquet")],
)  # fmt: skip
def test_dvl_status_column_drops_lost_lock_readings(
    tmp_path: Path, cells: list[Any], fmt: str
) -> None:
    """A DVL's own bottom-lock flag (status_column): each reading flagged lost is dropped
    with that reason and its fate reaches the run's ledger; a status that is neither 1/0 nor
    true/false, or missing, is an error naming the line and the field."""
    dvl = dvl_table()
    dvl["bottom_lock"] = cells
    d = config_dict()
    d["sensors"]["dvl"]["file"] = f"dvl.{fmt}"
    d["sensors"]["dvl"]["status_column"] = "bottom_lock"
    d["initial"] = {"mode": "state", "lat_deg": 10.0, "lon_deg": 20.0, "rpy_deg": [0, 0, 0]}
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), f"dvl.{fmt}": dvl})
    m = load_mission(root)
    np.testing.assert_array_equal(m.sensors["dvl"].rows, [0, 1, 3])
    assert [(x.row, x.reason) for x in m.dropped] == [
        (r, "DVL bottom lock lost: bottom_lock = 0 (status_column)") for r in (2, 4)
    ]
    ledger = api.run(m, "meskf").ledger
    fates = ledger[ledger["sensor"] == "dvl"].set_index("row")["fate"]
    assert fates[2] == "dropped" and fates[4] == "dropped"


def test_dvl_status_column_errors(tmp_path: Path) -> None:
    dvl = dvl_table()
    dvl["bottom_lock"] = ["1", "1", "2", "1", "0"]
    d = config_dict()
    d["sensors"]["dvl"]["status_column"] = "bottom_lock"
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), "dvl.csv": dvl})
    msg = load_error(root)
    assert "dvl.csv line 4" in msg and "bottom_lock" in msg and "status 2" in msg
    dvl["bottom_lock"] = ["1", "1", "", "1", "0"]
    write_dir(tmp_path, d, {"dvl.csv": dvl})
    assert "dvl.csv line 4" in load_error(root)
    d["sensors"]["dvl"]["file"] = "dvl.parquet"  # a nullable bool with a missing cell
    dvl["bottom_lock"] = pd.array([True, True, None, True, False], dtype="boolean")
    write_dir(tmp_path, d, {"dvl.parquet": dvl})
    assert "dvl.parquet row 2, bottom_lock: status missing" in load_error(root)
    d["sensors"]["dvl"]["file"] = "dvl.csv"
    d["sensors"]["dvl"]["status_column"] = "lock"
    write_dir(tmp_path, d, {})
    assert "status column 'lock' not found" in load_error(root)
    d["sensors"]["depth"] = {"kind": "depth", "file": "z.csv", "sigma": [1, "m"],
                             "status_column": "x"}  # fmt: skip
    assert "only for dvl" in str(_config_error(lambda c: c.update(d)))


def test_imu_gap_names_lines_and_times(tmp_path: Path) -> None:
    imu = imu_rates()
    imu.loc[20:, "t_s"] += 0.5
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    msg = load_error(root)
    assert "imu.csv: IMU gap of 0.51 s between imu.csv line 21 (t = 10.19 s) and" in msg
    assert "imu.csv line 22 (t = 10.7 s) exceeds imu.max_gap_s = 0.05 s" in msg
    d = config_dict()
    d["imu"]["max_gap_s"] = 1.0
    write_dir(tmp_path, d, {})
    assert len(load_mission(tmp_path).imu) == 49


def test_sensor_without_samples(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    empty = "t_s,vx_m_s,vy_m_s,vz_m_s\n"
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": empty})
    assert "sensor 'dvl' (dvl.csv): no samples (set optional = true" in load_error(root)
    d = config_dict()
    d["sensors"]["dvl"]["optional"] = True
    write_dir(tmp_path, d, {})
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        m = load_mission(tmp_path)
    assert m.sensors == {}
    (r,) = m.repairs
    assert r.action == "disabled sensor" and "dvl" in r.detail
    assert "disabled sensor" in caplog.text


def test_off_sensor_is_not_loaded(tmp_path: Path) -> None:
    d = config_dict()
    d["sensors"]["dvl"]["use"] = "off"
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates()})  # no dvl.csv at all
    m = load_mission(root)
    assert m.sensors == {} and set(m.tables) == {"imu"}


def test_absurd_imu_magnitudes_hint_at_units(tmp_path: Path) -> None:
    imu = imu_rates()
    imu.loc[12, "gyro_z_rad_s"] = 57.3  # deg/s given as rad/s
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu, "dvl.csv": dvl_table()})
    msg = load_error(root)
    assert "imu.csv line 14, gyro_z_rad_s: value 57.3 exceeds 20 rad/s: wrong units?" in msg
    assert "deg/s" in msg
    imu = imu_rates()
    imu["accel_z_m_s2"] = -9806.65  # mm/s²
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu})
    assert "imu.csv line 2, accel_z_m_s2: value -9806.65 exceeds 20 g" in load_error(root)
    d = config_dict()
    d["imu"]["format"] = "increments"
    inc = _increments()
    inc.loc[2, "dtheta_x_rad"] = 0.573  # deg per 10 ms given as rad
    root = write_dir(tmp_path, d, {"imu.csv": inc})
    msg = load_error(root)
    assert "imu.csv line 4, dtheta_x_rad: value 0.573 over dt = 0.01 s is a rate of 57.3" in msg


def test_degree_columns_are_converted_and_noted(tmp_path: Path) -> None:
    d = config_dict()
    d["sensors"] = {"hdg": {"kind": "heading", "file": "hdg.csv", "sigma": [1, "deg"]}}
    hdg = pd.DataFrame({"t_s": [10.1, 10.2], "yaw_deg": [90.0, -45.0], "quality": [1, 2]})
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), "hdg.csv": hdg})
    m = load_mission(root)
    np.testing.assert_allclose(m.sensors["hdg"].z[:, 0], [math.pi / 2, -math.pi / 4])
    (r,) = m.repairs
    assert (r.file, r.field, r.action) == ("hdg.csv", "yaw_deg", "converted degrees")
    assert list(m.tables["hdg"].columns) == ["t_s", "yaw_deg", "quality"]


def test_gnss_height_column_only_with_use_height(tmp_path: Path) -> None:
    d = config_dict()
    d["sensors"] = {"gps": {"kind": "gnss", "file": "g.csv", "sigma": [2, "m"]}}
    gps = pd.DataFrame({"t_s": [10.1, 10.2], "lat_deg": [26.8, 26.8], "lon_deg": [56.0, 56.1]})
    root = write_dir(tmp_path, d, {"imu.csv": imu_rates(), "g.csv": gps})
    z = load_mission(root).sensors["gps"].z
    np.testing.assert_allclose(z, np.deg2rad(gps[["lat_deg", "lon_deg"]].to_numpy()))
    d["sensors"]["gps"]["use_height"] = True
    write_dir(tmp_path, d, {})
    assert "missing column(s) ['h_m']" in load_error(tmp_path)


def test_many_repairs_are_all_recorded_but_logged_briefly(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    dvl = dvl_table(n=30)
    t = dvl["t_s"].to_numpy().copy()
    t[1::2] = t[0::2]  # every other stamp repeated
    dvl["t_s"] = t
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": dvl})
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        m = load_mission(root)
    assert len(m.dropped) == 15 and len(m.sensors["dvl"].t) == 15
    assert "5 more: duplicate timestamp" in caplog.text


def test_write_mission_checks_the_tables(tmp_path: Path) -> None:
    cfg = parse_config(config_dict())
    with pytest.raises(MissionError, match=r"no table given for \['dvl'\]"):
        write_mission(tmp_path, cfg, {"imu": imu_rates()})
    with pytest.raises(MissionError, match=r"tables \['usbl'\] name no stream"):
        write_mission(tmp_path, cfg, {"imu": imu_rates(), "dvl": dvl_table(), "usbl": dvl_table()})
    kept = write_mission(tmp_path, cfg, {"imu": imu_rates(), "dvl": dvl_table()}, fmt=None)
    assert kept == cfg and (tmp_path / "imu.csv").is_file()
    assert isinstance(load_mission(tmp_path / "mission.toml").config, MissionConfig)


def test_header_problems(tmp_path: Path) -> None:
    semi = csv_text(dvl_table()).replace(",", ";")
    root = write_dir(tmp_path, config_dict(), {"imu.csv": imu_rates(), "dvl.csv": semi})
    assert "the separator must be a comma" in load_error(root)
    (root / "dvl.csv").write_text("t_s,vx_m_s,vx_m_s,vz_m_s\n1,2,3,4\n")
    assert "dvl.csv line 1: repeated column name(s) ['vx_m_s']" in load_error(root)


def test_truncated_parquet_file(tmp_path: Path) -> None:
    d = config_dict()
    d["imu"]["file"] = "imu.parquet"
    root = write_dir(tmp_path, d, {"imu.parquet": imu_rates(), "dvl.csv": dvl_table()})
    data = (root / "imu.parquet").read_bytes()
    (root / "imu.parquet").write_bytes(data[: len(data) // 2])
    assert "imu.parquet: not a readable Parquet file" in load_error(root)


@pytest.mark.parametrize(
    ("rate_hz", "warned"), [(0.001, True), (3.0, False), (2.0, False), (9.0, True)]
)
def test_a_sensor_rate_far_from_its_table_is_warned(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, rate_hz: float, warned: bool
) -> None:
    """A DVL pinging at 3 Hz (dvl_table) configured at 0.001 Hz or 9 Hz is warned about, naming
    the file, the sensor and both intervals (the configured rate is the one the spike screen,
    Q adaptation and the gap restart take); 2 Hz, within a factor of two of 3 Hz (a DVL's
    rate follows its range), and 3 Hz are not. Up to 0.4.8 nothing was said."""
    cfg = config_dict()
    cfg["sensors"]["dvl"]["rate_hz"] = rate_hz
    root = write_dir(tmp_path, cfg, {"imu.csv": imu_rates(), "dvl.csv": dvl_table(n=12)})
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        m = load_mission(root)
    assert m.sensors["dvl"].period == pytest.approx(1.0 / rate_hz)
    said = "dvl.csv: sensor 'dvl''s median interval 0.333333 s is not its rate_hz"
    assert (said in caplog.text) is warned, caplog.text
