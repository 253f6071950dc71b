"""``clamp batch problems.jsonl --out results.jsonl [--workers N] [--scheduler ADDRESS]``.

Plans every problem of a JSON Lines problems file (:mod:`clamp.batch.problems`) and appends one
result line per problem to ``--out`` as it finishes (:mod:`clamp.batch.runner`); a rerun with the
same ``--out`` skips the problems already there. In this process by default, in N local
worker processes with ``--workers N``, on a Dask cluster with ``--scheduler ADDRESS``. Shows a
progress bar (done, failed, rate, ETA; :mod:`skillplan.progress`: on a terminal only, never with
``-q``) and prints a summary of the whole output file for the problems of this file (not with
``-q``). Every problem of the file that did not pass gets one line on stderr, also under ``-q``:
its first reason (:func:`failure_line`). Exit code, as ``clamp plan``'s: 0 every problem
passed its verdict, 1 some failed it or were recorded as error or lost, 2 bad input, 130
interrupted (rerun to resume).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from clamp.errors import InvalidParameterError
from clamp.batch.problems import ProblemFormatError, read_problems
from skillplan.validation import as_file
from skillplan.command_line import integer_at_least, quiet
from skillplan.progress import progress


def add_batch_parser(sub: Any) -> None:
    """Register ``batch`` on the ``clamp`` command's subparsers."""
    p = sub.add_parser("batch", help="plan every problem of a JSON Lines file",
                       description=__doc__.splitlines()[0].replace("``", ""))
    p.add_argument("problems", help="problems file (JSON Lines, one clamp problem per line)")
    p.add_argument("--out", required=True, help="results file (JSON Lines; appended, resumable)")
    p.add_argument("--workers", type=integer_at_least(1), default=None,
                   help="local worker processes (default: plan in this process)")
    p.add_argument("--scheduler", default=None,
                   help="address of a Dask scheduler, e.g. tcp://host:8786 (pip install '.[dask]')")
    p.add_argument("--retries", type=integer_at_least(0), default=2,
                   help="tries again of a problem whose worker died (default 2)")
    p.add_argument("--trajectories", default="inline",
                   help="'inline' (in each result line, default), 'none', or a folder for one "
                        "trajectory JSON file per problem")
    p.set_defaults(run=run_batch)


def _executor(args: argparse.Namespace) -> tuple[Any, Any]:
    """The executor for the options and what closes it."""
    if args.workers is not None and args.scheduler is not None:
        raise InvalidParameterError("--workers, --scheduler: expected at most one of them")
    if args.scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise InvalidParameterError("--scheduler: Dask is not installed; pip install "
                                        "'skillplan[dask]' (or '.[dask]' in a checkout)") from None
        try:
            client = Client(args.scheduler, timeout="20s")
        except OSError as exc:
            raise InvalidParameterError(f"--scheduler: cannot reach {args.scheduler!r} ({exc})") \
                from None
        return client, client.close
    if args.workers is not None:
        from clamp.batch.pool import LocalPool
        pool = LocalPool(args.workers)
        return pool, pool.shutdown
    return None, lambda: None


def run_batch(args: argparse.Namespace) -> int:
    # deferred: the runner loads the planner; building the parser (clamp --help) stays light
    from clamp.batch.report import summarize, summary_table
    from clamp.batch.runner import TRAJECTORY_MODES, ResultsFile, pending_problems, plan_many, read_results
    problems_path = as_file(args.problems, "problems", ProblemFormatError)
    out = Path(args.out)
    if out.exists() and out.resolve() == problems_path.resolve():
        raise InvalidParameterError("--out: must not be the problems file")
    if args.trajectories not in TRAJECTORY_MODES and Path(args.trajectories).is_file():
        raise InvalidParameterError(f"--trajectories: expected 'inline', 'none' or a folder, got "
                                    f"the file {args.trajectories!r}")
    problems = read_problems(problems_path)
    failed = 0
    with ResultsFile(out, option="--out") as results:      # checked and locked before any work
        todo = pending_problems(problems, results)
        if len(todo) < len(problems) and not quiet(args):
            print(f"{out}: {len(problems) - len(todo)} of {len(problems)} problems already "
                  f"done; resuming", file=sys.stderr)
        executor, close = _executor(args)
        bar = progress(description="planning", total=len(todo), unit="plan")
        try:
            for record in plan_many(todo, executor, out=results, retries=args.retries,
                                    base_dir=problems_path.resolve().parent,
                                    trajectories=args.trajectories):
                failed += not (record["status"] == "done" and record["success"])
                bar.set_postfix(failed=failed, refresh=False)
                bar.update()
        except KeyboardInterrupt:
            bar.close()
            print("clamp batch: interrupted; rerun the same command to resume", file=sys.stderr)
            return 130
        finally:
            bar.close()
            close()
    hashes = {p.hash for p in problems}
    records = [r for r in read_results(out) if r.get("hash") in hashes]
    summary = summarize(records)
    if not quiet(args):
        print(summary_table(summary))
    failures = [failure_line(record) for record in records if not passed(record)]
    for line in failures:                       # also under -q: exit code 1 says so, this says why
        print(f"clamp batch: {line}", file=sys.stderr)
    return 1 if failures else 0


def passed(record: dict[str, Any]) -> bool:
    """Whether a result record's problem was planned and passed its verdict."""
    return record.get("status") == "done" and bool(record.get("success"))


def failure_line(record: dict[str, Any]) -> str:
    """Why a result record's problem did not pass, in one line: its first reason (a plan that
    failed its verdict), its error (type and message) or that its worker was lost."""
    name = f"problem {record.get('id')!r}"
    status = record.get("status")
    if status == "done":
        reasons = record.get("reasons") or ["no reason recorded"]
        return f"{name} failed: {reasons[0]}"
    if status == "error":
        error = record.get("error") or {}
        message = " ".join(str(error.get("message", "")).split())
        return f"{name}: error: {error.get('type', 'Error')}: {message}"
    return f"{name}: {status}: its worker died every try; rerun the same command to plan it again"
