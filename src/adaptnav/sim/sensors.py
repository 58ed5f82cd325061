"""Aiding sensors of the simulator: clean readings by the filter's own models, then disturbances.

Every clean reading is the error-free reading its kind declares, ``ideal_reading`` in
``sensors/<kind>.py`` (:func:`ideal`), which is the filter's ``predict`` at the true state, so
the simulator and the filter share one convention for every frame, lever arm and angle. What is
added on top (docs/simulation.md, 'What makes adaptation matter'):

DVL (3 Hz), per axis of the DVL frame::

    z = h_dvl(x_true, ω_ib) + k(t) σ(v) n + spike,      σ(v) = 0.02 |v_dvl| + 0.002 m/s

* nominal noise σ(v): the paper's Table 2 "2% ± 2 mm/s (1σ)", read as 2% of the speed plus
  2 mm/s on each axis;
* noise segments (bottom-lock loss, aeration in waves): intervals covering ``segment_fraction``
  of the navigation time, each of 60-300 s with its own factor k ~ U(3, 10) (k = 1 elsewhere);
* outliers ("drastic and unreal changes"): exactly ``round(outlier_rate · n)`` of the n valid
  navigation samples, in events that are single samples or (``burst_fraction`` of events)
  bursts of 2-5 consecutive samples; each event picks a random non-empty set of axes and each
  of its samples adds ±U(0.5, 3) m/s on them;
* dropouts (bottom lock lost): intervals of 2-30 s covering ``dropout_fraction`` of the
  navigation time whose rows are written with **NaN** velocities (rows are kept, so the stream's
  timing stays visible and the engine records them as dropped, "invalid reading").

Depth meter (1 Hz): ``z = h_depth(x_true) + σ_d(t) n`` with the sea-state-dependent
``σ_d(t) = σ_calm + (σ_nom - σ_calm) E(t)²`` (E the sea-state level of the trajectory; pressure
fluctuations of passing waves grow with wave height), e.g. 0.1 m in harbour, 0.5 m (nominal) at
E = 1 and 1.7 m at E = 2, below the Table-2 "< 2 m". Switched off: σ_nom throughout.

Inclinometer (5 Hz) as a pendulum: it does not read the attitude but the direction of the
specific force at the IMU, ``f_b = C_nbᵀ (v̇_n - g_n + (2ω_ie + ω_en) × v_n)``::

    roll_m = atan2(-f_y, -f_z),    pitch_m = atan2(f_x, √(f_y² + f_z²)),

exact at rest (``f_b = C_nbᵀ [0, 0, -g]``), but a horizontal acceleration a tilts the apparent
vertical by ``atan(a/g)``: a level vessel accelerating forward by a reads a pitch of
``atan(a/g)``, one turning to starboard at rate χ̇ a roll of ``-atan(s χ̇/g)``. Waves (orbital
motion), turns and speed changes thus corrupt it by physics. On top, the instrument's own
white noise σ = 0.1°. The pendulum is modelled as ideal (no swing dynamics). The mission says
so (``model = "pendulum"``; ``"attitude"`` with ``inclinometer_pendulum`` off), and the filter's
pendulum model (``sensors.inclinometer.tilt``, the same function) predicts it from the IMU.

Heading sensor (gyrocompass, 1 Hz, 0.5°): the yaw of ``heading.predict``; off in the paper's
configuration (written with ``use = "off"``).

GPS (1 Hz) of the antenna (lever arm ``l_b``): white 1.5 m plus a first-order Gauss-Markov
2.5 m / 120 s per horizontal axis (total ≈ 2.9 m, i.e. < 10 m at 3σ), used only to initialise
(``use = "init"``); the true trajectory is the reference.

Clocks: each sensor starts at its own offset, ``U(0, T)`` after t = 0, and samples every period
T with a white jitter (σ a few ms, clipped at ±T/4). Stamps are the true sampling instants (no
latency), so the streams are truly asynchronous but exactly time-tagged.

Calibration errors (:class:`Calibration`; docs/simulation.md, 'Calibration errors'): the DVL's
scale factor and misalignment, ``z = s C_mis z_clean``, the depth meter's bias and the
inclinometer's roll and pitch biases, added to the angles it outputs. The truth columns stay the
error-free readings. None by default.

A registered kind without a function of its own (:class:`GenericSpec`, :func:`generic`): its
``ideal_reading`` plus white noise of the given σ, on its own clock.

What was injected is saved in each table's extra columns (the loader keeps them in
``Mission.tables`` and ignores them for the filter); ``docs/simulation.md`` lists them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from adaptnav.core import attitude, earth
from adaptnav.core.units import DEG, Kind, si_unit
from adaptnav.sensors.kind import IdealInput
from adaptnav.sensors.registry import KINDS

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class Disturbances:
    """One switch per disturbance; the default is the paper's scenario (all on but the
    uncalibrated turn-on offsets and the scale factors).

    Attributes:
        waves: wave-induced roll, pitch, yaw, heave and orbital motion (off: calm sea).
        imu_white_noise: ARW and VRW.
        imu_in_run_bias: Gauss-Markov in-run biases.
        imu_turn_on_bias: random turn-on constants (by default the residual after calibration).
        imu_uncalibrated_turn_on: apply the full Table-2 turn-on offsets (20 deg/h, 50 mg)
            instead of the calibrated residual; the mission's ``initial_bias_sigma`` follows.
        imu_scale_factor: scale-factor errors.
        sensor_noise: the nominal white noise of every aiding sensor and the GPS, and the
            error of the initial heading written to ``[initial]`` (the quay's bearing).
        dvl_noise_segments: DVL segments with σ × 3-10.
        dvl_outliers: DVL spikes (single and bursts).
        dvl_dropouts: DVL NaN rows.
        depth_sea_state: depth σ varying with the sea state (off: nominal σ).
        inclinometer_pendulum: the inclinometer reads the specific-force direction (off: the
            true roll and pitch).
        clock_offsets: each sensor starts at its own offset (off: all at one period after 0).
        clock_jitter: sampling-time jitter.
    """

    waves: bool = True
    imu_white_noise: bool = True
    imu_in_run_bias: bool = True
    imu_turn_on_bias: bool = True
    imu_uncalibrated_turn_on: bool = False
    imu_scale_factor: bool = False
    sensor_noise: bool = True
    dvl_noise_segments: bool = True
    dvl_outliers: bool = True
    dvl_dropouts: bool = True
    depth_sea_state: bool = True
    inclinometer_pendulum: bool = True
    clock_offsets: bool = True
    clock_jitter: bool = True

    @classmethod
    def clean(cls) -> Disturbances:
        """Only what the filter models: the IMU's modelled errors (white noise, in-run and
        residual turn-on biases), every sensor's nominal white noise, waves and asynchronous
        start offsets; no outliers, dropouts, σ changes, pendulum errors or jitter."""
        return cls(
            dvl_noise_segments=False,
            dvl_outliers=False,
            dvl_dropouts=False,
            depth_sea_state=False,
            inclinometer_pendulum=False,
            clock_jitter=False,
        )

    @classmethod
    def perfect(cls) -> Disturbances:
        """No error at all (exact IMU and sensor readings, regular clocks); waves kept."""
        return cls(**{f.name: f.name == "waves" for f in fields(cls)})

    def as_dict(self) -> dict[str, bool]:
        return {k: bool(v) for k, v in asdict(self).items()}


MAX_SCALE_ERROR = 0.5
"""A DVL scale factor s beyond 1 ± this is refused: such a DVL is broken, not miscalibrated
(and 101 or 0.01 for 1.01 are typos)."""
MAX_LATENCY_S = 1.0
"""A sensor latency beyond ±1 s is refused: a ping-to-output time or a logger's delay is
milliseconds to a few tenths of a second; more is a clock in the wrong unit, or a typo."""
MAX_DEPTH_BIAS_M = 100.0
"""A depth bias beyond ±100 m is refused: a wrong atmospheric pressure or zero is metres to
tens of metres (1 bar ≈ 10 m of water); a larger one is a different sensor, or a typo."""
MAX_CALIBRATION_ANGLE = 10.0 * DEG
"""A misalignment or tilt bias beyond ±10° is refused: calibration errors are small angles; a
larger rotation is a mounting, which the mission states (``mounting_rpy_deg``)."""


def _small_angles(label: str, values: Any, n: int) -> tuple[float, ...]:
    """``values`` as n finite floats within ±:data:`MAX_CALIBRATION_ANGLE` (rad)."""
    out = tuple(float(v) for v in values)
    if len(out) != n:
        raise ValueError(f"{label} needs {n} angles, got {len(out)}")
    for a in out:
        if not abs(a) <= MAX_CALIBRATION_ANGLE:  # also refuses NaN
            raise ValueError(
                f"{label} angle {math.degrees(a):g}° is beyond ±{MAX_CALIBRATION_ANGLE / DEG:g}°"
            )
    return out


@dataclass(frozen=True)
class Calibration:
    """The sensors' true calibration errors (docs/simulation.md, 'Calibration errors'); the
    default is none, with the tables of a perfectly calibrated set.

    Attributes:
        dvl_scale: s in ``z = s C_mis C_sb (C_nbᵀ v_n + ω_ib_b × l_b)``; 1.01 reads 1 % high.
        dvl_misalignment: ZYX Euler angles (roll, pitch, yaw) of the true DVL frame from the
            nominal one (rad): ``C_mis = euler_to_dcm(roll, pitch, yaw)ᵀ ≈ I - [δ×]``.
        depth_bias: b (m) in ``z = depth + b``.
        inclinometer_bias: (b_roll, b_pitch) (rad) added to the angles the inclinometer
            outputs (the pendulum's tilt, or the attitude's roll and pitch).
        dvl_latency: τ_d (s): each DVL reading, taken at its true sampling instant t, is
            stamped ``t + τ_d`` (the state ``dvl.latency`` of docs/calibration.md).
        gps_latency, heading_latency: the same for the GPS's fixes and the heading sensor's
            readings (the GNSS's and the heading's ``latency`` states).
    """

    dvl_scale: float = 1.0
    dvl_misalignment: tuple[float, float, float] = (0.0, 0.0, 0.0)
    depth_bias: float = 0.0
    inclinometer_bias: tuple[float, float] = (0.0, 0.0)
    dvl_latency: float = 0.0
    gps_latency: float = 0.0
    heading_latency: float = 0.0

    def __post_init__(self) -> None:
        s = float(self.dvl_scale)
        if not abs(s - 1.0) <= MAX_SCALE_ERROR:  # also refuses NaN
            raise ValueError(
                f"DVL scale factor {s:g} is not within 1 ± {MAX_SCALE_ERROR:g} "
                "(1.01 reads 1 % high)"
            )
        b = float(self.depth_bias)
        if not abs(b) <= MAX_DEPTH_BIAS_M:  # also refuses NaN
            raise ValueError(f"depth bias {b:g} m is beyond ±{MAX_DEPTH_BIAS_M:g} m")
        for name, label in (("dvl_latency", "DVL"), ("gps_latency", "GPS"),
                            ("heading_latency", "heading")):  # fmt: skip
            lag = float(getattr(self, name))
            if not abs(lag) <= MAX_LATENCY_S:  # also refuses NaN
                raise ValueError(f"{label} latency {lag:g} s is beyond ±{MAX_LATENCY_S:g} s")
            object.__setattr__(self, name, lag)
        object.__setattr__(self, "dvl_scale", s)
        object.__setattr__(self, "depth_bias", b)
        for name, label, n in (
            ("dvl_misalignment", "DVL misalignment", 3),
            ("inclinometer_bias", "inclinometer bias", 2),
        ):
            object.__setattr__(self, name, _small_angles(label, getattr(self, name), n))

    def dvl(self, clean: Array) -> Array:
        """The DVL's readings (N, 3) from its error-free ones z: ``s C_mis z``."""
        if any(self.dvl_misalignment):  # else C_mis = I: a product would only cost time
            # rows: (C_mis z)ᵀ = zᵀ C_misᵀ = zᵀ euler_to_dcm(δ)
            clean = clean @ attitude.euler_to_dcm(*self.dvl_misalignment)
        return self.dvl_scale * clean

    def as_dict(self) -> dict[str, Any]:
        """``simulation.json``'s ``calibration``: the true values, angles in rad and degrees."""
        return {
            "convention": "docs/simulation.md, 'Calibration errors'",
            "dvl_scale_factor": self.dvl_scale,
            "dvl_misalignment_rad": list(self.dvl_misalignment),
            "dvl_misalignment_deg": [math.degrees(a) for a in self.dvl_misalignment],
            "depth_bias_m": self.depth_bias,
            "inclinometer_bias_rad": list(self.inclinometer_bias),
            "inclinometer_bias_deg": [math.degrees(a) for a in self.inclinometer_bias],
            "dvl_latency_s": self.dvl_latency,
            "gps_latency_s": self.gps_latency,
            "heading_latency_s": self.heading_latency,
        }


