"""The table-plane constraint family (clamp.factors.table_plane), on both arms:

- analytic Jacobians against central finite differences at random points (every hinge shifted
  too, so the shifted kernel is covered);
- the GTSAM adapters (``problem.graph()``) against the fast kernel: error and whitened
  linearization per factor (as tests/clamp/factors/test_families.py does for every family);
- a plan whose free path dips below the plane ends above it, with success: measured here on
  the spheres' world centres from Pinocchio's own frame placements, at every support state and
  densely in between, independently of the planner's vectorized sphere kinematics;
- the family made from its height alone joins ``plan(extra_factors=[...])`` and its check is the
  verdict's (a reason and ``violations["table_plane"]`` when it is broken).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bad_input import raises_naming
from clamp import PlannerConfig, learn_prior, plan
from clamp.factors import StateWindow
from clamp.factors.table_plane import TablePlaneFamily
from clamp.graph.problem import PlanningProblem
from scenes import make_demonstrations
from tests.clamp.factors.test_families import (assert_jacobians_match_finite_differences, dense_residual,
                                 random_theta)

T = 6


def family_at(robot, theta: np.ndarray, rng) -> TablePlaneFamily:
    """A plane through the middle of the arm's spheres at theta: some hinges active."""
    centres, _ = robot.sphere_centres(theta[:, :robot.n])
    height = float(np.median(centres[..., 2]))
    return TablePlaneFamily(height, sigma=rng.uniform(1e-3, 1e-2), margin=0.01,
                            states=np.arange(T), robot=robot)


@pytest.fixture(params=["jaco", "sawyer"])
def setup(request):
    robot = request.getfixturevalue(request.param)
    rng = np.random.default_rng(11 if request.param == "jaco" else 12)
    return robot, rng


def test_jacobians_match_finite_differences(setup):
    robot, rng = setup
    for _ in range(3):                                    # random points
        theta = random_theta(robot, rng)
        family = family_at(robot, theta, rng)
        residual = dense_residual(family, robot, theta)
        assert np.any(residual > 0) and np.any(residual == 0)     # active and inactive hinges
        assert_jacobians_match_finite_differences(family, robot, theta)
        shifted = family.with_shift(rng.uniform(0.0, 0.02, (len(family), family.dim)))
        assert_jacobians_match_finite_differences(shifted, robot, theta)


def test_the_hinge_is_the_spheres_height_above_the_plane(setup):
    robot, rng = setup
    theta = random_theta(robot, rng)
    family = family_at(robot, theta, rng)
    centres, _ = robot.sphere_centres(theta[:, :robot.n])
    grown = robot.spheres.radii + robot.spheres.inflation
    expected = np.maximum(0.0, family.height + family.margin + grown - centres[..., 2])
    np.testing.assert_allclose(dense_residual(family, robot, theta), expected, atol=1e-12)


def test_gtsam_error_equals_the_fast_error(setup):
    robot, rng = setup
    theta = random_theta(robot, rng)
    family = family_at(robot, theta, rng).with_shift(
        rng.uniform(0.0, 0.005, (T, len(robot.spheres.radii))))
    problem = PlanningProblem(robot, T, [family], [], theta)
    graph, values = problem.graph(), problem.values(theta)
    assert graph.size() == len(family)
    window = StateWindow(robot, theta)
    for f in range(len(family)):
        fast = family.error(window, np.array([f]))
        assert graph.at(f).error(values) == pytest.approx(fast, rel=1e-10, abs=1e-14)
        # the whitened linearization of the factor: GTSAM's Jacobian block against the kernel's
        linear = graph.at(f).linearize(values)
        A, b = linear.jacobian()
        lin = family.residual(window, np.array([f]), True)
        white = np.zeros((family.dim, theta.shape[1]))
        rhs = np.zeros(family.dim)
        if len(lin.rows):
            white = family.whiten(lin.rows, lin.jacobian)[0]
            rhs = family.whiten(lin.rows, lin.error)[0]
        np.testing.assert_allclose(A, white, atol=1e-9)
        np.testing.assert_allclose(b, -rhs, atol=1e-9)
    assert graph.error(values) == pytest.approx(problem.error(theta), rel=1e-10)


