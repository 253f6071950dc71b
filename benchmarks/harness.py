"""Shared benchmark helpers: median wall times and the environment header every script prints.

Benchmarks are scripts (``python benchmarks/bench_<topic>.py``); they print tables of medians
and ratios and never assert on time.
"""
from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np


def median_seconds(function: Callable[[], object], repeats: int, warmup: int = 1,
                   clock: Callable[[], float] = time.perf_counter) -> float:
    """Median time of ``function()`` in seconds over ``repeats`` calls after warm-up: wall time,
    or this process's CPU time with ``clock=time.process_time`` (what a loaded machine keeps)."""
    for _ in range(warmup):
        function()
    times = np.empty(repeats)
    for k in range(repeats):
        start = clock()
        function()
        times[k] = clock() - start
    return float(np.median(times))


def interleaved_median_seconds(functions: dict[str, Callable[[], object]], repeats: int,
                               warmup: int = 1) -> dict[str, float]:
    """Median wall time [s] of each ``functions[name]()``, the calls interleaved (one of each per
    round) so a drifting load on a shared machine hits all alike; ratios between them are
    then far steadier than those of back-to-back blocks of repeats."""
    for _ in range(warmup):
        for function in functions.values():
            function()
    times = {name: np.empty(repeats) for name in functions}
    for k in range(repeats):
        for name, function in functions.items():
            start = time.perf_counter()
            function()
            times[name][k] = time.perf_counter() - start
    return {name: float(np.median(t)) for name, t in times.items()}


def median_ms(function: Callable[[], object], repeats: int, warmup: int = 1) -> float:
    """Median wall time of ``function()`` in milliseconds (see ``median_seconds``)."""
    return 1e3 * median_seconds(function, repeats, warmup)


def exit_with_parent(poll_s: float = 2.0) -> None:
    """Worker-process initializer: the worker exits when the process that started it has gone
    (a killed benchmark would otherwise leave its pool's workers computing, orphaned), checked
    every ``poll_s`` seconds by a daemon thread."""
    import threading
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def print_environment() -> None:
    """One line naming the machine and library versions, so figures can be compared later."""
    from importlib.metadata import version

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {load:.1f}; "
          f"python {platform.python_version()}, "
          + ", ".join(f"{name} {version(name)}" for name in ("numpy", "scipy", "pin", "gtsam")))


def machine_reference() -> tuple[float, float]:
    """Milliseconds of two fixed workloads, timed now (median of 5 after a warm-up): a pure-Python
    loop (2e5 additions and multiplications of floats: the interpreter's speed) and a numpy
    workload (100 products of 6 x 6 matrices batched over 250, then 50 Cholesky factorisations
    of a 100 x 100 matrix: small-array overhead and dense kernels, one BLAS thread). Benchmark
    figures divided by these compare across machines."""
    from threadpoolctl import threadpool_limits

    def python_loop() -> float:
        total = 0.0
        for k in range(200_000):
            total += k * 1e-6
        return total

    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((250, 6, 6)), rng.standard_normal((250, 6, 6))
    m = rng.standard_normal((100, 100))
    spd = m @ m.T + 100 * np.eye(100)

    def numpy_work() -> None:
        for _ in range(100):
            np.matmul(a, b)
        for _ in range(50):
            np.linalg.cholesky(spd)

    with threadpool_limits(limits=1, user_api="blas"):
        return median_ms(python_loop, 5), median_ms(numpy_work, 5)


def print_machine_reference() -> tuple[float, float]:
    """Print the :func:`machine_reference` line (and return its two figures [ms])."""
    python_ms, numpy_ms = machine_reference()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"# machine reference (harness.machine_reference, same run, load {load:.1f}): "
          f"pure-Python loop {python_ms:.1f} ms, numpy workload {numpy_ms:.1f} ms")
    return python_ms, numpy_ms


def shared_demonstrations(name: str):
    """The real data set ``<name>.mat`` as ``scenes.Demonstrations`` (from $SKILLPLAN_DATASETS or
    ../shared/datasets beside this checkout), or None with a printed note when it is absent."""
    from scenes import load_demonstrations, shared_dataset
    from scenes.datasets import DATASETS_ENV

    beside = Path(__file__).resolve().parents[2] / "shared" / "datasets"
    if not os.environ.get(DATASETS_ENV) and beside.is_dir():
        os.environ[DATASETS_ENV] = str(beside)
    path = shared_dataset(name)
    if path is None:
        print(f"# {name}.mat not found in ../shared/datasets (set {DATASETS_ENV}): skipped")
        return None
    return load_demonstrations(path)
