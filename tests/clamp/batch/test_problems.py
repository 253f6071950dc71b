"""Planning problems as plain data (clamp.batch.problems), their generators (clamp.batch.problem_sets) and
the batch summary (clamp.batch.report)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bad_input import raises_naming
from clamp.batch.runner import load_prior
from clamp.batch.report import reason_key, summarize
from clamp.errors import InvalidParameterError
from clamp.batch.problem_sets import (CLEAR_POSITION, across_robots, scene_benchmark, start_problems,
                                start_region)
from clamp.batch.problems import Problem, ProblemFormatError, make_problem, read_problems, write_problems
from scenes import Box, Cylinder, Scene, Sphere

SHORT = {"skill": "box_closing", "seed": 0, "num_demos": 6, "num_points": 40}


def _full_problem() -> Problem:
    scene = Scene([Box([0.3, -0.4, 0.2], [0.05, 0.06, 0.07]), Sphere([0.1, -0.5, 0.3], 0.031),
                   Cylinder([0.2, -0.3, 0.1], 0.02, 0.1, [0.0, 1.0, 1.0])])
    return make_problem("p/1", {"path": "priors/box.npz"},
                        {"urdf": "arm.urdf", "end_effector": "tool0", "base_frame": "base"},
                        np.array([0.1, 0.2, 1 / 3]), scene=scene, goal=[0.4, -0.3, 0.1 + 1e-17],
                        via_points=[(10, [0.3, -0.4, 0.3])],
                        config={"sigma_obs": 0.005, "optimizer": "gtsam"},
                        expected="feasible", meta={"note": "x", "k": [1, 2]})


def test_json_round_trip_is_exact_and_hash_stable():
    problem = _full_problem()
    text = problem.to_json()
    again = Problem.from_json(text)
    assert again == problem and again.to_json() == text and again.hash == problem.hash
    assert again.start[2] == 1 / 3                                  # floats survive exactly
    # key order of the JSON object does not change the problem or its hash
    data = json.loads(text)
    shuffled = Problem.from_dict(dict(reversed(list(data.items()))))
    assert shuffled.hash == problem.hash
    # every field enters the hash
    changed = [problem.replace(start=[0.1, 0.2, 0.3334]), problem.replace(id="p/2"),
               problem.replace(config={"sigma_obs": 0.01}), problem.replace(scene=None),
               problem.replace(expected="impossible"), problem.replace(robot="jaco")]
    assert len({p.hash for p in changed} | {problem.hash}) == len(changed) + 1
    # the string shorthand of a built-in robot is the same problem as its object form
    assert problem.replace(robot="jaco").hash == problem.replace(robot={"name": "jaco"}).hash


def test_structure_errors_name_the_field(tmp_path):
    good = _full_problem().to_dict()
    for change, words in [({"start": "x"}, "start"), ({"robot": {"urdf": "a.urdf"}}, "robot"),
                          ({"prior": {"skill": "a", "path": "b"}}, "prior"),
                          ({"expected": "maybe"}, "expected"), ({"colour": 1}, "colour"),
                          ({"via_points": [[1.5, [0, 0, 0]]]}, "via_points")]:
        with raises_naming(ProblemFormatError, words):
            Problem.from_dict({**good, **change})
    with raises_naming(ProblemFormatError, "start"):
        Problem.from_dict({k: v for k, v in good.items() if k != "start"})
    path = tmp_path / "problems.jsonl"
    with raises_naming(ProblemFormatError, "problems[1]", "p/1"):
        write_problems([_full_problem(), _full_problem()], path)     # never written
    assert not path.exists()
    path.write_text(2 * (_full_problem().to_json() + "\n"))
    with raises_naming(ProblemFormatError, "problems[1]", "p/1"):
        read_problems(path)
    path.write_text(_full_problem().to_json() + "\n{not json\n")
    with raises_naming(ProblemFormatError, "problems.jsonl:2"):
        read_problems(path)


def test_file_round_trip(tmp_path):
    problems = [_full_problem().replace(id=f"p{k}", start=[0.1 * k, 0.2, 0.3]) for k in range(5)]
    path = write_problems(problems, tmp_path / "problems.jsonl")
    assert read_problems(path) == problems
    before = path.read_bytes()
    with raises_naming(ProblemFormatError, "problems.jsonl"):
        write_problems(problems[:2], path)
    assert path.read_bytes() == before                         # the user's file untouched
    with raises_naming(ProblemFormatError, "no folder"):
        write_problems(problems, tmp_path / "no folder" / "problems.jsonl")
    write_problems(problems[:2], path, overwrite=True)
    assert read_problems(path) == problems[:2]
    assert [f.name for f in tmp_path.iterdir()] == ["problems.jsonl"]   # no temporary left


def test_start_problems_cover_the_start_region():
    base = make_problem("base", SHORT, "jaco", [0.2, -0.47, 0.26])
    prior = load_prior(SHORT, Path("."))
    low, high = start_region(prior)
    centre, std = prior.mean[0, :3], np.sqrt(np.diag(prior.cov0)[:3])
    np.testing.assert_allclose((high - low) / 2, np.maximum(2 * std, 0.01))
    np.testing.assert_allclose((high + low) / 2, centre)
    sample = start_problems(base, 200, seed=3)
    starts = np.array([p.start for p in sample])
    assert np.all(starts >= low) and np.all(starts <= high)
    assert np.all(starts.min(0) < low + 0.1 * (high - low))       # the sample spreads over it
    assert [p.hash for p in start_problems(base, 200, seed=3)] == [p.hash for p in sample]
    grid = np.array([p.start for p in start_problems(base, grid=3)])
    assert len(np.unique(grid, axis=0)) == 27
    np.testing.assert_allclose(grid.min(0), low)
    np.testing.assert_allclose(grid.max(0), high)
    with raises_naming(InvalidParameterError, "count", "grid"):
        start_problems(base, 5, grid=2)


def test_across_robots():
    base = make_problem("base", SHORT, "jaco", [0.2, -0.47, 0.26], goal=[0.44, -0.27, 0.14])
    problems = across_robots(base, ["jaco", "sawyer"])
    assert [p.id for p in problems] == ["base/jaco", "base/sawyer"]
    assert problems[1].robot == Problem.from_dict({**base.to_dict(), "robot": "sawyer"}).robot
    assert problems[1].start == base.start and problems[1].goal == base.goal
    joint = base.replace(start=[0.0] * 6)
    with raises_naming(InvalidParameterError, "start"):
        across_robots(joint, ["sawyer"])


def test_scene_benchmark_labels_and_obstacles():
    problems = scene_benchmark(20, "jaco", seed=5, num_points=40, impossible_share=0.25)
    assert [p.hash for p in scene_benchmark(20, "jaco", seed=5, num_points=40,
                                            impossible_share=0.25)] == [p.hash for p in problems]
    impossible = [p for p in problems if p.expected == "impossible"]
    assert len(impossible) == 5
    assert {p.to_dict()["meta"]["impossible"] for p in impossible} == {"start", "goal"}
    for p in problems:
        scene = Scene.from_dict(p.scene_data())
        start, goal = np.array(p.start), np.array(p.goal)
        if p.expected == "impossible":
            inside = start if p.to_dict()["meta"]["impossible"] == "start" else goal
            assert scene.distance(inside) < -0.01                 # covered by at least 1 cm
        else:
            assert scene.distance(np.stack([start, goal])).min() >= CLEAR_POSITION
            assert 1 <= len(scene.obstacles) <= 3
            prior = load_prior(p.to_dict()["prior"], Path("."))
            # every obstacle is near the skill's mean path
            path = np.asarray(prior.mean)[:, :3]
            assert all(np.min(ob.distance(path)) < 0.08 for ob in scene.obstacles)


def test_summary_groups_reasons():
    records = [{"status": "done", "success": True, "reasons": [], "timings": {"total": 0.1},
                "expected": "feasible"},
               {"status": "done", "success": False, "expected": "feasible",
                "reasons": ["collision: minimum clearance -9.1 mm"], "timings": {"total": 0.3}},
               {"status": "done", "success": False, "expected": "impossible",
                "reasons": ["collision: minimum clearance -1.0 mm",
                            "start configuration is in collision (clearance -3.0 mm)"],
                "timings": {"total": 0.2}},
               {"status": "error", "success": False, "reasons": [], "timings": {},
                "error": {"type": "UnknownRobotError", "message": "..."}},
               {"status": "lost", "success": False, "reasons": [], "timings": {}}]
    summary = summarize(records)
    assert summary["success"] == 1 and summary["problems"] == 5
    assert summary["feasible"] == 2 and summary["feasible_success"] == 1
    assert summary["impossible_failed"] == 1
    assert summary["reasons"] == {"collision: minimum clearance # mm": 2,
                                  "start configuration is in collision": 1,
                                  "error: UnknownRobotError": 1, "lost (worker died)": 1}
    assert summary["median_s"] == pytest.approx(0.2)
    assert reason_key("goal error 0.03739 exceeds 0.02") == "goal error # exceeds #"


def test_a_saved_problem_naming_a_removed_setting_is_refused(tmp_path):
    """A problem file written before issue 36 (its config naming a setting that is now a
    constant or part of the stopping rule) is read, and planning it is refused with the
    setting and its replacement named, not planned with the value silently ignored."""
    from clamp.batch.runner import resolve
    old = make_problem("old/1", SHORT, {"name": "jaco"}, [0.2, -0.45, 0.25],
                       config={"relative_error_tol": 0.05, "sigma_obs": 0.005})
    [read] = read_problems(write_problems([old], tmp_path / "old.jsonl"))
    assert read.config_changes() == {"relative_error_tol": 0.05, "sigma_obs": 0.005}
    with raises_naming(InvalidParameterError, "relative_error_tol", "stopping"):
        resolve(read, tmp_path)


def test_a_saved_problem_gives_its_stopping_rule_as_fields(tmp_path):
    """What replaces the old tolerances in a file: ``stopping`` as a name or as the rule's
    fields (the others the default rule's)."""
    from clamp import PlannerConfig
    from clamp.batch.runner import resolve
    problems = [make_problem(f"new/{k}", SHORT, {"name": "jaco"}, [0.2, -0.45, 0.25],
                             config={"stopping": stopping})
                for k, stopping in enumerate(("fast", {"relative_tol": 0.05, "patience": 1}))]
    fast = PlannerConfig.fast().optimizer.stopping_rule()
    for problem in read_problems(write_problems(problems, tmp_path / "new.jsonl")):
        assert resolve(problem, tmp_path)["config"].optimizer.stopping_rule() == fast


def test_a_goal_pose_reads_writes_and_hashes_as_a_pose():
    """A goal pose {"position", "quaternion"} round-trips exactly, from make_problem's pair
    (position, quaternion) as clamp.plan takes it; a wrong count names the field; a goal
    position keeps its list form."""
    pair = (np.array([0.4, -0.3, 0.2]), np.array([0.0, 0.0, 0.6, 0.8]))
    problem = make_problem("pose", SHORT, "jaco", [0.1, 0.2, 0.3], goal=pair)
    assert problem.to_dict()["goal"] == {"position": [0.4, -0.3, 0.2], "quaternion": [0.0, 0.0, 0.6, 0.8]}
    again = Problem.from_json(problem.to_json())
    assert again == problem and again.hash == problem.hash
    position = make_problem("pose", SHORT, "jaco", [0.1, 0.2, 0.3], goal=pair[0])
    assert position.to_dict()["goal"] == [0.4, -0.3, 0.2] and position.hash != problem.hash
    with raises_naming(ProblemFormatError, "goal.quaternion", "expected 4 numbers", "got 3"):
        problem.replace(goal={"position": [0.4, -0.3, 0.2], "quaternion": [0.0, 0.6, 0.8]})
    with raises_naming(ProblemFormatError, "goal", "position", "quaternion", "['position']"):
        problem.replace(goal={"position": [0.4, -0.3, 0.2]})
