"""The command line as a new user with their own arm meets it: wall time of whole processes.

Run: python benchmarks/bench_cli.py [--repeats N] [--anchor CHECKOUT]  (prints; never asserts on
time). ``--anchor /path/to/main`` times another checkout of the project in the same rounds,
interleaved (its plans may draw figures: it is timed as it is).

The user's arm is example-robot-data's Franka Panda URDF (end effector ``panda_hand``, meshes
found with ``--package-dir``); the demonstrations are joint-space recordings in the documented
CSV format (header ``demo,t,panda_joint1..7``, radians): the synthetic box_closing skill (6
demonstrations, seed 0) followed by the Panda's inverse kinematics; the scene is a 3 cm box on
the prior's mean path half way along it. Timed, each as a fresh process (``python -m clamp``):

- ``clamp --version``;
- ``clamp learn --demos joints.csv --urdf panda.urdf ...``;
- a first ``clamp plan --urdf ... --prior ... --scene ...`` with a cold sphere cache (a fresh,
  empty ``SKILLPLAN_CACHE_DIR``: the collision spheres are fitted and stored);
- a second, identical plan (the spheres read from that cache).

No figures are asked for (``--figures`` is off by default). Medians over ``--repeats`` runs
(each first plan gets its own empty cache folder), printed beside the targets of issue 38
(``--version`` <= 0.5 s, second plan <= 3 s, first plan <= 8 s) and the machine's load average.
Anchors, timed in the same rounds: the interpreter alone (``python -c pass``) and NumPy's import
(``python -c 'import numpy'``, which ``clamp --version`` needs). Each command's wall time and its
CPU time (user + system, of the process and its children): on a shared machine the wall time
grows with the load, the CPU time is what the command itself needs, the wall time it would take
on a quiet machine (a conservative one where BLAS uses both cores); the targets are read
against it.
The first plan's q and the second's are compared: they must be identical (the cache stores the
spheres exactly).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from harness import print_environment

ROOT = Path(__file__).resolve().parents[1]
#: issue 38's targets [s] per timed command (None: no target; the anchors: the interpreter alone)
TARGETS = {"anchor: python -c pass": None, "anchor: python -c 'import numpy'": None,
           "clamp --version": 0.5, "clamp learn": None, "first clamp plan (cold cache)": 8.0,
           "second clamp plan (cached spheres)": 3.0}


def panda_files(folder: Path) -> dict[str, str]:
    """Write the user's files into ``folder``: joint-space demonstrations (CSV) and a scene with a
    box on the path; returns the paths and the Panda's URDF, package folder and start."""
    from clamp import learn_prior
    from robots import Robot
    from robots.registry import example_robot_data_share
    from scenes import Box, Scene, make_demonstrations
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "panda_description" / "urdf" / "panda.urdf"
    robot = Robot.from_urdf(urdf, end_effector="panda_hand", package_dirs=[share])
    demos = make_demonstrations("box_closing", num_demos=6, seed=0)
    rows = []
    for m in range(demos.M):
        q = robot.ik_trajectory(demos.positions[m]).q
        rows += [[m, t, *joints] for t, joints in zip(demos.time, q)]
    csv = folder / "joints.csv"
    header = ",".join(["demo", "t", *robot.joint_names])
    np.savetxt(csv, np.array(rows), delimiter=",", header=header, comments="",
               fmt=["%d"] + ["%.17g"] * (1 + robot.n))
    mean = learn_prior(demos).mean[:, :3]
    scene = folder / "scene.json"
    Scene([Box(mean[len(mean) // 2], [0.03, 0.03, 0.03])]).save(scene)
    return {"urdf": str(urdf), "share": str(share), "csv": str(csv), "scene": str(scene),
            "start": " ".join(f"{x:.4f}" for x in mean[0])}


def timed(command: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system) [s] of one process running ``command`` in ``cwd``
    (stopped on failure). On a quiet machine the two agree; under load the CPU time is what the
    process itself needed."""
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    begin = time.perf_counter()
    done = subprocess.run(command, env=env, cwd=cwd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - begin
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"bench_cli: {' '.join(command[2:])} exited {done.returncode}: {done.stderr.strip()}")
    return wall, (after.ru_utime - used.ru_utime) + (after.ru_stime - used.ru_stime)


def one_round(checkout: Path, folder: Path, files: dict[str, str], k: int) -> dict[str, tuple[float, float]]:
    """Wall and CPU time [s] of each timed command of round ``k`` with the project of ``checkout``
    (run in a fresh folder: ``python -m`` puts the working folder first on the path)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(checkout), os.environ.get("PYTHONPATH")])))
    clamp = [sys.executable, "-m", "clamp"]
    arm = ["--urdf", files["urdf"], "--end-effector", "panda_hand", "--package-dir", files["share"]]
    work = Path(tempfile.mkdtemp(prefix="round_", dir=folder))
    times = {"anchor: python -c pass": timed([sys.executable, "-c", "pass"], env, work),
             "anchor: python -c 'import numpy'": timed([sys.executable, "-c", "import numpy"], env, work),
             "clamp --version": timed([*clamp, "--version"], env, work)}
    times["clamp learn"] = timed([*clamp, "learn", "-q", "--demos", files["csv"], *arm,
                                  "--out", str(work / "prior.npz")], env, work)
    run_env = dict(env, SKILLPLAN_CACHE_DIR=str(work / "cache"))     # a fresh, empty sphere cache
    plans = []
    for name in ("first clamp plan (cold cache)", "second clamp plan (cached spheres)"):
        out = work / f"out{len(plans)}"
        times[name] = timed([*clamp, "plan", "-q", *arm, "--prior", str(work / "prior.npz"), "--scene",
                             files["scene"], "--start", *files["start"].split(), "--out", str(out)], run_env, work)
        plans.append(json.loads((out / "plan.json").read_text(encoding="utf-8")))
    same = np.array_equal(np.array(plans[0]["q"]), np.array(plans[1]["q"]))
    print(f"{checkout} round {k}: first and second plan q identical: {same}; success "
          f"{plans[0]['success']}, clearance {1e3 * plans[0]['min_clearance']:.1f} mm", flush=True)
    return times


