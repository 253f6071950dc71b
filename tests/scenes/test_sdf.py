"""Grid signed distance field: accuracy, gradient, outside-grid behaviour, construction."""
import ast
from pathlib import Path

import numpy as np
import pytest

from bad_input import raises_naming
import scenes.sdf
from scenes import (Box, Capsule, Cylinder, InvalidArgumentError, InvalidObstacleError, Scene,
                    SignedDistanceField, Sphere)

BOUNDS = [[0.0, -0.6, -0.1], [0.6, 0.0, 0.5]]
H = 0.01
OBSTACLES = {
    "box": Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28]),
    "sphere": Sphere([0.25, -0.3, 0.25], 0.1),
    "cylinder": Cylinder([0.3, -0.3, 0.2], 0.06, 0.2),
    "capsule": Capsule([0.3, -0.3, 0.2], 0.05, 0.15, axis=[1.0, 0.0, 1.0]),
}


def central_difference(f, pts, eps=1e-6):
    return np.stack([(f(pts + eps * e) - f(pts - eps * e)) / (2 * eps) for e in np.eye(3)], axis=-1)


@pytest.fixture(scope="module", params=list(OBSTACLES))
def case(request):
    ob = OBSTACLES[request.param]
    scene = Scene([ob], bounds=BOUNDS)
    return ob, scene, scene.sdf(H)


def test_values_within_one_cell_of_analytic(case):
    ob, scene, sdf = case
    rng = np.random.default_rng(0)
    near = ob.aabb()
    pts = np.concatenate([rng.uniform(BOUNDS[0], BOUNDS[1], (3000, 3)),
                          rng.uniform(near[0] - 0.05, near[1] + 0.05, (3000, 3))])
    pts = np.clip(pts, BOUNDS[0], BOUNDS[1])   # outside the grid the value is an upper bound
    d, _ = sdf.query(pts)
    assert np.abs(d - ob.distance(pts)).max() <= H
    # the sign is right wherever the point is clearly inside or outside
    clear = np.abs(ob.distance(pts)) > H
    assert np.all(np.sign(d[clear]) == np.sign(ob.distance(pts)[clear]))


def test_exact_mode_is_closer_and_matches_at_nodes(case):
    ob, scene, sdf = case
    exact = scene.sdf(H, exact=True)
    nodes = exact.grid_points()
    assert np.allclose(exact.values, ob.distance(nodes))
    rng = np.random.default_rng(1)
    near = ob.aabb()
    pts = rng.uniform(near[0] - 0.05, near[1] + 0.05, (3000, 3))
    err_exact = np.abs(exact.query(pts)[0] - ob.distance(pts)).max()
    assert err_exact < 0.5 * H


def test_gradient_matches_finite_differences_of_interpolant(case):
    _, _, sdf = case
    rng = np.random.default_rng(2)
    pts = rng.uniform(BOUNDS[0], BOUNDS[1], (500, 3))
    # keep away from cell faces, where the trilinear interpolant has kinks
    frac = (pts - sdf.origin) / H % 1.0
    pts = pts[np.all((frac > 0.01) & (frac < 0.99), axis=1)]
    _, grad = sdf.query(pts)
    fd = central_difference(sdf.distance, pts)
    assert np.allclose(grad, fd, atol=1e-6)


