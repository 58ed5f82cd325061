"""Odd but real inputs against the load-time cross-checks (loader.cross_check), one kind at a
time: each case copies a mission folder (the simulated demo with its heading sensor aiding),
changes its tables or mission.toml, and loads it with every warning an error. Prints per case
the outcome (OK, MissionError and its words, or CRASH with the line it came from) and the
warnings logged (docs/robustness.md, 'Odd inputs to the cross-checks').

    adaptnav simulate demo --out DEMO   # then set [sensors.heading] use = "aid"
    python scripts/odd_inputs_eval.py DEMO SCRATCH [REGEX]

SCRATCH receives one folder per case, removed after it.
"""

from __future__ import annotations

import logging
import math
import re
import shutil
import sys
import time
import traceback
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from adaptnav.mission import load_mission
from adaptnav.mission.config import MissionError

DEMO = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("demo")
OUT = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("odd-cases")


class Grab(logging.Handler):
    def __init__(self):
        super().__init__()
        self.msgs = []

    def emit(self, r):
        if r.levelno >= logging.WARNING:
            self.msgs.append(r.getMessage())


def rd(root, n):
    return pd.read_parquet(root / f"{n}.parquet")


def wr(root, n, df):
    df.to_parquet(root / f"{n}.parquet", index=False)


def toml(root, old, new, count=1):
    p = root / "mission.toml"
    s = p.read_text()
    assert old in s, old
    p.write_text(s.replace(old, new, count))


def sect(root, name, line):
    p = root / "mission.toml"
    s = p.read_text()
    s = s.replace(f"[sensors.{name}]\n", f"[sensors.{name}]\n{line}\n", 1)
    p.write_text(s)


def keep(root, n, idx):
    df = rd(root, n)
    wr(root, n, df.iloc[idx].reset_index(drop=True))


def cut_all(root, t0, t1):
    for n in ["imu", "heading", "dvl", "gps", "depth", "inclinometer", "truth"]:
        df = rd(root, n)
        wr(root, n, df[(df.t_s >= t0) & (df.t_s <= t1)].reset_index(drop=True))


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


CASES = {}


def case(name):
    def deco(f):
        CASES[name] = f
        return f

    return deco


