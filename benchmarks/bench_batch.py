"""Many plans: throughput of clamp.batch.runner.plan_many in this process and in 1 / 2 local workers,
worker start-up cost, and the resident memory of a long in-process batch.

Problems: box_closing (synthetic, 6 demonstrations, T = 250) on the Jaco from ``--count``
seeded starts in the demonstrations' start region, with the README's box. Prints:

- the start-up time of a pool of 1 and of 2 workers (spawn + import), measured apart;
- per executor: batch wall time, throughput (plans/s), wall time per plan (batch wall / count)
  beside CPU time per plan (this process + the workers' processes, from /proc), median / p95 of
  each plan's own wall time (``timings["total"]``) beside its median CPU time
  (``timings["cpu"]``);
- what the machine was doing during each batch, so a wall-clock ratio can be read honestly on
  a shared machine: the load average (1 min) before and after, the cores the batch used (its
  CPU time / wall time) and the cores busy on the whole machine meanwhile (/proc/stat), hence
  the cores other work took;
- anchors: throughput 2 workers / 1 worker (target >= 1.8 on two free cores) beside the ratio
  of cores the two batches obtained (what bounds it under load) and the CPU time per plan
  2 workers / 1 worker (the pool's own overhead, what stays meaningful under load); median
  plan time in the 2-worker pool / in this process (target <= 1.15) beside the same ratio of
  CPU times;
- memory: RSS after problem 20 and after problem ``--memory-plans`` of an in-process batch,
  each problem with a new random box (target: within 20 MB).

    python benchmarks/bench_batch.py [--count 200] [--memory-plans 500]
"""
from __future__ import annotations

import argparse
import gc
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness import print_environment
from soak_clamp import rss_mb

CLOCK_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def _process_cpu(pid: int) -> float:
    """CPU time [s] (user + system) of a live process, from /proc/PID/stat (NaN without /proc)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS      # utime, stime


def _machine_jiffies() -> tuple[float, float]:
    """(busy, total) CPU jiffies of the whole machine since boot, from /proc/stat (NaN without)."""
    try:
        values = [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    except OSError:
        return float("nan"), float("nan")
    idle = values[3] + (values[4] if len(values) > 4 else 0)          # idle + iowait
    return float(sum(values) - idle), float(sum(values))


@dataclass
class Run:
    """One batch: wall [s], per-problem plan wall and CPU times [s], our CPU time [s], machine
    busy cores during it, load average before / after."""

    startup: float
    wall: float
    times: np.ndarray
    cpu: np.ndarray
    our_cpu: float
    machine_cores: float
    load: tuple[float, float]

    @property
    def our_cores(self) -> float:
        return self.our_cpu / self.wall


def _batch(problems, executor, pids=(), startup: float = 0.0) -> Run:
    """Plan ``problems`` with ``executor``; what it cost and what the machine did meanwhile."""
    from clamp.batch.runner import plan_many
    load0, busy0, cpu0 = os.getloadavg()[0], _machine_jiffies(), time.process_time()
    workers0 = sum(_process_cpu(pid) for pid in pids)
    t0 = time.perf_counter()
    records = list(plan_many(problems, executor, trajectories="none"))
    wall = time.perf_counter() - t0
    workers = sum(_process_cpu(pid) for pid in pids) - workers0
    busy1 = _machine_jiffies()
    machine = (busy1[0] - busy0[0]) / (busy1[1] - busy0[1]) * (os.cpu_count() or 1)
    assert len(records) == len(problems) and all(r["status"] == "done" for r in records)
    return Run(startup, wall, np.array([r["timings"]["total"] for r in records]),
               np.array([r["timings"]["cpu"] for r in records]),
               time.process_time() - cpu0 + workers, machine, (load0, os.getloadavg()[0]))


def _memory(count: int, seed: int) -> None:
    from clamp.batch.runner import load_prior, plan_many
    from clamp.batch.problem_sets import start_problems
    from clamp.batch.problems import make_problem
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
    from clamp.batch.runner import LocalPool
    from clamp.batch.problem_sets import start_problems
    from clamp.batch.problems import make_problem
    from scenes import Box, Scene

    box = Scene([Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])])
    base = make_problem("bench", {"skill": "box_closing"}, "jaco", [0.2054, -0.4722, 0.2625],
                        scene=box)
    problems = start_problems(base, args.count, seed=args.seed)
    _batch(problems[:3], None)                      # warm this process (imports, caches)
    rows = {"in-process": _batch(problems, None)}
    for workers in (1, 2):
        with LocalPool(workers) as pool:
            startup = pool.start()
            rows[f"{workers} worker(s)"] = _batch(problems, pool, pool.pids, startup)
            assert pool.restarts == 0
    n = len(problems)
    print(f"\n{n} problems (box_closing, T = 250, Jaco, README box); wall times are noisy on a "
          f"shared machine, read them with the columns on the right")
    print(f"{'executor':<14} {'start-up s':>10} {'wall s':>7} {'plans/s':>7} {'wall ms':>8} "
          f"{'CPU ms':>7} {'plan med ms':>11} {'p95 ms':>7} {'CPU med ms':>10} | {'load':>11} "
          f"{'our cores':>9} {'busy':>5} {'others':>6}")
    print(f"{'':<14} {'':>10} {'':>7} {'':>7} {'per plan':>8} {'per plan':>7} {'':>11} {'':>7} "
          f"{'':>10} | {'before-after':>11}")
    for name, r in rows.items():
        print(f"{name:<14} {r.startup:>10.2f} {r.wall:>7.2f} {n / r.wall:>7.2f} "
              f"{1e3 * r.wall / n:>8.1f} {1e3 * r.our_cpu / n:>7.1f} {1e3 * np.median(r.times):>11.1f} "
              f"{1e3 * np.percentile(r.times, 95):>7.1f} {1e3 * np.median(r.cpu):>10.1f} | "
              f"{r.load[0]:>5.2f}-{r.load[1]:<5.2f} {r.our_cores:>9.2f} {r.machine_cores:>5.2f} "
              f"{max(r.machine_cores - r.our_cores, 0.0):>6.2f}")
    one, two, local = rows["1 worker(s)"], rows["2 worker(s)"], rows["in-process"]
    print(f"(cores: CPU time / wall time of this process + its workers; busy: cores busy on the "
          f"whole machine meanwhile, of {os.cpu_count()}; others = busy - ours)")
    print(f"throughput 2 workers / 1 worker: {one.wall / two.wall:.2f}x (target >= 1.8 on two "
          f"free cores); cores obtained 2 workers / 1 worker: {two.our_cores / one.our_cores:.2f}x; "
          f"CPU time per plan 2 workers / 1 worker: {two.our_cpu / one.our_cpu:.2f}")
    print(f"throughput 2 workers / in-process: {local.wall / two.wall:.2f}x")
    print(f"median plan time, 2 workers / in-process: {np.median(two.times) / np.median(local.times):.2f}"
          f" (target <= 1.15); median CPU time per plan: {np.median(two.cpu) / np.median(local.cpu):.2f}")
    if args.memory_plans:
        print(f"\nmemory: in-process batch of {args.memory_plans} problems, a new box each")
        _memory(args.memory_plans, args.seed)


if __name__ == "__main__":
    main()
