"""VB-MAESKF: per-component noise variances by variational Bayes (spec §6.3, the paper's method).

Each measurement component j of sensor i has ``σ²_ij ~ InvGamma(α_ij, β_ij)`` (P-8), R_i diagonal
(Särkkä & Nummenmaa 2009). Initialisation ``α = α0``, ``β = α0 σ²_nominal``.

Prediction, only for sensor i at its own epoch (P-12, P-13): ``α⁻ = ρ_i α⁺``, ``β⁻ = ρ_i β⁺``
(variant for irregular data: ``ρ_i^(dt/T_i)``).

Update over the received components, x⁻ = 0 (P-23..P-28)::

    α = α⁻ + 1/2
    β = β⁻
    repeat N times (or until R̂ changes by < tol, relative):
        R̂ = diag(β / α)
        S = H P⁻ Hᵀ + R̂;  K = P⁻ Hᵀ S⁻¹
        x⁺ = K y;  P⁺ = P⁻ - K S Kᵀ
        β = β⁻ + ½ (y - H x⁺)² + ½ diag(H P⁺ Hᵀ)

Components not received keep α, β (P-29, P-30): the engine passes only received sensors.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from adaptnav import kalman
from adaptnav.noise.base import Array, Block, StackedResult, slices, stack


@dataclass(frozen=True)
class VBState:
    alpha: Array
    beta: Array


@dataclass(frozen=True)
class VariationalBayes:
    """Settings: α0, forgetting ρ, at most N fixed-point iterations, relative tolerance."""

    alpha0: float = 1.0
    rho: float = 0.99
    iterations: int = 5
    tol: float = 1e-6
    irregular: bool = False
    """Use ``ρ^(dt/T)`` instead of ρ (for sensors with jitter and gaps)."""
    name: str = "vb"

    def __post_init__(self) -> None:
        if not np.isfinite(self.alpha0) or self.alpha0 <= 0:
            raise ValueError(f"vb alpha0: value {self.alpha0!r} must be > 0")
        if not 0 < self.rho <= 1:
            raise ValueError(f"vb rho: value {self.rho!r} must be in (0, 1]")
        if self.iterations < 1:
            raise ValueError(f"vb iterations: value {self.iterations!r} must be >= 1")

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
        r_hat = beta / alpha
        done = 0
        while True:
            done += 1
            corr = kalman.correct(P, H, y, np.diag(r_hat))
            resid = y - H @ corr.dx
            hph = np.einsum("ij,jk,ik->i", H, corr.P, H)
            beta = beta_prior + 0.5 * resid * resid + 0.5 * hph
            r_next = beta / alpha
            if done >= self.iterations or np.all(np.abs(r_next - r_hat) <= self.tol * r_hat):
                break
            r_hat = r_next
        states = tuple(VBState(alpha[sl], beta[sl]) for sl in slices(blocks))
        Rs = tuple(np.diag(r_hat[sl]) for sl in slices(blocks))
        return StackedResult(corr, states, Rs, done)
