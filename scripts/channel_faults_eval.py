"""One IMU channel stuck, dead or reading only noise for part of a mission (docs/robustness.md,
'One IMU channel stuck', 'An IMU axis that fails mid-mission').

Each case copies a mission folder (the simulated demo, an increments IMU) and changes one
column of its IMU table from ``--from`` seconds on: zeroed, held at its last value, or replaced
by white noise at the IMU's ARW / VRW (``[imu.noise]``: what an axis that lost its signal but
not its noise reads; seed 1). The copy is loaded (the verdict: ok, or the MissionError's words)
and, with ``--run``, run with the robust filter and scored against the truth (RMSE) when it
loads. One line a case on stdout. The figures up to 0.4.12 come from the same script on that
code::

    git archive <0.4.12 commit> src | tar -x -C /tmp/old
    PYTHONPATH=/tmp/old/src python scripts/channel_faults_eval.py DEMO --run
    python scripts/channel_faults_eval.py DEMO --run

``--right MISSION ...``: right data instead, one line each: the load's verdict and time, each
IMU column's longest run of one value (s) and share of samples repeating the one before, and
per angle of a sensor that sees rotation its spans (``axes.segment_finding``'s), for the gyro
and (an inclinometer's) the accelerometers' levelling: how many follow, fail and are undecided,
and the lowest ``k + 4 se`` of those whose slope decides.
"""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from adaptnav import api
from adaptnav.analysis.evaluate import evaluate
from adaptnav.mission import Mission, MissionError, axes, load_mission, loader

CASES = (
    "dtheta_x_rad zero",
    "dtheta_y_rad zero",
    "dtheta_z_rad zero",
    "dtheta_x_rad noise",
    "dtheta_y_rad noise",
    "dtheta_z_rad noise",
    "dtheta_z_rad last",
    "dvel_x_m_s last",
    "dvel_y_m_s zero",
    "dvel_z_m_s last",
    "dvel_x_m_s noise",
)


def _faulted(src: Path, scratch: Path, case: str, t0: float) -> Path:
    """A copy of ``src`` with ``case`` ("column how") put in from ``t0`` on."""
    column, how = case.split()
    root = scratch / case.replace(" ", "-")
    shutil.rmtree(root, ignore_errors=True)
    shutil.copytree(src, root)
    df = pd.read_parquet(root / "imu.parquet")
    after = df["t_s"].to_numpy() >= t0
    if how == "zero":
        df.loc[after, column] = 0.0
    elif how == "last":
        df.loc[after, column] = df[column].to_numpy()[np.argmax(after) - 1]
    else:
        noise = load_mission(src).config.imu.noise.to_imu_noise()
        dt = float(np.median(np.diff(df["t_s"].to_numpy())))
        psd = noise.arw if column.startswith("dtheta") else noise.vrw
        rng = np.random.default_rng(1)
        df.loc[after, column] = rng.normal(0.0, psd * math.sqrt(dt), int(after.sum()))
    df.to_parquet(root / "imu.parquet", index=False)
    return root


def _verdict(root: Path, run: bool) -> str:
    """The load's verdict (its time) and, with ``run``, the robust filter's RMSE."""
    started = time.perf_counter()
    try:
        mission = load_mission(root)
    except MissionError as err:
        return f"exit 2: {str(err)[:260]}"
    out = f"loads in {time.perf_counter() - started:.2f} s"
    if run and mission.truth is not None:
        m = evaluate(api.run(mission, "robust"), mission.truth)
        out += f"; exit 0, RMSE {m.rmse_m:.2f} m (horizontal {m.horizontal_rmse_m:.2f} m)"
    return out


def _runs(m: Mission) -> str:
    """Each IMU column's longest run of one value (s) and share of repeats, in the table's
    values (rates or increments: what the loader compares)."""
    df = m.tables["imu"]
    t = df["t_s"].to_numpy()
    words = []
    for column in loader.imu_columns(m.config.imu.format):
        x = df[column].to_numpy()
        same = np.r_[False, x[1:] == x[:-1]]
        edge = np.diff(same.view(np.int8), append=np.int8(0))
        first, last = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)
        longest = float(np.max(t[last] - t[first])) if first.size else 0.0
        words.append(f"{longest:.3g} s/{same.mean():.0%}")
    return "runs " + " ".join(words)


def _spans(m: Mission) -> str:
    """Per angle and instrument (the gyro; for an inclinometer the accelerometers' levelling
    too): the spans that follow, fail and are undecided (``axes._segment_verdict``), and the
    lowest ``k + 4 se`` of the spans whose slope decides."""
    noise = m.config.imu.noise.to_imu_noise()
    views = axes.ImuViews(m.imu.t, m.imu.dt, m.imu.dtheta, m.imu.dvel, (noise.arw, noise.vrw))
    words = []
    for ref in loader._axis_references(m.config, m.sensors):
        sigma = loader._reference_sigma(m.config, ref)
        spans = axes._spans(ref, views.gyro(ref.c_sb))
        if not spans:
            continue
        imus: list[tuple[str, axes.Gyro | axes.AccelTilt, int]] = [
            ("gyro", views.gyro(ref.c_sb), ref.axis)
        ]
        if ref.tilt is not None:
            imus.append(("accel", views.tilt(ref.c_sb), ref.tilt))
        for name, imu, axis in imus:
            counts, ups = [0, 0, 0], []
            for ts, us in spans:
                part = imu.window(ts[0] - 1.0, ts[-1] + 1.0) if isinstance(imu, axes.Gyro) else imu
                v = axes._segment_verdict(part, axis, ts, us, sigma)
                counts[0 if v is None else 1 if v[0] else 2] += 1
                s = axes.best_slope(part, axis, ts, us)
                if s is not None:
                    ups.append(s[0].upper)
            low = f"{min(ups):.2f}" if ups else "-"
            words.append(
                f"{ref.angle}/{name} {counts[1]} follow, {counts[2]} fail, {counts[0]} undecided"
                f" (lowest upper {low})"
            )
    return "; ".join(words) or "no angle"


def right(folders: Sequence[Path]) -> None:
    """The ``--right`` lines (the module's docstring)."""
    for folder in folders:
        verdict = _verdict(folder, False)
        m = load_mission(folder) if verdict.startswith("loads") else None
        extra = f"; {_runs(m)}; {_spans(m)}" if m is not None else ""
        print(f"{folder.name}: {verdict}{extra}", flush=True)


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("mission", type=Path)
    p.add_argument("--from", dest="t0", type=float, default=750.0, help="fault start (s)")
    p.add_argument("--cases", default=",".join(CASES), help="comma-separated 'column how'")
    p.add_argument("--run", action="store_true", help="run the robust filter on each load")
    p.add_argument("--scratch", type=Path, default=None, help="where the copies go [a temp dir]")
    p.add_argument("--right", nargs="*", type=Path, help="right missions: their figures")
    a = p.parse_args(argv)
    if a.right is not None:
        right([a.mission, *a.right])
        return
    print(f"{a.mission.name} right: {_verdict(a.mission, a.run)}", flush=True)
    with tempfile.TemporaryDirectory(dir=a.scratch) as scratch:
        for case in a.cases.split(","):
            root = _faulted(a.mission, Path(scratch), case, a.t0)
            print(f"{case} from {a.t0:g} s: {_verdict(root, a.run)}", flush=True)
            shutil.rmtree(root)


if __name__ == "__main__":
    main()
