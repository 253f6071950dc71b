"""Exact signed distances of the primitive obstacles."""
import numpy as np
import pytest

from scenes import Box, Cylinder, InvalidObstacleError, Sphere
from scenes.obstacles import obstacle_from_dict


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def surface_samples(ob, rng, count=40_000):
    """Points on the surface: random points pushed onto the zero level set by Newton steps."""
    box = ob.aabb()
    pts = rng.uniform(box[0] - 0.05, box[1] + 0.05, (count, 3))
    for _ in range(4):
        d = ob.distance(pts)
        eps = 1e-7
        grad = np.stack([(ob.distance(pts + eps * e) - ob.distance(pts - eps * e)) / (2 * eps)
                         for e in np.eye(3)], axis=-1)
        pts = pts - d[:, None] * grad
    assert np.abs(ob.distance(pts)).max() < 1e-9
    return pts


OBSTACLES = [
    Box([0.3, -0.2, 0.1], [0.1, 0.2, 0.3]),
    Box([0.3, -0.2, 0.1], [0.1, 0.2, 0.3], rotation([1, 2, 3], 0.7)),
    Sphere([0.1, 0.2, 0.3], 0.15),
    Cylinder([0.2, -0.3, 0.2], 0.05, 0.3),
    Cylinder([0.2, -0.3, 0.2], 0.08, 0.2, axis=[1.0, 1.0, 0.5]),
]
IDS = ["box", "rotated_box", "sphere", "cylinder", "tilted_cylinder"]


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_distance_is_exact_against_dense_surface_samples(ob):
    rng = np.random.default_rng(1)
    surface = surface_samples(ob, rng)
    box = ob.aabb()
    queries = rng.uniform(box[0] - 0.1, box[1] + 0.1, (300, 3))
    nearest = np.min(np.linalg.norm(queries[:, None] - surface[None], axis=-1), axis=1)
    d = ob.distance(queries)
    # |d| is the distance to the surface; sampling leaves a small gap only one way.
    assert np.all(np.abs(d) <= nearest + 1e-9)
    assert np.allclose(np.abs(d), nearest, atol=5e-3)
    assert np.any(d < 0) and np.any(d > 0)


def test_analytic_values():
    box = Box([0, 0, 0], [2, 4, 6])
    assert np.allclose(box.distance([[3, 0, 0], [0, 0, 0], [0, 1.5, 0], [2, 3, 4]]),
                       [2, -1, -0.5, np.sqrt(3)])
    sphere = Sphere([1, 1, 1], 0.5)
    assert np.allclose(sphere.distance([[1, 1, 1], [1, 1, 3]]), [-0.5, 1.5])
    cyl = Cylinder([0, 0, 0], 1.0, 2.0, axis=[0, 0, 5])
    assert np.allclose(cyl.distance([[0, 0, 0], [3, 0, 0], [0, 0, 4], [4, 0, 5], [0.9, 0, 0.5]]),
                       [-1, 2, 3, 5, -0.1])
    tilted = Cylinder([0, 0, 0], 1.0, 2.0, axis=[1, 0, 0])
    assert np.allclose(tilted.distance([[4, 0, 0], [0, 0, 3]]), [3, 2])


def test_rotated_box_matches_box_in_its_own_frame():
    rng = np.random.default_rng(2)
    R = rotation([0.3, -1, 0.2], 1.1)
    centre = np.array([0.2, 0.1, -0.3])
    rotated = Box(centre, [0.1, 0.3, 0.2], R)
    aligned = Box([0, 0, 0], [0.1, 0.3, 0.2])
    local = rng.normal(size=(100, 3)) * 0.2
    assert np.allclose(rotated.distance(centre + local @ R.T), aligned.distance(local))


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_vectorized_over_leading_shape_and_aabb_contains_inside(ob):
    rng = np.random.default_rng(3)
    box = ob.aabb()
    pts = rng.uniform(box[0] - 0.1, box[1] + 0.1, (4, 5, 6, 3))
    d = ob.distance(pts)
    assert d.shape == (4, 5, 6)
    assert np.allclose(d.reshape(-1), ob.distance(pts.reshape(-1, 3)))
    inside = pts[d < 0]
    assert np.all((inside >= box[0] - 1e-12) & (inside <= box[1] + 1e-12))
    # tight: the box touches the surface on every side
    near = surface_samples(ob, rng, 20_000)
    assert np.allclose(near.min(axis=0), box[0], atol=5e-3)
    assert np.allclose(near.max(axis=0), box[1], atol=5e-3)


def test_from_reference_and_translation_and_dict_round_trip():
    box = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])
    assert np.allclose(box.center, [0.32, -0.32, 0.13]) and np.allclose(box.size, [0.09, 0.06, 0.28])
    moved = box.translated([0.1, 0, 0])
    assert np.isclose(moved.distance([0.42, -0.32, 0.13]), -0.03)
    for ob in OBSTACLES:
        assert obstacle_from_dict(ob.to_dict()) == ob
    assert obstacle_from_dict({"type": "box", "reference": [0, 0, 0, 1, 1, 1]}) == Box([0, 0, 0], [1, 1, 1])


@pytest.mark.parametrize("make, field", [
    (lambda: Box([0, 0, 0], [0.1, 0.0, 0.1]), "Box size"),
    (lambda: Box([0, 0, 0], [0.1, -0.2, 0.1]), "Box size"),
    (lambda: Box.from_reference([0, 0, 0, 0.1, 0.1, -1]), "Box size"),
    (lambda: Box.from_reference([0, 0, 0, 0.1]), "reference row"),
    (lambda: Box([0, 0], [1, 1, 1]), "Box center"),
    (lambda: Box([0, 0, np.nan], [1, 1, 1]), "NaN"),
    (lambda: Box([0, 0, 0], [1, 1, 1], np.ones((3, 3))), "rotation"),
    (lambda: Sphere([0, 0, 0], 0.0), "Sphere radius"),
    (lambda: Sphere([0, 0, 0], -1), "Sphere radius"),
    (lambda: Cylinder([0, 0, 0], -0.1, 1.0), "Cylinder radius"),
    (lambda: Cylinder([0, 0, 0], 0.1, 0.0), "Cylinder height"),
    (lambda: Cylinder([0, 0, 0], 0.1, 1.0, axis=[0, 0, 0]), "Cylinder axis"),
])
def test_invalid_obstacles_raise(make, field):
    with pytest.raises(InvalidObstacleError, match=field):
        make()


def test_bad_points_raise():
    with pytest.raises(ValueError, match=r"points: expected shape \(\.\.\., 3\)"):
        Sphere([0, 0, 0], 1).distance(np.zeros((5, 2)))
