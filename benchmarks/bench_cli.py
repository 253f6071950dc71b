"""The command line as a new user with their own arm meets it: wall time of whole processes.

Run: python benchmarks/bench_cli.py [--repeats N]  (prints; never asserts on time).

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
The first plan's q and the second's are compared: they must be identical (the cache stores the
spheres exactly).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from harness import print_environment

ROOT = Path(__file__).resolve().parents[1]
#: issue 38's targets [s] per timed command
TARGETS = {"clamp --version": 0.5, "clamp learn": None, "first clamp plan (cold cache)": 8.0,
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


def timed(command: list[str], env: dict[str, str]) -> tuple[float, subprocess.CompletedProcess]:
    """Wall time [s] of one process running ``command``, and its outcome (stopped on failure)."""
    begin = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - begin
    if done.returncode != 0:
        sys.exit(f"bench_cli: {' '.join(command[2:])} exited {done.returncode}: {done.stderr.strip()}")
    return seconds, done


def main() -> None:
    options = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    options.add_argument("--repeats", type=int, default=3, help="runs per command (default 3)")
    repeats = options.parse_args().repeats
    print_environment()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    clamp = [sys.executable, "-m", "clamp"]
    times: dict[str, list[float]] = {name: [] for name in TARGETS}
    with tempfile.TemporaryDirectory(prefix="bench_cli_") as tmp:
        folder = Path(tmp)
        files = panda_files(folder)
        arm = ["--urdf", files["urdf"], "--end-effector", "panda_hand", "--package-dir", files["share"]]
        for k in range(repeats):
            times["clamp --version"].append(timed([*clamp, "--version"], env)[0])
            prior = folder / f"prior{k}.npz"
            times["clamp learn"].append(timed([*clamp, "learn", "-q", "--demos", files["csv"], *arm,
                                               "--out", str(prior)], env)[0])
            cache = folder / f"cache{k}"                 # a fresh, empty sphere cache per repeat
            run_env = dict(env, SKILLPLAN_CACHE_DIR=str(cache))
            plans = []
            for name in ("first clamp plan (cold cache)", "second clamp plan (cached spheres)"):
                out = folder / f"out{k}_{len(plans)}"
                command = [*clamp, "plan", "-q", *arm, "--prior", str(prior), "--scene", files["scene"],
                           "--start", *files["start"].split(), "--out", str(out)]
                times[name].append(timed(command, run_env)[0])
                plans.append(json.loads((out / "plan.json").read_text(encoding="utf-8")))
            same = np.array_equal(np.array(plans[0]["q"]), np.array(plans[1]["q"]))
            print(f"repeat {k}: first and second plan q identical: {same}; "
                  f"success {plans[0]['success']}, clearance {1e3 * plans[0]['min_clearance']:.1f} mm")
    load = os.getloadavg()
    print(f"\nload average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs "
          f"(medians of {repeats} runs, each a fresh process)")
    print(f"{'command':38s} {'median s':>9s} {'target s':>9s}")
    for name, seconds in times.items():
        target = TARGETS[name]
        verdict = "" if target is None else ("  met" if np.median(seconds) <= target else "  MISSED")
        print(f"{name:38s} {np.median(seconds):9.2f} {'-' if target is None else f'{target:.1f}':>9s}{verdict}")


if __name__ == "__main__":
    main()
