"""Importer of the Snapir AUV ("A-KIT") recordings into mission folders (docs/akit.md).

The recordings (Cohen & Klein 2025, repository ``ansfl/A-KIT``; the data README in
``shared/data/akit-snapir-auv``) are 400-s segments of three CSV files each:
``IMU_trajectoryN.csv`` (iXblue Phins Subsea, 100 Hz), ``DVL_trajectoryN.csv`` (Teledyne RDI
Workhorse, 1 Hz, body-frame bottom-track velocity) and ``GT_trajectoryN.csv`` (iXblue Delph
post-processed reference, 1 Hz). The raw files need five corrections (the README, all checked
here against the data itself) and a sixth the data show:

1. index time: IMU ``t = 0.01 j``, DVL and reference ``t = 1.0 k`` (the ``Time [s]`` columns are
   synthetic, 400/39999 s apart, and are ignored);
2. the IMU y axis (``ACC Y``, ``GYRO Y``) is negated to give the FRD body frame of the
   reference and the DVL;
3. reference sample k belongs to IMU time ``k + L``: L is **estimated** from the data by
   :func:`estimate_reference_offset` (the README's table for segments 1-9 is only a check);
4. DVL sample k belongs to IMU time ``k + 1.0`` s (checked by :func:`estimate_dvl_offset`);
5. the DVL sits at ``[-1.84, -0.05, +0.10]`` m FRD from the reference point (the engine's DVL
   model adds ω × l_b for the lever arm of ``mission.toml``);
6. the IMU senses the motion of a point ``r ≈ [-1.77, -0.01, -0.115]`` m FRD from the reference
   point, not of the reference point (the README assumes r = 0): estimated per segment by
   :func:`estimate_imu_lever_arm`. The mission navigates the IMU point: truth and initial state
   are the reference moved there, the DVL lever arm is ``[-1.84, -0.05, 0.10] - r``.

:func:`import_segment` writes a mission folder (docs/data-format.md) with the IMU as rates, the
DVL (optionally with injected faults, :func:`inject_dvl_faults`), a **semi-synthetic** depth
stream (the reference depth plus seeded white noise: the recordings have no depth sensor), the
time-shifted reference as truth, an initial state from the reference, and ``import.json``
recording the estimated offsets, the README's values and every correction and repair.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import cumulative_trapezoid
from scipy.spatial.transform import Rotation

from adaptnav.analysis.dvl_fit import reference_consistency
from adaptnav.analysis.evaluate import ned_errors
from adaptnav.core import attitude, earth
from adaptnav.engine import propagation
from adaptnav.importers.timing import minimise_lag
from adaptnav.importers.tracks import TrackError, inconsistent_fixes
from adaptnav.mission.config import MissionConfig, MissionError, parse_config
from adaptnav.mission.loader import write_mission
from adaptnav.mission.tables import Journal, Repair, Table, numeric, read_table
from adaptnav.models import strapdown
from adaptnav.models.errorstate import N_NOISE, N_STATES
from adaptnav.models.strapdown import NOM_ATT, NOM_VEL, NavState
from adaptnav.sim.faults import spike_vectors

log = logging.getLogger("adaptnav.importers.akit")

Array = NDArray[np.float64]

__all__ = [
    "DVL_LEVER_ARM_M",
    "DVL_SIGMA_M_S",
    "README_DVL_OFFSET_S",
    "README_REFERENCE_OFFSET_S",
    "AkitError",
    "RawSegment",
    "dvl_residuals",
    "estimate_dvl_offset",
    "estimate_imu_lever_arm",
    "estimate_reference_offset",
    "free_inertial_error",
    "import_segment",
    "inject_dvl_faults",
    "read_segment",
    "reference_at",
    "reference_increments",
    "reference_state",
    "segments_in",
]

IMU_PERIOD_S = 0.01
"""IMU sample spacing (s): 100 Hz (correction 1)."""
DVL_PERIOD_S = 1.0
"""DVL sample spacing (s) (correction 1)."""
REF_PERIOD_S = 1.0
"""Reference sample spacing (s) (correction 1)."""
README_REFERENCE_OFFSET_S: dict[int, float] = {
    1: -0.40, 2: -0.45, 3: -0.45, 4: -0.40, 5: +0.50, 6: +0.45, 7: -0.45, 8: -0.40, 9: -0.40,
}  # fmt: skip
"""The data README's table of L (s) for segments 1-9 (a check; L is estimated from the data)."""
README_DVL_OFFSET_S = 1.0
"""The data README's DVL time offset (s), "about 1.0 s, all trajectories" (correction 4)."""
README_RECORDED_ON = "2022-06-08"
"""The day of the recording (data README: "off Haifa on 2022-06-08"). The README gives no time of
day and no segment's start, and the files' ``Time [s]`` columns are synthetic (0-400 s), so a
segment has no absolute time: import.json's ``time`` says so (no ``stamp_origin_ns``), and an
export to a ROS 2 bag warns that its stamps are mission seconds (docs/rosbag.md, 'Export')."""
TIME_NOTE = (
    f"recorded on {README_RECORDED_ON} (data README), no time of day or segment start given: "
    "no absolute time"
)
"""import.json's ``time.note``, quoted by the ROS 2 export's warning."""
DVL_LEVER_ARM_M: tuple[float, float, float] = (-1.84, -0.05, 0.10)
"""DVL position relative to the reference point, body FRD (m) (data README, item 5); the
mission's lever arm is from the IMU, this minus the IMU's position (correction 6)."""
DVL_SIGMA_M_S = 0.02
"""Nominal DVL σ per axis (m/s): the Workhorse Navigator specification quoted by the README;
the README's measured DVL-minus-reference residuals are 0.016 / 0.024 / 0.017 m/s (this
importer measures 0.006-0.014 m/s per axis on segments 1-8)."""
DEPTH_SIGMA_M = 0.05
"""σ (m) of the white noise added to the reference depth for the semi-synthetic depth sensor."""
GT_SPAN_MARGIN_S = 1e-9
"""Times this close outside the reference span still count as inside (float rounding)."""

IMU_COLUMNS = (
    "GYRO X [rad/s]", "GYRO Y [rad/s]", "GYRO Z [rad/s]",
    "ACC X [m/s^2]", "ACC Y [m/s^2]", "ACC Z [m/s^2]",
)  # fmt: skip
DVL_COLUMNS = ("DVL X [m/s]", "DVL Y [m/s]", "DVL Z [m/s]")
GT_COLUMNS = (
    "Latitude [rad]", "Longitude [rad]", "Altitude [m]",
    "V North [m/s]", "V East [m/s]", "V Down [m/s]",
    "Roll [rad]", "Pitch [rad]", "Yaw [rad]",
)  # fmt: skip

# IMU noise of the Phins Subsea (docs/akit.md, "Vehicle configuration"). Datasheet-class
# figures for the iXblue Phins Subsea as quoted in the project brief (gyro bias stability
# < 0.01 deg/h, accelerometer bias < 50 µg; the datasheet is not in this repository); the
# white-noise levels are assumptions of the order quoted for this FOG class, the ARW raised for
# the recording's 1e-4 rad/s rate rounding (σ = q/√12 at 100 Hz is an ARW of 0.0099 deg/√h,
# four times the FOG's own 0.0025 deg/√h). τ = 1 h is assumed.
PHINS_NOISE: dict[str, tuple[float | str, str]] = {
    "arw": (0.0102, "deg/sqrt(h)"),  # √(0.0025² + 0.0099²): FOG (assumed) + quantisation
    "vrw": (20.0, "ug/sqrt(Hz)"),  # assumed, middle of 10-30 µg/√Hz
    "gyro_bias_sigma": (0.01, "deg/h"),  # datasheet class: bias stability < 0.01 deg/h
    "gyro_bias_tau": (1.0, "h"),  # assumed
    "accel_bias_sigma": (50.0, "ug"),  # datasheet class: bias < 50 µg
    "accel_bias_tau": (1.0, "h"),  # assumed
}
PHINS_INITIAL_BIAS_SIGMA: dict[str, tuple[float, str]] = {
    "gyro": (0.05, "deg/h"),  # assumed: no alignment in the segments, 5× the in-run figure
    "accel": (100.0, "ug"),  # assumed: 2× the datasheet bias
}
INITIAL_SIGMA_POSITION_M = 1.0
INITIAL_SIGMA_VELOCITY_M_S = 0.05
INITIAL_SIGMA_ATTITUDE_DEG = (0.05, 0.05, 0.1)
"""Initial σ's (assumed): the reference's own error is of centimetres / hundredths of a degree;
these also cover carrying it to the first IMU sample at the navigation start."""

_SEGMENT_RE = re.compile(r"^IMU_trajectory(\d+)\.csv$")


