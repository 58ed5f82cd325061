"""Metrics (docs/metrics.md; paper eqs. (32), (33)) on hand-made cases with independently known
answers."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from adaptnav.analysis import evaluate as evaluate_module
from adaptnav.analysis.evaluate import (
    NEES_BAND,
    Metrics,
    block_errors,
    evaluate,
    forward_metrics,
    fraction_in_band,
    nees,
    nees_from,
    nees_position,
    nis_bounds,
    nis_summary,
    outage_drift,
    position_errors,
    relative_rmse_pct,
    rmse,
    travelled_distance,
)
from adaptnav.api.results import (
    COV_COLUMNS,
    REQUIRED_SOLUTION_COLUMNS,
    SD_COLUMNS,
    SOLUTION_COLUMNS,
    Result,
    cov_column,
    ledger_frame,
    load,
    noise_frame,
)
from adaptnav.core import attitude, earth

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
    # The line is straight in the tangent plane at its start, so it climbs s²/(2R) above the
    # ellipsoid: its horizontal length is ∫ cos(s/R) ds = L - L³/(6R²), 4 µm short of 1 km.
    L, R = 1000.0, float(earth.meridian_radius(LAT0))
    assert travelled_distance(truth) == pytest.approx(L - L**3 / (6.0 * R**2), abs=1e-8)
    assert travelled_distance(truth) == pytest.approx(1000.0, abs=1e-5)
    m = evaluate(make_result(sol, []), truth)
    assert isinstance(m, Metrics)
    assert m.rmse_m == pytest.approx(3.0, abs=1e-6)
    assert m.relative_rmse_pct == pytest.approx(0.3, abs=1e-8)
    assert m.horizontal_rmse_m == pytest.approx(3.0, abs=1e-6)
    assert m.max_horizontal_error_m == pytest.approx(3.0, abs=1e-6)
    assert m.distance_m == pytest.approx(1000.0, abs=1e-5)
    assert m.duration_s == 1000.0
    assert m.samples == 1001
    assert m.mean_nees_position == pytest.approx(9.0, abs=1e-5)  # (3 m / 1 m)²
    assert m.nees_position_in_95 == 1.0  # 9 < 9.348
    assert m.nees_uses_correlations
    d = m.to_dict()
    for key in ("rmse_m", "relative_rmse_pct", "distance_m", "duration_s"):
        assert key in d
    assert d["yaw_rmse_rad"] is None  # truth without attitude
    for key in ("mean_nees_velocity", "mean_nees_attitude", "nees_velocity_in_95"):
        assert d[key] is None  # truth without velocity and attitude
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
    values = nees_position(sol, truth)
    np.testing.assert_allclose(values["nees"], (1.0 + 4.0 + 4.0) / 4.0, atol=1e-6)


def _set_block(sol: pd.DataFrame, names: tuple[str, str, str], P: np.ndarray) -> None:
    """Write a constant 3×3 covariance ``P`` of the error states ``names`` into ``sol``."""
    for i, a in enumerate(names):
        sol[f"sd_{a}"] = math.sqrt(P[i, i])
        for j in range(i + 1, 3):
            sol[cov_column(a, names[j])] = P[i, j]


def test_nees_uses_the_correlations_by_hand() -> None:
    """P = [[4, 3, 0], [3, 4, 0], [0, 0, 1]] m²: along (1, -1, 0)/√2 its variance is 4 - 3 = 1,
    along (1, 1, 0)/√2 it is 7. e = (1, -1, 0) m gives NEES |e|²/1 = 2, e = (1, 1, 0) m gives
    2/7; P's diagonal alone gives 1/4 + 1/4 = 0.5 for both."""
    truth = straight_north().iloc[:21]
    P = np.array([[4.0, 3.0, 0.0], [3.0, 4.0, 0.0], [0.0, 0.0, 1.0]])
    for e, full in (([1.0, -1.0, 0.0], 2.0), ([1.0, 1.0, 0.0], 2.0 / 7.0)):
        sol = offset_solution(truth, np.array(e))
        _set_block(sol, ("dr_N", "dr_E", "dr_D"), P)
        got = nees(sol, truth, "position")
        assert got.attrs["uses_correlations"]
        np.testing.assert_allclose(got["nees"], full, rtol=1e-6)
        diagonal = nees(sol.drop(columns=list(COV_COLUMNS)), truth, "position")
        assert not diagonal.attrs["uses_correlations"]
        np.testing.assert_allclose(diagonal["nees"], 0.5, rtol=1e-6)


