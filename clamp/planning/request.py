"""A planning request checked at the boundary: the prior, robot, scene, configuration, start,
goal and via points a caller passed, validated once (ClampError naming the argument) and
resolved (an end-effector start solved by inverse kinematics; with a pose prior, the hand
turned as the skill starts)."""
from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from clamp.config import PlannerConfig, as_config
from clamp.prior import so3
from clamp.prior.linear_gaussian import check_prior
from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.planning.reach import check_prior_reach
from clamp.validation import as_array, as_count
from skillplan.validation import as_sequence
from scenes import Scene
from scenes.quaternions import QUATERNION_TOLERANCE
from scenes.obstacles import Obstacle
from clamp.factors import Family
from robots.ik import solve_ik_turned

#: [m] the inverse kinematics accuracy that makes an end-effector start reachable (at most the
#: start tolerance) and that the search's IK starts are solved to
IK_TOLERANCE = 1e-4


@dataclass(frozen=True)
class Target:
    """A start / goal / via point: kind "joint" (value (n,) rad) or "position" (value (3,) m);
    a pose is a position target with the hand's ``rotation`` (3, 3) as well (None: position
    only)."""

    kind: str
    value: np.ndarray
    rotation: np.ndarray | None = None

    def given(self) -> Any:
        """The target as a caller gives it (what :func:`as_target` reads back): the value, or
        for a pose the pair (position (3,), quaternion (4,) x, y, z, w)."""
        if self.rotation is None:
            return self.value
        return (self.value, so3.to_quaternions(self.rotation))


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


def is_gtsam_factor(value: Any) -> bool:
    """Whether ``value`` is a ``gtsam.NonlinearFactor``, asked without loading GTSAM (a GTSAM
    factor exists only once GTSAM is loaded)."""
    gtsam = sys.modules.get("gtsam")
    return gtsam is not None and isinstance(value, gtsam.NonlinearFactor)


def as_extras(extra_factors: Any) -> list:
    """extra_factors as a list: a sequence as is, a single family / factor / maker wrapped."""
    if isinstance(extra_factors, Family) or is_gtsam_factor(extra_factors) or callable(extra_factors):
        return [extra_factors]
    return as_sequence(extra_factors, "extra_factors", "a list of clamp Families, GTSAM factors "
                       "or makers", ClampTypeError)


def as_pose(value: Any, name: str) -> Target | None:
    """A pose target from a homogeneous transform (4, 4) or a pair (position (3,) [m],
    quaternion (4,) x, y, z, w), None when ``value`` is neither; ShapeError / InvalidParameterError
    naming ``name`` for a pose that is not one (not a rotation, not a unit quaternion)."""
    pair = (isinstance(value, (tuple, list)) and len(value) == 2
            and all(np.ndim(part) == 1 for part in value)
            and (np.size(value[0]), np.size(value[1])) == (3, 4))
    if not pair and np.ndim(value) == 2 and np.shape(value) == (4, 4):
        matrix = as_array(value, name, (4, 4))
        if np.abs(matrix[3] - [0.0, 0.0, 0.0, 1.0]).max() > 1e-9:
            raise InvalidParameterError(f"{name}: expected a homogeneous transform with last "
                                        f"row [0, 0, 0, 1], got {matrix[3].tolist()}")
        rotation = matrix[:3, :3]
        if np.abs(rotation.T @ rotation - np.eye(3)).max() > 1e-6 or np.linalg.det(rotation) < 0:
            raise InvalidParameterError(f"{name}: expected a proper rotation in the transform's "
                                        "upper-left (3, 3) block")
        return Target("position", matrix[:3, 3].copy(), rotation)
    if pair:
        position = as_array(value[0], f"{name} position", (3,))
        quaternion = as_array(value[1], f"{name} quaternion", (4,))
        norm = float(np.linalg.norm(quaternion))
        if abs(norm - 1.0) > QUATERNION_TOLERANCE:
            raise InvalidParameterError(f"{name} quaternion: expected a unit quaternion (x, y, "
                                        f"z, w) within {QUATERNION_TOLERANCE:g} of length 1, got "
                                        f"length {norm:.4g}")
        return Target("position", position, so3.from_quaternions(quaternion / norm))
    return None


def as_target(value: Any, name: str, n: int) -> Target:
    """A joint configuration (n,), an end-effector position (3,) (joint wins when n == 3) or
    an end-effector pose (:func:`as_pose`: a transform (4, 4) or (position, quaternion))."""
    pose = as_pose(value, name)
    if pose is not None:
        return pose
    size = np.size(value) if np.ndim(value) == 1 else -1
    if size == n:
        return Target("joint", as_array(value, name, (n,)))
    if size == 3:
        return Target("position", as_array(value, name, (3,)))
    raise ShapeError(f"{name}: expected a joint configuration ({n},), an end-effector "
                     f"position (3,) or a pose (a transform (4, 4), or (position (3,), "
                     f"quaternion (4,))), got shape {np.shape(value)}")


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
    ``start_ik_error`` [m]): :func:`start_configuration`."""
    check_prior(prior, workspace=True)
    check_robot(robot)
    config = as_config(config)
    n, T = robot.n, prior.Phi.shape[0] + 1
    check_prior_reach(prior, robot)
    if start is None:
        raise InvalidParameterError(f"start: expected a joint configuration ({n},) or an "
                                    "end-effector position (3,), got None")
    start_target = as_target(start, "start", n)
    if start_target.rotation is not None:
        raise InvalidParameterError(f"start: expected a joint configuration ({n},) or an "
                                    "end-effector position (3,), got a pose: the start pose is "
                                    "the arm's (give its start configuration)")
    goal_target = None if goal is None else as_target(goal, "goal", n)
    vias = _via_targets(via_points, T, n)
    ik_error = 0.0
    if q_start is not None:
        q_start = as_array(q_start, "q_start", (n,))
    elif start_target.kind == "joint":
        q_start = start_target.value
    else:
        q_start, ik_error = start_configuration(
            prior, robot, start_target.value, min(IK_TOLERANCE, config.checks.start_tolerance))
    position = start_target.value if start_target.kind == "position" else robot.fk(q_start)
    return Request(start_target, goal_target, vias, q_start, position, ik_error)


def start_configuration(prior: Any, robot: Any, position: np.ndarray,
                        tolerance: float) -> tuple[np.ndarray, float]:
    """The arm's start configuration (n,) [rad] for an end-effector start ``position`` (3,)
    [m], and its IK error [m] (``tolerance`` [m] the IK's). A position-only prior: position
    IK (``robot.ik``). A pose prior: the hand also turned as near the skill's start rotation
    (its orientation chain's mean at step 0) as is reachable there
    (:func:`robots.ik.solve_ik_turned`). The start pose is the arm's (the orientation chain is
    conditioned on it), so a start on another IK branch would ask the plan to turn the hand
    back by up to 180 deg against the skill (a UR5 whose position IK turned it 149 deg away
    failed its free plan, docs/decisions.md#a-position-start-of-a-pose-skill)."""
    orientation = getattr(prior, "orientation", None)
    if orientation is None:
        ik = robot.ik(position, tol=tolerance)
    else:
        ik = solve_ik_turned(robot, position, orientation.mean_rotations[0], tol=tolerance)
    return np.asarray(ik.q, dtype=float), float(ik.error)
