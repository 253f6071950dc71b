"""Is a skill within the arm's reach at all? A unit check before planning.

Demonstrations recorded in millimetres or centimetres learn a prior hundreds of metres from
the robot; planned as is, every state is out of reach and the plan can say nothing useful.
:func:`check_reach` refuses positions farther from the robot's base than REACH_FACTOR times
the arm's reach and names the likely unit mistake.

The reach is an upper bound on the end effector's distance from the base origin: the length
of the kinematic chain base -> joint origins -> end effector (``robot.frame_positions``),
largest over the neutral and 32 seeded random configurations (Jaco2 1.26 m, Sawyer 1.43 m).
"""
from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.validation import ERRORS
from skillplan.validation import as_trailing

#: positions farther from the base than this many reaches are refused (a different base
#: frame or a skill partly out of reach stays below it; a unit mistake lands far above)
REACH_FACTOR = 3.0
#: (divisor, what the positions then look like, the fix), tried in this order
_UNITS = ((100.0, "centimetres", "divide by 100"), (1000.0, "millimetres", "divide by 1000"))
#: reach_radius per robot (its kinematics do not change)
_REACH: "weakref.WeakKeyDictionary[Any, float]" = weakref.WeakKeyDictionary()


def reach_radius(robot: Any) -> float:
    """Upper bound [m] on the end effector's distance from the base origin (module docstring);
    computed once per robot."""
    try:
        return _REACH[robot]
    except (KeyError, TypeError):
        pass
    reach = _reach_radius(robot)
    try:
        _REACH[robot] = reach
    except TypeError:                      # not weakly referenceable: not cached
        pass
    return reach


def _reach_radius(robot: Any) -> float:
    rng = np.random.default_rng(0)
    q = np.stack([robot.neutral_configuration()]
                 + [robot.random_configuration(rng) for _ in range(32)])
    points = robot.frame_positions(q)                                  # (33, L, 3)
    chain = np.linalg.norm(points[:, 0], axis=-1) + np.linalg.norm(
        np.diff(points, axis=1), axis=-1).sum(axis=1)
    return float(chain.max())


def check_reach(robot: Any, positions: Any, name: str = "prior") -> None:
    """Refuse positions (..., 3) [m] farther than REACH_FACTOR reaches from the robot's base.

    InvalidParameterError naming ``name``, the farthest distance, the reach and, when dividing
    by 100 or 1000 brings the positions within reach, the likely unit ("positions look like
    millimetres: divide by 1000").
    """
    positions = as_trailing(positions, f"{name} positions", (3,), None, ERRORS)
    if positions.size == 0:
        return
    farthest = float(np.linalg.norm(positions, axis=-1).max())
    reach = reach_radius(robot)
    if farthest <= REACH_FACTOR * reach:
        return
    label = getattr(robot, "name", "the robot")
    hint = "expected metres in the robot's base frame"
    for divisor, unit, fix in _UNITS:
        if farthest / divisor <= reach:
            hint = f"positions look like {unit}: {fix} (expected metres)"
            break
    raise InvalidParameterError(
        f"{name}: positions reach {farthest:.4g} m from the base of {label}, more than "
        f"{REACH_FACTOR:g} x its reach of {reach:.3g} m; {hint}")


def check_prior_reach(prior: Any, robot: Any) -> None:
    """:func:`check_reach` on a workspace prior's mean positions (T, 3)."""
    check_reach(robot, np.asarray(prior.mean)[:, :3], "prior")
