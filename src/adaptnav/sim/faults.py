"""Sensor faults injected into a simulated mission: the benchmark of issue 12 (docs/faults.md).

:func:`inject` takes a mission folder (as written by ``adaptnav simulate``, or any mission with a
DVL and a depth sensor, CSV or Parquet) and writes a **faulted copy** to a new folder: every file
copied as it is, except the tables of the faulted sensors, and a ``faults.json`` that says what
was injected where. The IMU, the truth and ``mission.toml`` are untouched, so a faulted run is
scored against the same reference as the clean one and differs from it only by the fault.

The fault models (the issue's, :class:`FaultParams` holds their sizes):

* ``depth_spike``: one depth reading + 1000 m;
* ``depth_offset``: 10 s of depth readings + 1000 m;
* ``dvl_stuck``: 60 s of DVL readings all equal to the first valid reading of the window (the
  first one is genuine; the repeats are the fault);
* ``dvl_dropout``: 300 s of DVL rows removed from the table (no reading at all, not NaN rows);
* ``dvl_spikes``: 1 % of the DVL readings get ± U(1, 3) m/s on a random non-empty set of axes
  (:func:`spike_vectors`, the draw of :func:`adaptnav.importers.akit.inject_dvl_faults`);
* ``all``: every one of them at once, in disjoint windows.

**Placement.** One seeded layout places the four windows (depth spike, depth offset, DVL stuck,
DVL dropout) disjointly, at least ``gap_s`` apart, inside ``[alignment end + settle_s, end -
end_margin_s]``; the spikes then go on readings inside that span and outside the DVL windows.
The layout and the spikes are drawn for every kind whichever is injected, so with the same
generator state a fault sits at the same place alone and inside ``all``.

**The oracle.** Every changed reading is flagged ``is_outlier = 1`` in its table (a column the
depth table gains), so the oracle (:mod:`adaptnav.api.oracle`) drops it as a known outlier and stays
the bound it is on the clean mission: what a filter told about the fault could do. A removed
reading needs no flag.

``faults.json`` rows are 0-based data rows of the *faulted* table, the ledger's ``row``
(docs/data-format.md): after a dropout, the later rows of the DVL table move up.
"""

from __future__ import annotations

import json
import math
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.core.formats import format_problem
from adaptnav.mission import MissionConfig, load_config
from adaptnav.mission.loader import CONFIG_NAME
from adaptnav.mission.tables import table_format, write_table
from adaptnav.sim.sensors import in_intervals, place_intervals

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = [
    "ALL",
    "FAULTS_FILE",
    "FAULT_KINDS",
    "FaultKind",
    "FaultLog",
    "FaultParams",
    "Injected",
    "inject",
    "layout",
    "plan",
    "read_faults",
    "spike_vectors",
]

FaultKind = Literal["depth_spike", "depth_offset", "dvl_stuck", "dvl_dropout", "dvl_spikes"]
FAULT_KINDS: tuple[FaultKind, ...] = get_args(FaultKind)
"""The single faults, in the order they are drawn and written."""
ALL = "all"
"""The case with every fault of :data:`FAULT_KINDS` at once."""
WINDOW_KINDS: tuple[FaultKind, ...] = ("depth_spike", "depth_offset", "dvl_stuck", "dvl_dropout")
"""The faults that occupy a time window of the layout (the spikes are scattered)."""
FAULTS_FILE = "faults.json"
FORMAT_NAME = "adaptnav-faults"
FORMAT_VERSION = 1
OUTLIER_COLUMN = "is_outlier"
"""The simulator's per-reading outlier flag, which the oracle drops (:mod:`adaptnav.api.oracle`)."""
DVL_COLUMNS = ("vx_m_s", "vy_m_s", "vz_m_s")
DEPTH_COLUMN = "depth_m"


