"""Restart trajectories for the constrained solve: the skill's path detoured around an obstacle.

When the problem as built ends in a collision no penalty removes (the path runs through the
obstacle's middle, a local optimum on the wrong side) or pinned between an obstacle and the
skill's tube, :func:`clamp.optim.constrained.solve_constrained` tries other starts.

:func:`detour_search` makes them (issue 27): around each obstacle that blocks the skill's own
path (:func:`blocking_obstacles`), the path moved over, left, right and under it, each by
two heights (the least that takes the path past the obstacle's face by the clearance, and
that plus :data:`SECOND_HEIGHT`), faded in and out over the states near the obstacle; ranked
in the workspace before any solve (:func:`rank_detours`: the hand point's own clearance,
the skill's tube, the arm's reach), best first, every way around once before any twice.
:func:`detour_trajectory` turns one path into a joint trajectory (inverse kinematics seeded at
the start). (The older pair, pushed away from an obstacle's bounding sphere and lifted over
it, left the skill's tube by construction; see docs/decisions.md#detour-search.)
"""
from __future__ import annotations

import numpy as np

from clamp.planning.initialisation import joint_velocities

#: the detour directions: over (+z), left / right (horizontal, across the local direction of
#: travel), under (-z)
DIRECTIONS = ("over", "left", "right", "under")
#: [m] the second height of every detour: this much beyond the least one
SECOND_HEIGHT = 0.05
#: [m] an obstacle blocks the skill when it comes within this of the path, beyond the tube
BLOCKING = 0.02
#: [m] the states within this of an obstacle, beyond the clearance, are the ones a detour moves
#: fully (the hand's own size)
NEAR = 0.05


def blocking_obstacles(obstacles, path: np.ndarray, tube: np.ndarray,
                       clearance: float) -> list[tuple[int, object]]:
    """(scene index, obstacle) of the obstacles that block ``path`` (T, 3) [m]: closer to one
    of its states than that state's ``tube`` radius (T,) [m] plus ``clearance`` plus
    :data:`BLOCKING`, nearest (deepest into the path) first."""
    found = []
    for k, obstacle in enumerate(obstacles):
        distance = np.asarray(obstacle.distance(path), dtype=float)
        if np.any(distance < tube + clearance + BLOCKING):
            found.append((float(distance.min()), k, obstacle))
    return [(k, obstacle) for _, k, obstacle in sorted(found, key=lambda f: f[:2])]


