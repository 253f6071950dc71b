"""Scenes: distance over obstacles, default bounds, JSON files and their errors."""
import json

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import (DEFAULT_WORKSPACE, Box, Capsule, Cylinder, InvalidArgumentError, InvalidObstacleError,
                    Obstacle, Scene, SceneFileError, SignedDistanceField, Sphere, available_scenes, builtin_scene)


def make_scene():
    return Scene([Box([0.3, -0.3, 0.1], [0.1, 0.1, 0.2]), Sphere([0.0, 0.4, 0.3], 0.1),
                  Cylinder([-0.3, 0.0, 0.2], 0.05, 0.4, axis=[0, 1, 1])])


def test_distance_is_min_over_obstacles_and_inf_when_empty():
    scene = make_scene()
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.5, 0.5, (7, 11, 3))
    expected = np.min([ob.distance(pts) for ob in scene.obstacles], axis=0)
    assert np.allclose(scene.distance(pts), expected)
    assert np.all(np.isposinf(Scene().distance(pts)))
    assert Scene().distance(np.zeros(3)).shape == ()


def test_default_bounds_cover_workspace_and_obstacles():
    assert np.allclose(Scene().bounds, DEFAULT_WORKSPACE)
    far = Scene([Sphere([1.5, 0.0, 0.2], 0.1)])
    assert np.isclose(far.bounds[1, 0], 1.7)
    assert np.allclose(far.bounds[0], DEFAULT_WORKSPACE[0])
    with raises_naming(InvalidArgumentError, "bounds"):
        Scene(bounds=[[0, 0, 0], [1, -1, 1]])
    with raises_naming(InvalidArgumentError, "bounds"):
        Scene(bounds=[0, 0, 0, 1, 1, 1])


def test_save_load_round_trip(tmp_path):
    scene = Scene(make_scene().obstacles, bounds=[[-1, -1, -0.5], [1, 1, 1]])
    path = tmp_path / "scene.json"
    scene.save(path)
    loaded = Scene.load(path)
    assert loaded.obstacles == scene.obstacles
    assert np.allclose(loaded.bounds, scene.bounds)
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (50, 3))
    assert np.allclose(loaded.distance(pts), scene.distance(pts))


def test_builtin_box_closing_scene_is_the_reference_obstacle():
    assert "box_closing" in available_scenes()
    scene = builtin_scene("box_closing")
    assert scene.obstacles == (Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28]),)
    with raises_naming(SceneFileError, "nope", "box_closing"):
        builtin_scene("nope")


@pytest.mark.parametrize("content, names", [
    ("{not json", ()),
    ("[1, 2]", ()),
    ('{"obstacles": {}}', ("obstacles",)),
    ('{"obstacles": [], "colour": 1}', ("colour",)),
    ('{"obstacles": [{"type": "sphere", "center": [0,0,0], "radius": 0.1}, '
     '{"type": "sphere", "center": [0,0,0], "radius": -0.1}]}', ("obstacles[1]", "radius")),
    ('{"obstacles": [{"type": "box", "center": [0,0,0], "size": [0.1, 0, 0.1]}]}', ("obstacles[0]", "size")),
    ('{"obstacles": [{"type": "cone"}]}', ("obstacles[0].type", "cone")),
    ('{"obstacles": [{"type": "box", "center": [0,0,0]}]}', ("obstacles[0]", "size")),
    ('{"obstacles": [{"type": "sphere", "center": [0,0], "radius": 1}]}', ("obstacles[0]", "center")),
    ('{"obstacles": [{"type": "sphere", "center": [0,0,0], "radius": 1, "mass": 2}]}', ("obstacles[0]", "mass")),
    ('{"obstacles": [{"type": "box", "reference": [0,0,0,1,1]}]}', ("obstacles[0].reference",)),
    ('{"obstacles": [], "bounds": [[0,0,0],[1,1]]}', ("bounds",)),
])
def test_malformed_scene_files_raise_naming_the_field(tmp_path, content, names):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with raises_naming(SceneFileError, "bad.json", *names):
        Scene.load(path)


def test_missing_scene_file_raises(tmp_path):
    with raises_naming(SceneFileError, "absent.json"):
        Scene.load(tmp_path / "absent.json")


def test_reference_box_rows_in_scene_file(tmp_path):
    path = tmp_path / "ref.json"
    path.write_text(json.dumps({"obstacles": [{"type": "box", "reference": [0.32, -0.32, 0.13, 0.09, 0.06, 0.28]}]}))
    assert Scene.load(path).obstacles[0] == Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])


def test_scene_rejects_non_obstacles():
    with raises_naming(InvalidObstacleError, "obstacles[0]"):
        Scene([[0, 0, 0]])


# ----------------------------------------------------------------------------------------------
# Exact query with gradient, the planner's distance query, the scene's grid cache.


