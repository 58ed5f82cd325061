"""Measurement-noise adaptation: three strategies, a closed set (:class:`NoiseKind`,
estimation/noise/base.py), and Q adaptation (:mod:`~adaptnav.estimation.noise.process`)."""

from adaptnav.estimation.noise.base import Block, NoiseKind, StackedResult
from adaptnav.estimation.noise.fixed import FixedNoise
from adaptnav.estimation.noise.matching import CovarianceMatching, MatchingState
from adaptnav.estimation.noise.vb import VariationalBayes, VBState

NoiseStrategy = FixedNoise | CovarianceMatching | VariationalBayes
"""A filter's R strategy: one of the three, nothing else (the engine's kernel runs each)."""

__all__ = [
    "Block",
    "CovarianceMatching",
    "FixedNoise",
    "MatchingState",
    "NoiseKind",
    "NoiseStrategy",
    "StackedResult",
    "VBState",
    "VariationalBayes",
]
