"""The stages of a plan (clamp.planning.pipeline): immutable records, plan() and replan() equal to the
stages run by hand, the model's graph inspectable before solving, bad input named."""
from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import (PlannerConfig, evaluate, make_request, model, plan, plan_model, posterior,
                   replan, solve)
from clamp.planning.reference import planning_prior
from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.planning.pipeline import Posterior
from clamp.planning.replanning import replan_start
from clamp.optim.solver import WarmStart
from scenes import Box, Scene

START = [0.2054, -0.4722, 0.2625]
BOX = Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])


def by_hand(prior, robot, scene, start, goal, config=None, covariance=True):
    """plan() as the caller would write it with the stages; returns (model, solution, result)."""
    started = time.perf_counter()
    request = make_request(prior, robot, start, goal, (), config)
    planned = model(prior, robot, scene, request, config)
    solution = solve(planned)
    belief = posterior(planned, solution, covariance)
    return planned, solution, evaluate(planned, solution, belief, started=started)


@pytest.fixture(scope="module")
def staged(prior, jaco):
    return by_hand(prior, jaco, Scene([BOX]), START, prior.mean[-1, :3])


def test_every_stage_record_is_immutable(prior, jaco, staged):
    planned, solution, _ = staged
    belief = posterior(planned, solution, covariance=False)
    for record, name in ((planned.request, "q_start"), (planned, "problem"),
                         (solution, "optimum"), (belief, "floor")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(record, name, None)
    assert belief == Posterior()      # not asked for: no covariance, no fault


def test_plan_equals_the_stages_run_by_hand(prior, jaco, staged):
    planned, solution, by_stages = staged
    result = plan(prior, jaco, Scene([BOX]), START, prior.mean[-1, :3])
    assert result.success and by_stages.success, (result.reasons, by_stages.reasons)
    assert result.reasons == by_stages.reasons
    np.testing.assert_allclose(np.hstack([by_stages.q, by_stages.qdot]),
                               np.hstack([result.q, result.qdot]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(by_stages.ee_covariance, result.ee_covariance, rtol=0,
                               atol=1e-12)
    assert by_stages.attempts == result.attempts and len(result.attempts) >= 1
    # the verdict made the whole result: what plan() used to patch on afterwards is there
    np.testing.assert_array_equal(by_stages.initial_q, planned.initialisation.q)
    assert by_stages.inputs.model_prior is planned.model_prior
    assert by_stages.inputs.extra_factors == () and by_stages.inputs.sdf is None
    assert {"build", "optimize", "marginals", "total"} <= set(result.timings)
    assert result.timings["total"] >= result.timings["optimize"] > 0.0
    # the solution's problem is the one judged: its error at the optimum is the final error
    assert solution.problem.error(solution.optimum.theta) == pytest.approx(result.final_error,
                                                                           rel=1e-9)


def test_the_model_graph_can_be_inspected_before_solving(prior, sawyer):
    request = make_request(prior, sawyer, START, prior.mean[-1, :3])
    planned = model(prior, sawyer, Scene([BOX]), request, None)
    problem = planned.problem
    graph_error = problem.graph().error(problem.values())
    assert graph_error == pytest.approx(problem.error(problem.initial), rel=1e-9)
    assert graph_error > 0.0
    # a random joint trajectory too (the graph is the problem's, not only at its start)
    theta = problem.initial + 0.01 * np.random.default_rng(1).standard_normal(
        problem.initial.shape)
    assert problem.graph().error(problem.values(theta)) == pytest.approx(
        problem.error(theta), rel=1e-9)


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_replan_equals_its_stages_run_by_hand(prior, arm, request):
    """tests/clamp/planning/test_replan.py's cases (moved goal, moved box, each with two configurations) replanned
    by replan() and by the public stages (the previous free plan given as replan gives it):
    the same plan to 1e-12, the same verdict."""
    robot = request.getfixturevalue(arm)
    goal = prior.mean[-1, :3]
    previous = plan(prior, robot, Scene([BOX]), START, goal, covariance=False)
    moved_goal, moved = goal + [0.0, 0.05, 0.0], Scene([BOX.translated([0.0, 0.05, 0.0])])
    inputs = previous.inputs
    for new_goal, scene, config in ((moved_goal, inputs.scene, None),
                                    (moved_goal, inputs.scene, PlannerConfig.fast()),
                                    (goal, moved, None), (goal, moved, PlannerConfig.fast())):
        result = (replan(previous, scene=scene, config=config, covariance=False)
                  if scene is moved else
                  replan(previous, goal=new_goal, config=config, covariance=False))
        config = config or inputs.config
        asked = make_request(prior, robot, inputs.start, new_goal, inputs.via_points, config,
                             q_start=previous.q[0])
        model_prior = (inputs.model_prior if new_goal is goal
                       else planning_prior(prior, robot, asked, config, inputs.model_prior))
        shift = model_prior.mean - inputs.model_prior.mean
        # the previous plan moved, and the previous free plan when only the scene moved, else
        # its moved guess (as replan gives them)
        start = replan_start(previous, robot, shift,
                             new_goal is goal and config.model == inputs.config.model)
        assert ("free" in start) == (new_goal is goal) != ("free_start" in start)
        planned = model(prior, robot, scene, asked, config, model_prior=model_prior, **start)
        solution = solve(planned, warm_start=WarmStart())
        staged = evaluate(planned, solution, posterior(planned, solution, False), {},
                          time.perf_counter())
        assert result.success and staged.success, (result.reasons, staged.reasons)
        assert result.reasons == staged.reasons
        np.testing.assert_allclose(staged.q, result.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(staged.qdot, result.qdot, rtol=0, atol=1e-12)
        assert result.inputs.scene is scene and result.inputs.model_prior is not None
        # a replanned result can be replanned: back to the first goal and box
        again = replan(result, goal=goal, scene=inputs.scene, covariance=False)
        assert again.success, again.reasons
        assert np.abs(again.ee_path - previous.ee_path).max() < 0.005


def test_the_solution_is_the_plan_model_of_plan(prior, jaco):
    """plan_model (the later stages) from a model equals plan() for the same request."""
    request = make_request(prior, jaco, START)
    planned = model(prior, jaco, None, request, None)
    result = plan_model(planned, covariance=False)
    fresh = plan(prior, jaco, None, START, covariance=False)
    np.testing.assert_allclose(result.q, fresh.q, rtol=0, atol=1e-12)
    assert result.success == fresh.success and result.reasons == fresh.reasons


@pytest.mark.parametrize("call, error, name", [
    (lambda p, r, m, s: model(p, r, None, "request", None), ClampTypeError, "request"),
    (lambda p, r, m, s: model(p, r, None, m.request, None, model_prior=object()), ShapeError,
     "model_prior"),
    (lambda p, r, m, s: model(p, r, None, m.request, None, free_start=np.zeros((3, 2 * r.n))),
     ShapeError, "free_start"),
    (lambda p, r, m, s: solve("model"), ClampTypeError, "model"),
    (lambda p, r, m, s: solve(m, warm_start=0.1), ClampTypeError, "warm_start"),
    (lambda p, r, m, s: posterior(m, "solution"), ClampTypeError, "solution"),
    (lambda p, r, m, s: posterior(m, s, covariance="yes"), InvalidParameterError, "covariance"),
    (lambda p, r, m, s: evaluate(m, s, None, {}, 0.0), ClampTypeError, "posterior"),
    (lambda p, r, m, s: evaluate(m, s, Posterior(), [], 0.0), ClampTypeError, "timings"),
    (lambda p, r, m, s: evaluate(m, s, Posterior(), None, "now"), InvalidParameterError,
     "started"),
])
def test_bad_stage_input_is_named(prior, jaco, staged, call, error, name):
    planned, solution, _ = staged
    with raises_naming(error, name):
        call(prior, jaco, planned, solution)


def test_a_request_for_another_robot_is_refused(prior, jaco, sawyer):
    request = make_request(prior, jaco, np.zeros(jaco.n))
    if sawyer.n == jaco.n:
        pytest.skip("both arms have the same number of joints")
    with raises_naming(ShapeError, "request"):
        model(prior, sawyer, None, request, None)
