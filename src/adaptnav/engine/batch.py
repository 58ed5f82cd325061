"""Asynchronous multirate fusion engine: the only module that knows time.

docs/filters.md, 'Epochs' and 'Stacked update' (paper eqs. (9), (14), (18)-(22)). IMU intervals
``(t_k - dt_k, t_k]`` carry increments; sensor i delivers readings at its own epochs ``t^i``. A
:class:`Navigator` consumes both in time order:

* between sensor epochs the nominal state and P are propagated IMU interval by interval by the
  compiled kernel (:mod:`adaptnav.compiled.propagation`; docs/filters.md, 'Propagation', paper eqs.
  (10) and (11));
* epoch policy ``exact`` (default) splits the interval that contains a reading's stamp and
  updates at the stamp itself; ``grid`` (the paper) updates at the end ``t_k`` of the interval
  containing the stamp, i.e. a reading stamped in ``(t_{k-1}, t_k]`` is used at ``t_k``;
* readings sharing an epoch are stacked into one update: received mask S, stacked H, y and
  ``R = blockdiag(R_i)`` (paper eqs. (14), (20)-(22)); a sensor's adaptation state changes only
  at its own epochs (paper eqs. (18), (19), (29), (30));
* before the update each reading may pass an outlier gate (docs/filters.md, 'Gate'); after it
  the error estimate is fed back into the nominal state and reset to zero (closed loop;
  docs/filters.md, 'Feedback and reset').

Every reading's fate is written to the ledger: ``used``, ``rejected`` (rule, statistic,
threshold) or ``dropped`` (why). The batch runner :func:`run_batch` feeds whole tables through
the same :class:`Navigator` that a live system feeds sample by sample.

Speed: the engine runs compiled. Readings go to a store of arrays and a queue sorted by (stamp,
sensor, arrival), the order a heap would give them; :meth:`Navigator.feed_imu` hands an IMU chunk
and the queue to :func:`_navigate`, the compiled form of the time ordering above: it propagates to
the next reading (:func:`_advance`: whole intervals, an output row every ``output_every``, split
intervals; the steps of :mod:`adaptnav.compiled.propagation`), drops late readings, gathers an
epoch's readings and updates with them (:func:`adaptnav.compiled.update.epoch`: linearise, predict
the adaptation states, gate, stacked update, feedback, reset, ledger rows), until the chunk is used
up. Python sees a chunk once, not an epoch. Per-sensor settings and adaptation states are packed
into tables built once; ledger and output rows go to arrays that grow by doubling and become dicts /
arrays in :meth:`Navigator.output`. A sensor without a compiled linearisation
(:func:`~adaptnav.compiled.update.compiled_linearisation` is None) is linearised by its ``evaluate``
in Python: the loop returns at its epochs, which then go through the same compiled update. The noise
strategy must be :class:`~adaptnav.estimation.noise.FixedNoise`,
:class:`~adaptnav.estimation.noise.CovarianceMatching` or
:class:`~adaptnav.estimation.noise.VariationalBayes`, whose ``update`` methods are the readable
twins of the compiled update; ``tests/helpers/engine_reference.py`` keeps the engine as it was (a
Python loop, NumPy epochs) and the tests hold the two equal.
"""

from __future__ import annotations

import gc
import math
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.compiled import smoother as smk
from adaptnav.compiled import update as uk
from adaptnav.compiled.propagation import (
    _SERIES_LAT,
    State,
    Vec3,
    _extra_step,
    _flush,
    _lat_ref,
    _load,
    _pad,
    _store,
    _unpad,
    _width,
    block_full,
    jit,
    jit_inline,
    jit_nogil,
)
from adaptnav.core import earth
from adaptnav.engine import coldstart, prefault
from adaptnav.estimation.gate import Gate, Guard
from adaptnav.estimation.health import OFF, DivergenceGuard
from adaptnav.estimation.noise import (
    CovarianceMatching,
    FixedNoise,
    MatchingState,
    NoiseStrategy,
    VariationalBayes,
    VBState,
)
from adaptnav.estimation.noise.process import QAdaptation
from adaptnav.estimation.smoother import Nodes
from adaptnav.models import errorstate
from adaptnav.models.errorstate import (
    CORE,
    N_STATES,
    RESET_ATTITUDE,
    RESET_INVARIANT,
    RESET_OFF,
    StateLayout,
)
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.models.strapdown import NOM_SIZE
from adaptnav.sensors.base import MeasurementModel

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]
EpochPolicy = Literal["exact", "grid"]
MAX_DIM = uk.MAX_DIM
"""Largest sensor dimension; the ledger keeps this many innovation / R columns."""
SAME_EPOCH_S = 1e-9
"""Stamps closer than this are one epoch under the ``exact`` policy (float rounding)."""
P_CROSS_PAIRS: tuple[tuple[int, int], ...] = tuple(
    (b + i, b + j) for b in (0, 3, 6) for i, j in ((0, 1), (0, 2), (1, 2))
)
"""The off-diagonal elements ``P[i, j]`` of the position, velocity and attitude error blocks
recorded at every output row (:attr:`EngineOutput.P_cross`), in this order: dr_N·dr_E,
dr_N·dr_D, dr_E·dr_D, then the same for dv and phi."""
N_CROSS = len(P_CROSS_PAIRS)

LEDGER_KEYS: tuple[str, ...] = (
    "t", "t_epoch", "sensor", "row", "fate", "reason", "statistic", "threshold", "iterations",
    *(key for j in range(MAX_DIM) for key in (f"nu_{j}", f"r_{j}")),
)  # fmt: skip
"""Keys of a ledger row, in order."""
assert MAX_DIM == 3, "Navigator._ledger spells out the nu_j, r_j keys"


class LedgerRows(Sequence[dict[str, Any]]):
    """The engine's ledger: one row per reading, kept as columns (:attr:`columns`, keys
    :data:`LEDGER_KEYS`, arrays of equal length) and read as dicts, which are built on first use.

    Why: tens of thousands of dicts cost a run more than its compiled loop's updates, while a
    table is built from the columns directly (adaptnav.api.results.ledger_frame)."""

    def __init__(self, columns: dict[str, NDArray[Any]]) -> None:
        self.columns = columns

    @cached_property
    def _rows(self) -> list[dict[str, Any]]:
        values = [self.columns[k].tolist() for k in LEDGER_KEYS]
        gc_was_on = gc.isenabled()
        gc.disable()  # tens of thousands of new dicts: no cyclic garbage, no need to scan
        try:
            return [dict(zip(LEDGER_KEYS, row, strict=True)) for row in zip(*values, strict=True)]
        finally:
            if gc_was_on:
                gc.enable()

    def __len__(self) -> int:
        return len(self.columns["t"])

    @overload
    def __getitem__(self, i: int) -> dict[str, Any]: ...

    @overload
    def __getitem__(self, i: slice) -> list[dict[str, Any]]: ...

    def __getitem__(self, i: int | slice) -> dict[str, Any] | list[dict[str, Any]]:
        return self._rows[i]

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return iter(self._rows)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and list(self) == list(other)

    __hash__ = None  # type: ignore[assignment]  # equal to a list: not hashable either


AFTER_IMU_REASON = "after the last IMU sample"
"""Ledger reason of a reading stamped after the IMU's last sample (the engine drops it)."""
BEFORE_IMU_REASON = "before the first IMU sample"
"""Ledger reason of a reading stamped before the IMU's first interval starts (dropped before
the engine; docs/robustness.md, 'The ledger')."""
OUTSIDE_IMU_REASONS = frozenset({AFTER_IMU_REASON, BEFORE_IMU_REASON})

_FATES: dict[int, tuple[str, str]] = {
    uk.LEDGER_USED: ("used", ""),
    uk.LEDGER_REJECTED_COMPONENT: ("rejected", "gate component"),
    uk.LEDGER_REJECTED_CHI2: ("rejected", "gate chi2"),
    uk.LEDGER_DUPLICATE: ("dropped", "duplicate: sensor already at this epoch"),
    uk.LEDGER_INVALID: ("dropped", "invalid reading (non-finite)"),
    uk.LEDGER_LATE: ("dropped", "late: stamped before the current time"),
    uk.LEDGER_AFTER_IMU: ("dropped", AFTER_IMU_REASON),
    uk.LEDGER_REJECTED_GUARD: ("rejected", "guard chi2 (nominal R)"),
    uk.LEDGER_REJECTED_SINGULAR: ("rejected", "S not positive definite: P repaired"),
}
EVENT_KEYS: tuple[str, ...] = (
    "t", "sensor", "row", "event", "statistic", "threshold", "factor", "detail",
)  # fmt: skip
"""Keys of an event row (docs/robustness.md, divergence guard)."""
_EVENTS: dict[int, tuple[str, str]] = {
    uk.EVENT_NIS: ("nis", "mean NIS/d over the window above its threshold: P inflated"),
    uk.EVENT_LOCKOUT: ("lockout", "every reading rejected by the guard for the lockout time: "
                       "P inflated"),
    uk.EVENT_SINGULAR: ("covariance", "P not positive definite: repaired"),
    uk.EVENT_Q: ("q_scale", "innovations correlated: the IMU white noise in Q scaled by "
                 "the factor"),
}  # fmt: skip
HOLE_EVENT = "imu_hole"
"""Event of an IMU interval stretched over lost samples whose unknown motion was added to P."""
_NO_HOLE_K = np.zeros(0, dtype=np.int64)
_NO_HOLE_Q = np.zeros((0, 6))
_ONE_HOLE_K = np.zeros(1, dtype=np.int64)


def hole_event(t: float, dt: float, var: Sequence[float]) -> dict[str, Any]:
    """The event row of an IMU hole: the interval's end t, ``statistic`` its length (s), and
    the σ (root of the summed variances over the three axes) added to the velocity (m/s) and
    attitude (degrees) errors (docs/robustness.md, 'The σ over a hole')."""
    sv, sa = math.sqrt(sum(var[:3])), math.degrees(math.sqrt(sum(var[3:6])))
    detail = (
        f"IMU samples lost: the {dt:.6g}-s interval's motion unknown, P grown by σ = {sa:.3g}° "
        f"in attitude and {sv:.3g} m/s in velocity (the mission's own IMU over as long)"
    )
    return dict(
        zip(EVENT_KEYS, (t, "imu", -1, HOLE_EVENT, dt, math.nan, math.nan, detail), strict=True)
    )


