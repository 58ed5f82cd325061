"""A GNSS track mirrored (latitude and longitude swapped, a hemisphere's sign lost) against the
DVL's dead reckoning (mission/gnss_mirror.py): docs/robustness.md, 'A GNSS track mirrored'.

For each mission folder given, each case's GNSS table (``lat_rad``, ``lon_rad``) is written in
a copy under ``--scratch``, the copy is loaded by ``load_mission`` and the load's verdict
printed ("loads", or the error's first words), with the fits :func:`gnss_mirror.mirror_fit`
makes (the residual variance ratio direct / mirrored, the likelihood ratio statistic, the
scales) and the check's time::

    .venv/bin/python scripts/gnss_mirror_eval.py --scratch ../scratch ../data/demo-1 ...

With ``PYTHONPATH=old/src`` (0.4.12's code) only the load's verdict is printed.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import shutil
import time
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from adaptnav.mission import MissionError, load_mission
from adaptnav.mission import loader as loader_module

Turn = Callable[[pd.DataFrame], None]


def _swap(t: pd.DataFrame) -> None:
    t["lat_rad"], t["lon_rad"] = t["lon_rad"].copy(), t["lat_rad"].copy()


def _neg(column: str) -> Turn:
    def f(t: pd.DataFrame) -> None:
        t[column] = -t[column]

    return f


CASES: dict[str, Turn] = {
    "right": lambda t: None,
    "swapped": _swap,
    "lon negated": _neg("lon_rad"),
    "lat negated": _neg("lat_rad"),
}


def gnss_table(text: str, out: Path) -> Path | None:
    """The GNSS table of a mission folder ``out`` (its mission.toml's ``text``)."""
    for name in ("gps.parquet", "gnss.parquet"):
        if (out / name).exists() and name in text:
            return out / name
    return None


def written(src: Path, out: Path, turn: Turn) -> Path | None:
    """A copy of the mission ``src`` in ``out`` with its GNSS's fixes turned by ``turn``
    (None: no GNSS)."""
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(src, out)
    path = gnss_table((out / "mission.toml").read_text(), out)
    if path is None:
        return None
    table = pd.read_parquet(path)
    turn(table)
    table.to_parquet(path)
    return out


def fits(path: Path) -> str:
    """The fits gnss_mirror makes on the loaded mission (new code only), and the check's time."""
    try:
        from adaptnav.mission import gnss_mirror
    except ImportError:
        return ""
    seen: list[str] = []
    orig = gnss_mirror.mirror_fit

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        m = orig(*args, **kwargs)
        seen.append(
            "undecided"
            if m is None
            else f"V {m.ratio:.3g}, LR {m.log_lr:.0f}, scale {m.k:.3f} mirrored / "
            f"{m.k_direct:.3f} direct, {m.n // 2} windows"
        )
        return m

    gnss_mirror.mirror_fit = spy
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
    gnss_mirror.check(cap["config"], cap["views"], cap["sensors"])  # type: ignore[arg-type]
    took = time.perf_counter() - t0
    gnss_mirror.mirror_fit = orig
    return f"{'; '.join(seen) or 'no DVL or no GNSS'} ({took:.3f} s)"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("missions", nargs="+", type=Path)
    parser.add_argument("--scratch", type=Path, required=True)
    parser.add_argument("--cases", type=str, default=",".join(CASES))
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    logging.getLogger("adaptnav.mission").setLevel(logging.ERROR)
    for src in args.missions:
        for case in args.cases.split(","):
            path = written(src, args.scratch / f"{src.name}-{case.replace(' ', '-')}", CASES[case])
            if path is None:
                print(f"{src.name}: no GNSS", flush=True)
                shutil.rmtree(args.scratch / f"{src.name}-{case.replace(' ', '-')}")
                break
            try:
                load_mission(path)
                verdict = "loads"
            except MissionError as e:
                verdict = "ERROR " + str(e)[:100]
            extra = ""
            with contextlib.suppress(MissionError):
                extra = fits(path)
            print(f"{src.name} {case}: {verdict} | {extra}", flush=True)
            shutil.rmtree(path)


if __name__ == "__main__":
    main()
