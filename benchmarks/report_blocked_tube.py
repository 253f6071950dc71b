"""Is the skill's tube blocked? Would a certified "no" fire on a family's problems (issue 36)?

The verdict passes a plan only if at every state t its hand point lies within TUBE_RATIO tube
radii R_t of the reference (:func:`clamp.prior.skill.skill_checks`: per state, time-aligned) and,
for a pose prior, its rotation within TUBE_RATIO orientation spreads a_t of the reference's. Two
measures per problem whose start is clear, at the states where an obstacle cuts the tube:

- **hand** (sound): an upper bound on the clearance of the hand's own collision geometry (the
  geometry rigid with the end-effector frame, as surface points g in that frame) over every hand
  pose the checks allow: sdf is 1-Lipschitz, so at state t the clearance is at most
  min_g sdf(ref_t + Rref_t g) + R_t + chord(a_t) |g| with a pose prior, and
  sdf(ref_t) + R_t + min_g |g| without (any rotation). Below zero at some state, no plan can pass
  the checks: the tube is blocked there. The same at the skill's end: a plan without a goal of its own
  ends within the completion radius of the demonstrations' mean end. Printed: the least bound over the states [mm] (the room
  the tube leaves the hand) and whether it is blocked.
- **arm** (sampled, NOT a certificate): at 8 states across the cut, hand points drawn in the
  tube ball clear of the obstacles by 2 mm, inverse kinematics from random configurations, and
  how many of the solutions are clear of the scene and of the arm itself ("clear / solved"). One
  clear configuration proves that state open; none proves nothing.

    SKILLPLAN_DATASETS=../shared/datasets python benchmarks/report_blocked_tube.py --family hard \\
        --arms sawyer --problems 20
"""
from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

import bench_fidelity as fidelity
from harness import print_environment

#: [m] a bound below minus this counts as blocked (the clearance check's resolution, 0.2 mm)
TOLERANCE = 2e-4
#: hand surface points sampled per link shape set (besides a mesh's vertices)
SURFACE_POINTS = 4000
#: hand points kept (a random subset: every one is a point of the geometry, the bound stays sound)
MAX_POINTS = 4000


def hand_points(robot: Any) -> np.ndarray:
    """Points (G, 3) [m] of the collision geometry rigid with the end-effector frame, in that
    frame (surface samples and mesh vertices: every one is a point of the geometry)."""
    import pinocchio as pin
    from robots.collision_geometry import link_surfaces
    from robots.kinematics import frame_index
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.to_pinocchio(np.zeros(robot.n)))
    pin.updateFramePlacements(model, data)
    hand = data.oMf[frame_index(model, robot.end_effector)]
    rng = np.random.default_rng(0)
    for surface in link_surfaces(model, robot.collision_model):
        if surface.joint_id == robot.attachment(robot.end_effector).joint:
            link = data.oMf[model.getFrameId(surface.link_name)]
            points = np.vstack([surface.sample_surface(SURFACE_POINTS, rng)]
                               + [shape.triangles.reshape(-1, 3) for shape in surface.shapes
                                  if shape.triangles is not None])
            if len(points) > MAX_POINTS:   # any subset of the geometry's points keeps the bound
                points = points[rng.choice(len(points), MAX_POINTS, replace=False)]
            return (points @ link.rotation.T + link.translation - hand.translation) @ hand.rotation
    raise SystemExit("the robot has no collision geometry moves with the end effector")


def tube(prior: Any, robot: Any, start: Any) -> tuple[np.ndarray, np.ndarray, Any]:
    """Where the skill goes from ``start`` (a joint configuration (n,) [rad] or a hand position
    (3,) [m]) without a goal: the reference path (T, 3) [m], the tube limit R (T,) [m] and the
    reference prior (the planner's own: the prior conditioned on the request)."""
    from clamp.config import as_config
    from clamp.planning.reference import planning_prior, skill_reference
    from clamp.planning.request import make_request
    from clamp.planning.time_scale import demonstrated_speed_config
    from clamp.prior.skill import TUBE_RATIO, SkillRegion
    config = demonstrated_speed_config(as_config(None), prior)
    request = make_request(prior, robot, start, None, (), config)
    reference, _ = skill_reference(prior, robot, request, config,
                                   planning_prior(prior, robot, request, config), [])
    return (np.asarray(reference.mean)[:, :3], TUBE_RATIO * SkillRegion.of(prior).tube,
            reference)


