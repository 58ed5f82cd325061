"""The filter fed one reading at a time: ``adaptnav.api.stream`` (docs/streaming.md).

:class:`Stream` is the batch run (:func:`adaptnav.api.run`) taken apart in time: built from a
mission's configuration, a filter kind and an initial state (given, the configured one, or the
same static alignment over the first IMU samples it is fed), it takes IMU intervals
(:meth:`Stream.push_imu`) and sensor readings (:meth:`Stream.push`) one at a time, screens each
reading as the loader screens a table (:class:`adaptnav.mission.live.LiveScreen`), hands them to
the engine's :class:`~adaptnav.engine.batch.Navigator` and returns each solution row (the batch
solution table's columns and units, :data:`adaptnav.api.results.SOLUTION_COLUMNS`) from the push
that determined it. :meth:`Stream.close` gives the run's :class:`~adaptnav.api.results.Result`,
ledger and events included.

Fed a recorded mission in time order (:func:`replay`), the rows and the ledger are the batch
run's to 1e-9 (tests/integration/test_stream.py). What is held back, and why: the IMU until the
alignment window is covered; an IMU sample while a reading stamped at or before it is held by
the stuck-run screen (docs/streaming.md, 'Screening'). A reading stamped at or before the time
the filter has integrated to is dropped by the engine as ``late``, in the ledger.
"""

from __future__ import annotations

import heapq
import math
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav import __version__
from adaptnav.api import runner
from adaptnav.api.diagnosis import with_warnings
from adaptnav.api.results import SOLUTION_COLUMNS, Result, declared_columns, solution_rows
from adaptnav.engine import batch as engine
from adaptnav.estimation.settings import FilterKind, FilterSettings
from adaptnav.mission import (
    ImuData,
    Mission,
    MissionConfig,
    MissionError,
    SensorData,
    calibration,
    load_config,
)
from adaptnav.mission.imu_holes import NEAR_S, recent_variance, trapezoid
from adaptnav.mission.live import LiveScreen, Reading
from adaptnav.mission.live_cross import CrossWatch
from adaptnav.mission.live_imu import ImuWatch
from adaptnav.mission.loader import CONFIG_NAME, MAX_ACCEL_M_S2, MAX_GYRO_RAD_S, true_north
from adaptnav.mission.tables import DroppedRow
from adaptnav.models.errorstate import N_STATES
from adaptnav.models.strapdown import NOM_SIZE

__all__ = ["IMU", "Item", "Stream", "replay"]

Array = NDArray[np.float64]
Row = dict[str, float]
"""A solution row: column of the batch solution table → value."""
Vec3 = tuple[float, float, float]
"""An IMU sample's Δθ or Δv as plain floats (the stream's per-sample work is on floats)."""
IMU = "imu"
"""The sensor name of IMU items (:class:`Item`)."""
START_EPS_S = 1e-9
"""IMU samples stamped within this of the start are the alignment's (api.runner.run)."""
CROSS_CHECK_S = 600.0
"""The default time after the start (the alignment window's end, when the stream aligns) over
which a stream gathers what the loader's cross-checks of the IMU's axes and the DVL's and
depth's scales read, then makes them (s; docs/streaming.md, 'Cross-checks')."""


class Item(NamedTuple):
    """One pushed input: an IMU interval (``sensor == IMU``, ``z`` = Δθ (3) then Δv (3), ``dt``
    its length) or a sensor reading (``z`` its values in SI units, ``row`` its row)."""

    sensor: str
    t: float
    z: Array
    row: int = -1
    dt: float = math.nan


