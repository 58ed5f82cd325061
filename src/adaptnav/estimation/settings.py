"""The filter kinds as settings for one engine (README, docs/robustness.md).

The paper's three:

* ``meskf``: fixed nominal R (:class:`~adaptnav.estimation.noise.FixedNoise`), outlier gate on;
* ``maeskf``: R by innovation covariance matching
(:class:`~adaptnav.estimation.noise.CovarianceMatching`),
  gate on;
* ``vb``: VB-MAESKF, R by variational Bayes (:class:`~adaptnav.estimation.noise.VariationalBayes`),
no gate;

beyond it:

* ``robust``: the recommended filter for real data, the default of ``adaptnav run``: VB-MAESKF
  whose R̂ is bounded relative to the nominal R (``r_bounds``); the windowed NIS test of the
  divergence guard (:mod:`adaptnav.estimation.health`) is an option (``divergence``);
* ``oracle``: not a filter a user can run on real data, a baseline: fixed R, no gate, each
  reading given its true variance and known outliers removed (:mod:`adaptnav.api.oracle`).

Every kind has the **guard** (:class:`~adaptnav.estimation.gate.Guard`) on every sensor by default:
a χ² test on the whole innovation with the nominal R (times a headroom), for gross errors, with its
lockout (P inflated when it has rejected a sensor for ``guard_lockout_s``), and **Q adaptation**
(:mod:`adaptnav.estimation.noise.process`): the IMU white noise in Q scaled up when the innovations
are correlated, the sign of a Q too small. ``guard_probability = 0`` and ``q_adaptation = None``
(``q_adaptation = false`` in a mission) turn them off, and the paper's three filters are then
exactly the paper's.

Default gate coefficients are the paper's best on its trajectory No. 1 (q = 600 for MESKF,
1800 for MAESKF; Fig. 4); the paper gives no ρ, N or α0, so ours are stated choices: ρ = 0.99
(memory ≈ 100 of the sensor's epochs), N = 5 iterations, α0 = 1.

:class:`FilterSettings` is the one settings model, from ``mission.toml``'s ``[filter]`` section
(:class:`adaptnav.mission.config.FilterConfig` adds only the engine's output rate, epoch policy
and specific-force filter) to the kernel's packed tables (``adaptnav.engine.batch``, the one
function ``Navigator._build_tables``): each field is declared, constrained and defaulted here
once, and sweeps describe runs as overrides of it (``filter.<field>`` in
:class:`adaptnav.experiments.spec.RunSpec`'s ``config``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, field_validator

from adaptnav.estimation.gate import (
    DEFAULT_HEADROOM,
    DEFAULT_LOCKOUT_S,
    Gate,
    GateReference,
    GateRule,
    Guard,
)
from adaptnav.estimation.health import OFF, DivergenceGuard
from adaptnav.estimation.noise import (
    CovarianceMatching,
    FixedNoise,
    NoiseStrategy,
    VariationalBayes,
)
from adaptnav.estimation.noise.process import QAdaptation

FilterKind = Literal["meskf", "maeskf", "vb", "robust", "oracle"]
FILTER_KINDS: tuple[FilterKind, ...] = ("meskf", "maeskf", "vb", "robust", "oracle")
DEFAULT_GATE_Q: dict[FilterKind, float] = {"meskf": 600.0, "maeskf": 1800.0}
MAX_MATCHING_WINDOW = 100_000
"""MAESKF's innovation window holds at most this many readings per sensor (an hour of a
25-Hz sensor; the paper's is 20): its ring takes memory in proportion, and up to 0.4.4 a
window of 1e9 ended in a MemoryError traceback."""
DEFAULT_MATCHING_GAP_PERIODS = 0.0
"""MAESKF's window restarts after a sensor gap of more than this many periods (0: never, the
paper). An option: 10 helps MAESKF through the simulated DVL faults but costs it at the start
of a short mission and after a GNSS outage (estimation/noise/matching.py has the
measurements)."""
DEFAULT_GUARD_PROBABILITY = 1e-6
"""The guard's false-alarm probability per reading for a consistent filter (gate.Guard)."""
DEFAULT_R_BOUNDS: dict[FilterKind, tuple[float, float]] = {"robust": (0.1, 100.0)}
"""[floor, ceiling] of R̂ as factors of the nominal variance, per kind (estimation/noise/vb.py)."""
CONSTRAINT_R_FLOOR = 1.0
"""Under bounded R̂, the R̂ of a motion constraint (NHC, ZUPT) and of a GNSS position never falls
below its nominal R (docs/robustness.md, 'Bounded R̂'). A constraint's residuals are small
because the filter bends the solution to it, and a VB that took them for a precise sensor made
it stiffer than the model holds, overconfident in GNSS outages (robust, RTKLIB drive, driving
Q, GNSS + NHC: mean 60-s outage drift 22.5 → 13.3 m, MESKF's 12.3 m). A GNSS position's error is
correlated over minutes (multipath, the atmosphere, the ambiguities: lag-1 correlation of the
RTKLIB drive's innovations 0.75-0.96), so its residuals are small from one fix to the next
while its error is not, and a VB that shrank R̂ to them trusted the fixes more than they hold,
drifting further in outages (since 0.3.8: robust's mean outage drift with the fixes alone
125.4 → 111.3 m, 133.4 → 128.5 m and 128.1 → 132.0 m with the measured, driving and published
IMU noise; MESKF's 111.5, 128.5 and 122.2 m)."""
DEFAULT_ROBUST_DOF = 100.0
"""Student-t ν of the robust filter's reading weights (estimation/noise/vb.py, ``weights_only``:
each reading weighted by its λ, R̂ learned as by the Gaussian VB update); 0: Gaussian readings.
Chosen in 0.3.3 on the measurements of docs/robustness.md, 'The robust filter', against the
Gaussian robust filter of 0.3.2: the A-KIT faulted / clean mean relative RMSE 1.119 → 1.087
(issue 12's target ≤ 1.10; ν = 60: 1.082, ν = 200: 1.096), 0.2 % more clean error there, the
RTKLIB drive's outage drifts unchanged within 1 m, and 2.6 / 1.1 % more on the simulated trials
(mean relative RMSE over ten seeds, paper-1 / paper-2; ν = 60: 3.4 / 2.0 %, ν = 200: 1.7 /
0.3 %), whose noise is Gaussian: there down-weighting a reading only costs."""
DEFAULT_ROBUST_GNSS_RHO = 0.95
"""VB's forgetting ρ per fix of a GNSS position under the robust filter, when the mission sets no
``vb_rho`` for that sensor (the paper's 0.99 elsewhere). A receiver's accuracy changes within
seconds (satellites masked, multipath, a manoeuvre the configured Q does not cover), and a
memory of 1 / (1 - ρ) = 100 fixes (25 s at 4 Hz) kept an R̂ raised by such a burst for a minute
afterwards, trusting the fixes less when the next outage began: on the RTKLIB drive with the
published IMU noise, R̂ rose to 15× nominal at 53-56 s and 9× just before the last outage, whose
drift was 364 m against MESKF's 317 m. With ρ = 0.95 (20 fixes), mean outage drift 132.0 → 99.6 m
with the fixes alone and 11.5 → 9.3 m with the NHC (MESKF 122.2 and 12.6 m; ρ = 0.98 / 0.97 /
0.9: 118.7 / 107.7 / 98.3 m), the measured and driving Q within 0.4 m, median aided error
2.3 → 2.5 cm; the simulated trials with the GPS as an aid within 0.03 m of RMSE (docs/robustness.md,
'GNSS R̂ memory'). The floor at the nominal R (:data:`CONSTRAINT_R_FLOOR`) keeps the noisier R̂
of a shorter memory from trusting the fixes more than configured."""
DEFAULT_DIVERGENCE: dict[FilterKind, DivergenceGuard] = {}
"""The windowed NIS test per kind (estimation/health.py); a kind absent here runs without it. None
by default: on the adapted R it fires in the simulated trials' noise segments (robust with
``nis_ratio = 5``: mean relative RMSE over 20 seeds 0.630 / 1.530 % against 0.541 / 1.008 % without,
paper-1 / paper-2), though it is what holds the RTKLIB drive with a too-small Q (mean
outage drift 345 m against 2569 m); docs/robustness.md."""


Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]


