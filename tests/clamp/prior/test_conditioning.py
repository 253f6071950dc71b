"""Goals and via points met exactly: the prior conditioned on target positions
(clamp.prior.conditioning) and the planner's target checks (clamp.planning.targets)."""
from __future__ import annotations

import numpy as np
import pytest

from clamp import PlannerConfig, learn_prior, plan
from clamp.errors import InvalidParameterError
from clamp.prior.conditioning import condition_prior, conditioned, retargeted
from scenes import make_demonstrations

START = np.array([0.2054, -0.4722, 0.2625])      # the README's start


def dense_conditioning(prior, observations, sigma):
    """Mean (T*D,) and marginal covariances of the prior conditioned by dense Gaussian algebra."""
    T, D = prior.T, prior.D
    Sigma = np.zeros((T * D, T * D))
    for i in range(T):
        Sigma[i * D:(i + 1) * D, i * D:(i + 1) * D] = prior.cov[i]
        M = np.eye(D)
        for j in range(i + 1, T):
            M = prior.Phi[j - 1] @ M
            Sigma[j * D:(j + 1) * D, i * D:(i + 1) * D] = M @ prior.cov[i]
            Sigma[i * D:(i + 1) * D, j * D:(j + 1) * D] = (M @ prior.cov[i]).T
    H = np.zeros((3 * len(observations), T * D))
    y = np.zeros(3 * len(observations))
    for k, (i, p) in enumerate(observations):
        H[3 * k:3 * k + 3, i * D:i * D + 3] = np.eye(3)
        y[3 * k:3 * k + 3] = p
    gain = Sigma @ H.T @ np.linalg.inv(H @ Sigma @ H.T + sigma**2 * np.eye(len(y)))
    mean = prior.mean.reshape(-1) + gain @ (y - H @ prior.mean.reshape(-1))
    cov = Sigma - gain @ H @ Sigma
    return mean, np.stack([cov[i * D:(i + 1) * D, i * D:(i + 1) * D] for i in range(T)])


def test_conditioned_chain_equals_dense_gaussian_conditioning():
    small = learn_prior(make_demonstrations("box_closing", num_demos=6, num_points=15, seed=2))
    observations = [(0, small.mean[0, :3] + 0.01), (14, small.mean[-1, :3] + [0, 0.05, 0]),
                    (7, small.mean[7, :3] + [0.03, 0, 0])]
    for sigma in (1e-5, 1e-3):
        mean, cov = dense_conditioning(small, observations, sigma)
        conditioned = condition_prior(small, observations, sigma)
        assert np.abs(conditioned.mean.reshape(-1) - mean).max() < 1e-9
        assert np.abs(conditioned.cov - cov).max() < 1e-9 * np.abs(cov).max() + 1e-14


def test_retargeted_equals_conditioning_again(prior):
    """The same observed states and sigma, other positions (a goal and a via point moved): the
    previous conditioned prior moved by retargeted is the prior conditioned again, to
    rounding; Phi, Q and the covariances are shared (they do not depend on the positions)."""
    T, sigma = prior.T, 1e-5
    before = [(0, prior.mean[0, :3]), (60, prior.mean[60, :3]), (T - 1, prior.mean[-1, :3])]
    after = [(0, prior.mean[0, :3]), (60, prior.mean[60, :3] + [0.01, 0.0, 0.02]),
             (T - 1, prior.mean[-1, :3] + [0.03, -0.05, 0.0])]
    again = conditioned(prior, after, sigma)
    moved = retargeted(conditioned(prior, before, sigma), after)
    for name in ("u", "mean0", "mean"):
        np.testing.assert_allclose(getattr(moved, name), getattr(again, name), rtol=0, atol=1e-12)
    for name in ("Phi", "Q", "cov0", "cov"):
        np.testing.assert_array_equal(getattr(moved, name), getattr(again, name))
    assert moved.info["conditioned_on"] == again.info["conditioned_on"]
    assert np.linalg.norm(moved.mean[-1, :3] - after[-1][1]) < 1e-3
    with pytest.raises(InvalidParameterError, match="conditioned_prior"):
        retargeted(again, after[::2])                   # other states: condition again
    with pytest.raises(InvalidParameterError, match="conditioned_prior"):
        retargeted(prior, after)                        # not conditioned at all


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_goal_moved_5cm_in_six_directions_is_met_within_2mm(prior, arm, request):
    robot = request.getfixturevalue(arm)
    for axis in range(3):
        for sign in (1.0, -1.0):
            goal = prior.mean[-1, :3].copy()
            goal[axis] += sign * 0.05
            result = plan(prior, robot, None, start=START, goal=goal, covariance=False)
            miss = float(np.linalg.norm(robot.fk(result.q[-1]) - goal))   # our own FK
            assert miss < 0.002, (axis, sign, miss)
            assert result.success, result.reasons
            assert result.goal_error == pytest.approx(miss, abs=1e-9)
            assert np.isfinite(result.plausibility)


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_via_point_3cm_off_the_mean_is_met_within_2mm(prior, arm, request):
    robot = request.getfixturevalue(arm)
    via = prior.mean[prior.T // 2, :3] + [0.03, 0.0, 0.0]
    result = plan(prior, robot, None, start=START, via_points=[(prior.T // 2, via)],
                  covariance=False)
    miss = float(np.linalg.norm(robot.fk(result.q[prior.T // 2]) - via))
    assert miss < 0.002 and result.success, (miss, result.reasons)
    assert result.via_errors == [pytest.approx(miss, abs=1e-9)]
    # a joint-space via point: the configuration of that plan at another state
    q_via = result.q[60]
    joint = plan(prior, robot, None, start=START, via_points=[(60, q_via)], covariance=False)
    assert joint.success and joint.via_errors[0] < 0.002, (joint.via_errors, joint.reasons)


def test_without_conditioning_the_soft_goal_misses(prior, jaco):
    goal = prior.mean[-1, :3] + [0.0, 0.05, 0.0]
    result = plan(prior, jaco, None, start=START, goal=goal, covariance=False,
                  config=PlannerConfig().with_(condition_on_targets=False))
    assert result.goal_error > 0.01 and not result.success
    assert any("goal error" in r for r in result.reasons)


def test_unreachable_via_point_fails_with_a_reason(prior, jaco):
    result = plan(prior, jaco, None, start=START, via_points=[(100, [2.0, 0.0, 0.5])],
                  covariance=False)
    assert not result.success
    assert any("via point at state 100" in r and "out of reach" in r for r in result.reasons)
