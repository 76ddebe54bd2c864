"""Quaternion conventions and the SO(3) distance."""

import numpy as np
from scipy.spatial.transform import Rotation

from harness.model import rotations


def test_order_conversion_round_trip():
    q = np.array([0.9, 0.1, -0.3, 0.2])
    assert np.allclose(rotations.xyzw_to_wxyz(rotations.wxyz_to_xyzw(q)), q)
    assert np.allclose(rotations.wxyz_to_xyzw(q), [0.1, -0.3, 0.2, 0.9])


def test_matrix_matches_scipy_scalar_first():
    q = rotations.from_axis_angle([1.0, 2.0, 3.0], 0.7)
    R = Rotation.from_quat(q, scalar_first=True).as_matrix()
    assert np.allclose(rotations.matrix(q), R)


def test_geodesic_angle_is_sign_invariant_and_accurate_for_tiny_angles():
    a = rotations.from_axis_angle([0.0, 0.0, 1.0], 0.3)
    for angle in (1e-12, 1e-6, 0.5, 3.0):
        b = rotations.multiply(a, rotations.from_axis_angle([1.0, -1.0, 0.5], angle))
        assert np.isclose(rotations.geodesic_angle(a, b), angle, rtol=1e-9)
        assert np.isclose(rotations.geodesic_angle(a, -b), angle, rtol=1e-9)


def test_multiply_composes_rotations():
    a = rotations.from_axis_angle([1.0, 0.0, 0.0], 0.4)
    b = rotations.from_axis_angle([0.0, 1.0, 0.0], -1.1)
    assert np.allclose(rotations.matrix(rotations.multiply(a, b)), rotations.matrix(a) @ rotations.matrix(b))


def test_xz_plane_angle_is_the_turn_about_minus_y():
    import numpy as np

    from harness.model.rotations import from_axis_angle, xz_plane_angle

    angles = np.array([-3.0, -1.2, 0.0, 0.7, 2.9])
    q = np.stack([from_axis_angle(np.array([0.0, -1.0, 0.0]), a) for a in angles])
    assert np.allclose(xz_plane_angle(q), angles, atol=1e-14)


def test_wrap_angle_gives_the_shortest_turn():
    import numpy as np

    from harness.model.rotations import wrap_angle

    assert np.allclose(wrap_angle(np.array([0.1, 2 * np.pi + 0.1, -2 * np.pi - 0.1, 3.0 * np.pi / 2])),
                       [0.1, 0.1, -0.1, -np.pi / 2], atol=1e-12)


def test_cross_is_np_cross_to_the_last_bit():
    rng = np.random.default_rng(7)
    for _ in range(50):
        a, b = rng.standard_normal(3) * 10.0 ** rng.integers(-8, 8), rng.standard_normal(3)
        assert np.array_equal(rotations.cross(a, b), np.cross(a, b))
    A, B = rng.standard_normal((4, 3)), rng.standard_normal((4, 3))
    assert np.array_equal(rotations.cross(A, B), np.cross(A, B))
    assert np.array_equal(rotations.cross(A, B[0]), np.cross(A, B[0]))
    C, D = rng.standard_normal((2, 5, 3)), rng.standard_normal((5, 3))  # leading axes broadcast
    assert np.array_equal(rotations.cross(C, D), np.cross(C, D))
