"""Exact signed distances of the primitive obstacles, and their gradients."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from bad_input import raises_naming
from scenes import Box, Capsule, Cylinder, InvalidArgumentError, InvalidObstacleError, Sphere
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
    Capsule([0.1, -0.1, 0.2], 0.06, 0.25, axis=[1.0, -2.0, 0.5]),
    Capsule([0.0, 0.1, 0.3], 0.04, 0.2),
]
IDS = ["box", "rotated_box", "sphere", "cylinder", "tilted_cylinder", "tilted_capsule", "capsule"]


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_distance_is_exact_against_dense_surface_samples(ob):
    rng = np.random.default_rng(1)
    surface = surface_samples(ob, rng)
    box = ob.aabb()
    queries = rng.uniform(box[0] - 0.1, box[1] + 0.1, (300, 3))
    nearest = cKDTree(surface).query(queries)[0]   # exact nearest sample
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
    (lambda: Box.from_reference([0, 0, 0, 0.1]), "Box reference"),
    (lambda: Box([0, 0], [1, 1, 1]), "Box center"),
    (lambda: Box([0, 0, np.nan], [1, 1, 1]), "Box center"),
    (lambda: Box([0, 0, 0], [1, 1, 1], np.ones((3, 3))), "rotation"),
    (lambda: Sphere([0, 0, 0], 0.0), "Sphere radius"),
    (lambda: Sphere([0, 0, 0], -1), "Sphere radius"),
    (lambda: Cylinder([0, 0, 0], -0.1, 1.0), "Cylinder radius"),
    (lambda: Cylinder([0, 0, 0], 0.1, 0.0), "Cylinder height"),
    (lambda: Cylinder([0, 0, 0], 0.1, 1.0, axis=[0, 0, 0]), "Cylinder axis"),
    (lambda: Capsule([0, 0, 0], 0.0, 1.0), "Capsule radius"),
    (lambda: Capsule([0, 0, 0], 0.1, -0.5), "Capsule height"),
    (lambda: Capsule([0, 0, 0], 0.1, [1.0, 2.0]), "Capsule height"),
    (lambda: Capsule([0, 0, 0], 0.1, 1.0, axis=[0, 0, 0]), "Capsule axis"),
    (lambda: Capsule([0, 0, 0, 1], 0.1, 1.0), "Capsule center"),
])
def test_invalid_obstacles_raise(make, field):
    with raises_naming(InvalidObstacleError, field):
        make()


def test_bad_points_raise():
    with raises_naming(InvalidArgumentError, "points"):
        Sphere([0, 0, 0], 1).distance(np.zeros((5, 2)))
    for ob in OBSTACLES:
        with raises_naming(InvalidArgumentError, "points"):
            ob.query(np.zeros(4))
        with raises_naming(InvalidArgumentError, "points"):
            ob.query([[0.0, np.nan, 0.0]])


# ----------------------------------------------------------------------------------------------
# Exact distance against surfaces sampled from each primitive's parametrisation (independent of
# the distance code), gradients, subgradients at medial points.


def frame_of(axis):
    """Orthonormal (3,3) with columns (u, v, axis) for a unit axis, built independently."""
    axis = np.asarray(axis, float)
    u = np.linalg.svd(axis[None])[2][1]
    return np.column_stack([u, np.cross(axis, u), axis])


def parametric_surface(ob, rng, count=200_000):
    """Points (count, 3) uniformly spread over the surface of a Box, Sphere, Cylinder or Capsule."""
    if isinstance(ob, Sphere):
        u = rng.normal(size=(count, 3))
        return ob.center + ob.radius * u / np.linalg.norm(u, axis=1, keepdims=True)
    if isinstance(ob, Box):
        h = 0.5 * ob.size
        areas = np.array([h[1] * h[2], h[0] * h[2], h[0] * h[1]])
        axis = rng.choice(3, size=count, p=areas / areas.sum())
        local = rng.uniform(-h, h, (count, 3))
        local[np.arange(count), axis] = rng.choice([-1.0, 1.0], count) * h[axis]
        rot = np.eye(3) if ob.rotation is None else ob.rotation
        return ob.center + local @ rot.T
    r, half, frame = ob.radius, 0.5 * ob.height, frame_of(ob.axis)
    if isinstance(ob, Cylinder):
        side = rng.uniform(size=count) < (2 * half) / (2 * half + r)   # mantle vs caps by area
        phi = rng.uniform(0, 2 * np.pi, count)
        rho = np.where(side, r, r * np.sqrt(rng.uniform(size=count)))
        z = np.where(side, rng.uniform(-half, half, count), rng.choice([-half, half], count))
        local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    else:  # capsule: mantle plus two hemispheres (together one sphere)
        side = rng.uniform(size=count) < (2 * half) / (2 * half + 2 * r)
        phi = rng.uniform(0, 2 * np.pi, count)
        u = rng.normal(size=(count, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        cap = r * u + np.sign(u[:, 2:3]) * [0.0, 0.0, half]
        mantle = np.column_stack([r * np.cos(phi), r * np.sin(phi), rng.uniform(-half, half, count)])
        local = np.where(side[:, None], mantle, cap)
    return ob.center + local @ frame.T


def inside_reference(ob, pts):
    """Boolean (P,) containment from the shape's definition (no distance code)."""
    if isinstance(ob, Sphere):
        return np.linalg.norm(pts - ob.center, axis=1) < ob.radius
    if isinstance(ob, Box):
        rot = np.eye(3) if ob.rotation is None else ob.rotation
        return np.all(np.abs((pts - ob.center) @ rot) < 0.5 * ob.size, axis=1)
    local = (pts - ob.center) @ frame_of(ob.axis)
    if isinstance(ob, Cylinder):
        return (np.hypot(local[:, 0], local[:, 1]) < ob.radius) & (np.abs(local[:, 2]) < 0.5 * ob.height)
    t = np.clip(local[:, 2], -0.5 * ob.height, 0.5 * ob.height)
    return np.linalg.norm(local - np.column_stack([0 * t, 0 * t, t]), axis=1) < ob.radius


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_query_matches_brute_force_distance_to_parametric_surface(ob):
    rng = np.random.default_rng(10)
    surface = parametric_surface(ob, rng)
    box = ob.aabb()
    queries = np.concatenate([rng.uniform(box[0] - 0.1, box[1] + 0.1, (300, 3)),
                              rng.uniform(box[0], box[1], (300, 3))])   # many inside
    nearest = cKDTree(surface).query(queries)[0]   # exact nearest sample
    d, grad = ob.query(queries)
    assert np.array_equal(d, ob.distance(queries))
    # |d| is the exact distance to the surface: never more than the nearest sample, and less
    # only by the sampling gap
    assert np.all(np.abs(d) <= nearest + 1e-9)
    assert np.all(np.abs(d) >= nearest - 2e-3)
    clear = nearest > 1e-3
    assert np.array_equal(d[clear] < 0, inside_reference(ob, queries[clear]))
    assert np.any(d < 0) and np.any(d > 0)
    # the gradient points from the nearest surface point: p - d * grad lies on the surface
    foot = queries - d[:, None] * grad
    assert np.abs(ob.distance(foot)).max() < 1e-12


