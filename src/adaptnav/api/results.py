"""The result of one filter run as tables, and its run folder on disk.

A :class:`Result` holds what :func:`adaptnav.engine.batch.run_batch` produced, as pandas tables with
units in the column names:

* ``solution``: one row per recorded epoch: time, nominal state (lat/lon in rad, ellipsoidal
  height, NED velocity, ZYX Euler angles of ``q_nb``, IMU biases), one standard deviation
  ``sd_<name>`` per error state (:data:`adaptnav.models.errorstate.STATE_NAMES`), the square root of
  P's diagonal, and the covariances inside the position, velocity and attitude error blocks,
  ``cov_<a>_<b> = P[a, b]`` (:data:`COV_COLUMNS`: ``cov_dr_N_dr_E``, ``cov_dr_N_dr_D``,
  ``cov_dr_E_dr_D`` in m², the same for dv in m²/s² and phi in rad²). With the ``sd_`` columns
  they give each 3×3 block of P in full (:func:`covariance_block`), which the NEES needs
  (:mod:`adaptnav.analysis.evaluate`, docs/metrics.md); the correlations between blocks and with the
  biases are not kept. Run folders written before these columns existed load without them
  (they are not required).
* ``ledger``: the engine's per-reading rows as they are (``t, t_epoch, sensor, row, fate, reason,
  statistic, threshold, iterations, nu_j, r_j``), plus a ``kind`` column when sensor kinds are
  given.
* ``noise``: long table ``t_s, sensor, component, r_hat``, one row per used reading and
  measurement component: the diagonal of R the filter used at that reading (the paper's Fig. 10
  record of the estimated measurement noise). ``t_s`` is the reading's own stamp (ledger ``t``).
* ``events``: the divergence guard's events ``t, sensor, row, event, statistic, threshold,
  factor, detail`` (``event``: ``lockout``, ``nis`` or ``covariance``; ``factor``: what P was
  multiplied by; docs/robustness.md). Run folders written before it load with none.
* ``meta``: settings, timing, counts (JSON values only); ``repairs``: input repairs
  ``file, line, field, action, detail`` (may be empty; ``line`` missing for a repair of a
  whole table or sensor).

* ``forward``: a smoothed run's forward solution (its ``solution`` is then the RTS-smoothed
  one, docs/smoothing.md), same columns; absent for a run that was not smoothed.

A run folder holds ``solution.parquet``, ``ledger.parquet``, ``noise.parquet``,
``repairs.parquet``, ``events.parquet``, ``forward.parquet`` for a smoothed run,
``truth.parquet`` when the mission has a reference, and ``summary.json`` (filter, mission,
meta, ledger counts per sensor and fate, event counts, and ``files``: the SHA-256 and size of
each table as written); :func:`save` writes it and :func:`load` reads it back, refusing a
table that is not the one the run wrote (:func:`check_files`; :func:`load_truth` for the
reference).
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from adaptnav.core.formats import format_problem, read_json_object
from adaptnav.engine.batch import EVENT_KEYS, MAX_DIM, P_CROSS_PAIRS, EngineOutput, LedgerRows
from adaptnav.mission.tables import write_parquet as write_parquet  # the one Parquet writer
from adaptnav.models.errorstate import N_STATES, STATE_NAMES
from adaptnav.models.strapdown import NOM_ATT, NOM_BA, NOM_BG, NOM_POS, NOM_SIZE, NOM_VEL

Array = NDArray[np.float64]

FORMAT_NAME = "adaptnav-run"
FORMAT_VERSION = 1

STATE_COLUMNS: tuple[str, ...] = (
    "lat_rad", "lon_rad", "h_m", "vn_m_s", "ve_m_s", "vd_m_s", "roll_rad", "pitch_rad", "yaw_rad",
    "ba_x_m_s2", "ba_y_m_s2", "ba_z_m_s2", "bg_x_rad_s", "bg_y_rad_s", "bg_z_rad_s",
)  # fmt: skip
SD_COLUMNS: tuple[str, ...] = tuple(f"sd_{name}" for name in STATE_NAMES)


def cov_column(a: str, b: str) -> str:
    """The solution column of ``P[a, b]`` for error-state names a, b (``cov_dr_N_dr_E``)."""
    return f"cov_{a}_{b}"


COV_COLUMNS: tuple[str, ...] = tuple(
    cov_column(STATE_NAMES[i], STATE_NAMES[j]) for i, j in P_CROSS_PAIRS
)
"""Off-diagonal elements of P's position, velocity and attitude blocks, in the order of
:data:`adaptnav.engine.batch.P_CROSS_PAIRS` (units m², m²/s², rad²)."""
SOLUTION_COLUMNS: tuple[str, ...] = ("t_s", *STATE_COLUMNS, *SD_COLUMNS, *COV_COLUMNS)
"""Every column of a solution table as written now."""
REQUIRED_SOLUTION_COLUMNS: tuple[str, ...] = ("t_s", *STATE_COLUMNS, *SD_COLUMNS)
"""The columns a solution must have (older run folders have no :data:`COV_COLUMNS`)."""
LEDGER_COLUMNS: tuple[str, ...] = (
    "t", "t_epoch", "sensor", "row", "fate", "reason", "statistic", "threshold", "iterations",
    *(f"nu_{j}" for j in range(MAX_DIM)), *(f"r_{j}" for j in range(MAX_DIM)),
)  # fmt: skip
NOISE_COLUMNS: tuple[str, ...] = ("t_s", "sensor", "component", "r_hat")
REPAIR_COLUMNS: tuple[str, ...] = ("file", "line", "field", "action", "detail")
EVENT_COLUMNS: tuple[str, ...] = EVENT_KEYS
FATES: tuple[str, ...] = ("used", "rejected", "dropped")

SUMMARY_FILE = "summary.json"
CALIBRATION_FILE = "calibration.json"
"""The calibration states' final estimates and σ (docs/calibration.md), when there are any."""
TABLE_FILES: dict[str, str] = {
    "solution": "solution.parquet",
    "ledger": "ledger.parquet",
    "noise": "noise.parquet",
    "repairs": "repairs.parquet",
    "events": "events.parquet",
    "forward": "forward.parquet",
}
TRUTH_FILE = "truth.parquet"
"""The mission's reference, kept beside the run when the mission has one (``run``, ``compare``)."""
FILES_KEY = "files"
"""``summary.json``'s record of the tables the run wrote: ``{file name: {"sha256": hex digest,
"bytes": size}}`` (since 0.4.7; a summary without it, of an older run, is read unchecked)."""
OPTIONAL_TABLES = ("events", "forward")
"""Tables a run folder written by an older version may lack (read as empty)."""
_REQUIRED: dict[str, tuple[str, ...]] = {
    "solution": REQUIRED_SOLUTION_COLUMNS,
    "ledger": LEDGER_COLUMNS,
    "noise": NOISE_COLUMNS,
    "repairs": REPAIR_COLUMNS,
    "events": EVENT_COLUMNS,
    "forward": REQUIRED_SOLUTION_COLUMNS,
}
_LEDGER_INT = ("row", "iterations")
_LEDGER_STR = ("sensor", "fate", "reason")


