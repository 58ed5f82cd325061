"""viz.pngs.PngJob: a child that fails or dies surfaces in the parent as a RuntimeError (never a
hang, never a silent folder without its figures)."""

from __future__ import annotations

import multiprocessing
import os
from pathlib import Path
from typing import Any

import pytest

from adaptnav.viz import pngs

pytestmark = pytest.mark.skipif(
    "fork" not in multiprocessing.get_all_start_methods(), reason="PngJob forks its children"
)


def _raises(*_args: Any) -> tuple[list[str], list[str]]:
    raise ValueError("no such axis: 'sd_depth'")


def _dies(*_args: Any) -> tuple[list[str], list[str]]:
    os._exit(3)


def _writes(_cmp: Any, fig_dir: Path, part: pngs.Part = bool) -> tuple[list[str], list[str]]:
    stems = ["trajectory", "noise_dvl"]
    done = [s for s in stems if part(s)]
    for s in done:
        (fig_dir / f"{s}.png").write_bytes(b"png")
    return stems, done


def test_a_failing_child_raises_with_its_traceback(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(pngs, "write_pngs", _raises)  # the forked children inherit it
    with pngs.PngJob(None, tmp_path) as job, pytest.raises(RuntimeError) as err:  # type: ignore[arg-type]
        job.wait()
    assert "failed in its process" in str(err.value)
    assert "ValueError: no such axis: 'sd_depth'" in str(err.value)


def test_a_child_that_dies_raises_with_its_exit_code(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(pngs, "write_pngs", _dies)
    with pngs.PngJob(None, tmp_path) as job, pytest.raises(RuntimeError, match="exit code 3"):  # type: ignore[arg-type]
        job.wait()


def test_the_children_split_the_figures_and_report_them_in_drawing_order(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(pngs, "write_pngs", _writes)
    with pngs.PngJob(None, tmp_path) as job:  # type: ignore[arg-type]
        stems = job.wait()
    assert stems == ["trajectory", "noise_dvl"]
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == [
        "noise_dvl.png",
        "trajectory.png",
    ]
