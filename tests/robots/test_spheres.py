"""Sphere fitting and coverage: analytic single shapes, the Jaco and Sawyer, the built-in sphere files."""
from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest
from bad_input import raises_naming
from synthetic_arms import TIP_PLACEMENT, builtin_models, one_link_model

from robots import registry
from robots.errors import CollisionGeometryError, UnknownFrameError
from robots.sphere_model import SphereModel, load_sphere_file
from robots.sphere_cli import main
from robots.spheres import enclosing_ball, fit_spheres, sphere_coverage

BOX_PLACEMENT = pin.SE3(pin.utils.rpyToMatrix(0.2, 0.5, -0.3), np.array([0.1, 0.0, 0.25]))


def _box_model():
    return one_link_model({"box": (coal.Box(0.08, 0.1, 0.5), BOX_PLACEMENT)})


def test_enclosing_ball_matches_analytic_cases():
    rng = np.random.default_rng(0)
    directions = rng.standard_normal((500, 3))
    on_sphere = 0.3 * directions / np.linalg.norm(directions, axis=1, keepdims=True) + [1.0, -2.0, 0.5]
    centre, radius = enclosing_ball(on_sphere)
    np.testing.assert_allclose(centre, [1.0, -2.0, 0.5], atol=1e-6)
    assert radius == pytest.approx(0.3, abs=1e-9)
    centre, radius = enclosing_ball(np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]]))
    np.testing.assert_allclose(centre, [0.1, 0.0, 0.0], atol=1e-9)
    assert radius == pytest.approx(0.1)
    corners = np.array([[x, y, z] for x in (0, 0.1) for y in (0, 0.2) for z in (0, 0.4)])  # box: half diagonal
    cloud = np.vstack([corners, rng.uniform(0, 1, (300, 3)) * [0.1, 0.2, 0.4]])
    centre, radius = enclosing_ball(cloud)
    np.testing.assert_allclose(centre, [0.05, 0.1, 0.2], atol=1e-6)
    assert radius == pytest.approx(0.5 * np.sqrt(0.01 + 0.04 + 0.16), abs=1e-7)


def test_single_sphere_geometry_is_fitted_by_itself():
    placement = pin.SE3(np.eye(3), np.array([0.02, -0.03, 0.2]))
    model, geometry = one_link_model({"ball": (coal.Sphere(0.06), placement)})
    spheres = fit_spheres(model, geometry, inflation=0.01, rng=1)
    assert spheres.count == 1 and spheres.link_names == ("link1",) and spheres.inflation == 0.01
    np.testing.assert_allclose(spheres.centres[0], placement.translation, atol=1e-3)
    assert spheres.radii[0] == pytest.approx(0.05, abs=1e-3)  # grown by 1 cm it is the ball again


def test_box_on_one_link_is_covered_with_few_compact_spheres():
    model, geometry = _box_model()
    spheres = fit_spheres(model, geometry, max_spheres=40, inflation=0.01, rng=0)
    report = sphere_coverage(model, geometry, spheres, inflation=0.01, samples=20000, rng=123)
    assert 2 <= spheres.count <= 40
    assert report.coverage >= 0.99 and report.link_names == ("link1",)
    assert report.max_gap < 0.005
    # compact: each sphere smaller than the box's half diagonal, and the union hugs the box
    assert report.max_radius < 0.5 * np.linalg.norm([0.08, 0.1, 0.5])
    assert report.mean_overshoot < 0.03
    # centres lie inside the box
    local = (spheres.centres - BOX_PLACEMENT.translation) @ BOX_PLACEMENT.rotation
    assert np.all(np.abs(local) <= np.array([0.04, 0.05, 0.25]) + 1e-9)


def test_fitting_is_deterministic_for_a_seed():
    model, geometry = _box_model()
    first = fit_spheres(model, geometry, rng=7)
    second = fit_spheres(model, geometry, rng=np.random.default_rng(7))
    np.testing.assert_array_equal(first.centres, second.centres)
    np.testing.assert_array_equal(first.radii, second.radii)


