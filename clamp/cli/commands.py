"""Command line of CLAMP: clamp demo (built-in synthetic skill) and clamp plan (user files).

Both learn the workspace prior from demonstrations, plan on a robot (a registered name or any
URDF arm) and write to the output folder (new or empty, or ``--force``): plans as JSON (q,
qdot, end-effector path, metrics), the scene, prior figures, plan figures (3-D, top view, joint
angles with limits, clearance, uncertainty) and browser animations (``clamp demo`` always,
``clamp plan`` with ``--figures``: drawing takes seconds) and, for a successful plan,
its executable joint trajectory: retimed within the arm's velocity limits and ``--acc-limit``
(TOPP-RA, from rest to rest; with ``--jerk-limit`` jerk-limited by ruckig) as skillplan JSON (with the verdict) and as a ROS 2
``trajectory_msgs/JointTrajectory`` message; a summary table is printed. Exit codes: 0 success,
1 a plan was computed but failed (no trajectory is written for it), 2 bad input (nothing is
left behind: a folder the run created is removed again). Shared plumbing (errors, output
folder, atomic writes, logging): :mod:`skillplan.command_line`.

A sub-command is registered in :func:`parser` by ``add_parser`` + ``set_defaults(run=...)``;
:func:`robot_options` / :func:`planning_options` add the shared options.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from clamp.config import PlannerConfig
from clamp.errors import InvalidParameterError, PriorFileError
from clamp.config import INITIALISATIONS, OPTIMIZERS
from clamp.cli.batch import add_batch_parser
from clamp.cli.figures import figure_clocks, figure_options, plan_json, write_figures
from clamp.cli.show import add_show_parser
from clamp.cli.viewer import add_view_parser, robot_spec, save_view_inputs
from skillplan.command_line import (EXIT_FAILED, EXIT_OK, CommandLineParser, atomic_write_text,
                                 integer_at_least, number, output_directory, output_file, quiet, run)
from skillplan.progress import progress
from robots.retiming import DEFAULT_ACCELERATION_LIMIT
from robots.errors import RetimingError, RobotError
from scenes.errors import DemonstrationFileError, SceneFileError
from skillplan.validation import as_file

# The planner, learning, robots and scenes load inside the commands that use them: building the
# parser (clamp --version, --help, a usage error) loads none of them.
if TYPE_CHECKING:
    from clamp.planning.result import PlanResult

log = logging.getLogger(__name__)

DEMO_START_OFFSET = np.array([0.0, -0.03, 0.03])
#: What ``clamp`` writes per plan NAME besides figures: the executable trajectory files.
TRAJECTORY_FILES = ("trajectory_{}.json", "trajectory_{}_ros2.json")


#: the planner setting each option sets: (option, the setting's name in a config error)
CONFIG_OPTIONS = {"epsilon": ("--epsilon", "config.model.epsilon"),
                  "min_clearance": ("--min-clearance", "config.checks.min_clearance"),
                  "initialisation": ("--init", "config.optimizer.initialisation"),
                  "max_iterations": ("--max-iterations", "config.optimizer.max_iterations"),
                  "optimizer": ("--optimizer", "config.optimizer.optimizer"),
                  "sigma_obs": ("--sigma-obs", "config.model.sigma_obs")}


def _config(args: argparse.Namespace) -> PlannerConfig:
    """PlannerConfig() (PlannerConfig.fast() with --fast) with the options given on the command
    line; an option left out keeps the Python API's default. A value the config refuses is
    InvalidParameterError naming the option as typed."""
    given = {"epsilon": args.epsilon, "min_clearance": args.min_clearance, "initialisation": args.init,
             "max_iterations": args.max_iterations, "optimizer": args.optimizer,
             "sigma_obs": args.sigma_obs}
    changes = {name: value for name, value in given.items() if value is not None}
    try:
        config = PlannerConfig.fast(**changes) if args.fast else PlannerConfig().with_(**changes)
        return config.validate()
    except InvalidParameterError as exc:
        text = str(exc)
        for name, (option, setting) in CONFIG_OPTIONS.items():
            if name in changes and text.startswith(f"{setting}:"):
                raise InvalidParameterError(option + text[len(setting):]) from None
        raise


def write_plan(result: PlanResult, path: Path, **extra: Any) -> None:
    """Plan and metrics as JSON (arrays as lists; +inf as null), written atomically, with the
    goal orientation error in degrees (``goal_rotation_error_deg``) when a goal rotation was
    given; with the ``trajectory`` record in ``extra``, the nearest contact is dated on both clocks
    (:func:`on_trajectory_clock`)."""
    data = result.to_dict()
    if result.goal_rotation_error is not None:
        data["goal_rotation_error_deg"] = float(np.degrees(result.goal_rotation_error))
    data.update(extra)
    if "trajectory" in extra:
        data["nearest_contact"] = on_trajectory_clock(result, extra["trajectory"])
    atomic_write_text(path, json.dumps(data, indent=1) + "\n", overwrite=True)


def _mm(value: float | None) -> str:
    """A length [m] in mm for the summary ("-" for none, "inf" without obstacles)."""
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return "-"
    return "inf" if not np.isfinite(value) else f"{value * 1e3:.1f}"


def summary_table(rows: Sequence[tuple[str, PlanResult]],
                  exported: dict[str, dict[str, Any]] | None = None, verbose: bool = False) -> str:
    """Plain-text table, one row per plan: its verdict, clearance [mm] (on the robot's collision
    geometry), end error [mm] (from where the demonstrations end; without a goal) and goal
    error [mm] (or rad for a joint goal), the hand's angle from a goal pose's rotation [deg]
    ("-" without a goal rotation), orientation error [deg] where one was asked, the time
    scale k (the plan lasts k times the skill), the executable trajectory's duration [s] on its
    own clock (``exported[name]["duration"]``: "-" when none was written) and the reasons.
    ``verbose`` adds the solver's figures: iterations, build and optimisation time [s], the
    final graph error and the log-likelihood [nats], the plausibility."""
    head = (f"{'plan':<22} {'verdict':<8} {'clear mm':>8} {'end mm':>7} {'goal mm':>7} "
            f"{'goal deg':>8} {'orient deg':>10} {'k':>5} {'traj s':>7}")
    if verbose:
        head += f" {'iters':>5} {'build s':>8} {'opt s':>7} {'final err':>10} {'log-lik':>10} {'plaus':>6}"
    head += "  reasons"
    lines = [head, "-" * len(head)]
    exported = exported or {}
    for name, r in rows:
        orientation = r.violations.get("orientation")
        duration = exported.get(name, {}).get("duration")
        line = (f"{name:<22} {'success' if r.success else 'FAILED':<8} {_mm(r.min_clearance):>8} "
                f"{_end(r):>7} {_goal(r):>7} {_degrees(r.goal_rotation_error):>8} "
                f"{'-' if orientation is None else f'{np.degrees(orientation):.1f}':>10} "
                f"{r.time_scale:>5.2f} {'-' if duration is None else f'{duration:.2f}':>7}")
        if verbose:
            line += (f" {r.iterations:>5} {r.timings['build']:>8.3f} {r.timings['optimize']:>7.3f} "
                     f"{r.final_error:>10.4g} {r.log_likelihood:>10.4g} {r.plausibility:>6.3f}")
        lines.append(line + f"  {'; '.join(r.reasons)}")
    return "\n".join(lines)


def _end(result: PlanResult) -> str:
    """The end error in mm from where the demonstrations end; "-" with a goal (the goal error
    says how the plan ends)."""
    goal = None if result.inputs is None else result.inputs.goal
    return "-" if goal is not None else _mm(result.skill.get("end_distance"))


def _goal(result: PlanResult) -> str:
    """The goal error in mm, or in rad (suffix "r") for a joint goal; "-" without a goal."""
    goal = None if result.inputs is None else result.inputs.goal
    if result.goal_error is None or goal is None:
        return "-"
    position = isinstance(goal, tuple) or np.size(goal) == 3      # a pose: (position, quaternion)
    return _mm(result.goal_error) if position else f"{result.goal_error:.4f}r"


def _degrees(angle: float | None) -> str:
    """An angle [rad] in degrees for the summary ("-" for none)."""
    return "-" if angle is None else f"{np.degrees(angle):.2f}"


def report_failures(args: argparse.Namespace, rows: Sequence[tuple[str, PlanResult]],
                    exported: dict[str, dict[str, Any]]) -> None:
    """One line each on stderr (also under -q: exit code 1 says a plan failed, this says why)
    for every plan that failed its verdict (its first reason) and every passing plan that got
    no trajectory (``exported[name]["error"]``, e.g. the retiming failed)."""
    for name, result in rows:
        if not result.success and result.reasons:
            print(f"clamp {args.command}: plan {name!r} failed: {result.reasons[0]}", file=sys.stderr)
        elif result.success and not exported[name]["files"]:
            print(f"clamp {args.command}: plan {name!r}: no trajectory: {exported[name]['error']}",
                  file=sys.stderr)


@contextmanager
def created_output_directory(path: Any, force: bool) -> Iterator[Path]:
    """:func:`skillplan.command_line.output_directory`, undone on error: when the run stops with
    an exception, the folders it created are removed again if they are still empty."""
    missing = [folder for folder in (Path(path), *Path(path).parents) if not folder.exists()]
    out = output_directory(path, force)
    try:
        yield out
    except BaseException:
        for folder in missing:  # innermost first
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()
        raise


def _limits(values: Any, option: str, unit: str, robot: Any, no_retime: bool) -> float | np.ndarray:
    """The values of a per-joint limit option ``option`` [``unit``]: one positive number for every
    joint or one per joint; not with --no-retime (a limit is what the trajectory is retimed to)."""
    if no_retime:
        raise InvalidParameterError(f"{option}: not with --no-retime (the limit is what the "
                                    "trajectory is retimed to)")
    array = np.array(values, dtype=float)
    if len(array) not in (1, robot.n) or np.any(array <= 0.0):
        raise InvalidParameterError(f"{option}: expected one positive limit [{unit}] or one per "
                                    f"joint of {robot.name} ({robot.n}), got {values}")
    return float(array[0]) if len(array) == 1 else array


def acceleration_limits(args: argparse.Namespace, robot: Any) -> float | np.ndarray:
    """The --acc-limit values [rad/s^2] (default robots.retiming.DEFAULT_ACCELERATION_LIMIT)."""
    if args.acc_limit is None:
        return DEFAULT_ACCELERATION_LIMIT
    return _limits(args.acc_limit, "--acc-limit", "rad/s^2", robot, args.no_retime)


def jerk_limits(args: argparse.Namespace, robot: Any) -> float | np.ndarray | None:
    """The --jerk-limit values [rad/s^3]; None when not given (the trajectory is then not
    jerk-limited)."""
    if args.jerk_limit is None:
        return None
    return _limits(args.jerk_limit, "--jerk-limit", "rad/s^3", robot, args.no_retime)


def write_trajectory(out: Path, name: str, result: PlanResult, robot: Any,
                     limits: float | np.ndarray, retime: bool,
                     jerk: float | np.ndarray | None = None) -> dict[str, Any]:
    """The executable trajectory of a successful plan: ``trajectory_NAME.json`` (skillplan
    format, verdict and retiming report in its header) and ``trajectory_NAME_ros2.json`` (the
    ROS 2 JointTrajectory message), retimed within the arm's velocity limits and ``limits``
    [rad/s^2] from rest to rest unless ``retime`` is False (and within ``jerk`` [rad/s^3] by
    ruckig when given). A failed plan, or one the retimer
    cannot parameterise, gets none (files of that name left by an earlier run are removed:
    they would pass for this plan's). Returns what the plan JSON records as "trajectory":
    files, retimed, acceleration_limits [rad/s^2] (None when not retimed), jerk_limits [rad/s^3]
    (None when not jerk-limited), duration [s], state_times [s] (when the trajectory passes
    each support state, on its own clock: :func:`state_times`), error (why there is none)."""
    paths = [out / pattern.format(name) for pattern in TRAJECTORY_FILES]
    record: dict[str, Any] = {"files": [], "retimed": retime, "acceleration_limits": None,
                              "jerk_limits": None, "duration": None, "error": None}
    if retime:
        record["acceleration_limits"] = np.broadcast_to(limits, (robot.n,)).tolist()
        if jerk is not None:
            record["jerk_limits"] = np.broadcast_to(jerk, (robot.n,)).tolist()
    if result.success:
        try:
            trajectory = result.to_joint_trajectory(robot, retime=retime, acceleration_limits=limits,
                                                    jerk_limits=jerk)
        except RetimingError as exc:
            record["error"] = f"retiming failed: {exc}"
        else:
            trajectory.to_json(paths[0], overwrite=True)
            trajectory.to_ros2_json(paths[1], overwrite=True)
            record.update(files=[path.name for path in paths], duration=trajectory.duration,
                          state_times=state_times(result.q, trajectory).tolist())
            return record
    else:
        record["error"] = "the plan failed: no executable trajectory"
    for path in paths:
        path.unlink(missing_ok=True)
    log.warning("plan %r: %s", name, record["error"])
    return record


def state_times(q: np.ndarray, trajectory: Any) -> np.ndarray:
    """When ``trajectory`` (a robots.JointTrajectory of the plan q (T, n) [rad], retimed or not)
    passes each support state: times (T,) [s] on the trajectory's own clock, matched by the
    share of the joint-space path length travelled (both follow the same path in order)."""
    def travelled(points: np.ndarray) -> np.ndarray:
        steps = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        return steps / steps[-1] if steps[-1] > 0.0 else np.linspace(0.0, 1.0, len(points))
    return np.interp(travelled(np.asarray(q)), travelled(np.asarray(trajectory.positions)),
                     np.asarray(trajectory.time_from_start))


def on_trajectory_clock(result: PlanResult, record: dict[str, Any]) -> dict[str, Any] | None:
    """``result.nearest_contact`` (its ``time`` on the skill's clock, which ``time_clock``
    names) with ``skill_time`` and ``trajectory_time`` [s] added: the same instant on the
    executable trajectory's clock (None without a trajectory); None without a contact."""
    contact = result.nearest_contact
    if contact is None:
        return None
    times = record.get("state_times")
    index = contact.get("index")
    moment = None if times is None or index is None else float(
        np.interp(index, np.arange(len(times)), times))
    return {**contact, "time_clock": "skill", "skill_time": contact.get("time"), "trajectory_time": moment}


def contact_summary(name: str, contact: dict[str, Any] | None) -> str | None:
    """One line for the summary: where plan ``name`` comes closest to an obstacle, on the
    trajectory's clock where it has one and on the skill's (``contact``: the plan JSON's
    ``nearest_contact``, :func:`on_trajectory_clock`); None without obstacles."""
    if contact is None or contact.get("distance") is None:
        return None
    when = [] if contact.get("trajectory_time") is None else [f"trajectory time {contact['trajectory_time']:.2f} s"]
    if contact.get("skill_time") is not None:
        when.append(f"skill time t = {contact['skill_time']:.2f} s")
    at = f" at {when[0]}" + (f" ({when[1]})" if len(when) > 1 else "") if when else ""
    return (f"nearest contact {name}: {1e3 * contact['distance']:.1f} mm, link {contact.get('link')} "
            f"to {contact.get('obstacle')}{at}")


def flagged(error: Exception, option: str) -> Exception:
    """``error`` (a file's error naming the file) as the same kind of error naming ``option``
    first, the flag the user typed; unchanged when it names a flag already."""
    text = str(error)
    return error if text.startswith("--") else type(error)(f"{option}: {text}")


def load_robot_from_args(args: argparse.Namespace) -> Any:
    """The robot of ``--robot NAME`` or ``--urdf FILE --end-effector FRAME`` (the arguments
    checked here, the robot loaded by :func:`robots.resolve_robot`, as a batch problem's)."""
    from robots import available_robots, resolve_robot
    if args.urdf is None:
        if args.end_effector is not None:
            raise InvalidParameterError("--end-effector: only with --urdf (a registered robot "
                                        "has its own end effector)")
        if args.robot not in available_robots():
            raise InvalidParameterError(f"--robot: unknown robot {args.robot!r} (registered: "
                                        f"{', '.join(available_robots())}); for any other arm pass "
                                        f"--urdf FILE --end-effector FRAME [--package-dir DIR]")
        return resolve_robot(args.robot)
    if args.end_effector is None:
        raise InvalidParameterError("--end-effector: required with --urdf (the frame to plan "
                                    "for, e.g. the tool or the last link)")
    as_file(args.urdf, "--urdf", RobotError)
    if args.spheres is not None:
        as_file(args.spheres, "--spheres", RobotError)
    return resolve_robot({"urdf": args.urdf, "end_effector": args.end_effector, "package_dirs": args.package_dir,
                          "spheres": args.spheres, "base_frame": args.base_frame})


def _plan_all(prior: Any, robot: Any, start: np.ndarray,
              requests: Sequence[tuple[str, Any, PlannerConfig, dict[str, Any]]]
              ) -> list[PlanResult]:
    """plan() for each (name, scene, config, options), one progress-bar step per plan, and the
    search's own progress line (:func:`search_progress`)."""
    from clamp.planning.planner import plan
    results = []
    bar = progress(requests, description="planning", unit="plan")
    for name, scene, config, options in bar:
        bar.set_postfix_str(f"{name} ({config.optimizer.optimizer})")
        log.info("planning %r with the %s optimizer", name, config.optimizer.optimizer)
        with search_progress(name):
            results.append(plan(prior, robot, scene, start, config=config, **options))
    return results


#: [s] how long a plan searches before its progress line shows (a quick plan draws none)
SEARCH_PROGRESS_DELAY = 1.0


@contextmanager
def search_progress(name: str) -> Iterator[None]:
    """Within the block, a progress line on stderr for the search of plan ``name`` once it has
    lasted SEARCH_PROGRESS_DELAY s (on a terminal only, never with -q:
    :mod:`skillplan.progress`): the work spent against the budget (solver trials and judged
    optima, the budget's count), the starts and solves,
    updated after every start (:mod:`clamp.planning.progress`; the searches of one plan, at
    several time scales, add up)."""
    from clamp.planning.progress import SearchProgress, watching
    spent = {"before": 0, "last": 0}

    with progress(description=f"searching {name!r}", unit="trial",
                  delay=SEARCH_PROGRESS_DELAY) as bar:
        def show(state: SearchProgress) -> None:
            if state.work < spent["last"]:               # a new search of the same plan
                spent["before"] += spent["last"]
            spent["last"] = state.work
            bar.total = None if state.limit is None else spent["before"] + math.ceil(state.limit)
            bar.set_postfix_str(f"{state.starts} start{'s' if state.starts != 1 else ''}, {state.solves} "
                                f"solve{'s' if state.solves != 1 else ''}", refresh=False)
            bar.update(spent["before"] + state.work - bar.n)
        with watching(show):
            yield


def learned_prior(demos: Any) -> Any:
    """learn_prior(demos), with a progress line on a terminal (long recordings take seconds)."""
    from clamp.prior.learning import learn_prior
    with progress(description=f"learning the prior from {demos.M} demonstrations", total=1,
                  unit="prior") as bar:
        prior = learn_prior(demos)
        bar.update()
    return prior


def unaware_summary(robot: Any, scene: Any, empty: PlanResult) -> str:
    """One line: the empty scene's plan measured in ``scene`` (on the robot's collision
    geometry), i.e. what the skill does when it ignores the obstacle."""
    from clamp.planning.clearance import check_clearance
    report = check_clearance(robot, scene, empty.q)
    verdict = "collides" if report.collision else "clear"
    return (f"the empty scene's plan in the obstacle scene (the skill unaware of the obstacle): "
            f"{verdict}, clearance {_mm(report.min_distance)} mm")


def run_demo(args: argparse.Namespace) -> int:
    from scenes.synthetic import SKILLS
    if args.skill not in SKILLS:          # bad input is refused before the output folder is made
        raise InvalidParameterError(f"--skill: unknown skill {args.skill!r}; expected one of the "
                                    f"built-in skills: {', '.join(SKILLS)}")
    return _in_output_folder(args, _demo)


def _in_output_folder(args: argparse.Namespace, run: Callable[[argparse.Namespace, Path], int]) -> int:
    """``run(args, out)`` in the output folder ``--out`` made for it, once the planner settings
    are checked (bad settings leave no folder behind)."""
    _config(args)
    with created_output_directory(args.out, args.force) as out:
        return run(args, out)


def _robot_and_limits(args: argparse.Namespace) -> tuple[Any, Any, Any]:
    """The robot the arguments name, its acceleration limits and its jerk limits."""
    robot = load_robot_from_args(args)
    return robot, acceleration_limits(args, robot), jerk_limits(args, robot)


def _demo(args: argparse.Namespace, out: Path) -> int:
    from scenes import Scene, make_demonstrations
    robot, limits, jerk = _robot_and_limits(args)
    demos = make_demonstrations(args.skill, num_demos=6, num_points=args.num_points)
    prior = learned_prior(demos)
    start = prior.mean[0, :3] + DEMO_START_OFFSET
    config = _config(args)
    [empty] = _plan_all(prior, robot, start, [("empty scene", None, config, {})])
    scene = Scene([obstacle_below_path(empty)])
    scene.save(out / "scene_obstacle.json")
    [with_obstacle] = _plan_all(prior, robot, start, [("obstacle", scene, config, {})])
    rows = [("empty scene", empty), ("obstacle", with_obstacle)]
    exported = {name: write_trajectory(out, name, result, robot, limits, not args.no_retime, jerk)
                for name, result in (("empty", empty), ("obstacle", with_obstacle))}
    write_plan(empty, out / plan_json("empty"), robot=robot.name, skill=args.skill,
               trajectory=exported["empty"])
    write_plan(with_obstacle, out / plan_json("obstacle"), robot=robot.name, skill=args.skill,
               scene=scene.to_dict(), trajectory=exported["obstacle"])
    write_figures(out, prior, demos, robot, config,
                  [("empty", empty, None), ("obstacle", with_obstacle, scene)],
                  figure_clocks(args.clock, exported))
    save_view_inputs(out, {"empty": {"scene": None, "start": start},
                           "obstacle": {"scene": scene, "start": start}}, prior, demos, robot_spec(args), config)
    if not quiet(args):
        print(f"CLAMP demo: skill {args.skill!r} ({demos.M} demonstrations, T = {demos.T}), "
              f"robot {robot.name}, start {np.round(start, 4).tolist()}")
        print(summary_table(rows, {"empty scene": exported["empty"], "obstacle": exported["obstacle"]},
                            verbose=verbose(args)))
        print(unaware_summary(robot, scene, empty))
        print(trajectory_summary(exported))
        contact = contact_summary("obstacle", on_trajectory_clock(with_obstacle, exported["obstacle"]))
        if contact is not None:
            print(contact)
        print(f"wrote figures and plans to {out}")
    report_failures(args, rows, {"empty scene": exported["empty"], "obstacle": exported["obstacle"]})
    return EXIT_OK if all(record["files"] for record in exported.values()) else EXIT_FAILED


def check_demonstration_args(args: argparse.Namespace) -> None:
    """The --demos files (or bags) and their options, checked before any output is made."""
    from scenes.bags import is_bag
    bags = [is_bag(d) for d in args.demos]
    bag_options = args.topic is not None or args.split is not None or args.frames is not None
    if not all(bags) and (len(args.demos) > 1 or bag_options):
        raise DemonstrationFileError(f"--demos: several files, and --topic / --split / --frames, are for "
                                     f"ROS 2 bags (folders with metadata.yaml, .mcap or .db3 files), got "
                                     f"{' '.join(args.demos)}")
    if all(bags) and args.topic is None:
        raise DemonstrationFileError("--topic: ROS 2 bags need the topic to read, e.g. --topic /joint_states")
    for demos in args.demos:                                    # named as the user typed them,
        if not is_bag(demos):                                   # before the output folder is made
            as_file(demos, "--demos", DemonstrationFileError)
        elif not Path(demos).exists():
            raise DemonstrationFileError(f"--demos: {demos} does not exist (no such bag)")


def load_demonstrations_from_args(args: argparse.Namespace, robot: Any) -> Any:
    """The demonstrations of --demos (a file, or ROS 2 bags with --topic / --split / --frames),
    resampled to --num-points and moved by --translate when given. ``robot`` (None for
    ``clamp learn`` without --robot / --urdf) reads joint-space demonstrations."""
    from scenes import load_demonstrations
    try:
        if args.topic is None:                              # a joint-space file needs the arm
            demos = load_demonstrations(args.demos[0], robot=robot)
        else:
            demos = load_demonstrations(args.demos, robot=robot, topic=args.topic,
                                        split=args.split or "auto", frames=args.frames)
            if not quiet(args):                             # the split, always said
                print(f"--demos: {demos.bag_split}")
    except DemonstrationFileError as exc:
        if robot is None and "pass robot=" in str(exc):
            raise DemonstrationFileError(f"--robot: {' '.join(args.demos)} hold joint-space demonstrations; "
                                         "pass --robot NAME or --urdf FILE --end-effector FRAME (the arm "
                                         "whose forward kinematics gives the end-effector paths)") from None
        raise flagged(exc, "--demos") from None
    if args.num_points is not None:
        demos = demos.resample(args.num_points)
    if args.translate is not None:
        demos = demos.translated(np.array(args.translate, dtype=float))
    return demos


def prior_output(path: str, force: bool) -> Path:
    """The prior file --out names (``.npz`` added when missing, as ``WorkspacePrior.save``
    does): new, or an existing file only with --force; checked before any work."""
    target = Path(path)
    if target.suffix != ".npz":
        target = target.with_name(target.name + ".npz")
    return output_file(target, force)


def run_learn(args: argparse.Namespace) -> int:
    check_demonstration_args(args)
    out = prior_output(args.out, args.force)
    no_arm = args.robot is None and args.urdf is None
    if no_arm and args.end_effector is not None:
        raise InvalidParameterError("--end-effector: only with --urdf (the arm of joint-space demonstrations)")
    robot = None if no_arm else load_robot_from_args(args)
    demos = load_demonstrations_from_args(args, robot)
    prior = learned_prior(demos)
    prior.save(out, overwrite=args.force)
    if not quiet(args):
        print(prior.summary())
        print(f"wrote the prior to {out} (plan from it: clamp plan --prior {out} ...)")
    return EXIT_OK


def load_prior_from_args(args: argparse.Namespace) -> Any:
    """The workspace prior of --prior FILE (``clamp learn``'s output, ``WorkspacePrior.save``);
    PriorFileError naming --prior and the file when it cannot be read."""
    from clamp.prior.linear_gaussian import WorkspacePrior
    try:
        return WorkspacePrior.load(args.prior)
    except PriorFileError as exc:
        raise PriorFileError(f"--prior: {str(exc).removeprefix('path: ')}") from None


#: the options of --demos that say how to learn; a saved prior was learned with its own
LEARNING_OPTIONS = {"--topic": "topic", "--frames": "frames", "--num-points": "num_points",
                    "--translate": "translate"}


def run_plan(args: argparse.Namespace) -> int:
    if args.clock is not None and not args.figures:
        raise InvalidParameterError("--clock: only with --figures (the figures' time axis; clamp show "
                                    "--clock draws them later)")
    if args.prior is not None:
        given = [option for option, name in LEARNING_OPTIONS.items() if getattr(args, name) is not None]
        given += ["--split"] if args.split is not None else []
        if given:
            raise InvalidParameterError(f"{given[0]}: only with --demos (a prior from --prior was learned "
                                        f"with its own settings: give them to clamp learn)")
        as_file(args.prior, "--prior", PriorFileError)
    else:
        check_demonstration_args(args)
    if args.scene:
        as_file(args.scene, "--scene", SceneFileError)
    goal_quaternion(args)
    return _in_output_folder(args, _plan_from_files)


def _plan_from_files(args: argparse.Namespace, out: Path) -> int:
    from scenes import Scene
    robot, limits, jerk = _robot_and_limits(args)
    start = _start(args, robot)
    if args.prior is not None:        # figures from the prior alone: no demonstrations drawn
        demos, prior = None, load_prior_from_args(args)
    else:
        demos = load_demonstrations_from_args(args, robot)
        prior = learned_prior(demos)
    from clamp.planning.reach import check_reach
    check_reach(robot, np.asarray(prior.mean)[:, :3], "--prior" if args.prior is not None else "--demos")
    try:
        scene = Scene.load(args.scene) if args.scene else None
    except SceneFileError as exc:
        raise flagged(exc, "--scene") from None
    config = _config(args)
    goal = goal_from_args(args, robot)
    [result] = _plan_all(prior, robot, start, [("plan", scene, config, {"goal": goal})])
    refuse_unstartable(args, result)
    exported = {"result": write_trajectory(out, "result", result, robot, limits, not args.no_retime, jerk)}
    source = {"prior": str(args.prior)} if args.prior is not None else {"demos": " ".join(args.demos)}
    write_plan(result, out / plan_json("plan"), robot=robot.name, **source,
               urdf=None if args.urdf is None else str(args.urdf),
               scene=None if scene is None else scene.to_dict(), trajectory=exported["result"])
    if args.figures:
        write_figures(out, prior, demos, robot, config, [("result", result, scene)],
                      figure_clocks(args.clock, exported))
    save_view_inputs(out, {"plan": {"scene": scene, "start": start, "goal": goal}}, prior, demos,
                     robot_spec(args), config)
    name = Path(args.prior if args.prior is not None else args.demos[0]).stem
    if not quiet(args):
        print(summary_table([(name, result)], {name: exported["result"]}, verbose=verbose(args)))
        print(trajectory_summary(exported))
        contact = contact_summary(name, on_trajectory_clock(result, exported["result"]))
        if contact is not None:
            print(contact)
        print(f"wrote {'figures and ' if args.figures else ''}plan to {out}")
    report_failures(args, [(name, result)], {name: exported["result"]})
    return EXIT_OK if exported["result"]["files"] else EXIT_FAILED


def verbose(args: argparse.Namespace) -> bool:
    """True with -v: the summary adds the solver's figures."""
    return bool(getattr(args, "verbose", 0))


#: what a request that can start the plan needs, by the option that asks it
STARTABLE = {"--goal": "a goal the arm reaches within its joint limits, outside the obstacles",
             "--start": "a start the arm reaches within its joint limits, clear of the obstacles "
                        "and of itself",
             "--start-joints": "a start configuration within the joint limits, clear of the "
                               "obstacles and of itself"}


def refuse_unstartable(args: argparse.Namespace, result: PlanResult) -> None:
    """A request the planner could not even start (its start or goal out of reach, beyond the
    joint limits, inside an obstacle or in self-collision: ``stop_reason`` "not started") is bad
    input: InvalidParameterError naming the option the user typed, what it needs and why."""
    if result.stop_reason != "not started":
        return
    reason = result.reasons[0]
    option = ("--goal" if reason.startswith(("goal", "via")) else
              "--start-joints" if args.start_joints is not None else "--start")
    more = f" (and {len(result.reasons) - 1} more)" if len(result.reasons) > 1 else ""
    raise InvalidParameterError(f"{option}: {reason}{more}; expected {STARTABLE[option]}")


def goal_quaternion(args: argparse.Namespace) -> np.ndarray | None:
    """--goal-quaternion qx qy qz qw (None when not given), checked before any work: four
    numbers, a unit quaternion within scenes.quaternions.QUATERNION_TOLERANCE, with --goal."""
    from scenes.quaternions import QUATERNION_TOLERANCE
    if args.goal_quaternion is None:
        return None
    values = np.array(args.goal_quaternion, dtype=float)
    given = f"{len(values)} number{'s' if len(values) != 1 else ''} {np.round(values, 4).tolist()}"
    if len(values) != 4:
        raise InvalidParameterError(f"--goal-quaternion: expected 4 numbers qx qy qz qw (a unit "
                                    f"quaternion, x y z w), got {given}")
    norm = float(np.linalg.norm(values))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise InvalidParameterError(f"--goal-quaternion: expected a unit quaternion qx qy qz qw "
                                    f"(length 1 within {QUATERNION_TOLERANCE:g}), got length "
                                    f"{norm:.4g}: {np.round(values, 4).tolist()}")
    if args.goal is None:
        raise InvalidParameterError("--goal-quaternion: only with --goal x y z (the goal's position "
                                    "[m]); got no --goal")
    return values


def goal_from_args(args: argparse.Namespace, robot: Any) -> Any:
    """The goal of --goal (a position x y z [m] or robot.n joint values [rad]) and
    --goal-quaternion: None, an array, or a pose (position (3,), quaternion (4,)) as
    :func:`clamp.plan` takes it. InvalidParameterError naming the flag for a wrong count or a
    rotation with a joint goal. A position-only skill meets a goal rotation as :func:`clamp.plan`
    does (an end-effector rotation target, judged by the verdict's goal check)."""
    if args.goal is None:
        return None
    goal = joint_values(args.goal, "--goal", robot)
    quaternion = goal_quaternion(args)
    if len(goal) not in (3, robot.n):
        hint = ("; a goal rotation is --goal-quaternion qx qy qz qw" if len(goal) == 7 else "")
        raise InvalidParameterError(f"--goal: expected a position x y z [m] or {robot.n} joint values "
                                    f"[rad] for {robot.name}, got {len(goal)} numbers "
                                    f"{np.round(goal, 4).tolist()}{hint}")
    if quaternion is None:
        return goal
    if len(goal) == robot.n:
        raise InvalidParameterError(f"--goal-quaternion: only with a goal position --goal x y z; "
                                    f"--goal gives {robot.n} joint values, which fix the hand's "
                                    "rotation already")
    return goal, quaternion


def _start(args: argparse.Namespace, robot: Any) -> np.ndarray:
    """--start x y z (or a configuration), or --start-joints q1 .. qn (the robot's measured
    configuration: exactly one value per joint)."""
    if args.start_joints is None:
        return joint_values(args.start, "--start", robot)
    if len(args.start_joints) != robot.n:
        raise InvalidParameterError(f"--start-joints: expected {robot.n} joint values [rad] for "
                                    f"{robot.name} ({', '.join(robot.joint_names)}), got "
                                    f"{len(args.start_joints)}")
    return joint_values(args.start_joints, "--start-joints", robot)


def joint_values(values: Sequence[float], option: str, robot: Any) -> np.ndarray:
    """``values`` as an array; a joint configuration (robot.n values other than a position's 3)
    that looks like degrees (beyond two turns, which a continuous joint in radians may pass
    one of, and within the joint limits once converted to radians) is refused naming
    ``option``: radians expected."""
    array = np.array(values, dtype=float)
    if len(array) != robot.n or (len(array) == 3 and option != "--start-joints"):
        return array
    if np.max(np.abs(array)) > 4.0 * np.pi and bool(np.all(robot.within_limits(np.radians(array)))):
        raise InvalidParameterError(
            f"{option}: joint values {np.round(array, 2).tolist()} look like degrees: radians expected "
            f"(in radians {np.round(np.radians(array), 4).tolist()}, within the limits of {robot.name})")
    return array


def trajectory_summary(exported: dict[str, dict[str, Any]]) -> str:
    """One line per plan: the trajectory files written (duration, retimed or not) or why none."""
    lines = []
    for name, record in exported.items():
        if record["files"]:
            how = ("plan timing, not retimed" if not record["retimed"] else
                   "retimed, jerk-limited" if record.get("jerk_limits") else "retimed")
            lines.append(f"trajectory {name}: {', '.join(record['files'])} ({record['duration']:.2f} s, {how})")
        else:
            lines.append(f"trajectory {name}: none ({record['error']})")
    return "\n".join(lines)


def obstacle_below_path(result: PlanResult, size: float = 0.08, overlap: float = 0.02) -> Any:
    """A cube under the middle of a plan's end-effector path, reaching ``overlap`` m above it."""
    from scenes import Box
    middle = result.ee_path[len(result.ee_path) // 2]
    centre = middle - np.array([0.0, 0.0, 0.5 * size - overlap])
    return Box(centre, [size, size, size])


def planning_options(p: argparse.ArgumentParser, out_default: str | None = "clamp_out") -> None:
    """--out/--force and the planner settings; defaults are PlannerConfig()'s (clamp.config)."""
    p.add_argument("--out", default=out_default, required=out_default is None,
                   help="output folder: new or empty unless --force"
                        + (f" (default: {out_default})" if out_default else ""))
    p.add_argument("--force", action="store_true", help="replace files in a non-empty --out")
    p.add_argument("--fast", action="store_true",
                   help="PlannerConfig.fast(): stop at 5 %% relative decrease (about ten "
                        "iterations; less polished plans)")
    defaults = PlannerConfig()
    p.add_argument("--sigma-obs", type=number, default=None, metavar="M",
                   help=f"obstacle hinge noise [m] (default {defaults.model.sigma_obs})")
    p.add_argument("--epsilon", type=number, default=None, metavar="M",
                   help=f"soft safety distance [m]: the obstacle factors push the arm this far from "
                        f"obstacles where the skill allows; not a guarantee (default "
                        f"{defaults.model.epsilon}; see --min-clearance)")
    p.add_argument("--min-clearance", type=number, default=None, metavar="M",
                   help=f"required clearance [m]: a successful plan keeps the arm's collision geometry "
                        f"at least this far from every obstacle, at and between states (the planner "
                        f"holds it as a constraint; a plan that cannot fails, exit 1, no trajectory; a "
                        f"start closer is refused, exit 2; default {defaults.checks.min_clearance}: "
                        f"only a collision fails)")
    p.add_argument("--init", choices=INITIALISATIONS, default=None,
                   help=f"initialisation (default {defaults.optimizer.initialisation})")
    p.add_argument("--optimizer", choices=OPTIMIZERS, default=None,
                   help=f"optimizer (default {defaults.optimizer.optimizer})")
    p.add_argument("--max-iterations", type=integer_at_least(1), default=None, metavar="N",
                   help=f"(default {defaults.optimizer.max_iterations})")


def trajectory_options(p: argparse.ArgumentParser) -> None:
    """--acc-limit, --jerk-limit and --no-retime: how the executable trajectory is timed."""
    p.add_argument("--acc-limit", type=number, nargs="+", default=None, metavar="RAD_S2",
                   help="joint acceleration limit [rad/s^2] the trajectory is retimed to, one for all "
                        f"joints or one per joint (default {DEFAULT_ACCELERATION_LIMIT}; URDFs carry none: "
                        "use the arm's data sheet)")
    p.add_argument("--jerk-limit", type=number, nargs="+", default=None, metavar="RAD_S3",
                   help="joint jerk limit [rad/s^3], one for all joints or one per joint: the trajectory is "
                        "retimed jerk-limited along the planned path (ruckig, as MoveIt 2 smooths its "
                        "trajectories; for controllers that reject acceleration jumps); default: not jerk-limited")
    p.add_argument("--no-retime", action="store_true",
                   help="write the trajectory with the plan's own timing (not retimed: it may exceed "
                        "the limits and start and end moving)")


def robot_options(p: argparse.ArgumentParser, default_robot: str | None = None, required: bool = True) -> None:
    """--robot NAME or --urdf FILE --end-effector FRAME (plus URDF helpers); required unless
    there is a ``default_robot`` or ``required`` is False (clamp learn: only joint-space
    demonstrations need the arm)."""
    group = p.add_mutually_exclusive_group(required=required and default_robot is None)
    group.add_argument("--robot", default=default_robot,
                       help="registered robot (jaco, sawyer)"
                            + (f"; default {default_robot}" if default_robot else ""))
    group.add_argument("--urdf", default=None, metavar="FILE", help="any URDF arm")
    p.add_argument("--end-effector", default=None, metavar="FRAME",
                   help="with --urdf: the frame to plan for")
    p.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                   help="with --urdf: folder holding package:// meshes (repeatable)")
    p.add_argument("--base-frame", default=None, metavar="FRAME",
                   help="with --urdf: planning frame (default: the URDF root)")
    p.add_argument("--spheres", default=None, metavar="FILE",
                   help="with --urdf: collision sphere file (default: fitted from the URDF)")


DEMOS_HELP = ("demonstrations (.mat, .npz, .csv), or ROS 2 bags (folders, .mcap, .db3) with --topic")


def demonstration_options(p: argparse.ArgumentParser) -> None:
    """How --demos are read and learned: --topic / --split / --frames (bags), --num-points,
    --translate (shared by clamp learn and clamp plan)."""
    from scenes.bag_split import SPLITS
    p.add_argument("--topic", default=None,
                   help="bags: the topic to read (JointState, PoseStamped or /tf)")
    p.add_argument("--split", choices=SPLITS, default=None,
                   help="bags: auto (default): one demonstration per bag unless a bag holds rests "
                        "separating repeated motions, judged against its own speed and duration; bag: "
                        "one demonstration per bag; rest: cut at every rest of 2 mm/s for 2 s")
    p.add_argument("--frames", nargs=2, default=None, metavar=("PARENT", "CHILD"),
                   help="bags with --topic /tf: the transform to read")
    p.add_argument("--num-points", type=integer_at_least(2), default=None, metavar="T",
                   help="resample the demonstrations to T support states before learning "
                        "(default: as recorded)")
    p.add_argument("--translate", type=number, nargs=3, default=None, metavar=("DX", "DY", "DZ"),
                   help="move the demonstrations by dx dy dz [m] before learning")


def parser() -> argparse.ArgumentParser:
    """Argument parser of the ``clamp`` command."""
    main = CommandLineParser(prog="clamp", description="CLAMP: learn a skill from demonstrations "
                             "and plan it on a robot arm; executable trajectories out.")
    sub = main.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser("demo", help="learn a built-in synthetic skill and plan it")
    planning_options(demo)
    robot_options(demo, default_robot="jaco")
    trajectory_options(demo)
    demo.add_argument("--skill", default="box_closing", help="built-in skill (scenes.SKILLS)")
    figure_options(demo)
    demo.add_argument("--num-points", type=integer_at_least(4), default=250,
                      help="support states T (at least 4; default 250)")
    demo.set_defaults(run=run_demo)

    learn = sub.add_parser("learn", help="learn the prior from demonstrations and save it (plan from it "
                                         "with clamp plan --prior)")
    learn.add_argument("--out", required=True, metavar="FILE",
                       help="prior file (.npz, added when missing): new unless --force")
    learn.add_argument("--force", action="store_true", help="replace an existing --out file")
    learn.add_argument("--demos", required=True, nargs="+", metavar="FILE", help=DEMOS_HELP)
    demonstration_options(learn)
    robot_options(learn, required=False)
    learn.set_defaults(run=run_learn)

    user = sub.add_parser("plan", help="plan from demonstrations (learned here) or a saved prior")
    planning_options(user)
    robot_options(user)
    trajectory_options(user)
    source = user.add_mutually_exclusive_group(required=True)
    source.add_argument("--demos", nargs="+", metavar="FILE", help=DEMOS_HELP)
    source.add_argument("--prior", default=None, metavar="FILE",
                        help="a prior saved by clamp learn (.npz): plan without learning again "
                             "(the figures then show the prior without the demonstrations)")
    demonstration_options(user)
    starts = user.add_mutually_exclusive_group(required=True)
    starts.add_argument("--start", type=number, nargs="+", default=None, metavar="X",
                        help="start: end-effector position x y z [m] (or a joint configuration)")
    starts.add_argument("--start-joints", type=number, nargs="+", default=None, metavar="Q",
                        help="start: the robot's measured joint configuration q1 .. qn [rad], "
                             "e.g. from /joint_states")
    user.add_argument("--goal", type=number, nargs="+", default=None,
                      help="goal: end-effector position x y z [m] (a pose with --goal-quaternion) or a "
                           "joint configuration q1 .. qn [rad]")
    user.add_argument("--goal-quaternion", type=number, nargs="+", default=None,
                      metavar="Q",
                      help="with --goal x y z: the hand's rotation at the goal, 4 numbers: a unit "
                           "quaternion qx qy qz qw (the order of ROS geometry_msgs/Quaternion, as tf2_echo "
                           "prints it), in the planning frame; for a skill learned with the hand's "
                           "rotation")
    user.add_argument("--scene", default=None, help="scene JSON file (scenes.Scene.save)")
    user.add_argument("--figures", action="store_true",
                      help="also draw the figures (prior, plan 3-D, top view, joints, clearance, "
                           "uncertainty) and the browser animation: seconds more (default: plan and "
                           "trajectory files only; clamp show OUT draws them later)")
    figure_options(user)
    user.set_defaults(run=run_plan)
    add_batch_parser(sub)
    add_view_parser(sub)
    add_show_parser(sub)
    return main


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``clamp``; returns the exit code (0 success, 1 plan failed, 2 bad input)."""
    return run(parser(), argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
