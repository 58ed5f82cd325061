"""What the motion over an IMU hole can be (mission.imu_holes; docs/robustness.md, 'The σ
over a hole'), against hand calculations."""

from __future__ import annotations

import numpy as np
import pytest

from adaptnav.mission.imu_holes import (
    find_holes,
    recent_variance,
    repair_errors,
)


def test_a_ramp_gives_the_error_of_the_stretch_by_hand() -> None:
    """Increments on a ramp x_j = a + b j: over a window of m rows whose last k hold the
    repair's increments, Σ x - (m/k) Σ_last_k x = b m (k - m) / 2 (the sums of j by hand),
    in every window; the mean square its square."""
    n, a, b = 400, 0.3, 0.002
    x = a + b * np.arange(n, dtype=float)
    dth = np.stack([x, 2 * x, np.zeros(n)], axis=1)
    dv = np.stack([np.zeros(n), x, -x], axis=1)
    for m, k in ((2, 1), (5, 1), (7, 3), (40, 1)):
        sq, ends = repair_errors(dth, dv, m, k)
        e = b * m * (k - m) / 2
        want = np.array([0.0, e, -e, e, 2 * e, 0.0]) ** 2  # velocity, then attitude
        np.testing.assert_allclose(sq, np.broadcast_to(want, sq.shape), rtol=1e-9, atol=1e-20)
        assert ends[0] == m - 1 and np.all(np.diff(ends) == (m if n // m >= 8 else 1))


def test_a_constant_rate_costs_nothing() -> None:
    """A steady turn at constant acceleration: the stretch is exact, the variance zero."""
    n = 1000
    dth = np.tile([0.0, 0.0, 0.0003], (n, 1))
    dv = np.tile([0.01, 0.0, -0.098], (n, 1))
    assert np.all(recent_variance(dth, dv, 100, 1) < 1e-24)  # rounding: 1e-12 m/s, rad


def test_holes_are_found_with_their_periods_rows_and_local_motion() -> None:
    """Two holes: 4 periods lost before index 300 (m = 5, k = 1) and 1 before index 2500
    (m = 2). The motion is still but for a ramp of the x gyro from 200 to 400: the first
    hole, inside it, takes the windows near it (their mean square, larger than the whole
    table's); the second, far from it, the whole table's mean square."""
    n, p = 3000, 0.01
    dth, dv = np.zeros((n, 3)), np.zeros((n, 3))
    dth[200:400, 0] = 1e-4 * np.arange(200)
    own = np.full(n, p)
    dt = own.copy()
    dt[300], dt[2500] = 5 * p, 2 * p
    rows = np.arange(n) + 7
    holes = find_holes(dth, dv, own, dt, rows, p)
    assert holes.index.tolist() == [300, 2500] and holes.row.tolist() == [307, 2507]
    assert holes.periods.tolist() == [5, 2] and holes.held.tolist() == [1, 1]
    # the ramp's windows of 5: e = b m (k - m) / 2 = -1e-4 * 10 in the x gyro, others 0
    sq5, ends5 = repair_errors(dth, dv, 5, 1)
    in_ramp = (ends5 >= 204) & (ends5 < 400)
    assert sq5[in_ramp, 3] == pytest.approx(1e-6, rel=1e-9)
    near = (ends5 >= 300 - 12000) & (ends5 <= 300 + 12000)  # 120 s at 100 Hz: every window
    assert holes.var[0, 3] == pytest.approx(sq5[near, 3].mean(), rel=1e-12)
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
    near = np.abs(ends - at) <= 12000
    assert holes.var[0, 3] == pytest.approx(sq[near, 3].mean(), rel=1e-12)
