"""Result tables from an engine run, ledger counts, noise record, run folder round trip."""

from __future__ import annotations

import hashlib
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from adaptnav.api.results import (
    COV_COLUMNS,
    REQUIRED_SOLUTION_COLUMNS,
    SOLUTION_COLUMNS,
    STATE_COLUMNS,
    Result,
    RunFolderError,
    covariance_block,
    dropped_ledger,
    has_covariances,
    ledger_counts,
    ledger_frame,
    load,
    quat_to_euler_rows,
    save,
    write_parquet,
)
from adaptnav.core import attitude
from adaptnav.engine.batch import LEDGER_KEYS, EngineOutput, LedgerRows
from adaptnav.models.errorstate import STATE_NAMES
from helpers.run_folders import without_digests

EULER = np.array(
    [[0.1, -0.2, 0.3], [0.0, 0.0, 3.1], [-0.3, 0.4, -3.0], [0.05, 1.2, 1.0], [1.0, -0.7, -1.5]]
)


def _row(
    t: float, sensor: str, fate: str, nu: list[float], r: list[float], **kw: object
) -> dict[str, object]:
    rec: dict[str, object] = {
        "t": t,
        "t_epoch": kw.get("t_epoch", t),
        "sensor": sensor,
        "row": kw.get("row", 0),
        "fate": fate,
        "reason": kw.get("reason", ""),
        "statistic": kw.get("statistic", math.nan),
        "threshold": kw.get("threshold", math.nan),
        "iterations": kw.get("iterations", 0),
    }
    for j in range(3):
        rec[f"nu_{j}"] = nu[j] if j < len(nu) else math.nan
        rec[f"r_{j}"] = r[j] if j < len(r) else math.nan
    return rec


def synthetic_output() -> EngineOutput:
    n = EULER.shape[0]
    t = np.arange(n, dtype=float) * 0.1
    x = np.zeros((n, 16))
    x[:, 0] = math.radians(45.0) + 1e-6 * np.arange(n)
    x[:, 1] = math.radians(7.0) - 2e-6 * np.arange(n)
    x[:, 2] = -10.0 + np.arange(n)
    x[:, 3:6] = [1.0, -0.5, 0.1]
    for k in range(n):
        x[k, 6:10] = attitude.euler_to_quat(*EULER[k])
    x[:, 10:13] = [1e-3, -2e-3, 3e-3]
    x[:, 13:16] = [1e-5, -2e-5, 3e-5]
    P_diag = np.tile((np.arange(15, dtype=float) + 1.0) ** 2, (n, 1))
    ledger = [
        _row(0.1, "dvl", "used", [0.1, -0.2, 0.05], [0.01, 0.02, 0.03], statistic=2.5, row=0),
        _row(0.15, "depth", "used", [0.3], [0.04], statistic=0.8, row=0, iterations=3),
        _row(
            0.2,
            "dvl",
            "rejected",
            [5.0, 1.0, 0.0],
            [0.01, 0.02, 0.03],
            reason="gate q",
            statistic=40.0,
            threshold=9.0,
            row=1,
        ),
        _row(0.3, "dvl", "used", [0.0, 0.1, 0.0], [0.011, 0.021, 0.031], statistic=3.1, row=2),
        _row(0.25, "depth", "dropped", [], [], reason="late", t_epoch=0.3, row=1),
        _row(0.9, "depth", "dropped", [], [], reason="after", t_epoch=math.nan, row=2),
    ]
    # off-diagonal elements of the dr, dv, phi blocks: correlation RHO[k] between their pairs
    sd = np.sqrt(P_diag[0])
    P_cross = np.array(
        [
            [RHO[k] * sd[b + i] * sd[b + j] for b in (0, 3, 6) for i, j in ((0, 1), (0, 2), (1, 2))]
            for k in range(n)
        ]
    )
    return EngineOutput(t, x, P_diag, ledger, x[-1].copy(), np.diag(P_diag[-1]), P_cross=P_cross)


