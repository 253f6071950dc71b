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
  height, as in scenes) likewise;
- TriangleMesh(vertices, faces): a ``coal.BVHModelOBBRSS`` of its triangles at the identity (coal
  measures the surface: a shape wholly inside a closed mesh, touching no triangle, is apart
  from it for coal, while the planner's distance is negative there);
- PointCloud(points, radius): one ``coal.Sphere`` per point, the cloud's real geometry. These
  are several coal shapes for one scene obstacle: :func:`coal_obstacles` names them
  ``"<name>[<point>]"`` and :func:`coal_obstacle_owners` maps each triple back to its obstacle.

The local x axis of a cylinder or capsule is :func:`scenes.obstacles.axis_frame`'s (both shapes
are symmetric about their axis, so it does not change any distance).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import coal
import numpy as np

from .errors import InvalidArgumentError
from .mesh import TriangleMesh
from .obstacles import Box, Capsule, Cylinder, Obstacle, Sphere, axis_frame
from .point_cloud import PointCloud

SUPPORTED = ("box", "sphere", "cylinder", "capsule", "mesh", "point_cloud")


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
    if isinstance(obstacle, TriangleMesh):
        model = coal.BVHModelOBBRSS()
        model.beginModel(len(obstacle.faces), len(obstacle.vertices))
        model.addVertices(np.asarray(obstacle.vertices, dtype=float))
        model.addTriangles(np.asarray(obstacle.faces, dtype=np.int64))
        model.endModel()
        return model, np.eye(4)
    raise InvalidArgumentError(f"obstacle: expected a scenes Box, Sphere, Cylinder, Capsule or "
                               f"TriangleMesh (a PointCloud is several shapes: coal_parts), got "
                               f"{type(obstacle).__name__}")


def coal_parts(obstacle: Obstacle) -> list[tuple[coal.CollisionGeometry, np.ndarray]]:
    """The coal shapes (and placements (4, 4)) that make up one scene obstacle: one for every
    kind but a PointCloud, one sphere per point for a cloud."""
    if isinstance(obstacle, PointCloud):
        radii = np.broadcast_to(np.asarray(obstacle.radius, dtype=float), (len(obstacle.points),))
        return [(coal.Sphere(float(r)), _homogeneous(np.eye(3), x))
                for x, r in zip(obstacle.points, radii)]
    return [coal_shape(obstacle)]


def _items(obstacles: Any) -> list[Obstacle]:
    """The obstacles of a Scene, a sequence of obstacles, one obstacle or None (checked)."""
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
    return items


def coal_obstacles(obstacles: Any, names: Sequence[str] | None = None
                   ) -> list[tuple[str, coal.CollisionGeometry, np.ndarray]]:
    """(name, coal shape, placement (4, 4)) for every obstacle of a Scene, a sequence of
    obstacles or one obstacle. names: one unique non-empty string per obstacle; default
    "<kind>_<index>" (e.g. "box_0"); a point cloud's spheres are "<name>[<point index>]". An
    empty scene gives an empty list."""
    items = _items(obstacles)
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
    triples = []
    for name, item in zip(names, items):
        parts = coal_parts(item)
        if len(parts) == 1 and not isinstance(item, PointCloud):
            triples.append((name, *parts[0]))
        else:
            triples.extend((f"{name}[{j}]", *part) for j, part in enumerate(parts))
    return triples


def coal_obstacle_owners(obstacles: Any) -> np.ndarray:
    """For each triple of ``coal_obstacles(obstacles)``, in order, the index (int) of the
    obstacle it belongs to (a point cloud gives several triples)."""
    items = _items(obstacles)
    counts = [len(item.points) if isinstance(item, PointCloud) else 1 for item in items]
    return np.repeat(np.arange(len(items)), counts)
