"""One self-contained HTML page from a comparison folder
(:meth:`adaptnav.analysis.compare.Comparison.save`).

:func:`write_report` reads ``comparison.json``, the run folders' ``summary.json`` (filter
settings, speed), the figures under ``figures/`` and, when it can find the mission folder
(``<compare_dir>/mission``, else the ``mission_dir`` that ``comparison.json`` records), its
``mission.toml`` (sensors, rates, nominal σ, lever arms, IMU noise) and the simulator's
``simulation.json`` (seed, disturbances injected, timeline). It writes one HTML file a person
reads from top to bottom:

1. the scenario (trajectory, duration, distance, seed, disturbances; docs/simulation.md);
2. the sensors and the IMU noise model;
3. each filter's settings (gate q, VB ρ, N, α0, matching window; docs/filters.md, 'Gate' and
   the sections on the three filters);
4. our RMSE and relative RMSE (docs/metrics.md, 'Accuracy'; paper eqs. (32), (33); the distance is
   the horizontal length of the reference track) beside the paper's Table 3
   (``<table id="comparison">``, one row per filter), then each filter's consistency: the mean
   NEES of position, velocity and attitude and the share of epochs inside the χ²(3) 95 % band
   (``<table id="consistency">``, docs/metrics.md);
5. every figure (the paper's Figs. 7-10, ledger counts, NIS) as a ``<figure>`` with its PNG as a
   ``data:`` URI and a caption saying what to look at;
6. the ledger counts (``<table id="ledger">``) and the shared initial alignment
   (docs/alignment.md).

The page needs nothing else: no scripts, no external style sheets, fonts or images, and every
string from the files is escaped (:func:`html.escape`).
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from adaptnav.analysis.compare import (
    COMPARISON_JSON,
    FILTER_LABELS,
    FORMAT_NAME,
    NEES_BAND_TEXT,
    PAPER_TABLE3,
    SIMULATION_FILE,
)

__all__ = ["REPORT_FILE", "ReportError", "write_report"]

REPORT_FILE = "report.html"
MISSION_SUBDIR = "mission"

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto;
       max-width: 1200px; padding: 0 1.5em 3em; color: #1a1a1a; line-height: 1.45; }
h1 { font-size: 1.6em; margin-top: 1.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f0f0f0; } td:first-child, th:first-child { text-align: left; }
td.text, th.text { text-align: left; } td:first-child { white-space: nowrap; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.92em; color: #333; max-width: 70em; margin-top: 0.4em; }
.note { color: #555; font-size: 0.9em; } nav ul { columns: 2; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


class ReportError(ValueError):
    """The comparison folder is missing or unreadable; the message names the file."""


def _e(value: Any) -> str:
    return html.escape(str(value), quote=True)


def _num(value: Any, fmt: str = "{:.2f}", missing: str = "–") -> str:
    if value is None or isinstance(value, bool):
        return missing
    try:
        x = float(value)
    except (TypeError, ValueError):
        return _e(value)
    return missing if not math.isfinite(x) else fmt.format(x)


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise ReportError(f"{path}: missing") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ReportError(f"{path}: not readable JSON ({exc})") from exc


def _optional_json(path: Path) -> dict[str, Any] | None:
    try:
        value = _read_json(path)
    except ReportError:
        return None
    return value if isinstance(value, dict) else None


def _mission_dir(compare_dir: Path, doc: Mapping[str, Any]) -> Path | None:
    local = compare_dir / MISSION_SUBDIR
    if (local / "mission.toml").is_file():
        return local
    recorded = doc.get("mission_dir")
    if isinstance(recorded, str) and (Path(recorded) / "mission.toml").is_file():
        return Path(recorded)
    return None


def _mission_toml(folder: Path | None) -> dict[str, Any] | None:
    if folder is None:
        return None
    try:
        return tomllib.loads((folder / "mission.toml").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None


def _table(
    headers: Sequence[str],
    rows: Iterable[Sequence[str]],
    *,
    table_id: str | None = None,
    text_columns: int = 1,
) -> str:
    """An HTML table; ``headers`` are escaped here, cells must already be HTML. The first
    ``text_columns`` columns are left-aligned text, the rest right-aligned numbers."""
    ident = f' id="{_e(table_id)}"' if table_id else ""
    text = ' class="text"'

    def cls(i: int) -> str:
        return text if i < text_columns else ""

    head = "".join(f'<th scope="col"{cls(i)}>{_e(h)}</th>' for i, h in enumerate(headers))
    body = [
        "<tr>" + "".join(f"<td{cls(i)}>{cell}</td>" for i, cell in enumerate(row)) + "</tr>"
        for row in rows
    ]
    return (
        f"<table{ident}>\n<thead><tr>{head}</tr></thead>\n<tbody>\n"
        + "\n".join(body)
        + "\n</tbody>\n</table>"
    )


def _pair(value: Any) -> str:
    """A mission.toml quantity ``[value, "unit"]`` as text."""
    if isinstance(value, list) and len(value) == 2 and isinstance(value[1], str):
        v = value[0]
        shown = ", ".join(str(x) for x in v) if isinstance(v, list) else str(v)
        return _e(f"{shown} {value[1]}")
    if isinstance(value, list):
        return _e(", ".join(str(x) for x in value))
    return "–" if value is None else _e(value)


# --- sections ------------------------------------------------------------------------------


def _scenario(
    doc: Mapping[str, Any], toml: Mapping[str, Any] | None, sim: Mapping[str, Any] | None
) -> str:
    results: Mapping[str, Any] = doc.get("results", {})
    first: Mapping[str, Any] = next(iter(results.values()), {})
    parts = ['<section id="scenario"><h2>Scenario</h2>']
    mission = toml.get("mission", {}) if toml else {}
    if mission.get("description"):
        parts.append(f"<p>{_e(mission['description'])}</p>")
    rows: list[tuple[str, str]] = [("mission", _e(doc.get("mission", "?")))]
    if sim:
        rows += [
            ("simulated preset", _e(sim.get("preset", "?"))),
            ("seed", _e(sim.get("seed", "?"))),
            (
                "mission duration",
                f"{_num(sim.get('duration_s'), '{:.1f}')} s "
                f"({_num(_div(sim.get('duration_s'), 60.0), '{:.1f}')} min)",
            ),
            ("static (alignment) phase", f"0 – {_num(sim.get('static_end_s'), '{:.0f}')} s"),
            (
                "track length (simulator)",
                f"{_num(_div(sim.get('distance_m'), 1000.0), '{:.2f}')} km",
            ),
        ]
    rows += [
        (
            "navigated duration (scored)",
            f"{_num(_div(first.get('duration_s'), 60.0), '{:.1f}')} min",
        ),
        (
            "distance travelled (scored, horizontal)",
            f"{_num(_div(first.get('distance_m'), 1000.0), '{:.3f}')} km",
        ),
    ]
    if sim:
        heading = sim.get("initial_heading_error_rad")
        if heading is not None:
            rows.append(
                ("error of the given initial heading", f"{_num(math.degrees(heading), '{:.2f}')}°")
            )
        imu = sim.get("imu", {})
        if isinstance(imu, dict) and imu.get("gyro_turn_on_rad_s") is not None:
            g = [math.degrees(v) * 3600.0 for v in imu["gyro_turn_on_rad_s"]]
            a = [v / 9.80665 * 1000.0 for v in imu.get("accel_turn_on_m_s2", [])]
            rows.append(
                (
                    "IMU turn-on bias applied ({})".format(_e(imu.get("turn_on", ""))),
                    f"gyro {', '.join(_num(v, '{:.2f}') for v in g)} deg/h; "
                    f"accel {', '.join(_num(v, '{:.3f}') for v in a)} mg",
                )
            )
    parts.append(_table(("quantity", "value"), rows, text_columns=2))
    if sim:
        parts.append(_disturbances(sim))
        segments = sim.get("segments")
        if isinstance(segments, list) and segments:
            seg_rows = [
                (
                    _e(s[0]),
                    _num(_div(s[1], 60.0), "{:.1f}"),
                    _num(_div(s[2], 60.0), "{:.1f}"),
                    _num(_div(_sub(s[2], s[1]), 60.0), "{:.1f}"),
                )
                for s in segments
                if isinstance(s, list) and len(s) >= 3
            ]
            parts.append("<h3>Timeline of the trajectory</h3>")
            parts.append(_table(("segment", "start (min)", "end (min)", "length (min)"), seg_rows))
    else:
        parts.append(
            '<p class="note">No simulation.json next to the mission: a recorded '
            "mission, or its folder was not found; disturbances unknown.</p>"
        )
    parts.append("</section>")
    return "\n".join(parts)


def _div(a: Any, b: float) -> float | None:
    try:
        return float(a) / b
    except (TypeError, ValueError):
        return None


def _sub(a: Any, b: Any) -> float | None:
    try:
        return float(a) - float(b)
    except (TypeError, ValueError):
        return None


def _disturbances(sim: Mapping[str, Any]) -> str:
    switches = sim.get("disturbances", {})
    on = sorted(k for k, v in switches.items() if v) if isinstance(switches, dict) else []
    off = sorted(k for k, v in switches.items() if not v) if isinstance(switches, dict) else []
    out = ["<h3>Disturbances injected</h3>"]
    out.append(
        f"<p>On: {', '.join(f'<code>{_e(k)}</code>' for k in on) or 'none'}.<br>"
        f"Off: {', '.join(f'<code>{_e(k)}</code>' for k in off) or 'none'}.</p>"
    )
    dvl = sim.get("dvl")
    if isinstance(dvl, dict):
        segs = [s for s in dvl.get("noise_segments", []) if isinstance(s, list) and len(s) >= 3]
        drops = [d for d in dvl.get("dropouts", []) if isinstance(d, list) and len(d) >= 2]
        seg_time = sum(float(s[1]) - float(s[0]) for s in segs)
        drop_time = sum(float(d[1]) - float(d[0]) for d in drops)
        factors = [float(s[2]) for s in segs]
        rows = [
            (
                "outliers",
                f"{_e(dvl.get('outlier_samples', '?'))} samples in "
                f"{_e(dvl.get('outlier_events', '?'))} events, of "
                f"{_e(dvl.get('navigation_samples', '?'))} navigation samples",
            ),
            (
                "noise segments (σ × factor)",
                f"{len(segs)}, {seg_time:.0f} s in all"
                + (f", factor {min(factors):.1f}–{max(factors):.1f}" if factors else ""),
            ),
            ("dropouts", f"{len(drops)}, {drop_time:.0f} s in all"),
        ]
        out.append("<h3>DVL disturbances realised</h3>")
        out.append(_table(("quantity", "value"), rows, text_columns=2))
    return "\n".join(out)


def _sensor_kind(s: dict[str, Any]) -> str:
    """A sensor's kind, and for an inclinometer which model reads it (docs/inclinometer.md)."""
    kind = str(s.get("kind", "?"))
    return f"{kind} ({s.get('model', 'pendulum')})" if kind == "inclinometer" else kind


