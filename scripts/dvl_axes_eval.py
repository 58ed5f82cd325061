"""The DVL-axes check (mission/dvl_axes.py) on mission folders: each DVL as loaded and with its
table slipped (x, y, z negated, x and y swapped, knots). Prints, per folder and case, each
axis's fitted slope k ± se and correlation r (``/y0.93``: another DVL axis follows that
axis's prediction better, with that |r|), the verdict, and the seconds spent summing the IMU's
blocks and fitting (docs/robustness.md, 'DVL axes against the accelerometers').

    python scripts/dvl_axes_eval.py FOLDER [FOLDER ...] [--right-only]

The folders are loaded with the current code, so a right DVL the check refused would stop the
script with its MissionError: that is the silence test.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence

import numpy as np

from adaptnav.mission import dvl_axes, load_mission

CASES = {
    "right": np.eye(3),
    "x neg": np.diag([-1.0, 1.0, 1.0]),
    "y neg": np.diag([1.0, -1.0, 1.0]),
    "z neg": np.diag([1.0, 1.0, -1.0]),
    "x<->y": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    "knots": np.eye(3) * 1.943844,
}


def _fit_text(f: dvl_axes.AxisFit | None) -> str:
    if f is None:
        return "undecided"
    other = f"/{'xyz'[f.follower]}{f.follower_r:.2f}" if f.follower != f.axis else ""
    return f"{f.slope.k:+.3f}±{f.slope.se:.3f} r{f.r:+.2f}{other}"


def _one(folder: str, cases: dict[str, np.ndarray]) -> None:
    m = load_mission(folder)
    start = time.perf_counter()
    blocks = dvl_axes.Blocks.of(m.imu.t, m.imu.dt, m.imu.dtheta, m.imu.dvel)
    t_blocks = time.perf_counter() - start
    vrw = m.config.imu.noise.to_imu_noise().vrw
    for name, d in m.sensors.items():
        if d.kind != "dvl":
            continue
        cfg = m.config.sensors[name]
        period = d.period if math.isfinite(d.period) else float(np.median(np.diff(d.t)))
        ok = np.isfinite(d.t) & np.all(np.isfinite(d.z[:, :3]), axis=1)
        base = dvl_axes.Readings(
            d.t[ok], d.z[ok, :3], cfg.sensor_from_body(), cfg.lever_arm(), period
        )
        for case, slip in cases.items():
            readings = base.slipped(slip)
            start = time.perf_counter()
            found = dvl_axes.check_dvl_axes(blocks, readings, vrw)
            t_check = time.perf_counter() - start
            fits, _ = dvl_axes.fit_readings(blocks, readings, vrw)
            verdict = "silent" if found is None else f"REFUSED {'xyz'[found.axis]}"
            if found is not None and found.slip:
                verdict += f" as '{found.slip}'"
            text = "  ".join(_fit_text(f) for f in fits)
            label = folder.rstrip("/").split("/")[-1]
            print(f"{label:10s} {case:6s} {text}  -> {verdict}  [{t_blocks:.3f}+{t_check:.3f} s]")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+")
    parser.add_argument("--right-only", action="store_true", help="only the DVL as loaded")
    args = parser.parse_args(argv)
    cases = {"right": CASES["right"]} if args.right_only else CASES
    for folder in args.folders:
        _one(folder, cases)


if __name__ == "__main__":
    main()
