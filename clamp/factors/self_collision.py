"""Self-collision family: one factor per step i -> i + 1, every kept sphere pair in one residual.

The factor of step i checks the configurations q(tau) = (1 - tau) q_i + tau q_{i+1} at
tau = 0, 1 / (B + 1), ..., 1 (both support states and B = ``between`` in between: the motion
the collision checker verifies is linear in joint space too). For sphere pair p = (a, b)
(centres c, radii r [m]) its residual is the worst hinge over those configurations:

    e_p = max_tau max(0, eps_p - (|c_a(q(tau)) - c_b(q(tau))| - r_a - r_b))

eps_p = min(epsilon, the gap the pair keeps in 95 % of random configurations): a pair that is
structurally closer than epsilon (the Sawyer's base and shoulder) is only kept from overlapping.

with d e_p / d q_i = (1 - tau*) g, d e_p / d q_{i+1} = tau* g, g = -u^T (d c_a / d q - d c_b / d q)
at the worst tau* (u = (c_a - c_b) / |c_a - c_b|) where the hinge is active, 0 otherwise, 0 for
qdot. Checking only the support states lets the optimiser swing a link through another between
two of them (seen on the Jaco: a 0.8 rad step through the base). The spheres are the robot's
collision spheres plus constant ones on the base; the pairs are those of
:func:`robots.self_collision.self_collision_spheres` (links neither the same body nor parent and
child, that come within reach in some configuration, not overlapping almost always), computed
once per robot. Centre Jacobians only for factors with an active hinge; the others are left out.

A lazy constraint: its check (:meth:`SelfCollisionFamily.check`) is the verdict's
self-collision report on the URDF collision geometry (:func:`robots.self_collision_report`),
run on every plan; the hinges join the solve (:meth:`SelfCollisionFamily.joining`, checking
:data:`BETWEEN` configurations in every step) when it first finds a collision.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError
from robots.self_collision import (SPHERE_REACH, SelfCollisionSpheres, self_collision_report,
                                   self_collision_spheres)
from clamp.validation import as_count, as_scalar

from robots.contact import collision_reason

from .family import SKILL_CLOCK, CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow

#: |c_a - c_b| below this [m] counts as coincident centres (the direction u is then +x)
_COINCIDENT = 1e-12
#: configurations checked between two states by the hinges the planner adds (a count; see
#: docs/decisions.md#self_collision_between)
BETWEEN = 8
#: [m] the self-collision check's tolerance on a clear plan's clearance (collisions and depths
#: exact; see docs/decisions.md#self_clearance_tolerance)
CLEARANCE_TOLERANCE = 0.01


#: [m] safety distance of the hinges the planner adds when a plan collides with itself (capped
#: per sphere pair at the gap the pair keeps in 95 % of random configurations)
SAFETY_DISTANCE = 0.03
#: [m] their noise
SIGMA = 5e-4


class SelfCollisionFamily(Family):
    """Self-collision hinges between the sphere pairs of ``spheres`` (a
    :class:`robots.self_collision.SelfCollisionSpheres`) on the steps that start at support
    states ``indices`` (each factor connects i and i + 1). epsilon [m]: clearance the hinge
    keeps; sigma [m]: noise of each hinge residual; between: configurations checked strictly
    inside each step (module docstring)."""

    name = "self_collision"
    arity = 2
    kinematics = 2
    role = "constraint"
    lazy = True
    #: [m] of overlap between two links: a hair short (issue 27)
    near = 0.0015
    check_rank = 10

    def __init__(self, indices: Sequence[int], spheres: SelfCollisionSpheres, epsilon: float, sigma: float,
                 between: int = 4):
        if not isinstance(spheres, SelfCollisionSpheres):
            raise ClampTypeError(f"spheres: expected a robots.self_collision.SelfCollisionSpheres "
                                    f"(self_collision_spheres(robot)), got {type(spheres).__name__}")
        if not len(spheres.first):
            raise InvalidParameterError("spheres: the robot has no sphere pair that can come within reach")
        self.spheres = spheres
        self.epsilon = as_scalar(epsilon, "epsilon", minimum=0.0, maximum=SPHERE_REACH)
        self.between = as_count(between, "between", minimum=0)
        #: tau of the configurations checked on every step (between + 2,)
        self.tau = np.linspace(0.0, 1.0, self.between + 2)
        #: clearance [m] each pair is held to: epsilon, or less where the pair keeps less in most
        #: configurations (``spheres.clearance``)
        self.pair_epsilon = np.minimum(self.epsilon, spheres.clearance)
        self._reach = self.pair_epsilon + spheres.radii[spheres.first] + spheres.radii[spheres.second]   # (P,)
        super().__init__(indices, len(spheres.first), sigma=sigma)

    @classmethod
    def for_robot(cls, robot, states: Sequence[int], epsilon: float, sigma: float,
                  between: int = 4) -> "SelfCollisionFamily":
        """The family of ``robot`` (:func:`robots.self_collision.self_collision_spheres`,
        computed once per robot) on the steps i -> i + 1 of the support states i in ``states``
        (``range(T - 1)``: a whole plan of T states). epsilon at most SPHERE_REACH (0.1 m)."""
        return cls(states, self_collision_spheres(robot), epsilon, sigma, between)

    @classmethod
    def check(cls, context: CheckContext, theta: np.ndarray) -> ConstraintCheck:
        """The plan's self-collision report on the URDF collision geometry; amount [m]: the
        deepest overlap."""
        report = self_collision_report(context.robot, theta[:, :context.robot.n], context.time,
                                       tolerance=CLEARANCE_TOLERANCE)
        return ConstraintCheck(cls.name, bool(report.collision),
                               max(0.0, -float(report.min_distance)) if report.collision else 0.0,
                               (collision_reason(report, SKILL_CLOCK),) if report.collision else (), report,
                               listed=False)

    @classmethod
    def joining(cls, context: CheckContext) -> "SelfCollisionFamily":
        """The hinges on every step of the plan, at :data:`SAFETY_DISTANCE` and
        :data:`SIGMA`."""
        return cls.for_robot(context.robot, range(context.num_states - 1), SAFETY_DISTANCE,
                             SIGMA, BETWEEN)

    def _centres(self, robot, q: np.ndarray, jacobians: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Centres (M, S + B, 3) of the robot's and the fixed spheres at q (M, n), and their
        Jacobians (M, S + B, 3, n) (zero for the fixed ones) if asked."""
        moving, jac = robot.sphere_centres(q, jacobians=jacobians)
        fixed = self.spheres.fixed_centres
        centres = np.concatenate([moving, np.broadcast_to(fixed, (len(q),) + fixed.shape)], axis=1)
        if jacobians:
            jac = np.concatenate([jac, np.zeros((len(q),) + fixed.shape + (q.shape[1],))], axis=1)
        return centres, jac

    def _distances(self, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centre offsets (..., P, 3) and distances (..., P) of the pairs."""
        offset = centres[..., self.spheres.first, :] - centres[..., self.spheres.second, :]
        return offset, np.sqrt(np.einsum("...k,...k->...", offset, offset))

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        sp, n, C = self.spheres, window.n, len(self.tau)
        i = window.local(self.first[rows])
        q0, q1 = window.q[i], window.q[i + 1]
        used = np.unique(np.concatenate([i, i + 1]))                                       # window rows
        moving = window.sphere_centres()[used]
        fixed = np.broadcast_to(sp.fixed_centres, (len(used),) + sp.fixed_centres.shape)
        _, at_state = self._distances(np.concatenate([moving, fixed], axis=1))            # (K', P)
        start, end = at_state[np.searchsorted(used, i)], at_state[np.searchsorted(used, i + 1)]     # (R, P)
        least = np.minimum(start, end)
        worst = np.where(end < start, C - 1, 0)                                           # (R, P) tau index
        # in between, a pair's distance is at least the mean of its end distances minus half the
        # motion bound of its two spheres: only steps where that leaves a hinge open are sampled
        motion = np.abs(q1 - q0) @ sp.motion_radius.T                                     # (R, S + B)
        floor = 0.5 * (start + end - motion[:, sp.first] - motion[:, sp.second])
        # the shift (read, not added: the base class adds it) widens the steps that can be open
        r, p = np.nonzero(floor < self._reach + self.offset(rows))                        # open (step, pair)
        if r.size and C > 2:
            inside, r = np.unique(r, return_inverse=True)
            qs = q0[inside, None] + self.tau[None, 1:-1, None] * (q1 - q0)[inside, None]  # (R', C - 2, n)
            centres, _ = self._centres(window.robot, qs.reshape(-1, n), False)
            centres = centres.reshape(len(inside), C - 2, -1, 3)
            offset = centres[r, :, sp.first[p]] - centres[r, :, sp.second[p]]            # (M, C - 2, 3)
            between = np.sqrt(np.einsum("mck,mck->mc", offset, offset))
            closest = np.argmin(between, axis=1)
            value = between[np.arange(len(r)), closest]
            smaller = value < least[inside[r], p]
            least[inside[r[smaller]], p[smaller]] = value[smaller]
            worst[inside[r[smaller]], p[smaller]] = closest[smaller] + 1
        value = self._reach - least                                                       # (R, P)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            # centre Jacobians at the worst configuration of every active pair (each one once)
            r, p = np.nonzero(active)
            c = worst[states[r], p]
            tau = self.tau[c]
            configs, index = np.unique(np.stack([states[r], c], axis=1), axis=0,
                                       return_inverse=True)
            q_worst = q0[configs[:, 0]] + self.tau[configs[:, 1], None] * (q1 - q0)[configs[:, 0]]
            centres, centre_jac = self._centres(window.robot, q_worst, True)
            index = index.reshape(-1)
            offset = centres[index, sp.first[p]] - centres[index, sp.second[p]]           # (A, 3)
            d = np.linalg.norm(offset, axis=1)
            direction = np.where(d[:, None] > _COINCIDENT,
                                 offset / np.maximum(d, _COINCIDENT)[:, None],
                                 np.array([1.0, 0.0, 0.0]))
            relative = centre_jac[index, sp.first[p]] - centre_jac[index, sp.second[p]]   # (A, 3, n)
            g = -np.einsum("ak,akj->aj", direction, relative)                             # (A, n)
            jac = np.zeros((len(states), self.dim, 4 * n))
            jac[r, p, :n] = (1.0 - tau)[:, None] * g
            jac[r, p, 2 * n:3 * n] = tau[:, None] * g
            return jac
        return Constraint(value, jacobian if jacobians else None)
