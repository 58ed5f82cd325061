"""Cold start on two cores: one compiled kernel compiled in a second process meanwhile.

docs/performance.md, 'Cold start'. Numba compiles under a lock held per process, so threads
do not compile in parallel, but its on-disk cache (``cache=True``) is shared between processes:
a child process that compiles a kernel for the exact argument types this process will call it
with saves it there, and this process, compiling a caller later, loads the kernel from the cache
instead of compiling it (Numba's ``Dispatcher.compile`` looks in the cache first, also for a
callee). The engine (``Navigator._compile_cold`` in :mod:`adaptnav.engine.batch`) has the
measurement epoch compiled aside while it compiles the propagation loop, then waits for the
child and compiles the loop that calls both. It pays when the second core is free; when other
work keeps it busy the two processes share what is left and the start is no faster, or a little
slower (the child's imports; docs/performance.md, 'Cold start').

Everything degrades to the ordinary compile: no child (it could not start), a failed child
(logged), or no usable cache (the child's work is then simply not found) leave this process to
compile the kernel itself when its caller needs it.

Numba's cache writes each function's index and data files whole (a temporary file, then a
rename) but does not lock: two processes that save the *same* function for *different*
argument types at the same moment could leave an index naming the other's data. The two
processes here only share small helpers of compiled/propagation.py, which both compile for the
same types (the same cache entry, whichever write wins).
"""

from __future__ import annotations

import logging
import os
import pickle
import re
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from typing import IO, Any

import numba

log = logging.getLogger("adaptnav.engine")

_CHILD = (
    "import importlib, pickle, sys\n"
    "paths, module, name, sig = pickle.load(sys.stdin.buffer)\n"
    "sys.path[:0] = paths\n"
    "getattr(importlib.import_module(module), name).compile(sig)\n"
)
"""The child's work: compile ``module.name`` for ``sig`` (Numba saves it in its cache)."""
_EXCEPTION = re.compile(r"^[\w.]+(Error|Exception): ")
"""A traceback's line that names the exception (Numba's messages run over many lines)."""


def cores() -> int:
    """The cores this process may run on."""
    affinity = getattr(os, "sched_getaffinity", None)
    return len(affinity(0)) if affinity is not None else os.cpu_count() or 1


def signature(args: Sequence[Any]) -> tuple[Any, ...]:
    """Numba's argument types for a call with ``args`` (what the dispatcher compiles for)."""
    return tuple(numba.typeof(a) for a in args)  # type: ignore[no-untyped-call]


Aside = tuple[subprocess.Popen[bytes], IO[bytes]]
"""A child of :func:`compile_aside` and the file its stderr goes to."""


def compile_here(kernel: Any, args: Sequence[Any]) -> None:
    """Compile the kernel ``kernel`` (a Numba dispatcher) in this process for the types of
    ``args`` (or load it from the cache), without calling it."""
    kernel.compile(signature(args))


def compile_aside(kernel: Any, args: Sequence[Any]) -> Aside | None:
    """Start a child process that compiles the ``cache=True`` kernel ``kernel`` (a Numba
    dispatcher) for the types of ``args`` into Numba's cache; None if it could not start, or
    would not help (one core)."""
    if not sys.executable or cores() < 2:  # an embedded interpreter: no Python to start
        return None
    fn = kernel.py_func
    payload = pickle.dumps((sys.path, fn.__module__, fn.__name__, signature(args)))
    # stderr to a file, not a pipe: a pipe nobody reads until join could stall the child;
    # the file is closed by join
    err = tempfile.TemporaryFile()  # noqa: SIM115
    try:
        child = subprocess.Popen(
            [sys.executable, "-c", _CHILD], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
            stderr=err,
        )  # fmt: skip
        assert child.stdin is not None
        child.stdin.write(payload)
        child.stdin.close()
    except OSError as exc:
        err.close()
        log.info("compiling %s in a second process did not start: %s", fn.__name__, exc)
        return None
    return child, err


def join(aside: Aside | None) -> None:
    """Wait for the child of :func:`compile_aside`; a failure is logged with the last line of
    its stderr (this process then compiles the kernel itself when it needs it)."""
    if aside is None:
        return
    child, err = aside
    with err:
        try:
            code = child.wait()
        except BaseException:  # interrupted: the child's work is no use to anyone now
            child.kill()
            raise
        if code != 0:
            err.seek(0)
            lines = err.read().decode(errors="replace").strip().splitlines() or [""]
            errors = [line for line in lines if _EXCEPTION.match(line)]
            log.warning("compiling in a second process failed (exit %s): %s",
                        child.returncode, (errors or lines)[-1])  # fmt: skip
