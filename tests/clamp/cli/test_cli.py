"""The ``clamp`` command line: demo and plan write figures and JSON plans; bad input exits 2."""
from __future__ import annotations

import json

import numpy as np
import pytest

from clamp.cli.commands import main


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    code = main(["demo", "--out", str(out), "--num-points", "60", "--max-iterations", "200"])
    return out, code


def test_demo_writes_figures_and_plans(demo_out, capsys):
    out, code = demo_out
    for name in ("prior_3d.png", "prior_time.png", "plan_empty.png", "plan_obstacle.png",
                 "plan_empty.json", "plan_obstacle.json", "scene_obstacle.json"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    plan = json.loads((out / "plan_obstacle.json").read_text())
    q = np.array(plan["q"])
    assert q.shape == (60, 6)
    assert np.array(plan["ee_path"]).shape == (60, 3)
    assert plan["robot"] == "jaco" and "min_clearance" in plan and "reasons" in plan
    empty = json.loads((out / "plan_empty.json").read_text())
    assert empty["success"] and empty["min_clearance"] is None  # +inf without obstacles
    assert code in (0, 1)


def test_plan_from_user_files(tmp_path, capsys):
    from scenes import Box, Scene, make_demonstrations
    demos = make_demonstrations("box_closing", num_points=60, seed=1)
    demos.save_npz(tmp_path / "demos.npz")
    start = demos.positions[:, 0].mean(axis=0)
    Scene([Box([0.9, 0.9, 0.5], [0.05, 0.05, 0.05])]).save(tmp_path / "scene.json")
    code = main(["plan", "--demos", str(tmp_path / "demos.npz"), "--robot", "jaco",
                 "--start", *map(str, start), "--scene", str(tmp_path / "scene.json"),
                 "--out", str(tmp_path / "out")])
    assert code == 0
    plan = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert plan["success"]
    assert np.linalg.norm(np.array(plan["ee_path"][0]) - start) <= 1e-3
    assert not list((tmp_path / "out").glob("*.png")) and not list((tmp_path / "out").glob("*.html"))
    assert f"wrote plan to {tmp_path / 'out'}" in capsys.readouterr().out    # figures only when asked


@pytest.mark.parametrize("argv, message", [
    (["plan", "--demos", "missing.npz", "--robot", "jaco", "--start", "0.3", "0", "0.2"], "missing"),
    (["demo", "--robot", "nonexistent_robot"], "jaco"),
    (["demo", "--skill", "no_such_skill"], "box_closing"),
])
def test_bad_input_exits_with_message(tmp_path, capsys, argv, message):
    assert main(argv + ["--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


def _user_files(tmp_path, num_points=40):
    from scenes import make_demonstrations
    demos = make_demonstrations("box_closing", num_points=num_points, seed=1)
    demos.save_npz(tmp_path / "demos.npz")
    return tmp_path / "demos.npz", demos.positions[:, 0].mean(axis=0)


def test_plan_on_an_unregistered_urdf_arm(tmp_path, capsys):
    """UR5 from example-robot-data (not registered): the plan starts where asked, stays in
    the URDF's limits (read independently by Pinocchio) and exports the UR5's joint names."""
    import pinocchio as pin

    from robots.registry import example_robot_data_share
    from scenes import Box, Scene
    share = example_robot_data_share()
    urdf = share / "example-robot-data/robots/ur_description/urdf/ur5_joint_limited_robot.urdf"
    demos, start = _user_files(tmp_path)
    Scene([Box([0.6, 0.3, 0.2], [0.1, 0.1, 0.1])]).save(tmp_path / "scene.json")
    out = tmp_path / "out"
    code = main(["plan", "--urdf", str(urdf), "--end-effector", "tool0", "--package-dir", str(share),
                 "--demos", str(demos), "--start", *map(str, start), "--scene",
                 str(tmp_path / "scene.json"), "--out", str(out), "-q", "--figures"])
    assert code == 0
    assert capsys.readouterr().out == ""  # -q: no summary
    trajectory = json.loads((out / "trajectory_result.json").read_text())
    model = pin.buildModelFromUrdf(str(urdf))
    names = [model.names[j] for j in range(1, model.njoints)]
    assert trajectory["joint_names"] == names
    q = np.array(json.loads((out / "plan.json").read_text())["q"])
    assert np.all(q >= model.lowerPositionLimit - 1e-4) and np.all(q <= model.upperPositionLimit + 1e-4)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q[0])
    np.testing.assert_allclose(data.oMf[model.getFrameId("tool0")].translation, start, atol=1e-3)
    for name in ("plan_result_top.png", "plan_result_joints.png", "plan_result_clearance.png",
                 "animation_result.html"):
        assert (out / name).stat().st_size > 0, name


def test_start_inside_an_obstacle_is_refused_and_outputs_need_force(tmp_path, capsys):
    """A start inside a box cannot even be planned: exit 2, one line naming --start, no output
    folder; a non-empty --out needs --force, and its files are untouched without it."""
    from scenes import Box, Scene
    demos, start = _user_files(tmp_path)
    Scene([Box(start, [0.2, 0.2, 0.2])]).save(tmp_path / "scene.json")  # start inside a box
    argv = ["plan", "--robot", "jaco", "--demos", str(demos), "--start", *map(str, start),
            "--scene", str(tmp_path / "scene.json"), "--out", str(tmp_path / "out")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--start:" in err[0] and "inside an obstacle" in err[0], err
    assert not (tmp_path / "out").exists()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "mine.txt").write_text("keep me")
    assert main(argv) == 2  # the folder is not empty
    assert "--force" in capsys.readouterr().err
    assert main(argv + ["--force"]) == 2
    assert (tmp_path / "out" / "mine.txt").read_text() == "keep me"
    assert not list((tmp_path / "out").glob(".*.tmp"))
