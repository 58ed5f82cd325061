"""``mission.toml``: the validated mission configuration (docs/data-format.md).

Pydantic v2 models, all ``extra="forbid"`` and frozen, so an unknown key is refused with its
path (``sensors.dvl.sigmaa``). Quantities with units are ``[value, "unit"]`` pairs converted by
:mod:`adaptnav.core.units`; keys ending in ``_m``, ``_s``, ``_hz``, ``_deg``, ``_m_s`` are in those
units. Every error of a loaded file comes out as one :class:`MissionError` naming the file and
the key path; unit errors are also :class:`~adaptnav.core.units.UnitError`.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path, PureWindowsPath
from typing import Annotated, Any, Literal, TypeVar

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    ValidationError,
    ValidationInfo,
    create_model,
    field_validator,
    model_validator,
)

from adaptnav.core.attitude import euler_to_dcm
from adaptnav.core.earth import MAX_LAT_DEG
from adaptnav.core.units import DEG, SIGMA_RANGE_SI, Kind, UnitError, check_sigma, si_unit, to_si
from adaptnav.estimation.settings import MAX_MATCHING_WINDOW, FilterSettings, SensorOverrides
from adaptnav.models.imu_noise import NOISE_FIELDS, ImuNoise, check_value, pair_si
from adaptnav.sensors import registry
from adaptnav.sensors.dvl import DVL_AFTER_GAP_S
from adaptnav.sensors.kind import StuckDefault
from adaptnav.sensors.registry import KINDS

Array = NDArray[np.float64]

TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
RESERVED_NAMES = ("imu", "truth")
"""Stream names taken by the IMU and the reference; a sensor may not use them."""
DEFAULT_GAP_PERIODS = 5.0
"""Default ``imu.max_gap_s``: this many nominal IMU periods (0.05 s at 100 Hz)."""
DEFAULT_IMU_STUCK_S = 1.0
"""Default ``imu.stuck_s``: a real IMU's six values never all repeat for a second
(docs/robustness.md, 'A frozen IMU')."""
CHANNEL_STUCK_FACTOR = 5.0
"""Default ``imu.channel_stuck_s``: this many times ``imu.stuck_s`` (5 s by default). One IMU
value alone repeats longer than all six do (a coarse output step), but in the A-KIT segments at
most for 0.29 s, in the RTKLIB car's IMU 0.03 s (docs/robustness.md, 'One IMU channel stuck')."""
DEFAULT_SATURATION_ROWS = 10
"""Default ``imu.saturation_rows``: a real IMU column reaches its extreme value once or twice
(docs/robustness.md, 'A saturated IMU')."""
FALLBACK_GYRO_BIAS_SIGMA = 10.0 * DEG / 3600.0
"""Initial gyro-bias σ (rad/s, 10 °/h) when neither the config nor the noise model gives one."""
FALLBACK_ACCEL_BIAS_SIGMA = 1e-3 * 9.80665
"""Initial accelerometer-bias σ (m/s², 1 mg) when neither the config nor the noise model does."""

_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_-]*$")
INIT_KINDS = ("gnss", "heading")
"""Kinds a sensor with ``use = "init"`` may be: what the alignment takes its position (a GNSS)
or its heading (a heading sensor) from (docs/alignment.md)."""


def check_euler_deg(key: str, rpy: Sequence[float]) -> None:
    """ZYX roll, pitch, yaw (deg): pitch within ±90°, roll and yaw within ±360° (up to 0.4.4 any
    finite number: a pitch of 100° or a yaw of 1e300 ran, far off, with exit 0)."""
    r, p, y = (float(a) for a in rpy)
    if not (abs(p) <= 90.0 and abs(r) <= 360.0 and abs(y) <= 360.0):
        raise ValueError(
            f"{key}: {list(rpy)} outside roll and yaw ±360°, pitch ±90° (ZYX Euler angles, deg)"
        )


def sensor_name_problem(name: str) -> str | None:
    """Why ``name`` cannot name a sensor (``[sensors.<name>]``, and the importers' table
    files named after it), or None: a letter then letters, digits, '_' or '-' (no path), not
    a reserved name."""
    if not _NAME_RE.match(name):
        return f"sensor name {name!r}: use a letter then letters, digits, '_' or '-'"
    if name in RESERVED_NAMES:
        return f"sensor name {name!r} is reserved ({', '.join(RESERVED_NAMES)})"
    return None


SENSOR_KINDS = registry.SENSOR_KINDS
"""The sensor kinds a mission may configure (adaptnav.sensors.registry)."""
SENSOR_COLUMNS: dict[str, tuple[str, ...]] = {k: v.columns for k, v in KINDS.items()}
"""Measurement columns of each sensor table, after ``t_s`` (gnss ``h_m`` only with height)."""
SENSOR_LIMITS: dict[str, dict[str, tuple[float, float]]] = {
    k: dict(v.limits) for k, v in KINDS.items()
}
"""Default plausible range of each sensor column (SI units; ``[sensors.<name>] limits``
overrides them), declared by each sensor kind (``KIND.limits`` in ``sensors/<kind>.py``)."""
STUCK_DEFAULTS: dict[str, StuckDefault] = {k: v.stuck for k, v in KINDS.items()}
"""Default stuck-reading detection of each sensor kind (``[sensors.<name>] stuck_s`` and
``resolution`` override it), declared by each kind (``KIND.stuck``); the reasons are in
docs/robustness.md ("Stuck readings")."""
_OPTIONS = frozenset().union(*(k.options for k in KINDS.values()))
"""Every kind-specific key of a ``[sensors.<name>]`` section."""


class MissionError(ValueError):
    """Bad mission input; the message names the file, the line (or row) and the field.

    ``file``, ``line`` and ``field`` repeat them for programs (None where not applicable).
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        field: str | None = None,
    ) -> None:
        super().__init__(message)
        self.file = file
        self.line = line
        self.field = field


class MissionUnitError(MissionError, UnitError):
    """A wrong unit or an unconvertible value in ``mission.toml`` (both error kinds at once)."""


# --- field types --------------------------------------------------------------------------------

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
MAX_RATE_HZ = 100_000.0
"""Highest sampling rate a table may be declared at: no IMU or aiding sensor samples faster
(up to 0.4.8 ``imu.rate_hz = 1e300`` passed, and the loader's arithmetic overflowed into a
misleading "wrong units?")."""
Rate = Annotated[float, Field(gt=0, le=MAX_RATE_HZ, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Sigma = Annotated[float, Field(ge=SIGMA_RANGE_SI[0], le=SIGMA_RANGE_SI[1], allow_inf_nan=False)]
"""A standard deviation in SI units, within what any sensor or prior could mean
(core.units.SIGMA_RANGE_SI)."""
SigmaDeg = Annotated[float, Field(gt=0, le=180, allow_inf_nan=False)]
"""An attitude standard deviation in degrees: more than 180° says nothing."""
Latitude = Annotated[float, Field(ge=-MAX_LAT_DEG, le=MAX_LAT_DEG, allow_inf_nan=False)]
H_RANGE_M = (-12_000.0, 100_000.0)
"""Initial heights accepted (m, above the ellipsoid): the deepest ocean to the edge of space."""
SURFACE_H_RANGE_M = (-1_000.0, 10_000.0)
"""Bounds (m) of a depth meter's ``surface_h_m``: the geoid, where the sea's surface lies, is
within about ±110 m of the ellipsoid; a lake's surface may be kilometres up."""
Vec3 = tuple[Finite, Finite, Finite]
Pair = tuple[float | str, str]
"""``[value, "unit"]``; the value may be the string ``"inf"`` for correlation times."""
VecPair = tuple[float | list[float], str]
"""``[value, "unit"]`` or ``[[v1, v2, ...], "unit"]`` (one value per component)."""


