"""Command line: the only place that knows files and human units (degrees, hours).

One module per group of commands, each registering on the one :data:`app`:
:mod:`~adaptnav.cli.core` (demo, run, evaluate, simulate, version).
"""

from adaptnav.cli import core as core
from adaptnav.cli._app import app

__all__ = ["app"]
