"""The demo mission simulated with known sensor calibration errors (docs/simulation.md,
'Calibration errors'), as simulated or asking the filter to estimate them (docs/calibration.md).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from adaptnav.sim.scenarios import simulate
from adaptnav.sim.sensors import Calibration

TRUTH = {
    "dvl.scale": 0.01,
    "dvl.misalignment_roll": 0.0,
    "dvl.misalignment_pitch": 0.0,
    "dvl.misalignment_yaw": math.radians(1.0),
    "depth.bias": 0.3,
    "inclinometer.bias_roll": math.radians(0.3),
    "inclinometer.bias_pitch": math.radians(-0.2),
}
"""The true calibration states (SI) of :data:`CALIBRATION`, in the order a run lists them."""
CALIBRATION = Calibration(
    1.01, (0.0, 0.0, math.radians(1.0)), 0.3, (math.radians(0.3), math.radians(-0.2))
)
ESTIMATE = {"dvl": '["scale", "misalignment"]', "depth": '["bias"]', "inclinometer": '["bias"]'}
"""What the estimating mission asks for, per sensor (``estimate = ...`` of mission.toml)."""


def mission(
    out: Path,
    *,
    estimate: bool,
    seed: int = 4,
    preset: str = "demo",
    calibration: Calibration = CALIBRATION,
    quantities: dict[str, str] = ESTIMATE,
) -> Path:
    """The ``preset`` with the true ``calibration`` written to ``out``; with ``estimate`` its
    mission.toml asks for every quantity of ``quantities``."""
    folder = simulate(preset, seed, out, calibration=calibration)
    if estimate:
        toml = folder / "mission.toml"
        text = toml.read_text()
        for sensor, asked in quantities.items():
            head = f'[sensors.{sensor}]\nkind = "{sensor}"\n'
            assert head in text
            text = text.replace(head, f"{head}estimate = {asked}\n")
        toml.write_text(text)
    return folder


def true_states(folder: Path) -> dict[str, float]:
    """The true calibration states of a mission in report units (%, deg, m), read straight
    from its simulation.json (docs/simulation.md, 'Calibration errors')."""
    sim = json.loads((folder / "simulation.json").read_text())["calibration"]
    mis, tilt = sim["dvl_misalignment_rad"], sim["inclinometer_bias_rad"]
    axes = ("roll", "pitch", "yaw")
    return {
        "dvl.scale": 100.0 * (sim["dvl_scale_factor"] - 1.0),
        **{f"dvl.misalignment_{a}": math.degrees(mis[i]) for i, a in enumerate(axes)},
        "depth.bias": sim["depth_bias_m"],
        **{f"inclinometer.bias_{a}": math.degrees(tilt[i]) for i, a in enumerate(axes[:2])},
    }
