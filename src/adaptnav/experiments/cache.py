"""The sweep's on-disk cache: simulated missions, their alignments and finished runs (issue 5).

Cache layout (``cache`` folder)::

    missions/<preset>-s<seed>/            the simulated mission (adaptnav.sim.scenarios.simulate)
    missions/<preset>-s<seed>.alignment.npz   its static alignment (x0, P0, t0), computed once
    runs/<key>.json                       one finished run: spec, version, metrics

A mission is simulated once per (preset, seed[, disturbances]) and its alignment
(:func:`adaptnav.api.initial_state`) computed once and shared by every filter and parameter
on it, as the paper's comparison does. ``key`` is a SHA-256 of the spec and the package
version (:meth:`adaptnav.experiments.spec.RunSpec.key`); a finished run is never rerun, so an
interrupted sweep resumes. Files are written atomically (temporary file ``.<name>.tmp-<pid>``
+ ``os.replace``); temporaries of killed processes are removed by :func:`remove_stale_tmp`.
The cache does not notice code changes within one package version: use a fresh cache folder
after changing the code.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptnav import __version__
from adaptnav.experiments.spec import RunSpec

if TYPE_CHECKING:
    from adaptnav.mission import Mission

__all__ = [
    "Alignment",
    "cached_record",
    "load_prepared",
    "mission_dir",
    "mission_ready",
    "prepare_mission",
    "remove_stale_tmp",
    "run_record",
    "store_record",
]

Alignment = tuple[np.ndarray, np.ndarray, float]
"""A mission's static alignment: initial state x0, covariance P0 and time t0."""


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def mission_dir(cache: Path, name: str) -> Path:
    """The folder of the simulated mission ``name`` (``<preset>-s<seed>[-d<tag>]``)."""
    return cache / "missions" / name


def _alignment_path(cache: Path, name: str) -> Path:
    return cache / "missions" / f"{name}.alignment.npz"


def _run_path(cache: Path, key: str) -> Path:
    return cache / "runs" / f"{key}.json"


def mission_ready(cache: Path, name: str) -> bool:
    """Whether mission ``name`` and its alignment are both in the cache."""
    return (mission_dir(cache, name) / "mission.toml").is_file() and _alignment_path(
        cache, name
    ).is_file()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


def remove_stale_tmp(root: Path) -> None:
    """Remove temporary files and folders (``.<name>.tmp-<pid>``) left by killed processes."""
    for folder in (root / "missions", root / "runs"):
        for p in folder.glob(".*.tmp-*"):
            pid = p.name.rpartition(".tmp-")[2]
            if pid.isdigit() and not _pid_alive(int(pid)):
                if p.is_dir():
                    shutil.rmtree(p, ignore_errors=True)
                else:
                    p.unlink(missing_ok=True)


def cached_record(cache: Path, key: str) -> dict[str, Any] | None:
    """The finished run ``key`` (:func:`run_record`), or None if it is not cached or its
    file is unreadable."""
    try:
        record = json.loads(_run_path(cache, key).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and isinstance(record.get("metrics"), dict) else None


def run_record(spec: RunSpec, metrics: Mapping[str, float]) -> dict[str, Any]:
    """What the cache keeps of a finished run: key, package version, spec, metrics (NaN and
    infinities as None) and the time it finished."""
    return {
        "key": spec.key(),
        "version": __version__,
        "spec": spec.as_dict(),
        "metrics": {k: (v if math.isfinite(v) else None) for k, v in metrics.items()},
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def store_record(cache: Path, record: Mapping[str, Any]) -> None:
    """Write ``record`` (:func:`run_record`) atomically to ``runs/<key>.json``."""
    _write_atomic(_run_path(cache, record["key"]), json.dumps(record, indent=1, sort_keys=True))


def prepare_mission(cache: Path, spec: RunSpec) -> Path:
    """Simulate ``spec``'s mission into the cache (unless there) and compute its static
    alignment once (unless there); returns the mission folder. Both are written atomically."""
    from adaptnav import api
    from adaptnav.mission import load_mission
    from adaptnav.sim.scenarios import simulate

    name = spec.mission_name
    folder = mission_dir(cache, name)
    folder.parent.mkdir(parents=True, exist_ok=True)
    if not (folder / "mission.toml").is_file():
        shutil.rmtree(folder, ignore_errors=True)
        tmp = folder.with_name(f".{name}.tmp-{os.getpid()}")
        shutil.rmtree(tmp, ignore_errors=True)
        simulate(spec.preset, spec.seed, tmp, spec.disturbances)
        try:
            os.replace(tmp, folder)
        except OSError:
            if not (folder / "mission.toml").is_file():
                raise
            shutil.rmtree(tmp, ignore_errors=True)
    align_path = _alignment_path(cache, name)
    if not align_path.is_file():
        x0, P0, t0, _ = api.initial_state(load_mission(folder))
        tmp_align = align_path.with_name(f".{align_path.name}.tmp-{os.getpid()}")
        with tmp_align.open("wb") as fh:
            np.savez(fh, x0=x0, P0=P0, t0=np.array(t0))
        os.replace(tmp_align, align_path)
    return folder


def load_prepared(cache: Path, name: str) -> tuple[Mission, Alignment]:
    """Mission ``name`` and its alignment, as :func:`prepare_mission` left them."""
    from adaptnav.mission import load_mission

    mission = load_mission(mission_dir(cache, name))
    with np.load(_alignment_path(cache, name)) as z:
        initial = (np.array(z["x0"]), np.array(z["P0"]), float(z["t0"]))
    return mission, initial
