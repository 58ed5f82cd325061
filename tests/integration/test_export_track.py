"""``adaptnav export track`` (importers/track.py, cli/track.py): a run's solution as CSV and
KML, on tables built by hand (units, decimation, the KML's structure) and on the tiny mission's
run through the command line (files, refusals, exit 2 with one line)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.cli import app
from adaptnav.importers.track import decimate, track_kml, track_table

KML = "{http://www.opengis.net/kml/2.2}"
runner = CliRunner()


def _solution(n: int) -> pd.DataFrame:
    """n rows of a solution table: 30° N, 60° E moving north; every σ column set."""
    t = np.arange(n, dtype=float)
    cols: dict[str, Any] = {
        "t_s": t,
        "lat_rad": math.radians(30.0) + 1e-6 * t,
        "lon_rad": np.full(n, math.radians(60.0)),
        "h_m": np.full(n, -5.0),
        "vn_m_s": np.ones(n), "ve_m_s": np.zeros(n), "vd_m_s": np.zeros(n),
        "roll_rad": np.zeros(n), "pitch_rad": np.zeros(n),
        "yaw_rad": np.full(n, -math.pi / 2),  # west: 270°
    }  # fmt: skip
    for i, c in enumerate(("dr_N", "dr_E", "dr_D", "dv_N", "dv_E", "dv_D")):
        cols[f"sd_{c}"] = np.full(n, (3.0, 4.0, 1.0, 0.1, 0.1, 0.1)[i])
    for c in ("phi_N", "phi_E", "phi_D"):
        cols[f"sd_{c}"] = np.full(n, math.radians(0.5))
    return pd.DataFrame(cols)


def test_the_csv_is_in_degrees_and_metres_with_the_claimed_sigma() -> None:
    """Worked by hand: 30° and 60°, a yaw of -90° as 270°, σ north 3 and east 4 m give a
    horizontal σ of 5 m, attitude σ 0.5°."""
    table = track_table(_solution(3))
    row = table.iloc[0]
    assert row["lat_deg"] == pytest.approx(30.0) and row["lon_deg"] == pytest.approx(60.0)
    assert row["yaw_deg"] == pytest.approx(270.0) and row["h_m"] == -5.0
    assert row["sd_horizontal_m"] == pytest.approx(5.0)
    assert row["sd_phi_d_deg"] == pytest.approx(0.5)
    assert list(table.columns[:4]) == ["t_s", "lat_deg", "lon_deg", "h_m"]
    with pytest.raises(ValueError, match="no column 'sd_dr_N'"):
        track_table(_solution(3).drop(columns="sd_dr_N"))


def test_longitudes_past_the_antimeridian_are_wrapped() -> None:
    """A run that crosses the antimeridian eastwards has longitudes past 180° in its state
    (180.0012° measured); track.csv and the KML write them in [-180°, 180°), as KML requires
    (up to 0.4.5 written as they were)."""
    sol = _solution(3)
    sol["lon_rad"] = np.radians([179.999, 180.0012, 181.5])
    table = track_table(sol)
    np.testing.assert_allclose(table["lon_deg"], [179.999, -179.9988, -178.5], atol=1e-9)
    root = ET.fromstring(track_kml("run", sol))
    coords = [c.text for c in root.iter(f"{KML}coordinates")]
    lons = [float(p.split(",")[0]) for text in coords for p in str(text).split()]
    assert lons and all(-180.0 <= v < 180.0 for v in lons)


def test_decimation_keeps_every_kth_row_and_the_last() -> None:
    """10 rows to at most 4: k = ceil(9 / 3) = 3; 11 rows: k = ceil(10 / 3) = 4, the last added."""
    assert decimate(10, 4).tolist() == [0, 3, 6, 9]
    assert decimate(11, 4).tolist() == [0, 4, 8, 10]
    assert decimate(3, 4).tolist() == [0, 1, 2]
    with pytest.raises(ValueError, match="max_points"):
        decimate(10, 1)


def _placemarks(text: str) -> dict[str, list[tuple[float, float]]]:
    root = ET.fromstring(text)
    out = {}
    for pm in root.iter(f"{KML}Placemark"):
        name = pm.find(f"{KML}name")
        coords = pm.find(f".//{KML}coordinates")
        assert name is not None and coords is not None and coords.text is not None
        pairs = [tuple(float(v) for v in c.split(",")) for c in coords.text.split()]
        out[str(name.text)] = [(p[0], p[1]) for p in pairs]
    return out


def test_the_kml_holds_lon_lat_lines_and_the_ends() -> None:
    sol = _solution(101)
    sol.loc[0, ["lat_rad", "lon_rad"]] = math.nan  # an unfinished first row is left out
    ref = sol.assign(lat_rad=sol["lat_rad"] + 1e-7)
    marks = _placemarks(track_kml("dive <1>", sol, ref, max_points=11))
    line = marks["dive <1>: solution"]
    assert len(line) == 11 and line[0] == pytest.approx((60.0, 30.0 + math.degrees(1e-6)))
    assert line[-1][1] == pytest.approx(30.0 + math.degrees(100e-6))
    assert len(marks["dive <1>: reference"]) == 11
    assert marks["start, t = 1.0 s"] == [pytest.approx(line[0])]
    assert "end, t = 100.0 s" in marks
    assert "dive <1>: reference" not in _placemarks(track_kml("x", sol, None))
    with pytest.raises(ValueError, match="no finite position"):
        track_kml("x", sol.assign(lat_rad=math.nan))


def _cli(*args: Any) -> Any:
    res = runner.invoke(app, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    return res


def test_export_track_from_a_run_folder(mission: Path, tmp_path: Path) -> None:
    run = tmp_path / "run"
    assert _cli("run", mission, "--out", run, "--quiet").exit_code == 0
    out = tmp_path / "track"
    res = _cli("export", "track", run, "--out", out, "--quiet")
    assert res.exit_code == 0, res.output
    solution = pd.read_parquet(run / "solution.parquet")
    table = pd.read_csv(out / "track.csv")
    assert len(table) == len(solution)
    np.testing.assert_allclose(table["lat_deg"], np.degrees(solution["lat_rad"]), rtol=1e-12)
    marks = _placemarks((out / "track.kml").read_text(encoding="utf-8"))
    assert any(name.endswith(": reference") for name in marks)  # the run kept the truth
    again = _cli("export", "track", run, "--out", out)
    assert again.exit_code == 2 and "not empty" in again.output
    smooth = _cli("export", "track", run, "--out", tmp_path / "f", "--forward")
    assert smooth.exit_code == 2 and "not a --smooth run" in smooth.output
    assert not (tmp_path / "f").exists()
    missing = _cli("export", "track", tmp_path / "nothing", "--out", tmp_path / "g")
    assert missing.exit_code == 2 and "does not exist" in missing.output
