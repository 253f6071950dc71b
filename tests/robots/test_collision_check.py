"""Trajectory collision check on the robots' URDF collision geometry (robots.collision_check) and
the scene -> coal conversion it takes its obstacles from (scenes.coal_shapes).

Every distance the checker reports is coal's: the brute-force references here are coal on every
pair with the full meshes (CollisionChecker.distances) and pin.computeDistances
(CollisionChecker.reference_distances)."""
from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from bad_input import raises_naming
from robots import Robot, RobotError, SphereModel
from robots import collision_check
from robots.collision_check import REACH, SLACK, CollisionChecker, CollisionReport
from robots.errors import CollisionCheckError, InvalidArrayError
from scenes import Box, Capsule, Cylinder, Scene, Sphere
from scenes.coal_shapes import coal_obstacles, coal_shape
from scenes.errors import InvalidArgumentError

# The probe of issue 9: a Jaco configuration whose fingertip mesh reaches ~2 mm into a 4 cm box
# that the collision spheres clear by +6.3 mm (coal's mesh depth: the depth of a penetrating
# triangle, about 1 mm here).
PROBE_Q = np.array([0.8342, 2.7134, 4.9144, 0.894, 2.2859, 0.0])
PROBE_BOX = Box([0.2271, -0.3773, 0.1763], [0.04, 0.04, 0.04])


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.linalg.det(q)


def random_obstacles(rng: np.random.Generator, near: np.ndarray, count: int) -> list:
    """Boxes (rotated), spheres, cylinders and capsules (arbitrary axes) around points `near`."""
    obstacles = []
    for k in range(count):
        centre = near[rng.integers(len(near))] + rng.normal(0.0, 0.1, 3)
        kind = k % 4
        if kind == 0:
            obstacles.append(Box(centre, rng.uniform(0.02, 0.12, 3), random_rotation(rng)))
        elif kind == 1:
            obstacles.append(Sphere(centre, rng.uniform(0.01, 0.06)))
        elif kind == 2:
            obstacles.append(Cylinder(centre, rng.uniform(0.01, 0.05), rng.uniform(0.02, 0.2), rng.normal(size=3)))
        else:
            obstacles.append(Capsule(centre, rng.uniform(0.01, 0.05), rng.uniform(0.0, 0.2), rng.normal(size=3)))
    return obstacles


def sphere_clearance(robot: Robot, obstacles, q: np.ndarray) -> np.ndarray:
    """The optimiser's clearance per state (T,): exact scene distance of every sphere centre minus its radius."""
    centres, _ = robot.sphere_centres(q)
    return (Scene(obstacles).distance(centres) - robot.spheres.radii).min(axis=1)


# ---------------------------------------------------------------------------------- the probe
def test_probe_fingertip_mesh_penetrates_the_box_the_spheres_clear(jaco):
    q = np.stack([PROBE_Q, PROBE_Q])
    obstacles = coal_obstacles([PROBE_BOX], names=["probe_box"])
    report = CollisionChecker(jaco, obstacles).check(q)
    assert isinstance(report, CollisionReport) and report.geometry == "urdf"
    assert report.collision and report.min_distance < 0.0
    assert "finger_tip" in report.nearest.link and report.nearest.obstacle == "probe_box"
    assert -0.004 < report.nearest.distance < -0.0005            # coal: about 1 mm deep
    assert report.nearest.distance == report.min_distance
    assert report.min_distance == pytest.approx(CollisionChecker(jaco, obstacles).distances(q).min(), abs=0)
    np.testing.assert_allclose(report.state_distance, report.min_distance)
    assert report.states_in_collision.all()

    spheres = CollisionChecker(jaco, obstacles, geometry="spheres").check(q)
    assert spheres.geometry == "spheres" and not spheres.collision
    np.testing.assert_allclose(spheres.min_distance, sphere_clearance(jaco, [PROBE_BOX], q).min(), atol=1e-12)
    assert spheres.min_distance == pytest.approx(0.0063, abs=0.0002)


