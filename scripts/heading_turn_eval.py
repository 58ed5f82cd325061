"""A heading a few degrees off the GNSS course (a magnetic heading whose declination is not
set, a DVL yaw mounting not set): the load's warning (scales.Fit.off_course), docs/robustness.md,
'A heading a few degrees off the GNSS course'.

For each mission folder given (a simulated one: DVL, GNSS, a heading sensor written with
``use = "off"``), a copy under ``--scratch`` gets its heading sensor ``use = "aid"`` and, per
case, its headings turned into magnetic ones of an undeclared declination D (``ψ − D``), or the
same with ``declination_deg = D`` declared, or its DVL's readings turned by a yaw mounting β
(``v_s = C_bsᵀ v_b``) left undeclared or declared; ``carried`` cases leave the heading sensor
off (the start's yaw carried by the gyro). Each copy is loaded by ``load_mission``; printed: the
direction fit (angle ± σ over the chords, as the loader makes it) and the verdict ("silent",
"WARNED", or the error's first words)::

    .venv/bin/python scripts/heading_turn_eval.py --scratch ../scratch ../data/demo-1 ...

With ``PYTHONPATH=old/src`` (0.4.12's code) the verdicts are the old ones.
"""

from __future__ import annotations

import argparse
import logging
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from adaptnav.mission import MissionError, load_mission, scales

CASES = (
    "dec 0", "dec 3", "dec 5", "dec 10", "dec 5 declared", "dvl yaw 5", "dvl yaw 5 declared",
    "carried", "carried dvl yaw 10",
)  # fmt: skip


class Grab(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.msgs: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.msgs.append(record.getMessage())


def section(text: str, name: str, line: str) -> str:
    """``line`` added to ``[sensors.name]`` of a mission.toml's ``text``."""
    return text.replace(f"[sensors.{name}]\n", f"[sensors.{name}]\n{line}\n", 1)


def written(src: Path, out: Path, case: str) -> Path:
    """A copy of ``src`` in ``out`` changed as ``case`` says (module docstring)."""
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(src, out)
    toml = out / "mission.toml"
    text = toml.read_text()
    if not case.startswith("carried"):
        i = text.index("[sensors.heading]")
        j = text.index('use = "off"', i)
        text = text[:j] + 'use = "aid"' + text[j + len('use = "off"') :]
    angle = float(re.findall(r"[\d.]+", case)[0]) if re.search(r"\d", case) else 0.0
    if case.startswith("dec"):
        h = pd.read_parquet(out / "heading.parquet")
        yaw = h["yaw_rad"].to_numpy() - math.radians(angle)
        h["yaw_rad"] = np.angle(np.exp(1j * yaw))
        h.to_parquet(out / "heading.parquet")
        if case.endswith("declared"):
            text = section(text, "heading", f"declination_deg = {angle:g}")
    if "dvl yaw" in case:
        d = pd.read_parquet(out / "dvl.parquet")
        b = math.radians(angle)
        vx, vy = d["vx_m_s"].to_numpy(), d["vy_m_s"].to_numpy()
        d["vx_m_s"], d["vy_m_s"] = (
            math.cos(b) * vx + math.sin(b) * vy,
            -math.sin(b) * vx + math.cos(b) * vy,
        )
        d.to_parquet(out / "dvl.parquet")
        if case.endswith("declared"):
            text = section(text, "dvl", f"mounting_rpy_deg = [0.0, 0.0, {angle:g}]")
    toml.write_text(text)
    return out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("missions", nargs="+", type=Path)
    parser.add_argument("--scratch", type=Path, required=True)
    parser.add_argument("--cases", type=str, default=",".join(CASES))
    args = parser.parse_args()
    log = logging.getLogger("adaptnav.mission")
    seen: list[str] = []
    orig = scales.dvl_track

    def spy(*a, **k):  # type: ignore[no-untyped-def]
        speed, turn = orig(*a, **k)
        if turn is not None:
            seen.append(f"{turn.angle_deg:+.2f} ± {turn.angle_se_deg:.2f}° over {turn.n} chords")
        return speed, turn

    scales.dvl_track = spy
    for src in args.missions:
        for case in args.cases.split(","):
            path = written(src, args.scratch / f"{src.name}-{case.replace(' ', '-')}", case)
            grab = Grab()
            seen.clear()
            log.addHandler(grab)
            try:
                load_mission(path)
                verdict = "silent"
            except MissionError as e:
                verdict = "ERROR " + str(e)[:90]
            finally:
                log.removeHandler(grab)
            said = [m for m in grab.msgs if "off the GNSS course" in m or "° off over" in m]
            if said:
                verdict = "WARNED"
                hint = re.findall(r"= ([-\d.]+) in \[sensors|: ([-\d.]+)° in \[sensors", said[0])
                verdict += f" (sets {hint})"
            print(f"{src.name} {case}: {'; '.join(seen) or 'undecided'} | {verdict}", flush=True)
            shutil.rmtree(path)


if __name__ == "__main__":
    main()
