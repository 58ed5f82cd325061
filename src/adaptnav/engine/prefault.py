"""Fresh memory faulted in by a helper thread, ahead of the thread that will write it.

The smoother's node store takes about 100 MB per hour of 100-Hz IMU (docs/smoothing.md,
'Memory'), allocated before each IMU chunk and written node by node by the forward pass. The
first write to each page of it is a page fault in which the kernel finds and zeroes a page:
work of the forward pass's thread, on the smoothed run's critical path, while the machine's
other cores wait for the backward pass. :func:`start` hands that work to a helper thread:
``madvise(MADV_POPULATE_WRITE)`` (Linux 5.14 and later) faults the pages in for writing as a
write would, without changing what they hold, so it may run while the forward pass writes the
same arrays. It changes no value anywhere; where it is not available (another system, an
older kernel) nothing is done and the pages are faulted in by their first write, as before.
Measured: docs/smoothing.md, 'Speed'.
"""

from __future__ import annotations

import ctypes
import functools
import mmap
import sys
import threading
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

MADV_POPULATE_WRITE = 23
"""``madvise`` advice (Linux ≥ 5.14): populate the page tables writable, as writes would."""
MIN_BYTES = 1 << 22
"""Less memory than this is not worth a thread."""
PIECE_BYTES = 1 << 23
"""Bytes faulted in per call, between which the helper checks whether it was stopped."""


@functools.cache
def _madvise() -> Callable[[int, int, int], int] | None:
    """libc's ``madvise``, or None where there is none to call (not Linux)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        fn = ctypes.CDLL(None, use_errno=True).madvise
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    fn.restype = ctypes.c_int
    return fn


def _ranges(arrays: Sequence[NDArray[np.generic]]) -> list[tuple[int, int]]:
    """The whole pages (start address, length) inside each array's buffer."""
    page = mmap.PAGESIZE
    out = []
    for a in arrays:
        lo = -(-a.ctypes.data // page) * page
        hi = (a.ctypes.data + a.nbytes) // page * page
        if hi > lo:
            out.append((lo, hi - lo))
    return out


class Prefault:
    """A helper thread faulting in the pages of some arrays, piece by piece, until it is done,
    finds the call unsupported, or is stopped (:meth:`stop`). It holds the arrays, so they
    outlive its work; its owner drops it when done with it."""

    def __init__(self, arrays: Sequence[NDArray[np.generic]], madvise: Callable[..., int]):
        self._arrays = list(arrays)
        self._madvise = madvise
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="adaptnav-prefault", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        for start, length in _ranges(self._arrays):
            for at in range(start, start + length, PIECE_BYTES):
                if self._stop.is_set():
                    return
                n = min(PIECE_BYTES, start + length - at)
                if self._madvise(at, n, MADV_POPULATE_WRITE) != 0:
                    return  # EINVAL before Linux 5.14, ENOMEM: the writes fault them in

    def wait(self) -> None:
        """Wait until every page is faulted in (or the call turned out unsupported)."""
        self._thread.join()

    def stop(self) -> None:
        """Stop after the piece under way (pages not yet faulted in stay as they are) and wait
        for the thread."""
        self._stop.set()
        self._thread.join()


def start(arrays: Sequence[NDArray[np.generic]]) -> Prefault | None:
    """A :class:`Prefault` over ``arrays`` (C-contiguous), or None when they are too small to
    be worth it (:data:`MIN_BYTES`) or the system has no ``madvise``."""
    madvise = _madvise()
    if madvise is None or sum(a.nbytes for a in arrays) < MIN_BYTES:
        return None
    return Prefault(arrays, madvise)
