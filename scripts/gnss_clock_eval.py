"""A GNSS's clock against the DVL's dead-reckoned track (mission/gnss_clock.py) on right and
shifted stamps: docs/robustness.md, 'Sensor clocks'.

For each mission folder given, the GNSS table's ``t_s`` is moved by each shift (s; > 0: the
stamps late) in a copy under ``--scratch``, the copy is loaded by ``load_mission`` and the
load's verdict printed ("loads", the warning, or the error's first words), with the offset ±
σ, scale and likelihood ratio that :func:`gnss_clock.gnss_offset` finds and the check's time::

    .venv/bin/python scripts/gnss_clock_eval.py --scratch ../scratch ../data/demo-1 ...

With ``PYTHONPATH=old/src`` (0.4.11's code) only the load's verdict is printed.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import shutil
import time
from pathlib import Path

import pandas as pd

from adaptnav.mission import MissionError, load_mission
from adaptnav.mission import loader as loader_module

SHIFTS_S = (0.0, 2.0, 5.0, 18.0, -10.0)


def shifted(src: Path, out: Path, shift: float) -> Path:
    """A copy of the mission ``src`` in ``out`` with its GNSS's stamps moved by ``shift``."""
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(src, out)
    text = (out / "mission.toml").read_text()
    for name in ("gps.parquet", "gnss.parquet"):
        if (out / name).exists() and name in text:
            table = pd.read_parquet(out / name)
            table["t_s"] = table["t_s"] + shift
            table.to_parquet(out / name)
    return out


def found(path: Path) -> str:
    """The offset gnss_clock finds on the loaded mission (new code only), and its time."""
    try:
        from adaptnav.mission import gnss_clock
    except ImportError:
        return ""
    seen: list[str] = []
    orig = gnss_clock.gnss_offset

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        f = orig(*args, **kwargs)
        seen.append(
            "undecided"
            if f is None
            else f"{f.offset_s:+.2f} ± {f.se_s:.2f} s, scale {f.k:.3f}, LR {f.log_lr:.0f}"
        )
        return f

    gnss_clock.gnss_offset = spy
    cap: dict[str, object] = {}
    cross = loader_module.cross_check

    def grab(config, views, sensors, off=None):  # type: ignore[no-untyped-def]
        cap.update(config=config, views=views, sensors=sensors)

    loader_module.cross_check = grab
    try:
        load_mission(path)
    finally:
        loader_module.cross_check = cross
    t0 = time.perf_counter()
    with contextlib.suppress(MissionError):  # the load's verdict, printed beside
        gnss_clock.check(cap["config"], cap["views"], cap["sensors"])  # type: ignore[arg-type]
    took = time.perf_counter() - t0
    gnss_clock.gnss_offset = orig
    return f"{'; '.join(seen) or 'no DVL'} ({took:.2f} s)"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("missions", nargs="+", type=Path)
    parser.add_argument("--scratch", type=Path, required=True)
    parser.add_argument("--shifts", type=str, default=",".join(map(str, SHIFTS_S)))
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    logging.getLogger("adaptnav.mission").setLevel(logging.ERROR)
    for src in args.missions:
        for shift in map(float, args.shifts.split(",")):
            path = shifted(src, args.scratch / f"{src.name}{shift:+g}", shift)
            try:
                load_mission(path)
                verdict = "loads"
            except MissionError as e:
                verdict = "ERROR " + str(e)[:110]
            extra = ""
            if verdict == "loads" or "lat_rad" in verdict:
                extra = found(path)
            print(f"{src.name} {shift:+g} s: {verdict} | {extra}", flush=True)
            shutil.rmtree(path)


if __name__ == "__main__":
    main()
