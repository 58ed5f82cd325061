"""WGS84 earth model against published constants, identities and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adaptnav.core import earth

lats = st.floats(-math.radians(89.0), math.radians(89.0))


def test_published_values() -> None:
    # Normal gravity at the equator and poles (WGS84, NIMA TR8350.2 table 3.4).
    assert earth.gravity(0.0, 0.0) == pytest.approx(9.7803253359, abs=1e-9)
    assert earth.gravity(math.pi / 2, 0.0) == pytest.approx(9.8321849378, abs=1e-6)
    assert earth.meridian_radius(0.0) == pytest.approx(earth.A * (1 - earth.E2))
    assert earth.transverse_radius(0.0) == pytest.approx(earth.A)
    assert earth.transverse_radius(math.pi / 2) == pytest.approx(earth.A**2 / earth.B)
    # Free-air gradient ≈ -3.086e-6 s⁻² near the surface.
    assert earth.gravity_gradient(0.5, 0.0)[1] == pytest.approx(-3.086e-6, rel=5e-3)


@settings(max_examples=50, deadline=None, derandomize=True)
@given(lats, st.floats(-1000.0, 1000.0))
def test_derivatives_match_finite_differences(lat: float, h: float) -> None:
    e = 1e-6
    fd = lambda f: (f(lat + e) - f(lat - e)) / (2 * e)  # noqa: E731
    assert earth.meridian_radius_dlat(lat) == pytest.approx(
        fd(earth.meridian_radius), rel=1e-6, abs=1e-3
    )
    assert earth.transverse_radius_dlat(lat) == pytest.approx(
        fd(earth.transverse_radius), rel=1e-6, abs=1e-3
    )
    g_lat, g_h = earth.gravity_gradient(lat, h)
    # g varies by 1e-11 per µrad of latitude: a larger step keeps the FD out of roundoff.
    fd_g = (earth.gravity(lat + 1e-4, h) - earth.gravity(lat - 1e-4, h)) / 2e-4
    assert g_lat == pytest.approx(fd_g, rel=1e-6, abs=1e-10)
    assert g_h == pytest.approx(
        (earth.gravity(lat, h + 1.0) - earth.gravity(lat, h - 1.0)) / 2, rel=1e-6
    )


@settings(max_examples=100, deadline=None, derandomize=True)
@given(lats, st.floats(-math.pi, math.pi), st.floats(-5000.0, 1e5))
def test_ecef_round_trip(lat: float, lon: float, h: float) -> None:
    la, lo, hh = earth.ecef_to_geodetic(earth.geodetic_to_ecef(lat, lon, h))
    assert la == pytest.approx(lat, abs=1e-12)
    assert math.remainder(lo - lon, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
    assert hh == pytest.approx(h, abs=1e-6)


def test_ecef_known_points() -> None:
    np.testing.assert_allclose(earth.geodetic_to_ecef(0.0, 0.0, 0.0), [earth.A, 0, 0], atol=1e-9)
    np.testing.assert_allclose(
        earth.geodetic_to_ecef(math.pi / 2, 0.0, 0.0), [0, 0, earth.B], atol=1e-6
    )


def test_ned_axes_and_round_trip() -> None:
    lat0, lon0, h0 = math.radians(26.8), math.radians(56.0), 0.0
    rm, rn = earth.meridian_radius(lat0), earth.transverse_radius(lat0)
    north = earth.geodetic_to_ned(lat0 + 100.0 / rm, lon0, h0, lat0, lon0, h0)
    east = earth.geodetic_to_ned(lat0, lon0 + 100.0 / (rn * math.cos(lat0)), h0, lat0, lon0, h0)
    up = earth.geodetic_to_ned(lat0, lon0, h0 + 10.0, lat0, lon0, h0)
    np.testing.assert_allclose(north, [100, 0, 0], atol=2e-3)
    np.testing.assert_allclose(east, [0, 100, 0], atol=2e-3)
    np.testing.assert_allclose(up, [0, 0, -10], atol=1e-9)
    pts = np.array([[1234.0, -567.0, 8.0], [-20000.0, 30000.0, -50.0]])
    la, lo, hh = earth.ned_to_geodetic(pts, lat0, lon0, h0)
    np.testing.assert_allclose(earth.geodetic_to_ned(la, lo, hh, lat0, lon0, h0), pts, atol=1e-6)


def test_rates() -> None:
    lat = math.radians(26.8)
    np.testing.assert_allclose(np.linalg.norm(earth.earth_rate_n(lat)), earth.OMEGA_IE)
    # Moving east at v along a parallel turns the n-frame about north at v / (R_N + h).
    w = earth.transport_rate_n(lat, 0.0, [0.0, 10.0, 0.0])
    assert w[0] == pytest.approx(10.0 / earth.transverse_radius(lat))
    assert w[2] == pytest.approx(-10.0 * math.tan(lat) / earth.transverse_radius(lat))


def test_ned_to_geodetic_takes_one_origin_per_point() -> None:
    rng = np.random.default_rng(8)
    lat, lon, h = rng.uniform(-1.4, 1.4, 5), rng.uniform(-3, 3, 5), rng.uniform(-50, 2000, 5)
    r_n = rng.normal(0.0, 30.0, (5, 3))
    got = np.column_stack(earth.ned_to_geodetic(r_n, lat, lon, h))
    want = np.array(
        [np.hstack(earth.ned_to_geodetic(r_n[k], lat[k], lon[k], h[k])) for k in range(5)]
    )
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_wrap_longitude_is_the_half_open_interval_and_keeps_what_is_inside() -> None:
    """Longitudes written to files lie in [-π, π) (docs/conventions.md, 'Frames'): 180° is
    written -180°, one step below -π comes back near π, and a value already inside is returned
    bit-for-bit (a simulated mission away from the antimeridian keeps its files' hashes)."""
    inside = np.array([-math.pi, -3.0, -1e-300, 0.0, 0.97, np.nextafter(math.pi, 0.0)])
    assert np.array_equal(earth.wrap_longitude(inside), inside)
    values = np.array([math.pi, np.nextafter(-math.pi, -4.0), -math.pi - 1e-6, 7.0, -20.0])
    got = earth.wrap_longitude(values)
    assert got[0] == -math.pi and got[2] == pytest.approx(math.pi - 1e-6, abs=1e-15)
    turns = (got - values) / (2.0 * math.pi)  # whole turns, to rounding
    np.testing.assert_allclose(turns, np.round(turns), rtol=0, atol=1e-15)
    assert np.all((got >= -math.pi) & (got < math.pi))
    assert np.isnan(earth.wrap_longitude(np.array([np.nan]))[0])
