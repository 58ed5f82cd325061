"""The simulator's IMU increments are exact to double precision (sim/kinematics.py,
docs/simulation.md, 'Exact increments').

Reference: 16-point Gauss-Legendre on every smooth piece of every interval, the pieces cut at
the joints the test reads from the trajectory's step profiles itself (not from
``Motion.breakpoints``), written out here independently of ``imu_increments``.

Bound: an increment ``∫ g dt`` over an interval of length h can be known only to the resolution
of its inputs: the instants carry at most ulp(t) of rounding, which moves g by up to
``ulp(t) max|ġ|``, and the arithmetic rounds at ε = 2⁻⁵² of the largest term, ``ε max|g|``
(gravity for Δv). The result and the reference each carry that much, so they may differ by

    2 h (ε max|g| + ulp(t_max) max|ġ|)

per component (max over the triad; ġ from differences of the signal at the instants), a figure
fixed by the floating-point format and the motion, not by the code under test. A quadrature
error does not hide under it: the same comparison with the joints hidden from the simulator
(a polynomial rule across them) is off by 10⁶ times the bound.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from adaptnav.core.units import DEG
from adaptnav.sim import kinematics as kin
from adaptnav.sim import scenarios
from adaptnav.sim import trajectory as tr

Array = np.ndarray
EPS = float(np.finfo(float).eps)


def _joints(traj: tr.Trajectory) -> Array:
    """Start and end of every smooth step of the profiles (trajectory.py, 'Smooth profiles')."""
    steps = (traj.speed, traj.course_rate, traj.depth, traj.sea_state)
    return np.unique(np.concatenate([np.r_[p.starts, p.starts + p.widths] for p in steps]))


def _reference(motion: kin.Motion, t: Array, joints: Array, nodes: int = 16) -> Array:
    """(N-1, 6) ``[Δθ, Δv]``: Gauss-Legendre with ``nodes`` nodes on each piece of each
    interval between the joints inside it."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    lo: list[float] = []
    hi: list[float] = []
    owner: list[int] = []
    for k in range(t.size - 1):
        inside = joints[(joints > t[k]) & (joints < t[k + 1])]
        edges = np.r_[t[k], inside, t[k + 1]]
        lo += edges[:-1].tolist()
        hi += edges[1:].tolist()
        owner += [k] * (edges.size - 1)
    a, b = np.array(lo), np.array(hi)
    half = 0.5 * (b - a)
    tau = (0.5 * (a + b))[:, None] + half[:, None] * x[None, :]
    g = np.hstack(kin.imu_rates(motion, tau.ravel())).reshape(a.size, nodes, 6)
    out = np.zeros((t.size - 1, 6))
    np.add.at(out, np.array(owner), np.einsum("pnc,pn->pc", g, half[:, None] * w[None, :]))
    return out


def _excess(motion: kin.Motion, t: Array, reference: Array) -> float:
    """max |increment - reference| / bound (module docstring) over intervals and triads."""
    got = np.hstack(kin.imu_increments(motion, t))
    g = np.hstack(kin.imu_rates(motion, t))
    h = np.diff(t)[:, None]
    worst = 0.0
    for triad in (slice(0, 3), slice(3, 6)):
        g_max = np.abs(g[:, triad]).max()
        g_dot = (np.abs(np.diff(g[:, triad], axis=0)) / h).max()
        bound = 2.0 * h[:, 0] * (EPS * g_max + float(np.spacing(np.abs(t).max())) * g_dot)
        err = np.abs(got[:, triad] - reference[:, triad]).max(axis=1)
        worst = max(worst, float((err / bound).max()))
    return worst


@pytest.fixture(scope="module")
def steep() -> tr.Trajectory:
    """70 s in waves from the start (sea state 1.6), with steep smooth steps (1 s minimum,
    0.5 m/s², 5°/s²): speed changes, two turns, a depth change, a sea-state change; 15 joints."""
    segments = (
        tr.Straight(20.0, 2.0),
        tr.Turn(60 * DEG, rate=6 * DEG),
        tr.DepthChange(12.0, 2.0, speed=1.0),
        tr.Turn(-30 * DEG, rate=4 * DEG, speed=2.5),
        tr.Straight(15.0),
    )
    sea = (tr.SeaState(0.0, 1.6, 8.0), tr.SeaState(40.0, 1.0, 10.0))
    spec = tr.TrajectorySpec(
        0.47, 0.98, 0.0, 0.3, segments, scenarios.NOMINAL_WAVES, sea,
        max_accel=0.5, max_yaw_accel=5 * DEG, min_step=1.0,
    )  # fmt: skip
    return tr.build(spec)


