"""Long-run variance (estimation/long_run.py): the Bartlett sum against its formula by hand, the
automatic bandwidth's factor against the known AR(1) value, and - the property the calibration
σ rests on (docs/calibration.md, 'Correlated readings') - the variance of a sum of correlated
terms over many draws against what the factor predicts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptnav.estimation import long_run


def _ar1(rng: np.random.Generator, rho: float, n: int, draws: int = 1) -> np.ndarray:
    """``draws`` stationary AR(1) series of n terms, unit innovation variance."""
    e = rng.normal(size=(draws, n))
    x = np.empty((draws, n))
    x[:, 0] = e[:, 0] / math.sqrt(1.0 - rho * rho)
    for k in range(1, n):
        x[:, k] = rho * x[:, k - 1] + e[:, k]
    return x


def test_bartlett_is_the_weighted_sum_of_autocovariances() -> None:
    g = np.array([[1.0, 2.0], [-0.5, 0.25], [3.0, -1.0], [0.5, 0.5], [-2.0, 1.5]])

    def gamma(lag: int) -> np.ndarray:
        return sum((np.outer(g[k], g[k - lag]) for k in range(lag, len(g))), np.zeros((2, 2)))

    by_hand = gamma(0) + (2 / 3) * (gamma(1) + gamma(1).T) + (1 / 3) * (gamma(2) + gamma(2).T)
    np.testing.assert_allclose(long_run.bartlett(g, 3.0), by_hand, rtol=1e-12)
    np.testing.assert_allclose(long_run.bartlett(g, 1.0), g.T @ g, rtol=1e-12)
    np.testing.assert_allclose(long_run.bartlett(g, 0.0), g.T @ g, rtol=1e-12)


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.6])
def test_the_factor_of_a_long_ar1_series_is_its_known_value(rho: float) -> None:
    """For AR(1) of lag-1 correlation ρ the variance of a long sum is (1 + ρ)/(1 - ρ) times the
    sum of the variances: 1, 1.86, 4."""
    x = _ar1(np.random.default_rng(7), rho, 40_000)[0]
    want = (1.0 + rho) / (1.0 - rho)
    assert long_run.variance_factor(x) == pytest.approx(want, rel=0.15)


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8])
def test_the_factor_predicts_the_spread_of_sums_over_draws(rho: float) -> None:
    """400 terms per draw (an A-KIT segment's DVL readings), 2000 draws: the mean of
    (Σ g)² / Σ g² is (1 + ρ)/(1 - ρ) (1, 3, 9), and with the factor near 1. Without the
    prewhitening (the Bartlett sum alone, its bandwidth from the data) it was 1.23 at ρ = 0.5
    and 1.53 at 0.8: the small-sample shortfall the prewhitening removes."""
    x = _ar1(np.random.default_rng(11), rho, 400, draws=2000)
    x -= x.mean()  # the population mean, known here: the sum's spread about it
    sums, squares = x.sum(axis=1) ** 2, (x * x).sum(axis=1)
    factors = np.array([long_run.variance_factor(row) for row in x])
    assert np.mean(sums / squares) == pytest.approx((1 + rho) / (1 - rho), rel=0.15)
    assert 0.9 < np.mean(sums / (factors * squares)) < 1.12


def test_too_few_or_constant_terms_have_no_factor() -> None:
    assert math.isnan(long_run.variance_factor(np.arange(long_run.MIN_TERMS - 1, dtype=float)))
    assert math.isnan(long_run.variance_factor(np.full(100, 2.5)))
    assert math.isnan(long_run.variance_factor(np.full(100, np.nan)))
    assert long_run.bandwidth(np.array([1.0, 2.0])) == 0.0
    # non-finite terms are left out, not spread into the sums
    x = _ar1(np.random.default_rng(3), 0.0, 500)[0]
    with_nan = np.insert(x, [10, 200], np.nan)
    assert long_run.variance_factor(with_nan) == pytest.approx(long_run.variance_factor(x))