def test_nees_monte_carlo_full_block_against_diagonal() -> None:
    """Position errors drawn from a known correlated P (heading error: N and E strongly
    correlated), the solution claiming that P. With the full block NEES ~ χ²(3): mean 3, spread
    var 6 and 95 % inside NEES_BAND. The diagonal-only NEES also has mean 3 (tr(D⁻¹P) = 3 for
    any P), but not the χ²(3) spread: var 2 tr(ρ²) = 2 (3 + 2 Σ ρ_ij²) and the wrong share in the
    band, so a test on its per-epoch values would call a consistent filter inconsistent."""
    rng = np.random.default_rng(2024)
    n = 20000
    t = np.arange(n, dtype=float)
    truth = truth_from_ned(t, np.zeros((n, 3)))  # at rest: one truth point, n epochs
    sd = np.array([3.0, 3.0, 1.0])
    rho = np.array([[1.0, 0.95, 0.2], [0.95, 1.0, -0.1], [0.2, -0.1, 1.0]])
    P = rho * np.outer(sd, sd)
    e = rng.multivariate_normal(np.zeros(3), P, size=n)
    sol = offset_solution(truth, np.zeros(3))
    lat, lon, h = earth.ned_to_geodetic(e, LAT0, LON0, H0)
    sol["lat_rad"], sol["lon_rad"], sol["h_m"] = lat, lon, h
    _set_block(sol, ("dr_N", "dr_E", "dr_D"), P)

    full = nees(sol, truth, "position")["nees"].to_numpy()
    # standard error of the mean sqrt(6 / n) = 0.017; of the band share sqrt(.95 .05 / n) = 0.0015
    assert full.mean() == pytest.approx(3.0, abs=0.06)
    assert full.var() == pytest.approx(6.0, abs=0.4)
    assert fraction_in_band(full) == pytest.approx(0.95, abs=0.006)

    diagonal = nees(sol.drop(columns=list(COV_COLUMNS)), truth, "position")["nees"].to_numpy()
    var_diagonal = 2.0 * float(np.sum(rho**2))  # 2 tr(ρ²) = 2 (3 + 2 (0.9025 + 0.04 + 0.01))
    assert var_diagonal == pytest.approx(9.81)
    assert diagonal.var() == pytest.approx(var_diagonal, rel=0.1)
    assert diagonal.var() > 8.0  # clearly not χ²(3)'s 6
    assert fraction_in_band(diagonal) < 0.93  # clearly not 0.95
    assert not np.allclose(full, diagonal, rtol=0.1)

    # and evaluate() reports the full-block figures with the flag set
    m = evaluate(make_result(sol, []), truth)
    assert m.mean_nees_position == pytest.approx(full.mean(), rel=1e-9)
    assert m.nees_position_in_95 == pytest.approx(fraction_in_band(full))
    assert m.nees_uses_correlations
    old = evaluate(make_result(sol[list(REQUIRED_SOLUTION_COLUMNS)], []), truth)
    assert not old.nees_uses_correlations
    assert old.nees_position_in_95 == pytest.approx(fraction_in_band(diagonal))


def _moving_truth(t: np.ndarray) -> pd.DataFrame:
    """North at 2 m/s with a heave velocity, and an attitude whose yaw crosses ±π."""
    truth = truth_from_ned(t, np.stack([2.0 * t, 0.0 * t, 0.0 * t], axis=-1))
    truth["vn_m_s"] = 2.0
    truth["ve_m_s"] = 0.1 * np.sin(t)
    truth["vd_m_s"] = 0.3 * np.cos(0.5 * t)
    truth["roll_rad"] = 0.05 * np.sin(0.3 * t)
    truth["pitch_rad"] = -0.04 + 0.02 * np.cos(0.2 * t)
    truth["yaw_rad"] = attitude.wrap_angle(math.pi - 0.05 + 0.01 * t)
    return truth


