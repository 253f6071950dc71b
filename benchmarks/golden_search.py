"""Golden plans of the search: a fixed, representative set of planning problems with obstacles
on the path, planned by whatever ``clamp.plan`` is importable, each plan's outcome saved so a
restructured search can be compared with the one before it.

The set: the first problems of each ``bench_fidelity`` family (scene, hard, handwriting) on
both arms where the family has them, the hard ones without a blocked start. Per problem it
stores the verdict (success, reasons), the least real-geometry clearance [m], the joint path
length [rad], the plan q (T, n) and its time (T,) [s], the planning time of the obstacle plan
and of the free plan (same problem, empty scene) [s], and the independent checks of
``bench_fidelity.judge`` (a false success: success while one of them fails).

    SKILLPLAN_DATASETS=/work/shared/datasets python benchmarks/golden_search.py OUT.npz
    python benchmarks/golden_search.py --compare BEFORE.npz AFTER.npz
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np

import bench_fidelity as fidelity
from harness import print_environment

#: (family, arm, how many, which problem ids besides the first ones)
SETS = (("scene", "jaco", 4, ()), ("scene", "sawyer", 4, ()),
        ("hard", "jaco", 5, ()), ("hard", "sawyer", 4, ("hard/sawyer/0170",)),
        ("handwriting", "jaco", 4, ()))
#: handwriting: the shapes planned (one held-out demonstration each, the first two)
SHAPES = ("Angle", "WShape")


def problems() -> list[dict[str, Any]]:
    """The golden problem dicts (module docstring)."""
    import hard_problems
    from clamp.batch.problem_sets import scene_benchmark
    out = []
    for family, arm, count, extra in SETS:
        if family == "scene":
            out += [p.to_dict() for p in scene_benchmark(count, arm, 0, impossible_share=0.0,
                                                         start_offset=0.08)]
        elif family == "hard":
            every = hard_problems.hard_problems(171 if extra else 2 * count, arm, 0)
            free = [p for p in every if not p["meta"]["start_blocked"]]
            out += free[:count] + [p for p in every if p["id"] in extra]
        else:
            every = hard_problems.handwriting_problems(list(SHAPES), arm)
            free = [p for p in every if not p["meta"]["start_blocked"]]
            for shape in SHAPES:
                out += [p for p in free if f"/{shape}/" in p["id"]][:count // len(SHAPES)]
    return out


def run(data: dict[str, Any]) -> dict[str, Any]:
    """Plan problem ``data`` with and without its obstacles; its record."""
    robot = fidelity._robot(data["robot"]["name"])
    fidelity._plan(data, False)                  # warm-up of this skill's caches
    free = fidelity._plan(data, False)
    result = fidelity._plan(data, True)
    step = float(np.median(np.diff(result.time)))
    judged = fidelity.judge(data, result.q, True, step)
    return {"id": data["id"], "success": bool(result.success),
            "reasons": [str(r)[:160] for r in result.reasons],
            "min_clearance": float(result.min_clearance),
            "joint_path": float(np.sum(np.abs(np.diff(result.q, axis=0)))),
            "free_joint_path": float(np.sum(np.abs(np.diff(free.q, axis=0)))),
            "plan_s": float(result.timings["total"]), "free_s": float(free.timings["total"]),
            "failed": sorted(judged["failed"]),
            "false_success": bool(result.success and judged["failed"]),
            "q": np.asarray(result.q), "time": np.asarray(result.time),
            "solves": len(getattr(result, "attempts", []) or []),
            "winner": next((a["candidate"] for a in result.attempts if a["feasible"]), None),
            "work": getattr(result, "search", {}).get("work"),
            "limit": getattr(result, "search", {}).get("limit")}


def without(mechanisms: list[str]) -> None:
    """Take ``mechanisms`` out of the search, for measuring what each one earns (this process
    only): strategies by name, or the polish rounds, the active multipliers, the relaxed and
    widened margins, the soft start."""
    from dataclasses import replace
    from clamp.optim import constrained
    from clamp.planning import search
    names = {s.name for s in search.STRATEGIES}
    search.STRATEGIES = tuple(s for s in search.STRATEGIES if s.name not in mechanisms)
    if "polish" in mechanisms:
        search.POLISH_ROUNDS = 0
        search.STRATEGIES = tuple(replace(s, polish=0) for s in search.STRATEGIES)
    if "update_active" in mechanisms:
        search.AL = replace(search.AL, update_active=False)
    if "relax" in mechanisms:
        search.AL = replace(search.AL, margin_floor=float("inf"))
    if "soft_start" in mechanisms:
        search.SOFT_START = 1.0
    if "widen" in mechanisms:           # the checks' amounts only widen the margins
        constrained._amounts = lambda verdict: {}
    unknown = set(mechanisms) - names - {"polish", "update_active", "relax", "widen",
                                         "soft_start"}
    if unknown:
        raise SystemExit(f"--without: unknown {', '.join(sorted(unknown))}")
    if mechanisms:
        print(f"# without {', '.join(mechanisms)}")


def save(path: str, records: list[dict[str, Any]]) -> None:
    arrays = {}
    meta = []
    for k, r in enumerate(records):
        arrays[f"q_{k}"], arrays[f"time_{k}"] = r["q"], r["time"]
        meta.append({key: v for key, v in r.items() if key not in ("q", "time")})
    np.savez(path, meta=json.dumps(meta), **arrays)


def load(path: str) -> list[dict[str, Any]]:
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        for k, r in enumerate(meta):
            r["q"], r["time"] = data[f"q_{k}"], data[f"time_{k}"]
    return meta


def compare(before: str, after: str) -> None:
    """Per family: successes, false successes, the plans that changed and how."""
    old = {r["id"]: r for r in load(before)}
    new = {r["id"]: r for r in load(after)}
    families = sorted({"/".join(i.split("/")[:2]) for i in old})
    for family in families:
        ids = [i for i in old if i.startswith(family + "/") and i in new]
        print(f"# {family}: success {sum(old[i]['success'] for i in ids)} -> "
              f"{sum(new[i]['success'] for i in ids)} of {len(ids)}; false successes "
              f"{sum(old[i]['false_success'] for i in ids)} -> "
              f"{sum(new[i]['false_success'] for i in ids)}; time/free median "
              f"{np.median([old[i]['plan_s'] / old[i]['free_s'] for i in ids]):.1f}x -> "
              f"{np.median([new[i]['plan_s'] / new[i]['free_s'] for i in ids]):.1f}x")
        for i in ids:
            a, b = old[i], new[i]
            same_shape = a["q"].shape == b["q"].shape
            dq = float(np.max(np.abs(a["q"] - b["q"]))) if same_shape else float("inf")
            if dq > 1e-6 or a["success"] != b["success"]:
                print(f"  {i}: success {a['success']} -> {b['success']}, max |dq| {dq:.3g} rad, "
                      f"clearance {1e3 * a['min_clearance']:.1f} -> {1e3 * b['min_clearance']:.1f}"
                      f" mm, joint path {a['joint_path']:.2f} -> {b['joint_path']:.2f} rad, "
                      f"time {a['plan_s'] / a['free_s']:.1f}x -> {b['plan_s'] / b['free_s']:.1f}x"
                      f"; {'; '.join(b['reasons'][:1]) or 'no reasons'}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", nargs="?", help="where to save the records (.npz)")
    parser.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    parser.add_argument("--only", default="", help="only problem ids containing these "
                        "(comma-separated)")
    parser.add_argument("--without", nargs="*", default=(), metavar="MECHANISM",
                        help="measure the search without these: strategy names of "
                        "clamp.planning.search.STRATEGIES, or polish, update_active, relax, "
                        "widen, soft_start")
    args = parser.parse_args(argv)
    if args.compare:
        compare(*args.compare)
        return 0
    if not args.out:
        parser.error("give OUT.npz or --compare BEFORE AFTER")
    print_environment()
    without(args.without)
    records = []
    wanted = args.only.split(",")
    for data in problems():
        if not any(w in data["id"] for w in wanted):
            continue
        t0 = time.perf_counter()
        record = run(data)
        records.append(record)
        print(f"{record['id']}: success {record['success']} (false {record['false_success']}), "
              f"clearance {1e3 * record['min_clearance']:.1f} mm, plan {record['plan_s']:.2f} s "
              f"= {record['plan_s'] / record['free_s']:.1f}x free, {record['solves']} solves, "
              f"{time.perf_counter() - t0:.0f} s; {'; '.join(record['reasons'][:1])}",
              flush=True)
        save(args.out, records)
    return 0


if __name__ == "__main__":
    sys.exit(main())
