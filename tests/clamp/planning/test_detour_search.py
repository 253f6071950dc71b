"""Issue 27: the planner searches where the skill is blocked (clamp.planning.detours,
clamp.planning.pipeline._restarts) within a budget (ConstraintConfig.search_budget, detours).

- the detours (geometry alone): around an obstacle on a straight path, over / left / right /
  under, two heights each, every one past the obstacle's face by the clearance where the path
  met it, the start unmoved; ranked in the workspace, a detour whose hand point stays clear and
  inside the skill's tube first;
- a blocked skill (hard-family problem 22 on the Jaco: pick_place, three boxes on its path;
  the untied restart ends 9.6 demonstration spreads from the skill) is found by a detour,
  measured independently: coal distances of the URDF geometry to the boxes, the joint limits;
- the budget bounds the search: with no time left past the first restart no detour is solved
  (and the plan fails), with ``detours`` = 1 at most one;
- a plan a hair short (handwriting WShape / 5) is polished until it passes, its margins held.
"""
from __future__ import annotations

import numpy as np
import pytest

from clamp import PlannerConfig, learn_prior, plan
from clamp.planning.detours import (DIRECTIONS, SECOND_HEIGHT, blocking_obstacles,
                                    detour_search, detours_around)
from clamp.prior.skill import TUBE_RATIO
from robots import load_robot
from robots.collision_check import CollisionChecker
from scenes import Box, Scene, make_demonstrations
from scenes.coal_shapes import coal_obstacles

# benchmarks/hard_problems.py, hard_problems(23, "jaco", 0)[22]
BOXES = [([0.332065332131458, -0.3565806955768545, 0.2871123118965735],
          [0.10619302803836705, 0.06199799913282885, 0.04592937657548462]),
         ([0.2131844357076972, -0.4480538710212683, 0.2132108518058037],
          [0.10499394413478849, 0.11479262130598988, 0.06817316281536281]),
         ([0.21019944893679438, -0.4807338357342546, 0.10897361054038217],
          [0.05742282594115919, 0.041002095454671914, 0.05631463493533175])]
START = [0.2388330349227913, -0.6236308175716141, 0.39022671321091745]


def test_detours_go_around_the_obstacle_on_the_path():
    T = 101
    path = np.stack([np.linspace(0.0, 0.6, T), np.zeros(T), np.full(T, 0.3)], axis=1)
    box = Box([0.3, 0.0, 0.3], [0.08, 0.06, 0.1])
    tube = np.full(T, 0.02)
    assert [k for k, _ in blocking_obstacles([box], path, tube, 0.04)] == [0]
    assert blocking_obstacles([Box([0.3, 0.5, 0.3], [0.05, 0.05, 0.05])], path, tube, 0.04) == []
    detours = detours_around(path, box, 0.04, 0.09)
    assert len(detours) == 2 * len(DIRECTIONS)
    inside = np.flatnonzero(box.distance(path) < 0.0)
    for name, detour in detours:
        assert name.split("-")[0] in DIRECTIONS
        np.testing.assert_array_equal(detour[0], path[0])
        assert np.min(box.distance(detour[inside])) >= 0.04 - 1e-9, name
    heights = {name: float(np.max(np.linalg.norm(d - path, axis=1))) for name, d in detours}
    assert heights["over-9"] == pytest.approx(0.05 + 0.04)           # half the box + clearance
    assert heights["left-7"] == pytest.approx(0.03 + 0.04)
    assert heights["over-14"] == pytest.approx(0.09 + SECOND_HEIGHT)
    # ranked: a wide tube lets the least detour come first (the narrowest side: left / right);
    # every way around once (by score) before any second height (by score)
    ranked = detour_search(path, [box], path, np.full(T, 0.2), 0.04, np.zeros(3), 2.0)
    assert len(ranked) == 8 and ranked[0][0].split("-")[0] in ("left", "right")
    ways = [c[0].split("-")[0] for c in ranked]
    assert sorted(ways[:4]) == sorted(DIRECTIONS) and sorted(ways[4:]) == sorted(DIRECTIONS)
    for half in (ranked[:4], ranked[4:]):
        assert [c[2] for c in half] == sorted(c[2] for c in half)
    for way in DIRECTIONS:                     # a way's first height scores best of its two
        first, second = (c[2] for c in ranked if c[0].startswith(way))
        assert first <= second


@pytest.fixture(scope="module")
def blocked():
    prior = learn_prior(make_demonstrations("pick_place", num_demos=6, num_points=250, seed=0))
    return prior, load_robot("jaco"), Scene([Box(c, s) for c, s in BOXES])


