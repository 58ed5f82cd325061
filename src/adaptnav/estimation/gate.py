"""Outlier gate with rejection coefficient q (docs/filters.md, 'Gate').

For one sensor's innovation ν with ``S = H P⁻ Hᵀ + R``:

* ``component`` (the paper's rule): reject if for any component j, ``ν_j² > q S_jj``;
* ``chi2`` (Mahalanobis): reject if ``νᵀ S⁻¹ ν > q``.

The paper sweeps q over 25 values in [200, 2600]; its best values are large because its R are
small hand-tuned nominal values.

Which R goes into S is the gate's ``reference``:

* ``adapted`` (the paper's): the R the filter's noise strategy holds now (nominal for MESKF, the
  matching estimate for MAESKF, β/α for VB-MAESKF);
* ``nominal``: the sensor's configured R (per reading where the data gives one), whatever the
  strategy has adapted to. An adaptive filter can then not open its own gate: a sustained fault
  (a bottom-lock loss that reads zeros, say) first inflates the adapted R, and with the
  ``adapted`` reference the gate then lets the rest of the fault through. Measured on the A-KIT
  recordings, docs/results-akit.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtri

Array = NDArray[np.float64]
GateRule = Literal["component", "chi2"]
GateReference = Literal["adapted", "nominal"]


@dataclass(frozen=True)
class Gate:
    """An outlier gate: ``rule``, threshold ``q`` (> 0) and the R of its S (``reference``)."""

    q: float
    rule: GateRule = "component"
    reference: GateReference = "adapted"

    def __post_init__(self) -> None:
        if not np.isfinite(self.q) or self.q <= 0:
            raise ValueError(f"gate q: value {self.q!r} must be a finite number > 0")
        if self.rule not in ("component", "chi2"):
            raise ValueError(f"gate rule: value {self.rule!r} must be 'component' or 'chi2'")
        if self.reference not in ("adapted", "nominal"):
            raise ValueError(
                f"gate reference: value {self.reference!r} must be 'adapted' or 'nominal'"
            )


DEFAULT_HEADROOM = 100.0
"""The guard's κ: a sensor up to 10× noisier (in σ) than its nominal σ is still normal."""
DEFAULT_LOCKOUT_S = 30.0
"""A sensor the guard has rejected for this long makes the filter inflate P
(estimation/health.py)."""
DEFAULT_LOCKOUT_MAX = 100.0
"""At most this factor of P per lockout; a larger divergence takes several."""


@dataclass(frozen=True)
class Guard:
    """The guard: a χ² gate on the whole innovation with ``S = H P Hᵀ + κ R_nominal``, on every
    sensor, whatever the filter kind (docs/robustness.md).

    A reading ν of dimension d is rejected if ``νᵀ S⁻¹ ν > χ²_d⁻¹(1 - p)``: the value that a
    consistent filter exceeds with probability ``p`` (``probability``) if the sensor were κ
    times noisier in variance than nominal (``headroom``). S holds the sensor's *nominal* R,
    so no noise adaptation can widen it. It is meant for gross errors (a depth 1000 m off,
    a DVL spike of metres per second), not for a sensor that is merely noisier than its
    datasheet, which is the noise strategy's business: κ = 100 leaves a sensor 10× noisier
    in σ alone (the most the paper's noise segments reach), and with p = 1e-6 a scalar reading
    is rejected beyond ≈ 49 nominal σ (√(100 × 23.9)). The paper's gate (:class:`Gate`) stays
    as it was, after it.

    A guard that rejects everything a sensor says for ``lockout_s`` seconds has most likely
    locked the filter out of its own correction (P too small, the state gone wrong): the
    filter then inflates P, at most ``lockout_max`` times per rejected reading, until a
    reading passes (the lockout of :mod:`adaptnav.estimation.health`; 0 s: never).
    """

    probability: float
    headroom: float = DEFAULT_HEADROOM
    lockout_s: float = DEFAULT_LOCKOUT_S
    lockout_max: float = DEFAULT_LOCKOUT_MAX

    def __post_init__(self) -> None:
        if not (math.isfinite(self.probability) and 0.0 < self.probability < 1.0):
            raise ValueError(
                f"guard probability: value {self.probability!r} must be in (0, 1) "
                "(0 in a configuration turns the guard off)"
            )
        if not (math.isfinite(self.headroom) and self.headroom >= 1.0):
            raise ValueError(f"guard headroom: value {self.headroom!r} must be >= 1")
        if not (math.isfinite(self.lockout_s) and self.lockout_s >= 0.0):
            raise ValueError(f"guard lockout_s: value {self.lockout_s!r} must be >= 0")
        if not (math.isfinite(self.lockout_max) and self.lockout_max >= 2.0):
            raise ValueError(f"guard lockout_max: value {self.lockout_max!r} must be >= 2")

    def threshold(self, dim: int) -> float:
        """``χ²_d⁻¹(1 - p)`` for an innovation of dimension ``dim``."""
        # chdtri is what scipy.stats.chi2.isf evaluates; scipy.stats alone takes ~1 s to import
        return float(chdtri(dim, self.probability))


@dataclass(frozen=True)
class GateDecision:
    accepted: bool
    statistic: float
    """component rule: max_j ν_j²/S_jj; chi2 rule: νᵀ S⁻¹ ν."""
    threshold: float
    rule: GateRule


def apply_gate(gate: Gate, nu: Array, S: Array) -> GateDecision:
    """Apply ``gate`` to innovation ``nu`` with covariance ``S`` (docs/filters.md, 'Gate')."""
    if gate.rule == "component":
        stat = float(np.max(nu * nu / np.diag(S)))
    else:
        stat = float(nu @ np.linalg.solve(S, nu))
    return GateDecision(stat <= gate.q, stat, gate.q, gate.rule)