def test_sphere_budget_and_inflation_are_respected():
    model, geometry = _box_model()
    one = fit_spheres(model, geometry, max_spheres=1, inflation=0.0, rng=0)
    assert one.count == 1
    assert one.radii[0] == pytest.approx(0.5 * np.linalg.norm([0.08, 0.1, 0.5]), rel=0.01)
    assert sphere_coverage(model, geometry, one, inflation=0.0).coverage == 1.0
    strict = fit_spheres(model, geometry, max_spheres=3, inflation=0.0, rng=0)
    assert strict.count <= 3
    assert sphere_coverage(model, geometry, strict, inflation=0.0, rng=5).coverage >= 0.99


def test_coverage_accepts_spheres_on_welded_frames():
    model, geometry = _box_model()
    spheres = fit_spheres(model, geometry, rng=0)
    tip = model.frames[model.getFrameId("tip")].placement
    on_tip = SphereModel(("tip",) * spheres.count, (spheres.centres - tip.translation) @ tip.rotation, spheres.radii)
    direct = sphere_coverage(model, geometry, spheres, rng=4)
    moved = sphere_coverage(model, geometry, on_tip, rng=4)
    assert moved.coverage == pytest.approx(direct.coverage)
    assert moved.max_gap == pytest.approx(direct.max_gap, abs=1e-12)
    misplaced = SphereModel(spheres.link_names, spheres.centres + 1.0, spheres.radii)
    assert sphere_coverage(model, geometry, misplaced).coverage == 0.0


def test_tip_geometry_gets_spheres_on_the_link():
    model, geometry = one_link_model({}, tip_shape=coal.Sphere(0.03))
    spheres = fit_spheres(model, geometry, rng=0)
    assert spheres.link_names == ("link1",)
    np.testing.assert_allclose(spheres.centres[0], TIP_PLACEMENT.translation, atol=1e-3)


def test_bad_arguments_raise_clear_errors():
    model, geometry = _box_model()
    for kwargs, name in [(dict(inflation=-0.01), "inflation"),
                         (dict(inflation=float("nan")), "inflation"),
                         (dict(max_spheres=0), "max_spheres"),
                         (dict(rng="seed"), "rng")]:
        with raises_naming(CollisionGeometryError, name):
            fit_spheres(model, geometry, **kwargs)
    two_links = one_link_model({"box": (coal.Box(0.1, 0.1, 0.1), pin.SE3.Identity())}, base_shape=coal.Sphere(0.1))
    with raises_naming(CollisionGeometryError, "max_spheres"):
        fit_spheres(*two_links, links=["base", "link1"], max_spheres=1)
    with raises_naming(UnknownFrameError, "spheres.link_names", "elbow"):
        sphere_coverage(model, geometry, SphereModel(("elbow",), np.zeros((1, 3)), np.ones(1)))
    with raises_naming(CollisionGeometryError, "spheres"):
        sphere_coverage(model, geometry, {"radii": [1.0]})


def _hand_model():
    """A palm (20 x 6 x 6 cm) with two fingers (2 x 2 x 5 cm) 14 cm apart below it: a gripper."""
    palm = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.03]))
    left, right = (pin.SE3(np.eye(3), np.array([0.0, y, 0.085])) for y in (0.07, -0.07))
    return one_link_model({"palm": (coal.Box(0.06, 0.2, 0.06), palm), "left": (coal.Box(0.02, 0.02, 0.05), left),
                           "right": (coal.Box(0.02, 0.02, 0.05), right)})


def _cube_distances(model, geometry, spheres, side, positions):
    """Signed distances [m] of an axis-aligned cube of edge `side` centred at each of `positions`
    (P, 3) to the geometry (coal) and to the spheres grown by their inflation (exact cube SDF)."""
    cube, half = coal.Box(side, side, side), np.full(3, side / 2)
    request = coal.DistanceRequest()
    request.enable_signed_distance = True
    on_geometry = []
    for position in positions:
        distances = []
        for obj in geometry.geometryObjects:
            result = coal.DistanceResult()
            coal.distance(obj.geometry, coal.Transform3s(obj.placement.rotation, obj.placement.translation),
                          cube, coal.Transform3s(np.eye(3), position), request, result)
            distances.append(result.min_distance)
        on_geometry.append(min(distances))
    q = np.abs(spheres.centres[None] - positions[:, None]) - half
    cube_sdf = np.linalg.norm(np.maximum(q, 0.0), axis=2) + np.minimum(q.max(axis=2), 0.0)
    on_spheres = np.min(cube_sdf - spheres.radii[None] - spheres.inflation, axis=1)
    return np.array(on_geometry), on_spheres


