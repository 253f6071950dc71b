"""The examples/ scripts run (exactly the commands the README lists) and do what they say; the
file-format examples of docs/file_formats.md load with the project's own readers."""
from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
FILE_FORMATS = (ROOT / "docs" / "file_formats.md").read_text(encoding="utf-8")


def readme_commands() -> list[str]:
    """The commands of the README's "## Examples" bash block (comments stripped)."""
    section = README.split("## Examples", 1)[1]
    block = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    return [line.split("#", 1)[0].strip() for line in block.splitlines() if line.strip()]


def test_readme_lists_every_example():
    scripts = {shlex.split(c)[1] for c in readme_commands()}
    assert scripts == {f"examples/{p.name}" for p in (ROOT / "examples").glob("*.py")}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{script name: CompletedProcess} of every README command, run from the repository root
    (two at a time; temporary files under a pytest folder)."""
    tmp = tmp_path_factory.mktemp("examples")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", TMPDIR=str(tmp))

    def one(command: str):
        argv = shlex.split(command)
        assert argv[0] == "python"
        return Path(argv[1]).stem, subprocess.run([sys.executable, *argv[1:]], cwd=ROOT, env=env,
                                                  capture_output=True, text=True, timeout=600)
    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(pool.map(one, readme_commands()))


@pytest.mark.parametrize("name", [Path(shlex.split(c)[1]).stem for c in readme_commands()])
def test_example_runs(runs, name):
    done = runs[name]
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr


def test_learn_and_plan_and_own_urdf_succeed(runs):
    assert runs["learn_and_plan"].stdout.startswith("success True")
    out = runs["your_own_urdf"].stdout
    assert "ur5: 6 joints" in out and "success True" in out


def test_tlgc_reproductions_stay_inside(runs):
    assert "points inside the cylinder 100.0 %" in runs["tlgc_reproduce"].stdout


def test_boundary_factor_keeps_more_states_inside(runs):
    fractions = [float(f) for f in re.findall(r"([\d.]+) % of states inside", runs["boundary_factor"].stdout)]
    assert len(fractions) == 2 and fractions[1] > fractions[0] + 20


def test_export_and_retime_within_limits_on_both_arms(runs):
    """box_closing + box on the Jaco and the Sawyer: every retimed sample within the velocity
    limits (URDF) and 1.5 rad/s^2, the end effector within 1 mm of the planned path (both
    measured here, independently of the retiming report)."""
    from robots import JointTrajectory, load_robot
    from robots.retiming import toppra_available
    from robots.trajectory import finite_difference
    from tests.robots.test_retiming import ee_distance_to_path
    folder = Path(re.search(r"wrote (.*)", runs["export_and_retime"].stdout).group(1).strip())
    for name in ("jaco", "sawyer"):
        robot = load_robot(name)
        planned = JointTrajectory.load(folder / f"{name}_plan.json")
        retimed = JointTrajectory.load(folder / f"{name}_retimed.json")
        assert np.array_equal(JointTrajectory.load(folder / f"{name}_retimed.csv").positions, retimed.positions)
        t = retimed.time_from_start
        assert np.all(np.abs(retimed.velocities) <= robot.velocity_limits * (1 + 1e-6))
        assert np.all(np.abs(np.diff(retimed.positions, axis=0)) / np.diff(t)[:, None]
                      <= robot.velocity_limits * (1 + 1e-6))
        assert np.all(np.abs(finite_difference(retimed.velocities, t)) <= 1.5 * (1 + 1e-6))
        assert ee_distance_to_path(robot, planned, retimed) <= 1e-3
        assert retimed.verdict["success"] and retimed.verdict["retiming"]["within_limits"]
        if toppra_available():                          # no fall-back to uniform scaling
            assert retimed.verdict["retiming"]["method"] == "toppra", name


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", FILE_FORMATS, re.S)


def test_readme_file_formats_load(tmp_path):
    from clamp.planning.result import PlanResult
    from robots import JointTrajectory
    from robots.trajectory import load_schema
    from scenes import Scene, load_demonstrations
    from clamp.batch.problems import Problem
    scene_text, problem_text, plan_text, trajectory_text, ros2_text = _blocks("json")
    goal = Problem.from_json(" ".join(problem_text.split())).to_dict()["goal"]
    assert set(goal) == {"position", "quaternion"} and len(goal["quaternion"]) == 4
    (tmp_path / "scene.json").write_text(scene_text)
    scene = Scene.load(tmp_path / "scene.json")
    assert [o.kind for o in scene.obstacles] == ["box", "box", "sphere", "cylinder"]
    (tmp_path / "demos.csv").write_text(_blocks("csv")[0])
    demos = load_demonstrations(tmp_path / "demos.csv")
    assert (demos.M, demos.T) == (3, 5)
    (tmp_path / "poses.csv").write_text(_blocks("csv")[1])
    poses = load_demonstrations(tmp_path / "poses.csv")
    assert poses.orientations.shape == (2, 3, 4)
    np.testing.assert_allclose(np.abs(poses.orientations[:, -1, 1]), np.sqrt(0.5), atol=1e-6)
    plan = json.loads(plan_text)
    # every field but those to_dict leaves out (the joint covariance, the request's objects,
    # the problem solved)
    assert (set(PlanResult.__dataclass_fields__) - {"state_covariance", "inputs", "problem"}
            <= set(plan))
    assert np.array(plan["q"]).shape == (5, 6) and plan["success"]
    assert len(plan["scene"]["obstacles"]) == len(scene.obstacles)
    data = json.loads(trajectory_text)
    jsonschema = pytest.importorskip("jsonschema", reason="schema validation needs jsonschema (test extra)")
    jsonschema.validate(data, load_schema())
    trajectory = JointTrajectory.from_dict(data)
    np.testing.assert_allclose(trajectory.positions, plan["q"])
    message = json.loads(ros2_text)
    jsonschema.validate(message, load_schema(ros2=True))
    ros2 = JointTrajectory.from_ros2_dict(message)
    assert ros2.joint_names == trajectory.joint_names and ros2.duration == pytest.approx(3.700537168)
    assert not np.any(ros2.velocities[[0, -1]]) and not np.any(ros2.accelerations[[0, -1]])