@dataclass(frozen=True)
class FaultParams:
    """Sizes and placement of the faults (docs/faults.md); the defaults are issue 12's.

    Attributes:
        depth_spike_m: added to the one depth reading of ``depth_spike``.
        depth_spike_window_s: the slot the spike takes in the layout (one reading at 1 Hz).
        depth_offset_m, depth_offset_s: added to the depth readings of a window that long.
        dvl_stuck_s: how long the DVL repeats one reading.
        dvl_dropout_s: how long the DVL has no reading.
        dvl_spike_fraction: share of the DVL's navigation readings (after the alignment) that
            get a spike (at least one).
        dvl_spike_range_m_s: spike size per axis, U(low, high) with a random sign.
        settle_s: no fault before the alignment's end plus this: the adaptive filters' noise
            estimates (a matching window, VB's forgetting) have settled by then.
        end_margin_s: no fault in this last stretch, so each fault's aftermath is scored.
        gap_s: least time between two windows, so one fault's transient has decayed before the
            next (in ``all``).
        dvl_sensor, depth_sensor: the faulted sensors' names; None: the mission's only aiding
            sensor of that kind.
    """

    depth_spike_m: float = 1000.0
    depth_spike_window_s: float = 1.0
    depth_offset_m: float = 1000.0
    depth_offset_s: float = 10.0
    dvl_stuck_s: float = 60.0
    dvl_dropout_s: float = 300.0
    dvl_spike_fraction: float = 0.01
    dvl_spike_range_m_s: tuple[float, float] = (1.0, 3.0)
    settle_s: float = 300.0
    end_margin_s: float = 300.0
    gap_s: float = 120.0
    dvl_sensor: str | None = None
    depth_sensor: str | None = None

    def __post_init__(self) -> None:
        positive = ("depth_spike_window_s", "depth_offset_s", "dvl_stuck_s", "dvl_dropout_s")
        for name in positive:
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name}: {v!r} must be a finite number > 0")
        for name in ("settle_s", "end_margin_s", "gap_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"{name}: {v!r} must be a finite number >= 0")
        for name in ("depth_spike_m", "depth_offset_m"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name}: {getattr(self, name)!r} must be finite")
        if not 0.0 < self.dvl_spike_fraction <= 1.0:
            raise ValueError(f"dvl_spike_fraction: {self.dvl_spike_fraction!r} not in (0, 1]")
        lo, hi = self.dvl_spike_range_m_s
        if not (math.isfinite(hi) and 0.0 <= lo <= hi):
            raise ValueError(f"dvl_spike_range_m_s: {self.dvl_spike_range_m_s!r}: 0 <= low <= high")
        object.__setattr__(self, "dvl_spike_range_m_s", (float(lo), float(hi)))

    def window_s(self, kind: FaultKind) -> float:
        """The length of ``kind``'s window in the layout."""
        return {
            "depth_spike": self.depth_spike_window_s,
            "depth_offset": self.depth_offset_s,
            "dvl_stuck": self.dvl_stuck_s,
            "dvl_dropout": self.dvl_dropout_s,
        }[kind]


@dataclass(frozen=True)
class Injected:
    """One injected fault, as written to ``faults.json``.

    ``rows``: the changed readings, 0-based data rows of the faulted table (the ledger's
    ``row``); ``removed_rows``: the source table's rows taken out (a dropout); ``window_s``:
    ``[start, end)`` in the mission's time (None for the scattered spikes); ``detail``: the
    kind's own figures (offset, stuck value, spike vectors).
    """

    kind: FaultKind
    sensor: str
    file: str
    window_s: tuple[float, float] | None
    rows: tuple[int, ...]
    removed_rows: tuple[int, ...] = ()
    detail: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "sensor": self.sensor,
            "file": self.file,
            "window_s": None if self.window_s is None else list(self.window_s),
            "rows": list(self.rows),
            "removed_rows": list(self.removed_rows),
            "detail": dict(self.detail),
        }