RHO = np.array([0.5, -0.3, 0.0, 0.9, -0.99])
"""Correlation of every pair within a block, per row of :func:`synthetic_output`."""


def make_result(**kw: object) -> Result:
    meta = {"settings": {"q": 3.0, "epoch_policy": "exact"}, "elapsed_s": np.float64(1.5)}
    repairs = [
        {"file": "dvl.csv", "line": 12, "field": "vx", "action": "drop", "detail": "NaN"},
    ]
    return Result.from_engine(
        synthetic_output(),
        "vb",
        "m1",
        meta,
        repairs=repairs,
        **kw,  # type: ignore[arg-type]
    )


def test_solution_table() -> None:
    out = synthetic_output()
    res = make_result()
    sol = res.solution
    assert list(sol.columns) == list(SOLUTION_COLUMNS)
    assert [c for c in sol.columns if c.startswith("sd_")] == [f"sd_{s}" for s in STATE_NAMES]
    np.testing.assert_array_equal(sol["t_s"], out.t)
    np.testing.assert_array_equal(sol["lat_rad"], out.x[:, 0])
    np.testing.assert_array_equal(sol["vd_m_s"], out.x[:, 5])
    np.testing.assert_array_equal(sol["bg_z_rad_s"], out.x[:, 15])
    np.testing.assert_allclose(sol[["roll_rad", "pitch_rad", "yaw_rad"]], EULER, atol=1e-12)
    np.testing.assert_allclose(sol["sd_dbg_z"], 15.0)
    np.testing.assert_allclose(sol["sd_dr_N"], 1.0)
    assert COV_COLUMNS == (
        "cov_dr_N_dr_E", "cov_dr_N_dr_D", "cov_dr_E_dr_D",
        "cov_dv_N_dv_E", "cov_dv_N_dv_D", "cov_dv_E_dv_D",
        "cov_phi_N_phi_E", "cov_phi_N_phi_D", "cov_phi_E_phi_D",
    )  # fmt: skip
    np.testing.assert_array_equal(sol[list(COV_COLUMNS)], out.P_cross)
    np.testing.assert_allclose(sol["cov_dr_E_dr_D"], RHO * 2.0 * 3.0)  # sd 2 m and 3 m
    np.testing.assert_allclose(sol["cov_phi_N_phi_D"], RHO * 7.0 * 9.0)
    # the velocity block in full: sd 4, 5, 6 m/s, correlation RHO[k] between every pair
    P = covariance_block(sol, ("dv_N", "dv_E", "dv_D"))
    s = np.array([4.0, 5.0, 6.0])
    for k in range(len(sol)):
        expected = np.outer(s, s) * (RHO[k] + (1.0 - RHO[k]) * np.eye(3))
        np.testing.assert_allclose(P[k], expected, rtol=1e-12)
    assert has_covariances(sol, ("dv_N", "dv_E", "dv_D"))


