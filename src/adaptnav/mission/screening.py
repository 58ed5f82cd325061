"""Screening a sensor's readings at load: readings frozen by a failing sensor or driver.

A sensor that fails at sea often keeps talking: a DVL driver repeats its last velocity, a
depth meter sticks at one value. Such readings pass every plausibility limit and the filter
uses them as if they were measured. :func:`stuck_runs` finds them by the rule of
docs/robustness.md ("Stuck readings"):

    A **stuck run** is a maximal run of consecutive readings ``z_a, ..., z_b`` in which every
    component stays within its resolution ``r`` of the run's first reading,
    ``|z_k - z_a| <= r`` for all components and all ``a <= k <= b``, that lasts at least the
    minimum duration, ``t_b - t_a >= stuck_s``, and holds at least ``min_readings`` readings.
    A non-finite reading (NaN, ±inf) in any component breaks a run.

Runs are taken greedily in time order: a run starts at the first reading that does not
belong to the run before it. Readings ``a + 1 .. b`` of a stuck run are the caught ones; the
first, ``z_a``, is kept: a frozen driver repeats its last good value, so the first of the run
is the last genuine reading before the freeze.

Pure NumPy, no I/O: the loader (:func:`adaptnav.mission.loader.load_mission`) decides what is
done with the readings caught (dropped, with their reason, to the run's ledger).
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

STUCK_MIN_READINGS = 3
"""Fewest readings (the first included) that make a stuck run: two equal readings across a
data gap say nothing of a freeze."""
_SHORT = 8
"""Runs up to this many readings long are measured for every reading of a chain at once;
longer ones by a search from their first reading."""
_BLOCK = 1 << 16
"""Readings of a chain whose short runs are measured at once, when the walk reaches them."""
_FIRST_WINDOW = 64
"""Readings compared with a run's first reading at once in that search; doubled until the
run ends."""


def stuck_runs(
    t: ArrayLike,
    z: ArrayLike,
    resolution: ArrayLike,
    stuck_s: float,
    min_readings: int = STUCK_MIN_READINGS,
) -> NDArray[np.int64]:
    """The stuck runs of readings ``z`` (n, d) at times ``t`` (n,), as ``(first, last)``
    index pairs (m, 2), both inclusive, in time order (the rule is the module's docstring).

    ``resolution`` is one value or one per column (d,), >= 0, in the columns' unit;
    ``stuck_s`` the minimum duration (s), 0 or less to find none. ``t`` must increase
    strictly (the loader has dropped repeated stamps).

    Vectorised where it matters. Two readings of one run differ by at most twice the
    resolution, so the series is first cut into chains of such close neighbours; a chain too
    short in time or count to hold a stuck run is passed over. So is one with no quiet stretch:
    a stuck run spans ``stuck_s``, so it covers a whole block of ``stuck_s / 2`` (blocks laid
    from the chain's start), whose range is then within twice the resolution. On noisy data
    nearly every chain is one reading long and the cost is a few NumPy passes (8 million
    readings of three components: under a second). Only the chains left are walked run by run:
    a stuck run costs one search; a quiet stretch that is not stuck (readings about one
    resolution apart, possible only with a resolution set near the sensor's output step) costs
    about a microsecond per reading.
    """
    tt = np.asarray(t, dtype=float)
    zz = np.asarray(z, dtype=float)
    if zz.ndim == 1:
        zz = zz[:, None]
    n, d = zz.shape
    if tt.shape != (n,):
        raise ValueError(f"t has shape {tt.shape}, z has {n} rows")
    if np.any(np.diff(tt) <= 0.0):
        raise ValueError("t must increase strictly")
    res = np.broadcast_to(np.asarray(resolution, dtype=float), (d,))
    if not np.all(res >= 0.0):
        raise ValueError(f"resolution {res.tolist()} must be >= 0 (and not NaN)")
    none = np.empty((0, 2), dtype=np.int64)
    need = max(int(min_readings), 2)
    if not stuck_s > 0.0 or n < need:
        return none
    # Column by column: NumPy is much faster on contiguous 1-D arrays than on (n, d) ones.
    link = np.ones(n - 1, dtype=bool)
    with np.errstate(invalid="ignore"):  # NaN, inf - inf: False, a non-finite reading links none
        for c in range(d):
            link &= np.abs(zz[1:, c] - zz[:-1, c]) <= 2.0 * res[c]
    # Chains: maximal index ranges [s, e] whose neighbours are all linked.
    edges = np.diff(np.concatenate(([False], link, [False])).astype(np.int8))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)  # index of the chain's last reading
    long = (ends - starts + 1 >= need) & (tt[ends] - tt[starts] >= stuck_s)
    runs: list[tuple[int, int]] = []
    for s, e in zip(starts[long].tolist(), ends[long].tolist(), strict=True):
        tc, zc = tt[s : e + 1], zz[s : e + 1]
        if _has_quiet_block(tc, zc, res, stuck_s):
            runs += [(s + a, s + b) for a, b in _walk(tc, zc, res, stuck_s, need)]
    return np.array(runs, dtype=np.int64).reshape(-1, 2) if runs else none


def _has_quiet_block(t: Array, z: Array, res: Array, stuck_s: float) -> bool:
    """Whether a block of ``stuck_s / 2`` from ``t[0]`` is empty or has every component's
    range within ``2 res``: a stuck run covers one such block whole."""
    block = np.floor((t - t[0]) / (0.5 * stuck_s)).astype(np.int64)
    first = np.flatnonzero(np.diff(block, prepend=-1))
    if np.any(np.diff(block[first]) > 1):
        return True  # an empty block: a gap in the data, which a run may span
    spread = np.maximum.reduceat(z, first, axis=0) - np.minimum.reduceat(z, first, axis=0)
    return bool(np.any(np.all(spread <= 2.0 * res, axis=1)))


def _walk(t: Array, z: Array, res: Array, stuck_s: float, need: int) -> list[tuple[int, int]]:
    """The stuck runs of one chain, cutting it into runs from its first reading on."""
    n = t.size
    times = t.tolist()
    steps = [0] * n  # 0: not measured yet; filled a block of _BLOCK readings at a time
    found: list[tuple[int, int]] = []
    a = 0
    while n - a >= need and times[-1] - times[a] >= stuck_s:
        step = steps[a]
        if not step:
            steps[a : a + _BLOCK] = _ahead(z, res, a, min(n, a + _BLOCK))
            step = steps[a]
        v = a + step if step <= _SHORT else _first_departure(z, res, a, a + _SHORT + 1)
        b = v - 1
        if b - a + 1 >= need and times[b] - times[a] >= stuck_s:
            found.append((a, b))
        a = v
    return found


def _ahead(z: Array, res: Array, lo: int, hi: int) -> list[int]:
    """For each reading i in ``[lo, hi)``: how many readings on the first one departing
    from ``z[i]`` is, if within ``_SHORT``; reading ``len(z)`` departs (the chain has ended);
    else ``_SHORT + 1``."""
    n = int(z.shape[0])
    idx = np.arange(lo, hi)
    ahead = np.minimum(np.full(hi - lo, _SHORT + 1, dtype=np.int64), n - idx)
    for j in range(min(_SHORT, n - 1 - lo), 0, -1):  # downwards: the nearest departure stays
        m = min(hi, n - j) - lo  # readings i that have an i + j in the chain
        out = np.zeros(m, dtype=bool)
        for c in range(z.shape[1]):
            out |= np.abs(z[lo + j : lo + j + m, c] - z[lo : lo + m, c]) > res[c]
        ahead[:m][out] = j
    return [int(v) for v in ahead.tolist()]


def _first_departure(z: Array, res: Array, a: int, lo: int) -> int:
    """First index from ``lo`` on with a component farther than its resolution from
    ``z[a]``, else ``len(z)``; compares growing windows, so the cost follows the run."""
    n, width = int(z.shape[0]), _FIRST_WINDOW
    while lo < n:
        hi = min(n, lo + width)
        out = np.any(np.abs(z[lo:hi] - z[a]) > res, axis=1)
        if out.any():
            return lo + int(np.argmax(out))
        lo, width = hi, width * 2
    return n


def stuck_mask(
    t: ArrayLike,
    z: ArrayLike,
    resolution: ArrayLike,
    stuck_s: float,
    min_readings: int = STUCK_MIN_READINGS,
) -> NDArray[np.bool_]:
    """Which readings (n,) are caught as stuck: readings 2nd to last of every run of
    :func:`stuck_runs` (the first of a run is the last genuine one and is not marked)."""
    n = np.asarray(t).shape[0]
    runs = stuck_runs(t, z, resolution, stuck_s, min_readings)
    # +1 at each run's second reading, -1 after its last: the running sum is 1 inside.
    marks = np.zeros(n + 1, dtype=np.int64)
    np.add.at(marks, runs[:, 0] + 1, 1)
    np.add.at(marks, runs[:, 1] + 1, -1)
    return np.asarray(np.cumsum(marks[:n]) > 0, dtype=np.bool_)


SPIKE_HALF_WINDOW = 7
"""Neighbours on each side a reading is compared with (:func:`spike_mask`): 15 readings in all;
fewer make the median absolute deviation too noisy a scale (Gaussian noise in 3 components at
10 MADs: 7e-5 of the readings flagged with 15 readings, 7e-3 with 7)."""
SPIKE_MIN_NEIGHBOURS = 3
"""Fewest neighbours (the reading itself not counted) that make a median to judge it by."""
SPIKE_REACH_PERIODS = 1.5
"""A neighbour counts only within this many sensor periods per step of index from the reading
(so across a data gap the readings on its far side are no neighbours)."""


def spike_mask(
    t: ArrayLike,
    z: ArrayLike,
    mads: float,
    floor: ArrayLike,
    period: float,
    judge: ArrayLike | None = None,
) -> NDArray[np.bool_]:
    """Which readings (n,) of ``z`` (n, d) at times ``t`` are isolated spikes, by a Hampel
    test (Hampel 1974; docs/robustness.md, 'Spikes'): with ``m_j`` the median and
    ``s_j = 1.4826 median |z_j - m_j|`` the scaled median absolute deviation of component j
    over the reading and its neighbours (:data:`SPIKE_HALF_WINDOW` each side, each within
    ``SPIKE_REACH_PERIODS × period`` per index step, at least :data:`SPIKE_MIN_NEIGHBOURS`),

        |z_j - m_j| > mads · max(s_j, floor_j)      for some component j.

    ``floor`` (d,) keeps a quiet stretch (s_j near 0) from turning ordinary noise into spikes:
    the sensor's nominal σ. ``mads`` ≤ 0 finds none. A run of bad readings as long as the half
    window is not an isolated spike and is left to the filter's guard. Non-finite components
    are no evidence either way. ``judge`` (n,) bool, if given, limits the test to those
    readings (their neighbours are all readings all the same): :func:`after_gap_mask`."""
    tt, zz = np.asarray(t, dtype=float), np.atleast_2d(np.asarray(z, dtype=float))
    n, h = zz.shape[0], SPIKE_HALF_WINDOW
    out = np.zeros(n, dtype=bool)
    if not mads > 0.0 or n < SPIKE_MIN_NEIGHBOURS + 1 or not period > 0.0:
        return out
    pad_z = np.pad(zz, ((h, h), (0, 0)), constant_values=np.nan)
    pad_t = np.pad(tt, (h, h), constant_values=np.nan)
    fl = np.asarray(floor, dtype=float)
    if judge is not None:
        idx = np.flatnonzero(np.asarray(judge, dtype=bool))
        at = idx[:, None] + np.arange(2 * h + 1)  # rows of pad_*: the window of each
        win_z = np.moveaxis(pad_z[at], 1, 2)  # (m, d, 2h+1)
        out[idx] = _spikes(tt[idx], zz[idx], pad_t[at], win_z, mads, fl, period)
        return out
    for a in range(0, n, _SPIKE_BLOCK):  # blocks: the windows take 2h + 1 copies of each
        b = min(a + _SPIKE_BLOCK, n)
        out[a:b] = _spikes(
            tt[a:b],
            zz[a:b],
            np.lib.stride_tricks.sliding_window_view(pad_t[a : b + 2 * h], 2 * h + 1),
            np.lib.stride_tricks.sliding_window_view(pad_z[a : b + 2 * h], 2 * h + 1, axis=0),
            mads,
            fl,
            period,
        )
    return out


_SPIKE_BLOCK = 1 << 16
"""Readings judged at once by :func:`spike_mask` (their windows: about 25 MB for a DVL)."""


def _spikes(
    t: Array, z: Array, win_t: Array, win_z: Array, mads: float, floor: Array, period: float
) -> NDArray[np.bool_]:
    """:func:`spike_mask` of the readings t, z (m, d), given their windows ``win_t`` (m, 2h+1)
    and ``win_z`` (m, d, 2h+1): the h readings before and after each, NaN past either end."""
    h = SPIKE_HALF_WINDOW
    steps = np.abs(np.arange(-h, h + 1))
    near = np.abs(win_t - t[:, None]) <= SPIKE_REACH_PERIODS * period * np.maximum(steps, 1)
    near[:, h] = True
    enough = near.sum(axis=1) - 1 >= SPIKE_MIN_NEIGHBOURS
    vals = np.where(near[:, None, :], win_z, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN window: no evidence
        med = np.nanmedian(vals, axis=2)
        mad = 1.4826 * np.nanmedian(np.abs(vals - med[:, :, None]), axis=2)
    scale = np.maximum(mad, floor[None, :])
    with np.errstate(invalid="ignore"):
        off = np.abs(z - med) > mads * scale
    return np.asarray(enough & np.any(off & np.isfinite(z), axis=1))


AFTER_GAP_MADS = 10.0
"""The Hampel threshold (:func:`spike_mask`'s ``mads``) for the readings just after a gap
(``after_gap_s``): the value measured for ``spike_mads`` (docs/robustness.md, 'Spikes')."""
AFTER_GAP_READINGS = SPIKE_HALF_WINDOW
"""Readings after a gap that :func:`after_gap_mask` marks: a burst shorter than this is one
the Hampel test can see, since their windows reach the readings after it."""


def after_gap_mask(
    t: ArrayLike, gap_s: float, count: int = AFTER_GAP_READINGS
) -> NDArray[np.bool_]:
    """Which readings (n,) at times ``t`` (increasing) are among the first ``count`` after a
    gap: an interval ``t_i - t_{i-1} >= gap_s`` between consecutive readings (docs/robustness.md,
    'After a gap'). ``gap_s`` ≤ 0 marks none; the first reading of all is not after a gap."""
    tt = np.asarray(t, dtype=float)
    out = np.zeros(tt.size, dtype=bool)
    if not gap_s > 0.0 or tt.size < 2:
        return out
    starts = np.flatnonzero(np.diff(tt) >= gap_s) + 1
    for a in starts.tolist():
        out[a : a + count] = True
    return out


def thinned_mask(
    t: ArrayLike,
    min_interval_s: float,
    usable: ArrayLike | None = None,
    last: float = -np.inf,
) -> NDArray[np.bool_]:
    """Which readings (n,) at times ``t`` (increasing) to drop so that the ones kept are at
    least ``min_interval_s`` apart (docs/robustness.md, 'Correlated readings'): greedily in
    time order, a reading less than ``min_interval_s`` after the last one kept is dropped, so
    the first reading of every stretch is kept. ``usable`` (n,) marks the readings that count:
    one that does not (no finite value) is neither kept as an anchor nor dropped. ``last``: the
    time of the reading kept before these (a stream's earlier ones). ``min_interval_s`` ≤ 0
    drops none."""
    tt = np.asarray(t, dtype=float)
    out = np.zeros(tt.size, dtype=bool)
    if not min_interval_s > 0.0:
        return out
    ok = np.ones(tt.size, dtype=bool) if usable is None else np.asarray(usable, dtype=bool)
    for i in np.flatnonzero(ok).tolist():
        if tt[i] - last < min_interval_s:
            out[i] = True
        else:
            last = tt[i]
    return out
