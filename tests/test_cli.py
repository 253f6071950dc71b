"""The ``clamp`` command line: demo and plan write figures and JSON plans; bad input exits 2."""
from __future__ import annotations

import json

import numpy as np
import pytest

from clamp.cli import main


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
    assert (tmp_path / "out" / "plan_result.png").is_file()
    assert "plan" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["plan", "--demos", "missing.npz", "--robot", "jaco", "--start", "0.3", "0", "0.2"], "missing"),
    (["demo", "--robot", "nonexistent_robot"], "jaco"),
    (["demo", "--skill", "no_such_skill"], "box_closing"),
])
def test_bad_input_exits_with_message(tmp_path, capsys, argv, message):
    assert main(argv + ["--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err
