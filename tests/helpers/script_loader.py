"""Load a file of ``scripts/`` as a module, for the smoke tests of the results pages."""

from __future__ import annotations

import importlib.util
from types import ModuleType

from helpers import REPO

SCRIPTS = REPO / "scripts"


def load_script(name: str) -> ModuleType:
    """``scripts/<name>.py`` as a module (not run: its ``main`` is for the caller)."""
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
