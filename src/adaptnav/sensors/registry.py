"""The sensor kinds a mission may configure, by name: each declared once in its own module
(sensors/kind.py). Adding a kind is its module and one line here; docs/architecture.md,
'Adding a sensor'."""

from __future__ import annotations

from adaptnav.sensors import depth, dvl, gnss, heading, inclinometer, nhc
from adaptnav.sensors.kind import SensorKind
from adaptnav.sensors.zupt import ZeroVelocity

KINDS: dict[str, SensorKind] = {
    k.name: k
    for k in (
        dvl.KIND,
        depth.KIND,
        inclinometer.KIND,
        heading.KIND,
        gnss.KIND,
        nhc.KIND,
    )
}
SENSOR_KINDS: tuple[str, ...] = tuple(KINDS)

LINEARISED: tuple[type, ...] = (
    *(cls for k in KINDS.values() for cls in k.linearised),
    ZeroVelocity,  # the alignment's pseudo-measurement, not a mission sensor
)
"""Every model class with a compiled linearisation (``LIN_CODE``, ``lin_params``)."""
