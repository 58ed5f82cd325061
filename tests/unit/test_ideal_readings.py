"""Each kind's ``ideal_reading`` (over all N instants at once) equals its readable one-state
``predict`` called reading by reading, to 1e-12 relative (sensors/kind.py, docs/simulation.md,
'Aiding sensors').

The two compute the same formula with the same :mod:`adaptnav.core.attitude` functions, once over
arrays and once per state, so they may differ only by the rounding of a different order of
operations: a few ulps of the largest term (1e-15 relative), far inside 1e-12. The states are
random (seeded) and not the simulator's: any attitude away from pitch ±90° (where the Euler
angles are ill-conditioned), any position, non-zero IMU biases, lever arms and mountings.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from adaptnav.core import attitude
from adaptnav.models.strapdown import NOM_ATT, NOM_BA, NOM_BG, NOM_VEL
from adaptnav.sensors import depth, dvl, gnss, heading, inclinometer
from adaptnav.sensors.kind import IdealInput
from adaptnav.sensors.registry import KINDS

Array = np.ndarray
OneState = Callable[[Array, Array, Array, Array, Array | None], Array]
"""(x, ω_ib_b, f_b, l_b, C_sb) of one reading → its predicted reading."""

ONE_STATE: dict[tuple[str, str | None], OneState] = {
    ("dvl", None): lambda x, w, f, lb, C: dvl.predict(x, w, lb, C),
    ("depth", None): lambda x, w, f, lb, C: depth.predict(x, lb),
    ("heading", None): lambda x, w, f, lb, C: heading.predict(x, C),
    ("inclinometer", "attitude"): lambda x, w, f, lb, C: inclinometer.predict(x, C),
    ("inclinometer", None): lambda x, w, f, lb, C: inclinometer.pendulum_predict(x, f, C),
    ("gnss", None): lambda x, w, f, lb, C: gnss.predict(x, lb, use_height=True),
}
"""The readable path per (kind, model): what the simulator read reading by reading before the
hooks were vectorised."""

N = 400


def _truth(seed: int) -> tuple[Array, Array, Array]:
    """N random states (attitude with |pitch| < 0.8 rad, biases non-zero), body rates and
    specific forces."""
    rng = np.random.default_rng(seed)
    x = np.zeros((N, 16))
    x[:, 0] = rng.uniform(-1.4, 1.4, N)
    x[:, 1] = rng.uniform(-3.0, 3.0, N)
    x[:, 2] = rng.uniform(-500.0, 500.0, N)
    x[:, NOM_VEL] = rng.normal(0.0, 3.0, (N, 3))
    rpy = rng.uniform([-3.0, -0.8, -3.1], [3.0, 0.8, 3.1], (N, 3))
    x[:, NOM_ATT] = [attitude.euler_to_quat(*e) for e in rpy]
    x[:, NOM_BA] = rng.normal(0.0, 0.05, (N, 3))
    x[:, NOM_BG] = rng.normal(0.0, 1e-3, (N, 3))
    w = rng.normal(0.0, 0.3, (N, 3))
    f = rng.normal(0.0, 1.0, (N, 3)) + np.array([0.0, 0.0, -9.8])
    return x, w, f


def test_every_kind_with_an_ideal_reading_is_checked() -> None:
    simulated = {name for name, kind in KINDS.items() if kind.ideal_reading is not None}
    assert {name for name, _ in ONE_STATE} == simulated


@pytest.mark.parametrize("installed", [False, True], ids=["at the IMU", "lever arm, mounting"])
@pytest.mark.parametrize(("name", "model"), sorted(ONE_STATE, key=str))
def test_ideal_reading_is_predict_at_each_state(
    name: str, model: str | None, installed: bool
) -> None:
    kind = KINDS[name]
    assert kind.ideal_reading is not None
    x, w, f = _truth(seed=len(name) + 10 * installed)
    rng = np.random.default_rng(99)
    l_b = rng.uniform(-3.0, 3.0, 3) if installed and kind.lever_arm else np.zeros(3)
    C_sb = (
        attitude.euler_to_dcm(*rng.uniform(-0.3, 0.3, 3)).T if installed and kind.mounting else None
    )
    batch = kind.ideal_reading(IdealInput(x, w, f, l_b, C_sb, model))
    one = ONE_STATE[(name, model)]
    loop = np.array([one(x[i], w[i], f[i], l_b, C_sb) for i in range(N)])
    assert batch.shape == loop.shape == (N, len(kind.columns))
    # relative to each column's largest reading (a roll near 0 is as exact as one of 1 rad)
    error = np.abs(batch - loop) / np.abs(loop).max(axis=0)
    assert error.max() <= 1e-12
