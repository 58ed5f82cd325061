"""The typer application and what every command module shares: consoles, the failure exit,
filter names and the paper's Table 3."""

from __future__ import annotations

import os
from typing import NoReturn

import typer
from rich.console import Console

from adaptnav.compare import FILTER_LABELS as FILTER_LABELS  # single sources, re-exported
from adaptnav.compare import PAPER_TABLE3 as PAPER_TABLE3

FILTER_CHOICES = ("meskf", "maeskf", "vb", "oracle")
"""Filters ``adaptnav run`` runs (the engine's kinds; the floor is not a filter)."""

app = typer.Typer(
    help="adaptnav: asynchronous multirate multi-sensor inertial navigation.",
    no_args_is_help=True,
    add_completion=False,
)
PIPE_WIDTH = 120
"""Columns of output that goes to a file or pipe (rich's own default there is 80, which cuts
the comparison table); ``COLUMNS`` in the environment still wins."""


def _console(stderr: bool = False) -> Console:
    c = Console(stderr=stderr)
    if c.is_terminal or "COLUMNS" in os.environ:
        return c
    return Console(stderr=stderr, width=PIPE_WIDTH)


console = _console()
err_console = _console(stderr=True)


def fail(message: str) -> NoReturn:
    """A user's mistake (bad file, bad config): one clear line, exit status 2, no traceback."""
    err_console.print(f"[bold red]error:[/] {message}")
    raise typer.Exit(2)
