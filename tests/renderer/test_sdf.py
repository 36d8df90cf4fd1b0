"""Signed-distance primitives of the built-in head, on shapes with known distances."""

import numpy as np

from renderer.sdf import capsule, ellipsoid, ray_surface, smax, smin, smoothstep


def test_sphere_distances_are_exact():
    p = np.array([[0.0, 0, 0], [3.0, 0, 0], [0, 0, -1.0]])
    np.testing.assert_allclose(ellipsoid(p, (0, 0, 0), (2, 2, 2)), [-0.0, 1.0, -1.0], atol=1e-9)


def test_ellipsoid_is_zero_on_its_surface_and_signed():
    r = np.array([4.0, 2.0, 1.0])
    surface = np.diag(r)
    np.testing.assert_allclose(ellipsoid(surface, (0, 0, 0), tuple(r)), 0.0, atol=1e-12)
    assert ellipsoid(np.array([[0.0, 0, 0.5]]), (0, 0, 0), tuple(r))[0] < 0
    assert ellipsoid(np.array([[0.0, 3.0, 0]]), (0, 0, 0), tuple(r))[0] > 0


def test_capsule_tapers_between_its_radii():
    p = np.array([[0.0, 5.0, 0], [10.0, 5.0, 0], [5.0, 0, 0]])
    d = capsule(p, (0, 0, 0), (10, 0, 0), 1.0, 3.0)
    np.testing.assert_allclose(d, [4.0, 2.0, -2.0], atol=1e-12)


def test_smooth_union_and_intersection_bound_the_sharp_ones():
    a, b = np.linspace(-2, 2, 41), np.linspace(2, -2, 41)
    assert np.all(smin(a, b, 0.5) <= np.minimum(a, b) + 1e-12)
    assert np.all(smax(a, b, 0.5) >= np.maximum(a, b) - 1e-12)
    far = np.array([0.0]), np.array([5.0])
    assert smin(*far, 0.5)[0] == 0.0 and smax(*far, 0.5)[0] == 5.0  # no blend beyond k


def test_smoothstep_ends_and_middle():
    np.testing.assert_allclose(
        smoothstep(0.0, 2.0, np.array([-1.0, 0, 1, 2, 3])), [0, 0, 0.5, 1, 1]
    )


def test_ray_surface_finds_a_sphere_radius():
    dirs = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]])
    t = ray_surface(lambda q: np.linalg.norm(q, axis=-1) - 7.0, np.zeros(3), dirs, 20.0)
    np.testing.assert_allclose(t, 7.0, atol=1e-6)
