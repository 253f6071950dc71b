"""Generators of common problem sets (lists of :class:`~clamp.batch.problems.Problem`), all seeded.

- :func:`start_problems`: one problem from many starts, a grid or a seeded random sample in
  the demonstrations' start region (the prior's initial mean +- ``scale`` standard deviations
  per axis, at least ``min_half_width`` m);
- :func:`across_robots`: one problem on several robots (end-effector starts / goals only);
- :func:`scene_benchmark`: the scene benchmark's problems: seeded skill, start and random
  boxes / spheres / cylinders near the skill's mean path, plus a share of impossible ones
  (an obstacle over the start or over the goal, ``expected="impossible"``).

"Feasible" in the scene benchmark means what the generator checked, not a proof that a plan
exists: the start and goal positions are at least ``CLEAR_POSITION`` from every obstacle, and
the arm's configurations there (inverse kinematics, as the planner solves them) are at least
``CLEAR_CONFIGURATION`` from every obstacle on the robot's URDF collision geometry.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.batch.problems import Problem, make_problem
from clamp.prior.linear_gaussian import check_prior
from clamp.validation import ERRORS, as_count, as_scalar
from skillplan.validation import as_generator, as_instance, as_path, as_sequence, as_seed
from scenes import Box, Cylinder, Sphere
from robots.collision_check import CollisionChecker
from scenes.coal_shapes import coal_obstacles
from clamp.batch.runner import load_prior, load_robot
from scenes import Scene
from scenes.synthetic import SKILLS

#: skills of the scene benchmark (all synthetic skills that carry no obstacle of their own)
BENCHMARK_SKILLS = ("box_closing", "reach_from_above", "pick_place", "two_target_press")
CLEAR_POSITION = 0.05          # [m] start / goal position to any obstacle (feasible problems)
CLEAR_CONFIGURATION = 0.02     # [m] start / goal arm geometry to any obstacle (feasible problems)
_MAX_TRIES = 200


def start_region(prior: Any, scale: float = 2.0, min_half_width: float = 0.01) -> np.ndarray:
    """Axis-aligned box (2, 3) [m] around the prior's initial mean position: +- ``scale``
    initial standard deviations per axis, at least ``min_half_width``."""
    check_prior(prior)
    scale = as_scalar(scale, "scale", strictly_positive=True)
    min_half_width = as_scalar(min_half_width, "min_half_width", minimum=0.0)
    centre = np.asarray(prior.mean)[0, :3]
    std = np.sqrt(np.diag(np.asarray(prior.cov0)[:3, :3]))
    half = np.maximum(scale * std, min_half_width)
    return np.stack([centre - half, centre + half])


def start_problems(base: Problem, count: int | None = None, *, grid: int | None = None,
                   seed: Any = 0, scale: float = 2.0, min_half_width: float = 0.01,
                   base_dir: str | Path | None = None) -> list[Problem]:
    """Copies of ``base`` with starts in the start region of its prior (:func:`start_region`):
    ``count`` seeded uniform samples, or a ``grid`` x ``grid`` x ``grid`` grid (exactly one of
    the two). Ids ``<base id>/start<k>``; ``meta["start_index"] = k``."""
    _check_problem(base, "base")
    rng = as_generator(seed, "seed", error=ERRORS)
    if base_dir is not None:
        as_path(base_dir, "base_dir", ClampTypeError)
    if (count is None) == (grid is None):
        raise InvalidParameterError("count, grid: expected exactly one of them, got "
                                    f"count={count!r}, grid={grid!r}")
    prior = load_prior(base.to_dict()["prior"], Path(base_dir or "."))
    low, high = start_region(prior, scale, min_half_width)
    if grid is not None:
        k = as_count(grid, "grid", minimum=1)
        axes = [np.linspace(lo, hi, k) if k > 1 else np.array([(lo + hi) / 2])
                for lo, hi in zip(low, high)]
        starts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    else:
        starts = rng.uniform(low, high, size=(as_count(count, "count"), 3))
    width = len(str(len(starts) - 1))
    return [base.replace(id=f"{base.id}/start{k:0{width}d}", start=start.tolist(),
                         meta={**base.to_dict()["meta"], "start_index": k})
            for k, start in enumerate(starts)]


def across_robots(problem: Problem, robots: Sequence[str | dict[str, Any]]) -> list[Problem]:
    """``problem`` on each robot (a built-in name or ``{"urdf": .., "end_effector": ..}``);
    ids ``<id>/<robot>``. The start, goal and via points must be end-effector positions (3,):
    a joint configuration belongs to one arm."""
    _check_problem(problem, "problem")
    robots = as_sequence(robots, "robots", "a list of robot names or {'urdf': .., "
                         "'end_effector': ..} objects", ClampTypeError)
    for k, robot in enumerate(robots):
        as_instance(robot, f"robots[{k}]", (str, dict), "a robot name or a {'urdf': .., "
                    "'end_effector': ..} object", ClampTypeError)
    targets = [("start", problem.start)] + ([("goal", problem.goal)] if problem.goal else [])
    targets += [(f"via_points[{k}]", v) for k, (_, v) in enumerate(problem.via_points)]
    for name, value in targets:
        if len(value) != 3:
            raise InvalidParameterError(f"problem {problem.id!r} {name}: expected an end-effector "
                                        f"position (3,) to carry over to other robots, got a "
                                        f"joint configuration ({len(value)},)")
    out = []
    for robot in robots:
        label = robot if isinstance(robot, str) else Path(robot.get("urdf", "robot")).stem
        out.append(problem.replace(id=f"{problem.id}/{label}", robot=robot))
    return out


def _check_problem(problem: Any, name: str) -> None:
    as_instance(problem, name, Problem, "a clamp.batch.problems.Problem", ClampTypeError)


# ------------------------------------------------------------------ scene benchmark
def _random_obstacle(rng: np.random.Generator, centre: np.ndarray) -> Any:
    kind = rng.choice(["box", "sphere", "cylinder"])
    if kind == "box":
        return Box(centre, rng.uniform(0.03, 0.08, size=3))
    if kind == "sphere":
        return Sphere(centre, rng.uniform(0.02, 0.04))
    axis = rng.normal(size=3)
    axis = axis / np.linalg.norm(axis) if rng.random() < 0.5 else np.array([0.0, 0.0, 1.0])
    return Cylinder(centre, rng.uniform(0.015, 0.03), rng.uniform(0.05, 0.15), axis)


def _covering_obstacle(rng: np.random.Generator, point: np.ndarray) -> Any:
    """An obstacle that contains ``point`` (by at least 1 cm)."""
    centre = point + rng.uniform(-0.01, 0.01, size=3)
    if rng.random() < 0.5:
        return Box(centre, rng.uniform(0.06, 0.10, size=3))
    return Sphere(centre, rng.uniform(0.04, 0.06))


def _configurations_clear(robot: Any, obstacles: list, targets: np.ndarray) -> bool:
    """Whether the arm's IK configurations at ``targets`` (K, 3) are CLEAR_CONFIGURATION clear
    of ``obstacles`` on the URDF collision geometry (each configuration checked on its own)."""
    checker = CollisionChecker(robot, coal_obstacles(obstacles))
    return all(checker.check(np.asarray(robot.ik(t).q)[None]).min_distance >= CLEAR_CONFIGURATION
               for t in targets)


def scene_benchmark(count: int, robot: str = "jaco", seed: int = 0, *,
                    skills: Sequence[str] = BENCHMARK_SKILLS, impossible_share: float = 0.2,
                    num_points: int = 250, obstacles: tuple[int, int] = (1, 3),
                    start_offset: float = 0.02, near: float = 0.08,
                    config: dict[str, Any] | None = None) -> list[Problem]:
    """``count`` seeded scene-benchmark problems for a built-in ``robot``.

    Problem k: skill ``skills[k % len(skills)]`` (prior learned from 6 synthetic
    demonstrations, seed 0, ``num_points`` states); start = the prior's mean start + a uniform
    offset of up to ``start_offset`` m per axis; goal = the prior's mean end. Feasible problems
    (``expected="feasible"``) get ``obstacles`` (min, max) random boxes / spheres / cylinders
    centred within ``near`` m of a point of the mean path between 20 % and 80 % of it, each
    drawn again until it leaves the start and goal clear (module docstring; the distance
    bound grows to 2 ``near`` over the tries, for arms whose body covers much of the path at
    the start or goal, e.g. the Sawyer's wrist over reach_from_above). A share
    ``impossible_share`` (every k with ``floor((k+1) s) > floor(k s)``) instead get one obstacle
    over the start or the goal (alternately), ``expected="impossible"``, ``meta["impossible"]``
    "start" / "goal". Ids ``scenes/<robot>/<k>``.
    """
    count = as_count(count, "count")
    share = as_scalar(impossible_share, "impossible_share", minimum=0.0, maximum=1.0)
    seed = as_seed(seed, "seed", ERRORS)
    skills = as_sequence(skills, "skills", "a list of skill names", ClampTypeError)
    if not skills or any(s not in SKILLS for s in skills):
        raise InvalidParameterError(f"skills: expected a non-empty list of skills from "
                                    f"{list(SKILLS)}, got {skills!r:.100}")
    num_points = as_count(num_points, "num_points", minimum=2)
    fewest, most = _obstacle_counts(obstacles)
    start_offset = as_scalar(start_offset, "start_offset", minimum=0.0)
    near = as_scalar(near, "near", strictly_positive=True)
    if config is not None:
        as_instance(config, "config", dict, "a dict of PlannerConfig field changes or None",
                    ClampTypeError)
    arm = load_robot({"name": robot}, Path("."))
    rng = np.random.default_rng(seed)
    paths = {}
    out, impossible = [], 0
    for k in range(count):
        skill = skills[k % len(skills)]
        prior_spec = {"skill": skill, "seed": 0, "num_demos": 6, "num_points": int(num_points)}
        if skill not in paths:
            paths[skill] = np.asarray(load_prior(prior_spec, Path(".")).mean)[:, :3]
        path = paths[skill]
        start = path[0] + rng.uniform(-start_offset, start_offset, size=3)
        goal = path[-1]
        meta: dict[str, Any] = {"skill": skill, "seed": seed, "index": k}
        if np.floor((k + 1) * share) > np.floor(k * share):
            where = "start" if impossible % 2 == 0 else "goal"
            impossible += 1
            shapes = [_covering_obstacle(rng, start if where == "start" else goal)]
            expected, meta["impossible"] = "impossible", where
        else:
            expected = "feasible"
            lo, hi = int(0.2 * len(path)), int(0.8 * len(path))
            ends = np.stack([start, goal])
            shapes = []
            for _ in range(rng.integers(fewest, most + 1)):
                for attempt in range(_MAX_TRIES):   # drawn until it leaves the ends clear
                    direction = rng.normal(size=3)
                    reach = near * (1.0 + attempt / _MAX_TRIES)
                    centre = path[rng.integers(lo, hi)] + direction / np.linalg.norm(direction) \
                        * rng.uniform(0.0, reach)
                    shape = _random_obstacle(rng, centre)
                    if (shape.distance(ends).min() >= CLEAR_POSITION
                            and _configurations_clear(arm, [shape], ends)):
                        shapes.append(shape)
                        break
                else:
                    raise InvalidParameterError(f"scene_benchmark: no obstacle near the path of "
                                                f"problem {k} leaves its start and goal clear "
                                                f"after {_MAX_TRIES} tries (near={near} m)")
        out.append(make_problem(f"scenes/{robot}/{k:04d}", prior_spec, robot, start,
                                scene=Scene(shapes), goal=goal, config=config,
                                expected=expected, meta=meta))
    return out


def _obstacle_counts(obstacles: Any) -> tuple[int, int]:
    """``obstacles`` as (fewest, most) obstacles per feasible problem, 0 <= fewest <= most."""
    pair = as_sequence(obstacles, "obstacles", "a pair (min, max) of obstacle counts",
                       ClampTypeError)
    if len(pair) != 2:
        raise InvalidParameterError(f"obstacles: expected a pair (min, max), got {obstacles!r}")
    fewest = as_count(pair[0], "obstacles[0]", minimum=0)
    most = as_count(pair[1], "obstacles[1]", minimum=fewest)
    return fewest, most
