"""The sweep's on-disk cache: simulated missions, their alignments and finished runs (issue 5).

Cache layout (``cache`` folder)::

    missions/<preset>-s<seed>/            the simulated mission (adaptnav.sim.scenarios.simulate)
    missions/<preset>-s<seed>.alignment.npz   its static alignment (x0, P0, t0), computed once,
                                          and the package version that simulated and aligned it
    runs/<key>.json                       one finished run: spec, version, metrics

A mission is simulated once per (preset, seed[, disturbances]) and its alignment
(:func:`adaptnav.api.initial_state`) computed once and shared by every filter and parameter
on it, as the paper's comparison does. ``key`` is a SHA-256 of the spec and the package
version (:meth:`adaptnav.experiments.spec.RunSpec.key`); a finished run is never rerun, so an
interrupted sweep resumes. A mission and its alignment are the version's too: one left by
another version (or before the alignment recorded it) is simulated and aligned again, since
the simulator and the alignment change between versions and the runs filed under this
version's keys must not start from another's. Files and folders are written atomically: to
a temporary sibling ``.<name>.tmp-<random>``, unique across the processes and machines of a
cluster sharing the cache, then ``os.replace``; a failed write removes its temporary, only a
killed worker leaves one behind (hidden, never read; safe to delete when no sweep runs;
docs/scale-out.md). The cache does not notice code changes within one package version: use a
fresh cache folder after changing the code.
"""

from __future__ import annotations

import json
import math
import os
import secrets
import shutil
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
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
    "run_record",
    "store_record",
]

Alignment = tuple[np.ndarray, np.ndarray, float]
"""A mission's static alignment: initial state x0, covariance P0 and time t0."""


def _tmp_path(path: Path) -> Path:
    """A temporary sibling of ``path`` no other writer uses: 64 random bits, since process ids
    repeat across the machines of a cluster."""
    return path.with_name(f".{path.name}.tmp-{secrets.token_hex(8)}")


@contextmanager
def _atomic(path: Path) -> Iterator[Path]:
    """A temporary file to write; renamed to ``path`` when the block ends, removed if it
    fails."""
    tmp = _tmp_path(path)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)  # gone after a successful rename


def mission_dir(cache: Path, name: str) -> Path:
    """The folder of the simulated mission ``name`` (``<preset>-s<seed>[-d<tag>]``)."""
    return cache / "missions" / name


def _alignment_path(cache: Path, name: str) -> Path:
    return cache / "missions" / f"{name}.alignment.npz"


def _run_path(cache: Path, key: str) -> Path:
    return cache / "runs" / f"{key}.json"


def _aligned_by(cache: Path, name: str) -> str | None:
    """The package version that wrote mission ``name``'s alignment; None when there is none,
    it is unreadable, or it predates the record."""
    try:
        with np.load(_alignment_path(cache, name)) as z:
            return str(z["version"]) if "version" in z.files else None
    except (OSError, ValueError):
        return None


def mission_ready(cache: Path, name: str) -> bool:
    """Whether mission ``name`` and its alignment are both in the cache, of this version."""
    return (mission_dir(cache, name) / "mission.toml").is_file() and _aligned_by(
        cache, name
    ) == __version__


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
    with _atomic(_run_path(cache, record["key"])) as tmp:
        tmp.write_text(json.dumps(record, indent=1, sort_keys=True), encoding="utf-8")


def prepare_mission(cache: Path, spec: RunSpec) -> Path:
    """Simulate ``spec``'s mission into the cache (unless there) and compute its static
    alignment once (unless there); returns the mission folder. Both are written atomically."""
    from adaptnav import api
    from adaptnav.mission import load_mission

    name = spec.mission_name
    folder = mission_dir(cache, name)
    folder.parent.mkdir(parents=True, exist_ok=True)
    align_path = _alignment_path(cache, name)
    if _aligned_by(cache, name) != __version__:
        # Another version's (or an interrupted preparation's): its mission cannot be told
        # from this version's, so both are made again.
        align_path.unlink(missing_ok=True)
        shutil.rmtree(folder, ignore_errors=True)
    if not (folder / "mission.toml").is_file():
        shutil.rmtree(folder, ignore_errors=True)
        _simulate_into(folder, spec)
    if not align_path.is_file():
        x0, P0, t0, _ = api.initial_state(load_mission(folder))
        with _atomic(align_path) as tmp, tmp.open("wb") as fh:
            np.savez(fh, x0=x0, P0=P0, t0=np.array(t0), version=np.array(__version__))
    return folder


def _simulate_into(folder: Path, spec: RunSpec) -> None:
    """Simulate ``spec``'s mission into a temporary sibling and rename it to ``folder``; if
    another worker got there first, its mission (the same, seeded) is kept."""
    from adaptnav.sim.scenarios import simulate

    tmp = _tmp_path(folder)
    try:
        simulate(spec.preset, spec.seed, tmp, spec.disturbances)
        os.replace(tmp, folder)
    except OSError:
        if not (folder / "mission.toml").is_file():
            raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def load_prepared(cache: Path, name: str) -> tuple[Mission, Alignment]:
    """Mission ``name`` and its alignment, as :func:`prepare_mission` left them."""
    from adaptnav.mission import load_mission

    mission = load_mission(mission_dir(cache, name))
    with np.load(_alignment_path(cache, name)) as z:
        initial = (np.array(z["x0"]), np.array(z["P0"]), float(z["t0"]))
    return mission, initial
