"""A magnetic compass's headings with ``declination_deg`` (docs/data-format.md, 'Magnetic
headings'). Up to 0.4.7 a heading table had to hold true headings: the key was refused, and a
magnetic compass's readings aided the yaw off by the declination.

The reference for each check is a run on the true headings the simulator wrote (heading.csv),
independent of the conversion's code: the magnetic table is that one less D, so the declined
run must be that run, and a run on the magnetic table without the key must not be.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav import api
from adaptnav.api.stream import Stream, replay
from adaptnav.mission import MissionError, load_mission
from helpers import badinput

D_DEG = 12.0
"""The declination of the tests (east): magnetic north 12° east of true north."""


def _mission(source: Path, root: Path, *, magnetic: bool, key: str = "") -> Path:
    """The tiny mission with its heading sensor aiding; ``magnetic``: its table less D;
    ``key``: lines added to ``[sensors.heading]``."""
    root = badinput.copy_mission(source, root)
    toml = (root / "mission.toml").read_text()
    section = '[sensors.heading]\nkind = "heading"\n'
    toml = toml.replace(section, section + key)
    head, tail = toml.split(section)
    tail = tail.replace('use = "off"', 'use = "aid"', 1)
    (root / "mission.toml").write_text(head + section + tail)
    if magnetic:
        table = badinput.read(root, "heading")
        table["yaw_rad"] = table["yaw_rad"] - math.radians(D_DEG)
        badinput.write(root, "heading", table)
    return root


def test_a_declined_magnetic_compass_is_the_true_one(source: Path, tmp_path: Path) -> None:
    true = api.run(load_mission(_mission(source, tmp_path / "true", magnetic=False)), "robust")
    key = f"declination_deg = {D_DEG}\n"
    declined = load_mission(_mission(source, tmp_path / "declined", magnetic=True, key=key))
    got = api.run(declined, "robust")
    assert (got.ledger["fate"] == "used").sum() == (true.ledger["fate"] == "used").sum()
    a, b = got.solution.to_numpy(), true.solution.to_numpy()
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale)
    # Without the key the same magnetic table disagrees with the gyrocompass at rest by 12°,
    # beyond max(2°, 10 σ) (docs/robustness.md, 'Angles at rest'): an error with the cause.
    raw = load_mission(_mission(source, tmp_path / "raw", magnetic=True))
    with pytest.raises(MissionError, match=r"-1[12]\.[0-9]° off .*a magnetic compass, its decl"):
        api.run(raw, "robust")
    # A stream turns each pushed magnetic heading as the loader does; replay gives them back.
    with Stream(declined, "robust") as stream:
        headings = []
        for item in replay(declined):
            if item.sensor == "heading":
                headings.append(float(item.z[0]))
            stream.push_item(item)
    assert stream.result is not None
    c = stream.result.solution.to_numpy()
    assert c.shape == b.shape and np.all(np.abs(c - b) <= 1e-9 * scale)
    magnetic = badinput.read(declined.root, "heading")["yaw_rad"].to_numpy()
    diff = np.angle(np.exp(1j * (np.asarray(headings) - magnetic[: len(headings)])))
    assert np.abs(diff).max() < 1e-12


def test_declination_only_on_a_heading_sensor(source: Path, tmp_path: Path) -> None:
    root = badinput.copy_mission(source, tmp_path / "m")
    toml = (root / "mission.toml").read_text()
    section = '[sensors.dvl]\nkind = "dvl"\n'
    (root / "mission.toml").write_text(toml.replace(section, section + "declination_deg = 3.0\n"))
    with pytest.raises(MissionError, match="declination_deg: only for heading sensors"):
        load_mission(root)
    root = _mission(source, tmp_path / "n", magnetic=False, key="declination_deg = 120.0\n")
    with pytest.raises(MissionError, match="declination_deg"):
        load_mission(root)


def test_the_conversion_wraps(source: Path) -> None:
    from adaptnav.mission.loader import true_north

    z = np.array([[math.radians(175.0)], [math.radians(-179.0)], [math.nan]])
    got = np.degrees(true_north(z, math.radians(10.0)))
    np.testing.assert_allclose(got[:2, 0], [-175.0, -169.0], atol=1e-12)
    assert math.isnan(got[2, 0])
    assert isinstance(pd.DataFrame(got), pd.DataFrame)
