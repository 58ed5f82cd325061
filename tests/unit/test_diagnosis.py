"""The after-run diagnosis of sensors at odds with the rest and of correlated innovations
(api/diagnosis.py), on ledgers built by hand: the window arithmetic, what counts as
disagreement, and when innovations count as correlated."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from adaptnav.api import diagnosis as dg
from adaptnav.api.results import LEDGER_COLUMNS, typed_ledger
from adaptnav.engine.batch import SensorChannel
from adaptnav.estimation.noise.fixed import FixedNoise
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.inclinometer import PendulumInclinometer
from adaptnav.sensors.nhc import NonHolonomic

R_DVL = np.array([0.048**2] * 3)


def ledger(
    sensor: str, t: np.ndarray, fate: list[str], reason: list[str], r: np.ndarray
) -> pd.DataFrame:
    """Ledger rows of one three-component sensor (innovations zero)."""
    n = t.size
    cols: dict[str, object] = {c: np.full(n, math.nan) for c in LEDGER_COLUMNS}
    cols.update(t=t, t_epoch=t, sensor=sensor, row=np.arange(n), fate=fate, reason=reason,
                iterations=np.zeros(n, dtype=np.int64))  # fmt: skip
    for j in range(3):
        cols[f"nu_{j}"] = np.zeros(n)
        cols[f"r_{j}"] = r[:, j]
    return typed_ledger(pd.DataFrame(cols))


def test_windows_of_a_50_s_stretch() -> None:
    """1 Hz for 200 s, readings 50-99 bad. The window [t, t + 60] holds 61 readings; the worst
    starts at 50 (50 of 61 bad); a window holds more than 30.5 bad ones from start 20
    (readings 50-80: 31) to start 69 (69-99: 31), whose last reading is 129."""
    t = np.arange(200.0)
    bad = (t >= 50) & (t < 100)
    worst, t_from, t_to = dg.windows(t, bad)
    assert worst == pytest.approx(50 / 61)
    assert (t_from, t_to) == (20.0, 129.0)


def test_a_burst_under_half_a_window_is_not_flagged() -> None:
    t = np.arange(200.0)
    worst, t_from, t_to = dg.windows(t, (t >= 50) & (t < 70))  # 20 of at most 61
    assert worst == pytest.approx(20 / 61)
    assert math.isnan(t_from) and math.isnan(t_to)


def test_a_burst_at_the_end_is_judged_in_a_whole_window() -> None:
    """24 bad readings at the end of a 400-s run at 1 Hz (A-KIT segment 7's second fault
    draw): the last window holding them is [339, 399], 61 readings, 24 bad. Before, the
    windows starting near the end held fewer readings, and 24 of the last 28 warned."""
    t = np.arange(400.0)
    worst, t_from, _ = dg.windows(t, t >= 376)
    assert worst == pytest.approx(24 / 61)
    assert math.isnan(t_from)
    # A run shorter than the window is one window.
    short = np.arange(40.0)
    assert dg.windows(short, short >= 10)[0] == pytest.approx(30 / 40)


def test_too_few_readings_are_not_judged() -> None:
    t = np.arange(float(dg.MIN_READINGS - 1))
    assert dg.windows(t, np.ones(t.size, dtype=bool))[0] == 0.0
    # Ten readings 100 s apart: every window holds one reading, none is judged.
    assert dg.windows(np.arange(10) * 100.0, np.ones(10, dtype=bool))[0] == 0.0


def test_rejections_and_r_at_the_limit_count_and_nothing_else() -> None:
    """3 Hz for 300 s. From 100 to 200 s the readings alternate: rejected by the guard, then
    used with R̂ at the ceiling (robust's 100); a covariance repair and an R̂ just under the
    limit do not count, and a depth meter without trouble gives no warning."""
    t = np.arange(900) / 3.0
    fate, reason = ["used"] * t.size, [""] * t.size
    r = np.tile(R_DVL, (t.size, 1))
    inside = np.flatnonzero((t >= 100) & (t < 200))
    for k, i in enumerate(inside):
        if k % 2 == 0:
            fate[i], reason[i] = "rejected", "guard chi2 (nominal R)"
        else:
            r[i, 1] = 100.0 * R_DVL[1]
    repaired = int(np.flatnonzero(t >= 250)[0])
    fate[repaired], reason[repaired] = "rejected", "S not positive definite: P repaired"
    r[np.flatnonzero(t >= 260)[:30], 0] = 0.999 * 100.0 * R_DVL[0]
    led = ledger("dvl", t, fate, reason, r)
    depth = ledger("depth", t, ["used"] * t.size, [""] * t.size, np.tile(R_DVL, (t.size, 1)))
    found = dg.diagnose(
        pd.concat([led, depth], ignore_index=True),
        {"dvl": R_DVL, "depth": R_DVL},
        {"dvl": 100.0, "depth": 100.0},
    )
    assert [w.sensor for w in found] == ["dvl"]
    w = found[0]
    assert (w.readings, w.rejected, w.at_limit) == (900, 150, 150)
    assert w.worst_share == pytest.approx(1.0)
    assert 100.0 - 60.0 < w.t_from < 100.0 and 200.0 < w.t_to < 200.0 + 60.0
    assert w.message.startswith("dvl: at odds with the INS and the other sensors from t = ")
    assert "150 of 900 rejected, 150 used with R̂ at 100 × its nominal variance" in w.message
    assert "mounting_rpy_deg" in w.message


def test_an_unbounded_r_counts_from_the_ratio() -> None:
    """Without a ceiling (VB-MAESKF, MAESKF) an R̂ counts from RATIO × the nominal variance:
    the simulated trials' tenfold σ (100 × the variance) does not."""
    t = np.arange(300.0)
    r = np.tile(R_DVL, (t.size, 1))
    r[:, 2] = 100.0 * R_DVL[2]
    led = ledger("dvl", t, ["used"] * t.size, [""] * t.size, r)
    assert dg.diagnose(led, {"dvl": R_DVL}, {"dvl": math.inf}) == []
    r[:, 2] = dg.RATIO * R_DVL[2]
    led = ledger("dvl", t, ["used"] * t.size, [""] * t.size, r)
    (w,) = dg.diagnose(led, {"dvl": R_DVL}, {"dvl": math.inf})
    assert w.at_limit == 300 and f"{dg.RATIO:g} × its nominal variance" in w.message


# --- correlated innovations --------------------------------------------------------------------


def _innovations(sensor: str, nu: np.ndarray) -> pd.DataFrame:
    """Ledger rows of one sensor, every reading used, with innovations ``nu`` (n, d)."""
    n, d = nu.shape
    frame = ledger(sensor, np.arange(n, dtype=float), ["used"] * n, [""] * n, np.ones((n, 3)))
    for j in range(d):
        frame[f"nu_{j}"] = nu[:, j]
    return frame


def _ar1(rho: float, n: int, d: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.standard_normal((n, d))
    out = np.empty_like(e)
    out[0] = e[0]
    for k in range(1, n):
        out[k] = rho * out[k - 1] + e[k]
    return out


def test_white_innovations_give_no_correlation_warning() -> None:
    channel = SensorChannel(DVL(0.048), 1 / 3, FixedNoise())
    for seed in range(5):
        white = _innovations("dvl", np.random.default_rng(seed).standard_normal((2000, 3)))
        assert dg.correlated(white, [channel]) == []


def test_the_advice_on_correlated_innovations_is_the_sensor_kinds() -> None:
    """A drifting inclinometer leaves correlated innovations: its warning says to estimate its
    biases (up to 0.4.6 it gave a GNSS's and a DVL's advice, nothing for an inclinometer)."""
    drift = np.cumsum(np.random.default_rng(8).standard_normal((3000, 2)), axis=0)
    channel = SensorChannel(PendulumInclinometer(0.002), 0.2, FixedNoise())
    (w,) = dg.correlated(_innovations("inclinometer", drift), [channel])
    assert 'estimate its biases (estimate = ["bias"]' in w.message
    assert "min_interval_s" not in w.message and "misalignment" not in w.message


def test_correlated_innovations_are_flagged_with_their_factor() -> None:
    """An AR(1) series with ρ = 0.6 on the y axis: long-run variance factor (1 + ρ)/(1 - ρ) = 4
    (worked by hand), the component named; ρ = 0.2 (factor 1.5) is not flagged; a motion
    constraint and a sensor with too few readings are not judged."""
    rng = np.random.default_rng(3)
    nu = rng.standard_normal((3000, 3))
    nu[:, 1] = _ar1(0.6, 3000, 1, 4)[:, 0]
    channel = SensorChannel(DVL(0.048), 1 / 3, FixedNoise())
    (w,) = dg.correlated(_innovations("dvl", nu), [channel])
    assert (w.sensor, w.component, w.readings, w.kind) == ("dvl", "dvl_y", 3000, "correlated")
    assert w.factor == pytest.approx(4.0, rel=0.25)
    assert "dvl_y: long-run variance" in w.message and '["scale", "misalignment"]' in w.message
    assert "min_interval_s" not in w.message  # the GNSS's advice, not the DVL's
    nu[:, 1] = _ar1(0.2, 3000, 1, 5)[:, 0]
    assert dg.correlated(_innovations("dvl", nu), [channel]) == []
    nhc = SensorChannel(NonHolonomic(0.1), 0.1, FixedNoise())
    assert dg.correlated(_innovations("nhc", _ar1(0.9, 3000, 2, 6)), [nhc]) == []
    short = _innovations("dvl", _ar1(0.9, dg.CORRELATED_READINGS - 1, 3, 7))
    assert dg.correlated(short, [channel]) == []


def test_calibration_scores_are_flagged_per_sensor_at_the_factor() -> None:
    """One warning per sensor with a state's factor ≥ CALIBRATION_FACTOR (2.0, from the white
    and slow-error runs of docs/calibration.md), naming its largest; below it, or unknown
    (None), nothing."""
    factors = [
        ("dvl", "dvl.scale", 5.3),
        ("dvl", "dvl.misalignment_yaw", 7.4),
        ("dvl", "dvl.misalignment_roll", None),
        ("depth", "depth.bias", 1.99),
        ("inclinometer", "inclinometer.bias_roll", dg.CALIBRATION_FACTOR),
    ]
    found = dg.calibration_correlated(factors)
    assert [(w.sensor, w.state, w.factor) for w in found] == [
        ("dvl", "dvl.misalignment_yaw", 7.4),
        ("inclinometer", "inclinometer.bias_roll", 2.0),
    ]
    assert found[0].as_dict()["kind"] == "calibration_correlated"
    assert found[0].message.startswith("dvl: the readings that estimate its calibration are")
    assert dg.calibration_correlated([("dvl", "dvl.scale", 1.3)]) == []
