"""Load-time checks of the reference (truth) table's values (docs/data-format.md, 'Bad input').

The reference is not filtered: every run is scored against it and ``fit-dvl`` reads the DVL's
calibration off it, so a value that cannot be right would make every number computed from it
wrong without a word. Three things are refused, each an error naming the file, and where one
row shows it, the line and the column:

* a value that is not finite (NaN, inf, an empty cell) in a position, velocity or attitude
  column: a NaN position made the RMSE NaN, a NaN velocity or attitude made ``fit-dvl`` fail
  inside SciPy ('SVD did not converge', 'Found zero norm quaternions');
* an attitude angle outside ``±2π`` (roll, yaw) or ``±π/2`` (pitch), the ranges of Euler
  angles in radians (the same bounds as ``initial.rpy_deg``): degrees in a radian column,
  as a heading of 0-360 is;
* velocity columns that do not move the vehicle as its positions do (:func:`check_velocity`):
  a velocity in knots gave ``fit-dvl`` a scale of -47 % and a velocity NEES of 149 394.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from adaptnav.core import earth
from adaptnav.mission.config import MissionError
from adaptnav.mission.tables import Table, show

Array = NDArray[np.float64]

__all__ = ["ATTITUDE_LIMITS", "check_values", "check_velocity", "velocity_disagreement"]

ATTITUDE_LIMITS = {"roll_rad": 2.0 * math.pi, "pitch_rad": 0.5 * math.pi, "yaw_rad": 2.0 * math.pi}
"""Largest |angle| (rad) of each attitude column: the Euler angles' ranges (pitch ±90°), roll
and yaw allowed a full turn either way for a yaw in [0, 2π) or one wrapped differently."""
WINDOW_S = 10.0
"""Length (s) of the windows over which the positions' displacement and the velocity's integral
are compared: long enough that a position noise of centimetres moves the comparison by
millimetres per second, short enough that the vehicle's speed changes from one to the next."""
MIN_SPEED_M_S = 0.2
"""A window counts when the positions move at least this fast on average (under way)."""
MIN_WINDOWS = 3
"""Fewest windows under way for the comparison; with fewer it is not made (a vehicle at rest:
a velocity in the wrong unit is then still about 0)."""
MAX_DISAGREEMENT = 0.2
"""Largest median of ``|Δp - ∫v dt| / |Δp|`` over the windows under way. Measured (0.4.6): A-KIT
segments 1-9, whose velocity is not the derivative of their positions, 0.003-0.028 (segment 9;
the speeds' ratio 0.996-1.005), the RTKLIB drive 0.010, the simulated demo, paper-1 and paper-2
missions 2e-5; a velocity in knots gives 0.94, in km/h 2.6, 20 % off in scale 0.2."""


def check_values(table: Table, columns: list[str], z: Array, used: list[str]) -> None:
    """MissionError at the first non-finite value of ``z`` (n, d; SI, the table's ``columns``,
    taken from its columns ``used[1:]``), and at the first attitude angle outside
    :data:`ATTITUDE_LIMITS`."""
    bad = np.argwhere(~np.isfinite(z))
    if bad.size:
        r, c = (int(v) for v in bad[0])
        raise table.error(
            r,
            used[1 + c],
            f"value {show(table.df[used[1 + c]].iloc[r])} is not finite; the reference is not "
            f"filtered (every run is scored against it): drop or fill the row "
            f"({int(np.count_nonzero(~np.isfinite(z)))} such value(s) in the table)",
        )
    for c, name in enumerate(columns):
        if name not in ATTITUDE_LIMITS:
            continue
        limit = ATTITUDE_LIMITS[name]
        out = np.flatnonzero(np.abs(z[:, c]) > limit)
        if out.size:
            r = int(out[0])
            converted = " (after × π/180)" if "_deg" in used[1 + c] else ""
            unwrapped = "; a yaw unwrapped over turns: wrap it into ±π" if name == "yaw_rad" else ""
            raise table.error(
                r,
                used[1 + c],
                f"angle {show(table.df[used[1 + c]].iloc[r])}{converted} is outside ±{limit:.6g} "
                f"rad, not an Euler angle in radians (degrees? name the column "
                f"{name.replace('_rad', '_deg')}{unwrapped}; {out.size} row(s))",
            )


