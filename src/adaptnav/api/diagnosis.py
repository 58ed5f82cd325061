"""After a run: the aiding sensors the filter found at odds with the INS and the other sensors.

The load-time checks (docs/robustness.md) catch readings that are not numbers, lie outside
physical limits, are stuck, or are stamped outside the IMU's time. A sensor can pass them all
and still be wrong: a DVL logged in knots, one mounted backwards (x negated), a velocity
bias of many σ, a wrong ``mounting_rpy_deg``. The filter then sees it, in one of two ways
depending on its kind:

* a filter with a fixed R (MESKF, the oracle) or a gate (MESKF, MAESKF) **rejects** most of the
  sensor's readings (the guard's χ² on the nominal R, or the gate);
* an adaptive filter (MAESKF, VB-MAESKF, robust) **raises R̂** until the readings fit: it takes
  them, with a variance of 400 or more times the configured one (σ twenty times the
  configured σ), or pinned at the ceiling of its bounded R̂ (``r_bounds``; robust: 100) if that
  is lower.

Either way the sensor has stopped informing the solution, or informs it wrongly, while the run
ends as if nothing happened. This module turns that into a **warning** (not an error: a sensor
may be legitimately bad for a stretch, and the filter has then done the right thing): per aiding
sensor, over every window of :data:`WINDOW_S` seconds of the readings that reached the filter
(used or rejected), the share of *disagreeing* readings

    share = (rejected by the guard or the gate + used with some r̂_j ≥ limit_j) / readings,
    limit_j = min(ceiling, RATIO) · R_nominal,jj  (less a relative 1e-6, so a clipped R̂ counts),

and the sensor is flagged when a window of at least :data:`MIN_READINGS` readings has a share
above :data:`SHARE`. A burst shorter than half the window (a spike, ten seconds of a depth at
+1000 m) is not flagged: the ledger and the guard's events already say what happened to it.

A second warning looks at what the filter took: a consistent Kalman filter's innovations are
white (Mehra 1970), and a sensor whose errors are correlated from reading to reading (a GNSS
receiver's multipath over a minute, a DVL's scale and mounting errors) leaves innovations that
are not. Per aiding sensor that is not a motion constraint (the NHC's and ZUPT's residuals are
the vehicle's own motion), over its used readings in time order, each component's long-run
variance factor F of its innovations (:func:`adaptnav.estimation.long_run.variance_factor`: 1
for white ones, ``(1 + ρ) / (1 - ρ)`` for a lag-1 correlation ρ) is computed, and the sensor is
flagged when some F ≥ :data:`CORRELATED_FACTOR` over at least :data:`CORRELATED_READINGS`
readings: the filter then counts the readings as more independent than they are and its σ is
too small, by up to √F.

The same test on the scores of a sensor's calibration states (``long_run_factor`` of
``calibration.json``, adaptnav.api.runner) flags the sensor when some factor is at least
:data:`CALIBRATION_FACTOR` (:func:`calibration_correlated`): a slow error of the sensor that the
filter does not model, which biases a calibration estimate beyond its σ (docs/calibration.md,
'A slow DVL error').

A third warning is about time, not disagreement: a sensor with more than
:data:`OUTSIDE_SHARE` of its readings (and at least :data:`OUTSIDE_READINGS`) stamped before the
IMU's first sample or after its last. Each such reading has its ledger row, but half a DVL lost
after the IMU's log stopped, or a sensor on another clock, is not what a user expects a run to
have done quietly.

The warnings go into the run's ``meta.warnings`` (``summary.json``), the command line prints
them after the run and with ``evaluate``, and the report shows them. The thresholds and what
they separate on the simulated trials, the real data and the faulty sensors:
docs/robustness.md, 'Sensors at odds with the rest'.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.api.results import Result
from adaptnav.engine.batch import AFTER_IMU_REASON, BEFORE_IMU_REASON, SensorChannel, nominal_R
from adaptnav.estimation.long_run import variance_factor
from adaptnav.estimation.noise.matching import CovarianceMatching
from adaptnav.estimation.noise.vb import VariationalBayes
from adaptnav.sensors.depth import Depth
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.gnss import GNSS
from adaptnav.sensors.heading import Heading
from adaptnav.sensors.inclinometer import Inclinometer, PendulumInclinometer

Array = NDArray[np.float64]

WINDOW_S = 60.0
"""Length of the sliding window over a sensor's readings, s."""
SHARE = 0.5
"""A window whose share of disagreeing readings is above this flags the sensor."""
MIN_READINGS = 10
"""A window with fewer readings than this is not judged (too few to say)."""
RATIO = 400.0
"""R̂ at this many times the nominal variance (σ 20× the configured one), or at the ceiling of
a bounded R̂ if that is lower, counts as disagreement. The simulated trials raise a DVL's σ up
to tenfold for minutes (docs/simulation.md), which an adaptive R̂ follows: 100 would flag them."""
DISAGREEING = frozenset({"gate component", "gate chi2", "guard chi2 (nominal R)"})
"""Ledger reasons of a rejection that says the reading disagreed with the prediction (not, e.g.,
a covariance repair)."""
OUTSIDE_SHARE = 0.05
"""A sensor with more than this share of its readings stamped outside the IMU's time is
flagged (:func:`outside_imu`)..."""
OUTSIDE_READINGS = 5
"""...when they are at least this many: a reading or two either side of the IMU is the usual
difference between two loggers' start and stop."""
OUTSIDE_HINT = (
    "a log cut short, or the sensor's clock on another origin or offset than the IMU's "
    "(docs/robustness.md, 'The ledger')"
)
CORRELATED_FACTOR = 2.5
"""Long-run variance factor of a component's innovations at or above which the sensor is
flagged as correlated (docs/robustness.md, 'Correlated readings': 0.9-1.2 for the adaptive
filters' sensors on the simulated trials, 2.9-3.8 for ten minutes of simulated GNSS fixes
given as white, 3.0-6.0 for the A-KIT DVL's x axis)."""
CORRELATED_READINGS = 100
"""Fewer used readings than this are not judged for correlation."""
_INDEPENDENT = "the filter takes their errors as independent, so its σ is too small"
_SEE_CORRELATED = 'docs/robustness.md, "Correlated readings"'
CORRELATED_HINTS: tuple[tuple[tuple[type, ...], str], ...] = (
    (
        (GNSS,),
        'give its errors a bias state with their correlation time (estimate = ["bias"], '
        "calibration.bias.tau) or thin its fixes (min_interval_s)",
    ),
    (
        (DVL,),
        'estimate its scale and misalignment (estimate = ["scale", "misalignment"]); where it '
        "does, a slow error: a Gauss-Markov bias with that error's σ and correlation time "
        '(estimate = ["bias"], calibration.bias = {sigma, tau})',
    ),
    (
        (Inclinometer, PendulumInclinometer),
        'a slow drift or tilt error: estimate its biases (estimate = ["bias"], with a random '
        "walk, calibration.bias.random_walk)",
    ),
    (
        (Depth,),
        'an offset that drifts: estimate its bias (estimate = ["bias"], with a random walk)',
    ),
    (
        (Heading,),
        "a compass's deviation, which changes with the heading: a larger sigma, or a heading "
        "sensor that is not magnetic",
    ),
)
"""What to do about a sensor kind's correlated innovations (:func:`correlated`); a kind not
listed gets :data:`CORRELATED_HINT`."""
CORRELATED_HINT = (
    f"{_INDEPENDENT}; a GNSS's correlated "
    'errors: give them a bias state with their correlation time (estimate = ["bias"], '
    "calibration.bias.tau) or thin its fixes (min_interval_s); a DVL's: estimate its scale and "
    f'misalignment (estimate = ["scale", "misalignment"]); {_SEE_CORRELATED}'
)
HINT = (
    "either the sensor's configuration is wrong (its units, sign, mounting_rpy_deg, lever "
    "arm or sigma) or the filter's model is ([imu.noise], or an adaptive R that ran away: "
    "try --filter robust), or the IMU's axes are (a sign flipped or two axes swapped in its "
    "table: every aiding sensor then disagrees); docs/robustness.md, 'Sensors at odds with "
    "the rest'"
)


