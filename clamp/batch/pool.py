"""Local worker processes for :mod:`clamp.batch.runner`: a dead worker costs only its own problem, and
no worker outlives the process that started it.

:class:`LocalPool` runs ``workers`` spawned processes, each planning one problem at a time
through its own pipe; the parent knows which problem every worker holds. When a worker dies
(killed, out of memory, a crash in native code) its pipe closes and its process sentinel fires:
that one problem fails with :class:`WorkerDied` (``plan_many`` retries it or records it lost),
a new worker replaces the dead one, and the other workers go on undisturbed.

Why not an executor from a library: ``concurrent.futures.ProcessPoolExecutor`` breaks as a
whole when one worker dies (every future in flight fails with ``BrokenProcessPool``: with two
workers a ``kill -9`` cost 4 problems, two in flight per worker), and loky's reusable executor
does the same (``TerminatedWorkerError`` for every pending future, then the executor is
restarted). ``multiprocessing.Pool`` replaces a dead worker but never completes the task it
held. One pipe per worker and one problem per worker is what keeps a death to one problem;
workers stay alive between problems, so each keeps the robots and priors it loaded (spawning
a worker and importing the planner takes ~1-2 s, a plan ~0.1-0.5 s).

Workers die with their parent: on Linux each worker asks the kernel for SIGKILL when its parent
dies (``prctl(PR_SET_PDEATHSIG)``, set first thing in the worker, then the parent's pid is
checked in case it died before); elsewhere a thread in the worker checks the parent's pid
every second. An idle worker also ends when its pipe closes. With no worker left, the
multiprocessing resource tracker sees its pipe close and ends too. Measured on Linux: after a
``kill -9`` of ``clamp batch --workers 2`` planning, its two workers (~250 MB each) and the
resource tracker were gone 0.17 s later (with ``ProcessPoolExecutor`` they ran on for over a
minute, re-parented to PID 1). A worker still importing the planner when its parent dies ends
once the imports are done (a few seconds; the signal is armed in the worker's code, which runs
after them). PR_SET_PDEATHSIG fires when the *thread* that started the worker ends: run
``plan_many`` with a pool from a thread that outlives it, e.g. the main thread.
"""
from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from multiprocessing.connection import Connection, wait
from typing import Any

from clamp.errors import InvalidParameterError

log = logging.getLogger(__name__)

_PR_SET_PDEATHSIG = 1           # linux/prctl.h
_WATCHDOG_SECONDS = 1.0


class WorkerDied(RuntimeError):
    """The worker process running a problem died before returning its record."""


# =============================================================== worker side
def _die_with_parent(parent: int) -> None:
    """End this process when ``parent`` (pid) dies: PR_SET_PDEATHSIG on Linux, a watchdog
    thread elsewhere (or when prctl fails); exits at once if the parent is already gone."""
    armed = False
    if sys.platform.startswith("linux"):
        import ctypes
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            armed = libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
        except (OSError, AttributeError):
            armed = False
    if os.getppid() != parent:          # the parent died before the signal was armed
        os._exit(1)
    if not armed:
        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(_WATCHDOG_SECONDS)
            os._exit(1)
        threading.Thread(target=watch, name="parent-watchdog", daemon=True).start()


def _worker_main(conn: Connection, parent: int) -> None:
    """A worker's loop: receive (function, arguments), send back ("done", its value) or
    ("raised", text); ends on None or when the pipe closes."""
    _die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # Ctrl-C: the parent stops the workers
    import clamp.planning.planner  # noqa: F401 - the start-up cost, paid before the first problem
    conn.send(("ready", os.getpid()))
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):                 # the parent is gone
            return
        if task is None:
            return
        function, args = task
        try:
            reply: tuple[str, Any] = ("done", function(*args))
        except Exception as exc:  # noqa: BLE001 - not a problem's error: reported to the parent
            reply = ("raised", f"{type(exc).__name__}: {exc}")
        conn.send(reply)


