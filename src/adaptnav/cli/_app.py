"""The typer application and what every command module shares: consoles, the failure exit,
filter names and the paper's Table 3."""

from __future__ import annotations

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
console = Console()
err_console = Console(stderr=True)


def fail(message: str) -> NoReturn:
    """A user's mistake (bad file, bad config): one clear line, exit status 2, no traceback."""
    err_console.print(f"[bold red]error:[/] {message}")
    raise typer.Exit(2)