class AkitError(MissionError):
    """Bad A-KIT input: a missing file or column, a malformed line, an unusable value.

    A :class:`~adaptnav.mission.MissionError` (``file``, ``line``, ``field``), so callers that
    handle mission errors handle these too.
    """


# --- reading ------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RawSegment:
    """One segment as read, with index times (correction 1) and, unless ``y_flipped`` is
    False, the IMU y axis negated (correction 2); no time offset applied yet.

    Attributes:
        trajectory: the segment number N.
        source: the folder of the CSV files.
        imu_t: IMU index time ``0.01 j`` (N,); gyro (N, 3) rad/s and accel (N, 3) m/s², FRD.
        dvl_k: DVL index time ``k`` (M,), before the DVL offset; dvl_v (M, 3) m/s.
        ref_k: reference index time ``k`` (K,), before L; ref_pos (K, 3) lat, lon (rad), h (m);
            ref_vel (K, 3) NED m/s; ref_rpy (K, 3) ZYX roll, pitch, yaw (rad).
        repairs: what was changed while reading (truncated last lines dropped).
        y_flipped: whether correction 2 was applied.
    """

    trajectory: int
    source: Path
    imu_t: Array
    gyro: Array
    accel: Array
    dvl_k: Array
    dvl_v: Array
    ref_k: Array
    ref_pos: Array
    ref_vel: Array
    ref_rpy: Array
    repairs: tuple[Repair, ...]
    y_flipped: bool = True

    def reference_rotation(self) -> Rotation:
        """C_nb of the reference samples (scipy Rotation, ZYX Euler)."""
        return self._rotation

    @cached_property
    def _rotation(self) -> Rotation:
        return Rotation.from_euler("ZYX", self.ref_rpy[:, ::-1])

    @cached_property
    def rotation_steps(self) -> Array:
        """Log(C_nb,kᵀ C_nb,k+1) (K-1, 3): the rotation from each sample to the next."""
        rot = self._rotation
        return np.asarray((rot[:-1].inv() * rot[1:]).as_rotvec(), dtype=float)

    @cached_property
    def gyro_integral(self) -> Array:
        """Θ(t_j) = ∫ ω_ib_b dt from the first sample (N, 3), cumulative trapezoid (rad)."""
        return np.asarray(
            cumulative_trapezoid(self.gyro, self.imu_t, axis=0, initial=0.0), dtype=float
        )

    def gyro_at(self, t: Array) -> Array:
        """Gyro rate (rad/s, FRD) linearly interpolated at times ``t`` (n, 3)."""
        return np.stack([np.interp(t, self.imu_t, self.gyro[:, i]) for i in range(3)], axis=-1)


def segments_in(src_dir: str | Path) -> list[int]:
    """Segment numbers N with an ``IMU_trajectoryN.csv`` in ``src_dir`` (sorted)."""
    root = Path(src_dir)
    if not root.is_dir():
        return []
    found = (_SEGMENT_RE.match(p.name) for p in root.iterdir())
    return sorted(int(m.group(1)) for m in found if m is not None)


def _column(table: Table, name: str) -> Array:
    """A column found by header name (surrounding spaces ignored; case-insensitive fallback)."""
    names = [str(c) for c in table.df.columns]
    folded = {n.casefold(): n for n in names}
    found = name if name in names else folded.get(name.casefold())
    if found is not None:
        try:
            return numeric(table, found)
        except MissionError as exc:  # a cell that is not a number: same message, our class
            raise AkitError(str(exc), file=exc.file, line=exc.line, field=exc.field) from None
    raise AkitError(
        f"{table.label}: missing column {name!r}; found {names}", file=table.label, field=name
    )


def _columns(table: Table, names: Sequence[str], finite: bool) -> Array:
    values = np.column_stack([_column(table, n) for n in names])
    if finite:
        bad = ~np.isfinite(values)
        if bad.any():
            r, c = (int(i) for i in np.argwhere(bad)[0])
            raise AkitError(
                f"{table.where(r)}, {names[c]}: value {float(values[r, c])!r} is not a finite "
                "number",
                file=table.label,
                line=int(table.lines[r]),
                field=names[c],
            )
    return values


def _check_reference_track(table: Table, ref: Array) -> None:
    """A reference position off the line through its neighbours by more than a vehicle can
    move (:func:`~.tracks.inconsistent_fixes`) is an AkitError naming its line and the
    coordinate most off: a damaged line. It cannot be left out, since the rows are timed by
    their index (correction 1)."""
    t = REF_PERIOD_S * np.arange(ref.shape[0], dtype=float)
    lat, lon, h = ref[:, 0], ref[:, 1], ref[:, 2]
    try:
        off = inconsistent_fixes(t, earth.geodetic_to_ecef(lat, lon, h), np.ones(t.size, bool))
    except TrackError as exc:
        raise AkitError(f"{table.label}: reference positions: {exc}", file=table.label) from None
    if not off.any():
        return
    r = int(np.flatnonzero(off)[0])
    a, c = (r + 1, r + 2) if r == 0 else (r - 2, r - 1) if r == t.size - 1 else (r - 1, r + 1)
    w = (t[r] - t[a]) / (t[c] - t[a])
    miss = ref[r, :3] - ref[a, :3] - w * (ref[c, :3] - ref[a, :3])
    rm, rn = earth.meridian_radius(lat[r]), earth.transverse_radius(lat[r])
    metres = np.abs(miss) * np.array([rm + h[r], (rn + h[r]) * math.cos(lat[r]), 1.0])
    k = int(np.argmax(metres))
    raise AkitError(
        f"{table.where(r)}, {GT_COLUMNS[k]}: the reference position is {metres[k]:.4g} m off "
        f"the line through its neighbours (lines {int(table.lines[a])} and "
        f"{int(table.lines[c])}), more than a vehicle moves (a damaged line?)",
        file=table.label,
        line=int(table.lines[r]),
        field=GT_COLUMNS[k],
    )


TIME_COLUMN = "Time [s]"
"""The recordings' time column: synthetic, evenly spaced from 0 to 400 s (correction 1), so
not used as time, but a row lost, repeated or moved shows in it (:func:`_check_rows`)."""
TIME_STEP_TOLERANCE = 0.01
"""How far (a fraction of the median step) a step of ``Time [s]`` may differ from the median."""


DVL_FIT_LIMIT_M_S = 20.0
"""DVL readings beyond this (m/s, any axis) are left out of the offset fit (an AUV moves at a
few m/s; the mission keeps them, for the run's plausibility limits to drop)."""
IMU_LIMITS = (20.0, 200.0)
"""|gyro| (rad/s) and |acc| (m/s²) beyond these are no motion of an AUV but a damaged line or a
unit slip: an error naming the line (the Phins' own ranges are smaller)."""


MAX_GYRO_MISFIT = 0.1
"""The gyro's rotation over each reference second may differ from the reference's by at most
this fraction of it (RMS) at the fitted L (segments 1-9: 0.0003-0.0013): beyond, the gyro is in
another unit, or an axis or a sign is wrong (:func:`estimate_reference_offset`)."""
ACC_MEDIAN_RANGE = (7.0, 13.0)
"""The median |acc| (m/s²) of a segment must lie in this range: an AUV senses gravity, 9.8
(segments 1-9: 9.795-9.799); an accelerometer in g reads about 1."""
MAX_DVL_MISFIT_M_S = 0.5
"""The DVL's RMS misfit to the reference at its fitted offset (m/s, per axis) must be below
this (segments 1-9: 0.007-0.035): beyond, the DVL is in another unit (knots, mm/s) or axes."""


def _check_imu_range(table: Table, w_f: Array) -> None:
    """AkitError naming the first IMU line and column beyond :data:`IMU_LIMITS`."""
    limit = np.repeat(np.asarray(IMU_LIMITS), 3)
    bad = np.abs(w_f) > limit
    if bad.any():
        r, c = (int(i) for i in np.argwhere(bad)[0])
        raise AkitError(
            f"{table.where(r)}, {IMU_COLUMNS[c]}: {float(w_f[r, c])!r} is beyond "
            f"±{limit[c]:g}, no motion of an AUV (a damaged line or another unit?)",
            file=table.label,
            line=int(table.lines[r]),
            field=IMU_COLUMNS[c],
        )


