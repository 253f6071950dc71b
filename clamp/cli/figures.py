"""The figures and browser animations of plans, drawn into an output folder (``clamp demo``,
``clamp plan --figures``, ``clamp show``). matplotlib and the animation writer load only when
figures are drawn."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from skillplan.command_line import save_figure
from skillplan.progress import progress

if TYPE_CHECKING:
    from clamp.config import PlannerConfig
    from clamp.planning.result import PlanResult


def write_figures(out: Path, prior: Any, demos: Any, robot: Any, config: PlannerConfig,
                  plans: Sequence[tuple[str, PlanResult, Any]]) -> None:
    """Prior figures; per plan: 3-D, top view, joint angles, clearance and uncertainty
    figures and the browser animation (HTML). ``demos`` None (a plan from a saved prior): the
    same figures, drawn from the prior alone (mean path and envelope, no demonstrations)."""
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
    for name, result, scene in progress(plans, description="figures and animations", unit="plan"):
        if pose:
            save_figure(plot_skill_orientation(result, robot), out / f"plan_{name}_orientation.png")
        save_figure(plot_plan_3d(result, robot, scene, prior=prior, demos=demos),
                    out / f"plan_{name}.png")
        save_figure(plot_top_view(result, robot, scene, prior=prior, demos=demos),
                    out / f"plan_{name}_top.png")
        save_figure(plot_joint_angles(result, robot), out / f"plan_{name}_joints.png")
        if scene is not None and len(getattr(scene, "obstacles", ())):
            save_figure(plot_clearance(result, robot, scene, epsilon=config.model.epsilon),
                        out / f"plan_{name}_clearance.png")
        if result.ee_covariance is not None:
            save_figure(plot_plan_uncertainty(result), out / f"plan_{name}_uncertainty.png")
        write_animation(out / f"animation_{name}.html", robot, result.time, result.q,
                        obstacles=scene, demonstrations=None if demos is None else demos.positions,
                        mean_path=np.asarray(prior.mean)[:, :3],
                        title=f"CLAMP plan {name} on {robot.name}")