# =============================================================== parent side
class _Worker:
    """One worker process, the parent's end of its pipe and the problem it holds."""

    def __init__(self, context: Any):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_worker_main, args=(child, os.getpid()),
                                       name="clamp-batch-worker", daemon=True)
        self.process.start()
        child.close()                   # the pipe closes when the worker dies
        self.pid: int = self.process.pid
        self.ready = False
        self.task: Any = None           # the handle of the problem it runs (None: idle)

    def receive(self) -> tuple[str, Any] | None:
        """The worker's next message, or None when it died (pipe closed)."""
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            return None

    def death(self) -> WorkerDied:
        self.process.join(timeout=5)
        code = self.process.exitcode
        how = (f"killed by {signal.Signals(-code).name}" if code is not None and code < 0
               else f"exit code {code}")
        return WorkerDied(f"worker process {self.pid} died ({how})")

    def stop(self, kill: bool) -> None:
        """End the worker: ask it (idle) or kill it (busy: its result is not wanted)."""
        if kill:
            self.process.kill()
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.process.join(timeout=10)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


class LocalPool:
    """``workers`` local worker processes (spawned: safe with threads, CUDA, macOS), one
    problem each at a time; a worker that dies is replaced and costs only its own problem (see
    the module docstring). :meth:`start` starts them ahead of the batch and returns how long
    that took; :attr:`pids` are the live workers' process ids; :attr:`restarts` counts workers
    replaced after dying. Spawned workers import the main module afresh: a script that uses a
    pool needs the ``if __name__ == "__main__":`` guard."""

    def __init__(self, workers: int):
        if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
            raise InvalidParameterError(f"workers: expected an integer >= 1, got {workers!r}")
        self.workers = workers
        self.window = workers           # problems in flight: one per worker
        self.restarts = 0
        self._context = multiprocessing.get_context("spawn")
        self._pool: list[_Worker] = []

    @property
    def pids(self) -> list[int]:
        return sorted(w.pid for w in self._pool)

    def _spawn(self) -> _Worker:
        worker = _Worker(self._context)
        self._pool.append(worker)
        return worker

    def start(self) -> float:
        """Start every worker and wait until each has imported the planner; seconds taken."""
        t0 = time.perf_counter()
        while len(self._pool) < self.workers:
            self._spawn()
        for worker in [w for w in self._pool if not w.ready and w.task is None]:
            message = worker.receive()
            if message is None or message[0] != "ready":
                raise worker.death()
            worker.ready = True
        return time.perf_counter() - t0

    # ------------------------------------------------------------------- runner protocol
    def submit(self, function: Callable[..., Any], *args: Any) -> Any:
        """Run ``function(*args)`` (picklable: a module-level function) on an idle worker,
        started if needed; returns a handle for :meth:`next_done`."""
        idle = [w for w in self._pool if w.task is None]
        worker = idle[0] if idle else self._spawn()
        handle = object()
        try:
            worker.conn.send((function, args))
        except OSError:                 # died while idle: its death is reported for this task
            pass
        worker.task = handle
        return handle

    def next_done(self) -> list[tuple[Any, Any, BaseException | None]]:
        """Wait until busy workers answer or die: [(handle, value, error)], at least one."""
        out: list[tuple[Any, Any, BaseException | None]] = []
        while not out:
            busy = [w for w in self._pool if w.task is not None]
            ready = set(wait([w.conn for w in busy] + [w.process.sentinel for w in busy]))
            for worker in busy:
                if worker.conn not in ready and worker.process.sentinel not in ready:
                    continue
                message = worker.receive()   # a dead worker's pipe: what it sent, then EOF
                if message is not None and message[0] == "ready":
                    worker.ready = True      # start-up done; its problem is still running
                    continue
                handle, worker.task = worker.task, None
                if message is None:
                    error = worker.death()
                    log.warning("%s; its problem is retried or recorded as lost", error)
                    self._pool.remove(worker)
                    worker.conn.close()
                    self.restarts += 1
                    out.append((handle, None, error))
                elif message[0] == "done":
                    out.append((handle, message[1], None))
                else:
                    out.append((handle, None, RuntimeError(message[1])))
        return out

    def close(self) -> None:
        """Stop the workers still running a problem (the batch ended early); idle ones stay."""
        for worker in [w for w in self._pool if w.task is not None]:
            worker.stop(kill=True)
            self._pool.remove(worker)

    def shutdown(self) -> None:
        """Stop every worker."""
        for worker in self._pool:
            worker.stop(kill=worker.task is not None)
        self._pool = []

    def __enter__(self) -> "LocalPool":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.shutdown()
