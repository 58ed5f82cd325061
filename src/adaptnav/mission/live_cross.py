"""The load-time cross-checks of the IMU's axes and the DVL's and depth's scales, on a stream's
first window (docs/streaming.md, 'Cross-checks'; the rules: docs/robustness.md, 'IMU axes',
'DVL and depth scales').

:func:`adaptnav.mission.loader.cross_check` judges a whole mission: each gyro axis against the
angles of the aiding sensors that see rotation (:mod:`adaptnav.mission.axes`), the DVL's speed
and direction against a GNSS track and its vertical velocity against a depth meter
(:mod:`adaptnav.mission.scales`). A stream has no whole mission; :class:`CrossWatch` keeps what
those checks read over the stream's first ``window_s`` seconds (from the start of the first
IMU interval) and hands it to the same function once, when the window has passed:

* the IMU as sums over blocks of :data:`~adaptnav.mission.axes.TILT_BLOCK_S` (0.1 s: ``per``
  samples, ``per = max(1, round(0.1 / median dt))`` of the first :data:`PER_FROM` samples, as
  ``AccelTilt.of`` takes it of the whole table): per block its last stamp, its span ``Σ dt``
  and the sums ``Σ Δθ``, ``Σ Δv``. Passed to :class:`~adaptnav.mission.axes.ImuViews` as an
  IMU of one sample per block, they give the accelerometers' block means of ``AccelTilt``
  exactly (its ``per`` is then 1), and the gyro's integral at the blocks' ends, where the batch
  check has it at every sample: the angle changes between readings are interpolated over 0.1 s
  instead of 0.01 s (the difference: ``ω̇ Δ² / 8``, 1.3 mrad at 1 rad/s², against the
  reference's noise and a rule that needs the slope below half of 1 even 4 σ up);
* the aiding readings the screens released, of the kinds the checks read (heading,
  inclinometer, GNSS, DVL, depth; ``use`` aid or init), as the loader's ``SensorData``.

The IMU samples up to :data:`~adaptnav.mission.axes.MAX_LAG_S` past the window's end are kept
(the axis fit tries the references up to a second late), the readings up to its end. Memory:
8 doubles per block, 640 B per second of IMU (2.3 MB an hour at any rate of 10 Hz or more),
plus the readings (a Python object each); all of it let go once judged.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission import axes
from adaptnav.mission.config import MissionConfig, MissionError
from adaptnav.mission.live import Reading
from adaptnav.mission.loader import SensorData, cross_check

Array = NDArray[np.float64]
Vec3 = Sequence[float]
"""An IMU sample's Δθ or Δv: three floats (the stream's), or an array of three."""

PER_FROM = 100
"""IMU samples whose median interval sets the samples per block (1 s at 100 Hz)."""
AXIS_KINDS = ("heading", "inclinometer", "gnss")
"""The kinds whose angles the IMU's axes are fitted on (loader._axis_references)."""
SCALE_KINDS = ("dvl", "depth", "gnss", "heading")
"""The kinds the DVL's and depth's scale checks read (loader._check_scales)."""
BLOCK_COLUMNS = 8
"""Per block: last stamp, span, Σ Δθ (3), Σ Δv (3)."""


def _checked(config: MissionConfig) -> dict[str, str]:
    """Sensor → kind of the sensors the cross-checks would read (none: nothing to check)."""
    on = {n: c.kind for n, c in config.sensors.items() if c.use != "off"}
    axis = config.imu.check_axes and any(k in AXIS_KINDS for k in on.values())
    dvl = any(k == "dvl" and config.sensors[n].check_scale for n, k in on.items())
    scale = dvl and any(k in ("gnss", "depth") for k in on.values())
    # A depth read under water at GNSS fixes (loader._check_depth_at_fixes), DVL or not.
    depth = "gnss" in on.values() and any(
        k == "depth" and config.sensors[n].check_scale for n, k in on.items()
    )
    kinds = (
        (AXIS_KINDS if axis else ()) + (SCALE_KINDS if scale else ())
        + (("depth", "gnss") if depth else ())
    )  # fmt: skip
    return {n: k for n, k in on.items() if k in kinds}


