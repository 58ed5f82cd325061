"""What the motion over an IMU hole can be (mission.imu_holes; docs/robustness.md, 'The σ
over a hole'), against hand calculations."""

from __future__ import annotations

import numpy as np
import pytest

from adaptnav.mission.imu_holes import (
    find_holes,
    find_rate_holes,
    recent_variance,
    repair_errors,
)


def _quadratic_error(m: int, k: int) -> float:
    """The repair's error e over a window of x_u = u² (u = -1 the row before, 0..m-1 the
    window), by hand: Σ u² = (m-1) m (2m-1)/6, the last k's T_k = Σ_{m-k..m-1} u², the row
    before 1. A linear part a + b u of the increments is filled exactly by the trapezoid when
    k = 1, and e is the same whatever the window's place: x = (j0 + u)² differs from u² by a
    linear part."""
    total = (m - 1) * m * (2 * m - 1) / 6
    tail = sum(u * u for u in range(m - k, m))
    return total - tail - (m - k) * 0.5 * (1.0 + tail / k)


def test_a_ramp_gives_the_error_of_the_stretch_by_hand() -> None:
    """A hole within the default max_gap_s (m <= 5) is stretched. Increments on a ramp
    x_j = a + b j: over a window of m rows whose last k hold the repair's increments,
    Σ x - (m/k) Σ_last_k x = b m (k - m) / 2 (the sums of j by hand), in every window."""
    n, a, b = 400, 0.3, 0.002
    x = a + b * np.arange(n, dtype=float)
    dth = np.stack([x, 2 * x, np.zeros(n)], axis=1)
    dv = np.stack([np.zeros(n), x, -x], axis=1)
    for m, k in ((2, 1), (5, 1), (4, 3)):
        sq, ends = repair_errors(dth, dv, m, k)
        e = b * m * (k - m) / 2
        want = np.array([0.0, e, -e, e, 2 * e, 0.0]) ** 2  # velocity, then attitude
        np.testing.assert_allclose(sq, np.broadcast_to(want, sq.shape), rtol=1e-9, atol=1e-20)
        assert ends[0] == m and np.all(np.diff(ends) == m)


