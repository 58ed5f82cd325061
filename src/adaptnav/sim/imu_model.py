"""IMU error model of the simulator: turn-on bias, in-run bias, white noise, scale factor.

Per axis of each triad and IMU interval k = (t_{k-1}, t_k] of length dt (Groves (2013) §4.4)::

    Δθ̃_k = (1 + s_g) Δθ_k + b_g(t_k) dt + ARW √dt n_k,
    Δṽ_k = (1 + s_a) Δv_k + b_a(t_k) dt + VRW √dt m_k,          n_k, m_k ~ N(0, 1),

with ``b(t) = b_on + b_run(t)``:

* ``b_on ~ N(0, σ_on²)``: the turn-on bias, a random constant per run;
* ``b_run``: the in-run bias, first-order Gauss-Markov ``ḃ = -b/τ + w``, ``E[w w] = 2σ²/τ``,
  sampled exactly (``b_k = e^{-dt/τ} b_{k-1} + σ √(1 - e^{-2dt/τ}) ξ_k``); τ = inf makes it a
  random walk of root-PSD ``rrw`` (``b_k = b_{k-1} + rrw √dt ξ_k``). It starts at 0 by default
  (the in-run part is the wander *from* the turn-on value; Groves §4.4.1), or in its
  stationary distribution (``stationary_start``);
* white noise of root-PSD ARW (rad/√s) and VRW (m/s/√s): angle/velocity random walk;
* ``s ~ N(0, σ_s²)``: a scale-factor error per axis (optional; not in the paper's Table 2).

Allan deviation of what this generates (IEEE Std 952-1997 Annex C; :mod:`adaptnav.sim.allan`):
white noise gives ``σ_A(τ) = ARW / √τ`` (so ARW is read at τ = 1 s); the Gauss-Markov bias
gives ``σ_A²(τ) = (σ² T²/τ²) (2τ/T - 3 + 4 e^{-τ/T} - e^{-2τ/T})``, a hump of height
``0.6166 σ`` at ``τ = 1.893 T``; the turn-on constant does not appear.

The paper's IMU (:data:`PAPER_IMU`, its Table 2): gyro in-run 1 deg/h, ARW 0.0667 deg/√h,
turn-on 20 deg/h; accelerometer in-run 0.25 mg, 55 µg/√Hz, turn-on 50 mg. Table 2 gives no
correlation time: τ = 1 h is assumed for both, and the datasheet "bias stability" is taken as
the Gauss-Markov σ, as :class:`adaptnav.models.imu_noise.ImuNoise` does (Groves §4.4.3).

What the 10-minute static alignment calibrates (and so what the simulator applies)
----------------------------------------------------------------------------------
At rest a ZUPT/levelling/gyrocompass alignment (``adaptnav.engine.align``) observes (Groves §5.6,
§14.4):

* the vertical accelerometer bias (|f̄| against g): to ``VRW/√T`` ≈ 2 µg in 600 s;
* the *north* gyro bias (it tilts the platform, which the ZUPTs see growing as ``g b t²/2``);
* the down gyro bias only weakly (through the heading drift it causes);
* **not** the horizontal accelerometer bias: the levelling tilts the platform until
  ``g φ = b_a`` - inseparable from tilt, a 50 mg bias would leave a 2.9° tilt error that
  flips sign when the vessel turns round;
* **not** the east gyro bias: the gyrocompass heading absorbs it,
  ``δψ = b_E / (Ω cos L)`` with Ω cos L = 13.4 deg/h at 26.8° N, so a 20 deg/h bias would give
  a heading error of ~85° (gyrocompassing impossible), and even 1 deg/h gives 4.3°.

A 20 deg/h / 50 mg turn-on offset therefore cannot be what enters the navigation: no static
alignment could recover heading and tilt from it, yet the paper navigated without a heading
sensor. The Table-2 "bias offset" is read as the *uncompensated* offset, which the INS's stored
calibration (factory/port calibration, refreshed from previous runs' estimates) removes before
the run, leaving a residual of the order of the in-run instability. So by default the
simulator applies the **residual** turn-on bias (:meth:`ImuErrorModel.calibrated`: σ_on =
1 deg/h and 0.25 mg for the paper's IMU), the mission's ``imu.initial_bias_sigma`` states
exactly that σ, and the filter's own 10-min alignment estimates the observable part of it
(vertical accelerometer, north gyro) while the rest (horizontal accelerometer ↔ tilt, east gyro
↔ heading) stays in its initial P with the correlations ``align.coarse_covariance`` carries.
The full Table-2 offsets remain available (``Disturbances.imu_uncalibrated_turn_on``) as a
stress case; the mission then says 20 deg/h and 50 mg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.core.units import DEG, G0, Kind
from adaptnav.models.imu_noise import KIND_KEY, NOISE_FIELDS, ImuNoise

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ImuErrorModel(ImuNoise):
    """IMU errors in SI units (module docstring for the model): the noise terms of
    :class:`ImuNoise` (white noise, in-run biases; declared, defaulted and checked there), then
    the simulator's own, checked the same way (:meth:`ImuNoise.from_datasheet` builds either).

    Attributes:
        gyro_turn_on_sigma, accel_turn_on_sigma: σ of the turn-on constants (rad/s, m/s²).
        gyro_scale_sigma, accel_scale_sigma: σ of the scale-factor errors (dimensionless; plain
            numbers in :meth:`from_datasheet`, 1e-4 = 100 ppm).
    """

    gyro_turn_on_sigma: float = field(default=0.0, metadata={KIND_KEY: Kind.ANGULAR_RATE})
    accel_turn_on_sigma: float = field(default=0.0, metadata={KIND_KEY: Kind.ACCELERATION})
    gyro_scale_sigma: float = 0.0
    accel_scale_sigma: float = 0.0

    _MODEL_NAME: ClassVar[str] = "IMU error"

    def noise(self) -> ImuNoise:
        """The filter's noise model: white noise and in-run biases (turn-on is in P0)."""
        return ImuNoise(**{f.name: getattr(self, f.name) for f in NOISE_FIELDS})

    def calibrated(
        self, gyro_residual: float | None = None, accel_residual: float | None = None
    ) -> ImuErrorModel:
        """The model after the pre-mission calibration: turn-on σ replaced by the residual
        (rad/s, m/s²; default: the in-run σ, the repeatability a calibration can reach)."""
        g = self.gyro_bias_sigma if gyro_residual is None else gyro_residual
        a = self.accel_bias_sigma if accel_residual is None else accel_residual
        return replace(self, gyro_turn_on_sigma=g, accel_turn_on_sigma=a)

    def config_noise(self) -> dict[str, tuple[float | str, str]]:
        """``[imu.noise]`` of mission.toml: ``[value, unit]`` pairs in datasheet units."""
        deg_h = DEG / 3600.0
        out: dict[str, tuple[float | str, str]] = {
            "arw": (self.arw / (DEG / 60.0), "deg/sqrt(h)"),
            "vrw": (self.vrw / (1e-6 * G0), "ug/sqrt(Hz)"),
            "gyro_bias_sigma": (self.gyro_bias_sigma / deg_h, "deg/h"),
            "gyro_bias_tau": _tau_pair(self.gyro_bias_tau),
            "accel_bias_sigma": (self.accel_bias_sigma / (1e-3 * G0), "mg"),
            "accel_bias_tau": _tau_pair(self.accel_bias_tau),
        }
        if self.gyro_bias_rrw > 0.0:
            out["gyro_bias_rrw"] = (self.gyro_bias_rrw / (deg_h / 60.0), "deg/h/sqrt(h)")
        if self.accel_bias_arw > 0.0:
            out["accel_bias_arw"] = (self.accel_bias_arw / (1e-6 * G0 / 60.0), "ug/sqrt(h)")
        return out


