"""Mission input format: a folder with ``mission.toml`` and one table per stream.

Defined once here and documented in docs/data-format.md: the TOML schema
(:mod:`adaptnav.mission.config`), the tables and their columns (:mod:`adaptnav.mission.tables`) and
the loaded, checked data (:mod:`adaptnav.mission.loader`). Bad input gives a :class:`MissionError`
naming file, line and field, or a logged :class:`Repair` (logger ``adaptnav.mission``).
"""

from adaptnav.mission.config import (
    FilterConfig,
    ImuConfig,
    ImuNoiseConfig,
    InitialBiasSigma,
    InitialConfig,
    MissionConfig,
    MissionError,
    MissionSection,
    MissionUnitError,
    SensorConfig,
    TruthConfig,
    load_config,
    parse_config,
    with_overrides,
    write_config,
)
from adaptnav.mission.loader import (
    ImuData,
    Mission,
    SensorData,
    build_sensor_model,
    load_mission,
    write_mission,
)
from adaptnav.mission.tables import DroppedRow, Repair

__all__ = [
    "DroppedRow",
    "FilterConfig",
    "ImuConfig",
    "ImuData",
    "ImuNoiseConfig",
    "InitialBiasSigma",
    "InitialConfig",
    "Mission",
    "MissionConfig",
    "MissionError",
    "MissionSection",
    "MissionUnitError",
    "Repair",
    "SensorConfig",
    "SensorData",
    "TruthConfig",
    "build_sensor_model",
    "load_config",
    "load_mission",
    "parse_config",
    "with_overrides",
    "write_config",
    "write_mission",
]
