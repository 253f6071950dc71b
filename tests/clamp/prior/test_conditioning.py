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
    """Mean (T*D,) and covariance (T*D, T*D) of the prior conditioned by dense Gaussian
    algebra."""
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
    return mean, Sigma - gain @ H @ Sigma


def blocks(cov, T, D):
    return np.stack([cov[i * D:(i + 1) * D, i * D:(i + 1) * D] for i in range(T)])


def dense_capped_mean(prior, observations, sigma):
    """The conditioned mean (T, D) with the goal's response capped (clamp.prior.goal_response),
    by dense algebra: the mean given the other observations plus s_t times the response to the
    goal, s_t = min(1, 1 / ||G_t||_2) from the dense gain G_t of state t's position on the
    goal's; the velocities follow the scaled positions (s v + ds/dt p)."""
    T, D = prior.T, prior.D
    others = [o for o in observations if o[0] != T - 1]
    rest, rest_cov = dense_conditioning(prior, others, sigma)
    full, _ = dense_conditioning(prior, observations, sigma)
    end = slice((T - 1) * D, (T - 1) * D + 3)
    G = rest_cov[:, end] @ np.linalg.inv(rest_cov[end, end] + sigma**2 * np.eye(3))
    scale = np.array([min(1.0, 1.0 / np.linalg.norm(G[t * D:t * D + 3], 2)) for t in range(T)])
    response = (full - rest).reshape(T, D)
    capped = response * scale[:, None]
    capped[:, 3:] += np.gradient(scale, prior.time)[:, None] * response[:, :3]
    return rest.reshape(T, D) + capped, scale


def test_conditioned_chain_equals_dense_gaussian_conditioning():
    """Covariances exactly the dense conditioning's; the mean too, but where the goal's
    response amplifies (a state moving farther than the goal moved): there it is capped."""
    small = learn_prior(make_demonstrations("box_closing", num_demos=6, num_points=15, seed=2))
    observations = [(0, small.mean[0, :3] + 0.01), (14, small.mean[-1, :3] + [0, 0.05, 0]),
                    (7, small.mean[7, :3] + [0.03, 0, 0])]
    for sigma in (1e-5, 1e-3):
        _, cov = dense_conditioning(small, observations, sigma)
        mean, scale = dense_capped_mean(small, observations, sigma)
        conditioned = condition_prior(small, observations, sigma)
        assert np.abs(conditioned.mean - mean).max() < 1e-9
        cov = blocks(cov, small.T, small.D)
        assert np.abs(conditioned.cov - cov).max() < 1e-9 * np.abs(cov).max() + 1e-14
        assert conditioned.info["goal_response"]["capped_states"] == np.sum(scale < 1)
    without_goal = condition_prior(small, observations[::2], 1e-5)   # start and via: exact
    mean, _ = dense_conditioning(small, observations[::2], 1e-5)
    assert np.abs(without_goal.mean.reshape(-1) - mean).max() < 1e-9


def test_a_goal_never_moves_a_state_farther_than_itself():
    """Three demonstrations fit each step's regression exactly: conditioned exactly on a goal
    1 cm off in the direction the chain amplifies most, it swings states mid-motion by several
    cm. Capped, no state's position moves farther from where the start alone puts it than the
    goal moved; start and goal are met."""
    prior = learn_prior(make_demonstrations("box_closing", num_demos=3, seed=0))
    T, D, sigma = prior.T, prior.D, 1e-5
    start = [(0, prior.mean[0, :3])]
    alone, alone_cov = dense_conditioning(prior, start, sigma)
    alone = alone.reshape(T, D)
    end = slice((T - 1) * D, (T - 1) * D + 3)
    G = (alone_cov[:, end] @ np.linalg.inv(alone_cov[end, end])).reshape(T, D, 3)[:, :3]
    worst = np.linalg.svd(G[np.argmax(np.linalg.norm(G, 2, axis=(1, 2)))])[2][0]
    for direction in (worst, *np.eye(3)):
        goal = alone[-1, :3] + 0.01 * direction
        moved = condition_prior(prior, start + [(T - 1, goal)], sigma)
        shift = np.linalg.norm(moved.mean[:, :3] - alone[:, :3], axis=1)
        assert shift.max() <= 0.01 * (1 + 1e-6)
        assert np.linalg.norm(moved.mean[-1, :3] - goal) < sigma      # met as exactly as before
        assert np.linalg.norm(moved.mean[0, :3] - start[0][1]) < sigma
        capped = moved.info["goal_response"]
        assert f"capped at its own offset on {capped['capped_states']} states" in moved.summary()
    worst_swing = np.linalg.norm(dense_conditioning(prior, start + [(
        T - 1, alone[-1, :3] + 0.01 * worst)], sigma)[0].reshape(T, D)[:, :3] - alone[:, :3],
        axis=1).max()
    assert worst_swing > 0.03                  # the exact chain amplifies the goal over 3x


@pytest.mark.parametrize("skill, capped", [("box_closing", True), ("reach_from_above", False)])
def test_retargeted_equals_conditioning_again(skill, capped):
    """The same observed states and sigma, other positions (a goal, then a via point moved):
    the previous conditioned prior moved by retargeted is the prior conditioned again, to
    rounding; Phi, Q and the covariances are shared (they do not depend on the positions).
    Where the goal's response is capped, only the goal may move."""
    prior = learn_prior(make_demonstrations(skill, num_demos=6, seed=0))
    T, sigma = prior.T, 1e-5
    before = [(0, prior.mean[0, :3]), (60, prior.mean[60, :3]), (T - 1, prior.mean[-1, :3])]
    goal_moved = before[:2] + [(T - 1, prior.mean[-1, :3] + [0.03, -0.05, 0.0])]
    via_moved = [before[0], (60, prior.mean[60, :3] + [0.01, 0.0, 0.02]), goal_moved[-1]]
    previous = conditioned(prior, before, sigma)
    assert (previous.info["goal_response"]["capped_states"] > 0) == capped
    for after in (goal_moved, via_moved):
        again = conditioned(prior, after, sigma)
        if capped and after is via_moved:
            with pytest.raises(InvalidParameterError, match="conditioned_prior"):
                retargeted(previous, after)
            continue
        moved = retargeted(previous, after)
        for name in ("u", "mean0", "mean"):
            np.testing.assert_allclose(getattr(moved, name), getattr(again, name), rtol=0,
                                       atol=1e-12)
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
