"""A goal pose on the command line (``clamp plan --goal x y z --goal-quaternion qx qy qz qw``)
and in a problems file (``"goal": {"position": [...], "quaternion": [...]}`` for ``clamp
batch``), through the real command line (a subprocess, as a user runs it), with a synthetic
pose skill (robots.pose_skills, no ../shared data): the plan ends within 1 mm and 1 deg of the
goal pose, measured on the executable trajectory by Pinocchio's forward kinematics and scipy's
rotations (not the planner's kinematics nor the result's own fields); each bad input is exit 2
with one line naming the flag, what was expected and what was given."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tests.clamp.cli.test_cli_contract import clamp, refused
from tests.hand_measures import hand_pose

#: support states of the test skills (small: each case plans in about a second)
T = 40


def goal_pose(demos) -> tuple[np.ndarray, np.ndarray, float]:
    """A goal pose the skill shows: the end pose of the demonstration whose end rotation is
    farthest from the demonstrations' mean end rotation (scipy's mean); (position (3,),
    quaternion (4,) x, y, z, w, that angle [deg])."""
    ends = Rotation.from_quat(demos.orientations[:, -1])
    angles = (ends.mean().inv() * ends).magnitude()
    k = int(np.argmax(angles))
    return demos.positions[k, -1], demos.orientations[k, -1], float(np.degrees(angles[k]))


def numbers(values) -> list[str]:
    return [repr(float(v)) for v in values]


@pytest.fixture(scope="module")
def work(tmp_path_factory, jaco, sawyer) -> Path:
    """Pouring by the Jaco and the Sawyer (joint recordings: positions and rotations), and a
    position-only skill, as demonstration files."""
    from robots.pose_skills import make_pose_demonstrations
    from scenes import make_demonstrations
    folder = tmp_path_factory.mktemp("goal_pose")
    for robot in (jaco, sawyer):
        make_pose_demonstrations(robot, "pouring", num_demos=6, num_points=T, seed=0).save_npz(
            folder / f"pour_{robot.name}.npz")
    make_demonstrations("box_closing", num_points=20, seed=1).save_npz(folder / "positions.npz")
    return folder


def demonstrations(work: Path, arm: str):
    from scenes import load_demonstrations
    return load_demonstrations(work / f"pour_{arm}.npz")


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_the_plan_ends_at_a_goal_pose_given_on_the_command_line(work, arm, request):
    from robots.trajectory import load_trajectory
    robot = request.getfixturevalue(arm)
    demos = demonstrations(work, arm)
    position, quaternion, turned = goal_pose(demos)
    assert turned > 2.0             # the goal's rotation is not the skill's mean end rotation
    out = f"out_{arm}"
    result = clamp(["plan", "--robot", arm, "--demos", f"pour_{arm}.npz",
                    "--start-joints", *numbers(demos.joint_positions[0, 0]),
                    "--goal", *numbers(position), "--goal-quaternion", *numbers(quaternion),
                    "--out", out], work)
    assert result.returncode == 0, result.stderr
    trajectory = load_trajectory(work / out / "trajectory_result.json")
    reached, rotation = hand_pose(robot, trajectory.positions[-1])     # what the arm executes
    angle = np.degrees((Rotation.from_quat(quaternion).inv() * rotation).magnitude())
    assert np.linalg.norm(reached - position) <= 1e-3
    assert angle <= 1.0
    record = json.loads((work / out / "plan.json").read_text())
    assert record["goal_rotation_error_deg"] == pytest.approx(angle, abs=1e-3)
    head, _, row = result.stdout.splitlines()[:3]                       # the summary
    assert head.split()[:10] == ["plan", "verdict", "clear", "mm", "end", "mm", "goal", "mm", "goal", "deg"]
    assert row.split()[3:6] == ["-", f"{record['goal_error'] * 1e3:.1f}",
                                f"{record['goal_rotation_error_deg']:.2f}"]
    # clamp view plans the folder's recorded problem again: the same goal pose, its handle at
    # the goal's position, and dragging it keeps the rotation
    from clamp.cli.viewer import replan_recorded
    from clamp.viz.viewer import goal_position, moved_goal
    _, inputs, again, _ = replan_recorded(work / out)
    assert again.success and np.degrees(again.goal_rotation_error) <= 1.0
    np.testing.assert_allclose(goal_position(inputs["goal"], again.ee_path[-1]), position)
    moved = moved_goal(again.inputs.goal, position + 0.01)
    assert (Rotation.from_quat(moved[1]).inv() * Rotation.from_quat(quaternion)).magnitude() < 1e-9


def test_wrong_count_of_quaternion_numbers(work):
    line = refused(clamp(["plan", "--robot", "jaco", "--demos", "pour_jaco.npz", "--goal", "0.3", "-0.3",
                          "0.2", "--goal-quaternion", "0", "0", "1", "--start", "0.3", "-0.3", "0.3",
                          "--out", "out", "-q"], work), work, "--goal-quaternion", "expected 4 numbers")
    assert "got 3 numbers [0.0, 0.0, 1.0]" in line


def test_a_quaternion_that_is_not_unit(work):
    line = refused(clamp(["plan", "--robot", "jaco", "--demos", "pour_jaco.npz", "--goal", "0.3", "-0.3",
                          "0.2", "--goal-quaternion", "0", "0", "1", "1", "--start", "0.3", "-0.3", "0.3",
                          "--out", "out", "-q"], work), work, "--goal-quaternion", "unit quaternion")
    assert "got length 1.414" in line


def test_a_rotation_without_a_goal_position(work):
    refused(clamp(["plan", "--robot", "jaco", "--demos", "pour_jaco.npz", "--goal-quaternion", "0", "0",
                   "0", "1", "--start", "0.3", "-0.3", "0.3", "--out", "out", "-q"], work),
            work, "--goal-quaternion", "only with --goal x y z", "no --goal")


def position_skill_goal(work: Path, robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the position-only skill: (start position (3,), goal position (3,), goal quaternion
    (4,)): the prior's mean end, the hand turned 10 deg about its tool axis from where the
    skill's free plan ends it (a rotation the arm reaches, which nothing learned gives)."""
    from clamp import learn_prior, plan
    from scenes import load_demonstrations
    prior = learn_prior(load_demonstrations(work / "positions.npz"))
    free = plan(prior, robot, None, prior.mean[0, :3], goal=prior.mean[-1, :3], covariance=False)
    assert free.success, free.reasons
    _, end = hand_pose(robot, free.q[-1])
    turned = end * Rotation.from_rotvec(np.radians(10.0) * np.array([0.0, 0.0, 1.0]))
    return prior.mean[0, :3], prior.mean[-1, :3], turned.as_quat()


