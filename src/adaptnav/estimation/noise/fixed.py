"""MESKF: fixed, hand-tuned nominal measurement noise (docs/filters.md, 'MESKF: fixed R')."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from adaptnav.estimation import kalman
from adaptnav.estimation.noise.base import Array, Block, NoiseKind, StackedResult, stack, stacked_R


@dataclass(frozen=True)
class FixedNoise:
    """R_i = nominal R_i at every epoch."""

    kind: ClassVar[NoiseKind] = NoiseKind.FIXED

    name: str = "fixed"

    def initial_state(self, R_nominal: Array) -> None:
        return None

    def predict(self, state: Any, dt: float, period: float) -> None:
        return None

    def current_R(self, state: Any, R_nominal: Array) -> Array:
        return R_nominal

    def update(self, P: Array, blocks: Sequence[Block]) -> StackedResult:
        H, y = stack(blocks)
        Rs = tuple(b.R_nominal for b in blocks)
        corr = kalman.correct(P, H, y, stacked_R(Rs))
        return StackedResult(corr, tuple(None for _ in blocks), Rs, 1)
