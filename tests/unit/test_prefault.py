"""engine.prefault: a helper thread faults in fresh memory and changes no value."""

from __future__ import annotations

import mmap
import threading

import numpy as np
import pytest

from adaptnav.engine import prefault

needs_madvise = pytest.mark.skipif(prefault._madvise() is None, reason="no libc madvise (Linux)")


def _resident_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * mmap.PAGESIZE


def test_small_arrays_get_no_thread() -> None:
    assert prefault.start([np.zeros(1000)]) is None
    assert prefault.start([]) is None


@needs_madvise
def test_the_pages_are_faulted_in_without_a_write() -> None:
    """64 MiB of np.zeros are not resident until written (the kernel maps them lazily); the
    helper makes them resident with no write of ours, and they still hold zeros."""
    a = np.zeros(8 << 20)  # 64 MiB
    before = _resident_bytes()
    helper = prefault.start([a])
    assert helper is not None
    helper.wait()
    assert _resident_bytes() - before > 0.9 * a.nbytes
    assert not a.any()


@needs_madvise
def test_writes_made_meanwhile_are_kept() -> None:
    """The forward pass writes the store while the helper runs: every value written before,
    during and after the helper's work is there at the end."""
    a = np.zeros((1 << 20, 16))  # 128 MiB, a row a node
    rows = np.arange(a.shape[0])
    a[:100] = 7.0  # before
    helper = prefault.start([a])
    assert helper is not None
    writer = threading.Thread(target=lambda: a.__setitem__(slice(None), rows[:, None] + 0.5))
    writer.start()
    writer.join()
    helper.wait()
    np.testing.assert_array_equal(a[:, 3], rows + 0.5)
    a[-1] = -1.0  # after
    assert a[-1, 0] == -1.0 and a[0, 0] == 0.5


@needs_madvise
def test_stop_returns_early_and_keeps_the_values() -> None:
    a = np.zeros(32 << 20)  # 256 MiB
    a[::4096] = 1.0
    helper = prefault.start([a])
    assert helper is not None
    helper.stop()  # at most the piece under way
    assert a[::4096].all() and a.sum() == a[::4096].size
