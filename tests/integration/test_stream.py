"""The streaming API (adaptnav.api.stream, docs/streaming.md) against the batch run.

The mission is the golden one (tests/helpers/golden.py: 5 minutes, every disturbance on, the
alignment's position from the GPS fixes). Fed reading by reading in time order, every filter
kind a stream runs must give the batch run's solution and ledger to 1e-9: the batch run is the
reference, computed independently of the stream's path (whole tables, one IMU chunk).
"""

from __future__ import annotations

import contextlib
import io
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav import api
from adaptnav.api import runner
from adaptnav.api.results import SOLUTION_COLUMNS
from adaptnav.api.stream import Stream, replay
from adaptnav.mission import Mission, MissionError, load_mission
from adaptnav.mission.imu_holes import NEAR_S, recent_variance
from adaptnav.mission.live import OUT_OF_ORDER_REASON
from helpers import golden

DOCS = Path(__file__).resolve().parents[2] / "docs" / "streaming.md"
KINDS = ("meskf", "maeskf", "vb", "robust")


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> Mission:
    return load_mission(golden.mission(tmp_path_factory.mktemp("stream") / "mission"))


def _sorted(ledger: pd.DataFrame) -> pd.DataFrame:
    return ledger.sort_values(["sensor", "row"], kind="stable").reset_index(drop=True)


@pytest.mark.parametrize("kind", KINDS)
def test_a_stream_fed_in_time_order_is_the_batch_run(mission: Mission, kind: str) -> None:
    batch = api.run(mission, kind)  # type: ignore[arg-type]
    rows = []
    with Stream(mission, kind) as stream:  # type: ignore[arg-type]
        for item in replay(mission):
            rows += stream.push_item(item)
    assert stream.result is not None
    pushed = pd.DataFrame(rows)
    assert list(pushed.columns) == list(batch.solution.columns)
    a, b = pushed.to_numpy(), batch.solution.to_numpy()
    assert a.shape == b.shape and len(a) > 2000
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale)
    # The rows returned as they were determined are the run's solution, bit for bit.
    np.testing.assert_array_equal(stream.result.solution.to_numpy(), a)
    la, lb = _sorted(stream.result.ledger), _sorted(batch.ledger)
    assert la.columns.tolist() == lb.columns.tolist()
    for c in la.columns:
        if la[c].dtype.kind == "f":
            np.testing.assert_allclose(la[c], lb[c], rtol=1e-9, atol=1e-12, equal_nan=True)
        else:
            assert la[c].tolist() == lb[c].tolist(), c
    assert {"used", "dropped"} <= set(la["fate"])
    assert stream.result.events.shape == batch.events.shape


def test_late_and_out_of_order_readings_are_in_the_ledger(mission: Mission) -> None:
    start = api.initial_state(mission)[:3]
    imu, dvl = mission.imu, mission.sensors["dvl"]
    stream = Stream(mission, "robust", initial=start)
    first = int(np.searchsorted(imu.t, start[2] + 1e-9))
    rows = []
    for k in range(first, first + 300):  # 3 s of IMU: 30 rows at 10 Hz
        rows += stream.push_imu(imu.t[k], imu.dtheta[k], imu.dvel[k], dt=imu.dt[k])
    assert len(rows) == 30 + 1  # and the start's
    assert [r["t_s"] for r in rows] == pytest.approx(start[2] + 0.1 * np.arange(31), abs=1e-6)
    now = stream.t
    stream.push("dvl", now - 0.5, dvl.z[0], row=7)  # stamped before the filter's time
    stream.push("dvl", now + 0.5, dvl.z[1], row=8)
    stream.push("dvl", now + 0.2, dvl.z[2], row=9)  # before the sensor's previous reading
    for k in range(first + 300, first + 400):
        stream.push_imu(imu.t[k], imu.dtheta[k], imu.dvel[k], dt=imu.dt[k])
    ledger = stream.close().ledger.set_index("row")
    assert ledger.loc[7, "fate"] == "dropped" and ledger.loc[7, "reason"].startswith("late")
    assert ledger.loc[8, "fate"] in ("used", "rejected")
    assert ledger.loc[8, "t_epoch"] == pytest.approx(now + 0.5)
    assert (ledger.loc[9, "fate"], ledger.loc[9, "reason"]) == ("dropped", OUT_OF_ORDER_REASON)


