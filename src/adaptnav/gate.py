"""Outlier gate with rejection coefficient q (spec §7).

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

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

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
