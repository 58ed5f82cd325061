"""GNSS (or USBL) position fix of the antenna: latitude, longitude and optionally height.

Model (docs/filters.md, 'Measurement models'; Groves (2013) ch. 14, loosely coupled position
with lever arm): the antenna is at ``r_n + a``, ``a = C_nb l_b`` (NED, m), whose geodetic
coordinates are, to O(|a|²/R) (≈ 1e-6 m for a few metres of lever arm)::

    lat_a = lat + a_N / (R_M(lat) + h),
    lon_a = lon + a_E / ((R_N(lat) + h) cos lat),
    h_a = h - a_D.

The residual is taken in NED metres at the estimate (radii at lat_hat, h_hat; longitude
difference wrapped to (-π, π] so fixes across the antimeridian work)::

    y = [(lat_z - lat_a)(R_M + h), wrap(lon_z - lon_a)(R_N + h) cos lat, -(h_z - h_a)]

(the third component only with ``use_height``). For ``dx = x_true ⊖ x_hat`` (lat_true =
lat + dr_N/(R_M + h), ..., ``C_true = Exp(phi) C``) this is
``y ≈ dr + (Exp(phi) a - a) + (curvature terms of the lever arm)``, and H is its exact derivative::

    H_dr  = [[1 - a_N R_M'/ρ_M²,          0, a_N/ρ_M],
             [a_E (tan lat - R_N'/ρ_N)/ρ_M, 1, a_E/ρ_N],
             [0,                          0, 1      ]]     (ρ = R + h, R' = dR/dlat)
    H_phi = -[a×]

The curvature terms (a/R ≈ 1e-6, a tan(lat)/R at high latitude) change nothing in practice but
make H the true Jacobian of the model above.

With a latency state τ (docs/calibration.md, 'GNSS latency': a fix stamped t is the antenna's
position at t - τ) the antenna is taken τ earlier, ``r_a - τ v_a`` with its velocity
``v_a = v_n + C_nb (ω × l_b)``, ω = ω̃ - b_g: the residual gains ``+τ v_a`` and H gains
``-τ ∂v_a/∂dx`` (``-τ I`` on dv, ``τ [(C_nb (ω × l_b))×]`` on phi, ``-τ C_nb [l_b×]`` on db_g)
and ``-v_a`` on τ (the change of the radii with position over τ v_a is left out: ~1e-8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from adaptnav.core import attitude, earth
from adaptnav.core.units import Kind
from adaptnav.models.errorstate import ATT, BG, N_STATES, POS, VEL
from adaptnav.models.strapdown import NOM_ATT, NOM_BG, NOM_SIZE, NOM_VEL
from adaptnav.sensors.base import (
    Array,
    Components,
    Measurement,
    check_name,
    check_reading,
    check_sigma,
    check_state,
    check_vector3,
    readings_rate,
)
from adaptnav.sensors.calibration import GNSS_BIAS, LATENCY, bias, widen
from adaptnav.sensors.kind import IdealInput, SensorKind, StuckDefault, pack_params


def _lever_n(x: Array, l_b: ArrayLike) -> Array:
    return np.asarray(attitude.quat_to_dcm(x[NOM_ATT]) @ np.asarray(l_b, dtype=float), dtype=float)


def predict(x: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0), use_height: bool = True) -> Array:
    """h(x) = antenna [lat, lon (, h)] (rad, rad, m); longitude wrapped to (-π, π]."""
    xa = check_state(x)
    lat, lon, h = float(xa[0]), float(xa[1]), float(xa[2])
    a = _lever_n(xa, l_b)
    rm = float(earth.meridian_radius(lat)) + h
    rn = float(earth.transverse_radius(lat)) + h
    lat_a = lat + a[0] / rm
    lon_a = float(attitude.wrap_angle(lon + a[1] / (rn * np.cos(lat))))
    out = np.array([lat_a, lon_a, h - a[2]])
    return out if use_height else out[:2]


def residual(x: ArrayLike, z: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0)) -> Array:
    """y = z - h(x) in NED metres at the estimate (module docstring); len(z) is 2 or 3."""
    xa = check_state(x)
    zz = np.asarray(z, dtype=float)
    pred = predict(xa, l_b, use_height=zz.shape == (3,))
    lat, h = float(xa[0]), float(xa[2])
    rm = float(earth.meridian_radius(lat)) + h
    rn = float(earth.transverse_radius(lat)) + h
    y = np.empty(zz.shape)
    y[0] = (zz[0] - pred[0]) * rm
    y[1] = float(attitude.wrap_angle(zz[1] - pred[1])) * rn * np.cos(lat)
    if zz.shape == (3,):
        y[2] = -(zz[2] - pred[2])
    return y


def antenna_velocity(x: ArrayLike, omega_ib_b: ArrayLike, l_b: ArrayLike) -> Array:
    """``v_a = v_n + C_nb ((ω̃ - b_g) × l_b)``, the antenna's NED velocity (m/s)."""
    xa = check_state(x)
    rate = np.asarray(omega_ib_b, dtype=float) - xa[NOM_BG]
    turn = _lever_n(xa, np.cross(rate, np.asarray(l_b, dtype=float)))
    return np.asarray(xa[NOM_VEL] + turn, dtype=float)


