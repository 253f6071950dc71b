"""Scenes at perception scale: the spatial index behind Scene.query against brute force, triangle
mesh and point cloud obstacles (exact distances, coal shapes, scene files, bad input) and a plan
that avoids both, checked with coal directly."""
from __future__ import annotations

import json

import coal
import numpy as np
import pinocchio as pin
import pytest

from bad_input import raises_naming
from scenes import Box, Capsule, Cylinder, PointCloud, Scene, SceneFileError, Sphere, TriangleMesh
from scenes.coal_shapes import coal_obstacle_owners, coal_obstacles
from scenes.errors import InvalidArgumentError, InvalidObstacleError, OutputPathError
from scenes.mesh import box_triangles
from scenes.nearest import INDEX_FROM

def table_mesh(top_centre, top_size, thickness, leg) -> TriangleMesh:
    """A closed mesh of a pedestal table: a top slab and one square leg down to z = 0."""
    x, y, z = top_centre
    v1, f1 = box_triangles([x, y, z - thickness / 2], [top_size[0], top_size[1], thickness])
    v2, f2 = box_triangles([x, y, (z - thickness) / 2], [leg, leg, z - thickness])
    return TriangleMesh(np.vstack([v1, v2]), np.vstack([f1, f2 + 8]))


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.linalg.det(q)


def random_scene(rng: np.random.Generator, count: int) -> list:
    """Every kind of obstacle, of sizes spanning two orders of magnitude, in a 1.2 m cube."""
    obstacles = []
    for k in range(count):
        centre, scale = rng.uniform(-0.6, 0.6, 3), 10 ** rng.uniform(-2.0, -0.5)
        kind = k % 6
        if kind == 0:
            obstacles.append(Box(centre, scale * rng.uniform(0.3, 1.0, 3), random_rotation(rng)))
        elif kind == 1:
            obstacles.append(Sphere(centre, scale))
        elif kind == 2:
            obstacles.append(Cylinder(centre, scale, 2 * scale, rng.normal(size=3)))
        elif kind == 3:
            obstacles.append(Capsule(centre, scale, scale, rng.normal(size=3)))
        elif kind == 4:
            obstacles.append(PointCloud(centre + scale * rng.normal(size=(20, 3)), scale * rng.uniform(0.1, 0.3, 20)))
        else:
            vertices, faces = box_triangles(centre, scale * rng.uniform(0.3, 1.0, 3))
            obstacles.append(TriangleMesh(vertices @ random_rotation(rng).T, faces))
    return obstacles


def brute_force(obstacles, points) -> tuple[np.ndarray, np.ndarray]:
    """Least distance over every obstacle's own query, the first listed winning ties."""
    d, g = obstacles[0].query(points)
    for ob in obstacles[1:]:
        dk, gk = ob.query(points)
        closer = dk < d
        d, g = np.where(closer, dk, d), np.where(closer[:, None], gk, g)
    return d, g


# ------------------------------------------------------------------------- the spatial index
@pytest.mark.parametrize("seed, count", [(0, INDEX_FROM), (1, 60), (2, 250)])
def test_index_answers_equal_brute_force(seed, count):
    rng = np.random.default_rng(seed)
    obstacles = random_scene(rng, count)
    scene = Scene(obstacles)
    points = rng.uniform(-0.8, 0.8, (2000, 3))
    want_d, want_g = brute_force(obstacles, points)
    d, g = scene.query(points)
    np.testing.assert_array_equal(d, want_d)
    np.testing.assert_array_equal(g, want_g)
    np.testing.assert_array_equal(scene.distance(points), want_d)
    for cap in (0.01, 0.08):
        d, g = scene.query(points, max_distance=cap)
        near = want_d <= cap
        assert near.any() and (~near).any()
        # equal to rounding: a mesh's point nearest a shared edge may be measured on either face
        np.testing.assert_allclose(d, np.minimum(want_d, cap), rtol=0, atol=1e-15)
        np.testing.assert_allclose(g[near], want_g[near], rtol=0, atol=1e-12)
        assert not g[~near].any()