def test_velocity_nees_by_hand() -> None:
    t = np.arange(11, dtype=float)
    truth = _moving_truth(t)
    sol = offset_solution(truth, np.zeros(3))
    dv = np.array([0.2, -0.1, 0.05])  # truth minus estimate
    for c, d in zip(("vn_m_s", "ve_m_s", "vd_m_s"), dv, strict=True):
        sol[c] = truth[c] - d
    P = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, -0.02], [0.0, -0.02, 0.01]])
    _set_block(sol, ("dv_N", "dv_E", "dv_D"), P)
    np.testing.assert_allclose(block_errors(sol, truth, "velocity")[["e_0", "e_1", "e_2"]],
                               np.broadcast_to(dv, (t.size, 3)), atol=1e-12)  # fmt: skip
    expected = float(dv @ np.linalg.solve(P, dv))
    got = nees(sol, truth, "velocity")
    np.testing.assert_allclose(got["nees"], expected, rtol=1e-9)
    m = evaluate(make_result(sol, []), truth)
    assert m.mean_nees_velocity == pytest.approx(expected, rel=1e-9)
    assert m.nees_velocity_in_95 == float(NEES_BAND[0] <= expected <= NEES_BAND[1])


def test_attitude_nees_with_a_known_rotation_vector() -> None:
    """The estimate is the truth turned back by a known phi, C_nb_hat = Exp(-phi) C_nb_true,
    i.e. C_nb_true = Exp(phi) C_nb_hat (docs/conventions.md): the attitude error is phi, not
    -phi, and its NEES is phiᵀ P⁻¹ phi, computed here by hand."""
    t = np.arange(0.0, 21.0, 1.0)
    truth = _moving_truth(t)
    sol = offset_solution(truth, np.zeros(3))
    phi = np.array([0.004, -0.003, 0.02])  # rad, in n
    q_back = attitude.rotvec_to_quat(-phi)
    rows = truth[["roll_rad", "pitch_rad", "yaw_rad"]].to_numpy()
    est = np.array([
        attitude.quat_to_euler(attitude.quat_mult(q_back, attitude.euler_to_quat(*r)))
        for r in rows
    ])  # fmt: skip
    sol["roll_rad"], sol["pitch_rad"], sol["yaw_rad"] = est[:, 0], est[:, 1], est[:, 2]
    got_phi = block_errors(sol, truth, "attitude")[["e_0", "e_1", "e_2"]].to_numpy()
    np.testing.assert_allclose(got_phi, np.broadcast_to(phi, got_phi.shape), atol=1e-10)

    sd = np.array([0.002, 0.002, 0.01])
    rho = np.array([[1.0, -0.4, 0.5], [-0.4, 1.0, 0.3], [0.5, 0.3, 1.0]])
    P = rho * np.outer(sd, sd)
    _set_block(sol, ("phi_N", "phi_E", "phi_D"), P)
    # phiᵀ P⁻¹ phi with P⁻¹ = D⁻¹ ρ⁻¹ D⁻¹ by the adjugate of ρ
    z = phi / sd
    a, b, c = rho[0, 1], rho[0, 2], rho[1, 2]
    adj = np.array(
        [[1 - c * c, b * c - a, a * c - b], [b * c - a, 1 - b * b, a * b - c],
         [a * c - b, a * b - c, 1 - a * a]]
    )  # fmt: skip
    det = 1 + 2 * a * b * c - a * a - b * b - c * c
    expected = float(z @ adj @ z) / det
    got = nees(sol, truth, "attitude")
    np.testing.assert_allclose(got["nees"], expected, rtol=1e-6)
    m = evaluate(make_result(sol, []), truth)
    assert m.mean_nees_attitude == pytest.approx(expected, rel=1e-6)
    assert math.isnan(m.mean_nees_velocity) is False  # the truth has velocity too