def _pair_si(
    pair: tuple[Any, str], kind: Kind, field: str, allow_negative: bool = False
) -> float | Array:
    """SI value of a ``[value, unit]`` pair; "inf" is allowed for times (random-walk biases)."""
    value, unit = pair
    if kind is Kind.TIME and (
        (isinstance(value, str) and value.strip().lower() == "inf")
        or (isinstance(value, float) and value == math.inf)
    ):
        to_si(1.0, unit, kind, field)  # the unit must still be a time
        return math.inf
    if isinstance(value, list):
        if not value:
            raise UnitError(f"{field}: empty list of values")
        return np.array([to_si(v, unit, kind, field, allow_negative) for v in value])
    if isinstance(value, str):
        raise UnitError(f"{field}: value {value!r} is not a number")
    return to_si(value, unit, kind, field, allow_negative)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --- sections -----------------------------------------------------------------------------------


class MissionSection(_Model):
    """``[mission]``: a name (required) and a free description."""

    name: Annotated[str, Field(min_length=1)]
    description: str = ""


_NOISE_KINDS: dict[str, Kind] = {f.name: f.kind for f in NOISE_FIELDS if f.kind is not None}
"""The ``[imu.noise]`` keys, one per noise term of :class:`ImuNoise`, and their quantity kinds."""
_WHITE_NOISE = ("arw", "vrw")
"""``[imu.noise]`` keys that must be > 0 (the bias terms may be 0: no bias)."""

_Section = TypeVar("_Section", bound=BaseModel)


def _noise_keys(section: type[_Section]) -> type[_Section]:
    """``section`` with one ``[value, "unit"]`` key per noise term
    (:data:`adaptnav.models.imu_noise.NOISE_FIELDS`): required where the term has no default,
    else optional (absent: the term's default)."""
    keys: dict[str, Any] = {
        f.name: (Pair, ...) if f.default is None else (Pair | None, None) for f in NOISE_FIELDS
    }
    return create_model(
        section.__name__,
        __base__=section,
        __module__=section.__module__,
        __doc__=section.__doc__,
        **keys,
    )


@_noise_keys
class ImuNoiseConfig(_Model):
    """``[imu.noise]``: the fields of :meth:`ImuNoise.from_datasheet`, each ``[value, "unit"]``
    (its keys come from the noise terms' table: :func:`_noise_keys`)."""

    @field_validator("*")
    @classmethod
    def _check_unit(cls, v: Pair | None, info: ValidationInfo) -> Pair | None:
        if v is None:
            return v
        name = str(info.field_name)
        kind = _NOISE_KINDS[name]
        si = pair_si(name, kind, v)
        check_value(name, kind, si)
        if name in _WHITE_NOISE and not si > 0.0:
            # Zero white noise: a Q with no noise at all makes the filter trust the IMU
            # absolutely (and P singular); no real IMU has it.
            raise UnitError(f"{name}: value {v[0]!r} must be > 0 (no IMU is noise-free)")
        if kind is not Kind.TIME:
            check_sigma(name, si, si_unit(kind), zero_ok=name not in _WHITE_NOISE)
        return v

    def to_imu_noise(self) -> ImuNoise:
        """The SI noise model (``ImuNoise.from_datasheet`` of the given pairs)."""
        return ImuNoise.from_datasheet(**self.model_dump(exclude_none=True))


class InitialBiasSigma(_Model):
    """``[imu.initial_bias_sigma]``: bias σ after alignment (initial P); None → see ``si``."""

    gyro: Pair | None = None
    accel: Pair | None = None

    @field_validator("gyro", "accel")
    @classmethod
    def _check_unit(cls, v: Pair | None, info: ValidationInfo) -> Pair | None:
        if v is not None:
            kind = Kind.ANGULAR_RATE if info.field_name == "gyro" else Kind.ACCELERATION
            si = float(_pair_si(v, kind, str(info.field_name)))
            check_sigma(str(info.field_name), si, si_unit(kind), zero_ok=True)
        return v

    def si(self, noise: ImuNoise) -> tuple[float, float]:
        """(gyro rad/s, accel m/s²): the given values, else the noise model's in-run bias σ,
        else 10 °/h and 1 mg."""
        if self.gyro is not None:
            g = float(_pair_si(self.gyro, Kind.ANGULAR_RATE, "gyro"))
        else:
            g = noise.gyro_bias_sigma or FALLBACK_GYRO_BIAS_SIGMA
        if self.accel is not None:
            a = float(_pair_si(self.accel, Kind.ACCELERATION, "accel"))
        else:
            a = noise.accel_bias_sigma or FALLBACK_ACCEL_BIAS_SIGMA
        return g, a


class InitialBias(_Model):
    """``[imu.initial_bias]``: bias estimates to start from (a calibration, or a static mean
    taken by an importer), each ``[[x, y, z], "unit"]`` in body axes; zero where absent. Used
    with ``initial.mode = "state"`` (an alignment estimates its own)."""

    gyro: VecPair | None = None
    accel: VecPair | None = None

    @field_validator("gyro", "accel")
    @classmethod
    def _check_vector(cls, v: VecPair | None, info: ValidationInfo) -> VecPair | None:
        if v is not None:
            name = str(info.field_name)
            kind = Kind.ANGULAR_RATE if name == "gyro" else Kind.ACCELERATION
            si = np.asarray(_pair_si(v, kind, name, allow_negative=True), dtype=float)
            if si.shape != (3,):
                raise UnitError(f"{name}: give three values [[x, y, z], unit], got {v[0]!r}")
        return v

    def given(self) -> bool:
        return self.gyro is not None or self.accel is not None

    def si(self) -> tuple[Array, Array]:
        """(gyro rad/s (3,), accel m/s² (3,))."""

        def vector(pair: VecPair | None, kind: Kind, name: str) -> Array:
            if pair is None:
                return np.zeros(3)
            return np.asarray(_pair_si(pair, kind, name, allow_negative=True), dtype=float)

        return (
            vector(self.gyro, Kind.ANGULAR_RATE, "gyro"),
            vector(self.accel, Kind.ACCELERATION, "accel"),
        )


