"""Planning with a pose prior (issue 37): the goal pose met on both arms, measured on the
plan's own kinematics; the skill's orientation check against a plan forced to turn the hand
away mid-skill, next to today's position-only check of the same plan; a box on the path of a
pose skill recorded in joint space (a URDF arm), passed with the hand turned as the skill
turns it; bad pose input."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bad_input import raises_naming
from clamp import PlannerConfig, errors, learn_prior, make_request, plan
from clamp.factors import OrientationFamily
from clamp.prior import so3
from clamp.planning.reference import ROTATION_NOISE_FLOOR, noise_floored, planning_prior
from clamp.prior.skill import TUBE_RATIO, skill_checks
from scenes import Box, Scene, make_demonstrations
from scenes.joint_demonstrations import from_joint_trajectories
from robots.pose_skills import make_pose_demonstrations
from tests.clamp.factors.test_pose_factors import panda  # noqa: F401  (the Panda fixture)
from tests.clamp.planning.test_min_clearance import coal_clearance
from tests.pose_demos import pose_demonstrations
from tests.hand_measures import hand_angle, hand_pose


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_the_plan_ends_at_the_goal_pose(arm, request):
    robot = request.getfixturevalue(arm)
    demos = pose_demonstrations(robot)
    prior = learn_prior(demos)
    end = so3.from_quaternions(prior.mean_quaternions()[-1])
    rotation = end @ so3.exp_map(np.radians(10.0) * np.array([0.0, 0.6, 0.8]))
    position = prior.mean[-1, :3] + np.array([0.02, -0.01, 0.02])
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = rotation, position
    result = plan(prior, robot, None, demos.joint_positions[1, 0], goal=pose, covariance=False)
    assert result.success, result.reasons
    assert np.linalg.norm(robot.fk(result.q[-1]) - position) <= 1e-3
    assert hand_angle(robot, result.q[-1], rotation) <= 1.0
    assert result.goal_rotation_error is not None and np.degrees(result.goal_rotation_error) <= 1.0


@pytest.mark.parametrize("skill", ["pouring", "inserting"])
@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_a_goal_turned_beyond_the_demonstrations_is_met(arm, skill, request):
    """The synthetic pose skills' demonstrations agree on the hand's end rotation to 1e-7 rad
    in some axes (inserting in all three, pouring in the two it does not tilt about); a goal
    turned 10 deg from their mean end rotation, about an axis of the hand across those, and
    moved 2 cm, is met within 1 mm and 1 deg (issue 37: was met in part, 5-9.9 deg off).
    Measured by Pinocchio's forward kinematics of the plan's last configuration and scipy."""
    robot = request.getfixturevalue(arm)
    demos = make_pose_demonstrations(robot, skill, num_demos=6, num_points=40, seed=0)
    end = Rotation.from_quat(demos.orientations[:, -1]).mean()
    turned = end * Rotation.from_rotvec(np.radians(10.0) * np.array([0.0, 0.6, 0.8]))
    position = demos.positions[:, -1].mean(axis=0) + np.array([0.02, 0.0, 0.0])
    prior = learn_prior(demos)
    result = plan(prior, robot, None, demos.joint_positions[0, 0],
                  goal=(position, turned.as_quat()), covariance=False)
    assert result.success, result.reasons
    reached, rotation = hand_pose(robot, result.q[-1])
    assert np.linalg.norm(reached - position) <= 1e-3
    assert np.degrees((rotation.inv() * turned).magnitude()) <= 1.0


def test_only_a_goal_or_via_rotation_loosens_the_orientation_chain(jaco):
    """The inserting demonstrations end with the hand's rotation agreeing to 1e-7 rad (measured
    here with scipy). A plan without a goal or via rotation (none, or a goal position only)
    holds the hand's end rotation that closely: its orientation chain's end std stays below
    ROTATION_NOISE_FLOOR (with the floor applied at learning, issue 37's third session, it
    was 1.7x it, and every plan's orientation factor softer). A via rotation mid-skill floors
    the chain (what meets a goal rotation beyond the demonstrations' agreement:
    test_a_goal_turned_beyond_the_demonstrations_is_met), so after it the end is that loose."""
    demos = make_pose_demonstrations(jaco, "inserting", num_demos=6, num_points=40, seed=0)
    ends = Rotation.from_quat(demos.orientations[:, -1])
    assert np.max((ends * ends.mean().inv()).magnitude()) <= 1e-7
    prior = learn_prior(demos)
    config = PlannerConfig()
    start = demos.joint_positions[0, 0]
    goal = demos.positions[:, -1].mean(axis=0) + np.array([0.02, 0.0, 0.0])
    middle = prior.T // 2
    via = (demos.positions[:, middle].mean(axis=0),
           Rotation.from_quat(demos.orientations[:, middle]).mean().as_quat())

    def end_std(goal, vias=()):
        request = make_request(prior, jaco, start, goal, vias, config)
        orientation = planning_prior(prior, jaco, request, config).orientation
        return float(np.linalg.norm(orientation.std[-1, :3]))

    assert end_std(None) < ROTATION_NOISE_FLOOR
    assert end_std(goal) < ROTATION_NOISE_FLOOR
    assert end_std(None, [(middle, via)]) >= ROTATION_NOISE_FLOOR


def test_a_chain_floored_twice_is_floored_once(jaco):
    """A pose prior saved while the floor was applied at learning plans as it did: flooring
    its orientation chain again changes no number."""
    prior = learn_prior(make_pose_demonstrations(jaco, "pouring", num_demos=4, num_points=30))
    once = noise_floored(prior.orientation)
    twice = noise_floored(once)
    r = np.arange(3)
    assert np.all(np.asarray(once.Q)[:, r, r] >= ROTATION_NOISE_FLOOR ** 2 * (1 - 1e-12))
    assert np.array_equal(np.asarray(twice.Q), np.asarray(once.Q))
    assert np.array_equal(np.asarray(twice.cov0), np.asarray(once.cov0))
    assert np.array_equal(np.asarray(twice.mean), np.asarray(once.mean))


def test_a_hand_turned_60_degrees_mid_skill_fails_the_orientation_check(sawyer):
    """An orientation window against the skill turns the hand 60 deg in the middle: the pose
    verdict fails it, naming the angle, while the position-only skill check passes it. The
    turn is a roll about the tool's axis, which the wrist makes without moving the hand: a
    turn about another axis also moves the hand, and whether that leaves the position tube
    depends on the solve, not on the verdict under test."""
    demos = pose_demonstrations(sawyer, spread=0.03)
    prior = learn_prior(demos)
    start = demos.joint_positions[0, 0]
    free = plan(prior, sawyer, None, start, covariance=False)
    assert free.success, free.reasons
    T = prior.T
    middle = np.arange(T // 2 - 2, T // 2 + 3)
    R_mid, _ = sawyer.ee_rotation(free.q[T // 2])
    turned = R_mid @ so3.exp_map([0.0, 0.0, np.radians(60.0)])      # about the tool's axis
    window = OrientationFamily(middle, rotation=turned, tolerance=np.radians(3.0))
    result = plan(prior, sawyer, None, start, extra_factors=[window], covariance=False)
    assert result.violations["orientation"] == 0.0                  # the window is met
    reference = so3.from_quaternions(prior.mean_quaternions())
    away = max(hand_angle(sawyer, result.q[i], reference[i]) for i in middle)
    assert away >= 45.0                                              # measured independently
    assert not result.success
    reason = next(r for r in result.reasons if r.startswith("turned away from the skill"))
    assert "deg from how the skill turns it" in reason and "limit" in reason
    assert f"{result.skill['angle_at_worst_deg']:.0f} deg" in reason
    assert result.skill["max_angle_ratio"] > TUBE_RATIO
    # today's position-only check of the same plan: with the skill
    position_only = learn_prior(demos.__class__(demos.positions, demos.velocities, demos.time))
    check = skill_checks(position_only, result.inputs.model_prior, result.ee_path, False)
    assert check.within_tube and check.completed and not check.reasons
    assert not any(r.startswith("left the skill") for r in result.reasons)


def test_a_position_prior_meets_a_goal_pose(sawyer):
    """A goal pose with a position-only prior: the rotation target holds the hand's rotation."""
    demos = pose_demonstrations(sawyer)
    prior = learn_prior(demos.__class__(demos.positions, demos.velocities, demos.time))
    rotation = so3.from_quaternions(demos.orientations[0, -1])
    result = plan(prior, sawyer, None, demos.joint_positions[1, 0],
                  goal=(prior.mean[-1, :3], so3.to_quaternions(rotation)), covariance=False)
    assert result.success, result.reasons
    assert hand_angle(sawyer, result.q[-1], rotation) <= 1.0
    assert np.linalg.norm(sawyer.fk(result.q[-1]) - prior.mean[-1, :3]) <= 1e-3


def test_bad_pose_targets_are_named(sawyer):
    demos = pose_demonstrations(sawyer, T=20)
    prior = learn_prior(demos)
    start = demos.joint_positions[0, 0]
    with raises_naming(errors.InvalidParameterError, "goal quaternion", "unit"):
        plan(prior, sawyer, None, start, goal=(prior.mean[-1, :3], [0.0, 0.0, 0.0, 2.0]))
    skewed = np.eye(4)
    skewed[0, 1] = 0.5
    with raises_naming(errors.InvalidParameterError, "goal", "rotation"):
        plan(prior, sawyer, None, start, goal=skewed)
    pose = np.eye(4)
    pose[:3, 3] = prior.mean[0, :3]
    with raises_naming(errors.InvalidParameterError, "start", "pose"):
        plan(prior, sawyer, None, pose)


def test_a_box_on_the_path_of_a_pose_skill_recorded_in_joint_space_is_passed_holding_its_orientation(panda):
    """Joint recordings of a Panda (a synthetic reach followed by its inverse kinematics) give
    a pose prior; a box on the prior's mean path half way along it: the plan passes the
    verdict, clears the box on the arm's own geometry, and turns the hand no further from the
    skill's rotation than TUBE_RATIO times the demonstrations' own orientation spread."""
    reach = make_demonstrations("box_closing", num_demos=6, seed=0)
    joints = [panda.ik_trajectory(path).q for path in reach.positions]
    demos = from_joint_trajectories(panda, joints, [reach.time] * reach.M)
    prior = learn_prior(demos)
    assert prior.orientation is not None
    mean = np.asarray(prior.mean)[:, :3]
    box = Box(mean[len(mean) // 2], [0.03, 0.03, 0.03])
    result = plan(prior, panda, Scene([box]), mean[0], covariance=False)
    assert result.success, result.reasons
    assert coal_clearance(panda, box, result.q) > 0.0        # the URDF's meshes, measured here
    # the hand's angle from the skill's mean rotation, measured on the arm, against the
    # demonstrations' own angles from it (both from forward kinematics, not from the verdict)
    reference = so3.from_quaternions(prior.mean_quaternions())
    planned = np.array([hand_angle(panda, q, R) for q, R in zip(result.q, reference)])
    shown = np.array([[hand_angle(panda, q, R) for q, R in zip(demo, reference)]
                      for demo in demos.joint_positions])
    spread = np.sqrt(np.mean(shown ** 2, axis=0))
    assert np.max(planned) <= TUBE_RATIO * np.max(spread)
    assert result.skill["max_angle_ratio"] <= TUBE_RATIO