def test_nees_needs_the_truth_group() -> None:
    truth = straight_north().iloc[:5]
    sol = offset_solution(truth, np.zeros(3))
    with pytest.raises(ValueError, match="no velocity NEES"):
        nees(sol, truth, "velocity")
    with pytest.raises(ValueError, match="no attitude NEES"):
        nees(sol, truth, "attitude")
    with pytest.raises(ValueError, match="block"):
        nees(sol, truth, "bias")  # type: ignore[arg-type]


def test_fraction_in_band() -> None:
    lo, hi = NEES_BAND
    assert lo == pytest.approx(0.2157953, rel=1e-6)  # χ²(3) table values
    assert hi == pytest.approx(9.3484036, rel=1e-6)
    values = np.array([0.1, 0.3, 5.0, 9.3, 9.4, math.nan, lo, hi])
    assert fraction_in_band(values) == pytest.approx(5.0 / 7.0)  # the NaN is not counted
    assert math.isnan(fraction_in_band(np.array([math.nan])))
    assert fraction_in_band(np.array([1.0, 2.0, 20.0]), (0.5, 10.0)) == pytest.approx(2.0 / 3.0)


def test_distance_is_horizontal_despite_heave() -> None:
    """1 km north at 1 m/s while heaving ±2 m with an 8-s period: the 3-D path is about 1.5
    times longer, the scored distance is the horizontal 1 km (less the tangent line's 4 µm)."""
    t = np.arange(1001, dtype=float)
    heave = 2.0 * np.sin(2.0 * np.pi * t / 8.0)
    truth = truth_from_ned(t, np.stack([t, np.zeros_like(t), -heave], axis=-1))
    steps_3d = np.sqrt(1.0 + np.diff(heave) ** 2).sum()
    assert steps_3d > 1400.0
    assert travelled_distance(truth) == pytest.approx(1000.0, abs=1e-4)
    sol = offset_solution(truth, np.array([0.0, 3.0, 0.0]))
    m = evaluate(make_result(sol, []), truth)
    assert m.distance_m == pytest.approx(1000.0, abs=1e-4)
    assert m.relative_rmse_pct == pytest.approx(0.3, rel=1e-6)


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


def test_evaluate_says_how_much_of_the_run_the_reference_covers() -> None:
    """A 1000-s run scored against a reference of its first 400 s covers 0.4 of it (and the
    metrics say so, with a warning); a reference with a 300-s hole covers 0.7; a whole one 1,
    and so does one with a 0.5-s hiccup at 1 Hz... which is no hole (steps ≤ 10 × the median)."""
    truth = straight_north()
    sol = offset_solution(truth, np.array([0.0, 3.0, 0.0]))
    whole = evaluate(make_result(sol, []), truth)
    assert whole.run_duration_s == 1000.0 and whole.reference_coverage == pytest.approx(1.0)
    assert evaluate_module.coverage_warning(whole) is None
    first = evaluate(make_result(sol, []), truth.iloc[:401])
    assert first.duration_s == 400.0 and first.run_duration_s == 1000.0
    assert first.reference_coverage == pytest.approx(0.4)
    warning = evaluate_module.coverage_warning(first)
    assert warning is not None and "covers 40.0 % of the run's 1000.0 s" in warning
    holed = truth[(truth["t_s"] <= 300.0) | (truth["t_s"] >= 600.0)]
    assert evaluate(make_result(sol, []), holed).reference_coverage == pytest.approx(0.7)
    t_ref = np.r_[np.arange(0.0, 500.0), 500.5, np.arange(501.0, 1001.0)]
    assert evaluate_module.reference_coverage(t_ref, np.array([0.0, 1000.0])) == 1.0
    assert evaluate_module.reference_coverage(np.array([5.0]), np.array([0.0, 10.0])) == 0.0
    assert evaluate_module.reference_coverage(np.array([5.0]), np.array([5.0])) == 1.0


