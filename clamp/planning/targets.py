"""Targets of a plan: reachability of the goal and via points, checked before planning (the
constraint families' violations after planning are their own checks, :mod:`clamp.factors.family`).

An end-effector target (goal or via point) that inverse kinematics cannot reach within the
check's tolerance cannot be met by any plan: the plan fails at once with a reason naming the
target, its position and how far the arm's closest reach is. Joint-space targets are checked
against the joint limits. A target inside an obstacle of the scene (an end-effector position
with a negative signed distance, like the start's check) cannot be met without collision: it
fails at once too, with its depth.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from clamp.config import PlannerConfig
from clamp.planning.request import Request, Target, has_obstacles


def _problem(robot: Any, name: str, target: Target, tolerance: float,
             seed: np.ndarray) -> str | None:
    if target.kind == "joint":
        if not bool(np.all(robot.within_limits(target.value, 1e-9))):
            return f"{name} configuration is outside the joint limits"
        return None
    ik = robot.ik(target.value, seed=seed, tol=0.1 * tolerance)
    if float(ik.error) > tolerance:
        return (f"{name} position {np.round(target.value, 4).tolist()} is out of reach (closest "
                f"reach {float(ik.error) * 1000:.1f} mm away, tolerance "
                f"{tolerance * 1000:.1f} mm)")
    return None


def inside_obstacle(scene: Any, name: str, target: Target) -> str | None:
    """The reason when the end-effector position ``target`` (start, goal or via point, called
    ``name``) lies inside an obstacle of ``scene``, with its depth; else None."""
    if target.kind != "position" or not has_obstacles(scene):
        return None
    depth = -float(scene.distance(target.value))
    if depth <= 0.0:
        return None
    return (f"{name} position {np.round(target.value, 4).tolist()} is inside an obstacle "
            f"({depth * 1000:.1f} mm deep)")


def target_problems(robot: Any, request: Request, config: PlannerConfig,
                    scene: Any = None) -> list[str]:
    """Reasons (empty: none) why the goal or a via point of ``request`` cannot be met: out of
    reach, outside the joint limits, or inside an obstacle of ``scene``."""
    checks = config.checks
    named = [("goal", request.goal, checks.goal_tolerance)] if request.goal is not None else []
    named += [(f"via point at state {i}", t, checks.via_tolerance) for i, t in request.vias]
    reasons = [inside_obstacle(scene, name, target) or _problem(robot, name, target, tol, request.q_start)
               for name, target, tol in named]
    return [r for r in reasons if r is not None]