def test_bad_input_is_refused_and_the_stream_goes_on(mission: Mission) -> None:
    with pytest.raises(ValueError, match="oracle"):
        Stream(mission, "oracle")
    with pytest.raises(ValueError, match=r"^filter 'vbx': not one of meskf, maeskf, vb, robust"):
        Stream(mission, "vbx")  # type: ignore[arg-type]
    start = api.initial_state(mission)[:3]
    stream = Stream(mission, "meskf", initial=start)
    t = start[2] + 0.01
    stream.push_imu(t, np.zeros(3), [0.0, 0.0, -0.098])
    with pytest.raises(ValueError, match="after the previous sample"):
        stream.push_imu(t, np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="non-finite"):
        stream.push_imu(t + 0.01, [math.nan, 0.0, 0.0], np.zeros(3))
    with pytest.raises(KeyError, match="unknown sensor 'sonar'"):
        stream.push("sonar", t, [1.0])
    with pytest.raises(ValueError, match="3 value"):
        stream.push("dvl", t + 0.1, [1.0, 2.0])
    for row in (-1, 2.7, True):
        with pytest.raises(ValueError, match=r"dvl: row .* is not a row number"):
            stream.push("dvl", t + 0.1, [1.0, 2.0, 0.0], row=row)  # type: ignore[arg-type]
    assert len(stream.push_imu(t + 0.01, np.zeros(3), [0.0, 0.0, -0.098])) == 0
    assert stream.t == pytest.approx(t + 0.01)


def test_a_given_start_skips_the_imu_before_it_as_the_batch_run(mission: Mission) -> None:
    """With ``initial``, the samples stamped at or before t0 are not integrated, as the batch
    run starts after them (up to 0.4.4 the stream integrated them: time ran back from t0 to the
    first sample, 3x the rows and a solution about 1 km off, silently)."""
    start = api.initial_state(mission)[:3]
    batch = api.run(mission, "meskf", initial=start)
    with Stream(mission, "meskf", initial=start) as stream:
        for item in replay(mission):  # every sample, those before t0 too
            stream.push_item(item)
    assert stream.result is not None
    a, b = stream.result.solution.to_numpy(), batch.solution.to_numpy()
    assert a.shape == b.shape
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale)
    # no alignment ran, and nothing used the GPS (use = "init"): the ledgers say so, alike
    # (up to 0.4.8 both gave the alignment's reasons)
    for ledger in (batch.ledger, stream.result.ledger):
        by = ledger.groupby("sensor")["reason"].agg(set)
        assert by["gps"] == {runner.GIVEN_INIT_REASON}, by["gps"]
        assert (
            runner.GIVEN_START_REASON in by["dvl"] and runner.BEFORE_START_REASON not in by["dvl"]
        )
    pd.testing.assert_series_equal(
        _sorted(stream.result.ledger)["reason"], _sorted(batch.ledger)["reason"]
    )


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda x, P, t: (x, P * math.nan, t), "initial P0: every element finite"),
        (lambda x, P, t: (x, -P, t), "the diagonal > 0"),
        (lambda x, P, t: (x[:3], np.eye(3), t), "initial x0: 3 values"),
        (lambda x, P, t: (x, P[:3, :3], t), "initial P0: shape (3, 3)"),
        (lambda x, P, t: (x, P, math.nan), "initial t0: nan s is not within"),
        (lambda x, P, t: (x, P), "initial: expected (x0, P0, t0)"),
    ],
)
def test_a_bad_initial_state_is_refused_naming_it(
    mission: Mission, change: object, message: str
) -> None:
    """Up to 0.4.4: a NaN P0 ran with every reading rejected and every σ NaN; a NaN t0 gave a
    solution of one row; a wrong shape a broadcast error from deep inside."""
    initial = change(*api.initial_state(mission)[:3])  # type: ignore[operator]
    with pytest.raises(ValueError, match=re.escape(message)):
        api.run(mission, "meskf", initial=initial)
    with pytest.raises(ValueError, match=re.escape(message)):
        Stream(mission, "meskf", initial=initial)
    if "t0" in message:
        x, P, _ = api.initial_state(mission)[:3]
        with pytest.raises(ValueError, match="not within the IMU's span"):
            api.run(mission, "meskf", initial=(x, P, float(mission.imu.t[-1]) + 100.0))


