"""Skill orientation: the hand turned as the demonstrations turn it, for a pose prior. One
unary factor per support state, a constraint hinge on the angle from where the skill turns the
hand:

e_i = max(0, a_i - (limit_i - margin_i) + s_i) (1,) [rad], a_i = |log(Rref_i^T R(q_i))|,

with Rref (T, 3, 3) the reference (the orientation chain's mean conditioned on the plan's start,
goal and via rotations), limit (T,) [rad] the verdict's (TUBE_RATIO x the floored orientation
spread, :mod:`clamp.prior.orientation_skill`), margin a fraction MARGIN of it and s the
augmented Lagrangian's shift. d a / d theta_i = [(R u)^T W, 0], u the unit rotation axis of
Rref^T R (the log map's right Jacobian leaves its own axis unchanged). Inactive factors are left
out.

Like the position tube (:mod:`clamp.factors.skill_tube`) it is lazy: it joins the solve when a
collision-free optimum turns the hand out of the skill, and its check is the verdict's
orientation check (:func:`clamp.prior.orientation_skill.orientation_checks`); a plan that does
not end turned as the demonstrations end (without a goal rotation) is refused. Without a pose
prior it checks nothing.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from clamp.prior import so3
from clamp.prior.orientation_skill import angle_spread, orientation_checks
from clamp.prior.skill import TUBE_RATIO
from clamp.validation import as_array, as_scalar

from .family import CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow

#: the hinge starts this fraction of the limit inside it
MARGIN = 0.1
#: [rad] the hinge's noise when it joins the solve (0.6 deg)
SIGMA = 0.01
#: [rad] below this angle the axis is undefined (the hinge is inactive)
_NEAR = 1e-9


def _orientations(context: CheckContext) -> tuple[Any, Any]:
    return (getattr(context.prior, "orientation", None),
            getattr(context.reference, "orientation", None))


class SkillOrientationFamily(Family):
    """One factor per support state: reference rotations (T, 3, 3), limit (T,) [rad] on the
    angle from them, hinge noise sigma [rad]."""

    name = "skill_orientation"
    arity = 1
    kinematics = 1
    role = "constraint"
    lazy = True
    check_rank = 41
    only_if_clear = True

    def __init__(self, reference: Any, limit: Any, sigma: float = SIGMA):
        self.reference = as_array(reference, "reference", (None, 3, 3))
        self.limit = as_array(limit, "limit", (len(self.reference),))
        super().__init__(np.arange(len(self.reference)), 1,
                         sigma=as_scalar(sigma, "sigma", strictly_positive=True))

    @classmethod
    def check(cls, context: CheckContext, theta: np.ndarray) -> ConstraintCheck | None:
        """The orientation checks of the plan's hand rotations (the solve's: only with
        obstacles; the verdict's always), None without a pose prior; amount: the largest angle
        from the reference in orientation spreads beyond TUBE_RATIO."""
        orientation, reference = _orientations(context)
        if orientation is None or reference is None or not (context.final or context.obstacles):
            return None
        rotations, _ = context.robot.ee_rotation(theta[:, :context.robot.n])
        goal = context.goal_given and any(
            f.name in ("ee_rotation", "joint_target") and context.num_states - 1 in f.first
            for f in context.families)
        report = orientation_checks(orientation, reference, rotations, goal)
        return ConstraintCheck(cls.name, not report.within_tube,
                               max(0.0, float(report.ratio[report.worst]) - TUBE_RATIO),
                               report.reasons, report, accepted=report.completed, listed=False)

    @classmethod
    def joining(cls, context: CheckContext) -> "SkillOrientationFamily":
        """The hinge around where the skill turns the hand, at TUBE_RATIO orientation spreads."""
        orientation, reference = _orientations(context)
        return cls(reference.mean_rotations, TUBE_RATIO * angle_spread(orientation))

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        R, W, _, _ = window.rotation(False)
        i = window.local(self.first[rows])
        r = so3.log_map(np.swapaxes(self.reference[self.first[rows]], -1, -2) @ R[i])
        angle = np.linalg.norm(r, axis=1)
        value = np.where(angle > _NEAR, angle - (1.0 - MARGIN) * self.limit[self.first[rows]],
                         -np.inf)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            axis = np.einsum("kij,kj->ki", R[i[states]], r[states] / angle[states, None])
            n = window.n
            jac = np.zeros((len(states), 1, 2 * n))
            jac[:, 0, :n] = np.einsum("kj,kjn->kn", axis, W[i[states]])
            return jac
        return Constraint(value[:, None], jacobian if jacobians else None)