def _sensors(toml: Mapping[str, Any] | None) -> str:
    parts = ['<section id="sensors"><h2>Sensors</h2>']
    if not toml:
        parts.append('<p class="note">mission.toml not found: sensor details unavailable.</p>')
        parts.append("</section>")
        return "\n".join(parts)
    rows = []
    for name, s in (toml.get("sensors") or {}).items():
        if not isinstance(s, dict):
            continue
        over = [f"{k} = {s[k]}" for k in ("gate_q", "vb_rho", "matching_window") if k in s]
        rows.append(
            (
                _e(name),
                _e(_sensor_kind(s)),
                _e(s.get("use", "aid")),
                _num(s.get("rate_hz"), "{:g}", "from data"),
                _pair(s.get("sigma")),
                _pair(s.get("lever_arm_m")) if s.get("lever_arm_m") is not None else "0, 0, 0",
                _e("; ".join(over)) or "–",
            )
        )
    parts.append(
        _table(
            (
                "sensor",
                "kind",
                "use",
                "rate (Hz)",
                "nominal σ",
                "lever arm (m, body FRD)",
                "overrides",
            ),
            rows,
            text_columns=3,
        )
    )
    imu = toml.get("imu") or {}
    noise = imu.get("noise") or {}
    bias = imu.get("initial_bias_sigma") or {}
    imu_rows = [(_e(k), _pair(v)) for k, v in noise.items()]
    imu_rows += [(_e(f"initial bias σ, {k}"), _pair(v)) for k, v in bias.items()]
    parts.append(
        f"<h3>IMU ({_num(imu.get('rate_hz'), '{:g}')} Hz, {_e(imu.get('format', '?'))})</h3>"
    )
    parts.append(_table(("noise term", "value"), imu_rows, text_columns=2))
    parts.append(
        '<p class="note"><em>use</em>: <code>aid</code> readings are fused, '
        "<code>init</code> only initialise (GPS: the alignment's position), "
        "<code>off</code> are ignored.</p>"
    )
    parts.append("</section>")
    return "\n".join(parts)


