"""Metrics (spec §10, P-32, P-33) on hand-made cases with independently known answers."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from adaptnav import earth
from adaptnav.evaluate import (
    Metrics,
    evaluate,
    nees_position,
    nis_bounds,
    nis_summary,
    outage_drift,
    position_errors,
    relative_rmse_pct,
    rmse,
    travelled_distance,
)
from adaptnav.results import SD_COLUMNS, SOLUTION_COLUMNS, Result, ledger_frame, noise_frame

LAT0, LON0, H0 = math.radians(43.0), math.radians(5.5), -20.0


def truth_from_ned(t: np.ndarray, ned: np.ndarray) -> pd.DataFrame:
    lat, lon, h = earth.ned_to_geodetic(ned, LAT0, LON0, H0)
    return pd.DataFrame({"t_s": t, "lat_rad": lat, "lon_rad": lon, "h_m": h})


def straight_north() -> pd.DataFrame:
    """1 km straight north in the tangent plane at the origin, 1 m/s, sampled at 1 Hz."""
    t = np.arange(1001, dtype=float)
    ned = np.stack([t, np.zeros_like(t), np.zeros_like(t)], axis=-1)
    return truth_from_ned(t, ned)


def offset_solution(truth: pd.DataFrame, offset_ned: np.ndarray, sd: float = 1.0) -> pd.DataFrame:
    """A solution at the truth times, each point displaced by ``offset_ned`` in the truth
    point's own NED frame."""
    rows = [
        earth.ned_to_geodetic(offset_ned, la, lo, hh)
        for la, lo, hh in truth[["lat_rad", "lon_rad", "h_m"]].to_numpy()
    ]
    lat, lon, h = (np.array([float(r[i]) for r in rows]) for i in range(3))
    sol = pd.DataFrame(0.0, index=range(len(truth)), columns=list(SOLUTION_COLUMNS))
    sol["t_s"] = truth["t_s"].to_numpy()
    sol["lat_rad"], sol["lon_rad"], sol["h_m"] = lat, lon, h
    for c in SD_COLUMNS:
        sol[c] = sd
    return sol


def make_result(solution: pd.DataFrame, ledger_rows: list[dict[str, object]]) -> Result:
    ledger = ledger_frame(ledger_rows)
    return Result("vb", "line", solution, ledger, noise_frame(ledger), {})


def test_straight_line_constant_east_offset() -> None:
    truth = straight_north()
    sol = offset_solution(truth, np.array([0.0, 3.0, 0.0]))
    err = position_errors(sol, truth)
    assert len(err) == 1001
    np.testing.assert_allclose(err["dE_m"], 3.0, atol=1e-6)
    np.testing.assert_allclose(err[["dN_m", "dD_m"]], 0.0, atol=1e-6)
    np.testing.assert_allclose(err["horizontal_m"], 3.0, atol=1e-6)
    assert rmse(err) == pytest.approx(3.0, abs=1e-6)
    assert travelled_distance(truth) == pytest.approx(1000.0, abs=1e-6)
    m = evaluate(make_result(sol, []), truth)
    assert isinstance(m, Metrics)
    assert m.rmse_m == pytest.approx(3.0, abs=1e-6)
    assert m.relative_rmse_pct == pytest.approx(0.3, abs=1e-8)
    assert m.horizontal_rmse_m == pytest.approx(3.0, abs=1e-6)
    assert m.max_horizontal_error_m == pytest.approx(3.0, abs=1e-6)
    assert m.distance_m == pytest.approx(1000.0, abs=1e-6)
    assert m.duration_s == 1000.0
    assert m.samples == 1001
    assert m.mean_nees_position == pytest.approx(9.0, abs=1e-5)  # (3 m / 1 m)²
    d = m.to_dict()
    for key in ("rmse_m", "relative_rmse_pct", "distance_m", "duration_s"):
        assert key in d
    assert d["yaw_rmse_rad"] is None  # truth without attitude
    assert d["counts"] == {} and d["nis"] == {}


def test_rmse_mixes_components() -> None:
    err = pd.DataFrame({"dN_m": [3.0, 0.0], "dE_m": [4.0, 0.0], "dD_m": [0.0, 12.0]})
    # mean of 25 and 144
    assert rmse(err) == pytest.approx(math.sqrt((25.0 + 144.0) / 2.0))
    assert relative_rmse_pct(5.0, 2000.0) == pytest.approx(0.25)
    assert math.isnan(relative_rmse_pct(5.0, 0.0))


