"""The verdict's clearance: distances from the robot's own collision geometry to the scene.

The optimiser plans with collision spheres; the verdict never trusts them. :func:`check_clearance`
measures a joint trajectory on the robot's URDF collision geometry (coal, through
:class:`robots.collision_check.CollisionChecker`) against the scene's exact obstacles, at every
support state and in between (segments subdivided so that no link point moves more than
:data:`MAX_MOTION` between checks, and the motion between checks certified to the checker's
RESOLUTION, 0.2 mm: a clear verdict means no link comes more than 0.1 mm into an obstacle
anywhere along the motion). A check that cannot be made (coal fails on a geometry) gives a
report with a fault, which the verdict states as its reason (worded by :mod:`robots.contact`, as
the self-collision check's). A robot without collision geometry falls back to its
collision spheres (``report.geometry == "spheres"``, which the result repeats).

One checker is built per (robot, scene) and kept while both live (a scene is immutable), so a
planner that checks several candidate plans in one scene pays for the set-up once.
"""
from __future__ import annotations

import logging
import weakref
from typing import Any

import numpy as np

from clamp.planning.request import has_obstacles
from robots.collision_check import RESOLUTION, CollisionChecker, CollisionReport
from robots.contact import Contact, collision_reason, describe_contact
from robots.errors import CollisionCheckError
from scenes.coal_shapes import coal_obstacle_owners, coal_obstacles

log = logging.getLogger(__name__)

#: describe_contact and collision_reason: robots.contact's wording, re-exported
__all__ = ["checker", "check_clearance", "state_clearance", "contact_obstacle", "pusher",
           "describe_contact", "collision_reason", "MAX_MOTION"]

#: [m] largest motion of any link point between two checked configurations of a segment
MAX_MOTION = 0.005

_CHECKERS: "weakref.WeakKeyDictionary[Any, weakref.WeakKeyDictionary]" = weakref.WeakKeyDictionary()


def checker(robot: Any, scene: Any) -> CollisionChecker:
    """The collision checker of ``robot`` against the obstacles of ``scene`` (cached per pair;
    obstacles are named "<kind>_<index>" in the scene's order, e.g. "box_0")."""
    per_robot = _CHECKERS.setdefault(scene, weakref.WeakKeyDictionary())
    found = per_robot.get(robot)
    if found is None:
        found = per_robot[robot] = CollisionChecker(robot, coal_obstacles(scene))
    return found


def check_clearance(robot: Any, scene: Any, q: np.ndarray, time: np.ndarray | None = None,
                    margin: float = 0.0) -> CollisionReport | None:
    """Real-geometry check of q (T, n) [rad] (linear in joint space between states) against the
    scene; time (T,) [s] only dates the nearest contact; ``collision`` is a clearance below
    ``margin`` [m] (the required clearance, ``CheckConfig.min_clearance``; exact below it).
    None when the scene has no obstacles."""
    if not has_obstacles(scene):
        return None
    def failed(fault: str) -> CollisionReport:
        log.warning("collision check failed: %s", fault)
        return CollisionReport.failed("urdf", 0.0, MAX_MOTION, len(q), fault)

    try:
        found = checker(robot, scene)
    except CollisionCheckError as error:          # a collision mesh coal cannot use
        return failed(str(error))
    try:
        return found.check(q, time, margin=margin, max_motion=MAX_MOTION, resolution=RESOLUTION)
    except CollisionCheckError as error:          # a trajectory too long to subdivide
        return failed(f"the plan could not be checked for collisions: {error}")


def state_clearance(robot: Any, scene: Any, q: np.ndarray, cap: float
                    ) -> tuple[np.ndarray, str]:
    """Least distance (T,) [m] of the robot's collision geometry to the scene at each support
    state of q (T, n): exact below ``cap`` [m], ``cap`` at and above it (and everywhere without
    obstacles); and the geometry measured ("urdf", or "spheres" for a robot without one)."""
    if not has_obstacles(scene):
        return np.full(len(q), cap), "urdf"
    # margin = cap: every state closer than the cap gets its exact distance; a motion bound
    # larger than any step checks the support states only
    report = checker(robot, scene).check(q, margin=cap, max_motion=1e3, resolution=None)
    return np.minimum(report.state_distance, cap), report.geometry


def contact_obstacle(robot: Any, scene: Any, contact: Contact) -> Any:
    """The scene obstacle a contact of :func:`check_clearance` names."""
    triple = checker(robot, scene).obstacle_names.index(contact.obstacle)
    return scene.obstacles[coal_obstacle_owners(scene)[triple]]


def pusher(scene: Any, reference: np.ndarray, path: np.ndarray, epsilon: float):
    """describe(state) -> what pushed ``path`` (T, 3) away from ``reference`` (T, 3) at that
    state: the obstacle nearest to where the skill goes, when it is within the plan's departure
    plus the safety distance ``epsilon`` [m] ("box_0 (the skill's path runs 27 mm inside it
    there)"), else that no obstacle is near; None without obstacles."""
    if not has_obstacles(scene):
        return None

    def describe(state: int) -> str:
        point = reference[state][None]
        gaps = [float(o.distance(point)[0]) for o in scene.obstacles]
        k = int(np.argmin(gaps))
        name = f"{scene.obstacles[k].kind}_{k}"
        if gaps[k] > np.linalg.norm(path[state] - reference[state]) + epsilon:
            return (f"no obstacle (the nearest, {name}, is {1000 * gaps[k]:.0f} mm from the "
                    "skill's path there): the plan's other factors")
        where = (f"the skill's path runs {-1000 * gaps[k]:.0f} mm inside it there" if gaps[k] < 0
                 else f"{1000 * gaps[k]:.0f} mm from the skill's path there")
        return f"{name} ({where})"
    return describe