class ImuConfig(_Model):
    """``[imu]``: the IMU table, its format and rate, the gap limit and the noise model."""

    file: str
    noise: ImuNoiseConfig
    format: Literal["rates", "increments"] = "rates"
    rate_hz: Rate = 100.0
    max_gap_s: Positive | None = None
    """Largest accepted interval between IMU samples; None → 5 nominal periods."""
    stuck_s: NonNegative | None = None
    """Longest time every IMU value may stay unchanged before the IMU is taken as frozen (an
    error); None → :data:`DEFAULT_IMU_STUCK_S`; 0: not checked."""
    channel_stuck_s: NonNegative | None = None
    """Longest time one IMU value may stay unchanged while the others of its triad change and
    it changes elsewhere, before the channel is taken as stuck (an error; since 0.4.13); None →
    :data:`CHANNEL_STUCK_FACTOR` × the ``stuck_s`` in force; 0: not checked."""
    saturation_rows: Annotated[int, Field(ge=0)] | None = None
    """Rows at a column's largest or smallest value that make it saturated (an error); None →
    :data:`DEFAULT_SATURATION_ROWS`; 0: not checked."""
    restamp: StrictBool | None = None
    """Increments whose stamps jitter about a grid, the increments one period each: re-stamp the
    rows on the fitted grid (a repair; since 0.4.9) or, false, only warn; None → true (not
    written, so a mission folder stays readable by 0.4.8)."""
    axis_check: StrictBool | None = None
    """Compare the gyro's axes with the aiding sensors that see rotation and refuse an axis that
    does not follow them (a flipped sign, swapped axes, deg/s; since 0.4.10) or, false, do not;
    None → true (docs/robustness.md, 'IMU axes')."""
    initial_bias_sigma: InitialBiasSigma = InitialBiasSigma()
    initial_bias: InitialBias = InitialBias()

    @field_validator("file")
    @classmethod
    def _check_file(cls, v: str) -> str:
        return _check_table_file(v)

    @property
    def check_axes(self) -> bool:
        """``axis_check`` or, if not given, true."""
        return self.axis_check is not False

    @property
    def stuck_limit_s(self) -> float:
        """``stuck_s`` or, if not given, :data:`DEFAULT_IMU_STUCK_S` (0: off)."""
        return self.stuck_s if self.stuck_s is not None else DEFAULT_IMU_STUCK_S

    @property
    def channel_stuck_limit_s(self) -> float:
        """``channel_stuck_s`` or, if not given, :data:`CHANNEL_STUCK_FACTOR` ×
        :attr:`stuck_limit_s` (0: off, also when ``stuck_s = 0`` turns the frozen check off)."""
        if self.channel_stuck_s is not None:
            return self.channel_stuck_s
        return CHANNEL_STUCK_FACTOR * self.stuck_limit_s

    @property
    def saturation_limit(self) -> int:
        """``saturation_rows`` or, if not given, :data:`DEFAULT_SATURATION_ROWS` (0: off)."""
        return self.saturation_rows if self.saturation_rows is not None else DEFAULT_SATURATION_ROWS

    @property
    def restamp_jitter(self) -> bool:
        """``restamp`` or, if not given, true."""
        return self.restamp is not False

    @property
    def gap_limit_s(self) -> float:
        """``max_gap_s`` or, if not given, 5 nominal periods."""
        return self.max_gap_s if self.max_gap_s is not None else DEFAULT_GAP_PERIODS / self.rate_hz


def _check_table_file(v: str) -> str:
    """A table's file: a relative path inside the mission folder with a known extension (the
    loader also checks where symbolic links lead: :func:`adaptnav.mission.loader.load_mission`)."""
    if not v.strip():
        raise ValueError("file name is empty")
    path = Path(v)
    if path.is_absolute() or PureWindowsPath(v).drive:
        raise ValueError(
            f"{v!r} is an absolute path; give the table's path relative to the mission folder "
            "(tables live inside it)"
        )
    if ".." in path.parts or ".." in PureWindowsPath(v).parts:
        raise ValueError(
            f"{v!r} leads out of the mission folder ('..'); tables live inside it (copy the file "
            "in)"
        )
    if Path(v).suffix.lower() not in TABLE_SUFFIXES:
        raise ValueError(
            f"{v!r}: unknown table format {Path(v).suffix!r} (use {', '.join(TABLE_SUFFIXES)})"
        )
    return v


PRIOR_SIGMA_MAX = {
    Kind.RATIO: 0.5,
    Kind.ANGLE: math.radians(30.0),
    Kind.LENGTH: 100.0,
    Kind.SPEED: 1.0,
    Kind.TIME: 1.0,
}
"""Largest prior σ of a calibration state, by its unit kind (SI): 50 % of scale, 30° of
misalignment or tilt bias, 100 m of depth or GNSS bias, 1 m/s of DVL bias, 1 s of latency. The
states' models are linear in small errors; a prior far beyond these lets the filter put a
wrong rotation into three angles near 180° with tight σ (a misalignment prior of 1000° did,
up to 0.4.5)."""


class CalibrationConfig(_Model):
    """``[sensors.<name>.calibration.<quantity>]``: the prior σ and the random-walk density of
    an estimated calibration quantity, ``[value, "unit"]`` (docs/calibration.md); each left
    out takes the kind's default (sensors/calibration.py). Or, instead of a random walk, a
    correlation time ``tau``: the quantity is then a first-order Gauss-Markov process whose σ,
    at the start and ever after, is ``sigma`` (docs/calibration.md, 'Gauss-Markov states')."""

    sigma: Pair | None = None
    random_walk: Pair | None = None
    tau: Pair | None = None