def test_errors_match_geodetic_to_ned_per_point() -> None:
    truth = straight_north().iloc[::100].reset_index(drop=True)
    rng = np.random.default_rng(7)
    offsets = rng.normal(scale=50.0, size=(len(truth), 3))
    ref_geo = truth[["lat_rad", "lon_rad", "h_m"]].to_numpy(dtype=float)
    est_geo = np.array(
        [
            [float(v) for v in earth.ned_to_geodetic(offsets[k], *ref_geo[k])]
            for k in range(len(truth))
        ]
    )
    sol = truth.copy()
    sol[["lat_rad", "lon_rad", "h_m"]] = est_geo
    err = position_errors(sol, truth)
    for k in range(len(truth)):
        ref = earth.geodetic_to_ned(*est_geo[k], *ref_geo[k])
        np.testing.assert_allclose(err.loc[k, ["dN_m", "dE_m", "dD_m"]], ref, atol=1e-8)
        np.testing.assert_allclose(ref, offsets[k], atol=1e-6)


def test_circle_distance() -> None:
    radius, m = 200.0, 720
    ang = 2.0 * np.pi * np.arange(m + 1) / m  # closed: last point = first
    ned = np.stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros_like(ang)], axis=-1)
    truth = truth_from_ned(np.arange(m + 1, dtype=float), ned)
    polygon = 2.0 * m * radius * math.sin(math.pi / m)  # perimeter of the inscribed m-gon
    assert travelled_distance(truth) == pytest.approx(polygon, abs=1e-6)
    assert travelled_distance(truth) == pytest.approx(2.0 * math.pi * radius, rel=1e-5)
    assert travelled_distance(truth.iloc[:1]) == 0.0


def test_interpolation_at_truth_times_and_span() -> None:
    # Solution every 2 s along a path linear in lat, lon, h; truth at 1 Hz on the same path,
    # starting before and ending after the solution: only the inner samples are compared.
    def path(t: np.ndarray) -> pd.DataFrame:
        return pd.DataFrame(
            {
                "t_s": t,
                "lat_rad": LAT0 + 1e-6 * t,
                "lon_rad": LON0 - 2e-6 * t,
                "h_m": H0 + 0.5 * t,
                "yaw_rad": np.pi - 0.01 + 0.002 * t,  # crosses +π
            }
        )

    t_sol = np.arange(0.0, 21.0, 2.0)
    sol = pd.DataFrame(0.0, index=range(t_sol.size), columns=list(SOLUTION_COLUMNS))
    p = path(t_sol)
    sol["t_s"], sol["lat_rad"], sol["lon_rad"], sol["h_m"] = (
        p["t_s"],
        p["lat_rad"],
        p["lon_rad"],
        p["h_m"],
    )
    sol["yaw_rad"] = np.angle(np.exp(1j * p["yaw_rad"].to_numpy()))  # wrapped
    truth = path(np.arange(-3.0, 25.0, 1.0))
    truth["roll_rad"] = 0.0
    truth["pitch_rad"] = 0.0
    err = position_errors(sol, truth)
    np.testing.assert_array_equal(err["t_s"], np.arange(0.0, 21.0, 1.0))
    np.testing.assert_allclose(err[["dN_m", "dE_m", "dD_m"]], 0.0, atol=1e-7)
    np.testing.assert_allclose(err["dyaw_rad"], 0.0, atol=1e-12)

    # a 1 m height bias, seen at the sampled and the interpolated times alike
    sol2 = sol.copy()
    sol2["h_m"] += 1.0
    err2 = position_errors(sol2, truth)
    np.testing.assert_allclose(err2["dD_m"], -1.0, atol=1e-7)  # estimate above truth: dD < 0


def test_nees_position() -> None:
    truth = straight_north().iloc[:11]
    sol = offset_solution(truth, np.array([1.0, -2.0, 2.0]), sd=2.0)
    nees = nees_position(sol, truth)
    np.testing.assert_allclose(nees["nees"], (1.0 + 4.0 + 4.0) / 4.0, atol=1e-6)


def _used(sensor: str, stat: float, dim: int) -> dict[str, object]:
    rec: dict[str, object] = {
        "t": 0.0, "t_epoch": 0.0, "sensor": sensor, "row": 0, "fate": "used", "reason": "",
        "statistic": stat, "threshold": math.nan, "iterations": 0,
    }  # fmt: skip
    for j in range(3):
        rec[f"nu_{j}"] = 0.1 if j < dim else math.nan
        rec[f"r_{j}"] = 0.5 if j < dim else math.nan
    return rec