NO_CALIBRATION = Calibration()
"""No calibration error."""


# --- specifications ---------------------------------------------------------------------------


@dataclass(frozen=True)
class DvlSpec:
    """DVL: rate, noise σ = scale |v| + floor per axis, lever arm, clock and disturbances."""

    rate_hz: float = 3.0
    sigma_scale: float = 0.02
    sigma_floor: float = 0.002
    lever_arm: tuple[float, float, float] = (1.0, 0.0, 1.5)
    jitter: float = 0.005
    segment_fraction: float = 0.10
    segment_duration: tuple[float, float] = (60.0, 300.0)
    segment_factor: tuple[float, float] = (3.0, 10.0)
    outlier_rate: float = 0.01
    burst_fraction: float = 0.3
    burst_length: tuple[int, int] = (2, 5)
    spike: tuple[float, float] = (0.5, 3.0)
    dropout_fraction: float = 0.02
    dropout_duration: tuple[float, float] = (2.0, 30.0)

    def nominal_sigma(self, speed: float) -> float:
        """σ per axis (m/s) at ``speed``: the filter's nominal R at the cruising speed."""
        return self.sigma_scale * speed + self.sigma_floor


@dataclass(frozen=True)
class DepthSpec:
    """Depth meter: rate, σ in calm water and at sea-state level 1 (nominal), lever arm."""

    rate_hz: float = 1.0
    sigma_calm: float = 0.1
    sigma_nominal: float = 0.5
    lever_arm: tuple[float, float, float] = (-2.0, 0.0, 1.2)
    jitter: float = 0.01