def test_bounded_query_is_the_planner_query_and_checks_its_bound():
    scene = Scene(random_scene(np.random.default_rng(3), 20))
    points = np.random.default_rng(4).uniform(-0.8, 0.8, (500, 3))
    query = scene.distance_query(max_distance=0.05)
    np.testing.assert_array_equal(query(points)[0], scene.query(points, max_distance=0.05)[0])
    assert scene.distance_query() == scene.query
    assert Scene().query(points, max_distance=0.05)[0].max() == 0.05      # empty scene: the cap
    for bad in (0.0, -1.0, float("nan"), "far"):
        with raises_naming(InvalidArgumentError, "max_distance"):
            scene.query(points, max_distance=bad)


# ------------------------------------------------------------------------- triangle meshes
def test_closed_mesh_distance_equals_the_box_it_meshes_and_its_gradient_is_exact():
    rng = np.random.default_rng(5)
    rotation = random_rotation(rng)
    vertices, faces = box_triangles([0, 0, 0], [0.4, 0.3, 0.2])
    box = Box([0.1, 0.2, 0.3], [0.4, 0.3, 0.2], rotation)
    points = rng.uniform(-0.4, 0.6, (4000, 3))
    for order in (faces, faces[:, [0, 2, 1]]):                 # inward faces are turned outward
        mesh = TriangleMesh(vertices @ rotation.T + [0.1, 0.2, 0.3], order)
        assert mesh.closed
        d, g = mesh.query(points)
        want_d, want_g = box.query(points)
        assert (want_d < 0).any()
        np.testing.assert_allclose(d, want_d, atol=1e-12)
        np.testing.assert_allclose(g, want_g, atol=1e-9)
    h = 1e-6                                                   # central differences
    for axis in range(3):
        step = np.eye(3)[axis] * h
        numeric = (mesh.distance(points + step) - mesh.distance(points - step)) / (2 * h)
        smooth = np.abs(numeric - g[:, axis]) < 1e-3
        assert smooth.mean() > 0.99


def test_open_mesh_is_unsigned_and_mesh_bounds_cover_it():
    vertices, faces = box_triangles([0, 0, 0], [0.2, 0.2, 0.2])
    surface = TriangleMesh(vertices, faces[:10])               # the top's triangles missing: no inside
    assert not surface.closed
    points = np.random.default_rng(6).uniform(-0.3, 0.3, (2000, 3))
    d = surface.distance(points)
    assert d.min() >= 0.0
    inside = np.all(np.abs(points) < 0.1, axis=1)              # the top (z = +0.1) is missing
    x, y, z = points[inside].T
    np.testing.assert_allclose(d[inside], np.minimum.reduce([0.1 - np.abs(x), 0.1 - np.abs(y), 0.1 + z]),
                               atol=1e-12)
    outside = np.all(np.abs(points) > 0.1, axis=1)             # nearest a corner: as the box
    np.testing.assert_allclose(d[outside], Box([0, 0, 0], [0.2, 0.2, 0.2]).distance(points[outside]), atol=1e-12)
    np.testing.assert_allclose(surface.aabb(), [[-0.1] * 3, [0.1] * 3])


def test_point_cloud_equals_its_spheres():
    rng = np.random.default_rng(7)
    centres = rng.uniform(-0.2, 0.2, (300, 3))
    points = rng.uniform(-0.4, 0.4, (3000, 3))
    for radius in (0.02, rng.uniform(0.005, 0.04, 300)):
        cloud = PointCloud(centres, radius)
        spheres = [Sphere(c, r) for c, r in zip(centres, np.broadcast_to(radius, 300))]
        want_d, want_g = brute_force(spheres, points)
        d, g = cloud.query(points)
        np.testing.assert_allclose(d, want_d, atol=1e-15)
        np.testing.assert_allclose(g, want_g, atol=1e-12)