@dataclass(frozen=True)
class FaultLog:
    """A faulted mission's ``faults.json``: what :func:`inject` did.

    ``case``: the kind asked for (a :data:`FAULT_KINDS` or :data:`ALL`); ``span_s``: where faults
    could go (after the alignment and ``settle_s``, before ``end_margin_s``); ``seed``: the
    generator's seed entropy if it was made from one (provenance only); ``layout_s``: the
    window of every kind of :data:`WINDOW_KINDS`, injected or not (:func:`layout`); ``faults``:
    one :class:`Injected` per fault, in :data:`FAULT_KINDS` order.
    """

    source: str
    case: str
    params: FaultParams
    navigation_start_s: float
    span_s: tuple[float, float]
    seed: Any
    layout_s: Mapping[str, tuple[float, float]]
    faults: tuple[Injected, ...]

    def of(self, kind: FaultKind) -> Injected:
        """The fault of ``kind`` (KeyError if it was not injected)."""
        for f in self.faults:
            if f.kind == kind:
                return f
        raise KeyError(f"no {kind} fault in this mission (case {self.case!r})")

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "source": self.source,
            "case": self.case,
            "params": asdict(self.params),
            "navigation_start_s": self.navigation_start_s,
            "span_s": list(self.span_s),
            "seed": self.seed,
            "layout_s": {k: list(v) for k, v in self.layout_s.items()},
            "faults": [f.to_json() for f in self.faults],
        }


def read_faults(folder: str | Path) -> FaultLog:
    """The :class:`FaultLog` of a faulted mission folder (its ``faults.json``)."""
    path = Path(folder) / FAULTS_FILE
    doc = json.loads(path.read_text(encoding="utf-8"))
    problem = format_problem(doc, FORMAT_NAME, FORMAT_VERSION)
    if problem:
        raise ValueError(f"{path}: {problem}")
    p = dict(doc["params"])
    p["dvl_spike_range_m_s"] = tuple(p["dvl_spike_range_m_s"])
    faults = tuple(
        Injected(
            kind=f["kind"],
            sensor=f["sensor"],
            file=f["file"],
            window_s=None if f["window_s"] is None else (f["window_s"][0], f["window_s"][1]),
            rows=tuple(f["rows"]),
            removed_rows=tuple(f["removed_rows"]),
            detail=f["detail"],
        )
        for f in doc["faults"]
    )
    return FaultLog(
        source=doc["source"],
        case=doc["case"],
        params=FaultParams(**p),
        navigation_start_s=float(doc["navigation_start_s"]),
        span_s=(float(doc["span_s"][0]), float(doc["span_s"][1])),
        seed=doc.get("seed"),
        layout_s={k: (float(v[0]), float(v[1])) for k, v in doc["layout_s"].items()},
        faults=faults,
    )


# --- drawing -----------------------------------------------------------------------------------


def spike_vectors(
    rng: np.random.Generator, count: int, magnitude_m_s: tuple[float, float]
) -> Array:
    """``count`` spike vectors (count, 3): each on a random non-empty set of axes (each of the
    seven sets equally likely), ± U(magnitude) m/s per axis with a random sign, 0 elsewhere.

    The same draws, in the same order, as the spikes of
    :func:`adaptnav.importers.akit.inject_dvl_faults` (the paper's "drastic and unreal changes";
    docs/simulation.md, 'What makes adaptation matter').
    """
    out = np.zeros((count, 3))
    for i in range(count):
        axes = np.zeros(3, dtype=bool)
        while not axes.any():  # rejection: uniform over the non-empty subsets
            axes = rng.random(3) < 0.5
        magnitude = rng.uniform(*magnitude_m_s, size=3)
        sign = rng.choice([-1.0, 1.0], size=3)
        out[i] = np.where(axes, sign * magnitude, 0.0)
    return out


def layout(
    span_s: tuple[float, float], params: FaultParams, rng: np.random.Generator
) -> dict[FaultKind, tuple[float, float]]:
    """The windows ``[start, end)`` of :data:`WINDOW_KINDS`: disjoint, at least ``gap_s``
    apart, uniformly placed in ``span_s`` in a random order (:func:`place_intervals`)."""
    lo, hi = span_s
    lengths = [params.window_s(k) for k in WINDOW_KINDS]
    # Each window carries its gap behind it; the last gap may hang past the span's end.
    padded = [d + params.gap_s for d in lengths]
    try:
        placed = place_intervals(lo, hi + params.gap_s, padded, rng)
    except ValueError:
        need = sum(lengths) + params.gap_s * (len(lengths) - 1)
        raise ValueError(
            f"the fault windows ({need:g} s with their gaps) do not fit in the span "
            f"[{lo:.1f}, {hi:.1f}] s left after the alignment, settle_s and end_margin_s"
        ) from None
    return {
        k: (float(a), float(a) + d)
        for k, (a, _), d in zip(WINDOW_KINDS, placed, lengths, strict=True)
    }