def jacobian(x: ArrayLike, l_b: ArrayLike = (0.0, 0.0, 0.0), use_height: bool = True) -> Array:
    """H (2 or 3 × 15) on dr and phi, as in the module docstring."""
    xa = check_state(x)
    lat, h = float(xa[0]), float(xa[2])
    a = _lever_n(xa, l_b)
    rm = float(earth.meridian_radius(lat)) + h
    rn = float(earth.transverse_radius(lat)) + h
    drm = float(earth.meridian_radius_dlat(lat))
    drn = float(earth.transverse_radius_dlat(lat))
    H = np.zeros((3, N_STATES))
    H[:, POS] = [
        [1.0 - a[0] * drm / rm**2, 0.0, a[0] / rm],
        [a[1] * (np.tan(lat) - drn / rn) / rm, 1.0, a[1] / rn],
        [0.0, 0.0, 1.0],
    ]
    H[:, ATT] = -attitude.skew(a)
    return H if use_height else H[:2]


@dataclass(frozen=True, eq=False)
class GNSS(Components):
    """GNSS / USBL position fix.

    Attributes:
        sigma: nominal noise σ of the residual components [N, E(, D)] (m); a scalar applies to
            all; shape (2,) without height, (3,) with.
        l_b: lever arm from the IMU to the antenna (transducer), body FRD (m).
        use_height: also use the height (3 components) or only lat, lon (2).
        name: sensor name; components are ``{name}_N``, ``{name}_E`` (, ``{name}_D``).
        cal_bias: error-state index of its horizontal bias states (north, east, m;
            docs/calibration.md, 'GNSS bias'); -1: none. The antenna then reads ``r + a + b``:
            the residual's N and E components less b, H with 1 on each.
        cal_latency: error-state index of its latency state (s; module docstring); -1: none.
    """

    COMPONENTS: ClassVar[tuple[str, ...]] = ("N", "E", "D")

    sigma: float | Array
    l_b: Array = field(default_factory=lambda: np.zeros(3))
    use_height: bool = True
    name: str = "gnss"
    cal_bias: int = -1
    cal_latency: int = -1

    LIN_CODE: ClassVar[int] = 4
    """Its branch in the compiled ``linearise`` (sensors/kind.py)."""

    def lin_params(self) -> Array:
        """Its parameters for the compiled ``linearise`` (sensors/kind.py)."""
        flag = 1.0 if self.use_height else 0.0
        cal = (self.cal_bias, -1, -1, self.cal_latency)
        return pack_params(self.l_b, flag=flag, calibration=cal)

    def __post_init__(self) -> None:
        if not isinstance(self.use_height, bool):
            raise ValueError(f"use_height must be a bool, got {self.use_height!r}")
        object.__setattr__(self, "sigma", check_sigma("sigma", self.sigma, self.dim))
        object.__setattr__(self, "l_b", check_vector3("l_b", self.l_b))
        object.__setattr__(self, "name", check_name("name", self.name))

    @property
    def dim(self) -> int:
        return 3 if self.use_height else 2

    @property
    def midpoint_update(self) -> bool:
        """With a latency state its reading multiplies τ with the velocity: linearised at the
        midpoint of the update's step, as a calibrated DVL (docs/calibration.md)."""
        return self.cal_latency >= 0

    def _latency(self, x: Array, omega_ib_b: ArrayLike | None) -> tuple[float, Array]:
        """``(τ, v_a)`` (module docstring); ``(0, zeros)`` without a latency state."""
        if self.cal_latency < 0 or x.size == NOM_SIZE:
            return 0.0, np.zeros(3)
        if omega_ib_b is None:
            raise ValueError("a GNSS with a latency state needs the gyro rate omega_ib_b")
        return float(x[self.cal_latency + 1]), antenna_velocity(x[:NOM_SIZE], omega_ib_b, self.l_b)

    @property
    def names(self) -> tuple[str, ...]:
        return (f"{self.name}_N", f"{self.name}_E", f"{self.name}_D")[: self.dim]

    def predict(self, x: ArrayLike, omega_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`predict`; with the bias states (north, east, m) the antenna moved by them,
        with a latency state moved by ``-τ v_a`` (``omega_ib_b``, the raw gyro rate, needed
        then)."""
        xa = np.asarray(x, dtype=float)
        out = predict(xa[:NOM_SIZE], self.l_b, self.use_height)
        lag, v_a = self._latency(xa, omega_ib_b)
        b = bias(xa, self.cal_bias, 2) - lag * v_a[:2]
        lat, h = float(xa[0]), float(xa[2])
        out[0] += b[0] / (float(earth.meridian_radius(lat)) + h)
        rn = float(earth.transverse_radius(lat)) + h
        out[1] = float(attitude.wrap_angle(out[1] + b[1] / (rn * math.cos(lat))))
        if self.use_height:
            out[2] += lag * v_a[2]
        return out

    def jacobian(self, x: ArrayLike, omega_ib_b: ArrayLike | None = None) -> Array:
        """See :func:`jacobian`; a column per error state of x (15 + m), 1 on the bias states,
        and with a latency state its terms (module docstring)."""
        xa = np.asarray(x, dtype=float)
        H = widen(xa, jacobian(xa[:NOM_SIZE], self.l_b, self.use_height))
        if self.cal_bias >= 0 and H.shape[1] > N_STATES:
            H[0, self.cal_bias] = H[1, self.cal_bias + 1] = 1.0
        lag, v_a = self._latency(xa, omega_ib_b)
        if self.cal_latency >= 0 and H.shape[1] > N_STATES:
            d = self.dim
            turn = v_a - xa[NOM_VEL]
            C = attitude.quat_to_dcm(xa[NOM_ATT])
            H[:, VEL] -= lag * np.eye(3)[:d]
            H[:, ATT] += lag * attitude.skew(turn)[:d]
            H[:, BG] -= lag * (C @ attitude.skew(self.l_b))[:d]
            H[:, self.cal_latency] = -v_a[:d]
        return H

    def evaluate(
        self, x: Array, z: ArrayLike, omega_ib_b: ArrayLike | None = None
    ) -> Measurement | None:
        """Residual in NED metres (see :func:`residual`), H and R; None if z has a NaN/inf.

        ``z = [lat, lon(, h)]`` (rad, rad, m), of length :attr:`dim`; ``omega_ib_b`` (the raw
        gyro rate) is used only with a latency state.
        """
        zz = check_reading(self.name, z, self.dim)
        if zz is None:
            return None
        xa = np.asarray(x, dtype=float)
        y = residual(xa[:NOM_SIZE], zz, self.l_b)
        y[:2] -= bias(xa, self.cal_bias, 2)
        lag, v_a = self._latency(xa, omega_ib_b)
        y += lag * v_a[: self.dim]
        return Measurement(y, self.jacobian(xa, omega_ib_b), self.R, self.names)


def fix_rate(z: Array, t: Array) -> Array:
    """The velocity (NED m/s) of fixes z (n, 2 or 3: lat, lon(, h)) at times t: their offsets
    from the first fix in metres (radii there; longitude unwrapped) by :func:`readings_rate`."""
    za = np.atleast_2d(np.asarray(z, dtype=float))
    lat0, h0 = za[0, 0], za[0, 2] if za.shape[1] > 2 else 0.0
    rm = float(earth.meridian_radius(lat0)) + h0
    rn = float(earth.transverse_radius(lat0)) + h0
    ned = np.empty(za.shape)
    ned[:, 0] = (za[:, 0] - lat0) * rm
    ned[:, 1] = np.unwrap(za[:, 1] - za[0, 1]) * rn * math.cos(lat0)
    if za.shape[1] > 2:
        ned[:, 2] = -(za[:, 2] - h0)
    return readings_rate(ned, t)


def ideal(t: IdealInput) -> Array:
    """Error-free fixes (N, 3) of the antenna, height included: :func:`predict` at each true
    state, over all N at once."""
    lat, lon, h = t.x[:, 0], t.x[:, 1], t.x[:, 2]
    a = t.lever_n
    rm = earth.meridian_radius(lat) + h
    rn = earth.transverse_radius(lat) + h
    lon_a = attitude.wrap_angle(lon + a[:, 1] / (rn * np.cos(lat)))
    return np.stack([lat + a[:, 0] / rm, lon_a, h - a[:, 2]], axis=-1)


LATLON_RESOLUTION_RAD = 1e-11
"""0.06 mm on the earth: below the steps of RTKLIB's output (1e-7° = 1.7e-9 rad in the car
data of docs/rtklib.md, 1e-9° at its finest)."""
HEIGHT_RESOLUTION_M = 1e-5
"""0.01 mm: below RTKLIB's height steps (1 mm in the car data, 0.1 mm at its finest)."""

