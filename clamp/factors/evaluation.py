"""Shared evaluation of all support states for the factors of one graph.

GTSAM calls every Python factor separately. An :class:`TrajectoryEvaluator` makes those calls
cheap: when a factor is called it compares its own joint states with the cached copy; on a
mismatch the evaluator reloads all T states from ``values`` and every residual family is
recomputed for all support states in one vectorized call (lazily, on first use). Factors then
return slices. This is correct by construction because a factor's output depends only on its
own states, which are compared on every call.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import gtsam
import numpy as np

from clamp.keys import state_key, values_to_states


@dataclass(frozen=True)
class Residuals:
    """Residuals of one factor family for all its factors.

    error (F, m); jacobians: one (F, m, 2n) array per variable of a factor (in key order),
    or None when Jacobians were not requested.
    """

    error: np.ndarray
    jacobians: tuple[np.ndarray, ...] | None


@dataclass(frozen=True)
class WorkspaceStates:
    """Workspace states x = [p, J(q) qdot] (T, 6) and their Jacobian d x / d theta (T, 6, 2n)."""

    x: np.ndarray
    jacobian: np.ndarray | None


def workspace_states(robot, theta: np.ndarray, jacobians: bool = True) -> WorkspaceStates:
    """x(theta) = [fk(q), J(q) qdot] for joint states theta (T, 2n), with d x / d theta.

    d x / d theta = [[J, 0], [d(J qdot)/dq, J]].
    """
    n = robot.n
    kin = robot.ee_kinematics(theta[:, :n], theta[:, n:], jacobians=jacobians)
    x = np.concatenate([kin.position, kin.velocity], axis=1)
    if not jacobians:
        return WorkspaceStates(x, None)
    T = theta.shape[0]
    jac = np.zeros((T, 6, 2 * n))
    jac[:, :3, :n] = kin.jacobian
    jac[:, 3:, :n] = kin.velocity_jacobian
    jac[:, 3:, n:] = kin.jacobian
    return WorkspaceStates(x, jac)


@dataclass(frozen=True)
class FamilyBlock:
    """The GTSAM adapters of one residual family made by :func:`custom_factors`.

    states (F, k) support-state indices of every factor (its keys, in order);
    sqrt_information (F, m, m) whitening of every factor's noise model; factors the F adapters.
    """

    family: "ResidualFamily"
    states: np.ndarray
    sqrt_information: np.ndarray
    factors: tuple


class ResidualFamily:
    """A family of factors whose residuals are computed for all factors at once.

    Subclasses set ``name`` (and optionally ``cost``, used to evaluate cheap families first)
    and implement :meth:`compute`, returning the residuals of every factor of the family at the
    evaluator's current joint states.
    """

    name: str = "family"
    cost: int = 1  # relative evaluation cost (0: no kinematics; 2: collision spheres + SDF)

    def compute(self, evaluator: "TrajectoryEvaluator", jacobians: bool) -> Residuals:
        raise NotImplementedError


class TrajectoryEvaluator:
    """Cache of joint states (T, 2n), kinematics and residual families for one graph."""

    def __init__(self, robot, num_states: int):
        self.robot = robot
        self.num_states = int(num_states)
        self.keys = [state_key(i) for i in range(self.num_states)]
        self.theta = np.full((self.num_states, 2 * robot.n), np.nan)
        self._state_bytes = [b""] * self.num_states  # bytes of each cached state, for fast compares
        self._version = 0
        self._memo: dict[object, tuple[int, bool, object]] = {}
        self.reloads = 0
        self.blocks: list[FamilyBlock] = []  # adapters made by custom_factors (see there)

    # -- states ------------------------------------------------------------------------------
    def load(self, theta: np.ndarray) -> None:
        """Set all joint states (T, 2n) directly (used outside GTSAM, e.g. in tests)."""
        self.theta = np.array(theta, dtype=float, copy=True)
        self._state_bytes = [row.tobytes() for row in self.theta]
        self._version += 1

    def set_states(self, theta: np.ndarray) -> None:
        """Load joint states (T, 2n) unless they equal the cached ones (memoised results kept)."""
        if not np.array_equal(theta, self.theta):
            self.load(theta)

    def sync(self, values: gtsam.Values, indices: Sequence[int]) -> None:
        """Make the cache agree with ``values`` on the states ``indices``; reload all on mismatch."""
        for i in indices:
            if values.atVector(self.keys[i]).tobytes() != self._state_bytes[i]:
                self.load(values_to_states(values, self.keys))
                self.reloads += 1
                return

    # -- memoised quantities -------------------------------------------------------------------
    def _cached(self, tag: object, jacobians: bool, compute: Callable[[bool], object]):
        hit = self._memo.get(tag)
        if hit is not None and hit[0] == self._version and (hit[1] or not jacobians):
            return hit[2]
        value = compute(jacobians)
        self._memo[tag] = (self._version, jacobians, value)
        return value

    def workspace(self, jacobians: bool) -> WorkspaceStates:
        """Workspace states of all support states (see :func:`workspace_states`).

        Always computed with the Jacobian: the end-effector velocity already needs the
        position Jacobian, so it costs ~3 % more, and a linearization at a point whose error
        was just evaluated (every accepted trial point) then reuses it.
        """
        states = self._cached("workspace", True,
                              lambda jac: workspace_states(self.robot, self.theta, True))
        return states if jacobians else WorkspaceStates(states.x, None)

    def spheres(self, jacobians: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Collision sphere centres (T, S, 3) and their Jacobians d c / d q (T, S, 3, n) or None."""
        n = self.robot.n
        return self._cached("spheres", jacobians,
                            lambda jac: self.robot.sphere_centres(self.theta[:, :n], jacobians=jac))

    def residuals(self, family: ResidualFamily, jacobians: bool) -> Residuals:
        """Residuals of ``family`` at the current states (memoised until the states change)."""
        return self._cached(family, jacobians, lambda jac: family.compute(self, jac))


