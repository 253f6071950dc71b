"""A point cloud obstacle: balls of a radius about N points (a depth camera's cloud, an array
of spheres; :meth:`PointCloud.from_depth` makes one from a depth image).

Signed distance of p: ``min_i |p - x_i| - r_i`` (exact for the union of the balls outside them,
and at least the depth inside, the usual sphere-set distance). With one radius for every
point the nearest point decides (a k-d tree's nearest neighbour, ``scipy.spatial.cKDTree``);
with a radius per point the points within reach are searched. Gradient: the unit vector from
the nearest point's centre (+x at a centre).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .depth import DEPTH_RADIUS, ROBOT_MARGIN, depth_points
from .errors import InvalidObstacleError
from .nearest import ball_pairs
from .obstacles import IndexedObstacle
from skillplan.validation import MAX_COORDINATE, as_array, as_scalar, as_shaped


def _unit_from(offset: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Unit vectors (M,3) of offsets (M,3) of lengths (M,); +x where the length is 0."""
    unit = np.zeros_like(offset)
    apart = length > 0.0
    unit[apart] = offset[apart] / length[apart, None]
    unit[~apart, 0] = 1.0
    return unit


class PointCloud(IndexedObstacle):
    """Balls of ``radius`` [m] (one number, or (N,) one per point) about ``points`` (N,3) [m]."""

    kind = "point_cloud"

    def __init__(self, points: Any, radius: Any):
        points = as_shaped(points, "PointCloud points", (None, 3), InvalidObstacleError, MAX_COORDINATE)
        if not len(points):
            raise InvalidObstacleError("PointCloud points: expected at least one point (N >= 1, "
                                       "shape (N, 3)), got an empty array")
        if np.ndim(radius) == 0:
            radius = as_scalar(radius, "PointCloud radius", maximum=MAX_COORDINATE,
                               strictly_positive=True, error=InvalidObstacleError)
        else:
            radius = as_shaped(radius, "PointCloud radius", (len(points),), InvalidObstacleError,
                               MAX_COORDINATE)
            if np.any(radius <= 0.0):
                raise InvalidObstacleError(f"PointCloud radius: expected positive radii [m], got "
                                           f"{float(radius.min())}")
            radius.setflags(write=False)
        points.setflags(write=False)
        self.points = points
        self.radius = radius
        self._tree = cKDTree(points)
        self._largest = float(np.max(radius))

    @classmethod
    def from_depth(cls, depth: Any, intrinsics: Any, camera_pose: Any, *, depth_scale: float = 1.0,
                   roi: Any = None, voxel: float | None = None, radius: Any = DEPTH_RADIUS,
                   robot: Any = None, q: Any = None, robot_margin: float = ROBOT_MARGIN) -> "PointCloud":
        """The cloud a depth camera sees, in the robot's base frame (:mod:`scenes.depth`).

        depth (H, W): metres, or integers (a 16-bit image) times ``depth_scale`` [m per unit,
        0.001 for millimetres]; pixels of 0, NaN or inf are dropped. intrinsics: pinhole fx, fy,
        cx, cy [px] (a 3x3 K, a dict or a sequence). camera_pose (4, 4): the camera's optical
        frame (z forward, x right, y down) -> robot base. roi (2, 3): keep the points inside
        this axis-aligned box [m] of the robot frame. voxel [m]: one point per occupied voxel
        (the centroid of its points). radius [m]: the balls about the points (one number or
        (N,)). robot, q (n,) [rad]: drop the points within ``robot_margin`` [m] of the robot's
        URDF collision geometry at q (coal), the arm's own pixels. InvalidArgumentError names
        a bad argument; InvalidObstacleError when no point is left.
        """
        points = depth_points(depth, intrinsics, camera_pose, depth_scale=depth_scale, roi=roi,
                              voxel=voxel, robot=robot, q=q, robot_margin=robot_margin)
        if not len(points):
            raise InvalidObstacleError("PointCloud.from_depth: no point left (no valid pixel, none "
                                       "in roi, or all of them the robot's); see the INFO log")
        return cls(points, radius)

    def _evaluate_within(self, coords: np.ndarray, gradient: bool, max_distance: float
                         ) -> tuple[np.ndarray, np.ndarray | None]:
        points = np.ascontiguousarray(coords.T)
        d = np.full(len(points), np.inf)
        if np.ndim(self.radius) == 0:
            dist, j = self._tree.query(points, k=1, distance_upper_bound=max_distance + self.radius + 1e-9)
            near = np.flatnonzero(np.isfinite(dist))
            p, j, length = near, j[near], dist[near]
            d[p] = length - self.radius
        else:
            if math.isfinite(max_distance):
                reach = np.full(len(points), max_distance + self._largest)
            else:  # the nearest centre bounds the distance: search within that bound
                dist, j = self._tree.query(points, k=1)
                reach = dist - self.radius[j] + self._largest
            p, j = ball_pairs(self._tree, points, reach + 1e-9)
            length = np.linalg.norm(points[p] - self.points[j], axis=1)
            value = length - self.radius[j]
            order = np.lexsort((value, p))          # per point, least value first
            first = order[np.r_[True, p[order][1:] != p[order][:-1]]] if len(p) else order
            p, j, length = p[first], j[first], length[first]
            d[p] = value[first]
        if not gradient:
            return d, None
        g = np.zeros((len(points), 3))
        g[p] = _unit_from(points[p] - self.points[j], length)
        return d, g

    def _balls(self) -> tuple[np.ndarray, float, float]:
        box = self.aabb()
        centre = 0.5 * (box[0] + box[1])
        outer = float(np.max(np.linalg.norm(self.points - centre, axis=1) + self.radius))
        return centre, -np.inf, outer

    def aabb(self) -> np.ndarray:
        lo = np.min(self.points - np.reshape(self.radius, (-1, 1)), axis=0)
        hi = np.max(self.points + np.reshape(self.radius, (-1, 1)), axis=0)
        return np.stack([lo, hi])

    def translated(self, offset: np.ndarray) -> "PointCloud":
        return PointCloud(self.points + as_array(offset, "offset").reshape(3), self.radius)

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays that define the cloud: points (N,3) and radius ((N,) or a scalar) [m]."""
        return {"points": self.points, "radius": np.asarray(self.radius)}

    def to_dict(self) -> dict[str, Any]:
        radius = self.radius if np.ndim(self.radius) == 0 else self.radius.tolist()
        return {"type": self.kind, "points": self.points.tolist(), "radius": radius}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PointCloud):
            return NotImplemented
        return (self.points.shape == other.points.shape and np.allclose(self.points, other.points)
                and np.shape(self.radius) == np.shape(other.radius)
                and np.allclose(self.radius, other.radius))

    def __repr__(self) -> str:
        radius = self.radius if np.ndim(self.radius) == 0 else f"({len(self.points)},) array"
        return f"PointCloud({len(self.points)} points, radius={radius})"