class SensorConfig(_Model):
    """``[sensors.<name>]``: one aiding sensor; ``kind`` picks the model (adaptnav.sensors)."""

    kind: str
    """The sensor kind (adaptnav.sensors.registry), e.g. ``dvl``."""
    file: str
    sigma: VecPair
    rate_hz: Rate | None = None
    """Nominal rate; None → from the median interval of the table."""
    lever_arm_m: Vec3 | None = None
    mounting_rpy_deg: Vec3 | None = None
    """ZYX roll, pitch, yaw (deg) of C_bs, sensor → body; the model's C_sb is its transpose."""
    use: Literal["aid", "init", "off"] = "aid"
    gate_q: Positive | None = None
    vb_rho: Annotated[float, Field(gt=0, le=1)] | None = None
    matching_window: Annotated[int, Field(ge=1, le=MAX_MATCHING_WINDOW)] | None = None
    guard_probability: Annotated[float, Field(ge=0, lt=1)] | None = None
    """This sensor's guard p (gate.Guard, docs/robustness.md); 0: no guard on it; None: the
    filter's ``guard_probability``."""
    use_height: StrictBool | None = None
    """GNSS only (false is accepted and ignored elsewhere); None → false (marine: the height
    comes from the depth sensor)."""
    optional: StrictBool = False
    model: Literal["pendulum", "attitude"] | None = None
    """Inclinometer only: ``pendulum`` (it reads the tilt of the apparent gravity, the specific
    force; the default) or ``attitude`` (it reads the attitude's roll and pitch, white noise):
    docs/inclinometer.md."""
    surface_h_m: float | Literal["auto"] | None = None
    """Depth meter only: the height (m) of the water surface, where it reads zero, in the frame
    of the navigation's heights. None: 0 (heights measured from the surface, as the simulator's
    and the A-KIT reference's are). With GNSS heights, which are ellipsoidal, the sea surface
    lies near the geoid, tens of metres off: give its height, or ``"auto"`` to take it from the
    GNSS heights and the depth readings over the static alignment window (docs/filters.md,
    'Depth and the water surface')."""
    zero_is_lost: StrictBool = False
    """DVL only: a reading of exactly zero on every axis is a lost bottom lock (drivers that
    report the loss so), dropped at load with that reason. Not for a vehicle that can sit
    still on the bottom."""
    status_column: str | None = None
    """DVL only: the table's column holding the DVL's own bottom-lock flag (1 or true: locked,
    0 or false: lost), as DVL drivers report it; a reading flagged lost is dropped at load
    with that reason."""
    spike_mads: NonNegative | None = None
    """DVL only: drop at load, as an isolated spike, a reading with a component more than this
    many scaled median absolute deviations (at least the nominal σ) from the median of it and
    its neighbours (a Hampel test, :func:`adaptnav.mission.screening.spike_mask`;
    docs/robustness.md, 'Spikes'). None or 0: off, the default; 10 is the value measured."""
    after_gap_s: NonNegative | None = None
    """DVL only: after a gap of at least this many seconds between its readings, judge the
    first readings by the same Hampel test against the readings after them (10 MADs,
    :func:`adaptnav.mission.screening.after_gap_mask`), and drop a spike at load: after a
    long gap the filter's own velocity is too uncertain to tell it from the drift
    (docs/robustness.md, 'After a gap'). None: 10 s (``DVL_AFTER_GAP_S``); 0: off."""
    scale_check: StrictBool | None = None
    """DVL, depth meter and GNSS: compare the readings' scale with the other sensors' at load
    (a depth's changes with the DVL's vertical velocity on a vehicle that dives, a DVL's speed
    and direction with a GNSS track and a heading sensor) and refuse one clearly off (knots,
    feet, kPa, an axis negated or swapped; since 0.4.10) or, false, do not; on a depth meter
    also the warning when its readings at a GNSS receiver's fixes put the antenna under water
    (since 0.4.11, 'A depth offset at the surface'); on a DVL also the warning of its direction
    a few degrees off a GNSS course, on a GNSS receiver the check of its track mirrored against
    the DVL's dead reckoning (since 0.4.13, 'A heading a few degrees off the GNSS course', 'A
    GNSS track mirrored'); None → true (docs/robustness.md, 'DVL and depth scales')."""
    declination_deg: Annotated[float, Field(ge=-90.0, le=90.0, allow_inf_nan=False)] | None = None
    """Heading sensor only: the magnetic declination (deg, east positive: magnetic north lies
    east of true north) of a magnetic compass, whose readings are then magnetic headings; each
    is turned into true north at load (and by a stream) as ``ψ = wrap(ψ_mag + D)``, exact at
    any tilt (a turn of the navigation frame about its down axis changes the yaw alone). None
    or 0: the readings are true headings. docs/data-format.md, 'Magnetic headings'."""
    limits: tuple[float, float] | dict[str, tuple[float, float]] | None = None
    """Plausible range of a reading, in the SI unit of its column: ``[min, max]`` for every
    component, or ``{ column = [min, max] }`` per column; the rest from
    :data:`SENSOR_LIMITS`. A reading outside is dropped at load (ledger: "implausible");
    a column with every value outside is an error (wrong units). docs/robustness.md."""
    stuck_s: NonNegative | None = None
    """Shortest time (s) a reading must stay unchanged, within :attr:`resolution`, to be
    taken as stuck (a frozen sensor or driver): the readings of such a run after its first are
    dropped at load (ledger: "stuck"). 0: no detection; None: the kind's default,
    :data:`STUCK_DEFAULTS`. docs/robustness.md."""
    latency_s: Annotated[float, Field(ge=-60.0, le=60.0, allow_inf_nan=False)] | None = None
    """How much older a reading is than its stamp (s): a DVL's ping-to-output delay, a GNSS
    receiver's position latency, a logger that stamps on arrival. The readings are taken at
    ``t_s - latency_s`` (at load, before any screening: the ledger's times are those; a stream
    holds the IMU back by the largest latency so that a reading still to come is never late).
    None or 0: as stamped. docs/data-format.md, 'Latency'."""
    min_interval_s: NonNegative | None = None
    """Shortest time (s) between two readings kept: a reading less than this after the last
    one kept is dropped at load (ledger: "thinned"). For readings whose errors are correlated
    over about this time (a GNSS receiver's multipath and atmosphere: a minute or two), which
    the filter takes as independent and so would trust far too much when many come in a row.
    None or 0: off. docs/robustness.md, 'Correlated readings'."""
    estimate: tuple[str, ...] | None = None
    """Calibration quantities to estimate as states of the filter (docs/calibration.md): of the
    DVL ``scale`` and ``misalignment``, of the depth meter and the inclinometer ``bias``;
    None: none."""
    calibration: dict[str, CalibrationConfig] | None = None
    """Per estimated quantity, its prior σ and random walk (defaults: the kind's)."""
    resolution: NonNegative | dict[str, NonNegative] | None = None
    """How far, in the SI unit of its column, a component may move from the run's first
    reading and still count as unchanged for :attr:`stuck_s`: one value for every component, or
    ``{ column = value }`` per column; the rest from :data:`STUCK_DEFAULTS`."""

    @field_validator("kind")
    @classmethod
    def _check_kind(cls, v: str) -> str:
        if v not in KINDS:
            raise ValueError(f"{v!r} is not a sensor kind (use {', '.join(SENSOR_KINDS)})")
        return v

    @field_validator("file")
    @classmethod
    def _check_file(cls, v: str) -> str:
        return _check_table_file(v)

    @field_validator("sigma")
    @classmethod
    def _check_sigma(cls, v: VecPair, info: ValidationInfo) -> VecPair:
        kind = info.data.get("kind")
        if kind is None:
            return v  # the kind error is reported on its own
        si = np.atleast_1d(_pair_si(v, KINDS[kind].sigma_kind, "sigma"))
        if not np.all(si > 0.0):
            raise UnitError(f"sigma: value {v[0]!r} must be > 0")
        for x in si:
            check_sigma("sigma", float(x), si_unit(KINDS[kind].sigma_kind))
        dims = KINDS[kind].dims()  # optional components: checked with the option below
        if si.size not in (1, *dims):
            raise UnitError(f"sigma: {si.size} values given, {kind} has {dims[-1]} components")
        return v

    @field_validator("surface_h_m")
    @classmethod
    def _check_surface(cls, v: float | str | None) -> float | str | None:
        lo, hi = SURFACE_H_RANGE_M
        if isinstance(v, float) and not lo <= v <= hi:
            raise ValueError(
                f"value {v!r} must be within [{lo:g}, {hi:g}] m (the geoid lies within ±110 m "
                "of the ellipsoid; a lake's surface at its altitude)"
            )
        return v

    @field_validator("limits")
    @classmethod
    def _check_limits(
        cls, v: tuple[float, float] | dict[str, tuple[float, float]] | None, info: ValidationInfo
    ) -> tuple[float, float] | dict[str, tuple[float, float]] | None:
        if v is None:
            return v
        pairs = v if isinstance(v, dict) else {"": v}
        kind = info.data.get("kind")
        for column, (lo, hi) in pairs.items():
            at = f"limits.{column}" if column else "limits"
            if math.isnan(lo) or math.isnan(hi) or not lo < hi:
                raise ValueError(f"{at}: [{lo!r}, {hi!r}] must be [min, max] with min < max")
            if column and kind is not None and column not in KINDS[kind].columns:
                raise ValueError(
                    f"{at}: not a column of a {kind} sensor ({', '.join(KINDS[kind].columns)})"
                )
        return v

    @field_validator("resolution")
    @classmethod
    def _check_resolution(
        cls, v: float | dict[str, float] | None, info: ValidationInfo
    ) -> float | dict[str, float] | None:
        kind = info.data.get("kind")
        if isinstance(v, dict) and kind is not None:
            for column in v:
                if column not in KINDS[kind].columns:
                    raise ValueError(
                        f"resolution.{column}: not a column of a {kind} sensor "
                        f"({', '.join(KINDS[kind].columns)})"
                    )
        return v

    @model_validator(mode="after")
    def _check_kind_fields(self) -> SensorConfig:
        kind = KINDS[self.kind]
        for option in sorted(_OPTIONS - kind.options):
            if getattr(self, option) not in (None, False):
                having = [k for k, v in KINDS.items() if option in v.options]
                raise ValueError(
                    f"{option}: only for {' or '.join(having)} sensors, not a {self.kind}"
                )
        if kind.optional_columns:
            s = np.atleast_1d(_pair_si(self.sigma, kind.sigma_kind, "sigma"))
            if s.size not in (1, self.dim):
                raise ValueError(
                    f"sigma: {s.size} values given, {self.kind} with use_height = "
                    f"{str(bool(self.use_height)).lower()} has {self.dim} components"
                )
        self._check_calibration()
        if not kind.lever_arm and self.lever_arm_m not in (None, (0.0, 0.0, 0.0)):
            raise ValueError(f"lever_arm_m: a {self.kind} sensor has no lever arm (leave it out)")
        if not kind.mounting and self.mounting_rpy_deg not in (None, (0.0, 0.0, 0.0)):
            raise ValueError(
                f"mounting_rpy_deg: a {self.kind} sensor has no mounting rotation (leave it out)"
            )
        if self.mounting_rpy_deg is not None:
            check_euler_deg("mounting_rpy_deg", self.mounting_rpy_deg)
        if self.use == "init" and self.kind not in INIT_KINDS:
            raise ValueError(
                f"use: 'init' is for a GNSS (the position the alignment takes) or a heading "
                f"sensor (its heading), not a {self.kind} ('aid' to use its readings, 'off' to "
                "leave it out)"
            )
        return self

    def _check_calibration(self) -> None:
        known = KINDS[self.kind].calibration
        estimate = self.estimate or ()
        if estimate and self.use == "init":  # "off" keeps them for when it is on again
            raise ValueError(
                f"estimate: {list(estimate)} on a sensor with use = 'init': only a sensor that "
                "aids the filter has calibration states (up to 0.4.5 they were dropped without "
                "a word); drop estimate, or use = 'aid'"
            )
        for name in estimate:
            if name not in known:
                can = ", ".join(known) or "nothing"
                raise ValueError(f"estimate: a {self.kind} sensor cannot estimate {name!r} ({can})")
        if len(set(estimate)) != len(estimate):
            raise ValueError(f"estimate: {list(estimate)} names a quantity twice")
        for name in self.calibration or {}:
            if name not in estimate:
                raise ValueError(f"calibration.{name}: not in estimate = {list(estimate)}")
        for name, given in (self.calibration or {}).items():
            if given.tau is not None and given.random_walk is not None:
                raise ValueError(
                    f"calibration.{name}: give random_walk or tau (a Gauss-Markov process whose "
                    "σ is sigma), not both"
                )
        for name, spec in self.calibration_si().items():
            if not spec[0] > 0.0:
                raise ValueError(f"calibration.{name}.sigma: must be > 0")
            if not spec[2] > 0.0:
                raise ValueError(f"calibration.{name}.tau: must be > 0 (inf: a random walk)")
            kind = KINDS[self.kind].calibration[name].sigma_kind
            check_sigma(f"calibration.{name}.sigma", spec[0], si_unit(kind))
            if spec[0] > PRIOR_SIGMA_MAX[kind]:
                raise ValueError(
                    f"calibration.{name}.sigma: {spec[0]:g} {si_unit(kind)} is above "
                    f"{PRIOR_SIGMA_MAX[kind]:g} {si_unit(kind)}, the largest prior σ the state's "
                    "small-error model takes (docs/calibration.md, 'The states')"
                )
            # As a σ: beyond 1e7 SI a random walk is a wrong unit (up to 0.4.4 a scale's
            # 1e9 /√s was taken, and the run ended 1400 km off with exit 0).
            unit = si_unit(KINDS[self.kind].calibration[name].random_walk_kind)
            check_sigma(f"calibration.{name}.random_walk", spec[1], unit, zero_ok=True)

    def calibration_si(self) -> dict[str, tuple[float, float, float]]:
        """Prior σ, random-walk density and correlation time (SI; inf: none, a random walk) of
        each estimated quantity, by name."""
        out = {}
        for name in self.estimate or ():
            q = KINDS[self.kind].calibration[name]
            given = (self.calibration or {}).get(name, CalibrationConfig())
            at = f"calibration.{name}"
            sigma = (
                q.sigma
                if given.sigma is None
                else _pair_si(given.sigma, q.sigma_kind, f"{at}.sigma")
            )
            rw = (
                q.random_walk
                if given.random_walk is None
                else _pair_si(given.random_walk, q.random_walk_kind, f"{at}.random_walk")
            )
            tau = math.inf if given.tau is None else _pair_si(given.tau, Kind.TIME, f"{at}.tau")
            out[name] = (float(sigma), float(rw), float(tau))
        return out

    def declination_rad(self) -> float:
        """``declination_deg`` in radians (0 when not given)."""
        return math.radians(self.declination_deg or 0.0)

    def surface_h(self) -> float:
        """The depth meter's water-surface height (m): 0 when not given; an error while it is
        still ``"auto"`` (the runner measures it first: api/runner.py, ``resolve_surfaces``)."""
        if self.surface_h_m == "auto":
            raise ValueError('surface_h_m = "auto" has not been measured yet')
        return 0.0 if self.surface_h_m is None else float(self.surface_h_m)

    @property
    def dim(self) -> int:
        """Number of measurement components."""
        return KINDS[self.kind].dim(bool(self.use_height))

    @property
    def columns(self) -> tuple[str, ...]:
        """The table's measurement columns (SI names), after ``t_s``."""
        cols = KINDS[self.kind].columns
        return cols[: self.dim]

    def limits_si(self) -> Array:
        """``[min, max]`` (d, 2) of each measurement column (:attr:`columns`), SI units: the
        configured ``limits``, else :data:`SENSOR_LIMITS` of the kind."""
        default = KINDS[self.kind].limits
        out = np.array([default[c] for c in self.columns], dtype=float)
        if isinstance(self.limits, dict):
            for i, c in enumerate(self.columns):
                if c in self.limits:
                    out[i] = self.limits[c]
        elif self.limits is not None:
            out[:] = self.limits
        return out

    def after_gap_duration_s(self) -> float:
        """Gap (s) after which a DVL's first readings are screened: ``after_gap_s``, else
        :data:`adaptnav.sensors.dvl.DVL_AFTER_GAP_S`; 0 (off) for every other kind."""
        if self.kind != "dvl":
            return 0.0
        return DVL_AFTER_GAP_S if self.after_gap_s is None else self.after_gap_s

    def stuck_duration_s(self) -> float:
        """Minimum duration (s) of a stuck run: ``stuck_s``, else the kind's default
        (:data:`STUCK_DEFAULTS`); 0 means no detection."""
        return KINDS[self.kind].stuck.stuck_s if self.stuck_s is None else self.stuck_s

    def resolution_si(self) -> Array:
        """Resolution (d,) of each measurement column (:attr:`columns`), SI units: the
        configured ``resolution``, else :data:`STUCK_DEFAULTS` of the kind."""
        default = KINDS[self.kind].stuck.resolution
        out = np.array([default[c] for c in self.columns], dtype=float)
        if isinstance(self.resolution, dict):
            for i, c in enumerate(self.columns):
                if c in self.resolution:
                    out[i] = self.resolution[c]
        elif self.resolution is not None:
            out[:] = self.resolution
        return out

    def sigma_si(self) -> float | Array:
        """σ in SI units (m/s, m, rad): a scalar or one value per component."""
        s = _pair_si(self.sigma, KINDS[self.kind].sigma_kind, "sigma")
        return float(s) if np.ndim(s) == 0 else np.asarray(s, dtype=float)

    def lever_arm(self) -> Array:
        """l_b, body FRD (m); zero if not given."""
        return np.array(self.lever_arm_m if self.lever_arm_m is not None else (0.0, 0.0, 0.0))

    @property
    def check_scale(self) -> bool:
        """``scale_check`` or, if not given, true."""
        return self.scale_check is not False

    def sensor_from_body(self) -> Array:
        """C_sb = C_bsᵀ with ``C_bs = euler_to_dcm(mounting_rpy_deg)`` (identity if not given)."""
        if self.mounting_rpy_deg is None:
            return np.eye(3)
        r, p, y = (a * DEG for a in self.mounting_rpy_deg)
        return np.asarray(euler_to_dcm(r, p, y).T, dtype=float)

    def overrides(self) -> SensorOverrides:
        """Per-sensor filter overrides (gate q, VB ρ, matching window)."""
        return SensorOverrides(
            self.gate_q, self.vb_rho, self.matching_window, self.guard_probability
        )