class RunFolderError(ValueError):
    """A run folder is missing, incomplete or unreadable; the message names the file."""


@dataclass(frozen=True, eq=False)
class Result:
    """One filter run on one mission (see the module docstring for the tables' columns)."""

    filter: str
    mission: str
    solution: pd.DataFrame
    ledger: pd.DataFrame
    noise: pd.DataFrame
    meta: dict[str, Any] = field(default_factory=dict)
    repairs: pd.DataFrame = field(default_factory=lambda: empty_repairs())
    events: pd.DataFrame = field(default_factory=lambda: events_frame([]))
    forward: pd.DataFrame | None = None
    """A smoothed run's forward solution (``solution`` is then the smoothed one), same columns;
    None for a run that was not smoothed (docs/smoothing.md)."""

    def __post_init__(self) -> None:
        for name, required in _REQUIRED.items():
            table = getattr(self, name)
            if table is None and name == "forward":
                continue
            if not isinstance(table, pd.DataFrame):
                raise TypeError(f"Result.{name} must be a pandas DataFrame, got {type(table)}")
            missing = [c for c in required if c not in table.columns]
            if missing:
                raise ValueError(f"Result.{name} lacks columns {missing}")
        object.__setattr__(self, "meta", jsonable(self.meta, "meta"))

    @classmethod
    def from_engine(
        cls,
        output: EngineOutput,
        filter: str,
        mission: str,
        meta: Mapping[str, Any] | None = None,
        repairs: pd.DataFrame | Sequence[Mapping[str, Any]] | None = None,
        kinds: Mapping[str, str] | None = None,
        *,
        ledger: pd.DataFrame | None = None,
    ) -> Result:
        """Tables from an engine run. ``kinds`` maps sensor name → kind (adds ``ledger.kind``);
        ``repairs`` is a DataFrame or a list of ``{file, line, field, action, detail}`` rows;
        ``ledger``: the ledger table when the caller has built it (:func:`typed_ledger`; the
        runner's, with the readings that never reached the engine) instead of the table of
        ``output.ledger``'s rows."""
        if ledger is None:
            ledger = ledger_frame(output.ledger, kinds)
        else:
            ledger = typed_ledger(ledger, kinds)
        names = output.declared_names
        forward = with_declared(
            solution_frame(output.t, output.x, output.P_diag, output.P_cross),
            names, output.declared, output.declared_var,
        )  # fmt: skip
        sm = output.smoothed
        solution = forward
        if sm is not None:
            table = solution_frame(sm.t, sm.x, sm.P_diag, sm.P_cross)
            solution = with_declared(table, names, sm.declared, sm.declared_var)
        info = dict(meta or {})
        if sm is not None:
            info["smoother"] = {
                "nodes": sm.nodes,
                "update_nodes": sm.update_nodes,
                "failed_nodes": sm.failed,
                "store_bytes": sm.store_bytes,
            }
        return cls(
            filter=filter,
            mission=mission,
            solution=solution,
            ledger=ledger,
            noise=noise_frame(ledger),
            meta=info,
            repairs=repairs_frame(repairs),
            events=events_frame(output.events),
            forward=None if sm is None else forward,
        )


