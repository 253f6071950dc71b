"""Joint states of a window of consecutive support states, with their kinematics computed once.

A :class:`StateWindow` holds theta = [q, qdot] (K, 2n) of the support states
``first .. first + K - 1`` and computes, on first use and for all K states in one vectorized
call, what the factor families need: the workspace states x = [fk(q), J(q) qdot] with their
Jacobian, and the collision-sphere centres. It is the only kinematics cache of the planner:
the fast solver makes one window per trial point (K = T), a GTSAM adapter one per evaluation
(K = T when GTSAM hands it all support states, else just the factor's own states).
"""
from __future__ import annotations

from typing import Any

import numpy as np


class StateWindow:
    """Joint states theta (K, 2n) of support states first .. first + K - 1 of ``robot``."""

    __slots__ = ("robot", "theta", "first", "_workspace", "_centres", "_rotation", "_chains")

    def __init__(self, robot: Any, theta: np.ndarray, first: int = 0):
        self.robot = robot
        self.theta = theta
        self.first = int(first)
        self._workspace: tuple[np.ndarray, np.ndarray] | None = None
        self._centres: np.ndarray | None = None
        self._rotation: tuple[np.ndarray, ...] | None = None
        self._chains: dict[int, tuple[Any, dict[str, Any]]] = {}

    @property
    def n(self) -> int:
        """Number of robot joints."""
        return self.theta.shape[1] // 2

    @property
    def q(self) -> np.ndarray:
        """Joint positions (K, n) [rad]."""
        return self.theta[:, : self.n]

    @property
    def qdot(self) -> np.ndarray:
        """Joint velocities (K, n) [rad/s]."""
        return self.theta[:, self.n:]

    def local(self, index: np.ndarray) -> np.ndarray:
        """Rows of this window (...,) holding the support states ``index`` (...,)."""
        return index - self.first

    def workspace(self) -> tuple[np.ndarray, np.ndarray]:
        """Workspace states x (K, 6) = [fk(q) [m], J(q) qdot [m/s]] and d x / d theta (K, 6, 2n).

        d x / d theta = [[J, 0], [d(J qdot)/dq, J]]. Always computed with the Jacobian: the
        velocity needs the position Jacobian anyway (~3 % more), and a linearization at an
        accepted trial point then reuses it.
        """
        if self._workspace is None:
            n = self.n
            kin = self.robot.ee_kinematics(self.q, self.qdot, jacobians=True)
            x = np.concatenate([kin.position, kin.velocity], axis=1)
            jac = np.zeros((len(x), 6, 2 * n))
            jac[:, :3, :n] = kin.jacobian
            jac[:, 3:, :n] = kin.velocity_jacobian
            jac[:, 3:, n:] = kin.jacobian
            self._workspace = (x, jac)
        return self._workspace

    def rotation(self, jacobians: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """The hand's rotation R (K, 3, 3), its angular Jacobian W (K, 3, n) (base-frame angular
        velocity omega = W qdot), omega (K, 3) [rad/s] and, if ``jacobians``, d omega / d q
        (K, 3, n) (else None), each computed once. Column k of d omega / d q is
        w_k x sum_{i > k} w_i qdot_i (joint i's axis turns with every revolute joint k upstream
        of it)."""
        if self._rotation is None:
            R, W = self.robot.ee_rotation(self.q, jacobians=True)
            self._rotation = (R, W, np.einsum("kjn,kn->kj", W, self.qdot), None)
        R, W, omega, domega = self._rotation
        if jacobians and domega is None:
            spin = W * self.qdot[:, None, :]                               # (K, 3, n)
            after = omega[:, :, None] - np.cumsum(spin, axis=2)            # sum over i > k
            domega = np.stack([W[:, 1] * after[:, 2] - W[:, 2] * after[:, 1],     # W x after
                               W[:, 2] * after[:, 0] - W[:, 0] * after[:, 2],
                               W[:, 0] * after[:, 1] - W[:, 1] * after[:, 0]], axis=1)
            self._rotation = (R, W, omega, domega)
        return self._rotation

    def chain_cache(self, chain: Any) -> dict[str, Any]:
        """A dict this window keeps for ``chain`` (an object compared by identity, e.g. a learned
        chain's mean rotations): what a family computes of every state for that chain, kept
        for the other families, the solver's correction and the error at the same states
        (:func:`clamp.factors.hand_orientation.chain_states`)."""
        entry = self._chains.get(id(chain))
        if entry is None or entry[0] is not chain:
            entry = (chain, {})
            self._chains[id(chain)] = entry
        return entry[1]

    def sphere_centres(self) -> np.ndarray:
        """Collision-sphere centres (K, S, 3) [m] of every state (no Jacobians)."""
        if self._centres is None:
            self._centres, _ = self.robot.sphere_centres(self.q, jacobians=False)
        return self._centres

    def sphere_jacobians(self, rows: np.ndarray) -> np.ndarray:
        """d centre / d q (R, S, 3, n) of the window rows ``rows`` (R,) only."""
        _, jac = self.robot.sphere_centres(self.q[rows], jacobians=True)
        return jac
