"""Posterior uncertainty of a plan: the Laplace covariance at the optimum.

The Gauss-Newton information matrix H = J^T J of the whole graph at the optimum is
block-tridiagonal (:meth:`clamp.problem.PlanningProblem.normal_equations`); its inverse's
diagonal blocks are the covariances of the joint states, computed without a dense inverse
(:func:`clamp.marginals.block_tridiagonal_inverse`). They equal ``gtsam.Marginals`` on
``problem.graph()`` at the same values. End-effector covariances follow by propagation
through the position Jacobian.
"""
from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_limits

from clamp.problem import PlanningProblem


def plan_covariances(problem: PlanningProblem, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Covariances of the joint states (T, 2n, 2n) and end-effector positions (T, 3, 3) [m^2]
    at theta (T, 2n)."""
    from clamp.marginals import block_tridiagonal_inverse, ee_position_covariance  # TEMP
    with threadpool_limits(limits=1, user_api="blas"):
        system = problem.normal_equations(theta)
        C, _ = block_tridiagonal_inverse(system.D, system.E)
        _, dx = problem.window(theta).workspace()
        return C, ee_position_covariance(C, dx[:, :3])