def test_imu_samples_the_loader_refuses_are_refused(mission: Mission) -> None:
    """A gap over imu.max_gap_s, an interval overlapping the previous one, a rate beyond 20 g:
    ValueError and the stream unchanged (up to 0.4.4 integrated: heights of 1e24 m, then a
    bare LinAlgError from a later sample). A reading stamped inf is refused too (it held its
    sensor's later readings back as out of order)."""
    start = api.initial_state(mission)[:3]
    stream = Stream(mission, "meskf", initial=start)
    t = start[2] + 0.01
    stream.push_imu(t, np.zeros(3), [0.0, 0.0, -0.098])
    with pytest.raises(ValueError, match=r"a gap over imu\.max_gap_s"):
        stream.push_imu(t + 1e6, np.zeros(3), [0.0, 0.0, -0.098])
    with pytest.raises(ValueError, match="an interval overlapping it"):
        stream.push_imu(t + 0.01, np.zeros(3), [0.0, 0.0, -0.098], dt=5.0)
    rate = "a rate beyond 20 rad/s or 20 g ([0. 0. 0.] rad/s, [1.e+10 0.e+00 0.e+00] m/s²)"
    with pytest.raises(ValueError, match=re.escape(rate)):
        stream.push_imu(t + 0.01, np.zeros(3), [1e8, 0.0, 0.0])
    # The values named as NumPy prints them, also since the checks run on plain floats (0.4.12).
    with pytest.raises(
        ValueError, match=re.escape("non-finite increment [ 0. nan  0.], [0. 0. 0.]")
    ):
        stream.push_imu(t + 0.01, [0.0, math.nan, 0.0], np.zeros(3))
    with pytest.raises(ValueError, match="cannot reshape array of size 4"):
        stream.push_imu(t + 0.01, np.zeros(4), [0.0, 0.0, -0.098])
    with pytest.raises(ValueError, match="not a finite time"):
        stream.push("dvl", math.inf, [0.5, 0.0, 0.0])
    assert len(stream.push_imu(t + 0.01, np.zeros(3), [0.0, 0.0, -0.098])) == 0
    assert stream.t == pytest.approx(t + 0.01)


def test_a_stream_that_never_covers_the_alignment_window_says_so(mission: Mission) -> None:
    stream = Stream(mission, "robust")
    for k in range(100):
        assert stream.push_imu(mission.imu.t[k], mission.imu.dtheta[k], mission.imu.dvel[k]) == []
    with pytest.raises(MissionError, match="alignment window"):
        stream.close()


def test_the_example_of_the_docs_runs(mission: Mission) -> None:
    code = re.search(r"```python\n(.*?)```", DOCS.read_text(encoding="utf-8"), re.S)
    assert code is not None
    out = io.StringIO()
    scope = {"MISSION_DIR": str(mission.root)}
    with contextlib.redirect_stdout(out):
        exec(code.group(1), scope)
    times = [float(line.split()[0]) for line in out.getvalue().splitlines() if " s  lat" in line]
    # The golden mission: aligned over its first 60 s, 213 s after that; a row every 10 s.
    assert times == list(range(60, 280, 10))
    assert "used" in out.getvalue()
    assert list(scope["stream"].result.solution.columns) == list(SOLUTION_COLUMNS)


def _late_dvl(src: Path, root: Path, lag: float, latency: float | None) -> Path:
    """The golden mission with its DVL stamped ``lag`` seconds late, and ``latency_s`` set to
    ``latency`` (None: not set)."""
    import shutil

    shutil.copytree(src, root)
    table = root / "dvl.parquet"
    df = pd.read_parquet(table)
    df["t_s"] = df["t_s"] + lag
    df.to_parquet(table)
    toml = (root / "mission.toml").read_text()
    head = '[sensors.dvl]\nkind = "dvl"\n'
    assert head in toml
    if latency is not None:
        toml = toml.replace(head, head + f"latency_s = {latency}\n")
    (root / "mission.toml").write_text(toml)
    return root


