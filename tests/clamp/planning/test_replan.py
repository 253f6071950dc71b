"""Replanning from a previous plan (clamp.replan): same checks as a fresh plan, warm start."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import PlannerConfig, build, errors, plan, replan
from clamp.planning.result import PlanResult
from clamp.optim.solver import WarmStart, levenberg_marquardt
from clamp.planning.clearance import check_clearance
from robots.self_collision import self_collision_report
from scenes import Box, Scene

START = [0.2054, -0.4722, 0.2625]
BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_replan_after_goal_and_obstacle_moves(prior, arm, request):
    robot = request.getfixturevalue(arm)
    goal = prior.mean[-1, :3]
    previous = plan(prior, robot, Scene([BOX]), START, goal, covariance=False)
    assert previous.success, previous.reasons
    moved_goal = goal + [0.0, 0.05, 0.0]
    for config in (None, PlannerConfig.fast()):
        result = replan(previous, goal=moved_goal, config=config, covariance=False)
        assert result.success, result.reasons
        assert np.linalg.norm(robot.fk(result.q[-1]) - moved_goal) < 0.002
        np.testing.assert_allclose(result.q[0], previous.q[0], atol=1e-8)   # same start
        fresh = plan(prior, robot, Scene([BOX]), START, moved_goal, covariance=False)
        assert np.abs(result.ee_path - fresh.ee_path).max() < 0.005     # the same motion
    moved = Scene([BOX.translated([0.0, 0.05, 0.0])])
    result = replan(previous, scene=moved, covariance=False)
    assert result.success and result.min_clearance > 0.0, result.reasons
    assert result.inputs.scene is moved and result.inputs.goal is goal
    assert result.goal_error < 0.002
    fresh = plan(prior, robot, moved, START, goal, covariance=False)
    assert np.abs(result.ee_path - fresh.ee_path).max() < 0.005
    # the arm's posture too: both are tied to the free plan's posture, so the replan holds the
    # fresh plan's (not the old box's) and is as good as a fresh plan (to the warm-start
    # rule's 0.1 nats, or 1 %)
    assert np.abs(result.q - fresh.q).max() < 0.05
    assert result.final_error <= fresh.final_error + max(0.1, 0.01 * fresh.final_error)


def test_replan_after_a_10cm_goal_move_is_as_good_as_a_fresh_plan(prior, jaco):
    """The new free plan is solved from the previous one moved to the new goal, to the
    configured tolerances: the replan ends on the fresh plan's path, at its error (a free plan
    stopped by the warm-start rule left the Jaco's wrist 1.3 rad away, 0.14 nats higher), and
    its verdict agrees with an independent check of its trajectory on the real geometry."""
    goal = prior.mean[-1, :3]
    previous = plan(prior, jaco, Scene([BOX]), START, goal, covariance=False)
    moved_goal = goal + [0.0, 0.1, 0.0]
    result = replan(previous, goal=moved_goal, covariance=False)
    fresh = plan(prior, jaco, Scene([BOX]), START, moved_goal, covariance=False)
    assert result.success and fresh.success, (result.reasons, fresh.reasons)
    assert np.abs(result.ee_path - fresh.ee_path).max() < 0.002
    assert result.final_error <= fresh.final_error + max(0.1, 0.01 * fresh.final_error)
    report = check_clearance(jaco, Scene([BOX]), result.q, result.time)
    assert not report.collision and report.min_distance == pytest.approx(result.min_clearance,
                                                                         abs=1e-9)
    assert self_collision_report(jaco, result.q).min_distance > 0.0


def test_the_free_plan_is_reused_only_for_the_same_free_problem(prior, jaco):
    """A moved box with another solver setting (PlannerConfig.fast()) keeps the previous free
    plan (the same free problem); a moved goal solves a new one from the previous one moved,
    and where the previous plan was its free plan the replan is the new free plan (the tied
    solve starts at it: no step)."""
    goal = prior.mean[-1, :3]
    previous = plan(prior, jaco, Scene([BOX]), START, goal, covariance=False)
    assert np.abs(previous.q - previous.inputs.free_plan[:, :jaco.n]).max() < 1e-6
    moved = Scene([BOX.translated([0.0, 0.05, 0.0])])
    boxed = replan(previous, scene=moved, config=PlannerConfig.fast(), covariance=False)
    assert boxed.success, boxed.reasons
    assert boxed.inputs.free_plan is previous.inputs.free_plan
    other = replan(previous, scene=moved, config=PlannerConfig().with_(posture_sigma=0.5),
                   covariance=False)                   # another free problem: solved again
    assert other.inputs.free_plan is not previous.inputs.free_plan
    moved_goal = goal + [0.0, 0.05, 0.0]
    result = replan(previous, goal=moved_goal, covariance=False)
    fresh = plan(prior, jaco, Scene([BOX]), START, moved_goal, covariance=False)
    assert result.success and result.iterations == 0, (result.reasons, result.iterations)
    np.testing.assert_allclose(np.hstack([result.q, result.qdot]), result.inputs.free_plan,
                               rtol=0, atol=1e-6)
    assert np.abs(result.inputs.free_plan - fresh.inputs.free_plan)[:, :jaco.n].max() < 0.1
    assert np.abs(result.ee_path - fresh.ee_path).max() < 0.002


def test_warm_start_rule_stops_at_an_optimum_and_near_one(prior, jaco):
    """From the cold solver's optimum the warm-start rule takes no step (the linear model
    predicts less than its tolerance); from a perturbed optimum it ends within a few times the
    tolerance [nats] of the cold optimum, in fewer iterations than the cold rule."""
    problem = build(prior, jaco, Scene([BOX]), START, prior.mean[-1, :3])
    cold = levenberg_marquardt(problem, problem.initial)
    assert cold.stop_reason == "converged"
    warm = WarmStart()
    again = levenberg_marquardt(problem, cold.theta, warm_start=warm)
    assert (again.iterations, again.stop_reason) == (0, "converged")
    np.testing.assert_array_equal(again.theta, cold.theta)
    assert again.final_error == again.initial_error == pytest.approx(cold.final_error)
    rng = np.random.default_rng(0)
    n = jaco.n
    nudged = cold.theta + np.hstack([0.02 * rng.standard_normal((len(cold.theta), n)),
                                     np.zeros((len(cold.theta), n))])
    from_nudged = levenberg_marquardt(problem, nudged, warm_start=warm)
    slow = levenberg_marquardt(problem, nudged)
    assert from_nudged.initial_error > cold.final_error + 10 * warm.tolerance
    assert from_nudged.final_error < cold.final_error + 3 * warm.tolerance
    assert from_nudged.iterations <= slow.iterations


def test_replan_needs_a_planned_result(prior, jaco):
    blank = PlanResult(**{k: v for k, v in vars(plan(prior, jaco, None, START,
                                                     covariance=False)).items()
                          if k not in ("inputs", "problem")})
    with raises_naming(errors.InvalidParameterError, "previous"):
        replan(blank, goal=prior.mean[-1, :3])
