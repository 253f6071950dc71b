"""Jacobians of every CLAMP factor family against central finite differences (Jaco and Sawyer),
and the GTSAM adapters against the numpy residuals (errors, whitened Jacobians)."""
from __future__ import annotations

import warnings

import gtsam
import numpy as np
import pytest

from clamp.factors import (TrajectoryEvaluator, ee_position_factors, ee_position_residuals,
                           joint_gp_factors, joint_gp_residuals, joint_limit_factors,
                           joint_limit_residuals, joint_position_factor, obstacle_factors,
                           obstacle_residuals, workspace_gp_factors, workspace_gp_residuals,
                           workspace_start_factor, workspace_start_residuals, workspace_states)
from clamp.factors.evaluation import square_root_information
from clamp.factors.joint_gp import joint_gp_covariance
from clamp.keys import state_key

T = 5
STEP = 1e-6


@pytest.fixture(scope="module", params=["jaco", "sawyer"])
def robot(request):
    from robots import load_robot
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(request.param)
        robot.sphere_centres(np.zeros((1, robot.n)))  # build the sphere model once
    return robot


def random_theta(robot, seed: int) -> np.ndarray:
    """Random joint states (T, 2n): configurations inside the limits, velocities ~0.3 rad/s."""
    rng = np.random.default_rng(seed)
    q = np.stack([robot.random_configuration(rng) for _ in range(T)])
    qdot = rng.normal(scale=0.3, size=q.shape)
    return np.concatenate([q, qdot], axis=1)


def numeric_jacobian(fun, theta: np.ndarray) -> np.ndarray:
    """Central differences of fun(theta (T, 2n)) -> (F, m), shape (F, m, T, 2n)."""
    base = fun(theta)
    jac = np.zeros(base.shape + theta.shape)
    for t in range(theta.shape[0]):
        for k in range(theta.shape[1]):
            plus, minus = theta.copy(), theta.copy()
            plus[t, k] += STEP
            minus[t, k] -= STEP
            jac[..., t, k] = (fun(plus) - fun(minus)) / (2 * STEP)
    return jac


def assert_blocks(result, numeric, states_of_row, atol=1e-5):
    """Analytic Jacobian blocks of every factor row equal the numeric ones; others are zero."""
    for row, states in enumerate(states_of_row):
        for block, state in zip(result.jacobians, states):
            np.testing.assert_allclose(block[row], numeric[row, :, state], atol=atol, rtol=1e-5)
        others = [t for t in range(numeric.shape[2]) if t not in states]
        assert np.allclose(numeric[row][:, others], 0.0, atol=atol)


def random_prior_terms(seed: int, count: int):
    rng = np.random.default_rng(seed)
    Phi = np.eye(6) + 0.1 * rng.normal(size=(count, 6, 6))
    u = 0.05 * rng.normal(size=(count, 6))
    A = rng.normal(size=(count, 6, 6))
    Q = A @ np.swapaxes(A, 1, 2) * 1e-3 + 1e-4 * np.eye(6)
    return Phi, u, Q


# ------------------------------------------------------------------------ workspace states
def test_workspace_states_jacobian(robot):
    theta = random_theta(robot, 1)
    ws = workspace_states(robot, theta)
    numeric = numeric_jacobian(lambda th: workspace_states(robot, th, False).x, theta)
    for t in range(T):
        np.testing.assert_allclose(ws.jacobian[t], numeric[t, :, t], atol=1e-6, rtol=1e-5)


def test_workspace_gp_jacobians(robot):
    theta = random_theta(robot, 2)
    Phi, u, _ = random_prior_terms(3, T - 1)
    fun = lambda th: workspace_gp_residuals(workspace_states(robot, th, False), Phi, u).error
    result = workspace_gp_residuals(workspace_states(robot, theta), Phi, u)
    assert result.error.shape == (T - 1, 6)
    assert_blocks(result, numeric_jacobian(fun, theta), [(i, i + 1) for i in range(T - 1)])


def test_workspace_gp_residual_is_zero_on_its_own_dynamics(robot):
    theta = random_theta(robot, 4)
    x = workspace_states(robot, theta, False).x
    Phi, _, _ = random_prior_terms(5, T - 1)
    u = x[1:] - np.einsum("tij,tj->ti", Phi, x[:-1])
    result = workspace_gp_residuals(workspace_states(robot, theta, False), Phi, u)
    np.testing.assert_allclose(result.error, 0.0, atol=1e-12)


def test_workspace_start_jacobian(robot):
    theta = random_theta(robot, 6)
    mean = np.arange(6.0) * 0.1
    fun = lambda th: workspace_start_residuals(workspace_states(robot, th, False), mean).error
    result = workspace_start_residuals(workspace_states(robot, theta), mean)
    assert_blocks(result, numeric_jacobian(fun, theta), [(0,)])