def test_latency_takes_late_stamped_readings_at_their_own_time(
    mission: Mission, tmp_path: Path
) -> None:
    """A DVL whose every stamp is 0.2 s late: with ``latency_s = 0.2`` the run is the on-time
    run (to rounding: the stamps went through + 0.2 - 0.2), without it clearly not; a stream of
    the late mission, its readings pushed with their late stamps, is its batch run."""
    on_time = api.run(mission, "vb").solution.to_numpy()
    fixed = load_mission(_late_dvl(mission.root, tmp_path / "fixed", 0.2, 0.2))
    late = load_mission(_late_dvl(mission.root, tmp_path / "late", 0.2, None))
    a = api.run(fixed, "vb").solution.to_numpy()
    b = api.run(late, "vb").solution.to_numpy()
    scale = np.maximum(np.nanmax(np.abs(on_time), axis=0), 1e-300)
    assert np.all(np.abs(a - on_time) <= 1e-9 * scale)
    # 0.2 s late at the run's 0.5 m/s² is up to 0.1 m/s off in the DVL's readings while it
    # speeds up: the late run's velocity moves by millimetres a second, far beyond rounding
    vel = [list(SOLUTION_COLUMNS).index(c) for c in ("vn_m_s", "ve_m_s")]
    assert np.abs(b[:, vel] - on_time[:, vel]).max() > 1e-3
    np.testing.assert_allclose(fixed.sensors["dvl"].t, mission.sensors["dvl"].t, atol=1e-9)
    rows = []
    with Stream(fixed, "vb") as stream:
        items = list(replay(fixed))
        stamps = [i.t for i in items if i.sensor == "dvl"]
        np.testing.assert_allclose(stamps, fixed.sensors["dvl"].t + 0.2, atol=0.0)
        for item in items:
            rows += stream.push_item(item)
    assert stream.result is not None and (stream.result.ledger["fate"] != "late").all()
    got = stream.result.solution.to_numpy()
    assert got.shape == a.shape and np.all(np.abs(got - a) <= 1e-9 * scale)
    # the IMU held 0.2 s behind: the rows of the last 0.2 s come with close(), not before
    pushed = pd.DataFrame(rows).to_numpy()
    np.testing.assert_array_equal(pushed, got[: len(pushed)])
    assert 0.2 - 0.1 <= got[-1, 0] - pushed[-1, 0] <= 0.2 + 0.1


def test_readings_before_the_first_imu_sample_have_the_batch_runs_reason(
    mission: Mission, tmp_path: Path
) -> None:
    """A DVL whose clock runs 30 s early: its first readings come before the IMU's first
    sample. The batch run drops them as "before the first IMU sample" and warns of a sensor
    stamped outside the IMU's time; the stream gave them "before navigation start (alignment)"
    and no warning (up to 0.4.7), though its ledger is documented to be the batch run's."""
    early = load_mission(_late_dvl(mission.root, tmp_path / "early", -30.0, None))
    batch = api.run(early, "meskf")
    with Stream(early, "meskf") as stream:
        for item in replay(early):
            stream.push_item(item)
    assert stream.result is not None
    la, lb = _sorted(stream.result.ledger), _sorted(batch.ledger)
    before = lb["reason"] == "before the first IMU sample"
    assert before.sum() > 50 and (lb.loc[before, "sensor"] == "dvl").all()
    assert la["reason"].tolist() == lb["reason"].tolist()
    assert la["fate"].tolist() == lb["fate"].tolist()
    kinds = [w["kind"] for w in batch.meta["warnings"]]
    assert "outside_imu" in kinds
    assert [w["kind"] for w in stream.result.meta["warnings"]] == kinds


def _with_imu(mission: Mission, **imu: object) -> Mission:
    """The mission with ``[imu]`` settings changed (stuck_s, saturation_rows)."""
    from dataclasses import replace

    cfg = mission.config
    return replace(mission, config=cfg.model_copy(update={"imu": cfg.imu.model_copy(update=imu)}))


