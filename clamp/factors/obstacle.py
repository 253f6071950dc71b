"""Obstacle family: one factor per support state, all collision spheres in one residual.

e_s = max(0, eps + r_s - d(c_s)) for sphere s (centre c_s, radius r_s), d the scene's signed
distance (the planner's query clips it at eps + the largest radius, beyond which every hinge is
inactive anyway, so only the obstacles within that reach of the spheres are measured:
``scenes.Scene.query(points, max_distance)``); d e_s / d q = -grad d(c_s)^T d c_s / d q where
the hinge is active, 0 otherwise, 0 for qdot (the hinge and its shift are the base class's,
:meth:`clamp.factors.family.Family.residual`). The sphere centres of every state are computed (without Jacobians) to find the active
hinges; centre Jacobians only for the states that have one (usually a few percent): the other
factors are exactly zero and left out.

Its check (:meth:`ObstacleFamily.check`) is not the spheres: the verdict measures the plan on the
robot's own collision geometry against the scene's exact obstacles (``context.clearance``,
:func:`clamp.planning.clearance.check_clearance`), and a collision there ends the judgement.
"""
from __future__ import annotations

import copy
import inspect
from collections.abc import Callable, Sequence

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.validation import as_array, as_scalar

from robots.contact import collision_reason, describe_contact

from .family import SKILL_CLOCK, CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow

#: query(points (..., 3)) -> (signed distance (...,) [m], gradient (..., 3)); a query that
#: takes a keyword ``gradient`` (e.g. scenes.Scene.query) is asked for the distance alone
#: (``gradient=False``) where no Jacobian is needed: the error evaluations
DistanceQuery = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


def _takes_gradient(query: Callable) -> bool:
    """Whether ``query`` accepts the keyword ``gradient``."""
    try:
        return "gradient" in inspect.signature(query).parameters
    except (TypeError, ValueError):
        return False


class ObstacleFamily(Family):
    """Obstacle hinges of the spheres (radii (S,) [m]) at support states ``indices``."""

    name = "obstacle"
    arity = 1
    kinematics = 2
    role = "constraint"
    check_rank = 0
    decisive = True
    always_checked = True
    #: [m] of penetration on the collision geometry: a hair short (issue 27)
    near = 0.0015

    def __init__(self, indices: Sequence[int], radii: np.ndarray, query: DistanceQuery,
                 epsilon: float, sigma: float):
        self.radii = as_array(radii, "radii", (None,))
        if np.any(self.radii < 0):
            raise InvalidParameterError(f"radii: expected sphere radii >= 0 m, got "
                                        f"{float(self.radii.min())}")
        if not callable(query):
            raise ClampTypeError(f"query: expected a function points (..., 3) -> (distance, "
                                    f"gradient) (e.g. scene.query), got {type(query).__name__}")
        self.query = query
        self._distance_only = _takes_gradient(query)
        self.epsilon = as_scalar(epsilon, "epsilon", minimum=0.0)
        super().__init__(indices, len(self.radii), sigma=sigma)

    @classmethod
    def check(cls, context: CheckContext, theta: np.ndarray) -> ConstraintCheck | None:
        """The plan on the robot's collision geometry against the scene (None without
        obstacles): violated by a collision, or a clearance below the required
        ``config.checks.min_clearance``; amount [m]: how far below that (the deepest
        penetration when none is required)."""
        report = context.clearance(theta[:, :context.robot.n])
        if report is None:
            return None
        required = float(context.config.checks.min_clearance)
        distance = float(report.min_distance)
        if report.collision and report.fault is None and distance >= 0.0:
            reasons: tuple[str, ...] = (
                f"clearance {distance * 1e3:.1f} mm below the required min_clearance "
                f"{required * 1e3:.1f} mm: "
                f"{describe_contact(report.nearest, report.geometry, SKILL_CLOCK)}",)
        else:
            reason = collision_reason(report, SKILL_CLOCK)
            reasons = () if reason is None else (reason,)
        return ConstraintCheck(cls.name, bool(report.collision), max(0.0, required - distance),
                               reasons, report, clearance=distance, listed=False)

    def relaxed(self, floor: float) -> "ObstacleFamily | None":
        """A copy with half the safety distance epsilon (at least ``floor`` [m]), or None when
        it is there already."""
        epsilon = max(0.5 * self.epsilon, floor)
        if epsilon >= self.epsilon:
            return None
        new = copy.copy(self)
        new.epsilon = epsilon
        return new

    def widened(self, amount: float) -> "ObstacleFamily":
        """A copy whose safety distance epsilon grows by ``amount`` [m] (the penetration the
        check measured on the collision geometry), at least by ``near``: the spheres at the
        support states clear, the geometry still touches (between two states, or where the
        spheres do not cover it)."""
        new = copy.copy(self)
        new.epsilon = self.epsilon + max(float(amount), self.near)
        return new

    def penetration(self, window: StateWindow) -> float:
        """Deepest penetration [m] of a sphere into an obstacle over the family's states
        (r_s - d(c_s); negative: every sphere is clear by that much, or by at least the
        query's clip)."""
        distance = self._distance(window.sphere_centres()[window.local(self.first)])
        return float(np.max(self.radii - distance))

    def _distance(self, points: np.ndarray) -> np.ndarray:
        """The query's distances (...,) [m] at points (..., 3), without the gradient when the
        query can leave it out (the same values)."""
        if self._distance_only:
            return self.query(points, gradient=False)[0]
        return self.query(points)[0]

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        i = window.local(self.first[rows])
        reach = self.epsilon + self.radii
        if not jacobians:
            return Constraint(reach - self._distance(window.sphere_centres()[i]), None)
        distance, gradient = self.query(window.sphere_centres()[i])

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            centre_jac = window.sphere_jacobians(i[states])              # (R, S, 3, n)
            g = gradient[states] * active[..., None]
            n = centre_jac.shape[-1]
            jac = np.zeros((len(states), len(self.radii), 2 * n))
            jac[:, :, :n] = -np.einsum("rsk,rskj->rsj", g, centre_jac)
            return jac
        return Constraint(reach - distance, jacobian)