def test_vectorised_euler_matches_attitude() -> None:
    rng = np.random.default_rng(1)
    q = rng.normal(size=(200, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    rows = quat_to_euler_rows(q)
    ref = np.array([attitude.quat_to_euler(qk) for qk in q])
    np.testing.assert_allclose(rows, ref, rtol=0, atol=1e-14)


def test_ledger_kept_and_kind() -> None:
    res = make_result(kinds={"dvl": "DVL", "depth": "Depth"})
    led = res.ledger
    assert len(led) == 6
    assert list(led.columns[:4]) == ["t", "t_epoch", "sensor", "kind"]
    assert list(led["kind"]) == ["DVL", "Depth", "DVL", "DVL", "Depth", "Depth"]
    assert led["row"].dtype == np.int64
    assert led.loc[2, "reason"] == "gate q"
    with pytest.raises(ValueError, match="depth"):
        make_result(kinds={"dvl": "DVL"})


def test_ledger_counts() -> None:
    counts = ledger_counts(make_result().ledger)
    assert counts == {
        "depth": {"used": 1, "rejected": 0, "dropped": 2},
        "dvl": {"used": 2, "rejected": 1, "dropped": 0},
    }
    assert ledger_counts(make_result().ledger.iloc[0:0]) == {}


def test_noise_table_from_used_rows() -> None:
    noise = make_result().noise
    assert list(noise.columns) == ["t_s", "sensor", "component", "r_hat"]
    expected = pd.DataFrame(
        {
            "t_s": [0.1, 0.1, 0.1, 0.15, 0.3, 0.3, 0.3],
            "sensor": ["dvl", "dvl", "dvl", "depth", "dvl", "dvl", "dvl"],
            "component": [0, 1, 2, 0, 0, 1, 2],
            "r_hat": [0.01, 0.02, 0.03, 0.04, 0.011, 0.021, 0.031],
        }
    )
    np.testing.assert_array_equal(noise["t_s"], expected["t_s"])
    assert list(noise["sensor"]) == list(expected["sensor"])
    assert list(noise["component"]) == list(expected["component"])
    np.testing.assert_array_equal(noise["r_hat"], expected["r_hat"])


def test_save_load_round_trip(tmp_path: Path) -> None:
    res = make_result(kinds={"dvl": "DVL", "depth": "Depth"})
    folder = save(res, tmp_path / "run")
    names = sorted(p.name for p in folder.iterdir())
    assert names == [
        "events.parquet", "ledger.parquet", "noise.parquet", "repairs.parquet",
        "solution.parquet", "summary.json",
    ]  # fmt: skip
    info = json.loads((folder / "summary.json").read_text())
    assert info["filter"] == "vb" and info["mission"] == "m1"
    assert info["counts"]["dvl"] == {"used": 2, "rejected": 1, "dropped": 0}
    back = load(folder)
    assert back.filter == "vb" and back.mission == "m1"
    assert (
        back.meta
        == res.meta
        == {
            "settings": {"q": 3.0, "epoch_policy": "exact"},
            "elapsed_s": 1.5,
        }
    )
    for name in ("solution", "ledger", "noise", "repairs"):
        pd.testing.assert_frame_equal(getattr(back, name), getattr(res, name))
    assert list(back.solution.columns) == list(SOLUTION_COLUMNS)
    np.testing.assert_array_equal(back.solution[list(COV_COLUMNS)], synthetic_output().P_cross)


def test_old_run_folder_without_covariances_loads(tmp_path: Path) -> None:
    """A run folder written before the cov_ columns existed: loaded as it is, without them;
    the blocks of P are then its diagonal."""
    folder = save(make_result(), tmp_path / "old")
    without_digests(folder)  # an older adaptnav's summary.json: no digests either
    solution = pd.read_parquet(folder / "solution.parquet")
    solution[list(REQUIRED_SOLUTION_COLUMNS)].to_parquet(folder / "solution.parquet")
    back = load(folder)
    assert list(back.solution.columns) == list(REQUIRED_SOLUTION_COLUMNS)
    names = ("dr_N", "dr_E", "dr_D")
    assert not has_covariances(back.solution, names)
    P = covariance_block(back.solution, names)
    np.testing.assert_allclose(P, np.broadcast_to(np.diag([1.0, 4.0, 9.0]), P.shape))
    # but a folder missing an sd_ column is still refused
    solution.drop(columns=["sd_dr_E"]).to_parquet(folder / "solution.parquet")
    with pytest.raises(RunFolderError, match="sd_dr_E"):
        load(folder)


def test_empty_repairs_round_trip(tmp_path: Path) -> None:
    res = Result.from_engine(synthetic_output(), "meskf", "m2", {})
    assert res.repairs.empty and list(res.repairs.columns) == [
        "file", "line", "field", "action", "detail",
    ]  # fmt: skip
    back = load(save(res, tmp_path))
    assert back.repairs.empty
    pd.testing.assert_frame_equal(back.solution, res.solution)


def test_meta_must_be_json() -> None:
    with pytest.raises(TypeError, match=r"meta\.bad"):
        Result.from_engine(synthetic_output(), "vb", "m", {"bad": object()})
    res = Result.from_engine(synthetic_output(), "vb", "m", {"x": math.nan, "a": (1, 2)})
    assert res.meta == {"x": None, "a": [1, 2]}


def test_load_errors(tmp_path: Path) -> None:
    with pytest.raises(RunFolderError, match="does not exist"):
        load(tmp_path / "nowhere")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match=r"missing summary\.json"):
        load(empty)
    (empty / "mission.toml").write_text("")
    with pytest.raises(RunFolderError, match="is a mission folder, not a run folder"):
        load(empty)
    folder = save(make_result(), tmp_path / "run")
    (folder / "noise.parquet").unlink()
    with pytest.raises(RunFolderError, match=r"missing noise\.parquet"):
        load(folder)
    (folder / "summary.json").write_text("{not json")
    with pytest.raises(RunFolderError, match=r"summary\.json"):
        load(folder)


def test_a_smoothed_run_keeps_its_forward_solution(tmp_path: Path) -> None:
    """docs/smoothing.md: ``solution`` is the smoothed one, ``forward.parquet`` the filter's; a
    run saved later into the same folder without smoothing leaves no forward table behind."""
    out = synthetic_output()
    res = _smoothed_result(out)
    assert res.forward is not None and res.meta["smoother"]["store_bytes"] == 1234
    np.testing.assert_array_equal(res.forward["lat_rad"], out.x[:, 0])
    np.testing.assert_array_equal(res.solution["lat_rad"], out.x[:, 0] + 1e-7)
    folder = save(res, tmp_path / "run")
    assert (folder / "forward.parquet").is_file()
    back = load(folder)
    assert back.forward is not None
    pd.testing.assert_frame_equal(back.forward, res.forward)
    pd.testing.assert_frame_equal(back.solution, res.solution)
    save(Result.from_engine(out, "vb", "m1", {}), folder)
    assert not (folder / "forward.parquet").exists() and load(folder).forward is None


def _smoothed_result(out: Any) -> Result:
    """A smoothed run's Result of the engine output ``out``: its smoothed solution 1e-7 rad
    off the forward one, half its variances."""
    from dataclasses import replace

    from adaptnav.engine.batch import Smoothed

    none = np.zeros((out.t.size, 0))
    smoothed = Smoothed(
        out.t, out.x + 1e-7, 0.5 * out.P_diag, 0.5 * out.P_cross, 9, 4, 0, 1234,
        declared=none, declared_var=none,
    )  # fmt: skip
    return Result.from_engine(replace(out, smoothed=smoothed), "vb", "m1", {})


def _smoothed_folder(folder: Path) -> Path:
    """A smoothed run's folder (:func:`test_a_smoothed_run_keeps_its_forward_solution`)."""
    return save(_smoothed_result(synthetic_output()), folder)


def _plain_folder(folder: Path) -> Path:
    return save(Result.from_engine(synthetic_output(), "vb", "m1", {}), folder)


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (
            "delete",
            "missing forward.parquet (summary.json's meta.smoother says the run was smoothed",
        ),
        ("one row", "forward.parquet: 1 rows, and solution.parquet has 5"),
        ("shifted", "forward.parquet row 0, t_s: 1000.0, and solution.parquet's is 0.0"),
        ("stray", "forward.parquet: a forward solution in a run that was not smoothed"),
    ],
)
def test_a_forward_solution_at_odds_with_the_run_is_refused(
    tmp_path: Path, damage: str, message: str
) -> None:
    """Before 0.4.6 `evaluate` took whatever forward.parquet it found: none (a smoothed run
    scored as a plain one), one row (forward RMSE 3.99 m for 2.63 m), another run's, or one left
    in a plain run's folder. The smoother writes its solution at the forward pass's output
    times, so the two t_s columns are equal value for value."""
    folder = (_plain_folder if damage == "stray" else _smoothed_folder)(tmp_path / "run")
    path = folder / "forward.parquet"
    if damage == "stray":
        pd.read_parquet(folder / "solution.parquet").to_parquet(path, index=False)
    elif damage == "delete":
        path.unlink()
    else:
        forward = pd.read_parquet(path)
        if damage == "one row":
            forward = forward.iloc[:1]
        else:
            forward["t_s"] += 1000.0
        forward.to_parquet(path, index=False)
    with pytest.raises(RunFolderError, match=re.escape(message)):
        load(folder)