def test_ee_position_jacobian(robot):
    theta = random_theta(robot, 7)
    indices = np.array([0, 2, T - 1])
    targets = np.full((3, 3), 0.3)
    fun = lambda th: ee_position_residuals(workspace_states(robot, th, False), indices, targets).error
    result = ee_position_residuals(workspace_states(robot, theta), indices, targets)
    assert_blocks(result, numeric_jacobian(fun, theta), [(int(i),) for i in indices])


def test_joint_gp_jacobian_and_covariance(robot):
    theta = random_theta(robot, 8)
    dt = 0.16
    result = joint_gp_residuals(theta, dt)
    fun = lambda th: joint_gp_residuals(th, dt).error
    assert_blocks(result, numeric_jacobian(fun, theta), [(i, i + 1) for i in range(T - 1)])
    # constant-velocity motion has zero residual
    q0, qdot = theta[0, :robot.n], theta[0, robot.n:]
    line = np.array([np.concatenate([q0 + k * dt * qdot, qdot]) for k in range(T)])
    np.testing.assert_allclose(joint_gp_residuals(line, dt).error, 0.0, atol=1e-12)
    Q = joint_gp_covariance(robot.n, dt, 2.0)
    np.testing.assert_allclose(Q[0, 0], 2.0 * dt ** 3 / 3)
    np.testing.assert_allclose(Q[0, robot.n], 2.0 * dt ** 2 / 2)
    np.testing.assert_allclose(Q[robot.n, robot.n], 2.0 * dt)


def sphere_obstacle_query(centre: np.ndarray, radius: float):
    """Exact signed distance to a ball and its gradient (an analytic stand-in for an SDF)."""
    def query(points):
        diff = points - centre
        norm = np.linalg.norm(diff, axis=-1)
        return norm - radius, diff / norm[..., None]
    return query