def _filters(doc: Mapping[str, Any], summaries: Mapping[str, Mapping[str, Any]]) -> str:
    rows = []
    for name in doc.get("filters", []):
        meta = summaries.get(name, {}).get("meta", {})
        fs = meta.get("filter_settings") if isinstance(meta, dict) else None
        label = FILTER_LABELS.get(name, name)
        rate = meta.get("imu_samples_per_s") if isinstance(meta, dict) else None
        if not isinstance(fs, dict):
            rows.append((_e(label), "–", "–", "–", "–", "–", _num(rate, "{:,.0f}")))
            continue
        kind = fs.get("kind", name)
        q = (fs.get("gate_q") or {}).get(kind)
        gate = (
            f"q = {q:g} ({_e(fs.get('gate_rule'))}, {_e(fs.get('gate_reference', 'adapted'))} R) "
            f"on {_e(', '.join(fs.get('gate_sensors', [])))}"
            if q is not None
            else "none"
        )
        p_guard = fs.get("guard_probability")
        if isinstance(p_guard, int | float) and p_guard > 0:
            gate += (
                f"; guard χ² on {_e(fs.get('guard_headroom'))} × the nominal R, p = "
                f"{p_guard:g}, every sensor, lockout {_e(fs.get('guard_lockout_s'))} s"
            )
        qa = fs.get("q_adaptation")
        if isinstance(qa, Mapping):
            gate += f"; Q adaptation above lag-1 correlation {_e(qa.get('target'))}"
        if kind == "maeskf":
            r = (
                f"covariance matching, window {_e(fs.get('matching_window'))}, "
                f"floor {_e(fs.get('matching_floor'))}"
            )
        elif kind in ("vb", "robust"):
            r = (
                f"variational Bayes, ρ = {_e(fs.get('vb_rho'))}, N = "
                f"{_e(fs.get('vb_iterations'))}, α0 = {_e(fs.get('vb_alpha0'))}"
            )
            bounds = (fs.get("r_bounds") or {}).get(kind)
            if bounds:
                r += f", R̂ in [{_e(bounds[0])}, {_e(bounds[1])}] × nominal"
            dg = (fs.get("divergence") or {}).get(kind)
            if isinstance(dg, dict) and dg.get("nis_ratio"):
                r += (
                    f"; windowed NIS test: NIS/d > {_e(dg.get('nis_ratio'))} over "
                    f"{_e(dg.get('window'))} readings inflates P"
                )
        elif kind == "oracle":
            r = "the simulator's true σ per reading, outliers flagged"
        else:
            r = "fixed nominal R"
        rows.append(
            (
                _e(label),
                _e(kind),
                gate,
                r,
                _e(meta.get("epoch_policy", "?")),
                _e(meta.get("initial", "?")),
                _num(rate, "{:,.0f}"),
            )
        )
    table = _table(
        (
            "filter",
            "kind",
            "outlier gate",
            "measurement noise R",
            "epochs",
            "start",
            "IMU samples/s",
        ),
        rows,
        text_columns=6,
    )
    return (
        '<section id="filters"><h2>Filter settings</h2>\n'
        "<p>All filters share one engine and one start (the alignment below, "
        "<em>start = given</em>); they differ only in how R is chosen and whether readings "
        "are gated. The gate rejects a reading when the square of its innovation exceeds q "
        "times the innovation's predicted variance (component by component for the "
        "<em>component</em> rule, as one χ² statistic for <em>chi2</em>); q is the paper's "
        "rejection coefficient (Fig. 4).</p>\n"
        f"{table}\n</section>"
    )


