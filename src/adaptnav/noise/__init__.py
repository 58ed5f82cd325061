"""Measurement-noise adaptation: one interface (:class:`NoiseStrategy`), three strategies."""

from adaptnav.noise.base import Block, NoiseStrategy, StackedResult
from adaptnav.noise.fixed import FixedNoise
from adaptnav.noise.matching import CovarianceMatching, MatchingState
from adaptnav.noise.vb import VariationalBayes, VBState

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
