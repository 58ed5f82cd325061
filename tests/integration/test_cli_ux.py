"""The command line as a user meets it: help text in plain words, every long command's stages
on stderr (none with --quiet), and the wrong folder named for what it is."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import typer.main
from rich.text import Text
from typer.testing import CliRunner

from adaptnav.cli import _app, app
from adaptnav.sim.scenarios import PRESETS

runner = CliRunner()
COLUMNS = {"COLUMNS": "100"}

STAGE = re.compile(r"^\[\s*\d+\.\d s\] (.+)$", re.MULTILINE)
"""A stage line where stderr is not a terminal: the time since the command began, the stage."""


def _commands() -> Iterator[tuple[list[str], Any]]:
    """Every command and group of the CLI (typer's click objects) with its argument path
    (``["import", "akit"]``)."""
    todo: list[tuple[list[str], Any]] = [([], typer.main.get_command(app))]
    while todo:
        path, cmd = todo.pop()
        yield path, cmd
        todo += [([*path, name], sub) for name, sub in getattr(cmd, "commands", {}).items()]


COMMANDS = list(_commands())
assert len(COMMANDS) > 10, "the walk of the command tree found too few commands"
IDS = [" ".join(path) or "adaptnav" for path, _ in COMMANDS]


def _help(path: list[str]) -> str:
    res = runner.invoke(app, [*path, "--help"], env=COLUMNS)
    assert res.exit_code == 0, res.output
    return res.output


# --- help -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("path", "cmd"), COMMANDS, ids=IDS)
def test_help_shows_no_value_type_for_flags(path: list[str], cmd: Any) -> None:
    """A flag takes no value: its help row has no ``<bool>`` (typer 0.29 puts one on every
    flag, ``--help`` included); an option with a value keeps its type."""
    text = _help(path)
    assert "<bool>" not in text
    if any(getattr(p, "is_flag", True) is False for p in cmd.params):  # an option with a value
        assert re.search(r"<(str|int|float|path)>", text), text


@pytest.mark.parametrize(("path", "cmd"), COMMANDS, ids=IDS)
def test_help_is_plain_words(path: list[str], cmd: Any) -> None:
    """No reST or Markdown markup (backticks, ``:func:`` roles) and no spec or equation IDs
    (the spec's ``P-32``) in what ``--help`` prints."""
    text = _help(path)
    assert "`" not in text
    assert not re.search(r":(func|mod|class|data|meth|attr):", text), text
    assert not re.search(r"\bP-\d", text), text


@pytest.mark.parametrize(("path", "cmd"), COMMANDS, ids=IDS)
def test_help_strings_are_not_taken_for_markup(path: list[str], cmd: Any) -> None:
    """typer renders help as rich markup: a bracketed word (``[estimated from the data]``)
    would be taken for a style and vanish from the help. Every help string renders as
    written."""
    strings = [cmd.help or "", *(getattr(p, "help", None) or "" for p in cmd.params)]
    for s in strings:
        assert Text.from_markup(s).plain == s, s


@pytest.mark.parametrize("preset", ["paper-1", "paper-2"])
def test_simulate_help_gives_the_simulators_sensor_rates(preset: str) -> None:
    """The rates ``simulate --help`` quotes are the scenario's own (the pendulum inclinometer
    at 5 Hz, not 1 Hz)."""
    sc = PRESETS[preset]()
    text = " ".join(_help(["simulate"]).split())
    for quoted in (
        f"DVL ({sc.dvl.rate_hz:g} Hz)",
        f"depth meter ({sc.depth.rate_hz:g} Hz)",
        f"pendulum inclinometer ({sc.inclinometer.rate_hz:g} Hz)",
        f"GPS ({sc.gps.rate_hz:g} Hz",
    ):
        assert quoted in text


# --- the wrong folder -------------------------------------------------------------------------


def test_evaluate_on_a_mission_folder_says_it_is_a_mission(source: Path) -> None:
    res = runner.invoke(app, ["evaluate", str(source)])
    assert res.exit_code == 2
    assert "is a mission folder, not a run folder" in res.output
    assert f"adaptnav run {source}" in res.output and "Traceback" not in res.output


def test_evaluate_against_another_missions_reference_is_refused(
    source: Path, tmp_path: Path
) -> None:
    """``evaluate --mission`` of a mission of another name than the run's: its truth would
    score the run (up to 0.4.4: an RMSE of 235.7 m for a run whose own is 2.6 m, exit 0)."""
    run = tmp_path / "run"
    assert runner.invoke(app, ["run", str(source), "--out", str(run), "-q"]).exit_code == 0
    other = shutil.copytree(source, tmp_path / "other")
    toml = (other / "mission.toml").read_text()
    (other / "mission.toml").write_text(re.sub(r'name = "[^"]*"', 'name = "other"', toml, count=1))
    res = runner.invoke(app, ["evaluate", str(run), "--mission", str(other)])
    assert res.exit_code == 2, res.output
    assert "mission 'other', and the run is of" in " ".join(res.output.split())
    ok = runner.invoke(app, ["evaluate", str(run), "--mission", str(source), "--json"])
    assert ok.exit_code == 0, ok.output


# --- stages and --quiet -----------------------------------------------------------------------


def test_run_shows_its_stages_on_stderr(source: Path, tmp_path: Path) -> None:
    """Where stderr is not a terminal (a CI log) each stage is one line as it begins, stamped,
    in order, then ``done``; stdout keeps only the result."""
    res = runner.invoke(app, ["run", str(source), "--out", str(tmp_path / "r"), "--smooth"])
    assert res.exit_code == 0, res.output
    stages = STAGE.findall(res.stderr)
    expected = [
        f"loading {source}",
        "aligning over the static window",
        "running robust (VB, Student-t, bounded R̂)",
        "RTS smoothing robust (VB, Student-t, bounded R̂)",
        f"writing {tmp_path / 'r'}/",
        "done",
    ]
    assert [s.split("; compiling")[0] for s in stages] == expected
    assert not STAGE.search(res.stdout) and "IMU samples" in res.stdout


def test_quiet_prints_no_stages_only_the_result(source: Path, tmp_path: Path) -> None:
    res = runner.invoke(app, ["run", str(source), "--out", str(tmp_path / "r"), "--quiet"])
    assert res.exit_code == 0, res.output
    assert res.stderr == ""
    assert "IMU samples" in res.stdout and "dvl" in res.stdout
    evaluated = runner.invoke(app, ["evaluate", str(tmp_path / "r"), "-q"])
    assert evaluated.exit_code == 0 and evaluated.stderr == ""
    assert "RMSE (m)" in evaluated.stdout


def test_compare_stages_and_quiet_json(source: Path, tmp_path: Path) -> None:
    """compare: a stage per filter on stderr; with --quiet --json stdout is one JSON object
    and stderr is empty."""
    loud = runner.invoke(
        app, ["compare", str(source), "-f", "meskf,vb", "--out", str(tmp_path / "c"), "--json"]
    )
    assert loud.exit_code == 0, loud.output
    stages = STAGE.findall(loud.stderr)
    assert "running MESKF" in stages and "running VB-MAESKF" in stages and stages[-1] == "done"
    quiet = runner.invoke(
        app,
        ["compare", str(source), "-f", "meskf,vb", "--out", str(tmp_path / "q"), "--json", "-q"],
    )
    assert quiet.exit_code == 0 and quiet.stderr == ""
    assert set(json.loads(quiet.stdout)) == {"meskf", "vb"}


@pytest.mark.parametrize(("cached", "noted"), [(False, True), (True, False), (None, False)])
def test_a_cold_kernel_cache_is_announced_once(
    cached: bool | None,
    noted: bool,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The first stage that calls the kernels says they are being compiled only when Numba's
    cache is known to be cold; later stages never do."""
    from adaptnav.engine import batch

    monkeypatch.setattr(batch, "kernels_cached", lambda: cached)
    with _app.Stages(quiet=False) as st:
        st.begin("aligning", compiles=True)
        st.begin("running MESKF", compiles=True)
    lines = STAGE.findall(capsys.readouterr().err)
    assert lines[0] == ("aligning; " + _app.COMPILING if noted else "aligning")
    assert lines[1:] == ["running MESKF", "done"]


@pytest.mark.parametrize(("path", "cmd"), COMMANDS, ids=IDS)
def test_every_command_that_writes_a_folder_can_be_quiet(path: list[str], cmd: Any) -> None:
    """A command with ``--force`` writes a folder and may take minutes: it shows its stages or
    progress, and so takes ``--quiet``."""
    options = {o for p in cmd.params for o in getattr(p, "opts", [])}
    if "--force" in options:
        assert {"--quiet", "-q"} <= options, path
