"""Collision geometry: shapes read from Pinocchio, grouping per moving link, surface sampling."""
from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest
from bad_input import raises_naming
from synthetic_arms import TIP_PLACEMENT, builtin_models, cube_mesh, one_link_model

from robots.collision_geometry import link_frame_name, link_surfaces
from robots.errors import CollisionGeometryError, UnknownFrameError

PLACEMENT = pin.SE3(pin.utils.rpyToMatrix(0.4, 0.1, -0.7), np.array([0.1, 0.2, -0.05]))


def _local(points: np.ndarray, placement: pin.SE3) -> np.ndarray:
    """Link-frame points (P, 3) in the shape's own frame."""
    return (points - placement.translation) @ placement.rotation


def _single_surface(shape, placement=PLACEMENT):
    model, geometry = one_link_model({"shape": (shape, placement)})
    (surface,) = link_surfaces(model, geometry)
    return surface


def test_box_surface_points_lie_on_faces_weighted_by_area():
    surface = _single_surface(coal.Box(0.1, 0.2, 0.4))
    half = np.array([0.05, 0.1, 0.2])
    assert surface.area == pytest.approx(2 * (0.1 * 0.2 + 0.1 * 0.4 + 0.2 * 0.4))
    local = _local(surface.sample_surface(20000, np.random.default_rng(0)), PLACEMENT)
    ratios = np.abs(local) / half
    np.testing.assert_allclose(ratios.max(axis=1), 1.0, atol=1e-9)
    on_face = np.argmax(ratios, axis=1)
    expected = np.array([0.2 * 0.4, 0.1 * 0.4, 0.1 * 0.2]) / (0.2 * 0.4 + 0.1 * 0.4 + 0.1 * 0.2)
    np.testing.assert_allclose(np.bincount(on_face, minlength=3) / 20000, expected, atol=0.015)


def test_sphere_cylinder_capsule_points_lie_on_their_surfaces():
    rng = np.random.default_rng(1)
    sphere = _local(_single_surface(coal.Sphere(0.07)).sample_surface(2000, rng), PLACEMENT)
    np.testing.assert_allclose(np.linalg.norm(sphere, axis=1), 0.07, atol=1e-12)

    cylinder_surface = _single_surface(coal.Cylinder(0.05, 0.3))
    assert cylinder_surface.area == pytest.approx(2 * np.pi * 0.05 * 0.3 + 2 * np.pi * 0.05**2)
    cylinder = _local(cylinder_surface.sample_surface(5000, rng), PLACEMENT)
    rho, z = np.linalg.norm(cylinder[:, :2], axis=1), cylinder[:, 2]
    on_side = np.isclose(rho, 0.05, atol=1e-12) & (np.abs(z) <= 0.15 + 1e-12)
    on_cap = np.isclose(np.abs(z), 0.15, atol=1e-12) & (rho <= 0.05 + 1e-12)
    assert np.all(on_side | on_cap)
    assert np.mean(on_cap) == pytest.approx(0.05 / (0.3 + 0.05), abs=0.02)  # caps' share of the area

    capsule = _local(_single_surface(coal.Capsule(0.04, 0.2)).sample_surface(5000, rng), PLACEMENT)
    axial = np.clip(capsule[:, 2], -0.1, 0.1)
    distance_to_segment = np.linalg.norm(capsule - np.column_stack([0 * axial, 0 * axial, axial]), axis=1)
    np.testing.assert_allclose(distance_to_segment, 0.04, atol=1e-12)


def test_mesh_surface_is_sampled_on_its_triangles():
    surface = _single_surface(cube_mesh(0.2))
    assert surface.shapes[0].kind == "mesh"
    assert surface.area == pytest.approx(6 * 0.04)
    local = _local(surface.sample_surface(6000, np.random.default_rng(2)), PLACEMENT)
    assert np.all((local > -1e-12) & (local < 0.2 + 1e-12))
    on_a_face = np.isclose(local, 0.0, atol=1e-12) | np.isclose(local, 0.2, atol=1e-12)
    assert np.all(on_a_face.any(axis=1))
    np.testing.assert_allclose(local.mean(axis=0), 0.1, atol=0.005)  # uniform over the six faces


def test_welded_and_base_geometry_grouping():
    model, geometry = one_link_model({"body": (coal.Sphere(0.05), pin.SE3.Identity())},
                                     base_shape=coal.Box(1, 1, 0.1), tip_shape=coal.Sphere(0.02))
    surfaces = link_surfaces(model, geometry)
    assert [s.link_name for s in surfaces] == ["link1"]  # base geometry does not move: left out
    tip_points = surfaces[0].shapes[1].sample_surface(500, np.random.default_rng(3))
    # the tip sphere's centre sits at the tip frame, i.e. TIP_PLACEMENT of the joint
    np.testing.assert_allclose(tip_points.mean(axis=0), TIP_PLACEMENT.translation, atol=0.003)
    named = link_surfaces(model, geometry, links=["base", "tip"])
    assert [(s.link_name, len(s.shapes)) for s in named] == [("base", 1), ("link1", 1)]


def test_bad_links_and_shapes_raise_clear_errors():
    model, geometry = one_link_model({"body": (coal.Sphere(0.05), pin.SE3.Identity())})
    with raises_naming(UnknownFrameError, "links", "nope"):
        link_surfaces(model, geometry, links=["nope"])
    with raises_naming(CollisionGeometryError, "links", "tip"):
        link_surfaces(model, geometry, links=["tip"])
    cone_model, cone_geometry = one_link_model({"cone": (coal.Cone(0.1, 0.2), pin.SE3.Identity())})
    with raises_naming(CollisionGeometryError, "collision_model", "cone"):
        link_surfaces(cone_model, cone_geometry)
    with raises_naming(CollisionGeometryError, "model"):
        link_surfaces("model", geometry)
    only_base_model, only_base = one_link_model({}, base_shape=coal.Sphere(0.1))
    with raises_naming(CollisionGeometryError, "collision_model"):
        link_surfaces(only_base_model, only_base)


def test_link_frame_falls_back_to_the_joint_frame():
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "j")
    with raises_naming(CollisionGeometryError, "model"):
        link_frame_name(model, joint)
    model.addJointFrame(joint, 0)
    assert link_frame_name(model, joint) == "j"


def test_jaco_fingers_join_the_last_link():
    model, geometry = builtin_models("jaco")
    surfaces = link_surfaces(model, geometry)
    assert [s.link_name for s in surfaces] == [f"j2s6s200_link_{i}" for i in range(1, 7)]
    assert len(surfaces[-1].shapes) == 5  # hand + two proximal and two distal finger meshes
    assert all(shape.kind == "mesh" for s in surfaces for shape in s.shapes)