class CrossWatch:
    """The IMU's block sums and the aiding readings of a stream's first ``window_s`` seconds,
    judged once by :func:`adaptnav.mission.loader.cross_check` (the module's docstring).
    ``periods``: each sensor's nominal period (s; NaN: the median interval of its readings).
    :attr:`done` from the start when there is nothing to check (no sensor that sees the axes
    or a DVL's scale, ``imu.axis_check`` and ``scale_check`` off) or ``window_s <= 0``."""

    def __init__(self, config: MissionConfig, periods: dict[str, float], window_s: float) -> None:
        self._config, self._periods = config, periods
        self.window_s = float(window_s)
        self._kinds = _checked(config) if self.window_s > 0.0 else {}
        self.done = not self._kinds
        """Judged, or nothing to judge: the stream feeds nothing more."""
        self.start = math.nan
        """The start of the first IMU interval (s), known from the first flush of samples."""
        self.end = math.inf
        """The window's end (s): ``start + window_s``."""
        self.due_at = math.inf
        """Judge once every reading stamped up to this has come: the window's end and the
        lags' (:data:`~adaptnav.mission.axes.MAX_LAG_S`); inf while unknown, and once judged."""
        self._per = 0
        self._flush_at = PER_FROM
        self._pending: list[tuple[float, float, Vec3, Vec3]] = []
        self._blocks = array("d")
        self._readings: dict[str, list[Reading]] = {n: [] for n in self._kinds}

    @property
    def nbytes(self) -> int:
        """Bytes of the IMU's block sums held (the samples not yet summed aside)."""
        return self._blocks.itemsize * len(self._blocks)

    def imu(self, t: float, dt: float, dtheta: Vec3, dvel: Vec3) -> None:
        """One IMU interval ``(t - dt, t]`` as integrated (after any stretch over a hole).
        Kept as it is and summed with the next ones every :data:`PER_FROM` samples: one
        vectorised sum costs less per sample than a running sum in Python (docs/streaming.md,
        'Cross-checks', the cost per push)."""
        if t > self.due_at:
            return
        self._pending.append((t, dt, dtheta, dvel))
        if len(self._pending) >= self._flush_at:
            self._flush()

    def reading(self, sensor: str, r: Reading) -> None:
        """A reading released by the sensor's screen (kept if the checks read its sensor)."""
        if r.t <= self.end and sensor in self._readings:
            self._readings[sensor].append(r)

    def _flush(self) -> None:
        """The whole blocks among the pending samples stamped up to the lags' end summed into
        :attr:`_blocks`; the samples of a block under way kept, those after the end let go."""
        pending = self._pending
        if math.isnan(self.start):
            self.start = pending[0][0] - pending[0][1]
            self.end = self.start + self.window_s
            self.due_at = self.end + axes.MAX_LAG_S
        t, dt, dth, dv = zip(*pending, strict=True)
        if not self._per:
            self._per = max(1, round(axes.TILT_BLOCK_S / float(np.median(dt))))
            self._flush_at = max(PER_FROM, self._per)
        per, stamps = self._per, np.array(t)
        inside = int(np.searchsorted(stamps, self.due_at, side="right"))
        n = inside // per * per
        if n:
            rows = np.column_stack([
                stamps[per - 1 : n : per], np.array(dt[:n]).reshape(-1, per).sum(axis=1),
                np.array(dth[:n], dtype=float).reshape(-1, per, 3).sum(axis=1),
                np.array(dv[:n], dtype=float).reshape(-1, per, 3).sum(axis=1),
            ])  # fmt: skip
            self._blocks.frombytes(np.ascontiguousarray(rows, dtype=np.float64).tobytes())
        self._pending = pending[n:] if inside == len(pending) else []

    def views(self) -> axes.ImuViews | None:
        """The IMU's views of the window from its block sums (None: fewer than two blocks)."""
        if self._pending:
            self._flush()
        b = np.frombuffer(self._blocks, dtype=np.float64).reshape(-1, BLOCK_COLUMNS).copy()
        if b.shape[0] < 2:
            return None
        noise = self._config.imu.noise.to_imu_noise()
        return axes.ImuViews(b[:, 0], b[:, 1], b[:, 2:5], b[:, 5:8], (noise.arw, noise.vrw))

    def sensors(self) -> dict[str, SensorData]:
        """The window's readings as the loader's SensorData (the sensors with any)."""
        out = {}
        for name, readings in self._readings.items():
            kept = [r for r in readings if r.t <= self.end]
            if not kept:
                continue
            out[name] = SensorData(
                name, self._kinds[name], np.array([r.t for r in kept]),
                np.array([r.z for r in kept], dtype=float).reshape(len(kept), -1),
                np.array([r.row for r in kept], dtype=np.int64),
                self._periods.get(name, math.nan),
            )  # fmt: skip
        return out

    def verdict(self) -> MissionError | None:
        """Judge the window once (:func:`~adaptnav.mission.loader.cross_check`) and let its data
        go: the loader's error for the first finding, None when nothing is found."""
        if self.done:
            return None
        views, sensors = self.views(), self.sensors()
        self.done, self.due_at = True, math.inf
        self._pending, self._blocks, self._readings = [], array("d"), {}
        if views is None or not sensors:
            return None
        try:
            cross_check(self._config, views, sensors)
        except MissionError as exc:
            return exc
        return None