def obstacle_near_arm(robot, theta):
    """A ball placed at one collision sphere of the middle state so some hinges are active."""
    centres, _ = robot.sphere_centres(theta[:, :robot.n])
    return sphere_obstacle_query(centres[T // 2, 0] + np.array([0.03, 0.02, 0.01]), 0.05)


def test_obstacle_jacobian(robot):
    theta = random_theta(robot, 9)
    radii = np.asarray(robot.spheres.radii)
    query = obstacle_near_arm(robot, theta)

    def fun(th):
        centres, _ = robot.sphere_centres(th[:, :robot.n])
        return obstacle_residuals(centres, None, radii, query, 0.05).error

    centres, jac = robot.sphere_centres(theta[:, :robot.n], jacobians=True)
    result = obstacle_residuals(centres, jac, radii, query, 0.05)
    assert result.error.shape == (T, len(radii))
    assert np.count_nonzero(result.error) > 0, "test setup: no active hinge"
    assert np.all(result.error >= 0)
    assert_blocks(result, numeric_jacobian(fun, theta), [(t,) for t in range(T)])


def test_joint_limit_jacobian(robot):
    theta = random_theta(robot, 10)
    lower = np.where(np.isfinite(robot.lower_limits), robot.lower_limits, -np.inf)
    upper = np.where(np.isfinite(robot.upper_limits), robot.upper_limits, np.inf)
    # tighten the limits so that some hinges are active
    finite = np.isfinite(lower) & np.isfinite(upper)
    mid = np.where(finite, 0.5 * (np.where(finite, lower, 0) + np.where(finite, upper, 0)), 0.0)
    lower = np.where(finite, mid - 0.2, lower)
    upper = np.where(finite, mid + 0.2, upper)
    vmax = np.full(robot.n, 0.2)
    result = joint_limit_residuals(theta, lower, upper, vmax)
    assert np.count_nonzero(result.error) > 0
    assert np.all(result.error[:, :robot.n][:, ~finite] == 0.0)
    fun = lambda th: joint_limit_residuals(th, lower, upper, vmax).error
    assert_blocks(result, numeric_jacobian(fun, theta), [(t,) for t in range(T)])


# ------------------------------------------------------------------------ GTSAM adapters
def values_of(theta):
    values = gtsam.Values()
    for i, row in enumerate(theta):
        values.insert(state_key(i), row)
    return values


def check_adapter(factor, values, error, jacobians, sqrt_info):
    """Unwhitened error equals the numpy residual; linearized A and b are R J and -R e."""
    np.testing.assert_allclose(factor.unwhitenedError(values), error, atol=1e-10)
    A, b = factor.linearize(values).jacobian()
    expected = np.hstack([sqrt_info @ J for J in jacobians])
    np.testing.assert_allclose(A, expected, rtol=1e-9, atol=1e-6 * max(1.0, np.abs(expected).max()))
    np.testing.assert_allclose(b, -sqrt_info @ error, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(factor.error(values), 0.5 * np.sum((sqrt_info @ error) ** 2),
                               rtol=1e-9, atol=1e-12)


def test_gtsam_adapters_match_numpy(robot):
    theta = random_theta(robot, 11)
    values = values_of(theta)
    evaluator = TrajectoryEvaluator(robot, T)
    ws = workspace_states(robot, theta)

    Phi, u, Q = random_prior_terms(12, T - 1)
    ref = workspace_gp_residuals(ws, Phi, u)
    for i, f in enumerate(workspace_gp_factors(evaluator, Phi, u, Q)):
        check_adapter(f, values, ref.error[i], [ref.jacobians[0][i], ref.jacobians[1][i]],
                      square_root_information(Q[i]))

    mean, cov = 0.1 * np.ones(6), 1e-2 * np.eye(6) + 1e-3
    ref = workspace_start_residuals(ws, mean)
    check_adapter(workspace_start_factor(evaluator, mean, cov), values, ref.error[0],
                  [ref.jacobians[0][0]], square_root_information(cov))

    targets = np.array([[0.3, 0.1, 0.2], [0.1, 0.2, 0.3]])
    ref = ee_position_residuals(ws, np.array([1, 3]), targets)
    for k, f in enumerate(ee_position_factors(evaluator, [1, 3], targets, [0.01, 0.02])):
        check_adapter(f, values, ref.error[k], [ref.jacobians[0][k]],
                      np.eye(3) / [0.01, 0.02][k])

    radii = np.asarray(robot.spheres.radii)
    query = obstacle_near_arm(robot, theta)
    centres, jac = robot.sphere_centres(theta[:, :robot.n], jacobians=True)
    ref = obstacle_residuals(centres, jac, radii, query, 0.05)
    for t, f in enumerate(obstacle_factors(evaluator, range(T), radii, query, 0.05, 0.05)):
        check_adapter(f, values, ref.error[t], [ref.jacobians[0][t]], np.eye(len(radii)) / 0.05)

    lower, upper = robot.lower_limits + 0.5, robot.upper_limits - 0.5
    vmax = np.full(robot.n, 0.2)
    ref = joint_limit_residuals(theta, lower, upper, vmax)
    for t, f in enumerate(joint_limit_factors(evaluator, range(T), lower, upper, vmax, 1e-2)):
        check_adapter(f, values, ref.error[t], [ref.jacobians[0][t]], np.eye(2 * robot.n) / 1e-2)


def test_linear_factors_match_numpy(robot):
    theta = random_theta(robot, 13)
    values = values_of(theta)
    dt, Qc = 0.16, 0.5
    ref = joint_gp_residuals(theta, dt)
    R = square_root_information(joint_gp_covariance(robot.n, dt, Qc))
    for i, f in enumerate(joint_gp_factors(T, robot.n, dt, Qc)):
        white = R @ ref.error[i]
        np.testing.assert_allclose(f.error(values), 0.5 * white @ white, rtol=1e-8)
        A, b = f.linearize(values).jacobian()
        np.testing.assert_allclose(A @ np.zeros(A.shape[1]) - b, white, rtol=1e-8, atol=1e-10)
    q_target = theta[2, :robot.n] + 0.01
    f = joint_position_factor(2, q_target, 1e-3)
    np.testing.assert_allclose(f.error(values), 0.5 * np.sum(((theta[2, :robot.n] - q_target) / 1e-3) ** 2),
                               rtol=1e-8)


def test_cache_follows_values(robot):
    """A factor evaluated on other values (other states) recomputes; same values reuse the cache."""
    theta = random_theta(robot, 14)
    evaluator = TrajectoryEvaluator(robot, T)
    Phi, u, Q = random_prior_terms(15, T - 1)
    factors = workspace_gp_factors(evaluator, Phi, u, Q)
    e1 = factors[1].unwhitenedError(values_of(theta))
    reloads = evaluator.reloads
    factors[2].unwhitenedError(values_of(theta))
    assert evaluator.reloads == reloads
    moved = theta.copy()
    moved[2, 0] += 0.1
    e2 = factors[1].unwhitenedError(values_of(moved))
    assert evaluator.reloads == reloads + 1
    ref = workspace_gp_residuals(workspace_states(robot, moved, False), Phi, u).error[1]
    np.testing.assert_allclose(e2, ref, atol=1e-12)
    assert not np.allclose(e1, e2)
