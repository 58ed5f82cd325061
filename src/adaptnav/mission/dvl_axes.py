"""Cross-check of a DVL's axes against the accelerometers and the gyro, with no heading.

A DVL whose x axis is negated (a vehicle going ahead reads as going astern), whose y or z is
negated, or whose x and y are swapped passes every check of its own table, and the checks of
mission/scales.py see it only beside a GNSS track with a known heading, or beside a depth on a
vehicle that flies pitched. The IMU sees it everywhere: the DVL's velocity changes are what the
accelerometers measure, in the same body axes (docs/robustness.md, 'DVL axes against the
accelerometers').

**The body velocity's kinematics** (Groves (2013) ch. 5, resolved in the body frame, the
earth's rate, the transport rate and the Coriolis term left out: below 1e-4 m/s² at a few
m/s): ``dv_b/dt = f_b + g_b - ω_ib × v_b``. Over 0.1-s blocks of IMU samples
(:data:`BLOCK_S`), with ``Δv_f`` the accelerometers' velocity increment and ``Δθ`` the gyro's,
the predicted change is

    Δu_j = Δv_f,j + g_b,j h_j - Δθ_j × v_b,j,

``v_b`` the DVL's velocity at the block (its lever arm's share ``ω × l`` taken off: the IMU's
point). Summed, ``U`` is the body velocity up to a constant; at the DVL the prediction is
``C_sb (U + ω × l)``.

**Gravity in the body** ``g_b`` needs the tilt to a few hundredths of a degree (0.1° is
0.017 m/s²): levelling the accelerometers alone reads the vehicle's own accelerations as tilt
and cancels them. Here each block's gravity is the accelerometers' ``-f`` with the vehicle's
acceleration ``dv_b/dt + ω × v_b`` (from the DVL) taken off, turned by the gyro into the body
frame of the first block (``q_j``, the gyro's rotation increments multiplied up: a frame that
does not turn), averaged over :data:`GRAVITY_WINDOW_S` there, and turned back: ``g_b,j =
q_j* ⊗ mean_W(q ⊗ (dv/dt + ω × v - f) ⊗ q*) ⊗ q_j``. Over a minute the gyro's drift (1°/h: 0.02°)
and the earth's turn (15°/h, centred) are negligible, the accelerometers' noise is averaged
down, and the DVL's part enters only through its mean over a minute.

**The fit.** The DVL's readings (its own frame) and the prediction at their times are averaged
over consecutive windows of :data:`WINDOW_S`, and per DVL axis the change from one window to
the next, ``a_i = k b_i + c Δt_i``, is fitted robustly by
:func:`adaptnav.mission.axes.axis_slope` (``c`` takes an accelerometer's bias and a constant
error of the gravity). A right axis gives k ≈ 1; negated ≈ -1; swapped with another ≈ 0. The
fit's correlation ``r = t / sqrt(t² + n - 2)`` (``t = k / se``, over
the intervals kept) says how well the DVL follows the prediction at all.

**The rule**, in order. (1) The declared axes are confirmed (each ``k - 4 se >= 0.5`` with
``r >=`` :data:`CONFIRM_CORRELATION`, none above :data:`MAX_SLOPE` 4 σ down): nothing is said.
(2) Else the readings' likely slips (:data:`SLIPS`: an axis negated, x and y swapped) are tried
in turn, and one that makes every axis confirmed is named: the DVL's own readings shape the
prediction (a negated x turns the centripetal term of every turn the wrong way on y, and
spoils the gravity's mean), so the declared fits alone may decide nothing. (3) Else one axis is
refused when the other two are confirmed (the DVL's clock and the prediction agree there) and
it has ``k + 4 se < 0.5`` with a slip's signature: its own changes follow the prediction the
opposite way (``r <= -``:data:`MIN_CORRELATION`: negated) or another DVL axis follows it
closely (``|r| >=`` :data:`CONFIRM_CORRELATION`: swapped). A prediction that no DVL axis
follows (a vehicle that never accelerates along it; the IMU's noise alone) decides nothing, an
axis that follows it the right way but weakly (a poor prediction, not a slip) is not refused,
and a DVL whose stamps are off by many seconds (its changes matched with the wrong ones:
chance correlations of the waves) confirms nothing and is not judged (since 0.4.12 the loader
dates the DVL first, against the same prediction: mission/clocks.py, :func:`velocity_integral`).
The DVL's scale is not judged: its readings enter the prediction (the centripetal term, the
gravity's mean), which then partly follows a wrong unit; a DVL above :data:`MAX_SLOPE` is only
not confirmed.

Pure NumPy, no I/O: :func:`adaptnav.mission.loader.load_mission` calls :func:`check_dvl_axes`
and turns a finding into a MissionError naming the DVL's file and column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d

from adaptnav.core.attitude import quat_mult
from adaptnav.mission import axes

Array = NDArray[np.float64]

BLOCK_S = 0.1
"""Length of the blocks the IMU's samples are summed over (s)."""
GRAVITY_WINDOW_S = 60.0
"""Span the gravity in the gyro's non-turning frame is averaged over (s)."""
WINDOW_S = 3.0
"""Span of the windows the DVL's readings and the prediction are averaged over (s)."""
MIN_SLOPE = axes.MIN_SLOPE
"""The fewest of the prediction's metres per second a DVL axis may show per m/s."""
CONFIDENCE = axes.CONFIDENCE
"""Standard errors a slope's interval spans before it is judged."""
MIN_CORRELATION = 0.5
"""Fewest -r with which an axis must follow its prediction the opposite way to be negated."""
CONFIRM_CORRELATION = 0.8
"""Fewest r of every axis for a set of axes to be confirmed, and fewest |r| with which another
DVL axis must follow an axis's prediction for the two to be swapped."""
MAX_SLOPE = 1.5
"""Most of the DVL's m/s per m/s of the prediction a confirmed axis may show (4 σ down)."""
SLIPS: dict[str, Array] = {
    "x negated": np.diag([-1.0, 1.0, 1.0]),
    "y negated": np.diag([1.0, -1.0, 1.0]),
    "z negated": np.diag([1.0, 1.0, -1.0]),
    "x and y swapped": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
}
"""The readings' likely slips, as the matrix that turns the table's readings into the right
ones (each its own inverse); the first axis it changes is the one named."""


