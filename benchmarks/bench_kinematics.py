"""Benchmark of the robots package: vectorized kinematics vs a per-configuration Pinocchio loop,
and trajectory IK on box_closing's mean end-effector path.

Run:  python benchmarks/bench_kinematics.py [--repeats 30] [--T 250] [--no-spheres]
Prints medians (ms) and ratios; no assertions. Sphere models come from robots/spheres/<name>.json
when present, otherwise they are fitted once (slow) before timing.
"""
from __future__ import annotations

import argparse
import itertools
import time

import numpy as np
import pinocchio as pin

from robots import Robot, load_robot
from robots.spheres import sphere_coverage
from harness import median_ms, print_environment, shared_demonstrations



def pinocchio_ee_loop(robot: Robot, q: np.ndarray, qdot: np.ndarray) -> None:
    """Per-configuration Pinocchio: end-effector position, velocity and d v/dq, d v/d qdot."""
    model, data = robot.model, robot.model.createData()
    ee = robot.chain.frame_id(robot.end_effector)
    q_pin = robot.to_pinocchio(q)
    for t in range(len(q)):
        pin.computeForwardKinematicsDerivatives(model, data, q_pin[t], qdot[t], np.zeros(robot.n))
        pin.updateFramePlacement(model, data, ee)
        pin.getFrameVelocity(model, data, ee, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        pin.getFrameVelocityDerivatives(model, data, ee, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)


def pinocchio_sphere_loop(robot: Robot, q: np.ndarray, joints: np.ndarray, local: np.ndarray) -> None:
    """Per-configuration, per-sphere Pinocchio: sphere centres and their Jacobians."""
    model, data = robot.model, robot.model.createData()
    q_pin = robot.to_pinocchio(q)
    placements = [pin.SE3(np.eye(3), c) for c in local]
    for t in range(len(q)):
        pin.computeJointJacobians(model, data, q_pin[t])
        for joint, placement in zip(joints, placements):
            (data.oMi[int(joint)] * placement).translation
            pin.getFrameJacobian(model, data, int(joint), placement, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)


def alternating(call, *batches):
    """A call without arguments that cycles through the argument tuples `batches`, so that
    consecutive calls never pass equal q and SerialChain.joint_frames' cache of the most recent
    batch cannot answer (a planner evaluates new configurations every iteration)."""
    arguments = itertools.cycle(batches)
    return lambda: call(*next(arguments))


def box_closing_mean_path() -> np.ndarray | None:
    """Mean end-effector path (250, 3) of ../shared/datasets/box_closing.mat, or None if absent."""
    demos = shared_demonstrations("box_closing")
    return None if demos is None else demos.mean_position()


def sphere_report(robot: Robot) -> None:
    report = sphere_coverage(robot.model, robot.collision_model, robot.spheres)
    print(f"  spheres: {report.num_spheres}, surface coverage {100 * report.coverage:.1f} % "
          f"(inflation {report.inflation * 1e3:.0f} mm), max gap {report.max_gap * 1e3:.1f} mm, "
          f"mean radius {report.mean_radius * 1e3:.0f} mm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--T", type=int, default=250)
    parser.add_argument("--no-spheres", action="store_true", help="skip sphere timings and report")
    args = parser.parse_args()
    print_environment()
    rng = np.random.default_rng(0)
    mean_path = box_closing_mean_path()
    for name in ("jaco", "sawyer"):
        robot = load_robot(name)
        q = np.array([robot.random_configuration(rng) for _ in range(args.T)])
        qdot = rng.normal(0.0, 0.5, q.shape)
        q_other = np.array([robot.random_configuration(rng) for _ in range(args.T)])
        print(f"{name} (n={robot.n}, T={args.T}):")
        ours = median_ms(alternating(lambda q, qdot: robot.ee_kinematics(q, qdot, jacobians=True),
                                     (q, qdot), (q_other, qdot)), args.repeats)
        loop = median_ms(lambda: pinocchio_ee_loop(robot, q, qdot), max(3, args.repeats // 5))
        print(f"  ee_kinematics + Jacobians: {ours:7.3f} ms   Pinocchio loop {loop:7.3f} ms   ratio {loop / ours:5.1f}x")
        if not args.no_spheres:
            start = time.perf_counter()
            spheres = robot.spheres
            setup = time.perf_counter() - start
            if setup > 0.5:
                print(f"  (sphere model fitted in {setup:.1f} s: no robots/spheres/{name}.json override)")
            ours = median_ms(alternating(lambda q: robot.sphere_centres(q, jacobians=True), (q,), (q_other,)),
                             args.repeats)
            joints, local = robot.sphere_attachments()
            loop = median_ms(lambda: pinocchio_sphere_loop(robot, q, joints, local), max(3, args.repeats // 10))
            print(f"  sphere_centres + Jacobians (S={spheres.count}): {ours:7.3f} ms   Pinocchio loop {loop:7.3f} ms"
                  f"   ratio {loop / ours:5.1f}x")
            sphere_report(robot)
        if mean_path is not None:
            result = robot.ik_trajectory(mean_path)
            ik_ms = median_ms(lambda: robot.ik_trajectory(mean_path), max(3, args.repeats // 6))
            print(f"  ik_trajectory on box_closing mean path (T={len(mean_path)}): {ik_ms:7.1f} ms, "
                  f"max error {result.errors.max() * 1e3:.3f} mm, success {result.success}")
        else:
            print("  box_closing.mat not found in ../shared/datasets: trajectory IK timing skipped")


if __name__ == "__main__":
    main()
