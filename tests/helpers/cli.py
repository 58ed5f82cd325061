"""The CLI as a user meets it, for the tests: :func:`cli` runs ``adaptnav`` in process and
fails the test on a traceback; :func:`error_line` is the one error line of a refused command."""

from __future__ import annotations

from typing import Any

from typer.testing import CliRunner

from adaptnav.cli import app

runner = CliRunner()


def cli(*args: Any) -> Any:
    """``adaptnav *args`` (each turned to a string); no traceback, no exception but an exit."""
    res = runner.invoke(app, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res


def error_line(res: Any) -> str:
    """The one error line of a failed command (exit 2)."""
    assert res.exit_code == 2, res.output
    lines = [line for line in res.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, res.output
    return str(lines[0])
