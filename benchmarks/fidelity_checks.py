"""Independent checks of a plan for the skill-fidelity benchmark (issue 19).

These checks judge a joint trajectory without the planner's verdict code (``clamp.planning.verdict``,
``clamp.planning.clearance``, ``robots.collision_check``): the geometry goes straight to Pinocchio's
collision model of the URDF and coal, at a dense subdivision of the path.

- **Obstacles** (:class:`GeometryCheck`): every collision object of the URDF that moves with
  a joint against every obstacle, at ``PER_SEGMENT`` configurations per segment between
  support states (joint-space linear interpolation), by ``pinocchio.computeCollisions`` (coal's
  exact narrow phase on the meshes / primitives). Geometry fixed to the world (the base) is
  left out: no plan can move it. A mesh is a surface: an obstacle wholly inside a link mesh
  touches no triangle, but a path from a clear start cannot get there without crossing the
  surface, which the dense subdivision sees.
- **Self-collision** (:func:`self_collision_pairs`): pairs of collision objects on links that
  are not adjacent. Rule: objects are *adjacent* when they hang off the same joint or off a
  joint and its parent joint in the kinematic tree (the base, joint 0, is the parent of the
  first joint); pairs that already collide at ``robot.neutral_configuration()`` (the middle of
  the limits) are left out as well, for URDFs whose meshes overlap by design (none on the
  Jaco or the Sawyer: 35 and 47 pairs are checked). Every other
  pair, the base included, is checked at the same dense subdivision.
- **Completion** (:func:`end_error`): the plan's last end-effector point lies within
  ``END_SPREAD_FACTOR`` x the demonstrations' end spread (the largest distance of their end
  points from their mean, at least ``END_SPREAD_FLOOR``) of the demonstrations' mean end
  point (issue 19's definition as ``clamp.prior.skill`` documents it; coded again here).
- **Stays with the skill** (:func:`skill_deviation`): at each state, the end-effector distance
  from the prior mean conditioned on the plan's start (the skill carried to this start), in
  units of the demonstrations' spread at that state (the largest distance of a demonstration
  from their mean, at least ``END_SPREAD_FLOOR``); the plan leaves the skill when a state is
  more than ``TIGHT_SIGMA`` spreads away: where the demonstrations agree that is a few
  centimetres, where they vary a long detour.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from scenes.errors import InvalidArgumentError

PER_SEGMENT = 10            # configurations checked per segment between support states
END_SPREAD_FACTOR = 2.0     # completion tolerance in units of the demonstrations' end spread
END_SPREAD_FLOOR = 0.005    # [m] least spread of the demonstrations (end and per state)
TIGHT_SIGMA = 4.0           # deviation (in demonstration spreads) beyond which the skill is left


def subdivide(q: np.ndarray, per_segment: int = PER_SEGMENT) -> tuple[np.ndarray, np.ndarray]:
    """Configurations (K, n) on the joint-space segments between the rows of q (T, n),
    ``per_segment`` per segment (the support states included, K = (T-1) per_segment + 1), and
    their fractional state indices (K,)."""
    q = np.asarray(q, dtype=float)
    s = np.arange((len(q) - 1) * per_segment + 1) / per_segment
    i = np.minimum(np.floor(s).astype(int), len(q) - 2)
    w = (s - i)[:, None]
    return (1.0 - w) * q[i] + w * q[i + 1], s


def _axis_rotation(axis: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) taking +z onto the unit vector ``axis``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    v, c = np.cross(z, axis), float(z @ axis)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def obstacle_geometry(obstacle: Any) -> tuple[coal.CollisionGeometry, pin.SE3]:
    """The coal shape of a scenes Box / Sphere / Cylinder / Capsule and its placement in the
    robot's base frame (the scene frame)."""
    from scenes import Box, Capsule, Cylinder, Sphere
    centre = np.asarray(obstacle.center, dtype=float)
    if isinstance(obstacle, Box):
        rotation = np.eye(3) if obstacle.rotation is None else np.asarray(obstacle.rotation)
        return coal.Box(*map(float, obstacle.size)), pin.SE3(rotation, centre)
    if isinstance(obstacle, Sphere):
        return coal.Sphere(float(obstacle.radius)), pin.SE3(np.eye(3), centre)
    if isinstance(obstacle, (Cylinder, Capsule)):
        kind = coal.Cylinder if isinstance(obstacle, Cylinder) else coal.Capsule
        return (kind(float(obstacle.radius), float(obstacle.height)),
                pin.SE3(_axis_rotation(obstacle.axis), centre))
    raise InvalidArgumentError(f"obstacle: expected a scenes Box, Sphere, Cylinder or Capsule, "
                               f"got {type(obstacle).__name__}")