def velocity_disagreement(t: Array, llh: Array, v: Array) -> tuple[int, float, float]:
    """(windows under way, median ``|Δp - ∫v dt| / |Δp|``, median ``|∫v dt| / |Δp|``) over
    windows of about :data:`WINDOW_S` (consecutive rows, so a sparse table's window is its
    step). Δp is the NED displacement of the positions ``llh`` (lat, lon rad, h m) across the
    window (``ΔN = (R_M + h) ΔL``, ``ΔE = (R_N + h) cos L Δλ``, ``ΔD = -Δh``, Groves 2013
    eq. 2.111, radii at the window's start), ∫v dt the trapezoidal integral of the NED
    velocity ``v`` over it. Both vectors: a velocity rotated or scaled shows, not only one
    whose speed is wrong. NaN medians when fewer than :data:`MIN_WINDOWS` windows are under
    way."""
    edges = np.unique(np.searchsorted(t, np.arange(t[0], t[-1] + WINDOW_S, WINDOW_S)))
    edges = np.unique(np.append(edges[edges < t.size], t.size - 1))
    a, b = edges[:-1], edges[1:]
    lat, lon, h = llh[:, 0], np.unwrap(llh[:, 1]), llh[:, 2]
    d_p = np.column_stack(
        [
            (lat[b] - lat[a]) * (earth.meridian_radius(lat[a]) + h[a]),
            (lon[b] - lon[a]) * (earth.transverse_radius(lat[a]) + h[a]) * np.cos(lat[a]),
            -(h[b] - h[a]),
        ]
    )
    # cumulative trapezoid: the integral over [a, b] is a difference of two of its values
    dt = np.diff(t)[:, None]
    cum = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * dt * (v[1:] + v[:-1]), axis=0)])
    d_v = cum[b] - cum[a]
    dist = np.linalg.norm(d_p, axis=1)
    moving = dist >= MIN_SPEED_M_S * (t[b] - t[a])
    if int(moving.sum()) < MIN_WINDOWS:
        return int(moving.sum()), math.nan, math.nan
    diff = np.linalg.norm(d_p[moving] - d_v[moving], axis=1) / dist[moving]
    ratio = np.linalg.norm(d_v[moving], axis=1) / dist[moving]
    return int(moving.sum()), float(np.median(diff)), float(np.median(ratio))


def check_velocity(table: Table, t: Array, columns: list[str], z: Array, used: list[str]) -> None:
    """MissionError naming the file and the velocity columns when the table has positions and
    velocity, the vehicle moves, and :func:`velocity_disagreement` exceeds
    :data:`MAX_DISAGREEMENT`: the velocity in another unit (knots, km/h) or frame (ENU)."""
    if "vn_m_s" not in columns or t.size < 2:
        return
    k = columns.index("vn_m_s")
    n, diff, ratio = velocity_disagreement(t, z[:, :3], z[:, k : k + 3])
    if not diff > MAX_DISAGREEMENT:  # NaN: too few windows under way to judge
        return
    names = used[1 + k : 4 + k]
    raise MissionError(
        f"{table.label} (truth), {', '.join(names)}: the velocity does not move the vehicle as "
        f"its positions do: over {n} windows of {WINDOW_S:g} s under way, |Δp - ∫v dt| is "
        f"{100.0 * diff:.3g} % of the displacement Δp (median; at most "
        f"{100.0 * MAX_DISAGREEMENT:g} % allowed) and the velocity's distance "
        f"{ratio:.3g} × the positions' (knots give 1.94, km/h 3.6): the velocity in another "
        "unit or frame (NED, m/s)?",
        file=table.label,
        field=names[0],
    )
