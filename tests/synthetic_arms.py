"""Tiny Pinocchio models with hand-placed collision shapes, for the sphere and geometry tests."""
from __future__ import annotations

import functools

import coal
import numpy as np
import pinocchio as pin

TIP_PLACEMENT = pin.SE3(pin.utils.rpyToMatrix(0.3, -0.2, 0.5), np.array([0.05, -0.02, 0.3]))


def one_link_model(shapes: dict[str, tuple[object, pin.SE3]], base_shape: object | None = None,
                   tip_shape: object | None = None) -> tuple[pin.Model, pin.GeometryModel]:
    """One revolute joint carrying BODY frame "link1" with `shapes` (name -> (coal shape, placement)).

    A frame "tip" welded to link1 at TIP_PLACEMENT may carry `tip_shape` (placed at the tip frame),
    and a world-fixed frame "base" may carry `base_shape`.
    """
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "joint1")
    base = model.addFrame(pin.Frame("base", 0, 0, pin.SE3.Identity(), pin.FrameType.BODY))
    model.addJointFrame(joint, 0)
    link = model.addBodyFrame("link1", joint, pin.SE3.Identity(), -1)
    weld = model.addFrame(pin.Frame("tip_joint", joint, link, TIP_PLACEMENT, pin.FrameType.FIXED_JOINT))
    tip = model.addFrame(pin.Frame("tip", joint, weld, TIP_PLACEMENT, pin.FrameType.BODY))
    geometry = pin.GeometryModel()
    for name, (shape, placement) in shapes.items():
        geometry.addGeometryObject(pin.GeometryObject(name, joint, link, placement, shape))
    if base_shape is not None:
        geometry.addGeometryObject(pin.GeometryObject("base_shape", 0, base, pin.SE3.Identity(), base_shape))
    if tip_shape is not None:
        geometry.addGeometryObject(pin.GeometryObject("tip_shape", joint, tip, TIP_PLACEMENT, tip_shape))
    return model, geometry


def cube_mesh(side: float) -> coal.BVHModelOBBRSS:
    """Closed triangle mesh of an axis-aligned cube [0, side]^3 (12 triangles)."""
    vertices = side * np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    triangles = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                          [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(triangles), len(vertices))
    mesh.addVertices(vertices)
    mesh.addTriangles(triangles)
    mesh.endModel()
    return mesh


@functools.cache
def builtin_models(name: str) -> tuple[pin.Model, pin.GeometryModel]:
    """Kinematic and collision models of a built-in robot, as `robots.load_robot(name)` builds them."""
    from robots import load_robot

    robot = load_robot(name)
    return robot.model, robot.collision_model