@pytest.mark.parametrize("build", [_box_model, _hand_model], ids=["box", "hand"])
def test_spheres_cover_the_volume_not_only_the_surface(build):
    """A small cube anywhere through the link: wherever it overlaps the geometry the spheres
    overlap it too, by about as much (the fit covers the solid, so no obstacle slips between
    two spheres while the geometry hits it)."""
    model, geometry = build()
    spheres = fit_spheres(model, geometry, inflation=0.01, rng=0)
    report = sphere_coverage(model, geometry, spheres, inflation=0.01, samples=20000, rng=5)
    points = np.vstack([obj.placement.act(corner) for obj in geometry.geometryObjects
                        for corner in np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
                        * obj.geometry.halfSide])
    rng = np.random.default_rng(7)
    positions = rng.uniform(points.min(axis=0) - 0.02, points.max(axis=0) + 0.02, (400, 3))
    on_geometry, on_spheres = _cube_distances(model, geometry, spheres, 0.03, positions)
    hit = on_geometry < 0.0
    assert hit.sum() > 50                                       # the cube goes through the link
    assert np.all(on_spheres[hit] <= on_geometry[hit] + report.max_gap + 1e-4)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_builtin_robots_are_covered_by_at_most_40_spheres(name):
    model, geometry = builtin_models(name)
    spheres = fit_spheres(model, geometry, max_spheres=40, inflation=0.01, rng=0)
    report = sphere_coverage(model, geometry, spheres, inflation=0.01, samples=20000, rng=99)
    assert spheres.count <= 40
    assert report.coverage >= 0.99
    assert np.all(report.link_coverage >= 0.98)
    assert report.max_radius < 0.09 and report.mean_overshoot < 0.015
    small = fit_spheres(model, geometry, max_spheres=len(report.link_names) + 2, rng=0)
    assert len(report.link_names) <= small.count <= len(report.link_names) + 2
    assert set(small.link_names) == set(report.link_names)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_builtin_sphere_files_cover_their_robot(name):
    path = registry.sphere_override_path(name)
    if not path.is_file():
        pytest.skip(f"{path} not generated (python -m robots.sphere_cli --robot {name})")
    model, geometry = builtin_models(name)
    spheres = load_sphere_file(path)
    report = sphere_coverage(model, geometry, spheres, inflation=0.01, samples=20000, rng=2024)
    assert spheres.count <= 40 and report.coverage >= 0.99


def test_command_line_writes_a_loadable_sphere_file(tmp_path, capsys):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text("""<robot name="arm">
  <link name="base"/>
  <link name="upper"><collision><origin xyz="0 0 0.2"/><geometry><cylinder radius="0.04" length="0.4"/>
    </geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>""")
    out = tmp_path / "arm.json"
    assert main(["--urdf", str(urdf), "--end-effector", "upper", "--out", str(out), "--max-spheres", "8"]) == 0
    spheres = load_sphere_file(out)
    assert set(spheres.link_names) == {"upper"} and 1 <= spheres.count <= 8
    assert "coverage" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_robot_sphere_centres_cover_the_posed_geometry(name):
    """Spheres placed by Robot.sphere_centres at random poses cover the surface placed by Pinocchio."""
    from robots import load_robot
    from robots.collision_geometry import link_surfaces

    robot = load_robot(name)
    rng = np.random.default_rng(11)
    data = robot.model.createData()
    base = robot.model.getFrameId(robot.base_frame)
    for _ in range(3):
        q = robot.random_configuration(rng)
        pin.framesForwardKinematics(robot.model, data, robot.to_pinocchio(q))
        world_from_base = data.oMf[base]
        centres = robot.sphere_centres(q)[0] @ world_from_base.rotation.T + world_from_base.translation
        for surface in link_surfaces(robot.model, robot.collision_model):
            placement = data.oMi[surface.joint_id]
            points = surface.sample_surface(2000, rng) @ placement.rotation.T + placement.translation
            gap = np.min(np.linalg.norm(points[:, None] - centres[None], axis=2) - robot.spheres.radii, axis=1)
            assert np.mean(gap <= 0.01 + 1e-9) >= 0.98, surface.link_name
