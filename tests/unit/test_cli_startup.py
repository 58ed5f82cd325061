"""The command line starts without the scientific stack: each command imports what it needs."""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any

import typer.main

from adaptnav.cli import app
from adaptnav.importers.nmea import UERE_M
from adaptnav.importers.rosbag import STAMP_TOLERANCE_S

HEAVY = ("numpy", "pandas", "scipy", "matplotlib", "plotly", "pyarrow", "adaptnav.mission")


def test_importing_the_cli_loads_no_heavy_module() -> None:
    code = f"import sys, adaptnav.cli; print(*[m for m in {HEAVY!r} if m in sys.modules])"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    assert done.stdout.split() == []


def test_nmea_uere_help_states_the_importer_default() -> None:
    # The option's default is resolved inside the command (the importer is imported there);
    # its help must still give the importer's value.
    group: Any = typer.main.get_command(app)
    nmea = group.commands["import"].commands["nmea"]
    option = next(p for p in nmea.params if p.name == "uere_m")
    assert option.default is None
    assert f"default: {UERE_M:g}," in (getattr(option, "help", None) or "")


def test_rosbag_stamp_tolerance_help_states_the_importer_default() -> None:
    group: Any = typer.main.get_command(app)
    rosbag = group.commands["import"].commands["rosbag"]
    option = next(p for p in rosbag.params if p.name == "stamp_tolerance_s")
    assert option.default is None
    assert f"default: {STAMP_TOLERANCE_S:g}," in (getattr(option, "help", None) or "")
