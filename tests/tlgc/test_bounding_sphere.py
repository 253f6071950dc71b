"""Smallest enclosing spheres of point sets and primitive obstacles."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls

from bad_input import raises_naming
from scenes import Box, Cylinder, Sphere
from tlgc.bounding_sphere import BoundingSphere, bounding_sphere, minimal_bounding_sphere
from tlgc.errors import TLGCArgumentError


def _is_minimal(points: np.ndarray, sphere: BoundingSphere) -> bool:
    """KKT check: the centre is a convex combination of the points on the surface."""
    d = np.linalg.norm(points - sphere.center, axis=1)
    support = points[d >= sphere.radius * (1 - 1e-9) - 1e-12]
    a = np.vstack([support.T, np.ones(len(support))])
    _, residual = nnls(a, np.r_[sphere.center, 1.0])
    return residual < 1e-7


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 50, 2000])
def test_minimal_sphere_encloses_and_is_minimal(count):
    rng = np.random.default_rng(count)
    pts = rng.normal(size=(count, 3)) * [1.0, 0.5, 2.0] + [1, -2, 3]
    s = minimal_bounding_sphere(pts)
    assert np.all(np.linalg.norm(pts - s.center, axis=1) <= s.radius * (1 + 1e-9) + 1e-12)
    assert _is_minimal(pts, s)


def test_known_spheres():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(400, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    s = minimal_bounding_sphere(0.3 * u + [0.1, 0.2, 0.3])
    assert s.radius == pytest.approx(0.3, rel=1e-9)
    np.testing.assert_allclose(s.center, [0.1, 0.2, 0.3], atol=1e-9)
    two = minimal_bounding_sphere([[0, 0, 0], [2, 0, 0], [1, 0.1, 0]])     # obtuse triangle
    assert two.radius == pytest.approx(1.0) and np.allclose(two.center, [1, 0, 0])
    cube = minimal_bounding_sphere(np.array(np.meshgrid([0, 1], [0, 1], [0, 1])).reshape(3, -1).T)
    assert cube.radius == pytest.approx(np.sqrt(3) / 2)


def test_primitive_obstacles_match_their_sampled_points():
    rng = np.random.default_rng(5)
    box = Box([0.3, -0.2, 0.1], [0.2, 0.1, 0.4])
    corners = box.center + 0.5 * box.size * np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    assert bounding_sphere(box).radius == pytest.approx(minimal_bounding_sphere(corners).radius)
    cyl = Cylinder([0, 0, 0.5], 0.1, 0.3)
    a = rng.uniform(0, 2 * np.pi, 5000)
    rim = np.stack([0.1 * np.cos(a), 0.1 * np.sin(a), np.where(a > np.pi, 0.15, -0.15) + 0.5], axis=1)
    assert bounding_sphere(cyl).radius == pytest.approx(minimal_bounding_sphere(rim).radius, rel=1e-4)
    s = bounding_sphere(Sphere([1, 2, 3], 0.5))
    assert s.radius == 0.5 and np.allclose(s.center, [1, 2, 3])
    assert bounding_sphere(([0, 0, 0], 0.2)).radius == 0.2


def test_bad_obstacles_raise():
    with raises_naming(TLGCArgumentError, "obstacle"):
        bounding_sphere("rock")
    with raises_naming(TLGCArgumentError, "points"):
        minimal_bounding_sphere(np.zeros((0, 3)))
    with raises_naming(TLGCArgumentError, "points"):
        minimal_bounding_sphere([[0, 0, np.nan]])
    with raises_naming(TLGCArgumentError, "obstacle radius"):
        bounding_sphere(([0, 0, 0], -1.0))
