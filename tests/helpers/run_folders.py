"""Run folders as a test needs them beside the ones ``results.save`` writes.

``summary.json`` records the SHA-256 of every table the run wrote (``files``), and loading a
run folder refuses a table that differs (adaptnav.api.results.check_files). A test that
changes a table on purpose, to see what is checked after that (a NaN in the solution, a
reference cut short), records the table's new digest with :func:`reseal`; one that stands for
a run folder of an older adaptnav removes the record with :func:`without_digests`.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

SUMMARY = "summary.json"
FILES = "files"
"""summary.json's record of the tables (adaptnav.api.results.FILES_KEY)."""


def reseal(folder: Path, *names: str) -> None:
    """Record in ``folder``'s summary.json the digests of the files ``names`` as they are now."""
    path = folder / SUMMARY
    info = json.loads(path.read_text(encoding="utf-8"))
    for name in names:
        data = (folder / name).read_bytes()
        info[FILES][name] = {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    path.write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")


def without_digests(folder: Path) -> None:
    """Make ``folder``'s summary.json one written before the digests were (no ``files``)."""
    path = folder / SUMMARY
    info = json.loads(path.read_text(encoding="utf-8"))
    info.pop(FILES, None)
    path.write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
