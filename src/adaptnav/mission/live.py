"""A sensor's readings screened one at a time, as :func:`adaptnav.mission.load_mission` screens
its table (docs/streaming.md, 'Screening'; the rules: docs/robustness.md).

A reading pushed to :class:`LiveScreen` is, in the loader's order:

* dropped if it repeats the stamp of the sensor's previous reading ("duplicate timestamp") or
  is stamped before it (:data:`OUT_OF_ORDER_REASON`: a table would be refused, a stream cannot
  be);
* dropped if its status flag says no bottom lock (``status_column``), or, with
  ``zero_is_lost``, if it is all zeros;
* dropped if a value lies outside the sensor's plausible range (``limits``);
* otherwise screened for stuck runs (:func:`adaptnav.mission.screening.stuck_runs`, the same
  greedy rule read forwards): a reading within ``resolution`` of the first reading of the run
  under way is **held** until the run either ends (then it is released, not stuck) or is found
  stuck (at least ``stuck_s`` long and three readings: dropped, with the run's first and last
  stamps in its reason once the run has ended). The first reading of a run is never stuck and
  is released at once. On noisy readings no run is longer than one reading and nothing is held;
* then, a DVL's, screened for spikes (:func:`adaptnav.mission.screening.spike_mask`): every
  reading with ``spike_mads`` set, else the first readings after a gap of ``after_gap_s``
  (:func:`~adaptnav.mission.screening.after_gap_mask`). A reading to be judged is **held**
  until its window is whole (the 7 readings after it, or one beyond the window's reach:
  2.3 s at 3 Hz), then dropped as the loader drops it or released with the readings behind it;
* last, with ``min_interval_s``, dropped if it comes less than that after the last reading
  released (:func:`adaptnav.mission.screening.thinned_mask`, read forwards).

The released readings are the loader's kept ones, in the same order; the drops are its
:class:`~adaptnav.mission.tables.DroppedRow` with the same reasons. One check of the loader has
no counterpart: a column whose *every* value is implausible is a wrong-units error of the table,
which a stream cannot see before its end.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission.config import SensorConfig
from adaptnav.mission.loader import (
    LOST_LOCK_REASON,
    after_gap_reason,
    implausible_reason,
    lost_status_reason,
    spike_reason,
    stuck_reason,
    thinned_reason,
)
from adaptnav.mission.screening import (
    AFTER_GAP_MADS,
    AFTER_GAP_READINGS,
    SPIKE_HALF_WINDOW,
    SPIKE_REACH_PERIODS,
    STUCK_MIN_READINGS,
    spike_mask,
    thinned_mask,
)
from adaptnav.mission.tables import DroppedRow

Array = NDArray[np.float64]

OUT_OF_ORDER_REASON = "out of order: stamped before the sensor's previous reading"
"""Ledger reason of a reading older than its sensor's previous one (docs/streaming.md)."""
DUPLICATE_REASON = "duplicate timestamp"
"""The loader's reason for a repeated stamp (mission/loader.py)."""


@dataclass(frozen=True)
class Reading:
    """One reading of a sensor: its stamp (s), values (d,) in SI units, row number."""

    t: float
    z: Array
    row: int


@dataclass
class _Run:
    """The run of unchanged readings under way: its first reading, the readings held after
    it, how many it has, its last stamp, whether it is stuck and the rows dropped as such."""

    first: Reading
    held: list[Reading] = field(default_factory=list)
    count: int = 1
    t_last: float = math.nan
    stuck: list[Reading] | None = None


