"""``clamp view FOLDER``: the plan of a ``clamp plan`` / ``clamp demo`` output folder, live in the
browser (:class:`clamp.viz.viewer.PlanViewer` on 127.0.0.1), until Ctrl-C.

The planning commands record what a view needs to plan again (:func:`save_view_inputs`):
``prior.npz`` (the learned prior), ``demos.npz`` (the demonstrations, as learned from) and one
``problem_<plan>.json`` per plan: a planning problem in the format of :mod:`clamp.batch.problems`
(one JSON object; robot, scene, start, goal, settings; prior ``{"file": "prior.npz"}``;
``meta.demonstrations`` names the demonstration file, absent for a plan from ``--prior``). ``clamp view`` plans that problem again
(:mod:`clamp.batch.runner`'s resolver: same inputs, same plan) and serves it; dragging a box or the
goal in the page replans. Folders written before these files existed cannot be viewed.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import fields
from pathlib import Path
from typing import Any

from clamp.errors import InvalidParameterError
from clamp.config import GROUPS, PlannerConfig
from clamp.batch.problems import Problem, make_problem
from skillplan.command_line import atomic_write_text
from skillplan.validation import as_path
from skillplan.command_line import EXIT_OK, quiet
from skillplan.command_line import integer_at_least

PRIOR_FILE = "prior.npz"
DEMOS_FILE = "demos.npz"


def problem_file(name: str) -> str:
    """File name of the recorded problem of plan ``name`` (``plan``, ``obstacle``, ...)."""
    return f"problem_{name}.json"


def config_changes(config: Any) -> dict[str, Any]:
    """The fields of a PlannerConfig that differ from ``PlannerConfig()`` (field -> value)."""
    default = PlannerConfig()
    return {f.name: getattr(getattr(config, group), f.name)
            for group in GROUPS for f in fields(getattr(config, group))
            if getattr(getattr(config, group), f.name) != getattr(getattr(default, group), f.name)}


def save_view_inputs(out: Path, plans: dict[str, dict[str, Any]], prior: Any, demos: Any,
                     robot_spec: dict[str, Any], config: Any) -> None:
    """Write prior.npz, demos.npz and problem_<name>.json (name -> {"scene", "start", "goal"})
    into the output folder ``out`` (see the module docstring); ``demos`` None (a plan from a
    saved prior): no demos.npz, and the problems name no demonstrations."""
    prior.save(out / PRIOR_FILE)
    if demos is not None:
        demos.save_npz(out / DEMOS_FILE)
    for name, request in plans.items():
        problem = make_problem(name, {"file": PRIOR_FILE}, robot_spec, request["start"], scene=request["scene"],
                               goal=request.get("goal"), config=config_changes(config),
                               meta={} if demos is None else {"demonstrations": DEMOS_FILE})
        atomic_write_text(out / problem_file(name), problem.to_json() + "\n", overwrite=True)


def robot_spec(args: argparse.Namespace) -> dict[str, Any]:
    """The robot of the planning command line as a problem's robot field."""
    if args.urdf is None:
        return {"name": args.robot}
    spec = {"urdf": str(Path(args.urdf).resolve()), "end_effector": args.end_effector,
            "base_frame": args.base_frame}
    if args.package_dir:
        spec["package_dirs"] = [str(Path(folder).resolve()) for folder in args.package_dir]
    if args.spheres:
        spec["spheres"] = str(Path(args.spheres).resolve())
    return spec


def load_view(folder: str | Path, name: str | None = None) -> tuple[Any, Any]:
    """Plan the recorded problem of ``folder`` again; returns (PlanResult, Demonstrations).
    ``name``: which plan (``problem_<name>.json``); None: the only one, or ``obstacle``."""
    _, _, result, demos = replan_recorded(folder, name)
    return result, demos


def replan_recorded(folder: str | Path, name: str | None = None) -> tuple[str, dict[str, Any], Any, Any]:
    """The recorded problem ``name`` of the output folder ``folder`` (None: the only one, or
    ``obstacle``) planned again: (its name, the keyword arguments of :func:`clamp.plan`, the
    PlanResult, the Demonstrations or None)."""
    from clamp.batch.runner import resolve      # deferred: the planner loads when a plan is made
    from clamp.planning.planner import plan
    from scenes import Demonstrations
    folder = Path(as_path(folder, "FOLDER", InvalidParameterError))
    if not folder.is_dir():
        raise InvalidParameterError(f"FOLDER: expected the output folder of clamp plan / clamp demo, "
                                    f"got {str(folder)!r} ({'not a folder' if folder.exists() else 'missing'})")
    found = sorted(p.name[len("problem_"):-len(".json")] for p in folder.glob(problem_file("*")))
    if not found:
        raise InvalidParameterError(f"FOLDER: {str(folder)!r} holds no {problem_file('*')} (written by clamp plan "
                                    "and clamp demo; rerun the command to view its plan)")
    if name is None:
        name = found[0] if len(found) == 1 else "obstacle" if "obstacle" in found else None
        if name is None:
            raise InvalidParameterError(f"--plan: {str(folder)!r} holds several plans; choose one of {found}")
    elif name not in found:
        raise InvalidParameterError(f"--plan: no plan {name!r} in {str(folder)!r}; choose one of {found}")
    problem = Problem.from_json((folder / problem_file(name)).read_text(encoding="utf-8"),
                                source=str(folder / problem_file(name)))
    inputs = resolve(problem, folder)
    result = plan(**inputs)
    demos_file = problem.to_dict()["meta"].get("demonstrations")
    demos = Demonstrations.load_npz(folder / demos_file) if demos_file else None
    return name, inputs, result, demos


def run_view(args: argparse.Namespace) -> int:
    from clamp.viz.viewer import PlanViewer     # deferred: viser is the optional "viewer" extra
    result, demos = load_view(args.folder, args.plan)
    with PlanViewer(result, demonstrations=demos, port=args.port) as viewer:
        if not quiet(args):
            print(f"clamp view: {viewer.url} (Ctrl-C stops)", flush=True)
        while True:
            time.sleep(1.0)
    return EXIT_OK   # pragma: no cover (left by Ctrl-C: exit 130)


def add_view_parser(sub: Any) -> None:
    """Register ``clamp view`` on the ``clamp`` subparsers."""
    view = sub.add_parser("view", help="show the plan of an output folder live in the browser (127.0.0.1)")
    view.add_argument("folder", metavar="FOLDER", help="output folder of clamp plan / clamp demo")
    view.add_argument("--plan", default=None, metavar="NAME",
                      help="which plan of the folder (problem_NAME.json; default: the only one, or obstacle)")
    view.add_argument("--port", type=integer_at_least(0), default=8080,
                      help="port on 127.0.0.1 (default 8080; 0: a free one)")
    view.set_defaults(run=run_view)