def _paper(mission: str, name: str) -> tuple[float, float]:
    return PAPER_TABLE3.get(mission, {}).get(name, (math.nan, math.nan))


def _results(doc: Mapping[str, Any]) -> str:
    mission = str(doc.get("mission", ""))
    results: Mapping[str, Mapping[str, Any]] = doc.get("results", {})
    rows = []
    for name in doc.get("filters", list(results)):
        r = results.get(name, {})
        p_rmse, p_rel = _paper(mission, name)
        rows.append(
            (
                _e(FILTER_LABELS.get(name, name)),
                _num(r.get("rmse_m"), "{:.1f}"),
                _num(r.get("relative_rmse_pct"), "{:.3f}"),
                _num(p_rmse, "{:.0f}"),
                _num(p_rel, "{:.2f}"),
                _num(r.get("horizontal_rmse_m"), "{:.1f}"),
                _num(r.get("max_horizontal_error_m"), "{:.1f}"),
                _num(r.get("final_horizontal_error_m"), "{:.1f}"),
                _num(_div(r.get("distance_m"), 1000.0), "{:.3f}"),
                _num(_div(r.get("duration_s"), 60.0), "{:.1f}"),
            )
        )
    table = _table(
        (
            "filter",
            "RMSE (m)",
            "relative RMSE (%)",
            "paper RMSE (m)",
            "paper relative RMSE (%)",
            "horizontal RMSE (m)",
            "max horizontal error (m)",
            "final horizontal error (m)",
            "horizontal distance (km)",
            "duration (min)",
        ),
        rows,
        table_id="comparison",
    )
    parts = ['<section id="results"><h2>Results beside the paper\'s Table 3</h2>', table]
    parts.append(f"<p>{_summary(mission, doc.get('filters', []), results)}</p>")
    parts.append(
        '<p class="note">RMSE = √mean(δN² + δE² + δD²) over the reference samples within the '
        "run (the paper's eq. 32); relative RMSE = 100 RMSE / distance travelled (eq. 33), the "
        "distance being the horizontal length of the reference track, so that heave does not "
        "lengthen it. One seed of a simulation: the paper's sea trials are not these data, so "
        "compare the ordering and the size of the improvements, not the absolute numbers.</p>"
    )
    parts.append("</section>")
    return "\n".join(parts)


