"""The HTML report: parsed without a browser (table rows, each figure either an interactive
Plotly figure or a data-URI <img>, no external reference, escaped strings, one colour per
filter in every figure) and rendered in headless Chromium (every interactive figure drawn,
every image decodes, the table has one row per filter, no console error, no request leaving
the file), with a screenshot kept as an artifact.

Chromium is Debian's ``chromium`` package, driven by Playwright with that executable (never
``playwright install``). Without either the browser test is skipped, except under CI (``CI``
set), where it fails.
"""

from __future__ import annotations

import base64
import html
import json
import os
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.analysis import compare as compare_mod
from adaptnav.analysis.compare import COMPARISON_JSON, Comparison, compare
from adaptnav.api.results import CALIBRATION_FILE, events_frame, write_parquet
from adaptnav.cli import app
from adaptnav.experiments import figures as sweep_figures
from adaptnav.sim.scenarios import simulate
from adaptnav.viz import interactive, plots
from adaptnav.viz.report import ReportError, write_report
from helpers import calibrated

runner = CliRunner()

FILTERS: tuple[str, ...] = ("meskf", "maeskf", "vb", "oracle")
CHROMIUM_PATH = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip
PNG = b"\x89PNG\r\n\x1a\n"


INTERACTIVE = {"position_error", "noise_dvl", "noise_depth", "noise_inclinometer", "nis"}
"""The demo's figures that the report shows interactive (time series); the others are PNGs."""


def _save(cmp: Comparison, out: Path) -> Path:
    return cmp.save(
        out, figures=plots.comparison_figures(cmp), interactive=interactive.comparison_figures(cmp)
    )


@pytest.fixture(scope="module")
def compared(tmp_path_factory: pytest.TempPathFactory) -> tuple[Comparison, Path]:
    """The comparison of the demo preset and its folder, mission inside the folder."""
    out = tmp_path_factory.mktemp("report")
    mission = simulate("demo", 4, out / "mission")
    cmp = compare(mission, FILTERS)
    return cmp, _save(cmp, out)


@pytest.fixture(scope="module")
def report(compared: tuple[Comparison, Path]) -> tuple[Path, Path]:
    """(comparison folder, report file) of the demo preset."""
    return compared[1], write_report(compared[1])


class _Page(HTMLParser):
    """Collects the body rows of the tables with an id (``tables``; the comparison's are
    ``rows``), figures, images and captions."""

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.table: str | None = None
        self.tables: dict[str, list[list[str]]] = {}
        self.figures = 0
        self.captions: list[str] = []
        self.figure_imgs: list[str] = []
        self.imgs: list[str] = []
        self.plots: list[str] = []
        """Ids of the JSON specifications of the interactive figures' <div>s."""
        self.scripts: dict[str, str] = {}
        """Text of the <script> elements by id (``""`` for one without)."""
        self._script: tuple[str, list[str]] | None = None
        self._cell: list[str] | None = None
        self._caption: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "table" and a.get("id"):
            self.table = a["id"]
            self.tables[self.table] = []
        if self.table and tag == "tr" and "tbody" in self.stack:
            self.tables[self.table].append([])
        if self.table and tag == "td":
            self._cell = []
        if tag == "figure":
            self.figures += 1
        if tag == "figcaption":
            self._caption = []
        if tag == "div" and "plotly-figure" in (a.get("class") or "") and "figure" in self.stack:
            self.plots.append(a.get("data-spec") or "")
        if tag == "script":
            assert "src" not in a, "a script from a file or the network"
            self._script = (a.get("id") or "", [])
        if tag == "img":
            self.imgs.append(a.get("src") or "")
            if "figure" in self.stack:
                self.figure_imgs.append(a.get("src") or "")
        if tag not in ("img", "meta", "br"):
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag == "td" and self._cell is not None and self.table and self.tables[self.table]:
            self.tables[self.table][-1].append("".join(self._cell).strip())
            self._cell = None
        if tag == "table":
            self.table = None
        if tag == "script" and self._script is not None:
            self.scripts[self._script[0]] = "".join(self._script[1])
            self._script = None
        if tag == "figcaption" and self._caption is not None:
            self.captions.append("".join(self._caption).strip())
            self._caption = None
        if self.stack and self.stack[-1] == tag:
            self.stack.pop()

    @property
    def rows(self) -> list[list[str]]:
        return self.tables.get("comparison", [])

    def handle_data(self, data: str) -> None:
        if self._script is not None:
            self._script[1].append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._caption is not None:
            self._caption.append(data)


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def test_report_has_the_table_and_every_figure(report: tuple[Path, Path]) -> None:
    folder, path = report
    assert path == folder / "report.html"
    doc = json.loads((folder / COMPARISON_JSON).read_text())
    page = _parse(path)
    assert [r[0] for r in page.rows] == [doc["labels"][n] for n in FILTERS]
    for row, name in zip(page.rows, FILTERS, strict=True):
        assert float(row[1]) == pytest.approx(doc["results"][name]["rmse_m"], abs=0.05)
    assert set(doc["interactive"]) == INTERACTIVE
    assert page.figures == len(doc["figures"]) == len(page.figure_imgs) + len(page.plots)
    assert len(page.imgs) == len(page.figure_imgs) == len(doc["figures"]) - len(INTERACTIVE)
    assert sorted(page.plots) == sorted(f"spec-{stem}" for stem in INTERACTIVE)
    assert len(page.captions) == page.figures and all(len(c) > 40 for c in page.captions)
    for src in page.figure_imgs:
        head, data = src.split(",", 1)
        assert head == "data:image/png;base64"
        assert base64.b64decode(data)[:8] == PNG
    for spec in page.plots:
        figure = json.loads(page.scripts[spec])
        assert figure["data"] and all(t["type"] == "scatter" for t in figure["data"])