for s in ["heading", "inclinometer", "gps", "dvl", "depth"]:
    for k in (1, 2, 3):

        def f(root, s=s, k=k):
            df = rd(root, s)
            i = np.linspace(650, len(df) * 0.9, k).astype(int) if k > 1 else [len(df) * 3 // 4]
            keep(root, s, list(np.array(i) * len(df) // len(df)))

        CASES[f"{s}-{k}-readings"] = f

for s, cols in [
    ("heading", ["yaw_rad"]),
    ("inclinometer", ["roll_rad", "pitch_rad"]),
    ("gps", ["lat_rad", "lon_rad"]),
    ("dvl", ["vx_m_s", "vy_m_s", "vz_m_s"]),
    ("depth", ["depth_m"]),
]:

    def f(root, s=s, cols=cols):
        df = rd(root, s)
        m = np.ones(len(df), bool)
        m[[len(df) * 3 // 4, len(df) * 3 // 4 + 1, len(df) * 3 // 4 + 5]] = False
        df.loc[m, cols] = np.nan
        wr(root, s, df)

    CASES[f"{s}-nan-but-3"] = f

for s in ["heading", "inclinometer", "gps", "dvl"]:

    def f(root, s=s):
        df = rd(root, s)
        wr(root, s, df[df.t_s < 590].reset_index(drop=True))

    CASES[f"{s}-only-in-alignment"] = f

    def g(root, s=s):
        df = rd(root, s)
        df = df[df.t_s > 880].reset_index(drop=True)
        wr(root, s, df)

    CASES[f"{s}-last-26s-only"] = g


@case("heading-after-imu-ends")
def _(root):
    df = rd(root, "heading")
    df["t_s"] += 1000
    wr(root, "heading", df)


@case("dvl-ends-before-imu")
def _(root):
    df = rd(root, "dvl")
    df["t_s"] -= 1000
    wr(root, "dvl", df)


@case("heading-gap-10min")
def _(root):
    df = rd(root, "heading")
    wr(root, "heading", df[(df.t_s < 620) | (df.t_s > 880)].reset_index(drop=True))


@case("all-aiding-gap-hours-imu-gap")
def _(root):
    # an IMU gap of 2 h with max_gap_s raised to allow it, all sensors shifted after it
    toml(root, "rate_hz = 100.0\n", "rate_hz = 100.0\nmax_gap_s = 8000.0\n")
    for n in ["imu", "heading", "dvl", "gps", "depth", "inclinometer", "truth"]:
        df = rd(root, n)
        df.loc[df.t_s > 700, "t_s"] += 7200
        wr(root, n, df)


@case("heading-constant")
def _(root):
    df = rd(root, "heading")
    df["yaw_rad"] = 0.5
    wr(root, "heading", df)


@case("at-rest-whole-mission")
def _(root):
    cut_all(root, 0, 590)
    toml(root, "alignment_s = 600.0", "alignment_s = 60.0")


@case("heading-turned-150deg-off-the-track-near-180")
def _(root):
    df = rd(root, "heading")
    off = np.pi - float(df.yaw_rad[df.t_s > 600].median())
    df["yaw_rad"] = wrap(df.yaw_rad + off)
    wr(root, "heading", df)
    toml(
        root,
        "rpy_deg = [0.0, 0.0, 29.324648155956083]",
        f"rpy_deg = [0.0, 0.0, {math.degrees(float(wrap(0.5118 + off))):.6f}]",
    )


@case("heading-turned-off-the-track-in-0-360")
def _(root):
    df = rd(root, "heading")
    off = np.pi - float(df.yaw_rad[df.t_s > 600].median()) + np.pi
    df["yaw_rad"] = np.mod(df.yaw_rad + off, 2 * np.pi)
    wr(root, "heading", df)


@case(
    "heading-spin-fast"
)  # gyro-consistent? no: heading sensor spinning 10 rad/s (bad), wraps many times
def _(root):
    df = rd(root, "heading")
    df["yaw_rad"] = wrap(df.yaw_rad + 3.0 * df.t_s)
    wr(root, "heading", df)


@case("inclinometer-pitch-exactly-90")
def _(root):
    df = rd(root, "inclinometer")
    df.loc[df.index[-50:], "pitch_rad"] = np.pi / 2
    wr(root, "inclinometer", df)


@case("inclinometer-pitch-all-90")
def _(root):
    df = rd(root, "inclinometer")
    df["pitch_rad"] = np.pi / 2
    df["roll_rad"] = 0.0
    wr(root, "inclinometer", df)


@case("dvl-all-zero")
def _(root):
    df = rd(root, "dvl")
    df[["vx_m_s", "vy_m_s", "vz_m_s"]] = 0.0
    wr(root, "dvl", df)


@case("dvl-all-zero-zero_is_lost")
def _(root):
    df = rd(root, "dvl")
    df[["vx_m_s", "vy_m_s", "vz_m_s"]] = 0.0
    wr(root, "dvl", df)
    toml(root, "zero_is_lost = false", "zero_is_lost = true")


@case("dvl-1hz")
def _(root):
    keep(root, "dvl", list(range(0, len(rd(root, "dvl")), 3)))
    toml(root, "rate_hz = 3.0", "rate_hz = 1.0")


@case("dvl-50hz")
def _(root):
    df = rd(root, "dvl")
    t = np.arange(df.t_s.iloc[0], df.t_s.iloc[-1], 0.02)
    new = pd.DataFrame(
        {
            "t_s": t,
            **{
                c: np.interp(t, df.t_s, df[c]) + np.random.default_rng(1).normal(0, 0.01, t.size)
                for c in ["vx_m_s", "vy_m_s", "vz_m_s"]
            },
        }
    )
    wr(root, "dvl", new)
    toml(root, "rate_hz = 3.0", "rate_hz = 50.0")


def imu_rebin(root, r):
    df = rd(root, "imu")
    n = len(df) // r * r
    df = df.iloc[:n]
    cols = [c for c in df.columns if c != "t_s"]
    out = pd.DataFrame(
        {"t_s": df.t_s.values[r - 1 :: r], **{c: df[c].values.reshape(-1, r).sum(1) for c in cols}}
    )
    wr(root, "imu", out)
    toml(root, "rate_hz = 100.0", f"rate_hz = {100.0 / r}")


@case("imu-10hz")
def _(root):
    imu_rebin(root, 10)


@case("imu-1000hz")
def _(root):
    df = rd(root, "imu")
    cols = [c for c in df.columns if c != "t_s"]
    t = (df.t_s.values[:, None] - 0.01 + 0.001 * np.arange(1, 11)[None, :]).ravel()
    out = pd.DataFrame({"t_s": t, **{c: np.repeat(df[c].values / 10, 10) for c in cols}})
    wr(root, "imu", out)
    toml(root, "rate_hz = 100.0", "rate_hz = 1000.0")


@case("imu-nonuniform")
def _(root):
    df = rd(root, "imu")
    rng = np.random.default_rng(3)
    cols = [c for c in df.columns if c != "t_s"]
    grp = np.cumsum(rng.integers(1, 4, len(df)))  # steps of 1-3 samples
    g = np.repeat(np.arange(len(grp)), np.diff(np.concatenate([[0], grp])))[: len(df)]
    out = df.groupby(g).agg({"t_s": "last", **{c: "sum" for c in cols}}).reset_index(drop=True)
    wr(root, "imu", out)
    toml(root, "rate_hz = 100.0\n", "rate_hz = 50.0\nmax_gap_s = 0.1\n")


def duplicated(root, table, every):
    """Every ``every``-th row of ``table`` repeated after itself (stamps duplicated)."""
    df = rd(root, table)
    both = pd.concat([df, df.iloc[::every]]).sort_values("t_s", kind="stable")
    wr(root, table, both.reset_index(drop=True))


@case("heading-duplicate-stamps")
def _(root):
    duplicated(root, "heading", 7)


@case("gps-duplicate-stamps")
def _(root):
    duplicated(root, "gps", 5)


@case("dvl-duplicate-stamps")
def _(root):
    duplicated(root, "dvl", 5)


@case("heading-latency+60-stamped-60-late")
def _(root):
    df = rd(root, "heading")
    df["t_s"] += 60
    wr(root, "heading", df)
    sect(root, "heading", "latency_s = 60.0")


@case("heading-latency-60-stamped-60-early")
def _(root):
    df = rd(root, "heading")
    df["t_s"] -= 60
    wr(root, "heading", df)
    sect(root, "heading", "latency_s = -60.0")


@case("heading-latency+60-stamps-right")
def _(root):
    sect(root, "heading", "latency_s = 60.0")


def short_mission(root, seconds):
    """The demo cut to ``seconds`` from t = 700 s, started from a given state (no alignment)."""
    cut_all(root, 700, 700 + seconds)
    toml(root, 'mode = "alignment"', 'mode = "state"')
    toml(root, "alignment_s = 600.0\n", "")
    toml(root, "h_m = 0.0", "lat_deg = 26.8\nlon_deg = 56.0\nh_m = 0.0")
    toml(root, 'use = "init"', 'use = "aid"')


@case("mission-5s")
def _(root):
    short_mission(root, 5)


@case("mission-30s")
def _(root):
    short_mission(root, 30)


@case("gps-at-surface-depth-nan")
def _(root):
    df = rd(root, "depth")
    df["depth_m"] = np.nan
    df.loc[df.index[:3], "depth_m"] = 1.2
    wr(root, "depth", df)


@case("depth-all-nan")
def _(root):
    df = rd(root, "depth")
    df["depth_m"] = np.nan
    wr(root, "depth", df)


@case("lever-arms-100m")
def _(root):
    s = (root / "mission.toml").read_text()
    s = (
        s.replace("lever_arm_m = [1.0, 0.0, 1.5]", "lever_arm_m = [100.0, 100.0, 100.0]")
        .replace("lever_arm_m = [-2.0, 0.0, 1.2]", "lever_arm_m = [-100.0, 0.0, 100.0]")
        .replace("lever_arm_m = [0.0, 0.0, -5.0]", "lever_arm_m = [0.0, 100.0, -100.0]")
    )
    (root / "mission.toml").write_text(s)


for ax in "xyz":

    def f(root, ax=ax):
        df = rd(root, "imu")
        df[f"dtheta_{ax}_rad"] = 0.0
        wr(root, "imu", df)

    CASES[f"imu-gyro-{ax}-all-zero"] = f


@case("gps-constant-position")
def _(root):
    df = rd(root, "gps")
    df["lat_rad"] = df.lat_rad.iloc[0]
    df["lon_rad"] = df.lon_rad.iloc[0]
    wr(root, "gps", df)


@case("dvl-vz-nan")
def _(root):
    df = rd(root, "dvl")
    df["vz_m_s"] = np.nan
    wr(root, "dvl", df)


@case("no-rate_hz")
def _(root):
    s = (root / "mission.toml").read_text()
    s = re.sub(r"(\[sensors[^\]]*\][^\[]*?)rate_hz = [0-9.]+\n", r"\1", s)
    (root / "mission.toml").write_text(s)


@case("gps-use-off-depth-check")
def _(root):
    toml(root, 'use = "init"', 'use = "off"')
    toml(root, 'mode = "alignment"', 'mode = "alignment"')


@case("heading-degrees-in-rad-column")
def _(root):
    df = rd(root, "heading")
    df["yaw_rad"] = np.degrees(df.yaw_rad)
    wr(root, "heading", df)


@case("dvl-readings-stamped-identical-all")
def _(root):
    df = rd(root, "dvl")
    df = df.iloc[:5].copy()
    df["t_s"] = 700.0
    wr(root, "dvl", df)


@case("heading-1-reading-in-window-plus-inclinometer-3")
def _(root):
    keep(root, "heading", [800])
    keep(root, "inclinometer", [4000, 4001, 4002])


@case("imu-2-samples")
def _(root):
    keep(root, "imu", [70000, 70001])
    toml(root, 'mode = "alignment"', 'mode = "state"')
    toml(root, "alignment_s = 600.0\n", "")
    toml(root, "h_m = 0.0", "lat_deg = 26.8\nlon_deg = 56.0\nh_m = 0.0")
    toml(root, 'use = "init"', 'use = "aid"')


def gps_mirrored(root, seconds):
    """The GPS's longitude negated (a track mirrored), its fixes kept over the last ``seconds``
    only (docs/robustness.md, 'A GNSS track mirrored')."""
    df = rd(root, "gps")
    df["lon_rad"] = -df["lon_rad"]
    wr(root, "gps", df[df.t_s > df.t_s.iloc[-1] - seconds].reset_index(drop=True))


CASES["gps-lon-negated"] = lambda root: gps_mirrored(root, math.inf)
CASES["gps-lon-negated-last-240s-only"] = lambda root: gps_mirrored(root, 240.0)
CASES["gps-lon-negated-last-60s-only"] = lambda root: gps_mirrored(root, 60.0)


def run(name, f):
    root = OUT / name
    if root.exists():
        shutil.rmtree(root)
    shutil.copytree(DEMO, root)
    f(root)
    grab = Grab()
    lg = logging.getLogger("adaptnav")
    lg.addHandler(grab)
    lg.setLevel(logging.WARNING)
    t = time.time()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            load_mission(root)
        res = "OK"
    except MissionError as e:
        res = "MissionError: " + str(e)[:300]
    except Exception as e:
        tb = traceback.extract_tb(e.__traceback__)
        fr = [x for x in tb if "adaptnav" in x.filename][-1:]
        res = f"CRASH {type(e).__name__}: {str(e)[:150]} at " + "; ".join(
            f"{Path(x.filename).name}:{x.lineno} {x.name}" for x in fr
        )
    finally:
        lg.removeHandler(grab)
    dt = time.time() - t
    w = list(grab.msgs)
    shutil.rmtree(root)
    return res, dt, w


def imu_hole(root, t0, length, limit):
    toml(root, "rate_hz = 100.0\n", f"rate_hz = 100.0\nmax_gap_s = {limit}\n")
    df = rd(root, "imu")
    wr(root, "imu", df[(df.t_s <= t0) | (df.t_s > t0 + length)].reset_index(drop=True))


CASES["imu-hole-30s-under-way"] = lambda root: imu_hole(root, 750.0, 30.0, 60.0)
CASES["imu-hole-30s-at-rest"] = lambda root: imu_hole(root, 300.0, 30.0, 60.0)
CASES["imu-hole-5s-under-way"] = lambda root: imu_hole(root, 750.0, 5.0, 10.0)


def _aid_hole(root):
    for n in ["heading", "dvl", "gps", "depth", "inclinometer"]:
        df = rd(root, n)
        wr(root, n, df[(df.t_s <= 650) | (df.t_s > 850)].reset_index(drop=True))


CASES["all-aiding-hole-200s-under-way"] = _aid_hole


# Since 0.4.13: the inputs against the checks new in 0.4.13 (helper aud2's audit).


def imu_drop(root, keep_mask, limit):
    toml(root, "rate_hz = 100.0\n", f"rate_hz = 100.0\nmax_gap_s = {limit}\n")
    df = rd(root, "imu")
    wr(root, "imu", df[keep_mask(df)].reset_index(drop=True))


CASES["imu-hole-2s-at-start"] = lambda root: imu_drop(
    root, lambda df: (df.index == 0) | (df.index > 200), 10.0
)
CASES["imu-hole-2s-at-end"] = lambda root: imu_drop(
    root, lambda df: (df.index < len(df) - 201) | (df.index == len(df) - 1), 10.0
)
CASES["imu-holes-back-to-back"] = lambda root: imu_drop(
    root,
    lambda df: ~(((df.t_s > 750) & (df.t_s < 751.995)) | ((df.t_s > 752.005) & (df.t_s < 754))),
    10.0,
)


@case("imu-hole-3000s-max-gap-huge")
def _(root):
    toml(root, "rate_hz = 100.0\n", "rate_hz = 100.0\nmax_gap_s = 1e9\n")
    for n in ["imu", "heading", "dvl", "gps", "depth", "inclinometer", "truth"]:
        df = rd(root, n)
        df.loc[df.t_s > 700, "t_s"] += 3000
        wr(root, n, df)


@case("imu-hole-1.5-periods")
def _(root):
    df = rd(root, "imu")
    df = df.drop(index=75000).reset_index(drop=True)
    df.loc[75000, "t_s"] -= 0.005
    wr(root, "imu", df)


@case("imu-nan-rows-around-hole")
def _(root):
    toml(root, "rate_hz = 100.0\n", "rate_hz = 100.0\nmax_gap_s = 10.0\n")
    df = rd(root, "imu")
    df = df[(df.t_s <= 750) | (df.t_s > 752)].reset_index(drop=True)
    i = int(np.searchsorted(df.t_s.values, 750.0))
    df.loc[i - 2 : i + 2, "dtheta_x_rad"] = np.nan
    wr(root, "imu", df)


def to_rates(root):
    df = rd(root, "imu")
    dt = 0.01
    out = pd.DataFrame({"t_s": df.t_s - dt / 2})
    for a, b in [("dtheta", "gyro"), ("dvel", "accel")]:
        for ax in "xyz":
            unit = "rad_s" if b == "gyro" else "m_s2"
            src = f"{a}_{ax}_rad" if a == "dtheta" else f"{a}_{ax}_m_s"
            out[f"{b}_{ax}_{unit}"] = df[src] / dt
    wr(root, "imu", out)
    toml(root, 'format = "increments"', 'format = "rates"')


CASES["imu-rates"] = to_rates


def rates_drop(root, keep_mask, limit):
    to_rates(root)
    imu_drop(root, keep_mask, limit)


CASES["imu-rates-hole-at-start"] = lambda root: rates_drop(
    root, lambda df: (df.index == 0) | (df.index > 200), 10.0
)
CASES["imu-rates-hole-at-end"] = lambda root: rates_drop(
    root, lambda df: (df.index < len(df) - 201) | (df.index == len(df) - 1), 10.0
)
CASES["imu-rates-holes-back-to-back"] = lambda root: rates_drop(
    root,
    lambda df: ~(((df.t_s > 750) & (df.t_s < 751.99)) | ((df.t_s > 752.0) & (df.t_s < 754))),
    10.0,
)
CASES["imu-rates-hole-60s"] = lambda root: rates_drop(
    root, lambda df: (df.t_s < 750) | (df.t_s > 810), 100.0
)
CASES["imu-rates-hole-1s-max-gap-huge"] = lambda root: rates_drop(
    root, lambda df: (df.t_s < 750) | (df.t_s > 751), 1e9
)


@case("imu-accel-x-constant-throughout")
def _(root):
    df = rd(root, "imu")
    df["dvel_x_m_s"] = float(df.dvel_x_m_s.mean())
    wr(root, "imu", df)


@case("imu-gyro-y-constant-nonzero-throughout")
def _(root):
    df = rd(root, "imu")
    df["dtheta_y_rad"] = 1e-7
    wr(root, "imu", df)


def quantised(root, qg, qa):
    df = rd(root, "imu")
    for c in ["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]:
        df[c] = np.round(df[c] / qg) * qg
    for c in ["dvel_x_m_s", "dvel_y_m_s", "dvel_z_m_s"]:
        df[c] = np.round(df[c] / qa) * qa
    wr(root, "imu", df)


CASES["imu-quantised-1e-6rad-1e-4ms"] = lambda root: quantised(root, 1e-6, 1e-4)
CASES["imu-quantised-1e-5rad-1e-3ms"] = lambda root: quantised(root, 1e-5, 1e-3)
CASES["imu-quantised-1e-4rad-1e-2ms"] = lambda root: quantised(root, 1e-4, 1e-2)


def stuck_for(root, col, t0, seconds):
    df = rd(root, "imu")
    m = (df.t_s >= t0) & (df.t_s <= t0 + seconds + 1e-9)
    df.loc[m, col] = df.loc[m, col].iloc[0]
    wr(root, "imu", df)


CASES["imu-gyro-z-stuck-exactly-5s"] = lambda root: stuck_for(root, "dtheta_z_rad", 750.0, 5.0)
CASES["imu-gyro-z-stuck-4.99s"] = lambda root: stuck_for(root, "dtheta_z_rad", 750.0, 4.99)
CASES["imu-gyro-z-stuck-5s-at-start"] = lambda root: stuck_for(root, "dtheta_z_rad", 0.0, 5.0)
CASES["imu-gyro-z-stuck-5s-at-end"] = lambda root: stuck_for(root, "dtheta_z_rad", 901.0, 6.0)


@case("imu-gyro-x-noise-only-last-100s")
def _(root):
    df = rd(root, "imu")
    m = df.t_s > 806
    df.loc[m, "dtheta_x_rad"] = np.random.default_rng(1).normal(0, 2e-6, int(m.sum()))
    wr(root, "imu", df)


@case("heading-declination-0-360")
def _(root):
    df = rd(root, "heading")
    df["yaw_rad"] = np.mod(df.yaw_rad - math.radians(2.0), 2 * np.pi)
    wr(root, "heading", df)
    sect(root, "heading", "declination_deg = 2.0")


@case("heading-declination-not-set-3deg")
def _(root):
    df = rd(root, "heading")
    df["yaw_rad"] = wrap(df.yaw_rad - math.radians(3.0))
    wr(root, "heading", df)


def dvl_lost(root, share, zero_is_lost):
    df = rd(root, "dvl")
    n = int(len(df) * share)
    df.loc[df.index[-n:], ["vx_m_s", "vy_m_s", "vz_m_s"]] = 0.0
    wr(root, "dvl", df)
    if zero_is_lost:
        toml(root, "zero_is_lost = false", "zero_is_lost = true")


CASES["dvl-zeros-last-90pct"] = lambda root: dvl_lost(root, 0.9, False)
CASES["dvl-zeros-last-90pct-zero_is_lost"] = lambda root: dvl_lost(root, 0.9, True)
CASES["dvl-zeros-last-30pct"] = lambda root: dvl_lost(root, 0.3, False)


@case("dvl-constant-with-spikes")
def _(root):
    df = rd(root, "dvl")
    df[["vx_m_s", "vy_m_s", "vz_m_s"]] = [1.0, 0.0, 0.0]
    df.loc[df.index[::50], "vx_m_s"] = 5.0
    wr(root, "dvl", df)


@case("dvl-3-readings-with-spike")
def _(root):
    keep(root, "dvl", [2000, 2001, 2002])
    df = rd(root, "dvl")
    df.loc[1, "vx_m_s"] = 20.0
    wr(root, "dvl", df)


@case("gps-3-fixes-lon-negated")
def _(root):
    keep(root, "gps", [800, 801, 802])
    df = rd(root, "gps")
    df["lon_rad"] = -df["lon_rad"]
    wr(root, "gps", df)


@case("gps-lat-negated")
def _(root):
    df = rd(root, "gps")
    df["lat_rad"] = -df["lat_rad"]
    wr(root, "gps", df)


@case("gps-all-fixes-at-rest-lon-negated")
def _(root):
    df = rd(root, "gps")
    df["lon_rad"] = -df["lon_rad"]
    wr(root, "gps", df[df.t_s < 590].reset_index(drop=True))


@case("gps-nan-rows-and-inf")
def _(root):
    df = rd(root, "gps")
    df.loc[df.index[::3], "lat_rad"] = np.nan
    df.loc[df.index[700], "lon_rad"] = np.inf
    wr(root, "gps", df)


@case("gps-antenna-lever-100m-up")
def _(root):
    toml(root, "lever_arm_m = [0.0, 0.0, -5.0]", "lever_arm_m = [0.0, 0.0, -100.0]")


@case("gps-period-nan-no-rate")
def _(root):
    s = (root / "mission.toml").read_text()
    s = s.replace("rate_hz = 1.0\nlever_arm_m = [0.0, 0.0, -5.0]", "lever_arm_m = [0.0, 0.0, -5.0]")
    (root / "mission.toml").write_text(s)
    df = rd(root, "gps")
    df["lon_rad"] = -df["lon_rad"]
    wr(root, "gps", df)


@case("at-rest-whole-mission-gps-lon-negated")
def _(root):
    cut_all(root, 0, 590)
    toml(root, "alignment_s = 600.0", "alignment_s = 60.0")
    df = rd(root, "gps")
    df["lon_rad"] = -df["lon_rad"]
    wr(root, "gps", df)


@case("depth-negative-all-surface")
def _(root):
    df = rd(root, "depth")
    df["depth_m"] = df.depth_m - 3.0
    wr(root, "depth", df)


@case("gps-one-lon-inf")
def _(root):
    df = rd(root, "gps")
    df.loc[df.index[700], "lon_rad"] = np.inf
    wr(root, "gps", df)


@case("gps-one-lat-inf")
def _(root):
    df = rd(root, "gps")
    df.loc[df.index[700], "lat_rad"] = np.inf
    wr(root, "gps", df)


@case("heading-one-inf-declination")
def _(root):
    df = rd(root, "heading")
    df.loc[df.index[700], "yaw_rad"] = -np.inf
    wr(root, "heading", df)
    sect(root, "heading", "declination_deg = 2.0")


@case("heading-one-inf")
def _(root):
    df = rd(root, "heading")
    df.loc[df.index[700], "yaw_rad"] = np.inf
    wr(root, "heading", df)


@case("dvl-one-inf")
def _(root):
    df = rd(root, "dvl")
    df.loc[df.index[2000], "vy_m_s"] = np.inf
    wr(root, "dvl", df)


@case("depth-one-inf")
def _(root):
    df = rd(root, "depth")
    df.loc[df.index[700], "depth_m"] = np.inf
    wr(root, "depth", df)


for t_hole, length in [(700, 60), (700, 100), (700, 150), (740, 60), (650, 150), (800, 60)]:
    CASES[f"imu-hole-{length}s-at-{t_hole}s-under-way"] = (
        lambda root, t_hole=t_hole, length=length: imu_hole(root, t_hole, length, 400.0)
    )


for t_fail in (780, 800, 830, 860):
    for col in ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dvel_x_m_s"):

        def f(root, t_fail=t_fail, col=col):
            df = rd(root, "imu")
            m = df.t_s > t_fail
            sd = 2e-6 if "theta" in col else 6e-5
            df.loc[m, col] = np.random.default_rng(1).normal(0, sd, int(m.sum()))
            wr(root, "imu", df)

        CASES[f"imu-{col}-noise-only-from-{t_fail}"] = f


if __name__ == "__main__":
    pat = sys.argv[3] if len(sys.argv) > 3 else ""
    for name, f in CASES.items():
        if pat and not re.search(pat, name):
            continue
        res, dt, w = run(name, f)
        print(f"## {name} [{dt:.1f}s]\n   {res}")
        for m in w:
            print("   WARN:", m[:250])
        sys.stdout.flush()
