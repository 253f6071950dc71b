"""The start of a pose skill on a URDF arm whose position IK turns the hand far from the skill
(issue 37: example-robot-data's UR5, its wrist flipped): an end-effector start is solved with
the hand turned as the skill starts, and from a joint start turned far away the free plan
turns back and completes the skill. Judged on the plan's own kinematics against the
demonstrations, next to the verdict."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from clamp import learn_prior, plan
from robots import Robot
from robots.registry import example_robot_data_share
from tests.pose_demos import pose_demonstrations
from tests.hand_measures import angle_deg

H = np.pi / 2
#: Universal Robots' home posture (upper arm up, forearm level, tool pointing down) [rad]
UR_HOME = np.array([0.0, -H, H, -H, -H, 0.0])


@pytest.fixture(scope="module")
def ur5():
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
    return Robot.from_urdf(urdf, end_effector="tool0", package_dirs=[share], name="ur5")


def assert_completes_the_skill(ur5, demos, result) -> None:
    """The plan passes its verdict, and on its own kinematics ends where and turned as the
    demonstrations end (within the verdict's completion radius and angle)."""
    assert result.success, result.reasons
    end = demos.positions[:, -1]
    assert np.linalg.norm(ur5.fk(result.q[-1]) - end.mean(axis=0)) <= result.skill[
        "completion_radius"]
    end_rotation = Rotation.from_quat(demos.orientations[:, -1]).mean().as_matrix()
    assert angle_deg(ur5.ee_rotation(result.q[-1])[0], end_rotation) <= result.skill[
        "completion_angle_deg"]


def test_an_end_effector_start_is_turned_as_the_skill_starts_and_the_plan_completes_it(ur5):
    demos = pose_demonstrations(ur5, T=100, duration=5.0, base=UR_HOME)
    prior = learn_prior(demos)
    start_rotation = Rotation.from_quat(demos.orientations[:, 0]).mean().as_matrix()
    spread = max(angle_deg(start_rotation, R) for R in
                 Rotation.from_quat(demos.orientations[:, 0]).as_matrix())
    position_ik = ur5.ik(prior.mean[0, :3])         # the arm's own branch: the hand turned away
    assert angle_deg(ur5.ee_rotation(position_ik.q)[0], start_rotation) > 90.0

    result = plan(prior, ur5, None, prior.mean[0, :3], covariance=False)
    assert np.linalg.norm(ur5.fk(result.q[0]) - prior.mean[0, :3]) <= 1e-4
    assert angle_deg(ur5.ee_rotation(result.q[0])[0], start_rotation) <= spread
    assert_completes_the_skill(ur5, demos, result)


@pytest.mark.parametrize("base", [UR_HOME + [0.0, 0.0, 0.0, 0.0, 0.0, 0.5],
                                  UR_HOME + [0.0, 0.37, -0.37, -0.03, 0.0, 0.0]],
                         ids=["home, flange turned", "forearm lowered"])
def test_from_a_joint_start_turned_far_from_the_skill_the_free_plan_completes_it(ur5, base):
    """The start configuration is the one position IK gives (the hand turned > 90 deg from the
    skill's start; the skill about UR_HOME with the tool flange turned, or with the forearm
    lowered, where the initial guess's per-state steps stop on the flipped wrist): the
    conditioned orientation chain turns the hand back, and the plan follows it on the start's
    branch."""
    demos = pose_demonstrations(ur5, base=base)
    prior = learn_prior(demos)
    start = ur5.ik(prior.mean[0, :3]).q
    start_rotation = Rotation.from_quat(demos.orientations[:, 0]).mean().as_matrix()
    assert angle_deg(ur5.ee_rotation(start)[0], start_rotation) > 90.0

    result = plan(prior, ur5, None, start, covariance=False)
    np.testing.assert_allclose(result.q[0], start, atol=1e-6)
    assert_completes_the_skill(ur5, demos, result)