def central_difference(f, pts, eps=1e-6):
    return np.stack([(f(pts + eps * e) - f(pts - eps * e)) / (2 * eps) for e in np.eye(3)], axis=-1)


def away_from_medial_surfaces(query, pts, rng, delta=1e-4):
    """Mask of points whose gradient is continuous within delta (kinks of the distance, i.e.
    medial surfaces, and the sharp edges of the surface itself are discontinuities)."""
    _, grad = query(pts)
    keep = np.ones(len(pts), dtype=bool)
    for _ in range(8):
        step = rng.normal(size=pts.shape)
        step *= delta / np.linalg.norm(step, axis=1, keepdims=True)
        keep &= np.linalg.norm(query(pts + step)[1] - grad, axis=1) < 0.05
    return keep


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_gradient_matches_central_differences_and_is_unit(ob):
    rng = np.random.default_rng(11)
    box = ob.aabb()
    pts = np.concatenate([rng.uniform(box[0] - 0.1, box[1] + 0.1, (1500, 3)),
                          rng.uniform(box[0], box[1], (500, 3))])
    d, grad = ob.query(pts)
    assert np.allclose(np.linalg.norm(grad, axis=-1), 1.0, atol=1e-12)
    keep = away_from_medial_surfaces(ob.query, pts, rng)
    assert keep.mean() > 0.97
    assert np.any(d[keep] < 0) and np.any(d[keep] > 0)
    fd = central_difference(ob.distance, pts[keep])
    assert np.abs(grad[keep] - fd).max() < 1e-6


def test_subgradients_at_medial_points_follow_the_documented_rule():
    box = Box([0, 0, 0], [2, 4, 6])
    d, g = box.query([[0, 0, 0], [-0.5, 0, 0], [0.5, 1.5, 0], [0, 0, -2.5], [1, 2, 3]])
    assert np.allclose(d, [-1, -0.5, -0.5, -0.5, 0])
    # ties go to the lowest axis; a coordinate on the centre plane counts as positive
    assert np.array_equal(g, [[1, 0, 0], [-1, 0, 0], [1, 0, 0], [0, 0, -1], [1, 0, 0]])
    R = rotation([1, 2, 3], 0.7)
    assert np.allclose(Box([1, 2, 3], [2, 4, 6], R).query([1, 2, 3])[1], R[:, 0])
    assert np.array_equal(Sphere([1, 1, 1], 0.5).query([1, 1, 1])[1], [1, 0, 0])
    cyl = Cylinder([0, 0, 0], 1.0, 2.0)
    d, g = cyl.query([[0, 0, 0], [0, 0, 0.5], [0, 0, -0.5], [0.5, 0, 0]])
    assert np.allclose(d, [-1, -0.5, -0.5, -0.5])
    assert np.array_equal(g, [[1, 0, 0], [0, 0, 1], [0, 0, -1], [1, 0, 0]])   # tie: mantle
    d, g = Capsule([0, 0, 0], 0.5, 2.0).query([[0, 0, 0.7], [0, 0, 1.0], [0, 0, 1.2]])
    assert np.allclose(d, [-0.5, -0.5, -0.3])
    assert np.array_equal(g, [[1, 0, 0], [1, 0, 0], [0, 0, 1]])
    # any axis: on the axis / segment the gradient is a unit vector normal to it
    for ob in (Cylinder([0, 0, 0], 0.2, 1.0, axis=[1, 2, 2]), Capsule([0, 0, 0], 0.2, 1.0, axis=[1, 2, 2])):
        pts = np.outer([-0.3, 0.0, 0.3], [1, 2, 2]) / 3.0
        _, g = ob.query(pts)
        assert np.allclose(np.linalg.norm(g, axis=1), 1.0) and np.allclose(g @ ob.axis, 0.0)
        assert np.allclose(g, g[0])


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_bounding_balls_bracket_the_obstacle(ob):
    # Scene culls with them: the inner ball lies inside, the outer ball contains the surface
    centre, inner, outer = ob._balls()
    rng = np.random.default_rng(14)
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    assert np.all(ob.distance(centre + inner * u) <= 1e-12)
    surface = parametric_surface(ob, rng, 20_000)
    assert np.linalg.norm(surface - centre, axis=1).max() <= outer + 1e-12
    assert np.linalg.norm(surface - centre, axis=1).max() >= outer - 5e-3   # tight


