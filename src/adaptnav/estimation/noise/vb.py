"""VB-MAESKF: per-component noise variances by variational Bayes (the paper's method).

The equations in words: docs/filters.md, 'VB-MAESKF: variational Bayes'.

Each measurement component j of sensor i has ``σ²_ij ~ InvGamma(α_ij, β_ij)`` (paper eq. (8);
docs/filters.md, 'VB prior'), R_i diagonal (Särkkä & Nummenmaa 2009). Initialisation
``α = α0``, ``β = α0 σ²_nominal``.

Prediction, only for sensor i at its own epoch (paper eqs. (12), (13); docs/filters.md,
'VB prediction'): ``α⁻ = ρ_i α⁺``, ``β⁻ = ρ_i β⁺`` (variant for irregular data:
``ρ_i^(dt/T_i)``).

Update over the received components, x⁻ = 0 (paper eqs. (23)-(28); docs/filters.md,
'VB update')::

    α = α⁻ + 1/2
    β = β⁻
    repeat N times (or until R̂ changes by < tol, relative):
        R̂ = diag(β / α)
        S = H P⁻ Hᵀ + R̂;  K = P⁻ Hᵀ S⁻¹
        x⁺ = K y;  P⁺ = P⁻ - K S Kᵀ
        β = β⁻ + ½ (y - H x⁺)² + ½ diag(H P⁺ Hᵀ)

Components not received keep α, β (paper eqs. (29), (30)): the engine passes only received
sensors.

**Beyond the paper: a heavy-tailed (Student-t) reading.** With ``dof = ν`` set, each sensor's
reading b gets its own scale ``λ_b ~ Gamma(ν/2, ν/2)``, its noise ``N(0, R_b / λ_b)``: the
inverse-Gamma variances keep the slow level, λ the one bad reading (Huang et al. 2017, "A novel
robust Student's t-based Kalman filter", IEEE TAES 53(3); Roth et al. 2013). The iteration
becomes, with ``B_j = (y - H x⁺)²_j + diag(H P⁺ Hᵀ)_j`` and ``E[1/σ²_j] = α_j / β_j``::

        S = H P⁻ Hᵀ + diag(R̂ / λ)
        ...
        λ_b = (ν + d_b) / (ν + Σ_{j in b} B_j α_j / β_j)
        β = β⁻ + ½ λ B

so a reading far off its R̂ gets a small λ: it moves the state little and raises β little,
where the Gaussian update would raise β by ½ B and so R̂ for the next 1/(1 - ρ) epochs.
``dof = None`` (the default) is the paper's Gaussian update (λ = 1).

With ``weights_only``, β learns ``β⁻ + ½ B`` as in the Gaussian update while the correction
still uses ``R̂ / λ``: the reading is down-weighted at once, and a lasting rise of the noise
(a segment of minutes rather than a burst) still raises R̂ at the Gaussian update's pace,
which the Student-t β (½ λ B) slows down (measured: docs/robustness.md, 'The robust filter').

**Beyond the paper: bounds on R̂.** With ``r_floor`` / ``r_ceiling`` set, every R̂ of the iteration
is clipped to ``[r_floor, r_ceiling] × σ²_nominal`` and so is the state's β/α at the end (β clipped
to ``[r_floor, r_ceiling] α σ²_nominal``). When Q is too small for the real motion, the innovations
exceed what P predicts and an unbounded R̂ takes the excess for sensor noise: the filter trusts its
sensors less, drifts more, and R̂ grows again (measured on the RTKLIB drive, docs/robustness.md). A
ceiling stops R̂'s part of that loop; the windowed NIS test (estimation/health.py), if on, then sees
the excess and inflates P instead. Defaults 0 and inf: the paper.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from adaptnav.estimation import kalman
from adaptnav.estimation.noise.base import Array, Block, NoiseKind, StackedResult, slices, stack


@dataclass(frozen=True)
class VBState:
    alpha: Array
    beta: Array


@dataclass(frozen=True)
class VariationalBayes:
    """Settings: α0, forgetting ρ, at most N fixed-point iterations, relative tolerance."""

    kind: ClassVar[NoiseKind] = NoiseKind.VB

    alpha0: float = 1.0
    rho: float = 0.99
    iterations: int = 5
    tol: float = 1e-6
    irregular: bool = False
    """Use ``ρ^(dt/T)`` instead of ρ (for sensors with jitter and gaps)."""
    dof: float | None = None
    """Student-t degrees of freedom ν of each reading (module docstring); None: Gaussian."""
    r_floor: float = 0.0
    """Lower bound on R̂ as a factor of the nominal variance (module docstring)."""
    r_ceiling: float = math.inf
    """Upper bound on R̂ as a factor of the nominal variance (module docstring)."""
    name: str = "vb"
    weights_only: bool = False
    """With ``dof``: β learns ½ B, the Gaussian update's, instead of ½ λ B, so that λ only
    weights the reading in the correction (module docstring)."""

    def __post_init__(self) -> None:
        if not np.isfinite(self.alpha0) or self.alpha0 <= 0:
            raise ValueError(f"vb alpha0: value {self.alpha0!r} must be > 0")
        if not 0 < self.rho <= 1:
            raise ValueError(f"vb rho: value {self.rho!r} must be in (0, 1]")
        if self.iterations < 1:
            raise ValueError(f"vb iterations: value {self.iterations!r} must be >= 1")
        if self.dof is not None and not (np.isfinite(self.dof) and self.dof > 0):
            raise ValueError(f"vb dof: value {self.dof!r} must be a finite number > 0 (or none)")
        if not 0.0 <= self.r_floor < self.r_ceiling:
            raise ValueError(
                f"vb R̂ bounds: [{self.r_floor!r}, {self.r_ceiling!r}] must have 0 <= floor "
                "< ceiling"
            )

    def initial_state(self, R_nominal: Array) -> VBState:
        var = np.diag(R_nominal).copy()
        return VBState(np.full(var.size, self.alpha0), self.alpha0 * var)

    def predict(self, state: VBState, dt: float, period: float) -> VBState:
        rho = self.rho ** (dt / period) if self.irregular and period > 0 else self.rho
        return VBState(rho * state.alpha, rho * state.beta)

    def current_R(self, state: VBState, R_nominal: Array) -> Array:
        return np.diag(state.beta / state.alpha)

    def update(self, P: Array, blocks: Sequence[Block]) -> StackedResult:
        H, y = stack(blocks)
        alpha_prior = np.concatenate([b.state.alpha for b in blocks])
        beta_prior = np.concatenate([b.state.beta for b in blocks])
        alpha = alpha_prior + 0.5
        beta = beta_prior.copy()
        lam = np.ones(y.size)  # λ of each component's reading
        var = np.concatenate([np.diag(b.R_nominal) for b in blocks])
        lo, hi = self.r_floor * var, self.r_ceiling * var
        r_hat = np.clip(beta / alpha / lam, lo, hi)  # the R of the correction
        done = 0
        while True:
            done += 1
            corr = kalman.correct(P, H, y, np.diag(r_hat))
            resid = y - H @ corr.dx
            B = resid * resid + np.einsum("ij,jk,ik->i", H, corr.P, H)
            if self.dof is not None:
                for sl in slices(blocks):
                    d = sl.stop - sl.start
                    lam[sl] = (self.dof + d) / (self.dof + np.sum(B[sl] * alpha[sl] / beta[sl]))
            beta = beta_prior + 0.5 * (B if self.weights_only else lam * B)
            r_next = np.clip(beta / alpha / lam, lo, hi)
            if done >= self.iterations or np.all(np.abs(r_next - r_hat) <= self.tol * r_hat):
                beta = np.clip(beta, lo * alpha, hi * alpha)
                break
            r_hat = r_next
        states = tuple(VBState(alpha[sl], beta[sl]) for sl in slices(blocks))
        Rs = tuple(np.diag(r_hat[sl]) for sl in slices(blocks))
        return StackedResult(corr, states, Rs, done)