class InitialConfig(_Model):
    """``[initial]``: alignment (static window at the start) or an explicit state
    (docs/alignment.md)."""

    mode: Literal["alignment", "state"] = "alignment"
    alignment_s: Positive = 600.0
    lat_deg: Latitude | None = None
    lon_deg: Annotated[float, Field(ge=-180, le=360, allow_inf_nan=False)] | None = None
    h_m: Annotated[float, Field(ge=H_RANGE_M[0], le=H_RANGE_M[1], allow_inf_nan=False)] = 0.0
    v_ned_m_s: Vec3 = (0.0, 0.0, 0.0)
    rpy_deg: Vec3 | None = None
    sigma_position_m: Sigma = 5.0
    sigma_velocity_m_s: Sigma = 0.1
    sigma_attitude_deg: SigmaDeg | tuple[SigmaDeg, SigmaDeg, SigmaDeg] = (0.1, 0.1, 1.0)

    @model_validator(mode="after")
    def _check_state_mode(self) -> InitialConfig:
        if self.rpy_deg is not None:
            check_euler_deg("rpy_deg", self.rpy_deg)
        if self.mode == "alignment" and any(v != 0.0 for v in self.v_ned_m_s):
            raise ValueError(
                f"v_ned_m_s: {list(self.v_ned_m_s)} with mode = 'alignment', which starts at "
                "rest (v = 0): a velocity is taken with mode = 'state' only"
            )
        if self.mode == "state":
            default = type(self).model_fields["alignment_s"].default
            if self.alignment_s != default:  # the default is what write_config writes
                raise ValueError(
                    f"alignment_s: {self.alignment_s:g} s with mode = 'state', which starts from "
                    "the given state with no alignment window: it would be ignored (drop it, "
                    "or align with mode = 'alignment')"
                )
            missing = [k for k in ("lat_deg", "lon_deg", "rpy_deg") if getattr(self, k) is None]
            if missing:
                raise ValueError(f"{missing[0]}: required when mode = 'state' (missing {missing})")
        return self

    def sigma_attitude_rad(self) -> Array:
        """Initial attitude σ [roll, pitch, yaw] (rad)."""
        return np.broadcast_to(np.asarray(self.sigma_attitude_deg, dtype=float) * DEG, (3,)).copy()