def test_a_frozen_imu_is_refused_once_it_has_lasted_stuck_s(mission: Mission) -> None:
    """Every value of the golden IMU's sample at 100 s repeated with fresh stamps: the samples
    up to imu.stuck_s (1 s) after it are taken (the stream cannot know yet), the first one at 1 s
    is refused naming the span and the setting, the stream unchanged, and so is every repeat
    after it; a changed sample goes on. Up to 0.4.9 a stream took them all (a loaded table
    with the same rows is refused, loader._check_frozen)."""
    start = api.initial_state(mission)[:3]
    imu = mission.imu
    stream = Stream(mission, "meskf", initial=start)
    k0 = int(np.searchsorted(imu.t, start[2] + 1e-9))
    a = int(np.searchsorted(imu.t, 100.0))
    for k in range(k0, a + 1):
        stream.push_imu(imu.t[k], imu.dtheta[k], imu.dvel[k], dt=imu.dt[k])
    k = a + 1
    while imu.t[k] - imu.t[a] < 1.0:
        stream.push_imu(imu.t[k], imu.dtheta[a], imu.dvel[a], dt=imu.dt[k])
        k += 1
    now = stream.t
    for j, span in ((k, "1"), (k + 1, "1.01")):
        with pytest.raises(ValueError, match=f"every IMU value unchanged for {span} s") as err:
            stream.push_imu(imu.t[j], imu.dtheta[a], imu.dvel[a], dt=imu.dt[j])
        words = f"since the sample at t = {float(imu.t[a])!r} s: a frozen IMU or driver"
        assert words in str(err.value)
        assert f"set imu.stuck_s above {span} s (0: not checked)" in str(err.value)
        assert stream.t == now
    stream.push_imu(imu.t[k], imu.dtheta[k], imu.dvel[k], dt=imu.dt[k])
    assert stream.t == imu.t[k]
    off = Stream(_with_imu(mission, stuck_s=0.0), "meskf", initial=start)
    for j in range(k0, k + 100):
        off.push_imu(imu.t[j], imu.dtheta[min(j, a)], imu.dvel[min(j, a)], dt=imu.dt[j])


@pytest.mark.parametrize(("column", "held"), [(2, "zero"), (3, "last")])
def test_one_stuck_channel_is_refused_once_it_has_lasted_channel_stuck_s(
    mission: Mission, column: int, held: str
) -> None:
    """The golden IMU's dtheta_z at 0 (or its dvel_x at its value of the sample at 100 s) from
    the sample after 100 s on, the other five as they are: the samples up to
    imu.channel_stuck_s (5 s = 5 stuck_s) after the value's first are taken, the first one at
    5 s is refused naming the column, the span and the setting, the stream unchanged (up to
    0.4.12 a stream took them all, as the loader took such a table; loader.stuck_channel
    refuses it since 0.4.13). With channel_stuck_s = 0 the stream takes them."""
    start = api.initial_state(mission)[:3]
    imu = mission.imu
    k0 = int(np.searchsorted(imu.t, start[2] + 1e-9))
    a = int(np.searchsorted(imu.t, 100.0))
    v = np.column_stack([imu.dtheta, imu.dvel])
    first = a + 1 if held == "zero" else a  # the held value's first sample
    v[a + 1 :, column] = 0.0 if held == "zero" else v[a, column]
    stream = Stream(mission, "meskf", initial=start)
    k = k0
    while imu.t[k] - imu.t[first] < 5.0 - 1e-9:
        stream.push_imu(imu.t[k], v[k, :3], v[k, 3:], dt=imu.dt[k])
        k += 1
    now = stream.t
    name = ["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dvel_x_m_s"][column]
    with pytest.raises(ValueError, match=f"IMU sample t = .*, {name}: unchanged at ") as err:
        stream.push_imu(imu.t[k], v[k, :3], v[k, 3:], dt=imu.dt[k])
    msg = str(err.value)
    assert f"since the sample at t = {float(imu.t[first])!r} s" in msg
    assert "a channel stuck or dead" in msg and "set imu.channel_stuck_s above 5" in msg
    assert stream.t == now
    off = Stream(_with_imu(mission, channel_stuck_s=0.0), "meskf", initial=start)
    for j in range(k0, k + 100):
        off.push_imu(imu.t[j], v[j, :3], v[j, 3:], dt=imu.dt[j])