def test_a_reference_on_another_clock_is_found_from_the_velocities() -> None:
    """A vehicle weaving (velocity east a sum of sines of 37-s and 89-s periods, north 1 m/s)
    and a reference stamped 18 s late (GPS time against UTC): reference_lag finds 18 s and
    evaluate warns; the reference on the run's clock gives 0, and one without velocity
    columns NaN. A vehicle at constant velocity shows no lag, and none is reported."""
    t = np.arange(0.0, 600.0, 0.1)
    w1, w2 = 2.0 * np.pi / 37.0, 2.0 * np.pi / 89.0
    ve = 0.5 * np.sin(w1 * t) + 0.3 * np.sin(w2 * t)
    east = 0.5 / w1 * (1.0 - np.cos(w1 * t)) + 0.3 / w2 * (1.0 - np.cos(w2 * t))
    truth = truth_from_ned(t, np.stack([t, east, np.zeros_like(t)], axis=-1))
    truth["vn_m_s"], truth["ve_m_s"], truth["vd_m_s"] = 1.0, ve, 0.0
    v = ["vn_m_s", "ve_m_s", "vd_m_s"]
    sol = offset_solution(truth.iloc[::10].reset_index(drop=True), np.zeros(3))
    sol[v] = truth[v].iloc[::10].to_numpy()
    assert evaluate_module.reference_lag(sol, truth) == 0.0
    late = truth.assign(t_s=truth["t_s"] + 18.0)
    assert evaluate_module.reference_lag(sol, late) == pytest.approx(18.0, abs=0.11)
    warning = evaluate_module.lag_warning(evaluate(make_result(sol, []), late))
    assert warning is not None and "stamps 18.0 s late" in warning
    assert math.isnan(evaluate_module.reference_lag(sol, truth.drop(columns="ve_m_s")))
    still = truth.assign(ve_m_s=0.0)
    late_still = still.assign(t_s=still["t_s"] + 18.0)
    assert evaluate_module.reference_lag(sol.assign(ve_m_s=0.0), late_still) == 0.0


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


def _nees_by_eig_and_solve(e: np.ndarray, P: np.ndarray) -> np.ndarray:
    """The NEES as computed before the closed form: eigenvalues for definiteness, LU solve."""
    out = np.full(e.shape[0], np.nan)
    ok = np.all(np.isfinite(e), axis=1) & np.all(np.isfinite(P), axis=(1, 2))
    eig = np.linalg.eigvalsh(P[ok])
    ok[ok] = eig[:, 0] > 1e-12 * np.maximum(eig[:, -1], 1e-300)
    x = np.linalg.solve(P[ok], e[ok][..., None])[..., 0]
    out[ok] = np.einsum("ni,ni->n", e[ok], x)
    return out


def _random_covariances(
    rng: np.random.Generator, n: int, d: int, log10_cond: np.ndarray
) -> np.ndarray:
    """Random rotations of diagonal matrices with the given condition numbers, scales over
    ten decades."""
    q, _ = np.linalg.qr(rng.normal(size=(n, d, d)))
    lam = 10.0 ** (-log10_cond[:, None] * rng.uniform(0.0, 1.0, (n, d)))
    lam[:, 0], lam[:, -1] = 1.0, 10.0**-log10_cond  # the extremes exactly
    scale = 10.0 ** rng.uniform(-5.0, 5.0, n)
    return np.asarray(np.einsum("nij,nj,nkj->nik", q, lam * scale[:, None], q), dtype=float)


