"""Report: where and why the arm's plan of a pose skill leaves the prior's conditioned mean, on
bench_lfd's leave-one-out folds (issue 37).

For every fold and setting of a bench_lfd pose set, planned as bench_lfd plans it (the arm at
the held-out start pose, to its goal pose in the "goal" setting):
- ori [deg]: bench_lfd's orientation error against the held-out demonstration, of the arm's plan
  and of the planner's conditioned mean (the plan's model prior: conditioned on the arm's
  start rotation, as the plan is);
- how far the plan is from that mean: mean / largest angle [deg], mean offset [mm];
- reach: the start pose's pose IK miss; the mean's poses, each solved by pose IK (least squares
  within the joint limits, 1 mm weighing as 1 deg) tracked from the plan's start: the states
  beyond 1 mm or 1 deg, the largest misses, the least joint-limit margin [rad];
- the graph error per factor family [nats] at the plan and on the mean's IK path (velocities:
  the chain's [v, omega] through the hand's Jacobian): what following the mean costs each
  family; the families' rows count whitened residuals of 6 (workspace, orientation) or 12
  (joint GP) numbers;
- the solve: accepted iterations, stop reason, the Gauss-Newton model's predicted decrease at
  the plan [nats] (~0: a minimum); the time scale chosen and the plan's own need there;
- with --restart, the solve started on the mean's IK path (same time scale): its error and
  angle from the mean (the same optimum as the plan's, or another).

Run: python benchmarks/report_arm_plan.py [--sets wiping_rim pose_synthetic] [--folds 0 3]
     [--settings goal] [--restart]
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_lfd  # noqa: E402
import clamp  # noqa: E402
import robots  # noqa: E402
from clamp.factors.states import StateWindow  # noqa: E402
from clamp.planning.time_scale import peak_ratios  # noqa: E402
from clamp.prior import so3  # noqa: E402
from lfd_metrics import orientation_error  # noqa: E402

REACH_TOLERANCE = (1.0, 1.0)        # [mm], [deg]: a mean pose beyond either is out of reach


def tracked_pose_ik(robot, positions: np.ndarray, rotations: np.ndarray, q0: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Configurations (T, n) [rad] whose hand is at the poses (positions (T, 3) [m], rotations
    (T, 3, 3)), each solved from the one before (the first from q0) within the joint limits,
    1 mm weighing as 1 deg; with their position [mm] and rotation [deg] misses (T,)."""
    q, out, misses = np.asarray(q0, float), [], []
    for p, R in zip(positions, rotations):
        def residual(x: np.ndarray, p=p, R=R) -> np.ndarray:
            hand, _ = robot.ee_rotation(x)
            return np.concatenate([(robot.fk(x) - p) / 1e-3,
                                   np.degrees(so3.log_map(R.T @ hand))])
        q = least_squares(residual, np.clip(q, robot.lower_limits, robot.upper_limits),
                          bounds=(robot.lower_limits, robot.upper_limits)).x
        r = residual(q)
        out.append(q)
        misses.append((np.linalg.norm(r[:3]), np.linalg.norm(r[3:])))
    misses = np.array(misses)
    return np.array(out), misses[:, 0], misses[:, 1]


def chain_velocities(robot, q: np.ndarray, velocities: np.ndarray, rates: np.ndarray
                     ) -> np.ndarray:
    """Joint velocities (T, n) [rad/s] giving the hand the linear velocities (T, 3) [m/s] and
    base-frame angular velocities (T, 3) [rad/s] at configurations q (T, n) (least squares)."""
    zeros = np.zeros_like(q)
    _, W, _, _ = StateWindow(robot, np.hstack([q, zeros])).rotation(True)
    J = np.concatenate([robot.ee_kinematics(q, zeros).jacobian, W], axis=1)
    wanted = np.hstack([velocities, rates])
    return np.array([np.linalg.lstsq(J[t], wanted[t], rcond=None)[0] for t in range(len(q))])


def predicted_decrease(problem, theta: np.ndarray) -> float:
    """What a full Gauss-Newton step of ``problem`` at theta (T, 2n) would lower its error by,
    by its linear model [nats] (~0 at a minimum)."""
    system = problem.normal_equations(theta)
    T, d = system.D.shape[:2]
    H = np.zeros((T * d, T * d))
    for t in range(T):
        H[t * d:(t + 1) * d, t * d:(t + 1) * d] = system.D[t]
        if t + 1 < T:
            H[t * d:(t + 1) * d, (t + 1) * d:(t + 2) * d] = system.E[t]
            H[(t + 1) * d:(t + 2) * d, t * d:(t + 1) * d] = system.E[t].T
    g = system.g.reshape(-1)
    return 0.5 * float(g @ np.linalg.lstsq(H, g, rcond=None)[0])


def _rounded(errors: dict[str, float]) -> str:
    """The families' errors [nats] of 0.05 or more, one decimal."""
    return ", ".join(f"{name} {value:.1f}" for name, value in errors.items() if value >= 0.05)