@dataclass(frozen=True)
class InclinometerSpec:
    """Pendulum inclinometer: rate and instrument noise σ (rad)."""

    rate_hz: float = 5.0
    sigma: float = 0.1 * DEG
    jitter: float = 0.002


@dataclass(frozen=True)
class HeadingSpec:
    """Heading sensor (gyrocompass): rate, σ (rad), and its ``use`` in the mission."""

    rate_hz: float = 1.0
    sigma: float = 0.5 * DEG
    jitter: float = 0.01
    use: str = "off"


@dataclass(frozen=True)
class GpsSpec:
    """GPS: rate, white σ and Gauss-Markov σ, τ per horizontal axis (m, s), antenna lever arm."""

    rate_hz: float = 1.0
    sigma_white: float = 1.5
    sigma_gm: float = 2.5
    tau_gm: float = 120.0
    lever_arm: tuple[float, float, float] = (0.0, 0.0, -5.0)
    jitter: float = 0.005

    @property
    def sigma(self) -> float:
        """Total σ per axis (m)."""
        return math.hypot(self.sigma_white, self.sigma_gm)


@dataclass(frozen=True)
class GenericSpec:
    """A registered sensor kind without a function of its own here, simulated from its
    declaration alone (:func:`generic`): its ``ideal_reading`` plus white noise.

    Attributes:
        kind: its name in the registry (sensors/registry.py).
        rate_hz: sampling rate.
        sigma: white-noise σ of every column, in the SI unit of the kind's σ.
        lever_arm: from the IMU, body FRD (m); zeros for a kind without one.
        jitter: clock jitter σ (s).
        name: the table's and its ``[sensors.<name>]`` section's name; None: the kind's.
    """

    kind: str
    rate_hz: float
    sigma: float
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    jitter: float = 0.005
    name: str | None = None

    @property
    def key(self) -> str:
        """The table's and section's name."""
        return self.name or self.kind