def test_a_clipped_gyro_is_refused_as_saturated(mission: Mission) -> None:
    """The golden IMU's dtheta_z clipped at half its largest value (the 3°/s turn's): the
    sample at which 10 samples hold the column's largest value so far, twice as many as the
    next value inward, is refused, naming the column, the value and the setting (up to 0.4.9
    a stream took them all; loader._check_saturated refuses the table). With
    imu.saturation_rows = 0 the stream takes them."""
    start = api.initial_state(mission)[:3]
    imu = mission.imu
    top = 0.5 * float(imu.dtheta[:, 2].max())
    dth = imu.dtheta.copy()
    dth[:, 2] = np.minimum(dth[:, 2], top)
    k0 = int(np.searchsorted(imu.t, start[2] + 1e-9))
    clipped = np.flatnonzero(dth[:, 2] == top)
    tenth = int(clipped[9])
    stream = Stream(mission, "meskf", initial=start)
    for k in range(k0, tenth):
        stream.push_imu(imu.t[k], dth[k], imu.dvel[k], dt=imu.dt[k])
    with pytest.raises(ValueError, match="dtheta_z_rad: 10 samples") as err:
        stream.push_imu(imu.t[tenth], dth[tenth], imu.dvel[tenth], dt=imu.dt[tenth])
    msg = str(err.value)
    assert f"the first at t = {float(imu.t[clipped[0]])!r} s and the last this one" in msg
    assert f"hold the column's largest value so far, {top!r}" in msg
    assert "clipped at the IMU's range (saturated)?" in msg
    assert "set imu.saturation_rows above 10 (0: not checked)" in msg
    assert stream.t == imu.t[tenth - 1]
    off = Stream(_with_imu(mission, saturation_rows=0), "meskf", initial=start)
    for k in range(k0, tenth + 100):
        off.push_imu(imu.t[k], dth[k], imu.dvel[k], dt=imu.dt[k])


def test_a_quantized_imu_at_rest_is_not_saturated_on_a_stream(mission: Mission) -> None:
    """The loader's quantized IMU at rest (tests/unit/test_io.py): dvel_x within ±2 steps of
    0.01 m/s² for 26 s, 15 samples at each end, 300 at the steps next to them: a tail, not a
    pile-up, in every prefix of the stream too."""
    levels = np.repeat([-0.02, -0.01, 0.0, 0.01, 0.02], [15, 300, 2000, 300, 15])
    dv = mission.imu.dvel[: levels.size].copy()
    dv[:, 0] = np.random.default_rng(3).permutation(levels) * 0.01
    stream = Stream(mission, "meskf")
    imu = mission.imu
    for k in range(levels.size):
        stream.push_imu(imu.t[k], imu.dtheta[k], dv[k], dt=imu.dt[k])


def test_an_imu_at_rest_below_its_step_is_not_saturated_on_a_stream(mission: Mission) -> None:
    """The golden IMU's dvel_x at rest alternating between two output steps (0.01 and 0.02 m/s²
    over 0.01 s), the one farther from zero on two samples in three: a pile-up by count in
    every prefix from the 15th sample, one step from the rest. Up to 0.4.12 the stream refused
    it there ("clipped at the IMU's range", docs/streaming.md); a span of one step is not a
    range's end (fewer than loader.SATURATION_LEVELS values)."""
    imu = mission.imu
    dv = imu.dvel[:600].copy()
    dv[:, 0] = np.resize([2e-4, 2e-4, 1e-4], 600)
    stream = Stream(mission, "meskf")
    for k in range(600):
        stream.push_imu(imu.t[k], imu.dtheta[k], dv[k], dt=imu.dt[k])