def test_a_quadratic_gives_the_error_of_the_filling_by_hand() -> None:
    """A longer hole is filled with the trapezoid. Increments x_j = c j² (a steadily changing
    rate of turn): the same e in every window, its square the mean; a ramp alone (k = 1)
    costs nothing."""
    n, c = 400, 1e-7
    j = np.arange(n, dtype=float)
    dth = np.stack([c * j * j, 0.3 + 0.002 * j, np.zeros(n)], axis=1)
    dv = np.stack([np.zeros(n), -c * j * j, 2 * c * j * j], axis=1)
    for m in (6, 10, 40):
        sq, ends = repair_errors(dth, dv, m, 1)
        e = c * _quadratic_error(m, 1)
        want = np.array([0.0, e, 2 * e, e, 0.0, 0.0]) ** 2  # velocity, then attitude
        np.testing.assert_allclose(sq, np.broadcast_to(want, sq.shape), rtol=1e-6, atol=1e-24)
        assert ends[0] == m and np.all(np.diff(ends) == (m if (n - 1) // m >= 8 else 1))
    assert _quadratic_error(6, 1) == -35.0  # 55 - 25 - 5 (1 + 25) / 2


def test_rows_holding_part_of_the_hole() -> None:
    """k of the m periods held by the row (an IMU that accumulates until read): on a ramp
    x_u = u the filling leaves e = Σ u - T_k - (m - k)(-1 + T_k / k)/2, by hand."""
    n = 300
    x = np.arange(n, dtype=float) * 1e-5
    dth = np.stack([x, x, x], axis=1)
    for m, k in ((7, 2), (12, 5)):
        tail = sum(range(m - k, m))
        e = 1e-5 * ((m - 1) * m / 2 - tail - (m - k) * 0.5 * (-1.0 + tail / k))
        sq, _ = repair_errors(dth, dth, m, k)
        np.testing.assert_allclose(sq, e * e, rtol=1e-6)


def test_a_constant_rate_costs_nothing() -> None:
    """A steady turn at constant acceleration: the stretch is exact, the variance zero."""
    n = 1000
    dth = np.tile([0.0, 0.0, 0.0003], (n, 1))
    dv = np.tile([0.01, 0.0, -0.098], (n, 1))
    assert np.all(recent_variance(dth, dv, 100, 1) < 1e-24)  # rounding: 1e-12 m/s, rad


def test_holes_are_found_with_their_periods_rows_and_local_motion() -> None:
    """Two holes: 4 periods lost before index 300 (m = 5, k = 1) and 1 before index 2500
    (m = 2). The motion is still but for a ramp of the x gyro from 200 to 400; the table is
    short (30 s), so every window is near both holes: each takes the mean square of the
    stretch's error over the table."""
    n, p, c = 3000, 0.01, 1e-4
    dth, dv = np.zeros((n, 3)), np.zeros((n, 3))
    dth[200:400, 0] = c * np.arange(200)
    own = np.full(n, p)
    dt = own.copy()
    dt[300], dt[2500] = 5 * p, 2 * p
    rows = np.arange(n) + 7
    holes = find_holes(dth, dv, own, dt, rows, p)
    assert holes.index.tolist() == [300, 2500] and holes.row.tolist() == [307, 2507]
    assert holes.periods.tolist() == [5, 2] and holes.held.tolist() == [1, 1]
    sq5, ends5 = repair_errors(dth, dv, 5, 1)
    inside = (ends5 >= 205) & (ends5 < 400)
    assert sq5[inside, 3] == pytest.approx((c * 5 * (1 - 5) / 2) ** 2, rel=1e-9)
    assert holes.var[0, 3] == pytest.approx(sq5[:, 3].mean(), rel=1e-12)
    sq2, _ = repair_errors(dth, dv, 2, 1)
    assert holes.var[1, 3] == pytest.approx(sq2[:, 3].mean(), rel=1e-12)
    assert np.all(holes.var[:, [0, 1, 2, 4, 5]] == 0.0)


def test_local_motion_raises_the_variance_above_the_whole_tables() -> None:
    """A long still table with waves only near the hole: the hole's variance is the waves'
    (the windows within 120 s of it), not the table's mean diluted by the still hours."""
    n, p = 200_000, 0.01
    t = p * np.arange(n)
    dth = np.zeros((n, 3))
    waves = (t > 1000.0) & (t < 1300.0)
    dth[waves, 0] = 0.05 * p * np.sin(2 * np.pi * t[waves] / 8.0)
    dv = np.zeros((n, 3))
    own = np.full(n, p)
    dt = own.copy()
    at = int(1150.0 / p)
    dt[at] = 101 * p
    holes = find_holes(dth, dv, own, dt, np.arange(n), p)
    sq, ends = repair_errors(dth, dv, 101, 1)
    assert holes.var[0, 3] > 5 * sq[:, 3].mean()
    near = np.abs(ends - at) <= 12000  # within 120 s, to the runs of an eighth of that
    assert holes.var[0, 3] == pytest.approx(sq[near, 3].mean(), rel=0.1)


def test_rate_holes_take_the_error_of_the_trapezoid_of_rates_by_hand() -> None:
    """An IMU in rates (since 0.4.13): the hole between samples i and i + 1 is interval i, its
    row the file row of sample i + 1. Rates ω_u = c u² on the z gyro: the trapezoid across m
    periods from sample s against the trapezoids of each period, per unit p c,
    Σ_{u=s+1}^{s+m-1} u² - (m - 1)(s² + (s + m)²)/2 = -(m - 1) m (m + 1)/6 whatever s (by hand:
    the terms in s cancel; m = 2, s = 0: 1 - 4/2 = -1); a linear rate (the accelerometers'
    ramp) is integrated exactly. An interval of 1.4 periods (a late stamp) is no hole."""
    n, p, c = 3000, 0.01, 1e-6
    u = np.arange(n, dtype=float)
    gyro = np.stack([np.zeros(n), np.zeros(n), c * u * u], axis=1)
    accel = np.stack([0.2 + 0.001 * u, np.zeros(n), np.full(n, -9.8)], axis=1)
    gaps = np.full(n - 1, p)
    gaps[299], gaps[2499], gaps[1000] = 5 * p, 2 * p, 1.4 * p
    rows = np.arange(n) + 7
    holes = find_rate_holes(gyro, accel, gaps, rows, p)
    assert holes.index.tolist() == [299, 2499] and holes.row.tolist() == [307, 2507]
    assert holes.periods.tolist() == [5, 2] and holes.held.tolist() == [1, 1]
    for j, m in enumerate((5, 2)):
        e = p * c * (m - 1) * m * (m + 1) / 6
        assert holes.var[j, 5] == pytest.approx(e * e, rel=1e-6)
    assert np.all(holes.var[:, :5] < 1e-24)  # the ramp and the constants: rounding only
    assert holes.var[0, 5] == pytest.approx((20 * p * c) ** 2, rel=1e-6)  # m = 5: 4·5·6/6


def test_an_imu_in_rates_without_holes_has_none() -> None:
    """Regular and slightly irregular stamps (up to 0.45 period late) are no hole."""
    n, p = 2000, 0.01
    rng = np.random.default_rng(3)
    gyro, accel = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    gaps = p * (1.0 + rng.uniform(-0.45, 0.45, n - 1))
    assert len(find_rate_holes(gyro, accel, gaps, np.arange(n), p)) == 0


def test_jittered_rate_stamps_are_no_hole() -> None:
    """A ROS 2 driver's stamps jittered by up to 0.7 of a period, a late stamp followed by an
    early one (intervals 1.6 p then 0.4 p): each long interval lies beside a short one, no
    sample is lost, and nothing is a hole (the first 0.4.13 version made every one of them a
    2-period hole with a σ and a repair). A sample really lost between regular ones is."""
    n, p = 2000, 0.01
    rng = np.random.default_rng(8)
    gyro, accel = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    late = rng.uniform(0.5, 0.7, n)
    late[::2] = 0.0  # every other sample late by 0.5-0.7 period
    t = p * (np.arange(n) + late)
    gaps = np.diff(t)
    assert np.count_nonzero(gaps > 1.5 * p) > 300  # the first rule's "holes"
    assert len(find_rate_holes(gyro, accel, gaps, np.arange(n), p)) == 0
    regular = np.full(n - 1, p)
    regular[700] = 2 * p
    assert find_rate_holes(gyro, accel, regular, np.arange(n), p).index.tolist() == [700]


def test_a_hole_longer_than_the_table_is_known_no_better_than_its_longest_windows() -> None:
    """A hole of 1000 periods in a table of 400 rows (max_gap_s raised; a stream keeps only
    the last 120 s): no window of its length fits. A longer hole is no better known than a
    shorter one, so its variances are at least those of the longest windows the rows hold
    twice over (199 rows), and an angle at most π (unknown). Up to the first 0.4.13 version:
    zeros, no σ added and no wide-hole warning (odd_inputs_eval's imu-hole-3000s-max-gap-huge,
    helper aud2)."""
    n, p = 400, 0.01
    u = np.arange(n)
    dth, dv = np.zeros((n, 3)), np.zeros((n, 3))
    dth[:, 0] = 1e-3 * np.sin(2 * np.pi * u / 170)  # waves
    dv[:, 1] = 1e-3 * np.cos(2 * np.pi * u / 230)
    own = np.full(n, p)
    dt = own.copy()
    dt[200] = 1000 * p
    holes = find_holes(dth, dv, own, dt, np.arange(n), p)
    assert holes.periods.tolist() == [1000]
    sq, _ = repair_errors(dth, dv, (n - 1) // 2, 1)
    longest = sq.mean(axis=0)
    assert longest[1] > 0.0 and longest[3] > 0.0
    assert holes.var[0, 1] >= longest[1] and holes.var[0, 3] >= longest[3]
    assert np.all(holes.var[0, 3:] <= np.pi**2)
    # The stream's twin over the same samples.
    recent = recent_variance(dth, dv, 1000, 1)
    assert recent[1] >= longest[1] and recent[3] >= longest[3]
    big = recent_variance(100.0 * dth, dv, 10**6, 1)
    assert big[3] == pytest.approx(np.pi**2)