def test_a_goal_pose_for_a_skill_learned_without_orientation(work, jaco):
    """A position-only skill ends at the goal pose as ``clamp.plan`` does (the rotation a
    target on the last state), within 1 mm and 1 deg by Pinocchio, and says so in degrees."""
    from robots.trajectory import load_trajectory
    start, position, quaternion = position_skill_goal(work, jaco)
    result = clamp(["plan", "--robot", "jaco", "--demos", "positions.npz", "--start", *numbers(start),
                    "--goal", *numbers(position), "--goal-quaternion", *numbers(quaternion),
                    "--out", "out_positions", "-q"], work)
    assert result.returncode == 0, result.stderr
    record = json.loads((work / "out_positions" / "plan.json").read_text())
    assert record["success"], record["reasons"]
    trajectory = load_trajectory(work / "out_positions" / "trajectory_result.json")
    reached, rotation = hand_pose(jaco, trajectory.positions[-1])
    angle = np.degrees((Rotation.from_quat(quaternion).inv() * rotation).magnitude())
    assert np.linalg.norm(reached - position) <= 1e-3 and angle <= 1.0
    assert record["goal_rotation_error_deg"] == pytest.approx(angle, abs=1e-3)


def test_a_rotation_with_a_joint_goal(work, jaco):
    demos = demonstrations(work, "jaco")
    refused(clamp(["plan", "--robot", "jaco", "--demos", "pour_jaco.npz",
                   "--start-joints", *numbers(demos.joint_positions[0, 0]),
                   "--goal", *numbers(demos.joint_positions[1, -1]), "--goal-quaternion", "0", "0", "0", "1",
                   "--out", "out", "-q"], work),
            work, "--goal-quaternion", "only with a goal position", f"{jaco.n} joint values")


def test_a_pose_typed_as_seven_goal_numbers(work):
    """x y z qx qy qz qw on --goal of a 6-joint arm: the count is named, and where the
    rotation goes."""
    line = refused(clamp(["plan", "--robot", "jaco", "--demos", "pour_jaco.npz", "--start", "0.3", "-0.3",
                          "0.3", "--goal", "0.3", "-0.3", "0.2", "0", "0", "0", "1", "--out", "out", "-q"],
                         work), work, "--goal", "x y z [m] or 6 joint values", "got 7 numbers")
    assert "--goal-quaternion qx qy qz qw" in line


def test_a_goal_pose_in_a_batch_problems_file(work, sawyer, jaco):
    """A problems file with goal poses, for a pose skill (Sawyer pouring) and a position-only
    skill (Jaco): each planned to within 1 mm and 1 deg (the inline trajectory's last point,
    by Pinocchio)."""
    from robots.trajectory import JointTrajectory
    demos = demonstrations(work, "sawyer")
    position, quaternion, _ = goal_pose(demos)
    start, end, turned = position_skill_goal(work, jaco)
    goals = {"pour": (sawyer, position, quaternion), "positions": (jaco, end, turned)}
    problems = [{"id": "pour", "prior": {"demos": "pour_sawyer.npz"}, "robot": "sawyer",
                 "start": demos.joint_positions[0, 0].tolist(),
                 "goal": {"position": position.tolist(), "quaternion": quaternion.tolist()}},
                {"id": "positions", "prior": {"demos": "positions.npz"}, "robot": "jaco",
                 "start": start.tolist(),
                 "goal": {"position": end.tolist(), "quaternion": turned.tolist()}}]
    (work / "problems.jsonl").write_text("".join(json.dumps(p) + "\n" for p in problems))
    result = clamp(["batch", "problems.jsonl", "--out", "results.jsonl", "-q"], work)
    assert result.returncode == 0, result.stderr
    records = {r["id"]: r for r in map(json.loads, (work / "results.jsonl").read_text().splitlines())}
    for name, (robot, goal_position, goal_quaternion) in goals.items():
        planned = records[name]
        assert planned["status"] == "done" and planned["success"], (name, planned["reasons"])
        trajectory = JointTrajectory.from_dict(planned["trajectory"])
        reached, rotation = hand_pose(robot, trajectory.positions[-1])
        assert np.linalg.norm(reached - goal_position) <= 1e-3, name
        angle = (Rotation.from_quat(goal_quaternion).inv() * rotation).magnitude()
        assert np.degrees(angle) <= 1.0, name
