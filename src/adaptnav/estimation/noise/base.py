"""One interface for measurement-noise adaptation; three strategies implement it.

A filter kind fixes the strategy; each sensor has its own settings and its own adaptation state.
At an epoch the engine hands the strategy the received sensors' blocks (y_i, H_i, nominal R_i,
state_i); the strategy chooses R (fixed, matched, or variational) and performs the stacked
update (paper eqs. (20)-(22)), returning the new per-sensor states. Sensors not received are
not passed and so keep their state (paper eqs. (18), (19), (29), (30)). docs/filters.md,
'Stacked update' and the sections on the three filters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import block_diag

from adaptnav.estimation.kalman import Correction

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Block:
    """One received sensor at an epoch: residual y_i, H_i, nominal R_i and adaptation state."""

    sensor: str
    y: Array
    H: Array
    R_nominal: Array
    state: Any


@dataclass(frozen=True)
class StackedResult:
    """A stacked update: the correction, each block's new state and the R it was given."""

    correction: Correction
    states: tuple[Any, ...]
    R_used: tuple[Array, ...]
    iterations: int


class NoiseStrategy(Protocol):
    """How a filter chooses R: MESKF (fixed), MAESKF (matching), VB-MAESKF (variational)."""

    @property
    def name(self) -> str: ...

    def initial_state(self, R_nominal: Array) -> Any:
        """Adaptation state of a sensor before its first measurement."""
        ...

    def predict(self, state: Any, dt: float, period: float) -> Any:
        """Time update of a sensor's state at its own epoch, dt after its previous one."""
        ...

    def current_R(self, state: Any, R_nominal: Array) -> Array:
        """The R the strategy would use now (for gating and for the record)."""
        ...

    def update(self, P: Array, blocks: Sequence[Block]) -> StackedResult:
        """Stacked measurement update over the received blocks."""
        ...


def stack(blocks: Sequence[Block]) -> tuple[Array, Array]:
    """Stacked H (D×15) and y (D) over the received blocks (paper eqs. (20), (21))."""
    return np.vstack([b.H for b in blocks]), np.concatenate([b.y for b in blocks])


def stacked_R(Rs: Sequence[Array]) -> Array:
    """``R = blockdiag(R_i)`` over received sensors (paper eq. (22))."""
    return np.asarray(block_diag(*Rs), dtype=float)


def slices(blocks: Sequence[Block]) -> list[slice]:
    """Each block's rows in the stacked vectors."""
    out, start = [], 0
    for b in blocks:
        out.append(slice(start, start + b.y.size))
        start += b.y.size
    return out