def rotvec_quat(a: Array) -> Array:
    """``Exp(a)`` of rotation vectors (n, 3) as quaternions (n, 4)."""
    angle = np.linalg.norm(a, axis=1)
    half = 0.5 * angle
    # sin(x/2)/x by its series below 1e-4 rad, where the division loses digits.
    s = np.where(angle > 1e-4, np.sin(half) / np.maximum(angle, 1e-300), 0.5 - angle**2 / 48.0)
    return np.column_stack([np.cos(half), a * s[:, None]])


def rotate(q: Array, v: Array, inverse: bool = False) -> Array:
    """Vectors ``v`` (n, 3) turned by unit quaternions ``q`` (n, 4): ``q ⊗ v ⊗ q*`` (with
    ``inverse``: ``q* ⊗ v ⊗ q``)."""
    w, u = q[:, :1], (-q[:, 1:] if inverse else q[:, 1:])
    t = 2.0 * np.cross(u, v)
    return np.asarray(v + w * t + np.cross(u, t), dtype=float)


def cumulative(dq: Array) -> Array:
    """The running products ``dq_0 ⊗ dq_1 ⊗ ... ⊗ dq_j`` (n, 4), by doubling (log2 n
    vectorised steps instead of n small ones)."""
    q = dq.copy()
    step = 1
    while step < q.shape[0]:
        q[step:] = quat_mult(q[:-step], q[step:])
        step *= 2
    return np.asarray(q / np.linalg.norm(q, axis=1, keepdims=True), dtype=float)


@dataclass(frozen=True)
class Blocks:
    """The IMU's samples summed over blocks of about :data:`BLOCK_S`: block ``j`` spans
    ``(t_end[j] - h[j], t_end[j]]``; ``dtheta``, ``dvel`` (m, 3) its gyro and accelerometer
    increments; ``q_mid`` (m, 4) the body's attitude at its middle relative to the body at the
    first block's start, from the gyro alone."""

    t_end: Array
    h: Array
    dtheta: Array
    dvel: Array
    q_mid: Array

    @classmethod
    def of(cls, t: Array, dt: Array, dtheta: Array, dvel: Array) -> Blocks:
        """From the IMU's intervals ``(t - dt, t]`` and increments (ImuData's arrays)."""
        per = max(1, round(BLOCK_S / float(np.median(dt))))
        nb = t.size // per
        cut = nb * per
        starts = np.arange(0, cut, per)
        # reduceat: a sixth of the time of a reshape's sum over the middle axis.
        h = np.add.reduceat(dt[:cut], starts)
        w = np.add.reduceat(dtheta[:cut], starts, axis=0)
        f = np.add.reduceat(dvel[:cut], starts, axis=0)
        q_end = cumulative(rotvec_quat(w))
        start = np.vstack([[1.0, 0.0, 0.0, 0.0], q_end[:-1]])
        q_mid = quat_mult(start, rotvec_quat(0.5 * w))
        return cls(t[per - 1 : cut : per], h, w, f, q_mid)

    @property
    def mid(self) -> Array:
        """The blocks' middle times (s)."""
        return np.asarray(self.t_end - 0.5 * self.h, dtype=float)


