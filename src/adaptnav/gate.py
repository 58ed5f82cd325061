"""Outlier gate with rejection coefficient q (spec §7).

For one sensor's innovation ν with ``S = H P⁻ Hᵀ + R``:

* ``component`` (the paper's rule): reject if for any component j, ``ν_j² > q S_jj``;
* ``chi2`` (Mahalanobis): reject if ``νᵀ S⁻¹ ν > q``.

The paper sweeps q over 25 values in [200, 2600]; its best values are large because its R are
small hand-tuned nominal values.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
GateRule = Literal["component", "chi2"]


@dataclass(frozen=True)
class Gate:
    """An outlier gate: ``rule`` and threshold ``q`` (> 0)."""

    q: float
    rule: GateRule = "component"

    def __post_init__(self) -> None:
        if not np.isfinite(self.q) or self.q <= 0:
            raise ValueError(f"gate q: value {self.q!r} must be a finite number > 0")
        if self.rule not in ("component", "chi2"):
            raise ValueError(f"gate rule: value {self.rule!r} must be 'component' or 'chi2'")


@dataclass(frozen=True)
class GateDecision:
    accepted: bool
    statistic: float
    """component rule: max_j ν_j²/S_jj; chi2 rule: νᵀ S⁻¹ ν."""
    threshold: float
    rule: GateRule


def apply_gate(gate: Gate, nu: Array, S: Array) -> GateDecision:
    """Apply ``gate`` to innovation ``nu`` with covariance ``S`` (spec §7)."""
    if gate.rule == "component":
        stat = float(np.max(nu * nu / np.diag(S)))
    else:
        stat = float(nu @ np.linalg.solve(S, nu))
    return GateDecision(stat <= gate.q, stat, gate.q, gate.rule)
