"""IMU holes with a raised ``imu.max_gap_s``: the error after the hole against the σ the filter
claims (docs/robustness.md, 'The σ over a hole').

Each case copies a simulated mission, removes the IMU rows in (t0, t0 + length] (samples lost:
the next row's increments are one period's, stretched over the hole by the loader), raises
``max_gap_s`` above the hole and runs a filter. Printed per case: RMSE, the mean position /
velocity / attitude NEES over the run, the largest attitude and velocity NEES in the 120 s
after the hole, the attitude and velocity NEES at the first reference sample after the hole's end,
the attitude error (deg) and its claimed σ there, and the recovery
time: how long after the hole the velocity or attitude error stays farther than twice the
clean run's RMS from the clean run's error at the same time (NaN: not within the mission).
Each case's line is followed by the run without a hole ("clean") scored at the same times.

    adaptnav simulate demo --seed 1 --out DEMO
    python scripts/imu_hole_eval.py DEMO SCRATCH [robust] [T0:LEN,T0:LEN,...] [--smooth]

Run it from two checkouts (PYTHONPATH=OLD/src) to compare versions. SCRATCH receives one
folder per case, removed after it. ``--trapezoid`` prints instead the RMS repair error of the
mission's own IMU for the stretch of the next sample and for the mean of the samples either
side (mission.imu_holes), per hole length; ``--lost`` the cases of 'IMU samples lost' (rows
lost within the default max_gap_s). ``--rates`` first re-expresses the mission's IMU as rates
(:func:`as_rates`; an IMU in rates, whose holes the loader integrates by the trapezoid of the
rates either side) and runs the cases on that.
"""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.mission import Mission, MissionError, load_mission

AFTER_S = 120.0


def make_hole(src: Path, dst: Path, t0: float, length: float) -> None:
    """A copy of ``src`` with the IMU rows in (t0, t0 + length] removed, max_gap_s above."""
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    if length <= 0.0:
        return
    p = dst / "mission.toml"
    s = p.read_text()
    s = s.replace("[imu]\n", f"[imu]\nmax_gap_s = {length + 1.0}\n", 1)
    p.write_text(s)
    df = pd.read_parquet(dst / "imu.parquet")
    keep = (df.t_s <= t0 + 1e-9) | (df.t_s > t0 + length + 1e-9)
    df[keep].reset_index(drop=True).to_parquet(dst / "imu.parquet", index=False)


def as_rates(src: Path, dst: Path) -> None:
    """A copy of ``src`` with its IMU in rates: each row's increments over its interval, the
    mean rates there, stamped at the interval's middle (where the mean rate is the rate, to
    within h² ω̈ / 24: the trajectory's rates with the same IMU errors); ``imu.format``
    rates."""
    make_hole(src, dst, 0.0, 0.0)
    df = pd.read_parquet(dst / "imu.parquet")
    t = df.t_s.to_numpy()
    dt = np.diff(t, prepend=t[0] - float(np.median(np.diff(t))))
    out = pd.DataFrame({"t_s": t - 0.5 * dt})
    for a in "xyz":
        out[f"gyro_{a}_rad_s"] = df[f"dtheta_{a}_rad"].to_numpy() / dt
    for a in "xyz":
        out[f"accel_{a}_m_s2"] = df[f"dvel_{a}_m_s"].to_numpy() / dt
    out.to_parquet(dst / "imu.parquet", index=False)
    p = dst / "mission.toml"
    s = p.read_text()
    assert 'format = "increments"' in s
    p.write_text(s.replace('format = "increments"', 'format = "rates"', 1))


def errors(result: api.Result, truth: pd.DataFrame, block: str) -> tuple[Array, Array, Array]:
    sol = result.solution
    e = evaluate.block_errors(sol, truth, block)  # type: ignore[arg-type]
    n = evaluate.nees(sol, truth, block)  # type: ignore[arg-type]
    t = e["t_s"].to_numpy()
    return t, e[["e_0", "e_1", "e_2"]].to_numpy(), n["nees"].to_numpy()


Array = np.ndarray


