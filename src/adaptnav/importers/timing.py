"""Time-offset estimation shared by the importers: the lag minimising a smooth cost.

An importer writes a cost of the lag between two clocks (the misfit of two streams that see
the same motion: reference increments against the IMU, DVL velocity against the reference,
gyro yaw rate against a GNSS course) and :func:`minimise_lag` finds its minimum to a fraction
of the grid step.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def parabolic_minimum(x: Array, cost: Array) -> float:
    """Vertex of the parabola through the grid minimum and its neighbours (sub-step lag)."""
    i = int(np.argmin(cost))
    if i == 0 or i == cost.size - 1 or not np.isfinite(cost[i]):
        raise ValueError(
            f"cost minimum at the edge of the searched lags [{x[0]:.2f}, {x[-1]:.2f}] s"
        )
    c0, c1, c2 = cost[i - 1], cost[i], cost[i + 1]
    curv = c0 - 2.0 * c1 + c2
    step = x[1] - x[0]
    return float(x[i] + 0.5 * step * (c0 - c2) / curv) if curv > 0.0 else float(x[i])


COARSE_STEPS = 5
"""The lag searches first use a grid this many times coarser than ``step_s``."""


def minimise_lag(
    cost: Callable[[float], float],
    lo: float,
    hi: float,
    step: float,
    half_width: float,
    what: str = "the time offset",
) -> float:
    """Lag minimising ``cost`` over [lo, hi].

    ValueError, its message starting with ``what`` (the files and the offset), when the best
    lag of the coarse grid is at its edge or not finite: the two streams do not see the same
    motion there (rows lost, a value far out of range, a unit or an axis wrong), which up to
    0.4.4 was reported only as "cost minimum at the edge", naming neither.

    A grid of ``COARSE_STEPS × step`` finds the basin (the costs here have one smooth minimum
    over the span); then the cost on a grid of ``step`` within ``± half_width`` of it is
    fitted by a least-squares parabola (``numpy.polyfit``), whose vertex is the estimate. The
    fit smooths the small jitter of the cost from lag to lag (the gyro noise in the DVL's
    lever-arm term), which would otherwise move a three-point vertex by a few hundredths.
    """
    coarse = np.arange(lo, hi + 0.5 * step, COARSE_STEPS * step)
    try:
        centre = parabolic_minimum(coarse, np.array([cost(float(x)) for x in coarse]))
    except ValueError as exc:
        raise ValueError(
            f"{what}: {exc}: the two streams do not agree on any lag there (rows lost or out "
            "of order, a value far out of range, a unit or an axis wrong?)"
        ) from None
    fine = np.arange(centre - half_width, centre + half_width + 0.5 * step, step)
    c = np.array([cost(float(x)) for x in fine])
    ok = np.isfinite(c)
    a2, a1, _ = np.polyfit(fine[ok] - centre, c[ok], 2)
    vertex = centre - a1 / (2.0 * a2) if a2 > 0.0 else math.nan
    if not abs(vertex - centre) <= half_width:
        return float(fine[int(np.argmin(np.where(ok, c, np.inf)))])
    return float(vertex)


GPS_LEAP_SECONDS = (
    (dt.datetime(1999, 1, 1, tzinfo=dt.UTC), 13),
    (dt.datetime(2006, 1, 1, tzinfo=dt.UTC), 14),
    (dt.datetime(2009, 1, 1, tzinfo=dt.UTC), 15),
    (dt.datetime(2012, 7, 1, tzinfo=dt.UTC), 16),
    (dt.datetime(2015, 7, 1, tzinfo=dt.UTC), 17),
    (dt.datetime(2017, 1, 1, tzinfo=dt.UTC), 18),
)
"""GPST - UTC (s) from each UTC date on (IERS Bulletin C; GPS time has no leap seconds, UTC
has had 18 more since 1980-01-06, none since 2017). Add a row when the IERS announces one."""


def gpst_to_utc_ns(gpst_s: float) -> int:
    """UTC nanoseconds since 1970 (as ROS time) of a GPST time given, as RTKLIB's ``gtime_t``
    and the importers keep it, as the GPS calendar counted in seconds since 1970 like UTC:
    ``UTC = GPST - ΔLS`` with ΔLS of :data:`GPS_LEAP_SECONDS` (18 s since 2017). ValueError
    before 1999, which the table does not cover."""
    t = dt.datetime.fromtimestamp(gpst_s, dt.UTC)
    leaps = [n for since, n in GPS_LEAP_SECONDS if t - dt.timedelta(seconds=n) >= since]
    if not leaps:
        raise ValueError(f"GPST {t.isoformat()}: before 1999, no leap-second count here")
    whole = math.floor(gpst_s)
    return (whole - leaps[-1]) * 1_000_000_000 + round((gpst_s - whole) * 1e9)