@pytest.mark.parametrize("d", [1, 2, 3])
def test_nees_closed_form_matches_eigenvalues_and_solve(d: int) -> None:
    rng = np.random.default_rng(15)
    n = 4000
    log10_cond = rng.uniform(0.0, 8.0, n)
    P = _random_covariances(rng, n, d, log10_cond)
    e = rng.normal(size=(n, d)) * np.sqrt(np.einsum("nii->ni", P))
    if d > 1:
        # around the definiteness threshold, singular, indefinite and zero matrices
        near = 10.0 ** rng.uniform(-13.0, -11.0, 300)
        P[:300] = _random_covariances(rng, 300, d, -np.log10(near))
        P[300:310, :, :] = 0.0
        P[310:320] = -P[310:320]
        P[320:330, 0, 1] = P[320:330, 1, 0] = 3.0 * np.sqrt(P[320:330, 0, 0] * P[320:330, 1, 1])
    e[330:335, 0] = np.nan
    P[335:340, -1, -1] = np.inf
    got, want = nees_from(e, P), _nees_by_eig_and_solve(e, P)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    assert np.isnan(want).sum() >= 10  # the bad rows were bad
    well = np.isfinite(want) & (np.arange(n) >= 340) & (log10_cond <= 4.0)
    np.testing.assert_allclose(got[well], want[well], rtol=1e-12)
    # Both are backward stable: they differ by rounding amplified by P's condition number.
    finite = np.isfinite(want)
    eig = np.linalg.eigvalsh(P[finite])
    cond = eig[:, -1] / eig[:, 0]
    assert np.all(np.abs(got[finite] - want[finite]) <= 1e-14 * cond * np.abs(want[finite]))


def test_attitude_errors_closed_form_match_scipy_rotations() -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(7)
    n = 5000
    true = np.stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.5, 1.5, n),
                     rng.uniform(-np.pi, np.pi, n)], axis=1)  # fmt: skip
    # errors from none to nearly half a turn, with a 2π yaw wrap on some
    size = 10.0 ** rng.uniform(-9.0, 0.49, (n, 1)) * rng.choice([-1.0, 1.0], (n, 3))
    est = true + size * rng.uniform(0.2, 1.0, (n, 3))
    est[:100] = true[:100]
    est[50:100, 2] += 2.0 * np.pi
    q = evaluate_module.euler_quaternions(*true.T)
    C = Rotation.from_euler("ZYX", true[:, ::-1])
    np.testing.assert_allclose(np.abs(np.sum(q[:, [1, 2, 3, 0]] * C.as_quat(), axis=1)), 1.0,
                               atol=1e-14)  # fmt: skip
    got = evaluate_module.rotation_vectors_between(q, evaluate_module.euler_quaternions(*est.T))
    want = (C * Rotation.from_euler("ZYX", est[:, ::-1]).inv()).as_rotvec()
    np.testing.assert_allclose(got[:100], 0.0, atol=1e-14)  # 2π added to yaw: rounded
    norm = np.linalg.norm(want, axis=1)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-15)
    big = norm > 1e-3  # relative to the rotation angle, where rounding is no longer all
    assert np.all(np.linalg.norm(got - want, axis=1)[big] <= 1e-12 * norm[big])


def _smoothed_run(folder: Path, forward_nan_row: int | None = None) -> Path:
    """A smoothed run folder (3 m east smoothed, 5 m forward) with its truth.parquet; the
    forward position's latitude NaN at ``forward_nan_row``."""
    from adaptnav.api.results import save

    truth = straight_north().iloc[:201]
    forward = offset_solution(truth, np.array([0.0, 5.0, 0.0]))
    if forward_nan_row is not None:
        forward.loc[forward_nan_row, "lat_rad"] = math.nan
    result = replace(
        make_result(offset_solution(truth, np.array([0.0, 3.0, 0.0])), []),
        forward=forward,
        meta={"smoother": {"nodes": 201, "update_nodes": 0, "failed_nodes": 0, "store_bytes": 1}},
    )
    save(result, folder, truth=truth)
    return folder


def test_a_damaged_forward_solution_is_named_as_such(tmp_path: Path) -> None:
    """Before 0.4.6 a NaN in forward.parquet was reported as the smoothed solution's ("solution
    row 100, lat_rad"), and any other problem of it against truth.parquet."""
    from typer.testing import CliRunner

    from adaptnav.cli import app

    good = _smoothed_run(tmp_path / "good")
    res = CliRunner().invoke(app, ["evaluate", str(good), "--json", "-q"])
    assert res.exit_code == 0, res.output
    assert '"forward_rmse_m": 5.0' in res.output
    bad = _smoothed_run(tmp_path / "bad", forward_nan_row=100)
    with pytest.raises(ValueError, match=r"^forward row 100, lat_rad: nan is not a finite"):
        forward_metrics(load(bad), straight_north())
    res = CliRunner().invoke(app, ["evaluate", str(bad), "-q"])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert f"{bad / 'forward.parquet'}: forward row 100, lat_rad: nan" in " ".join(
        res.output.split()
    )


