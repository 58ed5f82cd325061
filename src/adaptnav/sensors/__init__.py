"""Aiding-sensor measurement models, one module per sensor (paper eq. (4)).

The table of sensors and what each H touches: docs/filters.md, 'Measurement models'.

Each sensor is a small frozen, validated config (nominal σ in SI units, lever arm ``l_b`` from
the IMU in body FRD, mounting rotation ``C_sb`` where it matters) with
``evaluate(x, z, omega_ib_b) -> Measurement | None`` giving ``y = z - h(x_hat)``,
``H = ∂h(x_hat ⊕ dx)/∂dx`` and the nominal R (``docs/conventions.md``). Each module also has
pure ``predict`` (h(x)) and ``jacobian`` (H) functions.
"""

from adaptnav.sensors.base import Measurement, MeasurementModel, euler_jacobian
from adaptnav.sensors.depth import Depth
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.gnss import GNSS
from adaptnav.sensors.heading import Heading
from adaptnav.sensors.inclinometer import Inclinometer, PendulumInclinometer
from adaptnav.sensors.nhc import NonHolonomic
from adaptnav.sensors.zupt import ZeroVelocity

__all__ = [
    "DVL",
    "GNSS",
    "Depth",
    "Heading",
    "Inclinometer",
    "Measurement",
    "MeasurementModel",
    "NonHolonomic",
    "PendulumInclinometer",
    "ZeroVelocity",
    "euler_jacobian",
]
