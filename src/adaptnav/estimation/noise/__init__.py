"""Measurement-noise adaptation: one interface (:class:`NoiseStrategy`), three strategies."""

from adaptnav.estimation.noise.base import Block, NoiseStrategy, StackedResult
from adaptnav.estimation.noise.fixed import FixedNoise
from adaptnav.estimation.noise.matching import CovarianceMatching, MatchingState
from adaptnav.estimation.noise.vb import VariationalBayes, VBState

__all__ = [
    "Block",
    "CovarianceMatching",
    "FixedNoise",
    "MatchingState",
    "NoiseStrategy",
    "StackedResult",
    "VBState",
    "VariationalBayes",
]
