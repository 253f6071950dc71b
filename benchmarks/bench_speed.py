"""Whole-call planning time across skills and arms, as a ratio to the recorded box_closing case
(issue 36 acceptance).

Every timing is one complete ``clamp.plan()`` call (default PlannerConfig, covariance
included), the median of ``--repeats`` calls after one warm-up. The anchor of a case is the
recorded box_closing case on the same arm and scene kind, timed in the same run: box_closing
(../shared/datasets) from the README start on the Jaco, shifted as the regression cases shift
it (tests/regression/cases.py) on the Sawyer; the Panda's and the UR5's cases, which have no
recorded skill, are anchored to the Jaco's (named in the table).

Cases (T <= 250): box_closing on the Jaco and the Sawyer; needle_threading and pick_place
embedded in the Jaco's workspace as bench_lfd does; the synthetic skills
(``scenes.make_demonstrations``, 6 demonstrations, 250 states); the 13 LASA shapes (200
states); the Panda (``panda_hand_tcp``) and the UR5 (``tool0``) of example-robot-data, each
with 5 joint-space demonstrations through 3 keyframes (minimum-jerk segments, keyframes
perturbed per demonstration, ``scenes.joint_demonstrations``); reach_from_above shown 2x
faster than the Jaco can follow. Every case runs in an empty scene and with one 6 cm box
centred on the prior's mean path at 50 % ("box"). Starts: the prior's mean start (box_closing:
the README start).

Prints per case: median [s], ratio to its anchor, success and the time scale; then the
target: every case's median within 3x its anchor.

    python benchmarks/bench_speed.py [--quick] [--repeats 3] [--only SUBSTRING ...]

--quick: 2 synthetic skills, 3 LASA shapes, 1 timed call after the warm-up.
"""
from __future__ import annotations

import argparse
import os
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from bench_lfd import _embedded, lasa_shapes
from harness import median_seconds, print_environment, print_machine_reference, \
    shared_demonstrations

REFERENCE_START = np.array([0.2054, -0.4722, 0.2625])      # the README / datasets README start
SAWYER_SHIFT = np.array([0.3, 0.0, 0.2])                    # tests/regression/cases.py
BOX_SIDE = 0.06                                             # [m]
TARGET = 3.0                                                # x the anchor
#: keyframes (3, n) [rad] of the URDF arms' joint-space demonstrations, and their end frames
KEYFRAMES = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand_tcp",
              [[0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8], [0.5, 0.1, 0.2, -1.8, 0.0, 2.1, 0.8],
               [1.0, -0.2, 0.1, -2.4, 0.0, 2.3, 0.8]]),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0",
            [[0.0, -1.2, 1.5, -1.9, -1.57, 0.0], [0.6, -1.0, 1.2, -1.8, -1.57, 0.3],
             [1.2, -1.4, 1.6, -1.8, -1.57, 0.6]]),
}
KEYFRAME_DEMOS, KEYFRAME_STATES, KEYFRAME_DURATION, KEYFRAME_SPREAD = 5, 200, 10.0, 0.05


@dataclass
class Case:
    """A skill to plan: ``prior`` on ``robot`` from ``start``; ``anchor`` names its anchor."""

    name: str
    robot_name: str
    robot: Any
    prior: Any
    start: np.ndarray
    anchor: str


def minimum_jerk(keyframes: np.ndarray, states: int) -> np.ndarray:
    """Joint positions (states, n) through ``keyframes`` (K, n), a minimum-jerk segment between
    consecutive keyframes, equal durations."""
    segments = len(keyframes) - 1
    s = np.linspace(0.0, segments, states)
    index = np.minimum(s.astype(int), segments - 1)
    tau = s - index
    blend = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    return keyframes[index] + blend[:, None] * (keyframes[index + 1] - keyframes[index])


def keyframe_demonstrations(robot: Any, keyframes: Any, name: str) -> Any:
    """KEYFRAME_DEMOS joint-space demonstrations of ``robot`` through ``keyframes`` (K, n)
    [rad], each keyframe moved by N(0, KEYFRAME_SPREAD^2) per joint (seeded), mapped to the
    workspace by the robot's kinematics (scenes.joint_demonstrations)."""
    from scenes.joint_demonstrations import from_joint_trajectories
    rng = np.random.default_rng(0)
    keyframes = np.asarray(keyframes, dtype=float)
    time = np.linspace(0.0, KEYFRAME_DURATION, KEYFRAME_STATES)
    q = [minimum_jerk(keyframes + KEYFRAME_SPREAD * rng.standard_normal(keyframes.shape),
                      KEYFRAME_STATES) for _ in range(KEYFRAME_DEMOS)]
    return from_joint_trajectories(robot, q, [time] * KEYFRAME_DEMOS, name=name)


def too_fast(demos: Any, robot: Any, faster: float) -> Any:
    """The prior of ``demos`` shown so fast that following it needs ``faster`` x the arm's
    velocity limits: time compressed by its empty-scene plan's peak velocity ratio / faster."""
    from clamp import learn_prior, plan
    from clamp.planning.time_scale import peak_ratios
    prior = learn_prior(demos)
    free = plan(prior, robot, None, np.asarray(prior.mean)[0, :3], time_scale=1.0,
                covariance=False)
    velocity, _ = peak_ratios(robot, free.q, free.qdot, free.time)
    squeeze = float(velocity.max()) / faster
    return learn_prior(type(demos)(demos.positions, demos.velocities / squeeze,
                                   demos.time * squeeze, name=f"{demos.name} x{faster:g}"))