class FilterConfig(FilterSettings):
    """``[filter]``: the filter's settings (:class:`adaptnav.estimation.settings.FilterSettings`,
    where each field is declared, constrained and defaulted once) and five of the engine's:
    output rate, epoch policy, the specific-force low-pass, the covariance blocks and the reset."""

    epoch_policy: Literal["exact", "grid"] = "exact"
    output_rate_hz: Positive = 10.0
    specific_force_tau_s: Annotated[float, Field(ge=0, le=60, allow_inf_nan=False)] | None = None
    """Time constant (s) of the low-pass on the specific force that F is evaluated with; None:
    the engine's default (``adaptnav.engine.batch.EngineConfig``; docs/error-model.md). At most
    60 s (up to 0.4.4 inf was taken: F kept the first step's specific force all run)."""
    covariance_block_s: Annotated[float, Field(ge=0, le=1)] | None = None
    """Span (s) of the blocks of IMU steps P is propagated over (0: every step); None: the
    engine's default (``adaptnav.engine.batch.EngineConfig``; docs/filters.md, 'Covariance
    blocks')."""
    invariant_reset: StrictBool | None = None
    """Carry the velocity error in the attitude error's frame across each feedback (the reset's
    velocity-attitude term); false: the attitude block's reset only, as up to 0.3.10; None: the
    engine's default, true (docs/filters.md, 'Feedback and reset')."""

    @field_validator("kind")
    @classmethod
    def _runnable_kind(cls, v: str) -> str:
        # The oracle needs the simulator's truth; it is a baseline, not a mission's filter.
        if v == "oracle":
            raise ValueError("'oracle' is a baseline (adaptnav compare), not a mission's filter")
        return v

    def settings(self, gate_sensors: tuple[str, ...]) -> FilterSettings:
        """The filter's settings alone, the gated sensors resolved to names."""
        fields = {k: getattr(self, k) for k in FilterSettings.model_fields}
        return FilterSettings(**{**fields, "gate_sensors": gate_sensors})