class Stream:
    """A filter run fed one reading at a time (the module's docstring; docs/streaming.md).

    Args:
        mission: a loaded :class:`~adaptnav.mission.Mission` (its sensors' periods are the
            batch run's), its folder or ``mission.toml`` (only the configuration is read: every
            aiding sensor needs ``rate_hz``), or a :class:`~adaptnav.mission.MissionConfig`.
        filter: ``"robust"``, ``"meskf"``, ``"maeskf"`` or ``"vb"``; default the mission's.
            The oracle needs the simulator's truth for every reading and is batch only.
        settings, epoch_policy: as for :func:`adaptnav.api.run`.
        initial: (x0, P0, t0) to start from; default the mission's ``[initial]``: the configured
            state from the first IMU interval's start, or the static alignment over the first
            ``alignment_s`` of IMU samples pushed.
        on_row: called with each solution row as it is determined (besides being returned).
        cross_check_s: the seconds after the start (the alignment window's end when the stream
            aligns) whose IMU (as 0.1-s block sums) and aiding readings are kept for the
            loader's cross-checks of the IMU's axes and the DVL's and depth's scales, made once
            they have passed (or at :meth:`close`, if sooner); a finding refuses the stream
            (MissionError, docs/streaming.md, 'Cross-checks'). 0: not made; ``math.inf``: made
            at :meth:`close` on everything.
    """

    _refused: MissionError | None = None
    """The cross-checks' finding, once made: every push after it is refused with it."""

    def __init__(
        self,
        mission: Mission | MissionConfig | str | Path,
        filter: FilterKind | None = None,
        *,
        settings: FilterSettings | None = None,
        epoch_policy: engine.EpochPolicy | None = None,
        initial: tuple[ArrayLike, ArrayLike, float] | None = None,
        on_row: Callable[[Row], None] | None = None,
        cross_check_s: float = CROSS_CHECK_S,
    ) -> None:
        cfg, periods, self._root = _configuration(mission)
        s = settings if settings is not None else cfg.filter_settings()
        s = s.with_kind(filter) if filter is not None else s
        if s.kind == "oracle":
            raise ValueError(
                "the oracle filter needs the simulator's true noise of every reading: run it "
                "in batch (adaptnav.api.run); a stream takes robust, meskf, maeskf or vb"
            )
        auto = [n for n, c in cfg.sensors.items() if c.surface_h_m == "auto"]
        if auto:
            raise MissionError(
                f'{CONFIG_NAME}: [sensors.{auto[0]}] surface_h_m = "auto": a stream needs the '
                "water surface's height as a number (a batch run measures it at rest and records "
                "it in its summary.json, meta.surface_h_m)",
                file=CONFIG_NAME,
                field=f"sensors.{auto[0]}.surface_h_m",
            )
        self.config, self.settings, self._on_row = cfg, s, on_row
        self.policy = epoch_policy or cfg.filter.epoch_policy
        self._states = calibration.calibration_states(cfg)
        self._engine = runner.engine_config(
            cfg, s, self.policy, cfg.imu.noise.to_imu_noise(), self._states
        )
        self._channels = runner.sensor_channels(cfg, s, periods, self._states)
        self._aiding = set(periods)
        self._screens = {
            n: LiveScreen(n, c, periods.get(n, math.nan)) for n, c in cfg.sensors.items()
        }
        self._latency = {n: c.latency_s or 0.0 for n, c in cfg.sensors.items()}
        self._lag = max([0.0, *self._latency.values()])
        """How far the IMU is held behind its newest stamp: the largest ``latency_s``."""
        self._rows = dict.fromkeys(cfg.sensors, 0)
        # What the alignment takes its position and heading from (runner.start_state).
        firsts = (cfg.first_sensor(kind) for kind in ("gnss", "heading"))
        self._at_rest: dict[str, list[Reading]] = {n: [] for n in firsts if n is not None}
        self._early: list[tuple[str, Reading]] = []
        self._extra: list[dict[str, Any]] = []
        self._imu: deque[tuple[float, float, Vec3, Vec3]] = deque()
        self._watch = ImuWatch(cfg.imu)
        self._cross = _cross_watch(cfg, periods, cross_check_s, aligning=initial is None)
        self._t_imu = -math.inf
        self._recent, self._hole_var = _hole_buffers(cfg.imu.rate_hz)
        self._imu_start = math.nan
        """The start of the first IMU interval pushed (the batch run's ``ImuData.start``)."""
        self._nav: engine.Navigator | None = None
        self._t0 = math.nan
        self._info: dict[str, Any] = {}
        self._seen = self._fed = 0
        self._started = math.nan
        self._hold = math.inf
        """The oldest stamp a screen holds back (inf: none): the IMU must not pass it."""
        self.result: Result | None = None
        self._reasons = runner.start_reasons(
            initial is None and self.config.initial.mode != "state"
        )
        """The ledger reasons of a use = "init" sensor's readings and of a reading before the
        start (runner.start_reasons)."""
        if initial is not None:
            self._start(*runner.check_initial(initial))
            self._info = {"initial": "given"}

    # --- the user's side ------------------------------------------------------------------------

    @property
    def t(self) -> float:
        """The time the filter has integrated to (NaN before it starts): a reading stamped at or
        before it is ``late``."""
        return self._nav.t if self._nav is not None else math.nan

    def push_imu(
        self, t: float, dtheta: ArrayLike, dvel: ArrayLike, dt: float | None = None
    ) -> list[Row]:
        """One IMU interval ``(t - dt, t]`` with its increments Δθ (rad) and Δv (m/s), body
        axes; ``dt`` defaults to the time since the previous sample (the first: 1 /
        ``imu.rate_hz``, as the loader). Returns the solution rows it determined.

        ValueError, the stream unchanged, for a stamp not after the previous sample's, a
        non-positive ``dt``, a non-finite value, or what the loader refuses in a table: an
        interval longer than ``imu.max_gap_s`` or overlapping the previous one (``dt`` longer
        than the time since it), a rate beyond 20 rad/s or 20 g (up to 0.4.4 these were
        integrated, to a state far off or a LinAlgError later); since 0.4.10 also a frozen IMU,
        a saturated column and a specific force far from g over the first second, at the sample
        where the loader would refuse the samples so far (:class:`ImuWatch`). A ``dt`` shorter
        than the time since the previous sample is stretched over the hole, as the loader
        stretches a row after lost ones (docs/streaming.md, 'IMU checks'). A sample stamped at
        or before a given ``initial``'s t0 is skipped (docs/streaming.md). Since 0.4.11 the
        first sample past the cross-checks' window (``cross_check_s``) is refused with their
        finding, if any (MissionError), and so is every push after it (docs/streaming.md,
        'Cross-checks')."""
        self._check_open()
        self._check_refused()
        tt = float(t)
        step = float(dt) if dt is not None else tt - self._t_imu
        if not math.isfinite(self._t_imu) and dt is None:
            step = 1.0 / self.config.imu.rate_hz
        # Plain floats, copied (a driver may hand over one buffer it refills, and samples are
        # held): NumPy's calls on three numbers took a third of a push (docs/streaming.md).
        dth, dv = _vec3(dtheta), _vec3(dvel)
        if not (tt > self._t_imu and step > 0.0 and math.isfinite(tt + step)):
            raise ValueError(
                f"IMU sample t = {tt!r} s, dt = {step!r} s: the stamp must be finite and after "
                f"the previous sample's ({self._t_imu!r} s), dt > 0"
            )
        if not math.isfinite(sum(dth) + sum(dv)):  # a NaN or inf anywhere: NaN or inf
            raise ValueError(
                f"IMU sample t = {tt!r} s: non-finite increment {np.array(dth)}, {np.array(dv)}"
            )
        due = self._cross.due_at  # inf until known and once judged: one comparison a push
        if tt - self._lag > due and self._hold > due:
            self._judge(f"IMU sample t = {tt!r} s")  # the window's data are all in
        self._check_imu(tt, step, dth, dv)
        self._recent.append((dth, dv, step))
        if step * (1.0 + 1e-9) < tt - self._t_imu < math.inf:
            # A hole before the interval: samples lost. Stretched over it at a constant rate, or
            # beyond the default max_gap_s filled at the mean of the rates either side, as the
            # loader does (since 0.4.13; up to 0.4.9 the engine jumped the hole).
            since = tt - self._t_imu
            self._hole_at(tt, since / step)
            if trapezoid(round(since / step)):  # a long hole: the trapezoid of rates
                p_th, p_dv, p_step = self._recent[-2] if len(self._recent) > 1 else self._recent[-1]
                lost = since - step
                dth = _filled(dth, p_th, p_step, step, lost)
                dv = _filled(dv, p_dv, p_step, step, lost)
            else:
                dth, dv = _scaled(dth, since / step), _scaled(dv, since / step)
            step = since
        if not self._cross.done:
            self._cross.imu(tt, step, dth, dv)
        self._t_imu = tt
        if math.isnan(self._imu_start):
            self._imu_start = tt - step
        if self._nav is not None and tt < self._t0 + START_EPS_S:
            return []  # before a given start: not integrated, as the batch run's nav_from
        self._imu.append((tt, step, dth, dv))
        return self._advance()

    def _hole_at(self, t: float, ratio: float) -> None:
        """The variances of the unknown motion over the hole before the sample stamped t,
        stretched by ``ratio``, for the engine (:meth:`Navigator.feed_imu_sample`'s ``hole``),
        from the samples of the last :data:`~adaptnav.mission.imu_holes.NEAR_S` seconds
        (mission.imu_holes.recent_variance; docs/streaming.md, 'IMU checks'). Since 0.4.13; up
        to 0.4.12 P grew over the hole by the IMU's white noise alone."""
        m = round(ratio)
        if m < 2:
            return
        # (n, 6): Δθ, Δv per sample, the last one this one
        held = np.array([(*th, *dv) for th, dv, _ in self._recent])
        self._hole_var[t] = recent_variance(held[:, :3], held[:, 3:], m, 1)

    def _check_imu(self, t: float, dt: float, dth: Vec3, dv: Vec3) -> None:
        """The loader's IMU checks on one sample (:meth:`push_imu`)."""
        since = t - self._t_imu
        limit = self.config.imu.gap_limit_s
        if math.isfinite(since) and (since > limit or dt > since * (1.0 + 1e-9)):
            raise ValueError(
                f"IMU sample t = {t!r} s, dt = {dt!r} s: {since:.6g} s after the previous "
                f"sample: a gap over imu.max_gap_s = {limit:.6g} s, or an interval overlapping it"
            )
        values = dth + dv
        g, a = max(map(abs, dth)), max(map(abs, dv))
        if g > MAX_GYRO_RAD_S * dt or a > MAX_ACCEL_M_S2 * dt:
            raise ValueError(
                f"IMU sample t = {t!r} s: a rate beyond 20 rad/s or 20 g ({np.array(dth) / dt} "
                f"rad/s, {np.array(dv) / dt} m/s²): wrong units?"
            )
        self._watch.check(t, dt, values)  # frozen, saturated, not the specific force

    def push(
        self, sensor: str, t: float, z: ArrayLike, *, row: int | None = None, lock: bool = True
    ) -> list[Row]:
        """One reading of ``sensor`` stamped ``t`` (s), values ``z`` in SI units (the table's
        columns, docs/data-format.md); ``row`` its number in the ledger (default: how many
        readings of the sensor came before it); ``lock``: the DVL's bottom-lock flag when
        ``status_column`` is configured. Screened as the loader screens a table, then queued
        for the filter; returns the solution rows it determined (a reading the screen had held
        back may let the IMU go on). KeyError for a sensor not configured, ValueError for a
        reading of the wrong size or a ``row`` that is not an integer >= 0 (to 0.4.7 -1 and 2.7
        were taken, the latter as 2)."""
        self._check_open()
        self._check_refused()
        if sensor not in self._screens:
            raise KeyError(f"unknown sensor {sensor!r}; configured: {list(self._screens)}")
        if not math.isfinite(float(t)):  # it would hold its sensor's later readings back
            raise ValueError(f"{sensor}: a reading stamped t = {t!r}, not a finite time")
        cfg = self.config.sensors[sensor]
        if cfg.use == "aid" and sensor not in self._aiding:
            raise KeyError(f"sensor {sensor!r} has no channel: the mission has no readings of it")
        zz = np.atleast_1d(np.array(z, dtype=float))  # a copy: readings are held
        if zz.shape != (cfg.dim,):
            raise ValueError(f"{sensor}: a reading has {cfg.dim} value(s) {cfg.columns}, got {zz}")
        if row is not None and (isinstance(row, bool) or not isinstance(row, int | np.integer)
                                or row < 0):  # fmt: skip
            raise ValueError(f"{sensor}: row {row!r} is not a row number (an integer >= 0)")
        r = row if row is not None else self._rows[sensor]
        self._rows[sensor] = r + 1
        at = float(t) - self._latency[sensor]  # the reading's own time (latency_s)
        if declination := cfg.declination_rad():  # a magnetic compass's, as the loader turns it
            zz = true_north(zz, declination)
        self._route(sensor, *self._screens[sensor].push(Reading(at, zz, int(r)), lock))
        self._hold = min(s.held_from for s in self._screens.values())
        return self._advance()

    def push_item(self, item: Item) -> list[Row]:
        """:meth:`push_imu` or :meth:`push` of an :class:`Item` (what :func:`replay` yields)."""
        if item.sensor == IMU:
            return self.push_imu(item.t, item.z[:3], item.z[3:], item.dt)
        return self.push(item.sensor, item.t, item.z, row=item.row)

    def close(self) -> Result:
        """End the stream: the screens release or drop what they held, the IMU samples still
        buffered are integrated, readings stamped after the last IMU sample are dropped (ledger)
        and the run's :class:`~adaptnav.api.results.Result` is returned (also :attr:`result`).
        A stream that never started (alignment window not covered) is a MissionError; so is a
        finding of the cross-checks when the stream ended before their window did (they are
        made here, on what came; a second close() returns the run)."""
        if self.result is not None:
            return self.result
        for name, screen in self._screens.items():
            self._route(name, *screen.close())
        self._hold = math.inf
        self._advance()
        nav = self._nav
        if nav is None:
            raise MissionError(
                f"{CONFIG_NAME}: the stream ended before the filter started: {len(self._imu)} "
                "IMU sample(s) pushed, not enough to cover the alignment window "
                f"(initial.alignment_s = {self.config.initial.alignment_s:g} s)",
                file=CONFIG_NAME,
            )
        if not self._cross.done and self._refused is None:
            self._judge("the stream's close()")  # shorter than its window: judged on what came
        self._feed_imu(math.inf)
        nav.flush()
        self.result = self._result(nav.output())
        return self.result

    def __enter__(self) -> Stream:
        return self

    def __exit__(self, kind: object, exc: object, tb: object) -> None:
        if exc is None:
            self.close()

    # --- inside ---------------------------------------------------------------------------------

    def _check_open(self) -> None:
        if self.result is not None:
            raise RuntimeError("the stream is closed")

    def _check_refused(self) -> None:
        if (r := self._refused) is not None:  # a fresh error: re-raising one grows its traceback
            raise MissionError(str(r), file=r.file, line=r.line, field=r.field)

    def _judge(self, at: str) -> None:
        """The loader's cross-checks on the window's data (:class:`CrossWatch`); a finding is
        the loader's MissionError prefixed with where the stream stands, and refuses the stream
        from then on (docs/streaming.md, 'Cross-checks')."""
        found = self._cross.verdict()
        if found is None:
            return
        span = min(self._cross.window_s, self._t_imu - self._cross.start)
        self._refused = MissionError(
            f"{at}: the cross-checks over the stream's first {span:.6g} s: {found} Refused, and "
            "so is every push after it: the rows so far were computed with it; close() gives the "
            "run so far (docs/streaming.md, 'Cross-checks')",
            file=found.file,
            line=found.line,
            field=found.field,
        )
        self._check_refused()

    def _route(self, sensor: str, released: list[Reading], dropped: list[DroppedRow]) -> None:
        """Each screened reading to its fate: dropped at the screen, of a sensor off or used to
        initialise (a GNSS sensor's fixes kept for the alignment), before the start, or queued."""
        self._extra += [runner.ledger_row(d.sensor, d.row, d.t, d.reason) for d in dropped]
        use = self.config.sensors[sensor].use
        if not self._cross.done:
            for r in released:
                self._cross.reading(sensor, r)
        for r in released:
            if sensor in self._at_rest and self._nav is None:
                self._at_rest[sensor].append(r)
            if use != "aid" or sensor not in self._aiding:
                why = self._reasons[0] if use == "init" else runner.OFF_REASON
                self._extra.append(runner.ledger_row(sensor, r.row, r.t, why))
            elif self._nav is None:
                self._early.append((sensor, r))
            else:
                self._queue(sensor, r)

    def _queue(self, sensor: str, r: Reading) -> None:
        if r.t <= self._t0:
            self._extra.append(runner.ledger_row(sensor, r.row, r.t, self._reasons[1]))
        else:
            assert self._nav is not None
            self._nav.feed_measurement(sensor, r.t, r.z, row=r.row)

    def _advance(self) -> list[Row]:
        """Start the filter if it can start, integrate the IMU samples no held reading waits
        for, and return the solution rows that determined."""
        if self._nav is None and not self._try_start():
            return []
        self._feed_imu(self._horizon())
        return self._new_rows()

    def _horizon(self) -> float:
        """The IMU is integrated up to (not including) this time: the oldest reading a screen
        holds back and, with a ``latency_s``, the newest IMU stamp less the largest latency (a
        reading still to come, stamped after that sample, may be that much older than its
        stamp)."""
        if self._lag > 0.0:
            return min(self._hold, self._t_imu - self._lag)
        return self._hold

    def _feed_imu(self, before: float) -> None:
        nav, imu = self._nav, self._imu
        assert nav is not None
        while imu and imu[0][0] < before:
            t, dt, dth, dv = imu.popleft()
            try:
                if self._hole_var:  # an interval stretched over lost samples is queued
                    nav.feed_imu_sample(t, dt, dth, dv, self._hole_var.pop(t, None))
                else:
                    nav.feed_imu_sample(t, dt, dth, dv)
            except engine.PoleError as exc:  # as the batch run says it (runner._run_engine)
                raise runner.FilterError(
                    f"{CONFIG_NAME}: the {self.settings.kind} filter stopped: {exc}",
                    file=CONFIG_NAME,
                ) from None
            except np.linalg.LinAlgError as exc:
                raise runner.FilterError(
                    f"{CONFIG_NAME}: the {self.settings.kind} filter broke down: {exc}",
                    file=CONFIG_NAME,
                ) from None
            self._fed += 1

    def _try_start(self) -> bool:
        """Start the filter from the mission's ``[initial]`` once the IMU allows: the configured
        state at the first sample, the alignment once its window is covered (and no reading
        inside it is held back)."""
        if not self._imu:
            return False
        ini, imu = self.config.initial, self._imu
        if ini.mode == "alignment":
            start = imu[0][0] - imu[0][1]
            if imu[-1][0] <= start + ini.alignment_s:  # before the median: once per sample
                return False
            stop = start + ini.alignment_s + 0.5 * float(np.median([s[1] for s in imu]))
            if imu[-1][0] <= stop or self._horizon() <= stop:  # as align._window_samples
                return False
        held = {
            n: _sensor_data(n, self.config.sensors[n].kind, r)
            for n, r in self._at_rest.items()
            if r
        }
        t, dt, dth, dv = self._imu_arrays()
        x0, P0, t0, self._info = runner.start_state(self.config, ImuData(t, dt, dth, dv), held)
        self._at_rest.clear()
        self._start(x0, P0, t0)
        while self._imu and self._imu[0][0] < t0 + START_EPS_S:
            self._imu.popleft()
        return True

    def _start(self, x0: Array, P0: Array, t0: float) -> None:
        x, P = calibration.extend(x0[:NOM_SIZE], P0[:N_STATES, :N_STATES], self._states)
        self._nav = engine.Navigator(self._engine, self._channels, x, P, t0)
        self._t0 = t0
        self._started = time.perf_counter()
        early, self._early = self._early, []
        for sensor, r in early:
            self._queue(sensor, r)

    def _imu_arrays(self) -> tuple[Array, Array, Array, Array]:
        imu = self._imu
        return (
            np.array([s[0] for s in imu]), np.array([s[1] for s in imu]),
            np.array([s[2] for s in imu]).reshape(-1, 3),
            np.array([s[3] for s in imu]).reshape(-1, 3),
        )  # fmt: skip

    def _new_rows(self) -> list[Row]:
        """The solution rows recorded since the last call, as the batch table has them."""
        nav = self._nav
        assert nav is not None
        if nav.n_rows == self._seen:
            return []
        t, x, p_diag, p_cross, dec, dec_var = nav.rows(self._seen)
        self._seen = nav.n_rows
        names = self._engine.layout.names[N_STATES:]
        columns = list(SOLUTION_COLUMNS)
        values = solution_rows(t, x, p_diag, p_cross)
        extra = declared_columns(names, dec, dec_var)
        rows = []
        for k in range(t.size):
            row = dict(zip(columns, values[k].tolist(), strict=True))
            row.update({c: float(v[k]) for c, v in extra.items()})
            rows.append(row)
            if self._on_row is not None:
                self._on_row(row)
        return rows

    def _result(self, out: engine.EngineOutput) -> Result:
        """The run's Result, as :func:`adaptnav.api.run` builds it (the ledger's rows are the
        pushed readings' rows; the readings that never reached the engine appended)."""
        extra = [_outside_imu(rec, self._imu_start) for rec in self._extra]
        out = replace(out, ledger=[*out.ledger, *extra])
        meta: dict[str, Any] = {
            "mission_dir": self._root,
            "adaptnav_version": __version__,
            "filter_settings": self.settings.as_dict(),
            "epoch_policy": self.policy,
            "engine": runner.engine_meta(self._engine),
            "imu_samples": self._fed,
            "q_scale_final": out.q_scale,
            "elapsed_s": time.perf_counter() - self._started,
            "stream": True,
            **self._info,
        }
        kinds = {n: c.kind for n, c in self.config.sensors.items()}
        cfg = self.config
        result = Result.from_engine(out, self.settings.kind, cfg.mission.name, meta, [], kinds)
        return with_warnings(result, self._channels)