def test_coal_shapes_of_mesh_and_cloud_measure_the_same_distances():
    rng = np.random.default_rng(8)
    vertices, faces = box_triangles([0.1, 0.0, 0.2], [0.3, 0.2, 0.1])
    mesh = TriangleMesh(vertices, faces)
    cloud = PointCloud(rng.uniform(-0.1, 0.1, (5, 3)) + [-0.3, 0.2, 0.0], 0.03)
    scene = Scene([Sphere([0.5, 0.5, 0.5], 0.05), cloud, mesh])
    triples = coal_obstacles(scene)
    names = [t[0] for t in triples]
    assert names == ["sphere_0"] + [f"point_cloud_1[{j}]" for j in range(5)] + ["mesh_2"]
    np.testing.assert_array_equal(coal_obstacle_owners(scene), [0, 1, 1, 1, 1, 1, 2])
    probe, request = coal.Sphere(1e-9), coal.DistanceRequest()
    points = rng.uniform(-0.6, 0.6, (50, 3))
    for obstacle, owner in ((cloud, 1), (mesh, 2)):
        parts = [t for t, o in zip(triples, coal_obstacle_owners(scene)) if o == owner]
        by_coal = np.array([min(coal.distance(probe, coal.Transform3s(np.eye(3), p), shape,
                                              coal.Transform3s(placement[:3, :3], placement[:3, 3]),
                                              request, coal.DistanceResult()) for _, shape, placement in parts)
                            for p in points])
        exact = obstacle.distance(points)
        outside = exact > 1e-6
        np.testing.assert_allclose(by_coal[outside], exact[outside], atol=2e-6)


# ------------------------------------------------------------------------------ scene files
@pytest.mark.parametrize("arrays", ["inline", "npz"])
def test_scene_files_with_mesh_and_cloud_round_trip(tmp_path, arrays):
    rng = np.random.default_rng(9)
    scene = Scene([table_mesh([0.4, -0.3, 0.3], [0.2, 0.2], 0.03, 0.04),
                   PointCloud(rng.uniform(-0.3, 0.3, (500, 3)), 0.01),
                   PointCloud(rng.uniform(-0.3, 0.3, (50, 3)), rng.uniform(0.01, 0.02, 50)),
                   Box([0.1, 0.1, 0.1], [0.1, 0.1, 0.1])])
    path = tmp_path / "scene.json"
    scene.save(path, arrays=arrays)
    sidecars = sorted(p.name for p in tmp_path.glob("*.npz"))
    assert sidecars == ([] if arrays == "inline" else
                        ["scene.obstacle0.npz", "scene.obstacle1.npz", "scene.obstacle2.npz"])
    loaded = Scene.load(path)
    assert list(loaded.obstacles) == list(scene.obstacles)
    np.testing.assert_array_equal(loaded.bounds, scene.bounds)
    points = rng.uniform(-0.5, 0.5, (1000, 3))
    np.testing.assert_array_equal(loaded.distance(points), scene.distance(points))
    before = sorted(tmp_path.iterdir())
    with raises_naming(OutputPathError, path.name):
        scene.save(path, overwrite=False, arrays=arrays)
    assert sorted(tmp_path.iterdir()) == before                  # nothing written


