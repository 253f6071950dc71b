"""Scenes at perception scale: planning time and memory against the number of obstacles, mesh and
point-cloud obstacles, large scene files.

1. Obstacle count (box_closing on the Jaco, default PlannerConfig): ``NEAR`` small boxes near
   the arm (2-6 cm from its collision spheres on the unobstructed path: within the obstacle
   hinge's reach, clear of the arm) plus boxes far out of reach (1.5-3 m from the base). Each case runs
   in its own process (so its peak RSS is its own) and prints: building the scene (index),
   the planning problem, one obstacle query on the initial trajectory's 7,500 sphere centres
   (the index with the hinge's reach, and every obstacle evaluated, the pre-index cost), the
   optimiser on the problem (the planner's part, with no real-geometry check:
   ``clamp.optimize``; median of 3 calls interleaved with the anchor's, the NEAR boxes alone, in
   the same process), and the whole ``plan`` (planner's part = optimize - clearance) where the
   real-geometry checker accepts the scene.
2. Obstacles near the arm: one obstacle query against 10-320 near boxes (and 10,000 far ones):
   its cost per near box.
3. Mesh and point cloud: the table mesh and a cloud in the way of box_closing, planned; the
   mesh kernel against coal (one BVH distance per point) and a 1 cm grid on the same points.
4. Scene files: a point cloud of about 50 MB as inline JSON and as an .npz sidecar, and the
   same size as one JSON object per sphere (the pre-array format), saved and loaded; the
   optimiser on the loaded cloud.

    python benchmarks/bench_scene_scale.py [--quick] [--sections 1 2 3 4]

Prints medians and ratios; asserts nothing on time.
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from harness import interleaved_median_seconds, median_seconds, print_environment

START = [0.2054, -0.4722, 0.2625]
NEAR = 20
COUNTS = (10, 100, 1_000, 10_000)


def setting():
    from clamp import learn_prior
    from robots import load_robot
    from scenes import make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    return prior, load_robot("jaco")


def near_boxes(centres: np.ndarray, radii: np.ndarray, count: int, seed: int) -> list:
    """Boxes (2-3 cm) 2-6 cm from the collision spheres (centres (T,S,3), radii (S,) [m]) of the
    arm on the unobstructed path: within the obstacle hinge's reach, clear of the arm."""
    from scenes import Box
    rng = np.random.default_rng(seed)
    flat = centres.reshape(-1, 3)
    rad = np.broadcast_to(radii, centres.shape[:2]).reshape(-1)
    lo, hi = flat.min(axis=0) - 0.15, flat.max(axis=0) + 0.15
    out = []
    while len(out) < count:
        centre, size = rng.uniform(lo, hi), rng.uniform(0.02, 0.03, 3)
        gap = np.min(np.linalg.norm(flat - centre, axis=1) - rad) - 0.5 * np.linalg.norm(size)
        if 0.02 < gap < 0.06:
            out.append(Box(centre, size))
    return out


def far_boxes(count: int, seed: int) -> list:
    """Boxes (2-10 cm) 1.5-3 m from the base: out of the Jaco's reach."""
    from scenes import Box
    rng = np.random.default_rng(seed)
    angle, radius = rng.uniform(0, 2 * np.pi, count), rng.uniform(1.5, 3.0, count)
    centres = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), rng.uniform(-0.5, 1.5, count)])
    return [Box(c, s) for c, s in zip(centres, rng.uniform(0.02, 0.1, (count, 3)))]


def every_obstacle(scene, coords: np.ndarray) -> None:
    """The pre-index cost: each obstacle's exact kernel at every point (min kept)."""
    d = np.full(coords.shape[1], np.inf)
    for ob in scene.obstacles:
        np.minimum(d, ob._evaluate(coords, True)[0], out=d)