def _outside_imu(rec: dict[str, Any], imu_start: float) -> dict[str, Any]:
    """A ledger row dropped as before the start, given the batch run's reason when its reading
    is stamped before the first IMU interval (``t < imu.start``, api.runner._feed): "before the
    first IMU sample", which the run's warnings count (api/diagnosis.py, ``outside_imu``). A
    stream learns the IMU's start only from its first sample, which may come after such
    readings, so the reason is settled at the end (up to 0.4.7 every such reading was "before
    navigation start (alignment)", and a sensor on another clock went without the warning)."""
    before = (runner.BEFORE_START_REASON, runner.GIVEN_START_REASON)
    if rec["reason"] in before and rec["t"] < imu_start:
        return {**rec, "reason": engine.BEFORE_IMU_REASON}
    return rec


def _configuration(
    mission: Mission | MissionConfig | str | Path,
) -> tuple[MissionConfig, dict[str, float], str]:
    """The configuration, each aiding sensor's nominal period (s) and the mission folder: a
    Mission's periods are its tables' (as the batch run's), a configuration's its ``rate_hz``."""
    if isinstance(mission, Mission):
        cfg = mission.config
        periods = {n: d.period for n, d in mission.sensors.items() if cfg.sensors[n].use == "aid"}
        return cfg, periods, runner.mission_folder(mission.root)
    if isinstance(mission, MissionConfig):
        cfg, root = mission, ""
    else:
        path = Path(mission)
        path = path / CONFIG_NAME if path.is_dir() else path
        cfg, root = load_config(path), runner.mission_folder(path.parent)
    periods = {}
    for n, c in cfg.sensors.items():
        if c.use != "aid":
            continue
        if c.rate_hz is None:
            raise MissionError(
                f"{CONFIG_NAME}: [sensors.{n}] rate_hz is needed to stream (a batch run takes "
                "the median interval of the sensor's table)",
                file=CONFIG_NAME,
                field=f"sensors.{n}.rate_hz",
            )
        periods[n] = 1.0 / c.rate_hz
    return cfg, periods, root


