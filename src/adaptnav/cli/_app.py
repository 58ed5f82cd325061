"""The typer application and what every command module shares: consoles, the failure exit,
the output folder, filter names and the paper's Table 3."""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, NoReturn

import typer
from rich.console import Console
from rich.markup import escape

from adaptnav.analysis.compare import FILTER_LABELS as FILTER_LABELS  # single sources, re-exported
from adaptnav.analysis.compare import PAPER_TABLE3 as PAPER_TABLE3

FILTER_CHOICES = ("meskf", "maeskf", "vb", "robust", "oracle")
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


def one_line(message: str) -> str:
    """A message on one line: ``"mission.toml: \n  a\n  b"`` → ``"mission.toml: a; b"``."""
    parts = [p.strip() for p in message.splitlines() if p.strip()]
    if not parts:
        return ""
    head, rest = parts[0], parts[1:]
    if not rest:
        return head
    return f"{head} {'; '.join(rest)}" if head.endswith(":") else "; ".join(parts)


def fail(message: str) -> NoReturn:
    """A user's mistake (bad file, bad config): one clear line, exit status 2, no traceback.

    The message is printed as is (no rich markup: ``[x]`` in a message stays) and unwrapped."""
    err_console.print(f"[bold red]error:[/] {escape(one_line(message))}", soft_wrap=True)
    raise typer.Exit(2)


Force = Annotated[
    bool,
    typer.Option("--force", help="replace a non-empty --out folder whole (nothing of it is kept)"),
]
"""The ``--force`` option of every command that writes a folder."""

Smooth = Annotated[
    bool,
    typer.Option(
        "--smooth",
        help="RTS-smooth each filter's solution; its forward one is kept beside it "
        "(docs/smoothing.md)",
    ),
]
"""The ``--smooth`` option of the commands that run filters (docs/smoothing.md)."""


@contextmanager
def output(out: Path, force: bool, inputs: Iterable[Path] = ()) -> Iterator[Path]:
    """``with output(out, force) as tmp:``: write the command's folder into ``tmp``; it is
    renamed to ``out`` at the end (:func:`adaptnav.api.outdir.output_folder`). A path that cannot
    be written, or a non-empty ``out`` without ``--force``, fails here before any work."""
    from adaptnav.api.outdir import OutputError, output_folder

    try:
        with output_folder(out, force=force, inputs=inputs) as tmp:
            yield tmp
    except OutputError as exc:
        fail(str(exc))
