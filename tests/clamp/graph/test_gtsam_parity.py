"""The GTSAM face of a planning problem against the fast solver, at the level of optima:

- the fast solver's optimum on box_closing (empty and with the box) is an optimum of GTSAM's
  own optimizers on ``problem.graph()``: started there, they find no lower error (1e-6
  relative) and do not move the end effector (1 mm);
- run to convergence, GTSAM's Levenberg-Marquardt (optimizer="gtsam") ends there too (a small
  problem);
- a caller's own GTSAM CustomFactor is honoured by the fast solver and by GTSAM's optimizers;
- GTSAM's Marginals on the graph equal the plan's posterior covariances.

(Per-factor and whole-graph error / linearization equality at random points are in
tests/clamp/factors/test_families.py.)
"""
from __future__ import annotations

import gtsam
import numpy as np
import pytest

from clamp import PlannerConfig, build, learn_prior, optimize, plan
from clamp.graph.keys import state_key, values_to_states
from clamp.optim.stopping import StoppingRule
from tests.regression.cases import REFERENCE_BOX, REFERENCE_START
from tests.clamp.factors.test_families import user_factor

TIGHT = PlannerConfig().with_(stopping=StoppingRule(relative_tol=1e-10, absolute_tol=1e-10,
                                                   patience=10), max_iterations=5000)


@pytest.fixture(scope="module")
def box_closing_prior():
    from scenes import load_demonstrations
    from tests.conftest import dataset_path
    path = dataset_path("box_closing")
    if path is None:
        pytest.skip("box_closing.mat not found in ../shared/datasets (set SKILLPLAN_DATASETS)")
    return learn_prior(load_demonstrations(path))


@pytest.mark.parametrize("with_box", [False, True])
def test_fast_optimum_is_an_optimum_of_gtsams_optimizers(jaco, box_closing_prior, with_box):
    from scenes import Box, Scene
    scene = Scene([Box.from_reference(REFERENCE_BOX)]) if with_box else None
    problem = build(box_closing_prior, jaco, scene, REFERENCE_START, config=TIGHT)
    fast = optimize(problem, TIGHT)
    graph, values = problem.graph(), problem.values(fast.theta)
    assert graph.error(values) == pytest.approx(fast.final_error, rel=1e-9)
    for make, params in ((gtsam.LevenbergMarquardtOptimizer, gtsam.LevenbergMarquardtParams()),
                         (gtsam.DoglegOptimizer, gtsam.DoglegParams())):
        params.setLinearSolverType("MULTIFRONTAL_QR")
        params.setMaxIterations(20)
        params.setRelativeErrorTol(1e-12)
        params.setAbsoluteErrorTol(1e-12)
        optimizer = make(graph, values, params)
        optimizer.optimize()
        assert optimizer.error() >= fast.final_error * (1 - 1e-6)
        theta = values_to_states(optimizer.values(), problem.keys)
        moved = np.linalg.norm(jaco.fk(theta[:, :jaco.n]) - jaco.fk(fast.theta[:, :jaco.n]), axis=1)
        assert moved.max() <= 1e-3


@pytest.fixture(scope="module")
def soft_prior():
    from scenes import make_demonstrations
    demos = make_demonstrations("box_closing", num_demos=6, num_points=60, dt=0.16 * 250 / 60,
                                seed=3)
    return learn_prior(demos, jitter=1e-4)


def test_gtsam_levenberg_marquardt_converges_to_the_fast_optimum(jaco, soft_prior):
    """Run to convergence from the initial trajectory, optimizer="gtsam" (GTSAM's own LM with
    clamp.optim.optimizers' settings) ends at the fast solver's optimum: the same error (1e-6
    relative) and end-effector path (1 mm). A small problem: on box_closing it takes GTSAM's
    LM ~2700 iterations (benchmarks/bench_gtsam_parity.py)."""
    problem = build(soft_prior, jaco, None, soft_prior.mean[0, :3], config=TIGHT)
    fast = optimize(problem, TIGHT)
    out = optimize(problem, TIGHT.with_(optimizer="gtsam", max_iterations=1000,
                                        stopping=StoppingRule(relative_tol=1e-12,
                                                              absolute_tol=1e-12, patience=10)))
    assert out.optimizer == "gtsam" and out.stop_reason == "converged"
    assert out.final_error == pytest.approx(fast.final_error, rel=1e-6)
    moved = np.linalg.norm(jaco.fk(out.theta[:, :jaco.n]) - jaco.fk(fast.theta[:, :jaco.n]), axis=1)
    assert moved.max() <= 1e-3


