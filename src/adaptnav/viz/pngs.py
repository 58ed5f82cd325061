"""A comparison's PNGs drawn and written in child processes while the caller goes on.

matplotlib lays out and rasterises in Python, under the GIL: the seven figures of ``adaptnav
demo`` cost 4-5 s of one core, about a quarter of the command. :class:`PngJob` forks two
children, which inherit the comparison (nothing is pickled, nothing copied until written to):
one draws the noise figures (their log axes' labels need matplotlib's mathtext parser, which
takes about 0.4 s to set up, once per process), the other the rest; each writes its figures as
``figures/<stem>.png`` (:func:`adaptnav.analysis.compare.write_png`) while the parent builds the
interactive figures and writes the run folders. The parent imports matplotlib only to hand it
down (:func:`import_in_background`, while it waits for something else). Where
``fork`` is not available (Windows) the figures are drawn in the caller when waited for. The
pixels are those :meth:`Comparison.save` writes from the figures themselves
(docs/performance.md, 'Where `make demo` spends its time').
"""

from __future__ import annotations

import importlib
import multiprocessing
import threading
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

from adaptnav.analysis.compare import FIGURES_DIR, write_png

if TYPE_CHECKING:
    from adaptnav.analysis.compare import Comparison

__all__ = ["PARTS", "PngJob", "import_in_background", "write_pngs"]

Part = Callable[[str], bool]


def _log_axes(stem: str) -> bool:
    return stem.startswith("noise_")


def _linear_axes(stem: str) -> bool:
    return not _log_axes(stem)


PARTS: tuple[Part, ...] = (_log_axes, _linear_axes)
"""Which figures each child draws, by file stem: the noise figures, and the others."""


def import_in_background() -> threading.Thread:
    """Import matplotlib and the figures' module in a thread, started now (e.g. while the filters'
    compiled loops run without the GIL), so that the children forked by :class:`PngJob`
    inherit them instead of each paying the import (about 0.4 s); join it before the fork."""
    thread = threading.Thread(
        target=importlib.import_module, args=("adaptnav.viz.plots",), name="import-plots"
    )
    thread.start()
    return thread


def write_pngs(cmp: Comparison, fig_dir: Path, part: Part = bool) -> tuple[list[str], list[str]]:
    """Draw the figures of ``cmp`` whose stem is in ``part`` and write each as
    ``fig_dir/<stem>.png``: every figure's stem in drawing order, and those written."""
    from adaptnav.viz import plots  # matplotlib: imported where the figures are drawn

    makers = plots.figure_makers(cmp)
    written = [stem for stem in makers if part(stem)]
    for stem in written:
        write_png(makers[stem](), fig_dir / f"{stem}.png")
    return list(makers), written


def _child(cmp: Comparison, fig_dir: Path, part: Part, send: Connection) -> None:
    """A child's work: what it wrote, or the traceback of what failed, sent to the parent."""
    try:
        send.send(("done", write_pngs(cmp, fig_dir, part)))
    except Exception:  # the parent raises it with this traceback
        send.send(("failed", traceback.format_exc()))
    finally:
        send.close()


class PngJob:
    """``with PngJob(cmp, out) as pngs: ...; stems = pngs.wait()``: the PNGs of ``cmp`` written
    into ``out/figures/`` by forked children from the ``with`` on (module docstring).

    ``wait`` (:class:`adaptnav.analysis.compare.PendingFigures`, for ``Comparison.save``)
    returns their stems once all are written and raises RuntimeError with a child's
    traceback if drawing failed. Leaving the block unwaited (an error in the caller) stops the
    children, so nothing writes into a folder its caller removes."""

    def __init__(self, cmp: Comparison, out: Path) -> None:
        self._cmp = cmp
        self._dir = Path(out) / FIGURES_DIR
        self._children: list[tuple[BaseProcess, Connection]] = []

    def __enter__(self) -> PngJob:
        self._dir.mkdir(parents=True, exist_ok=True)
        if "fork" not in multiprocessing.get_all_start_methods():
            return self
        context = multiprocessing.get_context("fork")
        for part in PARTS:
            receive, send = context.Pipe(duplex=False)
            child = context.Process(target=_child, args=(self._cmp, self._dir, part, send))
            child.start()
            send.close()  # the child's end: the parent sees EOF if the child dies
            self._children.append((child, receive))
        return self

    def wait(self) -> list[str]:
        """The stems of the PNGs written, once all are (drawn here without ``fork``)."""
        if not self._children:
            return write_pngs(self._cmp, self._dir)[1]
        stems: list[str] = []
        written: set[str] = set()
        for child, receive in self._children:
            try:
                status, payload = receive.recv()
            except EOFError:
                child.join()
                message = f"drawing the figures: a process died (exit code {child.exitcode})"
                raise RuntimeError(message) from None
            child.join()
            if status != "done":
                raise RuntimeError(f"drawing the figures failed in its process:\n{payload}")
            stems, done = payload
            written.update(done)
        return [stem for stem in stems if stem in written]

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        for child, receive in self._children:
            if child.is_alive():
                child.terminate()
            child.join()
            child.close()
            receive.close()