class _Warning:
    """A warning's record as ``meta.warnings`` keeps it (JSON values)."""

    def as_dict(self) -> dict[str, Any]:
        record: dict[str, Any] = asdict(self)  # type: ignore[call-overload]
        return record


@dataclass(frozen=True)
class SensorWarning(_Warning):
    """One sensor the filter found at odds with the rest (module docstring)."""

    sensor: str
    readings: int
    """Its readings that reached the filter (used or rejected)."""
    rejected: int
    """Of these, rejected by the guard or the gate."""
    at_limit: int
    """Of these, used with an R̂ at the limit."""
    worst_share: float
    """The highest share of disagreeing readings in a window."""
    t_from: float
    t_to: float
    """The span of the windows above :data:`SHARE` (first start, last end), s."""
    message: str


def disagreeing(
    ledger: pd.DataFrame, sensor: str, r_nominal: Array, ceiling: float
) -> tuple[Array, NDArray[np.bool_], NDArray[np.bool_]]:
    """Of ``sensor``'s readings that reached the filter, in time order: their stamps, and
    which were rejected by the guard or the gate, and which were used with an R̂ at the limit
    (module docstring). ``r_nominal``: the nominal R's diagonal."""
    rows = ledger[(ledger["sensor"] == sensor) & ledger["fate"].isin(("used", "rejected"))]
    rows = rows.sort_values("t", kind="stable")
    rejected = (rows["fate"] == "rejected").to_numpy() & rows["reason"].isin(DISAGREEING).to_numpy()
    d = r_nominal.size
    r = rows[[f"r_{j}" for j in range(d)]].to_numpy(dtype=float)
    limit = min(ceiling, RATIO) * r_nominal * (1.0 - 1e-6)
    high = (rows["fate"] == "used").to_numpy() & np.any(r >= limit, axis=1)
    return rows["t"].to_numpy(dtype=float), rejected, high


