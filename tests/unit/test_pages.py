"""Helpers of the generated results pages: Markdown tables and the revision stamp."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from adaptnav.viz.pages import git_revision, markdown_table


def test_markdown_table() -> None:
    assert markdown_table(["a", "b"], [["1", "2"], ["3", "4"]]) == (
        "| a | b |\n|---|---|\n| 1 | 2 |\n| 3 | 4 |"
    )


def test_git_revision_marks_uncommitted_changes(tmp_path: Path) -> None:
    assert git_revision(tmp_path) == "unknown"  # not a checkout
    if shutil.which("git") is None:
        pytest.skip("git not installed")

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=tmp_path,
            check=True, capture_output=True, text=True,
        ).stdout.strip()  # fmt: skip

    git("init", "-q")
    (tmp_path / "f.txt").write_text("one\n")
    git("add", "f.txt")
    git("commit", "-q", "-m", "one")
    head = git("rev-parse", "--short", "HEAD")
    assert git_revision(tmp_path) == head
    (tmp_path / "new.txt").write_text("untracked files do not count\n")
    assert git_revision(tmp_path) == head
    (tmp_path / "f.txt").write_text("two\n")
    assert git_revision(tmp_path) == f"{head} with uncommitted changes"
