"""The golden run: a short simulated mission's solution under every filter kind, pinned.

A refactoring that should not change behaviour (issue 13's redesign, a kernel made faster)
is checked against it by tests/integration/test_golden.py to 1e-9. A change that *should* change the
numbers rewrites it on purpose, with the reason in the commit (from the repository root):

    .venv/bin/python tests/helpers/golden.py --write

The mission: the simulator's demo scenario (every disturbance on: DVL outliers and noise
segments, currents, sea state) on a 5-minute track, 60 s alongside for the static alignment,
then 2 minutes straight at 1.5 m/s, a 90° turn and a minute straight; seeded. Stored per
kind, at 1 Hz: the nominal state and P's diagonal; at the end: x and P; per reading: fate
and NIS.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from adaptnav import api
from adaptnav.core.units import DEG
from adaptnav.mission import load_mission, write_mission
from adaptnav.sim import scenarios
from adaptnav.sim import trajectory as tr

SEED = 11
KINDS = ("meskf", "maeskf", "vb", "robust", "oracle")
FILE = Path(__file__).resolve().parents[1] / "data" / "golden.npz"
"""tests/data/golden.npz (this file also runs as a script, so it cannot import :mod:`helpers`)."""
EVERY = 10
"""Solution rows kept (10 Hz output → 1 Hz)."""


def mission(root: Path) -> Path:
    """Write the golden mission to ``root`` (Parquet tables) and return it."""
    base = scenarios.demo()
    spec = replace(
        base.trajectory,
        segments=(
            tr.Static(60.0),
            tr.Straight(120.0, 1.5),
            tr.Turn(90 * DEG, rate=3 * DEG),
            tr.Straight(60.0),
        ),
        max_accel=0.5,
        max_yaw_accel=2 * DEG,
        min_step=1.0,
    )
    sim = scenarios.generate(replace(base, name="golden", trajectory=spec), SEED)
    write_mission(root, sim.config, sim.tables)
    return root


def runs(root: Path) -> dict[str, np.ndarray]:
    """Every kind's pinned arrays, keyed ``<kind>/<name>``."""
    m = load_mission(root)
    start = api.initial_state(m)[:3]
    out: dict[str, np.ndarray] = {}
    for kind in KINDS:
        r = api.run(m, kind, initial=start)  # type: ignore[arg-type]
        sol = r.solution
        out[f"{kind}/solution"] = sol.select_dtypes("number").to_numpy(dtype=float)[::EVERY]
        out[f"{kind}/columns"] = np.array(list(sol.select_dtypes("number").columns))
        ledger = r.ledger.sort_values(["sensor", "row"], kind="stable")
        out[f"{kind}/fates"] = (ledger["sensor"] + ":" + ledger["fate"]).to_numpy(dtype=str)
        out[f"{kind}/statistic"] = ledger["statistic"].to_numpy(dtype=float)
    out["initial/x0"], out["initial/P0"] = start[0], start[1]
    return out


def main(argv: list[str]) -> int:
    if argv != ["--write"]:
        print(__doc__)
        return 2
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        arrays = runs(mission(Path(tmp) / "golden"))
    FILE.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(FILE, **arrays)  # type: ignore[arg-type]
    print(f"wrote {FILE} ({FILE.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