@pytest.mark.parametrize("case", ["empty", "box"])
def test_gtsam_levenberg_marquardt_reaches_the_fast_plan(jaco, soft_prior, case):
    """GTSAM's Levenberg-Marquardt with the planner's parameters (clamp.optim.optimizers.
    gtsam_params: the fast solver's tolerances, adaptive lambda, QR), run by hand on the final
    problem's graph from its own initial values (the fast solver's start), ends within 1 mm of
    the plan's end-effector path (benchmarks/bench_gtsam_parity.py, Table 0, for box_closing)."""
    from clamp.optim.optimizers import gtsam_params
    from scenes import Box, Scene
    start = soft_prior.mean[0, :3]
    scene = (Scene([Box(soft_prior.mean[30, :3] + [0, 0, -0.04], [0.06] * 3)])
             if case == "box" else None)
    result = plan(soft_prior, jaco, scene, start, covariance=False)
    assert result.success, result.reasons
    problem = result.problem
    params, make = gtsam_params(PlannerConfig().with_(optimizer="gtsam"))
    assert make is gtsam.LevenbergMarquardtOptimizer
    optimizer = make(problem.graph(), problem.values(), params)
    theta = values_to_states(optimizer.optimize(), problem.keys)
    gap = np.linalg.norm(jaco.fk(theta[:, :jaco.n]) - result.ee_path, axis=1).max()
    assert gap <= 1e-3
    # the same through clamp.optimize
    out = optimize(problem, PlannerConfig().with_(optimizer="gtsam"))
    np.testing.assert_allclose(out.theta, theta, atol=1e-9)


@pytest.mark.parametrize("optimizer", ["fast", "gtsam", "gtsam_dogleg"])
def test_user_custom_factor_is_honoured_by_every_optimizer(jaco, soft_prior, optimizer):
    start = soft_prior.mean[0, :3]
    free = plan(soft_prior, jaco, None, start, covariance=False)
    height = float(free.ee_path[30, 2]) + 0.02                 # 2 cm above the free plan
    result = plan(soft_prior, jaco, None, start, extra_factors=[user_factor(jaco, 30, height, sigma=1e-4)],
                  config=PlannerConfig().with_(optimizer=optimizer, max_iterations=200),
                  covariance=False)
    assert result.optimizer == optimizer
    assert result.ee_path[30, 2] >= height - 2e-3
    assert "foreign" in result.family_errors


@pytest.mark.parametrize("case", ["box", "joint_goal"])
def test_posterior_covariance_equals_gtsam_marginals(jaco, soft_prior, case):
    """On graphs that constrain every direction (GTSAM's Marginals refuse the others, see
    test_unconstrained_direction_gets_the_information_floor)."""
    from scenes import Box, Scene
    start = soft_prior.mean[0, :3]
    scene = goal = None
    if case == "box":
        scene = Scene([Box(soft_prior.mean[30, :3] + [0, 0, -0.04], [0.06] * 3)])
    else:
        goal = plan(soft_prior, jaco, None, start, covariance=False).q[-1] + 0.01
    result = plan(soft_prior, jaco, scene, start, goal=goal)
    assert result.covariance_floor == 0.0
    problem = build(soft_prior, jaco, scene, start, goal=goal)
    theta = np.concatenate([result.q, result.qdot], axis=1)
    marginals = gtsam.Marginals(problem.graph(), problem.values(theta))
    for i in (0, 1, 17, 30, len(theta) - 1):
        expected = marginals.marginalCovariance(state_key(i))
        np.testing.assert_allclose(result.state_covariance[i], expected, rtol=1e-6,
                                   atol=1e-6 * np.abs(expected).max())
    # the end-effector covariance is the joint covariance seen through the position Jacobian
    J = jaco.ee_kinematics(result.q, result.qdot).jacobian
    q_cov = result.state_covariance[:, :jaco.n, :jaco.n]
    expected = np.einsum("tij,tjk,tlk->til", J, q_cov, J)
    np.testing.assert_allclose(result.ee_covariance, expected, rtol=1e-6,
                               atol=1e-9 * np.abs(expected).max())


def test_unconstrained_direction_gets_the_information_floor(jaco, soft_prior):
    """The Jaco's continuous wrist can spin at any constant speed at no cost in an empty scene
    without a joint goal: GTSAM calls the graph underconstrained; the plan reports the floor."""
    from clamp.optim.uncertainty import INFORMATION_FLOOR
    start = soft_prior.mean[0, :3]
    result = plan(soft_prior, jaco, None, start)
    problem = build(soft_prior, jaco, None, start)
    theta = np.concatenate([result.q, result.qdot], axis=1)
    with pytest.raises(RuntimeError, match="nderconstrained|ndeterminate"):
        gtsam.Marginals(problem.graph(), problem.values(theta))
    assert result.covariance_floor == INFORMATION_FLOOR
    assert np.all(np.isfinite(result.ee_covariance))
    assert np.all(np.linalg.eigvalsh(result.ee_covariance) > -1e-15)