def _check_rows(table: Table) -> None:
    """The rows must be the recording's, all of them and in order: ``Time [s]`` (when the file
    has it) starts at 0 and rises by one even step. The rows are timed by their index
    (correction 1), so a row lost, repeated or moved would shift every later one in time,
    silently (up to 0.4.4: two reference rows lost gave a mission whose offsets and result
    were wrong, 17× the error, exit 0). AkitError naming the first line out of step."""
    names = {str(c).strip().casefold(): str(c) for c in table.df.columns}
    if TIME_COLUMN.casefold() not in names:
        return
    t = _column(table, names[TIME_COLUMN.casefold()])
    steps = np.diff(t)
    step = float(np.median(steps)) if steps.size else 0.0
    off = np.flatnonzero(~(np.abs(steps - step) <= TIME_STEP_TOLERANCE * step))
    if not step > 0.0:  # NaN, constant or falling: no even step to judge the rows by
        r = int(np.flatnonzero(~(steps > 0.0))[0]) + 1 if steps.size else 0
        why = (
            f"{TIME_COLUMN} does not rise: its median step is {step!r} s, and this line's "
            f"{t[r]!r} is not after the one before (not the recording's time, or rows reversed?)"
        )
    elif not (math.isfinite(t[0]) and abs(t[0]) <= TIME_STEP_TOLERANCE * step):
        r, why = 0, f"the first row's time is {t[0]!r}, not 0 (rows missing at the start?)"
    elif off.size:
        r = int(off[0]) + 1
        why = (
            f"{TIME_COLUMN} {t[r]!r} is {t[r] - t[r - 1]:.6g} s after the line before, where "
            f"every other step is {step:.6g} s (a row missing, repeated or out of order?)"
        )
    else:
        return
    raise AkitError(
        f"{table.where(r)}, {TIME_COLUMN}: {why}; the rows are timed by their index "
        "(docs/akit.md, correction 1), so it would shift every later one",
        file=table.label,
        line=int(table.lines[r]),
        field=TIME_COLUMN,
    )


def _read(path: Path, journal: Journal) -> Table:
    if not path.is_file():
        raise AkitError(f"{path.name}: file not found in {path.parent}", file=str(path))
    try:
        table = read_table(path, path.name, journal)
    except MissionError as exc:  # the same message, as this importer's error
        raise AkitError(str(exc), file=exc.file, line=exc.line, field=exc.field) from None
    if len(table) < 2:
        raise AkitError(f"{path.name}: {len(table)} data row(s), at least 2 needed", file=path.name)
    _check_rows(table)
    return table


def read_segment(src_dir: str | Path, trajectory: int, *, flip_y: bool = True) -> RawSegment:
    """Read ``IMU/DVL/GT_trajectoryN.csv`` of segment ``trajectory`` from ``src_dir``.

    Columns are found by header name, in any order. A last line with fewer fields than the
    header (a truncated file) is dropped and recorded (``RawSegment.repairs``, logged on
    ``adaptnav.mission`` naming file and line); any other malformed line, a missing column or a
    non-numeric cell raises :class:`AkitError` naming file, line and column. IMU and reference
    values must be finite; a non-finite DVL reading is kept (the engine drops it, logged).

    Applies corrections 1 (index time) and, with ``flip_y``, 2 (IMU y negated).
    """
    root = Path(src_dir)
    if not root.is_dir():
        raise AkitError(f"{root}: not a folder", file=str(root))
    n = int(trajectory)
    if not (root / f"IMU_trajectory{n}.csv").is_file():
        present = segments_in(root)
        raise AkitError(
            f"{root}: no IMU_trajectory{n}.csv (segments present: {present or 'none'})",
            file=f"IMU_trajectory{n}.csv",
        )
    journal = Journal()
    imu = _read(root / f"IMU_trajectory{n}.csv", journal)
    dvl = _read(root / f"DVL_trajectory{n}.csv", journal)
    gt = _read(root / f"GT_trajectory{n}.csv", journal)
    w_f = _columns(imu, IMU_COLUMNS, finite=True)
    _check_imu_range(imu, w_f)
    acc = float(np.median(np.linalg.norm(w_f[:, 3:], axis=1)))
    if not ACC_MEDIAN_RANGE[0] <= acc <= ACC_MEDIAN_RANGE[1]:
        raise AkitError(
            f"{imu.label}: the accelerometer's median |acc| is {acc:.4g}, where an AUV senses "
            "gravity, about 9.8 m/s² (ACC X/Y/Z in g, not m/s^2?)",
            file=imu.label,
            field=IMU_COLUMNS[3],
        )
    gyro, accel = w_f[:, :3].copy(), w_f[:, 3:].copy()
    if flip_y:
        # Correction 2: the recorded y axis points left; FRD needs it to the right. Negating
        # one axis of each triad turns the left-handed recorded frame into FRD.
        gyro[:, 1] *= -1.0
        accel[:, 1] *= -1.0
    ref = _columns(gt, GT_COLUMNS, finite=True)
    _check_reference_track(gt, ref)
    return RawSegment(
        trajectory=n,
        source=root,
        imu_t=IMU_PERIOD_S * np.arange(len(imu), dtype=float),
        gyro=gyro,
        accel=accel,
        dvl_k=DVL_PERIOD_S * np.arange(len(dvl), dtype=float),
        dvl_v=_columns(dvl, DVL_COLUMNS, finite=False),
        ref_k=REF_PERIOD_S * np.arange(len(gt), dtype=float),
        ref_pos=ref[:, 0:3],
        ref_vel=ref[:, 3:6],
        ref_rpy=ref[:, 6:9],
        repairs=tuple(journal.repairs),
        y_flipped=flip_y,
    )


# --- the reference at any time ------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ReferenceSample:
    """The reference interpolated at times t: position (n, 3) lat, lon, h; NED velocity (n, 3);
    attitude C_nb (scipy Rotation of n) and its ZYX Euler angles (n, 3)."""

    t: Array
    pos: Array
    vel: Array
    rotation: Rotation

    @property
    def rpy(self) -> Array:
        return np.asarray(self.rotation.as_euler("ZYX")[:, ::-1], dtype=float)

    def moved(self, r_b: ArrayLike, omega_b: Array) -> ReferenceSample:
        """The same rigid body's state at the point ``r_b`` (body FRD, m, from this point),
        with ``omega_b`` (n, 3) the body rate at the times (rigid-body kinematics, the same
        lever-arm terms as the DVL and depth models of :mod:`adaptnav.sensors`):

            r_e' = r_e + C_ne(lat, lon)ᵀ C_nb r_b      (exact, through ECEF)
            v_n' = v_n + C_nb (ω_b × r_b)

        (ω_ib_b stands in for ω_eb_b: the earth rate adds < 2e-4 m/s at 2 m.)
        """
        r = np.tile(np.asarray(r_b, dtype=float), (self.vel.shape[0], 1))
        d_n = self.rotation.apply(r).reshape(-1, 3)
        lat, lon, h = self.pos[:, 0], self.pos[:, 1], self.pos[:, 2]
        r_e = earth.geodetic_to_ecef(lat, lon, h) + np.einsum(
            "nji,nj->ni", earth.C_ne(lat, lon), d_n
        )
        lat2, lon2, h2 = earth.ecef_to_geodetic(r_e)
        vel = self.vel + self.rotation.apply(np.cross(omega_b, r)).reshape(-1, 3)
        return ReferenceSample(self.t, np.column_stack([lat2, lon2, h2]), vel, self.rotation)


def reference_at(segment: RawSegment, reference_offset_s: float, t: Array) -> ReferenceSample:
    """The reference (sample k at ``k + L``) at times ``t`` inside its span: position and
    velocity linearly interpolated, attitude by spherical linear interpolation (slerp)."""
    tr = segment.ref_k + reference_offset_s
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    if tt.size and (tt.min() < tr[0] - GT_SPAN_MARGIN_S or tt.max() > tr[-1] + GT_SPAN_MARGIN_S):
        raise ValueError(f"times outside the reference span [{tr[0]:.3f}, {tr[-1]:.3f}] s")
    tt = np.clip(tt, tr[0], tr[-1])
    pos = np.stack([np.interp(tt, tr, segment.ref_pos[:, i]) for i in range(3)], axis=-1)
    vel = np.stack([np.interp(tt, tr, segment.ref_vel[:, i]) for i in range(3)], axis=-1)
    # Slerp: C_nb,i Exp(f Log(C_nb,iᵀ C_nb,i+1)) at the fraction f of interval i.
    i = np.clip(np.searchsorted(tr, tt, side="right") - 1, 0, tr.size - 2)
    f = ((tt - tr[i]) / (tr[i + 1] - tr[i]))[:, None]
    steps = segment.rotation_steps
    rot = segment.reference_rotation()[i] * Rotation.from_rotvec(f * steps[i])
    return ReferenceSample(tt, pos, vel, rot)


def reference_state(
    segment: RawSegment, reference_offset_s: float, index: int | NDArray[np.int64]
) -> ReferenceSample:
    """The reference state of sample(s) ``index`` carried to the first IMU sample at or after
    its time ``t_k = index + L`` (less than one IMU period later): a navigation start.

    Position and velocity are interpolated linearly over that gap (it is under 0.01 s); the
    attitude is carried by the gyros, ``C_nb(t0) = C_nb,k Exp(Θ(t0) - Θ(t_k))`` with Θ the
    cumulative trapezoid integral of ω_ib_b (first order over < 0.01 s; the earth rate adds
    < 1e-6 rad). Interpolating the attitude between 1-s samples (slerp) instead is off by
    degrees where the vehicle rolls at 30 °/s, as segment 9 does at its start.
    """
    idx = np.atleast_1d(np.asarray(index, dtype=np.int64))
    t_k = segment.ref_k[idx] + reference_offset_s
    j = np.searchsorted(segment.imu_t, t_k - 1e-9, side="left")
    if np.any(j >= segment.imu_t.size):
        raise ValueError(f"reference sample(s) {idx[j >= segment.imu_t.size]} after the IMU data")
    t0 = segment.imu_t[j]
    ref = reference_at(segment, reference_offset_s, t0)
    theta = segment.gyro_integral
    d = np.column_stack(
        [
            np.interp(t0, segment.imu_t, theta[:, a]) - np.interp(t_k, segment.imu_t, theta[:, a])
            for a in range(3)
        ]
    )
    rot = segment.reference_rotation()[idx] * Rotation.from_rotvec(d)
    return ReferenceSample(ref.t, ref.pos, ref.vel, rot)


# --- offsets ------------------------------------------------------------------------------------


def reference_increments(segment: RawSegment) -> Array:
    """Body-frame rotation vectors (K-1, 3) between consecutive reference samples, as the
    gyros sense them: ``φ_k = Log(C_nb,kᵀ Exp(ω_in_n T) C_nb,k+1)``.

    The navigation frame itself turns at ``ω_in_n = ω_ie_n + ω_en_n`` (earth and transport
    rate, Groves 2.123 and 5.44, at the mean of the two samples), which the gyros sense but the
    reference attitude C_nb does not show; ``Exp(ω_in_n T)`` puts it back (T = 1 s).
    """
    rot = segment.reference_rotation()
    w_in = np.array(
        [
            earth.earth_rate_n(lat) + earth.transport_rate_n(lat, h, v)
            for (lat, _, h), v in zip(segment.ref_pos, segment.ref_vel, strict=True)
        ]
    )
    turn = Rotation.from_rotvec(0.5 * (w_in[:-1] + w_in[1:]) * REF_PERIOD_S)
    return np.asarray((rot[:-1].inv() * turn * rot[1:]).as_rotvec(), dtype=float)


def estimate_reference_offset(
    segment: RawSegment, *, max_lag_s: float = 2.0, step_s: float = 0.01
) -> float:
    """L (s) such that reference sample k belongs to IMU time ``k + L`` (correction 3).

    Matches the reference's attitude increments (:func:`reference_increments`) with the gyro
    integrated over ``[k + L, k + 1 + L]`` for candidate lags L. The gyro's rotation vector
    over ``[a, b]`` is taken to second order from Bortz's equation ``φ̇ = ω + ½ φ × ω + ...``
    (Savage 1998, Strapdown Inertial Navigation Integration Algorithm Design, part 1, eq. 12):

        φ ≈ Θ(b) - Θ(a) + ½ [K(b) - K(a) - Θ(a) × (Θ(b) - Θ(a))],

    with the cumulative trapezoid integrals ``Θ(t) = ∫₀ᵗ ω dt`` and ``K(t) = ∫₀ᵗ Θ × ω dt``
    (linearly interpolated between IMU samples). The second-order (coning) term matters in the sharp
    turns (up to 17 °/s with 8° of roll), where it is up to 0.6° in 1 s. The mean squared difference
    is minimised over ``[-max_lag_s, max_lag_s]``: a coarse grid, then a parabola fitted to the cost
    on a grid of ``step_s`` within ± 0.05 s (:func:`~adaptnav.importers.timing.minimise_lag`).
    Raises ValueError if the minimum lies at the edge of the span (L not identifiable).
    """
    t_imu = segment.imu_t
    theta = segment.gyro_integral
    coning = cumulative_trapezoid(np.cross(theta, segment.gyro), t_imu, axis=0, initial=0.0)
    increments = reference_increments(segment)
    k = segment.ref_k[:-1]

    def at(values: Array, t: Array) -> Array:
        return np.stack([np.interp(t, t_imu, values[:, a]) for a in range(3)], axis=-1)

    def misfit(lag: float) -> tuple[Array, Array]:
        """(gyro's φ - reference's, the reference's) over the seconds inside the IMU span."""
        ta, tb = k + lag, k + REF_PERIOD_S + lag
        ok = (ta >= t_imu[0]) & (tb <= t_imu[-1])
        th_a, th_b = at(theta, ta[ok]), at(theta, tb[ok])
        d = th_b - th_a
        phi = d + 0.5 * (at(coning, tb[ok]) - at(coning, ta[ok]) - np.cross(th_a, d))
        return phi - increments[ok], increments[ok]

    def cost(lag: float) -> float:
        r, _ = misfit(lag)
        return float(np.mean(np.sum(r**2, axis=1))) if r.shape[0] >= 10 else math.inf

    n = segment.trajectory
    what = f"IMU_trajectory{n}.csv against GT_trajectory{n}.csv, the reference offset L"
    lag = minimise_lag(cost, -max_lag_s, max_lag_s, step_s, 0.05, what)
    r, inc = misfit(lag)
    ratio = math.sqrt(float(np.sum(r**2)) / max(float(np.sum(inc**2)), 1e-300))
    if not ratio <= MAX_GYRO_MISFIT:
        raise AkitError(
            f"{what}: at its best the gyro's rotation over each second differs from the "
            f"reference's by {ratio:.0%} of it (0.03-0.13 % on segments 1-9): a gyro unit, an "
            "axis or a sign wrong?",
            file=f"IMU_trajectory{n}.csv",
        )
    return lag


def dvl_residuals(
    segment: RawSegment,
    reference_offset_s: float,
    dvl_offset_s: float,
    lever_arm_m: Sequence[float] = DVL_LEVER_ARM_M,
) -> tuple[Array, Array]:
    """(t, r): DVL reading minus the reference's prediction of it, at the DVL times
    ``t = k + dvl_offset_s`` inside the reference and IMU spans.

    ``r = z - (C_nbᵀ v_n + ω_ib_b × l_b)`` (the engine's DVL model, adaptnav.sensors.dvl) with
    the reference at ``k + L`` interpolated (:func:`reference_at`) and the gyro interpolated at
    the DVL time. Non-finite readings and those beyond :data:`DVL_FIT_LIMIT_M_S` are left out
    (a spike the run's plausibility limits drop; up to 0.4.4 one reading of 1e300 made the
    offset fit fail and the import with it).
    """
    tr = segment.ref_k + reference_offset_s
    t = segment.dvl_k + dvl_offset_s
    ok = (
        (t >= max(tr[0], segment.imu_t[0]))
        & (t <= min(tr[-1], segment.imu_t[-1]))
        & np.all(np.abs(segment.dvl_v) <= DVL_FIT_LIMIT_M_S, axis=1)  # NaN too
    )
    t = t[ok]
    ref = reference_at(segment, reference_offset_s, t)
    v_b = ref.rotation.inv().apply(ref.vel)
    lever = np.broadcast_to(np.asarray(lever_arm_m, dtype=float), v_b.shape)
    predicted = v_b + np.cross(segment.gyro_at(t), lever)
    return t, np.asarray(segment.dvl_v[ok] - predicted, dtype=float)


def estimate_dvl_offset(
    segment: RawSegment,
    reference_offset_s: float,
    *,
    lever_arm_m: Sequence[float] = DVL_LEVER_ARM_M,
    search_s: tuple[float, float] = (-0.5, 2.5),
    step_s: float = 0.01,
) -> float:
    """The DVL time offset (s): DVL sample k belongs to IMU time ``k + offset`` (correction 4).

    Minimises the mean squared :func:`dvl_residuals` (DVL against the reference's body-frame
    velocity with the lever-arm term) over ``search_s``: a coarse grid, then a parabola fitted to
    the cost on a grid of ``step_s`` within ± 0.15 s
    (:func:`~adaptnav.importers.timing.minimise_lag`). The body-frame velocity changes mostly with
    speed, sideslip and heave, so the minimum is flat over a few hundredths of a second and this is
    less sharp than L (docs/akit.md gives the spread over segments 1-9: 1.00-1.05 s).
    """

    def cost(lag: float) -> float:
        _, r = dvl_residuals(segment, reference_offset_s, lag, lever_arm_m)
        return float(np.mean(np.sum(r * r, axis=1))) if r.shape[0] >= 10 else math.inf

    n = segment.trajectory
    what = f"DVL_trajectory{n}.csv against GT_trajectory{n}.csv, the DVL time offset"
    lag = minimise_lag(cost, search_s[0], search_s[1], step_s, 0.15, what)
    rms = math.sqrt(cost(lag) / 3.0)
    if not rms <= MAX_DVL_MISFIT_M_S:
        raise AkitError(
            f"{what}: at its best the DVL differs from the reference's velocity by {rms:.3g} "
            f"m/s RMS per axis (0.007-0.035 on segments 1-9): DVL X/Y/Z in another unit "
            "(knots, mm/s) or axes?",
            file=f"DVL_trajectory{n}.csv",
        )
    return lag


