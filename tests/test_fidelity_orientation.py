"""The independent orientation check of the skill-fidelity benchmark
(benchmarks/fidelity_orientation.py): the hand's rotation by Pinocchio's forward kinematics, the
demonstrations' mean and spread, and the verdict's rule coded again. Built from the synthetic
inserting skill on the Sawyer (robots.pose_skills)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import fidelity_orientation as fo  # noqa: E402

from clamp import learn_prior, plan  # noqa: E402
from robots.pose_skills import make_pose_demonstrations  # noqa: E402
from scenes.errors import InvalidArgumentError  # noqa: E402

TURN = np.radians(60.0)


@pytest.fixture(scope="module")
def inserting(sawyer):
    """The inserting skill on the Sawyer, its orientation as the check reads it, and the free
    plan from the first demonstration's start configuration."""
    demos = make_pose_demonstrations(sawyer, "inserting", num_demos=6, num_points=100, seed=0)
    skill = fo.OrientationSkill.of(fo.hand_rotations(sawyer, demos.joint_positions))
    prior = learn_prior(demos)
    free = plan(prior, sawyer, None, demos.joint_positions[0, 0])
    return demos, skill, prior, free


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_hand_rotations_agree_with_the_robots_own_kinematics(request, name):
    robot = request.getfixturevalue(name)
    q = np.stack([robot.random_configuration(np.random.default_rng(k)) for k in range(4)])
    ours = fo.hand_rotations(robot, q)
    theirs, _ = robot.ee_rotation(q)
    assert ours.shape == (4, 3, 3)
    np.testing.assert_allclose(ours, theirs, atol=1e-9)
    assert fo.hand_rotations(robot, q.reshape(2, 2, robot.n)).shape == (2, 2, 3, 3)


def test_mean_rotation_agrees_with_the_learned_pose_prior(inserting):
    """Two ways of averaging the same demonstrations (scipy's quaternion mean here, clamp's
    chordal mean of the matrices there) agree to a fraction of a degree."""
    _, skill, prior, _ = inserting
    angle = fo.geodesic_angle(skill.mean, prior.orientation.mean_rotations)
    assert np.degrees(angle.max()) < 0.5
    assert np.all(skill.spread >= fo.ORIENTATION_FLOOR)


def test_accepts_the_free_plan_and_rejects_it_turned_60_degrees_mid_skill(sawyer, inserting):
    _, skill, _, free = inserting
    assert free.success, free.reasons
    rotations = fo.hand_rotations(sawyer, free.q)
    judged = fo.judge_orientation(rotations, skill)
    assert judged.passed, judged.failures
    assert judged.ratio <= 1.0

    # turn the wrist's last joint (the hand about its roll axis) up to 60 deg and back, around
    # the state of the middle half where the skill's limit is tightest
    T = len(free.q)
    middle = np.arange(T // 4, 3 * T // 4)
    k = int(middle[np.argmin(judged.limit[middle])])
    assert judged.limit[k] < TURN                # the turn is beyond the rule's limit there
    bump = np.exp(-0.5 * ((np.arange(T) - k) / (0.05 * T)) ** 2)
    q = free.q.copy()
    q[:, -1] += TURN * bump
    turned = fo.judge_orientation(fo.hand_rotations(sawyer, q), skill)
    assert not turned.passed
    assert abs(turned.worst - k) <= 0.1 * T
    assert turned.angle[turned.worst] > turned.limit[turned.worst]
    assert "deg from the demonstrations' mean" in turned.failures[0]
    assert f"state {turned.worst}" in turned.failures[0]
    # the turn is the free plan's rotation at the same state, 60 deg about the roll axis
    assert fo.added_rotation(fo.hand_rotations(sawyer, q), rotations) == pytest.approx(60.0, abs=0.1)
    assert fo.added_rotation(rotations, rotations) == pytest.approx(0.0, abs=1e-6)


def test_rejects_a_plan_that_ends_turned_away(sawyer, inserting):
    _, skill, _, free = inserting
    rotations = fo.hand_rotations(sawyer, free.q)
    turn = Rotation.from_rotvec([0.0, 0.0, 3.0 * skill.end_spread * fo.COMPLETION_FACTOR])
    ends_off = rotations.copy()
    ends_off[-1] = (turn * Rotation.from_matrix(rotations[-1])).as_matrix()
    judged = fo.judge_orientation(ends_off, skill)
    assert judged.end_angle > judged.end_limit
    assert any("ends" in text for text in judged.failures)


def test_bad_input_names_the_argument(sawyer, inserting):
    _, skill, _, free = inserting
    with pytest.raises(InvalidArgumentError, match="rotations"):
        fo.judge_orientation(np.eye(3)[None].repeat(3, axis=0), skill)
    with pytest.raises(InvalidArgumentError, match="q"):
        fo.hand_rotations(sawyer, np.zeros((4, 3)))
    with pytest.raises(InvalidArgumentError, match="demo_rotations"):
        fo.OrientationSkill.of(np.eye(3)[None, None])
    with pytest.raises(InvalidArgumentError, match="free_rotations"):
        fo.added_rotation(np.eye(3)[None].repeat(2, axis=0), np.eye(3)[None])
