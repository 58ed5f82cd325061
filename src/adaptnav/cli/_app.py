"""The typer application and what every command module shares: consoles, the failure exit,
filter names and the paper's Table 3."""

from __future__ import annotations

from typing import NoReturn

import typer
from rich.console import Console

FILTER_CHOICES = ("meskf", "maeskf", "vb")
FILTER_LABELS = {"meskf": "MESKF", "maeskf": "MAESKF", "vb": "VB-MAESKF"}

PAPER_TABLE3 = {
    "paper-1": {"vb": (46.0, 0.20), "maeskf": (80.0, 0.35), "meskf": (184.0, 0.80)},
    "paper-2": {"vb": (62.0, 0.65), "maeskf": (89.0, 0.91), "meskf": (102.0, 1.06)},
}
"""The paper's Table 3: RMSE (m) and relative RMSE (%) per trajectory and filter."""

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