def mixed_scene():
    tilt = np.linalg.qr(np.random.default_rng(20).normal(size=(3, 3)))[0]
    tilt *= np.linalg.det(tilt)                   # a proper rotation
    return Scene([Box([0.3, -0.3, 0.1], [0.1, 0.1, 0.2]), Box([-0.2, -0.3, 0.3], [0.2, 0.05, 0.1], tilt),
                  Sphere([0.0, 0.4, 0.3], 0.1), Cylinder([-0.3, 0.0, 0.2], 0.05, 0.4, axis=[0, 1, 1]),
                  Capsule([0.2, 0.2, 0.1], 0.04, 0.3, axis=[1, 0, 0.3])])


def test_query_takes_min_distance_and_the_argmin_obstacles_gradient():
    scene = mixed_scene()
    pts = np.random.default_rng(21).uniform(-0.5, 0.5, (3000, 3))
    d, g = scene.query(pts)
    each = [ob.query(pts) for ob in scene.obstacles]
    ds = np.array([e[0] for e in each])
    nearest = np.argmin(ds, axis=0)
    assert len(np.unique(nearest)) == len(scene.obstacles)   # every obstacle is the nearest somewhere
    assert np.array_equal(d, ds.min(axis=0))
    assert np.array_equal(g, np.array([e[1] for e in each])[nearest, np.arange(len(pts))])
    assert np.array_equal(d, scene.distance(pts))
    assert np.allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-12)
    # leading shapes
    d2, g2 = scene.query(pts.reshape(30, 100, 3))
    assert d2.shape == (30, 100) and g2.shape == (30, 100, 3) and np.array_equal(g2.reshape(-1, 3), g)


def test_query_ties_go_to_the_first_obstacle_and_empty_scene_is_infinite():
    a, b = Sphere([-1, 0, 0], 0.5), Sphere([1, 0, 0], 0.5)
    d, g = Scene([a, b]).query([[0, 0, 0], [0.2, 0, 0]])
    assert np.allclose(d, [0.5, 0.3]) and np.allclose(g, [[1, 0, 0], [-1, 0, 0]])
    d, g = Scene([b, a]).query([0, 0, 0])
    assert np.allclose(g, [-1, 0, 0])
    d, g = Scene().query(np.zeros((2, 4, 3)))
    assert d.shape == (2, 4) and np.all(np.isposinf(d)) and g.shape == (2, 4, 3) and np.all(g == 0)


def test_culling_many_obstacles_gives_the_same_result_as_evaluating_all():
    rng = np.random.default_rng(25)
    obstacles = []
    for k in range(17):
        centre = rng.uniform(-0.6, 0.6, 3)
        size = rng.uniform(0.002, 0.2)
        obstacles.append([Box(centre, rng.uniform(0.002, 0.2, 3)), Sphere(centre, size),
                          Cylinder(centre, size, rng.uniform(0.01, 0.3), rng.normal(size=3)),
                          Capsule(centre, size, rng.uniform(0.0, 0.3), rng.normal(size=3)),
                          MeshLike(Sphere(centre, size))][k % 5])
    obstacles.append(obstacles[3])                 # an exact duplicate: ties go to the first
    scene = Scene(obstacles)
    pts = np.concatenate([rng.uniform(-0.8, 0.8, (5000, 3)), rng.uniform(-50, 50, (500, 3)),
                          [ob.aabb().mean(axis=0) for ob in obstacles]])
    d, g = scene.query(pts)
    each = [ob.query(pts) for ob in obstacles]
    ds = np.array([e[0] for e in each])
    nearest = np.argmin(ds, axis=0)
    assert np.array_equal(d, ds.min(axis=0)) and np.array_equal(d, scene.distance(pts))
    assert np.array_equal(g, np.array([e[1] for e in each])[nearest, np.arange(len(pts))])
    assert len(np.unique(nearest)) == 17 and not np.any(nearest == 17)


def test_query_gradient_matches_central_differences_away_from_medial_surfaces():
    scene = mixed_scene()
    rng = np.random.default_rng(22)
    pts = rng.uniform(-0.5, 0.5, (2000, 3))
    _, grad = scene.query(pts)
    keep = np.ones(len(pts), dtype=bool)        # drop points where the gradient jumps within 0.1 mm
    for _ in range(8):
        step = rng.normal(size=pts.shape)
        step *= 1e-4 / np.linalg.norm(step, axis=1, keepdims=True)
        keep &= np.linalg.norm(scene.query(pts + step)[1] - grad, axis=1) < 0.05
    assert keep.mean() > 0.97
    eps = 1e-6
    fd = np.stack([(scene.distance(pts[keep] + eps * e) - scene.distance(pts[keep] - eps * e)) / (2 * eps)
                   for e in np.eye(3)], axis=-1)
    assert np.abs(grad[keep] - fd).max() < 1e-6


def test_query_validates_points_once_at_the_boundary():
    scene = mixed_scene()
    with raises_naming(InvalidArgumentError, "points"):
        scene.query(np.zeros((5, 2)))
    with raises_naming(InvalidArgumentError, "points"):
        scene.query([[0.0, 0.0, np.inf]])
    with raises_naming(InvalidArgumentError, "points"):
        scene.distance("abc")