# --- building the tables -------------------------------------------------------------------


def quat_to_euler_rows(q: Array) -> Array:
    """ZYX Euler angles ``[roll, pitch, yaw]`` (N, 3) of quaternions ``q_nb`` (N, 4).

    Row-wise twin of :func:`adaptnav.core.attitude.quat_to_euler`, the same DCM elements
    (Groves 2.34) and angles: ``roll = atan2(C32, C33)``, ``pitch = -asin(C31)``,
    ``yaw = atan2(C21, C11)``.
    """
    qa = np.asarray(q, dtype=float).reshape(-1, 4)
    w, x, y, z = qa[:, 0], qa[:, 1], qa[:, 2], qa[:, 3]
    c00 = w * w + x * x - y * y - z * z
    c10 = 2 * (x * y + w * z)
    c20 = 2 * (x * z - w * y)
    c21 = 2 * (y * z + w * x)
    c22 = w * w - x * x - y * y + z * z
    roll = np.arctan2(c21, c22)
    pitch = -np.arcsin(np.clip(c20, -1.0, 1.0))
    yaw = np.arctan2(c10, c00)
    return np.stack([roll, pitch, yaw], axis=-1)


def events_frame(rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """The ``events`` table from the engine's event rows (keys :data:`EVENT_COLUMNS`)."""
    df = pd.DataFrame(list(rows), columns=list(EVENT_COLUMNS))
    types: dict[str, Any] = {"row": "int64", "sensor": str, "event": str, "detail": str}
    types.update({k: float for k in ("t", "statistic", "threshold", "factor")})
    return df.astype(types)


def event_counts(events: pd.DataFrame) -> dict[str, int]:
    """How many events of each kind (``lockout``, ``nis``, ``covariance``), sorted by name."""
    return {str(k): int(v) for k, v in sorted(events["event"].value_counts().items())}


def solution_frame(t: Array, x: Array, P_diag: Array, P_cross: Array | None = None) -> pd.DataFrame:
    """The ``solution`` table from times (N,), nominal states (N, 16), P's diagonal (N, 15)
    and the off-diagonal elements of its position, velocity and attitude blocks (N, 9,
    :data:`COV_COLUMNS`; None: NaN, unknown): :func:`solution_rows` with its column names."""
    return pd.DataFrame(solution_rows(t, x, P_diag, P_cross), columns=list(SOLUTION_COLUMNS))


def solution_rows(t: Array, x: Array, P_diag: Array, P_cross: Array | None = None) -> Array:
    """The ``solution`` table's values (N, :data:`SOLUTION_COLUMNS`; column-major), arguments
    as for :func:`solution_frame`; also one row at a time (adaptnav.api.stream).

    ``sd_<name> = sqrt(P_ii)``; a negative diagonal element (a broken covariance) gives NaN.
    """
    ts = np.asarray(t, dtype=float).reshape(-1)
    xs = np.asarray(x, dtype=float).reshape(-1, NOM_SIZE)
    ps = np.asarray(P_diag, dtype=float).reshape(-1, N_STATES)
    n_cov = len(COV_COLUMNS)
    if P_cross is None:
        cs = np.full((ts.size, n_cov), np.nan)
    else:
        cs = np.asarray(P_cross, dtype=float).reshape(-1, n_cov)
    if not (ts.size == xs.shape[0] == ps.shape[0] == cs.shape[0]):
        raise ValueError(
            f"solution: t {ts.shape}, x {xs.shape}, P_diag {ps.shape} and P_cross {cs.shape} "
            "differ in rows"
        )
    blocks = [
        ts[None, :],
        xs[:, NOM_POS].T,
        xs[:, NOM_VEL].T,
        quat_to_euler_rows(xs[:, NOM_ATT]).T,
        xs[:, NOM_BA].T,
        xs[:, NOM_BG].T,
        np.sqrt(np.where(ps >= 0.0, ps, np.nan)).T,
        cs.T,
    ]
    # Filled column by column and handed over transposed: a table made of it takes each
    # column as it lies, without copying the whole array into columns.
    by_column = np.empty((len(SOLUTION_COLUMNS), ts.size))
    np.concatenate(blocks, axis=0, out=by_column)
    return by_column.T


def with_declared(
    solution: pd.DataFrame, names: Sequence[str], values: Array, variances: Array
) -> pd.DataFrame:
    """The solution with a column per declared state (e.g. the calibration states of
    docs/calibration.md, ``dvl.scale``; SI: ratio, rad, m) and its ``sd_`` column."""
    if not names:
        return solution
    extra = declared_columns(names, values, variances)
    return pd.concat([solution, pd.DataFrame(extra, index=solution.index)], axis=1)


def declared_columns(names: Sequence[str], values: Array, variances: Array) -> dict[str, Array]:
    """The columns :func:`with_declared` adds: each declared state's values (N,) and its
    ``sd_`` (the square root of its variance, 0 for a negative one)."""
    extra = {}
    for j, name in enumerate(names):
        extra[name] = values[:, j]
        extra[f"sd_{name}"] = np.sqrt(np.maximum(variances[:, j], 0.0))
    return extra


def has_covariances(solution: pd.DataFrame, names: Sequence[str]) -> bool:
    """Whether ``solution`` holds the covariances between the error states ``names`` (every
    pair's :func:`cov_column` present and not all NaN). Tables of older run folders do not."""
    columns = [cov_column(a, b) for k, a in enumerate(names) for b in names[k + 1 :]]
    return all(c in solution.columns for c in columns) and bool(
        np.isfinite(solution[columns].to_numpy(dtype=float)).any()
    )


def covariance_block(solution: pd.DataFrame, names: Sequence[str]) -> Array:
    """P's block (N, k, k) over the error states ``names`` (e.g. ``("dr_N", "dr_E",
    "dr_D")``) at every row: ``sd_<a>²`` on the diagonal, ``cov_<a>_<b>`` off it, and zero off
    it when the table has no covariances (:func:`has_covariances`, e.g. an older run folder).
    The pairs must be in the order of :data:`adaptnav.models.errorstate.STATE_NAMES`."""
    k = len(names)
    P = np.zeros((len(solution), k, k))
    for i, a in enumerate(names):
        P[:, i, i] = solution[f"sd_{a}"].to_numpy(dtype=float) ** 2
    if has_covariances(solution, names):
        for i, a in enumerate(names):
            for j in range(i + 1, k):
                v = solution[cov_column(a, names[j])].to_numpy(dtype=float)
                P[:, i, j] = P[:, j, i] = v
    return P


def ledger_frame(
    rows: Sequence[Mapping[str, Any]], kinds: Mapping[str, str] | None = None
) -> pd.DataFrame:
    """The engine's ledger rows as a table (known columns first, typed; extra keys kept):
    :func:`typed_ledger` of the rows (of the engine's columns when it kept them,
    :class:`adaptnav.engine.batch.LedgerRows`)."""
    if isinstance(rows, LedgerRows):
        return typed_ledger(pd.DataFrame(rows.columns, columns=list(LEDGER_COLUMNS)), kinds)
    extra = sorted(set().union(*rows) - set(LEDGER_COLUMNS))
    # pandas reads the dicts column by column in C; a key a row lacks becomes NaN.
    return typed_ledger(pd.DataFrame(list(rows), columns=[*LEDGER_COLUMNS, *extra]), kinds)


def typed_ledger(frame: pd.DataFrame, kinds: Mapping[str, str] | None = None) -> pd.DataFrame:
    """A ledger table (:data:`LEDGER_COLUMNS` first, then any others) with its known columns
    typed: ``row`` and ``iterations`` integers, ``sensor``, ``fate``, ``reason`` text, the rest
    floats.

    With ``kinds`` (sensor name → kind) a ``kind`` column follows ``sensor``; every sensor in
    the ledger must have a kind.
    """
    frame = frame.copy(deep=False)  # copy-on-write: the caller's table is left as it is
    for c in frame.columns:
        if c in _LEDGER_INT:
            frame[c] = frame[c].astype("int64")
        elif c in _LEDGER_STR:
            frame[c] = frame[c].astype("str")
        elif c in LEDGER_COLUMNS:
            frame[c] = frame[c].astype("float64")
    if kinds is not None:
        unknown = sorted(set(frame["sensor"].unique()) - set(kinds))
        if unknown:
            raise ValueError(f"kinds: no kind given for sensors {unknown}")
        kind = frame["sensor"].map(dict(kinds)).astype("str")
        frame.insert(list(frame.columns).index("sensor") + 1, "kind", kind)
    return frame


def dropped_ledger(
    sensor: str | Sequence[str], rows: ArrayLike, t: ArrayLike, reason: str | Sequence[str]
) -> pd.DataFrame:
    """Ledger rows (:func:`typed_ledger`) of readings at file ``rows`` and times ``t`` dropped
    before the engine: fate ``dropped``, no statistic, no innovation, as
    :func:`adaptnav.api.runner.ledger_row`'s rows. ``sensor`` and ``reason``: one for all
    rows, or one per row."""
    r = np.asarray(rows, dtype=np.int64).reshape(-1)
    nan = np.full(r.size, math.nan)
    columns: dict[str, Any] = {c: nan for c in LEDGER_COLUMNS}
    columns.update(
        t=np.asarray(t, dtype=float).reshape(-1), sensor=sensor, row=r, fate="dropped",
        reason=reason, iterations=np.zeros(r.size, dtype=np.int64),
    )  # fmt: skip
    return typed_ledger(pd.DataFrame(columns, index=pd.RangeIndex(r.size)))


def noise_frame(ledger: pd.DataFrame) -> pd.DataFrame:
    """The ``noise`` table: for each ``used`` ledger row and component j with a finite ``r_j``,
    ``(t_s = t, sensor, component = j, r_hat = r_j)``, in ledger order then component order."""
    used = ledger[ledger["fate"] == "used"]
    r = used[[f"r_{j}" for j in range(MAX_DIM)]].to_numpy(dtype=float)
    rows, comps = np.nonzero(np.isfinite(r))  # row-major: ledger order, then component
    return pd.DataFrame(
        {
            "t_s": used["t"].to_numpy(dtype=float)[rows],
            "sensor": pd.Series(used["sensor"].to_numpy()[rows], dtype="str"),
            "component": comps.astype("int64"),
            "r_hat": r[rows, comps],
        },
        columns=list(NOISE_COLUMNS),
    )


def empty_repairs() -> pd.DataFrame:
    """A repairs table with no rows."""
    return repairs_frame(None)


def repairs_frame(repairs: pd.DataFrame | Sequence[Mapping[str, Any]] | None) -> pd.DataFrame:
    """Input repairs ``file, line, field, action, detail`` (line a nullable integer, missing
    when the repair concerns a whole table or sensor; the rest text)."""
    if repairs is None:
        frame = pd.DataFrame({c: [] for c in REPAIR_COLUMNS})
    elif isinstance(repairs, pd.DataFrame):
        frame = repairs.copy()
    else:
        frame = pd.DataFrame(list(repairs), columns=list(REPAIR_COLUMNS))
    missing = [c for c in REPAIR_COLUMNS if c not in frame.columns]
    if missing:
        raise ValueError(f"repairs lack columns {missing}")
    frame = frame[list(REPAIR_COLUMNS)].reset_index(drop=True)
    # missing (<NA>) for a repair of a whole table or sensor (a degree column converted)
    frame["line"] = frame["line"].astype("Int64")
    for c in ("file", "field", "action", "detail"):
        frame[c] = frame[c].astype("str")
    return frame


def ledger_counts(ledger: pd.DataFrame) -> dict[str, dict[str, int]]:
    """Readings per sensor and fate: ``{sensor: {"used": n, "rejected": n, "dropped": n}}``.

    Every sensor in the ledger appears (sorted by name) with all three fates, zeros included;
    any other fate found in the ledger is counted too.
    """
    counts: dict[str, dict[str, int]] = {}
    if ledger.empty:
        return counts
    table = ledger.groupby(["sensor", "fate"]).size().reset_index(name="n")
    for sensor in sorted(set(ledger["sensor"].unique())):
        counts[str(sensor)] = {fate: 0 for fate in FATES}
    for sensor, fate, n in zip(table["sensor"], table["fate"], table["n"], strict=True):
        counts[str(sensor)][str(fate)] = int(n)
    return counts


# --- JSON ----------------------------------------------------------------------------------


def jsonable(value: Any, where: str = "value") -> Any:
    """``value`` with only JSON types: NumPy scalars/arrays → Python, tuples → lists, paths →
    str, non-finite floats → None. Raises TypeError (naming ``where``) for anything else."""
    if value is None or isinstance(value, bool | str | int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, np.generic):
        return jsonable(value.item(), where)
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist(), where)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): jsonable(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v, f"{where}[{i}]") for i, v in enumerate(value)]
    raise TypeError(f"{where}: {type(value).__name__} is not JSON-serialisable")


