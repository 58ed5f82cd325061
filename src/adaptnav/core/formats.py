"""The versioned JSON documents adaptnav writes (a run's ``summary.json``, a comparison's
``comparison.json``, a faulted mission's ``faults.json``): each names its format and carries
an integer version, raised when a change would make an older reader misread the document.
A reader takes its own version and older ones, and refuses a newer one by name rather than
reading fields whose meaning it does not know (docs/robustness.md, 'Run folders')."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

SIMULATION_FILE = "simulation.json"
"""A simulated mission's true errors, written beside its ``mission.toml`` by the simulator
(adaptnav.sim.scenarios) and read by the run's digest (adaptnav.api.runner) and the scoring
(adaptnav.analysis.calibration, adaptnav.viz.report)."""


def format_problem(doc: Mapping[str, Any], name: str, newest: int) -> str | None:
    """What is wrong with ``doc``'s ``format`` / ``version`` for a reader of format ``name``
    that knows versions up to ``newest``, or None. A document without a version is taken as
    version 1 (the first documents had none)."""
    if doc.get("format") != name:
        return f"format {doc.get('format')!r} is not {name!r}"
    version = doc.get("version", 1)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        return f"version {version!r} is not a format version (a whole number from 1)"
    if version > newest:
        return (
            f"{name} version {version} was written by a newer adaptnav; this one reads "
            f"versions up to {newest}: upgrade adaptnav to read it"
        )
    return None


def read_json_object(path: Path, error: Callable[[str], Exception]) -> dict[str, Any]:
    """The JSON object in the file at ``path``; ``error(message)`` raised, the message naming
    the file, when it cannot be read as JSON or holds something else than an object."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{path}: not readable JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise error(f"{path}: not a JSON object")
    return doc
