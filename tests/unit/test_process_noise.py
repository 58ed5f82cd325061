"""Q adaptation by the whiteness of the innovations (estimation/noise/process.py,
docs/robustness.md).

The estimator against an AR(1) sequence, whose lag-1 autocorrelation is its coefficient;
the engine on synthetic missions whose IMU is noisier than Q says (β grows, the velocity
error falls) and whose Q is right (β stays 1 and nothing changes); the settings from TOML.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adaptnav.engine import batch as engine
from adaptnav.estimation.noise import FixedNoise
from adaptnav.estimation.noise.process import QAdaptation, WhitenessState, whiteness_step
from adaptnav.mission import MissionError, parse_config
from adaptnav.models import errorstate
from helpers import synthetic
from helpers.missions import config_dict


def _feed(qa: QAdaptation, seq: np.ndarray, period: float = 1.0) -> tuple[WhitenessState, float]:
    state, beta = WhitenessState(), 1.0
    for k, v in enumerate(seq):
        state, beta = whiteness_step(qa, state, beta, k * period, period, [v], [1.0])
    return state, beta


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.8])
def test_the_ratio_is_the_lag_one_autocorrelation(phi: float) -> None:
    """For x_k = φ x_{k-1} + e_k the lag-1 autocorrelation is φ (stationary AR(1))."""
    rng = np.random.default_rng(1)
    e = rng.normal(size=20000)
    x = np.empty_like(e)
    x[0] = e[0] / math.sqrt(1 - phi**2)
    for k in range(1, e.size):
        x[k] = phi * x[k - 1] + e[k]
    state, _ = _feed(QAdaptation(window=5000), x)
    assert state.c1 / state.c0 == pytest.approx(phi, abs=0.05)
    assert state.c0 == pytest.approx(1 / (1 - phi**2), rel=0.1)  # the variance of x


def test_beta_grows_on_correlated_and_stays_one_on_white_innovations() -> None:
    rng = np.random.default_rng(2)
    qa = QAdaptation()  # ρ₀ = 0.5
    _, beta_white = _feed(qa, rng.normal(size=3000))
    assert beta_white == 1.0
    walk = np.cumsum(rng.normal(size=3000))  # a drift the filter does not follow: ρ ≈ 1
    _, beta_walk = _feed(qa, walk)
    assert beta_walk == qa.beta_max


def test_readings_further_apart_than_the_gap_are_not_paired() -> None:
    qa = QAdaptation(window=2)
    state, beta = WhitenessState(), 1.0
    for t in (0.0, 1.0, 10.0, 20.0, 30.0):  # only the first pair is within 2.5 periods
        state, beta = whiteness_step(qa, state, beta, t, 1.0, [1.0], [1.0])
    assert state.pairs == 1 and beta == 1.0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=40, max_size=80), st.floats(0.01, 2.0))
def test_beta_stays_within_its_bounds(seq: list[float], gain: float) -> None:
    qa = QAdaptation(gain=gain, beta_max=50.0, window=3)
    _, beta = _feed(qa, np.asarray(seq) + 1e-3)
    assert 1.0 <= beta <= 50.0


@pytest.mark.parametrize(
    "kwargs",
    [{"gain": 0.0}, {"gain": math.nan}, {"target": 1.0}, {"target": -0.1}, {"beta_max": 0.5},
     {"window": 1}],
)  # fmt: skip
def test_q_adaptation_refuses_bad_settings(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="q_adaptation"):
        QAdaptation(**kwargs)  # type: ignore[arg-type]


# --- the engine -----------------------------------------------------------------------------


def _noisy_imu(seed: int, factor: float) -> synthetic.Dataset:
    """A synthetic mission whose IMU white noise is ``factor`` × what synthetic.NOISE says."""
    ds = synthetic.make(seed, duration=120.0, sensors=("dvl", "depth", "gnss"))
    rng = np.random.default_rng(seed)
    sd = np.sqrt(np.broadcast_to(ds.dt, ds.dvel.shape[:1]))[:, None]
    ds.dvel[:] += rng.normal(0.0, factor * synthetic.NOISE.vrw * sd, ds.dvel.shape)
    ds.dtheta[:] += rng.normal(0.0, factor * synthetic.NOISE.arw * sd, ds.dtheta.shape)
    return ds


def _run(ds: synthetic.Dataset, q_factor: float, qa: QAdaptation | None) -> engine.EngineOutput:
    n = synthetic.NOISE
    noise = dataclasses.replace(n, arw=n.arw * q_factor, vrw=n.vrw * q_factor)
    periods = synthetic.periods()
    channels = [
        engine.SensorChannel(ds.models[s], periods[s], FixedNoise(), None, None)
        for s in ds.readings
    ]
    return engine.run_batch(
        engine.EngineConfig(noise, q_adaptation=qa), channels, ds.x0_hat, ds.P0, ds.t0,
        ds.imu_t, ds.dt, ds.dtheta, ds.dvel, ds.readings,
    )  # fmt: skip


def _velocity_rms(out: engine.EngineOutput, ds: synthetic.Dataset) -> float:
    j = np.searchsorted(ds.truth_t, out.t)
    ok = (j < ds.truth_t.size) & (
        np.abs(ds.truth_t[np.minimum(j, ds.truth_t.size - 1)] - out.t) < 1e-9
    )
    err = [
        errorstate.difference(x, ds.truth[i])[3:6] for x, i in zip(out.x[ok], j[ok], strict=True)
    ]
    return float(np.sqrt(np.mean(np.sum(np.square(err), axis=1))))


def test_q_too_small_is_scaled_up_and_the_error_falls() -> None:
    """The IMU 30× noisier in σ than Q says. Measured (seeds 31-33): β 3-28, velocity RMS
    0.080-0.105 m/s without the adaptation, 0.072-0.078 with it."""
    without, adapted = [], []
    for seed in (31, 32, 33):
        ds = _noisy_imu(seed, 30.0)
        out = _run(ds, 1.0, QAdaptation())
        assert out.q_scale > 2.0
        assert [e["event"] for e in out.events].count("q_scale") >= 1
        without.append(_velocity_rms(_run(ds, 1.0, None), ds))
        adapted.append(_velocity_rms(out, ds))
    assert np.mean(adapted) < 0.9 * np.mean(without)


def test_q_right_leaves_the_filter_as_it_was() -> None:
    """Q matching the IMU: the innovations are white, β stays 1, the run is the same."""
    ds = _noisy_imu(31, 30.0)
    out = _run(ds, 30.0, QAdaptation())
    bare = _run(ds, 30.0, None)
    assert out.q_scale == 1.0 and not out.events
    np.testing.assert_array_equal(out.x, bare.x)


# --- settings ---------------------------------------------------------------------------------


def test_q_adaptation_from_toml() -> None:
    assert parse_config(config_dict()).filter_settings().q_adaptation == QAdaptation()
    d = config_dict(filter={"q_adaptation": False})
    assert parse_config(d).filter_settings().q_adaptation is None
    d = config_dict(filter={"q_adaptation": {"target": 0.3, "beta_max": 50.0}})
    assert parse_config(d).filter_settings().q_adaptation == QAdaptation(target=0.3, beta_max=50.0)
    with pytest.raises(MissionError, match="q_adaptation"):
        parse_config(config_dict(filter={"q_adaptation": {"target": 1.5}}))
    with pytest.raises(MissionError, match="q_adaptation"):
        parse_config(config_dict(filter={"q_adaptation": "yes"}))