def main() -> None:
    options = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    options.add_argument("--repeats", type=int, default=3, help="runs per command (default 3)")
    options.add_argument("--anchor", type=Path, default=None, metavar="CHECKOUT",
                         help="another checkout of the project (e.g. main's) timed in the same rounds")
    given = options.parse_args()
    checkouts = [ROOT] + ([given.anchor.resolve()] if given.anchor else [])
    print_environment()
    times: dict[Path, dict[str, list[tuple[float, float]]]] = {
        checkout: {name: [] for name in TARGETS} for checkout in checkouts}
    with tempfile.TemporaryDirectory(prefix="bench_cli_") as tmp:
        folder = Path(tmp)
        files = panda_files(folder)
        for k in range(given.repeats):
            for checkout in checkouts:                   # interleaved: a drifting load hits both
                for name, measured in one_round(checkout, folder, files, k).items():
                    times[checkout][name].append(measured)
    load = os.getloadavg()
    print(f"\nload average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs "
          f"(medians of {given.repeats} runs, each a fresh process)")
    print("wall: median wall time; cpu: median CPU time (user + system) of the process, what it "
          "takes on a quiet machine; the targets are read against it")
    for checkout in checkouts:
        print(f"\n{checkout}\n{'command':38s} {'wall s':>8s} {'cpu s':>8s} "
              f"{'cpu / anchor':>13s} {'target s':>9s}")
        for name, runs in times[checkout].items():
            target = TARGETS[name]
            wall, cpu = (float(np.median([run[i] for run in runs])) for i in (0, 1))
            verdict = "" if target is None else ("  met" if cpu <= target else "  MISSED")
            anchor = float(np.median([run[1] for run in times[checkouts[-1]][name]]))
            versus = f"{cpu / anchor:13.2f}" if len(checkouts) > 1 else f"{'-':>13s}"
            print(f"{name:38s} {wall:8.2f} {cpu:8.2f} {versus} "
                  f"{'-' if target is None else f'{target:.1f}':>9s}{verdict}")


if __name__ == "__main__":
    main()