_NEES_BLOCKS = ("position", "velocity", "attitude")


def _consistency(doc: Mapping[str, Any]) -> str:
    results: Mapping[str, Mapping[str, Any]] = doc.get("results", {})
    rows = []
    diagonal = []
    for name in doc.get("filters", list(results)):
        r = results.get(name, {})
        cells = [_e(FILTER_LABELS.get(name, name))]
        for block in _NEES_BLOCKS:
            cells.append(_num(r.get(f"mean_nees_{block}"), "{:.2f}"))
            cells.append(_num(_mul(r.get(f"nees_{block}_in_95"), 100.0), "{:.0f}"))
        rows.append(cells)
        if r.get("nees_uses_correlations") is False:
            diagonal.append(FILTER_LABELS.get(name, name))
    headers = ["filter"]
    for block in _NEES_BLOCKS:
        headers += [f"mean NEES, {block}", f"{block}: % of epochs in band"]
    parts = [
        '<section id="nees"><h2>Consistency (NEES)</h2>',
        "<p>Does each filter's covariance describe its actual errors? At every reference "
        "sample, NEES = eᵀ P⁻¹ e for the position (m), velocity (m/s) and attitude (rotation "
        "vector, rad) errors, each with its full 3×3 block of P. For a consistent filter "
        f"NEES is χ²(3): {_e(NEES_BAND_TEXT)}. A mean above 3 means the filter claims more "
        "accuracy than it has; below 3, less. Successive epochs are strongly correlated, so "
        "one run's share in the band varies much more than a binomial count would.</p>",
        _table(headers, rows, table_id="consistency"),
    ]
    if diagonal:
        parts.append(
            '<p class="note">No covariance columns in the run folders of '
            f"{_e(', '.join(diagonal))}: their NEES use P's diagonal only.</p>"
        )
    parts.append("</section>")
    return "\n".join(parts)


def _mul(a: Any, b: float) -> float | None:
    try:
        return float(a) * b
    except (TypeError, ValueError):
        return None


def _reduction(better: float | None, worse: float | None) -> float | None:
    if better is None or worse is None or not worse:
        return None
    return 100.0 * (1.0 - better / worse)


def _summary(mission: str, filters: Sequence[str], results: Mapping[str, Mapping[str, Any]]) -> str:
    rel = {
        n: float(results[n]["relative_rmse_pct"])
        for n in filters
        if n in results and isinstance(results[n].get("relative_rmse_pct"), int | float)
    }
    if not rel:
        return "No filter produced a score."
    ranked = sorted(rel, key=lambda n: rel[n])
    text = (
        "Ranking by relative RMSE, best first: "
        + ", ".join(f"{_e(FILTER_LABELS.get(n, n))} ({rel[n]:.3f} %)" for n in ranked)
        + "."
    )
    sentences = [text]
    for other in ("meskf", "maeskf"):
        ours = _reduction(rel.get("vb"), rel.get(other))
        if ours is None:
            continue
        change = (
            f"lowers the relative RMSE by {ours:.0f} %"
            if ours >= 0
            else f"raises the relative RMSE by {-ours:.0f} %"
        )
        s = f"Against {FILTER_LABELS[other]}, VB-MAESKF {change}"
        theirs = _reduction(_paper(mission, "vb")[1], _paper(mission, other)[1])
        if theirs is not None and math.isfinite(theirs):
            s += f" (the paper, on this trajectory: by {theirs:.0f} %)"
        sentences.append(s + ".")
    paper_order = [n for n in ("vb", "maeskf", "meskf") if n in rel]
    if mission in PAPER_TABLE3 and len(paper_order) > 1:
        same = [n for n in ranked if n in paper_order] == paper_order
        sentences.append(
            "The paper's ordering (VB-MAESKF, MAESKF, MESKF) is "
            + ("reproduced." if same else "<strong>not</strong> reproduced.")
        )
    return " ".join(sentences)