def recovery(t: Array, err: Array, t_c: Array, err_c: Array, bound: float, t_end: float) -> float:
    """Seconds after t_end until the error stays within ``bound`` of the clean run's at the
    same times (NaN: not before the mission ends)."""
    ref = np.stack([np.interp(t, t_c, err_c[:, c]) for c in range(3)], axis=-1)
    after = t > t_end
    over = np.flatnonzero(after & (np.linalg.norm(err - ref, axis=1) > bound))
    if not over.size:
        return 0.0
    last = over[-1]
    return math.nan if last >= t.size - 2 else float(t[last] - t_end)


def load(root: Path) -> Mission:
    """The mission; a DVL clock check fooled by the hole (a MissionError that says to set
    ``scale_check = false``) is switched off, and said."""
    try:
        return load_mission(root)
    except MissionError as exc:
        if "scale_check = false" not in str(exc):
            raise
        print(f"   (the DVL clock check refused the mission: {str(exc)[:90]}...; switched off)")
        p = root / "mission.toml"
        s = p.read_text().replace("[sensors.dvl]\n", "[sensors.dvl]\nscale_check = false\n", 1)
        p.write_text(s)
        return load_mission(root)


def run_case(root: Path, kind: str, smooth: bool) -> tuple[dict[str, float], tuple]:
    """The run's metrics over the whole mission, and its error series for :func:`window`."""
    m = load(root)
    res = api.run(m, kind, smooth=smooth)
    met = evaluate.evaluate(res, m.truth)
    out = {"rmse": met.rmse_m, "nees_p": met.mean_nees_position,
           "nees_v": met.mean_nees_velocity, "nees_a": met.mean_nees_attitude}  # fmt: skip
    out["events"] = float((res.events["event"] == "imu_hole").sum()) if len(res.events) else 0.0
    series = (res.solution, *errors(res, m.truth, "attitude"), *errors(res, m.truth, "velocity"))
    ea, ev = series[2], series[5]
    out["rms_a"] = float(np.sqrt(np.mean(np.sum(ea**2, axis=1))))
    out["rms_v"] = float(np.sqrt(np.mean(np.sum(ev**2, axis=1))))
    return out, series


def window(
    series: tuple, t_end: float, clean: dict[str, float], clean_series: tuple
) -> dict[str, float]:
    """The largest attitude and velocity NEES in the AFTER_S seconds after t_end, the attitude
    error (deg) and its σ there, the recovery time against the clean run's RMS."""
    sol, ta, ea, na, tv, ev, nv = series
    out: dict[str, float] = {}
    win = (ta > t_end) & (ta <= t_end + AFTER_S)
    win_v = (tv > t_end) & (tv <= t_end + AFTER_S)
    out["max_nees_a"] = float(np.nanmax(na[win])) if win.any() else math.nan
    out["max_nees_v"] = float(np.nanmax(nv[win_v])) if win_v.any() else math.nan
    j = min(int(np.searchsorted(ta, t_end + 0.05)), ta.size - 1)
    out["nees_a_end"], out["nees_v_end"] = float(na[j]), float(nv[min(j, nv.size - 1)])
    out["att_err_deg"] = float(np.degrees(np.linalg.norm(ea[j])))
    i = int(np.searchsorted(sol["t_s"].to_numpy(), t_end + 0.05))
    var = sum(float(sol[f"sd_phi_{a}"].iloc[i]) ** 2 for a in "NED")
    out["att_sigma_deg"] = math.degrees(math.sqrt(var))
    _, tca, eca, _, tcv, ecv, _ = clean_series
    ra = recovery(ta, ea, tca, eca, 2.0 * clean["rms_a"], t_end)
    rv = recovery(tv, ev, tcv, ecv, 2.0 * clean["rms_v"], t_end)
    out["recovery_s"] = max(ra, rv)
    return out