def test_bad_mesh_and_cloud_input_names_the_argument(tmp_path):
    vertices, faces = box_triangles([0, 0, 0], [0.1, 0.1, 0.1])
    bad_faces = faces.copy()
    bad_faces[3, 1] = 8
    with raises_naming(InvalidObstacleError, "TriangleMesh faces", "face 3"):
        TriangleMesh(vertices, bad_faces)
    with raises_naming(InvalidObstacleError, "TriangleMesh faces"):
        TriangleMesh(vertices, faces[:, :2])
    with raises_naming(InvalidObstacleError, "TriangleMesh faces", "face 0"):
        TriangleMesh(vertices, [[0, 0, 1]])
    with raises_naming(InvalidObstacleError, "TriangleMesh vertices"):
        TriangleMesh(np.where(np.arange(24).reshape(8, 3) == 5, np.nan, vertices), faces)
    with raises_naming(InvalidObstacleError, "PointCloud points"):
        PointCloud([[0, 0, 0], [np.nan, 0, 0]], 0.01)
    with raises_naming(InvalidObstacleError, "PointCloud points"):
        PointCloud(np.zeros((0, 3)), 0.01)
    with raises_naming(InvalidObstacleError, "PointCloud radius"):
        PointCloud([[0, 0, 0]], 0.0)
    with raises_naming(InvalidObstacleError, "PointCloud radius"):
        PointCloud([[0, 0, 0], [1, 0, 0]], [0.1, 0.1, 0.1])
    cases = [
        ({"type": "mesh", "vertices": vertices.tolist(), "faces": bad_faces.tolist()},
         ("obstacles[0]", "TriangleMesh faces", "face 3")),
        ({"type": "point_cloud", "points": [], "radius": 0.01}, ("obstacles[0]", "PointCloud points")),
        ({"type": "point_cloud", "points": [[0, 0, "x"]], "radius": 0.01}, ("obstacles[0]", "PointCloud points")),
        ({"type": "point_cloud", "points": [[0, 0, 0]]}, ("obstacles[0]", "radius")),
        ({"type": "mesh", "file": "missing.npz"}, ("obstacles[0].file", "missing.npz")),
        ({"type": "mesh", "file": "x.npz", "faces": []}, ("obstacles[0]", "faces")),
        ({"type": "cone"}, ("obstacles[0].type", "cone")),
    ]
    for k, (entry, names) in enumerate(cases):
        path = tmp_path / f"bad{k}.json"
        path.write_text(json.dumps({"obstacles": [entry]}))
        with raises_naming(SceneFileError, path.name, *names):
            Scene.load(path)
    np.savez(tmp_path / "cloud.npz", points=np.array([[0.0, 0.0, np.nan]]), radius=0.01)
    (tmp_path / "nan.json").write_text(json.dumps({"obstacles": [{"type": "point_cloud", "file": "cloud.npz"}]}))
    with raises_naming(SceneFileError, "nan.json", "obstacles[0]", "cloud.npz", "PointCloud points"):
        Scene.load(tmp_path / "nan.json")
    with raises_naming(InvalidArgumentError, "arrays"):
        Scene().save(tmp_path / "x.json", arrays="hdf5")


# --------------------------------------------------------------------------------- planning
def coal_collides(robot, shapes: list, q: np.ndarray) -> bool:
    """Whether coal finds the robot's moving URDF collision geometry touching any of ``shapes``
    ((coal shape, 4x4 placement in the base frame), built by the test itself) at any q (K, n)."""
    gmodel = pin.GeometryModel()
    moving = [obj for obj in robot.collision_model.geometryObjects if obj.parentJoint != 0]
    for obj in moving:
        gmodel.addGeometryObject(pin.GeometryObject(obj))
    base_in_root = pin.SE3(robot.chain.base_rotation, robot.chain.base_translation).inverse()
    for j, (shape, placement) in enumerate(shapes):
        gmodel.addGeometryObject(pin.GeometryObject(f"obstacle{j}", 0, 0,
                                                    base_in_root * pin.SE3(placement[:3, :3], placement[:3, 3]), shape))
    for g in range(len(moving)):
        for j in range(len(shapes)):
            gmodel.addCollisionPair(pin.CollisionPair(g, len(moving) + j))
    gdata, data = pin.GeometryData(gmodel), robot.model.createData()
    return any(pin.computeCollisions(robot.model, data, gmodel, gdata, q_pin, True)
               for q_pin in robot.to_pinocchio(q))


