"""Plans judged on the real collision geometry and collision-free as a constraint (issue 9):
clamp.planning.clearance (the verdict's check) and clamp.optim.constrained (the constrained solve).

Collision-freeness is checked independently of the planner's own search: coal on every
link-obstacle pair (CollisionChecker.distances, brute force) at the support states and at four
configurations per segment."""
from __future__ import annotations

import numpy as np
import pytest

from clamp import PlannerConfig, build, learn_prior, plan
from clamp.factors.joint_limits import VELOCITY_TOLERANCE
from clamp.planning.clearance import check_clearance, checker
from clamp.planning.verdict import sphere_clearance
from robots import Robot
from robots.collision_check import CollisionChecker
from robots.registry import example_robot_data_share
from scenes import Box, Scene, make_demonstrations
from scenes.coal_shapes import coal_obstacles

# the probe of issue 9: the fingertip mesh reaches into the box the collision spheres clear
PROBE_Q = np.array([0.8342, 2.7134, 4.9144, 0.894, 2.2859, 0.0])
PROBE_BOX = Box([0.2271, -0.3773, 0.1763], [0.04, 0.04, 0.04])
README_BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])
START = np.array([0.2054, -0.4722, 0.2625])


def brute_force_clearance(robot, scene, q: np.ndarray, per_segment: int = 2) -> float:
    """Least coal distance over every link-obstacle pair at the states of q (T, n) and at
    per_segment - 1 configurations inside every segment."""
    s = np.linspace(0.0, 1.0, per_segment + 1)[:-1]
    dense = np.concatenate([(1 - a) * q[:-1] + a * q[1:] for a in s] + [q[-1:]], axis=0)
    return float(CollisionChecker(robot, coal_obstacles(scene)).distances(dense).min())


# ----------------------------------------------------------------------------- the verdict
def test_probe_fails_naming_the_fingertip_and_the_box(jaco, prior):
    scene = Scene([PROBE_BOX])
    assert sphere_clearance(jaco, scene, PROBE_Q[None]).min() > 0.005     # the spheres clear it
    result = plan(prior, jaco, scene, start=PROBE_Q, covariance=False)
    assert not result.success and result.stop_reason == "not started"
    reason = " ".join(result.reasons)
    assert "finger_tip" in reason and "box_0" in reason and "mm inside" in reason, reason


def test_verdict_measures_the_urdf_geometry_at_and_between_states(jaco, prior):
    scene = Scene([README_BOX])
    result = plan(prior, jaco, scene, start=START, covariance=False)
    assert result.success, result.reasons
    assert result.collision_geometry == "urdf"
    contact = result.nearest_contact
    assert contact["obstacle"] == "box_0" and contact["link"] in checker(jaco, scene).link_names
    assert contact["distance"] == result.min_clearance > 0.0
    # the least distance over support states and in-between configurations: not above the
    # support states' own (brute force) and not below a denser brute-force sampling by more
    # than what a link point can move between the verdict's checks (5 mm)
    at_states = float(CollisionChecker(jaco, coal_obstacles(scene)).distances(result.q).min())
    assert result.min_clearance <= at_states + 1e-9
    assert result.min_clearance >= brute_force_clearance(jaco, scene, result.q, 2) - 0.005
    verdict = result.verdict()
    assert verdict["collision_geometry"] == "urdf" and verdict["nearest_contact"] == contact
    assert check_clearance(jaco, scene, result.q) is not None
    assert checker(jaco, scene) is checker(jaco, scene)                     # built once
    assert check_clearance(jaco, Scene(), result.q) is None


def test_robot_without_collision_geometry_says_the_verdict_used_spheres(jaco, prior):
    bare = Robot(jaco.model, jaco.end_effector, spheres=jaco.spheres, base_frame=jaco.base_frame)
    result = plan(prior, bare, Scene([README_BOX]), start=START, covariance=False)
    assert result.collision_geometry == "spheres"
    assert "#" in result.nearest_contact["geometry"]
    assert result.min_clearance == pytest.approx(
        sphere_clearance(bare, Scene([README_BOX]), result.q).min(), abs=0.003)


