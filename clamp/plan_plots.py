"""Figures of CLAMP plans: the end-effector path in 3-D with the scene's obstacles and the arm
drawn at a few support states (headless matplotlib; PNG files)."""
from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

_BOX_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))


def _box_corners(center: np.ndarray, size: np.ndarray, rotation: np.ndarray | None) -> np.ndarray:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    local = 0.5 * signs * size
    return center + (local if rotation is None else local @ np.asarray(rotation).T)


def draw_obstacle(ax: Any, obstacle: Any, color: str = "tab:red", alpha: float = 0.3) -> None:
    """Draw a scenes Box, Sphere or Cylinder on a 3-D axis (others: their bounding box)."""
    kind = type(obstacle).__name__
    if kind == "Sphere":
        u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
        pts = obstacle.center + obstacle.radius * np.stack(
            [np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
        ax.plot_surface(pts[..., 0], pts[..., 1], pts[..., 2], color=color, alpha=alpha, lw=0)
        return
    if kind == "Cylinder":
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
    if kind == "Box":
        corners = _box_corners(obstacle.center, obstacle.size, obstacle.rotation)
    else:
        lo, hi = obstacle.aabb()
        corners = _box_corners(0.5 * (lo + hi), hi - lo, None)
    faces = [[corners[i] for i in face] for face in _BOX_FACES]
    ax.add_collection3d(Poly3DCollection(faces, facecolor=color, alpha=alpha, edgecolor="0.3",
                                         linewidth=0.4))


def plot_plan_3d(result: Any, robot: Any, scene: Any = None, *, prior: Any = None,
                 demos: Any = None, arm_states: int = 5, path: str | os.PathLike[str] | None = None,
                 title: str | None = None, others: Sequence[tuple[str, Any]] = (),
                 dpi: int = 120) -> Figure:
    """3-D figure of a plan: end-effector path, arm at ``arm_states`` support states, obstacles.

    result: PlanResult (uses q (T, n) and ee_path (T, 3)); prior / demos optional (mean path,
    demonstrations in grey); others: extra (label, PlanResult) paths to compare.
    Writes a PNG to ``path`` if given; returns the figure.
    """
    fig = Figure(figsize=(7.5, 6.5))
    ax = fig.add_subplot(projection="3d")
    if scene is not None:
        for obstacle in getattr(scene, "obstacles", ()):
            draw_obstacle(ax, obstacle)
    if demos is not None:
        for m, demo in enumerate(np.asarray(demos.positions)):
            ax.plot(*demo.T, color="0.6", lw=0.7, label="demonstrations" if m == 0 else None)
    if prior is not None:
        ax.plot(*np.asarray(prior.mean)[:, :3].T, color="tab:blue", lw=1.2, ls="--",
                label="prior mean")
    for label, other in others:
        ax.plot(*other.ee_path.T, lw=1.4, ls=":", label=label)
    T = len(result.q)
    frames = robot.frame_positions(result.q[np.linspace(0, T - 1, max(arm_states, 2)).astype(int)])
    for k, arm in enumerate(frames):
        ax.plot(*arm.T, color="0.2", lw=2.0, marker="o", ms=2.5, alpha=0.35 + 0.5 * k / len(frames),
                label="arm" if k == 0 else None)
    ax.plot(*result.ee_path.T, color="tab:orange", lw=2.4, label="plan (end effector)")
    ax.scatter(*result.ee_path[0], color="tab:green", s=36, label="start")
    ax.scatter(*result.ee_path[-1], color="tab:red", s=36, label="end")
    points = np.concatenate([result.ee_path, frames.reshape(-1, 3)])
    centre, half = points.mean(axis=0), 0.55 * np.ptp(points, axis=0).max()
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    status = "success" if result.success else "failed: " + "; ".join(result.reasons)
    ax.set_title(title or f"CLAMP plan on {getattr(robot, 'name', 'robot')} ({status})", fontsize=9)
    ax.legend(loc="upper left", fontsize=7)
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig
