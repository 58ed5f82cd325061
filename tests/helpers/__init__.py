"""Helpers shared by the tests (not tests themselves), imported as ``from helpers import ...``.

``tests/`` is on the import path through ``pythonpath`` in pyproject.toml's pytest settings.

* :mod:`helpers.synthetic`: missions made from known motion for the filter tests;
* :mod:`helpers.badinput`: the tiny simulated mission of the bad-input tests;
* :mod:`helpers.missions`: minimal mission folders (a ``mission.toml`` dict, IMU and DVL tables);
* :mod:`helpers.calibrated`: the demo mission with known calibration errors, estimating them or
  not;
* :mod:`helpers.engine_reference`: the readable engine the compiled one is held to;
* :mod:`helpers.golden`: the golden run (also a script: ``python tests/helpers/golden.py``);
* :mod:`helpers.script_loader`: a file of ``scripts/`` loaded as a module;
* :mod:`helpers.run_folders`: a run folder's table changed on purpose, its digest recorded
  again (:func:`~helpers.run_folders.reseal`), or a run folder of an older adaptnav.

The paths below locate the test data from any test folder.
"""

from __future__ import annotations

from pathlib import Path

TESTS = Path(__file__).resolve().parent.parent
"""The ``tests/`` folder."""
REPO = TESTS.parent
"""The repository root (``docs/``, ``scripts/``)."""
DATA = TESTS / "data"
"""The tests' own data files (``tests/data``)."""
SHARED_DATA = REPO.parent / "shared" / "data"
"""Recorded data sets kept beside the repository (A-KIT, RTKLIB), not in it."""
