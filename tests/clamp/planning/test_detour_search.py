"""Issue 27: the detours around an obstacle that blocks the skill (clamp.planning.detours),
and plans a hair short that the search's polish rounds finish:

- the detours (geometry alone): around an obstacle on a straight path, over / left / right /
  under, two heights each, every one past the obstacle's face by the clearance where the path
  met it, the start unmoved; ranked in the workspace, a detour whose hand point stays clear and
  inside the skill's tube first;
- a plan a hair short (handwriting WShape / 5) is polished until it passes, its margins held,
  measured independently.

The search itself (its budget, its outcomes): tests/clamp/planning/test_search.py.
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
from scenes import Box, Scene
from scenes.coal_shapes import coal_obstacles

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
                  config=PlannerConfig(budget=None, Qc_duration=None))
    assert result.success, result.reasons
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