# --- a consistency check: free inertial navigation ----------------------------------------------


def _free_inertial(
    segment: RawSegment,
    reference_offset_s: float,
    start_index: int | NDArray[np.int64],
    duration_s: float,
    imu_lever_arm_m: Sequence[float],
) -> tuple[Array, ReferenceSample, ReferenceSample]:
    """(final nominal states (n, 16), references at the starts, references at the ends) of
    free-inertial runs from reference sample(s) ``start_index``, the references moved to the
    IMU point ``imu_lever_arm_m`` (see :func:`free_inertial_error`)."""
    start = reference_state(segment, reference_offset_s, start_index)
    j0 = np.rint((start.t - segment.imu_t[0]) / IMU_PERIOD_S).astype(np.int64)
    steps = round(duration_s / IMU_PERIOD_S)
    if np.any(j0 + steps >= segment.imu_t.size):
        raise ValueError(f"a {duration_s:g}-s run from {start.t.max():.2f} s leaves the IMU data")
    end = reference_at(segment, reference_offset_s, segment.imu_t[j0 + steps])
    start = start.moved(imu_lever_arm_m, segment.gyro_at(start.t))
    end = end.moved(imu_lever_arm_m, segment.gyro_at(end.t))
    dt = np.diff(segment.imu_t)
    dtheta, dvel = strapdown.rates_to_increments(segment.gyro, segment.accel, dt)
    P0, q = np.zeros((N_STATES, N_STATES)), np.zeros(N_NOISE)
    rpy = start.rpy
    out = []
    for i, j in enumerate(j0):
        lat, lon, h = (float(v) for v in start.pos[i])
        roll, pitch, yaw = (float(a) for a in rpy[i])
        x0 = NavState.from_euler(lat, lon, h, start.vel[i], roll, pitch, yaw).to_array()
        sl = slice(int(j), int(j) + steps)  # intervals (t_j, t_j+1], ..., ending at t_j+steps
        w0, f0 = dtheta[sl.start] / dt[sl.start], dvel[sl.start] / dt[sl.start]
        x, _, _, _ = propagation.propagate(x0, P0, dtheta[sl], dvel[sl], dt[sl], w0, f0, q)
        out.append(x)
    return np.array(out), start, end


def free_inertial_error(
    segment: RawSegment,
    reference_offset_s: float,
    start_index: int,
    duration_s: float = 60.0,
    imu_lever_arm_m: Sequence[float] = (0.0, 0.0, 0.0),
) -> tuple[float, float]:
    """(horizontal position error (m), attitude error (deg)) after ``duration_s`` of free
    inertial navigation started from the reference state of sample ``start_index``.

    The reference is moved to the IMU point ``imu_lever_arm_m`` (body FRD from the reference
    point, :meth:`ReferenceSample.moved`; zero: the README's assumption that the IMU is at the
    reference point). Navigation starts at the first IMU sample at or after
    ``start_index + L`` (:func:`reference_state`), propagates with the strapdown
    mechanization of :mod:`adaptnav.engine.propagation` (compiled; rates turned into increments by
    the trapezoid rule; no sensor, no bias) and is compared with the reference at the end
    time: the horizontal part of the exact NED error (through ECEF) and the angle of
    ``C_nb,ref C_nb,estᵀ``.
    """
    xs, _, end = _free_inertial(
        segment, reference_offset_s, start_index, duration_s, imu_lever_arm_m
    )
    x = xs[0]
    e = ned_errors(
        np.array([x[0]]), np.array([x[1]]), np.array([x[2]]),
        end.pos[:, 0], end.pos[:, 1], end.pos[:, 2],
    )  # fmt: skip
    q = x[NOM_ATT]
    est = Rotation.from_quat([q[1], q[2], q[3], q[0]])
    att = (end.rotation[0] * est.inv()).magnitude()
    return float(np.hypot(e[0, 0], e[0, 1])), float(np.degrees(att))


def estimate_imu_lever_arm(
    segment: RawSegment, reference_offset_s: float, *, window_s: float = 2.0
) -> Array:
    """Position r (m, body FRD) of the point whose motion the IMU senses, from the reference
    point (the README takes it as zero; the data say otherwise, docs/akit.md).

    Short free-inertial runs (``window_s``, one from every reference sample) are started from
    the reference state *at the reference point*. If the IMU sits at r, its velocity is
    ``v_n + C_nb (ω × r)`` (rigid body, :meth:`ReferenceSample.moved`), so the run's velocity
    error at the end of a window [a, b] is, to first order,

        v_ins(b) - v_ref(b) = (C_nb(b) [ω(b)×] - C_nb(a) [ω(a)×]) r,

    linear in r, which is solved for by least squares over all windows (ω from the gyro at
    a and b). Over 2 s the other errors (tilt, accelerometer noise) stay at millimetres per
    second while ``ω × r`` reaches 0.5 m/s in the sharp turns.
    """
    tr = segment.ref_k + reference_offset_s
    last = min(segment.imu_t[-1], tr[-1]) - window_s - IMU_PERIOD_S
    starts = np.flatnonzero((tr >= segment.imu_t[0]) & (tr <= last))
    if starts.size < 3:
        raise ValueError("estimate_imu_lever_arm: too few windows inside the data")
    x, a, b = _free_inertial(segment, reference_offset_s, starts, window_s, (0.0, 0.0, 0.0))
    skew_a = np.array([attitude.skew(w) for w in segment.gyro_at(a.t)])
    skew_b = np.array([attitude.skew(w) for w in segment.gyro_at(b.t)])
    A = b.rotation.as_matrix() @ skew_b - a.rotation.as_matrix() @ skew_a
    e = x[:, NOM_VEL] - b.vel
    r, *_ = np.linalg.lstsq(A.reshape(-1, 3), e.reshape(-1), rcond=None)
    return np.asarray(r, dtype=float)


# --- fault injection ----------------------------------------------------------------------------


def _window(rng: np.random.Generator, lo: float, hi: float, length: float) -> float:
    """A start time with the window [start, start + length) inside [lo, hi]."""
    if hi - lo < length:
        raise ValueError(f"a {length:.0f}-s window does not fit in [{lo:.1f}, {hi:.1f}] s")
    return float(rng.uniform(lo, hi - length))


def _fault_windows(
    rng: np.random.Generator, t: Array, noisy_s: float, lock_loss_s: float
) -> tuple[float, float]:
    """(start of the noisy window, start of the lock loss) (s), drawn in that order over the
    DVL span ``[t_0, t_n + 1 s]`` (docs/akit.md, "Fault injection")."""
    lo, hi = float(t[0]), float(t[-1]) + DVL_PERIOD_S
    noisy_start = _window(rng, lo, hi, noisy_s)
    # The lock loss goes in the longer of the two stretches left beside the noisy window.
    before, after = (lo, noisy_start), (noisy_start + noisy_s, hi)
    side = before if before[1] - before[0] >= after[1] - after[0] else after
    return noisy_start, _window(rng, side[0], side[1], lock_loss_s)


def _dvl_truth(
    v: Array,
    sigma_m_s: float,
    factor: Array,
    lock: NDArray[np.bool_],
    outlier: NDArray[np.bool_],
    spikes: Array,
) -> pd.DataFrame:
    """The DVL table's truth columns (docs/akit.md, "The mission written"): per reading
    ``is_outlier``, ``is_lock_loss``, ``noise_factor``, the true σ ``sigma_m_s × factor``,
    ``spike_{x,y,z}_m_s`` and the recorded readings ``recorded_v{x,y,z}_m_s`` (``v``)."""
    return pd.DataFrame(
        {
            "is_outlier": outlier,
            "is_lock_loss": lock,
            "noise_factor": factor,
            "sigma_m_s": sigma_m_s * factor,
            **{f"spike_{a}_m_s": spikes[:, i] for i, a in enumerate("xyz")},
            **{f"recorded_v{a}_m_s": v[:, i] for i, a in enumerate("xyz")},
        }
    )