def sphere_heights(robot, q: np.ndarray, between: int = 10) -> np.ndarray:
    """Lowest point z - r - inflation (K, S) [m] of every sphere at every configuration of q (T, n)
    and ``between`` configurations inside each step, from Pinocchio's frame placements."""
    tau = np.linspace(0.0, 1.0, between + 2)[:-1]
    configurations = np.concatenate([
        (q[:-1, None] + tau[None, :, None] * (q[1:] - q[:-1])[:, None]).reshape(-1, q.shape[1]),
        q[-1:]])
    model, data = robot.model, robot.model.createData()
    spheres = robot.spheres
    frames = [model.getFrameId(name) for name in spheres.link_names]
    out = np.empty((len(configurations), len(frames)))
    for k, config in enumerate(configurations):
        pin.framesForwardKinematics(model, data, robot.to_pinocchio(config))
        for s, frame in enumerate(frames):
            out[k, s] = (data.oMf[frame].act(spheres.centres[s]))[2]
    return out - spheres.radii - spheres.inflation


# arm -> (skill, translation of the demonstrations [m], how far above the free plan's lowest
# sphere the plane goes [m]): the Sawyer's needs a constraint round, the Jaco's not
CASES = {"jaco": ("box_closing", [0.0, 0.0, 0.0], 0.03),
         "sawyer": ("pick_place", [0.4, 0.0, 0.0], 0.02)}


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_a_plan_that_dipped_below_the_plane_ends_above_it(arm, request):
    robot = request.getfixturevalue(arm)
    skill, shift, raise_by = CASES[arm]
    prior = learn_prior(make_demonstrations(skill, num_demos=6, seed=0).translated(np.array(shift)))
    start = np.asarray(prior.mean)[0, :3]
    free = plan(prior, robot, None, start, covariance=False)
    assert free.success, free.reasons
    height = float(sphere_heights(robot, free.q).min()) + raise_by
    assert sphere_heights(robot, free.q).min() < height           # the free path dips below

    result = plan(prior, robot, None, start, extra_factors=[TablePlaneFamily(height=height)],
                  covariance=False)
    assert result.success, result.reasons
    # independently: every sphere above the plane at and between the states
    assert sphere_heights(robot, result.q)[::11].min() >= height           # support states
    assert sphere_heights(robot, result.q).min() >= height - 1e-4          # densely in between
    assert result.violations["table_plane"] == 0.0
    assert result.problem.has("table_plane")
    assert result.goal_error is None and result.within_limits


def test_a_broken_plane_is_the_verdicts_reason(prior, jaco):
    """No constraint rounds and a loose hinge: the verdict reports the family's own check."""
    free = plan(prior, jaco, None, prior.mean[0, :3], covariance=False)
    height = float(sphere_heights(jaco, free.q, between=0).min()) + 0.03
    result = plan(prior, jaco, None, prior.mean[0, :3], covariance=False,
                  extra_factors=[TablePlaneFamily(height=height, sigma=1.0)],
                  config=PlannerConfig().with_(constraint_rounds=0))
    assert not result.success
    reason = next(r for r in result.reasons if r.startswith("table_plane: "))
    assert "below the table plane" in reason
    depth = height - sphere_heights(jaco, result.q, between=4).min()
    assert result.violations["table_plane"] == pytest.approx(depth, abs=1e-9)


def test_bad_arguments():
    from clamp.errors import InvalidParameterError
    with raises_naming(InvalidParameterError, "sigma"):
        TablePlaneFamily(0.1, sigma=0.0)
    with raises_naming(InvalidParameterError, "margin"):
        TablePlaneFamily(0.1, margin=-1.0)
    with raises_naming(InvalidParameterError, "states"):
        TablePlaneFamily(0.1, states=[])
    assert len(TablePlaneFamily(0.1)) == 0                 # no factors until a plan gives them
