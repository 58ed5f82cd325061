"""A run's track for spreadsheets and GIS tools: ``adaptnav export track`` (docs/export.md).

Two files from a run folder's solution (the smoothed one of a ``--smooth`` run; ``forward``:
the forward pass's):

* ``track.csv``: one row per solution row, in the units a chart or a spreadsheet wants:
  ``t_s, lat_deg, lon_deg, h_m, vn_m_s, ve_m_s, vd_m_s, roll_deg, pitch_deg, yaw_deg`` (yaw in
  [0, 360); ``h_m`` in the run's height frame: ellipsoidal with GNSS heights, else from the
  water surface, docs/filters.md), then the σ the filter claims: ``sd_north_m, sd_east_m,
  sd_down_m`` (position), ``sd_vn_m_s, sd_ve_m_s, sd_vd_m_s`` and ``sd_phi_n_deg,
  sd_phi_e_deg, sd_phi_d_deg`` (the attitude error about the north, east and down axes; about
  down it is the heading's σ), and ``sd_horizontal_m = sqrt(sd_north² + sd_east²)``. Numbers
  as Python writes them, no rounding.
* ``track.kml``: KML 2.2 (OGC 07-147r2) for Google Earth, QGIS and ArcGIS: the solution as
  one ``LineString`` of ``lon,lat`` (degrees, WGS84; no altitude, clamped to the ground: a depth
  would draw the track under the sea floor of the globe), placemarks at its first and last
  point, and the run folder's reference (``truth.parquet``) as a second line when it has one.
  A line has at most ``max_points`` vertices: every k-th row, the last always kept.

Pure functions of the tables; the command writes the folder atomically (``cli/track.py``).
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.api.results import check_finite
from adaptnav.core import earth

Array = NDArray[np.float64]

MAX_POINTS = 20000
"""Default vertex limit of a KML line: Google Earth draws a few tens of thousands smoothly."""

_COLUMNS = {  # track.csv column ← (solution column, factor)
    "t_s": ("t_s", 1.0),
    "lat_deg": ("lat_rad", 180.0 / math.pi),
    "lon_deg": ("lon_rad", 180.0 / math.pi),
    "h_m": ("h_m", 1.0),
    "vn_m_s": ("vn_m_s", 1.0),
    "ve_m_s": ("ve_m_s", 1.0),
    "vd_m_s": ("vd_m_s", 1.0),
    "roll_deg": ("roll_rad", 180.0 / math.pi),
    "pitch_deg": ("pitch_rad", 180.0 / math.pi),
    "yaw_deg": ("yaw_rad", 180.0 / math.pi),
    "sd_north_m": ("sd_dr_N", 1.0),
    "sd_east_m": ("sd_dr_E", 1.0),
    "sd_down_m": ("sd_dr_D", 1.0),
    "sd_vn_m_s": ("sd_dv_N", 1.0),
    "sd_ve_m_s": ("sd_dv_E", 1.0),
    "sd_vd_m_s": ("sd_dv_D", 1.0),
    "sd_phi_n_deg": ("sd_phi_N", 180.0 / math.pi),
    "sd_phi_e_deg": ("sd_phi_E", 180.0 / math.pi),
    "sd_phi_d_deg": ("sd_phi_D", 180.0 / math.pi),
}


def track_table(solution: pd.DataFrame) -> pd.DataFrame:
    """``track.csv``'s table of a run's ``solution`` (module docstring). Raises ValueError
    naming the first column it lacks, or the first row and column that is not a finite number
    (:func:`adaptnav.api.results.check_finite`)."""
    missing = [src for src, _ in _COLUMNS.values() if src not in solution.columns]
    if missing:
        raise ValueError(f"solution: no column {missing[0]!r} (not a run's solution table?)")
    check_finite(solution, [src for src, _ in _COLUMNS.values()], "solution")
    out = pd.DataFrame(
        {name: solution[src].to_numpy(dtype=float) * k for name, (src, k) in _COLUMNS.items()}
    )
    out["yaw_deg"] = np.mod(out["yaw_deg"].to_numpy(), 360.0)
    # Into [-180°, 180°), as KML and most GIS take them: the state's longitude runs on across
    # the antimeridian (180.0012° after crossing it; up to 0.4.5 written as it was).
    out["lon_deg"] = np.degrees(earth.wrap_longitude(solution["lon_rad"].to_numpy(dtype=float)))
    out["sd_horizontal_m"] = np.hypot(out["sd_north_m"], out["sd_east_m"])
    return out


def decimate(n: int, max_points: int) -> NDArray[np.int64]:
    """Row indices of at most ``max_points`` (≥ 2) of n rows: every k-th, the last kept."""
    if max_points < 2:
        raise ValueError(f"max_points: {max_points} must be >= 2")
    if n <= max_points:
        return np.arange(n, dtype=np.int64)
    k = math.ceil((n - 1) / (max_points - 1))
    idx = np.arange(0, n, k, dtype=np.int64)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


def _coordinates(lat_rad: Array, lon_rad: Array, max_points: int) -> str:
    ok = np.isfinite(lat_rad) & np.isfinite(lon_rad)
    lat, lon = np.degrees(lat_rad[ok]), np.degrees(earth.wrap_longitude(lon_rad[ok]))
    idx = decimate(lat.size, max_points)
    return " ".join(f"{lon[i]:.8f},{lat[i]:.8f}" for i in idx.tolist())


def _line(name: str, style: str, lat: Array, lon: Array, max_points: int) -> str:
    return (
        f"<Placemark><name>{escape(name)}</name><styleUrl>#{style}</styleUrl>"
        "<LineString><tessellate>1</tessellate>"
        f"<coordinates>{_coordinates(lat, lon, max_points)}</coordinates>"
        "</LineString></Placemark>"
    )


def _point(name: str, lat: float, lon: float) -> str:
    return (
        f"<Placemark><name>{escape(name)}</name><Point>"
        f"<coordinates>{math.degrees(float(earth.wrap_longitude(lon))):.8f},"
        f"{math.degrees(lat):.8f}</coordinates>"
        "</Point></Placemark>"
    )


def track_kml(
    name: str,
    solution: pd.DataFrame,
    reference: pd.DataFrame | None = None,
    max_points: int = MAX_POINTS,
) -> str:
    """``track.kml``'s text (module docstring): the solution's line, its start and end, and
    the ``reference`` line when given. Raises ValueError if the solution has no finite
    position."""
    lat = solution["lat_rad"].to_numpy(dtype=float)
    lon = solution["lon_rad"].to_numpy(dtype=float)
    ok = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon))
    if ok.size == 0:
        raise ValueError("solution: no finite position to draw")
    parts = [_line(f"{name}: solution", "solution", lat, lon, max_points)]
    if reference is not None and {"lat_rad", "lon_rad"} <= set(reference.columns):
        rlat = reference["lat_rad"].to_numpy(dtype=float)
        rlon = reference["lon_rad"].to_numpy(dtype=float)
        if np.any(np.isfinite(rlat) & np.isfinite(rlon)):
            parts.append(_line(f"{name}: reference", "reference", rlat, rlon, max_points))
    t = solution["t_s"].to_numpy(dtype=float)
    first, last = int(ok[0]), int(ok[-1])
    parts.append(_point(f"start, t = {t[first]:.1f} s", lat[first], lon[first]))
    parts.append(_point(f"end, t = {t[last]:.1f} s", lat[last], lon[last]))
    styles = (
        '<Style id="solution"><LineStyle><color>ff0000ff</color><width>2</width></LineStyle>'
        "</Style>"
        '<Style id="reference"><LineStyle><color>ffffffff</color><width>1</width></LineStyle>'
        "</Style>"
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<kml xmlns="http://www.opengis.net/kml/2.2"><Document>'
        f"<name>{escape(name)}</name>{styles}{''.join(parts)}</Document></kml>\n"
    )


def write_track(
    solution: pd.DataFrame,
    folder: Path,
    name: str,
    reference: pd.DataFrame | None = None,
    max_points: int = MAX_POINTS,
) -> dict[str, int]:
    """``track.csv`` and ``track.kml`` of ``solution`` into ``folder`` (existing); returns the
    rows written and the KML line's vertices."""
    table = track_table(solution)
    table.to_csv(folder / "track.csv", index=False)
    (folder / "track.kml").write_text(
        track_kml(name, solution, reference, max_points), encoding="utf-8"
    )
    finite = int(np.sum(np.isfinite(table["lat_deg"]) & np.isfinite(table["lon_deg"])))
    return {"rows": len(table), "vertices": int(decimate(finite, max_points).size)}
