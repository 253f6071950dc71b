"""Joint-configuration targets (start, goal, via points): e_k = q_{i_k} - q_target_k (n,) (or the
velocities qdot, for a subclass that sets ``velocities``). Linear."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.validation import as_array, as_indices

from .family import Family, Linearization
from .states import StateWindow


class JointTargetFamily(Family):
    """One factor per target: state indices (K,), targets (K, n) [rad], sigmas (K,) [rad]."""

    name = "joint_target"
    arity = 1
    kinematics = 0
    linear = True
    #: the half of the state [q, qdot] targeted: False the positions, True the velocities
    #: (a subclass's choice, e.g. :class:`~clamp.factors.PostureVelocityFamily`)
    velocities = False

    def __init__(self, indices: Sequence[int], targets: np.ndarray, sigmas: Sequence[float]):
        indices = as_indices(indices, "indices")
        order = np.argsort(indices, kind="stable")
        self.targets = as_array(targets, "targets", (len(order), None))[order]
        sigmas = as_array(sigmas, "sigmas", (len(order),))
        super().__init__(indices[order], self.targets.shape[1], sigma=sigmas[order])
        n = self.dim
        block = [np.zeros((n, n)), np.eye(n)]
        self._jacobian = np.hstack(block if self.velocities else block[::-1])

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        i = window.local(self.first[rows])
        error = (window.qdot if self.velocities else window.q)[i] - self.targets[rows]
        jac = np.broadcast_to(self._jacobian, (len(rows),) + self._jacobian.shape) \
            if jacobians else None
        return Linearization(rows, error, jac)
