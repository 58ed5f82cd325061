"""The DVL's and the depth meter's clocks against the IMU (docs/robustness.md, 'Sensor clocks').

For each mission folder, each of the ``--tables`` (the DVL's, the depth's: the sensor of that
kind) has its ``t_s`` moved by each of the ``--shifts`` in a copy under ``--scratch``, one table
at a time; the copy is loaded by :func:`adaptnav.mission.load_mission` (the load's verdict: ok,
the warnings on stamps, or the MissionError's offset) and, with ``--run``, run with the robust
filter and scored against the truth (3-D and vertical RMSE). Then, where the package has them
(since 0.4.12), the offsets :func:`adaptnav.mission.clocks.dvl_offset` and
:func:`~adaptnav.mission.clocks.depth_offset` find on the stamps as they are (``-``:
undecided). One line a case on stdout.

The figures up to 0.4.11 come from the same script on that code::

    git archive <0.4.11 commit> src | tar -x -C /tmp/old
    PYTHONPATH=/tmp/old/src python scripts/clocks_eval.py runs/demo --run
"""

from __future__ import annotations

import argparse
import logging
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
from adaptnav.mission import Mission, MissionError, axes, clocks, dvl_axes, load_mission, scales


class _Warnings(logging.Handler):
    """The load's warnings about stamps."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.said: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if "stamps" in record.getMessage():
            self.said.append(record.getMessage())


def _shifted(src: Path, scratch: Path, kind: str, shift: float) -> Path | None:
    """A copy of ``src`` with the ``t_s`` of its ``kind`` sensor's table moved by ``shift``."""
    root = scratch / f"{src.name}-{kind}-{shift:+g}"
    shutil.rmtree(root, ignore_errors=True)
    shutil.copytree(src, root)
    mission = load_mission(src)
    names = [n for n, d in mission.sensors.items() if d.kind == kind]
    if not names:
        shutil.rmtree(root)
        return None
    path = root / mission.config.sensors[names[0]].file
    df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    df["t_s"] = df["t_s"] + shift
    if path.suffix == ".parquet":
        df.to_parquet(path)
    else:
        df.to_csv(path, index=False)
    return root


def _verdict(root: Path, run: bool) -> str:
    """The load's verdict and, with ``run``, the robust filter's RMSE."""
    heard = _Warnings()
    logging.getLogger("adaptnav").addHandler(heard)
    started = time.perf_counter()
    try:
        mission = load_mission(root)
    except MissionError as err:
        said = str(err).split(": the stamps of sensor ")[-1].split(" its readings")[0]
        return f"error: {said}"
    finally:
        logging.getLogger("adaptnav").removeHandler(heard)
    out = f"loads in {time.perf_counter() - started:.2f} s"
    if heard.said:
        out += "; warning: " + heard.said[0].split(": the stamps of sensor ")[-1][:60]
    if run and mission.truth is not None:
        m = evaluate(api.run(mission, "robust"), mission.truth)
        vertical = math.sqrt(max(m.rmse_m**2 - m.horizontal_rmse_m**2, 0.0))
        out += f"; RMSE {m.rmse_m:.2f} m (vertical {vertical:.2f} m)"
    return out


def _offsets(mission: Mission) -> str:
    """The DVL's and the depths' offsets on the stamps as they are (since 0.4.12)."""
    if not hasattr(clocks, "dvl_offset"):
        return ""
    noise = mission.config.imu.noise.to_imu_noise()
    imu = mission.imu
    views = axes.ImuViews(imu.t, imu.dt, imu.dtheta, imu.dvel, (noise.arw, noise.vrw))
    blocks = dvl_axes.Blocks.of(*views.samples)
    words = []
    for name, d in mission.sensors.items():
        if d.kind != "dvl":
            continue
        cfg = mission.config.sensors[name]
        ok = np.isfinite(d.t) & np.all(np.isfinite(d.z[:, :3]), axis=1)
        lever = cfg.lever_arm()
        readings = dvl_axes.Readings(d.t[ok], d.z[ok, :3], cfg.sensor_from_body(), lever, d.period)
        words.append(f"{name} {_offset(clocks.dvl_offset(blocks, readings, noise.vrw))}")
        sigma = float(np.atleast_1d(cfg.sigma_si())[0])
        dvl = scales.Dvl.of(d.t, d.z[:, :3], cfg.sensor_from_body(), d.period, sigma)
        for dname, dd in mission.sensors.items():
            if dd.kind == "depth":
                arm = mission.config.sensors[dname].lever_arm() - lever
                found = clocks.depth_offset(dd.t, dd.z[:, 0], dvl, views.tilt(), arm)
                words.append(f"{dname} {_offset(found)}")
    return "; ".join(words)


def _offset(found: clocks.ClockOffset | None) -> str:
    if found is None:
        return "-"
    return f"{found.offset_s:+.2f} ± {found.se_s:.2f} s (k {found.k:.3f}, V {found.ratio:.3g})"


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("missions", nargs="+", type=Path)
    p.add_argument("--tables", default="dvl,depth", help="the sensor kinds to shift")
    p.add_argument("--shifts", default="0,2,5,18,-10", help="seconds added to t_s")
    p.add_argument("--run", action="store_true", help="run the robust filter on each load")
    p.add_argument("--scratch", type=Path, default=None, help="where the copies go [a temp dir]")
    a = p.parse_args(argv)
    shifts = [float(s) for s in a.shifts.split(",")]
    with tempfile.TemporaryDirectory(dir=a.scratch) as scratch:
        for src in a.missions:
            print(f"{src.name} right stamps: {_offsets(load_mission(src))}", flush=True)
            for kind in a.tables.split(","):
                for shift in shifts:
                    root = _shifted(src, Path(scratch), kind, shift)
                    if root is not None:
                        print(
                            f"{src.name} {kind} {shift:+g} s: {_verdict(root, a.run)}", flush=True
                        )
                        shutil.rmtree(root)


if __name__ == "__main__":
    main()