class TruthConfig(_Model):
    """``[truth]``: optional reference trajectory table."""

    file: str | None = None

    @field_validator("file")
    @classmethod
    def _check_file(cls, v: str | None) -> str | None:
        return None if v is None else _check_table_file(v)


class MissionConfig(_Model):
    """The whole ``mission.toml``."""

    mission: MissionSection
    imu: ImuConfig
    sensors: dict[str, SensorConfig] = Field(default_factory=dict)
    initial: InitialConfig = InitialConfig()
    filter: FilterConfig = FilterConfig()
    truth: TruthConfig = TruthConfig()

    @field_validator("sensors")
    @classmethod
    def _check_names(cls, v: dict[str, SensorConfig]) -> dict[str, SensorConfig]:
        for name in v:
            problem = sensor_name_problem(name)
            if problem is not None:
                raise ValueError(problem)
        return v

    @model_validator(mode="after")
    def _check_cross(self) -> MissionConfig:
        if self.filter.gate_sensors is not None:
            unknown = [s for s in self.filter.gate_sensors if s not in self.sensors]
            if unknown:
                raise ValueError(
                    f"filter.gate_sensors: {unknown} name no sensor (configured: "
                    f"{list(self.sensors)})"
                )
        if not 1.0 <= self.filter.output_rate_hz <= self.imu.rate_hz:
            raise ValueError(
                f"filter.output_rate_hz: {self.filter.output_rate_hz:g} Hz, between 1 Hz and the "
                f"IMU's {self.imu.rate_hz:g} Hz (a row per IMU interval at most; fewer than one a "
                "second leaves evaluate to score straight lines between them)"
            )
        self._check_output_rate()
        self._check_init_sensors()
        seen: dict[tuple[str, str], str] = {}
        for name, sc in self.sensors.items():
            if sc.use == "off":
                continue
            other = seen.setdefault((sc.kind, sc.file), name)
            if other != name:  # a kind reads fixed columns: the same readings, counted twice
                raise ValueError(
                    f"sensors.{name}: reads {sc.file} as sensors.{other} does, both {sc.kind}: "
                    "each reading would be used twice and the filter overconfident (one "
                    "section per sensor; 'off' to keep a second one aside)"
                )
        if self.initial.mode == "alignment" and self.imu.initial_bias.given():
            raise ValueError(
                "imu.initial_bias: used with initial.mode = 'state' only (an alignment estimates "
                "the biases)"
            )
        if self.initial.mode == "alignment" and not any(
            s.kind == "gnss" and s.use != "off" for s in self.sensors.values()
        ):
            missing = [k for k in ("lat_deg", "lon_deg") if getattr(self.initial, k) is None]
            if missing:
                raise ValueError(
                    f"initial.{missing[0]}: required for alignment without a GNSS sensor, as the "
                    f"position to align at (missing {missing})"
                )
        self._check_half_position()
        return self

    def _check_half_position(self) -> None:
        """``initial.lat_deg`` without ``lon_deg`` (or the reverse) is no position: a static
        alignment with a GNSS took the fixes' and ignored the one given, without a word (up to
        0.4.8)."""
        given = [k for k in ("lat_deg", "lon_deg") if getattr(self.initial, k) is not None]
        if len(given) == 1:
            other = "lon_deg" if given[0] == "lat_deg" else "lat_deg"
            raise ValueError(
                f"initial.{other}: missing beside initial.{given[0]}: a start position is both "
                "(give both, or neither to align at the GNSS fixes)"
            )

    def gated_sensors(self) -> tuple[str, ...]:
        """Names of the gated sensors (``filter.gate_sensors``, default: every dvl)."""
        if self.filter.gate_sensors is not None:
            return self.filter.gate_sensors
        return tuple(n for n, s in self.sensors.items() if s.kind == "dvl")

    def first_sensor(self, kind: str) -> str | None:
        """The first sensor of ``kind`` not off, or None: the one a static alignment takes its
        position (a GNSS) or heading (a heading sensor) from (docs/alignment.md)."""
        return next((n for n, s in self.sensors.items() if s.kind == kind and s.use != "off"), None)

    def filter_settings(self) -> FilterSettings:
        """The engine's :class:`adaptnav.estimation.settings.FilterSettings` of ``[filter]``."""
        return self.filter.settings(self.gated_sensors())

    def _check_init_sensors(self) -> None:
        """A sensor with ``use = "init"`` must be one the start takes something from: not with
        ``initial.mode = "state"``; a heading sensor only as the first heading sensor not off
        and without a configured heading (``rpy_deg``), which would be taken instead
        (docs/alignment.md, 'Heading source')."""
        init = [n for n, c in self.sensors.items() if c.use == "init"]
        if init and self.initial.mode == "state":
            raise ValueError(
                f"sensors.{init[0]}.use: 'init' with initial.mode = 'state', which starts "
                "from [initial] alone: nothing would use it ('aid' or 'off')"
            )
        first = self.first_sensor("heading")
        for name in (n for n in init if self.sensors[n].kind == "heading"):
            if self.initial.rpy_deg is not None:
                raise ValueError(
                    f"sensors.{name}.use: 'init' gives the alignment its heading, and so does "
                    "initial.rpy_deg, which would be taken: drop one"
                )
            if name != first:
                raise ValueError(
                    f"sensors.{name}.use: 'init', but the alignment takes its heading from "
                    f"sensors.{first}, the first heading sensor not off"
                )

    def _check_output_rate(self) -> None:
        """A rate set in ``[filter]`` must be the IMU's rate over a whole number of intervals,
        to 1 %: rows come every ``output_every`` IMU intervals, so 40 Hz on a 100-Hz IMU gave
        rows at 50 Hz, silently (up to 0.4.5). The default (10 Hz) is taken as the nearest."""
        if "output_rate_hz" not in self.filter.model_fields_set:
            return
        asked, imu = self.filter.output_rate_hz, self.imu.rate_hz
        got = imu / self.output_every()
        if abs(got - asked) <= 0.01 * asked:
            return
        k = imu / asked
        near = sorted({max(1, math.floor(k)), math.ceil(k)})
        options = " or ".join(f"{imu / n:.6g} Hz (every {n})" for n in near)
        raise ValueError(
            f"filter.output_rate_hz: {asked:g} Hz is not the IMU's {imu:g} Hz over a whole number "
            f"of intervals (rows come every whole number of IMU intervals): {options}"
        )

    def output_every(self) -> int:
        """IMU intervals per output sample (``imu.rate_hz / filter.output_rate_hz``, >= 1)."""
        return max(1, round(self.imu.rate_hz / self.filter.output_rate_hz))

    def document(self) -> dict[str, Any]:
        """This configuration as plain data, as ``mission.toml`` holds it. ``[filter]`` holds
        only the keys that were given: a setting left out follows the library's default
        (estimation/settings.py), also in a mission written by the simulator or an importer."""
        doc: dict[str, Any] = self.model_dump(mode="python", exclude_none=True)
        doc["filter"] = self.filter.model_dump(mode="python", exclude_none=True, exclude_unset=True)
        return doc

    def dump_toml(self) -> str:
        """This configuration as TOML text (``load_config`` reads it back equal)."""
        return dumps_toml(self.document())


