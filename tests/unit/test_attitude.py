"""Attitude algebra against scipy's Rotation (an independent implementation) and identities."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from adaptnav.core import attitude as at

rotvecs = st.lists(st.floats(-1.8, 1.8), min_size=3, max_size=3).map(np.array)
eulers = st.tuples(st.floats(-3.1, 3.1), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1))
SET = settings(max_examples=60, deadline=None, derandomize=True)


@SET
@given(rotvecs)
def test_exp_and_dcm_match_scipy(a: np.ndarray) -> None:
    q = at.rotvec_to_quat(a)
    ref = Rotation.from_rotvec(a)
    np.testing.assert_allclose(at.quat_to_dcm(q), ref.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(at.quat_to_rotvec(q), ref.as_rotvec(), atol=1e-10)
    np.testing.assert_allclose(
        at.quat_to_dcm(at.dcm_to_quat(ref.as_matrix())), ref.as_matrix(), atol=1e-12
    )


@SET
@given(eulers)
def test_euler_matches_scipy_zyx(e: tuple[float, float, float]) -> None:
    roll, pitch, yaw = e
    C = at.euler_to_dcm(roll, pitch, yaw)
    np.testing.assert_allclose(
        C, Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix(), atol=1e-12
    )
    np.testing.assert_allclose(at.dcm_to_euler(C), [roll, pitch, yaw], atol=1e-9)


@SET
@given(rotvecs, rotvecs)
def test_product_is_composition(a: np.ndarray, b: np.ndarray) -> None:
    qa, qb = at.rotvec_to_quat(a), at.rotvec_to_quat(b)
    np.testing.assert_allclose(
        at.quat_to_dcm(at.quat_mult(qa, qb)), at.quat_to_dcm(qa) @ at.quat_to_dcm(qb), atol=1e-12
    )


def test_small_angle_series() -> None:
    a = np.array([1e-7, -2e-7, 3e-8])
    np.testing.assert_allclose(at.quat_to_rotvec(at.rotvec_to_quat(a)), a, rtol=1e-9)
    np.testing.assert_allclose(
        at.quat_to_dcm(at.rotvec_to_quat(a)), np.eye(3) + at.skew(a), atol=1e-13
    )


def test_skew_is_cross_product() -> None:
    u, v = np.array([1.0, 2.0, 3.0]), np.array([-0.5, 4.0, 0.25])
    np.testing.assert_allclose(at.skew(u) @ v, np.cross(u, v))


def test_frd_ned_meaning() -> None:
    """Yaw 90°: the body x axis (forward) points east."""
    np.testing.assert_allclose(
        at.euler_to_dcm(0, 0, math.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-15
    )


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [(math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi + 0.1, -math.pi + 0.1), (0.2, 0.2)],
)
def test_wrap(angle: float, wrapped: float) -> None:
    assert float(at.wrap_angle(angle)) == pytest.approx(wrapped)


def test_quat_mult_of_rows_is_each_row_s_product() -> None:
    rng = np.random.default_rng(7)
    p, q = rng.normal(size=(5, 4)), rng.normal(size=(5, 4))
    rows = at.quat_mult(p, q)
    assert rows.shape == (5, 4)
    for i in range(5):
        np.testing.assert_array_equal(rows[i], at.quat_mult(p[i], q[i]))
    # p ⊗ q by the matrix of p's left product: an independent form of the product.
    w, x, y, z = p[0]
    left = np.array([[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]])
    np.testing.assert_allclose(rows[0], left @ q[0], rtol=1e-14, atol=1e-15)
