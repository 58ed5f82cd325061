"""The command line starts without the scientific stack: each command imports what it needs."""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any

import pytest
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


@pytest.mark.parametrize(
    ("command", "name", "default"),
    [("nmea", "uere_m", UERE_M), ("rosbag", "stamp_tolerance_s", STAMP_TOLERANCE_S)],
)
def test_an_importer_option_help_states_the_importer_default(
    command: str, name: str, default: float
) -> None:
    # The option's default is resolved inside the command (the importer is imported there);
    # its help must still give the importer's value.
    group: Any = typer.main.get_command(app)
    importer = group.commands["import"].commands[command]
    option = next(p for p in importer.params if p.name == name)
    assert option.default is None
    assert f"default: {default:g}," in (getattr(option, "help", None) or "")
