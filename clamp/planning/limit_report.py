"""Joint-limit violations of a trajectory in words, with the numbers: which joint, at which
state, by how much, and how many states are out (used by the plan verdict)."""
from __future__ import annotations

from typing import Any

import numpy as np


def _worst(excess: np.ndarray) -> tuple[int, int, float] | None:
    """(state, joint, amount) of the largest positive entry of excess (T, n), or None."""
    if not np.any(excess > 0):
        return None
    state, joint = np.unravel_index(int(np.argmax(excess)), excess.shape)
    return int(state), int(joint), float(excess[state, joint])


def limit_violations(robot: Any, q: np.ndarray, qdot: np.ndarray | None,
                     position_tolerance: float = 0.0, velocity_tolerance: float = 0.0,
                     what: str = "plan") -> list[str]:
    """Reasons (empty when none) for positions q (T, n) [rad] outside
    [robot.lower_limits, robot.upper_limits] by more than ``position_tolerance`` and
    velocities qdot (T, n) [rad/s] beyond robot.velocity_limits by more than
    ``velocity_tolerance``; each names the worst joint, its state, the excess and the limit."""
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
        vmax = np.asarray(robot.velocity_limits)
        over = np.abs(np.atleast_2d(qdot)) - vmax
        fast = over > velocity_tolerance
        worst = _worst(np.where(fast, over, 0.0))
        if worst is not None:
            state, joint, amount = worst
            reasons.append(f"{what}: joint {names[joint]} moves {amount:.4g} rad/s faster than "
                           f"its limit {vmax[joint]:.4g} rad/s at state {state} "
                           f"({int(np.count_nonzero(fast.any(axis=1)))} of {len(fast)} states "
                           "beyond the velocity limits)")
    return reasons
