"""Second-order correction of Levenberg-Marquardt trial points onto the predicted workspace path.

The learned workspace prior is extremely stiff (step noise down to the 1e-6 m jitter), so the
workspace states x(theta) = [fk(q), J(q) qdot] are pinned to micrometres while the joints keep
free (self-motion, orientation) directions. The Gauss-Newton model is linear in theta, but x is
curved: a joint step of s rad moves x off the linear prediction by ~ s^2 * arm length, which the
1e-6 m noise turns into a huge error, so plain LM only accepts tiny steps (hundreds of
iterations). The correction keeps the linear model's predicted workspace states

    x_pred_i = x(theta_i) + dx/dtheta(theta_i) delta_i

and moves each trial state theta_i + delta_i back onto them by a few per-state Gauss-Newton
(minimum-norm, damped pseudo-inverse) updates of theta_i. The free joint directions keep the
LM step; only the second-order workspace drift is removed. The LM loop still accepts a trial
point only if the true graph error decreases.
"""
from __future__ import annotations

from collections.abc import Sequence

import gtsam
import numpy as np

from clamp.factors.evaluation import workspace_states
from clamp.keys import states_to_values, values_to_states


def project_to_workspace(robot, theta: np.ndarray, target: np.ndarray, iterations: int,
                         damping: float = 1e-9) -> np.ndarray:
    """Joint states (T, 2n) near theta whose workspace states approach target (T, 6).

    Each iteration: theta += J^T (J J^T + damping I)^-1 (target - x(theta)), J = dx/dtheta
    (T, 6, 2n), all states at once (damping in m^2 keeps singular arms finite).
    """
    theta = np.array(theta, dtype=float, copy=True)
    eye = damping * np.eye(target.shape[1])
    for _ in range(iterations):
        states = workspace_states(robot, theta, jacobians=True)
        jac = states.jacobian
        gram = jac @ np.swapaxes(jac, 1, 2) + eye
        step = np.linalg.solve(gram, (target - states.x)[..., None])[..., 0]
        theta += np.einsum("tji,tj->ti", jac, step)
    return theta


class WorkspaceCorrection:
    """Correction callable for :func:`clamp.levenberg_marquardt.levenberg_marquardt`.

    robot: robots.Robot; keys: the T state keys; iterations: Gauss-Newton updates per trial
    point (0 returns the trial point unchanged). The linearisation point's workspace states
    and Jacobians are computed once per linearisation point and reused for every trial.
    """

    def __init__(self, robot, keys: Sequence[int], iterations: int = 2, damping: float = 1e-9):
        self.robot = robot
        self.keys = list(keys)
        self.iterations = int(iterations)
        self.damping = float(damping)
        self._base: tuple[bytes, np.ndarray, np.ndarray] | None = None

    def _linearisation(self, values: gtsam.Values) -> tuple[np.ndarray, np.ndarray]:
        theta = values_to_states(values, self.keys)
        tag = theta.tobytes()
        if self._base is None or self._base[0] != tag:
            states = workspace_states(self.robot, theta, jacobians=True)
            self._base = (tag, states.x, states.jacobian)
        return self._base[1], self._base[2]

    def __call__(self, values: gtsam.Values, delta: gtsam.VectorValues,
                 candidate: gtsam.Values) -> gtsam.Values:
        if self.iterations == 0:
            return candidate
        x, jac = self._linearisation(values)
        target = x + np.einsum("tij,tj->ti", jac, values_to_states(delta, self.keys))
        theta = project_to_workspace(self.robot, values_to_states(candidate, self.keys), target,
                                     self.iterations, self.damping)
        return states_to_values(theta, self.keys)
