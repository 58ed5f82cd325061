"""The oracle baseline: per-reading R in the engine, known outliers dropped, on a simulation."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptnav import api
from adaptnav.api.oracle import OUTLIER_REASON, mission_noise
from adaptnav.engine import batch as engine
from adaptnav.engine.channels import build_channels
from adaptnav.estimation.settings import FilterSettings
from adaptnav.mission import load_mission
from adaptnav.models import errorstate
from adaptnav.sensors.dvl import DVL
from adaptnav.sim.scenarios import simulate
from helpers import synthetic


def _run(
    ds: synthetic.Dataset,
    models: dict[str, object],
    readings: dict[str, tuple[np.ndarray, ...]],
    kind: str = "oracle",
) -> engine.EngineOutput:
    periods = synthetic.periods()
    sensors = [(models[name], periods[name]) for name in ds.readings]
    chans = build_channels(FilterSettings(kind=kind), sensors)  # type: ignore[arg-type]
    return engine.run_batch(
        engine.EngineConfig(synthetic.NOISE), chans, ds.x0_hat, ds.P0, ds.t0,
        ds.imu_t, ds.dt, ds.dtheta, ds.dvel, readings,
    )  # fmt: skip


def _rmse(out: engine.EngineOutput, ds: synthetic.Dataset) -> float:
    k = np.round(out.t / ds.dt).astype(int)
    err = np.array(
        [errorstate.difference(ds.truth[i], x)[:3] for i, x in zip(k, out.x, strict=True)]
    )
    return float(np.sqrt((err**2).sum(axis=1).mean()))


def test_reading_R_equal_to_the_nominal_changes_nothing() -> None:
    ds = synthetic.make(3, duration=30.0)
    plain = _run(ds, ds.models, ds.readings)
    t, z = ds.readings["dvl"]
    own = dict(ds.readings, dvl=(t, z, np.full((t.size, 3), 0.02**2)))
    given = _run(ds, ds.models, own)
    assert np.array_equal(plain.x, given.x)
    assert np.array_equal(plain.P_diag, given.P_diag)


def test_reading_R_replaces_the_nominal_one() -> None:
    """Every DVL reading told 4σ² gives exactly the filter whose DVL σ is 2σ (fixed R)."""
    ds = synthetic.make(4, duration=30.0)
    t, z = ds.readings["dvl"]
    told = _run(ds, ds.models, dict(ds.readings, dvl=(t, z, np.full((t.size, 3), 4 * 0.02**2))))
    wider = _run(ds, dict(ds.models, dvl=DVL(sigma=0.04)), ds.readings)
    plain = _run(ds, ds.models, ds.readings)
    assert np.allclose(told.x, wider.x, rtol=0.0, atol=1e-12)
    assert not np.allclose(told.x, plain.x, rtol=0.0, atol=1e-6)
    used = [r for r in told.ledger if r["sensor"] == "dvl" and r["fate"] == "used"]
    assert used and all(r["r_0"] == pytest.approx(4 * 0.02**2) for r in used)


def test_reading_R_is_checked() -> None:
    ds = synthetic.make(4, duration=5.0)
    t, z = ds.readings["dvl"]
    with pytest.raises(ValueError, match="dvl: r_diag must be finite and positive"):
        _run(ds, ds.models, dict(ds.readings, dvl=(t, z, np.zeros((t.size, 3)))))
    with pytest.raises(ValueError, match="r_diag must have"):
        _run(ds, ds.models, dict(ds.readings, dvl=(t, z, np.ones((t.size, 2)))))


@pytest.fixture(scope="module")
def demo_mission(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate("demo", 11, tmp_path_factory.mktemp("oracle") / "mission")


def test_oracle_on_a_simulation(demo_mission: Path) -> None:
    """True σ per reading reaches the update; every injected outlier is dropped with its reason;
    every DVL row has exactly one fate."""
    mission = load_mission(demo_mission)
    x0, P0, t0, _ = api.initial_state(mission)
    res = api.run(mission, "oracle", initial=(x0, P0, t0))
    assert res.meta["oracle_nominal_R"] == []
    dvl = mission.tables["dvl"]
    ledger = res.ledger[res.ledger["sensor"] == "dvl"]
    assert sorted(ledger["row"]) == list(range(len(dvl)))
    flagged = set(np.flatnonzero(dvl["is_outlier"].to_numpy(bool)))
    assert flagged, "the demo preset injects DVL outliers"
    dropped = ledger[ledger["reason"] == OUTLIER_REASON]
    after_start = {r for r in flagged if dvl["t_s"].iloc[r] > t0}
    assert set(dropped["row"]) == after_start
    used = ledger[ledger["fate"] == "used"]
    assert (used["fate"] != "rejected").all()
    sigma = dvl["sigma_m_s"].to_numpy(float)[used["row"].to_numpy(int)]
    assert np.allclose(used["r_0"], sigma**2, rtol=1e-12)
    incl = mission.tables["inclinometer"]
    used_i = res.ledger[(res.ledger["sensor"] == "inclinometer") & (res.ledger["fate"] == "used")]
    rows = used_i["row"].to_numpy(int)
    assert np.allclose(used_i["r_0"], incl["sigma_rad"].to_numpy(float)[rows] ** 2, rtol=1e-12)


def test_oracle_beats_the_filters_on_a_noise_jump_with_outliers() -> None:
    """The setting of test_filters' VB test (DVL σ ×10 after 150 s, 1 % outliers of 20σ): told
    the true σ(t) and the outliers, the same ESKF is the best of all (the practical limit)."""
    ds = synthetic.make(21, duration=300.0, dvl_sigma_factor_after=(150.0, 10.0),
                        dvl_outlier_rate=0.01)  # fmt: skip
    t, z = ds.readings["dvl"]
    ok = ~ds.outlier["dvl"]
    told = dict(ds.readings, dvl=(t[ok], z[ok], np.repeat(ds.sigma["dvl"][ok, None] ** 2, 3, 1)))
    rmse = {"oracle": _rmse(_run(ds, ds.models, told), ds)}
    for kind in ("meskf", "maeskf", "vb"):
        rmse[kind] = _rmse(_run(ds, ds.models, ds.readings, kind), ds)
    print(f"\nposition RMSE (m): {rmse}")
    assert rmse["oracle"] < min(rmse["meskf"], rmse["maeskf"], rmse["vb"])


def test_oracle_needs_truth_columns(demo_mission: Path, tmp_path: Path) -> None:
    mission = load_mission(demo_mission)
    bare = {
        name: pd.DataFrame({"t_s": mission.tables[name]["t_s"]})
        for name in mission.sensors
        if mission.config.sensors[name].use == "aid"
    }
    stripped = replace(mission, tables={**mission.tables, **bare})
    with pytest.raises(ValueError, match=r"oracle: mission .* has no per-reading truth"):
        mission_noise(stripped, list(bare))
