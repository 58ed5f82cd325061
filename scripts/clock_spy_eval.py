"""Every clock offset a load finds, printed in full: the angles' (clocks.clock_offset) and the
GNSS's by its positions (gnss_clock.gnss_offset), on a mission folder's copies with one
table's stamps moved or one setting changed (docs/robustness.md, 'Sensor clocks', 'Three
clock changes merged'). Run it on two versions of the code to compare them digit for digit::

    git archive <commit> src | tar -x -C ../old
    PYTHONPATH=../old/src python scripts/clock_spy_eval.py SCRATCH demo-1 paper-2 > old.txt
    python scripts/clock_spy_eval.py SCRATCH demo-1 paper-2 > new.txt && diff old.txt new.txt

The heading sensor is made to aid (the simulated missions have it off) so that its yaw is
dated too.
"""

from __future__ import annotations

import logging
import shutil
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from adaptnav.mission import clocks, gnss_clock, load_mission
from adaptnav.mission.config import MissionError

FOUND: list[tuple[str, Any]] = []


def _spy(module: Any, name: str) -> None:
    """Wrap ``module.name`` so that each result is kept in FOUND."""
    inner = getattr(module, name)

    def spy(*args: Any, **kwargs: Any) -> Any:
        found = inner(*args, **kwargs)
        FOUND.append((name, found))
        return found

    setattr(module, name, spy)


def _shift(table: str, seconds: float) -> Callable[[Path], None]:
    def apply(root: Path) -> None:
        df = pd.read_parquet(root / f"{table}.parquet")
        df["t_s"] += seconds
        df.to_parquet(root / f"{table}.parquet", index=False)

    return apply


def _latency(seconds: float) -> Callable[[Path], None]:
    def apply(root: Path) -> None:
        p = root / "mission.toml"
        line = f"[sensors.heading]\nlatency_s = {seconds}\n"
        p.write_text(p.read_text().replace("[sensors.heading]\n", line, 1))

    return apply


def _pegged(root: Path) -> None:
    """The inclinometer's last 10 s read exactly 90° of pitch (pegged at its range)."""
    df = pd.read_parquet(root / "inclinometer.parquet")
    df.loc[df.t_s > df.t_s.max() - 10.0, "pitch_rad"] = np.pi / 2
    df.to_parquet(root / "inclinometer.parquet", index=False)


CASES: dict[str, Callable[[Path], None]] = {
    "right": lambda root: None,
    "heading +18 s": _shift("heading", 18.0),
    "inclinometer +18 s": _shift("inclinometer", 18.0),
    "inclinometer pegged at 90 deg, last 10 s": _pegged,
    "heading latency_s = 60, stamps right": _latency(60.0),
    "gps +18 s": _shift("gps", 18.0),
    "gps -10 s": _shift("gps", -10.0),
    "dvl -10 s": _shift("dvl", -10.0),
}


def _heading_aids(root: Path) -> None:
    p = root / "mission.toml"
    text = p.read_text()
    at = text.index("[sensors.heading]")
    end = text.index('use = "off"', at)
    p.write_text(text[:end] + 'use = "aid"' + text[end + len('use = "off"') :])


def main() -> None:
    logging.disable(logging.CRITICAL)
    _spy(clocks, "clock_offset")
    _spy(gnss_clock, "gnss_offset")
    scratch = Path(sys.argv[1])
    for src in map(Path, sys.argv[2:]):
        for case, change in CASES.items():
            root = scratch / "case"
            shutil.rmtree(root, ignore_errors=True)
            shutil.copytree(src, root)
            _heading_aids(root)
            change(root)
            FOUND.clear()
            try:
                load_mission(root / "mission.toml")
                verdict = "loads"
            except MissionError as err:
                verdict = "error: " + str(err)[:90]
            print(f"{src.name}, {case}: {verdict}")
            for name, found in FOUND:
                fields = "undecided" if found is None else _fields(name, found)
                print(f"    {name}: {fields}")
            shutil.rmtree(root)


def _fields(name: str, found: clocks.ClockOffset) -> str:
    keys = ("offset_s", "se_s", "k", "k_zero", "ratio", "share", "n", "n_eff")
    rule = found.decisive()
    values = ", ".join(f"{k} {float(getattr(found, k)):.6g}" for k in keys)
    return f"{values}, decisive {rule}"


if __name__ == "__main__":
    main()
