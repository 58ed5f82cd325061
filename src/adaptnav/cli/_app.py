"""The typer application and what every command module shares: consoles, the failure exit,
the output folder, the stages a long command shows on stderr (``--quiet``), filter names and
the paper's Table 3."""

from __future__ import annotations

import gc
import os
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import Annotated, Any, NoReturn

import typer
import typer.core
from rich.console import Console
from rich.markup import escape
from rich.progress import Progress, SpinnerColumn, TaskID, TextColumn, TimeElapsedColumn

from adaptnav.analysis.compare import FILTER_LABELS as FILTER_LABELS  # single sources, re-exported
from adaptnav.analysis.compare import PAPER_TABLE3 as PAPER_TABLE3

FILTER_CHOICES = ("meskf", "maeskf", "vb", "robust", "oracle")
"""Filters ``adaptnav run`` runs (the engine's kinds; the floor is not a filter)."""

app = typer.Typer(
    help="adaptnav: asynchronous multirate multi-sensor inertial navigation.",
    no_args_is_help=True,
    add_completion=False,
)


def _hide_flag_types() -> None:
    """Typer 0.29's rich help shows a type beside every option, flags too (``--force <bool>``,
    ``--help <bool>``), though a flag takes no value (its plain help shows none). Flags get an
    empty type column here; every other option stays as typer shows it. A typer without
    ``display_type_rich`` is left alone."""
    display = getattr(typer.core.TyperOption, "display_type_rich", None)
    if display is None:
        return

    def display_type_rich(self: typer.core.TyperOption, ctx: Any) -> str | None:
        if self.is_flag:
            return None
        shown: str | None = display(self, ctx)
        return shown

    typer.core.TyperOption.display_type_rich = display_type_rich  # type: ignore[method-assign]


_hide_flag_types()

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


def warn(message: str) -> None:
    """A warning about the result (the run went on): one line on stderr, printed as is."""
    err_console.print(f"[bold yellow]warning:[/] {escape(one_line(message))}", soft_wrap=True)


def warn_sensors(meta: dict[str, Any], label: str = "") -> None:
    """The run's sensors at odds with the rest (``meta.warnings``, api/diagnosis.py), one
    :func:`warn` each; ``label`` (e.g. the filter) before each."""
    for w in meta.get("warnings", []):
        warn(f"{label}{w['message']}")


def warn_compared(results: Mapping[str, Any]) -> None:
    """:func:`warn_sensors` of each run of a comparison (filter name → its Result), labelled
    with the filter."""
    for name, result in results.items():
        warn_sensors(result.meta, f"{name}: ")


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


def freeze_heap() -> None:
    """Move every object alive now out of the garbage collector's sight (``gc.freeze``).

    The long commands call it once their modules are imported and again once their runs are
    in memory: the modules' functions, classes and constants (some 200 000 objects for numpy,
    pandas, scipy, numba, matplotlib) and the runs' tables live until the command ends, yet each
    full collection, and the interpreter's collections at exit, traverse them all. Frozen,
    they are skipped: about 1 s less of ``adaptnav demo`` (docs/performance.md). They are
    still freed by reference counting; only a reference cycle among them waits for the exit.
    """
    gc.freeze()


Quiet = Annotated[
    bool,
    typer.Option(
        "--quiet", "-q", help="no progress on stderr: only errors and the command's result"
    ),
]
"""The ``--quiet`` option of every command that shows its stages (:class:`Stages`)."""

COMPILING = "compiling the kernels first, about 1-2 min on a first run"
"""What a stage that first calls the compiled kernels says while their cache is cold."""


class Stages:
    """The stages of a long command on stderr, each named and timed; nothing with ``quiet``.

    ``with Stages(quiet) as st: st.begin("aligning"); ...; st.begin("running MESKF"); ...``:
    a stage lasts until the next begins or the block ends. On a terminal a live line shows the
    stage and its time so far, and each finished stage stays as one line with its time.
    Elsewhere (a CI log, a pipe) each stage is one plain line as it begins, stamped with the
    time since the command began, and the last line gives the total: no animation.
    ``begin(..., compiles=True)`` marks the stages that call the compiled kernels: the first
    of them says so while the kernels' cache is cold (a first run compiles them)."""

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self.console = err_console
        self._live = not quiet and self.console.is_terminal
        self._progress: Progress | None = None
        self._task: TaskID | None = None
        self._name = ""
        self._started = self._stage_started = time.perf_counter()
        self._compile_note: bool | None = None  # None: not yet asked

    def __enter__(self) -> Stages:
        if self._live:
            self._progress = Progress(
                SpinnerColumn(),
                TextColumn("{task.description}"),
                TimeElapsedColumn(),
                console=self.console,
                transient=True,
            )
            self._progress.start()
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self._end()
        if self._progress is not None:
            self._progress.stop()
        if kind is not None or self.quiet:
            return
        if self._live:
            self.console.print(f"[dim]done in {time.perf_counter() - self._started:.1f} s[/]")
        else:
            self._line("done")

    def begin(self, name: str, compiles: bool = False) -> None:
        """End the running stage and begin ``name`` (``compiles``: it may be the first to call
        the compiled kernels)."""
        self._end()
        if compiles and self._compile_note is None and not self.quiet:
            from adaptnav.engine.batch import kernels_cached

            self._compile_note = kernels_cached() is False
            if self._compile_note:
                name = f"{name}; {COMPILING}"
        self._name, self._stage_started = name, time.perf_counter()
        if self._progress is not None:
            self._task = self._progress.add_task(name, total=None)
        elif not self.quiet:
            self._line(name)

    def compiling_step(self, name: str) -> None:
        """:meth:`begin` for a library's progress callback whose steps call the kernels
        (:func:`adaptnav.analysis.compare.compare`'s ``progress``)."""
        self.begin(name, compiles=True)

    def _end(self) -> None:
        if self._progress is None or self._task is None:
            return
        seconds = time.perf_counter() - self._stage_started
        self._progress.remove_task(self._task)
        self._task = None
        self.console.print(f"[green]✓[/] {escape(self._name)} [dim]{seconds:.1f} s[/]")

    def _line(self, text: str) -> None:
        stamp = time.perf_counter() - self._started
        self.console.print(
            f"[{stamp:6.1f} s] {text}", markup=False, highlight=False, soft_wrap=True
        )


def run_progress(stages: Stages, kind: str) -> Callable[[str], None]:
    """``adaptnav.api.run``'s ``progress`` as stages: the alignment, the ``kind`` filter, its
    RTS backward pass (:data:`adaptnav.engine.batch.Phase`)."""
    label = FILTER_LABELS.get(kind, kind)
    names = {
        "aligning": "aligning over the static window",
        "filtering": f"running {label}",
        "smoothing": f"RTS smoothing {label}",
    }
    return lambda phase: stages.begin(names.get(phase, phase), compiles=phase != "smoothing")
