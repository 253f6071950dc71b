"""End-effector orientation family: the tool's rotation kept within an angle of a target.

One unary factor per support state of a window. Two kinds of target:

- a free axis: the tool axis ``axis`` (3,) (end-effector frame) against a base-frame
  ``direction`` (3,), angle a = arccos(R a_tool . d) (e.g. tool z vertical: axis (0, 0, 1),
  direction (0, 0, -1) for pointing down); rotation about the direction is free;
- a full rotation ``rotation`` (3, 3): a = the angle of R_target^T R.

Residual (1,) [rad]: the hinge e = max(0, a - (tolerance - margin)); the factor pulls from
``margin`` inside the tolerance, so the soft optimum still lies within it. Jacobians
(analytic, w_j the angular Jacobian's column j from ``robot.ee_rotation``):
axis: d a / d q_j = -w_j . (z x d) / |z x d| with z = R a_tool; rotation: d a / d q_j =
(R_target u) . w_j with u the unit axis of R_target^T R; zero for qdot. Inactive factors are
left out. :meth:`OrientationFamily.angles` gives the angle of every state of the window (the
violation the planner reports and the figure plots); the check (:meth:`OrientationFamily.check`)
is the largest angle beyond the tolerance, :meth:`OrientationFamily.violation`.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.validation import as_array, as_count, as_indices, as_scalar

from .family import CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow


def _unit(v: Any, name: str) -> np.ndarray:
    v = as_array(v, name, (3,))
    norm = float(np.linalg.norm(v))
    if norm < 1e-12:
        raise InvalidParameterError(f"{name}: expected a non-zero direction (3,), got {v}")
    return v / norm


def _rotation(R: Any) -> np.ndarray:
    R = as_array(R, "rotation", (3, 3))
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise InvalidParameterError("rotation: expected a proper rotation matrix (3, 3)")
    return R


class OrientationFamily(Family):
    """Tool orientation within ``tolerance`` [rad] of a target at the support states
    ``indices``: give ``axis`` and ``direction`` (free axis) or ``rotation``; ``sigma``
    [rad] the hinge noise, ``margin`` [rad] how far inside the tolerance it starts."""

    name = "orientation"
    arity = 1
    kinematics = 1
    role = "constraint"

    def __init__(self, indices: Sequence[int], *, tolerance: float,
                 axis: Any = None, direction: Any = None, rotation: Any = None,
                 sigma: float = 3e-3, margin: float | None = None):
        indices = np.unique(as_indices(indices, "indices"))
        if not len(indices):
            raise InvalidParameterError("indices: expected at least one support-state index, "
                                        "got none")
        if (rotation is None) == (axis is None or direction is None):
            raise InvalidParameterError("orientation target: give either rotation (3, 3) or "
                                        "both axis (3,) and direction (3,)")
        self.tolerance = as_scalar(tolerance, "tolerance", strictly_positive=True)
        self.margin = as_scalar(0.1 * self.tolerance if margin is None else margin, "margin",
                                minimum=0.0)
        if self.margin >= self.tolerance:
            raise InvalidParameterError(f"margin: expected less than the tolerance "
                                        f"{self.tolerance}, got {self.margin}")
        self.rotation = None if rotation is None else _rotation(rotation)
        self.axis = None if axis is None else _unit(axis, "axis")
        self.direction = None if direction is None else _unit(direction, "direction")
        super().__init__(indices, 1, sigma=as_scalar(sigma, "sigma", strictly_positive=True))

    @classmethod
    def window(cls, num_states: int, fraction: float, **target: Any) -> OrientationFamily:
        """The family over the last ``fraction`` (0, 1] of ``num_states`` support states."""
        num_states = as_count(num_states, "num_states")
        fraction = as_scalar(fraction, "fraction", strictly_positive=True)
        if fraction > 1:
            raise InvalidParameterError(f"fraction: expected at most 1, got {fraction}")
        first = int(np.floor((1.0 - fraction) * num_states))
        return cls(np.arange(first, num_states), **target)

    def _angles(self, robot: Any, q: np.ndarray, jacobians: bool
                ) -> tuple[np.ndarray, np.ndarray | None]:
        """Angles (K,) [rad] at q (K, n) and d angle / d q (K, n)."""
        R, W = robot.ee_rotation(q, jacobians=jacobians)
        if self.rotation is None:
            z = R @ self.axis
            cosine = np.clip(z @ self.direction, -1.0, 1.0)
            cross = np.cross(z, self.direction)
            sine = np.linalg.norm(cross, axis=1)
            angle = np.arctan2(sine, cosine)
            if not jacobians:
                return angle, None
            unit = cross / np.maximum(sine, 1e-12)[:, None]
            return angle, -np.einsum("kj,kjn->kn", unit, W)
        E = self.rotation.T @ R                                        # (K, 3, 3)
        vee = np.stack([E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0],
                        E[:, 1, 0] - E[:, 0, 1]], axis=1)              # 2 sin(a) u
        trace = np.trace(E, axis1=1, axis2=2)
        sine2 = np.linalg.norm(vee, axis=1)
        angle = np.arctan2(sine2, trace - 1.0)
        if not jacobians:
            return angle, None
        u = vee / np.maximum(sine2, 1e-12)[:, None]
        return angle, np.einsum("kj,kjn->kn", u @ self.rotation.T, W)

    def angles(self, robot: Any, q: np.ndarray) -> np.ndarray:
        """Angle (F,) [rad] from the target at every factor's state, for joint positions q
        (T, n) of the whole plan."""
        if not callable(getattr(robot, "ee_rotation", None)):
            raise ClampTypeError(f"robot: expected a robots.Robot, got {type(robot).__name__}")
        q = as_array(q, "q", (None, robot.n))
        if len(q) <= self.first[-1]:
            raise ShapeError(f"q: expected the joint positions of every support state (at least "
                             f"{self.first[-1] + 1} for this family), got {len(q)}")
        return self._angles(robot, q[self.first], False)[0]

    def violation(self, robot: Any, q: np.ndarray) -> float:
        """Largest angle beyond the tolerance [rad] over the window (0.0: met)."""
        return float(max(0.0, np.max(self.angles(robot, q)) - self.tolerance))

    def check(self, context: CheckContext, theta: np.ndarray) -> ConstraintCheck:
        """:meth:`violation` of the plan [rad]: violated when positive."""
        value = float(self.violation(context.robot, theta[:, :context.robot.n]))
        reasons = (f"{self.name} constraint violated by {value:.4g} beyond its tolerance "
                   f"{self.tolerance:.4g}",) if value > 0.0 else ()
        return ConstraintCheck(self.name, value > 0.0, value, reasons)

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        i = window.local(self.first[rows])
        angle, grad = self._angles(window.robot, window.q[i], jacobians)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            n = window.n
            jac = np.zeros((len(states), 1, 2 * n))
            jac[:, 0, :n] = grad[states]
            return jac
        return Constraint((angle - (self.tolerance - self.margin))[:, None],
                          jacobian if jacobians else None)