def windows(t: Array, bad: NDArray[np.bool_]) -> tuple[float, float, float]:
    """Over every window of :data:`WINDOW_S` starting at a reading, ``[t_i, t_i + WINDOW_S]``,
    moved back to end at the last reading where it would run past it (so a burst at the end of
    a run is judged in a whole window, like any other; a run shorter than the window is one
    window), with at least :data:`MIN_READINGS` readings: the highest share of ``bad``, and the
    span (first start, last end) of the windows above :data:`SHARE` (NaN, NaN if none)."""
    n = t.size
    if n < MIN_READINGS:
        return 0.0, math.nan, math.nan
    start = np.maximum(t[0], np.minimum(t, t[-1] - WINDOW_S))
    first = np.searchsorted(t, start, side="left")
    end = np.searchsorted(t, start + WINDOW_S, side="right")
    counts = end - first
    cum = np.concatenate(([0], np.cumsum(bad)))
    share = (cum[end] - cum[first]) / counts
    share[counts < MIN_READINGS] = 0.0
    over = np.flatnonzero(share > SHARE)
    if over.size == 0:
        return float(share.max()), math.nan, math.nan
    return float(share.max()), float(t[first[over[0]]]), float(t[end[over[-1]] - 1])


def diagnose(
    ledger: pd.DataFrame, nominal: Mapping[str, Array], ceilings: Mapping[str, float]
) -> list[SensorWarning]:
    """The sensors of ``nominal`` (name → the nominal R's diagonal) that the run's ``ledger``
    shows at odds with the rest, in that order; ``ceilings``: each sensor's R̂ ceiling as a
    factor of the nominal variance (inf: unbounded, or a fixed R)."""
    out = []
    for name, r_nominal in nominal.items():
        ceiling = ceilings.get(name, math.inf)
        t, rejected, high = disagreeing(ledger, name, np.asarray(r_nominal, dtype=float), ceiling)
        worst, t_from, t_to = windows(t, rejected | high)
        if math.isnan(t_from):
            continue
        limit = min(ceiling, RATIO)
        message = (
            f"{name}: at odds with the INS and the other sensors from t = {t_from:.1f} to "
            f"{t_to:.1f} s (up to {100 * worst:.0f} % of its readings in {WINDOW_S:.0f} s; "
            f"over the run {int(rejected.sum())} of {t.size} rejected, {int(high.sum())} used "
            f"with R̂ at {limit:g} × its nominal variance): {HINT}"
        )
        counts = int(t.size), int(rejected.sum()), int(high.sum())
        out.append(SensorWarning(name, *counts, worst, t_from, t_to, message))
    return out


