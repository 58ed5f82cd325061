"""The calibration states a mission asks for, as blocks of the error state (docs/calibration.md).

``[sensors.<name>] estimate = [...]`` of every aiding sensor becomes, in the order of the
``[sensors]`` tables and of each ``estimate`` list, one :class:`~adaptnav.models.errorstate.
StateBlock` per quantity, named ``<sensor>.<quantity>`` with states ``<sensor>.<state>``
(``dvl.scale``, ``dvl.misalignment_yaw``), random walks of the configured density or, with a
correlation time τ, first-order Gauss-Markov processes of σ the prior σ (PSD ``2σ²/τ``); their
nominal values start at zero (no error) with the configured prior σ.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission.config import MissionConfig
from adaptnav.models.errorstate import N_STATES, StateBlock, StateLayout
from adaptnav.sensors.calibration import Quantity
from adaptnav.sensors.registry import KINDS

log = logging.getLogger(__name__)

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CalibrationState:
    """One estimated quantity of one sensor: its place in the error state and its prior."""

    sensor: str
    quantity: Quantity
    first: int
    """Error-state index of its first state (its nominal values at index + 1)."""
    sigma: float
    random_walk: float
    tau: float = math.inf
    """Correlation time (s) of a Gauss-Markov quantity; inf: a random walk."""

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"{self.sensor}.{s}" for s in self.quantity.states)

    @property
    def block(self) -> StateBlock:
        """Its states: a random walk of PSD ``random_walk²``, or with a finite τ a Gauss-Markov
        process that keeps the prior σ (PSD ``2σ²/τ``: steady variance ``q τ / 2 = σ²``)."""
        rate = 0.0 if math.isinf(self.tau) else 1.0 / self.tau
        q = 2.0 * self.sigma**2 * rate if rate > 0.0 else self.random_walk**2
        n = len(self.names)
        return StateBlock(f"{self.sensor}.{self.quantity.name}", self.names, (q,) * n, (rate,) * n)


def calibration_states(cfg: MissionConfig) -> tuple[CalibrationState, ...]:
    """The mission's calibration states (module docstring), of its aiding sensors only."""
    out: list[CalibrationState] = []
    first = N_STATES
    for name, scfg in cfg.sensors.items():
        if scfg.use != "aid":
            if scfg.estimate:  # kept in mission.toml for when the sensor is on again
                log.warning("sensor %r is off: its estimate = %s gives no calibration states",
                            name, list(scfg.estimate))  # fmt: skip
            continue
        for quantity, (sigma, rw, tau) in scfg.calibration_si().items():
            q = KINDS[scfg.kind].calibration[quantity]
            out.append(CalibrationState(name, q, first, sigma, rw, tau))
            first += len(q.states)
    return tuple(out)


def layout(states: tuple[CalibrationState, ...]) -> StateLayout:
    """The error state with these calibration states after the core."""
    return StateLayout(tuple(s.block for s in states))


def indices(states: tuple[CalibrationState, ...], sensor: str) -> dict[str, int]:
    """Quantity → first error-state index, of ``sensor``'s estimated quantities."""
    return {s.quantity.name: s.first for s in states if s.sensor == sensor}


def extend(x0: Array, P0: Array, states: tuple[CalibrationState, ...]) -> tuple[Array, Array]:
    """The core's initial state and covariance with the calibration states appended: nominal
    zero, independent of the core, variance σ² each."""
    sd = np.array([s.sigma for s in states for _ in s.names], dtype=float)
    x = np.concatenate([np.asarray(x0, dtype=float), np.zeros(sd.size)])
    P = np.zeros((N_STATES + sd.size,) * 2)
    P[:N_STATES, :N_STATES] = P0
    P[N_STATES:, N_STATES:] = np.diag(sd**2)
    return x, P
