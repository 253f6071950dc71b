"""Many plans: run :class:`~clamp.batch.problems.Problem` s in this process, a local process pool,
any ``concurrent.futures.Executor`` or a Dask cluster, streaming one JSON line per problem.

::

    for record in plan_many(problems, executor=None | 2 | LocalPool(2) | executor | dask_client,
                            out="results.jsonl"):
        record["id"], record["status"], record["success"], record["reasons"]

``plan_many`` yields a record (a JSON-ready dict) per problem as it finishes:

- ``id``, ``hash`` (:attr:`Problem.hash`), ``expected`` (the problem's label), ``meta``;
- ``status``: ``"done"`` (planned; ``success`` / ``reasons`` are the planner's verdict),
  ``"error"`` (resolving or planning the problem raised: ``error`` = {type, message} and, for
  errors that are not input errors, ``traceback``) or ``"lost"`` (the worker running it died
  ``retries + 1`` times; planned again by a rerun);
- ``verdict``: ``PlanResult.verdict()`` (min clearance, start / goal errors, limits);
  ``metrics``: iterations, stop reason, final error, plausibility (null when the plan failed
  before optimising: stop reason "not started");
- ``timings`` [s]: the plan's own (``total``, ``build``, ``optimize``, ...) plus ``load``
  (robot, prior, scene, config), ``wall`` (all of the worker's time for the problem) and
  ``cpu`` (the CPU time of the worker's thread for it: wall time less waiting for a core);
- ``attempts``, ``worker`` ("host:pid");
- ``trajectory``: the plan as a ``robots.JointTrajectory`` JSON object (``trajectories=
  "inline"``), the path of that file (``trajectories=DIR``) or null (``"none"``);
- ``non_finite``: {dotted path: "NaN" | "inf" | "-inf"} of the numbers written as null
  (``metrics.final_error``, a NaN the user put in ``meta``, ...).

With ``out`` (:mod:`clamp.batch.results`), the results file is locked for the run (a second
run on it is refused at once, naming the holder's pid), every record is appended to it before
it is yielded, as one ``write`` of a complete strict-JSON line (NaN / inf written as null and
listed in the record's ``non_finite``), and problems the file holds as finished ("done" or
"error") are skipped: rerunning with the same file resumes, and plans the "lost" ones again. A
killed batch leaves whole lines (a torn last line left by a crash is removed on the next run);
a retried problem's earlier "lost" line is dropped when the run ends (atomic rewrite), and
readers take each problem's latest line, so the file holds one line per problem.

Executors. ``None``: in this process, one problem after the other. An int N or a
:class:`~clamp.batch.pool.LocalPool`: N spawned worker processes, one problem each; a worker
that dies costs only its own problem (tried again ``retries`` times, then recorded as lost) and
is replaced; workers die with the batch's process (:mod:`clamp.batch.pool`). Any other
``concurrent.futures.Executor``: used as it is (an executor that breaks, as
``ProcessPoolExecutor`` does when one of its workers dies, stops the batch with an error; rerun
to resume). A ``distributed.Client``: Dask runs the problems (a worker's death is retried by
Dask's scheduler, ``distributed.scheduler.allowed-failures``, then recorded as lost); install
with ``pip install '.[dask]'`` and run workers with one thread each.

Each worker process (and thread) keeps the robots and priors it loaded (a few of each, least
recently used dropped) and reuses them across problems.
"""
from __future__ import annotations

import concurrent.futures as cf
import json
import logging
import os
import socket
import threading
import time
import traceback
import warnings
from collections import OrderedDict
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from clamp.batch.pool import LocalPool, WorkerDied
from clamp.batch.results import (LOST, ResultsFile, finished_hashes, read_results,
                                 strict_json)
from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.batch.problems import Problem, check_unique_ids
from skillplan.command_line import atomic_write_text, writable_folder
from skillplan.validation import as_path, as_sequence
from clamp.prior.learning import learn_prior
from clamp.prior.linear_gaussian import WorkspacePrior
from scenes import make_demonstrations
from scenes import load_demonstrations
from robots import resolve_robot
from clamp.config import PlannerConfig
from scenes import Scene
from clamp.planning.planner import plan
from scenes.errors import InvalidArgumentError
from skillplan.threads import single_blas_thread

__all__ = ["LocalPool", "ResultsFile", "TRAJECTORY_MODES", "WorkerDied", "load_prior",
           "load_robot", "pending_problems", "plan_many", "read_results", "resolve",
           "run_problem"]

log = logging.getLogger(__name__)