# --- clocks and random placement -------------------------------------------------------------


def sample_times(
    t_end: float,
    rate_hz: float,
    jitter: float,
    rng: np.random.Generator,
    offsets: bool = True,
    jittered: bool = True,
) -> Array:
    """Sampling instants in (0, t_end]: ``t_k = o + k T + j_k`` (k >= 1), o ~ U(0, T),
    j_k ~ N(0, jitter²) clipped to ±T/4 (module docstring)."""
    period = 1.0 / rate_hz
    offset = rng.uniform(0.0, period)
    if not offsets:
        offset = 0.0
    k = np.arange(1, math.floor((t_end - offset) / period) + 2)
    t = offset + k * period
    j = np.clip(rng.normal(0.0, jitter, t.size), -0.25 * period, 0.25 * period)
    if jittered:
        t = t + j
    return np.asarray(t[(t > 0.0) & (t <= t_end)], dtype=float)


def draw_durations(
    total: float, bounds: tuple[float, float], rng: np.random.Generator
) -> list[float]:
    """Durations ~ U(bounds) until they sum to ``total`` (the last one cut to fit)."""
    out: list[float] = []
    left = total
    while left > 1e-9:
        d = min(float(rng.uniform(*bounds)), left)
        out.append(d)
        left -= d
    return out


