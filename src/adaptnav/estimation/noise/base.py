"""Measurement-noise adaptation: a closed set of three strategies, and what they share.

A filter kind fixes the strategy; each sensor has its own settings and its own adaptation state.
At an epoch the engine hands the strategy the received sensors' blocks (y_i, H_i, nominal R_i,
state_i); the strategy chooses R (fixed, matched, or variational) and performs the stacked
update (paper eqs. (20)-(22)), returning the new per-sensor states. Sensors not received are
not passed and so keep their state (paper eqs. (18), (19), (29), (30)). docs/filters.md,
'Stacked update' and the sections on the three filters.

The set is closed on purpose (:class:`NoiseKind`): the engine runs every epoch in the compiled
kernel (``adaptnav.compiled.update``), which implements each strategy's prediction, R and update,
and the classes here are their readable twins. A subclass overriding ``update`` would be ignored
by the kernel, so the engine refuses anything but the exact classes. A new strategy is a module
with its twin class, a :class:`NoiseKind` member, its branch in the kernel's predict/update and
its packed settings (``Navigator._build_tables``); docs/architecture.md, 'Adding a noise strategy'.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

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


class NoiseKind(IntEnum):
    """The strategies the engine runs; the values are the compiled kernel's codes."""

    FIXED = 0
    """MESKF: R = nominal R (:class:`~adaptnav.estimation.noise.fixed.FixedNoise`)."""
    MATCHING = 1
    """MAESKF: R by covariance matching
    (:class:`~adaptnav.estimation.noise.matching.CovarianceMatching`)."""
    VB = 2
    """VB-MAESKF: R by variational Bayes
    (:class:`~adaptnav.estimation.noise.vb.VariationalBayes`)."""


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