#: what ``trajectories`` may be besides a folder
TRAJECTORY_MODES = ("inline", "none")
_CACHE_SIZE = 8
_LOCAL = threading.local()


# =============================================================== worker side: resolve and plan
def _cached(kind: str, key: Any, make: Callable[[], Any]) -> Any:
    """Per-thread LRU cache of loaded robots / priors (a few entries per kind)."""
    caches = getattr(_LOCAL, "caches", None)
    if caches is None:
        caches = _LOCAL.caches = {}
    cache = caches.setdefault(kind, OrderedDict())
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    value = make()
    cache[key] = value
    if len(cache) > _CACHE_SIZE:
        cache.popitem(last=False)
    return value


def _path(value: str, base: Path) -> Path:
    path = Path(value).expanduser()
    return path if path.is_absolute() else base / path


def load_prior(spec: dict[str, Any], base: Path) -> Any:
    """The prior a problem names: a prior file (``file``, or ``path``; relative to ``base``,
    the problems file's folder), demonstrations to learn from, or a skill."""
    for key in ("file", "path"):
        if key in spec:
            return WorkspacePrior.load(_path(spec[key], base))
    if "demos" in spec:
        return learn_prior(load_demonstrations(_path(spec["demos"], base)))
    return learn_prior(make_demonstrations(spec["skill"], num_demos=spec["num_demos"],
                                           num_points=spec["num_points"], seed=spec["seed"]))