KIND = SensorKind(
    name="gnss",
    columns=("lat_rad", "lon_rad", "h_m"),
    sigma_kind=Kind.LENGTH,
    build=lambda s: GNSS(
        s.sigma,
        s.l_b,
        s.use_height,
        s.name,
        s.calibration.get("bias", -1),
        s.calibration.get("latency", -1),
    ),
    limits={
        "lat_rad": (-math.pi / 2, math.pi / 2),
        "lon_rad": (-math.pi, 2.0 * math.pi),
        "h_m": (-12000.0, 100000.0),
    },
    # Off: a receiver's static hold, or a coarse output on a moored or parked vehicle, repeats
    # a position legitimately, and dropping those fixes would leave the INS unaided.
    stuck=StuckDefault(
        0.0,
        {
            "lat_rad": LATLON_RESOLUTION_RAD,
            "lon_rad": LATLON_RESOLUTION_RAD,
            "h_m": HEIGHT_RESOLUTION_M,
        },
    ),
    lever_arm=True,
    options=frozenset({"use_height"}),
    optional_columns=1,
    linearised=(GNSS,),
    calibration={"bias": GNSS_BIAS, "latency": LATENCY},
    reading_rate=fix_rate,
    ideal_reading=ideal,
)
"""GNSS (or USBL) fixes as a sensor kind (sensors/kind.py): latitude within ±90°, longitude in
[-180°, 360°], height in [-12 km, 100 km]; no stuck detection (docs/robustness.md)."""
