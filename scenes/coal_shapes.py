"""coal collision shapes of scene obstacles, for checks on a robot's real collision geometry.

``coal_obstacles(scene)`` gives the ``(name, coal.CollisionGeometry, placement)`` triples that
:class:`robots.collision_check.CollisionChecker` takes (``robots`` does not import ``scenes``).
Placements are 4x4 homogeneous matrices in the scene's frame (the robot's base frame), mapping
the shape's local coordinates to the scene's:

- Box(center, size, rotation): ``coal.Box(*size)`` (full edge lengths) at center, rotated by the
  box's rotation (made exactly orthonormal, as the box's own distance does);
- Sphere(center, radius): ``coal.Sphere(radius)`` at center;
- Cylinder(center, radius, height, axis): ``coal.Cylinder(radius, height)`` (coal's axis is
  local z, its length the full height) at center, local z turned onto the axis;
- Capsule(center, radius, height, axis): ``coal.Capsule(radius, height)`` (segment length
  height, as in scenes) likewise.

The local x axis of a cylinder or capsule is :func:`scenes.obstacles.axis_frame`'s (both shapes
are symmetric about their axis, so it does not change any distance).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import coal
import numpy as np

from .errors import InvalidArgumentError
from .obstacles import Box, Capsule, Cylinder, Obstacle, Sphere, axis_frame

SUPPORTED = ("box", "sphere", "cylinder", "capsule")


def _homogeneous(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    placement = np.eye(4)
    placement[:3, :3] = rotation
    placement[:3, 3] = translation
    return placement


def coal_shape(obstacle: Obstacle) -> tuple[coal.CollisionGeometry, np.ndarray]:
    """The coal shape of one scene obstacle and its placement (4, 4) in the scene frame.

    Raises InvalidArgumentError naming ``obstacle`` for anything but Box, Sphere, Cylinder, Capsule.
    """
    if isinstance(obstacle, Box):
        rotation = np.eye(3)
        if obstacle.rotation is not None:  # nearest exact rotation (polar factor)
            u, _, vt = np.linalg.svd(np.asarray(obstacle.rotation, dtype=float))
            rotation = u @ vt
        return coal.Box(*(float(s) for s in obstacle.size)), _homogeneous(rotation, obstacle.center)
    if isinstance(obstacle, Sphere):
        return coal.Sphere(float(obstacle.radius)), _homogeneous(np.eye(3), obstacle.center)
    if isinstance(obstacle, Cylinder):
        return (coal.Cylinder(float(obstacle.radius), float(obstacle.height)),
                _homogeneous(axis_frame(np.asarray(obstacle.axis, dtype=float)), obstacle.center))
    if isinstance(obstacle, Capsule):
        return (coal.Capsule(float(obstacle.radius), float(obstacle.height)),
                _homogeneous(axis_frame(np.asarray(obstacle.axis, dtype=float)), obstacle.center))
    raise InvalidArgumentError(f"obstacle: expected a scenes Box, Sphere, Cylinder or Capsule, "
                               f"got {type(obstacle).__name__}")


def coal_obstacles(obstacles: Any, names: Sequence[str] | None = None
                   ) -> list[tuple[str, coal.CollisionGeometry, np.ndarray]]:
    """(name, coal shape, placement (4, 4)) for every obstacle of a Scene, a sequence of
    obstacles or one obstacle. names: one unique non-empty string per obstacle; default
    "<kind>_<index>" (e.g. "box_0"). An empty scene gives an empty list."""
    if isinstance(obstacles, Obstacle):
        items = [obstacles]
    elif hasattr(obstacles, "obstacles") and not isinstance(obstacles, (str, bytes)):
        items = list(obstacles.obstacles)                      # a Scene
    elif obstacles is None:
        items = []
    elif isinstance(obstacles, Sequence) and not isinstance(obstacles, (str, bytes)):
        items = list(obstacles)
    else:
        raise InvalidArgumentError(f"obstacles: expected a Scene, a sequence of obstacles or one obstacle, "
                                   f"got {type(obstacles).__name__}")
    for i, item in enumerate(items):
        if not isinstance(item, Obstacle):
            raise InvalidArgumentError(f"obstacles[{i}]: expected a scenes obstacle, got {type(item).__name__}")
    if names is None:
        names = [f"{item.kind}_{i}" for i, item in enumerate(items)]
    else:
        if isinstance(names, (str, bytes)) or not isinstance(names, Sequence):
            raise InvalidArgumentError(f"names: expected a sequence of strings, got {type(names).__name__}")
        names = list(names)
        if len(names) != len(items):
            raise InvalidArgumentError(f"names: expected {len(items)} names (one per obstacle), got {len(names)}")
        if not all(isinstance(n, str) and n for n in names) or len(set(names)) != len(names):
            raise InvalidArgumentError("names: expected unique non-empty strings")
    return [(name, *coal_shape(item)) for name, item in zip(names, items)]