def make_cases(quick: bool) -> list[Case]:
    from clamp import learn_prior
    from robots import Robot, load_robot
    from robots.registry import example_robot_data_share
    from scenes import SKILLS, make_demonstrations

    jaco, sawyer = load_robot("jaco"), load_robot("sawyer")
    cases: list[Case] = []

    def add(name: str, robot_name: str, robot: Any, demos: Any, start: Any = None,
            anchor: str = "jaco") -> None:
        prior = learn_prior(demos)
        cases.append(Case(name, robot_name, robot, prior,
                          np.asarray(prior.mean)[0, :3] if start is None else start, anchor))

    box_closing = shared_demonstrations("box_closing")
    if box_closing is not None:
        add("box_closing", "jaco", jaco, box_closing, REFERENCE_START)
        add("box_closing", "sawyer", sawyer, box_closing.translated(SAWYER_SHIFT),
            REFERENCE_START + SAWYER_SHIFT, anchor="sawyer")
    for name in ("needle_threading", "pick_place"):
        demos = shared_demonstrations(name)
        if demos is not None:
            add(name, "jaco", jaco, _embedded(demos, name)[0])
    for skill in SKILLS[:2] if quick else SKILLS:
        add(f"syn:{skill}", "jaco", jaco,
            make_demonstrations(skill, num_demos=6, num_points=250, seed=0))
    shapes = lasa_shapes()
    for shape in list(shapes)[:3] if quick else shapes:
        add(f"lasa:{shape}", "jaco", jaco, shapes[shape])
    share = example_robot_data_share()
    for arm, (urdf, frame, keyframes) in KEYFRAMES.items():
        robot = Robot.from_urdf(share / "example-robot-data" / "robots" / urdf,
                                end_effector=frame, package_dirs=[share])
        add(f"keyframes:{arm}", arm, robot, keyframe_demonstrations(robot, keyframes, arm))
    demos = make_demonstrations("reach_from_above", num_demos=6, num_points=250, seed=0)
    prior = too_fast(demos, jaco, 2.0)
    cases.append(Case("syn:reach_from_above x2 fast", "jaco", jaco, prior,
                      np.asarray(prior.mean)[0, :3], "jaco"))
    return cases


def box_on_path(prior: Any) -> Any:
    """One BOX_SIDE cube centred on the prior's mean path at 50 %."""
    from scenes import Box, Scene
    mean = np.asarray(prior.mean)[:, :3]
    return Scene([Box(mean[len(mean) // 2], [BOX_SIDE] * 3)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="2 synthetic skills, 3 LASA shapes, 1 timed call")
    parser.add_argument("--repeats", type=int, default=None, help="timed calls (default 3)")
    parser.add_argument("--only", nargs="*", default=(),
                        help="cases whose name contains one of these (anchors always run)")
    args = parser.parse_args()
    repeats = args.repeats or (1 if args.quick else 3)
    print_environment()
    print_machine_reference()
    warnings.simplefilter("ignore")
    from clamp import plan

    cases = [c for c in make_cases(args.quick)
             if c.name == "box_closing" or not args.only or any(o in c.name for o in args.only)]
    print(f"\nwhole plan() calls, median of {repeats} after 1 warm-up; ratio = median / the "
          f"box_closing case on the anchor arm, same scene kind (load "
          f"{os.getloadavg()[0]:.1f})")
    print(f"{'case':<34} {'arm':<7} {'scene':<6} {'median s':>9} {'ratio':>6} {'anchor':<7} "
          f"{'ok':<4} {'scale':>5}  reason")
    anchors: dict[tuple[str, str], float] = {}
    worst: list[tuple[float, str]] = []
    for case in sorted(cases, key=lambda c: c.name != "box_closing"):
        for kind in ("empty", "box"):
            scene = None if kind == "empty" else box_on_path(case.prior)
            last: list[Any] = []

            def call(case: Case = case, scene: Any = scene) -> None:
                last[:] = [plan(case.prior, case.robot, scene, case.start)]
            seconds = median_seconds(call, repeats)
            result = last[0]
            if case.name == "box_closing":
                anchors[(case.robot_name, kind)] = seconds
            anchor = anchors.get((case.anchor, kind))
            ratio = seconds / anchor if anchor else float("nan")
            if case.name != "box_closing" or case.robot_name != case.anchor:
                worst.append((ratio, f"{case.name} {case.robot_name} {kind}"))
            reason = "" if result.success else result.reasons[0][:70]
            print(f"{case.name:<34} {case.robot_name:<7} {kind:<6} {seconds:>9.3f} "
                  f"{ratio:>6.2f} {case.anchor:<7} {'yes' if result.success else 'no':<4} "
                  f"{result.time_scale:>5.2f}  {reason}", flush=True)
    if not anchors:
        print("# box_closing.mat absent: no anchor, no target line")
        return
    measured = [w for w in worst if np.isfinite(w[0])]
    within = sum(ratio <= TARGET for ratio, _ in measured)
    ratio, label = max(measured)
    print(f"\ntarget: every case's median within {TARGET:g}x its box_closing anchor: "
          f"{within} / {len(measured)} cases within; worst {ratio:.2f}x ({label}) -> "
          f"{'met' if within == len(measured) else 'NOT met'}")


if __name__ == "__main__":
    main()
