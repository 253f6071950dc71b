"""The pose prior's families (orientation chain, its start, rotation targets) on a URDF arm
(the Panda of example-robot-data), as tests/clamp/factors/test_families.py checks every family
on the Jaco and the Sawyer: analytic Jacobians against central finite differences at random
configurations, and the GTSAM face against the banded face (error and whitened linearization
per factor; the whole problem's error and Hessian)."""
from __future__ import annotations

import numpy as np
import pytest

from clamp.prior import so3
from robots import Robot
from robots.registry import example_robot_data_share
from tests.clamp.factors.test_families import (T, pose_families, random_theta,
                                               test_gtsam_adapters_equal_the_kernel,
                                               test_jacobians_match_finite_differences,
                                               test_whole_problem_equals_gtsam_graph)

__all__ = ["test_gtsam_adapters_equal_the_kernel", "test_jacobians_match_finite_differences",
           "test_whole_problem_equals_gtsam_graph"]


@pytest.fixture(scope="module")
def panda():
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "panda_description" / "urdf" / "panda.urdf"
    return Robot.from_urdf(urdf, end_effector="panda_hand", package_dirs=[share])


@pytest.fixture(params=[0, 1, 2])
def setup(panda, request):
    """The Panda at a random segment (seeds 0-2) with the pose families only."""
    rng = np.random.default_rng(100 + request.param)
    theta = random_theta(panda, rng)
    Phi = np.eye(6) + 0.1 * rng.normal(size=(T - 1, 6, 6))
    A = rng.normal(size=(T - 1, 6, 6))
    Q = A @ np.swapaxes(A, 1, 2) * 1e-3 + 1e-4 * np.eye(6)
    return panda, theta, pose_families(panda, theta[:, :panda.n], Phi, Q, rng)


def test_angular_velocity_derivative_matches_finite_differences(panda, jaco, sawyer):
    """d omega / d q of the window (the orientation state's velocity part) on all three arms."""
    from clamp.factors import StateWindow
    for robot in (panda, jaco, sawyer):
        rng = np.random.default_rng(3)
        theta = random_theta(robot, rng)
        n = robot.n
        _, W, omega, domega = StateWindow(robot, theta).rotation()
        np.testing.assert_allclose(omega, np.einsum("kij,kj->ki", W, theta[:, n:]))
        for k in range(n):
            plus, minus = theta.copy(), theta.copy()
            plus[:, k] += 1e-6
            minus[:, k] -= 1e-6
            numeric = (StateWindow(robot, plus).rotation()[2]
                       - StateWindow(robot, minus).rotation()[2]) / 2e-6
            np.testing.assert_allclose(domega[:, :, k], numeric, atol=1e-6)


def test_log_map_jacobian_is_the_inverse_right_jacobian():
    rng = np.random.default_rng(0)
    r = rng.normal(size=(20, 3))
    r *= rng.uniform(1e-6, 3.0, size=(20, 1)) / np.linalg.norm(r, axis=1, keepdims=True)
    J = so3.right_jacobian_inverse(r)
    for k in range(3):
        d = np.zeros(3)
        d[k] = 1e-6
        numeric = (so3.log_map(so3.exp_map(r) @ so3.exp_map(d))
                   - so3.log_map(so3.exp_map(r) @ so3.exp_map(-d))) / 2e-6
        np.testing.assert_allclose(J[:, :, k], numeric, atol=1e-6)