def run_case(near: int, far: int, full_plan: bool) -> dict:
    """One obstacle-count case (in a fresh process)."""
    from clamp import PlannerConfig, build, optimize, plan
    from robots.errors import CollisionCheckError
    from scenes import Scene
    prior, robot = setting()
    config = PlannerConfig()
    free = robot.sphere_centres(prior_path_q(prior, robot))[0]
    obstacles = near_boxes(free, robot.spheres.radii, near, 1) + far_boxes(far, 2)
    t0 = time.perf_counter()
    scene = Scene(obstacles)
    out = {"near": near, "far": far, "scene": time.perf_counter() - t0}
    t0 = time.perf_counter()
    problem = build(prior, robot, scene, START, config=config)
    out["build"] = time.perf_counter() - t0
    centres = robot.sphere_centres(problem.initial[:, :robot.n])[0]
    query = scene.distance_query(max_distance=config.model.epsilon + float(robot.spheres.radii.max()))
    out["query_index"] = median_seconds(lambda: query(centres), 21)
    coords = np.ascontiguousarray(centres.reshape(-1, 3).T)
    out["query_every"] = median_seconds(lambda: every_obstacle(scene, coords), 1 if near + far > 1000 else 3)
    solved = optimize(problem, config)
    out["iterations"] = solved.iterations
    # the anchor (the near boxes alone) in the same process, calls interleaved: a drifting load
    # on the shared machine hits both alike
    anchor = build(prior, robot, Scene(obstacles[:near]), START, config=config) if near else None
    timed = {"case": lambda: optimize(problem, config)}
    if anchor is not None:
        timed["anchor"] = lambda: optimize(anchor, config)
    medians = interleaved_median_seconds(timed, 3)
    out["optimize"], out["anchor"] = medians["case"], medians.get("anchor")
    out["plan"] = None
    if full_plan:
        try:
            t0 = time.perf_counter()
            result = plan(prior, robot, scene, START, config=config, covariance=False)
            out["plan"] = {"total": time.perf_counter() - t0, "success": bool(result.success),
                           "planner": result.timings["optimize"] - result.timings.get("clearance", 0.0),
                           "clearance": result.timings.get("clearance", 0.0)}
        except CollisionCheckError as exc:
            out["plan"] = {"refused": str(exc).split(";")[0][:90]}
    out["rss_mb"] = peak_rss_mb()
    return out