@dataclass(frozen=True)
class CorrelationWarning(_Warning):
    """One sensor whose innovations are correlated (module docstring)."""

    sensor: str
    readings: int
    """Its used readings."""
    component: str
    """The component with the largest factor."""
    factor: float
    """That component's long-run variance factor."""
    message: str
    kind: str = "correlated"


def _correlation_hint(model: object) -> str:
    """The sensor kind's advice on correlated innovations (:data:`CORRELATED_HINTS`), else
    :data:`CORRELATED_HINT`."""
    for kinds, own in CORRELATED_HINTS:
        if isinstance(model, kinds):
            return f"{_INDEPENDENT}; {own}; {_SEE_CORRELATED}"
    return CORRELATED_HINT


def innovation_factors(ledger: pd.DataFrame, sensor: str, d: int) -> tuple[int, Array]:
    """The number of ``sensor``'s used readings and, per component of its d, the long-run
    variance factor of its innovations in time order (NaN for fewer than
    :data:`CORRELATED_READINGS` finite ones)."""
    rows = ledger[(ledger["sensor"] == sensor) & (ledger["fate"] == "used")]
    rows = rows.sort_values("t", kind="stable")
    out = np.full(d, math.nan)
    for j in range(d):
        column = f"nu_{j}"
        if column not in rows:
            continue
        nu = rows[column].to_numpy(dtype=float)
        nu = nu[np.isfinite(nu)]
        if nu.size >= CORRELATED_READINGS:
            out[j] = variance_factor(nu)
    return len(rows), out


def correlated(ledger: pd.DataFrame, channels: Sequence[SensorChannel]) -> list[CorrelationWarning]:
    """The sensors of ``channels`` (motion constraints left out) whose innovations in the run's
    ``ledger`` are correlated (module docstring), in that order."""
    out = []
    for c in channels:
        if getattr(c.model, "CONSTRAINT", False):
            continue
        names = tuple(getattr(c.model, "names", ()))
        n, factors = innovation_factors(ledger, c.name, c.model.dim)
        if not np.any(factors >= CORRELATED_FACTOR):
            continue
        j = int(np.nanargmax(factors))
        component = names[j] if j < len(names) else f"{c.name}_{j}"
        f = float(factors[j])
        message = (
            f"{c.name}: its innovations are correlated from reading to reading ({component}: "
            f"long-run variance {f:.1f} × their variance over {n} readings, 1 when white): "
            f"{_correlation_hint(c.model)}"
        )
        out.append(CorrelationWarning(c.name, n, component, f, message))
    return out


CALIBRATION_FACTOR = 2.0
"""Long-run variance factor of a calibration state's scores (``long_run_factor`` in
``calibration.json``) at or above which its sensor is flagged (:func:`calibration_correlated`).
Paper-1, robust, DVL scale and misalignment estimated (docs/calibration.md, 'A slow DVL
error'): with white DVL readings every state's factor was 0.9-1.3 over 30 seeds; with a slow
AR(1) error of 2.5 cm/s under them the scale's, pitch's and yaw's were 2.1-5.4 (10 seeds), of
5 cm/s 4.3-13.2 (30 seeds); with a Gauss-Markov bias state modelling that error, 1.0-1.4."""
CALIBRATION_HINT = (
    "a slow error of the sensor that the filter does not model, under which a calibration "
    "estimate can be off by many σ and even sigma_long_run is a lower bound (paper-1, a DVL "
    "error of 5 cm/s correlated over 6.5-33 s: the scale +1.7 to +2.2 % for a true 1 %, σ "
    "0.15 %); model it (a Gauss-Markov bias with the error's σ and correlation time: "
    'estimate = ["bias"], calibration.bias = {sigma, tau}) and compare missions; '
    "docs/calibration.md, 'A slow DVL error'"
)


