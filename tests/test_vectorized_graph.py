"""VectorizedGraph: the planner graph's error and linearization computed per family in numpy
equal GTSAM's graph.error / graph.linearize (synthetic box_closing skill on the Jaco, with an
obstacle, a goal position, via-points and an extra factor that GTSAM keeps evaluating)."""
from __future__ import annotations


import gtsam
import numpy as np
import pytest

from clamp.keys import state_key
from clamp.learning import learn_prior
from clamp.levenberg_marquardt import chain_ordering
from clamp.planner import build
from clamp.vectorized_graph import VectorizedGraph


@pytest.fixture(scope="module")
def problem(jaco):
    from scenes import Box, Scene, make_demonstrations
    robot = jaco
    demos = make_demonstrations("box_closing", num_demos=5, num_points=40, seed=2)
    prior = learn_prior(demos)
    start = demos.positions[:, 0].mean(axis=0)
    goal = demos.positions[:, -1].mean(axis=0)
    scene = Scene([Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])])
    extra = gtsam.PriorFactorVector(state_key(3), np.zeros(2 * robot.n),
                                    gtsam.noiseModel.Isotropic.Sigma(2 * robot.n, 10.0))
    return build(prior, robot, scene, start, goal=goal, via_points=[(10, goal + 0.02)],
                 extra_factors=[extra])


def perturbed(problem, seed: int, scale: float) -> gtsam.Values:
    """Initial values with every state moved by N(0, scale^2) (puts spheres into the box and
    joints past their limits, so the hinges are active somewhere)."""
    rng = np.random.default_rng(seed)
    values = gtsam.Values()
    for key in problem.evaluator.keys:
        theta = problem.initial.atVector(key)
        values.insert(key, theta + scale * rng.normal(size=theta.shape))
    return values


def test_splits_families_from_other_factors(problem):
    system = VectorizedGraph(problem.graph, problem.evaluator)
    linear_or_extra = len(problem.families["joint_gp"]) + len(problem.families["extra"]) + 1
    assert system.rest.size() == linear_or_extra  # + the joint start factor (linear)
    assert system.num_vectorized + system.rest.size() == problem.graph.size()


@pytest.mark.parametrize("seed, scale", [(0, 0.0), (1, 0.05), (2, 0.5)])
def test_error_equals_graph_error(problem, seed, scale):
    system = VectorizedGraph(problem.graph, problem.evaluator)
    values = perturbed(problem, seed, scale)
    assert system.error(values) == pytest.approx(problem.graph.error(values), rel=1e-12)
    family = system.family_error(values)
    vectorized = sum(problem.graph.at(i).error(values)
                     for name in ("workspace_gp", "workspace_start", "obstacle", "joint_limits")
                     for i in problem.families[name])
    assert family > vectorized  # + the end-effector goal and via-point factors
    assert family < system.error(values)


@pytest.mark.parametrize("seed, scale", [(3, 0.05), (4, 0.5)])
def test_linearization_equals_graph_linearize(problem, seed, scale):
    system = VectorizedGraph(problem.graph, problem.evaluator)
    values = perturbed(problem, seed, scale)
    ours = system.linearize(values)
    reference = problem.graph.linearize(values)
    assert ours.size() < reference.size()  # rows of each consecutive pair stacked
    ordering = chain_ordering(problem.evaluator.keys)
    expected = reference.augmentedHessian(ordering)
    np.testing.assert_allclose(ours.augmentedHessian(ordering), expected,
                               rtol=0.0, atol=1e-12 * np.max(np.abs(expected)))
    rng = np.random.default_rng(seed)
    delta = gtsam.VectorValues()
    for key in problem.evaluator.keys:
        delta.insert(key, 0.01 * rng.normal(size=values.atVector(key).shape))
    assert ours.error(delta) == pytest.approx(reference.error(delta), rel=1e-10)


def test_repeated_and_partial_factors_fall_back_correctly(problem):
    """A graph holding a family factor twice and missing others still matches GTSAM."""
    graph = gtsam.NonlinearFactorGraph()
    obstacle = problem.families["obstacle"]
    for i in obstacle[::3] + obstacle[:2] + problem.families["workspace_gp"][5:9]:
        graph.add(problem.graph.at(i))
    system = VectorizedGraph(graph, problem.evaluator)
    values = perturbed(problem, 5, 0.3)
    assert system.rest.size() == 0
    assert system.error(values) == pytest.approx(graph.error(values), rel=1e-12)
    ordering = chain_ordering(problem.evaluator.keys)
    expected = graph.linearize(values).augmentedHessian(ordering)
    np.testing.assert_allclose(system.linearize(values).augmentedHessian(ordering), expected,
                               rtol=0.0, atol=1e-12 * np.max(np.abs(expected)))


def test_error_below_is_exact_below_the_bound_and_at_least_the_bound_above(problem):
    system = VectorizedGraph(problem.graph, problem.evaluator)
    values = perturbed(problem, 6, 0.2)
    exact = problem.graph.error(values)
    assert system.error_below(values, 2.0 * exact) == pytest.approx(exact, rel=1e-12)
    for bound in (1e-3 * exact, 0.5 * exact):
        assert bound <= system.error_below(values, bound) <= exact * (1 + 1e-12)
    costs = [getattr(block.family, "cost", 1) for block, _, _ in system.parts]
    assert costs == sorted(costs)  # joint limits (no kinematics) first, obstacles last


def dense_from_band(band: np.ndarray) -> np.ndarray:
    """Symmetric matrix (N, N) of LAPACK lower band storage (w + 1, N)."""
    N = band.shape[1]
    H = np.zeros((N, N))
    for u in range(band.shape[0]):
        H += np.diag(band[u, :N - u], -u)
    return H + np.tril(H, -1).T


@pytest.mark.parametrize("seed, scale", [(5, 0.05), (6, 0.5)])
def test_normal_equations_equal_the_linearization(problem, seed, scale):
    evaluator = problem.evaluator
    graph = gtsam.NonlinearFactorGraph()  # the problem without its nonlinear extra factor
    extra = set(problem.families["extra"])
    for i in range(problem.graph.size()):
        if i not in extra:
            graph.add(problem.graph.at(i))
    system = VectorizedGraph(graph, evaluator)
    values = perturbed(problem, seed, scale)
    band, gradient = system.normal_equations(values)
    d = 2 * evaluator.robot.n
    assert band.shape == (2 * d, evaluator.num_states * d)
    augmented = graph.linearize(values).augmentedHessian(chain_ordering(evaluator.keys))
    H, g = augmented[:-1, :-1], augmented[:-1, -1]
    np.testing.assert_allclose(dense_from_band(band), H, rtol=0.0, atol=1e-12 * np.abs(H).max())
    np.testing.assert_allclose(gradient, g, rtol=0.0, atol=1e-12 * np.abs(g).max())


def test_normal_equations_refuse_nonlinear_other_factors(problem):
    system = VectorizedGraph(problem.graph, problem.evaluator)  # has a PriorFactorVector
    assert system.normal_equations(perturbed(problem, 7, 0.05)) is None
    assert system.keys == problem.evaluator.keys
