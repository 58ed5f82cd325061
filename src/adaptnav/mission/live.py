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
  is released at once. On noisy readings no run is longer than one reading and nothing is held.

The released readings are the loader's kept ones, in the same order; the drops are its
:class:`~adaptnav.mission.tables.DroppedRow` with the same reasons. One check of the loader has
no counterpart: a column whose *every* value is implausible is a wrong-units error of the table,
which a stream cannot see before its end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission.config import SensorConfig
from adaptnav.mission.loader import (
    LOST_LOCK_REASON,
    implausible_reason,
    lost_status_reason,
    stuck_reason,
)
from adaptnav.mission.screening import STUCK_MIN_READINGS
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
    and :meth:`close` return the readings released for the filter and the rows dropped."""

    def __init__(self, name: str, cfg: SensorConfig) -> None:
        self.name = name
        self.cfg = cfg
        self._limits = cfg.limits_si()
        self._stuck_s = cfg.stuck_duration_s()
        self._resolution = cfg.resolution_si()
        self._t_last = -math.inf
        self._run: _Run | None = None

    @property
    def held_from(self) -> float:
        """The stamp of the oldest reading held (inf: none): the filter must not pass it."""
        run = self._run
        return run.held[0].t if run is not None and run.held else math.inf

    def push(self, reading: Reading, lock: bool = True) -> tuple[list[Reading], list[DroppedRow]]:
        """Screen ``reading`` (``lock``: the sensor's status flag, read when ``status_column`` is
        configured); returns the readings released (in time order) and the rows dropped."""
        why = self._first_check(reading, lock)
        if why is not None:
            return [], [DroppedRow(self.name, reading.row, reading.t, why)]
        return self._screen_stuck(reading)

    def close(self) -> tuple[list[Reading], list[DroppedRow]]:
        """The end of the stream: the run under way ends (its held readings are released, or
        dropped if it is stuck)."""
        return self._end_run()

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
        outside = (r.z < self._limits[:, 0]) | (r.z > self._limits[:, 1])
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