def hand_bound(scene: Any, prior: Any, centre: np.ndarray, limit: np.ndarray, reference: Any,
               points: np.ndarray) -> np.ndarray:
    """The sound upper bound (T,) [m] on the hand's clearance over the poses the checks allow."""
    from clamp.prior.orientation_skill import angle_spread
    from clamp.prior.skill import TUBE_RATIO
    reach = np.linalg.norm(points, axis=1)
    anyhow = scene.distance(centre) + limit + reach.min()          # any rotation
    if getattr(prior, "orientation", None) is None:
        return anyhow
    angle = np.minimum(TUBE_RATIO * angle_spread(prior.orientation), np.pi)
    placed = centre[:, None] + np.einsum("tij,gj->tgi", reference.orientation.mean_rotations, points)
    turned = (scene.distance(placed) + limit[:, None]
              + 2.0 * np.sin(angle / 2.0)[:, None] * reach).min(axis=1)
    return np.minimum(anyhow, turned)


def end_bound(scene: Any, prior: Any, points: np.ndarray) -> float:
    """The sound upper bound [m] on the hand's clearance where a plan without a goal of its own
    must end: within the completion radius of the demonstrations' mean end, any rotation."""
    from clamp.prior.skill import SkillRegion
    region = SkillRegion.of(prior)
    return float(scene.distance(region.end_mean[None])[0] + region.completion_radius
                 + np.linalg.norm(points, axis=1).min())


def arm_witnesses(robot: Any, scene: Any, centre: np.ndarray, limit: np.ndarray, state: int,
                  count: int, rng: np.random.Generator) -> str:
    """"clear / solved" configurations of ``count`` hand points in the tube ball at ``state``."""
    from clamp.planning.clearance import state_clearance
    from robots.ik import damped_least_squares
    from robots.self_collision import self_collision_report
    direction = rng.normal(size=(4 * count, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    radius = (limit[state] - 1e-3) * rng.random(4 * count) ** (1.0 / 3.0)
    points = centre[state] + direction * radius[:, None]
    points = points[scene.distance(points) > 2e-3][:count]
    if not len(points):
        return "no room"
    seeds = np.array([robot.random_configuration(rng) for _ in range(len(points))])
    q, error = damped_least_squares(robot, points, seeds, 5e-4, 150)
    q = q[error < 5e-4]
    clear = q[state_clearance(robot, scene, q, 0.01)[0] >= 0.0] if len(q) else q
    own = (self_collision_report(robot, clear, max_motion=1e3).states_in_collision
           if len(clear) else np.zeros(0, bool))
    return f"{int((~own).sum())}/{len(q)}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--family", choices=("scene", "hard", "handwriting", "pose"),
                        default="hard")
    parser.add_argument("--arms", nargs="+", choices=("jaco", "sawyer"), default=["sawyer"])
    parser.add_argument("--problems", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", nargs="*", default=[], help="problem ids")
    parser.add_argument("--samples", type=int, default=200,
                        help="hand points per state for the arm's witnesses (0: none)")
    args = parser.parse_args(argv)
    from clamp.batch.problem_sets import BENCHMARK_SKILLS
    args.skills, args.start_offset, args.shapes = list(BENCHMARK_SKILLS), 0.08, None
    from scenes import Scene
    print_environment()
    for arm in args.arms:
        robot = fidelity._robot(arm)
        points = hand_points(robot)
        print(f"# {arm}: hand geometry {1000 * np.linalg.norm(points, axis=1).min():.1f}-"
              f"{1000 * np.linalg.norm(points, axis=1).max():.1f} mm from the end-effector point")
        blocked = clear = 0
        for data in fidelity.family_problems(args, arm):
            if data.get("meta", {}).get("start_blocked") or (args.only and data["id"] not in args.only):
                continue
            started = time.process_time()
            prior, _ = fidelity._skill_of(data["prior"])
            scene = Scene.from_dict(data["scene"])
            centre, limit, reference = tube(prior, robot, data["start"])
            bound = hand_bound(scene, prior, centre, limit, reference, points)
            worst = int(np.argmin(bound))
            end = end_bound(scene, prior, points)
            shut = min(float(bound[worst]), end) < -TOLERANCE
            clear += 1
            blocked += shut
            line = (f"{data['id']} hand: {'BLOCKED' if shut else 'open'}, room "
                    f"{1000 * bound[worst]:.1f} mm at state {worst}, {1000 * end:.1f} mm at "
                    "the skill's end")
            cut = np.flatnonzero(scene.distance(centre) < limit)
            if args.samples and len(cut):
                rng = np.random.default_rng(args.seed + 1)
                states = np.unique(np.linspace(cut[0], cut[-1], 8).round().astype(int))
                line += "; arm: " + " ".join(
                    f"{t}:{arm_witnesses(robot, scene, centre, limit, t, args.samples, rng)}"
                    for t in states)
            print(line + f" ({time.process_time() - started:.1f} s CPU)", flush=True)
        print(f"# {arm}: tube or end blocked for the hand (sound) on {blocked} of {clear} problems "
              "whose start is clear")
    return 0


if __name__ == "__main__":
    sys.exit(main())
