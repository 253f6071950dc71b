"""Vectorized kinematics: analytic Jacobians against central finite differences and Pinocchio."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from robots import Robot, SphereModel, load_robot

EPS = 1e-6


def _central_difference(f, x: np.ndarray) -> np.ndarray:
    """d f / d x (..., n) by central differences; f maps (n,) to an array (...)."""
    columns = []
    for k in range(x.size):
        step = np.zeros_like(x)
        step[k] = EPS
        columns.append((f(x + step) - f(x - step)) / (2 * EPS))
    return np.stack(columns, axis=-1)


def _assert_close(analytic: np.ndarray, numeric: np.ndarray) -> None:
    # relative 1e-5, with an absolute floor for entries that are (near) zero
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-7)


def _test_spheres(robot: Robot) -> SphereModel:
    """Two spheres per chain link (placed off the link origin) plus one on the end effector."""
    bodies = [f for f in robot.model.frames if f.type == pin.FrameType.BODY]
    links = [next(f.name for f in bodies if f.parentJoint == joint) for joint in range(1, robot.n + 1)]
    rng = np.random.default_rng(7)
    names = [link for link in links for _ in range(2)] + [robot.end_effector]
    return SphereModel(tuple(names), rng.uniform(-0.1, 0.1, (len(names), 3)), np.full(len(names), 0.05))


@pytest.fixture(scope="module", params=["jaco", "sawyer"])
def robot(request) -> Robot:
    loaded = load_robot(request.param)
    loaded.spheres = _test_spheres(loaded)
    return loaded


def _random_states(robot: Robot, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = np.array([robot.random_configuration(rng) for _ in range(count)])
    return q, rng.normal(0.0, 1.0, q.shape)


def test_position_and_velocity_jacobians_match_finite_differences(robot):
    q, qdot = _random_states(robot, 4, seed=1)
    kin = robot.ee_kinematics(q, qdot)
    for t in range(len(q)):
        _assert_close(kin.jacobian[t], _central_difference(lambda x: robot.fk(x), q[t]))
        _assert_close(kin.velocity_jacobian[t],
                      _central_difference(lambda x: robot.ee_kinematics(x, qdot[t]).velocity, q[t]))
        _assert_close(kin.jacobian[t],
                      _central_difference(lambda v: robot.ee_kinematics(q[t], v).velocity, qdot[t]))


def test_velocity_is_jacobian_times_qdot(robot):
    q, qdot = _random_states(robot, 5, seed=2)
    kin = robot.ee_kinematics(q, qdot)
    np.testing.assert_allclose(kin.velocity, np.einsum("tin,tn->ti", kin.jacobian, qdot), atol=1e-14)
    still = robot.ee_kinematics(q)
    np.testing.assert_array_equal(still.velocity, 0.0)
    np.testing.assert_array_equal(still.velocity_jacobian, 0.0)
    at_rest = robot.ee_kinematics(q, np.zeros_like(q))     # the same arm, its velocity computed
    np.testing.assert_array_equal(still.position, at_rest.position)
    np.testing.assert_array_equal(still.jacobian, at_rest.jacobian)
    np.testing.assert_array_equal(still.velocity_jacobian, at_rest.velocity_jacobian)


def test_sphere_centre_jacobians_match_finite_differences(robot):
    q, _ = _random_states(robot, 3, seed=3)
    centres, jac = robot.sphere_centres(q, jacobians=True)
    S = robot.spheres.count
    assert centres.shape == (3, S, 3) and jac.shape == (3, S, 3, robot.n)
    for t in range(len(q)):
        _assert_close(jac[t], _central_difference(lambda x: robot.sphere_centres(x)[0], q[t]))


def test_kinematics_match_pinocchio_per_configuration(robot):
    q, _ = _random_states(robot, 6, seed=4)
    kin = robot.ee_kinematics(q)
    centres, _ = robot.sphere_centres(q)
    model, data = robot.model, robot.model.createData()
    base = robot.chain.frame_id(robot.base_frame)
    ee = robot.chain.frame_id(robot.end_effector)
    for t in range(len(q)):
        q_pin = robot.to_pinocchio(q[t])
        pin.framesForwardKinematics(model, data, q_pin)
        base_inv = data.oMf[base].inverse()
        np.testing.assert_allclose(kin.position[t], (base_inv * data.oMf[ee]).translation, atol=1e-12)
        jacobian = pin.computeFrameJacobian(model, data, q_pin, ee, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]
        np.testing.assert_allclose(kin.jacobian[t], base_inv.rotation @ jacobian, atol=1e-12)
        for s, (link, centre) in enumerate(zip(robot.spheres.link_names, robot.spheres.centres)):
            expected = base_inv * data.oMf[robot.chain.frame_id(link)] * centre
            np.testing.assert_allclose(centres[t, s], expected, atol=1e-12)


def test_batch_shapes_and_single_configuration(robot):
    q, qdot = _random_states(robot, 5, seed=5)
    kin = robot.ee_kinematics(q, qdot)
    assert kin.position.shape == (5, 3) and kin.jacobian.shape == (5, 3, robot.n)
    single = robot.ee_kinematics(q[2], qdot[2])
    assert single.position.shape == (3,) and single.velocity_jacobian.shape == (3, robot.n)
    np.testing.assert_allclose(single.velocity_jacobian, kin.velocity_jacobian[2], atol=1e-15)
    assert robot.fk(q[2]).shape == (3,)
    no_jac = robot.ee_kinematics(q, qdot, jacobians=False)
    assert no_jac.jacobian is None and no_jac.velocity_jacobian is None
    np.testing.assert_allclose(no_jac.velocity, kin.velocity)
    grid = robot.fk(q.reshape(5, 1, robot.n))
    assert grid.shape == (5, 1, 3)


def test_frame_positions_run_from_base_to_end_effector(robot):
    q, _ = _random_states(robot, 4, seed=6)
    points = robot.frame_positions(q)
    assert points.shape == (4, robot.n + 2, 3)
    np.testing.assert_allclose(points[:, -1], robot.fk(q), atol=1e-15)
    np.testing.assert_allclose(robot.frame_position(q, robot.base_frame), 0.0, atol=1e-15)
    # the first chain joint origin does not move with the joints
    np.testing.assert_allclose(points[:, 1], np.broadcast_to(points[0, 1], (4, 3)), atol=1e-15)


MIXED_URDF = """<?xml version="1.0"?>
<robot name="mixed">
  <link name="root"/>
  <link name="a"/><link name="b"/><link name="c"/><link name="tool"/>
  <joint name="spin" type="continuous"><parent link="root"/><child link="a"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/><limit effort="1" velocity="2"/></joint>
  <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/>
    <origin xyz="0.1 0 0" rpy="0.3 0 0.2"/><axis xyz="0.6 0 0.8"/>
    <limit lower="-0.2" upper="0.4" effort="1" velocity="0.5"/></joint>
  <joint name="bend" type="revolute"><parent link="b"/><child link="c"/>
    <origin xyz="0 0.2 0.1" rpy="1.0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1.5"/></joint>
  <joint name="tool_fixed" type="fixed"><parent link="c"/><child link="tool"/>
    <origin xyz="0.15 0.05 0.2" rpy="0 0 0"/></joint>
</robot>
"""


def test_continuous_prismatic_and_revolute_joints(tmp_path):
    path = tmp_path / "mixed.urdf"
    path.write_text(MIXED_URDF)
    robot = Robot.from_urdf(path, end_effector="tool")
    assert robot.chain.kinds == ("continuous", "prismatic", "revolute")
    assert robot.model.nq == 4 and robot.n == 3
    np.testing.assert_array_equal(robot.lower_limits, [-np.inf, -0.2, -2.0])
    np.testing.assert_array_equal(robot.velocity_limits, [2.0, 0.5, 1.5])
    robot.spheres = SphereModel(("a", "b", "c"), np.array([[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]), np.ones(3) * 0.02)
    rng = np.random.default_rng(8)
    for _ in range(3):
        q, qdot = robot.random_configuration(rng), rng.normal(size=3)
        kin = robot.ee_kinematics(q, qdot)
        _assert_close(kin.jacobian, _central_difference(robot.fk, q))
        _assert_close(kin.velocity_jacobian, _central_difference(lambda x: robot.ee_kinematics(x, qdot).velocity, q))
        _assert_close(robot.sphere_centres(q, True)[1], _central_difference(lambda x: robot.sphere_centres(x)[0], q))
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, robot.to_pinocchio(q))
        np.testing.assert_allclose(kin.position, data.oMf[robot.chain.frame_id("tool")].translation, atol=1e-12)
    np.testing.assert_allclose(robot.from_pinocchio(robot.to_pinocchio([3.0, 0.1, -1.0])), [3.0, 0.1, -1.0])


def test_joint_frames_of_a_repeated_batch_are_reused_read_only_and_renewed_for_a_new_one(robot):
    q, _ = _random_states(robot, 5, seed=21)
    first = robot.chain.joint_frames(q)
    again = robot.chain.joint_frames(q.copy())
    assert again is first
    assert not first.rotations.flags.writeable and not first.axes.flags.writeable
    moved = q.copy()
    moved[2, 0] += 0.1
    other = robot.chain.joint_frames(moved)
    assert other is not first
    assert not np.allclose(other.origins[2, -1], first.origins[2, -1])
    np.testing.assert_array_equal(other.origins[[0, 1, 3, 4]], first.origins[[0, 1, 3, 4]])
    # kinematics from kept frames equal those recomputed after another batch (no stale frames)
    pos_kept = robot.ee_kinematics(moved, np.zeros_like(moved), jacobians=False).position
    robot.chain.joint_frames(q)
    pos_recomputed = robot.ee_kinematics(moved, np.zeros_like(moved), jacobians=False).position
    np.testing.assert_array_equal(pos_kept, pos_recomputed)