# -------------------------------------------------------------- agreement with brute force
@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_distances_are_coal_on_every_pair_and_hulls_bound_them(name, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(7)
    q = np.array([robot.random_configuration(rng) for _ in range(4)])
    near = robot.frame_positions(q)[:, 2:].reshape(-1, 3)
    obstacles = random_obstacles(rng, near, 8)
    # any other coal shape goes to coal as it is (here an ellipsoid placed as a 4x4 matrix)
    placement = np.eye(4)
    placement[:3, :3], placement[:3, 3] = random_rotation(rng), near[0] + [0.05, 0.0, 0.0]
    ellipsoid = ("ellipsoid", coal.Ellipsoid(0.03, 0.05, 0.02), placement)
    checker = CollisionChecker(robot, coal_obstacles(obstacles) + [ellipsoid])
    mine = checker.distances(q)                                 # coal.distance, every pair, full meshes
    reference = checker.reference_distances(q)                  # pin.computeDistances, every pair
    assert mine.shape == reference.shape == (4, len(checker.geometry_names), 9)
    apart = (mine > 1e-6) & (reference > 1e-6)
    assert apart.mean() > 0.8
    np.testing.assert_allclose(mine[apart], reference[apart], atol=3e-6, rtol=0)     # coal's GJK tolerance
    overlap = ~apart
    np.testing.assert_array_equal(mine[overlap] <= 1e-6, reference[overlap] <= 1e-6)
    hull = checker.hull_distances(q)                            # convex bounds: lower bounds
    assert np.all(hull <= mine + SLACK)
    if name == "jaco":                                          # meshes: their hulls are below them
        assert np.any(hull < mine - 0.003) and np.any(hull[overlap] < 0.0)
    else:                                                       # primitives: their own bound
        np.testing.assert_array_equal(hull, mine)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_check_is_exact_against_every_pair_at_every_configuration(name, seed, request):
    """Bounds and pruning never change the verdict, the minimum or the nearest pair against
    coal on every pair at every checked configuration; state values are exact below the
    margin and lower bounds at least the margin elsewhere."""
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(seed)
    ends = np.array([robot.random_configuration(rng) for _ in range(2)])
    q = np.linspace(ends[0], ends[1], 5) + rng.normal(0.0, 0.05, (5, robot.n))
    obstacles = random_obstacles(rng, robot.frame_positions(q)[:, 2:].reshape(-1, 3), 3)
    checker = CollisionChecker(robot, coal_obstacles(obstacles))
    time = np.linspace(0.0, 2.5, 5)
    max_motion = 0.03
    sub = checker.configurations(q, max_motion=max_motion)
    tally = sum(checker.tally.values())
    every = checker.distances(sub.q)                                   # (K, G, O), coal on every pair
    brute_force = sum(checker.tally.values()) - tally                  # its coal queries
    states = every[sub.support].min(axis=(1, 2))
    margin = float(np.mean(np.sort(states)[1:3]))                      # two states closer, three not
    report = checker.check(q, time, margin=margin, max_motion=max_motion)
    assert report.num_configurations == len(sub.q) > len(q)
    assert report.min_distance == pytest.approx(every.min(), abs=SLACK)
    assert report.collision == (every.min() < margin)
    k = int(np.flatnonzero(sub.index == report.nearest.index)[0])
    g = checker.geometry_names.index(report.nearest.geometry)
    o = checker.obstacle_names.index(report.nearest.obstacle)
    assert every[k, g, o] == report.min_distance                       # a real pair's coal distance
    assert report.nearest.link == checker.link_names[g]
    i = min(int(report.nearest.index), 3)
    assert time[i] <= report.nearest.time <= time[i + 1]
    assert report.lower_bound == pytest.approx(report.min_distance - report.max_step / 2)
    close = states < margin
    assert close.sum() == 2
    np.testing.assert_allclose(report.state_distance[close], states[close], atol=SLACK, rtol=0)
    assert np.all(report.state_distance[~close] >= margin)
    assert np.all(report.state_distance <= states + SLACK)
    np.testing.assert_array_equal(report.states_in_collision, close)
    assert report.num_exact + report.num_hull < brute_force / 4        # the bounds do prune
    if name == "sawyer":                                               # primitives: no hulls
        assert report.num_hull == 0


def test_every_distance_is_a_coal_query(jaco, monkeypatch):
    """The checker computes no distance of its own: each one it uses is a coal.distance call,
    counted in num_exact (collision geometry) or num_hull (convex hulls)."""
    calls = []
    distance = coal.distance

    def counting(*args):
        calls.append(type(args[0]).__name__)
        return distance(*args)

    rng = np.random.default_rng(4)
    ends = np.array([jaco.random_configuration(rng) for _ in range(2)])
    q = np.linspace(ends[0], ends[1], 4)
    obstacles = random_obstacles(rng, jaco.frame_positions(q)[:, 2:].reshape(-1, 3), 4)
    checker = CollisionChecker(jaco, coal_obstacles(obstacles))
    monkeypatch.setattr(collision_check.coal, "distance", counting)
    report = checker.check(q, margin=0.01)
    assert len(calls) == report.num_exact + report.num_hull > 0
    assert calls.count("Convex") == report.num_hull > 0
    assert calls.count("BVHModelOBBRSS") == report.num_exact > 0


def test_obstacle_inside_a_hull_but_clear_of_the_mesh_is_no_collision(jaco):
    """A hull overlap is only a bound: the verdict comes from coal's mesh distance."""
    rng = np.random.default_rng(8)
    q = PROBE_Q[None]
    model, geometry = jaco.model, jaco.collision_model
    data, gdata = model.createData(), pin.GeometryData(geometry)
    pin.updateGeometryPlacements(model, data, geometry, gdata, jaco.to_pinocchio(q)[0])
    hand = geometry.getGeometryId("j2s6s200_link_6_0")
    vertices = np.asarray(geometry.geometryObjects[hand].geometry.vertices())
    pairs = rng.integers(len(vertices), size=(60, 2))
    local = 0.5 * (vertices[pairs[:, 0]] + vertices[pairs[:, 1]])   # midpoints of chords: in the hull
    placement = gdata.oMg[hand]
    in_root = local @ np.asarray(placement.rotation).T + placement.translation
    in_base = in_root @ jaco.chain.base_rotation.T + jaco.chain.base_translation
    balls = [Sphere(p, 0.002) for p in in_base]
    probe = CollisionChecker(jaco, coal_obstacles(balls))
    g = probe.geometry_names.index("j2s6s200_link_6_0")
    hull = probe.hull_distances(q)[0, g]
    mesh = probe.distances(q)[0].min(axis=0)                          # every link, per ball
    inside = np.flatnonzero((hull < 0.0) & (mesh > 0.004))
    assert inside.size
    ball = balls[int(inside[np.argmax(mesh[inside])])]
    checker = CollisionChecker(jaco, coal_obstacles([ball], names=["ball"]))
    report = checker.check(np.vstack([q, q]))
    assert not report.collision and report.min_distance > 0.004
    assert report.min_distance == pytest.approx(checker.distances(q).min(), abs=SLACK)
    assert report.num_exact >= 1


def test_poses_recomputed_per_batch_give_the_same_report(jaco, monkeypatch):
    """Long trajectories do not keep every pose: the same report either way."""
    rng = np.random.default_rng(6)
    q = np.array([jaco.random_configuration(rng) for _ in range(3)])
    obstacles = coal_obstacles(random_obstacles(rng, jaco.frame_positions(q)[:, 2:].reshape(-1, 3), 3))
    kept = CollisionChecker(jaco, obstacles).check(q, margin=0.01, max_motion=0.02)
    monkeypatch.setattr(collision_check, "_POSE_CACHE", 0)
    monkeypatch.setattr(collision_check, "_CHUNK", 7)
    batched = CollisionChecker(jaco, obstacles).check(q, margin=0.01, max_motion=0.02)
    assert batched.min_distance == kept.min_distance and batched.nearest == kept.nearest
    np.testing.assert_array_equal(batched.state_distance, kept.state_distance)
    assert (batched.num_exact, batched.num_hull) == (kept.num_exact, kept.num_hull)


# ---------------------------------------------------------------------- between support states
def test_thin_obstacle_crossed_between_two_clear_states_is_found(jaco):
    """The base joint turns 1 rad; a 5 mm plate stands across the fingertips' arc half way."""
    start = np.array([-0.52, 2.97, 4.80, 0.0, 2.14, 0.0])
    end = start + np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    middle = 0.5 * (start + end)
    tip = jaco.frame_position(middle, "j2s6s200_link_finger_tip_1")
    radial = np.array([tip[0], tip[1], 0.0]) / np.hypot(tip[0], tip[1])
    tangent = np.cross([0.0, 0.0, 1.0], radial)
    plate = Box(tip, [0.04, 0.005, 0.04], np.column_stack([radial, tangent, [0.0, 0.0, 1.0]]))
    checker = CollisionChecker(jaco, coal_obstacles([plate], names=["plate"]))
    q = np.stack([start, end])

    only_states = checker.check(q, max_motion=10.0, resolution=None)   # no configuration in between
    assert only_states.num_configurations == 2 and not only_states.collision
    assert np.all(only_states.state_distance > 0.03)
    certified = checker.check(q, max_motion=10.0)          # the certified bound refines the segment
    assert certified.collision and certified.nearest.obstacle == "plate"
    assert 0.0 < certified.nearest.index < 1.0

    report = checker.check(q, time=[0.0, 2.0])
    assert np.all(report.state_distance > 0.03)                        # both support states clear
    assert report.collision and report.min_distance < 0.0
    assert report.nearest.obstacle == "plate" and 0.0 < report.nearest.index < 1.0
    assert 0.0 < report.nearest.time < 2.0
    assert report.num_configurations > 20 and report.max_step <= 0.005


# ------------------------------------------------------------------------------ motion bound
def _surface_points(geometry, rng: np.random.Generator) -> np.ndarray:
    """Points on a collision geometry, in its own frame: mesh vertices (a seeded subset) or the
    extreme points of a primitive (box corners, cylinder rims, capsule tips and rims)."""
    kind = type(geometry).__name__
    if kind.startswith("BVHModel"):
        vertices = np.asarray(geometry.vertices())
        return vertices[rng.choice(len(vertices), size=min(300, len(vertices)), replace=False)]
    angle = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    if kind == "Box":
        return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * geometry.halfSide
    if kind == "Sphere":
        return geometry.radius * np.vstack([np.eye(3), -np.eye(3)])
    r, h = geometry.radius, geometry.halfLength
    rims = [np.column_stack([r * np.cos(angle), r * np.sin(angle), np.full(16, z)]) for z in (-h, h)]
    tips = [[[0.0, 0.0, h + r], [0.0, 0.0, -h - r]]] if kind == "Capsule" else []
    return np.vstack(rims + tips)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_no_link_point_moves_more_than_max_motion_between_checks(name, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(3)
    q = np.array([robot.random_configuration(rng) for _ in range(3)])
    checker = CollisionChecker(robot, coal_obstacles([Sphere([2.0, 0.0, 0.0], 0.1)]))
    max_motion = 0.01
    sub = checker.configurations(q, max_motion)
    assert len(sub.q) > 10 * len(q)
    np.testing.assert_array_equal(sub.q[sub.support], q)
    assert np.all(sub.step <= max_motion)
    # positions of sampled surface points by Pinocchio (independent of the checker's kinematics)
    model, geometry = robot.model, robot.collision_model
    data, gdata = model.createData(), pin.GeometryData(geometry)
    moving = [obj for obj in geometry.geometryObjects if obj.parentJoint != 0]
    points = [_surface_points(obj.geometry, rng) for obj in moving]
    index = [geometry.getGeometryId(obj.name) for obj in moving]
    positions = []
    for q_pin in robot.to_pinocchio(sub.q):
        pin.forwardKinematics(model, data, q_pin)
        pin.updateGeometryPlacements(model, data, geometry, gdata)
        positions.append(np.concatenate([pts @ np.asarray(gdata.oMg[i].rotation).T + gdata.oMg[i].translation
                                         for i, pts in zip(index, points)]))
    motion = np.linalg.norm(np.diff(np.array(positions), axis=0), axis=2).max(axis=1)
    assert motion.max() <= max_motion + 1e-12
    assert motion.max() > 0.3 * max_motion                            # the bound is not absurdly loose


# ---------------------------------------------------------------------------- sphere fallback
def test_robot_without_collision_geometry_falls_back_to_its_spheres(jaco):
    bare = Robot(jaco.model, jaco.end_effector, spheres=jaco.spheres, base_frame=jaco.base_frame)
    rng = np.random.default_rng(5)
    q = np.array([bare.random_configuration(rng) for _ in range(4)])
    obstacles = random_obstacles(rng, bare.frame_positions(q)[:, 2:].reshape(-1, 3), 4)
    checker = CollisionChecker(bare, coal_obstacles(obstacles))
    assert checker.geometry == "spheres"
    report = checker.check(q, max_motion=0.05)
    assert report.geometry == "spheres" and report.to_dict()["geometry"] == "spheres"
    expected = sphere_clearance(bare, obstacles, q)
    near = expected < REACH                  # farther states: a bound, at least the broad phase's reach
    assert near.any() and np.all(report.state_distance[~near] >= REACH)
    np.testing.assert_allclose(report.state_distance[near], expected[near], atol=1e-12)
    assert "#" in report.nearest.geometry and report.nearest.link in bare.spheres.link_names
    forced = CollisionChecker(jaco, coal_obstacles(obstacles), geometry="spheres").check(q, max_motion=0.05)
    np.testing.assert_allclose(forced.state_distance, report.state_distance, atol=1e-12)
    assert forced.min_distance == pytest.approx(report.min_distance, abs=1e-12)
    with raises_naming(CollisionCheckError, "geometry"):
        CollisionChecker(bare, [], geometry="urdf")


URDF_WITHOUT_COLLISION = """<robot name="bare">
  <link name="base"/>
  <link name="upper"><visual><geometry><box size="0.1 0.1 0.3"/></geometry></visual></link>
  <link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="upper"/><child link="tool"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>
"""


def test_urdf_without_collision_elements_falls_back_to_spheres(tmp_path):
    path = tmp_path / "bare.urdf"
    path.write_text(URDF_WITHOUT_COLLISION)
    spheres = SphereModel(("upper", "tool"), [[0.0, 0.0, 0.15], [0.0, 0.0, 0.05]], [0.06, 0.04])
    robot = Robot.from_urdf(path, end_effector="tool", spheres=spheres)
    assert robot.collision_model.ngeoms == 0
    obstacle = Sphere([0.2, 0.0, 0.35], 0.05)
    q = np.array([[0.0, 0.0], [0.0, 1.2]])
    report = CollisionChecker(robot, coal_obstacles([obstacle])).check(q)
    assert report.geometry == "spheres"
    np.testing.assert_allclose(report.state_distance, sphere_clearance(robot, [obstacle], q), atol=1e-12)
    assert report.min_distance <= report.state_distance.min()


def _stl(path, triangles) -> str:
    lines = ["solid part"]
    for tri in triangles:
        lines += ["facet normal 0 0 0", " outer loop"] + [f"  vertex {x} {y} {z}" for x, y, z in tri] + [" endloop", "endfacet"]
    path.write_text("\n".join(lines + ["endsolid part", ""]))
    return str(path)


def test_flat_mesh_gets_no_hull_and_is_measured_itself(tmp_path):
    """qhull cannot build the hull of a flat mesh: coal then measures the mesh itself."""
    square = [[(-0.05, -0.05, 0.0), (0.05, -0.05, 0.0), (0.05, 0.05, 0.0)],
              [(-0.05, -0.05, 0.0), (0.05, 0.05, 0.0), (-0.05, 0.05, 0.0)]]
    c = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.02
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    plate = _stl(tmp_path / "plate.stl", square)
    cube = _stl(tmp_path / "cube.stl", [c[list(f)] for f in faces])
    urdf = URDF_WITHOUT_COLLISION.replace(
        '<visual><geometry><box size="0.1 0.1 0.3"/></geometry></visual>',
        f'<collision><origin xyz="0 0 0.3"/><geometry><mesh filename="{plate}"/></geometry></collision>').replace(
        '<link name="tool"/>', f'<link name="tool"><collision><geometry><mesh filename="{cube}"/></geometry></collision></link>')
    path = tmp_path / "meshes.urdf"
    path.write_text(urdf)
    spheres = SphereModel(("upper", "tool"), [[0.0, 0.0, 0.15], [0.0, 0.0, 0.05]], [0.06, 0.04])
    robot = Robot.from_urdf(path, end_effector="tool", spheres=spheres)
    checker = CollisionChecker(robot, coal_obstacles([Sphere([0.12, 0.0, 0.32], 0.03), Box([0.0, 0.1, 0.3], [0.02] * 3)]))
    assert checker.geometry == "urdf" and checker.link_names == ("upper", "tool")
    q = np.array([[0.0, 0.0], [0.8, 1.0], [1.6, -0.5]])
    sub = checker.configurations(q, 0.01)
    every = checker.distances(sub.q)
    hull = checker.hull_distances(sub.q)
    np.testing.assert_array_equal(hull[:, 0], every[:, 0])            # the plate: no hull
    assert np.all(hull[:, 1] <= every[:, 1] + SLACK)
    report = checker.check(q, max_motion=0.01)
    assert report.min_distance == pytest.approx(every.min(), abs=SLACK)
    assert report.collision == (every.min() < 0.0)


# --------------------------------------------------------------------------- scenes -> coal
def test_coal_shapes_reproduce_the_scene_distances():
    rng = np.random.default_rng(11)
    obstacles = [Box([0.1, 0.2, 0.3], [0.1, 0.05, 0.2], random_rotation(rng)), Box([0.0, 0.0, 0.1], [0.2, 0.1, 0.05]),
                 Sphere([0.3, -0.1, 0.2], 0.07), Cylinder([-0.2, 0.1, 0.3], 0.04, 0.25, [1.0, -2.0, 0.5]),
                 Capsule([0.2, 0.3, -0.1], 0.03, 0.2, [0.3, 0.3, -1.0]), Capsule([0.0, 0.4, 0.0], 0.05, 0.0)]
    entries = coal_obstacles(Scene(obstacles))
    assert [name for name, _, _ in entries] == ["box_0", "box_1", "sphere_2", "cylinder_3", "capsule_4", "capsule_5"]
    points = rng.uniform(-0.6, 0.6, (60, 3))
    request = coal.DistanceRequest()
    point = coal.Sphere(1e-9)
    for obstacle, (_, shape, placement) in zip(obstacles, entries):
        assert placement.shape == (4, 4)
        exact = obstacle.distance(points)
        transform = coal.Transform3s(placement[:3, :3], placement[:3, 3])
        by_coal = [coal.distance(point, coal.Transform3s(np.eye(3), p), shape, transform, request, coal.DistanceResult())
                   for p in points]
        outside = exact > 1e-6
        np.testing.assert_allclose(np.array(by_coal)[outside], exact[outside], atol=2e-6)
    assert coal_obstacles(Scene()) == []
    assert coal_obstacles(obstacles[2], names=["ball"])[0][0] == "ball"


def test_coal_shapes_reject_bad_input():
    with raises_naming(InvalidArgumentError, "obstacle"):
        coal_shape("box")
    with raises_naming(InvalidArgumentError, "obstacles"):
        coal_obstacles(42)
    with raises_naming(InvalidArgumentError, "obstacles[1]"):
        coal_obstacles([PROBE_BOX, "box"])
    with raises_naming(InvalidArgumentError, "names"):
        coal_obstacles([PROBE_BOX], names=["a", "b"])
    with raises_naming(InvalidArgumentError, "names"):
        coal_obstacles([PROBE_BOX, PROBE_BOX], names=["a", "a"])


# ---------------------------------------------------------------------------------- bad input
def test_bad_input_raises_errors_naming_the_argument(jaco):
    good = coal_obstacles([PROBE_BOX])
    checker = CollisionChecker(jaco, good)
    q = np.stack([PROBE_Q, PROBE_Q])
    cases = [
        (lambda: CollisionChecker("jaco", good), "robot"),
        (lambda: CollisionChecker(jaco, good, geometry="mesh"), "geometry"),
        (lambda: CollisionChecker(jaco, good, include_fixed="yes"), "include_fixed"),
        (lambda: CollisionChecker(jaco, PROBE_BOX), "obstacles"),
        (lambda: CollisionChecker(jaco, [("a", coal.Sphere(0.1))]), "obstacles[0]"),
        (lambda: CollisionChecker(jaco, [("", coal.Sphere(0.1), np.eye(4))]), "obstacles[0]"),
        (lambda: CollisionChecker(jaco, [("a", PROBE_BOX, np.eye(4))]), "obstacles[0]"),
        (lambda: CollisionChecker(jaco, good + good), "obstacles[1]"),
        (lambda: CollisionChecker(jaco, [("a", coal.Sphere(0.1), np.ones((4, 4)))]), "obstacles[0] placement"),
        (lambda: CollisionChecker(jaco, [("a", coal.Sphere(0.1), 2.0 * np.eye(4))]), "obstacles[0] placement"),
        (lambda: CollisionChecker(jaco, [("a", coal.Sphere(0.1), np.eye(3))]), "obstacles[0] placement"),
        (lambda: checker.check(PROBE_Q[:5][None]), "q"),
        (lambda: checker.check(np.zeros((0, 6))), "q"),
        (lambda: checker.check(np.full((2, 6), np.nan)), "q"),
        (lambda: checker.check(q, time=[0.0]), "time"),
        (lambda: checker.check(q, time=[1.0, 1.0]), "time"),
        (lambda: checker.check(q, margin=float("nan")), "margin"),
        (lambda: checker.check(q, margin="0.01"), "margin"),
        (lambda: checker.check(q, max_motion=0.0), "max_motion"),
        (lambda: checker.check(q, max_motion=-1.0), "max_motion"),
        (lambda: checker.check(np.stack([PROBE_Q, PROBE_Q + 3.0]), max_motion=1e-7), "max_motion"),
        (lambda: checker.configurations(q, max_motion=True), "max_motion"),
        (lambda: checker.distances(np.zeros(6)), "q"),
    ]
    for call, argument in cases:
        with raises_naming(RobotError, argument) as info:
            call()
        assert isinstance(info.value, (CollisionCheckError, InvalidArrayError)), argument
        assert isinstance(info.value, ValueError)


def test_no_obstacles_and_single_state(jaco):
    report = CollisionChecker(jaco, []).check(np.stack([PROBE_Q, PROBE_Q]))
    assert report.min_distance == np.inf and report.nearest is None and not report.collision
    assert report.state_distance.shape == (2,) and np.all(np.isinf(report.state_distance))
    single = CollisionChecker(jaco, coal_obstacles([PROBE_BOX])).check(PROBE_Q[None], time=[3.0], margin=0.01)
    assert single.num_configurations == 1 and single.collision and single.nearest.time == 3.0
    assert single.max_step == 0.0 and single.lower_bound == single.min_distance


def test_margin_and_fixed_geometry(jaco):
    far = Box([0.6, 0.0, 0.3], [0.05, 0.05, 0.05])
    q = np.stack([PROBE_Q, PROBE_Q])
    checker = CollisionChecker(jaco, coal_obstacles([far]))
    clearance = checker.check(q).min_distance
    assert clearance > 0.0
    assert checker.check(q, margin=clearance + 1e-6).collision
    assert not checker.check(q, margin=clearance - 1e-6).collision
    # the base's mesh is fixed to the world: checked only on request, at every state the same
    base_box = Box([0.0, 0.0, 0.05], [0.03, 0.03, 0.03])
    moving = CollisionChecker(jaco, coal_obstacles([base_box])).check(q)
    with_base = CollisionChecker(jaco, coal_obstacles([base_box]), include_fixed=True).check(q)
    assert with_base.min_distance < 0.0 < moving.min_distance
    assert with_base.nearest.link == "j2s6s200_link_base"