def _cross_watch(
    cfg: MissionConfig, periods: dict[str, float], after_s: float, *, aligning: bool
) -> CrossWatch:
    """The cross-checks' window: ``after_s`` from the start, counted from the alignment window's
    end when the stream aligns (at rest nothing turns, so nothing decides: the simulated
    missions' 600 s alongside, docs/streaming.md, 'Cross-checks'). ValueError for a negative
    or NaN ``after_s``."""
    if not after_s >= 0.0:
        raise ValueError(f"cross_check_s = {after_s!r}: seconds >= 0 (0: no cross-checks)")
    lead = cfg.initial.alignment_s if aligning and cfg.initial.mode == "alignment" else 0.0
    return CrossWatch(cfg, periods, lead + after_s if after_s > 0.0 else 0.0)


def _vec3(v: ArrayLike) -> Vec3:
    """Three floats of ``v`` (ValueError for another size), a copy."""
    x, y, z = np.asarray(v, dtype=float).reshape(3).tolist()
    return x, y, z


def _scaled(v: Vec3, r: float) -> Vec3:
    """``v × r`` (as NumPy's product, element by element)."""
    return v[0] * r, v[1] * r, v[2] * r


def _filled(v: Vec3, before: Vec3, dt_before: float, dt: float, lost: float) -> Vec3:
    """A sample's increments ``v`` over its own ``dt`` and the ``lost`` time before it at the
    mean of its rate and that of the sample ``before`` (over ``dt_before``): the trapezoid of
    rates, as the loader fills a hole (mission.loader._filled), element by element."""
    return tuple(  # type: ignore[return-value]
        v[c] + lost * (0.5 * (before[c] / dt_before + v[c] / dt)) for c in range(3)
    )


