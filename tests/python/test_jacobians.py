"""Analytic Jacobians called from Python match central differences."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from numpy.typing import NDArray

from bearing_slam import models

F = NDArray[np.float64]


def numeric_jacobian(f: Callable[[F], F], x: F, h: float = 1e-6) -> F:
    x = np.asarray(x, dtype=np.float64)
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = h
        diff = np.atleast_1d(f(x + d)) - np.atleast_1d(f(x - d))
        cols.append(diff / (2.0 * h))
    return np.stack(cols, axis=-1)


def wrapped(a: F) -> F:
    return np.asarray((a + np.pi) % (2 * np.pi) - np.pi)


POSE = np.array([0.3, -1.2, 0.7])


@pytest.mark.parametrize(("left", "right"), [(0.1, 0.12), (0.05, 0.05), (-0.03, 0.04)])
def test_diff_drive(left: float, right: float) -> None:
    state, j_x, j_u, q = models.diff_drive(POSE, left, right, wheel_base=0.2)
    assert state.shape == (3,)
    assert j_x.shape == (3, 3)
    assert j_u.shape == (3, 2)
    np.testing.assert_allclose(
        j_x, numeric_jacobian(lambda x: models.diff_drive(x, left, right)[0], POSE), atol=1e-7
    )
    u = np.array([left, right])
    num_u = numeric_jacobian(lambda v: models.diff_drive(POSE, v[0], v[1])[0], u)
    np.testing.assert_allclose(j_u, num_u, atol=1e-7)
    np.testing.assert_allclose(q, q.T)
    assert np.all(np.linalg.eigvalsh(q) >= -1e-15)


@pytest.mark.parametrize("omega", [0.5, 1e-9, -0.8])
def test_velocity(omega: float) -> None:
    v, dt = 0.4, 0.1
    _state, j_x, j_u, _ = models.velocity(POSE, v, omega, dt)
    np.testing.assert_allclose(
        j_x, numeric_jacobian(lambda x: models.velocity(x, v, omega, dt)[0], POSE), atol=1e-7
    )
    num_u = numeric_jacobian(
        lambda u: models.velocity(POSE, u[0], u[1], dt)[0], np.array([v, omega])
    )
    np.testing.assert_allclose(j_u[:, :2], num_u, atol=1e-7)


def test_odometry() -> None:
    u = np.array([0.1, 0.5, -0.2])
    _, j_x, j_u, _ = models.odometry(POSE, *u)
    np.testing.assert_allclose(
        j_x, numeric_jacobian(lambda x: models.odometry(x, *u)[0], POSE), atol=1e-7
    )
    np.testing.assert_allclose(
        j_u, numeric_jacobian(lambda v: models.odometry(POSE, *v)[0], u), atol=1e-7
    )
    rot1, trans, rot2 = models.odometry_increment(POSE, models.odometry(POSE, *u)[0])
    np.testing.assert_allclose([rot1, trans, rot2], u, atol=1e-12)


def test_bearing_to_point() -> None:
    lm = np.array([2.0, 1.5])
    z, j_p, j_l = models.bearing_to_point(POSE, lm)
    assert j_p.shape == (1, 3)
    assert j_l.shape == (1, 2)

    def f(p: F) -> F:
        return wrapped(np.array([models.bearing_to_point(p, lm)[0] - z])) + z

    def g(m: F) -> F:
        return wrapped(np.array([models.bearing_to_point(POSE, m)[0] - z])) + z

    np.testing.assert_allclose(j_p, numeric_jacobian(f, POSE), atol=1e-7)
    np.testing.assert_allclose(j_l, numeric_jacobian(g, lm), atol=1e-7)


def test_bearing_to_inverse_depth() -> None:
    lm = np.array([-0.5, 0.2, 0.4, 0.3])
    z, j_p, j_l = models.bearing_to_inverse_depth(POSE, lm)
    assert j_l.shape == (1, 4)
    np.testing.assert_allclose(
        j_p,
        numeric_jacobian(lambda p: np.array([models.bearing_to_inverse_depth(p, lm)[0]]), POSE),
        atol=1e-7,
    )
    np.testing.assert_allclose(
        j_l,
        numeric_jacobian(lambda m: np.array([models.bearing_to_inverse_depth(POSE, m)[0]]), lm),
        atol=1e-7,
    )
    # The inverse-depth point and the Euclidean point give the same bearing.
    point, j = models.inverse_depth_to_point(lm)
    assert models.bearing_to_point(POSE, point)[0] == pytest.approx(z, abs=1e-12)
    np.testing.assert_allclose(
        j, numeric_jacobian(lambda m: models.inverse_depth_to_point(m)[0], lm), atol=1e-6
    )


def test_range_bearing_and_its_inverse() -> None:
    lm = np.array([2.0, 1.5])
    z, j_p, j_l = models.range_bearing(POSE, lm)
    np.testing.assert_allclose(
        j_p, numeric_jacobian(lambda p: models.range_bearing(p, lm)[0], POSE), atol=1e-7
    )
    np.testing.assert_allclose(
        j_l, numeric_jacobian(lambda m: models.range_bearing(POSE, m)[0], lm), atol=1e-7
    )
    point, j_pose, j_meas = models.inverse_range_bearing(POSE, z[0], z[1])
    np.testing.assert_allclose(point, lm, atol=1e-12)
    np.testing.assert_allclose(
        j_pose,
        numeric_jacobian(lambda p: models.inverse_range_bearing(p, z[0], z[1])[0], POSE),
        atol=1e-7,
    )
    np.testing.assert_allclose(
        j_meas,
        numeric_jacobian(lambda m: models.inverse_range_bearing(POSE, m[0], m[1])[0], z),
        atol=1e-7,
    )


def test_pi_sr_init() -> None:
    y, j_p, j_z = models.pi_sr_init(POSE, 0.3, 0.5)
    np.testing.assert_allclose(y, [POSE[0], POSE[1], POSE[2] + 0.3, 0.5])
    np.testing.assert_allclose(
        j_p, numeric_jacobian(lambda p: models.pi_sr_init(p, 0.3, 0.5)[0], POSE), atol=1e-7
    )
    np.testing.assert_allclose(
        j_z,
        numeric_jacobian(lambda z: models.pi_sr_init(POSE, z[0], 0.5)[0], np.array([0.3]))[:, 0],
        atol=1e-7,
    )


def test_triangulation_init() -> None:
    first, z1 = np.array([0.0, 0.0, 0.0]), 0.6
    pose, z2 = np.array([1.5, 0.1, 0.05]), 1.1
    y, j_p, j_z, j_p1, j_z1, par = models.triangulation_init(first, z1, pose, z2)
    assert par["alpha"] > 0.0
    assert par["baseline"] > 1.0
    # The landmark lies on the first ray: its point seen from the first pose has bearing z1.
    point, _ = models.inverse_depth_to_point(y)
    assert models.bearing_to_point(first, point)[0] == pytest.approx(z1, abs=1e-9)

    def at(p1: F, a: float, p2: F, b: float) -> F:
        return models.triangulation_init(p1, a, p2, b)[0]

    np.testing.assert_allclose(
        j_p, numeric_jacobian(lambda p: at(first, z1, p, z2), pose), atol=1e-6
    )
    np.testing.assert_allclose(
        j_p1, numeric_jacobian(lambda p: at(p, z1, pose, z2), first), atol=1e-6
    )
    np.testing.assert_allclose(
        j_z, numeric_jacobian(lambda z: at(first, z1, pose, z[0]), np.array([z2]))[:, 0], atol=1e-6
    )
    np.testing.assert_allclose(
        j_z1,
        numeric_jacobian(lambda z: at(first, z[0], pose, z2), np.array([z1]))[:, 0],
        atol=1e-6,
    )


def test_triangulate() -> None:
    p1, z1, p2, z2 = np.array([0.0, 0.0, 0.1]), 0.5, np.array([2.0, 0.0, -0.1]), 1.4
    point, j_p1, j_z1, j_p2, j_z2 = models.triangulate(p1, z1, p2, z2)
    assert models.bearing_to_point(p1, point)[0] == pytest.approx(z1, abs=1e-9)
    assert models.bearing_to_point(p2, point)[0] == pytest.approx(z2, abs=1e-9)
    np.testing.assert_allclose(
        j_p1, numeric_jacobian(lambda p: models.triangulate(p, z1, p2, z2)[0], p1), atol=1e-6
    )
    np.testing.assert_allclose(
        j_p2, numeric_jacobian(lambda p: models.triangulate(p1, z1, p, z2)[0], p2), atol=1e-6
    )
    np.testing.assert_allclose(
        j_z1,
        numeric_jacobian(lambda z: models.triangulate(p1, z[0], p2, z2)[0], np.array([z1]))[:, 0],
        atol=1e-6,
    )
    np.testing.assert_allclose(
        j_z2,
        numeric_jacobian(lambda z: models.triangulate(p1, z1, p2, z[0])[0], np.array([z2]))[:, 0],
        atol=1e-6,
    )


def test_models_accept_lists_and_ints() -> None:
    a = models.bearing_to_point([0, 0, 0], [1, 1])
    assert a[0] == pytest.approx(np.pi / 4)
    assert models.wrap_angle(3 * np.pi) == pytest.approx(np.pi)