def _directions(path: np.ndarray, near: np.ndarray) -> dict[str, np.ndarray]:
    tangent = path[min(near[-1] + 1, len(path) - 1)] - path[max(near[0] - 1, 0)]
    side = np.cross([0.0, 0.0, 1.0], tangent)
    if np.linalg.norm(side) < 1e-9:                  # travelling vertically
        side = np.array([0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    up = np.array([0.0, 0.0, 1.0])
    return {"over": up, "left": side, "right": -side, "under": -up}


def detours_around(path: np.ndarray, obstacle, clearance: float, reach: float,
                   label: str = "") -> list[tuple[str, np.ndarray]]:
    """Paths (T, 3) [m] that take ``path`` (T, 3) around ``obstacle`` (a scene obstacle with
    ``aabb()`` and ``distance(points)``): for each of :data:`DIRECTIONS`, moved by the least
    height h that takes every state within ``reach`` [m] of the obstacle past its face in that
    direction by ``clearance`` [m] (its axis-aligned box), and by h + :data:`SECOND_HEIGHT`;
    the offset faded in and out (raised cosine) over as many states again on either side (at
    least a twentieth of the path); the start never moves. Named "<direction>-<h in cm>"
    followed by ``label``."""
    T = len(path)
    distance = np.asarray(obstacle.distance(path), dtype=float)
    near = np.flatnonzero(distance < reach)
    if near.size == 0:
        near = np.array([int(np.argmin(distance))])
    lo, hi = (np.asarray(b, dtype=float) for b in obstacle.aabb())
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    pad = max(T // 20, (near[-1] - near[0]) // 2, 1)
    first, last = near[0] - pad, near[-1] + pad
    k = np.arange(T, dtype=float)
    window = np.ones(T)
    rise, fall = k < near[0], k > near[-1]
    window[rise] = 0.5 * (1.0 - np.cos(np.pi * np.clip((k[rise] - first) / pad, 0.0, 1.0)))
    window[fall] = 0.5 * (1.0 - np.cos(np.pi * np.clip((last - k[fall]) / pad, 0.0, 1.0)))
    window[0] = 0.0                                   # the start stays where it was asked
    out = []
    for name, direction in _directions(path, near).items():
        face = float(np.max(corners @ direction))
        height = max(face + clearance - float(np.min(path[near] @ direction)), clearance)
        for h in (height, height + SECOND_HEIGHT):
            out.append((f"{name}-{100 * h:.0f}{label}", path + h * window[:, None] * direction))
    return out


def rank_detours(candidates: list[tuple[str, np.ndarray]], obstacles, reference: np.ndarray,
                 tube: np.ndarray, clearance: float, base: np.ndarray, reach: float
                 ) -> list[tuple[str, np.ndarray, float]]:
    """``candidates`` (name, path (T, 3) [m]) with a workspace score, best (lowest) first, made
    before any solve: the hand point's clearance short of ``clearance`` [m] (over every
    obstacle, in units of it, weighted 10), the largest distance from ``reference`` (T, 3) in
    ``tube`` radii (T,) [m] beyond 1 (weighted 1, plus a tenth of the ratio itself: of two
    detours inside the tube the nearer one), and the path's reach beyond 90 % of ``reach`` [m]
    from ``base`` (3,) (in units of clearance, weighted 10)."""
    out = []
    for name, path in candidates:
        gap = min((float(np.min(o.distance(path))) for o in obstacles), default=np.inf)
        short = max(0.0, clearance - gap) / clearance
        ratio = float(np.max(np.linalg.norm(path - reference, axis=1) / tube))
        far = max(0.0, float(np.max(np.linalg.norm(path - base, axis=1))) - 0.9 * reach)
        score = 10.0 * short + max(0.0, ratio - 1.0) + 0.1 * ratio + 10.0 * far / clearance
        out.append((name, path, score))
    return sorted(out, key=lambda c: c[2])


def detour_search(path: np.ndarray, obstacles, reference: np.ndarray, tube: np.ndarray,
                  clearance: float, base: np.ndarray, reach: float, focus: int | None = None
                  ) -> list[tuple[str, np.ndarray, float]]:
    """Every detour of ``path`` (T, 3) [m] around every obstacle blocking the skill
    (:func:`blocking_obstacles` of the skill's ``reference`` path (T, 3) with its ``tube`` radii
    (T,) [m]), :func:`detours_around` each (the hand point kept ``clearance`` [m] past the
    face), ranked by :func:`rank_detours`, every way around an obstacle once before any twice:
    (name "<direction>-<cm>@<obstacle index>", path, score), best first; empty when nothing
    blocks the skill. ``focus``: the state where the
    closest optimum failed; the detours around the blocking obstacle nearest to the reference
    there come first (ranked among themselves), then the others."""
    blocking = blocking_obstacles(obstacles, reference, tube, clearance)
    if focus is not None and blocking:
        point = reference[int(np.clip(focus, 0, len(reference) - 1))][None]
        blocking.sort(key=lambda b: float(np.min(b[1].distance(point))))
    groups = [rank_detours(detours_around(path, obstacle, clearance, clearance + NEAR, f"@{k}"),
                           obstacles, reference, tube, clearance, base, reach)
              for k, obstacle in blocking]
    first = groups[:1] if focus is not None else []
    rest = [c for group in groups[len(first):] for c in group]
    return _each_way_first([c for group in first for c in group]) + _each_way_first(rest)


def _each_way_first(ranked: list[tuple[str, np.ndarray, float]]
                    ) -> list[tuple[str, np.ndarray, float]]:
    """``ranked`` (name "<direction>-<cm>@<obstacle>", path, score) ordered by score, but every
    way around an obstacle (direction and obstacle) once before any twice: the second height
    of a way mostly ends where its first did."""
    ways: dict[str, int] = {}
    keyed = []
    for candidate in sorted(ranked, key=lambda c: c[2]):
        way = candidate[0].split("-")[0] + candidate[0].split("@")[-1]
        keyed.append((ways.get(way, 0), candidate))          # the way's how-many-th height
        ways[way] = ways.get(way, 0) + 1
    # a stable sort on that count keeps the score order within each
    return [c for _, c in sorted(keyed, key=lambda k: k[0])]


def detour_trajectory(robot, path: np.ndarray, q_start: np.ndarray, dt: float,
                      tolerance: float) -> np.ndarray:
    """The joint states (T, 2n) along an end-effector ``path`` (T, 3) [m]: inverse kinematics
    seeded at q_start (n,), which stays the first configuration."""
    q = np.array(robot.ik_trajectory(path, seed=q_start, tol=tolerance).q, dtype=float)
    q[0] = q_start
    return np.concatenate([q, joint_velocities(q, dt)], axis=1)