class MeshLike(Obstacle):
    """A non-primitive obstacle (as a mesh would be): exact kernel, but not a closed form."""

    kind = "meshlike"

    def __init__(self, sphere):
        self.sphere = sphere

    def _evaluate(self, coords, gradient):
        return self.sphere._evaluate(coords, gradient)

    def aabb(self):
        return self.sphere.aabb()

    def translated(self, offset):
        return MeshLike(self.sphere.translated(offset))

    def to_dict(self):
        return {"type": self.kind}


def test_distance_query_is_analytic_for_primitives_and_the_cached_grid_otherwise():
    scene = mixed_scene()
    assert scene.analytic and Scene().analytic
    query = scene.distance_query()
    assert query == scene.query                    # the bound method: no grid built
    assert scene.distance_query(0.005) == scene.query
    assert not scene._grids
    empty = Scene()
    assert empty.distance_query() == empty.query   # empty: analytic too
    gridded = scene.distance_query(0.01, grid=True)
    assert gridded == scene.sdf(0.01).query and len(scene._grids) == 1
    bounds = [[0.0, 0.0, 0.0], [0.3, 0.3, 0.3]]
    other = Scene([MeshLike(Sphere([0.15, 0.15, 0.15], 0.05)), Box([0.08, 0.08, 0.08], [0.06, 0.06, 0.06])],
                  bounds=bounds)
    assert not other.analytic
    query = other.distance_query()                 # default 1 cm grid
    assert query == other.sdf(0.01).query
    pts = np.random.default_rng(23).uniform(0.0, 0.3, (500, 3))
    assert np.abs(query(pts)[0] - other.distance(pts)).max() <= 0.01
    assert other.distance_query(0.01, exact=True) == other.sdf(0.01, exact=True).query
    with raises_naming(InvalidArgumentError, "cell_size"):
        scene.distance_query(0.02)
    with raises_naming(InvalidArgumentError, "cell_size"):
        scene.distance_query(-1.0)


def test_sdf_is_built_once_per_cell_size_and_mode_and_is_read_only():
    scene = Scene([Box([0.1, 0.1, 0.1], [0.05, 0.05, 0.05])], bounds=[[0, 0, 0], [0.2, 0.2, 0.2]])
    first = scene.sdf(0.01)
    assert scene.sdf(0.01) is first and scene.sdf() is first and scene.sdf(cell_size=0.01, exact=0) is first
    exact = scene.sdf(0.01, exact=True)
    assert exact is not first and scene.sdf(0.01, exact=True) is exact
    assert scene.sdf(0.005) is not first and scene.sdf(0.005).cell_size == 0.005
    with pytest.raises(ValueError, match="read-only"):
        first.values[0, 0, 0] = 1.0
    # another scene with the same content has its own cache
    twin = Scene(scene.obstacles, bounds=scene.bounds)
    assert twin.sdf(0.01) is not first and np.array_equal(twin.sdf(0.01).values, first.values)


def test_scene_is_immutable():
    scene = mixed_scene()
    assert isinstance(scene.obstacles, tuple)
    with pytest.raises(AttributeError):
        scene.obstacles = ()
    with pytest.raises(AttributeError):
        scene.bounds = DEFAULT_WORKSPACE
    with pytest.raises(ValueError, match="read-only"):
        scene.bounds[0, 0] = -5.0
    given = [Sphere([0, 0, 0], 0.1)]
    built = Scene(given)
    given.append(Sphere([0.5, 0, 0], 0.1))        # the caller's list is not the scene's
    assert len(built.obstacles) == 1


def test_grid_too_large_for_memory_raises_before_allocating():
    scene = Scene([Sphere([0, 0, 0], 0.1)], bounds=[[-10, -10, -10], [10, 10, 10]])
    with raises_naming(InvalidArgumentError, "cell_size", "(2001, 2001, 2001)"):
        scene.sdf(0.01)
    assert not scene._grids
    assert scene.distance_query(0.01) == scene.query   # the analytic query needs no grid
    shape, need = SignedDistanceField.estimate_build_bytes(scene.bounds, 0.01)
    assert shape == (2001, 2001, 2001) and need > 2 * 2**30


def test_capsule_scene_file_round_trip(tmp_path):
    scene = Scene([Capsule([0.1, -0.2, 0.3], 0.05, 0.2, axis=[1, 1, 0]), Box([0, 0, 0], [0.1, 0.1, 0.1])])
    path = tmp_path / "capsule.json"
    scene.save(path)
    raw = json.loads(path.read_text())
    assert raw["obstacles"][0] == {"type": "capsule", "center": [0.1, -0.2, 0.3], "radius": 0.05,
                                   "height": 0.2, "axis": list(np.array([1, 1, 0]) / np.sqrt(2))}
    loaded = Scene.load(path)
    assert loaded.obstacles == scene.obstacles and np.array_equal(loaded.bounds, scene.bounds)
    pts = np.random.default_rng(24).uniform(-0.5, 0.5, (100, 3))
    assert np.allclose(loaded.query(pts)[0], scene.query(pts)[0], rtol=0, atol=1e-15)
    path.write_text(json.dumps({"obstacles": [{"type": "capsule", "center": [0, 0, 0], "radius": 0.1,
                                               "height": -1}]}))
    with raises_naming(SceneFileError, "capsule.json", "obstacles[0]", "height"):
        Scene.load(path)
