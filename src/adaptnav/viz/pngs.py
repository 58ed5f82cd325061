"""A comparison's PNGs drawn and written in a child process while the caller goes on.

matplotlib lays out and rasterises in Python, under the GIL: the seven figures of ``adaptnav
demo`` cost 3-5 s of one core, about a fifth of the command. :class:`PngJob` forks a child, which
inherits the comparison (nothing is pickled or copied until written to), draws
:func:`adaptnav.viz.plots.comparison_figures` and writes each as ``figures/<stem>.png``
(:func:`adaptnav.analysis.compare.write_png`) while the parent builds the interactive figures
and writes the run folders on the other core; the parent never imports matplotlib. Where
``fork`` is not available (Windows) the figures are drawn in the caller when waited for. The
pixels are those :meth:`Comparison.save` writes from the figures themselves
(docs/performance.md, 'Where `make demo` spends its time').
"""

from __future__ import annotations

import multiprocessing
import traceback
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

from adaptnav.analysis.compare import FIGURES_DIR, write_png

if TYPE_CHECKING:
    from adaptnav.analysis.compare import Comparison

__all__ = ["PngJob", "write_pngs"]


def write_pngs(cmp: Comparison, fig_dir: Path) -> list[str]:
    """Draw every figure of ``cmp`` and write it as ``fig_dir/<stem>.png``; their stems."""
    from adaptnav.viz import plots  # matplotlib: imported where the figures are drawn

    stems = []
    for stem, fig in plots.comparison_figures(cmp).items():
        write_png(fig, fig_dir / f"{stem}.png")
        stems.append(stem)
    return stems


def _child(cmp: Comparison, fig_dir: Path, send: Connection) -> None:
    """The child's work: the stems, or the traceback of what failed, sent to the parent."""
    try:
        send.send(("done", write_pngs(cmp, fig_dir)))
    except Exception:  # the parent raises it with this traceback
        send.send(("failed", traceback.format_exc()))
    finally:
        send.close()


class PngJob:
    """``with PngJob(cmp, out) as pngs: ...; stems = pngs.wait()``: the PNGs of ``cmp`` written
    into ``out/figures/`` by a forked child from the ``with`` on (module docstring).

    ``wait`` (:class:`adaptnav.analysis.compare.PendingFigures`, for ``Comparison.save``)
    returns their stems once all are written and raises RuntimeError with the child's
    traceback if drawing failed. Leaving the block unwaited (an error in the caller) stops the
    child, so nothing writes into a folder its caller removes."""

    def __init__(self, cmp: Comparison, out: Path) -> None:
        self._cmp = cmp
        self._dir = Path(out) / FIGURES_DIR
        self._process: BaseProcess | None = None
        self._receive: Connection | None = None

    def __enter__(self) -> PngJob:
        self._dir.mkdir(parents=True, exist_ok=True)
        if "fork" in multiprocessing.get_all_start_methods():
            context = multiprocessing.get_context("fork")
            self._receive, send = context.Pipe(duplex=False)
            self._process = context.Process(
                target=_child, args=(self._cmp, self._dir, send), name="adaptnav-pngs"
            )
            self._process.start()
            send.close()  # the child's end: the parent sees EOF if the child dies
        return self

    def wait(self) -> list[str]:
        """The stems of the PNGs written, once all are (drawn here without ``fork``)."""
        if self._process is None or self._receive is None:
            return write_pngs(self._cmp, self._dir)
        try:
            status, payload = self._receive.recv()
        except EOFError:
            self._process.join()
            code = self._process.exitcode
            message = f"drawing the figures: its process died (exit code {code})"
            raise RuntimeError(message) from None
        self._process.join()
        if status != "done":
            raise RuntimeError(f"drawing the figures failed in its process:\n{payload}")
        return list(payload)

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._process is not None:
            if self._process.is_alive():
                self._process.terminate()
            self._process.join()
            self._process.close()
        if self._receive is not None:
            self._receive.close()
