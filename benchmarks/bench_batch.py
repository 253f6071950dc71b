"""Many plans: throughput of clamp.batch.plan_many in this process and in 1 / 2 local workers,
worker start-up cost, and the resident memory of a long in-process batch.

Problems: box_closing (synthetic, 6 demonstrations, T = 250) on the Jaco from ``--count``
seeded starts in the demonstrations' start region, with the README's box. Prints:

- the start-up time of a pool of 1 and of 2 workers (spawn + import), measured apart;
- per executor: batch wall time, throughput (plans/s), median / p95 of each plan's own time
  (``timings["total"]``), median CPU time per problem (``timings["cpu"]``); anchors:
  throughput 2 workers / 1 worker (target >= 1.8 on two free cores), median plan time in the
  2-worker pool / in this process (target <= 1.15; the CPU-time ratio beside it is what stays
  meaningful when other work shares the cores);
- memory: RSS after problem 20 and after problem ``--memory-plans`` of an in-process batch,
  each problem with a new random box (target: within 20 MB).

    python benchmarks/bench_batch.py [--count 200] [--memory-plans 500]
"""
from __future__ import annotations

import argparse
import gc
import os
import time
from pathlib import Path

import numpy as np

from harness import print_environment
from soak_clamp import rss_mb


def _batch(problems, executor) -> tuple[float, np.ndarray, np.ndarray]:
    """Wall time of the batch [s], each plan's own time and each problem's CPU time [s]."""
    from clamp.batch import plan_many
    t0 = time.perf_counter()
    records = list(plan_many(problems, executor, trajectories="none"))
    wall = time.perf_counter() - t0
    assert len(records) == len(problems) and all(r["status"] == "done" for r in records)
    return (wall, np.array([r["timings"]["total"] for r in records]),
            np.array([r["timings"]["cpu"] for r in records]))


def _memory(count: int, seed: int) -> None:
    from clamp.batch import load_prior, plan_many
    from clamp.problem_sets import start_problems
    from clamp.problems import make_problem
    from scenes import Box, Scene
    base = make_problem("memory", {"skill": "box_closing"}, "jaco", [0.2054, -0.4722, 0.2625])
    rng = np.random.default_rng(seed)
    path = np.asarray(load_prior(base.to_dict()["prior"], Path(".")).mean)[:, :3]

    def problems():
        for k, p in enumerate(start_problems(base, count, seed=seed)):
            centre = path[rng.integers(len(path) // 4, len(path))] + rng.normal(scale=0.05, size=3)
            yield p.replace(scene=Scene([Box(centre, rng.uniform(0.03, 0.08, size=3))]).to_dict())

    marks = {}
    for k, _ in enumerate(plan_many(problems()), 1):
        if k in (20, count) or k % 100 == 0:
            gc.collect()
            marks[k] = rss_mb()
            print(f"  after problem {k:4d}: RSS {marks[k]:7.1f} MB", flush=True)
    print(f"memory: RSS after problem {count} minus after problem 20: "
          f"{marks[count] - marks[20]:+.1f} MB (target within 20 MB)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=200)
    parser.add_argument("--memory-plans", type=int, default=500, help="0: skip the memory run")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print_environment()
    from clamp.batch import LocalPool
    from clamp.problem_sets import start_problems
    from clamp.problems import make_problem
    from scenes import Box, Scene

    box = Scene([Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])])
    base = make_problem("bench", {"skill": "box_closing"}, "jaco", [0.2054, -0.4722, 0.2625],
                        scene=box)
    problems = start_problems(base, args.count, seed=args.seed)
    _batch(problems[:3], None)                      # warm this process (imports, caches)
    rows = {}
    rows["in-process"] = (0.0, *_batch(problems, None))
    for workers in (1, 2):
        with LocalPool(workers) as pool:
            startup = pool.start()
            rows[f"{workers} worker(s)"] = (startup, *_batch(problems, pool))
    print(f"\n{len(problems)} problems (box_closing, T = 250, Jaco, README box); timings noisy on "
          f"a shared machine")
    print(f"{'executor':<14} {'start-up s':>10} {'wall s':>8} {'plans/s':>8} {'median ms':>10} "
          f"{'p95 ms':>8} {'CPU ms':>8}")
    for name, (startup, wall, times, cpu) in rows.items():
        print(f"{name:<14} {startup:>10.2f} {wall:>8.2f} {len(problems) / wall:>8.1f} "
              f"{1e3 * np.median(times):>10.1f} {1e3 * np.percentile(times, 95):>8.1f} "
              f"{1e3 * np.median(cpu):>8.1f}")
    one, two, local = rows["1 worker(s)"], rows["2 worker(s)"], rows["in-process"]
    print(f"throughput 2 workers / 1 worker: {one[1] / two[1]:.2f}x (target >= 1.8)")
    print(f"throughput 2 workers / in-process: {local[1] / two[1]:.2f}x")
    print(f"median plan time, 2 workers / in-process: {np.median(two[2]) / np.median(local[2]):.2f}"
          f" (target <= 1.15); median CPU time per problem: {np.median(two[3]) / np.median(local[3]):.2f}")
    print(f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores: with other work on "
          f"the cores, wall-time ratios measure the contention, CPU-time ratios the overhead)")
    if args.memory_plans:
        print(f"\nmemory: in-process batch of {args.memory_plans} problems, a new box each")
        _memory(args.memory_plans, args.seed)


if __name__ == "__main__":
    main()