_CAPTIONS: dict[str, str] = {
    "trajectory": (
        "Estimated tracks, east against north of the navigation start, over the reference "
        "(black), as the paper's Figs. 7 and 8. Look at where each track leaves the reference "
        "and whether it comes back; the right panel zooms on the end of the run, where the "
        "accumulated error shows (markers: each run's end point, black square: the "
        "reference's)."
    ),
    "position_error": (
        "3-D (top) and horizontal (bottom) position error over time, estimate minus reference, "
        "as the paper's Fig. 9. Look at the jumps: they follow DVL outlier bursts and noisy "
        "segments that a filter trusted; in the paper VB-MAESKF's error stays lowest "
        "throughout, bounded on the round trip and growing on the straight run."
    ),
    "ledger_counts": (
        "Fate of the aiding readings after the navigation start, per sensor and filter: fused "
        "(used), refused by the outlier gate (rejected; only MESKF and MAESKF gate, and only "
        "the DVL by default) and dropped as invalid (e.g. DVL dropouts). Look at how many good "
        "readings a gate throws away beside the outliers it catches: VB-MAESKF rejects none "
        "and de-weights instead."
    ),
    "nis": (
        "Running mean of the normalised innovation squared per component (NIS divided by the "
        "reading's dimension) for each aiding sensor. A consistent filter stays near 1 (black "
        "line). Above 1 the filter trusts the sensor more than it deserves (R too small: "
        "MESKF in rough sea); below 1 it distrusts it."
    ),
}


def _caption(stem: str, sim: bool) -> str:
    if stem in _CAPTIONS:
        return _CAPTIONS[stem]
    if stem.startswith("noise_"):
        sensor = stem[len("noise_") :]
        text = (
            f"{sensor}: its measurements (top: grey; the simulator's true value in black and "
            "injected outliers as red crosses where known) and the noise variance R̂ that "
            "MAESKF and VB-MAESKF used at each reading (bottom, log scale), as the paper's "
            "Fig. 10. Grey dashes: the nominal R that MESKF uses throughout"
        )
        if sim:
            text += (
                "; black line: the true σ² the simulator applied; black dots: the actual "
                "squared error (running mean), pendulum error and outliers included"
            )
        text += (
            ". Look for R̂ rising where the measurements jump and falling back afterwards: "
            "MAESKF follows the innovations of its window, VB-MAESKF rises at once and "
            "forgets at the rate of ρ."
        )
        if sensor == "inclinometer":
            text += (
                " The inclinometer is a pendulum: vessel accelerations tilt it, an error its "
                "nominal σ (and the simulator's σ column) leave out, so compare R̂ with the "
                "actual squared error."
            )
        return text
    return f"Figure {stem}."


def _figures(compare_dir: Path, doc: Mapping[str, Any], sim: bool) -> str:
    parts = ['<section id="figures"><h2>Figures</h2>']
    files = doc.get("figures") or []
    if not files:
        parts.append('<p class="note">No figures were saved.</p>')
    for k, rel in enumerate(files, start=1):
        path = compare_dir / str(rel)
        stem = Path(str(rel)).stem
        try:
            data = base64.b64encode(path.read_bytes()).decode("ascii")
        except OSError as exc:
            raise ReportError(f"{path}: figure missing ({exc.strerror})") from exc
        caption = _caption(stem, sim)
        parts.append(
            f'<figure id="fig-{_e(stem)}">\n'
            f'<img src="data:image/png;base64,{data}" alt="{_e(caption[:120])}">\n'
            f"<figcaption><strong>Figure {k}.</strong> {_e(caption)}</figcaption>\n</figure>"
        )
    parts.append("</section>")
    return "\n".join(parts)