COVARIANCE_BLOCK_S = 0.1
"""Default span of a covariance block (EngineConfig.covariance_block_s; docs/filters.md,
'Covariance blocks')."""
MAX_COVARIANCE_BLOCK_S = 1.0
"""Longest block allowed: the second-order Φ of a summed F stays accurate while F T is small."""
MIDPOINT_ITERATIONS = 2
"""Default iterations of the midpoint linearisation (EngineConfig.midpoint_iterations)."""
SMOOTHER_THREADS = 4
"""Most threads the backward pass smooths the nodes between update nodes in (at most the
cores this process may use; compiled.smoother.backward); its chain of update nodes is
sequential."""
_STRATEGIES = (FixedNoise, CovarianceMatching, VariationalBayes)
"""The closed set of noise strategies (estimation/noise/base.py, :class:`NoiseKind`)."""


@dataclass(frozen=True)
class SensorChannel:
    """One aiding sensor as the engine sees it: its model, nominal period, R strategy, gate."""

    model: MeasurementModel
    period: float
    strategy: NoiseStrategy
    gate: Gate | None = None
    guard: Guard | None = None
    """The nominal-R χ² guard (gate.Guard), tested before ``gate``."""

    @property
    def name(self) -> str:
        return self.model.name


@dataclass(frozen=True)
class EngineConfig:
    """Filter-wide settings: IMU noise, epoch policy, covariance reset, output decimation."""

    imu_noise: ImuNoise
    epoch_policy: EpochPolicy = "exact"
    reset_covariance: bool = True
    output_every: int = 10
    """Record the solution every this many IMU intervals (10 → 10 Hz at 100 Hz)."""
    specific_force_tau_s: float = 0.0
    """Time constant of the low-pass filter on the specific force that F is evaluated with
    (compiled.propagation._low_pass; 0: the measured one of each IMU interval, the default). A 1-s
    low-pass lags turns and waves, so F's ``[f×]`` differs from the true one and the filter claims a
    heading it does not have: Monte Carlo NEES and RMSE in docs/error-model.md."""
    at_rest: bool = False
    """The vehicle is known to be at rest (static alignment): F is evaluated with the specific
    force at rest, ``-g_n`` at the start position, exactly (no low-pass needed). With the
    measured one, its noise and the tilt estimate's wander make heading look observable and the
    alignment claims a heading σ it does not have (tests/unit/test_align.py)."""
    divergence: DivergenceGuard = OFF
    """The windowed NIS test (estimation/health.py); off here, set by the filter settings."""
    q_adaptation: QAdaptation | None = None
    """Q scaled by the whiteness of the innovations (estimation/noise/process.py); None: the
    configured Q throughout (here; the filter settings turn it on)."""
    layout: StateLayout = CORE
    """The error state: the 15 core states and any declared blocks (errorstate.StateLayout);
    x0 and P0 have its sizes."""
    smooth: bool = False
    """Keep what the RTS backward pass needs (compiled.smoother) and give the smoothed
    solution beside the forward one (:attr:`EngineOutput.smoothed`; docs/smoothing.md)."""
    midpoint_iterations: int = MIDPOINT_ITERATIONS
    """Iterations of the midpoint linearisation for the readings of a sensor whose model asks
    for it (``midpoint_update``: a DVL with a scale or misalignment state;
    compiled.update._midpoint, docs/calibration.md); 0: linearised at the prior as any other."""
    covariance_block_s: float = COVARIANCE_BLOCK_S
    """Propagate P over blocks of IMU steps of this length (s) with ``Φ = exp(Σ F_k T_k)`` to
    second order, closed early at every update and output row; 0: every step
    (docs/filters.md, 'Covariance blocks')."""
    invariant_reset: bool = True
    """With ``reset_covariance``, the reset also carries the velocity error in the attitude
    error's frame across the feedback (errorstate.reset_jacobian, RESET_INVARIANT;
    docs/filters.md, 'Feedback and reset'); False: the attitude block's reset only, as up to
    0.3.10."""

    def __post_init__(self) -> None:
        if self.epoch_policy not in ("exact", "grid"):
            raise ValueError(f"epoch_policy: value {self.epoch_policy!r} must be 'exact' or 'grid'")
        if self.midpoint_iterations < 0:
            raise ValueError(
                f"midpoint_iterations: value {self.midpoint_iterations!r} must be >= 0"
            )
        if self.output_every < 1:
            raise ValueError(f"output_every: value {self.output_every!r} must be >= 1")
        if not self.specific_force_tau_s >= 0.0:  # NaN too
            raise ValueError(
                f"specific_force_tau_s: value {self.specific_force_tau_s!r} must be >= 0"
            )
        if not 0.0 <= self.covariance_block_s <= MAX_COVARIANCE_BLOCK_S:  # NaN too
            raise ValueError(
                f"covariance_block_s: value {self.covariance_block_s!r} must be in "
                f"[0, {MAX_COVARIANCE_BLOCK_S:g}] s"
            )

    @property
    def reset_mode(self) -> int:
        """The reset the update kernel applies (errorstate.RESET_*)."""
        if not self.reset_covariance:
            return RESET_OFF
        return RESET_INVARIANT if self.invariant_reset else RESET_ATTITUDE


@dataclass(frozen=True)
class _Records:
    """The outputs so far: solution samples (t, x, diag P, the 3×3 blocks' off-diagonal
    elements :data:`P_CROSS_PAIRS`) and the ledger rows."""

    sol_t: Array
    sol_x: Array
    sol_p: Array
    ledger: Sequence[dict[str, Any]]
    sol_cross: Array
    events: list[dict[str, Any]]


@dataclass(frozen=True)
class Smoothed:
    """The RTS-smoothed solution at the forward pass's output rows (docs/smoothing.md): t, the
    nominal states (N, 16), P's diagonal (N, 15) and off-diagonal block elements (N, 9,
    :data:`P_CROSS_PAIRS`) as :class:`EngineOutput` has them, and what the store held."""

    t: Array
    x: Array
    P_diag: Array
    P_cross: Array
    nodes: int
    """Nodes stored by the forward pass (output rows and measurement epochs)."""
    update_nodes: int
    """Nodes with an update (their P before it is stored too)."""
    failed: int
    """Update nodes whose P⁻ was not positive definite: the nodes from the update node before
    up to them kept their filtered values (compiled.smoother.backward)."""
    store_bytes: int
    """Memory the store's nodes took (docs/smoothing.md, 'Memory')."""
    declared: Array = field(kw_only=True)
    """The declared states' smoothed values (N, m) and variances, as in :class:`EngineOutput`."""
    declared_var: Array = field(kw_only=True)


@dataclass(frozen=True)
class EngineOutput:
    """What a run produced: solution samples, per-reading ledger rows, final state.

    ``P_cross`` (N, 9): at each solution sample, the off-diagonal elements of P's position,
    velocity and attitude error blocks, ``P[i, j]`` for ``(i, j)`` in :data:`P_CROSS_PAIRS`
    (keyword only)."""

    t: Array
    x: Array  # (N, 16) nominal states
    P_diag: Array  # (N, 15)
    ledger: Sequence[dict[str, Any]]
    """One row per reading (keys :data:`LEDGER_KEYS`); from the engine a :class:`LedgerRows`."""
    x_final: Array
    P_final: Array
    P_cross: Array = field(kw_only=True)  # (N, 9)
    events: list[dict[str, Any]] = field(kw_only=True, default_factory=list)
    """The divergence guard's events (keys :data:`EVENT_KEYS`, estimation/health.py), in time
    order."""
    q_scale: float = field(kw_only=True, default=1.0)
    """β at the end: the factor on the IMU white-noise PSDs of Q (estimation/noise/process.py)."""
    smoothed: Smoothed | None = field(kw_only=True, default=None)
    """The RTS-smoothed solution when :attr:`EngineConfig.smooth` is on."""
    declared_names: tuple[str, ...] = field(kw_only=True, default=())
    """The declared states beyond the core (errorstate.StateLayout), e.g. calibration states."""
    declared: Array = field(kw_only=True, default_factory=lambda: np.zeros((0, 0)))
    """Their nominal values (N, m) at the solution samples."""
    declared_var: Array = field(kw_only=True, default_factory=lambda: np.zeros((0, 0)))
    """Their variances (N, m), P's diagonal, at the solution samples."""


def cross_terms(P: Array) -> Array:
    """The 9 off-diagonal elements of P's position, velocity and attitude blocks
    (:data:`P_CROSS_PAIRS`), as :attr:`EngineOutput.P_cross` records them."""
    Pa = np.asarray(P, dtype=float)
    return np.array([Pa[i, j] for i, j in P_CROSS_PAIRS])