def candidates(result) -> list[str]:
    return list(dict.fromkeys(a["candidate"] for a in result.attempts))


def test_a_blocked_skill_is_found_by_a_detour(blocked):
    prior, robot, scene = blocked
    result = plan(prior, robot, scene, START, covariance=False,
                  config=PlannerConfig(search_budget=None))
    assert result.success, result.reasons
    chosen = next(a["candidate"] for a in reversed(result.attempts) if a["feasible"])
    assert chosen.startswith("detour_"), candidates(result)
    # independently: coal distances of the URDF geometry, the limits, the tube
    report = CollisionChecker(robot, coal_obstacles(scene.obstacles)).check(result.q)
    assert not report.collision and report.min_distance > 0.0
    assert np.all(robot.within_limits(result.q, tolerance=0.0))
    assert np.all(np.abs(result.qdot) <= np.asarray(robot.velocity_limits))
    assert result.skill["max_tube_ratio"] <= TUBE_RATIO


def test_the_budget_bounds_the_search(blocked):
    prior, robot, scene = blocked
    spent = plan(prior, robot, scene, START, covariance=False,
                 config=PlannerConfig(search_budget=0.0))
    searched = [name for name in candidates(spent) if "+" not in name]
    assert searched == ["configured", "untied"]               # the first restart always runs
    # none passed: the closest starts continued after the search ("+resumed", then "+wide",
    # the obstacles' safety distance widened), and here the wide one passes
    assert all(name.split("+")[0] in searched for name in candidates(spent))
    assert spent.success, spent.reasons
    assert next(a["candidate"] for a in spent.attempts if a["feasible"]).endswith("+wide")
    assert_passes_on_its_own(robot, scene, spent)
    one = plan(prior, robot, scene, START, covariance=False,
               config=PlannerConfig(search_budget=None, detours=1))
    assert sum(name.startswith("detour_") for name in candidates(one)) <= 1
    with pytest.raises(Exception, match="search_budget"):
        PlannerConfig(search_budget=-1.0)


# ------------------------------------------------------------------ a hair short (item 1)
LASA_FILE = "lasa_handwriting_dev.npz"


def lasa_problem(shape: str, held: int):
    """benchmarks/hard_problems.py's handwriting problem: the LASA ``shape`` written on a table
    by the Jaco, the prior learned from the demonstrations but ``held``, its start the held-out
    one's, a 4 x 4 x 8 cm block on the table at its middle. Skips without the data set."""
    import os
    from pathlib import Path
    from scenes import Demonstrations
    from scenes.datasets import DATASETS_ENV
    root = Path(os.environ.get(DATASETS_ENV) or Path(__file__).resolve().parents[4] / "shared"
                / "datasets")
    if not (root / LASA_FILE).is_file():
        pytest.skip(f"{LASA_FILE} not found in ../shared/datasets (set SKILLPLAN_DATASETS)")
    with np.load(root / LASA_FILE) as data:
        pos = np.asarray(data[f"{shape}__pos"], float)
        stamps = np.asarray(data[f"{shape}__t"], float)
    phase = np.linspace(0.0, 1.0, 200)
    dt = float(np.mean(stamps[:, -1] - stamps[:, 0])) / 199
    out = np.empty((len(pos), 200, 3))
    for m, (uv, t) in enumerate(zip(pos, stamps)):
        s = (t - t[0]) / (t[-1] - t[0])
        out[m] = np.stack([0.42 + 0.004 * np.interp(phase, s, uv[:, 0]),
                           -0.32 + 0.004 * np.interp(phase, s, uv[:, 1]),
                           np.full(200, 0.12)], axis=1)
    keep = [m for m in range(len(out)) if m != held]
    demos = Demonstrations(out[keep], np.gradient(out[keep], dt, axis=1), np.arange(200) * dt,
                           None, f"lasa_{shape}")
    middle = out[held][100]
    return learn_prior(demos), Scene([Box([middle[0], middle[1], 0.12], [0.04, 0.04, 0.08])]), \
        out[held][0]


