"""Skill tube: the end effector kept where the demonstrations agree. One unary factor per
support state, a constraint hinge on the distance from where the skill goes:

e_i = max(0, |p_i - r_i| - (limit_i - margin_i) + s_i) (1,) [m], p_i = fk(q_i),

with r (T, 3) the reference (the prior's mean conditioned on the plan's targets,
:func:`clamp.planning.reference.skill_reference`), limit (T,) [m] the verdict's
(:data:`clamp.prior.skill.TUBE_RATIO` tube radii, :func:`clamp.prior.skill.skill_checks`), margin a
fraction :data:`MARGIN` of it (the factor pulls from inside the limit, so that the optimum
keeps within it) and s the augmented Lagrangian's shift. d e / d theta_i = [u^T J(q_i), 0],
u = (p_i - r_i) / |p_i - r_i|. Inactive factors are left out.

The planner adds it when a collision-free optimum leaves the skill's tube (a lazy constraint,
:meth:`SkillTubeFamily.joining`): the tie to the free plan's posture let the hand go around an
obstacle where the demonstrations agree, when the arm could have gone around it instead. Its
check (:meth:`SkillTubeFamily.check`) is the verdict's skill check
(:func:`clamp.prior.skill.skill_checks`, which names the part of the skill and the obstacle): in
the solve only with obstacles and on a plan that meets every other check; a plan that does not
complete the skill is refused (not a constraint to tighten: another start is tried). The
verdict adds the plausibility score (:meth:`SkillTubeFamily.for_verdict`).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.prior.skill import (TUBE_RATIO, SkillRegion, skill_checks, skill_plausibility,
                               statistic)
from clamp.validation import as_array, as_scalar

from .family import CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow

#: the hinge starts this fraction of the limit inside it
MARGIN = 0.1
#: [m] below this distance the direction of the deviation is undefined (the hinge is inactive)
_NEAR = 1e-12


class SkillTubeFamily(Family):
    """One factor per support state: reference (T, 3) [m], limit (T,) [m] on the distance from
    it, hinge noise sigma [m]."""

    name = "skill_tube"
    arity = 1
    kinematics = 1
    role = "constraint"
    lazy = True
    #: [demonstration spreads] beyond the limit: 10 % of the tube (issue 27)
    near = 0.1 * TUBE_RATIO
    check_rank = 40
    only_if_clear = True

    def __init__(self, reference: Any, limit: Any, sigma: float):
        self.reference = as_array(reference, "reference", (None, 3))
        T = len(self.reference)
        self.limit = as_array(limit, "limit", (T,))
        if np.any(self.limit <= 0.0):
            raise InvalidParameterError(f"limit: expected positive distances ({T},), got a minimum of "
                             f"{float(self.limit.min())}")
        super().__init__(np.arange(T), 1, sigma=as_scalar(sigma, "sigma",
                                                          strictly_positive=True))

    @classmethod
    def check(cls, context: CheckContext, theta: np.ndarray) -> ConstraintCheck | None:
        """The skill checks of the plan's end-effector path (the solve's: only with obstacles,
        without the score; the verdict's with it); amount: the largest distance from where the
        skill goes in tube radii beyond :data:`~clamp.prior.skill.TUBE_RATIO`."""
        if not (context.final or context.obstacles):
            return None
        path = context.robot.fk(theta[:, :context.robot.n])
        skill = skill_checks(context.prior, context.reference, path, context.goal_given,
                             describe_pusher=context.pusher(path), score=context.final)
        return ConstraintCheck(cls.name, not skill.within_tube,
                               max(0.0, float(skill.ratio[skill.worst]) - TUBE_RATIO),
                               skill.reasons, skill, accepted=skill.completed, listed=False)

    @classmethod
    def for_verdict(cls, context: CheckContext, theta: np.ndarray,
                    record: ConstraintCheck) -> ConstraintCheck:
        """The solve's record with the plausibility score the verdict reports."""
        skill = record.report
        if np.isfinite(skill.plausibility):
            return record
        region = SkillRegion.of(context.prior)
        path = context.robot.fk(theta[:, :context.robot.n])
        value = float(skill_plausibility(region, context.prior, context.reference,
                                         statistic(region, np.asarray(context.reference.mean)[:, :3],
                                                   path)))
        return replace(record, report=replace(skill, plausibility=value))

    @classmethod
    def joining(cls, context: CheckContext) -> "SkillTubeFamily":
        """The tube around where the skill goes (the reference's path), at TUBE_RATIO tube
        radii, with the obstacle hinges' noise."""
        return cls(np.asarray(context.reference.mean)[:, :3],
                   TUBE_RATIO * SkillRegion.of(context.prior).tube, context.config.model.sigma_obs)

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        x, dx = window.workspace()
        i = window.local(self.first[rows])
        offset = x[i, :3] - self.reference[self.first[rows]]
        distance = np.linalg.norm(offset, axis=1)
        near = distance > _NEAR
        value = np.where(near, distance - (1.0 - MARGIN) * self.limit[self.first[rows]], -np.inf)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            u = offset[states] / distance[states, None]
            return np.einsum("kj,kjc->kc", u, dx[i[states], :3])[:, None, :]
        return Constraint(value[:, None], jacobian if jacobians else None)