# --- the mission folder ------------------------------------------------------------------------


def _read(path: Path) -> pd.DataFrame:
    if table_format(path) == "csv":
        return pd.read_csv(path)
    return pd.read_parquet(path)


def _time_column(path: Path) -> Array:
    """The ``t_s`` column of a table (names are matched without surrounding spaces)."""
    if table_format(path) == "csv":
        df = pd.read_csv(path, usecols=lambda c: str(c).strip() == "t_s")
    else:
        df = pd.read_parquet(path)
        df = df[[c for c in df.columns if str(c).strip() == "t_s"]]
    if df.shape[1] != 1:
        raise ValueError(f"{path}: no t_s column")
    return np.asarray(df.iloc[:, 0].to_numpy(dtype=float), dtype=float)


def _sensor(config: MissionConfig, kind: str, name: str | None) -> str:
    if name is not None:
        if name not in config.sensors or config.sensors[name].kind != kind:
            raise ValueError(f"{CONFIG_NAME}: no {kind} sensor named {name!r}")
        return name
    found = [n for n, s in config.sensors.items() if s.kind == kind and s.use == "aid"]
    if len(found) != 1:
        raise ValueError(
            f"{CONFIG_NAME}: {len(found)} aiding {kind} sensors ({found}); name the one to fault"
        )
    return found[0]


def _span(root: Path, config: MissionConfig, params: FaultParams) -> tuple[float, float, float]:
    """(navigation start, span start, span end): the alignment's end as api.initial_state puts
    it, then the margins; the end is the IMU's last time, or the truth's if it ends first."""
    imu_t = _time_column(root / config.imu.file)
    # The first increment covers the interval before its stamp (docs/data-format.md).
    t0 = float(imu_t[0]) - (1.0 / config.imu.rate_hz if config.imu.format == "increments" else 0.0)
    nav_start = t0 + (config.initial.alignment_s if config.initial.mode == "alignment" else 0.0)
    end = float(imu_t[-1])
    if config.truth.file is not None and (root / config.truth.file).is_file():
        end = min(end, float(_time_column(root / config.truth.file)[-1]))
    return nav_start, nav_start + params.settle_s, end - params.end_margin_s


def _finite_rows(table: pd.DataFrame, columns: Sequence[str]) -> NDArray[np.bool_]:
    values = table[list(columns)].to_numpy(dtype=float)
    return np.asarray(np.all(np.isfinite(values), axis=1), dtype=bool)


def _flag(table: pd.DataFrame, rows: IntArray) -> None:
    """Mark ``rows`` as outliers (known to the oracle); the depth table gains the column."""
    if OUTLIER_COLUMN in table.columns:
        flags = table[OUTLIER_COLUMN].to_numpy().copy()
    else:
        flags = np.zeros(len(table), dtype=np.int8)
    flags[rows] = 1
    table[OUTLIER_COLUMN] = flags


def _set(table: pd.DataFrame, columns: Sequence[str], rows: IntArray, values: Array) -> None:
    """``table[columns]`` at ``rows`` = ``values`` (rows, len(columns)); other rows untouched."""
    for j, c in enumerate(columns):
        col = table[c].to_numpy(dtype=float).copy()
        col[rows] = values[:, j]
        table[c] = col


def plan(
    source: str | Path, rng: np.random.Generator, params: FaultParams | None = None
) -> dict[FaultKind, tuple[float, float]]:
    """The windows :func:`inject` would place in the mission ``source`` with a generator in
    the state of ``rng`` (:func:`layout`), without writing anything: e.g. to score a clean run
    at the dropout's window."""
    p = params if params is not None else FaultParams()
    src = Path(source)
    _, lo, hi = _span(src, load_config(src / CONFIG_NAME), p)
    return layout((lo, hi), p, rng)


