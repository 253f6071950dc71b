"""Drawing scenes in matplotlib 3-D axes: obstacles, and equal-aspect limits around points."""
from __future__ import annotations

from typing import Any

import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from .obstacles import Box, Cylinder, Sphere

_BOX_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))


def _box_corners(center: np.ndarray, size: np.ndarray, rotation: np.ndarray | None) -> np.ndarray:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    local = 0.5 * signs * size
    return center + (local if rotation is None else local @ np.asarray(rotation).T)


def draw_obstacle(ax: Any, obstacle: Any, color: str = "tab:red", alpha: float = 0.3) -> None:
    """Draw a Box, Sphere or Cylinder on a 3-D matplotlib axis (others: their bounding box)."""
    if isinstance(obstacle, Sphere):
        u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
        pts = obstacle.center + obstacle.radius * np.stack(
            [np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
        ax.plot_surface(pts[..., 0], pts[..., 1], pts[..., 2], color=color, alpha=alpha, lw=0)
        return
    if isinstance(obstacle, Cylinder):
        axis = np.asarray(obstacle.axis, dtype=float)
        helper = np.array([1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.array([0, 1.0, 0])
        e1 = np.cross(axis, helper)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
        a, h = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(-0.5, 0.5, 2))
        pts = (obstacle.center + obstacle.radius * (np.cos(a)[..., None] * e1 + np.sin(a)[..., None] * e2)
               + obstacle.height * h[..., None] * axis)
        ax.plot_surface(pts[..., 0], pts[..., 1], pts[..., 2], color=color, alpha=alpha, lw=0)
        return
    if isinstance(obstacle, Box):
        corners = _box_corners(obstacle.center, obstacle.size, obstacle.rotation)
    else:
        lo, hi = obstacle.aabb()
        corners = _box_corners(0.5 * (lo + hi), hi - lo, None)
    faces = [[corners[i] for i in face] for face in _BOX_FACES]
    ax.add_collection3d(Poly3DCollection(faces, facecolor=color, alpha=alpha, edgecolor="0.3",
                                         linewidth=0.4))


def set_equal_axes_3d(ax: Any, points: np.ndarray, scale: float = 1.0) -> None:
    """Equal-aspect x/y/z limits [m] centred on ``points`` (P, 3), spanning ``scale`` times
    their largest extent; labels the axes in metres."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * scale * max(float(np.max(hi - lo)), 1e-9)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
