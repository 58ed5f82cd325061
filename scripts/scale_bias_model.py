"""The two-state model of docs/calibration.md, 'A known bias of the scale'.

A speed v and a reading scale s; the DVL reads ``z = (1 + s) v + ε`` at every step, the INS
gives the speed changes exactly plus a velocity random walk of variance ``q`` per step; the
speed is 2.35 m/s with slow-downs to 1.5 m/s and back (what makes s observable). Three updates
of the same filter are compared over 12 seeds, for a true scale of 0 and of 1 %:

* ``ekf``: linearised at the prior, as adaptnav's filters do;
* ``iekf``: iterated, linearised at the posterior (Gauss-Newton);
* ``midpoint``: iterated, H at the midpoint between prior and posterior, the innovation at the
  prior: for a product of two states ``h(x₁) - h(x₀) = H(½(x₀ + x₁)) (x₁ - x₀)`` exactly (a
  secant), so the update's linear prediction is exact along its step.

It prints the mean error of ŝ, its spread over the seeds, the mean σ the filter claims and the
mean of (error / σ)² (1 for a consistent estimate).
``python scripts/scale_bias_model.py [q [q_true]]``: the filter's velocity random walk q and the
truth's (default: the same; 0: the INS's speed changes exact while the filter assumes q).
"""

from __future__ import annotations

import sys

import numpy as np

SPEED, SLOW, SIGMA_Z = 2.35, 1.5, 0.047
STEPS, SEEDS = 30_000, 12


def speeds(n: int) -> np.ndarray:
    """The true speed: a ramp up from rest, then every 6000 steps a slow-down and back."""
    v = np.full(n, SPEED)
    v[:300] = np.linspace(0.0, SPEED, 300)
    for c in range(3000, n, 6000):
        v[c : c + 300] = np.linspace(SPEED, SLOW, 300)
        v[c + 300 : c + 1500] = SLOW
        v[c + 1500 : c + 1800] = np.linspace(SLOW, SPEED, 300)
    return v


def run(seed: int, q: float, update: str, s_true: float, q_true: float) -> tuple[float, float]:
    """One filter run; the final ŝ and its σ."""
    rng = np.random.default_rng(seed)
    v_true = speeds(STEPS)
    x, P = np.zeros(2), np.diag([0.01**2, 0.01**2])  # (v, s)
    for k in range(STEPS):
        if k > 0:
            x[0] += v_true[k] - v_true[k - 1] + np.sqrt(q_true) * rng.standard_normal()
        P = P + np.diag([q, 0.0])
        z = (1.0 + s_true) * v_true[k] + SIGMA_Z * rng.standard_normal()
        nu = z - (1.0 + x[1]) * x[0]
        xi = x.copy()
        for _ in range(1 if update == "ekf" else 6):
            at = x if update == "ekf" else xi if update == "iekf" else 0.5 * (x + xi)
            H = np.array([[1.0 + at[1], at[0]]])
            K = P @ H.T / (H @ P @ H.T + SIGMA_Z**2)
            innovation = nu
            if update == "iekf":  # Gauss-Newton: the residual at xi, brought back to x
                innovation = z - (1.0 + xi[1]) * xi[0] - (H @ (x - xi)).item()
            xi = x + (K * innovation).ravel()
        x, P = xi, (np.eye(2) - K @ H) @ P
    return float(x[1]), float(np.sqrt(P[1, 1]))


def main() -> None:
    q = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-6
    q_true = float(sys.argv[2]) if len(sys.argv) > 2 else q
    print(f"velocity random walk q = {q:g} (m/s)² per step (truth {q_true:g}), {SEEDS} seeds")
    for update in ("ekf", "iekf", "midpoint"):
        for s_true in (0.0, 0.01):
            runs = [run(seed, q, update, s_true, q_true) for seed in range(1, SEEDS + 1)]
            err = 100.0 * (np.array([r[0] for r in runs]) - s_true)
            sd = 100.0 * np.array([r[1] for r in runs])
            print(
                f"{update:8s} true {100 * s_true:.0f} %: mean error {err.mean():+.3f} %, "
                f"spread {err.std():.3f} %, claimed σ {sd.mean():.3f} %, "
                f"mean (error/σ)² {np.mean((err / sd) ** 2):.2f}"
            )


if __name__ == "__main__":
    main()