def inject(
    source: str | Path,
    out: str | Path,
    case: str,
    rng: np.random.Generator,
    params: FaultParams | None = None,
) -> FaultLog:
    """Write a copy of the mission ``source`` with the fault ``case`` (one of
    :data:`FAULT_KINDS`, or :data:`ALL`) to the new folder ``out``; returns what was injected
    (also written to ``out/faults.json``). See the module docstring for the models.

    ``out`` must not exist (or be an empty folder); it is written whole or not at all.
    ValueError for an unknown case, a mission without the sensor, a source that already has a
    ``faults.json``, or a span too short for the windows.
    """
    p = params if params is not None else FaultParams()
    kinds = _kinds(case)
    src, dst = Path(source), Path(out)
    _check_folders(src, dst)
    config = load_config(src / CONFIG_NAME)
    dvl, depth, files = _faulted_sensors(config, p)

    nav_start, lo, hi = _span(src, config, p)
    windows = layout((lo, hi), p, rng)
    tables = {dvl: _read(src / files[dvl]), depth: _read(src / files[depth])}
    placed = _place_dvl(tables[dvl], windows, nav_start, (lo, hi), p, rng)
    tables[dvl], faults = _fault_dvl(tables[dvl], dvl, files[dvl], kinds, placed, p)
    faults.update(_fault_depth(tables[depth], depth, files[depth], kinds, windows, hi, p))

    log = FaultLog(
        source=str(src.resolve()),
        case=case,
        params=p,
        navigation_start_s=nav_start,
        span_s=(lo, hi),
        seed=_seed_of(rng),
        layout_s={str(k): v for k, v in windows.items()},
        faults=tuple(faults[k] for k in FAULT_KINDS if k in faults),
    )
    changed = {files[n]: tables[n] for n in (dvl, depth) if any(f.sensor == n for f in log.faults)}
    _write_copy(src, dst, changed, log)
    return log


def _kinds(case: str) -> tuple[FaultKind, ...]:
    """The single faults of ``case`` (:data:`ALL`: every one); ValueError for an unknown case."""
    if case == ALL:
        return FAULT_KINDS
    if case in FAULT_KINDS:
        return (case,)
    raise ValueError(f"fault {case!r}: use one of {', '.join((*FAULT_KINDS, ALL))}")


def _check_folders(src: Path, dst: Path) -> None:
    """The source must be a clean mission, the output absent or an empty folder."""
    if (src / FAULTS_FILE).exists():
        raise ValueError(f"{src}: already a faulted mission ({FAULTS_FILE}); fault the clean one")
    if dst.exists() and (not dst.is_dir() or any(dst.iterdir())):
        raise ValueError(f"{dst}: exists and is not an empty folder")


def _faulted_sensors(config: MissionConfig, p: FaultParams) -> tuple[str, str, dict[str, str]]:
    """(DVL name, depth name, name -> table file) of the faulted sensors; ValueError when one
    shares its table with another sensor, the IMU or the truth (it could not be faulted alone)."""
    dvl = _sensor(config, "dvl", p.dvl_sensor)
    depth = _sensor(config, "depth", p.depth_sensor)
    files = {dvl: config.sensors[dvl].file, depth: config.sensors[depth].file}
    others = {config.imu.file, config.truth.file} | {
        s.file for n, s in config.sensors.items() if n not in files
    }
    for name, file in files.items():
        if file in others or list(files.values()).count(file) > 1:
            raise ValueError(f"{file}: sensor {name!r} shares its table; cannot fault it alone")
    return dvl, depth, files


@dataclass(frozen=True)
class _DvlPlacement:
    """Where the DVL faults go in the source table (rows are the source's), and the spikes."""

    t_s: Array
    stuck_window: tuple[float, float]
    stuck_first: int
    stuck_rows: IntArray
    stuck_value: Array
    drop_window: tuple[float, float]
    drop_rows: IntArray
    navigation_readings: int
    spike_rows: IntArray
    spikes: Array


