"""Figures of CLAMP plans: the end-effector path in 3-D with the scene's obstacles, the arm
drawn at a few support states and the posterior 95 % tube; the end-effector position against
time with its posterior band (headless matplotlib; PNG files)."""
from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from clamp.errors import ArgumentTypeError, InvalidParameterError
from clamp.prior_plots import covariance_tube
from scenes.plotting import draw_obstacle, set_equal_axes_3d

#: probability mass inside the drawn posterior tube / band
LEVEL = 0.95


def _check_result(result: Any, *fields: str) -> Any:
    """``result`` itself when it has a plan's ``q``, ``ee_path`` and ``fields`` (a clamp
    PlanResult); ArgumentTypeError naming it otherwise."""
    missing = [f for f in ("q", "ee_path", *fields) if not hasattr(result, f)]
    if missing:
        raise ArgumentTypeError(f"result: expected a clamp PlanResult (from clamp.plan), got "
                                f"{type(result).__name__} without {missing}")
    return result


def plot_plan_3d(result: Any, robot: Any, scene: Any = None, *, prior: Any = None,
                 demos: Any = None, arm_states: int = 5, path: str | os.PathLike[str] | None = None,
                 title: str | None = None, others: Sequence[tuple[str, Any]] = (),
                 dpi: int = 120) -> Figure:
    """3-D figure of a plan: end-effector path, arm at ``arm_states`` support states, obstacles.

    result: PlanResult (uses q (T, n), ee_path (T, 3) and, when present, ee_covariance
    (T, 3, 3), drawn as the 95 % posterior tube); prior / demos optional (mean path,
    demonstrations in grey); others: extra (label, PlanResult) paths to compare.
    Writes a PNG to ``path`` if given; returns the figure.
    """
    _check_result(result)
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
    cov = getattr(result, "ee_covariance", None)
    if cov is not None:
        tube = covariance_tube(result.ee_path, cov, LEVEL, resolution=16)
        ax.plot_surface(*np.moveaxis(tube, 2, 0), color="tab:orange", alpha=0.25, linewidth=0,
                        label=f"posterior {LEVEL:.0%} tube")
    ax.plot(*result.ee_path.T, color="tab:orange", lw=2.4, label="plan (end effector)")
    ax.scatter(*result.ee_path[0], color="tab:green", s=36, label="start")
    ax.scatter(*result.ee_path[-1], color="tab:red", s=36, label="end")
    points = np.concatenate([result.ee_path, frames.reshape(-1, 3)])
    set_equal_axes_3d(ax, points, scale=1.1)
    status = "success" if result.success else "failed: " + "; ".join(result.reasons)
    ax.set_title(title or f"CLAMP plan on {getattr(robot, 'name', 'robot')} ({status})", fontsize=9)
    ax.legend(loc="upper left", fontsize=7)
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig


def plot_plan_uncertainty(result: Any, path: str | os.PathLike[str] | None = None,
                          title: str | None = None, dpi: int = 120) -> Figure:
    """End-effector position x, y, z [m] against time [s] with the posterior 95 % band
    (+- 1.96 standard deviations from ``result.ee_covariance``), one panel per axis."""
    std = _check_result(result, "ee_std").ee_std
    if std is None:
        raise InvalidParameterError("result: no posterior covariance (plan with covariance=True)")
    fig = Figure(figsize=(7.5, 6.0))
    axes = fig.subplots(3, 1, sharex=True)
    z = 1.959963984540054
    for k, (ax, name) in enumerate(zip(axes, "xyz")):
        ax.fill_between(result.time, result.ee_path[:, k] - z * std[:, k],
                        result.ee_path[:, k] + z * std[:, k], color="tab:orange", alpha=0.3,
                        label=f"posterior {LEVEL:.0%} band")
        ax.plot(result.time, result.ee_path[:, k], color="tab:orange", lw=1.5, label="plan")
        ax.set_ylabel(f"{name} [m]")
    axes[0].legend(loc="best", fontsize=7)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(title or f"end-effector position and posterior uncertainty "
                      f"(largest std {1e3 * std.max():.2g} mm)", fontsize=9)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig
