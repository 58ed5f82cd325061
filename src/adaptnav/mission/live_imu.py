"""An IMU's samples checked one at a time, as :func:`adaptnav.mission.load_mission` checks its
table (docs/streaming.md, 'IMU checks'; the rules: docs/robustness.md, 'A frozen IMU', 'A
saturated IMU', and ``loader._check_gravity``).

:class:`ImuWatch` sees the samples :meth:`adaptnav.api.Stream.push_imu` takes, in time order,
and refuses (ValueError, nothing changed) the sample at which the loader would refuse the table
of the samples taken so far, that sample its last row:

* **frozen**: all six values exactly those of the sample before, over a run lasting
  ``imu.stuck_s`` or more from its first sample (``loader._check_frozen``);
* **one channel stuck**: one value exactly that of the sample before, over a run lasting
  ``imu.channel_stuck_s`` or more from its first sample, while another channel of its triad
  changed on more than :data:`~adaptnav.mission.loader.CHANNEL_QUANTISED_SHARE` of the run's
  samples and the channel itself repeated on less than that share of the samples before the run
  (at least :data:`~adaptnav.mission.loader.CHANNEL_MIN_ELSEWHERE` of them;
  ``loader.stuck_channel``, which counts the samples after the run too): per channel the stamp
  of its run's first sample and its repeats so far, the triad's counts taken at the run's first
  repeat;
* **saturated**: a column whose largest or smallest value so far (not 0) is held by
  ``imu.saturation_rows`` samples or more and by at least
  :data:`~adaptnav.mission.loader.SATURATION_PILEUP` times as many as the next value inward
  in a column of :data:`~adaptnav.mission.loader.SATURATION_LEVELS` distinct values or more so
  far, the two next values inward then apart (``loader._check_saturated``), tracked as the
  values come: per column and side the extreme, the next value inward and their counts (a new
  extreme makes the old one the next inward);
* **not the specific force**: the median |Δv|/dt of the samples of the first
  :data:`GRAVITY_WINDOW_S` outside :data:`~adaptnav.mission.loader.GRAVITY_BAND` × g (the
  loader takes the whole table's; ``loader._check_gravity``), judged once, at the first sample
  stamped that long after the first interval's start.

What the stream cannot do is take back what came before: a frozen run's samples up to
``stuck_s``, the samples of the gravity window, were taken (docs/streaming.md says what follows).
The values compared are the increments pushed, as the loader compares an increments table's
values. Plain floats throughout: the checks run on every sample (docs/streaming.md, 'Latency').
"""

from __future__ import annotations

import math
import statistics

from adaptnav.core.units import G0
from adaptnav.mission.config import ImuConfig
from adaptnav.mission.loader import (
    CHANNEL_MIN_ELSEWHERE,
    CHANNEL_QUANTISED_SHARE,
    GRAVITY_BAND,
    SATURATION_PILEUP,
    specific_force_words,
)
from adaptnav.mission.tables import IMU_INCREMENT_COLUMNS

GRAVITY_WINDOW_S = 1.0
"""The first seconds of samples whose median |specific force| must be near g (s): a vehicle's
over a second is (a car braking at 0.5 g: 1.1 g), and it is within any alignment window, so an
aligning stream is refused before it integrates a sample."""

ROUNDING = 1e-9
"""Values closer than this (relative) are one value to the saturation check: increments of a
constant rate times intervals that differ by their stamps' rounding (``rate × dt``, or an IMU in
rates replayed) take a few values a few ulps apart, a pile-up by count but no clipping (a real
IMU's steps are 1e-7 of its range or more apart)."""

Side = tuple[float, int, float, int, float]
"""One side of a column, values negated for the smallest: (extreme, its count, the next value
inward, its count, the stamp of the extreme's first sample)."""
_NONE: Side = (-math.inf, 0, -math.inf, 0, math.nan)


def _rise(s: Side, x: float, t: float) -> Side | None:
    """Side ``s`` after the value ``x`` (stamped ``t``); None when ``x`` is below both."""
    top, n, nxt, m, first = s
    if x > top:
        return x, 1, top, n, t
    if x == top:
        return top, n + 1, nxt, m, first
    if x > nxt:
        return top, n, x, 1, first
    if x == nxt:
        return top, n, nxt, m + 1, first
    return None