def inject_dvl_faults(
    t: Array,
    v: Array,
    sigma_m_s: float,
    rng: np.random.Generator,
    *,
    spike_fraction: float = 0.01,
    spike_range_m_s: tuple[float, float] = (1.0, 3.0),
    lock_loss_s: float = 20.0,
    noisy_s: float = 60.0,
    noise_factor: float = 5.0,
) -> tuple[Array, pd.DataFrame, dict[str, Any]]:
    """DVL readings with faults, their truth columns, and what was injected.

    * a ``noisy_s`` window of ``noise_factor`` × noise: extra white noise of σ
      ``sigma √(factor² - 1)`` per axis, so that the total σ is ``factor × sigma`` if the
      recorded noise has σ ``sigma`` (variances of independent noises add);
    * a ``lock_loss_s`` bottom-lock loss, disjoint from it, where all three axes read exactly
      0 (what a DVL without bottom lock reports; they are outliers for an oracle);
    * spikes on ``spike_fraction`` of the readings outside the lock loss (at least one): on a
      random non-empty set of axes, ± U(spike_range) m/s with a random sign per axis.

    Returns (readings (n, 3), truth table, info). The truth table has, per reading,
    ``is_outlier`` (spike or lock loss), ``is_lock_loss``, ``noise_factor``, ``sigma_m_s`` (the
    true σ of the reading), ``spike_{x,y,z}_m_s`` and ``recorded_v{x,y,z}_m_s``.
    """
    n = t.size
    out = np.array(v, dtype=float, copy=True)
    noisy_start, lock_start = _fault_windows(rng, t, noisy_s, lock_loss_s)
    noisy = (t >= noisy_start) & (t < noisy_start + noisy_s)
    lock = (t >= lock_start) & (t < lock_start + lock_loss_s)
    factor = np.ones(n)
    factor[noisy] = noise_factor
    extra = sigma_m_s * math.sqrt(noise_factor**2 - 1.0)
    out[noisy] += rng.normal(0.0, extra, size=(int(noisy.sum()), 3))
    out[lock] = 0.0
    candidates = np.flatnonzero(~lock)
    n_spikes = max(1, round(spike_fraction * n))
    rows = np.sort(rng.choice(candidates, size=n_spikes, replace=False))
    spikes = np.zeros((n, 3))
    spikes[rows] = spike_vectors(rng, rows.size, spike_range_m_s)  # shared with sim.faults
    out += spikes
    outlier = lock.copy()
    outlier[rows] = True
    truth = _dvl_truth(np.asarray(v, dtype=float), sigma_m_s, factor, lock, outlier, spikes)
    info = {
        "noisy_window_s": [noisy_start, noisy_start + noisy_s],
        "noise_factor": noise_factor,
        "noisy_readings": int(noisy.sum()),
        "lock_loss_window_s": [lock_start, lock_start + lock_loss_s],
        "lock_loss_readings": int(lock.sum()),
        "spike_rows": rows.tolist(),
        "spike_range_m_s": list(spike_range_m_s),
    }
    return out, truth, info


def _clean_dvl_truth(v: Array, sigma_m_s: float) -> pd.DataFrame:
    """The truth columns of readings without faults: no outlier, factor 1, the nominal σ."""
    n = v.shape[0]
    none = np.zeros(n, dtype=bool)
    return _dvl_truth(v, sigma_m_s, np.ones(n), none, none.copy(), np.zeros((n, 3)))


# --- the mission: check, estimate, build --------------------------------------------------------


@dataclass(frozen=True)
class SegmentSettings:
    """The checked settings of an import (:func:`check_settings`): the seed, whether DVL faults
    are injected, the semi-synthetic depth's σ (m), the DVL's nominal σ (m/s) and the
    ``[imu.noise]`` pairs (docs/akit.md, "Vehicle configuration")."""

    seed: int
    faults: bool
    depth_sigma_m: float
    dvl_sigma_m_s: float
    imu_noise: dict[str, tuple[float | str, str]]


def check_settings(
    seed: int,
    faults: bool,
    depth_sigma_m: float,
    dvl_sigma_m_s: float,
    imu_noise: Mapping[str, tuple[float | str, str]] | None,
) -> SegmentSettings:
    """The import's settings, the two σ's refused (ValueError) unless finite and > 0;
    ``imu_noise`` None stands for :data:`PHINS_NOISE`."""
    if not (math.isfinite(depth_sigma_m) and depth_sigma_m > 0.0):
        raise ValueError(f"depth_sigma_m: value {depth_sigma_m!r} must be > 0")
    if not (math.isfinite(dvl_sigma_m_s) and dvl_sigma_m_s > 0.0):
        raise ValueError(f"dvl_sigma_m_s: value {dvl_sigma_m_s!r} must be > 0")
    noise = dict(imu_noise) if imu_noise is not None else dict(PHINS_NOISE)
    return SegmentSettings(seed, faults, depth_sigma_m, dvl_sigma_m_s, noise)


@dataclass(frozen=True, eq=False)
class SegmentOffsets:
    """The corrections estimated from the data and those used (docs/akit.md, corrections 3, 4
    and 6): the reference offset L (s), the DVL offset (s) and the IMU's position r from the
    reference point (m, body FRD)."""

    reference_estimated: float
    reference: float
    dvl_estimated: float
    dvl: float
    imu_lever_arm_estimated: Array
    imu_lever_arm: Array

    @property
    def dvl_lever_arm(self) -> Array:
        """The DVL's lever arm from the IMU, ``DVL_LEVER_ARM_M - r`` (correction 6)."""
        return np.asarray(DVL_LEVER_ARM_M) - self.imu_lever_arm


def estimate_offsets(
    seg: RawSegment,
    reference_offset_s: float | None,
    dvl_offset_s: float | None,
    imu_lever_arm_m: Sequence[float] | None,
) -> SegmentOffsets:
    """Estimate L (:func:`estimate_reference_offset`), then the DVL offset
    (:func:`estimate_dvl_offset`) and r (:func:`estimate_imu_lever_arm`) at the L used; each
    given value replaces its estimate (docs/akit.md, "The corrections"). A given r that is not
    3 finite numbers is a ValueError."""
    L_est = estimate_reference_offset(seg)
    L = L_est if reference_offset_s is None else float(reference_offset_s)
    dvl_est = estimate_dvl_offset(seg, L)
    dvl_off = dvl_est if dvl_offset_s is None else float(dvl_offset_s)
    r_est = estimate_imu_lever_arm(seg, L)
    r_imu = r_est if imu_lever_arm_m is None else np.asarray(imu_lever_arm_m, dtype=float)
    if r_imu.shape != (3,) or not np.all(np.isfinite(r_imu)):
        raise ValueError(f"imu_lever_arm_m: {imu_lever_arm_m!r} is not 3 finite numbers")
    return SegmentOffsets(L_est, L, dvl_est, dvl_off, r_est, r_imu)


@dataclass(frozen=True, eq=False)
class NavigationSpan:
    """Where navigation runs (docs/akit.md, "Navigation start"): ``start`` the initial state at
    the IMU point, from reference sample ``start_index``; ``t0`` its time and ``t_end`` the
    last IMU sample used (s); ``imu`` the slice of IMU samples from ``t0`` to ``t_end``."""

    start: ReferenceSample
    start_index: int
    t0: float
    t_end: float
    imu: slice


def estimate_navigation_span(seg: RawSegment, offsets: SegmentOffsets) -> NavigationSpan:
    """The navigation start and end: the first reference sample inside the IMU data carried
    to the next IMU sample (:func:`reference_state`) and moved to the IMU point; the end at the
    last IMU sample inside the reference span (docs/akit.md, "Navigation start")."""
    # No static alignment in these segments: the reference gives the start.
    t_ref = seg.ref_k + offsets.reference
    k0 = int(np.searchsorted(t_ref, seg.imu_t[0] - 1e-9, side="left"))
    start = reference_state(seg, offsets.reference, k0)
    start = start.moved(offsets.imu_lever_arm, seg.gyro_at(start.t))
    t0 = float(start.t[0])
    t_end = float(min(seg.imu_t[-1], t_ref[-1]))
    j0 = int(np.searchsorted(seg.imu_t, t0 - 1e-9, side="left"))
    j_end = int(np.searchsorted(seg.imu_t, t_end + 1e-9, side="right"))
    t_end = float(seg.imu_t[j_end - 1])  # readings after the last IMU sample could not be used
    return NavigationSpan(start, k0, t0, t_end, slice(j0, j_end))


def build_imu_table(seg: RawSegment, span: NavigationSpan) -> pd.DataFrame:
    """The ``imu`` table (rates, FRD, y negated) over the navigation span (docs/akit.md, "The
    mission written")."""
    j = span.imu
    return pd.DataFrame(
        {
            "t_s": seg.imu_t[j],
            **{f"gyro_{a}_rad_s": seg.gyro[j, i] for i, a in enumerate("xyz")},
            **{f"accel_{a}_m_s2": seg.accel[j, i] for i, a in enumerate("xyz")},
        }
    )