def test_the_grid_weights_integrate_degree_nine_exactly() -> None:
    nodes = np.arange(1 - kin.GRID_SAMPLES // 2, kin.GRID_SAMPLES // 2 + 1, dtype=float)
    for k in range(kin.GRID_SAMPLES + 1):
        moment = kin.GRID_WEIGHTS @ nodes**k
        rounding = 4.0 * EPS * (np.abs(kin.GRID_WEIGHTS) @ np.abs(nodes) ** k)
        exact = k < kin.GRID_SAMPLES  # degree 10 is not integrated exactly
        assert (abs(moment - 1.0 / (k + 1)) <= rounding) == exact  # ∫_0^1 s^k ds = 1/(k+1)


def test_increments_are_exact_through_steep_joints(steep: tr.Trajectory) -> None:
    t = np.arange(0, math.floor(steep.duration * 100.0) + 1) / 100.0
    joints = _joints(steep)
    assert joints.size == 15
    reference = _reference(steep.motion, t, joints)
    assert _excess(steep.motion, t, reference) <= 1.0
    # An irregular grid (a 0.5-s gap) falls back to Gauss-Legendre around the gap.
    gap = np.r_[t[:3000], t[3050:]]
    assert _excess(steep.motion, gap, _reference(steep.motion, gap, joints)) <= 1.0
    # The same rules across the joints, which they would not see: far outside the bound.
    blind = replace(steep.motion, breakpoints=())
    assert _excess(blind, t, reference) > 1e5


@pytest.mark.parametrize("start", [2090.0, 10100.0], ids=["turn and speed change", "late"])
def test_increments_are_exact_on_paper_1(start: float) -> None:
    """50 s of paper-1 (t up to 10 150 s, where ulp(t) = 1.8e-12 s dominates the bound):
    around 2090 s a turn ends and a 6.6-s speed change begins (joints at 2095.9, 2106.9, 2115.9,
    2126.9, 2133.4 s) in a sea at level 1."""
    traj = tr.build(scenarios.paper_1().trajectory)
    t = np.arange(round(start * 100.0), round(start * 100.0) + 5001) / 100.0
    assert _excess(traj.motion, t, _reference(traj.motion, t, _joints(traj))) <= 1.0


@pytest.mark.parametrize("start", [0.0, 10_000.0])
def test_waves_on_an_even_grid_are_as_exact_as_sines(start: float) -> None:
    """On an even grid a wave's sine and cosine come by angle addition from every 64th instant
    (trajectory.py, ``_sincos``). Against the sine in extended precision at the same float
    instants, they must be within what evaluating ``sin(ω t + φ)`` in double can promise: the
    argument rounds twice by half an ulp (of ω t, then of ω t + φ: together at most
    ulp(ω t + φ)), the sine by half an ulp of 1 (4 ε leaves room for the sums)."""
    t = np.arange(round(start * 100.0), round(start * 100.0) + 5000) / 100.0
    grid = tr._even_grid(t)
    assert grid is not None and tr._even_grid(t[np.r_[0:2000, 2001:5000]]) is None
    wide = np.longdouble
    for c in scenarios.NOMINAL_WAVES.roll + scenarios.NOMINAL_WAVES.heave:
        omega = 2.0 * math.pi / c.period
        sn, cs = tr._sincos(omega, c.phase, t, grid)
        arg = wide(omega) * t.astype(wide) + wide(c.phase)
        bound = float(np.spacing(omega * t[-1] + c.phase)) + 4.0 * EPS
        assert np.abs(sn - np.sin(arg)).max() <= bound
        assert np.abs(cs - np.cos(arg)).max() <= bound