def gravity(blocks: Blocks, accel: Array) -> Array:
    """Gravity in the body (m, 3) at each block: ``-f`` with the vehicle's acceleration
    ``accel`` (m, 3; m/s²) taken off, averaged over :data:`GRAVITY_WINDOW_S` in the gyro's
    non-turning frame (module docstring)."""
    g_0 = rotate(blocks.q_mid, accel - blocks.dvel / blocks.h[:, None])
    n = max(1, round(GRAVITY_WINDOW_S / float(np.median(blocks.h))))
    mean = uniform_filter1d(g_0, n, axis=0, mode="nearest")
    return rotate(blocks.q_mid, mean, inverse=True)


def predicted(blocks: Blocks, t: Array, v_b: Array, lever: Array) -> Array:
    """The body velocity's change predicted by the IMU (module docstring) at the DVL's point
    at times ``t`` (n, 3; body axes, from an arbitrary constant), for the DVL's body-frame
    readings ``v_b`` (n, 3) at ``t`` and its lever arm ``lever`` (m)."""
    edges, u = velocity_integral(blocks, t, v_b, lever)
    out = np.column_stack([np.interp(t, edges, u[:, k]) for k in range(3)])
    rate = blocks.dtheta / blocks.h[:, None]
    w_t = np.column_stack([np.interp(t, blocks.mid, rate[:, k]) for k in range(3)])
    inside = (t >= edges[0]) & (t <= edges[-1])
    return np.where(inside[:, None], out + np.cross(w_t, lever), math.nan)


def velocity_integral(blocks: Blocks, t: Array, v_b: Array, lever: Array) -> tuple[Array, Array]:
    """``U``, the sum of the predicted changes ``Δu_j`` (module docstring) at the IMU's point,
    at the blocks' edges (m + 1,) from 0 at the first block's start (m + 1, 3), for the DVL's
    body-frame readings ``v_b`` (n, 3) at ``t`` and its lever arm ``lever`` (m)."""
    mid, h = blocks.mid, blocks.h
    rate = blocks.dtheta / h[:, None]
    v = np.column_stack([np.interp(mid, t, v_b[:, k]) for k in range(3)])
    v = v - np.cross(rate, lever)  # the IMU's point: the DVL's own turns ω × l out
    accel = np.gradient(v, mid, axis=0) + np.cross(rate, v)
    du = blocks.dvel + gravity(blocks, accel) * h[:, None] - np.cross(blocks.dtheta, v)
    edges = np.concatenate([[blocks.t_end[0] - h[0]], blocks.t_end])
    return edges, np.vstack([np.zeros(3), np.cumsum(du, axis=0)])


@dataclass(frozen=True)
class Readings:
    """A DVL's readings at times ``t`` (n,) in its own frame ``v_s`` (n, 3), its mounting
    ``c_sb`` (None: the body's axes), lever arm ``lever`` (body, m) and nominal period (s)."""

    t: Array
    v_s: Array
    c_sb: Array | None
    lever: Array
    period: float

    def slipped(self, slip: Array) -> Readings:
        """The readings as they would be with the table's slip ``slip`` undone."""
        return Readings(self.t, self.v_s @ slip.T, self.c_sb, self.lever, self.period)

    def body(self) -> Array:
        """The readings in the body's axes: ``v_b = C_bs v_s``."""
        return self.v_s if self.c_sb is None else np.asarray(self.v_s @ self.c_sb, dtype=float)

    def to_sensor(self, v_b: Array) -> Array:
        """Body vectors (n, 3) in the DVL's axes: ``C_sb v_b``."""
        return v_b if self.c_sb is None else np.asarray(v_b @ self.c_sb.T, dtype=float)


