"""The HTML report: parsed without a browser (table rows, one data-URI <img> per figure, no
external reference, escaped strings) and rendered in headless Chromium (every image decodes,
the table has one row per filter, no network request), with a screenshot kept as an artifact.

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

import pytest
from typer.testing import CliRunner

from adaptnav.analysis.compare import COMPARISON_JSON, compare
from adaptnav.api.results import CALIBRATION_FILE
from adaptnav.cli import app
from adaptnav.sim.scenarios import simulate
from adaptnav.viz import plots
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


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(comparison folder, report file) of the demo preset, mission inside the folder."""
    out = tmp_path_factory.mktemp("report")
    mission = simulate("demo", 4, out / "mission")
    cmp = compare(mission, FILTERS)
    cmp.save(out, figures=plots.comparison_figures(cmp))
    return out, write_report(out)


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
        if tag == "figcaption" and self._caption is not None:
            self.captions.append("".join(self._caption).strip())
            self._caption = None
        if self.stack and self.stack[-1] == tag:
            self.stack.pop()

    @property
    def rows(self) -> list[list[str]]:
        return self.tables.get("comparison", [])

    def handle_data(self, data: str) -> None:
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
    assert page.figures == len(doc["figures"]) == len(page.figure_imgs) == len(page.imgs)
    assert len(page.captions) == page.figures and all(len(c) > 40 for c in page.captions)
    for src in page.figure_imgs:
        head, data = src.split(",", 1)
        assert head == "data:image/png;base64"
        assert base64.b64decode(data)[:8] == PNG


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
    cmp.save(out, figures=plots.comparison_figures(cmp))
    return write_report(out)


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


def test_report_of_unsmoothed_runs_says_nothing_of_smoothing(report: tuple[Path, Path]) -> None:
    text = report[1].read_text(encoding="utf-8")
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
    png = re.search(
        r'<figure id="fig-calibration">\s*<img src="data:image/png;base64,([^"]+)"', text
    )
    assert png is not None and base64.b64decode(png.group(1))[:8] == PNG
    page = _parse(path)
    (caption,) = [c for c in page.captions if "calibration states the filters estimated" in c]
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
            assert cell == f"{c['estimate']:.3f} ± {c['sigma']:.3f} ({z:+.1f} σ)", (name, state)


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
    text = report[1].read_text(encoding="utf-8")
    for needle in ('src="http', "src='http", "<script", "<link", "url(", "@import", "//cdn"):
        assert needle not in text.lower(), needle


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
    text = write_report(copy, tmp_path / "r.html").read_text(encoding="utf-8")
    assert "<script" not in text and "<b>elsewhere" not in text
    assert "&lt;script&gt;alert(" in text and doc["mission"] in html.unescape(text)
    assert "mission.toml not found" in text


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
    executable = _chromium()
    from playwright.sync_api import sync_playwright

    folder, path = report
    doc = json.loads((folder / COMPARISON_JSON).read_text())
    artifacts = Path(os.environ.get("ADAPTNAV_TEST_ARTIFACTS", tmp_path))
    artifacts.mkdir(parents=True, exist_ok=True)
    shot = artifacts / "report.png"
    requests: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS, timeout=60_000)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on("request", lambda r: requests.append(r.url))
            page.goto(path.resolve().as_uri(), wait_until="load")
            images = page.evaluate(
                "Array.from(document.images).map(i => [i.complete, i.naturalWidth, "
                "i.naturalHeight, i.getBoundingClientRect().width])"
            )
            rows = page.locator("table#comparison tbody tr").count()
            first_cells = page.locator("table#comparison tbody tr td:first-child").all_inner_texts()
            page.screenshot(path=str(shot), full_page=True)
        finally:
            browser.close()
    assert len(images) == len(doc["figures"]) > 0
    for complete, width, height, shown in images:
        assert complete and width > 0 and height > 0 and shown > 0
    assert rows == len(FILTERS)
    assert [c.strip() for c in first_cells] == [doc["labels"][n] for n in FILTERS]
    external = [u for u in requests if not u.startswith(("file:", "data:"))]
    assert external == []
    assert shot.read_bytes()[:8] == PNG
    print(f"screenshot of the report: {shot}")
