"""An honest σ over an IMU hole (docs/robustness.md, 'The σ over a hole'): with
``imu.max_gap_s`` raised, the samples lost in a hole are stretched over it by the loader, and
the engine adds what the motion in the hole can be (mission.imu_holes) to P over the interval.

The demo (seed 1) turns at 1.95°/s from 720 to 800 s; a 10-s hole at 740 s leaves about 19.5°
of the turn to the stretch of one sample's rotation. Up to 0.4.12 the filter coasted over it
with the σ of the IMU's white noise alone (attitude error 20.8° against a σ of 0.99°, NEES in
the millions, 301 km RMS); the bounds below are the χ² quantiles of a consistent filter.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav import api
from adaptnav.analysis import evaluate
from adaptnav.api.stream import Stream, replay
from adaptnav.mission import Mission, load_mission

CHI2_3_999 = 16.27
"""The 99.9 % quantile of χ² with 3 degrees of freedom: a 3-dof NEES of a consistent filter
above it one time in a thousand."""
T0, LENGTH = 740.0, 10.0
HOLE_EVENT = "imu_hole"
"""The event of a hole in the run's events (adaptnav.engine.batch.HOLE_EVENT)."""


def _holed(demo: Path, tmp_path: Path, length: float = LENGTH) -> Path:
    """The demo with the IMU rows in (T0, T0 + length] lost and ``max_gap_s`` above that."""
    root = tmp_path / "holed"
    shutil.copytree(demo, root)
    toml = root / "mission.toml"
    limit = f"[imu]\nmax_gap_s = {length + 1.0}\n"
    toml.write_text(toml.read_text().replace("[imu]\n", limit, 1))
    imu = pd.read_parquet(root / "imu.parquet")
    keep = (imu.t_s <= T0 + 1e-9) | (imu.t_s > T0 + length + 1e-9)
    imu[keep].reset_index(drop=True).to_parquet(root / "imu.parquet", index=False)
    return root


@pytest.fixture(scope="module")
def holed(demo: Path, tmp_path_factory: pytest.TempPathFactory) -> Mission:
    return load_mission(_holed(demo, tmp_path_factory.mktemp("hole")))


def _after_hole(solution: pd.DataFrame, truth: pd.DataFrame, block: str, span: float) -> np.ndarray:
    """The NEES of ``block`` at the reference samples in the ``span`` seconds after the hole."""
    n = evaluate.nees(solution, truth, block)  # type: ignore[arg-type]
    t = n["t_s"].to_numpy()
    return n["nees"].to_numpy()[(t > T0 + LENGTH) & (t <= T0 + LENGTH + span)]


def test_a_hole_in_a_turn_leaves_the_nees_bounded(holed: Mission) -> None:
    """After the hole the attitude and velocity errors lie within the σ the filter claims
    (χ² bound at every reference sample of the next 60 s; up to 0.4.12 the attitude NEES
    was 6e6 at the hole's end), the run within twice the clean run's RMSE (2.63 m; 301 km up
    to 0.4.12), and the hole is an event naming the IMU file's row after it."""
    res = api.run(holed, "robust")
    assert holed.truth is not None
    for block in ("attitude", "velocity"):
        nees = _after_hole(res.solution, holed.truth, block, 60.0)
        assert nees.size > 500 and np.nanmax(nees) < CHI2_3_999, (block, np.nanmax(nees))
    assert evaluate.evaluate(res, holed.truth).rmse_m < 2 * 2.63
    events = res.events[res.events["event"] == HOLE_EVENT]
    assert len(events) == 1
    ev = events.iloc[0]
    table = pd.read_parquet(holed.root / "imu.parquet")
    assert table.t_s.iloc[int(ev["row"])] == pytest.approx(T0 + LENGTH + 0.01)
    assert ev["t"] == pytest.approx(T0 + LENGTH + 0.01) and ev["statistic"] == pytest.approx(10.01)


def test_the_smoother_counts_the_hole_as_process_noise(demo: Path, holed: Mission) -> None:
    """Smoothed, the σ across the hole holds the error too: the backward pass takes the added
    variance as the interval's process noise (docs/smoothing.md, 'Inflations of P'). Before
    and after the hole the smoothed attitude NEES stays within the χ² bound, the velocity NEES
    within the largest of the smoothed run without a hole (25.9: the demo's DVL noise segments)
    (the reference samples inside the hole are left out: the solution has no row there, and
    its interpolation across the 10 s misses the waves' roll)."""
    res = api.run(holed, "robust", smooth=True)
    clean = api.run(load_mission(demo), "robust", smooth=True)
    assert holed.truth is not None
    sol = res.solution
    st = sol["t_s"].to_numpy()
    after = st[np.searchsorted(st, T0 + LENGTH)]  # the first row after the hole
    for block in ("attitude", "velocity"):
        n = evaluate.nees(sol, holed.truth, block)  # type: ignore[arg-type]
        t = n["t_s"].to_numpy()
        around = ((t > T0 - 30.0) & (t <= T0)) | ((t >= after) & (t <= T0 + LENGTH + 60.0))
        assert around.sum() > 800
        bound = CHI2_3_999
        if block == "velocity":
            bound = np.nanmax(evaluate.nees(clean.solution, holed.truth, block)["nees"])
        assert np.nanmax(n["nees"].to_numpy()[around]) < bound, block


