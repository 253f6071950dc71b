"""Command line of CLAMP: ``clamp demo`` (built-in synthetic skill) and ``clamp plan`` (user files).

Both learn the workspace prior from demonstrations, plan on a robot and write to the output
folder: prior figures (3-D, against time), plan figures, plans as JSON (q, qdot, end-effector
path, metrics) and the scene; a summary table is printed.
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from clamp.config import PlannerConfig
from clamp.initialisation import INITIALISATIONS
from clamp.optimizers import OPTIMIZERS
from clamp.planner import plan
from clamp.result import PlanResult

DEMO_START_OFFSET = np.array([0.0, -0.03, 0.03])


def _config(args: argparse.Namespace) -> PlannerConfig:
    """PlannerConfig() (PlannerConfig.fast() with --fast) with the options given on the command
    line; an option left out keeps the Python API's default."""
    given = {"epsilon": args.epsilon, "initialisation": args.init,
             "max_iterations": args.max_iterations, "optimizer": args.optimizer,
             "sigma_obs": args.sigma_obs}
    changes = {name: value for name, value in given.items() if value is not None}
    return PlannerConfig.fast(**changes) if args.fast else PlannerConfig().with_(**changes)


def write_plan(result: PlanResult, path: Path, **extra: Any) -> None:
    """Plan and metrics as JSON (arrays as lists; +inf as null)."""
    data = result.to_dict()
    data.update(extra)
    path.write_text(json.dumps(data, indent=1))


def summary_table(rows: Sequence[tuple[str, PlanResult]]) -> str:
    """Plain-text table: one row per plan."""
    head = (f"{'plan':<22} {'ok':<4} {'iters':>5} {'build s':>8} {'opt s':>7} {'final err':>10} "
            f"{'clear mm':>9} {'start mm':>9} {'log-lik':>10} {'plaus':>7}  reasons")
    lines = [head, "-" * len(head)]
    for name, r in rows:
        clearance = "inf" if not np.isfinite(r.min_clearance) else f"{r.min_clearance * 1e3:.1f}"
        lines.append(f"{name:<22} {'yes' if r.success else 'no':<4} {r.iterations:>5} "
                     f"{r.timings['build']:>8.3f} {r.timings['optimize']:>7.3f} "
                     f"{r.final_error:>10.4g} {clearance:>9} {r.start_error * 1e3:>9.3f} "
                     f"{r.log_likelihood:>10.4g} {r.plausibility:>7.3f}  "
                     f"{'; '.join(r.reasons)}")
    return "\n".join(lines)


def _figures(out: Path, prior: Any, demos: Any, robot: Any,
             plans: Sequence[tuple[str, PlanResult, Any]]) -> None:
    """Prior figures; per plan: 3-D figure, uncertainty figure, executable trajectory (JSON)
    and the browser animation (HTML)."""
    from clamp.animation import write_animation
    from clamp.plan_plots import plot_plan_3d, plot_plan_uncertainty
    from clamp.prior_plots import plot_prior_3d, plot_prior_time
    plot_prior_3d(prior, demos, path=out / "prior_3d.png")
    plot_prior_time(prior, demos, path=out / "prior_time.png")
    for name, result, scene in plans:
        plot_plan_3d(result, robot, scene, prior=prior, demos=demos, path=out / f"plan_{name}.png")
        if result.ee_covariance is not None:
            plot_plan_uncertainty(result, path=out / f"plan_{name}_uncertainty.png")
        result.to_joint_trajectory(robot).to_json(out / f"trajectory_{name}.json", overwrite=True)
        write_animation(out / f"animation_{name}.html", robot, result.time, result.q,
                        obstacles=scene, demonstrations=demos.positions,
                        mean_path=np.asarray(prior.mean)[:, :3],
                        title=f"CLAMP plan {name} on {robot.name}")


def _load_robot(name: str) -> Any:
    from robots import load_robot
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_robot(name)