def report_fold(data: bench_lfd.DataSet, k: int, setting: str, robot, restart: bool) -> dict:
    """Print the fold's figures (module docstring); return the arm's and the mean's ori."""
    demos = data.demos
    held, turns = demos.positions[k], demos.orientations[k]
    train = bench_lfd.subset(demos, np.arange(demos.M) != k)
    start = np.concatenate([held[0], turns[0]])
    goal = np.concatenate([held[-1], turns[-1]]) if setting == "goal" else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clamp.ClampWarning)
        prior = clamp.learn_prior(train)
    if demos.joint_positions is not None:
        q0, start_miss = demos.joint_positions[k][0], "recorded joint start"
    else:
        q0, position_miss, angle_miss = bench_lfd.pose_ik(robot, start)
        start_miss = f"start pose IK {1e3 * position_miss:.1f} mm, {np.degrees(angle_miss):.1f} deg"
    goal_pose = None if goal is None else (goal[:3], goal[3:])
    result = clamp.plan(prior, robot, None, q0, goal=goal_pose)
    mean = result.inputs.model_prior
    mean_p, mean_R = np.asarray(mean.mean)[:, :3], mean.orientation.mean_rotations
    hand_R, _ = robot.ee_rotation(result.q)
    ori_arm = np.degrees(orientation_error(result.ee_path, Rotation.from_matrix(hand_R).as_quat(),
                                           held, turns))
    ori_mean = np.degrees(orientation_error(mean_p, Rotation.from_matrix(mean_R).as_quat(),
                                            held, turns))
    angle = np.degrees(so3.angle_between(hand_R, mean_R))
    offset = 1e3 * np.linalg.norm(result.ee_path - mean_p, axis=1)
    print(f"{data.name} fold {k} {setting}: {start_miss}; ori arm {ori_arm:.2f} / mean "
          f"{ori_mean:.2f} deg; plan from the mean: angle {angle.mean():.1f} (max "
          f"{angle.max():.1f} at state {angle.argmax()}) deg, offset {offset.mean():.0f} mm; "
          f"success {result.success}")
    q_mean, position_miss, angle_miss = tracked_pose_ik(robot, mean_p, mean_R, result.q[0])
    out = (position_miss > REACH_TOLERANCE[0]) | (angle_miss > REACH_TOLERANCE[1])
    margin = np.minimum(q_mean - robot.lower_limits, robot.upper_limits - q_mean).min()
    print(f"  mean's reach: {out.sum()} of {len(out)} states out (largest miss "
          f"{position_miss.max():.2f} mm, {angle_miss.max():.2f} deg); least joint-limit "
          f"margin {margin:.3f} rad")
    problem, theta = result.problem, np.hstack([result.q, result.qdot])
    chain = np.asarray(mean.orientation.mean)
    rates = np.einsum("tij,tj->ti", mean.orientation.rotations, chain[:, 3:])
    theta_mean = np.hstack([q_mean, chain_velocities(robot, q_mean, np.asarray(mean.mean)[:, 3:],
                                                     rates)])
    at_plan, at_mean = problem.family_errors(theta), problem.family_errors(theta_mean)
    print(f"  family errors [nats] at the plan: {_rounded(at_plan)} (total "
          f"{sum(at_plan.values()):.1f})")
    print(f"  on the mean's IK path: {_rounded(at_mean)} (total {sum(at_mean.values()):.1f})")
    velocity, _ = peak_ratios(robot, result.q, result.qdot, result.time)
    print(f"  solve: {result.iterations} iterations, {result.stop_reason}, predicted decrease "
          f"{predicted_decrease(problem, theta):.3g} nats; time scale {result.time_scale:.2f}, "
          f"the plan's own need {result.time_scale * velocity.max():.2f}")
    if restart:
        again = clamp.plan(prior, robot, None, q0, goal=goal_pose, initial=theta_mean,
                           time_scale=result.time_scale)
        turned, _ = robot.ee_rotation(again.q)
        print(f"  from the mean's IK path: error {again.final_error:.1f} (plan "
              f"{result.final_error:.1f}) nats, {again.iterations} iterations, angle from the "
              f"mean {np.degrees(so3.angle_between(turned, mean_R)).mean():.1f} deg")
    return {"arm": ori_arm, "mean": ori_mean}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", nargs="+", default=["wiping_rim"],
                        help="bench_lfd pose sets: wiping_rim, pose_synthetic")
    parser.add_argument("--folds", nargs="+", type=int, default=None)
    parser.add_argument("--settings", nargs="+", default=["goal"], choices=bench_lfd.SETTINGS)
    parser.add_argument("--restart", action="store_true",
                        help="also solve from the mean's IK path")
    args = parser.parse_args()
    robot = robots.load_robot("jaco")
    for data in bench_lfd.load_sets(args.sets, quick=False):
        if not data.pose:
            continue
        for setting in args.settings:
            folds = range(data.demos.M) if args.folds is None else args.folds
            ori = [report_fold(data, k, setting, robot, args.restart) for k in folds]
            print(f"{data.name} {setting}: ori arm {np.mean([o['arm'] for o in ori]):.2f} / mean "
                  f"{np.mean([o['mean'] for o in ori]):.2f} deg over {len(ori)} folds\n")


if __name__ == "__main__":
    main()