def peak_rss_mb() -> float:
    """Peak resident memory of this process [MB] (VmHWM: unlike ru_maxrss, not inherited from
    the parent that spawned it)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def in_process(near: int, far: int, full_plan: bool) -> dict:
    command = [sys.executable, __file__, "--case", str(near), str(far)] + (["--full-plan"] if full_plan else [])
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def obstacle_counts(quick: bool) -> None:
    print(f"\n=== 1. obstacle count: box_closing on the Jaco, {NEAR} boxes near the arm + far boxes "
          "(each case in its own process)")
    cases = [(10, 0), (NEAR, 0)] + [(NEAR, n - NEAR) for n in COUNTS if n > NEAR]
    if quick:
        cases = [(NEAR, 0), (NEAR, 980)]
    print(f"{'near':>5} {'far':>6} | {'scene':>7} {'build':>7} | {'query: index':>12} {'kernels':>10} | "
          f"{'optimize':>8} {'iter':>4} {'ratio':>6} | {'plan':>7} {'planner':>8} {'check':>7} | {'RSS MB':>7}")
    for near, far in cases:
        row = in_process(near, far, full_plan=True)
        ratio = f"{row['optimize'] / row['anchor']:6.2f}" if near == NEAR else "     -"
        p = row["plan"]
        if p is None or "refused" in p:
            plan_cols = f"{'-':>7} {'-':>8} {'-':>7}"
        else:
            plan_cols = f"{p['total']:6.2f}s {p['planner']:7.2f}s {p['clearance']:6.2f}s"
        print(f"{near:5d} {far:6d} | {row['scene']:6.3f}s {row['build']:6.2f}s | {row['query_index'] * 1e3:10.2f}ms "
              f"{row['query_every'] * 1e3:8.1f}ms | {row['optimize']:7.2f}s {row['iterations']:4d} {ratio} | "
              f"{plan_cols} | {row['rss_mb']:7.0f}")
        if p is not None and "refused" in p:
            print(f"{'':14}(plan: the real-geometry checker refused the scene: {p['refused']})")
    print(f"query: one obstacle query on the 7,500 sphere centres, with the index and the hinge's reach; "
          f"kernels: every obstacle's kernel at every point (the pre-index cost, without its bookkeeping)\n"
          f"ratio: optimize time / that of the {NEAR} near boxes alone (the anchor), medians of 3 calls "
          f"interleaved with the anchor's in the same process; plan = the whole "
          "plan(), planner = its optimize - clearance, check = its real-geometry clearance")


def near_scaling(quick: bool) -> None:
    from clamp import PlannerConfig
    from scenes import Scene
    print("\n=== 2. one obstacle query (7,500 sphere centres of the unobstructed path, the hinge's reach) "
          "against the boxes near the arm, with 10,000 far boxes")
    prior, robot = setting()
    config = PlannerConfig()
    centres = robot.sphere_centres(prior_path_q(prior, robot))[0]
    reach = config.model.epsilon + float(robot.spheres.radii.max())
    far = far_boxes(10_000, 2)
    near_all = near_boxes(centres, robot.spheres.radii, 320, 1)
    print(f"{'near':>5} | {'query':>8} {'per near box':>12} | {'kernels (near only)':>19}")
    for near in (10, 20, 40, 80, 160, 320)[: 3 if quick else None]:
        scene = Scene(near_all[:near] + far)
        query = scene.distance_query(max_distance=reach)
        seconds = median_seconds(lambda: query(centres), 9)
        coords = np.ascontiguousarray(centres.reshape(-1, 3).T)
        kernels = median_seconds(lambda: every_obstacle(Scene(near_all[:near]), coords), 5)
        print(f"{near:5d} | {seconds * 1e3:6.2f}ms {seconds / near * 1e6:10.0f}us | {kernels * 1e3:17.2f}ms")


def table_and_cloud(quick: bool) -> None:
    import coal
    from clamp import PlannerConfig, plan
    from scenes import PointCloud, Scene, SignedDistanceField, TriangleMesh
    from scenes.mesh import box_triangles
    print("\n=== 3. mesh and point-cloud obstacles on box_closing (Jaco)")
    prior, robot = setting()
    top, leg = box_triangles([0.38, -0.31, 0.385], [0.14, 0.14, 0.03]), box_triangles([0.38, -0.31, 0.185], [0.04, 0.04, 0.37])
    table = TriangleMesh(np.vstack([top[0], leg[0]]), np.vstack([top[1], leg[1] + 8]))   # a pedestal table
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(30, 3))
    cloud = PointCloud([0.43, -0.24, 0.22] + 0.04 * directions / np.linalg.norm(directions, axis=1, keepdims=True), 0.02)
    config = PlannerConfig()
    for label, scene in (("table mesh", Scene([table])), ("point cloud (30 points)", Scene([cloud])),
                         ("both", Scene([table, cloud]))):
        t0 = time.perf_counter()
        result = plan(prior, robot, scene, START, config=config, covariance=False)
        print(f"{label:24s} success {result.success}, min clearance {result.min_clearance * 1e3:5.1f} mm (URDF), "
              f"{time.perf_counter() - t0:5.2f} s, iterations {result.iterations}")
    centres = robot.sphere_centres(prior_path_q(prior, robot))[0].reshape(-1, 3)
    reach = config.model.epsilon + float(robot.spheres.radii.max())
    kernel = median_seconds(lambda: table._evaluate_within(centres.T, True, reach), 10)
    exact = median_seconds(lambda: table.query(centres), 5)
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(table.faces), len(table.vertices))
    model.addVertices(np.asarray(table.vertices))
    model.addTriangles(np.asarray(table.faces, dtype=np.int64))
    model.endModel()
    probe, request, identity = coal.Sphere(1e-9), coal.DistanceRequest(), coal.Transform3s()
    sample = centres[:: max(1, len(centres) // 500)]
    per_point = median_seconds(lambda: [coal.distance(model, identity, probe, coal.Transform3s(np.eye(3), p),
                                                      request, coal.DistanceResult()) for p in sample], 3) / len(sample)
    bounds = np.stack([table.aabb()[0] - reach, table.aabb()[1] + reach])
    t0 = time.perf_counter()
    grid = SignedDistanceField.from_obstacles([table], bounds, 0.01)
    grid_build = time.perf_counter() - t0
    grid_query = median_seconds(lambda: grid.query(centres), 10)
    print(f"table mesh distance on the {len(centres)} sphere centres of the prior's path: kernel within reach "
          f"{kernel * 1e3:.2f} ms (exact everywhere {exact * 1e3:.2f} ms); coal, one BVH distance per point "
          f"{per_point * len(centres) * 1e3:.1f} ms ({per_point * 1e6:.1f} us/point, unsigned); 1 cm grid "
          f"{grid_query * 1e3:.2f} ms + {grid_build * 1e3:.0f} ms build (one cell of error)")


def prior_path_q(prior, robot) -> np.ndarray:
    from clamp import build
    problem = build(prior, robot, None, START)
    return problem.initial[:, :robot.n]


def scene_files(quick: bool) -> None:
    from clamp import PlannerConfig, build, optimize
    from scenes import PointCloud, Scene
    print("\n=== 4. scene files (~50 MB)")
    count = 100_000 if quick else 800_000
    rng = np.random.default_rng(5)
    points = np.column_stack([rng.uniform(-0.6, 0.6, count), rng.uniform(-0.9, -0.1, count),
                              rng.uniform(-0.04, -0.02, count)])      # a table top under the arm
    scene = Scene([PointCloud(points, 0.005)])
    prior, robot = setting()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        for arrays in ("inline", "npz"):
            path = folder / f"cloud_{arrays}.json"
            t0 = time.perf_counter()
            scene.save(path, arrays=arrays)
            saved = time.perf_counter() - t0
            size = sum(p.stat().st_size for p in folder.glob(f"cloud_{arrays}*"))
            t0 = time.perf_counter()
            loaded = Scene.load(path)
            print(f"point cloud of {count:,} points, {arrays:6s}: {size / 1e6:6.1f} MB, saved in {saved:5.2f} s, "
                  f"loaded in {time.perf_counter() - t0:5.2f} s")
        spheres = {"obstacles": [{"type": "sphere", "center": p, "radius": 0.005}
                                 for p in points[: count * 420 // 800].tolist()]}
        path = folder / "spheres.json"
        path.write_text(json.dumps(spheres))
        t0 = time.perf_counter()
        old = Scene.load(path)
        print(f"{len(old.obstacles):,} spheres, one JSON object each: {path.stat().st_size / 1e6:6.1f} MB, "
              f"loaded in {time.perf_counter() - t0:5.2f} s (the pre-array format)")
        config = PlannerConfig()
        for label, big in (("the cloud", loaded), ("the spheres", old)):
            t0 = time.perf_counter()
            problem = build(prior, robot, big, START, config=config)
            built = time.perf_counter() - t0
            t0 = time.perf_counter()
            solved = optimize(problem, config)
            print(f"optimize on {label}: build {built:5.2f} s, optimize {time.perf_counter() - t0:5.2f} s "
                  f"({solved.iterations} iterations)")
    print(f"peak RSS of this process: {peak_rss_mb():.0f} MB")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer cases, a smaller file")
    parser.add_argument("--case", nargs=2, type=int, metavar=("NEAR", "FAR"), help=argparse.SUPPRESS)
    parser.add_argument("--full-plan", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--sections", nargs="+", type=int, default=[1, 2, 3, 4], choices=[1, 2, 3, 4],
                        help="1 obstacle count, 2 query against near boxes, 3 mesh and cloud, 4 scene files")
    args = parser.parse_args()
    if args.case:
        print(json.dumps(run_case(*args.case, args.full_plan)))
        return
    print_environment()
    sections = {1: obstacle_counts, 2: near_scaling, 3: table_and_cloud, 4: scene_files}
    for number in args.sections:
        sections[number](args.quick)


if __name__ == "__main__":
    main()