def test_a_hair_short_plan_is_polished_to_pass_with_its_margins():
    """WShape / 5 of the handwriting family: the planner before issue 27 (commit be42ad9)
    returned a plan 1.07 x the skill's tube, a hair short; now the rounds go on on the active
    constraints and the plan passes, every margin held, measured here on its own: coal
    distances of the URDF geometry, positions and finite-difference velocities within the
    limits; the tube by the verdict's measure."""
    prior, scene, start = lasa_problem("WShape", 5)
    robot = load_robot("jaco")
    # unbounded search: what is tested here is the polish, not the budget (a wall-time bound);
    # the joint-space factors as stated (Qc_duration None): planned as a 20 s skill in faster
    # time (docs/decisions.md#qc_duration) the first rounds already pass, nothing to polish
    result = plan(prior, robot, scene, start, covariance=False,
                  config=PlannerConfig(search_budget=None, Qc_duration=None))
    assert result.success, result.reasons
    rounds = PlannerConfig().optimizer.constraint_rounds
    polished = [a for a in result.attempts if a["round"] > rounds]
    assert polished and polished[-1]["feasible"]           # the last update was a polish round
    assert_passes_on_its_own(robot, scene, result)


def assert_passes_on_its_own(robot, scene, result) -> None:
    """A plan's margins measured here: coal distances of the URDF geometry to the scene,
    positions and finite-difference velocities within the limits; the tube by the verdict's
    measure."""
    report = CollisionChecker(robot, coal_obstacles(scene.obstacles)).check(result.q)
    assert not report.collision and report.min_distance > 0.0
    assert np.all(robot.within_limits(result.q, tolerance=0.0))
    speed = np.abs(np.diff(result.q, axis=0)) / np.diff(result.time)[:, None]
    assert np.all(speed <= np.asarray(robot.velocity_limits) * (1.0 + 1e-9))
    assert result.skill["max_tube_ratio"] <= TUBE_RATIO


def test_a_lazy_constraint_joins_while_polishing():
    """Angle / 0 of the handwriting family: the polish rounds fixed a joint velocity, then a
    contact, and pushed the plan out of the skill's tube (1.08 x), a check whose constraint had
    not joined the problem yet, so the polish stopped a hair short; now the tube joins as a
    polish round and the plan passes, measured here on its own as above."""
    prior, scene, start = lasa_problem("Angle", 0)
    robot = load_robot("jaco")
    result = plan(prior, robot, scene, start, covariance=False)
    assert result.success, result.reasons
    assert_passes_on_its_own(robot, scene, result)


def test_a_contact_between_two_states_widens_the_margin():
    """hard/sawyer/0049 of the fidelity benchmark (reach_from_above, a box on the skill's path,
    the Sawyer): the search ended with the hand 0.03 mm into the box between states 129 and
    130, where the obstacle hinges at the states saw nothing (their spheres cleared it) and
    the multiplier updates could not move the plan. Now the hinges' margin widens by what the
    check measured, the closest start continues after the search, and the plan passes,
    measured here on its own."""
    prior = learn_prior(make_demonstrations("reach_from_above", num_demos=6, num_points=250,
                                            seed=0))
    scene = Scene([Box([0.3309596756975612, -0.3515700346946033, 0.30427636707606215],
                       [0.0528141030580948, 0.09872842939723098, 0.04820894994435643])])
    robot = load_robot("sawyer")
    result = plan(prior, robot, scene, [0.10517073386556622, -0.49302210185744194,
                                        0.20375333108166413], covariance=False)
    assert result.success, result.reasons
    assert any("+" in a["candidate"] for a in result.attempts)     # continued after the search
    assert_passes_on_its_own(robot, scene, result)


def test_other_ik_branches_of_the_start(blocked):
    """The search's other starts of an end-effector start: other inverse-kinematics solutions,
    each reaching the start position, BRANCH_APART from the planner's start configuration and
    from each other, within the limits; none for a joint start."""
    from clamp.planning.pipeline import BRANCH_APART, model, other_branches
    from clamp.planning.request import make_request
    prior, robot, scene = blocked
    config = PlannerConfig()
    request = make_request(prior, robot, START, config=config)
    branches = other_branches(model(prior, robot, scene, request, config), 2)
    assert 1 <= len(branches) <= 2
    for k, q0 in enumerate(branches):
        assert np.linalg.norm(robot.fk(q0[None])[0] - START) <= config.checks.ik_tolerance
        assert np.max(np.abs(q0 - request.q_start)) >= BRANCH_APART
        assert all(np.max(np.abs(q0 - q)) >= BRANCH_APART for q in branches[:k])
        assert np.all(robot.within_limits(q0[None]))
    joint = make_request(prior, robot, request.q_start, config=config)
    assert other_branches(model(prior, robot, scene, joint, config), 2) == []