@dataclass(frozen=True)
class SensorOverrides:
    """Per-sensor settings that differ from the filter's: VB's ρ_i, the matching window W_i and
    the gate's q (docs/filters.md, 'VB prediction', 'MAESKF: covariance matching', 'Gate')."""

    gate_q: float | None = None
    vb_rho: float | None = None
    matching_window: int | None = None
    guard_probability: float | None = None


class FilterSettings(BaseModel):
    """Everything that distinguishes one filter run from another on the same engine; frozen and
    validated (a wrong value is a ``pydantic.ValidationError`` naming the field)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: FilterKind = "robust"
    gate_rule: GateRule = "component"
    gate_q: dict[FilterKind, NonNegative] = Field(default_factory=lambda: dict(DEFAULT_GATE_Q))
    """q per filter kind, over :data:`DEFAULT_GATE_Q` (a kind left out keeps its default, as in
    ``r_bounds``); 0, or a kind without a default left out: no gate (:meth:`kind_gate_q`). Up
    to 0.4.8 the dict replaced the defaults, so ``{meskf = 300}`` ran MAESKF ungated."""
    gate_reference: GateReference = "adapted"
    """R in the gate's S: ``adapted``, the strategy's current R (the paper), or ``nominal``
    (estimation/gate.py)."""
    gate_sensors: tuple[str, ...] | None = None
    """Names of the gated sensors; None: every DVL (engine/channels.py)."""
    matching_window: Annotated[int, Field(ge=1, le=MAX_MATCHING_WINDOW)] = 20
    matching_floor: Positive = 1e-2
    matching_residual_based: StrictBool = False
    matching_gap_periods: NonNegative = DEFAULT_MATCHING_GAP_PERIODS
    """MAESKF's window restarts after a gap of more than this many periods
    (estimation/noise/matching.py); 0: never, the paper."""
    vb_alpha0: Positive = 1.0
    vb_rho: Annotated[float, Field(gt=0, le=1)] = 0.99
    vb_iterations: Annotated[int, Field(ge=1, le=1000)] = 5
    vb_tol: Annotated[float, Field(ge=1e-15, allow_inf_nan=False)] = 1e-6
    vb_irregular: StrictBool = False
    vb_dof: Positive | None = None
    """Student-t ν of each reading for VB-MAESKF and robust (estimation/noise/vb.py, beyond the
    paper); None: Gaussian for VB-MAESKF (the paper's update), :attr:`robust_dof` for robust."""
    robust_dof: NonNegative = DEFAULT_ROBUST_DOF
    """Student-t ν of the robust filter's reading weights when ``vb_dof`` is not set (R̂
    learned as by the Gaussian update); 0: Gaussian readings (:data:`DEFAULT_ROBUST_DOF` says
    why the default is 100)."""
    robust_gnss_rho: Annotated[float, Field(gt=0, le=1)] = DEFAULT_ROBUST_GNSS_RHO
    """VB's ρ of a GNSS position under the robust filter when its sensor sets no ``vb_rho``
    (:data:`DEFAULT_ROBUST_GNSS_RHO` says why)."""
    guard_probability: Annotated[float, Field(ge=0, lt=1)] = DEFAULT_GUARD_PROBABILITY
    """The guard's p on every sensor (gate.Guard); 0: no guard (the paper's filters exactly)."""
    guard_headroom: Annotated[float, Field(ge=1, allow_inf_nan=False)] = DEFAULT_HEADROOM
    """The guard's κ: its S holds κ × the nominal R (gate.Guard)."""
    guard_lockout_s: NonNegative = DEFAULT_LOCKOUT_S
    """A sensor the guard has rejected this long makes the filter inflate P; 0: never."""
    r_bounds: dict[FilterKind, tuple[NonNegative, Positive]] = Field(
        default_factory=lambda: dict(DEFAULT_R_BOUNDS)
    )
    """``{kind: (floor, ceiling)}``: bounds on R̂ as factors of the nominal variance (maeskf: its
    ceiling only, the floor is ``matching_floor``); a kind left out keeps its default."""
    divergence: dict[FilterKind, DivergenceGuard] = Field(
        default_factory=lambda: dict(DEFAULT_DIVERGENCE)
    )
    """``{kind: {nis_ratio, window, inflate_max}}``: the windowed NIS test
    (estimation/health.py); a kind left out keeps its default."""
    q_adaptation: QAdaptation | None = Field(default_factory=QAdaptation)
    """Q scaled by the whiteness of the innovations (estimation/noise/process.py), every kind;
    None (``false`` in a mission): the configured Q throughout (the paper); ``true``: the
    defaults."""

    @field_validator("r_bounds", mode="after")
    @classmethod
    def _merge_bounds(
        cls, v: dict[FilterKind, tuple[float, float]]
    ) -> dict[FilterKind, tuple[float, float]]:
        for k, (floor, ceiling) in v.items():
            if k in ("meskf", "oracle"):  # fixed R: a bound would be taken and do nothing
                raise ValueError(f"{k}: its R is fixed (not adapted), there is nothing to bound")
            if not floor < ceiling:
                raise ValueError(
                    f"{k}: [floor, ceiling] = {[floor, ceiling]} must have floor < ceiling"
                )
        return {**DEFAULT_R_BOUNDS, **v}

    @field_validator("gate_q", mode="after")
    @classmethod
    def _merge_gate_q(cls, v: dict[FilterKind, float]) -> dict[FilterKind, float]:
        return {**DEFAULT_GATE_Q, **v}

    @field_validator("divergence", mode="after")
    @classmethod
    def _merge_divergence(
        cls, v: dict[FilterKind, DivergenceGuard]
    ) -> dict[FilterKind, DivergenceGuard]:
        return {**DEFAULT_DIVERGENCE, **v}

    @field_validator("q_adaptation", mode="before")
    @classmethod
    def _q_adaptation_switch(cls, v: Any) -> Any:
        if v is True:
            return QAdaptation()
        return None if v is False else v

    def with_kind(self, kind: FilterKind) -> FilterSettings:
        """These settings for filter ``kind``; a ValueError of one line naming the kinds for
        anything else (a Python caller's typo got pydantic's four-line report, to 0.4.7)."""
        if kind not in FILTER_KINDS:
            raise ValueError(f"filter {kind!r}: not one of {', '.join(FILTER_KINDS)}")
        return self.updated(kind=kind)

    def updated(self, **changes: Any) -> FilterSettings:
        """These settings with ``changes``, validated like the originals (``model_copy`` would
        not check them)."""
        return type(self).model_validate({**dict(self), **changes})

    def strategy(
        self, overrides: SensorOverrides = SensorOverrides(), at_nominal: bool = False
    ) -> NoiseStrategy:
        """The R strategy of this filter kind for one sensor; for a sensor whose R̂ should not
        fall below its nominal R (``at_nominal``: a motion model's pseudo-measurement,
        ``Components.CONSTRAINT``, or a GNSS position) the floor of bounded R̂ is raised to
        :data:`CONSTRAINT_R_FLOOR` (docs/robustness.md, 'Bounded R̂')."""
        floor, ceiling = self.r_bounds.get(self.kind, (0.0, math.inf))
        if at_nominal and self.kind in self.r_bounds:
            floor = max(floor, CONSTRAINT_R_FLOOR)
        if self.kind in ("meskf", "oracle"):
            return FixedNoise()
        if self.kind == "maeskf":
            window = overrides.matching_window or self.matching_window
            return CovarianceMatching(
                window, self.matching_floor, self.matching_residual_based, ceiling,
                self.matching_gap_periods,
            )  # fmt: skip
        rho = overrides.vb_rho if overrides.vb_rho is not None else self.vb_rho
        dof, weights_only = self.vb_dof, False
        if dof is None and self.kind == "robust" and self.robust_dof > 0.0:
            dof, weights_only = self.robust_dof, True
        return VariationalBayes(
            self.vb_alpha0, rho, self.vb_iterations, self.vb_tol, self.vb_irregular, dof,
            floor, ceiling, weights_only=weights_only,
        )  # fmt: skip

    def guard(self, overrides: SensorOverrides = SensorOverrides()) -> Guard | None:
        """The nominal-R guard of one sensor, or None (p = 0)."""
        p = overrides.guard_probability
        p = self.guard_probability if p is None else p
        return Guard(p, self.guard_headroom, self.guard_lockout_s) if p > 0 else None

    def as_dict(self) -> dict[str, Any]:
        """These settings as JSON values (a run's ``meta.filter_settings``)."""
        out = {k: v for k, v in self if k not in ("divergence", "q_adaptation")}
        out["divergence"] = {k: asdict(v) for k, v in self.divergence.items()}
        qa = self.q_adaptation
        out["q_adaptation"] = asdict(qa) if qa is not None else None
        return out

    def divergence_guard(self) -> DivergenceGuard:
        """The windowed NIS test of this kind (health.OFF if none)."""
        return self.divergence.get(self.kind, OFF)

    def gated(self, sensor: str, *, is_dvl: bool) -> bool:
        """Whether the gate applies to ``sensor``: named in ``gate_sensors``, or, if that is
        None, a DVL."""
        return is_dvl if self.gate_sensors is None else sensor in self.gate_sensors

    def gate(
        self, sensor: str, overrides: SensorOverrides = SensorOverrides(), *, is_dvl: bool
    ) -> Gate | None:
        """The outlier gate for ``sensor`` (a DVL or not) under this filter kind, or None."""
        q = self.kind_gate_q()
        if q is None or not self.gated(sensor, is_dvl=is_dvl):
            return None
        return Gate(
            overrides.gate_q if overrides.gate_q is not None else q,
            self.gate_rule,
            self.gate_reference,
        )

    def kind_gate_q(self) -> float | None:
        """The gate's q of this filter kind (:attr:`gate_q`), None when the kind runs without
        a gate (left out of ``gate_q`` without a default, or 0)."""
        q = self.gate_q.get(self.kind, 0.0)
        return q if q > 0.0 else None
