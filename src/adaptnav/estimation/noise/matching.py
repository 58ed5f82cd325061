"""MAESKF: measurement noise by innovation covariance matching.

The equations in words: docs/filters.md, 'MAESKF: covariance matching'.

Mohamed & Schwarz (1999), adaptive estimation by innovation (IAE): over a sensor's window of its
last W accepted innovations ν (x⁻ = 0, so ν = y),

    C_ν = (1/W) Σ ν νᵀ,     R_i = diag(C_ν) - diag(H_i P⁻ H_iᵀ),

floored at ``r_min = floor * nominal variance`` to stay positive definite and, beyond the paper,
capped at ``ceiling * nominal variance`` (default inf: no cap; why a cap, estimation/noise/vb.py).
The window ends with the current innovation.

Beyond the paper, an option: the window restarts after a gap in the sensor's readings longer
than ``gap_periods`` of its nominal periods (0, the filter settings' default: never, the
paper). The innovations after a gap come with a P that has grown through it, and a window that
mixes them with the squares from before the gap estimates R from two different filters. Until
the window is full again, R is the nominal R with each variance raised to the estimate from
the window so far where that is larger (:meth:`CovarianceMatching._window_R`): the IAE
window ends with the current innovation, so a full window weighs a spike down by its own
square, and the refilling one must too. (With the nominal R alone, the first reading after a
dropout, a 2.6 m/s spike within the guard's reach on paper-2 seed 3, went in at full weight,
turned the heading by 1.2° and made that run's RMSE 424 m against 122 m without restarts.)

Measured on the fault benchmark (``make faults``, 3 seeds; RMSE faulted / clean, mean over
the seeds, paper-1 / paper-2), 2026-12-03:

| restart; R while the window refills | DVL frozen 60 s | 300-s dropout | spikes | all five |
|---|---|---|---|---|
| never (the paper) | 1.39 / 1.38 | 1.19 / 1.72 | 1.15 / 0.88 | 2.04 / 2.04 |
| after 10 periods; nominal R | 1.00 / 1.03 | 1.00 / 0.95 | - / 1.87 | - |
| after 10 periods; R̂ from before the gap | 1.04 / 1.02 | 1.07 / 0.94 | 1.14 / 1.87 | 2.23 / 1.80 |
| after 10 periods; as above (since 0.3.4) | 1.01 / 1.05 | 1.10 / 1.03 | 1.11 / 0.89 | 1.29 / 0.91 |

and on the clean 20-seed Monte Carlo (every disturbance on) mean relative RMSE 0.588 / 1.114 %
against 0.586 / 1.113 % without restarts. It was the default for one commit (0.3.4) and is an
option again because of what the refilling rule costs where P is large against R: at the start
of a run (the rule holds from the first reading, since the window is not full), a one-reading
estimate ``ν² - H P Hᵀ`` scatters with ``H P Hᵀ`` and often raises R far above the truth; with
the right R on the synthetic missions of tests/integration/test_filters.py MAESKF's mean RMSE
was 1.157 × MESKF's, against the ≤ 1.05 that test holds it to. And on the RTKLIB drive the
first fixes after a GNSS outage, far off where MAESKF's P claims too little drift, raised
their own R̂: its smoothed error at the end of the 60-s outages went from 0.87 to 10.45 m.
Two further variants, measured on 2026-12-03 and not kept:

- The refilling rule only after a gap restart, the nominal R at the start of a run as in the
  paper. The start of a run is then the paper's (the synthetic-mission test above passes),
  the faults are as in the last row of the table (× 1.10 / 1.03 dropout, 1.29 / 0.91 all five;
  worst 1.12 / 1.41 and 1.40 / 1.15), but MAESKF's smoothed error at the end of the RTKLIB
  drive's 60-s outages is still 10.45 m: the cost there is the restart after the outage itself,
  and requiring a significant excess would not help, since the first fixes after an outage are
  exactly the readings with one.
- Each square less the ``diag(H P⁻ Hᵀ)`` of its own update instead of the current one, which
  is unbiased for a P that changes inside the window and needs no restart: paper-2's clean
  RMSE 244 m against 92.5 m (3 seeds), the dropout × 2.97 / worst 4.43. Where P is large
  against R, each row's ``ν² - H P Hᵀ`` scatters with ``H P Hᵀ``, and the floor clips the low
  ones, so R̂ is biased high and noisy; the paper's current ``H P Hᵀ``, smaller than the
  window's past ones while P shrinks, errs on the side of a larger R̂ instead.
Residual-based variant (RAE): ``R_i = diag(C_ε) + diag(H_i P⁺ H_iᵀ)`` with residuals
``ε = y - H dx⁺`` of the previous W updates.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from adaptnav.estimation import kalman
from adaptnav.estimation.noise.base import (
    Array,
    Block,
    NoiseKind,
    StackedResult,
    slices,
    stack,
    stacked_R,
)


@dataclass(frozen=True)
class MatchingState:
    """Ring of the last W squared innovations (or residuals) per component, and R̂ in use."""

    squares: Array  # (W, d): ν_j² (IAE) or ε_j² (RAE)
    hph: Array  # (W, d): diag(H P⁺ Hᵀ) for RAE (zeros for IAE)
    count: int
    R: Array  # (d, d) diagonal


@dataclass(frozen=True)
class CovarianceMatching:
    """Settings: window W, floor as a fraction of the nominal variance, IAE or RAE."""

    kind: ClassVar[NoiseKind] = NoiseKind.MATCHING

    window: int = 20
    floor: float = 1e-2
    residual_based: bool = False
    ceiling: float = math.inf
    """Upper bound on R̂ as a factor of the nominal variance (module docstring)."""
    gap_periods: float = 0.0
    """Restart the window after a gap of more than this many periods; 0: never."""
    name: str = "matching"

    def __post_init__(self) -> None:
        if self.window < 1:
            raise ValueError(f"matching window: value {self.window!r} must be >= 1")
        if not 0 < self.floor <= 1:
            raise ValueError(f"matching floor: value {self.floor!r} must be in (0, 1]")
        if not self.ceiling > self.floor:
            raise ValueError(
                f"matching ceiling: value {self.ceiling!r} must be > the floor {self.floor!r}"
            )

    def initial_state(self, R_nominal: Array) -> MatchingState:
        d = R_nominal.shape[0]
        z = np.zeros((self.window, d))
        return MatchingState(z, z.copy(), 0, R_nominal.copy())

    def predict(self, state: MatchingState, dt: float, period: float) -> MatchingState:
        if self.gap_periods > 0 and period > 0 and dt > self.gap_periods * period:
            return MatchingState(state.squares, state.hph, 0, state.R)
        return state

    def current_R(self, state: MatchingState, R_nominal: Array) -> Array:
        return state.R

    def _estimate(
        self, squares: Array, hph: Array, hph_now: Array, R_nominal: Array, k: int | None = None
    ) -> Array:
        """R̂ from the last ``k`` rows of the window (all of them by default)."""
        rows = slice(-k, None) if k is not None else slice(None)
        mean_sq = squares[rows].mean(axis=0)
        r = mean_sq + hph[rows].mean(axis=0) if self.residual_based else mean_sq - hph_now
        var = np.diag(R_nominal)
        return np.diag(np.clip(r, self.floor * var, self.ceiling * var))

    def _window_R(
        self, full: bool, k: int, squares: Array, hph: Array, hph_now: Array, R_nominal: Array
    ) -> Array:
        """R̂ of a full window; until it is full the nominal R, or with a gap restart on
        (``gap_periods`` > 0) the nominal R with each variance raised to the estimate from the
        window's last ``k`` rows, those since the restart, where larger."""
        if full:
            return self._estimate(squares, hph, hph_now, R_nominal)
        if self.gap_periods <= 0 or k == 0:
            return R_nominal
        R = R_nominal.copy()
        estimate = self._estimate(squares, hph, hph_now, R_nominal, k)
        np.fill_diagonal(R, np.maximum(np.diag(R_nominal), np.diag(estimate)))
        return R

    def update(self, P: Array, blocks: Sequence[Block]) -> StackedResult:
        Rs: list[Array] = []
        pushed: list[tuple[Array, int]] = []
        for b in blocks:
            st: MatchingState = b.state
            if self.residual_based:
                full = st.count >= self.window
                R = self._window_R(full, st.count, st.squares, st.hph, np.zeros(0), b.R_nominal)
                pushed.append((st.squares, st.count))
            else:
                sq = np.roll(st.squares, -1, axis=0)
                sq[-1] = b.y * b.y
                count = min(st.count + 1, self.window)
                hph_now = np.einsum("ij,jk,ik->i", b.H, P, b.H)
                full = count >= self.window  # count: the current reading included
                R = self._window_R(full, count, sq, st.hph, hph_now, b.R_nominal)
                pushed.append((sq, count))
            Rs.append(R)
        H, y = stack(blocks)
        corr = kalman.correct(P, H, y, stacked_R(Rs))
        states: list[MatchingState] = []
        for b, sl, R, (sq, count) in zip(blocks, slices(blocks), Rs, pushed, strict=True):
            st = b.state
            if self.residual_based:
                eps = y[sl] - H[sl] @ corr.dx
                sq = np.roll(st.squares, -1, axis=0)
                sq[-1] = eps * eps
                hph = np.roll(st.hph, -1, axis=0)
                hph[-1] = np.einsum("ij,jk,ik->i", H[sl], corr.P, H[sl])
                states.append(MatchingState(sq, hph, min(st.count + 1, self.window), R))
            else:
                states.append(MatchingState(sq, st.hph, count, R))
        return StackedResult(corr, tuple(states), tuple(Rs), 1)