def test_report_shows_each_filters_nees(report: tuple[Path, Path]) -> None:
    folder, path = report
    doc = json.loads((folder / COMPARISON_JSON).read_text())
    page = _parse(path)
    rows = page.tables["consistency"]
    assert [r[0] for r in rows] == [doc["labels"][n] for n in FILTERS]
    for row, name in zip(rows, FILTERS, strict=True):
        r = doc["results"][name]
        for k, block in enumerate(("position", "velocity", "attitude")):
            assert float(row[1 + 2 * k]) == pytest.approx(r[f"mean_nees_{block}"], abs=0.005)
            share = 100.0 * r[f"nees_{block}_in_95"]
            assert float(row[2 + 2 * k]) == pytest.approx(share, abs=0.5)
    text = path.read_text(encoding="utf-8")
    assert "mean 3, 95 % of epochs in [0.216, 9.348]" in text
    assert "horizontal length of the reference track" in text


@pytest.fixture(scope="module")
def smoothed_report(report: tuple[Path, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of two filters RTS-smoothed (docs/smoothing.md) on the same mission."""
    out = tmp_path_factory.mktemp("smoothed-report")
    cmp = compare(report[0] / "mission", ("meskf", "vb"), smooth=True)
    return write_report(_save(cmp, out))


def test_report_of_smoothed_runs_shows_forward_beside_smoothed(smoothed_report: Path) -> None:
    doc = json.loads((smoothed_report.parent / COMPARISON_JSON).read_text())["results"]
    page = _parse(smoothed_report)
    for row, name in zip(page.rows, ("meskf", "vb"), strict=True):
        r = doc[name]
        assert float(row[1]) == pytest.approx(r["rmse_m"], abs=0.05)
        assert float(row[2]) == pytest.approx(r["relative_rmse_pct"], abs=5e-4)
        assert float(row[3]) == pytest.approx(r["forward_rmse_m"], abs=0.05)
        assert float(row[4]) == pytest.approx(r["forward_relative_rmse_pct"], abs=5e-4)
    for row, name in zip(page.tables["consistency"], ("meskf", "vb"), strict=True):
        assert float(row[-1]) == pytest.approx(doc[name]["forward_mean_nees_position"], abs=0.005)
    text = smoothed_report.read_text(encoding="utf-8")
    for needle in ("smoothed RMSE (m)", "forward RMSE (m)", "forward mean NEES, position"):
        assert needle in text, needle
    assert "solution is RTS-smoothed (docs/smoothing.md)" in text
    (caption,) = [c for c in page.captions if "3-D (top) and horizontal" in c]
    assert "forward solution" in caption and "RTS-smoothed" in caption


def _outside_scripts(path: Path) -> str:
    """The page's text without its <script> elements (the Plotly library and the figures'
    data, whose words are not the page's)."""
    return re.sub(r"<script[^>]*>.*?</script>", "", path.read_text(encoding="utf-8"), flags=re.S)


def test_report_of_unsmoothed_runs_says_nothing_of_smoothing(report: tuple[Path, Path]) -> None:
    text = _outside_scripts(report[1])
    assert "smooth" not in text.lower() and "forward" not in text.lower()


@pytest.fixture(scope="module")
def calibrated_report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(comparison folder, mission folder): MESKF and VB-MAESKF estimating the calibration of
    the demo mission with known errors (helpers.calibrated; docs/calibration.md), compared and
    reported through the command line, the mission outside the comparison folder."""
    root = tmp_path_factory.mktemp("calibrated-report")
    mission = calibrated.mission(root / "mission", estimate=True)
    out = root / "cmp"
    res = runner.invoke(app, ["compare", str(mission), "--filters", "meskf,vb", "--out", str(out)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["report", str(out)])
    assert res.exit_code == 0, res.output
    return out, mission


def test_report_of_runs_estimating_calibration_has_their_figure_and_table(
    calibrated_report: tuple[Path, Path],
) -> None:
    folder, mission = calibrated_report
    assert (
        "figures/calibration.png" in json.loads((folder / COMPARISON_JSON).read_text())["figures"]
    )
    path = folder / "report.html"
    text = path.read_text(encoding="utf-8")
    page = _parse(path)
    assert "spec-calibration" in page.plots
    spec = json.loads(page.scripts["spec-calibration"])
    assert [a["text"] for a in spec["layout"]["annotations"]] == list(calibrated.TRUTH)
    assert {t["legendgroup"] for t in spec["data"]} == {"meskf", "vb"}
    (caption,) = [c for c in page.captions if "calibration states the filters estimated" in c]
    assert "σ allowing for correlated readings" in text
    assert "±2σ" in caption and "true value" in caption
    assert 'href="#calibration"' in text
    true = calibrated.true_states(mission)
    found = {n: json.loads((folder / n / CALIBRATION_FILE).read_text()) for n in ("meskf", "vb")}
    rows = page.tables["calibration-estimates"]
    assert [r[0] for r in rows] == list(calibrated.TRUTH)
    for state, unit, prior, shown_true, *cells in rows:
        c = found["vb"][state]
        assert unit == c["unit"] and prior == f"{c['prior_sigma']:.3f}"
        assert float(shown_true) == pytest.approx(true[state], abs=5e-4)
        for cell, name in zip(cells, ("meskf", "vb"), strict=True):
            c = found[name][state]
            z = (c["estimate"] - true[state]) / c["sigma"]
            assert cell == (
                f"{c['estimate']:.3f} ± {c['sigma']:.3f} [{c['sigma_long_run']:.3f}] ({z:+.1f} σ)"
            ), (name, state)


def test_evaluate_finds_the_true_calibration_of_a_compared_run(
    calibrated_report: tuple[Path, Path],
) -> None:
    folder, mission = calibrated_report
    res = runner.invoke(app, ["evaluate", str(folder / "vb"), "--json"])
    assert res.exit_code == 0, res.output
    scored = json.loads(res.stdout)["calibration"]
    found = json.loads((folder / "vb" / CALIBRATION_FILE).read_text())
    true = calibrated.true_states(mission)
    assert list(scored) == list(found)
    for state, s in scored.items():
        assert s["error"] == pytest.approx(found[state]["estimate"] - true[state], abs=1e-9)


def test_report_without_calibration_states_has_no_calibration_figure_or_table(
    report: tuple[Path, Path],
) -> None:
    folder, path = report
    assert not any(
        "calibration" in f for f in json.loads((folder / COMPARISON_JSON).read_text())["figures"]
    )
    text = path.read_text(encoding="utf-8")
    assert 'id="calibration' not in text and "fig-calibration" not in text
    assert "Calibration states" not in text and "±2σ" not in text


def test_report_is_self_contained(report: tuple[Path, Path]) -> None:
    """Nothing outside the scripts points elsewhere, no script has a source, the Plotly library
    is inlined once and its config offers no way out of the page."""
    text = report[1].read_text(encoding="utf-8")
    page = _parse(report[1])  # fails on a <script src=...>
    outside = _outside_scripts(report[1]).lower()
    for needle in ('src="http', "src='http", "<link", "url(", "@import", "//cdn", "http:"):
        assert needle not in outside, needle
    assert page.scripts["plotly-library"].startswith("/**\n* plotly.js v")
    assert text.count("* plotly.js v") == 1  # inlined once, not once per figure
    assert set(page.scripts) == {"plotly-library", "plotly-config", "render-figures"} | set(
        page.plots
    )
    config = json.loads(page.scripts["plotly-config"])
    assert config["displaylogo"] is False and config["showLink"] is False
    assert config["typesetMath"] is False and "http" not in json.dumps(config)
    for spec in page.plots:  # the figures' own data name no address either
        assert "http" not in page.scripts[spec] and "mathjax" not in page.scripts[spec].lower()


def test_report_ids_are_unique_and_every_link_lands(report: tuple[Path, Path]) -> None:
    text = report[1].read_text(encoding="utf-8")
    ids = re.findall(r'\sid="([^"]+)"', text)
    assert len(ids) == len(set(ids)), sorted(i for i in set(ids) if ids.count(i) > 1)
    for target in re.findall(r'href="#([^"]+)"', text):
        assert target in ids, target


def test_report_describes_scenario_sensors_settings_and_alignment(
    report: tuple[Path, Path],
) -> None:
    text = report[1].read_text(encoding="utf-8")
    for needle in (
        "Disturbances injected", "dvl_outliers", "seed", "lever arm", "0.048 m/s",
        "ρ = 0.99", "q = 600", "q = 1800", "window 20", 'id="ledger"', "Initial alignment",
        "heading from", "Q adaptation above lag-1 correlation 0.5", "Q scale β at the end",
    ):  # fmt: skip
        assert needle in text, needle


def test_user_strings_are_escaped(report: tuple[Path, Path], tmp_path: Path) -> None:
    folder, _ = report
    copy = tmp_path / "cmp"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("mission"))
    doc = json.loads((copy / COMPARISON_JSON).read_text())
    doc["mission"] = "<script>alert('x')</script>"
    doc["mission_dir"] = str(tmp_path / "<b>elsewhere</b>")
    (copy / COMPARISON_JSON).write_text(json.dumps(doc))
    # A name inside an interactive figure's JSON must not close its <script> element either.
    spec_file = copy / doc["interactive"]["nis"]
    spec = json.loads(spec_file.read_text())
    spec["layout"]["title"]["text"] = "</script><script>alert('y')</script>&"
    spec_file.write_text(json.dumps(spec))
    out = write_report(copy, tmp_path / "r.html")
    text = out.read_text(encoding="utf-8")
    assert "<script>alert" not in text and "<b>elsewhere" not in text
    assert "&lt;script&gt;alert(" in text and doc["mission"] in html.unescape(text)
    assert "mission.toml not found" in text
    shown = json.loads(_parse(out).scripts["spec-nis"])
    assert shown["layout"]["title"]["text"] == spec["layout"]["title"]["text"]


def test_the_start_is_written_with_its_hemispheres_and_the_guards_rejections_named(
    report: tuple[Path, Path], tmp_path: Path
) -> None:
    """Up to 0.4.6 the report wrote a start at 33.9° S, 70° W as '-33.900035° N,
    -69.999992° E', and said VB-MAESKF rejects none while its bars showed the guard's
    rejections (found by an output audit)."""
    folder, _ = report
    copy = tmp_path / "cmp"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("mission"))
    doc = json.loads((copy / COMPARISON_JSON).read_text())
    doc["initial"]["lat_deg"], doc["initial"]["lon_deg"] = -33.900035, -69.999992
    (copy / COMPARISON_JSON).write_text(json.dumps(doc))
    text = write_report(copy, tmp_path / "r.html").read_text(encoding="utf-8")
    assert "33.900035° S, 69.999992° W" in text and "° N" not in text
    assert "rejects none" not in text and "by the guard" in text
    assert "σ attitude (about N, E, D)" in text


def test_a_sensor_warning_heads_the_report_and_none_leaves_no_section(
    report: tuple[Path, Path], tmp_path: Path
) -> None:
    """A run's ``meta.warnings`` (api/diagnosis.py) is listed, escaped, in a Warnings section
    before the scenario, with the filter's label; the demo's own runs have none, and their
    report has no such section."""
    folder, page = report
    assert 'id="warnings"' not in page.read_text(encoding="utf-8")
    copy = tmp_path / "cmp"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("mission"))
    summary = json.loads((copy / "vb" / "summary.json").read_text())
    assert summary["meta"]["warnings"] == []
    summary["meta"]["warnings"] = [{"sensor": "dvl", "message": "dvl: at odds <b>x</b>"}]
    (copy / "vb" / "summary.json").write_text(json.dumps(summary))
    text = write_report(copy, tmp_path / "r.html").read_text(encoding="utf-8")
    section = text.split('<section id="warnings">')[1].split("</section>")[0]
    assert "<strong>VB-MAESKF</strong>: dvl: at odds &lt;b&gt;x&lt;/b&gt;" in section
    assert text.index('id="warnings"') < text.index('id="scenario"')
    assert '<a href="#warnings">' in text


def test_an_events_table_not_the_runs_own_is_refused(
    report: tuple[Path, Path], tmp_path: Path
) -> None:
    """The report reads each run's events.parquet: one that is not the table the run wrote
    (its digest in the run's summary.json) is an error naming it, not shown as the run's."""
    folder, _ = report
    copy = tmp_path / "cmp"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("mission"))
    path = copy / "vb" / "events.parquet"
    row = {"t": 1.0, "sensor": "dvl", "row": 3, "event": "lockout", "statistic": 50.0,
           "threshold": 9.0, "factor": 1.0, "detail": "not this run's"}  # fmt: skip
    write_parquet(events_frame([row]), path)
    with pytest.raises(ReportError, match=r"vb/events\.parquet: not the file this run wrote"):
        write_report(copy, tmp_path / "r.html")
    res = runner.invoke(app, ["report", str(copy), "--out", str(tmp_path / "p.html")])
    assert res.exit_code == 2 and "events.parquet: not the file this run wrote" in res.output


def test_a_folder_without_interactive_figures_gets_its_pngs_and_no_script(
    report: tuple[Path, Path], tmp_path: Path
) -> None:
    """A comparison folder written before interactive figures existed (no ``interactive`` in
    comparison.json) is reported as before: every figure a PNG, no Plotly, no script."""
    folder, _ = report
    copy = tmp_path / "cmp"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("mission", "*.plotly.json"))
    doc = json.loads((copy / COMPARISON_JSON).read_text())
    del doc["interactive"]
    (copy / COMPARISON_JSON).write_text(json.dumps(doc))
    out = write_report(copy, tmp_path / "r.html")
    page = _parse(out)
    assert len(page.figure_imgs) == page.figures == len(doc["figures"]) and page.plots == []
    assert "<script" not in out.read_text(encoding="utf-8")


def test_report_command(report: tuple[Path, Path], tmp_path: Path) -> None:
    folder, _ = report
    target = tmp_path / "sub" / "page.html"
    res = runner.invoke(app, ["report", str(folder), "--out", str(target)])
    assert res.exit_code == 0, res.output
    assert res.stdout.strip() == str(target) and target.is_file()
    res = runner.invoke(app, ["report", str(tmp_path / "nothing")])
    assert res.exit_code == 2 and "Traceback" not in res.output
    with pytest.raises(ReportError, match=r"comparison\.json"):
        write_report(tmp_path / "sub")


def test_a_comparison_of_a_newer_format_version_is_refused(
    report: tuple[Path, Path], tmp_path: Path
) -> None:
    """comparison.json written by a newer adaptnav (a higher format version) is refused by
    name, not read with fields whose meaning this version does not know."""
    folder, _ = report
    copy = tmp_path / "cmp"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("mission"))
    doc = json.loads((copy / COMPARISON_JSON).read_text())
    (copy / COMPARISON_JSON).write_text(json.dumps({**doc, "version": doc["version"] + 1}))
    with pytest.raises(ReportError, match="written by a newer adaptnav"):
        write_report(copy, tmp_path / "r.html")
    res = runner.invoke(app, ["report", str(copy), "--out", str(tmp_path / "p.html")])
    assert res.exit_code == 2 and "newer adaptnav" in res.output and "Traceback" not in res.output


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _chromium() -> str:
    """The Chromium executable, or skip (fail under CI) when it or Playwright is missing."""
    path = shutil.which("chromium") or (str(CHROMIUM_PATH) if CHROMIUM_PATH.is_file() else None)
    missing = []
    if path is None:
        missing.append("chromium (apt-get install chromium)")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        missing.append("playwright (pip install -e .[dev])")
    if missing:
        message = f"headless browser test needs {' and '.join(missing)}"
        if _in_ci():
            pytest.fail(message + " (CI is set: the browser check may not be skipped)")
        pytest.skip(message)
    assert path is not None
    return path


@pytest.mark.parametrize(
    ("ci", "outcome"), [("", pytest.skip.Exception), ("true", pytest.fail.Exception)]
)
def test_a_missing_browser_skips_only_outside_ci(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, ci: str, outcome: type[BaseException]
) -> None:
    monkeypatch.setattr(shutil, "which", lambda _name: None)
    monkeypatch.setitem(globals(), "CHROMIUM_PATH", tmp_path / "no-chromium")
    monkeypatch.setenv("CI", ci)
    with pytest.raises(outcome, match="chromium"):
        _chromium()


def test_report_renders_in_headless_chromium(report: tuple[Path, Path], tmp_path: Path) -> None:
    """Every interactive figure is drawn (its SVG has a plot area and one line per trace of its
    specification), every image decodes, no script fails and no request leaves the file."""
    executable = _chromium()
    from playwright.sync_api import sync_playwright

    folder, path = report
    doc = json.loads((folder / COMPARISON_JSON).read_text())
    artifacts = Path(os.environ.get("ADAPTNAV_TEST_ARTIFACTS", tmp_path))
    artifacts.mkdir(parents=True, exist_ok=True)
    shot = artifacts / "report.png"
    requests: list[str] = []
    problems: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS, timeout=60_000)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on("request", lambda r: requests.append(r.url))
            page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: problems.append(str(e)))
            page.goto(path.resolve().as_uri(), wait_until="load")
            drawn = page.evaluate(
                "Array.from(document.querySelectorAll('div.plotly-figure')).map(d => [d.id, "
                "d.querySelectorAll('.main-svg').length, d.querySelectorAll('g.trace').length, "
                "d.getBoundingClientRect().height, (d.data || []).length])"
            )
            images = page.evaluate(
                "Array.from(document.images).map(i => [i.complete, i.naturalWidth, "
                "i.naturalHeight, i.getBoundingClientRect().width])"
            )
            rows = page.locator("table#comparison tbody tr").count()
            first_cells = page.locator("table#comparison tbody tr td:first-child").all_inner_texts()
            page.screenshot(path=str(shot), full_page=True)
        finally:
            browser.close()
    assert problems == []
    assert sorted(d[0] for d in drawn) == sorted(f"plot-{stem}" for stem in INTERACTIVE)
    for div, svgs, traces, height, data in drawn:
        assert svgs > 0 and height > 200, div
        assert traces == data > 0, div  # each trace of the specification drawn
    assert len(images) == len(doc["figures"]) - len(INTERACTIVE) > 0
    for complete, width, height, shown in images:
        assert complete and width > 0 and height > 0 and shown > 0
    assert rows == len(FILTERS)
    assert [c.strip() for c in first_cells] == [doc["labels"][n] for n in FILTERS]
    page_url = path.resolve().as_uri()
    external = [u for u in requests if u != page_url and not u.startswith(("data:", "blob:"))]
    assert external == []
    assert shot.read_bytes()[:8] == PNG
    print(f"screenshot of the report: {shot}")


# --- one colour per filter ---------------------------------------------------------------------

SENTINEL = "#123456"
"""A colour no figure module knows: given to VB-MAESKF in the one mapping, every figure must
draw VB-MAESKF in it."""


def _plotly_colours(figure: dict[str, Any]) -> list[tuple[str, str]]:
    """(filter, colour) of each trace of an interactive figure that belongs to a filter."""
    return [
        (t["legendgroup"], (t.get("line") or {}).get("color") or t["marker"]["color"])
        for t in figure["data"]
        if t.get("legendgroup") in compare_mod.FILTER_NAMES
    ]


def _hex(colour: Any) -> str:
    from matplotlib.colors import to_hex

    return str(to_hex(colour))


def _matplotlib_colours(fig: Any, labels: dict[str, str]) -> list[tuple[str, str]]:
    """(filter, colour) of each line and bar drawn with a filter's label (``labels``: display
    name → filter)."""
    found = []
    for ax in fig.axes:
        for line in ax.lines:
            if line.get_label() in labels:
                found.append((labels[line.get_label()], _hex(line.get_color())))
        for bars in ax.containers:
            if bars.get_label() in labels:
                found += [(labels[bars.get_label()], _hex(b.get_facecolor()[:3])) for b in bars]
    return found


def _sweep_table() -> pd.DataFrame:
    """A hand-made sweep: two seeds, two gate coefficients, MESKF and VB-MAESKF."""
    rows = [
        {"preset": "p", "seed": seed, "filter": f, "q": q, "q_scale": qs, "rmse_m": 1.0,
         "relative_rmse_pct": 0.1 * seed + q / 1000.0, "error": None}
        for seed in (1, 2) for f in ("meskf", "vb") for q, qs in ((200.0, 1.0), (400.0, 10.0))
    ]  # fmt: skip
    return pd.DataFrame(rows)


def test_every_figure_takes_each_filters_colour_from_the_one_mapping(
    compared: tuple[Comparison, Path],
    report: tuple[Path, Path],
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
) -> None:
    """The report's interactive figures (as embedded), and, with VB-MAESKF's colour changed in
    ``FILTER_COLOURS``, the interactive, the static and the sweep figures drawn again."""
    cmp, _ = compared
    page = _parse(report[1])
    for spec in page.plots:
        for name, colour in _plotly_colours(json.loads(page.scripts[spec])):
            assert colour == compare_mod.FILTER_COLOURS[name], (spec, name)
    monkeypatch.setitem(compare_mod.FILTER_COLOURS, "vb", SENTINEL)
    colours = dict(compare_mod.FILTER_COLOURS)
    labels = {compare_mod.FILTER_LABELS[n]: n for n in FILTERS}
    drawn: list[tuple[str, str]] = []
    for figure in interactive.comparison_figures(cmp).values():
        drawn += _plotly_colours(json.loads(figure.to_json()))
    for fig in plots.comparison_figures(cmp).values():
        drawn += _matplotlib_colours(fig, labels)
    figs: list[Any] = []
    monkeypatch.setattr(sweep_figures, "_save", lambda fig, path, dpi: figs.append(fig) or path)
    for plot in (sweep_figures.plot_q_sweep, sweep_figures.plot_monte_carlo):
        plot(_sweep_table(), tmp_path / "sweep.png")
    short = {sweep_figures.LABELS[n]: n for n in ("meskf", "vb")}
    sweep = [c for fig in figs for c in _matplotlib_colours(fig, short)]
    # The box plot's points carry no label: one point set per filter, in the ticks' order.
    (box,) = figs[1].axes
    points = [ln for ln in box.lines if ln.get_marker() == "o"]
    ticks = [short[t.get_text()] for t in box.get_xticklabels()]
    sweep += [(n, _hex(ln.get_color())) for n, ln in zip(ticks, points, strict=True)]
    assert {n for n, _ in drawn} == set(FILTERS) and {n for n, _ in sweep} == {"meskf", "vb"}
    wrong = [(n, c) for n, c in drawn + sweep if c.lower() != colours[n]]
    assert wrong == []
    assert ("vb", SENTINEL) in drawn and ("vb", SENTINEL) in sweep
    import matplotlib.pyplot as plt

    for fig in figs:  # drawn through pyplot, and not closed by the replaced _save
        plt.close(fig)


@pytest.mark.parametrize(
    ("name", "make", "extra", "message"),
    [
        ("mission.toml", "file", [], "not an .html file name"),
        ("summary.json", "file", ["--force"], "not an .html file name"),
        ("old.html", "file", [], "exists; give --force to replace it"),
        ("folder.html", "folder", [], "is a folder"),
        ("/proc/adaptnav-report.html", None, [], "cannot write"),
    ],
)
def test_report_out_never_writes_over_what_it_should_not(
    report: tuple[Path, Path],
    tmp_path: Path,
    name: str,
    make: str | None,
    extra: list[str],
    message: str,
) -> None:
    """``report --out`` names an HTML file and replaces one only with ``--force`` (up to 0.4.4
    it wrote the page over any file, a mission.toml or a run's summary.json included, and a
    folder or an unwritable place was a traceback)."""
    out = Path(name) if name.startswith("/") else tmp_path / name
    if make == "file":
        out.write_text("keep me\n")
    elif make == "folder":
        out.mkdir()
    res = runner.invoke(app, ["report", str(report[0]), "--out", str(out), *extra])
    assert res.exit_code == 2, res.output
    assert message in " ".join(res.output.split()), res.output
    assert "Traceback" not in res.output
    if make == "file":
        assert out.read_text() == "keep me\n"
    forced = runner.invoke(
        app, ["report", str(report[0]), "--out", str(tmp_path / "old.html"), "--force"]
    )
    assert forced.exit_code == 0, forced.output
    assert (tmp_path / "old.html").read_text().startswith("<!DOCTYPE html>")