def test_a_stream_given_dt_adds_the_hole_as_well(demo: Path, holed: Mission) -> None:
    """A stream given each sample's own ``dt`` stretches it over the hole (since 0.4.10) and,
    since 0.4.13, adds the hole's motion to P from the samples of the last 120 s: the same
    bound after the hole, and the event."""
    clean = load_mission(demo).imu
    with Stream(holed, "robust") as stream:
        for item in replay(holed):
            if item.sensor != "imu":
                stream.push_item(item)
                continue
            k = int(np.searchsorted(clean.t, item.t))  # the row as recorded: its own period
            stream.push_imu(item.t, clean.dtheta[k], clean.dvel[k], dt=clean.dt[k])
    res = stream.result
    assert res is not None and holed.truth is not None
    nees = _after_hole(res.solution, holed.truth, "attitude", 60.0)
    assert nees.size > 500 and np.nanmax(nees) < CHI2_3_999, np.nanmax(nees)
    assert (res.events["event"] == HOLE_EVENT).sum() == 1


def test_no_hole_no_event(demo: Path) -> None:
    """The demo loses no sample: no hole, and its run has no hole event (its solution is the
    same as up to 0.4.12: tests/integration/test_golden.py)."""
    m = load_mission(demo)
    assert len(m.imu.holes) == 0


def test_a_hole_beyond_small_angles_is_warned(
    demo: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A 60-s hole over the turn: by the demo's own IMU the attitude after it is unknown by
    72° (σ, x axis), beyond the filter's small angles; the loader says so, naming the row after
    the hole. The 10-s hole (σ 16° at most) is not warned about."""
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        load_mission(_holed(demo, tmp_path / "a", 10.0))
    assert not [r for r in caplog.records if "beyond the small" in r.getMessage()]
    with caplog.at_level(logging.WARNING, logger="adaptnav.mission"):
        m = load_mission(_holed(demo, tmp_path / "b", 60.0))
    words = [r.getMessage() for r in caplog.records if "beyond the small" in r.getMessage()]
    assert len(words) == 1
    assert f"before imu.parquet row {int(m.imu.holes.row[0])}" in words[0]  # 0-based
    assert "60.01 s of IMU samples lost" in words[0]


def _as_rates(demo: Path, root: Path) -> Path:
    """The demo's IMU in rates (``imu.format`` rates): each row's increments over its interval
    divided by it, the mean rate, stamped at the interval's middle, where the mean rate is the
    rate to within h² ω̈ / 24 (the trajectory's rates, the same IMU errors)."""
    shutil.copytree(demo, root)
    imu = pd.read_parquet(root / "imu.parquet")
    t = imu.t_s.to_numpy()
    dt = np.diff(t, prepend=t[0] - 0.01)
    out = pd.DataFrame({"t_s": t - 0.5 * dt})
    for a in "xyz":
        out[f"gyro_{a}_rad_s"] = imu[f"dtheta_{a}_rad"].to_numpy() / dt
    for a in "xyz":
        out[f"accel_{a}_m_s2"] = imu[f"dvel_{a}_m_s"].to_numpy() / dt
    out.to_parquet(root / "imu.parquet", index=False)
    toml = root / "mission.toml"
    toml.write_text(toml.read_text().replace('format = "increments"', 'format = "rates"', 1))
    return root


def test_a_hole_in_an_imu_in_rates_leaves_the_nees_bounded(demo: Path, tmp_path: Path) -> None:
    """The demo in rates with the samples of (T0, T0 + 10 s] lost: the loader integrates the
    hole by the trapezoid of the rates either side, and since 0.4.13 adds the trapezoid's error
    over 10 s, by the mission's own rates, to P (up to 0.4.12 the white noise alone: attitude
    NEES 2.9e5 at the hole's end, 342 m RMS). The attitude NEES stays within the χ² bound over
    the next 60 s, the hole is a repair on the row after it and an event."""
    root = _holed(_as_rates(demo, tmp_path / "rates"), tmp_path)
    m = load_mission(root)
    res = api.run(m, "robust")
    assert m.truth is not None
    nees = _after_hole(res.solution, m.truth, "attitude", 60.0)
    assert nees.size > 500 and np.nanmax(nees) < CHI2_3_999, np.nanmax(nees)
    assert evaluate.evaluate(res, m.truth).rmse_m < 2 * 2.63
    assert (res.events["event"] == HOLE_EVENT).sum() == 1
    assert len(m.imu.holes) == 1 and int(m.imu.holes.periods[0]) == 1001
    table = pd.read_parquet(root / "imu.parquet")
    row = int(m.imu.holes.row[0])
    assert table.t_s.iloc[row] == pytest.approx(T0 + LENGTH + 0.005)
    assert table.t_s.iloc[row - 1] == pytest.approx(T0 - 0.005)
    assert m.imu.t[m.imu.holes.index[0]] == table.t_s.iloc[row]  # the interval ending there
    fixes = [r for r in m.repairs if r.action == "hole filled by the trapezoid of rates"]
    assert len(fixes) == 1 and fixes[0].line == row  # Parquet: the 0-based row


def test_an_imu_in_rates_without_a_hole_has_none(demo: Path, tmp_path: Path) -> None:
    """The demo in rates loses no sample: no hole, no repair, no event (its run takes the
    path of 0.4.12: the engine is given no hole list)."""
    m = load_mission(_as_rates(demo, tmp_path / "rates"))
    assert len(m.imu.holes) == 0
    assert not [r for r in m.repairs if "trapezoid of rates" in r.action]