def _grow(a: NDArray[Any], need: int) -> NDArray[Any]:
    """``a`` with at least ``need`` rows (doubling), the old rows kept."""
    if need <= a.shape[0]:
        return a
    out = np.zeros((max(need, 2 * a.shape[0]), *a.shape[1:]), dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


# --- the compiled time-ordering loop ------------------------------------------------------------
# The Navigator's state lives in small arrays that these functions update in place: the cursor
# ``cur`` (uk.C_*: time, start, length of and offset into the current IMU interval), the raw mean
# rates of the previous and current interval ``rates`` (uk.R_*), and the counters ``icur``.

I_START, I_DONE, I_HAVE_RATES, I_CLOSE, I_N_OUT, I_EVERY, I_HEAD, I_END, I_N_LEDGER = range(9)
I_HOLE = 9
"""``icur``: next interval of the chunk, intervals completed, rates known, an epoch completed the
interval, output rows, output decimation, first queued reading, end of the epoch's group,
ledger rows, the chunk's next IMU hole (:func:`_hole_psd`)."""
N_ICUR = 10
NO_HOLE = 1 << 62
"""The next hole's interval index when there is none left in the chunk."""
_ADVANCE_DONE, _ADVANCE_LATE, _ADVANCE_EPOCH = 0, 1, 2
NAV_DONE, NAV_PYTHON, NAV_SINGULAR, NAV_NOT_FINITE, NAV_POLE = 0, 1, 2, 3, 4
_MAX_LAT = earth.MAX_LAT_RAD  # a compile-time constant of the loop


class PoleError(ArithmeticError):
    """The navigation reached within ``90 - earth.MAX_LAT_DEG`` degrees of a pole, where the
    latitude-longitude mechanization is singular (core/earth.py ``MAX_LAT_DEG``): the engine
    stops there rather than write a longitude and heading that run away."""


@jit_inline
def _row(rates: Array, r: int) -> Vec3:
    return (rates[r, 0], rates[r, 1], rates[r, 2])


@jit
def _output_row(
    t: float,
    state: State,
    Pw: Array,
    icur: IntArray,
    out_t: Array,
    out_x: Array,
    out_p: Array,
    x: Array,
    P: Array,
    sm: smk.Store | None,
) -> None:
    """An output row, after every ``output_every``-th completed interval: t, x, and in
    ``out_p`` P's diagonal (15) then the off-diagonal elements of its position, velocity and
    attitude blocks (9, :data:`P_CROSS_PAIRS`); and when smoothing (a store ``sm``), its node
    (x and P are brought up to date for it). Called, not inlined: inlined, its many array
    arguments would cost reference counting at every interval, due or not."""
    o = icur[I_N_OUT]
    out_t[o] = t
    _store(out_x[o], state)
    for i in range(N_STATES):
        out_p[o, i] = Pw[i * 16 + i]
    for b in range(3):  # P_CROSS_PAIRS, spelt out
        a = 3 * b
        out_p[o, N_STATES + a] = Pw[a * 16 + a + 1]
        out_p[o, N_STATES + a + 1] = Pw[a * 16 + a + 2]
        out_p[o, N_STATES + a + 2] = Pw[(a + 1) * 16 + a + 2]
    icur[I_N_OUT] = o + 1
    for k in range(NOM_SIZE, x.shape[0]):  # declared states (errorstate.StateLayout)
        out_x[o, k] = x[k]
        out_p[o, N_STATES + N_CROSS + k - NOM_SIZE] = P[k - 1, k - 1]
    if sm is not None:
        _smoothing_row(sm, o, t, state, Pw, x, P)


@jit
def _smoothing_row(
    sm: smk.Store, o: int, t: float, state: State, Pw: Array, x: Array, P: Array
) -> None:
    """Output row o's smoother node (compiled.smoother.output_node), x and P brought up to date
    for it; not inlined, so that the propagation loop stays as lean as without smoothing."""
    _store(x, state)
    _unpad(Pw, P)
    smk.output_node(sm, o, t, x, P)


@jit_inline
def _engine_work(P: Array, q_psd: Array, rates: Array, wsp: Array) -> tuple[uk.Work, Array]:
    """The propagation's work arrays over the persistent rows ``wsp`` (uk.WS_PROP), the core of P
    copied into its padded rows, and the PSDs with the Q adaptation's β on the white-noise ones
    (estimation/noise/process.py; the array itself when β = 1)."""
    Pw = wsp[3]
    _pad(P, Pw)
    # n from the sizes at run time: LLVM then vectorizes the covariance's column loops
    # (compiled.propagation._work)
    wk = (wsp[0], wsp[1], wsp[2], Pw, _width(P, q_psd))
    beta = rates[uk.R_Q, 0]
    if beta != 1.0:
        q_psd = q_psd.copy()
        for c in range(6):
            q_psd[c] *= beta
    return wk, q_psd


@jit
def _close_block(
    wk: uk.Work,
    N: Array,
    x: Array,
    P: Array,
    q_psd: Array,
    cur: Array,
    sm: smk.Store | None,
    extra: bool,
) -> None:
    """Propagate the covariance over the open block, if any (compiled.propagation._flush), and
    hand its Φ to the smoother and the declared states, whose nominal values in x move with
    them (compiled.propagation._extra_step; docs/filters.md, 'Covariance blocks').

    Called, not inlined: :func:`_advance` closes blocks in five places, and five inlined copies
    of the covariance step doubled the kernels' compile time (bench/cold_bench.py)."""
    T_block = cur[uk.C_BLOCK]
    if T_block > 0.0:
        _flush(wk[3], wk[0], wk[1], wk[2], N, wk[4])
        if sm is not None:
            smk.accumulate(sm, wk[1])
        if extra:
            _extra_step(x, P, wk[1], wk[2], q_psd, T_block)
        cur[uk.C_BLOCK] = 0.0


@jit
def _hole_psd(
    q_psd: Array, hole_k: IntArray, hole_q: Array, idx: int, dt: float, icur: IntArray
) -> tuple[Array, int]:
    """The PSDs of a step of interval ``idx`` (of length dt) and the chunk's next hole from it
    on. At an IMU hole h (``hole_k[h] == idx``: an interval stretched over lost samples), the
    variances of its unknown motion ``hole_q[h]`` (velocity, attitude; body axes,
    mission.imu_holes) spread over the interval as white noise: ``q_psd[:6] + hole_q[h] / dt``,
    so that the interval's steps add them to P as process noise (S T over a step of span T,
    turned into the navigation frame with the step's attitude; docs/robustness.md, 'The σ over
    a hole'). Moves the pointer ``icur[I_HOLE]`` past the holes before idx. Called only when
    ``idx`` has reached the next hole: never on a run without holes."""
    h = icur[I_HOLE]
    nh = hole_k.shape[0]
    while h < nh and hole_k[h] < idx:
        h += 1
    icur[I_HOLE] = h
    if h == nh:
        return q_psd, NO_HOLE
    if hole_k[h] != idx:
        return q_psd, hole_k[h]
    q = q_psd.copy()
    for c in range(6):
        q[c] += hole_q[h, c] / dt
    return q, idx


@jit
def _advance(
    x: Array,
    P: Array,
    tk: Array,
    dts: Array,
    dth: Array,
    dv: Array,
    hole_k: IntArray,
    hole_q: Array,
    t_next: float,
    grid: bool,
    cur: Array,
    rates: Array,
    icur: IntArray,
    q_psd: Array,
    tau_a: float,
    tau_g: float,
    tau_f: float,
    block_s: float,
    out_t: Array,
    out_x: Array,
    out_p: Array,
    sm: smk.Store | None,
    wsp: Array,
    N: Array,
) -> int:
    """Propagate through the IMU intervals ``(tk - dts, tk]`` from ``icur[I_START]`` on until
    the earliest queued reading, stamped ``t_next`` (inf: none), must be acted on.

    Whole intervals one after the other (the steps of compiled.propagation.propagate_run), an
    output row after every ``output_every``-th completed one (:func:`_output_row`); the interval
    that contains t_next is begun (its rates; the previous ones carried) and propagated to t_next
    (``exact``, the steps of compiled.propagation.propagate_partial) or to its end (``grid``).
    Returns _ADVANCE_EPOCH (update now, at ``cur[C_T]``; an interval the update ends is completed
    on the next call), _ADVANCE_LATE (t_next is not after the current time) or _ADVANCE_DONE
    (chunk used up). Each loop turn chooses one (sub)step, so that the step is compiled once.

    The covariance moves in blocks (docs/filters.md, 'Covariance blocks'): each step adds its
    ``F T`` and ``½ S T`` to the open block (``wsp``, ``N``, its span in ``cur[C_BLOCK]``), which
    is closed once it spans ``block_s`` (0: every step), before an output row and before an
    update; a block still open when the chunk is used up stays open for the next call (P is then
    as of the block's start until :func:`finish_block`).

    ``hole_k`` (sorted) and ``hole_q``: the chunk's intervals stretched over lost IMU samples
    and their variances (:func:`_hole_psd`); empty without holes, when the loop only compares
    each step's interval index with :data:`NO_HOLE`."""
    n = tk.shape[0]
    h = icur[I_HOLE]
    hole_next = hole_k[h] if h < hole_k.shape[0] else NO_HOLE
    wk, q_psd = _engine_work(P, q_psd, rates, wsp)
    Pw = wk[3]
    extra = P.shape[0] > N_STATES  # declared state blocks (errorstate.StateLayout)
    state = _load(x)
    ref = _lat_ref(state[0])
    inv_tau = (1.0 / tau_a, 1.0 / tau_g)
    T_last, decay = -1.0, (1.0, 1.0, 0.0)
    f_lp = rates[uk.R_F_LP]
    status = _ADVANCE_DONE
    every = icur[I_EVERY]
    last = -1  # end of the run of whole intervals under way (-1: none)
    while True:
        if icur[I_CLOSE] != 0:  # an epoch at the end of its interval completed it
            icur[I_CLOSE] = 0
            icur[I_DONE] += 1
            if icur[I_DONE] % every == 0:
                _close_block(wk, N, x, P, q_psd, cur, sm, extra)
                _output_row(cur[uk.C_T], state, Pw, icur, out_t, out_x, out_p, x, P, sm)
        k = icur[I_START]
        t_start, dt, offset = cur[uk.C_T_START], cur[uk.C_DT], cur[uk.C_OFFSET]
        whole = offset >= dt
        if not whole:  # an interval split by an exact-time update is open: on to tau
            tau = dt
            if t_next <= t_start + dt:
                if t_next <= cur[uk.C_T]:
                    status = _ADVANCE_LATE
                    break
                status = _ADVANCE_EPOCH
                if not grid:
                    tau = t_next - t_start
            tau = min(max(tau, offset), dt)
            ta, tb = offset, tau
            wp, fp = _row(rates, uk.R_W_PREV), _row(rates, uk.R_F_PREV)
            wc, fc = _row(rates, uk.R_W_CUR), _row(rates, uk.R_F_CUR)
        else:
            if last < 0:  # where does the next run of whole intervals end?
                if k >= n:
                    break
                last = int(np.searchsorted(tk, t_next)) if t_next <= tk[n - 1] else n
                if last < n and t_next <= cur[uk.C_T]:
                    status = _ADVANCE_LATE
                    break
                if last > k and icur[I_HAVE_RATES] == 0:
                    for c in range(3):
                        rates[uk.R_W_CUR, c] = dth[k, c] / dts[k]
                        rates[uk.R_F_CUR, c] = dv[k, c] / dts[k]
                    icur[I_HAVE_RATES] = 1
            if k >= last:  # the run is done: stop at the chunk's end, or begin the interval
                if last == n:  # that contains t_next
                    icur[I_START] = n
                    break
                dt = dts[last]
                if icur[I_HAVE_RATES] == 0:
                    for c in range(3):
                        rates[uk.R_W_CUR, c] = dth[last, c] / dt
                        rates[uk.R_F_CUR, c] = dv[last, c] / dt
                    icur[I_HAVE_RATES] = 1
                for c in range(3):
                    rates[uk.R_W_PREV, c] = rates[uk.R_W_CUR, c]
                    rates[uk.R_F_PREV, c] = rates[uk.R_F_CUR, c]
                    rates[uk.R_W_CUR, c] = dth[last, c] / dt
                    rates[uk.R_F_CUR, c] = dv[last, c] / dt
                cur[uk.C_T_START] = tk[last] - dt
                cur[uk.C_DT] = dt
                cur[uk.C_OFFSET] = 0.0
                cur[uk.C_T] = cur[uk.C_T_START]
                icur[I_START] = last + 1
                last = -1
                continue
            dt = dts[k]
            ta, tb = 0.0, dt
            tau = dt
            wp, fp = _row(rates, uk.R_W_CUR), _row(rates, uk.R_F_CUR)
            wc = (dth[k, 0] / dt, dth[k, 1] / dt, dth[k, 2] / dt)
            fc = (dv[k, 0] / dt, dv[k, 1] / dt, dv[k, 2] / dt)
        if whole or tb > ta:  # one (sub)step [ta, tb] of an interval of length dt
            T = tb - ta
            if T_last != T:
                decay_f = math.exp(-T / tau_f) if tau_f > 0.0 else 0.0
                decay, T_last = (math.exp(-T / tau_a), math.exp(-T / tau_g), decay_f), T
            if abs(state[0] - ref[0]) >= 0.5 * _SERIES_LAT:
                ref = _lat_ref(state[0])
            q_step = q_psd
            idx = k if whole else icur[I_START] - 1
            if idx >= hole_next:  # an IMU hole, or past one (rare)
                q_step, hole_next = _hole_psd(q_psd, hole_k, hole_q, idx, dt, icur)
            state = uk.step(
                state, ref, wk, wp, fp, wc, fc, dt, ta, tb, decay, inv_tau, q_step, f_lp, N
            )
            cur[uk.C_BLOCK] += T
            if block_full(cur[uk.C_BLOCK], block_s):
                _close_block(wk, N, x, P, q_psd, cur, sm, extra)
        if whole:
            for c in range(3):
                rates[uk.R_W_CUR, c], rates[uk.R_F_CUR, c] = wc[c], fc[c]
            cur[uk.C_DT] = cur[uk.C_OFFSET] = dt
            cur[uk.C_T] = tk[k]
            cur[uk.C_T_START] = tk[k] - dt
            icur[I_START] = k + 1
            icur[I_DONE] += 1
            if icur[I_DONE] % every == 0:
                _close_block(wk, N, x, P, q_psd, cur, sm, extra)
                _output_row(tk[k], state, Pw, icur, out_t, out_x, out_p, x, P, sm)
            continue
        cur[uk.C_OFFSET] = tau
        cur[uk.C_T] = t_start + tau if tau < dt else t_start + dt
        if status == _ADVANCE_EPOCH:
            if tau >= dt:
                icur[I_CLOSE] = 1
            _close_block(wk, N, x, P, q_psd, cur, sm, extra)
            break
        icur[I_DONE] += 1
        if icur[I_DONE] % every == 0:
            _close_block(wk, N, x, P, q_psd, cur, sm, extra)
            _output_row(cur[uk.C_T], state, Pw, icur, out_t, out_x, out_p, x, P, sm)
    _store(x, state)
    _unpad(Pw, P)
    return status


@jit
def finish_block(
    x: Array,
    P: Array,
    q_psd: Array,
    cur: Array,
    rates: Array,
    sm: smk.Store | None,
    wsp: Array,
    N: Array,
) -> None:
    """Close the open covariance block (:func:`_advance`), so that P is current; with the Q
    adaptation's scale on the PSDs as :func:`_advance` applies it. (Python's way in: the end of
    the data, or P read between chunks.)"""
    if cur[uk.C_BLOCK] > 0.0:
        wk, q = _engine_work(P, q_psd, rates, wsp)
        _close_block(wk, N, x, P, q, cur, sm, P.shape[0] > N_STATES)
        _unpad(wk[3], P)


@jit
def _finite(x: Array) -> bool:
    """Whether every element of ``x`` is a finite number."""
    for v in x:  # noqa: SIM110 - a compiled loop: no generator
        if not math.isfinite(v):
            return False
    return True


@jit_nogil
def _navigate(
    x: Array,
    P: Array,
    tk: Array,
    dts: Array,
    dth: Array,
    dv: Array,
    hole_k: IntArray,
    hole_q: Array,
    q_t: Array,
    q_idx: IntArray,
    grid: bool,
    cur: Array,
    rates: Array,
    icur: IntArray,
    q_psd: Array,
    tau_a: float,
    tau_g: float,
    tau_f: float,
    block_s: float,
    out_t: Array,
    out_x: Array,
    out_p: Array,
    st_sensor: IntArray,
    st_z: Array,
    s_int: IntArray,
    s_flt: Array,
    s_state: Array,
    rings: Array,
    kind: int,
    reset: int,
    python_lin: bool,
    lg_int: IntArray,
    lg_flt: Array,
    ws: uk.Workspace,
    sm: smk.Store | None,
) -> int:
    """Run the IMU chunk against the queue (stamps q_t, readings q_idx, sorted; the first
    pending is ``icur[I_HEAD]``): propagate to the next reading; drop it if late; else gather
    the readings of its epoch (stamped <= the epoch, + SAME_EPOCH_S under ``exact``) and update
    with them (:func:`adaptnav.compiled.update.epoch`); until the chunk is used up (NAV_DONE).
    Returns early with NAV_PYTHON when the epoch's group ``icur[I_HEAD]..icur[I_END]`` has a
    reading to linearise in Python, NAV_SINGULAR if P was not finite (no repair possible),
    NAV_NOT_FINITE if the state x was not (a filter that diverged: a NaN or an infinity in the
    nominal state, checked after each stretch of propagation; up to 0.4.4 it ran on and wrote
    a solution of NaN), or NAV_POLE if its latitude was beyond ±``earth.MAX_LAT_DEG`` (up to
    0.4.7 it ran on there, its longitude swinging by radians, exit 0).

    ``sm``: the smoother's store, or None without smoothing; Numba prunes the ``sm is not None``
    branches here and in the functions it is passed to at compile time when its type is None, so
    a run without smoothing does not compile the smoother's code (a smoothed run compiles a
    second specialisation; bench/cold_bench.py)."""
    nq = q_t.shape[0]
    fb = np.zeros((0, uk.N_FB))  # no readings linearised in Python here
    while True:
        head = icur[I_HEAD]
        t_next = q_t[head] if head < nq else math.inf
        status = _advance(
            x, P, tk, dts, dth, dv, hole_k, hole_q, t_next, grid, cur, rates, icur, q_psd,
            tau_a, tau_g, tau_f, block_s, out_t, out_x, out_p, sm, ws[uk.WS_PROP], ws[uk.WS_NOISE],
        )  # fmt: skip
        if not _finite(x):
            return NAV_NOT_FINITE
        if not abs(x[0]) <= _MAX_LAT:
            return NAV_POLE
        if status == _ADVANCE_DONE:
            return NAV_DONE
        n = icur[I_N_LEDGER]
        if status == _ADVANCE_LATE:
            uk.ledger_drop(lg_int, lg_flt, n, q_idx[head], uk.LEDGER_LATE, cur[uk.C_T])
            icur[I_N_LEDGER] = n + 1
            icur[I_HEAD] = head + 1
            continue
        t_until = cur[uk.C_T] if grid else cur[uk.C_T] + SAME_EPOCH_S
        end = head
        while end < nq and q_t[end] <= t_until:
            end += 1
        icur[I_END] = end
        if python_lin:
            for k in range(head, end):
                if s_int[st_sensor[q_idx[k]], uk.S_CODE] == uk.LIN_PYTHON:
                    return NAV_PYTHON
        n = uk.epoch(
            x, P, rates, cur[uk.C_T], q_idx, head, end - head, st_sensor, st_z, fb, s_int,
            s_flt, s_state, rings, kind, reset, lg_int, lg_flt, n, ws,
        )  # fmt: skip
        icur[I_HEAD] = end
        if n < 0:
            icur[I_N_LEDGER] = -n - 1
            return NAV_SINGULAR
        icur[I_N_LEDGER] = n
        if sm is not None:
            smk.node(sm, cur[uk.C_T], x, uk.node_P(P, ws), ws[uk.WS_DX], ws[uk.WS_PRIOR])


def _pole_message(t: float, lat: float) -> str:
    side = "north" if lat > 0.0 else "south"
    return (
        f"the navigation reached latitude {math.degrees(lat):.5f}° at t = {t:.6g} s, within "
        f"{90.0 - earth.MAX_LAT_DEG:g}° of the {side} pole, where the latitude-longitude "
        "mechanization is singular and adaptnav does not navigate (docs/conventions.md); if the "
        "vehicle was not there, the filter drifted there (an initial position, velocity or "
        "heading far from the data's?)"
    )


def _not_finite_message(t: float) -> str:
    return (
        f"the navigation state is not finite at t = {t:.6g} s: the filter diverged (an "
        "initial state, a mounting or a noise setting far from the data's?)"
    )


def _off_the_earth(t: float, lat: float) -> Exception:
    """The error for a latitude beyond the limit: past ±90° it is no latitude but a filter
    that diverged (a state overflowing within one stretch: 1e12 m/s ran to 46510° in 0.3 s), a
    LinAlgError as a state not finite is; up to ±90° the pole, a :class:`PoleError`."""
    if abs(lat) > 0.5 * math.pi:
        return np.linalg.LinAlgError(
            f"the navigation state is out of range at t = {t:.6g} s (latitude "
            f"{math.degrees(lat):.6g}°): the filter diverged (an initial state, a mounting or a "
            "noise setting far from the data's?)"
        )
    return PoleError(_pole_message(t, lat))


class Navigator:
    """Streaming multirate ESKF: feed IMU intervals and sensor readings; read the solution.

    Readings may be fed ahead of the IMU (they wait in a time-ordered queue until the IMU covers
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
        self._kind = _strategy_kind(channels)
        self.config = config
        self.channels = tuple(channels)
        self._index = {c.name: i for i, c in enumerate(channels)}
        self.x = np.array(x0, dtype=float)
        self._P = np.array(P0, dtype=float)
        n = config.layout.n
        if self.x.shape != (config.layout.nominal_size,) or self._P.shape != (n, n):
            raise ValueError(f"x0 must be ({config.layout.nominal_size},), P0 ({n}, {n})")
        self._q = config.layout.kernel_psd(errorstate.noise_psd(config.imu_noise))
        self._tau_a = float(config.imu_noise.accel_bias_tau)
        self._tau_g = float(config.imu_noise.gyro_bias_tau)
        self._grid = config.epoch_policy == "grid"
        # The propagation cursor: the current IMU interval [t_start, t_start + dt] and how far
        # we are into it (offset), the previous and current interval's rates, counters.
        self._cur = np.zeros(uk.N_CUR)
        self._cur[uk.C_T] = self._cur[uk.C_T_START] = float(t0)
        self._rates = np.zeros((uk.N_RATES, 3))
        self._rates[uk.R_F_LP] = math.nan  # starts at the first step's specific force
        self._rates[uk.R_Q, :2] = 1.0  # β and β at the last q_scale event
        self._tau_f = config.specific_force_tau_s
        if config.at_rest:  # held at -g_n: decay exp(-T/inf) = 1
            self._rates[uk.R_F_LP] = -earth.gravity_n(self.x[0], self.x[2])
            self._tau_f = math.inf
        self._icur = np.zeros(N_ICUR, dtype=np.int64)
        self._icur[I_EVERY] = config.output_every
        self._build_tables()
        self._allocate()
        # None without smoothing: the compiled loop's smoother branches are then pruned by
        # Numba at compile time (the argument's type is None), not compiled and skipped
        self._sm = (
            smk.store(64, 16, config.layout.nominal_size, n, config.layout.extra_inv_tau())
            if config.smooth
            else None
        )
        self._smoothed: Smoothed | None = None
        self._prefault: prefault.Prefault | None = None
        self._state_cache: list[tuple[int, Any] | None] = [None] * len(self.channels)
        self._record()

    def _allocate(self) -> None:
        """The reading store, the queue of their indices, the ledger and the output rows, each
        grown by doubling as needed."""
        self._st_t = np.zeros(64)
        self._st_sensor = np.zeros(64, dtype=np.int64)
        self._st_row = np.zeros(64, dtype=np.int64)
        # A store row: the reading (MAX_DIM) then its own R diagonal (MAX_DIM; NaN: none).
        self._st_z = np.full((64, 2 * MAX_DIM), math.nan)
        self._n_store = 0
        self._python_z: dict[int, Array] = {}
        # The queue: store indices of the readings sorted by (t, sensor, arrival) and their
        # stamps, from the first pending one (icur[I_HEAD]) on; how many stored readings it has.
        self._q_idx = np.zeros(0, dtype=np.int64)
        self._q_t = np.zeros(0)
        self._n_queued = 0
        self._fb = np.zeros((8, uk.N_FB))
        self._lg_int = np.zeros((64, uk.N_LINT), dtype=np.int64)
        self._lg_flt = np.zeros((64, uk.N_LFLT))
        self._out_t = np.zeros(64)
        layout = self.config.layout
        self._out_x = np.zeros((64, layout.nominal_size))
        # diag P (the core's), P_CROSS_PAIRS, the declared states' variances
        self._out_p = np.zeros((64, layout.n + N_CROSS))
        # One IMU interval for feed_imu_sample: t, dt (1,), dtheta, dvel (1, 3).
        self._one = (np.zeros(1), np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)))
        self._hole_events: list[dict[str, Any]] = []

    def _build_tables(self) -> None:
        """Per-sensor settings, linearisations and initial adaptation states, packed."""
        n = len(self.channels)
        windows = [getattr(c.strategy, "window", 1) for c in self.channels]
        self._s_int = np.zeros((n, uk.N_SINT), dtype=np.int64)
        self._s_flt = np.zeros((n, uk.N_SFLT))
        self._s_state = np.zeros((n, uk.N_SSTATE))
        self._s_state[:, uk.X_LAST] = math.nan
        self._rings = np.zeros((n, 2, max(windows, default=1), MAX_DIM))
        for i, ch in enumerate(self.channels):
            d = int(ch.model.dim)
            if not 1 <= d <= MAX_DIM:
                raise ValueError(f"sensor {ch.name!r}: dimension {d} is not in 1..{MAX_DIM}")
            R = nominal_R(ch.model)
            spec = uk.compiled_linearisation(ch.model)
            si, sf, sx = self._s_int[i], self._s_flt[i], self._s_state[i]
            si[uk.S_CODE] = uk.LIN_PYTHON if spec is None else spec[0]
            if spec is not None:
                sf[: uk.N_PAR] = spec[1]
            si[uk.S_DIM] = d
            sf[uk.F_RNOM : uk.F_RNOM + 9] = _block3(R)
            sf[uk.F_PERIOD] = ch.period
            if getattr(ch.model, "midpoint_update", False):
                si[uk.S_MIDPOINT] = self.config.midpoint_iterations
            if ch.guard is not None:
                si[uk.S_GUARD] = 1
                sf[uk.F_GUARD_Q] = ch.guard.threshold(d)
                sf[uk.F_GUARD_K] = ch.guard.headroom
                sf[uk.F_LOCKOUT_S], sf[uk.F_LOCKOUT_MAX] = ch.guard.lockout_s, ch.guard.lockout_max
            dg = self.config.divergence
            sf[uk.F_DIV_NIS] = dg.nis_ratio
            sf[uk.F_DIV_WINDOW], sf[uk.F_INFLATE_MAX] = dg.window, dg.inflate_max
            sx[uk.X_WT] = math.nan
            qa = self.config.q_adaptation
            if qa is not None:
                sf[uk.F_QA_GAIN], sf[uk.F_QA_TARGET] = qa.gain, qa.target
                sf[uk.F_QA_MAX], sf[uk.F_QA_WINDOW] = qa.beta_max, qa.window
            sx[uk.X_REJ_SINCE] = sx[uk.X_PASSED] = math.nan
            sf[uk.F_RMIN], sf[uk.F_RMAX] = 0.0, math.inf
            if ch.gate is not None:
                rule = uk.GATE_COMPONENT if ch.gate.rule == "component" else uk.GATE_CHI2
                si[uk.S_GATE] = rule
                nominal = ch.gate.reference == "nominal"
                si[uk.S_GATE_REF] = uk.GATE_REF_NOMINAL if nominal else uk.GATE_REF_ADAPTED
                sf[uk.F_GATE_Q] = ch.gate.q
            _pack_strategy(ch.strategy, R, d, si, sf, sx, self._rings[i])
        self._python_lin = bool(np.any(self._s_int[:, uk.S_CODE] == uk.LIN_PYTHON))
        self._ws = uk.workspace(n, self.config.layout.n, self.config.smooth)

    @property
    def t(self) -> float:
        """The navigator's current time (s)."""
        return float(self._cur[uk.C_T])

    @property
    def P(self) -> Array:
        """The error covariance at :attr:`t`. While a covariance block is open (docs/filters.md,
        'Covariance blocks') the engine's own P is as of the block's start; this is then a copy
        with the block closed, and reading it changes nothing in the run."""
        if not self._cur[uk.C_BLOCK] > 0.0:
            return self._P
        P = self._P.copy()
        finish_block(
            self.x.copy(), P, self._q, self._cur.copy(), self._rates, None,
            self._ws[uk.WS_PROP].copy(), self._ws[uk.WS_NOISE].copy(),
        )  # fmt: skip
        return P

    # --- feeding ------------------------------------------------------------------------------

    def _check_reading(self, i: int, z: ArrayLike) -> Array:
        zz = np.atleast_1d(np.asarray(z, dtype=float))
        d = int(self._s_int[i, uk.S_DIM])
        if zz.shape != (d,):
            raise ValueError(
                f"{self.channels[i].name} reading must have shape ({d},), got {zz.shape}"
            )
        return zz

    def feed_measurement(
        self,
        sensor: str,
        t: float,
        z: ArrayLike,
        row: int = -1,
        r_diag: ArrayLike | None = None,
    ) -> None:
        """Queue a reading of ``sensor`` stamped ``t``; it is processed once the IMU covers t.

        ``r_diag`` (d,): this reading's own measurement variances, replacing the sensor's nominal
        R for it (the oracle baseline's known per-reading noise); default: the sensor's.
        """
        if sensor not in self._index:
            raise KeyError(f"unknown sensor {sensor!r}; configured: {list(self._index)}")
        i = self._index[sensor]
        k = self._reserve_store(1)
        self._st_t[k], self._st_sensor[k], self._st_row[k] = t, i, row
        self._st_z[k] = math.nan
        if r_diag is not None:
            self._st_z[k, MAX_DIM : MAX_DIM + int(self._s_int[i, uk.S_DIM])] = self._r_diag(
                i, r_diag, 1
            )[0]
        if self._s_int[i, uk.S_CODE] == uk.LIN_PYTHON:
            self._python_z[k] = np.asarray(z, dtype=float)
        else:
            zz = self._check_reading(i, z)
            self._st_z[k, : zz.size] = zz
        self._n_store = k + 1

    def feed_measurements(
        self,
        sensor: str,
        t: ArrayLike,
        z: ArrayLike,
        rows: ArrayLike | None = None,
        r_diag: ArrayLike | None = None,
    ) -> None:
        """Queue many readings of ``sensor`` at once: stamps ``t`` (n,), readings ``z`` (n, d),
        ledger row numbers ``rows`` (default 0..n-1), own variances ``r_diag`` (n, d) or None;
        as n calls of :meth:`feed_measurement`."""
        if sensor not in self._index:
            raise KeyError(f"unknown sensor {sensor!r}; configured: {list(self._index)}")
        i = self._index[sensor]
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        n = ts.size
        if n == 0:
            return
        zs = np.asarray(z, dtype=float).reshape(n, -1)
        rw = np.arange(n) if rows is None else np.asarray(rows, dtype=np.int64).reshape(n)
        k0 = self._reserve_store(n)
        self._st_t[k0 : k0 + n] = ts
        self._st_sensor[k0 : k0 + n] = i
        self._st_row[k0 : k0 + n] = rw
        self._st_z[k0 : k0 + n] = math.nan
        if r_diag is not None:
            d = int(self._s_int[i, uk.S_DIM])
            self._st_z[k0 : k0 + n, MAX_DIM : MAX_DIM + d] = self._r_diag(i, r_diag, n)
        if self._s_int[i, uk.S_CODE] == uk.LIN_PYTHON:
            for r in range(n):
                self._python_z[k0 + r] = zs[r]
        else:
            self._check_reading(i, zs[0])
            self._st_z[k0 : k0 + n, : zs.shape[1]] = zs
        self._n_store = k0 + n

    def _r_diag(self, i: int, r_diag: ArrayLike, n: int) -> Array:
        """Per-reading variances (n, d) of sensor i, checked: finite and positive."""
        d = int(self._s_int[i, uk.S_DIM])
        r = np.asarray(r_diag, dtype=float)
        if r.size != n * d:
            raise ValueError(f"{self.channels[i].name}: r_diag must have {n} x {d} values")
        r = r.reshape(n, d)
        if not np.all(np.isfinite(r) & (r > 0.0)):
            raise ValueError(f"{self.channels[i].name}: r_diag must be finite and positive")
        return r

    def _sort_queue(self) -> None:
        """Merge the readings fed since the last call into the queue, in the order (t, sensor,
        arrival): the order in which they are taken (ties at one stamp: sensor order)."""
        if self._n_queued == self._n_store:
            return
        head = int(self._icur[I_HEAD])
        idx = np.concatenate(
            [self._q_idx[head:], np.arange(self._n_queued, self._n_store, dtype=np.int64)]
        )
        t = self._st_t[idx]
        order = np.lexsort((idx, self._st_sensor[idx], t))
        self._q_idx = idx[order]
        self._q_t = t[order]
        self._icur[I_HEAD] = 0
        self._n_queued = self._n_store

    def _reserve_store(self, n: int) -> int:
        k = self._n_store
        if k + n > self._st_t.shape[0]:
            self._st_t = _grow(self._st_t, k + n)
            self._st_sensor = _grow(self._st_sensor, k + n)
            self._st_row = _grow(self._st_row, k + n)
            self._st_z = _grow(self._st_z, k + n)
        return k

    def feed_imu(
        self,
        t: ArrayLike,
        dt: ArrayLike,
        dtheta: ArrayLike,
        dvel: ArrayLike,
        holes: tuple[ArrayLike, ArrayLike] | None = None,
    ) -> None:
        """Integrate IMU intervals ``(t_k - dt_k, t_k]`` with increments, processing every queued
        reading they cover, in time order. ``holes``: the indices (into this chunk, sorted) of
        intervals stretched over lost samples and the variances of their unknown motion (n, 6):
        velocity (m²/s²) then attitude (rad²), body axes (mission.imu_holes); each is added to P
        over its interval as process noise and recorded as an event ``imu_hole``
        (docs/robustness.md, 'The σ over a hole'). Since 0.4.13; up to 0.4.12 P grew over such
        an interval by the IMU's white noise alone."""
        tk = np.require(np.atleast_1d(np.asarray(t, dtype=float)), np.float64, ["C", "W"])
        dts = np.broadcast_to(np.asarray(dt, dtype=float), tk.shape).copy()
        dth = np.require(np.atleast_2d(np.asarray(dtheta, dtype=float)), np.float64, ["C", "W"])
        dv = np.require(np.atleast_2d(np.asarray(dvel, dtype=float)), np.float64, ["C", "W"])
        n = tk.size
        if tk.ndim != 1 or dth.shape != (n, 3) or dv.shape != (n, 3):
            raise ValueError(
                f"IMU: t must be (N,), dtheta and dvel (N, 3); got {tk.shape}, {dth.shape}, "
                f"{dv.shape}"
            )
        hole_k, hole_q = self._holes(tk, dts, holes)
        self._run(tk, dts, dth, dv, hole_k, hole_q)

    def _holes(
        self, tk: Array, dts: Array, holes: tuple[ArrayLike, ArrayLike] | None
    ) -> tuple[IntArray, Array]:
        """The chunk's holes as the compiled loop takes them, checked, and their events."""
        if holes is None:
            return _NO_HOLE_K, _NO_HOLE_Q
        k = np.ascontiguousarray(np.asarray(holes[0], dtype=np.int64).reshape(-1))
        q = np.ascontiguousarray(np.asarray(holes[1], dtype=float).reshape(-1, 6))
        if k.size != q.shape[0] or np.any(np.diff(k) <= 0) or np.any((k < 0) | (k >= tk.size)):
            raise ValueError("IMU holes: sorted indices into the chunk, one row of 6 each")
        if not np.all(np.isfinite(q) & (q >= 0.0)):
            raise ValueError("IMU holes: variances must be finite and >= 0")
        for j, v in zip(k.tolist(), q.tolist(), strict=True):
            self._hole_events.append(hole_event(float(tk[j]), float(dts[j]), v))
        return k, q

    def feed_imu_sample(
        self,
        t: float,
        dt: float,
        dtheta: ArrayLike,
        dvel: ArrayLike,
        hole: ArrayLike | None = None,
    ) -> None:
        """:meth:`feed_imu` of one interval ``(t - dt, t]``, for a caller that has its samples one
        at a time (adaptnav.api.stream): the same loop, without the conversions of a chunk's
        arrays (docs/streaming.md, 'Latency'). ``hole``: the interval's 6 variances when it is
        stretched over lost samples (:meth:`feed_imu`'s ``holes``)."""
        one = self._one
        one[0][0], one[1][0] = t, dt
        one[2][0], one[3][0] = dtheta, dvel
        if hole is None:
            self._run(*one, _NO_HOLE_K, _NO_HOLE_Q)
        else:  # an interval stretched over lost samples (api.Stream.push_imu)
            self._run(*one, *self._holes(one[0], one[1], (_ONE_HOLE_K, hole)))

    def _run(
        self, tk: Array, dts: Array, dth: Array, dv: Array, hole_k: IntArray, hole_q: Array
    ) -> None:
        """The compiled loop over the IMU chunk, returning to Python only for the epochs of
        sensors linearised by their ``evaluate``."""
        if self._smoothed is not None:
            raise RuntimeError("the navigator has been smoothed: it takes no more IMU data")
        n = tk.size
        self._icur[I_START] = 0
        self._icur[I_HOLE] = 0
        self._reserve_output(n // self.config.output_every + 2)
        self._sort_queue()
        self._compile_cold(tk, dts, dth, dv)
        while True:
            pending = self._q_idx.size - int(self._icur[I_HEAD])
            self._reserve_ledger(pending)
            self._reserve_nodes(n // self.config.output_every + 2, pending)
            status = _navigate(
                self.x, self._P, tk, dts, dth, dv, hole_k, hole_q, self._q_t, self._q_idx,
                self._grid, self._cur, self._rates, self._icur, self._q, self._tau_a, self._tau_g,
                self._tau_f, self.config.covariance_block_s, self._out_t,
                self._out_x, self._out_p, self._st_sensor, self._st_z, self._s_int,
                self._s_flt, self._s_state, self._rings, self._kind,
                self.config.reset_mode, self._python_lin, self._lg_int, self._lg_flt,
                self._ws, self._sm,
            )  # fmt: skip
            if status == NAV_DONE:
                return
            if status == NAV_SINGULAR:
                raise np.linalg.LinAlgError(
                    f"the error covariance P is not finite at t = {self.t:.6g} s"
                )
            if status == NAV_NOT_FINITE:
                raise np.linalg.LinAlgError(_not_finite_message(self.t))
            if status == NAV_POLE:
                raise _off_the_earth(self.t, float(self.x[0]))
            self._epoch_python()

    def _epoch_args(self) -> tuple[Any, ...]:
        """Arguments of the types :func:`_navigate` calls the epoch with."""
        return (
            self.x, self._P, self._rates, 0.0, self._q_idx, 0, 0, self._st_sensor, self._st_z,
            np.zeros((0, uk.N_FB)), self._s_int, self._s_flt, self._s_state, self._rings,
            self._kind, self.config.reset_mode, self._lg_int, self._lg_flt, 0, self._ws,
        )  # fmt: skip

    def _advance_args(self, tk: Array, dts: Array, dth: Array, dv: Array) -> tuple[Any, ...]:
        """Arguments of the types :func:`_navigate` calls :func:`_advance` with."""
        ws = self._ws
        return (
            self.x, self._P, tk, dts, dth, dv, _NO_HOLE_K, _NO_HOLE_Q, 0.0, self._grid,
            self._cur, self._rates,
            self._icur, self._q, self._tau_a, self._tau_g, self._tau_f,
            self.config.covariance_block_s, self._out_t, self._out_x, self._out_p, self._sm,
            ws[uk.WS_PROP], ws[uk.WS_NOISE],
        )  # fmt: skip

    def _compile_cold(self, tk: Array, dts: Array, dth: Array, dv: Array) -> None:
        """On a cold start (the compiled loop neither compiled in this process nor in Numba's
        cache), the measurement epoch compiled by a second process while this one compiles the
        propagation loop and :func:`finish_block`, for the argument types :func:`_navigate`
        uses; then :func:`_navigate`'s compilation finds the epoch in the cache
        (engine/coldstart.py; docs/performance.md, 'Cold start')."""
        if _COLD_CHECKED.is_set():  # the common case, at every IMU sample of a stream
            return
        with _COLD_LOCK:  # once per process, also with navigators in threads
            if _COLD_CHECKED.is_set():
                return
            _COLD_CHECKED.set()
            if kernels_cached() is not False:
                return
            child = coldstart.compile_aside(uk.epoch, self._epoch_args())
            coldstart.compile_here(_advance, self._advance_args(tk, dts, dth, dv))
            ws = self._ws
            coldstart.compile_here(
                finish_block,
                (self.x, self._P, self._q, self._cur, self._rates, self._sm, ws[uk.WS_PROP],
                 ws[uk.WS_NOISE]),
            )  # fmt: skip
            coldstart.join(child)

    # --- measurement epochs -------------------------------------------------------------------

    def _epoch_python(self) -> None:
        """The epoch of the group icur[I_HEAD]..icur[I_END] when it has readings of sensors
        linearised by their ``evaluate``: those in Python, then the same compiled update."""
        head, end = int(self._icur[I_HEAD]), int(self._icur[I_END])
        g = end - head
        self._fb = _grow(self._fb, g)
        self._evaluate_in_python(head, g)
        n = uk.epoch(
            self.x, self._P, self._rates, self.t, self._q_idx, head, g, self._st_sensor,
            self._st_z, self._fb, self._s_int, self._s_flt, self._s_state, self._rings,
            self._kind, self.config.reset_mode, self._lg_int, self._lg_flt,
            int(self._icur[I_N_LEDGER]), self._ws,
        )  # fmt: skip
        self._icur[I_HEAD] = end
        if n < 0:
            self._icur[I_N_LEDGER] = -n - 1
            raise np.linalg.LinAlgError(
                f"the error covariance P is not finite at t = {self.t:.6g} s"
            )
        self._icur[I_N_LEDGER] = n
        if not _finite(self.x):  # as the compiled loop checks it
            raise np.linalg.LinAlgError(_not_finite_message(self.t))
        if not abs(self.x[0]) <= _MAX_LAT:
            raise _off_the_earth(self.t, float(self.x[0]))
        if self._sm is not None:
            ws, P = self._ws, self._P
            smk.node(self._sm, self.t, self.x, uk.node_P(P, ws), ws[uk.WS_DX], ws[uk.WS_PRIOR])

    def _evaluate_in_python(self, head: int, g: int) -> None:
        """Linearise the group's readings of sensors without a compiled linearisation by their
        ``evaluate`` into the fallback rows (a sensor's later readings are duplicates)."""
        seen: set[int] = set()
        w = self._rates[uk.R_W_CUR].copy()
        for k in range(g):
            idx = int(self._q_idx[head + k])
            i = int(self._st_sensor[idx])
            if self._s_int[i, uk.S_CODE] != uk.LIN_PYTHON or i in seen:
                continue
            meas = self.channels[i].model.evaluate(self.x, self._python_z[idx], w)
            row = self._fb[k]
            row[:] = 0.0
            if meas is None:
                continue
            seen.add(i)
            d = meas.y.size
            row[uk.FB_VALID] = 1.0
            row[uk.FB_Y : uk.FB_Y + d] = meas.y
            row[uk.FB_H : uk.FB_H + N_STATES * d] = np.asarray(meas.H, dtype=float).ravel()
            row[uk.FB_R : uk.FB_R + 9] = _block3(meas.R)

    def _reserve_ledger(self, n: int) -> None:
        # A reading has one fate row and may trigger an event (lockout or NIS); an epoch
        # adds at most one covariance event: three rows per reading at most.
        need = int(self._icur[I_N_LEDGER]) + 3 * n + 1
        self._lg_int = _grow(self._lg_int, need)
        self._lg_flt = _grow(self._lg_flt, need)

    def _events(self) -> list[dict[str, Any]]:
        """The event rows so far as dicts (keys :data:`EVENT_KEYS`), the IMU holes' among them
        in time order."""
        n = int(self._icur[I_N_LEDGER])
        li, lf = self._lg_int[:n], self._lg_flt[:n]
        out = list(self._hole_events)
        for r in np.flatnonzero(li[:, uk.L_CODE] >= uk.EVENT_NIS).tolist():
            idx = int(li[r, uk.L_STORE])
            event, detail = _EVENTS[int(li[r, uk.L_CODE])]
            out.append(
                dict(
                    zip(
                        EVENT_KEYS,
                        (
                            float(lf[r, uk.L_T_EPOCH]),
                            self.channels[int(self._st_sensor[idx])].name,
                            int(self._st_row[idx]),
                            event,
                            float(lf[r, uk.L_STAT]),
                            float(lf[r, uk.L_THRESHOLD]),
                            float(lf[r, uk.L_FACTOR]),
                            detail,
                        ),
                        strict=True,
                    )
                )
            )
        if self._hole_events:  # stable: an event at a hole's end before the epoch's there
            out.sort(key=lambda e: float(e["t"]))
        return out

    def _ledger(self) -> LedgerRows:
        """The ledger rows so far (keys :data:`LEDGER_KEYS`, in that order); events
        (:meth:`_events`) are not readings' fates and are left out."""
        n = int(self._icur[I_N_LEDGER])
        fates_only = self._lg_int[:n, uk.L_CODE] < uk.EVENT_NIS
        li, lf = self._lg_int[:n][fates_only], self._lg_flt[:n][fates_only]
        idx = li[:, uk.L_STORE]
        names = np.array([c.name for c in self.channels], dtype=object)
        codes = sorted(_FATES)
        which = np.searchsorted(codes, li[:, uk.L_CODE])
        fate = np.array([_FATES[c][0] for c in codes], dtype=object)[which]
        reason = np.array([_FATES[c][1] for c in codes], dtype=object)[which]
        columns: dict[str, NDArray[Any]] = {
            "t": self._st_t[idx],
            "t_epoch": lf[:, uk.L_T_EPOCH].copy(),
            "sensor": names[self._st_sensor[idx]],
            "row": self._st_row[idx],
            "fate": fate,
            "reason": reason,
            "statistic": lf[:, uk.L_STAT].copy(),
            "threshold": lf[:, uk.L_THRESHOLD].copy(),
            "iterations": li[:, uk.L_ITER].copy(),
        }
        for j in range(MAX_DIM):
            columns[f"nu_{j}"] = lf[:, uk.L_NU + j].copy()
            columns[f"r_{j}"] = lf[:, uk.L_R + j].copy()
        return LedgerRows({k: columns[k] for k in LEDGER_KEYS})

    def _reserve_output(self, n: int) -> None:
        need = int(self._icur[I_N_OUT]) + n
        self._out_t = _grow(self._out_t, need)
        self._out_x = _grow(self._out_x, need)
        self._out_p = _grow(self._out_p, need)

    def _record(self) -> None:
        self._reserve_output(1)
        self._reserve_nodes(1, 0)
        n = int(self._icur[I_N_OUT])
        self._out_t[n] = self.t
        self._out_x[n] = self.x
        self._out_p[n, :N_STATES] = np.diag(self._P)[:N_STATES]
        self._out_p[n, N_STATES : N_STATES + N_CROSS] = cross_terms(self._P)
        self._out_p[n, N_STATES + N_CROSS :] = np.diag(self._P)[N_STATES:]
        self._icur[I_N_OUT] = n + 1
        if self._sm is not None:
            smk.output_node(self._sm, n, self.t, self.x, self._P)

    def _reserve_nodes(self, rows: int, readings: int) -> None:
        """Room in the smoother's store, if any, for ``rows`` output rows and ``readings``
        epochs."""
        if self._sm is None:
            return
        counts = self._sm[smk.SM_COUNT]
        nodes, priors = int(counts[smk.K_NODES]), int(counts[smk.K_PRIORS])
        old, self._sm = self._sm, smk.grown(self._sm, nodes + rows + readings, priors + readings)
        # the rows this chunk may write, of the arrays just allocated, faulted in by a helper
        fresh = [
            self._sm[k][first : first + more]
            for keys, first, more in (
                (smk.NODE_ARRAYS, nodes, rows + readings),
                (smk.UPDATE_ARRAYS, priors, readings),
            )
            for k in keys
            if self._sm[k] is not old[k]
        ]
        if fresh:
            self._stop_prefault()
            self._prefault = prefault.start(fresh)

    def _stop_prefault(self) -> None:
        """Stop the helper faulting in the store's pages, if any (engine.prefault)."""
        if self._prefault is not None:
            self._prefault.stop()
            self._prefault = None

    @property
    def records(self) -> _Records:
        """The solution samples and ledger rows so far (copies)."""
        n = int(self._icur[I_N_OUT])
        return _Records(
            self._out_t[:n].copy(),
            self._out_x[:n, :NOM_SIZE].copy(),
            self._out_p[:n, :N_STATES].copy(),
            self._ledger(),
            self._out_p[:n, N_STATES : N_STATES + N_CROSS].copy(),
            self._events(),
        )

    @property
    def n_rows(self) -> int:
        """How many solution rows have been recorded so far (the first at t0)."""
        return int(self._icur[I_N_OUT])

    def rows(self, start: int) -> tuple[Array, Array, Array, Array, Array, Array]:
        """The solution rows from ``start`` on, as :meth:`output` has them (copies): t, the
        nominal states (k, 16), P's diagonal (k, 15), its block elements (k, 9,
        :data:`P_CROSS_PAIRS`), the declared states' values and variances (k, m); what a caller
        feeding sample by sample reads after each sample, without :attr:`records`' ledger."""
        n = int(self._icur[I_N_OUT])
        x, p = self._out_x[start:n], self._out_p[start:n]
        return (
            self._out_t[start:n].copy(), x[:, :NOM_SIZE].copy(), p[:, :N_STATES].copy(),
            p[:, N_STATES : N_STATES + N_CROSS].copy(), x[:, NOM_SIZE:].copy(),
            p[:, N_STATES + N_CROSS :].copy(),
        )  # fmt: skip

    def adaptation_state(self, sensor: str) -> Any:
        """The current noise-adaptation state of ``sensor`` (VB α, β; matching window; ...).

        The same object is returned until the sensor's state changes."""
        i = self._index[sensor]
        version = int(self._s_int[i, uk.S_VERSION])
        cached = self._state_cache[i]
        if cached is not None and cached[0] == version:
            return cached[1]
        d = int(self._s_int[i, uk.S_DIM])
        sx = self._s_state[i]
        state: Any = None
        if self._kind == uk.KIND_VB:
            state = VBState(
                sx[uk.X_ALPHA : uk.X_ALPHA + d].copy(), sx[uk.X_BETA : uk.X_BETA + d].copy()
            )
        elif self._kind == uk.KIND_MATCHING:
            w = int(self._s_int[i, uk.S_WINDOW])
            R = sx[uk.X_MR : uk.X_MR + 9].reshape(3, 3)[:d, :d].copy()
            state = MatchingState(
                self._rings[i, 0, :w, :d].copy(),
                self._rings[i, 1, :w, :d].copy(),
                int(self._s_int[i, uk.S_COUNT]),
                R,
            )
        self._state_cache[i] = (version, state)
        return state

    def flush(self) -> None:
        """Bring P up to the current time (close the open covariance block) and drop every
        reading still queued (the IMU ended before its stamp), with a reason."""
        finish_block(
            self.x, self._P, self._q, self._cur, self._rates, self._sm, self._ws[uk.WS_PROP],
            self._ws[uk.WS_NOISE],
        )  # fmt: skip
        self._sort_queue()
        head, n = int(self._icur[I_HEAD]), int(self._icur[I_N_LEDGER])
        rest = self._q_idx[head:]
        self._reserve_ledger(rest.size)
        self._lg_int[n : n + rest.size] = 0
        self._lg_int[n : n + rest.size, uk.L_STORE] = rest
        self._lg_int[n : n + rest.size, uk.L_CODE] = uk.LEDGER_AFTER_IMU
        self._lg_flt[n : n + rest.size] = math.nan
        self._icur[I_N_LEDGER] = n + rest.size
        self._icur[I_HEAD] = self._q_idx.size

    def smoother_nodes(self) -> Nodes:
        """The forward pass's node store as the readable smoother takes it
        (:class:`adaptnav.estimation.smoother.Nodes`: full matrices, Φ diagonal on the declared
        states); before :meth:`smooth`, which overwrites the store."""
        sm = self._sm
        if sm is None or self._smoothed is not None:
            raise RuntimeError("no forward store: smoothing is off or the store was smoothed")
        counts = sm[smk.SM_COUNT]
        N, n = int(counts[smk.K_NODES]), self.config.layout.n
        P = _unpacked(sm[smk.SM_P][:N], n)
        prior_idx = sm[smk.SM_PRIOR][:N]
        Pm = _unpacked(sm[smk.SM_PM][: int(counts[smk.K_PRIORS])], n)
        P_prior = P.copy()  # P⁻ = P at a node without an update (there may be none with one)
        P_prior[prior_idx >= 0] = Pm[prior_idx[prior_idx >= 0]]
        dx = np.zeros((N, n))
        dx[prior_idx >= 0] = sm[smk.SM_DX][prior_idx[prior_idx >= 0]]
        Phi = np.tile(np.eye(n), (N, 1, 1))
        stored = sm[smk.SM_PHI][:N]
        Phi[:, :9, :N_STATES] = stored[:, : smk.PHI_DIAG].reshape(N, 9, N_STATES)
        Phi[:, range(9, N_STATES), range(9, N_STATES)] = stored[:, smk.PHI_DIAG : smk.N_PHI]
        Phi[:, range(N_STATES, n), range(N_STATES, n)] = stored[:, smk.N_PHI :]
        return Nodes(
            sm[smk.SM_T][:N].copy(), sm[smk.SM_X][:N].copy(), dx, P,
            P_prior, Phi, self.config.reset_mode,
            sm[smk.SM_OUT][: int(self._icur[I_N_OUT])].copy(),
        )  # fmt: skip

    def smooth(self) -> Smoothed:
        """Run the RTS backward pass over everything fed so far (compiled.smoother.backward) and
        return the smoothed solution at the output rows; the navigator then takes no more IMU
        data (the store is smoothed in place). Needs :attr:`EngineConfig.smooth`."""
        sm = self._sm
        if sm is None:
            raise RuntimeError("smoothing needs EngineConfig(smooth=True) from the start")
        if self._smoothed is None:
            self._stop_prefault()  # the rows it has not reached are not needed
            threads = min(SMOOTHER_THREADS, coldstart.cores())
            counts = sm[smk.SM_COUNT]
            nodes, priors = int(counts[smk.K_NODES]), int(counts[smk.K_PRIORS])
            rows = int(self._icur[I_N_OUT])
            idx = sm[smk.SM_OUT][:rows]
            n = self.config.layout.n
            pairs = [
                *((i, i) for i in range(N_STATES)), *P_CROSS_PAIRS,
                *((i, i) for i in range(N_STATES, n)),
            ]  # fmt: skip
            columns = np.array([smk.packed_index(i, j, n) for i, j in pairs], dtype=np.int64)
            slot = np.full(nodes, -1, dtype=np.int64)
            slot[idx] = np.arange(rows)  # a node of two rows has the later: the other is gathered
            x, p = np.empty((rows, sm[smk.SM_X].shape[1])), np.empty((rows, columns.size))
            done = np.zeros(rows, dtype=np.bool_)
            # the solution reports P^s's diagonal and P_CROSS_PAIRS only (smk.reported); the
            # rows between update nodes are filled as the pass smooths them, the rest gathered
            smk.backward(sm, self.config.reset_mode, threads, full=False,
                         rows=(slot, columns, x, p, done))  # fmt: skip
            rest = np.flatnonzero(~done)
            if rest.size:
                x[rest], p[rest] = smk.gather(sm, idx[rest], columns)
            per_node = sum(sm[k][:1].nbytes for k in smk.NODE_ARRAYS)
            per_update = sum(sm[k][:1].nbytes for k in smk.UPDATE_ARRAYS)
            self._smoothed = Smoothed(
                self._out_t[:rows].copy(),
                x[:, :NOM_SIZE],
                p[:, :N_STATES],
                p[:, N_STATES : N_STATES + N_CROSS],
                nodes,
                priors,
                int(counts[smk.K_FAILED]),
                nodes * per_node + priors * per_update,
                declared=x[:, NOM_SIZE:],
                declared_var=p[:, N_STATES + N_CROSS :],
            )
        return self._smoothed

    def output(self) -> EngineOutput:
        n = int(self._icur[I_N_OUT])
        return EngineOutput(
            self._out_t[:n].copy(),
            self._out_x[:n, :NOM_SIZE].copy(),
            self._out_p[:n, :N_STATES].copy(),
            self._ledger(),
            self.x.copy(),
            self._P.copy(),
            P_cross=self._out_p[:n, N_STATES : N_STATES + N_CROSS].copy(),
            declared_names=self.config.layout.names[N_STATES:],
            declared=self._out_x[:n, NOM_SIZE:].copy(),
            declared_var=self._out_p[:n, N_STATES + N_CROSS :].copy(),
            events=self._events(),
            q_scale=float(self._rates[uk.R_Q, 0]),
            smoothed=self.smooth() if self.config.smooth else None,
        )


def _unpacked(packed: Array, n: int) -> Array:
    """(k, n, n) symmetric matrices from their packed upper triangles (k, n(n+1)/2), as
    compiled.smoother.pack lays them out."""
    iu = np.triu_indices(n)
    out = np.zeros((packed.shape[0], n, n))
    out[:, iu[0], iu[1]] = packed
    return out + np.triu(out, 1).transpose(0, 2, 1)


def _strategy_kind(channels: Sequence[SensorChannel]) -> int:
    """The kernel's code of the channels' one noise strategy (estimation/noise/base.py);
    sensor names must be unique."""
    names = [c.name for c in channels]
    if len(set(names)) != len(names):
        raise ValueError(f"sensor names must be unique, got {names}")
    kinds = {type(c.strategy) for c in channels}
    if len(kinds) > 1:
        raise ValueError("all sensors of one filter must use the same noise strategy class")
    if not kinds:
        return uk.KIND_FIXED
    cls = kinds.pop()
    if cls not in _STRATEGIES:
        raise TypeError(
            f"noise strategy {cls.__name__} has no compiled update; the strategies are a "
            "closed set: FixedNoise, CovarianceMatching and VariationalBayes"
        )
    return int(cls.kind)


def _pack_strategy(
    st: NoiseStrategy, R: Array, d: int, si: IntArray, sf: Array, sx: Array, ring: Array
) -> None:
    """One sensor's noise strategy into its rows of the kernel's tables: settings into ``si``
    and ``sf``, initial adaptation state into ``sx`` and its matching ``ring``
    (estimation/noise/vb.py, estimation/noise/matching.py)."""
    if isinstance(st, VariationalBayes):
        vb0 = st.initial_state(R)
        si[uk.S_ITER] = st.iterations
        sf[uk.F_RHO], sf[uk.F_TOL] = st.rho, st.tol
        sf[uk.F_IRREGULAR] = float(st.irregular)
        sf[uk.F_DOF] = st.dof if st.dof is not None else 0.0
        sf[uk.F_WEIGHTS_ONLY] = float(st.weights_only)
        sf[uk.F_RMIN], sf[uk.F_RMAX] = st.r_floor, st.r_ceiling
        sx[uk.X_ALPHA : uk.X_ALPHA + d] = vb0.alpha
        sx[uk.X_BETA : uk.X_BETA + d] = vb0.beta
    elif isinstance(st, CovarianceMatching):
        m0 = st.initial_state(R)
        si[uk.S_WINDOW] = st.window
        sf[uk.F_FLOOR], sf[uk.F_RAE] = st.floor, float(st.residual_based)
        sf[uk.F_RMAX], sf[uk.F_GAP] = st.ceiling, st.gap_periods
        ring[0, : st.window, :d] = m0.squares
        ring[1, : st.window, :d] = m0.hph
        si[uk.S_COUNT] = m0.count
        sx[uk.X_MR : uk.X_MR + 9] = _block3(m0.R)


def _block3(R: ArrayLike) -> Array:
    """A d×d matrix (d ≤ 3) in the top-left of a 3×3 one, flattened row-major."""
    Ra = np.asarray(R, dtype=float)
    out = np.zeros((MAX_DIM, MAX_DIM))
    out[: Ra.shape[0], : Ra.shape[1]] = Ra
    return out.ravel()


def nominal_R(model: MeasurementModel) -> Array:
    """The nominal measurement noise covariance R of a sensor model (its ``R``)."""
    R = getattr(model, "R", None)
    if R is None:
        raise TypeError(f"sensor {model.name!r} exposes no nominal R")
    return np.asarray(R() if callable(R) else R, dtype=float)


Phase = Literal["aligning", "filtering", "smoothing"]
"""The steps of a run a caller may show (``adaptnav.api.run``'s ``progress``): the static
alignment, the forward filter, the RTS backward pass (docs/smoothing.md)."""

Progress = Callable[[Phase], None]
"""Called with each :data:`Phase` as it begins."""


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
    readings: Mapping[str, tuple[ArrayLike, ...]],
    progress: Progress | None = None,
    imu_holes: tuple[ArrayLike, ArrayLike] | None = None,
) -> EngineOutput:
    """Run a whole mission: every reading queued, then the IMU fed through one Navigator.

    ``readings[name] = (t (n,), z (n, d))`` or ``(t, z, r_diag (n, d))`` with each reading's
    own variances; row numbers in the ledger index those arrays. ``progress`` hears
    ``"filtering"`` before the IMU is fed and, for a smoothed run, ``"smoothing"`` before the
    backward pass. The IMU goes in one piece either way: fed in 50 chunks (for a progress bar)
    a run differed from the one-piece run by up to 5e-16 in the solution (probably the series
    reference latitude, which the compiled loop takes afresh on each call). ``imu_holes``:
    :meth:`Navigator.feed_imu`'s ``holes``.
    """
    say = progress or (lambda _phase: None)
    nav = Navigator(config, channels, x0, P0, t0)
    for name, (t, z, *r_diag) in readings.items():
        nav.feed_measurements(name, t, z, r_diag=r_diag[0] if r_diag else None)
    say("filtering")
    nav.feed_imu(imu_t, imu_dt, dtheta, dvel, imu_holes)
    nav.flush()
    if config.smooth:
        say("smoothing")
    return nav.output()


_COLD_LOCK = threading.Lock()
_COLD_CHECKED = threading.Event()
"""Set once :meth:`Navigator._compile_cold` has looked at the cache in this process."""


def kernels_cached() -> bool | None:
    """Whether the engine's compiled loop is in Numba's on-disk cache for this source (False:
    the next run compiles the kernels first, a minute or two); None when Numba does not say.
    Reads the cache's index only, as Numba does to decide (a missing or stale index: compile)."""
    cache = getattr(_navigate, "_cache", None)
    try:
        return bool(cache._cache_file._load_index())  # type: ignore[union-attr]
    except Exception:  # a Numba without this cache layout: no answer, not a failure
        return None
