"""Where a sweep's runs go: a ``dask.distributed`` cluster, local or remote (issue 16;
docs/scale-out.md).

:func:`resolve` picks the cluster: a :class:`distributed.Client` or a scheduler address passed
by the caller (``--scheduler``), else the environment setting :data:`SCHEDULER_ENV`, else none:
a :class:`distributed.LocalCluster` of single-threaded worker processes that :func:`connect`
starts for the sweep and closes after it. ``"local"`` in either place asks for the local
cluster (so ``--scheduler local`` overrides the environment). :func:`connect` turns a scheduler
that cannot be reached, or workers that run another adaptnav, into a :class:`SchedulerError`
naming the address and where it came from.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import dask
from distributed import Client, LocalCluster
from distributed.comm.addressing import resolve_address

from adaptnav import __version__

__all__ = [
    "CONNECT_TIMEOUT_S",
    "LOCAL",
    "SCHEDULER_ENV",
    "THREAD_VARS",
    "WORKER_ENVIRON",
    "Remote",
    "Scheduler",
    "SchedulerError",
    "connect",
    "resolve",
]

SCHEDULER_ENV = "ADAPTNAV_SCHEDULER"
"""Environment variable with a scheduler address (``tcp://host:8786``), used when the caller
gives none."""
LOCAL = "local"
"""The scheduler "address" that asks for the local cluster."""
CONNECT_TIMEOUT_S = 10.0
"""How long to try to reach a scheduler before giving up: a typo fails in seconds."""
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
"""Thread pools a local worker limits to one: one worker per core."""
WORKER_ENVIRON: dict[str, int] = dict.fromkeys(THREAD_VARS, 1)
"""Set in a local worker's environment before it starts, unless set in this process's (dask's
``distributed.nanny.pre-spawn-environ``): :data:`THREAD_VARS`, and, unlike dask's default, no
``MALLOC_TRIM_THRESHOLD_``, which turns off glibc's adaptive mmap threshold: the simulator ran
2 × slower with it (docs/scale-out.md)."""

Scheduler = Client | str | None
"""What a caller may pass: a connected client, a scheduler address (or ``"local"``), or None:
the environment setting, else the local cluster."""


class SchedulerError(RuntimeError):
    """The scheduler cannot be reached, or its workers cannot run this sweep."""


@dataclass(frozen=True)
class Remote:
    """A scheduler address and where it came from (``--scheduler`` or the environment)."""

    address: str
    source: str


def resolve(scheduler: Scheduler, source: str = "--scheduler") -> Client | Remote | None:
    """The cluster to use: ``scheduler`` if given (``source`` names the setting it came from),
    else ``$ADAPTNAV_SCHEDULER``, else None (the local cluster); ``"local"`` in either is
    None."""
    if isinstance(scheduler, Client):
        return scheduler
    if scheduler is None:
        scheduler, source = os.environ.get(SCHEDULER_ENV, "").strip() or None, SCHEDULER_ENV
    if scheduler is None or scheduler.strip() == LOCAL:
        return None
    return Remote(scheduler.strip(), source)


def _worker_view(cache: str | None) -> tuple[str, bool]:
    """On a worker: its adaptnav version and whether it sees the folder ``cache``."""
    return __version__, cache is None or Path(cache).is_dir()


def _check_workers(client: Client, where: str, cache: Path | None) -> None:
    """Every worker connected now runs this adaptnav version and sees ``cache`` at its path
    (workers that join later are not checked)."""
    try:
        views = client.run(_worker_view, None if cache is None else str(cache))
    except Exception as exc:  # e.g. adaptnav not installed on a worker
        raise SchedulerError(f"{where}: a worker cannot run adaptnav: {exc}") from exc
    for worker, (version, sees) in sorted(views.items()):
        if version != __version__:
            raise SchedulerError(
                f"{where}: worker {worker} runs adaptnav {version}, this is {__version__}"
            )
        if not sees:
            raise SchedulerError(
                f"{where}: worker {worker} does not see the cache folder {cache}: workers need "
                "it at the same path (a shared filesystem)"
            )


def _remote(remote: Remote) -> Client:
    where = f"dask scheduler {remote.address!r} (from {remote.source})"
    try:
        # A malformed address or an unknown host fails here at once; a Client that failed on
        # one would hang for 20 s at exit, closing itself.
        resolve_address(remote.address)
        return Client(remote.address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, ValueError, TypeError) as exc:  # unreachable, or not an address
        raise SchedulerError(f"cannot reach the {where}: {exc}") from exc


@contextmanager
def connect(
    target: Client | Remote | None, workers: int, cache: Path | None = None
) -> Iterator[Client]:
    """A client of ``target`` (:func:`resolve`) for the duration of the block: a given client
    as it is (left open), a remote scheduler's (closed after), or a new local cluster of
    ``workers`` processes with one thread each, one-threaded BLAS/OpenMP/Numba and no dashboard
    (closed after). Workers are checked (:func:`_check_workers`): same adaptnav version, and
    ``cache`` (absolute) visible at its path."""
    if isinstance(target, Client):
        _check_workers(target, "the given dask client", cache)
        yield target
        return
    if isinstance(target, Remote):
        with _remote(target) as client:
            _check_workers(client, f"dask scheduler {target.address!r} ({target.source})", cache)
            yield client
        return
    with _local_cluster(workers) as cluster, Client(cluster, set_as_default=False) as client:
        yield client


def _local_cluster(workers: int) -> LocalCluster:
    """``workers`` single-threaded worker processes and a scheduler on this machine, started
    with :data:`WORKER_ENVIRON`."""
    with dask.config.set({"distributed.nanny.pre-spawn-environ": WORKER_ENVIRON}):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # The scheduler's HTTP endpoints (health, metrics; no dashboard) on any free local
            # port, not 8787: sweeps side by side need no free port.
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
            preload=["adaptnav.experiments.runner"],  # imported by all workers at once, at start
            # The sweep reports every failed task itself; dask's own messages (a worker's
            # heartbeat racing the shutdown on a busy machine) would clutter the progress bars.
            silence_logs=logging.CRITICAL,
        )
