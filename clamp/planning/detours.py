"""Restart trajectories for the constrained solve: the skill's path detoured around an obstacle.

When the problem as built ends in a collision no penalty removes (the path runs through the
obstacle's middle, a local optimum on the wrong side), :func:`clamp.optim.constrained.solve_constrained`
tries other starts; :func:`detour_restarts` gives two: the initial path pushed away from the
obstacle across its direction of travel, and lifted over it.
"""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from clamp.planning.initialisation import joint_velocities


def detour_paths(path: np.ndarray, centre: np.ndarray, radius: float, clearance: float,
                 index: float) -> list[tuple[str, np.ndarray]]:
    """End-effector paths (T, 3) [m] that leave ``path`` (T, 3) around an obstacle (bounding
    sphere ``centre`` (3,), ``radius`` [m]) met near state ``index``: "detour_away" pushes the
    path away from the centre across its direction of travel, "detour_over" lifts it (+z), each
    by radius + clearance at the contact, faded in and out (raised cosine) over the states within
    radius + 2 clearance of the centre (at least a tenth of the path each side)."""
    T = len(path)
    i = int(np.clip(round(index), 0, T - 1))
    near = np.flatnonzero(np.linalg.norm(path - centre, axis=1) < radius + 2.0 * clearance)
    half = max(T // 10, int(np.max(np.abs(near - i))) if near.size else 0, 1)
    s = np.clip((np.arange(T) - i) / half, -1.0, 1.0)
    window = 0.5 * (1.0 + np.cos(np.pi * s))
    window[0] = 0.0                                   # the start stays where it was asked
    tangent = path[min(i + 1, T - 1)] - path[max(i - 1, 0)]
    tangent /= max(np.linalg.norm(tangent), 1e-12)
    away = path[i] - centre
    away -= tangent * (away @ tangent)
    if np.linalg.norm(away) < 1e-9:
        away = np.cross(tangent, [0.0, 0.0, 1.0])
        if np.linalg.norm(away) < 1e-9:
            away = np.array([1.0, 0.0, 0.0])
    away /= np.linalg.norm(away)
    amplitude = radius + clearance
    out = []
    for name, direction in (("detour_away", away), ("detour_over", np.array([0.0, 0.0, 1.0]))):
        out.append((name, path + amplitude * window[:, None] * direction))
    return out


def bounding_sphere(obstacle) -> tuple[np.ndarray, float]:
    """Centre (3,) and radius [m] of a ball containing a scene obstacle (from its AABB)."""
    box = np.asarray(obstacle.aabb(), dtype=float)
    return 0.5 * (box[0] + box[1]), 0.5 * float(np.linalg.norm(box[1] - box[0]))


def detour_restarts(robot, path: np.ndarray, q_start: np.ndarray, dt: float, obstacle,
                    clearance: float, index: float, tolerance: float
                    ) -> Iterable[tuple[str, np.ndarray]]:
    """Joint-state trajectories (T, 2n) of :func:`detour_paths` around ``obstacle`` (a scene
    obstacle met near state ``index``), by inverse kinematics seeded at q_start (n,); generated
    lazily (each costs an IK of the path)."""
    centre, radius = bounding_sphere(obstacle)
    for name, detour in detour_paths(path, centre, radius, clearance, index):
        q = np.array(robot.ik_trajectory(detour, seed=q_start, tol=tolerance).q, dtype=float)
        q[0] = q_start
        yield name, np.concatenate([q, joint_velocities(q, dt)], axis=1)