def obstacle_below_path(result: PlanResult, size: float = 0.08, overlap: float = 0.02) -> Any:
    """A cube under the middle of a plan's end-effector path, reaching ``overlap`` m above it."""
    from scenes import Box
    middle = result.ee_path[len(result.ee_path) // 2]
    centre = middle - np.array([0.0, 0.0, 0.5 * size - overlap])
    return Box(centre, [size, size, size])


def run_demo(args: argparse.Namespace) -> int:
    from clamp.learning import learn_prior
    from scenes import Scene, make_demonstrations
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    robot = _load_robot(args.robot)
    demos = make_demonstrations(args.skill, num_demos=6, num_points=args.num_points)
    prior = learn_prior(demos)
    start = prior.mean[0, :3] + DEMO_START_OFFSET
    config = _config(args)
    empty = plan(prior, robot, None, start, config=config)
    scene = Scene([obstacle_below_path(empty)])
    scene.save(out / "scene_obstacle.json")
    with_obstacle = plan(prior, robot, scene, start, config=config)
    unaware = plan(prior, robot, scene, start, config=config.with_(obstacle_factors=False))
    rows = [("empty scene", empty), ("obstacle", with_obstacle),
            ("obstacle, no factors", unaware)]
    write_plan(empty, out / "plan_empty.json", robot=robot.name, skill=args.skill)
    write_plan(with_obstacle, out / "plan_obstacle.json", robot=robot.name, skill=args.skill,
               scene=scene.to_dict())
    _figures(out, prior, demos, robot, [("empty", empty, None), ("obstacle", with_obstacle, scene)])
    print(f"CLAMP demo: skill {args.skill!r} ({demos.M} demonstrations, T = {demos.T}), "
          f"robot {robot.name}, start {np.round(start, 4).tolist()}")
    print(summary_table(rows))
    print(f"wrote figures and plans to {out}")
    return 0 if empty.success and with_obstacle.success else 1


def run_plan(args: argparse.Namespace) -> int:
    from clamp.learning import learn_prior
    from scenes import Scene, load_demonstrations
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    robot = _load_robot(args.robot)
    demos = load_demonstrations(args.demos)
    if args.translate is not None:
        demos = demos.translated(np.array(args.translate, dtype=float))
    prior = learn_prior(demos)
    scene = Scene.load(args.scene) if args.scene else None
    result = plan(prior, robot, scene, np.array(args.start, dtype=float),
                  goal=None if args.goal is None else np.array(args.goal, dtype=float),
                  config=_config(args))
    write_plan(result, out / "plan.json", robot=robot.name, demos=str(args.demos),
               scene=None if scene is None else scene.to_dict())
    _figures(out, prior, demos, robot, [("result", result, scene)])
    print(summary_table([(Path(args.demos).stem, result)]))
    print(f"wrote figures and plan to {out}")
    return 0 if result.success else 1


def parser() -> argparse.ArgumentParser:
    """Argument parser of the ``clamp`` command."""
    main = argparse.ArgumentParser(prog="clamp", description=__doc__.splitlines()[0])
    sub = main.add_subparsers(dest="command", required=True)

    def planning_options(p: argparse.ArgumentParser) -> None:
        p.add_argument("--out", default="clamp_out", help="output folder (default: clamp_out)")
        p.add_argument("--fast", action="store_true",
                       help="PlannerConfig.fast(): stop at 5 %% relative decrease (about ten "
                            "iterations; less polished plans, check their success probability)")
        defaults = PlannerConfig()
        p.add_argument("--sigma-obs", type=float, default=None,
                       help=f"obstacle hinge noise [m] (default {defaults.model.sigma_obs})")
        p.add_argument("--epsilon", type=float, default=None,
                       help=f"obstacle safety distance [m] (default {defaults.model.epsilon})")
        p.add_argument("--init", choices=INITIALISATIONS, default=None,
                       help=f"initialisation (default {defaults.optimizer.initialisation})")
        p.add_argument("--optimizer", choices=OPTIMIZERS, default=None,
                       help=f"optimizer (default {defaults.optimizer.optimizer})")
        p.add_argument("--max-iterations", type=int, default=None,
                       help=f"(default {defaults.optimizer.max_iterations})")

    demo = sub.add_parser("demo", help="learn a built-in synthetic skill and plan it")
    planning_options(demo)
    demo.add_argument("--skill", default="box_closing", help="built-in skill (scenes.SKILLS)")
    demo.add_argument("--robot", default="jaco", help="built-in robot (default jaco)")
    demo.add_argument("--num-points", type=int, default=250, help="support states T")
    demo.set_defaults(run=run_demo)

    user = sub.add_parser("plan", help="learn from a demonstration file and plan")
    planning_options(user)
    user.add_argument("--demos", required=True, help="demonstrations (.mat, .npz, .csv)")
    user.add_argument("--robot", required=True, help="built-in robot name")
    user.add_argument("--start", type=float, nargs="+", required=True,
                      help="start: end-effector position x y z [m] or a joint configuration")
    user.add_argument("--goal", type=float, nargs="+", default=None,
                      help="goal: end-effector position x y z [m] or a joint configuration")
    user.add_argument("--scene", default=None, help="scene JSON file (scenes.Scene.save)")
    user.add_argument("--translate", type=float, nargs=3, default=None,
                      help="move the demonstrations by dx dy dz [m] before learning")
    user.set_defaults(run=run_plan)
    from clamp.batch_cli import add_batch_parser
    add_batch_parser(sub)
    return main


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``clamp``; returns the exit code (0 success, 1 plan failed, 2 bad input)."""
    import matplotlib
    matplotlib.use("Agg")
    args = parser().parse_args(argv)
    try:
        return args.run(args)
    except ValueError as exc:  # every package's input errors derive from ValueError
        print(f"clamp {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