def _sensor_data(name: str, kind: str, readings: list[Reading]) -> SensorData:
    """Readings as the loader's SensorData (the alignment's GNSS fixes and headings)."""
    return SensorData(
        name, kind, np.array([r.t for r in readings]), np.array([r.z for r in readings]),
        np.array([r.row for r in readings], dtype=np.int64),
    )  # fmt: skip


def _hole_buffers(
    rate_hz: float,
) -> tuple[deque[tuple[Vec3, Vec3, float]], dict[float, Array]]:
    """A stream's samples' own increments and intervals over the last :data:`NEAR_S` seconds,
    and the variances of the holes it has seen by the stamp of the sample after each, not yet
    fed to the engine (:meth:`Stream._hole_at`)."""
    return deque(maxlen=math.ceil(NEAR_S * rate_hz) + 1), {}


def replay(mission: Mission) -> Iterator[Item]:
    """A recorded mission's inputs as a stream would receive them: every IMU interval and every
    reading the loader kept (of every configured sensor, off ones included), in time order; at
    one stamp, readings before the IMU sample (the batch engine's order: a reading stamped at the
    end of an interval is used in it). A sensor's readings carry their stamps as recorded: the
    loader's times plus its ``latency_s``; a magnetic compass's its magnetic headings (the
    loader's less its ``declination_deg``)."""
    imu = mission.imu
    z = np.hstack([imu.dtheta, imu.dvel])
    streams = [_keyed(IMU, 1, imu.t, z, np.arange(imu.t.size), imu.dt)]
    for name, d in {**mission.sensors, **mission.off}.items():
        cfg = mission.config.sensors[name]
        stamps = d.t + (cfg.latency_s or 0.0)
        z = true_north(d.z, -declination) if (declination := cfg.declination_rad()) else d.z
        streams.append(_keyed(name, 0, stamps, z, d.rows, np.full(d.t.size, math.nan)))
    for _, _, item in heapq.merge(*streams, key=lambda e: (e[0], e[1])):
        yield item


def _keyed(
    sensor: str, order: int, t: Array, z: Array, rows: NDArray[np.int64], dt: Array
) -> Iterator[tuple[float, int, Item]]:
    """One table's items with their merge key (stamp, readings before the IMU)."""
    for k, tk in enumerate(t.tolist()):
        yield tk, order, Item(sensor, tk, z[k], int(rows[k]), float(dt[k]))