@dataclass(frozen=True)
class CalibrationWarning(_Warning):
    """A sensor whose calibration states' scores are correlated (:func:`calibration_correlated`)."""

    sensor: str
    state: str
    """Its calibration state with the largest factor."""
    factor: float
    """That state's long-run variance factor."""
    message: str
    kind: str = "calibration_correlated"


def calibration_correlated(
    factors: Sequence[tuple[str, str, float | None]],
) -> list[CalibrationWarning]:
    """Per sensor of ``factors`` ``(sensor, state, long-run factor or None)``, in their order, a
    warning when one of its calibration states has a factor of at least
    :data:`CALIBRATION_FACTOR`, naming the state with the largest. The factor is the run's own
    test of what the state's σ assumes, that the readings which move it are independent
    (adaptnav.api.runner, '_long_run_factor'); when they are not, its σ is too small, and a
    slow error also biases the estimate, which no factor of σ covers."""
    worst: dict[str, tuple[str, float]] = {}
    for sensor, state, f in factors:
        if f is not None and f >= CALIBRATION_FACTOR and f > worst.get(sensor, ("", 0.0))[1]:
            worst[sensor] = (state, float(f))
    return [
        CalibrationWarning(
            sensor, state, f,
            f"{sensor}: the readings that estimate its calibration are correlated ({state}: "
            f"long-run variance factor {f:.1f}, 1 when independent): {CALIBRATION_HINT}",
        )
        for sensor, (state, f) in worst.items()
    ]  # fmt: skip


@dataclass(frozen=True)
class OutsideImuWarning(_Warning):
    """One sensor with many readings stamped outside the IMU's time (module docstring)."""

    sensor: str
    readings: int
    """Its readings in the ledger (every fate)."""
    before: int
    """Of these, stamped before the IMU's first sample."""
    after: int
    """Of these, stamped after the IMU's last sample."""
    message: str
    kind: str = "outside_imu"


def outside_imu(ledger: pd.DataFrame) -> list[OutsideImuWarning]:
    """The sensors of the run's ``ledger`` (sorted) of whose readings more than
    :data:`OUTSIDE_SHARE`, and at least :data:`OUTSIDE_READINGS`, are stamped before the IMU's
    first sample or after its last: the ledger has them as dropped, but a log cut short or a
    clock on another origin loses a share of the sensor that deserves more than a ledger row."""
    out = []
    for name, rows in ledger.groupby("sensor", sort=True):
        reason = rows["reason"]
        before = int((reason == BEFORE_IMU_REASON).sum())
        after = int((reason == AFTER_IMU_REASON).sum())
        n = len(rows)
        if before + after < OUTSIDE_READINGS or before + after <= OUTSIDE_SHARE * n:
            continue
        message = (
            f"{name}: {before + after} of its {n} readings ({100 * (before + after) / n:.0f} %) "
            f"are stamped outside the IMU's time ({before} before its first sample, {after} "
            f"after its last) and were not used: {OUTSIDE_HINT}"
        )
        out.append(OutsideImuWarning(str(name), n, before, after, message))
    return out


def channel_ceiling(channel: SensorChannel) -> float:
    """The ceiling of a channel's R̂ as a factor of its nominal variance (inf: none, or a
    fixed R)."""
    st = channel.strategy
    if isinstance(st, VariationalBayes):
        return st.r_ceiling
    if isinstance(st, CovarianceMatching):
        return st.ceiling
    return math.inf


def with_warnings(result: Result, channels: Sequence[SensorChannel]) -> Result:
    """``result`` with ``meta.warnings``: :func:`diagnose` of its ledger for ``channels``
    (the run's aiding sensors), then :func:`correlated` of the others, as JSON values (an
    empty list when none is flagged)."""
    found = diagnose(
        result.ledger,
        {c.name: np.diag(nominal_R(c.model)) for c in channels},
        {c.name: channel_ceiling(c) for c in channels},
    )
    at_odds = {w.sensor for w in found}  # their warning says more than correlation would
    others = [c for c in channels if c.name not in at_odds]
    warnings = [w.as_dict() for w in found]
    warnings += [w.as_dict() for w in correlated(result.ledger, others)]
    warnings += [w.as_dict() for w in outside_imu(result.ledger)]
    return replace(result, meta={**result.meta, "warnings": warnings})