def base_placement(robot: Any) -> pin.SE3:
    """Placement of the robot's base frame (the frame of ``robot.fk`` and of the scenes) in
    Pinocchio's world frame (fixed to the root, so any configuration gives it)."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.to_pinocchio(robot.neutral_configuration()))
    frame = [f.name for f in model.frames].index(robot.base_frame)
    return pin.SE3(data.oMf[frame])


def _adjacent(model: pin.Model, a: int, b: int) -> bool:
    return a == b or model.parents[a] == b or model.parents[b] == a


def self_collision_pairs(robot: Any) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of ``robot.collision_model`` objects checked for self-collision:
    not adjacent (module docstring) and apart at the neutral configuration."""
    model, geometry = robot.model, robot.collision_model
    objects = geometry.geometryObjects
    candidates = [(i, j) for i in range(len(objects)) for j in range(i + 1, len(objects))
                  if not _adjacent(model, objects[i].parentJoint, objects[j].parentJoint)]
    check = pin.GeometryModel()
    for obj in objects:
        check.addGeometryObject(pin.GeometryObject(obj))
    for i, j in candidates:
        check.addCollisionPair(pin.CollisionPair(i, j))
    data, geometry_data = model.createData(), check.createData()
    pin.computeCollisions(model, data, check, geometry_data,
                          robot.to_pinocchio(robot.neutral_configuration()), False)
    return [pair for pair, result in zip(candidates, geometry_data.collisionResults)
            if not result.isCollision()]


@dataclass(frozen=True)
class Contact:
    """The first configuration of a path in collision: ``kind`` "obstacle" or "self",
    fractional state index, and the two geometry names (robot object, obstacle / object)."""

    kind: str
    state: float
    first: str
    second: str

    def __str__(self) -> str:
        return f"{self.kind}: {self.first} / {self.second} at state {self.state:.1f}"