def _truth(result: Result) -> pd.DataFrame:
    """A reference at the run's times (the solution's position 1 m north)."""
    truth = result.solution[["t_s", *STATE_COLUMNS[:9]]].copy()
    truth["lat_rad"] += 1.0 / 6.4e6
    return truth


def test_summary_records_the_digest_of_every_table_as_written(tmp_path: Path) -> None:
    """summary.json's ``files``: each table's SHA-256 and size, the reference's included (given
    as a table, or as a truth.parquet already written, copied as it is)."""
    from adaptnav.api.results import load_truth

    res = _smoothed_result(synthetic_output())
    folder = save(res, tmp_path / "run", truth=_truth(res))
    files = json.loads((folder / "summary.json").read_text())["files"]
    written = sorted(p.name for p in folder.glob("*.parquet"))
    assert sorted(files) == written and {"forward.parquet", "truth.parquet"} <= set(written)
    for name in written:
        data = (folder / name).read_bytes()
        assert files[name] == {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    load(folder)
    pd.testing.assert_frame_equal(load_truth(folder), _truth(res))
    copy = save(res, tmp_path / "copy", truth=folder / "truth.parquet")
    assert (copy / "truth.parquet").read_bytes() == (folder / "truth.parquet").read_bytes()
    assert json.loads((copy / "summary.json").read_text())["files"] == files
    # saved again without a reference: none is left from before
    save(res, copy)
    assert not (copy / "truth.parquet").exists() and load_truth(copy) is None


def test_file_digest_reads_in_chunks(tmp_path: Path) -> None:
    from adaptnav.api.results import file_digest

    data = np.random.default_rng(8).bytes(2 * (1 << 20) + 12345)  # several reads of any chunk
    path = tmp_path / "big.bin"
    path.write_bytes(data)
    assert file_digest(path) == {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    path.write_bytes(b"")
    assert file_digest(path) == {"sha256": hashlib.sha256(b"").hexdigest(), "bytes": 0}


@pytest.mark.parametrize(
    "name",
    [
        "solution.parquet", "ledger.parquet", "noise.parquet", "repairs.parquet",
        "events.parquet", "forward.parquet", "truth.parquet",
    ],
)  # fmt: skip
def test_a_table_not_as_the_run_wrote_it_is_refused(tmp_path: Path, name: str) -> None:
    """A table written again (here the same rows, gzip-compressed: other bytes) or another
    run's in its place is refused naming the file and both digests' first 12 digits; the
    shape, column and time checks cannot tell a table of another run of the same mission."""
    from adaptnav.api.results import load_truth

    res = _smoothed_result(synthetic_output())
    folder = save(res, tmp_path / "run", truth=_truth(res))
    path = folder / name
    recorded = json.loads((folder / "summary.json").read_text())["files"][name]["sha256"]
    pd.read_parquet(path).to_parquet(path, index=False, compression="gzip")
    now = hashlib.sha256(path.read_bytes()).hexdigest()
    assert now != recorded
    message = (
        f"{path}: not the file this run wrote (changed after the run, or taken from another "
        f"run): its SHA-256 begins {now[:12]}, and summary.json records {recorded[:12]}"
    )
    with pytest.raises(RunFolderError, match=re.escape(message)):
        load_truth(folder) if name == "truth.parquet" else load(folder)


def test_a_table_the_run_did_not_write_or_one_gone_is_refused(tmp_path: Path) -> None:
    """A reference added to a run folder that had none, and a table summary.json lists that
    is gone (events.parquet: an older run folder may lack it, a new one lists it)."""
    from adaptnav.api.results import load_truth

    res = make_result()
    folder = save(res, tmp_path / "run")
    _truth(res).to_parquet(folder / "truth.parquet", index=False)
    with pytest.raises(RunFolderError, match=r"truth\.parquet: not a file this run wrote"):
        load_truth(folder)
    (folder / "events.parquet").unlink()
    with pytest.raises(RunFolderError, match=r"missing events\.parquet \(the run wrote it"):
        load(folder)


def test_a_summary_without_digests_is_read_unchecked(tmp_path: Path) -> None:
    """summary.json of a run folder written before the digests: read as before, a table
    written again included (nothing to check it by); a record that is not one is refused."""
    from adaptnav.api.results import load_truth

    res = _smoothed_result(synthetic_output())
    folder = save(res, tmp_path / "run", truth=_truth(res))
    without_digests(folder)
    for name in ("forward.parquet", "truth.parquet"):
        path = folder / name
        pd.read_parquet(path).to_parquet(path, index=False, compression="gzip")
    pd.testing.assert_frame_equal(load(folder).forward, res.forward)
    pd.testing.assert_frame_equal(load_truth(folder), _truth(res))
    path = folder / "summary.json"
    info = json.loads(path.read_text())
    for bad in ([], {"solution.parquet": "abc"}, {"solution.parquet": {"sha256": "ab"}}):
        path.write_text(json.dumps({**info, "files": bad}))
        with pytest.raises(RunFolderError, match=r"summary\.json: 'files'"):
            load(folder)


def test_dropped_ledger_is_the_table_of_ledger_rows() -> None:
    from adaptnav.api.runner import ledger_row

    rng = np.random.default_rng(3)
    rows = rng.integers(0, 10_000, 50)
    t = np.sort(rng.uniform(0.0, 600.0, 50))
    sensors = rng.choice(["dvl", "depth"], 50).tolist()
    reasons = rng.choice(["sensor off", "before navigation start (alignment)"], 50).tolist()
    rows_t = zip(sensors, rows, t, reasons, strict=True)
    want = ledger_frame([ledger_row(s, int(r), float(x), why) for s, r, x, why in rows_t])
    pd.testing.assert_frame_equal(dropped_ledger(sensors, rows, t, reasons), want)
    one = [ledger_row("dvl", int(r), float(x), "sensor off") for r, x in zip(rows, t, strict=True)]
    pd.testing.assert_frame_equal(dropped_ledger("dvl", rows, t, "sensor off"), ledger_frame(one))
    empty = dropped_ledger("dvl", np.zeros(0, dtype=int), np.zeros(0), "sensor off")
    pd.testing.assert_frame_equal(empty, ledger_frame([]), check_index_type=False)


def test_from_engine_takes_a_ledger_table() -> None:
    out = synthetic_output()
    kinds = {"dvl": "dvl", "depth": "depth"}
    given = ledger_frame(out.ledger)
    given["row"] = given["row"] + 100
    res = Result.from_engine(out, "vb", "m", {}, kinds=kinds, ledger=given)
    moved = [{**r, "row": r["row"] + 100} for r in out.ledger]
    pd.testing.assert_frame_equal(res.ledger, ledger_frame(moved, kinds))
    assert "kind" not in given.columns  # the caller's table is left as it was


def test_parquet_dictionary_only_for_text_reads_back_the_same(tmp_path: Path) -> None:
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    rng = np.random.default_rng(5)
    n = 1000
    table = pd.DataFrame(
        {
            "t": np.cumsum(rng.uniform(0.0, 1.0, n)),
            "x": rng.normal(size=n),
            "row": rng.integers(0, 50, n),
            "flag": rng.uniform(size=n) < 0.1,
            "sensor": pd.Series(rng.choice(["dvl", "depth"], n), dtype="str"),
            "line": pd.array(np.arange(n), dtype="Int64"),
        }
    )
    table.loc[rng.uniform(size=n) < 0.2, "line"] = pd.NA
    path = tmp_path / "t.parquet"
    write_parquet(table, path)
    pd.testing.assert_frame_equal(pd.read_parquet(path), table, check_exact=True)
    meta = pq.ParquetFile(path).metadata.row_group(0)
    dictionary = {
        meta.column(i).path_in_schema: any("DICTIONARY" in e for e in meta.column(i).encodings)
        for i in range(meta.num_columns)
    }
    assert dictionary == {"t": False, "x": False, "row": False, "flag": False,
                          "sensor": True, "line": False}  # fmt: skip


def test_ledger_rows_read_as_the_dicts_and_build_the_same_table() -> None:
    """The engine's ledger kept as columns (engine.batch.LedgerRows) reads as the list of
    dicts it stands for, and ledger_frame builds the same table from its columns as from those
    dicts."""
    rng = np.random.default_rng(4)
    n = 7
    columns = {k: rng.normal(size=n) for k in LEDGER_KEYS}
    columns["sensor"] = np.array(["dvl", "depth"] * 3 + ["dvl"], dtype=object)
    columns["fate"] = np.array(["used", "rejected", "dropped", "used", "used", "used", "used"],
                               dtype=object)  # fmt: skip
    columns["reason"] = np.array(["", "gate chi2", "late", "", "", "", ""], dtype=object)
    columns["row"] = np.arange(n) * 3
    columns["iterations"] = np.ones(n, dtype=np.int64)
    columns["nu_2"][1] = math.nan
    rows = LedgerRows(columns)
    dicts = [{k: columns[k].tolist()[i] for k in LEDGER_KEYS} for i in range(n)]
    assert len(rows) == n and rows[3] == dicts[3] and rows[-2:] == dicts[-2:]
    assert list(rows[0]) == list(LEDGER_KEYS)
    # (NaN is not equal to itself: the rows with one are compared as tables)
    pd.testing.assert_frame_equal(pd.DataFrame(list(rows)), pd.DataFrame(dicts))
    assert rows != [*dicts[:1], *dicts[2:]] and rows[0] == dicts[0]
    pd.testing.assert_frame_equal(ledger_frame(rows), ledger_frame(dicts), check_exact=True)


def test_load_refuses_a_newer_format_version(tmp_path: Path) -> None:
    """A summary.json of a newer format version (a run folder from a newer adaptnav) is refused
    by name; its own version, and a summary without one (the first folders), load."""
    folder = save(make_result(), tmp_path / "run")
    path = folder / "summary.json"
    info = json.loads(path.read_text(encoding="utf-8"))
    assert info["version"] == 1
    load(folder)
    del info["version"]
    path.write_text(json.dumps(info), encoding="utf-8")
    load(folder)
    for bad, message in ((2, "written by a newer adaptnav"), ("1", "not a format version")):
        path.write_text(json.dumps({**info, "version": bad}), encoding="utf-8")
        with pytest.raises(RunFolderError, match=message):
            load(folder)


def test_format_problem() -> None:
    from adaptnav.core.formats import format_problem

    assert format_problem({"format": "f", "version": 3}, "f", 3) is None
    assert format_problem({"format": "f"}, "f", 1) is None
    assert "is not 'f'" in str(format_problem({"format": "g", "version": 1}, "f", 1))
    for version in (0, -1, True, 1.0, None, "2"):
        problem = format_problem({"format": "f", "version": version}, "f", 3)
        assert "not a format version" in str(problem)
    assert "version 4 was written by a newer adaptnav" in str(
        format_problem({"format": "f", "version": 4}, "f", 3)
    )
