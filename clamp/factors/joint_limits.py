"""Joint-limit family: hinges on the joint positions and velocities of every support state.

e = [max(0, max(lo + m - q, q - (hi - m))),  max(0, |qdot| - (vmax - mv))]  (2n,)
with margins m [rad], mv [rad/s] (the nearer limit's hinge: the two sides of a joint cannot both
be out); infinite limits (continuous joints) give zero rows. Only states with an active hinge
are returned (the others are exactly zero; hinge and shift are the base class's).

Its check (:meth:`JointLimitFamily.check`, which the verdict makes on every plan) is the
robot's own limits with the checks' tolerances, in words with the numbers
(:func:`limit_violations`: which joint, at which state, by how much, how many states are out);
velocities between the states too: the peak of each segment's cubic Hermite interpolation of
positions and velocities (:func:`robots.trajectory.interpolated_speed`, what a trajectory
controller executes; a plan whose joints jump between states faster than their velocities say
is beyond the limit there, whatever its states' velocities).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.validation import as_array, as_scalar
from robots.trajectory import interpolated_speed

from .family import CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow

#: [rad] the verdict's tolerance on the joint position limits (the hinges are soft: a plan on a
#: limit may end this hair beyond it)
LIMIT_TOLERANCE = 1e-4
#: [rad/s] the verdict's tolerance on the joint velocity limits (also the time stage's:
#: :func:`clamp.planning.time_scale.needed_scale`)
VELOCITY_TOLERANCE = 1e-3
#: [rad/s] the planner's velocity hinges start this far inside the limits (a plan on a velocity
#: limit otherwise ends a hair beyond it between states; docs/decisions.md#velocity_margin)
VELOCITY_MARGIN = 0.01


def _worst(excess: np.ndarray) -> tuple[int, int, float] | None:
    """(state, joint, amount) of the largest positive entry of excess (T, n), or None."""
    if not np.any(excess > 0):
        return None
    state, joint = np.unravel_index(int(np.argmax(excess)), excess.shape)
    return int(state), int(joint), float(excess[state, joint])


def limit_violations(robot: Any, q: np.ndarray, qdot: np.ndarray | None,
                     position_tolerance: float = 0.0, velocity_tolerance: float = 0.0,
                     what: str = "plan", time: np.ndarray | None = None) -> list[str]:
    """Reasons (empty when none) for positions q (T, n) [rad] outside
    [robot.lower_limits, robot.upper_limits] by more than ``position_tolerance`` and
    velocities qdot (T, n) [rad/s] beyond robot.velocity_limits by more than
    ``velocity_tolerance``; each names the worst joint, its state, the excess and the limit.
    With ``time`` (T,) [s], the velocities checked are those between the states
    (:func:`speeds`)."""
    q = np.atleast_2d(q)
    names = robot.joint_names
    lower, upper = np.asarray(robot.lower_limits), np.asarray(robot.upper_limits)
    reasons = []
    below, above = lower - q, q - upper
    out = (below > position_tolerance) | (above > position_tolerance)
    worst = _worst(np.where(out, np.maximum(below, above), 0.0))
    if worst is not None:
        state, joint, amount = worst
        side, limit = ("below its lower", lower[joint]) if below[state, joint] > 0 else \
            ("above its upper", upper[joint])
        where = "" if len(q) == 1 else (
            f" at state {state} ({int(np.count_nonzero(out.any(axis=1)))} of {len(q)} states "
            "outside the position limits)")
        reasons.append(f"{what}: joint {names[joint]} is {amount:.4g} rad {side} limit "
                       f"{limit:.4g} rad{where}")
    if qdot is not None:
        reasons += velocity_violations(robot, q, qdot, velocity_tolerance, what, time)
    return reasons


def velocity_violations(robot: Any, q: np.ndarray, qdot: np.ndarray,
                        velocity_tolerance: float = 0.0, what: str = "plan",
                        time: np.ndarray | None = None) -> list[str]:
    """The velocity part of :func:`limit_violations`: a reason (or none) for velocities qdot
    (T, n) [rad/s] (between the states with ``time`` (T,) [s]) of positions q (T, n) beyond
    robot.velocity_limits by more than ``velocity_tolerance``."""
    vmax = np.asarray(robot.velocity_limits)
    over = speeds(q, qdot, time) - vmax
    fast = over > velocity_tolerance
    worst = _worst(np.where(fast, over, 0.0))
    if worst is None:
        return []
    state, joint, amount = worst
    where, unit = ((f"at state {state}", "states") if time is None else
                   (f"between states {state} and {state + 1}", "segments"))
    return [f"{what}: joint {robot.joint_names[joint]} moves {amount:.4g} rad/s faster than "
            f"its limit {vmax[joint]:.4g} rad/s {where} "
            f"({int(np.count_nonzero(fast.any(axis=1)))} of {len(fast)} {unit} "
            "beyond the velocity limits)"]


def speeds(q: np.ndarray, qdot: np.ndarray, time: np.ndarray | None = None) -> np.ndarray:
    """|qdot| (T, n) [rad/s] at the states, or with ``time`` (T,) [s] and T >= 2 the peak speed
    of each segment between them (T-1, n; :func:`robots.trajectory.interpolated_speed`)."""
    qdot = np.atleast_2d(qdot)
    if time is None or len(qdot) < 2:
        return np.abs(qdot)
    return interpolated_speed(q, qdot, time)


class JointLimitFamily(Family):
    """One factor per support state in ``indices``, isotropic noise ``sigma``."""

    name = "joint_limits"
    arity = 1
    kinematics = 0
    role = "constraint"
    check_rank = 20
    always_checked = True
    #: [rad or rad/s] beyond a limit: a hair short (about 3 % of a limit; issue 27)
    near = 0.03

    def __init__(self, indices: Sequence[int], lower: np.ndarray, upper: np.ndarray,
                 velocity_limits: np.ndarray, sigma: float, margin: float = 0.0,
                 velocity_margin: float = 0.0):
        lower = as_array(lower, "lower", ("n",), allow_infinite=True)
        upper = as_array(upper, "upper", (len(lower),), allow_infinite=True)
        velocity_limits = as_array(velocity_limits, "velocity_limits", (len(lower),),
                                   allow_infinite=True)
        if np.any(lower > upper):
            j = int(np.argmax(lower > upper))
            raise InvalidParameterError(f"lower: expected lower <= upper joint limits, got "
                                        f"lower[{j}] = {lower[j]} > upper[{j}] = {upper[j]} rad")
        if np.any(velocity_limits < 0):
            raise InvalidParameterError(f"velocity_limits: expected limits >= 0 rad/s, got "
                                        f"{float(velocity_limits.min())}")
        margin = as_scalar(margin, "margin", minimum=0.0)
        velocity_margin = as_scalar(velocity_margin, "velocity_margin", minimum=0.0)
        self.low = lower + margin
        self.high = upper - margin
        self.vmax = velocity_limits - velocity_margin
        super().__init__(indices, 2 * len(self.low), sigma=sigma)

    @classmethod
    def check(cls, context: CheckContext, theta: np.ndarray) -> ConstraintCheck:
        """The robot's limits with the checks' tolerances (:func:`limit_violations`); amount:
        the largest excess over a limit [rad or rad/s]. The verdict's (``context.final``)
        checks positions and velocities; the solve's judge positions only: velocities are the
        time stage's (:mod:`clamp.planning.time_scale`), never a constraint to repair."""
        robot = context.robot
        q = theta[:, :robot.n]
        reasons = limit_violations(robot, q, None, LIMIT_TOLERANCE)
        excess = max(float(np.max(np.asarray(robot.lower_limits) - q)),
                     float(np.max(q - np.asarray(robot.upper_limits))), 0.0)
        record = ConstraintCheck(cls.name, bool(reasons), excess if reasons else 0.0,
                                 tuple(reasons), reasons, listed=False)
        return cls.for_verdict(context, theta, record) if context.final else record

    @classmethod
    def for_verdict(cls, context: CheckContext, theta: np.ndarray,
                    record: ConstraintCheck) -> ConstraintCheck:
        """The judge's ``record`` (positions) with the velocities between the states checked."""
        robot = context.robot
        q, qdot = theta[:, :robot.n], theta[:, robot.n:]
        fast = velocity_violations(robot, q, qdot, VELOCITY_TOLERANCE, time=context.time)
        if not fast:
            return record
        excess = float(np.max(speeds(q, qdot, context.time) - np.asarray(robot.velocity_limits)))
        reasons = [*record.reasons, *fast]
        return ConstraintCheck(cls.name, True, max(record.amount, excess), tuple(reasons),
                               reasons, listed=False)

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        i = window.local(self.first[rows])
        q, qdot = window.q[i], window.qdot[i]
        below, above = self.low - q, q - self.high
        value = np.concatenate([np.maximum(below, above), np.abs(qdot) - self.vmax], axis=1)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            side = np.where(below[states] > above[states], -1.0, 1.0)
            slope = np.where(active, np.concatenate([side, np.sign(qdot[states])], axis=1), 0.0)
            d = slope.shape[1]
            jac = np.zeros((len(states), d, d))
            jac[:, np.arange(d), np.arange(d)] = slope
            return jac
        return Constraint(value, jacobian if jacobians else None)
