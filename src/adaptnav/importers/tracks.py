"""Position tracks checked against the motion a vehicle can make, shared by the importers: a
position (a GNSS fix, a reference row) that lies off the line through its neighbours by more
than a bounded acceleration allows is a wrong fix or a damaged line (docs/rtklib.md, 'Wrong
fixes'; docs/akit.md)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

JUMP_ACCEL_M_S2 = 10.0
"""No vehicle here (a car, an AUV) accelerates harder than 1 g: the bound on how far a fix may
lie from the line through its neighbours (:func:`inconsistent_fixes`)."""
JUMP_FLOOR_M = 1.0
"""...plus this much (m), for the fixes' own errors."""
MAX_WRONG_FRACTION = 0.1
"""More than this share of a track's fixes off their neighbours' line (and more than 10) is
not a few wrong fixes but not a track: :class:`TrackError`."""
VELOCITY_FLOOR_M_S = 1.0
"""How far (m/s) a fix's velocity may differ from the positions' around it, beyond what the
acceleration bound allows (:func:`inconsistent_velocities`)."""


class TrackError(ValueError):
    """A track of which more than :data:`MAX_WRONG_FRACTION` of the fixes (and more than 10)
    lie off their neighbours' line: a column of something else, or of noise. The search
    stopped after ``limit`` of the ``total``."""

    def __init__(self, limit: int, total: int) -> None:
        super().__init__(
            f"more than {limit} of its {total} positions lie off the line through their "
            "neighbours (farther than a vehicle moves): not a position track (a wrong column?)"
        )
        self.limit, self.total = limit, total


def inconsistent_fixes(t: Array, r_e: Array, candidates: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The candidate fixes that disagree with their neighbours: a fix b whose position (ECEF,
    m) lies farther from the line through two neighbouring fixes a and c than a vehicle could
    leave it, ``|r_b - r_a - (t_b - t_a)/(t_c - t_a) (r_c - r_a)| >
    JUMP_FLOOR_M + ½ JUMP_ACCEL_M_S2 |t_b - t_a| |t_b - t_c|`` (the error of a line through a
    path whose acceleration is bounded), b interpolated between its neighbours, or extrapolated
    from the next two (the first) or the previous two (the last). The worst offender is left
    out and the rest tested again until none offends: a wrong fix (a false RTK fix, a damaged
    line) also pulls the line its neighbours are tested against. More than
    :data:`MAX_WRONG_FRACTION` of them (and more than 10) is a :class:`TrackError`, found
    after at most that many passes."""
    keep = np.flatnonzero(candidates)
    out = np.zeros(t.size, dtype=bool)
    limit = max(10, int(MAX_WRONG_FRACTION * keep.size))
    while keep.size >= 3:
        tt, r = t[keep], r_e[keep]
        a = np.r_[1, np.arange(0, keep.size - 2), keep.size - 3]
        c = np.r_[2, np.arange(2, keep.size), keep.size - 2]
        b = np.arange(keep.size)
        w = (tt[b] - tt[a]) / (tt[c] - tt[a])
        miss = np.linalg.norm(r[b] - r[a] - w[:, None] * (r[c] - r[a]), axis=1)
        bound = JUMP_FLOOR_M + 0.5 * JUMP_ACCEL_M_S2 * np.abs((tt[b] - tt[a]) * (tt[b] - tt[c]))
        k = int(np.argmax(miss / bound))
        if not miss[k] > bound[k]:
            break
        out[keep[k]] = True
        keep = np.delete(keep, k)
        if int(out.sum()) > limit:
            raise TrackError(limit, int(np.count_nonzero(candidates)))
    return out


def inconsistent_velocities(
    t: Array, r_e: Array, C_ne: Array, v_n: Array, candidates: NDArray[np.bool_]
) -> NDArray[np.bool_]:
    """The candidate fixes whose velocity (NED, m/s; NaN: none, not tested) disagrees with
    the positions around them: with a and c the neighbouring candidates of b (b itself at
    the first and the last),

        |v_n,b - C_ne,b (r_c - r_a) / (t_c - t_a)| >
            VELOCITY_FLOOR_M_S + JUMP_ACCEL_M_S2 max(t_b - t_a, t_c - t_b),

    the mean velocity over [t_a, t_c] being within that of any velocity inside it when the
    acceleration is bounded. ``C_ne`` (n, 3, 3) turns ECEF into each fix's NED."""
    idx = np.flatnonzero(candidates)
    out = np.zeros(t.size, dtype=bool)
    if idx.size < 2:
        return out
    b = idx
    a = np.r_[idx[0], idx[:-1]]
    c = np.r_[idx[1:], idx[-1]]
    mean_e = (r_e[c] - r_e[a]) / (t[c] - t[a])[:, None]
    mean_n = np.einsum("nij,nj->ni", C_ne[b], mean_e)
    miss = np.linalg.norm(v_n[b] - mean_n, axis=1)
    bound = VELOCITY_FLOOR_M_S + JUMP_ACCEL_M_S2 * np.maximum(t[b] - t[a], t[c] - t[b])
    out[b] = miss > bound  # NaN (no velocity) is never more
    return out
