"""Run specs of a sweep: which mission, which filter, which parameter (issue 5).

A sweep is a list of :class:`RunSpec` (preset, seed, filter, gate coefficient q or None,
gyro-bias process-noise scale or None, disturbances, config overrides); its key
(:meth:`RunSpec.key`) names the run in the cache (:mod:`adaptnav.experiments.cache`). Three
sweeps of the paper are prepared here:

* **q sweep** (the paper's Fig. 4; docs/filters.md, 'Gate'): 25 rejection coefficients ``q`` in
  [200, 2600] (:data:`Q_VALUES`), each filter with the gate **on** at that q with the paper's
  per-component rule ``nu_j² > q S_jj`` (VB-MAESKF too: the paper says it is "not sensitive
  to q"), plus VB-MAESKF ungated (its default) and the oracle as reference lines
  (:func:`q_sweep_specs`);
* **gyro-bias process-noise sweep** (the paper's Fig. 6): the driving-noise PSD of the gyro
  bias in the filter's Q (:attr:`adaptnav.models.imu_noise.ImuNoise.gyro_bias_psd`; docs/filters.md,
  'Error-state model') times a factor in 10^[-2, 2] (:data:`Q_SCALES`), each filter at its
  default q (:func:`process_noise_specs`, :func:`scale_gyro_bias_q`);
* **Monte Carlo over seeds** (the paper's Table 3 as a distribution): each filter at its
  defaults on many seeded missions (:func:`monte_carlo_specs`), summarised by
  :mod:`adaptnav.experiments.stats`.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from adaptnav import __version__
from adaptnav.estimation.settings import FILTER_KINDS
from adaptnav.models.imu_noise import ImuNoise
from adaptnav.sim.scenarios import PRESETS
from adaptnav.sim.sensors import Disturbances

__all__ = [
    "DEFAULT_FILTERS",
    "PAPER_FILTERS",
    "Q_SCALES",
    "Q_VALUES",
    "RunSpec",
    "available_filters",
    "config_tag",
    "disturbance_tag",
    "monte_carlo_specs",
    "parse_seeds",
    "process_noise_specs",
    "q_sweep_specs",
    "scale_gyro_bias_q",
]

PAPER_FILTERS: tuple[str, ...] = ("meskf", "maeskf", "vb")
"""The paper's three filters (docs/filters.md: MESKF, MAESKF, VB-MAESKF)."""
DEFAULT_FILTERS: tuple[str, ...] = (*PAPER_FILTERS, "robust", "oracle")
"""The paper's filters, the recommended ``robust`` one (docs/robustness.md) and the oracle
baseline (:mod:`adaptnav.api.oracle`), where available."""
Q_VALUES: tuple[float, ...] = tuple(float(v) for v in np.linspace(200.0, 2600.0, 25))
"""The paper's Fig. 4: 25 rejection coefficients in [200, 2600] (step 100)."""
Q_SCALES: tuple[float, ...] = tuple(float(v) for v in np.logspace(-2.0, 2.0, 9))
"""Factors on the gyro-bias process-noise PSD, 10^[-2, 2] in 9 steps (the paper's Fig. 6)."""