def _place_dvl(
    table: pd.DataFrame,
    windows: Mapping[FaultKind, tuple[float, float]],
    nav_start: float,
    span: tuple[float, float],
    p: FaultParams,
    rng: np.random.Generator,
) -> _DvlPlacement:
    """The DVL faults' rows: stuck and dropout windows first (the spikes must avoid them, and
    rows are counted before the dropout), then the spikes, drawn whether or not injected so
    the generator is in the same state after (docs/faults.md, "Placement and seeds")."""
    lo, hi = span
    t_dvl = table["t_s"].to_numpy(dtype=float)
    a, b = windows["dvl_stuck"]
    valid = _finite_rows(table, DVL_COLUMNS)
    if OUTLIER_COLUMN in table.columns:
        valid &= table[OUTLIER_COLUMN].to_numpy() == 0
    first = np.flatnonzero((t_dvl >= a) & (t_dvl < b) & valid)
    if first.size == 0:
        raise ValueError(f"no valid DVL reading in the stuck window [{a:.1f}, {b:.1f}) s")
    k0 = int(first[0])
    stuck_window = (a, b)
    # The window keeps its place (so it stays disjoint from the others) even when its first
    # reading is late (a NaN or an outlier of the simulator at the start).
    stuck_rows = np.flatnonzero((t_dvl > t_dvl[k0]) & (t_dvl < b))
    stuck_value = table.loc[k0, list(DVL_COLUMNS)].to_numpy(dtype=float)
    drop_window = windows["dvl_dropout"]
    drop_rows = np.flatnonzero((t_dvl >= drop_window[0]) & (t_dvl < drop_window[1]))

    n_nav = int(np.count_nonzero(t_dvl > nav_start))
    n_spikes = max(1, round(p.dvl_spike_fraction * n_nav))
    busy = in_intervals(t_dvl, np.array([stuck_window, drop_window]))
    candidates = np.flatnonzero((t_dvl >= lo) & (t_dvl < hi) & valid & ~busy)
    if candidates.size < n_spikes:
        raise ValueError(f"{n_spikes} DVL spikes wanted, {candidates.size} readings eligible")
    spike_rows = np.sort(rng.choice(candidates, size=n_spikes, replace=False))
    spikes = spike_vectors(rng, n_spikes, p.dvl_spike_range_m_s)
    return _DvlPlacement(
        t_s=t_dvl,
        stuck_window=stuck_window,
        stuck_first=k0,
        stuck_rows=stuck_rows,
        stuck_value=stuck_value,
        drop_window=drop_window,
        drop_rows=drop_rows,
        navigation_readings=n_nav,
        spike_rows=spike_rows,
        spikes=spikes,
    )


def _fault_dvl(
    table: pd.DataFrame,
    sensor: str,
    file: str,
    kinds: Sequence[FaultKind],
    placed: _DvlPlacement,
    p: FaultParams,
) -> tuple[pd.DataFrame, dict[FaultKind, Injected]]:
    """Apply the DVL faults of ``kinds`` to ``table`` (changed in place; a dropout returns a
    new table without its rows): the faulted table and the faults in ledger rows
    (docs/faults.md)."""
    stuck, spiked, t_dvl, k0 = placed.stuck_rows, placed.spike_rows, placed.t_s, placed.stuck_first
    if "dvl_stuck" in kinds:
        _set(table, DVL_COLUMNS, stuck, np.tile(placed.stuck_value, (stuck.size, 1)))
        _flag(table, stuck)
    if "dvl_spikes" in kinds:
        values = table[list(DVL_COLUMNS)].to_numpy(dtype=float)[spiked]
        _set(table, DVL_COLUMNS, spiked, values + placed.spikes)
        _flag(table, spiked)
    removed = placed.drop_rows if "dvl_dropout" in kinds else np.zeros(0, dtype=np.int64)
    # Source row -> row of the faulted table (ledger rows), once the dropout is taken out.
    new_row = np.cumsum(~np.isin(np.arange(len(table)), removed)) - 1
    if removed.size:
        table = table.drop(index=table.index[removed]).reset_index(drop=True)

    faults: dict[FaultKind, Injected] = {}
    if "dvl_stuck" in kinds:
        faults["dvl_stuck"] = Injected(
            "dvl_stuck", sensor, file, placed.stuck_window, _ledger_rows(new_row, stuck),
            detail={"stuck_row": int(new_row[k0]), "stuck_from_s": float(t_dvl[k0]),
                    "value_m_s": placed.stuck_value.tolist()},
        )  # fmt: skip
    if "dvl_dropout" in kinds:
        times = t_dvl[removed]
        faults["dvl_dropout"] = Injected(
            "dvl_dropout", sensor, file, placed.drop_window, (), tuple(int(r) for r in removed),
            detail={"removed": int(removed.size),
                    "removed_t_s": [float(times[0]), float(times[-1])] if times.size else []},
        )  # fmt: skip
    if "dvl_spikes" in kinds:
        faults["dvl_spikes"] = Injected(
            "dvl_spikes", sensor, file, None, _ledger_rows(new_row, spiked),
            detail={"spikes_m_s": placed.spikes.tolist(), "fraction": p.dvl_spike_fraction,
                    "navigation_readings": placed.navigation_readings},
        )  # fmt: skip
    return table, faults