def place_intervals(
    lo: float, hi: float, durations: list[float], rng: np.random.Generator
) -> Array:
    """Non-overlapping intervals of the given durations placed uniformly at random in [lo, hi]
    (random order; the free time split by sorted uniform cuts). Returns (k, 2) [start, end]."""
    d = np.asarray(durations, dtype=float)
    if d.size == 0:
        return np.zeros((0, 2))
    free = (hi - lo) - float(d.sum())
    if free < 0.0:
        raise ValueError(f"intervals of {d.sum():g} s do not fit in [{lo:g}, {hi:g}]")
    d = d[rng.permutation(d.size)]
    gaps = np.sort(rng.uniform(0.0, free, d.size))
    starts = lo + gaps + np.concatenate([[0.0], np.cumsum(d)[:-1]])
    return np.stack([starts, starts + d], axis=1)


def place_events(n_slots: int, lengths: list[int], rng: np.random.Generator) -> IntArray:
    """Start indices of non-overlapping runs of the given lengths among n_slots consecutive
    slots, uniformly over all arrangements (stars and bars)."""
    k = len(lengths)
    free = n_slots - sum(lengths)
    if free < 0:
        raise ValueError("the events do not fit")
    if k == 0:
        return np.zeros(0, dtype=np.int64)
    c = np.sort(rng.choice(free + k, size=k, replace=False))
    before = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    return np.asarray(c - np.arange(k) + before, dtype=np.int64)


def in_intervals(t: Array, intervals: Array) -> NDArray[np.bool_]:
    """Mask of the times inside any [start, end) interval."""
    mask = np.zeros(t.shape, dtype=bool)
    for a, b in intervals:
        mask |= (t >= a) & (t < b)
    return mask


# --- the sensors ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Truth:
    """True quantities at a sensor's sampling instants (from :mod:`adaptnav.sim.kinematics`)."""

    t: Array
    x: Array
    """Nominal 16-states (biases zero)."""
    omega_ib_b: Array
    f_b: Array
    sea_state: Array
    """Sea-state level E(t) (0 when the waves are off)."""


def ideal(
    kind: str,
    truth: Truth,
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0),
    model: str | None = None,
) -> Array:
    """The error-free readings (N, d) of the registered ``kind`` at the truth's instants: its
    declared ``ideal_reading`` (sensors/kind.py) of a sensor at ``lever_arm``, aligned with the
    body (the simulated sensors have no mounting rotation)."""
    hook = KINDS[kind].ideal_reading
    if hook is None:
        raise ValueError(f"sensor kind {kind!r} declares no ideal_reading: it cannot be simulated")
    lever = np.asarray(lever_arm, dtype=float)
    return hook(IdealInput(truth.x, truth.omega_ib_b, truth.f_b, lever, model=model))


