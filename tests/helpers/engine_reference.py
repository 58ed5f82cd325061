"""The engine as it was before the compiled epochs: the readable reference for the tests.

A verbatim copy of ``adaptnav.engine.batch`` before ``adaptnav.compiled.update`` (NumPy sensors'
``evaluate``, the strategies' ``update``, ``errorstate.inject`` / ``reset_jacobian``, a heap of
readings, ledger dicts), with the engine's data classes imported rather than redefined.
``tests/kernels/test_update_kernels.py`` runs it side by side with
:class:`adaptnav.engine.batch.Navigator`. Since then it has the guard and the divergence guard, in
:mod:`adaptnav.estimation.health`'s readable functions (docs/robustness.md).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.compiled import propagation as kernels
from adaptnav.core import earth
from adaptnav.engine.batch import (
    MAX_DIM,
    SAME_EPOCH_S,
    EngineConfig,
    EngineOutput,
    SensorChannel,
    hole_event,
    nominal_R,
)
from adaptnav.estimation import health
from adaptnav.estimation.gate import Gate, Guard, apply_gate
from adaptnav.estimation.kalman import innovation_covariance
from adaptnav.estimation.noise import process
from adaptnav.estimation.noise.base import Block
from adaptnav.models import errorstate
from adaptnav.models.errorstate import N_STATES
from adaptnav.models.strapdown import NOM_SIZE

Array = NDArray[np.float64]
EpochPolicy = Literal["exact", "grid"]


@dataclass
class _Records:
    """Growing output buffers (plain lists; turned into arrays once at the end)."""

    sol_t: list[float] = field(default_factory=list)
    sol_x: list[Array] = field(default_factory=list)
    sol_p: list[Array] = field(default_factory=list)
    sol_cross: list[Array] = field(default_factory=list)
    ledger: list[dict[str, Any]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)


class Navigator:
    """Streaming multirate ESKF: feed IMU intervals and sensor readings; read the solution.

    Readings may be fed ahead of the IMU (they wait in a time-ordered heap until the IMU covers
    their stamp); a reading stamped before the navigator's current time is dropped as ``late``.
    """

    def __init__(
        self,
        config: EngineConfig,
        channels: Sequence[SensorChannel],
        x0: ArrayLike,
        P0: ArrayLike,
        t0: float,
    ) -> None:
        names = [c.name for c in channels]
        if len(set(names)) != len(names):
            raise ValueError(f"sensor names must be unique, got {names}")
        kinds = {type(c.strategy) for c in channels}
        if len(kinds) > 1:
            raise ValueError("all sensors of one filter must use the same noise strategy class")
        self.config = config
        self.channels = tuple(channels)
        self._index = {c.name: i for i, c in enumerate(channels)}
        self.x = np.array(x0, dtype=float)
        self.P = np.array(P0, dtype=float)
        if self.x.shape != (NOM_SIZE,) or self.P.shape != (N_STATES, N_STATES):
            raise ValueError(f"x0 must be ({NOM_SIZE},), P0 ({N_STATES}, {N_STATES})")
        self.t = float(t0)
        self._q_nominal = errorstate.noise_psd(config.imu_noise)
        self._q = self._q_nominal.copy()
        self._beta = self._beta_event = 1.0  # Q's scale, and at the last q_scale event
        self._white = [process.WhitenessState()] * len(channels)
        self._tau_a = float(config.imu_noise.accel_bias_tau)
        self._tau_g = float(config.imu_noise.gyro_bias_tau)
        # The current IMU interval: [t_start, t_start + dt], rates, and how far we are into it.
        self._t_start = self.t
        self._dt = 0.0
        self._offset = 0.0
        self._w_cur = np.zeros(3)
        self._f_cur = np.zeros(3)
        self._w_prev = np.zeros(3)
        self._f_prev = np.zeros(3)
        # F's low-passed specific force (compiled.propagation._low_pass)
        self._f_lp = np.full(3, np.nan)
        self._tau_f = config.specific_force_tau_s
        if config.at_rest:
            self._f_lp = -earth.gravity_n(self.x[0], self.x[2])
            self._tau_f = math.inf
        self._have_rates = False
        self._intervals_done = 0
        self._holes: dict[int, Array] = {}
        self._hole_events: list[dict[str, Any]] = []
        self._open_hole: Array | None = None
        self._states: list[Any] = [c.strategy.initial_state(nominal_R(c.model)) for c in channels]
        self._last_epoch = [math.nan] * len(channels)
        self._rejected_since = [math.nan] * len(channels)  # the guard's lockout clock
        self._passed = [(math.nan, math.nan)] * len(channels)  # the guard's last pass: t, stat
        self._step = [False] * len(channels)  # the streak began with a step (health.is_step)
        self._nis = [(0.0, 0.0)] * len(channels)  # windowed NIS/d mean and count
        self._pending: list[tuple[float, int, int, int, Array]] = []
        self._seq = 0
        self.records = _Records()
        self._record()

    # --- feeding ------------------------------------------------------------------------------

    def feed_measurement(self, sensor: str, t: float, z: ArrayLike, row: int = -1) -> None:
        """Queue a reading of ``sensor`` stamped ``t``; it is processed once the IMU covers t."""
        if sensor not in self._index:
            raise KeyError(f"unknown sensor {sensor!r}; configured: {list(self._index)}")
        i = self._index[sensor]
        heapq.heappush(self._pending, (float(t), i, self._seq, row, np.asarray(z, dtype=float)))
        self._seq += 1

    def feed_imu(
        self,
        t: ArrayLike,
        dt: ArrayLike,
        dtheta: ArrayLike,
        dvel: ArrayLike,
        holes: tuple[ArrayLike, ArrayLike] | None = None,
    ) -> None:
        """Integrate IMU intervals ``(t_k - dt_k, t_k]`` with increments, processing every queued
        reading they cover, in time order. ``holes``: indices of intervals stretched over lost
        samples and the variances of their motion (velocity, attitude; body axes), added over
        the interval as white noise of PSD var / dt (adaptnav.engine.batch._hole_psd)."""
        self._holes = (
            {}
            if holes is None
            else {
                int(k): np.asarray(v, dtype=float)
                for k, v in zip(np.asarray(holes[0]).tolist(), np.asarray(holes[1]), strict=True)
            }
        )
        tk = np.atleast_1d(np.asarray(t, dtype=float))
        dts = np.broadcast_to(np.asarray(dt, dtype=float), tk.shape).copy()
        for k, v in self._holes.items():
            self._hole_events.append(hole_event(float(tk[k]), float(dts[k]), v.tolist()))
        dth = np.ascontiguousarray(np.atleast_2d(np.asarray(dtheta, dtype=float)))
        dv = np.ascontiguousarray(np.atleast_2d(np.asarray(dvel, dtype=float)))
        start, n = 0, tk.size
        while True:
            if self._offset < self._dt:  # an interval split by an exact-time update is open
                if self._pending and self._pending[0][0] <= self._t_start + self._dt:
                    self._epoch_in_open_interval()
                    continue
                self._advance_in_interval(self._dt)
                self._interval_done()
            if start >= n:
                return
            if not self._pending or self._pending[0][0] > tk[-1]:
                self._bulk(tk, dts, dth, dv, start, n)
                return
            if self._pending[0][0] <= self.t:
                self._drop_late()
                continue
            k = int(np.searchsorted(tk, self._pending[0][0], side="left"))
            self._bulk(tk, dts, dth, dv, start, k)
            self._begin_interval(float(tk[k] - dts[k]), float(dts[k]), dth[k], dv[k])
            self._open_hole = self._holes.get(k)
            start = k + 1

    def _epoch_in_open_interval(self) -> None:
        """Process the earliest queued reading, which lies in the open interval."""
        t_m = self._pending[0][0]
        if t_m <= self.t:
            self._drop_late()
            return
        t_end = self._t_start + self._dt
        if self.config.epoch_policy == "grid":
            self._advance_in_interval(self._dt)
            self._epoch(t_end, t_end)
        else:
            self._advance_in_interval(t_m - self._t_start)
            self._epoch(self.t, self.t + SAME_EPOCH_S)
        if self._offset >= self._dt:
            self._interval_done()

    # --- propagation --------------------------------------------------------------------------

    def _q_of(self, hole: Array | None, dt: float) -> Array:
        """Q's PSDs over an interval of length dt: with a hole's variances spread over it."""
        if hole is None:
            return self._q
        q = self._q.copy()
        q[:6] += hole / dt
        return q

    def _begin_interval(self, t_start: float, dt: float, dtheta: Array, dvel: Array) -> None:
        w, f = dtheta / dt, dvel / dt
        if not self._have_rates:
            self._w_cur, self._f_cur, self._have_rates = w, f, True
        self._w_prev, self._f_prev = self._w_cur, self._f_cur
        self._w_cur, self._f_cur = w, f
        self._t_start, self._dt, self._offset = t_start, dt, 0.0
        self.t = t_start

    def _advance_in_interval(self, tau: float) -> None:
        """Propagate inside the open interval up to offset tau (clamped to it)."""
        tau = min(max(tau, self._offset), self._dt)
        if tau > self._offset:
            kernels.propagate_partial(
                self.x, self.P, self._w_prev, self._f_prev, self._w_cur, self._f_cur,
                self._dt, self._offset, tau, self._q_of(self._open_hole, self._dt),
                self._tau_a, self._tau_g, self._f_lp, self._tau_f,
            )  # fmt: skip
            self._offset = tau
        self.t = self._t_start + tau if tau < self._dt else self._t_start + self._dt

    def _interval_done(self) -> None:
        self._intervals_done += 1
        if self._intervals_done % self.config.output_every == 0:
            self._record()

    def _bulk(self, tk: Array, dts: Array, dth: Array, dv: Array, a: int, b: int) -> None:
        """Whole intervals a..b-1, in compiled runs that end on output epochs and around each
        hole (its own run, with its Q: :meth:`_q_of`)."""
        if b <= a:
            return
        if not self._have_rates:
            self._w_cur, self._f_cur = dth[a] / dts[a], dv[a] / dts[a]
            self._have_rates = True
        every = self.config.output_every
        i = a
        while i < b:
            to_output = every - self._intervals_done % every
            j = min(b, i + to_output)
            hole = self._holes.get(i)  # a hole alone, with its own Q; else up to the next one
            j = i + 1 if hole is not None else min([j, *(h for h in self._holes if i < h < j)])
            wp, fp = self._w_cur.copy(), self._f_cur.copy()
            kernels.propagate_run(
                self.x, self.P, dth[i:j], dv[i:j], dts[i:j], wp, fp,
                self._q_of(hole, float(dts[i])), self._tau_a, self._tau_g, self._f_lp,
                self._tau_f, 0.0,
            )  # fmt: skip
            self._w_cur, self._f_cur = wp, fp
            self._dt = self._offset = float(dts[j - 1])
            self.t = float(tk[j - 1])
            self._t_start = self.t - self._dt
            self._intervals_done += j - i - 1
            self._interval_done()
            i = j

    # --- measurement epochs -------------------------------------------------------------------

    def _drop_late(self) -> None:
        t_m, i, _, row, _ = heapq.heappop(self._pending)
        self._ledger(i, row, t_m, self.t, "dropped", "late: stamped before the current time")

    def _epoch(self, t_epoch: float, t_until: float) -> None:
        """Stacked update with every queued reading stamped <= t_until (docs/filters.md,
        'Stacked update')."""
        group: list[tuple[float, int, int, Array]] = []
        while self._pending and self._pending[0][0] <= t_until:
            t_m, i, _, row, z = heapq.heappop(self._pending)
            group.append((t_m, i, row, z))
        blocks: list[Block] = []
        meta: list[tuple[int, int, float]] = []
        seen: set[int] = set()
        for t_m, i, row, z in group:
            ch = self.channels[i]
            if i in seen:
                self._ledger(
                    i, row, t_m, t_epoch, "dropped", "duplicate: sensor already at this epoch"
                )
                continue
            meas = ch.model.evaluate(self.x, z, self._w_cur)
            if meas is None:
                self._ledger(i, row, t_m, t_epoch, "dropped", "invalid reading (non-finite)")
                continue
            seen.add(i)
            last = self._last_epoch[i]
            dt_i = ch.period if math.isnan(last) else t_epoch - last
            self._states[i] = ch.strategy.predict(self._states[i], dt_i, ch.period)
            self._last_epoch[i] = t_epoch
            if ch.guard is not None:
                W = meas.H @ self.P @ meas.H.T
                q = ch.guard.threshold(meas.y.size)
                R_guard = ch.guard.headroom * meas.R
                d = apply_gate(Gate(q, "chi2", "nominal"), meas.y, W + R_guard)
                if not d.accepted:
                    self._ledger(
                        i, row, t_m, t_epoch, "rejected", "guard chi2 (nominal R)", d.statistic,
                        q, meas.y, np.diag(meas.R),
                    )  # fmt: skip
                    self._lockout(ch.guard, i, row, t_epoch, d.statistic, q, W, R_guard)
                    continue
                self._rejected_since[i] = math.nan
                self._passed[i] = (t_epoch, d.statistic)
            if ch.gate is not None:
                R_now = (
                    meas.R
                    if ch.gate.reference == "nominal"
                    else ch.strategy.current_R(self._states[i], meas.R)
                )
                S = innovation_covariance(self.P, meas.H, R_now)
                d = apply_gate(ch.gate, meas.y, S)
                if not d.accepted:
                    self._ledger(
                        i, row, t_m, t_epoch, "rejected", f"gate {d.rule}", d.statistic,
                        d.threshold, meas.y, np.diag(R_now),
                    )  # fmt: skip
                    continue
            blocks.append(Block(ch.name, meas.y, meas.H, meas.R, self._states[i]))
            meta.append((i, row, t_m))
        if not blocks:
            return
        P_prior = self.P
        try:
            res = self.channels[meta[0][0]].strategy.update(P_prior, blocks)
        except np.linalg.LinAlgError:
            for i, row, t_m in meta:
                self._ledger(
                    i, row, t_m, t_epoch, "rejected", "S not positive definite: P repaired"
                )
            repaired = health.repair(self.P)
            assert repaired is not None
            self.P = repaired
            self._event(meta[0][0], meta[0][1], t_epoch, "covariance", math.nan, math.nan, 1.0)
            return
        dx = res.correction.dx
        self.x = errorstate.inject(self.x, dx)
        P = res.correction.P
        if self.config.reset_mode != errorstate.RESET_OFF:
            G = errorstate.reset_jacobian(dx, self.config.reset_mode)
            P = G @ P @ G.T
        self.P = np.ascontiguousarray(0.5 * (P + P.T))
        if not np.all(np.diag(self.P) > 0):
            repaired = health.repair(self.P)
            assert repaired is not None
            self.P = repaired
            self._event(meta[0][0], meta[0][1], t_epoch, "covariance", math.nan, math.nan, 1.0)
        dg = self.config.divergence
        for (i, row, t_m), b, st, R in zip(meta, blocks, res.states, res.R_used, strict=True):
            self._states[i] = st
            S_i = innovation_covariance(P_prior, b.H, R)
            nis = float(b.y @ np.linalg.solve(S_i, b.y))
            self._ledger(
                i, row, t_m, t_epoch, "used", "", nis, math.nan, b.y, np.diag(R), res.iterations
            )
            if dg.nis_ratio > 0:
                mean, count = health.nis_step(*self._nis[i], nis / b.y.size, dg.window)
                self._nis[i] = (mean, count)
                if count >= dg.window and mean > dg.nis_ratio:
                    k = min(mean, dg.inflate_max)
                    self.P = self.P * k
                    self._event(i, row, t_epoch, "nis", mean, dg.nis_ratio, k)
                    self._nis[i] = (0.0, 0.0)
            if self.config.q_adaptation is not None:
                self._adapt_q(i, row, t_epoch, b.y, np.diag(S_i))

    def _adapt_q(self, i: int, row: int, t: float, y: Array, S_diag: Array) -> None:
        """Q adaptation after a used reading of sensor i (estimation/noise/process.py)."""
        qa = self.config.q_adaptation
        assert qa is not None
        self._white[i], beta = process.whiteness_step(
            qa, self._white[i], self._beta, t, self.channels[i].period, y, S_diag
        )
        if beta != self._beta:
            self._beta = beta
            self._q = self._q_nominal.copy()
            self._q[:6] *= beta
        last = self._beta_event
        if beta >= process.EVENT_STEP * last or beta * process.EVENT_STEP <= last:
            self._beta_event = beta
            w = self._white[i]
            self._event(i, row, t, "q_scale", w.c1 / w.c0, qa.target, beta)

    def _lockout(
        self, guard: Guard, i: int, row: int, t: float, stat: float, q: float, W: Array, R: Array
    ) -> None:
        """The guard rejected sensor i's reading: start its lockout clock, or inflate P if it
        has run for ``lockout_s``; the clock runs on until a reading passes
        (estimation/health.py)."""
        since = self._rejected_since[i]
        if math.isnan(since):
            self._rejected_since[i] = t
            period = self.channels[i].period
            passed_t, passed_stat = self._passed[i]
            self._step[i] = health.is_step(stat, passed_stat, t, passed_t, period)
            return
        wait = health.lockout_wait(guard.lockout_s, self._step[i])
        if not (guard.lockout_s > 0 and t - since >= wait):
            return
        k = health.lockout_factor(
            stat, q, float(np.trace(W)), float(np.trace(R)), guard.lockout_max
        )
        self.P = self.P * k
        self._event(i, row, t, "lockout", t - since, guard.lockout_s, k)

    def _event(
        self,
        i: int,
        row: int,
        t: float,
        event: str,
        statistic: float,
        threshold: float,
        factor: float,
    ) -> None:
        from adaptnav.engine.batch import _EVENTS

        detail = {name: text for name, text in _EVENTS.values()}[event]
        self.records.events.append(
            {
                "t": t,
                "sensor": self.channels[i].name,
                "row": row,
                "event": event,
                "statistic": statistic,
                "threshold": threshold,
                "factor": factor,
                "detail": detail,
            }
        )

    def _ledger(
        self,
        i: int,
        row: int,
        t_m: float,
        t_epoch: float,
        fate: str,
        reason: str,
        statistic: float = math.nan,
        threshold: float = math.nan,
        nu: Array | None = None,
        r_diag: Array | None = None,
        iterations: int = 0,
    ) -> None:
        rec: dict[str, Any] = {
            "t": t_m,
            "t_epoch": t_epoch,
            "sensor": self.channels[i].name,
            "row": row,
            "fate": fate,
            "reason": reason,
            "statistic": statistic,
            "threshold": threshold,
            "iterations": iterations,
        }
        for j in range(MAX_DIM):
            rec[f"nu_{j}"] = float(nu[j]) if nu is not None and j < nu.size else math.nan
            rec[f"r_{j}"] = float(r_diag[j]) if r_diag is not None and j < r_diag.size else math.nan
        self.records.ledger.append(rec)

    def _record(self) -> None:
        self.records.sol_t.append(self.t)
        self.records.sol_x.append(self.x.copy())
        self.records.sol_p.append(np.diag(self.P).copy())
        # dr_N·dr_E, dr_N·dr_D, dr_E·dr_D, then the same for dv and phi (engine.P_CROSS_PAIRS)
        P = self.P
        self.records.sol_cross.append(
            np.array([P[b + i, b + j] for b in (0, 3, 6) for i, j in ((0, 1), (0, 2), (1, 2))])
        )

    def adaptation_state(self, sensor: str) -> Any:
        """The current noise-adaptation state of ``sensor`` (VB α, β; matching window; ...)."""
        return self._states[self._index[sensor]]

    def flush(self) -> None:
        """Drop every reading still queued (the IMU ended before its stamp), with a reason."""
        while self._pending:
            t_m, i, _, row, _ = heapq.heappop(self._pending)
            self._ledger(i, row, t_m, math.nan, "dropped", "after the last IMU sample")

    def output(self) -> EngineOutput:
        r = self.records
        return EngineOutput(
            np.asarray(r.sol_t),
            np.asarray(r.sol_x),
            np.asarray(r.sol_p),
            list(r.ledger),
            self.x.copy(),
            self.P.copy(),
            P_cross=np.asarray(r.sol_cross).reshape(-1, 9),
            events=sorted(self._hole_events + r.events, key=lambda e: float(e["t"])),
            q_scale=self._beta,
        )


def run_batch(
    config: EngineConfig,
    channels: Sequence[SensorChannel],
    x0: ArrayLike,
    P0: ArrayLike,
    t0: float,
    imu_t: ArrayLike,
    imu_dt: ArrayLike,
    dtheta: ArrayLike,
    dvel: ArrayLike,
    readings: Mapping[str, tuple[ArrayLike, ArrayLike]],
    imu_holes: tuple[ArrayLike, ArrayLike] | None = None,
) -> EngineOutput:
    """Run a whole mission: every reading queued, then the IMU fed through one Navigator.

    ``readings[name] = (t (n,), z (n, d))``; row numbers in the ledger index those arrays.
    """
    nav = Navigator(config, channels, x0, P0, t0)
    for name, (t, z) in readings.items():
        ts = np.asarray(t, dtype=float)
        zs = np.asarray(z, dtype=float).reshape(ts.size, -1)
        for row in range(ts.size):
            nav.feed_measurement(name, float(ts[row]), zs[row], row)
    nav.feed_imu(imu_t, imu_dt, dtheta, dvel, imu_holes)
    nav.flush()
    return nav.output()
