"""The contract for "no", through the real command line (a subprocess, as a user runs it):
a request the planner cannot even start, or a file it cannot use, is one line on stderr naming
the flag the user typed, what was expected and what was given, exit 2, no traceback and no
output folder left behind; a plan that was made and failed its verdict is exit 1 with its
first reason on stderr, even under -q. Each case is small (T = 20 states)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
START = ["--start", "0.2054", "-0.4722", "0.2625"]


def clamp(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "clamp", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    from scenes import Demonstrations, make_demonstrations
    folder = tmp_path_factory.mktemp("contract")
    demos = make_demonstrations("box_closing", num_points=20, seed=1)
    demos.save_npz(folder / "demos.npz")
    Demonstrations(demos.positions * 1000.0, demos.velocities * 1000.0, demos.time,
                   name="millimetres").save_npz(folder / "demos_mm.npz")
    rows = ["demo,t,x,y"] + [f"{m},{t},{p[0]},{p[1]}" for m in range(demos.M)
                             for t, p in zip(demos.time, demos.positions[m])]
    (folder / "no_z.csv").write_text("\n".join(rows) + "\n")
    (folder / "typo.json").write_text(json.dumps(
        {"obstacles": [{"type": "box", "center": [0.3, -0.3, 0.1], "sise": [0.1, 0.1, 0.1]}]}))
    return folder


def refused(result: subprocess.CompletedProcess, work: Path, flag: str, *words: str,
            command: str = "plan") -> str:
    """Exit 2, one line on stderr (of ``clamp COMMAND``) naming ``flag`` and ``words``, no
    traceback, nothing on stdout, no output folder."""
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, (result.returncode, result.stderr)
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert lines[0].startswith(f"clamp {command}: error: "), lines[0]
    for word in (flag, *words):
        assert word in lines[0], (word, lines[0])
    assert result.stdout == ""
    assert not (work / "out").exists()
    return lines[0]


def test_start_out_of_reach(work):
    result = clamp(["plan", "--robot", "jaco", "--demos", "demos.npz", "--start", "2.0", "0", "0.3",
                    "--out", "out", "-q"], work)
    line = refused(result, work, "--start:", "out of reach", "[2.0, 0.0, 0.3]", "expected")
    assert "IK error" in line


def test_start_joints_in_degrees(work):
    result = clamp(["plan", "--robot", "jaco", "--demos", "demos.npz",
                    "--start-joints", "275", "150", "90", "0", "45", "10", "--out", "out"], work)
    refused(result, work, "--start-joints:", "look like degrees: radians expected", "275.0")


def test_unknown_key_in_a_scene_file_names_the_nearest(work):
    result = clamp(["plan", "--robot", "jaco", "--demos", "demos.npz", *START, "--scene", "typo.json",
                    "--out", "out"], work)
    refused(result, work, "--scene:", "typo.json", "'sise' (did you mean 'size'?)")


def test_position_csv_missing_z_says_the_position_header(work):
    result = clamp(["plan", "--robot", "jaco", "--demos", "no_z.csv", *START, "--out", "out"], work)
    refused(result, work, "--demos:", "no_z.csv", "expected header demo,t,x,y,z", "missing z")


def test_missing_urdf_names_the_flag(work):
    result = clamp(["plan", "--urdf", "missing.urdf", "--end-effector", "tool0", "--demos", "demos.npz",
                    *START, "--out", "out"], work)
    refused(result, work, "--urdf:", "missing.urdf", "does not exist")


def test_a_millimetre_prior_names_demos_and_the_unit(work):
    result = clamp(["plan", "--robot", "jaco", "--demos", "demos_mm.npz", *START, "--out", "out"], work)
    refused(result, work, "--demos:", "millimetres", "divide by 1000")


def test_a_plan_failing_its_verdict_under_quiet_says_why_on_stderr(work):
    """A goal 15 mm above a slab the hand cannot keep 20 mm from (--min-clearance 0.02): the
    plan is made, fails its verdict; exit 1, its first reason on stderr under -q, no
    trajectory written."""
    from clamp import learn_prior
    from scenes import Box, Scene, load_demonstrations
    goal = learn_prior(load_demonstrations(work / "demos.npz")).mean[-1, :3]
    Scene([Box(goal - np.array([0.0, 0.0, 0.025]), [0.4, 0.4, 0.02])]).save(work / "slab.json")
    result = clamp(["plan", "--robot", "jaco", "--demos", "demos.npz", *START, "--goal", *map(str, goal),
                    "--scene", "slab.json", "--min-clearance", "0.02", "--out", "failed", "-q"], work)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 1, (result.returncode, result.stderr)
    assert result.stdout == "" and "Traceback" not in result.stderr
    assert len(lines) == 1 and lines[0].startswith("clamp plan: plan 'demos' failed: "), lines
    record = json.loads((work / "failed" / "plan.json").read_text())
    assert not record["success"] and lines[0].endswith(record["reasons"][0])
    assert not list((work / "failed").glob("trajectory_*"))


def test_joint_demonstrations_in_degrees(work, jaco):
    """A joint-space CSV recorded in degrees: radians expected, naming --demos and the file."""
    from scenes import load_demonstrations
    q = jaco.ik_trajectory(load_demonstrations(work / "demos.npz").positions[0], seed=jaco.ik(
        load_demonstrations(work / "demos.npz").positions[0, 0]).q).q
    rows = ["demo,t," + ",".join(jaco.joint_names)]
    for m in range(2):
        rows += [f"{m},{0.1 * k}," + ",".join(f"{v:.6f}" for v in np.degrees(row)) for k, row in enumerate(q)]
    (work / "degrees.csv").write_text("\n".join(rows) + "\n")
    result = clamp(["plan", "--robot", "jaco", "--demos", "degrees.csv", *START, "--out", "out"], work)
    refused(result, work, "--demos:", "degrees.csv", "look like degrees: radians expected")


@pytest.mark.parametrize("args, flag, words", [
    (["--skill", "box_closin"], "--skill:", ["'box_closin'", "box_closing"]),
    (["--num-points", "3"], "--num-points", ["expected an integer >= 4", "3"]),
    (["--epsilon", "-0.01"], "--epsilon:", ["expected a number >= 0", "-0.01"]),
    (["--min-clearance", "-1"], "--min-clearance:", [">= 0"]),
    (["--robot", "nao"], "--robot:", ["'nao'", "jaco"]),
    (["--urdf", "missing.urdf", "--end-effector", "tool"], "--urdf:", ["missing.urdf"]),
    (["--acc-limit", "-2"], "--acc-limit:", ["positive", "-2.0"]),
    (["--out", "typo.json"], "--out:", ["typo.json", "folder"]),
])
def test_demo_refuses_bad_input_before_any_output(work, args, flag, words):
    result = clamp(["demo", *args] + ([] if "--out" in args else ["--out", "out"]), work)
    refused(result, work, flag, *words, command="demo")


def test_demo_leaves_a_folder_of_the_users_files_alone(work):
    folder = work / "mine"
    folder.mkdir(exist_ok=True)
    (folder / "notes.txt").write_text("the user's")
    result = clamp(["demo", "--out", "mine", "-q"], work)
    refused(result, work, "--out:", "'mine'", "not empty", "--force", command="demo")
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]


def test_clock_is_for_the_figures(work):
    result = clamp(["plan", "--robot", "jaco", "--demos", "demos.npz", *START, "--clock", "skill",
                    "--out", "out"], work)
    refused(result, work, "--clock:", "only with --figures", "clamp show")
