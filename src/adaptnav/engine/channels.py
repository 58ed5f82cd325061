"""The engine channels of one filter kind: each sensor's model with the R strategy, gate and
guard that :class:`~adaptnav.estimation.settings.FilterSettings` gives it."""

from __future__ import annotations

from collections.abc import Sequence

from adaptnav.engine.batch import SensorChannel
from adaptnav.estimation.settings import FilterSettings, SensorOverrides
from adaptnav.sensors.base import MeasurementModel
from adaptnav.sensors.dvl import DVL


def build_channels(
    settings: FilterSettings,
    sensors: Sequence[tuple[MeasurementModel, float]],
    overrides: dict[str, SensorOverrides] | None = None,
) -> list[SensorChannel]:
    """Engine channels for ``sensors`` given as (model, nominal period in s)."""
    ov = overrides or {}
    out = []
    for model, period in sensors:
        o = ov.get(model.name, SensorOverrides())
        out.append(
            SensorChannel(
                model, period, settings.strategy(o, getattr(model, "CONSTRAINT", False)),
                settings.gate(model.name, o, is_dvl=isinstance(model, DVL)), settings.guard(o),
            )
        )  # fmt: skip
    return out