def disturbance_tag(d: Disturbances) -> str:
    """First 8 hex digits of SHA-256 of the canonical JSON of non-default ``d``'s switches."""
    text = json.dumps(d.as_dict(), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def config_tag(config: Iterable[tuple[str, Any]]) -> str:
    """``path=value`` pairs of a run's config overrides, ``;``-joined ("" for none)."""
    return ";".join(f"{k}={v}" for k, v in config)


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: which mission, which filter, which parameter.

    Attributes:
        preset: simulation preset (``adaptnav.sim.scenarios.PRESETS``).
        seed: simulation seed (every error source's random stream).
        filter: a kind of :data:`adaptnav.estimation.settings.FILTER_KINDS`.
        q: DVL gate coefficient: the gate is **on** for this filter with this q (docs/filters.md,
            'Gate'; the mission's gate rule, by default per component); None: the filter's
            default (MESKF 600, MAESKF 1800 gated; VB-MAESKF and the oracle ungated).
        q_scale: factor on the gyro-bias process-noise PSD in the filter's Q
            (:func:`scale_gyro_bias_q`); None (or 1): the mission's Q.
        disturbances: the simulator's switches; None (or the default): all on.
        config: mission-config overrides ``(dotted.path, value)`` applied before the run
            (:func:`adaptnav.mission.with_overrides`), e.g. ``(("filter.specific_force_tau_s",
            1.0),)``; sorted by path. The alignment stays the mission's own.

    Equal runs are equal specs: ``q_scale=1`` is stored as None and the default disturbances
    as None, so they share one cache entry.
    """

    preset: str
    seed: int
    filter: str
    q: float | None = None
    q_scale: float | None = None
    disturbances: Disturbances | None = None
    config: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            raise ValueError(f"preset: {self.preset!r} is not one of {', '.join(PRESETS)}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            raise ValueError(f"seed: {self.seed!r} must be an integer")
        if self.seed < 0:
            raise ValueError(f"seed: {self.seed} must be >= 0")
        object.__setattr__(self, "seed", int(self.seed))
        if self.filter not in FILTER_KINDS:
            raise ValueError(f"filter: {self.filter!r} is not one of {', '.join(FILTER_KINDS)}")
        for name in ("q", "q_scale"):
            v = getattr(self, name)
            if v is None:
                continue
            if not isinstance(v, int | float | np.floating) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: {v!r} must be a finite number > 0")
            object.__setattr__(self, name, float(v))
        if self.q_scale == 1.0:
            object.__setattr__(self, "q_scale", None)
        object.__setattr__(self, "config", tuple(sorted((str(k), v) for k, v in self.config)))
        if self.disturbances == Disturbances():
            object.__setattr__(self, "disturbances", None)

    @property
    def mission_name(self) -> str:
        """``<preset>-s<seed>``, with ``-d<hash>`` of non-default disturbances."""
        base = f"{self.preset}-s{self.seed}"
        return (
            base if self.disturbances is None else f"{base}-d{disturbance_tag(self.disturbances)}"
        )

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-able fields (disturbances as their switch dict, None for the default)."""
        return {
            "preset": self.preset,
            "seed": self.seed,
            "filter": self.filter,
            "q": self.q,
            "q_scale": self.q_scale,
            "disturbances": None if self.disturbances is None else self.disturbances.as_dict(),
            # Only when set, so the keys of the paper's runs stay as they were.
            **({"config": dict(self.config)} if self.config else {}),
        }

    def key(self, version: str = __version__) -> str:
        """Stable cache key: the first 20 hex digits of SHA-256 of the canonical JSON of
        :meth:`as_dict` and the package ``version``."""
        text = json.dumps({"spec": self.as_dict(), "version": version}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:20]


def available_filters(filters: Iterable[str]) -> tuple[str, ...]:
    """``filters`` in order without duplicates; ValueError for a name that is not one of
    ``adaptnav.estimation.settings.FILTER_KINDS``."""
    out: list[str] = []
    for f in filters:
        if f not in FILTER_KINDS:
            raise ValueError(f"filter {f!r}: use one of {', '.join(FILTER_KINDS)}")
        if f not in out:
            out.append(f)
    return tuple(out)


def parse_seeds(text: str) -> list[int]:
    """Seeds from ``"1-5"``, ``"1,3,8"`` or ``"1-3,10"`` (a single number is that one seed).
    Ranges are inclusive; order kept, duplicates dropped. Raises ValueError for anything else
    (empty item, negative, reversed range)."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise ValueError(f"seeds {text!r}: empty item")
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise ValueError(f"seeds {text!r}: {part!r} is not N or N-M") from None
        if a < 0 or b < a:
            raise ValueError(f"seeds {text!r}: {part!r} must be N-M with 0 <= N <= M")
        if len(seeds) + b - a + 1 > MAX_SEEDS:  # before the range is made: 0-999999999999 hung
            raise ValueError(f"seeds {text!r}: more than {MAX_SEEDS} seeds")
        have = set(seeds)
        seeds += [s for s in range(a, b + 1) if s not in have]
    return seeds


MAX_SEEDS = 10_000
"""Seeds one sweep takes at most: ten thousand simulated missions is days of computing."""


def monte_carlo_specs(
    presets: Sequence[str], seeds: Sequence[int], filters: Sequence[str] = DEFAULT_FILTERS
) -> list[RunSpec]:
    """Each filter at its defaults on every (preset, seed): the Monte Carlo of Table 3."""
    fs = available_filters(filters)
    return [RunSpec(p, s, f) for p in presets for s in seeds for f in fs]


def q_sweep_specs(
    presets: Sequence[str],
    seeds: Sequence[int],
    q_values: Sequence[float] = Q_VALUES,
    filters: Sequence[str] = PAPER_FILTERS,
    references: Sequence[str] = ("vb", "oracle"),
) -> list[RunSpec]:
    """The paper's Fig. 4: every filter gated at every q, plus ``references`` at their
    defaults (VB-MAESKF ungated, the oracle) as the lines to compare with."""
    fs = available_filters(filters)
    refs = available_filters(references)
    out = [RunSpec(p, s, f, q=q) for p in presets for s in seeds for f in fs for q in q_values]
    out += [RunSpec(p, s, f) for p in presets for s in seeds for f in refs]
    return out


def process_noise_specs(
    presets: Sequence[str],
    seeds: Sequence[int],
    scales: Sequence[float] = Q_SCALES,
    filters: Sequence[str] = PAPER_FILTERS,
) -> list[RunSpec]:
    """The paper's Fig. 6: every filter at its default q with the gyro-bias Q times each
    factor of ``scales``."""
    fs = available_filters(filters)
    return [RunSpec(p, s, f, q_scale=k) for p in presets for s in seeds for f in fs for k in scales]


def scale_gyro_bias_q(noise: ImuNoise, scale: float) -> ImuNoise:
    """``noise`` with the gyro-bias driving-noise PSD (the Q block of ``db_g``; docs/filters.md,
    'Error-state model') times ``scale``: the Gauss-Markov σ times √scale at the same τ
    (PSD = 2σ²/τ), or, for a random walk (τ = inf), the rate random walk times √scale
    (PSD = RRW²). Nothing else changes."""
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale: {scale!r} must be a finite number > 0")
    root = math.sqrt(scale)
    if math.isinf(noise.gyro_bias_tau):
        return replace(noise, gyro_bias_rrw=noise.gyro_bias_rrw * root)
    return replace(noise, gyro_bias_sigma=noise.gyro_bias_sigma * root)
