"""The figures and browser animations of plans, drawn into an output folder (``clamp demo``,
``clamp plan --figures``, ``clamp show``). matplotlib and the animation writer load only when
figures are drawn."""
from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from skillplan.command_line import save_figure
from skillplan.progress import progress

if TYPE_CHECKING:
    from clamp.config import PlannerConfig
    from clamp.planning.result import PlanResult

log = logging.getLogger(__name__)

#: the clocks figures can be drawn on (``--clock``): the executable trajectory's, the skill's
CLOCKS = ("trajectory", "skill")


def plan_json(name: str) -> str:
    """The file name of plan ``name``'s JSON in an output folder: ``clamp plan`` writes its one
    plan (``name`` "plan") as plan.json, ``clamp demo`` each plan as plan_NAME.json."""
    return "plan.json" if name == "plan" else f"plan_{name}.json"


def figure_clocks(clock: str | None, exported: Mapping[str, Mapping[str, Any]]) -> dict[str, np.ndarray]:
    """The trajectory-clock times of the plans whose figures are drawn on it: plan name ->
    ``state_times`` (T,) [s] of its trajectory record (``exported[name]``). ``clock``
    (``--clock``): "skill" none; "trajectory" or None (the default) every plan with an
    executable trajectory; a plan without one is drawn on the skill's clock (said as a warning
    when --clock trajectory was asked)."""
    if clock == "skill":
        return {}
    times = {}
    for name, record in exported.items():
        if record.get("state_times") is not None:
            times[name] = np.asarray(record["state_times"], dtype=float)
        elif clock == "trajectory":
            log.warning("--clock trajectory: plan %r has no executable trajectory (%s); its figures "
                        "are on the skill's clock", name, record.get("error"))
    return times


def figure_options(p: argparse.ArgumentParser) -> None:
    """--clock: the time axis of the figures."""
    p.add_argument("--clock", choices=CLOCKS, default=None,
                   help="time axis of the figures: trajectory (default when the plan has an executable "
                        "trajectory: when the retimed arm passes each state, as it will run) or skill (the "
                        "skill's time, the demonstrations' times the time scale k)")


def write_figures(out: Path, prior: Any, demos: Any, robot: Any, config: PlannerConfig,
                  plans: Sequence[tuple[str, PlanResult, Any]],
                  state_times: Mapping[str, Any] | None = None) -> None:
    """Prior figures; per plan: 3-D, top view, joint angles, clearance and uncertainty
    figures and the browser animation (HTML). ``demos`` None (a plan from a saved prior): the
    same figures, drawn from the prior alone (mean path and envelope, no demonstrations).
    ``state_times``: plan name -> when its executable trajectory passes each support state
    (T,) [s]: that plan's figures against time are on the trajectory's clock, and its animation
    plays at the trajectory's pace (when those times strictly increase); the others' (and the
    prior's) on the skill's (:func:`clamp.viz.plan_plots.plan_clock`)."""
    # deferred: matplotlib and the animation writer load only when figures are written
    import matplotlib
    matplotlib.use("Agg")              # files only: no window, whatever the user's backend
    from clamp.viz.animation import write_animation
    from clamp.viz.plan_plots import (plot_clearance, plot_joint_angles, plot_plan_3d,
                                  plot_plan_uncertainty, plot_skill_orientation, plot_top_view)
    from clamp.viz.prior_plots import plot_prior_3d, plot_prior_orientation, plot_prior_time
    save_figure(plot_prior_3d(prior, demos), out / "prior_3d.png")
    save_figure(plot_prior_time(prior, demos), out / "prior_time.png")
    pose = getattr(prior, "orientation", None) is not None
    if pose:
        save_figure(plot_prior_orientation(prior, demos), out / "prior_orientation.png")
    state_times = state_times or {}
    for name, result, scene in progress(plans, description="figures and animations", unit="plan"):
        clock = {"state_times": state_times.get(name)}
        if pose:
            save_figure(plot_skill_orientation(result, robot, **clock), out / f"plan_{name}_orientation.png")
        save_figure(plot_plan_3d(result, robot, scene, prior=prior, demos=demos),
                    out / f"plan_{name}.png")
        save_figure(plot_top_view(result, robot, scene, prior=prior, demos=demos),
                    out / f"plan_{name}_top.png")
        save_figure(plot_joint_angles(result, robot, **clock), out / f"plan_{name}_joints.png")
        if scene is not None and len(getattr(scene, "obstacles", ())):
            save_figure(plot_clearance(result, robot, scene, epsilon=config.model.epsilon, **clock),
                        out / f"plan_{name}_clearance.png")
        if result.ee_covariance is not None:
            save_figure(plot_plan_uncertainty(result, **clock), out / f"plan_{name}_uncertainty.png")
        moving = clock["state_times"] is not None and bool(np.all(np.diff(clock["state_times"]) > 0.0))
        write_animation(out / f"animation_{name}.html", robot,        # played at the arm's speed
                        clock["state_times"] if moving else result.time, result.q,
                        obstacles=scene, demonstrations=None if demos is None else demos.positions,
                        mean_path=np.asarray(prior.mean)[:, :3],
                        title=f"CLAMP plan {name} on {robot.name}")
