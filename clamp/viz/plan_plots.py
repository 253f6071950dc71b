"""Figures of CLAMP plans (headless matplotlib; bare ``Figure`` objects, PNG files):

- :func:`plot_plan_3d`: end-effector path in 3-D with the obstacles, the arm at a few support
  states and the posterior 95 % tube;
- :func:`plot_top_view`: the same seen from above (x-y plane), obstacles as their footprints;
- :func:`plot_joint_angles`: every joint angle against time, outside its limits shaded;
- :func:`plot_clearance`: the arm's distance to the obstacles against time (on the collision
  geometry the verdict judges, and the optimiser's spheres) with the safety distance epsilon
  and contact marked;
- :func:`plot_plan_uncertainty`: end-effector position against time with its posterior band.

Two clocks: a figure against time is drawn on the skill's clock (the plan's support-state times
``result.time``: the demonstrations' time, times the time scale k), or, given ``state_times``
(T,) [s], when the executable trajectory passes each support state (the plan JSON's
``trajectory.state_times``), on the trajectory's clock; the time axis says which
(:func:`plan_clock`).
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.planning.request import as_scene, check_robot
from clamp.validation import as_array, as_count, as_scalar
from clamp.viz.prior_plots import covariance_tube
from scenes.plotting import draw_obstacle, set_equal_axes_3d
from clamp.factors import OrientationFamily
from clamp.planning.clearance import state_clearance
from clamp.planning.verdict import sphere_clearance

#: probability mass inside the drawn posterior tube / band
LEVEL = 0.95
#: the time axis on each clock (:func:`plan_clock`)
CLOCK_AXES = {"skill": "skill time [s]", "trajectory": "trajectory time [s]"}


def plan_clock(result: Any, state_times: Any = None) -> tuple[np.ndarray, str]:
    """The times (T,) [s] of a plan's support states and the axis label naming their clock: the
    skill's (``result.time``) when ``state_times`` is None, else ``state_times`` (T,) [s]: when
    the executable trajectory passes each state (non-decreasing, from 0), on its clock."""
    if state_times is None:
        return np.asarray(result.time, dtype=float), CLOCK_AXES["skill"]
    times = as_array(state_times, "state_times", (len(result.q),))
    if times[0] < 0.0 or np.any(np.diff(times) < 0.0):
        raise InvalidParameterError("state_times: expected non-decreasing times [s] from 0 (when the "
                                    "trajectory passes each support state)")
    return times, CLOCK_AXES["trajectory"]


def _check_result(result: Any, *fields: str) -> Any:
    """``result`` itself when it has a plan's ``q``, ``ee_path`` and ``fields`` (a clamp
    PlanResult); ClampTypeError naming it otherwise."""
    missing = [f for f in ("q", "ee_path", *fields) if not hasattr(result, f)]
    if missing:
        raise ClampTypeError(f"result: expected a clamp PlanResult (from clamp.plan), got "
                                f"{type(result).__name__} without {missing}")
    return result


def _check_inputs(result: Any, robot: Any, scene: Any = None) -> Any:
    """Checks a figure's plan (:func:`_check_result`) and robot; returns the scene as a
    scenes.Scene (or None), from anything :func:`clamp.plan` accepts as one."""
    _check_result(result)
    check_robot(robot)
    return as_scene(scene)


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
    scene = _check_inputs(result, robot, scene)
    arm_states = as_count(arm_states, "arm_states", minimum=0)
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
                          title: str | None = None, dpi: int = 120, *,
                          state_times: Any = None) -> Figure:
    """End-effector position x, y, z [m] against time [s] (on the clock of ``state_times``:
    :func:`plan_clock`) with the posterior 95 % band (+- 1.96 standard deviations from
    ``result.ee_covariance``), one panel per axis."""
    std = _check_result(result, "ee_std").ee_std
    t, axis = plan_clock(result, state_times)
    if std is None:
        raise InvalidParameterError("result: no posterior covariance (plan with covariance=True)")
    fig = Figure(figsize=(7.5, 6.0))
    axes = fig.subplots(3, 1, sharex=True)
    z = 1.959963984540054
    for k, (ax, name) in enumerate(zip(axes, "xyz")):
        ax.fill_between(t, result.ee_path[:, k] - z * std[:, k],
                        result.ee_path[:, k] + z * std[:, k], color="tab:orange", alpha=0.3,
                        label=f"posterior {LEVEL:.0%} band")
        ax.plot(t, result.ee_path[:, k], color="tab:orange", lw=1.5, label="plan")
        ax.set_ylabel(f"{name} [m]")
    axes[0].legend(loc="best", fontsize=7)
    axes[-1].set_xlabel(axis)
    axes[0].set_title(title or f"end-effector position and posterior uncertainty "
                      f"(largest std {1e3 * std.max():.2g} mm)", fontsize=9)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig


def plot_orientation(result: Any, robot: Any, family: Any,
                     path: str | os.PathLike[str] | None = None, title: str | None = None,
                     dpi: int = 120, *, state_times: Any = None) -> Figure:
    """Angle of the tool from an orientation family's target [deg] against time [s] (on the
    clock of ``state_times``: :func:`plan_clock`) over the whole plan, with the family's window
    shaded and its tolerance; writes a PNG to ``path``."""
    _check_inputs(result, robot)
    t, axis = plan_clock(result, state_times)
    if not isinstance(family, OrientationFamily):
        raise ClampTypeError(f"family: expected a clamp.factors.OrientationFamily, got "
                                f"{type(family).__name__}")
    every = type(family)(np.arange(len(result.q)), tolerance=family.tolerance,
                         axis=family.axis, direction=family.direction,
                         rotation=family.rotation)
    angles = np.degrees(every.angles(robot, result.q))
    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.add_subplot()
    window = t[family.first]
    ax.axvspan(window[0], window[-1], color="tab:green", alpha=0.12, label="constrained window")
    ax.axhline(np.degrees(family.tolerance), color="tab:red", ls="--", lw=1, label="tolerance")
    ax.plot(t, angles, color="tab:blue", lw=1.5, label="angle from target")
    ax.set_xlabel(axis)
    ax.set_ylabel("angle [deg]")
    worst = float(np.max(angles[family.first]))
    ax.set_title(title or f"tool orientation (largest in window {worst:.2f} deg)", fontsize=9)
    ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig


def _obstacle_footprint(ax: Any, obstacle: Any, color: str, label: str | None) -> None:
    """Fill the top-view footprint of any obstacle (points of its bounding box, sampled on a
    grid, that it contains at some height)."""
    lo, hi = np.asarray(obstacle.aabb(), dtype=float)
    pad = 0.05 * (hi - lo) + 1e-4  # the outline closes outside the bounding box
    lo, hi = lo - pad, hi + pad
    x, y, z = (np.linspace(lo[k], hi[k], n) for k, n in ((0, 61), (1, 61), (2, 15)))
    grid = np.stack(np.meshgrid(x, y, z, indexing="ij"), axis=-1)
    inside = obstacle.contains(grid.reshape(-1, 3)).reshape(grid.shape[:3]).any(axis=2)
    ax.contourf(x, y, inside.T.astype(float), levels=[0.5, 1.5], colors=[color], alpha=0.35)
    ax.contour(x, y, inside.T.astype(float), levels=[0.5], colors=[color], linewidths=0.8)
    if label:
        ax.fill([], [], color=color, alpha=0.35, label=label)


def plot_top_view(result: Any, robot: Any, scene: Any = None, *, prior: Any = None,
                  demos: Any = None, arm_states: int = 5, title: str | None = None) -> Figure:
    """Top view (x-y plane, [m], equal axes) of a plan: demonstrations, prior mean, the
    end-effector path, the arm at ``arm_states`` support states, obstacle footprints."""
    scene = _check_inputs(result, robot, scene)
    arm_states = as_count(arm_states, "arm_states", minimum=0)
    fig = Figure(figsize=(8.0, 6.0))
    ax = fig.add_subplot()
    extent = [np.zeros((1, 2)), result.ee_path[:, :2]]
    for k, obstacle in enumerate(getattr(scene, "obstacles", ()) if scene is not None else ()):
        _obstacle_footprint(ax, obstacle, "tab:red", "obstacle (footprint)" if k == 0 else None)
        extent.append(np.asarray(obstacle.aabb(), dtype=float)[:, :2])
    if demos is not None:
        for m, demo in enumerate(np.asarray(demos.positions)):
            ax.plot(demo[:, 0], demo[:, 1], color="0.6", lw=0.7,
                    label="demonstrations" if m == 0 else None)
    if prior is not None:
        mean = np.asarray(prior.mean)
        ax.plot(mean[:, 0], mean[:, 1], color="tab:blue", lw=1.2, ls="--", label="prior mean")
    T = len(result.q)
    frames = robot.frame_positions(result.q[np.linspace(0, T - 1, max(arm_states, 2)).astype(int)])
    for k, arm in enumerate(frames):
        ax.plot(arm[:, 0], arm[:, 1], color="0.2", lw=2.0, marker="o", ms=2.5,
                alpha=0.35 + 0.5 * k / len(frames), label="arm" if k == 0 else None)
    ax.plot(result.ee_path[:, 0], result.ee_path[:, 1], color="tab:orange", lw=2.2,
            label="plan (end effector)")
    ax.scatter(*result.ee_path[0, :2], color="tab:green", s=36, zorder=5, label="start")
    ax.scatter(*result.ee_path[-1, :2], color="tab:red", s=36, zorder=5, label="end")
    ax.scatter(0.0, 0.0, marker="s", color="k", s=30, zorder=5, label="robot base")
    points = np.concatenate(extent + [frames[..., :2].reshape(-1, 2)])
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.08 * float(np.max(hi - lo)) + 1e-3
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(alpha=0.3)
    ax.set_title(title or f"CLAMP plan on {getattr(robot, 'name', 'robot')}: top view", fontsize=10)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def plot_joint_angles(result: Any, robot: Any, title: str | None = None, *,
                      state_times: Any = None) -> Figure:
    """Every joint angle [rad] against time [s] (on the clock of ``state_times``:
    :func:`plan_clock`), one panel per joint; the region outside the joint's position limits
    is shaded (continuous joints: no limits)."""
    _check_inputs(result, robot)
    q = np.asarray(result.q)
    t, axis = plan_clock(result, state_times)
    n = q.shape[1]
    cols = 2 if n <= 8 else 3
    rows = int(np.ceil(n / cols))
    fig = Figure(figsize=(4.0 * cols, 1.9 * rows + 0.8))
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False).ravel()
    names = list(getattr(robot, "joint_names", [f"joint {j + 1}" for j in range(n)]))
    lower, upper = np.asarray(robot.lower_limits), np.asarray(robot.upper_limits)
    for j, ax in enumerate(axes[:n]):
        lo, hi = q[:, j].min(), q[:, j].max()
        finite = [v for v in (lower[j], upper[j]) if np.isfinite(v)]
        lo, hi = min([lo, *finite]), max([hi, *finite])
        pad = 0.12 * max(hi - lo, 0.2)
        view = (lo - pad, hi + pad)
        if np.isfinite(lower[j]):
            ax.axhspan(view[0], lower[j], color="tab:red", alpha=0.18, lw=0)
        if np.isfinite(upper[j]):
            ax.axhspan(upper[j], view[1], color="tab:red", alpha=0.18, lw=0)
        ax.plot(t, q[:, j], color="tab:blue", lw=1.6)
        ax.set_ylim(*view)
        ax.set_ylabel("angle [rad]", fontsize=8)
        ax.set_title(names[j] + ("" if finite else " (continuous: no limits)"), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes[n:]:
        ax.axis("off")
    for ax in axes[max(n - cols, 0):n]:
        ax.set_xlabel(axis)
        ax.tick_params(labelbottom=True)
    from matplotlib.patches import Patch
    from matplotlib.lines import Line2D
    fig.legend([Line2D([], [], color="tab:blue", lw=1.6), Patch(color="tab:red", alpha=0.18)],
               ["plan", "outside the position limits"], loc="upper right", fontsize=8, ncol=2)
    fig.suptitle(title or f"joint angles of {getattr(robot, 'name', 'robot')} against time "
                 f"({'within' if result.within_limits else 'OUTSIDE'} limits)", fontsize=10,
                 x=0.02, ha="left")
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 0.95))
    return fig


def plot_clearance(result: Any, robot: Any, scene: Any, epsilon: float,
                   title: str | None = None, *, state_times: Any = None) -> Figure:
    """Clearance [m] against time [s] at every support state: the distance between the arm's
    collision geometry (the URDF meshes the verdict judges, :mod:`clamp.planning.clearance`; exact up to
    a cap of max(3 epsilon, 15 cm), drawn at the cap beyond it) and the obstacles, the
    collision spheres' clearance the optimiser works with (dotted), the safety distance
    ``epsilon`` [m] (the obstacle factors act below it) and contact (0) marked; time on the
    clock of ``state_times`` (:func:`plan_clock`)."""
    scene = _check_inputs(result, robot, scene)
    epsilon = as_scalar(epsilon, "epsilon", minimum=0.0)
    q = np.asarray(result.q)
    spheres = np.min(sphere_clearance(robot, scene, q), axis=1)
    cap = max(3.0 * epsilon, 0.15)
    clearance, geometry = state_clearance(robot, scene, q, cap)
    t, axis = plan_clock(result, state_times)
    low = min(clearance.min(), spheres.min(), 0.0) - 0.01
    fig = Figure(figsize=(7.0, 3.6))
    ax = fig.add_subplot()
    ax.axhspan(low, 0.0, color="tab:red", alpha=0.15, lw=0, label="collision (< 0)")
    ax.axhline(epsilon, color="tab:orange", ls="--", lw=1.2,
               label=f"safety distance epsilon = {epsilon * 1e3:.0f} mm")
    ax.plot(t, clearance, color="tab:blue", lw=1.6,
            label=f"arm ({'URDF collision geometry' if geometry == 'urdf' else geometry}; "
                  f"shown up to {cap * 1e3:.0f} mm)")
    ax.plot(t, np.minimum(spheres, cap), color="tab:gray", lw=1.0, ls=":",
            label="collision spheres (the optimiser's model)")
    k = int(np.argmin(clearance))
    ax.scatter(t[k], clearance[k], color="k", s=20, zorder=5,
               label=f"minimum {clearance[k] * 1e3:.1f} mm at {axis.split(' [')[0]} {t[k]:.2f} s")
    ax.set_ylim(low, max(cap, epsilon) * 1.1 + 0.01)
    ax.set_xlabel(axis)
    ax.set_ylabel("clearance [m]")
    ax.grid(alpha=0.3)
    ax.set_title(title or "distance between the arm and the obstacles", fontsize=10)
    ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    return fig


def plot_skill_orientation(result: Any, robot: Any,
                           path: str | os.PathLike[str] | None = None, title: str | None = None,
                           dpi: int = 120, *, state_times: Any = None) -> Figure:
    """A plan of a pose prior against the skill's orientation: the angle [deg] of the hand from
    where the skill turns it (the orientation chain conditioned on the plan's start, goal and
    via rotations) at every state, and the verdict's limit (TUBE_RATIO x the demonstrations'
    floored orientation spread, :mod:`clamp.prior.orientation_skill`); writes a PNG to
    ``path``; time on the clock of ``state_times`` (:func:`plan_clock`). InvalidParameterError
    for a plan of a position-only prior."""
    from clamp.prior import so3
    from clamp.prior.orientation_skill import angle_spread
    from clamp.prior.skill import TUBE_RATIO
    _check_inputs(result, robot)
    t, axis = plan_clock(result, state_times)
    reference = getattr(result.inputs.model_prior, "orientation", None)
    learned = getattr(result.inputs.prior, "orientation", None)
    if reference is None or learned is None:
        raise InvalidParameterError("result: expected a plan of a pose prior (learned from "
                                    "demonstrations with orientations)")
    rotations, _ = robot.ee_rotation(result.q)
    angle = np.degrees(so3.angle_between(reference.mean_rotations, rotations))
    limit = np.degrees(TUBE_RATIO * angle_spread(learned))
    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.add_subplot()
    ax.fill_between(t, 0.0, limit, color="tab:green", alpha=0.12,
                    label=f"the skill ({TUBE_RATIO:g} x the orientation spread)")
    ax.plot(t, angle, color="tab:blue", lw=1.5, label="the hand's angle from the skill")
    ax.set_xlabel(axis)
    ax.set_ylabel("angle [deg]")
    worst = int(np.argmax(angle / limit))
    ax.set_title(title or f"orientation against the skill (worst {angle[worst]:.1f} deg at state "
                 f"{worst}, limit {limit[worst]:.1f} deg)", fontsize=9)
    ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig
