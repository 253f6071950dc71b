"""The hand's whole pose on three arms (the Jaco, the Sawyer and example-robot-data's Panda):
Robot.ee_poses and ee_pose_jacobian against pinocchio directly (and finite differences),
solve_pose_ik, and the synthetic pose skills (robots.pose_skills) judged by what the skill is:
pouring ends with a 90 degree turn about a horizontal axis with the hand in place, inserting
moves along the fixed tool axis without turning."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

from bad_input import raises_naming
from robots import Robot, RobotError
from robots.ik import solve_pose_ik
from robots.pose_skills import POSE_SKILLS, make_pose_demonstrations
from robots.registry import example_robot_data_share
from robots.self_collision import self_collision_report
from scenes import UnknownSkillError


@pytest.fixture(scope="module")
def panda():
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "panda_description" / "urdf" / "panda.urdf"
    return Robot.from_urdf(urdf, end_effector="panda_hand", package_dirs=[share], name="panda")


@pytest.fixture(params=["jaco", "sawyer", "panda"])
def arm(request):
    return request.getfixturevalue(request.param)


def pinocchio_pose(robot, q):
    """Position (3,) and rotation (3, 3) of the end effector in the base frame, by pinocchio."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.to_pinocchio(q))
    placement = data.oMf[model.getFrameId(robot.end_effector, pin.FrameType.BODY)]
    if robot.base_frame is not None:
        placement = data.oMf[model.getFrameId(robot.base_frame, pin.FrameType.BODY)].actInv(placement)
    return placement.translation, placement.rotation


def test_ee_poses_match_pinocchio(arm):
    rng = np.random.default_rng(11)
    q = np.array([arm.random_configuration(rng) for _ in range(8)])
    positions, rotations = arm.ee_poses(q)
    assert positions.shape == (8, 3) and rotations.shape == (8, 3, 3)
    for b in range(8):
        p, R = pinocchio_pose(arm, q[b])
        np.testing.assert_allclose(positions[b], p, atol=1e-12)
        np.testing.assert_allclose(rotations[b], R, atol=1e-12)
        one_p, one_R, jacobian = arm.ee_pose_jacobian(q[b])
        np.testing.assert_allclose(one_p, p, atol=1e-12)
        np.testing.assert_allclose(one_R, R, atol=1e-12)
        # columns against central differences: d p / d q_j and the turn (dR R^T) of q_j
        step = 1e-6
        for j in range(arm.n):
            dq = np.zeros(arm.n)
            dq[j] = step
            (p1, R1), (p0, R0) = pinocchio_pose(arm, q[b] + dq), pinocchio_pose(arm, q[b] - dq)
            np.testing.assert_allclose(jacobian[:3, j], (p1 - p0) / (2 * step), atol=1e-6)
            np.testing.assert_allclose(jacobian[3:, j], pin.log3(R1 @ R0.T) / (2 * step), atol=1e-6)


def test_solve_pose_ik_reaches_a_pose_the_arm_can_take(arm):
    rng = np.random.default_rng(4)
    for _ in range(3):
        q = arm.random_configuration(rng)
        p, R = pinocchio_pose(arm, q)
        seed = arm.clip_to_limits(q + rng.normal(0.0, 0.15, arm.n))
        result = solve_pose_ik(arm, p, R, seed)
        assert result.success, result
        p2, R2 = pinocchio_pose(arm, result.q)
        assert np.linalg.norm(p2 - p) < 1e-6
        assert np.linalg.norm(pin.log3(R2 @ R.T)) < 1e-6
        assert arm.within_limits(result.q)


def check_forward_kinematics(robot, demos):
    """Orientations and positions are pinocchio's FK of the joint trajectories."""
    M, T, _ = demos.joint_positions.shape
    for m in range(M):
        for t in (0, T // 3, T - 1):
            p, R = pinocchio_pose(robot, demos.joint_positions[m, t])
            np.testing.assert_allclose(demos.positions[m, t], p, atol=1e-9)
            angle = (Rotation.from_quat(demos.orientations[m, t]).inv() * Rotation.from_matrix(R)).magnitude()
            assert angle < 1e-9
    assert robot.within_limits(demos.joint_positions).all()
    # one branch of the arm: no joint swings round (10 s skills, slowest joint speeds < 0.9 rad/s)
    speed = np.abs(np.diff(demos.joint_positions, axis=1)).max() / demos.dt
    assert speed < 1.2, speed


def test_pouring_tilts_the_wrist_90_degrees_at_the_end(arm):
    demos = make_pose_demonstrations(arm, "pouring", num_demos=4, num_points=200, seed=1)
    assert demos.orientations.shape == (4, 200, 4) and demos.joint_names == arm.joint_names
    check_forward_kinematics(arm, demos)
    for m in range(4):
        q = demos.joint_positions[m]
        # the pour: the samples where only the last joint still moves
        still = np.all(np.abs(q[:, :-1] - q[-1, :-1]) < 1e-9, axis=1)
        first = int(np.argmax(still))
        assert still[first:].all() and first < 190
        turn = Rotation.from_quat(demos.orientations[m, first]).inv() * Rotation.from_quat(demos.orientations[m, -1])
        _, R_end = pinocchio_pose(arm, q[-1])
        axis = R_end @ turn.as_rotvec() / turn.magnitude()           # in the base frame
        assert 75.0 < np.degrees(turn.magnitude()) <= 105.0
        assert abs(axis[2]) < 0.05                                    # about a horizontal axis
        assert np.linalg.norm(demos.positions[m, first:] - demos.positions[m, -1], axis=1).max() < 0.2
        # the reach before it turns the hand less than the pour does
        reach = Rotation.from_quat(demos.orientations[m, 0]).inv() * Rotation.from_quat(demos.orientations[m, first])
        assert reach.magnitude() < np.radians(75.0)


def test_inserting_moves_along_the_fixed_tool_axis(arm):
    demos = make_pose_demonstrations(arm, "inserting", num_demos=4, num_points=200, seed=2)
    check_forward_kinematics(arm, demos)
    for m in range(4):
        tail = slice(int(0.75 * demos.T), None)                     # inside the insertion
        turns = Rotation.from_quat(demos.orientations[m, tail])
        assert np.degrees((turns[0].inv() * turns).magnitude()).max() < 0.5
        path = demos.positions[m, tail]
        direction = path[-1] - path[0]
        assert np.linalg.norm(direction) > 0.02
        direction /= np.linalg.norm(direction)
        offsets = path - path[0]
        across = offsets - np.outer(offsets @ direction, direction)
        assert np.linalg.norm(across, axis=1).max() < 1e-3          # a straight line
        assert direction[2] < -0.999                                 # straight down
        # along the tool's own axis: the direction is fixed in the hand's frame
        _, R = pinocchio_pose(arm, demos.joint_positions[m, -1])
        assert np.abs(R.T @ direction).max() > 0.999


@pytest.mark.parametrize("skill", POSE_SKILLS)
def test_every_demonstration_is_a_motion_the_arm_can_make(arm, skill):
    """No demonstration starts or passes in self-collision or outside the joint limits (the
    Jaco's wrist folds to within a millimetre of its forearm at the pour and the insertion, so
    draws that touch are redrawn), and the redrawn set is still the seed's."""
    demos = make_pose_demonstrations(arm, skill, num_demos=6, num_points=200, seed=0)
    assert arm.within_limits(demos.joint_positions).all()
    for m in range(demos.M):
        report = self_collision_report(arm, demos.joint_positions[m], demos.time)
        assert not report.collision, (m, report.reason)
        assert not report.states_in_collision.any()
    again = make_pose_demonstrations(arm, skill, num_demos=6, num_points=200, seed=0)
    np.testing.assert_array_equal(again.joint_positions, demos.joint_positions)


def test_pose_skills_vary_and_are_seeded(sawyer):
    a = make_pose_demonstrations(sawyer, "pouring", num_demos=3, num_points=60, seed=7)
    b = make_pose_demonstrations(sawyer, "pouring", num_demos=3, num_points=60, seed=7)
    c = make_pose_demonstrations(sawyer, "pouring", num_demos=3, num_points=60, seed=8)
    np.testing.assert_array_equal(a.orientations, b.orientations)
    assert np.abs(a.positions - c.positions).max() > 1e-3
    assert np.linalg.norm(a.positions[:, 0].std(axis=0)) > 0.005      # starts differ
    assert a.name == "pouring_sawyer" and set(POSE_SKILLS) == {"pouring", "inserting"}


def test_pose_skill_bad_arguments(sawyer):
    with raises_naming(UnknownSkillError, "skill", "pouring"):
        make_pose_demonstrations(sawyer, "juggling")
    with raises_naming(RobotError, "robot"):
        make_pose_demonstrations("sawyer", "pouring")
    with raises_naming(RobotError, "num_demos"):
        make_pose_demonstrations(sawyer, "pouring", num_demos=1)