def _factor_error(evaluator: TrajectoryEvaluator, family: ResidualFamily, row: int,
                  states: tuple[int, ...], this: gtsam.CustomFactor, values: gtsam.Values,
                  H: list | None) -> np.ndarray:
    evaluator.sync(values, states)
    result = evaluator.residuals(family, H is not None)
    if H is not None:
        for k, jac in enumerate(result.jacobians):
            H[k] = jac[row]
    return result.error[row]


def custom_factors(evaluator: TrajectoryEvaluator, family: ResidualFamily,
                   states: Sequence[tuple[int, ...]],
                   noise_models: Sequence[gtsam.noiseModel.Base]) -> list[gtsam.CustomFactor]:
    """Thin GTSAM adapters: factor ``row`` returns row ``row`` of ``family``'s residuals.

    states[row] lists the support-state indices the factor connects (its keys, in order);
    noise_models must be Gaussian (isotropic, diagonal or full). The adapters are also recorded
    in ``evaluator.blocks`` so that :mod:`clamp.vectorized_graph` can evaluate and linearize
    them all at once without calling them.
    """
    factors = []
    for row, (idx, noise) in enumerate(zip(states, noise_models)):
        keys = [evaluator.keys[i] for i in idx]
        fn = partial(_factor_error, evaluator, family, row, tuple(idx))
        factors.append(gtsam.CustomFactor(noise, keys, fn))
    if factors:
        indices = np.array(states, dtype=int).reshape(len(factors), -1)
        whitening = np.stack([np.asarray(m.R(), dtype=float) for m in noise_models])
        evaluator.blocks.append(FamilyBlock(family, indices, whitening, tuple(factors)))
    return factors


def square_root_information(cov: np.ndarray) -> np.ndarray:
    """Upper-triangular R (..., m, m) with R^T R = cov^-1, for covariances (..., m, m)."""
    info = np.linalg.inv(cov)
    info = 0.5 * (info + np.swapaxes(info, -1, -2))
    lower = np.linalg.cholesky(info)
    return np.swapaxes(lower, -1, -2)


def gaussian_noise(cov: np.ndarray) -> gtsam.noiseModel.Base:
    """GTSAM Gaussian noise model of covariance (m, m), built from its square-root information."""
    return gtsam.noiseModel.Gaussian.SqrtInformation(square_root_information(cov))