def build_dvl_table(
    seg: RawSegment,
    offsets: SegmentOffsets,
    span: NavigationSpan,
    settings: SegmentSettings,
    fault_ss: np.random.SeedSequence,
) -> tuple[pd.DataFrame, dict[str, Any], int]:
    """(``dvl`` table, injected faults, readings left out): the readings at ``k + offset``
    after the start and up to the last IMU sample, with faults (:func:`inject_dvl_faults`, the
    seed's second stream) or without, and their truth columns (docs/akit.md, "Fault
    injection")."""
    t_dvl = seg.dvl_k + offsets.dvl
    keep = (t_dvl > span.t0) & (t_dvl <= span.t_end)
    t_dvl, v_dvl = t_dvl[keep], seg.dvl_v[keep]
    sigma = settings.dvl_sigma_m_s
    if settings.faults:
        v_out, truth, info = inject_dvl_faults(t_dvl, v_dvl, sigma, np.random.default_rng(fault_ss))
    else:
        v_out, truth, info = v_dvl, _clean_dvl_truth(v_dvl, sigma), {}
    readings = pd.DataFrame(
        {"t_s": t_dvl, **{f"v{a}_m_s": v_out[:, i] for i, a in enumerate("xyz")}}
    )
    return pd.concat([readings, truth], axis=1), info, int(np.count_nonzero(~keep))


def build_truth_table(seg: RawSegment, offsets: SegmentOffsets) -> pd.DataFrame:
    """The ``truth`` table at ``t = k + L``: the reference moved to the IMU point
    (:meth:`ReferenceSample.moved`, correction 6), its attitude, ``ref_index`` and the recorded
    reference-point values as ``ref_*`` (docs/akit.md, "The mission written")."""
    t_ref = seg.ref_k + offsets.reference
    recorded = ReferenceSample(t_ref, seg.ref_pos, seg.ref_vel, seg.reference_rotation())
    at_imu = recorded.moved(offsets.imu_lever_arm, seg.gyro_at(t_ref))
    return pd.DataFrame(
        {
            "t_s": t_ref,
            "lat_rad": at_imu.pos[:, 0],
            "lon_rad": at_imu.pos[:, 1],
            "h_m": at_imu.pos[:, 2],
            "vn_m_s": at_imu.vel[:, 0],
            "ve_m_s": at_imu.vel[:, 1],
            "vd_m_s": at_imu.vel[:, 2],
            "roll_rad": seg.ref_rpy[:, 0],
            "pitch_rad": seg.ref_rpy[:, 1],
            "yaw_rad": seg.ref_rpy[:, 2],
            "ref_index": np.arange(t_ref.size, dtype=np.int64),
            **{f"ref_{c}": seg.ref_pos[:, i] for i, c in enumerate(("lat_rad", "lon_rad", "h_m"))},
            **{f"ref_v{c}_m_s": seg.ref_vel[:, i] for i, c in enumerate("ned")},
        }
    )


def build_depth_table(
    seg: RawSegment,
    offsets: SegmentOffsets,
    span: NavigationSpan,
    depth_sigma_m: float,
    depth_ss: np.random.SeedSequence,
) -> pd.DataFrame:
    """The semi-synthetic ``depth`` table (docs/akit.md, "Semi-synthetic depth"): the reference
    point's depth ``-h`` at the reference times inside the navigation span, plus white noise of
    σ ``depth_sigma_m`` from the seed's first stream (the recordings have no depth sensor)."""
    t_ref = seg.ref_k + offsets.reference
    in_span = (t_ref > span.t0) & (t_ref <= span.t_end)
    true_depth = -seg.ref_pos[in_span, 2]
    depth_noise = np.random.default_rng(depth_ss).normal(0.0, depth_sigma_m, true_depth.size)
    return pd.DataFrame(
        {
            "t_s": t_ref[in_span],
            "depth_m": true_depth + depth_noise,
            "true_depth_m": true_depth,
            "sigma_m": np.full(true_depth.size, depth_sigma_m),
        }
    )


def _description(n: int, settings: SegmentSettings, offsets: SegmentOffsets) -> str:
    """The mission's description: real data, the semi-synthetic depth, faults, offsets used."""
    return (
        f"Snapir AUV (A-KIT) segment {n}: real Phins IMU and RDI DVL data with the Delph "
        f"post-processed reference (moved to the IMU point) as truth; the depth sensor is "
        f"SEMI-SYNTHETIC (reference depth + N(0, {settings.depth_sigma_m:g} m), "
        f"seed {settings.seed})"
        + ("; DVL faults injected (seeded)" if settings.faults else "")
        + f"; L = {offsets.reference:+.3f} s, DVL offset {offsets.dvl:+.3f} s (import.json)"
    )


def _sensors_section(settings: SegmentSettings, offsets: SegmentOffsets) -> dict[str, Any]:
    """``[sensors]``: the DVL and the semi-synthetic depth, lever arms from the IMU
    (``DVL_LEVER_ARM_M - r`` and ``-r``, correction 6)."""
    return {
        "dvl": {
            "kind": "dvl",
            "file": "dvl.parquet",
            "sigma": [settings.dvl_sigma_m_s, "m/s"],
            "rate_hz": 1.0 / DVL_PERIOD_S,
            "lever_arm_m": [round(float(v), 4) for v in offsets.dvl_lever_arm],
            "use": "aid",
        },
        "depth": {
            "kind": "depth",
            "file": "depth_semisynthetic.parquet",
            "sigma": [settings.depth_sigma_m, "m"],
            "rate_hz": 1.0 / REF_PERIOD_S,
            "lever_arm_m": [round(float(-v), 4) for v in offsets.imu_lever_arm],
            "use": "aid",
        },
    }


def _initial_section(start: ReferenceSample) -> dict[str, Any]:
    """``[initial]``: ``mode = "state"`` at the navigation start, with the assumed σ's
    (docs/akit.md, "Vehicle configuration")."""
    lat0, lon0, h0 = (float(v) for v in start.pos[0])
    roll0, pitch0, yaw0 = (float(math.degrees(a)) for a in start.rpy[0])
    return {
        "mode": "state",
        "lat_deg": math.degrees(lat0),
        "lon_deg": math.degrees(lon0),
        "h_m": h0,
        "v_ned_m_s": [float(v) for v in start.vel[0]],
        "rpy_deg": [roll0, pitch0, yaw0],
        "sigma_position_m": INITIAL_SIGMA_POSITION_M,
        "sigma_velocity_m_s": INITIAL_SIGMA_VELOCITY_M_S,
        "sigma_attitude_deg": list(INITIAL_SIGMA_ATTITUDE_DEG),
    }


def build_config(
    n: int, settings: SegmentSettings, offsets: SegmentOffsets, span: NavigationSpan
) -> MissionConfig:
    """The mission configuration of segment ``n`` (docs/akit.md, "The mission written" and
    "Vehicle configuration"): the IMU as rates with the Phins noise, the DVL and depth sensors,
    the initial state at the navigation start and the truth."""
    doc: dict[str, Any] = {
        "mission": {"name": f"akit-{n}", "description": _description(n, settings, offsets)},
        "imu": {
            "file": "imu.parquet",
            "format": "rates",
            "rate_hz": 1.0 / IMU_PERIOD_S,
            "noise": {k: list(v) for k, v in settings.imu_noise.items()},
            "initial_bias_sigma": {k: list(v) for k, v in PHINS_INITIAL_BIAS_SIGMA.items()},
        },
        "sensors": _sensors_section(settings, offsets),
        "initial": _initial_section(span.start),
        "truth": {"file": "truth.parquet"},
    }
    return parse_config(doc, f"A-KIT segment {n} (import)")


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _offsets_record(seg: RawSegment, offsets: SegmentOffsets) -> dict[str, Any]:
    """import.json's offsets and lever arms, estimated, README and used, and the σ of the DVL
    residuals (:func:`dvl_residuals`) with and without the DVL lever arm (docs/akit.md,
    corrections 3-6)."""
    readme_L = README_REFERENCE_OFFSET_S.get(seg.trajectory)
    L_est, L, r_imu = offsets.reference_estimated, offsets.reference, offsets.imu_lever_arm
    _, r_used = dvl_residuals(seg, L, offsets.dvl)
    _, r_no_arm = dvl_residuals(seg, L, offsets.dvl, (0.0, 0.0, 0.0))
    return {
        "reference_offset_s": {
            "estimated": L_est,
            "readme": readme_L,
            "used": L,
            "estimated_minus_readme": None if readme_L is None else L_est - readme_L,
        },
        "dvl_offset_s": {
            "estimated": offsets.dvl_estimated,
            "readme": README_DVL_OFFSET_S,
            "used": offsets.dvl,
        },
        "imu_lever_arm_m": {
            "estimated": offsets.imu_lever_arm_estimated.tolist(),
            "readme": [0.0, 0.0, 0.0],
            "used": r_imu.tolist(),
            "meaning": "IMU position from the reference point, body FRD",
        },
        "dvl_lever_arm_m": {
            "from_reference_point": list(DVL_LEVER_ARM_M),
            "from_imu": offsets.dvl_lever_arm.tolist(),
        },
        "dvl_residual_sigma_m_s": {
            "with_lever_arm": np.std(r_used, axis=0).tolist(),
            "without_lever_arm": np.std(r_no_arm, axis=0).tolist(),
        },
    }