def test_nis_summary_and_bounds() -> None:
    rows = [_used("dvl", s, 3) for s in (2.0, 3.0, 4.0, 5.0)]
    rows += [_used("depth", s, 1) for s in (0.5, 1.5)]
    rejected = _used("dvl", 100.0, 3)
    rejected["fate"] = "rejected"
    rows.append(rejected)
    summ = nis_summary(ledger_frame(rows))
    assert sorted(summ) == ["depth", "dvl"]
    dvl = summ["dvl"]
    assert dvl.count == 4 and dvl.dof == 12 and dvl.dim == 3.0
    assert dvl.mean == pytest.approx(3.5)
    # sum of 4 chi²(3) is chi²(12): bounds of the mean are chi2(12) quantiles / 4
    assert dvl.lower == pytest.approx(chi2.ppf(0.025, 12) / 4)
    assert dvl.upper == pytest.approx(chi2.ppf(0.975, 12) / 4)
    assert dvl.lower == pytest.approx(4.4037885 / 4, rel=1e-6)  # table value
    assert dvl.upper == pytest.approx(23.3366709 / 4, rel=1e-6)
    assert dvl.consistent
    assert summ["depth"].mean == pytest.approx(1.0) and summ["depth"].dim == 1.0
    lo, hi = nis_bounds(1, 1)
    assert lo == pytest.approx(0.000982069, rel=1e-5) and hi == pytest.approx(5.0238862, rel=1e-6)
    with pytest.raises(ValueError):
        nis_bounds(0, 3)


def test_evaluate_counts_and_nis() -> None:
    truth = straight_north().iloc[:101]
    sol = offset_solution(truth, np.array([0.0, 3.0, 0.0]))
    rows = [_used("dvl", 3.0, 3), _used("dvl", 2.0, 3)]
    dropped = _used("depth", math.nan, 1)
    dropped["fate"] = "dropped"
    rows.append(dropped)
    m = evaluate(make_result(sol, rows), truth)
    assert m.counts == {
        "depth": {"used": 0, "rejected": 0, "dropped": 1},
        "dvl": {"used": 2, "rejected": 0, "dropped": 0},
    }
    assert m.mean_nis == {"dvl": 2.5}
    d = m.to_dict()
    assert d["nis"]["dvl"]["consistent"] is True
    assert m.relative_rmse_pct == pytest.approx(3.0, abs=1e-7)  # 3 m over 100 m


def test_evaluate_needs_overlap() -> None:
    truth = straight_north()
    sol = offset_solution(truth.iloc[:5], np.zeros(3))
    sol["t_s"] += 5000.0
    with pytest.raises(ValueError, match="no truth sample"):
        evaluate(make_result(sol, []), truth)
    with pytest.raises(ValueError, match="truth lacks"):
        position_errors(sol, truth.drop(columns="h_m"))


def test_outage_drift_scores_the_end_of_each_window() -> None:
    """A solution whose east error is ½ a (t - 100)² inside (100, 130] and zero elsewhere: the
    drift at the window's end is ½ a 30², its maximum the same, the distance 30 m (1 m/s)."""
    truth = straight_north()
    t = truth["t_s"].to_numpy()
    a = 0.02
    east = np.where((t > 100.0) & (t <= 130.0), 0.5 * a * (t - 100.0) ** 2, 0.0)
    lat, lon, h = [], [], []
    for k, (la, lo, hh) in enumerate(truth[["lat_rad", "lon_rad", "h_m"]].to_numpy()):
        r = earth.ned_to_geodetic(np.array([0.0, east[k], 0.0]), la, lo, hh)
        lat.append(float(r[0]))
        lon.append(float(r[1]))
        h.append(float(r[2]))
    sol = offset_solution(truth, np.zeros(3), sd=2.0)
    sol["lat_rad"], sol["lon_rad"], sol["h_m"] = lat, lon, h
    table = outage_drift(sol, truth, [(100.0, 30.0), (500.0, 10.0)])
    first, second = table.iloc[0], table.iloc[1]
    assert first["end_horizontal_m"] == pytest.approx(0.5 * a * 30.0**2, rel=1e-6)
    assert first["max_horizontal_m"] == pytest.approx(first["end_horizontal_m"])
    assert first["distance_m"] == pytest.approx(30.0, rel=1e-6)
    assert first["drift_pct"] == pytest.approx(100.0 * 9.0 / 30.0, rel=1e-6)
    assert first["claimed_sd_horizontal_m"] == pytest.approx(2.0 * math.sqrt(2.0))
    assert second["end_horizontal_m"] == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(ValueError, match="no truth sample inside"):
        outage_drift(sol, truth, [(2000.0, 10.0)])
