"""The engine channels of one filter kind: each sensor's model with the R strategy, gate and
guard that :class:`~adaptnav.estimation.settings.FilterSettings` gives it."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from adaptnav.engine.batch import SensorChannel
from adaptnav.estimation.settings import FilterSettings, SensorOverrides
from adaptnav.sensors.base import MeasurementModel
from adaptnav.sensors.dvl import DVL
from adaptnav.sensors.gnss import GNSS


def build_channels(
    settings: FilterSettings,
    sensors: Sequence[tuple[MeasurementModel, float]],
    overrides: dict[str, SensorOverrides] | None = None,
) -> list[SensorChannel]:
    """Engine channels for ``sensors`` given as (model, nominal period in s). A motion
    constraint's and a GNSS position's R̂ is held at or above its nominal R under bounded R̂
    (estimation/settings.py, ``CONSTRAINT_R_FLOOR``); under the robust filter a GNSS position
    without a ``vb_rho`` of its own forgets at ``settings.robust_gnss_rho``
    (``DEFAULT_ROBUST_GNSS_RHO``)."""
    ov = overrides or {}
    out = []
    for model, period in sensors:
        o = ov.get(model.name, SensorOverrides())
        if settings.kind == "robust" and isinstance(model, GNSS) and o.vb_rho is None:
            o = replace(o, vb_rho=settings.robust_gnss_rho)
        at_nominal = bool(getattr(model, "CONSTRAINT", False)) or isinstance(model, GNSS)
        out.append(
            SensorChannel(
                model, period, settings.strategy(o, at_nominal),
                settings.gate(model.name, o, is_dvl=isinstance(model, DVL)), settings.guard(o),
            )
        )  # fmt: skip
    return out