def test_no_percentage_of_a_distance_below_a_metre() -> None:
    """A run that barely moves: 3.99 m of error over 6e-9 m travelled gave 66 billion % before
    0.4.6 (only a zero distance gave NaN). Below evaluate.MIN_DISTANCE_M (1 m) it is NaN; from
    1 m on the percentage is given."""
    assert evaluate_module.MIN_DISTANCE_M == 1.0
    assert math.isnan(relative_rmse_pct(3.99, 6e-9))
    assert math.isnan(relative_rmse_pct(3.99, 0.999))
    assert relative_rmse_pct(3.0, 1.0) == pytest.approx(300.0)
    truth = straight_north().iloc[:3]  # 2 m
    still = truth.copy()
    still[["lat_rad", "lon_rad"]] = truth[["lat_rad", "lon_rad"]].iloc[0].to_numpy()
    sol = offset_solution(still, np.array([0.0, 4.0, 0.0]))
    m = evaluate(make_result(sol, []), still)
    assert m.distance_m < 1e-6 and math.isnan(m.relative_rmse_pct)  # rounding: not 0
    drift = outage_drift(sol, still, [(0.0, 2.0)])
    assert math.isnan(drift["drift_pct"].iloc[0])
    moving = outage_drift(offset_solution(truth, np.array([0.0, 4.0, 0.0])), truth, [(0.0, 2.0)])
    assert moving["drift_pct"].iloc[0] == pytest.approx(200.0, rel=1e-6)  # 4 m over 2 m


def test_the_mean_nees_says_over_how_many_epochs_it_is() -> None:
    """Epochs whose P block is not positive definite have no NEES; before 0.4.6 the mean left
    them out without a word (a forward position NEES over 127 of 201 epochs, a smoothed one
    over none: null with no reason). Now Metrics counts them and evaluate warns."""
    truth = straight_north().iloc[:101]
    sol = offset_solution(truth, np.array([0.0, 3.0, 0.0]))
    full = evaluate(make_result(sol, []), truth)
    assert full.nees_position_epochs == 101 and full.nees_velocity_epochs is None
    assert evaluate_module.nees_warning(full) is None
    sol.loc[:29, "sd_dr_N"] = 0.0  # singular: no NEES at these 30 epochs
    part = evaluate(make_result(sol, []), truth)
    assert part.nees_position_epochs == 71 and part.mean_nees_position == pytest.approx(9.0)
    assert part.to_dict()["nees_position_epochs"] == 71
    warning = evaluate_module.nees_warning(part)
    assert warning is not None and "mean NEES of position over 71 of 101 epochs" in warning
    sol["sd_dr_N"] = 0.0
    none = evaluate(make_result(sol, []), truth)
    assert none.nees_position_epochs == 0 and math.isnan(none.mean_nees_position)
    warning = evaluate_module.nees_warning(none)
    assert warning is not None and "position over none of the 101 epochs" in warning


def test_evaluate_shows_and_warns_of_epochs_left_out_of_the_nees(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from adaptnav.api.results import save
    from adaptnav.cli import app

    truth = straight_north().iloc[:101]
    sol = offset_solution(truth, np.array([0.0, 3.0, 0.0]))
    sol.loc[:29, "sd_dr_N"] = 0.0
    folder = save(make_result(sol, []), tmp_path / "run", truth=truth)
    res = CliRunner().invoke(app, ["evaluate", str(folder), "--json", "-q"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["nees_position_epochs"] == 71 and doc["nees_attitude_epochs"] is None
    assert any("position over 71 of 101 epochs" in w for w in doc["warnings"])
    res = CliRunner().invoke(app, ["evaluate", str(folder), "-q"])
    text = " ".join(res.output.split())
    assert "NEES position, epochs in the mean (of 101) │ 71" in text
    assert "warning: mean NEES of position over 71 of 101 epochs" in text
