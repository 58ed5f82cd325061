"""Where a ``push_imu`` of a stream spends its time (docs/streaming.md, 'Latency').

The bench's mission (bench/stream_bench.py, seeded) replayed through a Stream (robust, a given
start) twice, the second time with the parts of a push wrapped in timers: the median of each
part's calls and its total per IMU push (µs). The wrappers add a few tenths of a µs each, so
the parts are an upper bound and ``push_imu`` less its parts is its own code. Run it with the
code to measure on the path (``PYTHONPATH`` to a ``git archive`` of another commit's ``src``
to compare)::

    .venv/bin/python scripts/stream_cost.py [SCRATCH_FOLDER]
    .venv/bin/python scripts/stream_cost.py --rows MISSION OUT.npz
    .venv/bin/python scripts/stream_cost.py --same A.npz B.npz
    .venv/bin/python scripts/stream_cost.py --call MISSION

SCRATCH_FOLDER keeps the generated mission between runs (default: a temporary folder).
``--rows``: a mission's stream rows (robust; given start, aligned, and aligned with every 997th
IMU sample left out, so stretched over the holes) saved for ``--same``, which says whether two
codes' rows are bit-identical (every value, NaN equal to NaN). ``--call``: the engine's compiled
loop called with no IMU sample, mid-stream (the cost of the call itself, its 35 arguments).
"""

from __future__ import annotations

import sys
import tempfile
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from adaptnav import api
from adaptnav.api.stream import IMU, Item, Stream, replay
from adaptnav.engine.batch import Navigator
from adaptnav.mission import Mission, load_mission
from adaptnav.mission.live_cross import CrossWatch
from adaptnav.mission.live_imu import ImuWatch

PARTS: tuple[tuple[type, str], ...] = (
    (Stream, "push_imu"),
    (Stream, "_check_imu"),
    (ImuWatch, "check"),
    (CrossWatch, "imu"),
    (Stream, "_advance"),
    (Navigator, "feed_imu_sample"),
    (Stream, "_new_rows"),
)


def _timed(f: Callable[..., Any], into: list[float]) -> Callable[..., Any]:
    def g(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return f(*args, **kwargs)
        finally:
            into.append(time.perf_counter() - t0)

    return g


def replayed(m: Mission, items: list[Item]) -> list[float]:
    """Each push_imu's wall-clock time (s) over the replay."""
    out = []
    with Stream(m, "robust", initial=api.initial_state(m)[:3]) as s:
        for item in items:
            t0 = time.perf_counter()
            s.push_item(item)
            if item.sensor == IMU:
                out.append(time.perf_counter() - t0)
    return out


def main(folder: Path) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    import stream_bench

    root = folder / "stream-cost-mission"
    m = load_mission(root) if root.exists() else stream_bench.ten_minutes(root)
    items = list(replay(m))
    replayed(m, items)  # compile and warm
    pushes = replayed(m, items)
    print(f"push_imu median {1e6 * np.median(pushes):.2f} µs ({len(pushes)} pushes, unwrapped)")
    times: dict[str, list[float]] = {}
    for cls, name in PARTS:
        setattr(cls, name, _timed(getattr(cls, name), times.setdefault(name, [])))
    replayed(m, items)
    for name, v in times.items():
        us = 1e6 * np.asarray(v)
        print(
            f"  {name:16s} {len(us):6d} calls, median {np.median(us):6.2f} µs, "
            f"{us.sum() / len(pushes):6.2f} µs per push_imu"
        )


def rows(folder: Path, out: Path) -> None:
    """The three replays' rows of a mission (``--rows``)."""
    m = load_mission(folder)
    items = list(replay(m))
    holed = [it for k, it in enumerate(items) if not (it.sensor == IMU and k % 997 == 500)]
    runs = {"given": (api.initial_state(m)[:3], items), "aligned": (None, items)}
    runs["holed"] = (None, holed)
    saved = {}
    for name, (start, its) in runs.items():
        with Stream(m, "robust", initial=start) as s:
            got = [row for item in its for row in s.push_item(item)]
        saved[name] = np.array([list(r.values()) for r in got])
        print(f"{folder.name} {name}: {len(got)} rows")
    np.savez(out, **saved)


def same(a: Path, b: Path) -> None:
    """Whether two ``--rows`` files hold the same rows, bit for bit (``--same``)."""
    old, new = np.load(a), np.load(b)
    for k in old.files:
        print(f"{k}: {old[k].shape} {np.array_equal(old[k], new[k], equal_nan=True)}")


def call(folder: Path) -> None:
    """The time of an empty call of the engine's compiled loop (``--call``)."""
    from adaptnav.engine import batch

    m = load_mission(folder)
    s = Stream(m, "robust", initial=api.initial_state(m)[:3])
    for item in list(replay(m))[:20000]:
        s.push_item(item)
    n, none, none3 = s._nav, np.zeros(0), np.zeros((0, 3))
    assert n is not None
    args = (
        n.x, n._P, none, none, none3, none3, batch._NO_HOLE_K, batch._NO_HOLE_Q, n._q_t,
        n._q_idx, n._grid, n._cur, n._rates,
        n._icur, n._q, n._tau_a, n._tau_g, n._tau_f, n.config.covariance_block_s, n._out_t,
        n._out_x, n._out_p, n._st_sensor, n._st_z, n._s_int, n._s_flt, n._s_state, n._rings,
        n._kind, n.config.reset_mode, n._python_lin, n._lg_int, n._lg_flt, n._ws, n._sm,
    )  # fmt: skip
    k = 20000
    best = min(timeit.repeat(lambda: batch._navigate(*args), number=k, repeat=3))
    print(f"_navigate with no sample ({len(args)} arguments): {1e6 * best / k:.2f} µs a call")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--rows"]:
        rows(Path(sys.argv[2]), Path(sys.argv[3]))
    elif sys.argv[1:2] == ["--call"]:
        call(Path(sys.argv[2]))
    elif sys.argv[1:2] == ["--same"]:
        same(Path(sys.argv[2]), Path(sys.argv[3]))
    elif len(sys.argv) > 1:
        main(Path(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp))