# --- the run folder ------------------------------------------------------------------------


def summary(result: Result, files: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, Any]:
    """The ``summary.json`` content: format, filter, mission, meta, ledger counts and, when
    given, ``files`` (:data:`FILES_KEY`: each file written, its :func:`file_digest`)."""
    doc = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "filter": result.filter,
        "mission": result.mission,
        "meta": result.meta,
        "counts": ledger_counts(result.ledger),
        "events": event_counts(result.events),
    }
    if files is not None:
        doc[FILES_KEY] = {name: dict(entry) for name, entry in files.items()}
    return doc


def file_digest(path: Path) -> dict[str, Any]:
    """``{"sha256": hex digest, "bytes": size}`` of the file at ``path``, read in chunks by
    :func:`hashlib.file_digest` (a day-long run's solution is hundreds of MB, never held
    whole)."""
    with path.open("rb") as f:
        digest = hashlib.file_digest(f, "sha256")
        size = f.tell()
    return {"sha256": digest.hexdigest(), "bytes": size}


def save(
    result: Result, run_dir: str | Path, *, truth: pd.DataFrame | str | Path | None = None
) -> Path:
    """Write the run folder (created if needed; files of the same names are replaced).

    ``truth``: the mission's reference, written as ``truth.parquet`` (a table, or the path of
    a ``truth.parquet`` already written, copied byte for byte). A table the run does not write
    (``forward.parquet`` of a run that was not smoothed, ``truth.parquet`` without ``truth``)
    is removed if the folder had one. ``summary.json`` is written last, with the SHA-256 of
    every table as written (:data:`FILES_KEY`), which :func:`load` checks.

    RunFolderError for a mission folder (it would hold a run and a mission at once) or a path
    that is a file."""
    folder = Path(run_dir)
    if (folder / "mission.toml").is_file():
        raise RunFolderError(f"{folder}: a mission folder; save the run in a folder of its own")
    if folder.exists() and not folder.is_dir():
        raise RunFolderError(f"{folder}: a file, not a folder")
    folder.mkdir(parents=True, exist_ok=True)
    files: dict[str, dict[str, Any]] = {}
    for name, filename in TABLE_FILES.items():
        table: pd.DataFrame | None = getattr(result, name)
        if table is None:  # not smoothed: no forward table, and none left from before
            (folder / filename).unlink(missing_ok=True)
            continue
        write_parquet(table, folder / filename)
        files[filename] = file_digest(folder / filename)
    if _write_truth(truth, folder / TRUTH_FILE):
        files[TRUTH_FILE] = file_digest(folder / TRUTH_FILE)
    calibration = folder / CALIBRATION_FILE
    calibration.unlink(missing_ok=True)
    if result.meta.get("calibration"):
        text = json.dumps(result.meta["calibration"], indent=2, allow_nan=False)
        calibration.write_text(text + "\n", encoding="utf-8")
    text = json.dumps(summary(result, files), indent=2, allow_nan=False)
    (folder / SUMMARY_FILE).write_text(text + "\n", encoding="utf-8")
    return folder


