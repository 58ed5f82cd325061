"""Process-noise adaptation: the scale of Q from the whiteness of the innovations.

Why: R adaptation (MAESKF, VB-MAESKF) explains every innovation larger than expected by a
larger R. When the real cause is a Q too small (an IMU noisier than its datasheet, a
vibrating car), a larger R makes the filter trust its drifting INS more, and it runs away
(issue 12: the RTKLIB drive with the published IMU noise; docs/robustness.md).

What tells the two apart: the innovation sequence of an optimal Kalman filter is white, and
a sub-optimal gain shows as correlation between successive innovations (Mehra, IEEE TAC
1970, "On the identification of variances and adaptive Kalman filtering"). A gain too small,
which is what a Q too small gives, leaves a slowly varying error uncorrected from one
reading to the next: successive innovations share its sign and their lag-1 correlation is
positive. A measurement noise larger than R, with Q right, leaves them uncorrelated. On the
paper's simulated trials (every disturbance on, 10× noise segments) the median lag-1
correlation of every sensor's innovations over 50-reading windows is 0.00-0.03; on the RTKLIB
drive it is 0.75-0.96 (docs/robustness.md).

The rule (our own, after Mehra's test): per sensor, over consecutive readings (no more than
``GAP_PERIODS`` periods apart), the normalised innovation ``ν̃_j = y_j / sqrt(S_jj)`` (S with
the prior P and the R used) feeds running means, over the last ``window`` pairs, of

    c0 = Σ_j (ν̃_j(k)² + ν̃_j(k-1)²) / 2        and        c1 = Σ_j ν̃_j(k) ν̃_j(k-1),

and once the window is full their ratio ``ρ = c1 / c0`` (in [-1, 1]: the two means weigh the
pairs alike, and |ab| ≤ (a² + b²)/2) moves the scale β of the IMU's white-noise PSDs in Q
(angle and velocity random walk; the bias walks keep theirs):

    β ← clip(β exp(g (ρ - ρ₀)), 1, β_max).

ρ₀ (``target``) is the correlation tolerated: real sensors have slowly varying errors of
their own (an RTK fix's, a non-holonomic constraint's), which no Q explains. β never falls
below 1: the configured Q is a floor, the datasheet's promise. Every sensor's readings drive
the one β of the filter.

The compiled twin is ``compiled.update._whiteness`` (the engine's propagation scales Q by β,
``engine._advance``); ``tests/helpers/engine_reference.py`` uses this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["EVENT_STEP", "GAP_PERIODS", "QAdaptation", "WhitenessState", "whiteness_step"]

GAP_PERIODS = 2.5
"""Two readings further apart than this many sensor periods are not a lag-1 pair."""
EVENT_STEP = 2.0
"""A ``q_scale`` event (the run's events table) each time β has moved by this factor since
the last one."""


@dataclass(frozen=True)
class QAdaptation:
    """Settings of the Q adaptation (module docstring). The defaults are the evidence of
    docs/robustness.md: the RTKLIB drive under three IMU noise models, the paper's simulated
    trials (β stays 1) and the A-KIT recordings."""

    gain: float = 0.1
    """g: log-change of β per reading per unit of ρ - ρ₀."""
    target: float = 0.5
    """ρ₀: the lag-1 correlation tolerated before Q grows."""
    beta_max: float = 1000.0
    """Largest β (1000: the white noise's σ up to ~32× the configured one)."""
    window: int = 30
    """Readings in the running means (a plain mean until full, then an exponential one)."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.gain) and self.gain > 0.0):
            raise ValueError(f"q_adaptation gain: value {self.gain!r} must be > 0")
        if not (math.isfinite(self.target) and 0.0 <= self.target < 1.0):
            raise ValueError(f"q_adaptation target: value {self.target!r} must be in [0, 1)")
        if not (math.isfinite(self.beta_max) and self.beta_max >= 1.0):
            raise ValueError(f"q_adaptation beta_max: value {self.beta_max!r} must be >= 1")
        if self.window < 2:
            raise ValueError(f"q_adaptation window: value {self.window!r} must be >= 2")


@dataclass(frozen=True)
class WhitenessState:
    """One sensor's running means: c0, c1, the pairs counted, its last ν̃ and time."""

    c0: float = 0.0
    c1: float = 0.0
    pairs: int = 0
    last: tuple[float, ...] = ()
    t_last: float = math.nan


def whiteness_step(
    qa: QAdaptation,
    state: WhitenessState,
    beta: float,
    t: float,
    period: float,
    y: ArrayLike,
    S_diag: ArrayLike,
) -> tuple[WhitenessState, float]:
    """One used reading (innovation ``y``, ``diag(S)``) at time ``t`` of a sensor with this
    ``period``: the new state and the filter's new β (module docstring)."""
    v = np.asarray(y, dtype=float) / np.sqrt(np.asarray(S_diag, dtype=float))
    paired = bool(state.last) and t - state.t_last <= GAP_PERIODS * period
    if not paired:
        return WhitenessState(state.c0, state.c1, state.pairs, tuple(v), t), beta
    pairs = state.pairs + 1
    m = min(pairs, qa.window)
    last = np.asarray(state.last)
    c0 = state.c0 + (0.5 * float(v @ v + last @ last) - state.c0) / m
    c1 = state.c1 + (float(v @ last) - state.c1) / m
    new = WhitenessState(c0, c1, pairs, tuple(v), t)
    if pairs < qa.window or not c0 > 0.0:
        return new, beta
    rho = c1 / c0
    return new, min(max(beta * math.exp(qa.gain * (rho - qa.target)), 1.0), qa.beta_max)