class ImuWatch:
    """The loader's checks of an IMU table, on one sample at a time (the module's docstring).
    :meth:`check` raises or takes the sample; ``cfg`` gives ``stuck_s``,
    ``channel_stuck_s`` and ``saturation_rows`` (0: that check off)."""

    def __init__(self, cfg: ImuConfig) -> None:
        self._stuck_s = cfg.stuck_limit_s
        self._rows = cfg.saturation_limit
        self._last: tuple[float, ...] = ()
        self._run_t = math.nan
        """The stamp of the first sample of the run of equal samples under way."""
        self._hi = [_NONE] * 6
        self._lo = [_NONE] * 6
        # The next values inward of both sides: a value strictly between them changes
        # neither, the usual case on a noisy IMU (one comparison per column).
        self._floor = [math.inf] * 6
        self._ceil = [-math.inf] * 6
        self._forces: list[float] | None = []
        self._window_end = math.nan
        self._chan_s = cfg.channel_stuck_limit_s
        self._n = 0
        """Samples taken."""
        self._reps = [0] * 6
        """Per channel, the samples taken that repeated the one before in that channel."""
        self._since = [math.nan] * 6
        """Per channel in a run, the stamp of its first sample (its value's first)."""
        self._snap: list[tuple[int, tuple[int, ...]] | None] = [None] * 6
        """Per channel in a run, at its first repeat: that sample's index and the repeats
        before it (:attr:`_reps`); None: not in a run."""
        self._runs = False
        """Some channel's :attr:`_snap` is set."""
        self._prev_t = math.nan
        """The stamp of the sample before."""

    def check(self, t: float, dt: float, vals: tuple[float, ...]) -> None:
        """Take the sample (t, dt, Δθ then Δv) or raise ValueError, nothing changed."""
        repeat = vals == self._last
        if repeat and self._stuck_s > 0.0 and t - self._run_t >= self._stuck_s:
            raise ValueError(self._frozen(t))
        sides = self._extremes(t, vals) if self._rows > 0 else []
        # A repeated sample is the frozen check's to judge: a frozen IMU holding one column's
        # extreme would be called saturated before it is called frozen.
        if not (repeat and self._stuck_s > 0.0):
            self._judge_extremes(t, sides)
        chan, last = self._chan_s > 0.0, self._last
        # On a noisy IMU no channel repeats the sample before: six comparisons, nothing more
        # (written out: a third of any(map(operator.eq, ...))'s time).
        same = (
            chan and bool(last)
            and (vals[0] == last[0] or vals[1] == last[1] or vals[2] == last[2]
                 or vals[3] == last[3] or vals[4] == last[4] or vals[5] == last[5])
        )  # fmt: skip
        if same:
            self._channels(t, vals)
        if self._forces is not None:
            self._gravity(t, dt, vals)  # the last check: it takes the sample's force
        if same:
            self._count(vals)
        elif chan and self._runs:
            self._snap, self._runs = [None] * 6, False
        self._n += 1
        self._prev_t = t
        if not repeat:
            self._run_t = t
        self._last = vals
        for c, hi, lo in sides:
            self._hi[c], self._lo[c] = hi, lo
            self._ceil[c], self._floor[c] = hi[2], -lo[2]

    def _channels(self, t: float, vals: tuple[float, ...]) -> None:
        """Raise ValueError if a channel that repeats the sample before has stuck (the module's
        docstring)."""
        last, snap, limit = self._last, self._snap, self._chan_s
        for c in range(6):
            if vals[c] == last[c]:
                since = self._since[c] if snap[c] is not None else self._prev_t
                if t - since >= limit:
                    self._judge_channel(t, vals, c, since)

    def _judge_channel(self, t: float, vals: tuple[float, ...], c: int, since: float) -> None:
        n0, before = self._snap[c] or (self._n, tuple(self._reps))
        run = self._n - n0 + 1  # the run's repeats, this sample's included
        if n0 - 1 < CHANNEL_MIN_ELSEWHERE:
            return
        elsewhere = before[c] / (n0 - 1)
        triad = [d for d in range(3 * (c // 3), 3 * (c // 3) + 3) if d != c]
        held = [self._reps[d] - before[d] + (vals[d] == self._last[d]) for d in triad]
        moving = 1.0 - min(held) / run
        if elsewhere >= CHANNEL_QUANTISED_SHARE or moving <= 1.0 - CHANNEL_QUANTISED_SHARE:
            return
        names = IMU_INCREMENT_COLUMNS
        d = t - since
        raise ValueError(
            f"IMU sample t = {t!r} s, {names[c]}: unchanged at {vals[c]!r} for {d:.6g} s, since "
            f"the sample at t = {since!r} s, while {' or '.join(names[e] for e in triad)}"
            f" changed on {moving:.0%} of those samples and {names[c]} itself repeated on "
            f"{elsewhere:.1%} of the samples before: a channel stuck or dead (its last value, or "
            "0, repeated)? Refused (the samples before it were taken: a stream cannot look "
            "ahead); if they are right (an output step coarse against the noise), set "
            f"imu.channel_stuck_s above {d:.6g} s (0: not checked)"
        )

    def _count(self, vals: tuple[float, ...]) -> None:
        """The channels' runs and repeats once a sample that repeats some is taken: a run
        starts at the sample before its first repeat."""
        last, reps, snap = self._last, self._reps, self._snap
        before = tuple(reps)
        for c in range(6):
            if vals[c] != last[c]:
                snap[c] = None
            else:
                if snap[c] is None:
                    snap[c], self._since[c] = (self._n, before), self._prev_t
                reps[c] += 1
        self._runs = True

    def _frozen(self, t: float) -> str:
        d = t - self._run_t
        return (
            f"IMU sample t = {t!r} s: every IMU value unchanged for {d:.6g} s, since the sample "
            f"at t = {self._run_t!r} s: a frozen IMU or driver repeating its last sample? "
            "Refused (the samples before it were taken: a stream cannot look ahead); if they are "
            f"right, set imu.stuck_s above {d:.6g} s (0: not checked)"
        )

    def _extremes(self, t: float, vals: tuple[float, ...]) -> list[tuple[int, Side, Side]]:
        """(column, new largest side, new smallest side) of each column the sample changes."""
        out = []
        floor, ceil = self._floor, self._ceil
        for c, x in enumerate(vals):
            if floor[c] < x < ceil[c]:
                continue
            hi, lo = _rise(self._hi[c], x, t), _rise(self._lo[c], -x, t)
            if hi is not None or lo is not None:
                out.append((c, hi or self._hi[c], lo or self._lo[c]))
        return out

    def _judge_extremes(self, t: float, sides: list[tuple[int, Side, Side]]) -> None:
        rows = self._rows
        for c, *both in sides:
            # Four values or more: the next values inward of the two ends differ.
            wide = -both[1][2] < both[0][2]
            for side, (top, n, nxt, m, first), sign in zip(
                ("largest", "smallest"), both, (1.0, -1.0), strict=True
            ):
                if (
                    top != 0.0 and n >= rows and m > 0 and n >= SATURATION_PILEUP * m
                    and top - nxt > ROUNDING * abs(top) and wide
                ):  # fmt: skip
                    raise ValueError(
                        f"IMU sample t = {t!r} s, {IMU_INCREMENT_COLUMNS[c]}: {n} samples, the "
                        f"first at t = {first!r} s and the last this one, hold the column's "
                        f"{side} value so far, {sign * top!r} ({m} the next value inward): "
                        "clipped at the IMU's range (saturated)? The motion beyond it is lost "
                        "and the navigation through it wrong; if the values are right, set "
                        f"imu.saturation_rows above {n} (0: not checked)"
                    )

    def _gravity(self, t: float, dt: float, vals: tuple[float, ...]) -> None:
        """Add the sample's |specific force| to the window's; at the window's end judge their
        median (ValueError, the sample's taken back, if it is not near g) and stop."""
        forces = self._forces
        assert forces is not None
        if not forces:
            self._window_end = t - dt + GRAVITY_WINDOW_S
        _, _, _, x, y, z = vals
        forces.append(math.sqrt(x * x + y * y + z * z) / dt)
        if t < self._window_end:
            return
        med = statistics.median(forces)
        lo, hi = GRAVITY_BAND
        if lo * G0 <= med <= hi * G0:
            self._forces = None
            return
        forces.pop()
        over = f"the {len(forces) + 1} IMU samples of the first {GRAVITY_WINDOW_S:g} s"
        raise ValueError(
            f"IMU sample t = {t!r} s, dvel_x_m_s, dvel_y_m_s, dvel_z_m_s: "
            f"{specific_force_words(med, over)} Refused, and so is every sample after it: start "
            "a new stream with the specific force in m/s² (a stream cannot take back the "
            "samples it has taken)"
        )
