"""``clamp plan`` writes an executable trajectory: checked here on the written files, independently
of the retimer, for box_closing around the README box on the Jaco and the Sawyer.

Per file: every sample within the URDF's velocity limits (read here by Pinocchio from the URDF
the file names) and the given acceleration limit (stored accelerations, and the difference
quotients of positions and velocities), zero velocity and acceleration at both ends (1e-6),
and the end-effector path within 1 mm of the plan's end-effector path (the plan's joint
samples, cubic-Hermite interpolated with their velocities, through the robot's FK). The ROS 2
file validates against its schema and loads back to the same trajectory. A failed plan writes
no trajectory and exits 1.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

from clamp.cli.commands import main
from robots import JointTrajectory, load_robot
from robots.trajectory import load_schema

ACC_LIMIT = 1.5      # rad/s^2
TOL = 1e-6           # relative, on the limits; absolute [rad/s, rad/s^2] at the ends
SAWYER_OFFSET = [0.3, 0.0, 0.2]   # box_closing moved into the Sawyer's reach (as examples/export_and_retime.py)
README_BOX = {"type": "box", "center": [0.32, -0.32, 0.13], "size": [0.09, 0.06, 0.28]}


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> dict[str, Path]:
    """`clamp plan` on box_closing (synthetic, 100 states) around the README box, per arm."""
    from scenes import Scene, make_demonstrations
    work = tmp_path_factory.mktemp("executable")
    demos = make_demonstrations("box_closing", seed=0)
    demos.save_npz(work / "demos.npz")
    outputs = {}
    for name, offset in (("jaco", np.zeros(3)), ("sawyer", np.array(SAWYER_OFFSET))):
        box = dict(README_BOX, center=(np.array(README_BOX["center"]) + offset).tolist())
        Scene.from_dict({"obstacles": [box]}).save(work / f"scene_{name}.json")
        start = demos.positions[:, 0].mean(axis=0) + offset
        out = work / name
        code = main(["plan", "--robot", name, "--demos", str(work / "demos.npz"), "--num-points", "100",
                     "--translate", *map(str, offset), "--scene", str(work / f"scene_{name}.json"),
                     "--start", *map(str, start), "--acc-limit", str(ACC_LIMIT), "--out", str(out), "-q"])
        assert code == 0, name
        outputs[name] = out
    return outputs


def urdf_velocity_limits(urdf: str, joint_names) -> np.ndarray:
    """<limit velocity> of the named joints, read by Pinocchio from the URDF file."""
    import pinocchio as pin
    model = pin.buildModelFromUrdf(urdf)
    return np.array([model.velocityLimit[model.joints[model.getJointId(name)].idx_v] for name in joint_names])


def plan_ee_distance(robot, plan: dict, positions: np.ndarray, density: int = 16) -> np.ndarray:
    """Distance [m] of each configuration's end effector to the plan's end-effector path."""
    t, q, qdot = (np.array(plan[key]) for key in ("time", "q", "qdot"))
    dense = np.append((t[:-1, None] + np.diff(t)[:, None] * np.arange(density) / density).ravel(), t[-1])
    path = robot.fk(CubicHermiteSpline(t, q, qdot)(dense))
    points = robot.fk(positions)
    a, ab = path[:-1], np.diff(path, axis=0)
    w = np.clip(np.einsum("psk,sk->ps", points[:, None] - a[None], ab) / np.maximum((ab**2).sum(1), 1e-300), 0, 1)
    return np.linalg.norm(points[:, None] - (a[None] + w[..., None] * ab[None]), axis=-1).min(axis=1)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_written_trajectory_is_executable(planned, name):
    out = planned[name]
    data = json.loads((out / "trajectory_result.json").read_text())
    points = data["points"]
    t = np.array([p["time_from_start"] for p in points])
    q, qd, qdd = (np.array([p[key] for p in points]) for key in ("positions", "velocities", "accelerations"))
    vlim = urdf_velocity_limits(data["header"]["urdf"], data["joint_names"])
    dt = np.diff(t)[:, None]
    assert np.all(np.abs(qd) <= vlim * (1 + TOL))
    assert np.all(np.abs(np.diff(q, axis=0)) / dt <= vlim * (1 + TOL))
    assert np.all(np.abs(qdd) <= ACC_LIMIT * (1 + TOL))
    assert np.all(np.abs(np.diff(qd, axis=0)) / dt <= ACC_LIMIT * (1 + TOL))
    assert np.abs(qd[[0, -1]]).max() <= TOL and np.abs(qdd[[0, -1]]).max() <= TOL   # rest to rest
    plan = json.loads((out / "plan.json").read_text())
    assert plan["success"] and plan["trajectory"]["files"] == ["trajectory_result.json",
                                                               "trajectory_result_ros2.json"]
    np.testing.assert_allclose(q[[0, -1]], np.array(plan["q"])[[0, -1]], atol=1e-12)
    robot = load_robot(name)
    assert plan_ee_distance(robot, plan, q).max() <= 1e-3            # end-effector path, 1 mm
    assert t[-1] == pytest.approx(plan["trajectory"]["duration"])


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_ros2_file_validates_and_round_trips(planned, name):
    jsonschema = pytest.importorskip("jsonschema", reason="schema validation needs jsonschema (test extra)")
    out = planned[name]
    message = json.loads((out / "trajectory_result_ros2.json").read_text())
    jsonschema.Draft202012Validator(load_schema(ros2=True)).validate(message)
    ros2 = JointTrajectory.load(out / "trajectory_result_ros2.json")
    full = JointTrajectory.load(out / "trajectory_result.json")
    assert ros2.joint_names == full.joint_names
    for field in ("positions", "velocities", "accelerations"):
        np.testing.assert_array_equal(getattr(ros2, field), getattr(full, field))
    np.testing.assert_allclose(ros2.time_from_start, full.time_from_start, rtol=0, atol=0.51e-9)
    assert ros2.to_ros2_dict() == message


def test_start_joints_is_the_plans_first_state(planned, tmp_path):
    """--start-joints (the robot's measured configuration): the plan starts exactly there."""
    q0 = np.array(json.loads((planned["jaco"] / "plan.json").read_text())["q"][0]) + 0.01
    demos = planned["jaco"].parent / "demos.npz"
    argv = ["plan", "--robot", "jaco", "--demos", str(demos), "--num-points", "60", "-q"]
    assert main(argv + ["--start-joints", *map(str, q0), "--out", str(tmp_path / "a")]) == 0
    plan = json.loads((tmp_path / "a" / "plan.json").read_text())
    np.testing.assert_allclose(plan["q"][0], q0, atol=2e-3)
    assert len(plan["q"]) == 60                                       # --num-points
    assert main(argv + ["--start-joints", "0.1", "0.2", "--out", str(tmp_path / "b")]) == 2
    assert not (tmp_path / "b").exists()


def test_an_unreachable_start_writes_nothing_and_exits_2(planned, tmp_path, capsys):
    """An unreachable start: exit 2 naming --start, no output folder; with --force over an
    earlier successful run, that run's plan and trajectory files are left as they were."""
    demos = planned["jaco"].parent / "demos.npz"
    out = tmp_path / "out"
    argv = ["plan", "--robot", "jaco", "--demos", str(demos), "--num-points", "40", "--out", str(out), "-q"]
    assert main(argv + ["--start", "5", "5", "5"]) == 2
    assert "--start: start position [5.0, 5.0, 5.0] is out of reach" in capsys.readouterr().err
    assert not out.exists()
    good = json.loads((planned["jaco"] / "plan.json").read_text())["q"][0]   # a plan that succeeded
    assert main(argv + ["--start-joints", *map(str, good), "--force"]) == 0
    written = {path.name: path.read_bytes() for path in out.iterdir()}
    assert len([name for name in written if name.startswith("trajectory")]) == 2
    assert main(argv + ["--start", "5", "5", "5", "--force"]) == 2
    assert {path.name: path.read_bytes() for path in out.iterdir()} == written


def test_no_retime_writes_the_plans_own_timing(planned, tmp_path):
    demos = planned["jaco"].parent / "demos.npz"
    start = json.loads((planned["jaco"] / "plan.json").read_text())["ee_path"][0]
    out = tmp_path / "out"
    assert main(["plan", "--robot", "jaco", "--demos", str(demos), "--num-points", "40", "--no-retime",
                 "--start", *map(str, start), "--out", str(out), "-q"]) == 0
    plan = json.loads((out / "plan.json").read_text())
    trajectory = JointTrajectory.load(out / "trajectory_result.json")
    np.testing.assert_array_equal(trajectory.positions, plan["q"])
    np.testing.assert_allclose(trajectory.time_from_start, np.array(plan["time"]) - plan["time"][0])
    assert plan["trajectory"]["retimed"] is False and plan["trajectory"]["acceleration_limits"] is None


@pytest.mark.parametrize("extra, word", [
    (["--acc-limit", "0"], "--acc-limit"),
    (["--acc-limit", "1", "2"], "--acc-limit"),
    (["--acc-limit", "1", "--no-retime"], "--no-retime"),
])
def test_bad_trajectory_options_exit_2_and_leave_no_folder(planned, tmp_path, capsys, extra, word):
    demos = planned["jaco"].parent / "demos.npz"
    out = tmp_path / "new" / "out"
    assert main(["plan", "--robot", "jaco", "--demos", str(demos), "--start", "0.2", "-0.47", "0.27",
                 "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0]
    assert not (tmp_path / "new").exists()