def load_robot(spec: dict[str, Any], base: Path) -> Any:
    """The robot a problem names: built-in by name, or a URDF (relative to ``base``) with its
    end-effector frame (:func:`robots.resolve_robot`, the command lines' loader too)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return resolve_robot(spec, base)


def resolve(problem: Problem, base: Path) -> dict[str, Any]:
    """Keyword arguments of :func:`clamp.plan` for ``problem`` (robots and priors cached)."""
    import numpy as np

    data, key = problem.to_dict(), str(base)
    prior = _cached("prior", (problem.prior, key), lambda: load_prior(data["prior"], base))
    robot = _cached("robot", (problem.robot, key), lambda: load_robot(data["robot"], base))
    scene = problem.scene_data()
    if isinstance(scene, str):
        scene = Scene.load(_path(scene, base))
    elif scene is not None:
        scene = Scene.from_dict(scene, source=f"problem {problem.id!r} scene", folder=base)
    goal = data["goal"]
    if isinstance(goal, dict):                    # a pose: (position, quaternion) as plan takes it
        goal = (np.array(goal["position"]), np.array(goal["quaternion"]))
    elif goal is not None:
        goal = np.array(goal)
    return {"prior": prior, "robot": robot, "scene": scene, "start": np.array(problem.start),
            "goal": goal,
            "via_points": [(i, np.array(v)) for i, v in problem.via_points],
            "config": PlannerConfig().with_(**problem.config_changes())}


def _record(problem: Problem, **fields: Any) -> dict[str, Any]:
    return {"id": problem.id, "hash": problem.hash, "status": fields.pop("status"),
            "success": fields.pop("success", False), "reasons": fields.pop("reasons", []),
            "expected": problem.expected, "meta": problem.to_dict()["meta"],
            "verdict": None, "metrics": None, "timings": {}, "attempts": 1,
            "worker": f"{socket.gethostname()}:{os.getpid()}", "error": None, "trajectory": None,
            **fields}


def run_problem(data: dict[str, Any], base: str, trajectory: bool = True) -> dict[str, Any]:
    """Plan one problem (its JSON object) and return its record; never raises for a bad
    problem (the error is recorded). ``base``: folder of relative paths. Runs in workers."""
    t0, cpu0 = time.perf_counter(), time.thread_time()
    problem = Problem.from_dict(data)
    try:
        with single_blas_thread():  # one BLAS thread per worker: workers are the parallelism
            kwargs = resolve(problem, Path(base))
            t_load = time.perf_counter() - t0
            robot = kwargs["robot"]
            result = plan(**kwargs, covariance=False)
            traj = result.to_joint_trajectory(robot).to_dict() if trajectory else None
    except Exception as exc:  # recorded, the batch goes on
        error = {"type": type(exc).__name__, "message": str(exc)}
        extra = {} if isinstance(exc, InvalidArgumentError) else {
            "traceback": traceback.format_exc(limit=-4)}
        return _record(problem, status="error", error=error,
                       timings={"wall": time.perf_counter() - t0}, **extra)
    metrics = {"iterations": int(result.iterations), "stop_reason": result.stop_reason,
               "final_error": float(result.final_error),
               "plausibility": float(result.plausibility)}
    timings = {**{k: float(v) for k, v in result.timings.items()}, "load": t_load,
               "wall": time.perf_counter() - t0, "cpu": time.thread_time() - cpu0}
    return _record(problem, status="done", success=bool(result.success),
                   reasons=list(result.reasons), verdict=result.verdict(), metrics=metrics,
                   timings=timings, trajectory=traj)


# =============================================================== runners
class _Serial:
    """In this process, one problem after the other."""

    window = 1

    def __init__(self) -> None:
        self._done: list[tuple[Any, Any]] = []

    def submit(self, function: Callable[..., Any], *args: Any) -> Any:
        token = object()
        self._done.append((token, function(*args)))
        return token

    def next_done(self) -> list[tuple[Any, Any, BaseException | None]]:
        done, self._done = self._done, []
        return [(token, record, None) for token, record in done]

    def close(self) -> None:
        pass


class _Futures:
    """Any concurrent.futures executor, used as it is (one that breaks stops the batch)."""

    def __init__(self, executor: Any):
        self._executor = executor
        self.window = 2 * int(getattr(executor, "_max_workers", os.cpu_count() or 2))
        self._pending: set[cf.Future] = set()

    def submit(self, function: Callable[..., Any], *args: Any) -> Any:
        try:
            future = self._executor.submit(function, *args)
        except cf.BrokenExecutor as exc:
            future = cf.Future()
            future.set_exception(exc)
        self._pending.add(future)
        return future

    def next_done(self) -> list[tuple[Any, Any, BaseException | None]]:
        done, self._pending = cf.wait(self._pending, return_when=cf.FIRST_COMPLETED)
        out = [(f, None if f.exception() else f.result(), f.exception()) for f in done]
        broken = next((e for _, _, e in out if isinstance(e, cf.BrokenExecutor)), None)
        if broken is not None:
            raise RuntimeError("the executor broke (a worker died); rerun with the same output "
                               "to resume, or use workers=N (a dead local worker costs only "
                               "its own problem)") from broken
        return out

    def close(self) -> None:
        for future in self._pending:
            future.cancel()


class _Dask:
    """A distributed.Client: Dask schedules, retries on worker death, reports KilledWorker."""

    def __init__(self, client: Any):
        from distributed import as_completed
        self._client = client
        self._completed = as_completed(with_results=False)
        self.window = 2 * max(1, sum(client.nthreads().values()))

    def submit(self, function: Callable[..., Any], *args: Any) -> Any:
        future = self._client.submit(function, *args, pure=False)
        self._completed.add(future)
        return future

    def next_done(self) -> list[tuple[Any, Any, BaseException | None]]:
        out = []
        for future in [next(self._completed)] + list(self._completed.next_batch(block=False)):
            if future.status == "finished":
                out.append((future, future.result(), None))
            else:
                try:
                    future.result()
                    error: BaseException = RuntimeError(f"task ended as {future.status}")
                except BaseException as exc:  # KilledWorker, CancelledError, ...
                    error = exc
                out.append((future, None, error))
        return out

    def close(self) -> None:
        self._completed.clear()


def _runner(executor: Any) -> tuple[Any, Callable[[], None]]:
    """The runner for ``executor`` and what to call when the batch ends."""
    if executor is None:
        return _Serial(), lambda: None
    if isinstance(executor, int) and not isinstance(executor, bool):
        pool = LocalPool(executor)
        return pool, pool.shutdown
    if isinstance(executor, LocalPool):
        return executor, lambda: None
    if isinstance(executor, cf.Executor):
        return _Futures(executor), lambda: None
    if type(executor).__module__.startswith("distributed") and hasattr(executor, "nthreads"):
        return _Dask(executor), lambda: None
    raise InvalidParameterError(f"executor: expected None, a number of workers, a LocalPool, a "
                                f"concurrent.futures.Executor or a distributed.Client, got "
                                f"{type(executor).__name__}")


def pending_problems(problems: Iterable[Problem], out: str | Path | ResultsFile | None
                     ) -> list[Problem]:
    """The problems still to plan: ids checked unique (so hashes are too) and, with ``out``,
    those the results file holds as finished ("done" or "error"; a "lost" one is planned
    again) left out. A path is read without taking its lock."""
    problems = list(problems)
    for k, problem in enumerate(problems):
        if not isinstance(problem, Problem):
            raise InvalidParameterError(f"problems[{k}]: expected a clamp.batch.problems.Problem, got "
                                        f"{type(problem).__name__}")
    check_unique_ids(problems)
    if isinstance(out, ResultsFile):
        return out.pending(problems)
    done = finished_hashes(out) if out is not None and Path(out).is_file() else set()
    return [p for p in problems if p.hash not in done]


def _trajectory_mode(trajectories: str | Path) -> Path | None:
    if isinstance(trajectories, str) and trajectories in TRAJECTORY_MODES:
        return None
    folder = Path(trajectories)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InvalidParameterError(f"trajectories: cannot create folder {str(folder)!r} "
                                    f"({exc.strerror or exc})") from None
    writable_folder(folder, "trajectories", InvalidParameterError)
    return folder


# =============================================================== plan_many
def plan_many(problems: Iterable[Problem], executor: Any = None, *,
              out: str | Path | ResultsFile | None = None, retries: int = 2,
              base_dir: str | Path | None = None,
              trajectories: str | Path = "inline") -> Iterator[dict[str, Any]]:
    """Plan ``problems`` and yield one record per problem as it finishes (see the module
    docstring for the record, the executors and the output file).

    out: a results file path (opened and locked for the batch, see
    :mod:`clamp.batch.results`) or a :class:`ResultsFile` the caller opened (and closes);
    retries: how many times a problem whose local worker died is tried again before it is
    recorded as lost; base_dir: folder of the problems' relative paths (default: the working
    folder); trajectories: "inline" (in the record), "none", or a folder for one trajectory
    JSON file per problem (named by its hash). Closing the generator early stops the batch
    (the lines written so far stay; rerun with the same ``out`` to resume).
    """
    if not isinstance(retries, int) or isinstance(retries, bool) or retries < 0:
        raise InvalidParameterError(f"retries: expected an integer >= 0, got {retries!r}")
    problems = as_sequence(problems, "problems", "a list of clamp.batch.problems.Problem",
                           ClampTypeError)
    if out is not None and not isinstance(out, ResultsFile) \
            and as_path(out, "out", ClampTypeError).is_dir():
        raise InvalidParameterError(f"out: {out} is a folder; expected a results file (JSON "
                                    "Lines, new or from an earlier run)")
    if base_dir is not None:
        as_path(base_dir, "base_dir", ClampTypeError)
    if not (isinstance(trajectories, str) and trajectories in TRAJECTORY_MODES):
        if as_path(trajectories, "trajectories", ClampTypeError).exists() \
                and not Path(trajectories).is_dir():
            raise InvalidParameterError(f"trajectories: expected 'inline', 'none' or a folder, "
                                        f"got the existing file {str(trajectories)!r}")
    pending_problems(problems, None)                # ids unique, every item a Problem
    base = str(Path(base_dir if base_dir is not None else os.getcwd()).resolve())
    owned = out is not None and not isinstance(out, ResultsFile)
    results = ResultsFile(out) if owned else out    # checked and locked before any work
    try:
        todo = pending_problems(problems, results)
        if results is not None and len(todo) < len(problems):
            # a rerun: say what is left, so an empty result is not mistaken for a batch of none
            (log.warning if not todo else log.info)(
                "%d new problems; %d already in %s", len(todo), len(problems) - len(todo),
                results.path)
        folder = _trajectory_mode(trajectories)
        want_trajectory = not (folder is None and trajectories == "none")
        runner, finish = _runner(executor)
    except BaseException:
        if owned:
            results.close()
        raise
    queue = todo[::-1]             # pop() from the end keeps the given order
    in_flight: dict[Any, tuple[Problem, int]] = {}
    try:
        while queue or in_flight:
            while queue and len(in_flight) < runner.window:
                problem = queue.pop()
                handle = runner.submit(run_problem, problem.to_dict(), base, want_trajectory)
                in_flight[handle] = (problem, 1)
            for handle, record, error in runner.next_done():
                problem, attempt = in_flight.pop(handle)
                if error is not None:
                    if isinstance(error, WorkerDied) and attempt <= retries:
                        again = runner.submit(run_problem, problem.to_dict(), base,
                                              want_trajectory)
                        in_flight[again] = (problem, attempt + 1)
                        continue
                    record = _record(problem, status=LOST, error={
                        "type": type(error).__name__,
                        "message": f"the worker running it died or the task failed "
                                   f"({error}); tried {attempt} time(s)"})
                record["attempts"] = attempt
                record, replaced = strict_json(record)
                record["non_finite"] = replaced
                if folder is not None and record.get("trajectory") is not None:
                    path = folder / f"{problem.hash}.json"
                    atomic_write_text(path, json.dumps(record["trajectory"], allow_nan=False)
                                      + "\n", overwrite=True)
                    record["trajectory"] = str(path)
                if results is not None:
                    results.append(record)
                yield record
    finally:
        runner.close()
        finish()
        if owned:
            results.close()
