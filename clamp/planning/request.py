"""A planning request checked at the boundary: the prior, robot, scene, configuration, start,
goal and via points a caller passed, validated once (ClampError naming the argument) and
resolved (an end-effector start solved by inverse kinematics)."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from clamp.config import PlannerConfig, as_config
from clamp.prior.linear_gaussian import check_prior
from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.planning.reach import check_prior_reach
from clamp.validation import as_array, as_count
from skillplan.validation import as_sequence
from scenes import Scene
from scenes.obstacles import Obstacle
from clamp.factors import Family


@dataclass(frozen=True)
class Target:
    """A start / goal / via point: kind "joint" (value (n,) rad) or "position" (value (3,) m)."""

    kind: str
    value: np.ndarray


@dataclass(frozen=True)
class Request:
    """A validated planning request (what :func:`build` was asked), with the start resolved:
    q_start (n,) [rad], start_position (3,) [m], vias [(index, Target)]."""

    start: Target
    goal: Target | None
    vias: tuple[tuple[int, Target], ...]
    q_start: np.ndarray
    start_position: np.ndarray
    start_ik_error: float


def check_robot(robot: Any) -> None:
    for attr in ("n", "ee_kinematics", "sphere_centres", "fk", "ik", "ik_trajectory"):
        if not hasattr(robot, attr):
            raise ClampTypeError(f"robot: expected a robots.Robot, got "
                                        f"{type(robot).__name__} without '{attr}'")


def as_scene(scene: Any) -> Any:
    """A scenes.Scene from None, a Scene, an obstacle, a list of obstacles or a scene file path."""
    if scene is None or isinstance(scene, Scene):
        return scene
    if isinstance(scene, Obstacle):
        return Scene([scene])
    if isinstance(scene, (str, Path)):
        return Scene.load(scene)
    if isinstance(scene, (list, tuple)):
        for k, item in enumerate(scene):
            if not isinstance(item, Obstacle):
                raise ClampTypeError(f"scene[{k}]: expected a scenes obstacle (Box, Sphere, "
                                        f"Cylinder, Capsule), got {type(item).__name__}")
        return Scene(list(scene))
    raise ClampTypeError(f"scene: expected a scenes.Scene, an obstacle, a list of "
                                f"obstacles, a scene file path or None, got {type(scene).__name__}")


def as_sdf(sdf: Any, scene: Any) -> Any:
    """A signed distance field (anything with ``query(points) -> (distance, gradient)``) given
    with a scene that has obstacles (the verdict measures clearance on the scene), or None."""
    if sdf is None:
        return None
    if not callable(getattr(sdf, "query", None)):
        raise ClampTypeError(f"sdf: expected a scenes.SignedDistanceField (or an object with "
                                f"query(points)), got {type(sdf).__name__} {sdf!r:.40}")
    if not has_obstacles(scene):
        raise InvalidParameterError("sdf: given without a scene with obstacles; pass the scene "
                                    "the field was built from (clearance is checked on it)")
    return sdf


def as_extras(extra_factors: Any) -> list:
    """extra_factors as a list: a sequence as is, a single family / factor / maker wrapped."""
    import gtsam

    if isinstance(extra_factors, (Family, gtsam.NonlinearFactor)) or callable(extra_factors):
        return [extra_factors]
    return as_sequence(extra_factors, "extra_factors", "a list of clamp Families, GTSAM factors "
                       "or makers", ClampTypeError)


def as_target(value: Any, name: str, n: int) -> Target:
    """A joint configuration (n,) or an end-effector position (3,) (joint wins when n == 3)."""
    size = np.size(value) if np.ndim(value) == 1 else -1
    if size == n:
        return Target("joint", as_array(value, name, (n,)))
    if size == 3:
        return Target("position", as_array(value, name, (3,)))
    raise ShapeError(f"{name}: expected a joint configuration ({n},) or an end-effector "
                     f"position (3,), got shape {np.shape(value)}")


def _via_targets(via_points: Sequence[tuple[int, Any]], T: int,
                 n: int) -> tuple[tuple[int, Target], ...]:
    out = []
    via_points = as_sequence(via_points, "via_points", f"a list of pairs (index, position (3,) "
                             f"or configuration ({n},))", ClampTypeError)
    for k, item in enumerate(via_points):
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ShapeError(f"via_points[{k}]: expected a pair (index, position (3,) or "
                             f"configuration ({n},)), got {item!r}")
        index = as_count(item[0], f"via_points[{k}] index", minimum=0)
        if index >= T:
            raise InvalidParameterError(f"via_points[{k}] index: expected 0 <= index < {T}, "
                                        f"got {index}")
        out.append((index, as_target(item[1], f"via_points[{k}] target", n)))
    return tuple(out)


def has_obstacles(scene: Any) -> bool:
    return scene is not None and len(getattr(scene, "obstacles", ())) > 0


def make_request(prior: Any, robot: Any, start: Any, goal: Any = None, via_points: Sequence = (),
                 config: PlannerConfig | None = None,
                 q_start: np.ndarray | None = None) -> Request:
    """The :class:`Request` for planning ``prior`` with ``robot`` (the first stage of
    :mod:`clamp.planning.pipeline`): start, goal (or None) and via points checked against the robot's n
    joints and the prior's T states; the start configuration is ``q_start`` (n,) [rad] when
    given (a replan keeps its previous one), the joint start itself, or inverse kinematics of
    the start position (``config.checks`` tolerances, None: the defaults; its error is
    ``start_ik_error`` [m])."""
    check_prior(prior, workspace=True)
    check_robot(robot)
    config = as_config(config)
    n, T = robot.n, prior.Phi.shape[0] + 1
    check_prior_reach(prior, robot)
    if start is None:
        raise InvalidParameterError(f"start: expected a joint configuration ({n},) or an "
                                    "end-effector position (3,), got None")
    start_target = as_target(start, "start", n)
    goal_target = None if goal is None else as_target(goal, "goal", n)
    vias = _via_targets(via_points, T, n)
    ik_error = 0.0
    if q_start is not None:
        q_start = as_array(q_start, "q_start", (n,))
    elif start_target.kind == "joint":
        q_start = start_target.value
    else:
        checks = config.checks
        ik = robot.ik(start_target.value, tol=min(checks.ik_tolerance, checks.start_tolerance))
        q_start, ik_error = np.asarray(ik.q, dtype=float), float(ik.error)
    position = start_target.value if start_target.kind == "position" else robot.fk(q_start)
    return Request(start_target, goal_target, vias, q_start, position, ik_error)