def dvl(
    spec: DvlSpec,
    truth: Truth,
    nav_start: float,
    rng: dict[str, np.random.Generator],
    dist: Disturbances,
    calibration: Calibration = NO_CALIBRATION,
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """DVL table and what was injected (module docstring). ``rng`` keys: noise, segments,
    outliers, dropouts. The truth columns are the error-free readings; ``calibration``'s scale
    factor and misalignment act on the readings."""
    n = truth.t.size
    clean = ideal("dvl", truth, spec.lever_arm)
    speed = np.linalg.norm(clean, axis=1)
    sigma = spec.sigma_scale * speed + spec.sigma_floor
    t_end = float(truth.t[-1]) if n else nav_start
    span = max(0.0, t_end - nav_start)
    factor, seg, seg_k = _dvl_segments(spec, truth.t, nav_start, t_end, rng, dist)
    noise = rng["noise"].standard_normal((n, 3)) * (sigma * factor)[:, None]
    if not dist.sensor_noise:
        noise[:] = 0.0
    drop = np.zeros((0, 2))
    if dist.dvl_dropouts and span > 0.0:
        g = rng["dropouts"]
        drop = place_intervals(
            nav_start, t_end, draw_durations(spec.dropout_fraction * span,
                                             spec.dropout_duration, g), g,
        )  # fmt: skip
    is_drop = in_intervals(truth.t, drop)
    eligible = np.flatnonzero((truth.t > nav_start) & ~is_drop)
    spikes, is_out, events = _dvl_outliers(spec, eligible, n, rng, dist)
    z = calibration.dvl(clean) + noise + spikes
    z[is_drop] = np.nan
    df = pd.DataFrame(
        {
            "t_s": truth.t + calibration.dvl_latency,
            "vx_m_s": z[:, 0],
            "vy_m_s": z[:, 1],
            "vz_m_s": z[:, 2],
            "true_vx_m_s": clean[:, 0],
            "true_vy_m_s": clean[:, 1],
            "true_vz_m_s": clean[:, 2],
            "sigma_m_s": sigma * factor if dist.sensor_noise else np.zeros(n),
            "noise_factor": factor,
            "is_outlier": is_out.astype(np.int8),
            "spike_x_m_s": spikes[:, 0],
            "spike_y_m_s": spikes[:, 1],
            "spike_z_m_s": spikes[:, 2],
            "is_dropout": is_drop.astype(np.int8),
        }
    )
    info = {
        "noise_segments": [
            [float(a), float(b), float(k)] for (a, b), k in zip(seg, seg_k, strict=True)
        ],
        "dropouts": [[float(a), float(b)] for a, b in drop],
        "outlier_samples": int(is_out.sum()),
        "outlier_events": events,
        "navigation_samples": int(eligible.size),
    }
    return df, info


def _dvl_segments(
    spec: DvlSpec,
    t: Array,
    nav_start: float,
    t_end: float,
    rng: dict[str, np.random.Generator],
    dist: Disturbances,
) -> tuple[Array, Array, Array]:
    """(k(t) per reading, segments (m, 2), their factors (m,)): the noise segments covering
    ``segment_fraction`` of the navigation time, each with k ~ U(segment_factor), k = 1
    elsewhere (module docstring; docs/simulation.md)."""
    factor = np.ones(t.size)
    seg = np.zeros((0, 2))
    seg_k = np.zeros(0)
    span = max(0.0, t_end - nav_start)
    if dist.dvl_noise_segments and span > 0.0:
        g = rng["segments"]
        seg = place_intervals(
            nav_start, t_end, draw_durations(spec.segment_fraction * span,
                                             spec.segment_duration, g), g,
        )  # fmt: skip
        seg_k = g.uniform(*spec.segment_factor, seg.shape[0])
        for (a, b), k in zip(seg, seg_k, strict=True):
            factor[(t >= a) & (t < b)] = k
    return factor, seg, seg_k


def _dvl_outliers(
    spec: DvlSpec,
    eligible: IntArray,
    n: int,
    rng: dict[str, np.random.Generator],
    dist: Disturbances,
) -> tuple[Array, NDArray[np.bool_], int]:
    """(spikes (n, 3), outlier mask (n,), event count): ``round(outlier_rate · m)`` of the m
    ``eligible`` readings in single-sample or burst events, each on a random non-empty set of
    axes with ±U(spike) m/s per sample (module docstring; docs/simulation.md)."""
    spikes = np.zeros((n, 3))
    is_out = np.zeros(n, dtype=bool)
    n_out = round(spec.outlier_rate * eligible.size) if dist.dvl_outliers else 0
    if n_out <= 0:
        return spikes, is_out, 0
    g = rng["outliers"]
    lengths: list[int] = []
    while sum(lengths) < n_out:
        burst = g.uniform() < spec.burst_fraction
        lo, hi = spec.burst_length
        lengths.append(int(g.integers(lo, hi + 1)) if burst else 1)
    lengths[-1] -= sum(lengths) - n_out
    lengths = [x for x in lengths if x > 0]
    starts = place_events(eligible.size, lengths, g)
    for s0, ln in zip(starts, lengths, strict=True):
        rows = eligible[s0 : s0 + ln]
        axes = g.uniform(size=3) < 0.5
        if not axes.any():
            axes[g.integers(3)] = True
        mag = g.uniform(*spec.spike, (ln, 3)) * g.choice([-1.0, 1.0], (ln, 3))
        spikes[rows] = mag * axes
        is_out[rows] = True
    return spikes, is_out, len(lengths)


def depth(
    spec: DepthSpec,
    truth: Truth,
    rng: np.random.Generator,
    dist: Disturbances,
    calibration: Calibration = NO_CALIBRATION,
) -> pd.DataFrame:
    """Depth table: the error-free depth (the truth column) plus ``calibration``'s bias and
    sea-state noise (module docstring)."""
    n = truth.t.size
    clean = ideal("depth", truth, spec.lever_arm)[:, 0]
    if dist.depth_sea_state:
        sigma = spec.sigma_calm + (spec.sigma_nominal - spec.sigma_calm) * truth.sea_state**2
    else:
        sigma = np.full(n, spec.sigma_nominal)
    if not dist.sensor_noise:
        sigma = np.zeros(n)
    z = clean + calibration.depth_bias + sigma * rng.standard_normal(n)
    return pd.DataFrame(
        {"t_s": truth.t, "depth_m": z, "true_depth_m": clean, "sigma_m": sigma,
         "sea_state": truth.sea_state}
    )  # fmt: skip


def inclinometer(
    spec: InclinometerSpec,
    truth: Truth,
    rng: np.random.Generator,
    dist: Disturbances,
    calibration: Calibration = NO_CALIBRATION,
) -> pd.DataFrame:
    """Inclinometer table: true roll/pitch (the attitude model's error-free reading), the
    pendulum's acceleration error (its error-free reading less the attitude's), ``calibration``'s
    biases on the angles it outputs, and white noise (module docstring)."""
    n = truth.t.size
    true = ideal("inclinometer", truth, model="attitude")
    accel_err = attitude.wrap_angle(ideal("inclinometer", truth, model="pendulum") - true)
    if not dist.inclinometer_pendulum:
        accel_err = np.zeros_like(accel_err)
    sigma = spec.sigma if dist.sensor_noise else 0.0
    bias = np.asarray(calibration.inclinometer_bias)
    z = attitude.wrap_angle(true + accel_err + bias + sigma * rng.standard_normal((n, 2)))
    return pd.DataFrame(
        {
            "t_s": truth.t,
            "roll_rad": z[:, 0],
            "pitch_rad": z[:, 1],
            "true_roll_rad": true[:, 0],
            "true_pitch_rad": true[:, 1],
            "accel_err_roll_rad": accel_err[:, 0],
            "accel_err_pitch_rad": accel_err[:, 1],
            "sigma_rad": np.full(n, sigma),
        }
    )


def heading(
    spec: HeadingSpec,
    truth: Truth,
    rng: np.random.Generator,
    dist: Disturbances,
    calibration: Calibration = NO_CALIBRATION,
) -> pd.DataFrame:
    """Heading table: the error-free yaw plus white noise, wrapped to (-π, π]; each reading
    stamped ``calibration.heading_latency`` after its instant."""
    n = truth.t.size
    true = ideal("heading", truth)[:, 0]
    sigma = spec.sigma if dist.sensor_noise else 0.0
    z = attitude.wrap_angle(true + sigma * rng.standard_normal(n))
    return pd.DataFrame(
        {
            "t_s": truth.t + calibration.heading_latency,
            "yaw_rad": z,
            "true_yaw_rad": true,
            "sigma_rad": np.full(n, sigma),
        }
    )


def gps(
    spec: GpsSpec,
    truth: Truth,
    rng: np.random.Generator,
    dist: Disturbances,
    calibration: Calibration = NO_CALIBRATION,
) -> pd.DataFrame:
    """GPS table: the antenna's error-free fix plus white and Gauss-Markov errors in N, E
    metres (no height: the missions use the GPS horizontally); each fix stamped
    ``calibration.gps_latency`` after its instant. The longitude is wrapped into [-π, π) after
    the noise is added (:func:`adaptnav.core.earth.wrap_longitude`): near the antimeridian a
    fix past -180° would be dropped by the loader as implausible (docs/simulation.md)."""
    n = truth.t.size
    clean = ideal("gnss", truth, spec.lever_arm)[:, :2]
    white = spec.sigma_white * rng.standard_normal((n, 2))
    gm = np.zeros((n, 2))
    xi = rng.standard_normal((n, 2))
    if n:
        gm[0] = spec.sigma_gm * xi[0]
        for k in range(1, n):
            phi = math.exp(-(truth.t[k] - truth.t[k - 1]) / spec.tau_gm)
            gm[k] = phi * gm[k - 1] + spec.sigma_gm * math.sqrt(1.0 - phi * phi) * xi[k]
    err = white + gm
    if not dist.sensor_noise:
        err[:] = 0.0
    lat, h = truth.x[:, 0], truth.x[:, 2]
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    z_lat = clean[:, 0] + err[:, 0] / rm
    z_lon = earth.wrap_longitude(clean[:, 1] + err[:, 1] / (rn * np.cos(lat)))
    return pd.DataFrame(
        {
            "t_s": truth.t + calibration.gps_latency,
            "lat_rad": z_lat,
            "lon_rad": z_lon,
            "err_n_m": err[:, 0],
            "err_e_m": err[:, 1],
            "sigma_m": np.full(n, spec.sigma if dist.sensor_noise else 0.0),
        }
    )


def generic(
    spec: GenericSpec, truth: Truth, rng: np.random.Generator, dist: Disturbances
) -> pd.DataFrame:
    """Table of a kind simulated by its declaration (:class:`GenericSpec`): its error-free
    readings of its columns (optional ones left out) as ``true_<column>``, and those plus
    N(0, σ²) per column, angles wrapped to (-π, π]; ``sigma_<unit>`` the σ applied."""
    kind = KINDS[spec.kind]
    unit = si_unit(kind.sigma_kind).replace("/", "_")
    columns = kind.columns[: kind.dim(use_height=False)]
    if not all(c.endswith(f"_{unit}") for c in columns):
        raise ValueError(
            f"sensor kind {spec.kind!r}: columns {columns} are not all in {unit}, the unit of "
            "its σ, so white noise of σ cannot be added to them: it needs a function of its own"
        )
    clean = ideal(spec.kind, truth, spec.lever_arm)[:, : len(columns)]
    sigma = spec.sigma if dist.sensor_noise else 0.0
    z = clean + sigma * rng.standard_normal(clean.shape)
    if kind.sigma_kind is Kind.ANGLE:
        z = attitude.wrap_angle(z)
    return pd.DataFrame(
        {
            "t_s": truth.t,
            **{c: z[:, j] for j, c in enumerate(columns)},
            **{f"true_{c}": clean[:, j] for j, c in enumerate(columns)},
            f"sigma_{unit}": np.full(truth.t.size, sigma),
        }
    )
