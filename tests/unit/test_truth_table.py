"""Load-time checks of the reference (truth) table's values (adaptnav.mission.truth;
docs/data-format.md, 'Bad input'): a non-finite value, an attitude angle that is not in
radians, and velocity columns that do not move the vehicle as its positions do are errors
naming the file, and where a row shows it, the line and the column."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.cli import app
from adaptnav.core import earth
from adaptnav.mission import MissionError, load_mission
from adaptnav.mission import truth as reference
from helpers.missions import config_dict, dvl_table, imu_rates, write_dir

SPEED = 2.0
HEADING = math.radians(30.0)


def _truth(n: int = 121, speed: float = SPEED) -> pd.DataFrame:
    """A vehicle under way at ``speed`` on a heading of 30° for n s, one row a second, its
    velocity the rate of its positions (Groves 2013 eq. 2.111)."""
    t = np.arange(n, dtype=float)
    lat0, h = 0.46, -5.0
    v_n, v_e = speed * math.cos(HEADING), speed * math.sin(HEADING)
    lat = lat0 + v_n * t / (earth.meridian_radius(lat0) + h)
    lon = 0.97 + v_e * t / ((earth.transverse_radius(lat0) + h) * math.cos(lat0))
    return pd.DataFrame(
        {
            "t_s": t,
            "lat_rad": lat,
            "lon_rad": lon,
            "h_m": h,
            "vn_m_s": v_n,
            "ve_m_s": v_e,
            "vd_m_s": 0.0,
            "roll_rad": 0.02 * np.sin(0.3 * t),
            "pitch_rad": -0.05,
            "yaw_rad": HEADING,
        }
    )


def _mission(tmp_path: Path, truth: pd.DataFrame) -> Path:
    files: dict[str, pd.DataFrame | str] = {
        "imu.csv": imu_rates(),
        "dvl.csv": dvl_table(),
        "truth.csv": truth,
    }
    return write_dir(tmp_path / "m", config_dict(truth={"file": "truth.csv"}), files)


def _error(tmp_path: Path, truth: pd.DataFrame) -> MissionError:
    with pytest.raises(MissionError) as info:
        load_mission(_mission(tmp_path, truth))
    return info.value


def test_a_consistent_reference_loads(tmp_path: Path) -> None:
    m = load_mission(_mission(tmp_path, _truth()))
    assert m.truth is not None and len(m.truth) == 121


@pytest.mark.parametrize("column", ["lat_rad", "vn_m_s", "yaw_rad"])
def test_a_value_that_is_not_finite_is_named_by_line_and_column(
    tmp_path: Path, column: str
) -> None:
    """A NaN velocity made fit-dvl fail inside SciPy ('SVD did not converge'), a NaN yaw with
    'Found zero norm quaternions', a NaN position made the RMSE NaN."""
    truth = _truth()
    truth.loc[40:44, column] = np.nan
    err = _error(tmp_path, truth)
    assert err.file == "truth.csv" and err.line == 42 and err.field == column  # header: line 1
    assert "not finite" in str(err) and "5 such value(s)" in str(err)


@pytest.mark.parametrize(
    ("column", "factor", "limit"),
    [("yaw_rad", 180.0 / math.pi, "6.28319"), ("pitch_rad", 180.0 / math.pi, "1.5708")],
)
def test_an_angle_that_is_not_in_radians_is_named(
    tmp_path: Path, column: str, factor: float, limit: str
) -> None:
    truth = _truth()
    truth[column] *= factor
    err = _error(tmp_path, truth)
    assert err.field == column and err.line == 2
    assert f"outside ±{limit} rad" in str(err) and "degrees?" in str(err)
    ok = _truth()
    ok["yaw_rad"] = 2.0 * math.pi - 1e-9  # a yaw in [0, 2π) is one
    assert load_mission(_mission(tmp_path / "ok", ok)).truth is not None


def test_an_angle_in_a_degree_column_is_checked_after_conversion(tmp_path: Path) -> None:
    truth = _truth().rename(columns={"pitch_rad": "pitch_deg"})
    truth["pitch_deg"] = 95.0
    err = _error(tmp_path, truth)
    assert err.field == "pitch_deg" and "(after × π/180)" in str(err)


@pytest.mark.parametrize(
    ("factor", "swap", "ok"),
    [(1.9438, False, False), (3.6, False, False), (1.15, False, True), (0.87, False, True),
     (1.0, True, False)],
)  # fmt: skip
def test_a_velocity_that_does_not_move_the_vehicle_as_its_positions_is_named(
    tmp_path: Path, factor: float, swap: bool, ok: bool
) -> None:
    """Knots gave fit-dvl a scale of -47 % and evaluate a velocity NEES of 149 394, exit 0; km/h
    and north and east swapped (ENU) are caught too, 15 % off in scale is not."""
    truth = _truth()
    truth[["vn_m_s", "ve_m_s", "vd_m_s"]] *= factor
    if swap:
        truth[["vn_m_s", "ve_m_s"]] = truth[["ve_m_s", "vn_m_s"]].to_numpy()
    if ok:
        assert load_mission(_mission(tmp_path, truth)).truth is not None
        return
    err = _error(tmp_path, truth)
    assert err.file == "truth.csv" and err.field == "vn_m_s"
    assert "vn_m_s, ve_m_s, vd_m_s" in str(err) and "12 windows of 10 s" in str(err)
    assert f"{factor:.3g} × the positions'" in str(err)


def test_at_rest_or_without_velocity_the_velocity_is_not_judged(tmp_path: Path) -> None:
    """A vehicle at rest: knots or m/s, the velocity is about 0 and no window is under way."""
    still = _truth(speed=0.0)
    still[["vn_m_s", "ve_m_s"]] = 0.001
    assert load_mission(_mission(tmp_path / "a", still)).truth is not None
    no_velocity = _truth().drop(columns=["vn_m_s", "ve_m_s", "vd_m_s"])
    assert load_mission(_mission(tmp_path / "b", no_velocity)).truth is not None


def test_the_disagreement_of_a_consistent_reference_is_about_zero() -> None:
    truth = _truth()
    llh = truth[["lat_rad", "lon_rad", "h_m"]].to_numpy()
    v = truth[["vn_m_s", "ve_m_s", "vd_m_s"]].to_numpy()
    n, diff, ratio = reference.velocity_disagreement(truth["t_s"].to_numpy(), llh, v)
    assert n == 12 and diff < 1e-3 and ratio == pytest.approx(1.0, abs=1e-3)


def test_cli_exits_2_naming_the_truth_table(tmp_path: Path) -> None:
    truth = _truth()
    truth[["vn_m_s", "ve_m_s", "vd_m_s"]] *= 1.9438
    root = _mission(tmp_path, truth)
    res = CliRunner().invoke(app, ["fit-dvl", str(root), "-q"])
    assert res.exit_code == 2 and "truth.csv (truth), vn_m_s" in res.stderr
    assert "Traceback" not in res.output