def _write_truth(truth: pd.DataFrame | str | Path | None, path: Path) -> bool:
    """Write the reference to ``path`` (a table, or a file copied as it is); with none, remove
    one left from before. Whether it wrote one."""
    if truth is None:
        path.unlink(missing_ok=True)
        return False
    if isinstance(truth, pd.DataFrame):
        write_parquet(truth, path)
    else:
        shutil.copyfile(truth, path)
    return True


def check_times(solution: pd.DataFrame, label: str) -> None:
    """A solution table's rows must be epochs in time order: at least one, every ``t_s`` a
    finite number, each after the one before (what :func:`save` writes). Raises
    :class:`RunFolderError` naming the row (0-based) otherwise: a table edited or damaged
    after the run, which evaluation and export would otherwise take as it is."""
    if len(solution) == 0:
        raise RunFolderError(f"{label}: no rows (a run writes at least one epoch)")
    t = pd.to_numeric(solution["t_s"], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        k = int(bad[0])
        raise RunFolderError(
            f"{label} row {k}, t_s: {_shown(solution['t_s'].iloc[k])} is not a time"
        )
    back = np.flatnonzero(np.diff(t) <= 0.0)
    if back.size:
        k = int(back[0]) + 1
        raise RunFolderError(
            f"{label} row {k}, t_s: {t[k]!r} does not follow row {k - 1}'s {t[k - 1]!r} "
            "(a solution's times increase)"
        )


def _shown(value: Any) -> str:
    """A cell as a message shows it: ``nan``, ``inf``, ``1.5``, ``'abc'``."""
    return repr(float(value)) if isinstance(value, float | np.floating) else repr(value)


def check_finite(solution: pd.DataFrame, columns: Sequence[str], label: str) -> None:
    """Every value of ``columns`` must be a finite number: a run writes no NaN or infinity in
    its solution, so one is damage, and an exporter would write it on (a NaN pose in a bag, a
    gap in a KML line). Raises ValueError naming the first such row (0-based) and column."""
    for name in columns:
        values = pd.to_numeric(solution[name], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            k = int(bad[0])
            raise ValueError(
                f"{label} row {k}, {name}: {_shown(solution[name].iloc[k])} is not a finite number "
                f"({bad.size} such row(s); a run writes none: a damaged table?)"
            )


def check_forward(
    folder: Path, meta: Mapping[str, Any], tables: Mapping[str, pd.DataFrame]
) -> None:
    """A run folder's ``forward.parquet`` must be there exactly when ``summary.json``'s
    ``meta.smoother`` says the run was smoothed (:meth:`Result.from_engine` writes both), and
    its ``t_s`` must be the solution's, value for value: the smoother reports each output row
    of the forward pass smoothed (engine/batch.py ``Navigator.smooth`` copies the output
    times). Raises :class:`RunFolderError` naming the file otherwise (since 0.4.6): ``evaluate``
    scored a smoothed run without it as a plain one, and one truncated, shifted or of another
    run as that run's forward solution."""
    path = folder / TABLE_FILES["forward"]
    forward = tables.get("forward")
    smoothed = meta.get("smoother") is not None
    if forward is None:
        if smoothed:
            raise RunFolderError(
                f"run folder {folder}: missing {path.name} ({SUMMARY_FILE}'s meta.smoother says "
                "the run was smoothed, and its forward solution is kept beside the smoothed one)"
            )
        return
    if not smoothed:
        raise RunFolderError(
            f"{path}: a forward solution in a run that was not smoothed ({SUMMARY_FILE} has no "
            "meta.smoother): left from another run?"
        )
    t_fwd = forward["t_s"].to_numpy(dtype=float)
    t_sol = tables["solution"]["t_s"].to_numpy(dtype=float)
    if t_fwd.size != t_sol.size:
        raise RunFolderError(
            f"{path}: {t_fwd.size} rows, and {TABLE_FILES['solution']} has {t_sol.size} (the "
            "smoother writes both at the same output times): truncated, or of another run?"
        )
    differ = np.flatnonzero(t_fwd != t_sol)
    if differ.size:
        k = int(differ[0])
        raise RunFolderError(
            f"{path} row {k}, t_s: {float(t_fwd[k])!r}, and {TABLE_FILES['solution']}'s is "
            f"{float(t_sol[k])!r} (the smoother writes both at the same output times; "
            f"{differ.size} row(s) differ): of another run?"
        )


def read_summary(run_dir: str | Path) -> dict[str, Any]:
    """A run folder's ``summary.json``, checked: a JSON object of this format, of a version
    this adaptnav reads, with ``filter``, ``mission`` and a ``meta`` object. Raises
    :class:`RunFolderError` naming the folder or the file otherwise (a missing folder, a
    mission folder given for a run folder)."""
    folder = Path(run_dir)
    if not folder.exists():
        raise RunFolderError(f"run folder {folder} does not exist")
    if not folder.is_dir():
        raise RunFolderError(f"run folder {folder} is not a directory")
    path = folder / SUMMARY_FILE
    if not path.is_file():
        if (folder / "mission.toml").is_file():  # the commonest mix-up: a mission, not a run
            raise RunFolderError(
                f"{folder} is a mission folder, not a run folder: run a filter on it first "
                f"(adaptnav run {folder} --out RUN) and give RUN"
            )
        raise RunFolderError(f"run folder {folder}: missing {SUMMARY_FILE}")
    info = read_json_object(path, RunFolderError)
    problem = format_problem({"format": FORMAT_NAME, **info}, FORMAT_NAME, FORMAT_VERSION)
    if problem:
        raise RunFolderError(f"{path}: {problem}")
    missing_keys = [k for k in ("filter", "mission", "meta") if k not in info]
    if missing_keys:
        raise RunFolderError(f"{path}: missing keys {missing_keys}")
    if not isinstance(info["meta"], dict):
        raise RunFolderError(f"{path}: 'meta' must be a JSON object")
    return info


_HEX = frozenset("0123456789abcdef")


def recorded_files(run_dir: str | Path, info: Mapping[str, Any]) -> dict[str, str] | None:
    """The SHA-256 (hex) of each file the run wrote, by file name, from its ``summary.json``
    ``info`` (:data:`FILES_KEY`); None for a summary without them (an older run's). Raises
    :class:`RunFolderError` naming ``summary.json`` when the record is not one."""
    files = info.get(FILES_KEY)
    if files is None:
        return None
    where = Path(run_dir) / SUMMARY_FILE
    if not isinstance(files, dict):
        raise RunFolderError(f"{where}: {FILES_KEY!r} must be a JSON object")
    out = {}
    for name, entry in files.items():
        digest = entry.get("sha256") if isinstance(entry, dict) else None
        if not (isinstance(digest, str) and len(digest) == 64 and _HEX.issuperset(digest)):
            raise RunFolderError(
                f"{where}: {FILES_KEY!r} entry {name!r} must be an object with a 'sha256' of 64 "
                "hexadecimal digits"
            )
        out[str(name)] = digest
    return out


def check_files(run_dir: str | Path, info: Mapping[str, Any], names: Iterable[str]) -> None:
    """Each file of ``names`` in the run folder must be the one the run wrote: its SHA-256
    the one ``summary.json`` (``info``) records. Raises :class:`RunFolderError` naming the
    file when it differs (changed after the run, or taken from another run: another run of the
    same mission writes a table of the same shape at the same times, which no other check
    tells apart), when the summary records no digest for a file there (added after the run),
    or when a file it records is gone. A summary without the record (a run folder of an older
    adaptnav) is not checked. Since 0.4.7; docs/robustness.md, 'Run folders'."""
    folder = Path(run_dir)
    recorded = recorded_files(folder, info)
    if recorded is None:
        return
    for name in names:
        path = folder / name
        want = recorded.get(name)
        if not path.is_file():
            if want is not None:
                raise RunFolderError(
                    f"run folder {folder}: missing {name} (the run wrote it: {SUMMARY_FILE} "
                    "records its digest)"
                )
            continue
        if want is None:
            raise RunFolderError(
                f"{path}: not a file this run wrote ({SUMMARY_FILE} records no digest for it): "
                "added after the run, or left from another run?"
            )
        got = file_digest(path)["sha256"]
        if got != want:
            raise RunFolderError(
                f"{path}: not the file this run wrote (changed after the run, or taken from "
                f"another run): its SHA-256 begins {got[:12]}, and {SUMMARY_FILE} records "
                f"{want[:12]}"
            )


def _read_tables(folder: Path) -> dict[str, pd.DataFrame]:
    """The run folder's tables by name (:data:`TABLE_FILES`), each readable, with its
    required columns, and a solution's times in order (:func:`check_times`)."""
    tables: dict[str, pd.DataFrame] = {}
    for name, filename in TABLE_FILES.items():
        table_path = folder / filename
        if not table_path.is_file() and name in OPTIONAL_TABLES:
            if name == "events":
                tables[name] = events_frame([])
            continue
        if not table_path.is_file():
            raise RunFolderError(f"run folder {folder}: missing {filename}")
        try:
            table = pd.read_parquet(table_path)
        except Exception as exc:  # pyarrow raises several types for a corrupt file
            raise RunFolderError(f"{table_path}: not a readable parquet file ({exc})") from exc
        missing = [c for c in _REQUIRED[name] if c not in table.columns]
        if missing:
            raise RunFolderError(f"{table_path}: missing columns {missing}")
        if name in ("solution", "forward"):
            check_times(table, str(table_path))
        tables[name] = table
    return tables


def load(run_dir: str | Path) -> Result:
    """Read a run folder written by :func:`save`.

    Raises :class:`RunFolderError` (a ValueError) naming the folder or the file that is
    missing, unreadable or lacks required content, a ``forward.parquet`` at odds with the
    run (:func:`check_forward`), or a table that is not the one the run wrote
    (:func:`check_files`; checked last, so that a damaged table is named by what is wrong
    with it).
    """
    folder = Path(run_dir)
    info = read_summary(folder)
    tables = _read_tables(folder)
    check_forward(folder, info["meta"], tables)
    check_files(folder, info, TABLE_FILES.values())
    return Result(
        filter=str(info["filter"]),
        mission=str(info["mission"]),
        solution=tables["solution"],
        ledger=tables["ledger"],
        noise=tables["noise"],
        meta=info["meta"],
        repairs=tables["repairs"],
        events=tables["events"],
        forward=tables.get("forward"),
    )


def load_truth(run_dir: str | Path) -> pd.DataFrame | None:
    """A run folder's reference (``truth.parquet``, kept by ``run`` and ``compare`` for a
    mission with one) as it is, or None when the folder has none. Raises
    :class:`RunFolderError` naming the file when it is not a readable Parquet file or not the
    one the run wrote (:func:`check_files`)."""
    folder = Path(run_dir)
    path = folder / TRUTH_FILE
    if not path.is_file():
        return None
    try:
        truth = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        raise RunFolderError(f"{path}: not a readable Parquet file ({exc})") from None
    check_files(folder, read_summary(folder), [TRUTH_FILE])
    return truth