@pytest.mark.parametrize("ob", OBSTACLES, ids=IDS)
def test_query_any_leading_shape(ob):
    pts = np.random.default_rng(12).uniform(-0.3, 0.5, (4, 5, 3))
    d, g = ob.query(pts)
    assert d.shape == (4, 5) and g.shape == (4, 5, 3)
    d1, g1 = ob.query(pts.reshape(-1, 3))
    assert np.array_equal(d.reshape(-1), d1) and np.array_equal(g.reshape(-1, 3), g1)
    d0, g0 = ob.query(pts[1, 2])
    assert d0.shape == () and g0.shape == (3,) and np.isclose(d0, d[1, 2])
    d_empty, g_empty = ob.query(np.zeros((0, 3)))
    assert d_empty.shape == (0,) and g_empty.shape == (0, 3)


def test_capsule_analytic_values_and_special_cases():
    cap = Capsule([0, 0, 0], 0.5, 2.0, axis=[0, 0, 3])
    assert np.allclose(cap.axis, [0, 0, 1])
    assert np.allclose(cap.endpoints, [[0, 0, -1], [0, 0, 1]])
    assert np.allclose(cap.distance([[0, 0, 0], [2, 0, 0.3], [0, 0, 3], [3, 4, 1], [0.2, 0, -1.1]]),
                       [-0.5, 1.5, 1.5, 4.5, np.hypot(0.2, 0.1) - 0.5])
    assert np.allclose(cap.aabb(), [[-0.5, -0.5, -1.5], [0.5, 0.5, 1.5]])
    # height 0 is a sphere; a capsule contains the cylinder of the same radius and height
    pts = np.random.default_rng(13).uniform(-1, 1, (500, 3))
    assert np.allclose(Capsule([0.1, 0, 0], 0.3, 0.0).distance(pts), Sphere([0.1, 0, 0], 0.3).distance(pts))
    assert np.all(cap.distance(pts) <= Cylinder([0, 0, 0], 0.5, 2.0).distance(pts) + 1e-12)
    moved = cap.translated([1, 0, 0])
    assert isinstance(moved, Capsule) and np.allclose(moved.center, [1, 0, 0])
    assert moved.radius == cap.radius and moved.height == cap.height


def test_capsule_dict_round_trip():
    cap = Capsule([0.1, -0.1, 0.2], 0.06, 0.25, axis=[1.0, -2.0, 0.5])
    data = cap.to_dict()
    assert data["type"] == "capsule" and set(data) == {"type", "center", "radius", "height", "axis"}
    assert obstacle_from_dict(data) == cap
    assert obstacle_from_dict({"type": "capsule", "center": [0, 0, 0], "radius": 0.1, "height": 0.2}) \
        == Capsule([0, 0, 0], 0.1, 0.2)
    with raises_naming(InvalidObstacleError, "obstacle", "height"):
        obstacle_from_dict({"type": "capsule", "center": [0, 0, 0], "radius": 0.1})
    with raises_naming(InvalidObstacleError, "obstacle", "size"):
        obstacle_from_dict({"type": "capsule", "center": [0, 0, 0], "radius": 0.1, "height": 0.2, "size": 1})


def test_obstacles_are_immutable_and_copy_their_inputs():
    centre = np.array([0.1, 0.2, 0.3])
    box = Box(centre, [0.1, 0.2, 0.3], np.eye(3))
    centre[0] = 5.0                                  # the caller's array stays theirs
    assert box.center[0] == 0.1 and centre.flags.writeable
    for ob in [box] + OBSTACLES:
        for name in ("center", "size", "rotation", "axis"):
            arr = getattr(ob, name, None)
            if isinstance(arr, np.ndarray):
                with pytest.raises(ValueError, match="read-only"):
                    arr[0] = 1.0