class GeometryCheck:
    """Obstacle and self-collision check of joint paths for one robot and one set of obstacles
    (module docstring), on the URDF collision geometry with Pinocchio + coal."""

    def __init__(self, robot: Any, obstacles: Sequence[Any] = ()) -> None:
        self.robot = robot
        source = robot.collision_model
        self.geometry = pin.GeometryModel()
        for obj in source.geometryObjects:
            self.geometry.addGeometryObject(pin.GeometryObject(obj))
        base = base_placement(robot)
        moving = [k for k, obj in enumerate(source.geometryObjects) if obj.parentJoint != 0]
        self.obstacle_names = []
        self.kinds: list[str] = []
        for index, obstacle in enumerate(obstacles):
            shape, placement = obstacle_geometry(obstacle)
            name = f"{type(obstacle).__name__.lower()}_{index}"
            k = self.geometry.addGeometryObject(pin.GeometryObject(name, 0, base * placement, shape))
            self.obstacle_names.append(name)
            for g in moving:
                self.geometry.addCollisionPair(pin.CollisionPair(g, k))
                self.kinds.append("obstacle")
        for i, j in self_collision_pairs(robot):
            self.geometry.addCollisionPair(pin.CollisionPair(i, j))
            self.kinds.append("self")
        self._data = robot.model.createData()
        self._geometry_data = self.geometry.createData()

    def colliding_pairs(self, q: np.ndarray) -> np.ndarray:
        """Whether each collision pair collides (P,) at one configuration q (n,)."""
        pin.computeCollisions(self.robot.model, self._data, self.geometry, self._geometry_data,
                              self.robot.to_pinocchio(q), False)
        return np.array([r.isCollision() for r in self._geometry_data.collisionResults])

    def first_contacts(self, q: np.ndarray, per_segment: int = PER_SEGMENT) -> dict[str, Contact]:
        """The first contact of each kind ("obstacle", "self") along the path q (T, n), checked
        at ``per_segment`` configurations per segment; kinds without contact are absent."""
        configurations, states = subdivide(q, per_segment)
        kinds = np.array(self.kinds)
        found: dict[str, Contact] = {}
        for config, state in zip(configurations, states):
            colliding = self.colliding_pairs(config)
            if not colliding.any():
                continue
            for p in np.flatnonzero(colliding):
                kind = str(kinds[p])
                if kind not in found:
                    pair = self.geometry.collisionPairs[int(p)]
                    names = [self.geometry.geometryObjects[g].name for g in (pair.first, pair.second)]
                    found[kind] = Contact(kind, float(state), *names)
            if len(found) == len(set(self.kinds)):
                break
        return found


def end_error(ee_path: np.ndarray, demo_ends: np.ndarray) -> tuple[float, float]:
    """Distance [m] of the path's (T, 3) last point from the mean of the demonstrations' end
    points (M, 3), and the completion tolerance [m]: ``END_SPREAD_FACTOR`` x their largest
    distance from their mean, at least ``END_SPREAD_FLOOR``. The skill is completed when
    distance <= tolerance."""
    demo_ends = np.asarray(demo_ends, dtype=float)
    mean = demo_ends.mean(axis=0)
    spread = float(np.linalg.norm(demo_ends - mean, axis=1).max())
    distance = float(np.linalg.norm(np.asarray(ee_path)[-1] - mean))
    return distance, END_SPREAD_FACTOR * max(spread, END_SPREAD_FLOOR)


def skill_deviation(prior: Any, demos: np.ndarray, ee_path: np.ndarray, start: np.ndarray
                    ) -> np.ndarray:
    """Per-state deviation (T,) of the end-effector path (T, 3) [m] from the prior mean
    conditioned on ``start`` (3,) [m], in units of the demonstrations' (positions (M, T, 3))
    spread at each state (module docstring)."""
    from clamp import condition_prior
    conditioned = condition_prior(prior, [(0, np.asarray(start, dtype=float))])
    demos = np.asarray(demos, dtype=float)
    spread = np.linalg.norm(demos - demos.mean(axis=0), axis=2).max(axis=0)
    distance = np.linalg.norm(np.asarray(ee_path) - np.asarray(conditioned.mean)[:, :3], axis=1)
    return distance / np.maximum(spread, END_SPREAD_FLOOR)


def joint_path_length(q: np.ndarray) -> float:
    """Sum of the absolute joint steps of q (T, n) [rad]."""
    return float(np.abs(np.diff(np.asarray(q), axis=0)).sum())


def rotation_from_start(robot: Any, q: np.ndarray) -> np.ndarray:
    """Angle [rad] (T,) of the end-effector orientation at each state of q (T, n) away from
    its orientation at the first state."""
    rotation, _ = robot.ee_rotation(np.asarray(q))
    relative = np.einsum("ji,tjk->tik", rotation[0], rotation)     # R_0^T R_t
    cos = (np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0
    skew = relative - relative.transpose(0, 2, 1)
    sin = 0.5 * np.linalg.norm(skew[:, [2, 0, 1], [1, 2, 0]], axis=1)
    return np.arctan2(sin, cos)