def _ledger_rows(new_row: IntArray, rows: IntArray) -> tuple[int, ...]:
    """Source ``rows`` as rows of the faulted table (``new_row``: source row -> faulted row)."""
    return tuple(int(r) for r in new_row[rows])


def _fault_depth(
    table: pd.DataFrame,
    sensor: str,
    file: str,
    kinds: Sequence[FaultKind],
    windows: Mapping[FaultKind, tuple[float, float]],
    hi: float,
    p: FaultParams,
) -> dict[FaultKind, Injected]:
    """Apply the depth faults of ``kinds`` to ``table`` in place (the spike, then the offset);
    ``hi``: the span's end, which the spike's reading must come before (docs/faults.md)."""
    t_depth = table["t_s"].to_numpy(dtype=float)
    faults: dict[FaultKind, Injected] = {}
    if "depth_spike" in kinds:
        a, _ = windows["depth_spike"]
        rows = np.flatnonzero((t_depth >= a) & _finite_rows(table, [DEPTH_COLUMN]))[:1]
        if rows.size == 0 or t_depth[rows[0]] >= hi:
            raise ValueError(f"no depth reading after {a:.1f} s for the spike")
        _offset_depth(table, rows, p.depth_spike_m)
        t = float(t_depth[rows[0]])
        faults["depth_spike"] = Injected(
            "depth_spike", sensor, file, (t, t), (int(rows[0]),),
            detail={"offset_m": p.depth_spike_m},
        )  # fmt: skip
    if "depth_offset" in kinds:
        a, b = windows["depth_offset"]
        rows = np.flatnonzero((t_depth >= a) & (t_depth < b))
        if rows.size == 0:
            raise ValueError(f"no depth reading in the offset window [{a:.1f}, {b:.1f}) s")
        _offset_depth(table, rows, p.depth_offset_m)
        faults["depth_offset"] = Injected(
            "depth_offset", sensor, file, (a, b), tuple(int(r) for r in rows),
            detail={"offset_m": p.depth_offset_m},
        )  # fmt: skip
    return faults


def _offset_depth(table: pd.DataFrame, rows: IntArray, offset_m: float) -> None:
    """Add ``offset_m`` to the depth readings at ``rows`` and flag them as outliers."""
    z = table[DEPTH_COLUMN].to_numpy(dtype=float)[rows, None]
    _set(table, [DEPTH_COLUMN], rows, z + offset_m)
    _flag(table, rows)


def _seed_of(rng: np.random.Generator) -> Any:
    """The generator's seed entropy when it was made from a seed (provenance), else None."""
    entropy = getattr(rng.bit_generator.seed_seq, "entropy", None)
    if isinstance(entropy, int | list | tuple):
        return entropy if isinstance(entropy, int) else [int(v) for v in entropy]
    return None


def _write_copy(src: Path, dst: Path, changed: Mapping[str, pd.DataFrame], log: FaultLog) -> None:
    """Copy ``src`` to ``dst`` with the ``changed`` tables and ``faults.json``, atomically
    (a temporary sibling renamed into place)."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(f".{dst.name}.tmp-{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    skip = {str(Path(f)) for f in changed}

    def ignore(folder: str, names: list[str]) -> set[str]:
        rel = Path(folder).relative_to(src)
        return {n for n in names if str(rel / n) in skip}

    try:
        shutil.copytree(src, tmp, ignore=ignore)
        for file, table in changed.items():
            write_table(table, tmp / file)
        text = json.dumps(log.to_json(), indent=1) + "\n"
        (tmp / FAULTS_FILE).write_text(text, encoding="utf-8")
        if dst.exists():
            dst.rmdir()  # checked empty by inject
        os.replace(tmp, dst)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
