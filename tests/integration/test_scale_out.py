"""Sweeps on a dask cluster (docs/scale-out.md): two local workers give exactly the numbers of
one process, a resumed sweep reuses the cache, the scheduler setting's precedence, and a
scheduler that cannot be reached is one clear error.

The runs are seeded and each is a pure function of its spec, so any difference between the
cluster and one process (a worker with other BLAS threads, a mission simulated or aligned
differently on a worker, a record lost on the way) shows as an inequality of the metrics.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptnav.cli import app
from adaptnav.experiments import cluster
from adaptnav.experiments.runner import SweepOutcome, run_sweep, run_tasks
from adaptnav.experiments.spec import RunSpec
from adaptnav.experiments.stats import METRICS

SPECS = [
    RunSpec("demo", 1, "meskf"),
    RunSpec("demo", 1, "vb"),
    RunSpec("demo", 1, "meskf", q=200.0),
    RunSpec("demo", 1, "maeskf"),
]


@pytest.fixture(autouse=True)
def _no_scheduler_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(cluster.SCHEDULER_ENV, raising=False)


@pytest.fixture(scope="module")
def one_process(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, SweepOutcome]:
    cache = tmp_path_factory.mktemp("one") / "cache"
    return cache, run_sweep(SPECS, cache, jobs=1, progress=False)


def _metrics(table: pd.DataFrame) -> pd.DataFrame:
    cols = [c for c in METRICS if c != "elapsed_s"]  # wall time differs, nothing else may
    return table.set_index("key")[cols].sort_index()


def test_cluster_equals_one_process_and_resumes(
    one_process: tuple[Path, SweepOutcome], tmp_path: Path
) -> None:
    reference, one = one_process
    cache = tmp_path / "cache"
    # The simulated mission is copied (seeded, it would be the same; simulating it again costs
    # time), not its alignment: a worker computes that.
    shutil.copytree(reference / "missions" / "demo-s1", cache / "missions" / "demo-s1")
    # The local cluster a sweep of -j 2 starts, passed as a client (the Python API) to both
    # sweeps: one start-up.
    with cluster.connect(None, 2) as client:
        first = run_sweep(SPECS[:2], cache, progress=False, chunk_size=1, scheduler=client)
        resumed = run_sweep(SPECS, cache, progress=False, chunk_size=1, scheduler=client)
        assert client.status == "running"  # a caller's client is left open
        assert len(client.nthreads()) == 2 and set(client.nthreads().values()) == {1}
    assert (first.ran, first.reused, first.failed) == (2, 0, 0), first.errors
    assert (resumed.ran, resumed.reused, resumed.failed) == (2, 2, 0), resumed.errors
    assert (cache / "missions" / "demo-s1.alignment.npz").is_file()
    expected = _metrics(one.table)
    pd.testing.assert_frame_equal(_metrics(resumed.table), expected, check_exact=True)
    pd.testing.assert_frame_equal(
        _metrics(first.table), expected.loc[_metrics(first.table).index], check_exact=True
    )
    for spec in SPECS:  # every run cached by key, as one process caches it
        assert json.loads((cache / "runs" / f"{spec.key()}.json").read_text())["key"] == spec.key()
    assert not list(cache.rglob(".*.tmp-*"))  # no temporary left behind


def test_run_tasks_on_a_local_cluster() -> None:
    """The results scripts' loop (``make akit``, ``make faults``, ``make smoothing``) on a local
    cluster of two workers: every task run once, each result handed on with its task. (The
    client is not dask's default one: as_completed must be given its loop.)"""
    got: dict[tuple[int, int], int] = {}
    run_tasks(pow, [(2, k) for k in range(6)], 2, lambda task, result: got.update({task: result}))
    assert got == {(2, k): 2**k for k in range(6)}


def test_scheduler_precedence(monkeypatch: pytest.MonkeyPatch) -> None:
    assert cluster.resolve(None) is None  # nothing set: the local cluster
    monkeypatch.setenv(cluster.SCHEDULER_ENV, "tcp://env-host:8786")
    assert cluster.resolve(None) == cluster.Remote("tcp://env-host:8786", cluster.SCHEDULER_ENV)
    assert cluster.resolve("tcp://flag:1") == cluster.Remote("tcp://flag:1", "--scheduler")
    assert cluster.resolve("local") is None  # the flag overrides the environment
    monkeypatch.setenv(cluster.SCHEDULER_ENV, "local")
    assert cluster.resolve(None) is None


@pytest.mark.parametrize(
    ("flag", "env", "message"),
    [
        # Nothing listens on port 1: the connection is retried until the timeout.
        ("tcp://127.0.0.1:1", None, "'tcp://127.0.0.1:1' (from --scheduler)"),
        (None, "nonsense", "'nonsense' (from ADAPTNAV_SCHEDULER)"),
        # .invalid never resolves (RFC 2606): fails at once, before any connection.
        ("tcp://no-such-host.invalid:8786", None, "'tcp://no-such-host.invalid:8786'"),
    ],
)
def test_unreachable_scheduler_is_one_clear_error(
    flag: str | None,
    env: str | None,
    message: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    timeout = 2.0
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", timeout)
    if env is not None:
        monkeypatch.setenv(cluster.SCHEDULER_ENV, env)
    cache = tmp_path / "cache"
    args = ["sweep", "seeds", "demo", "--seeds", "1", "--filters", "meskf", "--cache", str(cache),
            "--no-progress", *(["--scheduler", flag] if flag else [])]  # fmt: skip
    started = time.perf_counter()
    result = CliRunner().invoke(app, args)
    assert time.perf_counter() - started < timeout + 5.0
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit)  # typer's exit, not an exception
    assert "Traceback" not in result.output
    assert result.output.startswith("error: cannot reach the dask scheduler " + message)
    assert not (cache / "seeds").exists()  # no output folder