# --- reading and writing --------------------------------------------------------------------


def _loc(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _is_union_tag(part: int | str) -> bool:
    """Union members add their type to an error's path ("value.float"); not a key."""
    return isinstance(part, str) and (
        part in ("float", "str", "int", "bool")
        or "[" in part
        or part.startswith(("constrained-", "function-"))
    )


_PREFIX = re.compile(r"^([A-Za-z_][A-Za-z0-9_.]*): (.*)$", re.DOTALL)


def _explain(source: str, exc: ValidationError) -> MissionError:
    """One readable error (path: message) per problem; UnitError if a unit was the cause."""
    lines: list[str] = []
    unit_error = False
    first_field: str | None = None
    for err in exc.errors(include_url=False):
        loc = [p for p in err["loc"] if not _is_union_tag(p)]
        cause = err.get("ctx", {}).get("error")
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        elif err["type"] == "missing":
            msg = "missing required key"
        elif isinstance(cause, BaseException):
            msg = str(cause)
            unit_error = unit_error or isinstance(cause, UnitError)
            # Validators name their key first ("sigma: ..."): fold it into the path.
            m = _PREFIX.match(msg)
            if m:
                keys = m.group(1).split(".")
                if loc and keys[0] == loc[-1]:
                    keys = keys[1:]
                loc = [*loc, *keys]
                msg = m.group(2)
        else:
            msg = err["msg"]
            if not isinstance(err.get("input"), dict):
                msg += f" (got {err.get('input')!r})"
        path = _loc(tuple(loc))
        first_field = first_field or path or None
        lines.append(f"{path}: {msg}" if path else msg)
    # A union reports each member's failure; keep distinct lines only.
    uniq = list(dict.fromkeys(lines))
    text = f"{source}: " + ("; ".join(uniq) if len(uniq) <= 1 else "\n  " + "\n  ".join(uniq))
    cls = MissionUnitError if unit_error else MissionError
    return cls(text, file=source, field=first_field)


def parse_config(data: Mapping[str, Any], source: str = "mission.toml") -> MissionConfig:
    """Validate a parsed TOML document; errors become :class:`MissionError` naming key paths."""
    try:
        return MissionConfig.model_validate(dict(data))
    except ValidationError as exc:
        raise _explain(source, exc) from None


def parse_sensor(name: str, doc: Mapping[str, Any], source: str) -> SensorConfig:
    """Validate one ``[sensors.<name>]`` section (an importer's, before it writes anything);
    errors become :class:`MissionError` naming ``source``, the section and its keys."""
    problem = sensor_name_problem(name)
    if problem is not None:
        raise MissionError(f"{source}: {problem}", file=source)
    try:
        return SensorConfig.model_validate(dict(doc))
    except ValidationError as exc:
        raise _explain(f"{source} [sensors.{name}]", exc) from None


def with_overrides(
    config: MissionConfig, overrides: Iterable[tuple[str, Any]], source: str = "overrides"
) -> MissionConfig:
    """``config`` with each ``(dotted.path, value)`` set (e.g. ``("filter.vb_rho", 0.95)``,
    ``("sensors.inclinometer.model", "attitude")``), validated again as a whole; a path through
    a key that does not exist is a :class:`MissionError`."""
    doc = config.document()
    for path, value in overrides:
        *parents, leaf = path.split(".")
        node = doc
        for key in parents:
            child = node.get(key)
            if not isinstance(child, dict):
                raise MissionError(f"{source}: {path}: no section {key!r}")
            node = child
        node[leaf] = value
    return parse_config(doc, source)


def load_config(path: str | Path) -> MissionConfig:
    """Read and validate ``mission.toml`` (tomllib)."""
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise MissionError(f"{p}: file not found", file=str(p)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MissionError(f"{p}: cannot read as UTF-8 text: {exc}", file=str(p)) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MissionError(f"{p}: invalid TOML: {exc}", file=str(p)) from None
    return parse_config(data, str(p))


def write_config(config: MissionConfig, path: str | Path) -> Path:
    """Write ``config`` as TOML to ``path``; returns the path."""
    p = Path(path)
    p.write_text(config.dump_toml(), encoding="utf-8")
    return p


# --- a small TOML writer (tomli-w is not a dependency) ------------------------------------------

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE_KEY.match(k) else json.dumps(k, ensure_ascii=False)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(str(k))} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} as TOML: {v!r}")


def _is_table(v: Any) -> bool:
    """Dicts holding dicts or arrays become [sections]; flat dicts are inline tables."""
    return isinstance(v, dict) and any(isinstance(x, dict | list | tuple) for x in v.values())


def dumps_toml(doc: Mapping[str, Any]) -> str:
    """TOML text of nested dicts of str, int, float (inf/nan), bool, lists and tuples."""
    out: list[str] = []

    def emit(prefix: str, table: Mapping[str, Any], top: bool) -> None:
        subtables = []
        body = []
        for k, v in table.items():
            if isinstance(v, dict) and (top or _is_table(v)):
                subtables.append((k, v))
            else:
                body.append(f"{_key(k)} = {_value(v)}")
        if prefix and (body or not subtables):
            out.append(f"[{prefix}]")
        out.extend(body)
        if prefix and (body or not subtables):
            out.append("")
        for k, v in subtables:
            emit(f"{prefix}.{_key(k)}" if prefix else _key(k), v, top=False)

    emit("", doc, top=True)
    return "\n".join(out).rstrip("\n") + "\n"