class LiveScreen:
    """Screens one sensor's readings as they arrive (the module's docstring): :meth:`push`
    and :meth:`close` return the readings released for the filter and the rows dropped.
    ``period``: the sensor's nominal period (s), as the loader takes it (``rate_hz``, else the
    table's median interval); the spike screen needs it (NaN: no spike screen)."""

    def __init__(self, name: str, cfg: SensorConfig, period: float = math.nan) -> None:
        self.name = name
        self.cfg = cfg
        self._limits = cfg.limits_si()
        self._stuck_s = cfg.stuck_duration_s()
        self._resolution = cfg.resolution_si()
        self._t_last = -math.inf
        self._run: _Run | None = None
        self._spikes = _SpikeScreen(name, cfg, period)
        self._min_interval = cfg.min_interval_s or 0.0
        self._t_kept = -math.inf

    @property
    def held_from(self) -> float:
        """The stamp of the oldest reading held (inf: none): the filter must not pass it."""
        run = self._run
        stuck = run.held[0].t if run is not None and run.held else math.inf
        return min(stuck, self._spikes.held_from)

    def push(self, reading: Reading, lock: bool = True) -> tuple[list[Reading], list[DroppedRow]]:
        """Screen ``reading`` (``lock``: the sensor's status flag, read when ``status_column`` is
        configured); returns the readings released (in time order) and the rows dropped."""
        why = self._first_check(reading, lock)
        if why is not None:
            return [], [DroppedRow(self.name, reading.row, reading.t, why)]
        return self._thin(*self._spikes.push(*self._screen_stuck(reading)))

    def close(self) -> tuple[list[Reading], list[DroppedRow]]:
        """The end of the stream: the run under way ends (its held readings are released, or
        dropped if it is stuck), and the readings held for the spike screen are judged."""
        released, dropped = self._spikes.push(*self._end_run())
        more, drops = self._spikes.settle(final=True)
        return self._thin(released + more, dropped + drops)

    def _thin(
        self, released: list[Reading], dropped: list[DroppedRow]
    ) -> tuple[list[Reading], list[DroppedRow]]:
        """Drop the released readings less than ``min_interval_s`` after the last one kept (a
        reading without a finite value is passed on and does not count)."""
        if not self._min_interval > 0.0 or not released:
            return released, dropped
        usable = [bool(np.any(np.isfinite(r.z))) for r in released]
        thin = thinned_mask([r.t for r in released], self._min_interval, usable, self._t_kept)
        out: list[Reading] = []
        drops = list(dropped)
        for r, counts, drop in zip(released, usable, thin.tolist(), strict=True):
            if drop:
                why = thinned_reason(r.t - self._t_kept, self._min_interval)
                drops.append(DroppedRow(self.name, r.row, r.t, why))
                continue
            out.append(r)
            if counts:
                self._t_kept = r.t
        return out, drops

    def _first_check(self, r: Reading, lock: bool) -> str | None:
        """The reason to drop ``r`` before the stuck-run screen, or None (the loader's order:
        duplicate stamp, lost lock, implausible value)."""
        t_prev, self._t_last = self._t_last, max(self._t_last, r.t)
        if r.t == t_prev:
            return DUPLICATE_REASON
        if r.t < t_prev:
            return OUT_OF_ORDER_REASON
        cfg = self.cfg
        if cfg.status_column is not None and not lock:
            return lost_status_reason(cfg.status_column)
        if cfg.zero_is_lost and bool(np.all(r.z == 0.0)):
            return LOST_LOCK_REASON
        # NaN and ±inf are not the limits' business (the loader's _check_plausible): the
        # engine drops them as non-finite, in a stream as in a batch run.
        outside = np.isfinite(r.z) & ((r.z < self._limits[:, 0]) | (r.z > self._limits[:, 1]))
        if outside.any():
            c = int(np.flatnonzero(outside)[0])
            return implausible_reason(cfg, c, float(r.z[c]), self._limits)
        return None

    def _screen_stuck(self, r: Reading) -> tuple[list[Reading], list[DroppedRow]]:
        """Extend the run under way with ``r``, or end it and start one at ``r``; a non-finite
        reading (and a DVL's all-zero one, zero_is_lost's business) ends the run and is
        released without starting one (screening.stuck_runs)."""
        if self._stuck_s <= 0.0:
            return [r], []
        run = self._run
        breaks = not np.all(np.isfinite(r.z)) or (
            self.cfg.kind == "dvl" and bool(np.all(r.z == 0.0))
        )
        if run is not None and not breaks and np.all(np.abs(r.z - run.first.z) <= self._resolution):
            run.count += 1
            run.t_last = r.t
            if run.stuck is not None:
                run.stuck.append(r)
            elif run.count >= STUCK_MIN_READINGS and r.t - run.first.t >= self._stuck_s:
                run.stuck, run.held = [*run.held, r], []
            else:
                run.held.append(r)
            return [], []
        released, dropped = self._end_run()
        self._run = None if breaks else _Run(r, t_last=r.t)
        return [*released, r], dropped

    def _end_run(self) -> tuple[list[Reading], list[DroppedRow]]:
        run, self._run = self._run, None
        if run is None:
            return [], []
        if run.stuck is None:
            return run.held, []
        why = stuck_reason(self.cfg, self._resolution, run.first.t, run.t_last)
        return [], [DroppedRow(self.name, s.row, s.t, why) for s in run.stuck]