def test_plan_avoids_a_table_mesh_and_a_point_cloud_checked_with_coal(jaco):
    from clamp import learn_prior, plan
    from scenes import make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    start = [0.2054, -0.4722, 0.2625]
    free = plan(prior, jaco, None, start, covariance=False)
    table = table_mesh([0.38, -0.31, 0.40], [0.14, 0.14], 0.03, 0.04)   # its top under the free path
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(30, 3))
    cloud_points = [0.43, -0.24, 0.22] + 0.04 * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    cloud = PointCloud(cloud_points, 0.02)
    # the test's own coal shapes: the table's triangles and a sphere per point
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(table.faces), len(table.vertices))
    model.addVertices(np.asarray(table.vertices))
    model.addTriangles(np.asarray(table.faces, dtype=np.int64))
    model.endModel()
    shapes = [(model, np.eye(4))]
    for x in cloud_points:
        placement = np.eye(4)
        placement[:3, 3] = x
        shapes.append((coal.Sphere(0.02), placement))
    assert coal_collides(jaco, shapes, free.q)                  # the obstacles are in the way
    result = plan(prior, jaco, Scene([table, cloud]), start, covariance=False)
    # the table and the cloud sit on the skill's path: the plan goes around them, and the
    # verdict may say it left the skill doing so (issue 19), but never that it collides
    assert not any(r.startswith(("collision", "self-collision")) for r in result.reasons), \
        result.reasons
    assert result.min_clearance > 0.0
    # between support states too: 4 joint-space steps per segment
    steps = np.linspace(0.0, 1.0, 4, endpoint=False)
    dense = (result.q[:-1, None] + steps[None, :, None] * np.diff(result.q, axis=0)[:, None]).reshape(-1, jaco.n)
    assert not coal_collides(jaco, shapes, np.vstack([dense, result.q[-1:]]))
    # and nothing of the arm inside the closed table: its spheres' centres are outside
    centres = jaco.sphere_centres(result.q)[0].reshape(-1, 3)
    assert table.distance(centres).min() > 0.0


def test_animation_draws_mesh_and_cloud(jaco, tmp_path):
    pytest.importorskip("meshcat", reason="the animation needs meshcat (pip install meshcat)")
    import meshcat.geometry as mg
    from clamp.viz.animation import _obstacle_geometry, write_animation
    table = table_mesh([0.38, -0.31, 0.40], [0.14, 0.14], 0.03, 0.04)
    geometry, placement = _obstacle_geometry(table, 0, mg, pin)
    np.testing.assert_allclose(geometry.vertices, table.vertices, atol=1e-6)   # scene frame (float32)
    np.testing.assert_array_equal(geometry.faces, table.faces)
    np.testing.assert_array_equal(placement, np.eye(4))
    cloud = PointCloud([[0.4, 0.0, 0.3], [0.4, 0.1, 0.3]], 0.02)
    q = np.linspace(np.zeros(jaco.n), np.full(jaco.n, 0.5), 5) + jaco.neutral_configuration()
    path = write_animation(tmp_path / "a.html", jaco, np.linspace(0.0, 1.0, 5), q, obstacles=[table, cloud])
    assert path.stat().st_size > 0


def test_far_obstacles_leave_the_plan_unchanged(jaco):
    """150 boxes out of the arm's reach (beyond INDEX_FROM: the index and the hinge's reach
    decide what is measured) give the very plan of the near box alone."""
    from clamp import learn_prior, plan
    from scenes import make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    start = [0.2054, -0.4722, 0.2625]
    box = Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])
    rng = np.random.default_rng(12)
    angle, radius = rng.uniform(0, 2 * np.pi, 150), rng.uniform(1.5, 3.0, 150)
    far = [Box([r * np.cos(a), r * np.sin(a), z], s) for a, r, z, s in
           zip(angle, radius, rng.uniform(-0.5, 1.5, 150), rng.uniform(0.02, 0.1, (150, 3)))]
    alone = plan(prior, jaco, Scene([box]), start, covariance=False)
    crowded = plan(prior, jaco, Scene([box] + far), start, covariance=False)
    assert alone.success and crowded.success
    np.testing.assert_array_equal(crowded.q, alone.q)
    assert crowded.iterations == alone.iterations
