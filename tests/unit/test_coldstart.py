"""engine.coldstart: a kernel compiled by a second process is found in Numba's cache here."""

from __future__ import annotations

import importlib
import logging
import sys
from pathlib import Path
from types import ModuleType

import pytest

from adaptnav.engine import coldstart

KERNELS = """
from numba import njit


@njit(cache=True)
def plus_one(x):
    return x + 1.0
"""


@pytest.fixture
def kernels(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """A fresh module with a ``cache=True`` kernel, importable here and in the child (its
    folder is on sys.path, which the child is given); its cache is empty (a new source file)."""
    (tmp_path / "cold_kernels.py").write_text(KERNELS)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("cold_kernels", None)
    return importlib.import_module("cold_kernels")


def test_kernel_compiled_aside_is_loaded_from_the_cache(kernels: ModuleType) -> None:
    kernel = kernels.plus_one
    aside = coldstart.compile_aside(kernel, (2.0,))
    assert aside is not None
    coldstart.join(aside)
    coldstart.compile_here(kernel, (2.0,))
    # loaded, not compiled: the child's entry was in the cache
    assert sum(kernel.stats.cache_hits.values()) == 1
    assert sum(kernel.stats.cache_misses.values()) == 0
    assert kernel(2.0) == 3.0


def test_a_failed_child_is_logged_and_the_kernel_compiles_here(
    kernels: ModuleType, caplog: pytest.LogCaptureFixture
) -> None:
    kernel = kernels.plus_one
    with caplog.at_level(logging.WARNING, logger="adaptnav.engine"):
        coldstart.join(coldstart.compile_aside(kernel, ("not a number",)))  # a typing error
    assert "compiling in a second process failed (exit 1)" in caplog.text
    assert "TypingError" in caplog.text or "No implementation" in caplog.text
    assert kernel(2.0) == 3.0  # compiled here, as without the child
    assert sum(kernel.stats.cache_misses.values()) == 1