def _corrections(offsets: SegmentOffsets) -> list[str]:
    """The six corrections as applied (docs/akit.md, "The corrections")."""
    return [
        "index time: IMU t = 0.01 j, DVL and reference t = 1.0 k (Time [s] ignored)",
        "IMU y axis negated (ACC Y, GYRO Y) to FRD",
        f"reference sample k at IMU time k + L, L = {offsets.reference:+.4f} s",
        f"DVL sample k at IMU time k + {offsets.dvl:.4f} s",
        f"DVL lever arm {list(DVL_LEVER_ARM_M)} m FRD from the reference point",
        f"IMU at {np.round(offsets.imu_lever_arm, 4).tolist()} m FRD from the reference point: "
        "truth, initial state, DVL and depth lever arms refer to the IMU",
    ]


def reference_record(truth: pd.DataFrame) -> dict[str, float]:
    """import.json's check of the reference against itself: how far its velocity columns and
    the rate of its positions disagree (:func:`adaptnav.analysis.dvl_fit.reference_consistency`;
    docs/akit.md, 'The reference')."""
    scale_pct, p95 = reference_consistency(truth)
    return {"position_rate_over_velocity_minus_1_pct": scale_pct, "difference_p95_m_s": p95}


def build_import_record(
    seg: RawSegment,
    settings: SegmentSettings,
    offsets: SegmentOffsets,
    span: NavigationSpan,
    left_out: tuple[int, int],
    fault_info: dict[str, Any],
    written: MissionConfig,
    truth: pd.DataFrame,
) -> dict[str, Any]:
    """import.json (docs/akit.md, "The mission written"): the source files' SHA-256, the
    recording's day and the lack of an absolute time (:data:`README_RECORDED_ON`), the seed,
    the offsets (:func:`_offsets_record`), the corrections, the navigation span and the IMU
    samples and DVL readings ``left_out``, the depth's origin, the repairs, the injected faults,
    the reference's consistency (:func:`reference_record`, of the ``truth`` table written) and
    the tables written."""
    n = seg.trajectory
    return {
        "importer": "adaptnav.importers.akit",
        "trajectory": n,
        "source": str(seg.source),
        "source_sha256": {
            f"{s}_trajectory{n}.csv": _sha256(seg.source / f"{s}_trajectory{n}.csv")
            for s in ("IMU", "DVL", "GT")
        },
        "time": {"stamp_origin_ns": None, "recorded_on": README_RECORDED_ON, "note": TIME_NOTE},
        "seed": settings.seed,
        "faults": settings.faults,
        **_offsets_record(seg, offsets),
        "corrections": _corrections(offsets),
        "navigation_start_s": span.t0,
        "navigation_start_reference_index": span.start_index,
        "navigation_end_s": span.t_end,
        "imu_samples_left_out": left_out[0],
        "dvl_readings_left_out": left_out[1],
        "depth": {
            "semi_synthetic": True,
            "source": "reference depth = -altitude at the reference times, plus white noise",
            "sigma_m": settings.depth_sigma_m,
        },
        "dvl_sigma_m_s": settings.dvl_sigma_m_s,
        "imu_noise": {k: list(v) for k, v in settings.imu_noise.items()},
        "repairs": [r.__dict__ for r in seg.repairs],
        "fault_injection": fault_info,
        "reference_consistency": reference_record(truth),
        "mission_files": {
            "imu": written.imu.file,
            **{k: s.file for k, s in written.sensors.items()},
            "truth": written.truth.file,
        },
    }


def import_segment(
    src_dir: str | Path,
    trajectory: int,
    out_dir: str | Path,
    *,
    seed: int = 0,
    faults: bool = False,
    depth_sigma_m: float = DEPTH_SIGMA_M,
    dvl_sigma_m_s: float = DVL_SIGMA_M_S,
    reference_offset_s: float | None = None,
    dvl_offset_s: float | None = README_DVL_OFFSET_S,
    imu_lever_arm_m: Sequence[float] | None = None,
    imu_noise: Mapping[str, tuple[float | str, str]] | None = None,
    fmt: Literal["parquet", "csv"] = "parquet",
) -> Path:
    """Import segment ``trajectory`` of ``src_dir`` as a mission folder ``out_dir``.

    Args:
        seed: drives the semi-synthetic depth noise and the faults (separate streams of
            ``np.random.SeedSequence(seed)``, so switching faults leaves the depth unchanged).
        faults: inject DVL faults (:func:`inject_dvl_faults`).
        depth_sigma_m: σ of the noise added to the reference depth (the depth sensor's σ).
        dvl_sigma_m_s: the DVL's nominal σ per axis (config and ``sigma_m_s``).
        reference_offset_s: L; None (default) estimates it (:func:`estimate_reference_offset`).
        dvl_offset_s: the DVL offset; None estimates it (:func:`estimate_dvl_offset`); the
            default is the README's 1.0 s (the estimate is recorded either way).
        imu_lever_arm_m: the IMU's position from the reference point (body FRD, m); None
            (default) estimates it (:func:`estimate_imu_lever_arm`); ``(0, 0, 0)`` is the
            README's assumption that the IMU sits at the reference point.
        imu_noise: ``[imu.noise]`` pairs replacing :data:`PHINS_NOISE`.
        fmt: table format.

    The mission navigates the IMU point: the truth table is the reference moved there
    (:meth:`ReferenceSample.moved`; the recorded reference-point values are kept as ``ref_*``
    columns), the DVL's lever arm is ``DVL_LEVER_ARM_M - r_imu`` and the semi-synthetic depth
    sensor measures the reference point's depth with lever arm ``-r_imu``.

    Writes ``mission.toml``, ``imu``, ``dvl``, ``depth_semisynthetic``, ``truth`` tables and
    ``import.json`` (offsets and lever arm estimated and used, README values, corrections,
    repairs, injected faults). Navigation starts (``[initial] mode = "state"``) at the first
    reference sample inside the IMU data, carried to the next IMU sample
    (:func:`reference_state`); IMU samples before it and DVL readings outside the IMU span are
    left out (counted in import.json). Returns ``out_dir``.

    The steps: :func:`check_settings`, :func:`read_segment`, :func:`estimate_offsets`,
    :func:`estimate_navigation_span`, the ``build_*_table`` functions, :func:`build_config` and
    :func:`build_import_record`.
    """
    settings = check_settings(seed, faults, depth_sigma_m, dvl_sigma_m_s, imu_noise)
    seg = read_segment(src_dir, trajectory)
    offsets = estimate_offsets(seg, reference_offset_s, dvl_offset_s, imu_lever_arm_m)
    depth_ss, fault_ss = np.random.SeedSequence(seed).spawn(2)
    span = estimate_navigation_span(seg, offsets)
    imu_df = build_imu_table(seg, span)
    dvl_df, fault_info, dvl_left_out = build_dvl_table(seg, offsets, span, settings, fault_ss)
    tables = {
        "imu": imu_df,
        "dvl": dvl_df,
        "depth": build_depth_table(seg, offsets, span, depth_sigma_m, depth_ss),
        "truth": build_truth_table(seg, offsets),
    }
    root = Path(out_dir)
    written = write_mission(
        root, build_config(seg.trajectory, settings, offsets, span), tables, fmt=fmt
    )
    left_out = (int(seg.imu_t.size - len(imu_df)), dvl_left_out)
    meta = build_import_record(
        seg, settings, offsets, span, left_out, fault_info, written, tables["truth"]
    )
    (root / "import.json").write_text(
        json.dumps(meta, indent=2, sort_keys=True, default=_json_default) + "\n", encoding="utf-8"
    )
    readme_L = README_REFERENCE_OFFSET_S.get(seg.trajectory)
    log.info(
        "A-KIT segment %d -> %s: L = %+.3f s (README %s), DVL offset %.3f s (estimated %.3f), "
        "IMU at %s m from the reference point",
        seg.trajectory,
        root,
        offsets.reference,
        "n/a" if readme_L is None else f"{readme_L:+.2f}",
        offsets.dvl,
        offsets.dvl_estimated,
        np.round(offsets.imu_lever_arm, 3).tolist(),
    )
    return root


def _json_default(value: object) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")
