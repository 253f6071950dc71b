"""Many plans: run :class:`~clamp.problems.Problem` s in this process, a local process pool,
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
  ``retries + 1`` times, or the executor broke);
- ``verdict``: ``PlanResult.verdict()`` (min clearance, start / goal errors, limits);
  ``metrics``: iterations, stop reason, final error, plausibility, start IK error;
- ``timings`` [s]: the plan's own (``total``, ``build``, ``optimize``, ...) plus ``load``
  (robot, prior, scene, config), ``wall`` (all of the worker's time for the problem) and
  ``cpu`` (the CPU time of the worker's thread for it: wall time less waiting for a core);
- ``attempts``, ``worker`` ("host:pid");
- ``trajectory``: the plan as a ``robots.JointTrajectory`` JSON object (``trajectories=
  "inline"``), the path of that file (``trajectories=DIR``) or null (``"none"``).

With ``out``, every record is appended to that JSON Lines file before it is yielded, as one
``write`` of the complete line (a killed batch leaves whole lines; a torn last line left by a
crash is removed on the next run), and problems whose hash the file already holds are skipped:
rerunning with the same file resumes. Exactly one line per problem.

Executors. ``None``: in this process, one problem after the other. An int N or a
:class:`LocalPool`: N spawned worker processes (``concurrent.futures.ProcessPoolExecutor``);
a worker that dies breaks that pool, so the pool is restarted and the problems that were in
flight (at most two per worker) are submitted again, each counting an attempt. Any other
``concurrent.futures.Executor``: used as it is (an executor that breaks stops the batch with
an error; rerun to resume). A ``distributed.Client``: Dask runs the problems (a worker's death
is retried by Dask's scheduler, ``distributed.scheduler.allowed-failures``, then recorded as
lost); install with ``pip install '.[dask]'`` and run workers with one thread each.

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

from clamp.errors import ArgumentTypeError, InvalidParameterError
from clamp.problems import Problem, check_unique_ids, iter_json_lines
from scenes.validation import as_path, as_sequence

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
    """The prior a problem names: a prior file, demonstrations to learn from, or a skill."""
    from clamp.learning import learn_prior
    from clamp.prior import WorkspacePrior
    if "path" in spec:
        return WorkspacePrior.load(_path(spec["path"], base))
    if "demos" in spec:
        from scenes import load_demonstrations
        return learn_prior(load_demonstrations(_path(spec["demos"], base)))
    from scenes import make_demonstrations
    return learn_prior(make_demonstrations(spec["skill"], num_demos=spec["num_demos"],
                                           num_points=spec["num_points"], seed=spec["seed"]))


def load_robot(spec: dict[str, Any], base: Path) -> Any:
    """The robot a problem names: built-in by name, or a URDF with its end-effector frame."""
    from robots import Robot
    from robots import load_robot as builtin
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if "name" in spec:
            return builtin(spec["name"])
        return Robot.from_urdf(_path(spec["urdf"], base), end_effector=spec["end_effector"],
                               base_frame=spec["base_frame"])


def resolve(problem: Problem, base: Path) -> dict[str, Any]:
    """Keyword arguments of :func:`clamp.plan` for ``problem`` (robots and priors cached)."""
    import numpy as np

    from clamp.config import PlannerConfig
    from scenes import Scene
    data, key = problem.to_dict(), str(base)
    prior = _cached("prior", (problem.prior, key), lambda: load_prior(data["prior"], base))
    robot = _cached("robot", (problem.robot, key), lambda: load_robot(data["robot"], base))
    scene = problem.scene_data()
    if isinstance(scene, str):
        scene = Scene.load(_path(scene, base))
    elif scene is not None:
        scene = Scene.from_dict(scene, source=f"problem {problem.id!r} scene", folder=base)
    return {"prior": prior, "robot": robot, "scene": scene, "start": np.array(problem.start),
            "goal": None if problem.goal is None else np.array(problem.goal),
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
    from clamp.planner import plan
    from scenes.errors import InvalidArgumentError
    from scenes.threads import single_blas_thread
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


def _worker_ready(delay: float = 0.0) -> int:
    """Imports the planner (the worker's start-up cost) and returns this process's pid."""
    import clamp.planner  # noqa: F401
    import robots  # noqa: F401
    time.sleep(delay)
    return os.getpid()


# =============================================================== local pool
class LocalPool:
    """``workers`` local worker processes (spawned: safe with threads, CUDA, macOS), restarted
    when one dies. :meth:`start` starts them ahead of the batch and returns how long that
    took; :attr:`pids` are the workers' process ids; :attr:`restarts` counts restarts.
    Workers are spawned (they import the main module afresh): a script that uses a pool needs
    the ``if __name__ == "__main__":`` guard."""

    def __init__(self, workers: int):
        if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
            raise InvalidParameterError(f"workers: expected an integer >= 1, got {workers!r}")
        self.workers = workers
        self.restarts = 0
        self.pids: list[int] = []
        self._executor: cf.ProcessPoolExecutor | None = None

    @property
    def executor(self) -> cf.ProcessPoolExecutor:
        if self._executor is None:
            import multiprocessing
            self._executor = cf.ProcessPoolExecutor(
                self.workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_worker_ready)
        return self._executor

    def start(self) -> float:
        """Start every worker and wait until each has imported the planner; seconds taken."""
        t0 = time.perf_counter()
        pids: set[int] = set()
        while len(pids) < self.workers:
            futures = [self.executor.submit(_worker_ready, 0.05) for _ in range(self.workers)]
            pids.update(f.result() for f in futures)
        self.pids = sorted(pids)
        return time.perf_counter() - t0

    def restart(self) -> None:
        """Replace a broken pool by a new one (the problems in flight are resubmitted)."""
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
        self._executor = None
        self.pids = []
        self.restarts += 1

    def shutdown(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    def __enter__(self) -> "LocalPool":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.shutdown()


# =============================================================== runners
class _Serial:
    """In this process, one problem after the other."""

    window = 1

    def __init__(self) -> None:
        self._done: list[tuple[Any, Any]] = []

    def submit(self, data: dict, base: str, trajectory: bool) -> Any:
        token = object()
        self._done.append((token, run_problem(data, base, trajectory)))
        return token

    def next_done(self) -> list[tuple[Any, Any, BaseException | None]]:
        done, self._done = self._done, []
        return [(token, record, None) for token, record in done]

    def close(self) -> None:
        pass


class _Futures:
    """A concurrent.futures executor (a LocalPool's is restarted when it breaks)."""

    def __init__(self, executor: Any, pool: LocalPool | None = None):
        self._given, self._pool = executor, pool
        workers = pool.workers if pool else getattr(executor, "_max_workers", os.cpu_count() or 2)
        self.window = 2 * int(workers)
        self._pending: set[cf.Future] = set()

    @property
    def _executor(self) -> Any:
        return self._pool.executor if self._pool else self._given

    def submit(self, data: dict, base: str, trajectory: bool) -> Any:
        try:
            future = self._executor.submit(run_problem, data, base, trajectory)
        except cf.BrokenExecutor as exc:
            future = cf.Future()
            future.set_exception(exc)
        self._pending.add(future)
        return future

    def next_done(self) -> list[tuple[Any, Any, BaseException | None]]:
        done, self._pending = cf.wait(self._pending, return_when=cf.FIRST_COMPLETED)
        out = [(f, None if f.exception() else f.result(), f.exception()) for f in done]
        if any(isinstance(e, cf.BrokenExecutor) for _, _, e in out):
            if self._pool is None:
                raise RuntimeError("the executor broke (a worker died); rerun with the same "
                                   "output to resume, or use workers=N (restarted pools)") \
                    from next(e for _, _, e in out if e is not None)
            # every future in flight fails with the pool; collect them all, then restart
            rest, self._pending = self._pending, set()
            cf.wait(rest)
            out += [(f, None if f.exception() else f.result(), f.exception()) for f in rest]
            log.warning("a worker died: restarting the local pool")
            self._pool.restart()
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

    def submit(self, data: dict, base: str, trajectory: bool) -> Any:
        future = self._client.submit(run_problem, data, base, trajectory, pure=False)
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
        return _Futures(None, pool), pool.shutdown
    if isinstance(executor, LocalPool):
        return _Futures(None, executor), lambda: None
    if isinstance(executor, cf.Executor):
        return _Futures(executor), lambda: None
    if type(executor).__module__.startswith("distributed") and hasattr(executor, "nthreads"):
        return _Dask(executor), lambda: None
    raise InvalidParameterError(f"executor: expected None, a number of workers, a LocalPool, a "
                                f"concurrent.futures.Executor or a distributed.Client, got "
                                f"{type(executor).__name__}")


# =============================================================== output file
#: how every record line starts (``json.dumps`` of :func:`_record`, "id" first): a torn last
#: line that does not is not the batch's own and is never cut
_RECORD_START = b'{"id":'


class ResultsFile:
    """The JSON Lines output of a batch: the hashes it holds, appending whole lines."""

    FSYNC_SECONDS = 5.0

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.hashes: set[str] = set()
        if self.path.exists():
            # every complete line checked before anything is cut: a file that is not a results
            # file is refused untouched
            for k, record in enumerate(iter_json_lines(self.path), 1):
                if not isinstance(record, dict) or not {"hash", "status"} <= record.keys():
                    raise InvalidParameterError(f"out: {str(self.path)!r} line {k} is not a "
                                                "batch result (no 'hash' / 'status'); expected "
                                                "a results file or a new path")
                self.hashes.add(record["hash"])
            self._repair()
        self._fd: int | None = None
        self._synced = time.monotonic()

    def _repair(self) -> None:
        """Cut a torn last line (a crash in the middle of a write) so appending stays valid."""
        with open(self.path, "rb+") as handle:
            data = handle.read()
            if data and not data.endswith(b"\n"):
                keep = data.rfind(b"\n") + 1
                if not data[keep:].startswith(_RECORD_START[:len(data) - keep]):
                    raise InvalidParameterError(
                        f"out: {str(self.path)!r} ends in a line that is not a batch result "
                        f"({data[keep:keep + 30]!r}); expected a results file or a new path")
                log.warning("%s: removing a torn last line (%d bytes)", self.path, len(data) - keep)
                handle.truncate(keep)

    def append(self, record: dict[str, Any]) -> None:
        line = (json.dumps(record, separators=(",", ":")) + "\n").encode()
        if self._fd is None:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        view = memoryview(line)
        while view:
            view = view[os.write(self._fd, view):]
        self.hashes.add(record["hash"])
        if time.monotonic() - self._synced > self.FSYNC_SECONDS:
            os.fsync(self._fd)
            self._synced = time.monotonic()

    def close(self) -> None:
        if self._fd is not None:
            os.fsync(self._fd)
            os.close(self._fd)
            self._fd = None


def pending_problems(problems: Iterable[Problem], out: str | Path | None) -> list[Problem]:
    """The problems still to plan: ids checked unique (so hashes are too) and, with ``out``,
    those whose hash the output file already holds left out."""
    problems = list(problems)
    for k, problem in enumerate(problems):
        if not isinstance(problem, Problem):
            raise InvalidParameterError(f"problems[{k}]: expected a clamp.problems.Problem, got "
                                        f"{type(problem).__name__}")
    check_unique_ids(problems)
    done = ResultsFile(out).hashes if out is not None and Path(out).exists() else set()
    return [p for p in problems if p.hash not in done]


def _trajectory_mode(trajectories: str | Path) -> Path | None:
    if isinstance(trajectories, str) and trajectories in TRAJECTORY_MODES:
        return None
    folder = Path(trajectories)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


# =============================================================== plan_many
def plan_many(problems: Iterable[Problem], executor: Any = None, *, out: str | Path | None = None,
              retries: int = 2, base_dir: str | Path | None = None,
              trajectories: str | Path = "inline") -> Iterator[dict[str, Any]]:
    """Plan ``problems`` and yield one record per problem as it finishes (see the module
    docstring for the record, the executors and the output file).

    retries: how many times a problem whose worker died is tried again before it is recorded
    as lost; base_dir: folder of the problems' relative paths (default: the working folder);
    trajectories: "inline" (in the record), "none", or a folder for one trajectory JSON file
    per problem (named by its hash). Closing the generator early stops the batch (the lines
    written so far stay; rerun with the same ``out`` to resume).
    """
    if not isinstance(retries, int) or isinstance(retries, bool) or retries < 0:
        raise InvalidParameterError(f"retries: expected an integer >= 0, got {retries!r}")
    problems = as_sequence(problems, "problems", "a list of clamp.problems.Problem",
                           ArgumentTypeError)
    if out is not None and as_path(out, "out", ArgumentTypeError).is_dir():
        raise InvalidParameterError(f"out: {out} is a folder; expected a results file (JSON "
                                    "Lines, new or from an earlier run)")
    if base_dir is not None:
        as_path(base_dir, "base_dir", ArgumentTypeError)
    if not (isinstance(trajectories, str) and trajectories in TRAJECTORY_MODES):
        if as_path(trajectories, "trajectories", ArgumentTypeError).exists() \
                and not Path(trajectories).is_dir():
            raise InvalidParameterError(f"trajectories: expected 'inline', 'none' or a folder, "
                                        f"got the existing file {str(trajectories)!r}")
    todo = pending_problems(problems, out)
    folder = _trajectory_mode(trajectories)
    want_trajectory = not (folder is None and trajectories == "none")
    base = str(Path(base_dir if base_dir is not None else os.getcwd()).resolve())
    results = ResultsFile(out) if out is not None else None
    runner, finish = _runner(executor)
    queue = todo[::-1]             # pop() from the end keeps the given order
    in_flight: dict[Any, tuple[Problem, int]] = {}
    try:
        while queue or in_flight:
            while queue and len(in_flight) < runner.window:
                problem = queue.pop()
                handle = runner.submit(problem.to_dict(), base, want_trajectory)
                in_flight[handle] = (problem, 1)
            for handle, record, error in runner.next_done():
                problem, attempt = in_flight.pop(handle)
                if error is not None:
                    if isinstance(error, cf.BrokenExecutor) and attempt <= retries:
                        again = runner.submit(problem.to_dict(), base, want_trajectory)
                        in_flight[again] = (problem, attempt + 1)
                        continue
                    record = _record(problem, status="lost", error={
                        "type": type(error).__name__,
                        "message": f"the worker running it died or the task failed "
                                   f"({error}); tried {attempt} time(s)"})
                record["attempts"] = attempt
                if folder is not None and record.get("trajectory") is not None:
                    from robots.trajectory import atomic_write_text
                    path = folder / f"{problem.hash}.json"
                    atomic_write_text(path, json.dumps(record["trajectory"]) + "\n", overwrite=True)
                    record["trajectory"] = str(path)
                if results is not None:
                    results.append(record)
                yield record
    finally:
        runner.close()
        finish()
        if results is not None:
            results.close()


def read_results(path: str | Path) -> list[dict[str, Any]]:
    """The records of a results file (complete lines only)."""
    return list(iter_json_lines(path))