# ------------------------------------------------------------------ constraint, not weight
def box_in_the_path(prior, robot, side: float = 0.05) -> Scene:
    """A cube centred on the empty-scene plan's end-effector path, half way along it."""
    empty = plan(prior, robot, None, start=prior.mean[0, :3], covariance=False)
    assert empty.success, empty.reasons
    scene = Scene([Box(empty.ee_path[len(empty.ee_path) // 2], [side] * 3)])
    assert brute_force_clearance(robot, scene, empty.q) < 0.0
    return scene


def test_a_weak_weight_still_gives_a_collision_free_plan(jaco, prior):
    # ten times the reference's weight, a hundred times the default's: one update more than the
    # default's two to stiffen the hinges enough
    weak = PlannerConfig().with_(sigma_obs=0.5, constraint_rounds=3)
    scene = box_in_the_path(prior, jaco)
    START = prior.mean[0, :3]
    given_up = plan(prior, jaco, scene, start=START, covariance=False,
                    config=weak.with_(constraint_rounds=0))
    # the weighted optimum collides: reported as such, never as converged
    assert brute_force_clearance(jaco, scene, given_up.q) < 0.0
    assert not given_up.success and given_up.stop_reason == "infeasible"
    assert given_up.min_clearance < 0.0
    contact = given_up.nearest_contact
    reason = next(r for r in given_up.reasons if r.startswith("collision"))
    assert contact["link"] in reason and "box_0" in reason and "mm inside" in reason
    assert f"{-contact['distance'] * 1e3:.1f} mm" in reason and "state" in reason

    result = plan(prior, jaco, scene, start=START, covariance=False, config=weak)
    assert result.success, result.reasons
    assert brute_force_clearance(jaco, scene, result.q) > 0.0
    feasible = [a for a in result.attempts if a["feasible"]]
    chosen = min(feasible, key=lambda a: a["prior_cost"])
    assert result.min_clearance == pytest.approx(chosen["min_distance"])
    assert result.iterations == sum(a["iterations"] for a in result.attempts)
    # the final error is the solved problem's (stiffer, shifted hinges): its GTSAM graph at the
    # plan is the one the solver finished on, and GTSAM's own Levenberg-Marquardt started
    # there finds nothing lower (to the solver's tolerance)
    import gtsam
    theta = np.hstack([result.q, result.qdot])
    solved = result.problem
    assert solved.family("obstacle").shift is not None
    assert 1.0 / solved.family("obstacle").whitening[0] < 0.5
    assert result.final_error == pytest.approx(
        solved.graph().error(solved.values(theta)), rel=1e-9)
    again = gtsam.LevenbergMarquardtOptimizer(solved.graph(), solved.values(theta)).optimize()
    assert solved.graph().error(again) >= result.final_error - max(0.1, 1e-3 * result.final_error)
    # the initial error is that of the problem as asked at its initial trajectory
    problem = build(prior, jaco, scene, START, config=weak)
    assert result.initial_error == pytest.approx(problem.error(problem.initial), rel=1e-9)
    assert result.initial_error == pytest.approx(given_up.initial_error, rel=1e-9)


def test_goal_inside_an_obstacle_fails_with_reasons_never_converged(jaco, prior):
    start = prior.mean[0, :3]
    goal = plan(prior, jaco, None, start=start, covariance=False).ee_path[-1]
    result = plan(prior, jaco, Scene([Box(goal, [0.06] * 3)]), start=start, goal=goal,
                  covariance=False)
    assert not result.success and result.stop_reason != "converged"
    depth = 1000 * (0.03 - 0.0)                       # the goal sits at the box's centre
    assert any(r.startswith("goal position") and f"inside an obstacle ({depth:.1f} mm deep)" in r
               for r in result.reasons), result.reasons


def test_first_feasible_solve_is_kept_alone(jaco, prior):
    result = plan(prior, jaco, Scene([README_BOX]), start=START, covariance=False)
    assert result.success, result.reasons
    assert result.search["work"] == result.search["unit"]      # the first solve was all the work
    assert result.stop_reason == "converged"


# ----------------------------------------------------------------------- long trajectories
def test_long_trajectory_is_collision_free_or_says_why(jaco):
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0)
                        .resample(1000))
    scene = box_in_the_path(prior, jaco)
    result = plan(prior, jaco, scene, start=prior.mean[0, :3], covariance=False)
    clearance = brute_force_clearance(jaco, scene, result.q, 1)
    print(f"\nT = 1000: success {result.success}, {result.stop_reason}, brute-force clearance "
          f"{clearance * 1e3:.1f} mm, attempts {[a['candidate'] for a in result.attempts]}")
    if result.success:
        assert clearance > 0.0
    else:
        assert result.stop_reason != "converged" or clearance > 0.0
        assert result.reasons
    assert not (result.stop_reason == "converged" and clearance < 0.0)


def test_a_motion_too_long_to_check_is_a_failed_check_not_an_error(jaco, prior):
    """A trajectory whose links travel kilometres (a diverged solve spinning a continuous joint
    hundreds of turns: hard/jaco/0006 of the fidelity benchmark raised out of plan()) needs
    more subdivisions than the checker makes: the clearance check reports it as failed, with
    the checker's reason, a collision (never clear), instead of raising."""
    scene = box_in_the_path(prior, jaco)
    q = np.zeros((5, jaco.n))
    q[:, 0] = np.linspace(0.0, 3000.0, len(q))          # rad: ~480 turns of the base
    report = check_clearance(jaco, scene, q)
    assert report.collision and report.fault and "could not be checked" in report.fault
    assert "configurations" in report.fault and np.isnan(report.min_distance)


# ------------------------------------------------------------------------ third-party arms
def test_third_party_arm_avoids_a_box_in_the_skill_path(prior):
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "panda_description" / "urdf" / "panda.urdf"
    robot = Robot.from_urdf(urdf, end_effector="panda_hand", package_dirs=[share])
    # a 3 cm cube: around a 5 cm one the Panda's wide hand leaves the skill by 4.4 of the
    # demonstrations' spreads there (the skill check of issue 19 fails it)
    scene = box_in_the_path(prior, robot, side=0.03)
    result = plan(prior, robot, scene, start=prior.mean[0, :3], covariance=False)
    assert result.success, result.reasons
    assert result.collision_geometry == "urdf"
    assert brute_force_clearance(robot, scene, result.q) > 0.0


def test_a_velocity_excess_is_a_question_of_time(jaco):
    """two_target_press with a 6 cm cube on its mean path at 50 %: the weighted solve ends a
    little beyond a velocity limit (the hinge is soft). A velocity is never a constraint the
    solve repairs (issue 36): at the caller's time scale 1 the verdict names the joint, however
    many rounds the solve may run; at the automatic scale the time stage slows the skill before
    the path solve and the plan holds every velocity limit, measured here from the plan's own
    velocities and the finite differences of its positions."""
    prior = learn_prior(make_demonstrations("two_target_press", num_demos=6, num_points=250,
                                            seed=0))
    mean = np.asarray(prior.mean)[:, :3]
    # the configured weight solved directly (no soft start and no posture tie, either of which
    # avoids the excess, at a 5 cm safety distance and 5 mm hinge noise)
    kwargs = {"prior": prior, "robot": jaco, "start": mean[0],
              "scene": Scene([Box(mean[int(round(0.5 * (len(mean) - 1)))], [0.06] * 3)]),
              "config": PlannerConfig(posture_sigma=0.0, epsilon=0.05, sigma_obs=0.005)}
    at_one = plan(**kwargs, covariance=False, time_scale=1.0)
    assert not at_one.success
    assert any("faster than its limit" in r for r in at_one.reasons), at_one.reasons
    timed = plan(**kwargs, covariance=False)
    assert timed.success, timed.reasons
    assert timed.time_scale > 1.0
    vmax = np.asarray(jaco.velocity_limits)
    tolerance = VELOCITY_TOLERANCE
    assert (np.abs(timed.qdot) - vmax).max() <= tolerance
    step = np.abs(np.diff(timed.q, axis=0)) / np.diff(timed.time)[:, None]
    assert (step - vmax).max() <= tolerance


def test_soft_start_ends_at_an_optimum_of_the_configured_problem(prior, jaco):
    """The soft start (a first solve with 4x softer obstacle hinges) only chooses where the
    solve at the configured weight starts: the plan's error is the configured problem's at the
    plan, the cold solver started from the plan finds nothing better (to its tolerance), and
    the configured attempt reports the iterations of both stages."""
    from clamp.optim.solver import levenberg_marquardt
    scene = Scene([README_BOX])
    soft = plan(prior, jaco, scene, START, covariance=False)
    direct = plan(prior, jaco, scene, START, covariance=False,
                  config=PlannerConfig(constraint_rounds=0))
    assert soft.success
    problem = build(prior, jaco, scene, START)
    theta = np.hstack([soft.q, soft.qdot])
    assert soft.final_error == pytest.approx(problem.error(theta), rel=1e-9)
    assert soft.initial_error == pytest.approx(direct.initial_error, rel=1e-9)
    again = levenberg_marquardt(problem, theta)
    assert again.final_error >= soft.final_error - max(0.1, 1e-3 * soft.final_error)
    assert soft.attempts[0]["iterations"] == soft.iterations
