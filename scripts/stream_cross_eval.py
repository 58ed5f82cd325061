"""A stream's cross-checks (mission/live_cross.py) over its first window, on right and faulted data.

For each mission folder given, loaded by the loader (whose own cross-checks on the whole mission
pass on right data), the window's IMU block sums and readings are fed to a
:class:`~adaptnav.mission.live_cross.CrossWatch` as a stream would feed it (no filter run: the
checks see only what the stream keeps), for each window length, on the data as they are and
with one fault put in: a gyro axis negated, the DVL in knots. Prints one line per (mission,
window, data): "silent" or the finding's first words. docs/streaming.md, 'Cross-checks'::

    .venv/bin/python scripts/stream_cross_eval.py ../data/demo ../data/paper-1 ...
    .venv/bin/python scripts/stream_cross_eval.py --replay ../data/demo ../data/paper-1 ...
    .venv/bin/python scripts/stream_cross_eval.py --cost

``--replay``: the missions through a Stream (default window) and the demo's two faults;
``--cost``: the watch's time per IMU sample and the bench's pushes with the checks off and on.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from adaptnav.mission import ImuData, Mission, load_mission
from adaptnav.mission.live import Reading

WINDOWS_S = (120.0, 300.0, 600.0, 900.0, 1200.0, 1e9)
KNOTS = 1.943844


def faults(m: Mission) -> dict[str, Mission]:
    """The mission as it is and with each fault (those that apply)."""
    out = {"right": m}
    for axis in range(3):
        dth = m.imu.dtheta.copy()
        dth[:, axis] *= -1.0
        imu = ImuData(m.imu.t, m.imu.dt, dth, m.imu.dvel)
        out[f"gyro {'xyz'[axis]} negated"] = replace(m, imu=imu)
    for name, d in m.sensors.items():
        if d.kind == "dvl":
            z = d.z.copy()
            z[:, :3] *= KNOTS
            out[f"{name} in knots"] = replace(m, sensors={**m.sensors, name: replace(d, z=z)})
    return out


def verdict(m: Mission, window_s: float) -> tuple[str, float]:
    """The CrossWatch's verdict on the mission's first ``window_s`` and the seconds it took."""
    from adaptnav.mission.live_cross import CrossWatch  # here: --replay runs on 0.4.10 too

    periods = {n: d.period for n, d in m.sensors.items()}
    watch = CrossWatch(m.config, periods, window_s)
    t0 = time.perf_counter()
    imu = m.imu
    stop = imu.start + window_s + 1.0
    for k in range(int(np.searchsorted(imu.t, stop, side="right"))):
        watch.imu(float(imu.t[k]), float(imu.dt[k]), imu.dtheta[k], imu.dvel[k])
    for name, d in m.sensors.items():
        for k in range(int(np.searchsorted(d.t, stop, side="right"))):
            watch.reading(name, Reading(float(d.t[k]), d.z[k], int(d.rows[k])))
    found = watch.verdict()
    took = time.perf_counter() - t0
    if found is None:
        return "silent", took
    return str(found)[:400], took


def replays(folders: list[str]) -> None:
    """Each mission replayed through a Stream with the default window (robust filter): its
    verdict; then the first folder's (the demo's) gyro x negated from a given start
    (cross_check_s = 900 where the stream takes it) and DVL in knots, aligning: the error, or
    the run's RMSE when the stream runs to the end (0.4.10's code: PYTHONPATH=old/src)."""
    from adaptnav import api
    from adaptnav.analysis import evaluate
    from adaptnav.api.stream import Stream, replay
    from adaptnav.mission import MissionError

    def run(m: Mission, **kw: object) -> str:
        stream = Stream(m, "robust", **kw)  # type: ignore[arg-type]
        try:
            for item in replay(m):
                stream.push_item(item)
            result = stream.close()
        except MissionError as exc:
            return "refused: " + str(exc)[:160]
        metrics = evaluate.evaluate(result, m.truth) if m.truth is not None else None
        rmse = f"{metrics.horizontal_rmse_m:.1f} m RMSE" if metrics is not None else "no truth"
        return f"ran to the end, {len(result.solution)} rows, {rmse}"

    new = "cross_check_s" in Stream.__init__.__code__.co_varnames
    for folder in folders:
        m = load_mission(folder)
        print(f"{Path(folder).name} right: {run(m)}", flush=True)
    m = load_mission(folders[0])
    start = api.initial_state(m)[:3]
    bad = faults(m)
    kw = {"cross_check_s": 900.0} if new else {}
    print(f"gyro x negated, given start: {run(bad['gyro x negated'], initial=start, **kw)}")
    print(f"dvl in knots, aligning: {run(bad['dvl in knots'])}", flush=True)


def cost() -> None:
    """On the bench's 10-minute mission (bench/stream_bench.py, seeded): CrossWatch.imu's time
    per sample (window 600 s) less the same loop's without it, three times; then the bench's
    replay (robust, given start) alternated in this process with the checks off
    (cross_check_s = 0) and on (600 s), four times each: push_imu and push medians (µs)."""
    import functools
    import tempfile

    from adaptnav import api
    from adaptnav.api.stream import Stream
    from adaptnav.mission.live_cross import CrossWatch

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    import stream_bench

    with tempfile.TemporaryDirectory() as tmp:
        m = stream_bench.ten_minutes(Path(tmp) / "mission")
    imu = m.imu
    rows = [
        (float(imu.t[k]), float(imu.dt[k]), imu.dtheta[k], imu.dvel[k]) for k in range(len(imu))
    ]
    periods = {n: d.period for n, d in m.sensors.items()}
    for _ in range(3):
        watch = CrossWatch(m.config, periods, 600.0)
        t0 = time.perf_counter()
        for _row in rows:
            pass
        base = time.perf_counter() - t0
        t0 = time.perf_counter()
        for row in rows:
            watch.imu(*row)
        took = time.perf_counter() - t0 - base
        print(f"{len(rows)} samples: {1e6 * took / len(rows):.2f} µs per CrossWatch.imu")
    start = api.initial_state(m)[:3]
    api.run(m, stream_bench.KIND, initial=start)  # compile and warm
    stream_bench.stream_latencies(m, start)
    for _ in range(4):
        for window in (0.0, 600.0):
            stream_bench.Stream = functools.partial(Stream, cross_check_s=window)  # type: ignore[misc]
            times = stream_bench.stream_latencies(m, start)
            imu_us, read_us = (1e6 * float(np.median(times[k])) for k in ("imu", "reading"))
            print(f"cross_check_s = {window:g}: push_imu {imu_us:.2f} µs, push {read_us:.2f} µs")


def main(folders: list[str]) -> None:
    for folder in folders:
        m = load_mission(folder)
        span = float(m.imu.t[-1] - m.imu.start)
        kinds = sorted({d.kind for d in m.sensors.values()})
        print(f"== {Path(folder).name}: {span:.0f} s of IMU, sensors {kinds}", flush=True)
        for label, mm in faults(m).items():
            for w in WINDOWS_S:
                if w > span + 300.0 and w < 1e9:
                    continue
                words, took = verdict(mm, w)
                wl = "whole" if w >= 1e9 else f"{w:.0f} s"
                print(f"{label:18s} {wl:>7s} {took:5.1f} s  {words}", flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--replay"]:
        replays(sys.argv[2:])
    elif sys.argv[1:2] == ["--cost"]:
        cost()
    else:
        main(sys.argv[1:])