def _ledger(doc: Mapping[str, Any]) -> str:
    results: Mapping[str, Mapping[str, Any]] = doc.get("results", {})
    rows = []
    for name in doc.get("filters", list(results)):
        counts = results.get(name, {}).get("counts") or {}
        nis = results.get(name, {}).get("mean_nis") or {}
        for sensor in sorted(counts):
            c = counts[sensor]
            rows.append(
                (
                    _e(FILTER_LABELS.get(name, name)),
                    _e(sensor),
                    *(_e(c.get(f, 0)) for f in ("used", "rejected", "dropped")),
                    _num(nis.get(sensor), "{:.2f}"),
                )
            )
    table = _table(
        ("filter", "sensor", "used", "rejected", "dropped", "mean NIS"),
        rows,
        table_id="ledger",
        text_columns=2,
    )
    return (
        '<section id="ledger-counts"><h2>Ledger</h2>\n'
        "<p>Every reading of the mission and its fate. <em>dropped</em> counts the whole "
        "mission: readings inside the alignment window, of initialisation-only sensors and "
        "invalid ones (the run folders' <code>ledger.parquet</code> says which, reading by "
        "reading). Mean NIS over the used readings; its expectation is the reading's "
        f"dimension.</p>\n{table}\n</section>"
    )


EVENTS_SHOWN = 12
"""Most events listed per filter in the report (all are in the run's events.parquet)."""


def _events(folder: Path, doc: Mapping[str, Any]) -> str:
    """Each filter's divergence guard events (estimation/health.py): counts, then the first ones."""
    import pandas as pd

    rows: list[tuple[str, ...]] = []
    for name in doc.get("filters", []):
        path = folder / str(name) / "events.parquet"
        try:
            ev = pd.read_parquet(path) if path.is_file() else None
        except Exception:  # an unreadable table is shown as such, the report still written
            ev = None
        label = _e(FILTER_LABELS.get(name, name))
        if ev is None:
            rows.append((label, "–", "–", "–", "–", "no events table"))
            continue
        n: dict[str, str] = {
            k: str(int((ev["event"] == k).sum())) for k in ("lockout", "nis", "covariance")
        }
        q = ev[ev["event"] == "q_scale"]
        n["q_scale"] = f"{q['factor'].iloc[-1]:.3g}" if len(q) else "1"
        first = "; ".join(
            f"{r.t:.1f} s {_e(r.sensor)} {_e(r.event)} ×{r.factor:.3g}"
            for r in ev.head(EVENTS_SHOWN).itertuples()
        )
        more = f" (+{len(ev) - EVENTS_SHOWN} more)" if len(ev) > EVENTS_SHOWN else ""
        rows.append((label, *n.values(), (first or "none") + more))
    table = _table(
        (
            "filter",
            "lockout",
            "NIS",
            "covariance",
            "Q scale β at the end",
            "first events (time, sensor, event, factor)",
        ),
        rows,
        table_id="events-table",
        text_columns=1,
    )
    return (
        '<section id="events"><h2>Divergence guard events</h2>\n'
        "<p>When a filter found itself inconsistent and inflated or repaired its covariance "
        "P: <em>lockout</em> (the guard rejected every reading of a sensor for the lockout "
        "time), <em>NIS</em> (the mean NIS/d of a sensor's recent readings above its "
        "threshold), <em>covariance</em> (P lost positive definiteness and was repaired); "
        "and the Q adaptation's scale β of the IMU white noise in Q (raised when successive "
        "innovations are correlated; 1: Q as configured). "
        "The windowed NIS test is off unless configured. The run folders' "
        "<code>events.parquet</code> lists every event.</p>\n"
        f"{table}\n</section>"
    )


def _initial(doc: Mapping[str, Any]) -> str:
    ini = doc.get("initial") or {}
    if not ini:
        return (
            '<section id="initial"><h2>Initial state</h2>'
            '<p class="note">No shared initial state (a baseline only).</p></section>'
        )
    source = {
        "heading": "the mission's given heading (e.g. the quay's charted bearing)",
        "gyrocompass": "gyrocompassing",
    }
    rows = [
        ("how", _e(ini.get("initial", "?"))),
        ("alignment window", f"{_num(ini.get('alignment_s'), '{:.0f}')} s"),
        (
            "heading from",
            _e(source.get(str(ini.get("heading_source")), ini.get("heading_source", "–"))),
        ),
        ("navigation starts at", f"{_num(ini.get('t0_s'), '{:.2f}')} s"),
        (
            "position",
            f"{_num(ini.get('lat_deg'), '{:.6f}')}° N, {_num(ini.get('lon_deg'), '{:.6f}')}° E, "
            f"h {_num(ini.get('h_m'), '{:.2f}')} m",
        ),
        ("coarse roll, pitch, yaw", _deg3(ini.get("coarse_rpy_deg"))),
        ("aligned roll, pitch, yaw", _deg3(ini.get("rpy_deg"))),
        ("σ attitude (roll, pitch, yaw)", _deg3(ini.get("sigma_attitude_deg"), "{:.3f}")),
        ("σ position (N, E, D)", _vec(ini.get("sigma_position_m"), "m")),
        ("σ velocity (N, E, D)", _vec(ini.get("sigma_velocity_m_s"), "m/s", "{:.4f}")),
    ]
    return (
        '<section id="initial"><h2>Initial alignment (shared by every filter)</h2>\n'
        "<p>One static alignment over the start of the mission (levelling, heading, ZUPT fine "
        "alignment); every filter starts from its state and covariance, so their "
        "differences come from the filters alone. The DVL dead-reckoning baseline, if "
        "present, starts on its own.</p>\n"
        + _table(("quantity", "value"), rows, text_columns=2)
        + "\n</section>"
    )