@pytest.mark.parametrize(("scale", "gravity"), [(1.0 / 9.80665, 1.0), (1.0, 0.0)])
def test_accelerations_in_g_or_without_gravity_are_refused(
    mission: Mission, scale: float, gravity: float
) -> None:
    """The golden IMU's first second with its Δv in g, or with gravity taken out (at rest,
    level: Δv_z + g dt): the sample that ends the first second is refused with the loader's
    words (loader._check_gravity), and every one after it (up to 0.4.9 a stream took them:
    "not static" at the alignment, or a state start that diverged)."""
    imu = mission.imu
    dv = imu.dvel[:200] * scale
    dv[:, 2] += (1.0 - gravity) * 9.80665 * imu.dt[:200]
    stream = Stream(mission, "robust")
    for k in range(99):
        stream.push_imu(imu.t[k], imu.dtheta[k], dv[k], dt=imu.dt[k])
    for k in (99, 100):
        with pytest.raises(ValueError, match="the median") as err:
            stream.push_imu(imu.t[k], imu.dtheta[k], dv[k], dt=imu.dt[k])
        msg = str(err.value)
        assert "the median |specific force| over the 100 IMU samples of the first 1 s is" in msg
        assert "in g: × 9.80665" in msg and "gravity taken out" in msg
        assert msg.startswith(f"IMU sample t = {float(imu.t[k])!r} s, dvel_x_m_s")


def test_lost_samples_with_dt_given_are_stretched_as_the_loader(
    mission: Mission, tmp_path: Path
) -> None:
    """Every 400th IMU row from 70 s on lost (isolated holes of one period): the loader
    stretches the next row's increments over the hole ("stretched increments over lost
    samples"); a stream given each sample's own dt stretches them too, and its run is the
    batch run of the table with the rows lost, to 1e-9. Up to 0.4.9 the stream jumped each
    hole, the motion in it lost (position off by the speed times the hole, at each). Since
    0.4.13 each hole's motion is added to P (docs/robustness.md, 'The σ over a hole'), by the
    loader from the whole table, by the stream from the samples of the last NEAR_S seconds
    (it has no others): the batch run here takes the latter, computed from the table."""
    import shutil

    root = tmp_path / "lost"
    shutil.copytree(mission.root, root)
    table = pd.read_parquet(root / "imu.parquet")
    lost = np.arange(7000, len(table) - 1, 400)
    table.drop(index=lost).to_parquet(root / "imu.parquet")
    holed = load_mission(root)
    stretched = [r for r in holed.repairs if r.action == "stretched increments over lost samples"]
    assert len(stretched) == lost.size
    imu = mission.imu  # as recorded: each row its own period's increments
    own = np.searchsorted(imu.t, holed.imu.t)  # the rows kept, as recorded
    n = math.ceil(NEAR_S * holed.config.imu.rate_hz) + 1
    holes = holed.imu.holes
    assert holes.index.size == lost.size and set(holes.periods.tolist()) == {2}
    var = [
        recent_variance(imu.dtheta[own[max(0, k + 1 - n) : k + 1]],
                        imu.dvel[own[max(0, k + 1 - n) : k + 1]], 2, 1)
        for k in holes.index.tolist()
    ]  # fmt: skip
    recent = replace(holed.imu, holes=replace(holes, var=np.array(var)))
    batch = api.run(replace(holed, imu=recent), "meskf")
    with Stream(holed, "meskf") as stream:
        for item in replay(holed):
            if item.sensor != "imu":
                stream.push_item(item)
                continue
            k = int(np.searchsorted(imu.t, item.t))
            stream.push_imu(item.t, imu.dtheta[k], imu.dvel[k], dt=imu.dt[k])
    assert stream.result is not None
    a, b = stream.result.solution.to_numpy(), batch.solution.to_numpy()
    assert a.shape == b.shape
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale)


def test_a_caller_that_reuses_one_buffer_gets_the_batch_run(mission: Mission) -> None:
    """A driver fills one preallocated array per message and hands it over: the stream must
    keep the values, not the array (up to 0.4.10 it kept the array for the samples it held,
    those of the alignment window among them, and aligned on the last values written)."""
    batch = api.run(mission, "robust")
    buf, rows = np.empty(6), []
    with Stream(mission, "robust") as stream:
        for item in replay(mission):
            n = item.z.size
            buf[:n] = item.z
            if item.sensor == "imu":
                rows += stream.push_imu(item.t, buf[:3], buf[3:6], item.dt)
            else:
                rows += stream.push(item.sensor, item.t, buf[:n], row=item.row)
            buf[:] = np.nan  # the driver's next message overwrites it
    a, b = pd.DataFrame(rows).to_numpy(), batch.solution.to_numpy()
    assert a.shape == b.shape
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale)
