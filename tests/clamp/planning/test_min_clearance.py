"""The required clearance (``CheckConfig.min_clearance``, ``clamp plan --min-clearance``): a plan
the verdict passes keeps it on the robot's URDF collision geometry, measured here independently
with Pinocchio and coal (not with the planner's checker); a request that cannot keep it fails
naming the clearance and the limit."""
from __future__ import annotations

import numpy as np
import pytest

from clamp import PlannerConfig, learn_prior, plan
from clamp.errors import InvalidParameterError
from scenes import Box, Scene, make_demonstrations

START_OFFSET = np.array([0.0, -0.03, 0.03])


def coal_clearance(robot, box: Box, q: np.ndarray, between: int = 4) -> float:
    """Least distance [m] between the moving links' URDF collision meshes and ``box`` over q
    (T, n), at the states and ``between`` configurations linearly between each two: Pinocchio
    places the meshes, coal measures them (links fixed to the world are left out)."""
    import coal
    import pinocchio as pin
    model, geometry, _ = pin.buildModelsFromUrdf(str(robot.urdf_path), [str(d) for d in robot.package_dirs])
    data, placements = model.createData(), pin.GeometryData(geometry)
    ids = [model.getJointId(name) for name in robot.joint_names]
    s = np.linspace(0.0, 1.0, between + 1, endpoint=False)
    dense = np.concatenate([(1 - s)[:, None] * a + s[:, None] * b for a, b in zip(q[:-1], q[1:])] + [q[-1:]])
    obstacle = coal.Box(*box.size)
    best = np.inf
    for row in dense:
        full = pin.neutral(model)
        for j, value in zip(ids, row):
            joint = model.joints[j]
            full[joint.idx_q:joint.idx_q + joint.nq] = [np.cos(value), np.sin(value)] if joint.nq == 2 else [value]
        pin.framesForwardKinematics(model, data, full)
        pin.updateGeometryPlacements(model, data, geometry, placements, full)
        base = data.oMf[model.getFrameId(robot.base_frame)] if robot.base_frame else pin.SE3.Identity()
        box_pose = coal.Transform3s(base.rotation, base.rotation @ box.center + base.translation)
        for g, item in enumerate(geometry.geometryObjects):
            if item.parentJoint == 0:
                continue
            pose = placements.oMg[g]
            result = coal.DistanceResult()
            distance = coal.distance(item.geometry, coal.Transform3s(pose.rotation, pose.translation),
                                     obstacle, box_pose, coal.DistanceRequest(), result)
            best = min(best, distance)
    return float(best)


@pytest.fixture(scope="module")
def setting(jaco):
    """A synthetic box_closing prior (T = 40), its start and a box under the middle of its free
    plan reaching 20 mm above the path."""
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, num_points=40))
    start = prior.mean[0, :3] + START_OFFSET
    free = plan(prior, jaco, None, start, covariance=False)
    middle = free.ee_path[len(free.ee_path) // 2]
    return prior, start, Box(middle - np.array([0.0, 0.0, 0.02]), [0.08, 0.08, 0.08]), free


def test_a_passing_plan_keeps_the_required_clearance_on_the_urdf_geometry(jaco, setting):
    prior, start, box, _ = setting
    config = PlannerConfig(min_clearance=0.02)
    result = plan(prior, jaco, Scene([box]), start, config=config, covariance=False)
    assert result.success, result.reasons
    assert result.collision_geometry == "urdf"
    measured = coal_clearance(jaco, box, result.q)
    assert measured >= 0.02, measured
    assert result.min_clearance >= 0.02


def test_a_plan_short_of_the_required_clearance_fails_naming_it_and_the_limit(jaco, setting):
    """The plan passes at a few mm without a required clearance; the weighted solve alone
    (``constraint_rounds=0``: nothing pushes the plan further out) gives the same few mm, and
    with ``min_clearance=0.02`` the verdict fails it, first reason the clearance and the limit."""
    prior, start, box, _ = setting
    scene = Scene([box])
    today = plan(prior, jaco, scene, start, covariance=False)
    assert today.success and 0.0 < today.min_clearance < 0.02
    result = plan(prior, jaco, scene, start, covariance=False,
                  config=PlannerConfig(min_clearance=0.02, constraint_rounds=0))
    assert not result.success and result.min_clearance < 0.02
    first = result.reasons[0]
    assert first.startswith(f"clearance {result.min_clearance * 1e3:.1f} mm below the required "
                            "min_clearance 20.0 mm"), result.reasons


def test_min_clearance_is_checked(jaco):
    with pytest.raises(InvalidParameterError, match="min_clearance"):
        PlannerConfig(min_clearance=-0.01)