def _tau_pair(tau: float) -> tuple[float | str, str]:
    return ("inf", "s") if math.isinf(tau) else (tau, "s")


PAPER_IMU = ImuErrorModel.from_datasheet(
    gyro_scale_sigma=100e-6,
    accel_scale_sigma=300e-6,
    arw=(0.0667, "deg/sqrt(h)"),
    vrw=(55.0, "ug/sqrt(Hz)"),
    gyro_bias_sigma=(1.0, "deg/h"),
    gyro_bias_tau=(1.0, "h"),
    accel_bias_sigma=(0.25, "mg"),
    accel_bias_tau=(1.0, "h"),
    gyro_turn_on_sigma=(20.0, "deg/h"),
    accel_turn_on_sigma=(50.0, "mg"),
)
"""The paper's Table 2 IMU, turn-on offsets uncompensated. τ = 1 h assumed (not in Table 2);
scale factors (100 ppm gyro, 300 ppm accel) are typical tactical-grade figures, applied only
when switched on (``Disturbances.imu_scale_factor``)."""

PAPER_IMU_CALIBRATED = PAPER_IMU.calibrated()
""":data:`PAPER_IMU` after the pre-mission calibration: turn-on residual 1 deg/h and 0.25 mg
(module docstring: what the alignment can and cannot calibrate)."""


@dataclass(frozen=True, eq=False)
class ImuErrors:
    """One realisation of the errors (the simulator's truth).

    Attributes:
        gyro_turn_on, accel_turn_on: the turn-on constants (3,) (rad/s, m/s²).
        gyro_scale, accel_scale: scale-factor errors (3,).
        gyro_bias, accel_bias: total bias (turn-on + in-run) per interval (N, 3).
    """

    gyro_turn_on: Array
    accel_turn_on: Array
    gyro_scale: Array
    accel_scale: Array
    gyro_bias: Array
    accel_bias: Array


def gauss_markov(
    n: int,
    dt: float,
    sigma: float,
    tau: float,
    rng: np.random.Generator,
    rw: float = 0.0,
    stationary_start: bool = False,
    axes: int = 3,
) -> Array:
    """Samples b_1..b_n (n, axes) of a first-order Gauss-Markov process at spacing dt, exact
    discretisation, starting from b_0 = 0 (or stationary); τ = inf: random walk of root-PSD rw.
    """
    xi = rng.standard_normal((n, axes))
    if math.isinf(tau):
        b0 = np.zeros(axes)
        return np.asarray(b0 + np.cumsum(rw * math.sqrt(dt) * xi, axis=0), dtype=float)
    phi = math.exp(-dt / tau)
    gain = sigma * math.sqrt(-math.expm1(-2.0 * dt / tau))
    b0 = sigma * rng.standard_normal(axes) if stationary_start else np.zeros(axes)
    return first_order_recursion(gain * xi, phi, b0)


def first_order_recursion(u: Array, phi: float, y0: Array) -> Array:
    """``y_k = φ y_{k-1} + u_k`` for k = 1..n from ``y_0``: rows y_1..y_n (n, axes) of u (n, axes).

    Run in blocks of about √n rows so that NumPy does the work (a loop over n rows in Python
    would take seconds for a day of IMU samples): every block from zero, all blocks at once,
    row by row; then each block's start ``c_b = φ^w c_{b-1} + (block b-1's last row)`` from
    ``c_0 = y_0``, w being the block's length; then row j of block b gets ``φ^(j+1) c_b``. The
    blocks are laid side by side (row j of every block in one contiguous row) so that each
    step reads contiguous memory. Each value differs from the plain sequential recursion
    (scipy.signal.lfilter, which takes 0.8 s to import) only by roundings: about 1e-13 of the
    process's scale after a million steps, as lfilter's own roundings (tests/unit/test_sim.py).
    """
    n, axes = u.shape
    width = max(1, math.isqrt(n))
    blocks = max(1, -(-n // width))  # one (empty) block for n = 0
    padded = np.zeros((blocks * width, axes))
    padded[:n] = u
    side = padded.reshape(blocks, width, axes).transpose(1, 0, 2).copy()  # (row, block, axis)
    for j in range(1, width):
        side[j] += phi * side[j - 1]
    powers = phi ** np.arange(1, width + 1)
    starts = np.empty((blocks, axes))
    starts[0] = y0
    for b in range(1, blocks):
        starts[b] = powers[-1] * starts[b - 1] + side[-1, b - 1]
    side += powers[:, None, None] * starts[None, :, :]
    return np.ascontiguousarray(side.transpose(1, 0, 2).reshape(-1, axes)[:n])


def corrupt(
    dtheta: ArrayLike,
    dvel: ArrayLike,
    dt: float,
    model: ImuErrorModel,
    rng: dict[str, np.random.Generator],
    *,
    white: bool = True,
    in_run: bool = True,
    turn_on: bool = True,
    scale: bool = False,
    stationary_start: bool = False,
) -> tuple[Array, Array, ImuErrors]:
    """Apply the model to exact increments (N, 3) over intervals of length dt (s).

    ``rng`` holds one generator per error source (keys ``turn_on``, ``scale``, ``gyro_bias``,
    ``accel_bias``, ``gyro_white``, ``accel_white``), so switching one source off leaves the
    others' realisations unchanged. Returns the measured increments and the errors applied.
    """
    th = np.asarray(dtheta, dtype=float)
    dv = np.asarray(dvel, dtype=float)
    n = th.shape[0]
    zero3 = np.zeros(3)
    g_on = rng["turn_on"].normal(0.0, 1.0, 3) * model.gyro_turn_on_sigma
    a_on = rng["turn_on"].normal(0.0, 1.0, 3) * model.accel_turn_on_sigma
    if not turn_on:
        g_on, a_on = zero3.copy(), zero3.copy()
    g_sf = rng["scale"].normal(0.0, 1.0, 3) * model.gyro_scale_sigma
    a_sf = rng["scale"].normal(0.0, 1.0, 3) * model.accel_scale_sigma
    if not scale:
        g_sf, a_sf = zero3.copy(), zero3.copy()
    if in_run:
        bg = gauss_markov(
            n, dt, model.gyro_bias_sigma, model.gyro_bias_tau, rng["gyro_bias"],
            model.gyro_bias_rrw, stationary_start,
        )  # fmt: skip
        ba = gauss_markov(
            n, dt, model.accel_bias_sigma, model.accel_bias_tau, rng["accel_bias"],
            model.accel_bias_arw, stationary_start,
        )  # fmt: skip
        bg += g_on
        ba += a_on
    else:
        bg = np.broadcast_to(g_on, (n, 3)).copy()
        ba = np.broadcast_to(a_on, (n, 3)).copy()
    th_m = th * (1.0 + g_sf) + bg * dt
    dv_m = dv * (1.0 + a_sf) + ba * dt
    if white:
        th_m += rng["gyro_white"].standard_normal((n, 3)) * (model.arw * math.sqrt(dt))
        dv_m += rng["accel_white"].standard_normal((n, 3)) * (model.vrw * math.sqrt(dt))
    return th_m, dv_m, ImuErrors(g_on, a_on, g_sf, a_sf, bg, ba)


RNG_KEYS = ("turn_on", "scale", "gyro_bias", "accel_bias", "gyro_white", "accel_white")
"""The error sources :func:`corrupt` draws from, one generator each."""


def generators(seed_sequence: np.random.SeedSequence) -> dict[str, np.random.Generator]:
    """One independent generator per key of :data:`RNG_KEYS` from a seed sequence."""
    return {
        k: np.random.default_rng(s)
        for k, s in zip(RNG_KEYS, seed_sequence.spawn(len(RNG_KEYS)), strict=True)
    }
