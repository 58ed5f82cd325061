"""Cold-start benchmark: ``.venv/bin/python bench/cold_bench.py`` (part of ``make bench``).

How long a first run waits for its first filter output while Numba compiles the kernels.
The ``demo`` preset (seed 1: 10 min alongside, 5 min under way) is simulated once into a
temporary folder, outside the timing. Then, each in a fresh subprocess whose
``NUMBA_CACHE_DIR`` is a new empty temporary folder, the mission is loaded, aligned over its
static window and run once with the default filter (robust): wall time of the whole
subprocess (interpreter, imports, compilation, run). The same subprocess again, on the now
filled cache, is the warm baseline.

Where Numba keeps its cache: the kernels are ``njit(cache=True)``
(:mod:`adaptnav.compiled.propagation`); Numba looks for a locator in order and the first that
applies wins: ``NUMBA_CACHE_DIR`` when it is set (the user-provided locator), else the
``__pycache__`` folder beside each source file when it is writable (in-tree), else a
user-wide folder. Setting ``NUMBA_CACHE_DIR`` to an empty folder therefore gives a cold
compile without touching the checkout's own cache, which later runs keep using.

Prints one line, ``cold start: X s (first filter output on the demo mission from an empty
Numba cache; warm: Y s; epoch compiled by a second process: yes)`` (``no``: the engine compiled
it itself, engine/coldstart.py). Issue 15 asks for X ≤ 60 s; this only measures it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FIRST_RUN = """
import sys
from adaptnav import api
from adaptnav.mission import load_mission

mission = load_mission(sys.argv[1])
start = api.initial_state(mission)[:3]
result = api.run(mission, "robust", initial=start)
assert len(result.solution) > 0
from adaptnav.compiled.update import epoch
print(sum(epoch.stats.cache_hits.values()))
"""
"""The child's work: load, align, run the first filter (the module docstring); prints how
often the epoch was loaded from the cache (1 on a cold start: compiled by a second process,
engine/coldstart.py; 0 on a warm one, where the engine's loop is loaded whole)."""


def first_output_s(mission: Path, cache: Path) -> tuple[float, bool]:
    """Wall time (s) of a fresh interpreter that loads ``mission``, aligns it and runs the
    default filter once, with Numba's cache in ``cache``; whether it loaded the epoch from the
    cache."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    t0 = time.perf_counter()
    run = subprocess.run(
        [sys.executable, "-c", FIRST_RUN, str(mission)], env=env, check=True,
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    return time.perf_counter() - t0, run.stdout.split()[-1:] == ["1"]


def bench_cold_start(preset: str = "demo", seed: int = 1) -> list[str]:
    """Simulate ``preset`` once, then time the first filter output cold and warm; print and
    return the ``cold start:`` line."""
    from adaptnav.sim.scenarios import simulate

    with tempfile.TemporaryDirectory() as tmp:
        mission = simulate(preset, seed, Path(tmp) / "mission")
        cache = Path(tmp) / "numba-cache"
        cache.mkdir()
        cold, aside = first_output_s(mission, cache)
        warm, _ = first_output_s(mission, cache)
    line = (
        f"cold start: {cold:.1f} s (first filter output on the {preset} mission from an empty "
        f"Numba cache; warm: {warm:.1f} s; epoch compiled by a second process: "
        f"{'yes' if aside else 'no'})"
    )
    print(line, flush=True)
    return [line]


if __name__ == "__main__":
    bench_cold_start()