def window_changes(t: Array, a: Array, b: Array, period: float) -> tuple[Array, Array, Array]:
    """The changes from each window of :data:`WINDOW_S` to the next of the means of ``a`` and
    ``b`` (n, 3) at times ``t``, and the time between the windows' mean times; a window with
    a gap (longer than 1.5 × its nominal span) or a NaN makes its changes NaN."""
    m = max(1, round(WINDOW_S / period))
    nw = t.size // m
    if nw < 2:
        return np.empty((0, 3)), np.empty((0, 3)), np.empty(0)
    cut = nw * m
    tw = t[:cut].reshape(nw, m)
    good = tw[:, -1] - tw[:, 0] <= 1.5 * max(m - 1, 1) * period
    mean_t = tw.mean(axis=1)
    mean_a = a[:cut].reshape(nw, m, 3).mean(axis=1)
    mean_b = b[:cut].reshape(nw, m, 3).mean(axis=1)
    step = np.diff(mean_t)
    ok = good[1:] & good[:-1] & (step <= 1.5 * m * period)
    da = np.where(ok[:, None], np.diff(mean_a, axis=0), math.nan)
    return da, np.where(ok[:, None], np.diff(mean_b, axis=0), math.nan), step


def correlation(s: axes.Slope) -> float:
    """The fit's correlation over the intervals it kept: ``r = t / sqrt(t² + n - 2)``,
    ``t = k / se`` (its sign k's)."""
    t = s.k / s.se if s.se > 0.0 else math.copysign(math.inf, s.k)
    return t / math.sqrt(t * t + max(s.n - 2, 1)) if math.isfinite(t) else math.copysign(1.0, t)


@dataclass(frozen=True)
class AxisFit:
    """The fit of DVL ``axis``'s changes on the prediction's same axis (:class:`Slope`, its
    correlation ``r``) and the DVL axis ``follower`` that follows that prediction best, with
    its |r| ``follower_r`` (the axis itself, or the one it is swapped with)."""

    axis: int
    slope: axes.Slope
    r: float
    follower: int
    follower_r: float

    @property
    def refused(self) -> bool:
        """``k + 4 se`` below :data:`MIN_SLOPE` with a slip's signature: the axis follows its
        prediction the opposite way (``r <= -MIN_CORRELATION``: negated) or not at all
        (``|r| <`` :data:`MIN_CORRELATION`) while another DVL axis follows it closely (``|r| >=``
        :data:`CONFIRM_CORRELATION`: swapped). An axis that follows its prediction the right way
        but weakly (a poor prediction, not a slip) is not refused, whichever axis follows it
        better: up to 0.4.11 it was, as swapped, when another did (paper-2's first 750 s as a
        stream: y at 0.28, r 0.79, its prediction carrying a share of the surge the DVL's x
        follows with r 0.95; docs/robustness.md, 'DVL axes against the accelerometers')."""
        s = self.slope
        negated = self.r <= -MIN_CORRELATION
        swapped = (
            self.follower != self.axis
            and self.follower_r >= CONFIRM_CORRELATION
            and abs(self.r) < MIN_CORRELATION
        )
        return s.k + CONFIDENCE * s.se < MIN_SLOPE and (negated or swapped)

    @property
    def confirmed(self) -> bool:
        """``k - 4 se >= MIN_SLOPE`` with ``r >=`` :data:`CONFIRM_CORRELATION`, and not above
        :data:`MAX_SLOPE` even 4 σ down."""
        s = self.slope
        fits = s.k - CONFIDENCE * s.se >= MIN_SLOPE and self.r >= CONFIRM_CORRELATION
        return fits and s.k - CONFIDENCE * s.se <= MAX_SLOPE


def fit_axes(a: Array, b: Array, dt: Array, noise_var: Array) -> list[AxisFit | None]:
    """Per DVL axis, the fit of its changes ``a`` (m, 3) on the prediction's ``b`` (m, 3) over
    intervals ``dt`` (None: too few, or the prediction not above its noise ``noise_var``), and
    which DVL axis follows that prediction best."""
    out: list[AxisFit | None] = []
    for j in range(3):
        own = axes.axis_slope(a[:, j], b[:, j], dt, noise_var=noise_var)
        if own is None:
            out.append(None)
            continue
        best, best_r = j, abs(correlation(own))
        for i in range(3):
            other = axes.axis_slope(a[:, i], b[:, j], dt, noise_var=noise_var) if i != j else None
            if other is not None and abs(correlation(other)) > best_r:
                best, best_r = i, abs(correlation(other))
        out.append(AxisFit(j, own, correlation(own), best, best_r))
    return out