@dataclass(frozen=True)
class _Held:
    """A reading held by :class:`_SpikeScreen`: whether it has a finite value (else it is no
    neighbour), whether it is to be judged, and if it is
    among the first readings after a gap, its place after it (1, 2, ...) and the gap (s)."""

    r: Reading
    finite: bool
    judge: bool
    after: int
    gap: float


class _SpikeScreen:
    """The loader's spike screen (:func:`adaptnav.mission.loader._spikes_caught`) one reading
    at a time: the same window of finite readings (h before, h after) for each reading
    judged, so the same verdicts; a reading with no finite value is held in its place but is
    no neighbour, as there."""

    def __init__(self, name: str, cfg: SensorConfig, period: float) -> None:
        self.name = name
        on = cfg.kind == "dvl" and period > 0.0
        self._mads = (cfg.spike_mads or 0.0) if on else 0.0
        self._gap_s = cfg.after_gap_duration_s() if on else 0.0
        self._floor = np.broadcast_to(np.asarray(cfg.sigma_si(), dtype=float), (cfg.dim,))
        self._period = period
        self._reach = SPIKE_REACH_PERIODS * period * SPIKE_HALF_WINDOW
        self._past: deque[Reading] = deque(maxlen=SPIKE_HALF_WINDOW)
        self._held: deque[_Held] = deque()
        self._t_prev = -math.inf
        self._after, self._gap = 0, math.nan

    @property
    def held_from(self) -> float:
        return self._held[0].r.t if self._held else math.inf

    def push(
        self, readings: list[Reading], dropped: list[DroppedRow]
    ) -> tuple[list[Reading], list[DroppedRow]]:
        """Hold ``readings`` (released by the stuck screen), then release or drop what can be
        judged; ``dropped`` (the stuck screen's) is passed on."""
        for r in readings:
            finite = bool(np.any(np.isfinite(r.z)))
            if finite:
                if 0.0 < self._gap_s <= r.t - self._t_prev < math.inf:  # the first: no gap
                    self._after, self._gap = 1, r.t - self._t_prev
                elif self._after:
                    self._after = self._after + 1 if self._after < AFTER_GAP_READINGS else 0
                self._t_prev = r.t
            after = self._after if finite else 0
            judge = finite and (self._mads > 0.0 or after > 0)
            self._held.append(_Held(r, finite, judge, after, self._gap))
        released, drops = self.settle(final=False)
        return released, dropped + drops

    def settle(self, final: bool) -> tuple[list[Reading], list[DroppedRow]]:
        """Release or drop the held readings from the oldest on, up to the first whose window
        is not whole yet (``final``: the stream's end, every window is)."""
        out: list[Reading] = []
        drops: list[DroppedRow] = []
        while self._held:
            h = self._held[0]
            why = None
            if h.judge:
                later = [q.r for q in self._held if q.finite and q.r.t > h.r.t]
                whole = len(later) >= SPIKE_HALF_WINDOW or self._held[-1].r.t - h.r.t > self._reach
                if not (final or whole):
                    break
                why = self._verdict(h, later[:SPIKE_HALF_WINDOW])
            self._held.popleft()
            if h.finite:
                self._past.append(h.r)
            if why is None:
                out.append(h.r)
            else:
                drops.append(DroppedRow(self.name, h.r.row, h.r.t, why))
        return out, drops

    def _verdict(self, h: _Held, later: list[Reading]) -> str | None:
        """The loader's reason to drop ``h`` judged in its window, or None."""
        window = [*self._past, h.r, *later]
        t = np.array([r.t for r in window])
        z = np.array([r.z for r in window])
        judge = np.zeros(t.size, dtype=bool)
        judge[len(self._past)] = True
        if (
            self._mads > 0.0
            and spike_mask(t, z, self._mads, self._floor, self._period, judge).any()
        ):
            return spike_reason(self._mads)
        if h.after and spike_mask(t, z, AFTER_GAP_MADS, self._floor, self._period, judge).any():
            return after_gap_reason(h.gap, h.after)
        return None
