"""The three filter kinds of the paper as settings for one engine (spec §6, §7).

* ``meskf``: fixed nominal R (:class:`~adaptnav.noise.FixedNoise`), outlier gate on;
* ``maeskf``: R by innovation covariance matching (:class:`~adaptnav.noise.CovarianceMatching`),
  gate on;
* ``vb``: VB-MAESKF, R by variational Bayes (:class:`~adaptnav.noise.VariationalBayes`), no gate;
* ``oracle``: not a filter a user can run on real data, a baseline: fixed R, no gate, each
  reading given its true variance and known outliers removed (:mod:`adaptnav.oracle`).

Default gate coefficients are the paper's best on its trajectory No. 1 (q = 600 for MESKF,
1800 for MAESKF; Fig. 4); the paper gives no ρ, N or α0, so ours are stated choices: ρ = 0.99
(memory ≈ 100 of the sensor's epochs), N = 5 iterations, α0 = 1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

from adaptnav.engine import SensorChannel
from adaptnav.gate import Gate, GateReference, GateRule
from adaptnav.noise import CovarianceMatching, FixedNoise, NoiseStrategy, VariationalBayes
from adaptnav.sensors.base import MeasurementModel

FilterKind = Literal["meskf", "maeskf", "vb", "oracle"]
FILTER_KINDS: tuple[FilterKind, ...] = ("meskf", "maeskf", "vb", "oracle")
DEFAULT_GATE_Q: dict[str, float] = {"meskf": 600.0, "maeskf": 1800.0}


@dataclass(frozen=True)
class SensorOverrides:
    """Per-sensor settings that differ from the filter's (spec §6: ρ_i, W_i; §7: q per sensor)."""

    gate_q: float | None = None
    vb_rho: float | None = None
    matching_window: int | None = None


@dataclass(frozen=True)
class FilterSettings:
    """Everything that distinguishes one filter run from another on the same engine."""

    kind: FilterKind = "vb"
    gate_rule: GateRule = "component"
    gate_q: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_GATE_Q))
    """q per filter kind; a kind absent here runs without a gate."""
    gate_reference: GateReference = "adapted"
    """R in the gate's S: the strategy's current R (the paper) or the nominal one (gate.py)."""
    gate_sensors: tuple[str, ...] = ("dvl",)
    matching_window: int = 20
    matching_floor: float = 1e-2
    matching_residual_based: bool = False
    vb_alpha0: float = 1.0
    vb_rho: float = 0.99
    vb_iterations: int = 5
    vb_tol: float = 1e-6
    vb_irregular: bool = False
    vb_dof: float | None = None
    """Student-t ν of each reading for VB-MAESKF (noise/vb.py, beyond the paper); None:
    Gaussian, the paper's update."""

    def __post_init__(self) -> None:
        if self.kind not in FILTER_KINDS:
            raise ValueError(f"filter kind: value {self.kind!r} must be one of {FILTER_KINDS}")

    def with_kind(self, kind: FilterKind) -> FilterSettings:
        return replace(self, kind=kind)

    def strategy(self, overrides: SensorOverrides = SensorOverrides()) -> NoiseStrategy:
        """The R strategy of this filter kind for one sensor."""
        if self.kind in ("meskf", "oracle"):
            return FixedNoise()
        if self.kind == "maeskf":
            window = overrides.matching_window or self.matching_window
            return CovarianceMatching(window, self.matching_floor, self.matching_residual_based)
        rho = overrides.vb_rho if overrides.vb_rho is not None else self.vb_rho
        return VariationalBayes(
            self.vb_alpha0, rho, self.vb_iterations, self.vb_tol, self.vb_irregular, self.vb_dof
        )

    def gate(self, sensor: str, overrides: SensorOverrides = SensorOverrides()) -> Gate | None:
        """The outlier gate for ``sensor`` under this filter kind, or None."""
        if self.kind not in self.gate_q or sensor not in self.gate_sensors:
            return None
        q = overrides.gate_q if overrides.gate_q is not None else self.gate_q[self.kind]
        return Gate(q, self.gate_rule, self.gate_reference)


def build_channels(
    settings: FilterSettings,
    sensors: Sequence[tuple[MeasurementModel, float]],
    overrides: dict[str, SensorOverrides] | None = None,
) -> list[SensorChannel]:
    """Engine channels for ``sensors`` given as (model, nominal period in s)."""
    ov = overrides or {}
    out = []
    for model, period in sensors:
        o = ov.get(model.name, SensorOverrides())
        out.append(SensorChannel(model, period, settings.strategy(o), settings.gate(model.name, o)))
    return out
