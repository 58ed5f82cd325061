"""A tiny simulated mission (about a minute, CSV tables) for the bad-input tests.

The simulator's demo scenario cut short: 20 s alongside (the static alignment), then 20 s
straight at 1 m/s, a 20° turn and 10 s straight, every disturbance on, with the demo's
sensors (DVL 3 Hz, depth 1 Hz, pendulum inclinometer 5 Hz, heading off, GPS for the
alignment only) and the truth. Built once per session and copied for each test.
"""

from __future__ import annotations

import shutil
from dataclasses import replace
from functools import cache
from pathlib import Path

import pandas as pd

from adaptnav.core.units import DEG
from adaptnav.mission import write_mission
from adaptnav.sim import scenarios
from adaptnav.sim import trajectory as tr

SEED = 7


@cache
def _generated(seed: int = SEED) -> scenarios.SimulatedMission:
    base = scenarios.demo()
    spec = replace(
        base.trajectory,
        segments=(
            tr.Static(20.0),
            tr.Straight(20.0, 1.0),
            tr.Turn(20 * DEG, rate=2 * DEG),
            tr.Straight(10.0),
        ),
        sea_state=(tr.SeaState(20.0, 1.0, 10.0),),
        max_accel=0.5,
        max_yaw_accel=2 * DEG,
        min_step=1.0,
    )
    return scenarios.generate(replace(base, name="tiny", trajectory=spec), seed)


def tiny_mission(root: Path, fmt: str = "csv", seed: int = SEED) -> Path:
    """Write the tiny mission to ``root`` (tables as ``fmt``: csv or parquet; ``seed``: the
    simulator's, another one giving the same mission with other noise); returns it."""
    sim = _generated(seed)
    tables = {k: v.copy() for k, v in sim.tables.items()}
    write_mission(root, sim.config, tables, fmt=fmt)  # type: ignore[arg-type]
    return root


def copy_mission(source: Path, root: Path) -> Path:
    """A copy of the mission folder ``source`` at ``root``."""
    shutil.copytree(source, root)
    return root


def read(root: Path, name: str) -> pd.DataFrame:
    """The table ``name`` (file stem) of a mission folder, CSV or Parquet."""
    for ext in (".csv", ".parquet"):
        if (root / f"{name}{ext}").is_file():
            if ext == ".csv":
                return pd.read_csv(root / f"{name}{ext}")
            return pd.read_parquet(root / f"{name}{ext}")
    raise FileNotFoundError(root / name)


def write(root: Path, name: str, df: pd.DataFrame) -> None:
    """Replace the table ``name`` (file stem) of a mission folder, in its own format."""
    if (root / f"{name}.csv").is_file():
        df.to_csv(root / f"{name}.csv", index=False)
    else:
        df.to_parquet(root / f"{name}.parquet", index=False)