def fit_readings(blocks: Blocks, dvl: Readings, vrw: float) -> tuple[list[AxisFit | None], Array]:
    """The fits of :func:`fit_axes` for ``dvl``'s readings against the prediction, and the
    first and last window times used."""
    p = dvl.to_sensor(predicted(blocks, dvl.t, dvl.body(), dvl.lever))
    a, b, dt = window_changes(dvl.t, dvl.v_s, p, dvl.period)
    fits: list[AxisFit | None] = [None, None, None]
    if dt.size:
        fits = fit_axes(a, b, dt, vrw**2 * dt)
    used = dvl.t[np.isfinite(p[:, 0])]
    span = [float(used[0]), float(used[-1])] if used.size else [math.nan, math.nan]
    return fits, np.asarray(span, dtype=float)


@dataclass(frozen=True)
class DvlAxisFinding:
    """A DVL ``axis`` (0, 1, 2: its x, y, z) whose changes do not follow the accelerometers'
    (``fit``), or, with ``slip``, a DVL whose readings are confirmed with that slip undone
    where they are not as declared (``axis`` the first the slip changes, ``fit`` its declared
    fit); over ``t_from``-``t_to``."""

    axis: int
    fit: AxisFit | None
    """None: the axis undecided as declared (a slip named)."""
    t_from: float
    t_to: float
    slip: str | None = None

    def cause(self) -> str:
        """What the slope points to, in words."""
        name = "xyz"[self.axis]
        if self.slip is not None:
            return (
                f"its readings follow the accelerometers on every axis once taken as {self.slip}"
                ": is the table's axis so, or its mounting_rpy_deg not set?"
            )
        if self.fit is None:
            return "it does not follow the accelerometers"
        k = self.fit.slope.k
        if self.fit.follower != self.axis:
            other = "xyz"[self.fit.follower]
            return (
                f"the DVL's {other} follows it instead: are {name} and {other} swapped, or its "
                "mounting_rpy_deg not set?"
            )
        turn = " (a vehicle going ahead reads as going astern)" if self.axis == 0 else ""
        return f"it changes the opposite way ({k:.2g}): is the {name} axis negated{turn}?"


def check_dvl_axes(blocks: Blocks, dvl: Readings, vrw: float) -> DvlAxisFinding | None:
    """What the DVL's readings point to (the module docstring's rule): None where the declared
    axes are confirmed or nothing decides; else a likely slip confirmed in their stead, else
    the first declared axis refused beside two confirmed. ``vrw``: the accelerometers'
    velocity random walk (m/s/√s), below which the prediction's changes decide nothing."""
    if dvl.t.size < 2 * axes.MIN_INTERVALS or blocks.h.size < 2:
        return None
    fits, span = fit_readings(blocks, dvl, vrw)
    known = [f for f in fits if f is not None]
    if len(known) == 3 and all(f.confirmed for f in known):
        return None
    if not known:  # no axis's prediction above its noise (a vehicle at rest): no slip decides
        return None
    t_from, t_to = float(span[0]), float(span[1])
    # The DVL's own readings shape the prediction's gravity and centripetal term: a wrong axis
    # can spoil the other axes' fits too, so a slip that makes every axis fit is named first.
    for name, slip in SLIPS.items():
        alt, _ = fit_readings(blocks, dvl.slipped(slip), vrw)
        if all(f is not None and f.confirmed for f in alt):
            axis = int(np.flatnonzero(np.diag(slip) != 1.0)[0])
            return DvlAxisFinding(axis, fits[axis], t_from, t_to, name)
    # One axis alone is judged only where the other two are confirmed: the DVL's clock and
    # the prediction agree there, so a poor fit is the axis's own, not a time offset's (a DVL
    # 30 s early on the demo's waves: x fits 0.06 with z following its prediction, r 0.5).
    if len(known) < 3:
        return None
    for f in known:
        if f.refused and all(o.confirmed for o in known if o is not f):
            return DvlAxisFinding(f.axis, f, t_from, t_to)
    return None