def angles_to(grad, normal):
    """Angles (degrees) between gradients (P,3) and unit normals (P,3)."""
    unit = grad / np.linalg.norm(grad, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", unit, normal), -1.0, 1.0)))


@pytest.mark.parametrize("exact", [False, True])
def test_gradient_direction_matches_box_face_normals(exact):
    box = OBSTACLES["box"]
    sdf = Scene([box], bounds=BOUNDS).sdf(H, exact=exact)
    rng = np.random.default_rng(3)
    # points facing each face of the box, 2-8 cm away from it, off edges and corners
    for axis in range(3):
        for sign in (-1, 1):
            pts = box.center + rng.uniform(-0.3, 0.3, (50, 3)) * box.size
            pts[:, axis] = box.center[axis] + sign * (0.5 * box.size[axis] + rng.uniform(0.02, 0.08, 50))
            normal = np.zeros((50, 3))
            normal[:, axis] = sign
            _, grad = sdf.query(pts)
            assert angles_to(grad, normal).max() < 10.0
            assert np.allclose(np.linalg.norm(grad, axis=-1), 1.0, atol=0.1)


@pytest.mark.parametrize("exact, worst, mean", [(False, 25.0, 8.0), (True, 5.0, 2.0)])
def test_gradient_direction_matches_sphere_normals(exact, worst, mean):
    # EDT mode: staircase occupancy of a curved surface tilts the gradient by a few degrees.
    sphere = OBSTACLES["sphere"]
    sdf = Scene([sphere], bounds=BOUNDS).sdf(H, exact=exact)
    rng = np.random.default_rng(4)
    directions = rng.normal(size=(500, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    pts = sphere.center + directions * (sphere.radius + rng.uniform(0.03, 0.1, (500, 1)))
    angles = angles_to(sdf.query(pts)[1], directions)
    assert angles.max() < worst and angles.mean() < mean


def test_outside_grid_queries_are_finite_and_grow_outward(case):
    _, _, sdf = case
    rng = np.random.default_rng(4)
    pts = rng.uniform(-2.0, 2.0, (2000, 3))
    d, grad = sdf.query(pts)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(grad))
    lo, hi = sdf.bounds
    clamped = np.clip(pts, lo, hi)
    gap = np.linalg.norm(pts - clamped, axis=1)
    outside = gap > 0
    assert np.allclose(d, sdf.distance(clamped) + gap)
    # the gradient has a positive component along the outward direction
    outward = (pts - clamped)[outside] / gap[outside, None]
    assert np.all(np.einsum("ij,ij->i", grad[outside], outward) > 0.99)
    frac = (pts - sdf.origin) / H % 1.0
    ok = np.all((frac > 0.01) & (frac < 0.99), axis=1)
    assert np.allclose(grad[ok], central_difference(sdf.distance, pts[ok]), atol=1e-6)


def test_query_any_leading_shape():
    sdf = Scene([OBSTACLES["sphere"]], bounds=BOUNDS).sdf(H)
    pts = np.random.default_rng(5).uniform(BOUNDS[0], BOUNDS[1], (4, 6, 3))
    d, grad = sdf.query(pts)
    assert d.shape == (4, 6) and grad.shape == (4, 6, 3)
    d1, g1 = sdf.query(pts.reshape(-1, 3))
    assert np.allclose(d.reshape(-1), d1) and np.allclose(grad.reshape(-1, 3), g1)
    d0, g0 = sdf.query(pts[0, 0])
    assert d0.shape == () and g0.shape == (3,)


def test_grid_covers_bounds_with_requested_cell_size():
    scene = Scene([OBSTACLES["box"]], bounds=[[0, 0, 0], [0.105, 0.2, 0.3]])
    sdf = scene.sdf(0.01)
    assert sdf.cell_size == 0.01
    assert np.allclose(sdf.origin, [0, 0, 0])
    assert sdf.shape == (12, 21, 31)
    assert np.all(sdf.bounds[1] >= scene.bounds[1] - 1e-12)


def test_empty_scene_is_infinite_with_zero_gradient():
    d, grad = Scene(bounds=BOUNDS).sdf(H).query(np.zeros((3, 3)))
    assert np.all(np.isposinf(d)) and np.all(grad == 0)


def test_thin_obstacle_between_nodes_is_not_lost():
    thin = Box([0.305, -0.305, 0.205], [0.004, 0.004, 0.004])
    d, _ = Scene([thin], bounds=BOUNDS).sdf(H).query(thin.center)
    assert d < H


def test_obstacle_outside_the_grid_still_gives_its_distance():
    far = Sphere([1.0, -0.3, 0.2], 0.1)
    sdf = Scene([far], bounds=BOUNDS).sdf(H)
    pts = np.random.default_rng(8).uniform(BOUNDS[0], BOUNDS[1], (200, 3))
    assert np.abs(sdf.distance(pts) - far.distance(pts)).max() < 1e-3


def test_several_obstacles_take_the_minimum():
    scene = Scene(list(OBSTACLES.values())[:2] + [Sphere([0.1, -0.1, 0.1], 0.05)], bounds=BOUNDS)
    sdf = scene.sdf(H)
    pts = np.random.default_rng(6).uniform(BOUNDS[0], BOUNDS[1], (2000, 3))
    assert np.abs(sdf.distance(pts) - scene.distance(pts)).max() <= H


def test_bad_arguments_raise():
    scene = Scene([OBSTACLES["box"]], bounds=BOUNDS)
    with raises_naming(InvalidArgumentError, "cell_size"):
        scene.sdf(0.02)
    with raises_naming(InvalidArgumentError, "cell_size"):
        scene.sdf(-0.01)
    with raises_naming(InvalidArgumentError, "points"):
        scene.sdf(H).query(np.zeros((2, 4)))
    with raises_naming(InvalidArgumentError, "points"):
        scene.sdf(H).query([0.1, np.nan, 0.1])


def test_save_load_round_trip(tmp_path):
    sdf = Scene([OBSTACLES["box"]], bounds=BOUNDS).sdf(H)
    sdf.save_npz(tmp_path / "sdf.npz")
    loaded = SignedDistanceField.load_npz(tmp_path / "sdf.npz")
    pts = np.random.default_rng(7).uniform(BOUNDS[0], BOUNDS[1], (100, 3))
    assert np.allclose(loaded.distance(pts), sdf.distance(pts))


def test_sdf_module_does_not_import_scene():
    tree = ast.parse(Path(scenes.sdf.__file__).read_text())
    imported = [node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)]
    imported += [alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names]
    assert not any(name and name.split(".")[-1] == "scene" for name in imported), imported


@pytest.mark.parametrize("exact", [False, True])
def test_from_obstacles_is_what_the_scene_builds(exact):
    obstacles = list(OBSTACLES.values())
    direct = SignedDistanceField.from_obstacles(obstacles, BOUNDS, H, exact=exact)
    cached = Scene(obstacles, bounds=BOUNDS).sdf(H, exact=exact)
    assert direct.shape == cached.shape and np.array_equal(direct.values, cached.values)
    assert not direct.values.flags.writeable
    assert np.allclose(direct.origin, BOUNDS[0]) and direct.cell_size == H


def test_grid_agrees_with_the_analytic_query():
    scene = Scene(list(OBSTACLES.values()), bounds=BOUNDS)
    pts = np.random.default_rng(9).uniform(BOUNDS[0], BOUNDS[1], (3000, 3))
    d, g = scene.query(pts)
    # the EDT mode's staircase on overlapping curved obstacles errs by up to ~1.3 cells here
    for exact, tol in ((False, 1.5 * H), (True, 0.5 * H)):
        dg, gg = scene.sdf(H, exact=exact).query(pts)
        assert np.abs(dg - d).max() <= tol
    # away from the surface and medial surfaces the exact grid's gradient is close to the true one
    far = np.abs(d) > 3 * H
    cos = np.einsum("ij,ij->i", gg[far] / np.linalg.norm(gg[far], axis=1, keepdims=True), g[far])
    assert np.median(cos) > 0.999


def test_from_obstacles_checks_its_arguments_and_memory_before_allocating():
    with raises_naming(InvalidObstacleError, "obstacles[1]"):
        SignedDistanceField.from_obstacles([OBSTACLES["box"], "box"], BOUNDS)
    with raises_naming(InvalidArgumentError, "bounds"):
        SignedDistanceField.from_obstacles([], [[0, 0, 0], [1, 0, 1]])
    with raises_naming(InvalidArgumentError, "cell_size", "(61, 61, 61)"):
        SignedDistanceField.from_obstacles([OBSTACLES["box"]], BOUNDS, H, max_bytes=1_000_000)
    shape, need = SignedDistanceField.estimate_build_bytes(BOUNDS, H, exact=True)
    assert shape == (61, 61, 61) and need == 61**3 * scenes.sdf.BUILD_BYTES_PER_NODE[True]
    SignedDistanceField.from_obstacles([OBSTACLES["box"]], BOUNDS, H, exact=True, max_bytes=need)
    # a workspace of 20 m on a side at 1 cm would need ~450 GiB: refused at once
    with raises_naming(InvalidArgumentError, "cell_size", "(2001, 2001, 2001)"):
        SignedDistanceField.from_obstacles([OBSTACLES["box"]], [[-10, -10, -10], [10, 10, 10]], H)
