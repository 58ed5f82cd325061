"""The divergence guard: the filter checks its own health and recovers (docs/robustness.md).

A Kalman filter that has become overconfident (P too small: a wrong Q, an unmodelled error, a
bad reading taken) does not notice by itself: it rejects the readings that would correct it or
weighs them too little, and its error runs away while its σ stays small. Three checks, each on
every sensor, each ending in an *event* (the run's ``events`` table, the report) rather than an
exception or silence:

* **Lockout** (part of the nominal-R guard of :mod:`adaptnav.estimation.gate`, on with it): a sensor
  whose every reading the guard has rejected for ``lockout_s`` seconds or more. A sensor fault
  that long is what the load-time checks catch (plausibility limits, stuck readings, lost
  bottom lock), so the filter is the likelier culprit: P ← k P with k from
  :func:`lockout_factor` (at most the guard's ``lockout_max``), the reading that triggered it
  still rejected. A streak that began with a *step* (:func:`is_step`: the first rejected
  reading's statistic more than twice that of the reading the guard passed a period or two
  before) is the sensor's fault, not the filter's: its lockout waits ``STEP_PATIENCE`` times
  as long (:func:`lockout_wait`). Up to 0.4.5 a depth 1000 m off for 35 s was taken after
  30 s, P scaled by up to 100 a reading until it fitted, and the state ran to NaN when the
  depth came back. The sensor stays locked out until one of its readings passes: each further
  rejection inflates P again, so a drift larger than one step's cap is caught up within a few
  readings (not one cap per ``lockout_s``, which left a car 10 km off after a GNSS outage).
* **Windowed NIS**: per sensor, the mean of ``NIS/d`` over its last ``window`` used readings
  (``NIS = yᵀ S⁻¹ y`` with the R used; its mean is 1 for a consistent filter). Above
  ``nis_ratio``: P ← k P with k the mean (at most ``inflate_max``). With an adaptive R this
  fires only when R̂ cannot absorb the excess, i.e. at its ceiling (``r_ceiling``): that pair is
  what keeps R adaptation from running away when Q is wrong.
* **Covariance health**: an innovation covariance S that is not positive definite (P has lost
  positive definiteness), or a non-positive variance after an update: the epoch's readings are
  rejected (``S not positive definite``) and P is repaired (:func:`repair`).

Scaling P by k > 1 keeps it symmetric positive definite and keeps its correlations; it says "the
error may be k times larger in every direction", the honest statement when the filter does not
know which direction went wrong.

The compiled twins are ``_lockout``, ``_nis_window`` and ``_repair`` in
:mod:`adaptnav.compiled.update`; ``tests/helpers/engine_reference.py`` uses these.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

STEP_RATIO = 2.0
"""A guard rejection whose statistic exceeds this many times that of the sensor's last reading
the guard passed, within :data:`STEP_PERIODS` of it, is a *step*: the sensor jumped, the filter
did not (:func:`is_step`)."""
STEP_PERIODS = 2.0
"""How recent (in the sensor's periods) the last passed reading must be for a step."""
STEP_PATIENCE = 4.0
"""A streak of rejections that began with a step waits this many lockout times before the
lockout inflates P (:func:`lockout_wait`)."""
EIG_FLOOR = 1e-12
""":func:`repair` clips P's eigenvalues at this fraction of the largest."""
MIN_LOCKOUT_FACTOR = 2.0
"""A lockout inflates P at least this much: a smaller step would take several lockouts."""


@dataclass(frozen=True)
class DivergenceGuard:
    """Settings of the windowed NIS test (module docstring), filter-wide; the lockout's are
    the guard's (:class:`adaptnav.estimation.gate.Guard`), per sensor.

    ``nis_ratio = 0`` turns the windowed NIS test off; the covariance health check is always
    on (it replaces an exception)."""

    nis_ratio: float = 0.0
    window: int = 30
    inflate_max: float = 100.0

    def __post_init__(self) -> None:
        if not (self.nis_ratio == 0.0 or (math.isfinite(self.nis_ratio) and self.nis_ratio > 1)):
            raise ValueError(f"divergence nis_ratio: value {self.nis_ratio!r} must be 0 or > 1")
        if self.window < 1:
            raise ValueError(f"divergence window: value {self.window!r} must be >= 1")
        if not (math.isfinite(self.inflate_max) and self.inflate_max >= MIN_LOCKOUT_FACTOR):
            raise ValueError(
                f"divergence inflate_max: value {self.inflate_max!r} must be >= "
                f"{MIN_LOCKOUT_FACTOR:g}"
            )


OFF = DivergenceGuard()
"""No windowed NIS test (the paper's filters as written)."""


def repair(P: Array) -> Array | None:
    """The symmetric positive definite matrix nearest ``P``: ``(P + Pᵀ)/2`` with its eigenvalues
    clipped at ``EIG_FLOOR`` × the largest; None if P is not finite or has no positive
    eigenvalue."""
    if not np.all(np.isfinite(P)):
        return None
    w, V = np.linalg.eigh(0.5 * (P + P.T))
    floor = max(float(w[-1]), 0.0) * EIG_FLOOR
    if not floor > 0.0:
        return None
    out = (V * np.maximum(w, floor)) @ V.T
    return np.asarray(0.5 * (out + out.T), dtype=float)


def lockout_factor(stat: float, q: float, hph_trace: float, r_trace: float, k_max: float) -> float:
    """The k with ``stat (W + R) / (k W + R) = q``: the factor of P that brings a reading the
    guard rejected with ``stat`` > q back to its threshold, with the traces of ``H P Hᵀ`` (W)
    and R standing for S's size; clipped to [MIN_LOCKOUT_FACTOR, k_max]."""
    k = (stat * (hph_trace + r_trace) / q - r_trace) / max(hph_trace, 1e-300)
    return min(max(k, MIN_LOCKOUT_FACTOR), k_max)


def is_step(stat: float, passed_stat: float, t: float, last_passed: float, period: float) -> bool:
    """Whether the first rejection of a streak, at t with the guard's statistic ``stat``, is a
    step of the sensor (module docstring, 'Lockout'): ``stat > STEP_RATIO passed_stat``, the
    statistic of the sensor's last reading the guard passed, at ``last_passed`` at most
    ``STEP_PERIODS`` periods before. A filter that drifts crosses the threshold gradually: the
    guard's S holds 100 × R, so a reading's own noise moves the statistic by a few units and
    the last passed reading sits just under the threshold, the first rejected one just over
    it. A sensor that jumps goes from its usual few units to beyond the threshold at once
    (a depth 1000 m off, a DVL 3 m/s off). After a gap (an outage) the filter may have drifted
    any amount: no step."""
    recent = not math.isnan(last_passed) and t - last_passed <= STEP_PERIODS * period
    return recent and stat > STEP_RATIO * passed_stat


def lockout_wait(lockout_s: float, step: bool) -> float:
    """How long a streak of rejections lasts before the lockout inflates P: ``lockout_s``, or
    ``STEP_PATIENCE`` times that for a streak that began with a step (:func:`is_step`). The
    sensor is still never locked out for good."""
    return lockout_s * (STEP_PATIENCE if step else 1.0)


def nis_step(mean: float, count: float, ratio: float, window: int) -> tuple[float, float]:
    """One used reading into the windowed NIS mean: a running mean of ``NIS/d`` until
    ``window`` readings, then an exponential mean of that length. Returns (mean, count)."""
    count += 1.0
    mean += (ratio - mean) / min(count, float(window))
    return mean, count