def lost_rows(src: Path, scratch: Path, kind: str) -> None:
    """The cases of docs/robustness.md, 'IMU samples lost' (default max_gap_s): one row lost
    at 700 s, four in a row there, 1 % of the rows after 601 s lost (isolated, seed 1)."""
    imu = pd.read_parquet(src / "imu.parquet")
    t = imu.t_s.to_numpy()
    at = int(np.searchsorted(t, 700.0))
    after = np.flatnonzero(t > 601.0)[:-1]
    rng = np.random.default_rng(1)
    picks = np.sort(rng.choice(after.size // 2, after.size // 100, replace=False))
    cases = {"none": [], "1 at 700 s": [at], "4 at 700 s": list(range(at, at + 4)),
             "1 % isolated": after[2 * picks].tolist()}  # fmt: skip
    root = scratch / "lost"
    for name, drop in cases.items():
        make_hole(src, root, 0.0, 0.0)
        imu.drop(index=drop).reset_index(drop=True).to_parquet(root / "imu.parquet")
        m = load(root)
        met = evaluate.evaluate(api.run(m, kind), m.truth)
        print(
            f"{name}\tRMSE {met.rmse_m:.3f} m\tNEES position {met.mean_nees_position:.3g}"
            f"\tvelocity {met.mean_nees_velocity:.3g}\tattitude {met.mean_nees_attitude:.3g}"
        )
    shutil.rmtree(root)


def trapezoid(root: Path) -> None:
    """RMS repair error (per axis, mean over axes) of the next sample stretched against the
    mean of the samples either side, over the mission's windows (module docstring)."""
    df = pd.read_parquet(root / "imu.parquet")
    cols = [c for c in df.columns if c.startswith(("dtheta", "dvel"))]
    v = df[cols].to_numpy()
    rate = 1.0 / float(np.median(np.diff(df.t_s.to_numpy())))
    for length in (0.05, 1.0, 10.0, 60.0):
        m = round(length * rate) + 1  # the lost samples and the one after
        n = (v.shape[0] - 1) // m * m
        w = v[1 : n + 1].reshape(-1, m, v.shape[1])
        before = v[0:n:m][: w.shape[0]]  # the sample before each window
        total = w.sum(axis=1)
        nxt = m * w[:, -1]
        trap = m * 0.5 * (w[:, -1] + before)
        for name, rep in (("next", nxt), ("trapezoid", trap)):
            e = total - rep
            rms = np.sqrt(np.mean(e * e, axis=0))
            print(f"{length:5g} s  {name:9s}  gyro {np.degrees(rms[:3].mean()):.4g} deg  "
                  f"accel {rms[3:].mean():.4g} m/s")  # fmt: skip


def main() -> None:
    src, scratch = Path(sys.argv[1]), Path(sys.argv[2])
    if "--rates" in sys.argv:
        scratch.mkdir(parents=True, exist_ok=True)
        as_rates(src, scratch / "rates-src")
        src = scratch / "rates-src"
    if "--trapezoid" in sys.argv:
        trapezoid(src)
        return
    if "--lost" in sys.argv:
        lost_rows(src, scratch, sys.argv[3] if len(sys.argv) > 3 else "robust")
        return
    args = [a for a in sys.argv[3:] if not a.startswith("--")]
    kind = args[0] if args else "robust"
    spec = args[1] if len(args) > 1 else "740:0.05,740:1,740:10,740:60,830:0.05,830:1,830:10,830:60"
    smooth = "--smooth" in sys.argv
    scratch.mkdir(parents=True, exist_ok=True)
    root = scratch / "case"
    make_hole(src, root, 0.0, 0.0)
    clean, clean_series = run_case(root, kind, smooth)
    keys = ("rmse", "nees_p", "nees_v", "nees_a", "nees_a_end", "nees_v_end", "max_nees_a",
            "max_nees_v", "att_err_deg", "att_sigma_deg", "recovery_s", "events")  # fmt: skip
    print("case", *keys, sep="\t")
    for item in spec.split(","):
        t0, length = (float(x) for x in item.split(":"))
        make_hole(src, root, t0, length)
        try:
            r, series = run_case(root, kind, smooth)
        except Exception as exc:  # a run that breaks down (FilterError) is a result too
            print(f"{t0:g}+{length:g}s", f"{type(exc).__name__}: {str(exc)[:150]}", sep="\t")
            continue
        r |= window(series, t0 + length, clean, clean_series)
        c = clean | window(clean_series, t0 + length, clean, clean_series)
        print(f"{t0:g}+{length:g}s", *(f"{r.get(k, math.nan):.4g}" for k in keys), sep="\t")
        print("  clean", *(f"{c.get(k, math.nan):.4g}" for k in keys), sep="\t")
        sys.stdout.flush()
    shutil.rmtree(root)


if __name__ == "__main__":
    main()
