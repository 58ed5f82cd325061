"""``python -m adaptnav.cli``: the ``adaptnav`` command without the installed entry point."""

from adaptnav.cli import app

app(prog_name="adaptnav")