def _deg3(values: Any, fmt: str = "{:.3f}") -> str:
    if not isinstance(values, list):
        return "–"
    return ", ".join(_num(v, fmt) for v in values) + " °"


def _vec(values: Any, unit: str, fmt: str = "{:.3f}") -> str:
    if not isinstance(values, list):
        return "–"
    return ", ".join(_num(v, fmt) for v in values) + f" {_e(unit)}"


# --- the page ------------------------------------------------------------------------------


def write_report(
    compare_dir: str | Path,
    out_file: str | Path | None = None,
    *,
    shown_as: str | Path | None = None,
) -> Path:
    """Write the HTML report of the comparison folder ``compare_dir``; returns its path
    (default ``compare_dir/report.html``). ``shown_as``: the folder's path to print in the
    page instead of ``compare_dir`` (a temporary folder renamed there afterwards).

    Raises :class:`ReportError` (a ValueError) naming the file when ``comparison.json`` or a
    figure it lists is missing or unreadable.
    """
    from adaptnav import __version__

    folder = Path(compare_dir)
    if not folder.is_dir():
        raise ReportError(f"comparison folder {folder} does not exist")
    doc = _read_json(folder / COMPARISON_JSON)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT_NAME:
        raise ReportError(f"{folder / COMPARISON_JSON}: not an {FORMAT_NAME} file")
    mission_dir = _mission_dir(folder, doc)
    toml = _mission_toml(mission_dir)
    sim = _optional_json(mission_dir / SIMULATION_FILE) if mission_dir else None
    summaries = {}
    for name in doc.get("filters", []):
        summary = _optional_json(folder / str(name) / "summary.json")
        if summary is not None:
            summaries[str(name)] = summary

    mission = str(doc.get("mission", "?"))
    title = f"adaptnav: filters compared on {mission}"
    if sim and sim.get("seed") is not None:
        title += f" (seed {sim['seed']})"
    filters = ", ".join(FILTER_LABELS.get(n, n) for n in doc.get("filters", []))
    shown = folder.resolve() if shown_as is None else Path(shown_as)
    if mission_dir is not None and shown_as is not None and mission_dir == folder / MISSION_SUBDIR:
        mission_dir = shown / MISSION_SUBDIR
    where = f"mission folder {mission_dir}" if mission_dir else "mission folder not found"
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    sections = [
        _scenario(doc, toml, sim),
        _sensors(toml),
        _filters(doc, summaries),
        _results(doc),
        _consistency(doc),
        _figures(folder, doc, sim is not None),
        _ledger(doc),
        _events(folder, doc),
        _initial(doc),
    ]
    toc = [
        ("scenario", "Scenario"),
        ("sensors", "Sensors"),
        ("filters", "Filter settings"),
        ("results", "Results beside the paper's Table 3"),
        ("nees", "Consistency (NEES)"),
        ("figures", "Figures"),
        ("ledger-counts", "Ledger"),
        ("events", "Divergence guard events"),
        ("initial", "Initial alignment"),
    ]
    nav = "".join(f'<li><a href="#{a}">{_e(t)}</a></li>' for a, t in toc)
    page = f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(title)}</title>
<style>{_CSS}</style>
</head>
<body>
<header>
<h1>{_e(title)}</h1>
<p>{_e(filters)} run on one mission from one shared alignment and scored against the
reference, after Davari &amp; Gholami, <em>Ocean Engineering</em> 174 (2019): its Table 3 and
Figs. 7–10.</p>
<nav><ul>{nav}</ul></nav>
</header>
<main>
{chr(10).join(sections)}
</main>
<footer><p class="note">Written by adaptnav {_e(__version__)} on {_e(now)} from
{_e(shown)} ({_e(where)}).</p></footer>
</body>
</html>
"""
    out = Path(out_file) if out_file is not None else folder / REPORT_FILE
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(page, encoding="utf-8")
    return out
