"""Bad input never gives a traceback or a silently wrong answer (issue 12, docs/robustness.md).

One test per case found on the old code (each failed there), through the CLI as a user meets
it, on a tiny simulated mission (:mod:`helpers.badinput`). The fuzz test is
tests/integration/test_fuzz_input.py.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from helpers import badinput
from helpers.cli import cli, error_line
from helpers.run_folders import reseal, without_digests

# --- output folders -------------------------------------------------------------------------


@pytest.fixture()
def no_run(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if a filter runs: an output problem must be found before the work."""
    from adaptnav import api

    def refuse(*_args: Any, **_kwargs: Any) -> None:
        raise AssertionError("the filter ran before the output folder was checked")

    monkeypatch.setattr(api, "run", refuse)


def test_out_that_is_a_file_is_refused_before_the_run(
    mission: Path, tmp_path: Path, no_run: None
) -> None:
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    line = error_line(cli("run", mission, "--out", blocker))
    assert str(blocker) in line and "is a file, not a folder" in line
    line = error_line(cli("run", mission, "--out", blocker / "sub" / "run"))
    assert f"{blocker} is a file" in line
    assert blocker.read_text() == "x"


def test_out_in_a_folder_that_cannot_be_written(
    mission: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, no_run: None
) -> None:
    real_mkdir = Path.mkdir

    def mkdir(self: Path, *args: Any, **kwargs: Any) -> None:
        if self.name.startswith(".run.tmp-"):  # what a read-only parent does (root ignores chmod)
            raise PermissionError(13, "Permission denied", str(self))
        real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", mkdir)
    line = error_line(cli("run", mission, "--out", tmp_path / "ro" / "run"))
    assert "cannot write in" in line and "Permission denied" in line
    assert not (tmp_path / "ro").exists()  # the parents it made are removed again


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a non-root POSIX user")
def test_out_in_a_read_only_folder(mission: Path, tmp_path: Path, no_run: None) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        line = error_line(cli("run", mission, "--out", ro / "run"))
    finally:
        ro.chmod(0o755)
    assert "cannot write in" in line


