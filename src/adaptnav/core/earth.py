"""WGS84 earth model: radii of curvature, normal gravity, earth and transport rate, geodetic/NED.

Sources: Groves (2013) ch. 2 (eqs. 2.105-2.106 radii, 2.134 Somigliana gravity, 2.139 height
correction, 2.123 earth rate, 5.44 transport rate); docs/mechanization.md, 'Earth model'.

All functions take scalars or NumPy arrays (broadcast), SI units, radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
Num = float | NDArray[np.float64]
"""A scalar or an array of them; the functions broadcast."""

A = 6378137.0
"""WGS84 equatorial radius (m)."""
FLATTENING = 1.0 / 298.257223563
E2 = FLATTENING * (2.0 - FLATTENING)
"""First eccentricity squared."""
B = A * (1.0 - FLATTENING)
"""Polar radius (m)."""
MAX_LAT_DEG = 89.99
"""Largest |latitude| navigated (deg): the latitude-longitude mechanization is singular at the
poles (the longitude rate v_E / ((R_N + h) cos L) and the transport rate's v_E tan L; Groves
2013 §5.4), and within about a kilometre of one its longitude and heading run away (at 90°: a
yaw error of 178° in 30 s, exit 0, up to 0.4.5; 89.999° still behaved). A wander-azimuth frame
would lift the limit; none is implemented (docs/conventions.md)."""
MAX_LAT_RAD = float(np.radians(MAX_LAT_DEG))
OMEGA_IE = 7.292115e-5
"""Earth rotation rate (rad/s)."""
GM = 3.986004418e14
"""Earth gravitational constant (m^3/s^2)."""
G_EQUATOR = 9.7803253359
"""Normal gravity at the equator (m/s^2), Somigliana."""
K_SOMIGLIANA = 0.001931853
"""Somigliana constant k = (b g_p - a g_e) / (a g_e)."""
_M_HEIGHT = OMEGA_IE**2 * A**2 * B / GM


def wrap_longitude(lon: ArrayLike) -> Array:
    """Longitudes (rad) wrapped into [-π, π), the interval of the longitudes adaptnav writes
    (docs/conventions.md, 'Frames'; ``export track``'s [-180°, 180°)); values already inside
    come back bit-for-bit unchanged, NaN stays NaN.

    Not :func:`adaptnav.core.attitude.wrap_angle`, whose (-π, π] suits angle differences: a
    longitude of exactly 180° is written -180° as GIS tools do. A track that crosses the
    antimeridian runs on past ±180° in the navigation state and the trajectory, and comes back
    here before a file is written: beyond -180° the mission loader drops the fix as implausible.
    """
    arr = np.asarray(lon, dtype=float)
    wrapped = np.remainder(arr + np.pi, 2.0 * np.pi) - np.pi
    # remainder of a tiny negative number rounds to 2π: the result π, outside the interval.
    wrapped = np.where(wrapped >= np.pi, wrapped - 2.0 * np.pi, wrapped)
    return np.asarray(np.where((arr >= -np.pi) & (arr < np.pi), arr, wrapped), dtype=float)


def meridian_radius(lat: Num) -> Any:
    """R_M = a (1 - e²) / (1 - e² sin² L)^{3/2} (Groves 2.105, his R_N)."""
    s2 = np.sin(lat) ** 2
    return A * (1.0 - E2) / (1.0 - E2 * s2) ** 1.5


def transverse_radius(lat: Num) -> Any:
    """R_N = a / (1 - e² sin² L)^{1/2} (Groves 2.106, his R_E; prime vertical)."""
    s2 = np.sin(lat) ** 2
    return A / np.sqrt(1.0 - E2 * s2)


def meridian_radius_dlat(lat: Num) -> Any:
    """dR_M/dL = 3 a (1 - e²) e² sin L cos L / (1 - e² sin² L)^{5/2}."""
    s, c = np.sin(lat), np.cos(lat)
    return 3.0 * A * (1.0 - E2) * E2 * s * c / (1.0 - E2 * s * s) ** 2.5


def transverse_radius_dlat(lat: Num) -> Any:
    """dR_N/dL = a e² sin L cos L / (1 - e² sin² L)^{3/2}."""
    s, c = np.sin(lat), np.cos(lat)
    return A * E2 * s * c / (1.0 - E2 * s * s) ** 1.5


def gravity(lat: Num, h: Num) -> Any:
    """Normal gravity magnitude g(L, h) (m/s², along the ellipsoid normal, down).

    Somigliana at the surface (Groves 2.134), ``g0 = g_e (1 + k sin² L) / sqrt(1 - e² sin² L)``,
    with the height correction of Groves 2.139:
    ``g = g0 [1 - 2 h (1 + f + m - 2 f sin² L) / a + 3 h² / a²]``.
    It already contains the centrifugal term, so a body at rest feels ``f_n = [0, 0, -g]``.
    """
    s2 = np.sin(lat) ** 2
    g0 = G_EQUATOR * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (
        1.0
        - 2.0 * h * (1.0 + FLATTENING + _M_HEIGHT - 2.0 * FLATTENING * s2) / A
        + 3.0 * h**2 / A**2
    )


def gravity_gradient(lat: Num, h: Num) -> tuple[Any, Any]:
    """Partial derivatives (dg/dL, dg/dh) of :func:`gravity`, analytic."""
    s, c = np.sin(lat), np.cos(lat)
    s2 = s * s
    w = 1.0 - E2 * s2
    g0 = G_EQUATOR * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(w)
    dg0 = G_EQUATOR * (
        2.0 * K_SOMIGLIANA * s * c / np.sqrt(w) + (1.0 + K_SOMIGLIANA * s2) * E2 * s * c / w**1.5
    )
    corr = (
        1.0
        - 2.0 * h * (1.0 + FLATTENING + _M_HEIGHT - 2.0 * FLATTENING * s2) / A
        + 3.0 * h**2 / A**2
    )
    dcorr_dlat = 2.0 * h * 4.0 * FLATTENING * s * c / A
    dcorr_dh = -2.0 * (1.0 + FLATTENING + _M_HEIGHT - 2.0 * FLATTENING * s2) / A + 6.0 * h / A**2
    return dg0 * corr + g0 * dcorr_dlat, g0 * dcorr_dh


def gravity_n(lat: float, h: float) -> Array:
    """Gravity vector in NED, ``g_n = [0, 0, g(L, h)]``."""
    return np.array([0.0, 0.0, float(gravity(lat, h))])


def earth_rate_n(lat: float) -> Array:
    """Earth rate resolved in NED, ``omega_ie_n = Ω [cos L, 0, -sin L]`` (Groves 2.123)."""
    return np.array([OMEGA_IE * np.cos(lat), 0.0, -OMEGA_IE * np.sin(lat)])


def transport_rate_n(lat: float, h: float, v_n: ArrayLike) -> Array:
    """Transport rate ``omega_en_n`` (Groves 5.44).

    ``[v_E / (R_N + h), -v_N / (R_M + h), -v_E tan L / (R_N + h)]``.
    """
    v = np.asarray(v_n, dtype=float)
    rm = meridian_radius(lat) + h
    rn = transverse_radius(lat) + h
    return np.array([v[1] / rn, -v[0] / rm, -v[1] * np.tan(lat) / rn])


# --- geodetic <-> ECEF <-> local NED (I/O and metrics; exact, not small-angle) -----------------


def geodetic_to_ecef(lat: ArrayLike, lon: ArrayLike, h: ArrayLike) -> Array:
    """ECEF position (..., 3) from geodetic coordinates (Groves 2.112)."""
    lat, lon, h = np.asarray(lat, float), np.asarray(lon, float), np.asarray(h, float)
    rn = transverse_radius(lat)
    x = (rn + h) * np.cos(lat) * np.cos(lon)
    y = (rn + h) * np.cos(lat) * np.sin(lon)
    z = (rn * (1.0 - E2) + h) * np.sin(lat)
    return np.stack([x, y, z], axis=-1)


def ecef_to_geodetic(r_e: ArrayLike) -> tuple[Array, Array, Array]:
    """Geodetic (lat, lon, h) from ECEF (..., 3), by fixed-point iteration on latitude.

    Converges to < 1e-12 rad in a handful of iterations for any point outside the Earth's core
    (Groves 2.113 and the iteration of Groves appendix C).
    """
    r = np.asarray(r_e, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - E2))
    for _ in range(8):
        # z + e² R_N sin L = (R_N + h) sin L and p = (R_N + h) cos L at the fixed point.
        lat = np.arctan2(z + E2 * transverse_radius(lat) * np.sin(lat), p)
    rn = transverse_radius(lat)
    h = np.hypot(p, z + E2 * rn * np.sin(lat)) - rn
    return lat, lon, h


def C_ne(lat: ArrayLike, lon: ArrayLike) -> Array:
    """Rotation from ECEF into local NED at (lat, lon), shape (..., 3, 3) (Groves 2.150)."""
    lat, lon = np.asarray(lat, float), np.asarray(lon, float)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    zero = np.zeros_like(sl)
    rows = [
        np.stack([-sl * co, -sl * so, cl], axis=-1),
        np.stack([-so, co, zero], axis=-1),
        np.stack([-cl * co, -cl * so, -sl], axis=-1),
    ]
    return np.stack(rows, axis=-2)


def geodetic_to_ned(
    lat: ArrayLike, lon: ArrayLike, h: ArrayLike, lat0: float, lon0: float, h0: float
) -> Array:
    """Exact local NED position (..., 3) of points relative to the origin (lat0, lon0, h0)."""
    d = geodetic_to_ecef(lat, lon, h) - geodetic_to_ecef(lat0, lon0, h0)
    result: Array = d @ C_ne(lat0, lon0).T
    return result


def ned_to_geodetic(
    r_n: ArrayLike, lat0: ArrayLike, lon0: ArrayLike, h0: ArrayLike
) -> tuple[Array, Array, Array]:
    """Inverse of :func:`geodetic_to_ned`; the origin may also be one per point (arrays of the
    points' leading shape)."""
    r = np.asarray(r_n, float)[..., None, :] @ C_ne(lat0, lon0)  # r_nᵀ C_ne = (C_neᵀ r_n)ᵀ
    return ecef_to_geodetic(r[..., 0, :] + geodetic_to_ecef(lat0, lon0, h0))
