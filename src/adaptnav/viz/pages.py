"""Helpers of the generated results pages (``docs/results*.md``, written by ``scripts/``):
Markdown tables and the revision a page was made at."""

from __future__ import annotations

import math
import subprocess
from collections.abc import Sequence
from pathlib import Path


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A GitHub-flavoured Markdown table (cells are written as given)."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def fmt_number(value: object, fmt: str) -> str:
    """``value`` formatted with ``fmt``, or ``-`` if it is not a finite number (a missing or
    failed figure in a generated table)."""
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return "-"
    return "-" if not math.isfinite(x) else format(x, fmt)


def git_revision(root: str | Path) -> str:
    """Short hash of the checkout at ``root``, with " with uncommitted changes" when a tracked
    file differs from it; "unknown" when git is missing or ``root`` is no checkout."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
            timeout=10, check=True,
        ).stdout.strip()  # fmt: skip
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
            capture_output=True, text=True, timeout=10, check=True,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return (head or "unknown") + (" with uncommitted changes" if dirty else "")