def test_reused_out_is_refused_and_force_replaces_it_whole(mission: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert cli("run", mission, "--out", out).exit_code == 0
    assert (out / "truth.parquet").is_file()
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(toml.replace('[truth]\nfile = "truth.csv"\n', ""))
    line = error_line(cli("run", mission, "--out", out))
    assert "not empty" in line and "--force" in line
    assert cli("run", mission, "--out", out, "--force").exit_code == 0
    # No file of the earlier run survives: evaluate cannot score against the old truth.
    assert not (out / "truth.parquet").exists()
    assert "no reference" in error_line(cli("evaluate", out))
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_a_failed_run_leaves_the_old_folder_and_no_temporary_one(
    mission: Path, tmp_path: Path
) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "keep.txt").write_text("old")
    (mission / "mission.toml").write_text("[mission]\n")
    assert "mission.toml" in error_line(cli("run", mission, "--out", out, "--force"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mission", "run"]
    assert (out / "keep.txt").read_text() == "old"


def test_force_never_replaces_the_input(mission: Path) -> None:
    line = error_line(cli("run", mission, "--out", mission, "--force"))
    assert "holds the input" in line
    assert (mission / "mission.toml").is_file()


@pytest.mark.parametrize(
    "args",
    [
        ["simulate", "demo"],
        ["compare", "{mission}"],
        ["demo", "--preset", "demo"],
        ["import", "akit", "-n", "1", "--src", "{tmp}"],
        ["import", "rtklib", "--pos", "{tmp}/x.pos", "--imu", "{tmp}/x.csv"],
        ["sweep", "seeds", "demo", "--seeds", "1", "--cache", "{tmp}/cache"],
    ],
    ids=lambda a: " ".join(a[:2]),
)
def test_every_folder_command_refuses_a_non_empty_out(
    args: list[str], mission: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    filled = [a.format(mission=mission, tmp=tmp_path) for a in args]
    line = error_line(cli(*filled, "--out", out))
    assert str(out) in line and "not empty" in line
    assert sorted(p.name for p in out.iterdir()) == ["old.txt"]


def test_simulate_with_force_replaces_the_folder(tmp_path: Path) -> None:
    out = tmp_path / "m"
    out.mkdir()
    (out / "stale.csv").write_text("t_s\n")
    assert cli("simulate", "demo", "--out", out, "--force").exit_code == 0
    assert (out / "mission.toml").is_file() and not (out / "stale.csv").exists()


# --- table paths ------------------------------------------------------------------------------


def _point(mission: Path, key: str, target: str) -> None:
    """Set ``[sensors.<key>] file`` (or the IMU's, key "imu") to ``target`` in mission.toml."""
    toml = (mission / "mission.toml").read_text()
    old = f'file = "{key}.csv"'
    assert old in toml
    (mission / "mission.toml").write_text(toml.replace(old, f'file = "{target}"', 1))


@pytest.mark.parametrize("where", ["../depth.csv", "{abs}", "sub/../../depth.csv"])
def test_table_paths_outside_the_mission_folder_are_errors(
    mission: Path, tmp_path: Path, where: str
) -> None:
    (mission / "depth.csv").rename(tmp_path / "depth.csv")
    target = where.format(abs=tmp_path / "depth.csv")
    _point(mission, "depth", target)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "sensors.depth.file" in line and target in line
    assert "absolute path" in line or "out of the mission folder" in line


def test_a_symbolic_link_out_of_the_mission_folder_is_an_error(
    mission: Path, tmp_path: Path
) -> None:
    (mission / "depth.csv").rename(tmp_path / "depth.csv")
    (mission / "depth.csv").symlink_to(tmp_path / "depth.csv")
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: depth.csv: leads to") and "outside the mission folder" in line
    # a link that stays inside is fine
    (mission / "depth.csv").unlink()
    (mission / "data").mkdir()
    (tmp_path / "depth.csv").rename(mission / "data" / "depth.csv")
    (mission / "depth.csv").symlink_to(mission / "data" / "depth.csv")
    assert cli("run", mission, "--out", tmp_path / "run").exit_code == 0


def test_a_symbolic_link_loop_is_a_clear_error(mission: Path, tmp_path: Path) -> None:
    (mission / "loop.csv").symlink_to(mission / "loop2.csv")
    (mission / "loop2.csv").symlink_to(mission / "loop.csv")
    _point(mission, "depth", "loop.csv")
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "loop.csv" in line and "symbolic link loop" in line


# --- column types -----------------------------------------------------------------------------


def test_a_bool_column_is_an_error_not_zeros_and_ones(mission: Path, tmp_path: Path) -> None:
    dvl = badinput.read(mission, "dvl")
    dvl["vx_m_s"] = dvl["vx_m_s"] > 0.5
    dvl.to_parquet(mission / "dvl.parquet", index=False)
    (mission / "dvl.csv").unlink()
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(toml.replace('"dvl.csv"', '"dvl.parquet"'))
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "dvl.parquet, vx_m_s: a true/false column" in line
    # the same in a CSV (pandas reads True/False cells as bools)
    dvl.to_csv(mission / "dvl.csv", index=False)
    (mission / "mission.toml").write_text(toml)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "dvl.csv, vx_m_s: a true/false column" in line


# --- a file cut short -------------------------------------------------------------------------


def test_a_number_cut_short_on_the_last_line_is_dropped_not_read(
    mission: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import pandas as pd

    dvl = badinput.read(mission, "dvl")
    dvl = dvl[[c for c in dvl.columns if c != "vx_m_s"] + ["vx_m_s"]]  # a long number last
    text = dvl.to_csv(index=False)
    n_rows = len(dvl)
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    cut = text.rstrip("\n")[:-6]  # the file ends inside the last line's last number
    assert cut.rsplit("\n", 1)[1].count(",") == last.count(",")  # all the fields are there
    (mission / "dvl.csv").write_text(cut)
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    assert f"dvl.csv line {n_rows + 1}" in caplog.text  # logged with file and line
    repairs = pd.read_parquet(tmp_path / "run" / "repairs.parquet")
    (r,) = repairs[repairs["file"] == "dvl.csv"].itertuples()
    assert r.line == n_rows + 1 and r.action == "dropped truncated last line"
    ledger = pd.read_parquet(tmp_path / "run" / "ledger.parquet")
    dvl = ledger[ledger["sensor"] == "dvl"]
    assert sorted(dvl["row"]) == list(range(n_rows))  # every line has its fate
    (fate,) = dvl[dvl["row"] == n_rows - 1].itertuples()
    assert fate.fate == "dropped" and "truncated" in fate.reason


def test_a_cut_last_line_of_a_late_stamped_sensor_is_in_the_ledger_at_its_reading_time(
    mission: Path,
) -> None:
    """With ``latency_s`` every ledger time is ``t_s - latency_s``: the cut line's too (up to
    0.4.8 it kept its stamp, 0.25 s after where its neighbours' times put it)."""
    from adaptnav.mission import load_mission

    text = (mission / "mission.toml").read_text()
    text = text.replace('file = "dvl.csv"', 'file = "dvl.csv"\nlatency_s = 0.25')
    (mission / "mission.toml").write_text(text)
    dvl = badinput.read(mission, "dvl")
    t_last = float(dvl["t_s"].iloc[-1])
    (mission / "dvl.csv").write_text(dvl.to_csv(index=False).rstrip("\n")[:-3])
    m = load_mission(mission)
    (cut,) = [d for d in m.dropped if d.sensor == "dvl"]
    assert cut.row == len(dvl) - 1 and "truncated" in cut.reason
    assert cut.t == pytest.approx(t_last - 0.25, abs=1e-12)
    assert m.sensors["dvl"].t[-1] == pytest.approx(float(dvl["t_s"].iloc[-2]) - 0.25, abs=1e-12)


def test_a_last_line_without_line_break_but_complete_is_kept(mission: Path, tmp_path: Path) -> None:
    """A fixed-width file whose last line is whole: no line break at the end is not enough."""
    depth = badinput.read(mission, "depth")
    text = depth.to_csv(index=False, float_format="%.6f")
    (mission / "depth.csv").write_text(text.rstrip("\n"))
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0 and "depth.csv" not in res.output, res.output


# --- plausibility -----------------------------------------------------------------------------


def _ledger(run: Path) -> Any:
    import pandas as pd

    return pd.read_parquet(run / "ledger.parquet")


def _fate(ledger: Any, sensor: str, row: int) -> tuple[str, str]:
    (r,) = ledger[(ledger["sensor"] == sensor) & (ledger["row"] == row)].itertuples()
    return str(r.fate), str(r.reason)


def test_implausible_readings_are_dropped_with_the_reason(
    mission: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    dvl, depth = badinput.read(mission, "dvl"), badinput.read(mission, "depth")
    k_dvl, k_depth = len(dvl) - 20, len(depth) - 10  # under way, after the alignment
    dvl.loc[k_dvl, "vx_m_s"] = 1e30
    depth.loc[k_depth, "depth_m"] = 1e20
    badinput.write(mission, "dvl", dvl)
    badinput.write(mission, "depth", depth)
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    ledger = _ledger(tmp_path / "run")
    fate, reason = _fate(ledger, "dvl", k_dvl)
    assert fate == "dropped" and reason.startswith("implausible: vx_m_s = 1e+30 outside [-20, 20]")
    fate, reason = _fate(ledger, "depth", k_depth)
    assert fate == "dropped" and reason.startswith("implausible: depth_m = 1e+20")
    assert "dropped (implausible: vx_m_s" in caplog.text  # logged


def test_a_depth_of_1e300_no_longer_breaks_the_filter(mission: Path, tmp_path: Path) -> None:
    depth = badinput.read(mission, "depth")
    depth.loc[len(depth) - 10, "depth_m"] = 1e300
    badinput.write(mission, "depth", depth)
    res = cli("run", mission, "--filter", "meskf", "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    assert _fate(_ledger(tmp_path / "run"), "depth", len(depth) - 10)[0] == "dropped"


def test_a_gnss_latitude_out_of_range_does_not_reach_the_alignment(
    mission: Path, source: Path, tmp_path: Path
) -> None:
    import pandas as pd

    gps = badinput.read(mission, "gps")
    gps.loc[3, "lat_rad"] = 2.0  # inside the alignment window
    badinput.write(mission, "gps", gps)
    assert cli("run", mission, "--out", tmp_path / "bad").exit_code == 0
    assert _fate(_ledger(tmp_path / "bad"), "gps", 3)[1].startswith("implausible: lat_rad = 2")
    assert cli("run", source, "--out", tmp_path / "good").exit_code == 0
    bad = pd.read_parquet(tmp_path / "bad" / "solution.parquet")
    good = pd.read_parquet(tmp_path / "good" / "solution.parquet")
    # the alignment position is the mean of the other fixes: about 1/60 of 2 rad away if not
    assert abs(bad["lat_rad"].iloc[0] - good["lat_rad"].iloc[0]) < 1e-6


def test_a_whole_column_outside_its_range_is_an_error(mission: Path, tmp_path: Path) -> None:
    gps = badinput.read(mission, "gps")
    gps["lat_rad"] = gps["lat_rad"] * 180.0 / 3.141592653589793  # degrees named as radians
    badinput.write(mission, "gps", gps)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "gps.csv line 2, lat_rad: every value of the column is outside" in line
    assert "wrong units" in line


def test_an_inclinometer_in_degrees_is_an_error_not_a_run_100_m_off(
    mission: Path, tmp_path: Path
) -> None:
    """Roll and pitch in degrees named as radians: the readings above 90 are implausible and
    dropped, the small ones pass the limits. Before, the guard rejected those, its lockout
    inflated P until it took them, and the run ended 103 m RMS off (4.6 m on the clean
    mission) with exit 0. Now the mean over the static window disagrees with the levelling."""
    incl = badinput.read(mission, "inclinometer")
    incl[["roll_rad", "pitch_rad"]] *= 180.0 / 3.141592653589793
    badinput.write(mission, "inclinometer", incl)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: inclinometer.csv, roll_rad: over the static alignment window")
    assert "degrees read as radians" in line and "mounting_rpy_deg" in line


def test_a_sensor_in_milliseconds_is_an_error_not_a_run_without_it(
    mission: Path, tmp_path: Path
) -> None:
    """DVL stamps in ms beside an IMU in s: every reading lies after the IMU's last sample.
    Before, each went to the ledger and the run went on without the DVL, exit 0."""
    dvl = badinput.read(mission, "dvl")
    dvl["t_s"] *= 1000.0
    badinput.write(mission, "dvl", dvl)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith(
        f"error: dvl.csv: none of the {len(dvl)} readings of sensor 'dvl' lies within the "
        "IMU's time span (0 .. "
    )
    assert "another time unit (ms, µs?)" in line


def test_a_dvl_turned_backwards_is_a_warning_not_a_quiet_run(mission: Path, tmp_path: Path) -> None:
    """A DVL turned 180° in yaw but configured as ahead (x and y negated) passes every check
    at load. Before, the robust filter took 124 of its 125 readings with R̂ pinned at its
    ceiling and the run ended with exit 0 and not a word (velocity NEES 57). Now the run, its
    summary.json and evaluate say which sensor and when (api/diagnosis.py); the clean mission
    gives no warning."""
    clean = cli("run", mission, "--out", tmp_path / "clean")
    assert clean.exit_code == 0 and "warning:" not in clean.output, clean.output
    summary = json.loads((tmp_path / "clean" / "summary.json").read_text())
    assert summary["meta"]["warnings"] == []
    dvl = badinput.read(mission, "dvl")
    dvl[["vx_m_s", "vy_m_s"]] *= -1.0
    badinput.write(mission, "dvl", dvl)
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    lines = [line for line in res.output.splitlines() if line.startswith("warning:")]
    assert len(lines) == 1, res.output
    assert lines[0].startswith("warning: dvl: at odds with the INS and the other sensors from t = ")
    assert "mounting_rpy_deg" in lines[0]
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    (w,) = summary["meta"]["warnings"]
    assert w["sensor"] == "dvl" and w["worst_share"] > 0.9
    ev = cli("evaluate", tmp_path / "run", "--json", "--quiet")
    assert json.loads(ev.stdout)["warnings"] == [w["message"]]


def test_an_inclinometer_mounted_off_needs_its_mounting(mission: Path, tmp_path: Path) -> None:
    """An inclinometer whose readings are 3° off in roll (its mounting) is an error until
    ``mounting_rpy_deg`` says so; then the run goes through (roll of C_ns = C_nb C_bs)."""
    incl = badinput.read(mission, "inclinometer")
    incl["roll_rad"] += 3.0 * 3.141592653589793 / 180.0
    badinput.write(mission, "inclinometer", incl)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "inclinometer.csv, roll_rad" in line
    assert float(line.split(" rad, ")[1].split("°")[0]) == pytest.approx(3.0, abs=0.1)
    toml = mission / "mission.toml"
    text = toml.read_text()
    head = '[sensors.inclinometer]\nkind = "inclinometer"\n'
    assert head in text
    toml.write_text(text.replace(head, head + "mounting_rpy_deg = [3.0, 0.0, 0.0]\n"))
    assert cli("run", mission, "--out", tmp_path / "run").exit_code == 0


GEOID_M = 45.0
"""The water surface's height above the ellipsoid in the tests below (a geoid undulation)."""


def _ellipsoidal_gnss(mission: Path, surface: str | None) -> None:
    """The tiny mission as a receiver with heights would log it: its GNSS (antenna 5 m above the
    IMU) with ellipsoidal heights, the sea's surface GEOID_M above the ellipsoid, the reference
    in the same heights; the depth meter still reads from the surface. ``surface``: the depth
    meter's ``surface_h_m`` as TOML, or None."""
    truth, gps = badinput.read(mission, "truth"), badinput.read(mission, "gps")
    truth["h_m"] += GEOID_M
    gps["h_m"] = np.interp(gps["t_s"], truth["t_s"], truth["h_m"]) + 5.0  # level enough
    badinput.write(mission, "truth", truth)
    badinput.write(mission, "gps", gps)
    toml = mission / "mission.toml"
    text = toml.read_text()
    for head, line in (
        ('[sensors.gps]\nkind = "gnss"\n', "use_height = true\n"),
        ('[sensors.depth]\nkind = "depth"\n', f"surface_h_m = {surface}\n" if surface else ""),
    ):
        assert head in text
        text = text.replace(head, head + line)
    toml.write_text(text)


def test_a_depth_beside_ellipsoidal_gnss_heights_needs_the_surface(
    mission: Path, tmp_path: Path
) -> None:
    """GNSS heights are ellipsoidal, a depth is measured from the sea's surface, which lies near
    the geoid. Before, the alignment took its height from the GNSS, the depth meter said 45 m
    otherwise, the guard rejected most of its readings until the lockout let them in, and the
    run ended 24 m RMS off (4.6 m with the surface known) with exit 0 and only the warning
    that the depth meter was at odds with the rest. Now the mismatch at rest
    is an error that gives the height to set; set, or measured with "auto", the run is as
    good as the clean one."""
    _ellipsoidal_gnss(mission, None)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: depth.csv, depth_m: over the static alignment window")
    given = float(line.split("surface_h_m = ")[2].split(",")[0])
    assert given == pytest.approx(GEOID_M, abs=1.0), line
    rmse = {}
    for name, surface in (("given", f"{given}"), ("auto", '"auto"')):
        copy = badinput.copy_mission(mission, tmp_path / name)
        text = (copy / "mission.toml").read_text()
        head = '[sensors.depth]\nkind = "depth"\n'
        (copy / "mission.toml").write_text(text.replace(head, f"{head}surface_h_m = {surface}\n"))
        assert cli("run", copy, "--out", tmp_path / f"run-{name}").exit_code == 0
        ev = json.loads(cli("evaluate", tmp_path / f"run-{name}", "--json", "-q").stdout)
        rmse[name] = ev["rmse_m"]
    summary = json.loads((tmp_path / "run-auto" / "summary.json").read_text())
    assert summary["meta"]["surface_h_m"]["depth"] == pytest.approx(given, abs=0.01)
    assert rmse["given"] < 5.0 and rmse["auto"] < 5.0, rmse


def test_surface_h_m_is_checked_and_only_for_a_depth_meter(mission: Path, tmp_path: Path) -> None:
    toml = mission / "mission.toml"
    text = toml.read_text()
    for head, line, words in (
        ('[sensors.dvl]\nkind = "dvl"\n', "surface_h_m = 1.0", "only for depth sensors"),
        ('[sensors.depth]\nkind = "depth"\n', "surface_h_m = 1e6", "within [-1000, 10000] m"),
        ('[sensors.depth]\nkind = "depth"\n', 'surface_h_m = "geoid"', "sensors.depth.surface_h_m"),
    ):
        toml.write_text(text.replace(head, f"{head}{line}\n"))
        assert words in error_line(cli("run", mission, "--out", tmp_path / "run")), line
    # "auto" with no GNSS heights at rest to measure it by
    head = '[sensors.depth]\nkind = "depth"\n'
    toml.write_text(text.replace(head, f'{head}surface_h_m = "auto"\n'))
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert 'surface_h_m = "auto" measures the water surface at rest' in line
    from adaptnav.api import Stream
    from adaptnav.mission import MissionError

    with pytest.raises(MissionError, match='surface_h_m = "auto": a stream needs'):
        Stream(mission)


def test_limits_are_set_per_sensor(mission: Path, tmp_path: Path) -> None:
    toml = (mission / "mission.toml").read_text()
    dvl_section = '[sensors.dvl]\nkind = "dvl"\n'
    assert dvl_section in toml
    (mission / "mission.toml").write_text(
        toml.replace(dvl_section, dvl_section + "limits = { vz_m_s = [-0.05, 0.05] }\n")
    )
    assert cli("run", mission, "--out", tmp_path / "run").exit_code == 0
    ledger = _ledger(tmp_path / "run")
    reasons = ledger.loc[ledger["sensor"] == "dvl", "reason"]
    assert reasons.str.startswith("implausible: vz_m_s").sum() > 0
    for bad, words in (
        ("limits = [1.0, -1.0]", "min < max"),
        ("limits = { depth_m = [0.0, 1.0] }", "not a column of a dvl sensor"),
        ('limits = "wide"', "sensors.dvl.limits"),
    ):
        (mission / "mission.toml").write_text(toml.replace(dvl_section, dvl_section + bad + "\n"))
        line = error_line(cli("run", mission, "--out", tmp_path / "r2"))
        assert "mission.toml" in line and words in line, line


# --- configuration ----------------------------------------------------------------------------


@pytest.mark.parametrize("key", ["arw", "vrw"])
def test_zero_white_noise_is_an_error(mission: Path, tmp_path: Path, key: str) -> None:
    toml = (mission / "mission.toml").read_text()
    start = toml.index(f"{key} = [") + len(f"{key} = [")
    end = toml.index(",", start)
    (mission / "mission.toml").write_text(toml[:start] + "0" + toml[end:])
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "mission.toml" in line and f"imu.noise.{key}: value 0" in line and "> 0" in line


# --- failures inside the computation ----------------------------------------------------------


def test_no_valid_gnss_fix_in_the_alignment_window_is_a_clear_error(
    mission: Path, tmp_path: Path
) -> None:
    gps = badinput.read(mission, "gps")
    gps.loc[gps["t_s"] <= 25.0, ["lat_rad", "lon_rad"]] = float("nan")
    badinput.write(mission, "gps", gps)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: gps.csv: no valid fix of sensor 'gps' inside the static")
    assert not (tmp_path / "run").exists()


def test_a_reading_that_would_break_the_filter_is_rejected_or_a_clear_error(
    mission: Path, tmp_path: Path
) -> None:
    """With the limits opened, a depth of 1e300 reaches the filter (it used to end in a
    LinAlgError traceback). The guard rejects it; with the guard off, the filter's state goes
    non-finite and the run stops with an error naming the filter and the time."""
    depth = badinput.read(mission, "depth")
    row = len(depth) - 10
    depth.loc[row, "depth_m"] = 1e300
    badinput.write(mission, "depth", depth)
    toml = (mission / "mission.toml").read_text()
    section = '[sensors.depth]\nkind = "depth"\n'
    (mission / "mission.toml").write_text(toml.replace(section, section + "limits = [-inf, inf]\n"))
    res = cli("run", mission, "--filter", "meskf", "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    ledger = pd.read_parquet(tmp_path / "run" / "ledger.parquet")
    fate = ledger[(ledger["sensor"] == "depth") & (ledger["row"] == row)].iloc[0]
    assert (fate["fate"], fate["reason"]) == ("rejected", "guard chi2 (nominal R)")
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(
        toml.replace("[filter]\n", "[filter]\nguard_probability = 0.0\n")
        if "[filter]" in toml
        else toml + "\n[filter]\nguard_probability = 0.0\n"
    )
    res = cli("run", mission, "--filter", "meskf", "--out", tmp_path / "run2")
    line = error_line(res)
    assert "the meskf filter broke down" in line and "at t = " in line
    assert "mission.toml" in line


def test_a_diverged_state_is_an_error_not_a_solution_of_nan(mission: Path, tmp_path: Path) -> None:
    """An initial velocity of 1e12 m/s (state mode): the nominal state overflows within
    seconds. The run stops with exit 2 naming the time (up to 0.4.4 it ran on, with a finite P,
    and wrote a solution mostly NaN, exit 0; compare then crashed in matplotlib). Since 0.4.8
    it stops earlier, at a latitude past 90° ('out of range'), not at the pole's message."""
    toml = (mission / "mission.toml").read_text().replace('use = "init"', 'use = "off"')
    toml = toml.replace('mode = "alignment"', 'mode = "state"\nlat_deg = 26.8\nlon_deg = 56.0')
    toml = toml.replace("alignment_s = 20.0\n", "")  # no alignment in state mode
    (mission / "mission.toml").write_text(
        toml.replace("v_ned_m_s = [0.0, 0.0, 0.0]", "v_ned_m_s = [1e12, 0.0, 0.0]")
    )
    for command in ("run", "compare"):
        res = cli(command, mission, "--out", tmp_path / command)
        line = error_line(res)
        assert "broke down: the navigation state is " in line, line
        assert " at t = " in line and "the filter diverged" in line, line
        assert not (tmp_path / command).exists()


def test_a_navigation_that_reaches_a_pole_stops_there(mission: Path, tmp_path: Path) -> None:
    """A start at 89.985° N at 30 m/s north (state mode): 556 m from the 0.01° limit, reached
    after about 18.5 s (the mechanization keeps v_N). The run stops there with exit 2 naming
    the latitude and the time (up to 0.4.7 it ran on through the pole, exit 0, its longitude
    swinging by radians); the stream says the same."""
    from adaptnav.api.stream import Stream, replay
    from adaptnav.mission import load_mission

    toml = (mission / "mission.toml").read_text().replace('use = "init"', 'use = "off"')
    toml = toml.replace('mode = "alignment"', 'mode = "state"\nlat_deg = 89.985\nlon_deg = 56.0')
    toml = toml.replace("alignment_s = 20.0\n", "")
    (mission / "mission.toml").write_text(
        toml.replace("v_ned_m_s = [0.0, 0.0, 0.0]", "v_ned_m_s = [30.0, 0.0, 0.0]")
    )
    for command in ("run", "compare"):
        line = error_line(cli(command, mission, "--out", tmp_path / command))
        assert "stopped: the navigation reached latitude 89.99" in line, line
        assert "of the north pole" in line and "mission.toml" in line
        t = float(line.split(" at t = ")[1].split(" s")[0])
        assert 17.0 < t < 20.0, line
        assert not (tmp_path / command).exists()
    loaded = load_mission(mission)
    stopped = r"stopped: the navigation reached latitude 89\.99"
    with pytest.raises(ValueError, match=stopped), Stream(loaded, "robust") as stream:
        for item in replay(loaded):
            stream.push_item(item)


def test_a_float32_time_column_that_rounds_is_refused(mission: Path, tmp_path: Path) -> None:
    """A Parquet DVL table whose t_s is float32 on a Unix-time origin: its values are 128 s
    apart there. An error naming the file (up to 0.4.4 read as it was: 2700 readings dropped
    as duplicates, the rest a minute off, exit 0); float32 near a small origin is read."""
    dvl = pd.read_csv(mission / "dvl.csv")
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(toml.replace('"dvl.csv"', '"dvl.parquet"'))
    dvl.assign(t_s=(dvl["t_s"] + 1.7e9).astype("float32")).to_parquet(mission / "dvl.parquet")
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "dvl.parquet, t_s: stored as float32, whose values near 1.7e+09 s are 128 s" in line
    dvl.assign(t_s=dvl["t_s"].astype("float32")).to_parquet(mission / "dvl.parquet")
    assert cli("run", mission, "--out", tmp_path / "run2", "-q").exit_code == 0


# --- the ledger: every reading's fate ---------------------------------------------------------


def _data_lines(path: Path) -> int:
    """Data lines of a CSV table (blank lines and the header not counted)."""
    return sum(1 for line in path.read_text().splitlines() if line.strip()) - 1


def test_every_reading_read_has_one_fate(mission: Path, tmp_path: Path) -> None:
    """For each sensor, readings in the file = used + rejected + dropped in the ledger, with
    every kind of removal at load in play: a duplicate stamp, an implausible value, NaN, a cut
    last line, and a sensor that is off."""
    import pandas as pd

    dvl = badinput.read(mission, "dvl")
    dvl.loc[len(dvl) - 5, "t_s"] = dvl.loc[len(dvl) - 6, "t_s"]  # duplicate timestamp
    dvl.loc[len(dvl) - 9, "vy_m_s"] = 99.0  # implausible
    dvl.loc[len(dvl) - 12, "vz_m_s"] = float("nan")  # the engine drops it
    badinput.write(mission, "dvl", dvl)
    text = (mission / "depth.csv").read_text()
    (mission / "depth.csv").write_text(text.rstrip("\n")[:-4])  # cut inside the last number
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    ledger = pd.read_parquet(tmp_path / "run" / "ledger.parquet")
    counts = ledger.groupby(["sensor", "fate"]).size().unstack(fill_value=0)
    toml = (mission / "mission.toml").read_text()
    names = ["dvl", "depth", "inclinometer", "heading", "gps"]
    assert 'use = "off"' in toml and sorted(counts.index) == sorted(names)
    for name in names:
        read = _data_lines(mission / f"{name}.csv")
        fates = counts.loc[name]
        assert read == sum(int(fates.get(f, 0)) for f in ("used", "rejected", "dropped")), name
        rows = ledger.loc[ledger["sensor"] == name, "row"]
        assert sorted(rows) == list(range(read)), name  # each row once
    heading = ledger[ledger["sensor"] == "heading"]
    assert set(heading["reason"]) == {"sensor off"}


def test_an_off_sensor_whose_table_cannot_be_read_is_a_repair(
    mission: Path, tmp_path: Path
) -> None:
    """The heading is off and its table goes back in time (an error for a sensor in use): the
    run goes on without it, and since its readings get no ledger row, repairs.parquet names
    the table and the line (up to 0.4.8 nothing in the run's output said so: 61 readings
    gone, exit 0, one INFO log line)."""
    heading = badinput.read(mission, "heading")
    heading.loc[[10, 11]] = heading.loc[[11, 10]].to_numpy()
    badinput.write(mission, "heading", heading)
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    assert "heading" not in set(_ledger(tmp_path / "run")["sensor"])
    repairs = pd.read_parquet(tmp_path / "run" / "repairs.parquet")
    (r,) = repairs[repairs["file"] == "heading.csv"].itertuples()
    assert (r.line, r.field, r.action) == (13, "t_s", "off sensor's table not read")
    assert "'heading' (use = 'off'): its readings are in no ledger" in r.detail
    assert "time goes backwards" in r.detail
    (mission / "heading.csv").unlink()  # no table at all: nothing to account for
    assert cli("run", mission, "--out", tmp_path / "run2", "-q").exit_code == 0
    assert pd.read_parquet(tmp_path / "run2" / "repairs.parquet").empty


def test_an_off_sensor_with_a_bad_table_does_not_stop_the_run(
    mission: Path, tmp_path: Path
) -> None:
    (mission / "heading.csv").write_text("t_s,yaw\n1,2\n")  # no yaw_rad column
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output


def test_a_mission_with_degree_columns_runs(mission: Path, tmp_path: Path) -> None:
    """A repair of a whole column (degrees converted) has no line: saved as missing, where
    the run used to end in a TypeError traceback."""
    import numpy as np
    import pandas as pd

    gps = badinput.read(mission, "gps")
    gps["lat_deg"] = np.degrees(gps.pop("lat_rad"))
    badinput.write(mission, "gps", gps)
    assert cli("run", mission, "--out", tmp_path / "run").exit_code == 0
    repairs = pd.read_parquet(tmp_path / "run" / "repairs.parquet")
    (r,) = repairs.itertuples()
    assert (r.file, r.field, r.action) == ("gps.csv", "lat_deg", "converted degrees")
    assert pd.isna(r.line)


def test_a_reference_position_that_cannot_be_one_is_an_error(mission: Path, tmp_path: Path) -> None:
    truth = badinput.read(mission, "truth")
    truth.loc[40, "lat_rad"] = 7.0  # not a latitude in radians
    badinput.write(mission, "truth", truth)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "truth.csv line 42, lat_rad: value 7.0 is outside" in line


def test_evaluate_with_a_bad_reference_is_a_clear_error(mission: Path, tmp_path: Path) -> None:
    import pandas as pd

    out = tmp_path / "run"
    assert cli("run", mission, "--out", out).exit_code == 0
    (out / "truth.parquet").write_text("garbage")
    line = error_line(cli("evaluate", out))
    assert "truth.parquet: not a readable Parquet file" in line
    pd.DataFrame({"t_s": [1.0, 2.0]}).to_parquet(out / "truth.parquet")
    reseal(out, "truth.parquet")  # what evaluate checks after the digest
    line = error_line(cli("evaluate", out, "--json"))
    assert "truth.parquet: truth lacks columns" in line


def test_evaluate_warns_when_the_reference_covers_part_of_the_run(
    mission: Path, tmp_path: Path
) -> None:
    """A reference that stops a third of the way through the run scores that third only, and
    evaluate says so (text and --json); the whole reference gives no such warning."""
    out = tmp_path / "run"
    assert cli("run", mission, "--out", out).exit_code == 0
    whole = json.loads(cli("evaluate", out, "--json").stdout)
    assert whole["reference_coverage"] > 0.99 and not any(
        "reference covers" in w for w in whole["warnings"]
    )
    truth = pd.read_parquet(out / "truth.parquet")
    t_run = pd.read_parquet(out / "solution.parquet")["t_s"].to_numpy()
    truth[truth["t_s"] <= t_run[0] + (t_run[-1] - t_run[0]) / 3].to_parquet(out / "truth.parquet")
    reseal(out, "truth.parquet")  # a reference cut short as the run wrote it
    part = json.loads(cli("evaluate", out, "--json").stdout)
    assert 0.25 < part["reference_coverage"] < 0.4
    assert part["run_duration_s"] == pytest.approx(whole["run_duration_s"])
    assert any("reference covers" in w for w in part["warnings"])
    res = cli("evaluate", out)
    assert res.exit_code == 0 and "warning: the reference covers" in res.stderr


def test_a_run_sparser_than_its_reference_is_scored_at_its_own_rows(
    mission: Path, tmp_path: Path
) -> None:
    """The same filter with 1-Hz rows against the simulator's 10-Hz truth: up to 0.4.6 its
    attitude was scored between rows 1 s apart, across the waves' roll, and the mean attitude
    NEES ran to several times the 10-Hz run's (exit 0, no warning). Scored at its own rows,
    which are rows of the 10-Hz run too (the same filter, the same numbers there), it scores
    as that run does."""
    dense = tmp_path / "dense"
    assert cli("run", mission, "-f", "meskf", "--out", dense, "-q").exit_code == 0
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(
        toml.replace("[filter]\n", "[filter]\noutput_rate_hz = 1.0\n")
    )
    sparse = tmp_path / "sparse"
    assert cli("run", mission, "-f", "meskf", "--out", sparse, "-q").exit_code == 0
    a = json.loads(cli("evaluate", dense, "--json").stdout)
    b = json.loads(cli("evaluate", sparse, "--json").stdout)
    for block in ("attitude", "velocity", "position"):
        assert b[f"mean_nees_{block}"] == pytest.approx(a[f"mean_nees_{block}"], rel=0.3), block
    assert b["rmse_m"] == pytest.approx(a["rmse_m"], rel=0.05)
    assert (a["scored_at"], b["scored_at"]) == ("reference", "solution")
    assert b["samples"] == len(pd.read_parquet(sparse / "solution.parquet"))


# --- run folders: every table the run's own ---------------------------------------------------


def _smoothed_runs(mission: Path, tmp_path: Path) -> tuple[Path, Path]:
    """Smoothed runs of the mission by VB-MAESKF and by MESKF: tables of the same shape at the
    same times, which the checks of shape and time cannot tell apart."""
    runs = []
    for name in ("vb", "meskf"):
        out = tmp_path / name
        assert cli("run", mission, "-f", name, "--smooth", "--out", out, "-q").exit_code == 0
        runs.append(out)
    vb, meskf = runs
    for table in ("solution.parquet", "forward.parquet"):
        t = [pd.read_parquet(r / table)["t_s"].to_numpy() for r in runs]
        np.testing.assert_array_equal(t[0], t[1])
    return vb, meskf


@pytest.mark.parametrize("table", ["forward.parquet", "solution.parquet"])
def test_a_table_of_another_run_of_the_mission_is_refused(
    mission: Path, tmp_path: Path, table: str
) -> None:
    """Another filter's run of the same mission copied in: up to 0.4.6 evaluate scored it as
    this run's (exit 0). Now summary.json's digest of each table tells (exit 2, naming it and
    both digests)."""
    vb, meskf = _smoothed_runs(mission, tmp_path)
    shutil.copyfile(meskf / table, vb / table)
    line = error_line(cli("evaluate", vb))
    recorded = json.loads((vb / "summary.json").read_text())["files"][table]["sha256"]
    theirs = hashlib.sha256((meskf / table).read_bytes()).hexdigest()
    assert f"{vb / table}: not the file this run wrote (changed after the run, or taken" in line
    assert f"its SHA-256 begins {theirs[:12]}, and summary.json records {recorded[:12]}" in line
    line = error_line(cli("export", "track", vb, "--out", tmp_path / "track", "-q"))
    assert f"{vb / table}: not the file this run wrote" in line


def test_a_reference_of_another_seed_of_the_mission_is_refused(
    mission: Path, tmp_path: Path
) -> None:
    """The mission simulated with another seed: a truth.parquet of the same mission at the
    same times, the same track, other true IMU biases. Up to 0.4.5 evaluate scored the run
    against it (exit 0)."""
    run, other = tmp_path / "run", tmp_path / "other"
    assert cli("run", mission, "--out", run, "-q").exit_code == 0
    seed = badinput.tiny_mission(tmp_path / "seed", seed=badinput.SEED + 1)
    assert cli("run", seed, "--out", other, "-q").exit_code == 0
    ours, theirs = (pd.read_parquet(r / "truth.parquet") for r in (run, other))
    np.testing.assert_array_equal(ours["t_s"], theirs["t_s"])
    np.testing.assert_array_equal(ours["lat_rad"], theirs["lat_rad"])
    assert not np.array_equal(ours["bg_z_rad_s"], theirs["bg_z_rad_s"])
    shutil.copyfile(other / "truth.parquet", run / "truth.parquet")
    line = error_line(cli("evaluate", run, "--json"))
    assert f"{run / 'truth.parquet'}: not the file this run wrote" in line
    line = error_line(cli("export", "track", run, "--out", tmp_path / "track", "-q"))
    assert f"{run / 'truth.parquet'}: not the file this run wrote" in line
    # the reference given from the mission folder: the run folder's is not read
    assert cli("evaluate", run, "--mission", mission, "--json").exit_code == 0


def test_an_untouched_run_folder_records_and_passes_every_digest(
    mission: Path, tmp_path: Path
) -> None:
    """summary.json records the SHA-256 and size of every table the run wrote, the reference
    included, and the untouched folder evaluates and exports."""
    run = tmp_path / "run"
    assert cli("run", mission, "--smooth", "--out", run, "-q").exit_code == 0
    files = json.loads((run / "summary.json").read_text())["files"]
    tables = sorted(p.name for p in run.glob("*.parquet"))
    assert sorted(files) == tables and {"forward.parquet", "truth.parquet"} <= set(tables)
    for name in tables:
        data = (run / name).read_bytes()
        assert files[name] == {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    assert cli("evaluate", run, "--json").exit_code == 0
    assert cli("export", "track", run, "--out", tmp_path / "track", "-q").exit_code == 0


def test_a_run_folder_without_digests_is_read_as_before(mission: Path, tmp_path: Path) -> None:
    """A summary.json without 'files' (a run folder written before 0.4.7) is read as before,
    unchecked: another run's table in it is not told (nothing to tell it by)."""
    vb, meskf = _smoothed_runs(mission, tmp_path)
    assert "files" in json.loads((vb / "summary.json").read_text())  # as a run writes it now
    without_digests(vb)
    before = json.loads(cli("evaluate", vb, "--json").stdout)
    shutil.copyfile(meskf / "forward.parquet", vb / "forward.parquet")
    after = json.loads(cli("evaluate", vb, "--json").stdout)
    assert after["rmse_m"] == before["rmse_m"]
    assert after["forward_rmse_m"] != before["forward_rmse_m"]


def test_a_sensor_much_of_which_lies_outside_the_imus_time_is_warned_of(
    mission: Path, tmp_path: Path
) -> None:
    """An IMU log that stopped half-way leaves half the DVL after its last sample: each such
    reading has its ledger row, and the run now warns of them too; readings stamped before the
    IMU's first sample have a reason of their own (not 'alignment'). The whole mission gives no
    such warning."""
    out = tmp_path / "whole"
    assert cli("run", mission, "--out", out).exit_code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert not [w for w in summary["meta"]["warnings"] if w.get("kind") == "outside_imu"]
    imu = badinput.read(mission, "imu")
    t = imu["t_s"].to_numpy()
    cut = t[0] + 0.75 * (t[-1] - t[0])
    badinput.write(mission, "imu", imu[t <= cut])
    dvl = badinput.read(mission, "dvl")
    early = dvl.iloc[:6].copy()
    early["t_s"] = t[0] - 1.0 - 0.1 * np.arange(6)[::-1]
    badinput.write(mission, "dvl", pd.concat([early, dvl], ignore_index=True))
    out = tmp_path / "cut"
    res = cli("run", mission, "--out", out)
    assert (
        res.exit_code == 0
        and "warning: dvl:" in res.stderr
        and "outside the IMU's time" in res.stderr
    )
    summary = json.loads((out / "summary.json").read_text())
    found = {w["sensor"]: w for w in summary["meta"]["warnings"] if w.get("kind") == "outside_imu"}
    assert set(found) == {"dvl", "depth", "inclinometer"}  # the IMU stopped under them all
    w = found["dvl"]
    n_after = int((dvl["t_s"] > t[t <= cut][-1]).sum())
    assert (w["sensor"], w["before"], w["after"]) == ("dvl", 6, n_after)
    assert w["readings"] == len(dvl) + 6
    ledger = pd.read_parquet(out / "ledger.parquet")
    rows = ledger[(ledger["sensor"] == "dvl") & (ledger["reason"] == "before the first IMU sample")]
    assert sorted(rows["row"]) == list(range(6))


def test_the_oracle_on_a_mission_without_simulated_truth(mission: Path, tmp_path: Path) -> None:
    columns = {
        "dvl": ["vx_m_s", "vy_m_s", "vz_m_s"],
        "depth": ["depth_m"],
        "inclinometer": ["roll_rad", "pitch_rad"],
    }
    for name, cols in columns.items():  # only what a real recording has
        badinput.write(mission, name, badinput.read(mission, name)[["t_s", *cols]])
    line = error_line(cli("run", mission, "--filter", "oracle", "--out", tmp_path / "run"))
    assert "the oracle needs a simulated mission" in line


def test_an_event_names_the_file_row_of_the_reading_that_triggered_it(
    mission: Path, tmp_path: Path
) -> None:
    """Events index the reading that triggered them by its data row in the file, as the ledger
    does (readings of the alignment window never reach the engine, so the engine's own index
    is off by that many). A guard on 1 × the nominal R at p = 0.2 with a 0.25-s lockout (1 s
    after a step, health.is_step) fires on this mission."""
    toml = (mission / "mission.toml").read_text()
    extra = "guard_probability = 0.2\nguard_headroom = 1.0\nguard_lockout_s = 0.25\n"
    if "[filter]\n" in toml:
        toml = toml.replace("[filter]\n", "[filter]\n" + extra)
    else:
        toml += "\n[filter]\n" + extra
    (mission / "mission.toml").write_text(toml)
    res = cli("run", mission, "--filter", "meskf", "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output
    events = pd.read_parquet(tmp_path / "run" / "events.parquet")
    ledger = pd.read_parquet(tmp_path / "run" / "ledger.parquet")
    lockouts = events[events["event"] == "lockout"]
    assert len(lockouts) > 0
    for ev in lockouts.itertuples():
        row = ledger[(ledger["sensor"] == ev.sensor) & (ledger["row"] == ev.row)]
        assert len(row) == 1
        assert row.iloc[0]["fate"] == "rejected" and row.iloc[0]["t_epoch"] == ev.t


def test_the_alignment_puts_the_imu_not_the_gnss_antenna_at_the_fixes(mission: Path) -> None:
    """The mean of the GNSS fixes in the window is the antenna's position, r_a = r + C_nb l_g;
    the aligned state is the IMU's, r = r_a - C_nb l_g: with the antenna 3 m forward and 1 m
    to starboard of the IMU, the state moves back by that, rotated by the aligned heading. The
    height stays the configured one (this GNSS gives no heights). Before, the state was the
    antenna's own position, 3.2 m off for the whole of a dive aided by no GNSS after it."""
    from adaptnav.api.runner import start_state
    from adaptnav.core import attitude, earth
    from adaptnav.mission import load_mission
    from adaptnav.mission.config import with_overrides

    m = load_mission(mission)
    states = {}
    for arm in ((0.0, 0.0, 0.0), (3.0, 1.0, -5.0)):
        cfg = with_overrides(m.config, [("sensors.gps.lever_arm_m", list(arm))])
        states[arm] = start_state(cfg, m.imu, m.sensors)[0]
    x_none, x_arm = states[(0.0, 0.0, 0.0)], states[(3.0, 1.0, -5.0)]
    moved = earth.geodetic_to_ned(*x_arm[:3], *x_none[:3])
    expected = -(attitude.quat_to_dcm(x_arm[6:10]) @ np.array([3.0, 1.0, -5.0]))
    expected[2] = 0.0
    np.testing.assert_allclose(moved, expected, atol=1e-6)
    assert np.hypot(*expected[:2]) == pytest.approx(math.hypot(3.0, 1.0), abs=0.05)  # tilt
    np.testing.assert_allclose(x_arm[3:], x_none[3:], atol=1e-12)


def test_api_arguments_of_the_wrong_type_are_refused_by_name(mission: Path) -> None:
    """``smooth="no"`` is a true string: api.run and compare smoothed it, silently. A number
    for the mission, a bad epoch policy, a filter list holding a number and threads = 0 each
    failed deep inside (pathlib, the engine, str.strip, the thread pool)."""
    from adaptnav import api
    from adaptnav.analysis.compare import compare

    with pytest.raises(TypeError, match="smooth: True or False, not 'no'"):
        api.run(mission, "vb", smooth="no")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="smooth: True or False"):
        compare(mission, ["vb"], smooth="no")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="mission: a Mission or a mission folder, not int"):
        api.run(123)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="epoch_policy: 'fast' is not"):
        api.run(mission, "vb", epoch_policy="fast")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="filters: 5 is not a filter name"):
        compare(mission, ["vb", 5])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="threads: a whole number from 1, not 0"):
        compare(mission, ["vb"], threads=0)
    assert api.run(mission, "vb", smooth=np.bool_(False)).forward is None


def _move_longitudes(mission: Path, to_rad: float, wrap: Any) -> None:
    """Shift the GNSS fixes and the reference of the tiny mission in longitude so that the
    fixes of its static window average ``to_rad``, then write them as ``wrap`` gives. The IMU
    does not see the longitude (the earth's rate depends on the latitude only), so the run is
    the same mission elsewhere."""
    gps = badinput.read(mission, "gps")
    shift = to_rad - float(gps.loc[gps["t_s"] <= 20.0, "lon_rad"].mean())
    for name in ("gps", "truth"):
        table = badinput.read(mission, name)
        table["lon_rad"] = wrap(table["lon_rad"].to_numpy() + shift)
        badinput.write(mission, name, table)


@pytest.mark.parametrize(
    ("to_rad", "wrap"),
    [
        (math.pi, lambda lon: np.angle(np.exp(1j * lon))),  # ±180°: fixes either side
        (0.0, lambda lon: np.mod(lon, 2.0 * math.pi)),  # Greenwich, written 0..360°
    ],
    ids=["antimeridian", "greenwich-0-360"],
)
def test_alignment_on_the_antimeridian_or_greenwich_in_0_360(
    mission: Path, tmp_path: Path, to_rad: float, wrap: Any
) -> None:
    """The alignment's position is the mean of the GNSS fixes in its window: the arithmetic
    mean of longitudes either side of ±180° (or of 0 and 360°) is half the world off (up to
    0.4.5: 6240 km, exit 0). The run there scores as the run at home."""
    home = tmp_path / "home"
    assert cli("run", mission, "--filter", "vb", "--out", home).exit_code == 0
    rmse = json.loads(cli("evaluate", home, "--json").stdout)["rmse_m"]
    _move_longitudes(mission, to_rad, wrap)
    gps = badinput.read(mission, "gps")
    window = gps.loc[gps["t_s"] <= 20.0, "lon_rad"].to_numpy()
    assert np.ptp(window) > math.pi  # the fixes do straddle the cut
    away = tmp_path / "away"
    assert cli("run", mission, "--filter", "vb", "--out", away).exit_code == 0
    moved = json.loads(cli("evaluate", away, "--json").stdout)["rmse_m"]
    assert moved == pytest.approx(rmse, abs=0.05)


def test_fixes_before_the_imu_are_not_averaged_into_the_start(
    mission: Path, tmp_path: Path
) -> None:
    """GNSS fixes logged before the IMU started (the vessel arriving, 2 km north) are not the
    vehicle at rest: up to 0.4.5 the alignment averaged them in and started 1.4 km off."""
    home = tmp_path / "home"
    assert cli("run", mission, "--filter", "vb", "--out", home).exit_code == 0
    rmse = json.loads(cli("evaluate", home, "--json").stdout)["rmse_m"]
    gps = badinput.read(mission, "gps")
    early = pd.concat([gps.iloc[:1]] * 60, ignore_index=True)
    early["t_s"] = gps["t_s"].iloc[0] - 100.0 + np.arange(60.0)
    early["lat_rad"] += 2000.0 / 6.37e6
    badinput.write(mission, "gps", pd.concat([early, gps], ignore_index=True))
    out = tmp_path / "early"
    assert cli("run", mission, "--filter", "vb", "--out", out).exit_code == 0
    assert json.loads(cli("evaluate", out, "--json").stdout)["rmse_m"] == pytest.approx(rmse)


def test_a_start_at_a_pole_is_refused(mission: Path, tmp_path: Path) -> None:
    """The latitude-longitude mechanization is singular at the poles: a start at 90° ran to a
    yaw 178° off with exit 0 (up to 0.4.5). A configured latitude, or GNSS fixes, within
    0.01° of a pole are refused."""
    toml = (mission / "mission.toml").read_text()
    (mission / "mission.toml").write_text(
        toml.replace('mode = "alignment"', 'mode = "alignment"\nlat_deg = 90.0\nlon_deg = 0.0')
    )
    assert "initial.lat_deg" in error_line(cli("run", mission, "--out", tmp_path / "r1"))
    (mission / "mission.toml").write_text(toml)
    gps = badinput.read(mission, "gps")
    gps["lat_rad"] = math.pi / 2 - 1e-7
    badinput.write(mission, "gps", gps)
    line = error_line(cli("run", mission, "--out", tmp_path / "r2"))
    assert "gps.csv" in line and "within 0.01° of a pole" in line


def test_a_configured_position_far_from_the_gnss_fixes_is_refused(
    mission: Path, tmp_path: Path
) -> None:
    """A static alignment takes ``initial.lat_deg/lon_deg`` over the GNSS fixes. Up to 0.4.8 a
    position 9000 km from the tiny mission's fixes (a template's, copied) ran with exit 0,
    every row that far off, the GNSS's ledger saying it was used for the initialisation; and
    a ``lat_deg`` without ``lon_deg`` was ignored for the fixes. Both are refused; a position
    that agrees with the fixes is taken as before."""
    toml = (mission / "mission.toml").read_text()
    far = 'mode = "alignment"\nlat_deg = -45.0\nlon_deg = 100.0'
    (mission / "mission.toml").write_text(toml.replace('mode = "alignment"', far))
    line = error_line(cli("run", mission, "--out", tmp_path / "r1"))
    assert "initial.lat_deg" in line and "'gps'" in line and "gps.csv" in line
    half = 'mode = "alignment"\nlat_deg = 26.8'
    (mission / "mission.toml").write_text(toml.replace('mode = "alignment"', half))
    assert "initial.lon_deg: missing" in error_line(cli("run", mission, "--out", tmp_path / "r2"))
    near = 'mode = "alignment"\nlat_deg = 26.8\nlon_deg = 56.0'  # the fixes' mean, within 10 m
    (mission / "mission.toml").write_text(toml.replace('mode = "alignment"', near))
    assert cli("run", mission, "--out", tmp_path / "r3").exit_code == 0


def test_a_heading_in_degrees_in_a_radians_column_is_an_error(
    mission: Path, tmp_path: Path
) -> None:
    """A heading logged in degrees in ``yaw_rad``: every reading above 6.28° is outside the
    plausible range and was dropped, the ones near north passed as radians, 57 times too large
    (up to 0.4.5 the run went on with one of them used 25° off, exit 0). Most of an angle
    column outside its range is an error naming the file and column."""
    toml = (mission / "mission.toml").read_text()
    head = toml.index("[sensors.heading]")
    toml = toml[:head] + toml[head:].replace('use = "off"', 'use = "aid"', 1)
    (mission / "mission.toml").write_text(toml)
    heading = badinput.read(mission, "heading")
    heading["yaw_rad"] = np.linspace(0.0, 359.0, len(heading))  # degrees, written as radians
    badinput.write(mission, "heading", heading)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "heading.csv line 4, yaw_rad: 59 of its 61 values" in line  # the first 2 < 6.28
    assert "degrees in a radians column?" in line


def test_a_depth_logged_as_a_height_is_an_error(mission: Path, tmp_path: Path) -> None:
    """The tiny mission's meter at about 1.2 m logged with the wrong sign: every reading is
    within [-100, 12000] m, and up to 0.4.6 the run pulled the height 2.4 m up with exit 0
    (RMSE 5.2 m against 4.6 m horizontal). A meter above the surface most of the time is an
    error naming the file, line and column; configured limits accept it."""
    depth = badinput.read(mission, "depth")
    depth["depth_m"] = -depth["depth_m"]
    badinput.write(mission, "depth", depth)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert "depth.csv line" in line and "depth_m: the median reading is -1.2" in line
    assert "depth is positive down" in line
    toml = (mission / "mission.toml").read_text()
    head = toml.index("[sensors.depth]")
    toml = toml[:head] + toml[head:].replace("use = ", "limits = [-50.0, 100.0]\nuse = ", 1)
    (mission / "mission.toml").write_text(toml)
    assert cli("run", mission, "--out", tmp_path / "accepted").exit_code == 0


@pytest.mark.parametrize(
    ("sensor", "column", "offset"),
    [("depth", "depth_m", 1000.0), ("dvl", "vx_m_s", 3.0)],
    ids=["depth+1000m", "dvl+3m/s"],
)
def test_a_sensor_fault_longer_than_the_lockout_does_not_take_the_filter_with_it(
    mission: Path, tmp_path: Path, sensor: str, column: str, offset: float
) -> None:
    """A sensor that jumps and stays off longer than the guard's lockout (here 5 s, a fault
    of 15 s): up to 0.4.5 the lockout scaled P by up to 100 a reading until the fault was
    taken, and the state ran to NaN when the sensor came back (exit 2, 'broke down'). A
    streak that begins with a step now waits four lockout times: the fault is rejected
    throughout and the run scores as the clean one."""
    toml = (mission / "mission.toml").read_text()
    toml = toml.replace("[filter]\n", "[filter]\nguard_lockout_s = 5.0\n")
    (mission / "mission.toml").write_text(toml)
    clean = tmp_path / "clean"
    assert cli("run", mission, "--out", clean).exit_code == 0
    rmse = json.loads(cli("evaluate", clean, "--json").stdout)["rmse_m"]
    table = badinput.read(mission, sensor)
    table.loc[(table["t_s"] > 25.0) & (table["t_s"] < 40.0), column] += offset
    badinput.write(mission, sensor, table)
    out = tmp_path / "fault"
    assert cli("run", mission, "--out", out).exit_code == 0
    faulted = json.loads(cli("evaluate", out, "--json").stdout)["rmse_m"]
    assert faulted < 1.2 * rmse


def test_evaluate_refuses_a_simulation_made_again_after_the_run(tmp_path: Path) -> None:
    """`evaluate` scores a run's calibration states against its mission's simulation.json.
    Simulated again into the same folder after the run (`simulate --force`, a true DVL scale of
    3 % for 1 %), up to 0.4.8 the new file's errors scored the old run's estimate, exit 0 (error
    -1.7 % for +0.26 %). The run records the file's SHA-256 and a different file is refused."""
    mission, run = tmp_path / "m", tmp_path / "r"
    assert cli("simulate", "demo", "--out", mission, "--dvl-scale", "1.01", "-q").exit_code == 0
    toml = (mission / "mission.toml").read_text()
    toml = toml.replace("zero_is_lost = false\n", 'zero_is_lost = false\nestimate = ["scale"]\n', 1)
    (mission / "mission.toml").write_text(toml)
    assert cli("run", mission, "--out", run, "-q").exit_code == 0
    own = json.loads(cli("evaluate", run, "--json", "-q").stdout)["calibration"]
    assert own["dvl.scale"]["true"] == pytest.approx(1.0)
    args = ("simulate", "demo", "--out", mission, "--dvl-scale", "1.03", "--force", "-q")
    assert cli(*args).exit_code == 0
    (mission / "mission.toml").write_text(toml)
    line = error_line(cli("evaluate", run, "-q"))
    assert "simulation.json: not the simulation the run was made from" in line


@pytest.mark.parametrize("factor", [1000.0, 100.0])
def test_a_dvl_in_mm_or_cm_per_second_is_an_error(
    mission: Path, tmp_path: Path, factor: float
) -> None:
    """A DVL logged in mm/s (a PD0 record's unit) or cm/s: its readings under way are far
    outside ±20 m/s, those at rest are not, so no column is outside as a whole. Up to 0.4.9
    the readings under way were dropped as implausible and the rest used, exit 0 (the demo:
    21.5 m RMSE against 2.6 m)."""
    dvl = badinput.read(mission, "dvl")
    dvl[["vx_m_s", "vy_m_s", "vz_m_s"]] *= factor
    badinput.write(mission, "dvl", dvl)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: dvl.csv line ") and ", vx_m_s: " in line, line
    assert "mm/s or cm/s in a m/s column" in line


def test_a_dvl_fill_value_over_most_readings_is_not_a_unit_error(
    mission: Path, tmp_path: Path
) -> None:
    """A driver's fill value (-32.768 m/s) on most readings is a lost bottom: each is dropped
    as implausible, the run goes on."""
    dvl = badinput.read(mission, "dvl")
    dvl.loc[: int(0.6 * len(dvl)), ["vx_m_s", "vy_m_s", "vz_m_s"]] = -32.768
    badinput.write(mission, "dvl", dvl)
    res = cli("run", mission, "--out", tmp_path / "run")
    assert res.exit_code == 0, res.output


def test_a_sensor_in_milliseconds_from_the_same_origin_is_an_error(
    mission: Path, tmp_path: Path
) -> None:
    """DVL stamps in ms from the IMU's origin: the readings of the first second (ms < the
    IMU's last second) lie within the IMU's span, the rest after it. Up to 0.4.9 those few
    were used and the run went on without the rest, exit 0 (the demo: 141 m RMSE)."""
    dvl = badinput.read(mission, "dvl")
    imu = badinput.read(mission, "imu")
    dvl.loc[0, "t_s"] = 0.05  # the tiny mission is 62 s long: one reading within, in ms
    dvl["t_s"] *= 1000.0
    assert ((dvl["t_s"] >= imu["t_s"].iloc[0]) & (dvl["t_s"] <= imu["t_s"].iloc[-1])).any()
    badinput.write(mission, "dvl", dvl)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: dvl.csv: only 1 of "), line
    assert "another time unit (ms, µs?)" in line


def test_gnss_radians_in_degree_columns_are_an_error(mission: Path, tmp_path: Path) -> None:
    """lat_deg and lon_deg holding radians: every fix lies within ±1.571° and ±3.142°, in the
    open sea off 0° N 0° E. Up to 0.4.9 they were taken as degrees, exit 0 (the demo with GNSS
    aiding: 6 270 km RMSE)."""
    gps = badinput.read(mission, "gps")
    gps = gps.rename(columns={"lat_rad": "lat_deg", "lon_rad": "lon_deg"})
    badinput.write(mission, "gps", gps)
    line = error_line(cli("run", mission, "--out", tmp_path / "run"))
    assert line.startswith("error: gps.csv line 2, lat_deg: every fix lies within"), line
    assert "radians in a degrees column?" in line
