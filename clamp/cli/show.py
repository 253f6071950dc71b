"""``clamp show FOLDER``: the figures and the browser animation of a plan in an output folder of
``clamp plan`` (which draws them only with ``--figures``) or ``clamp demo``, drawn into it.

The plan is made again from the folder's recorded problem (:func:`clamp.cli.viewer.replan_recorded`,
as ``clamp view`` does: the same inputs, the same plan) and drawn by the planning commands'
own figure writer, under the names they give it, on the clock ``--clock`` asks (default: the
executable trajectory's, when the plan JSON the run wrote records one). Figures already in the
folder are replaced only with ``--force``.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from clamp.cli.figures import figure_clocks, figure_options, plan_json
from clamp.cli.viewer import replan_recorded
from skillplan.command_line import EXIT_OK, quiet
from skillplan.errors import OutputPathError

#: the name of a recorded plan's figures where it differs from the plan's: ``clamp plan``
#: records its problem as ``plan`` and names its figures and trajectory ``result``
FIGURE_NAMES = {"plan": "result"}


def recorded_trajectory(folder: Path, name: str) -> dict[str, Any]:
    """The trajectory record of plan ``name`` in the plan JSON of ``folder`` (files, duration,
    state_times, error; :func:`clamp.cli.commands.write_trajectory`); an empty one when the JSON
    is missing or unreadable (its figures are then on the skill's clock)."""
    path = folder / plan_json(name)
    try:
        record = json.loads(path.read_text(encoding="utf-8")).get("trajectory")
    except (OSError, ValueError, AttributeError):
        return {"error": f"{path.name} cannot be read"}
    return record if isinstance(record, dict) else {"error": f"{path.name} records no trajectory"}


def run_show(args: argparse.Namespace) -> int:
    from clamp.cli.figures import write_figures
    folder = Path(args.folder)
    name, inputs, result, demos = replan_recorded(folder, args.plan)
    figure = FIGURE_NAMES.get(name, name)
    if (folder / f"plan_{figure}.png").exists() and not args.force:
        raise OutputPathError(f"--force: {str(folder)!r} already holds the figures of plan {name!r} "
                              f"(plan_{figure}.png); pass --force to draw them again")
    record = recorded_trajectory(folder, name)
    if len(record.get("state_times") or ()) != len(result.q):
        record = {"error": record.get("error") or "its trajectory does not match the plan"}
    write_figures(folder, inputs["prior"], demos, inputs["robot"], inputs["config"],
                  [(figure, result, inputs["scene"])], figure_clocks(args.clock, {figure: record}))
    if not quiet(args):
        print(f"wrote the figures and the animation of plan {name!r} to {folder} (plan_{figure}*.png, "
              f"animation_{figure}.html)")
    return EXIT_OK


def add_show_parser(sub: Any) -> None:
    """Register ``clamp show`` on the ``clamp`` subparsers."""
    show = sub.add_parser("show", help="draw the figures and the animation of a plan in an output folder "
                                       "(clamp plan draws them only with --figures)")
    show.add_argument("folder", metavar="FOLDER", help="output folder of clamp plan / clamp demo")
    show.add_argument("--plan", default=None, metavar="NAME",
                      help="which plan of the folder (problem_NAME.json; default: the only one, or obstacle)")
    show.add_argument("--force", action="store_true", help="draw again over figures already in FOLDER")
    figure_options(show)
    show.set_defaults(run=run_show)
