"""Is a plan still the skill in how the hand is turned? The orientation half of the skill's
verdict (the position half is :mod:`clamp.prior.skill`), for a pose prior
(:mod:`clamp.prior.orientation_prior`).

- **with the skill**: at every step, the angle between the hand's rotation and where the skill
  turns it there (the orientation chain's mean conditioned on the plan's start, goal and via
  rotations: the *reference*), in units of that step's orientation spread (the demonstrations'
  largest angle from their mean rotation, floored at :data:`ORIENTATION_FLOOR`), stays below
  the position tube's :data:`~clamp.prior.skill.TUBE_RATIO` (4);
- **completed**: unless the caller fixed the end rotation (a pose or joint goal), the hand
  ends within :data:`~clamp.prior.skill.COMPLETION_FACTOR` (2) x the demonstrations' end
  spread (floored) of their mean end rotation.

A failure names the states, the angle, the spread and the limit in degrees.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from clamp.prior import so3
from clamp.prior.skill import COMPLETION_FACTOR, TUBE_RATIO

__all__ = ["ORIENTATION_FLOOR", "OrientationCheck", "orientation_checks", "angle_spread"]

#: [rad] smallest orientation spread (5 deg): where the demonstrations turn the hand alike, a
#: plan may still turn it 4 x this (20 deg) from the reference before it leaves the skill
ORIENTATION_FLOOR = np.radians(5.0)


def angle_spread(orientation: Any) -> np.ndarray:
    """The floored orientation spread (T,) [rad] of an OrientationPrior."""
    return np.maximum(np.asarray(orientation.angle_radius, dtype=float), ORIENTATION_FLOOR)


@dataclass(frozen=True)
class OrientationCheck:
    """The skill's orientation verdict on one path: angle (T,) [rad] from the reference
    rotation; ratio (T,) that angle in orientation spreads; worst the step of the largest
    ratio; end_angle [rad] from the demonstrations' mean end rotation; completion_angle [rad]
    its limit (None: not judged, the caller fixed the end rotation); reasons."""

    angle: np.ndarray
    ratio: np.ndarray
    worst: int
    end_angle: float
    completion_angle: float | None
    reasons: tuple[str, ...]

    @property
    def within_tube(self) -> bool:
        return float(self.ratio[self.worst]) <= TUBE_RATIO

    @property
    def completed(self) -> bool:
        return self.completion_angle is None or self.end_angle <= self.completion_angle

    def to_dict(self) -> dict[str, Any]:
        """The figures in degrees, for ``PlanResult.skill``."""
        return {"max_angle_ratio": float(self.ratio[self.worst]),
                "worst_angle_state": self.worst,
                "max_angle_deg": float(np.degrees(self.angle.max())),
                "angle_at_worst_deg": float(np.degrees(self.angle[self.worst])),
                "end_angle_deg": float(np.degrees(self.end_angle)),
                "completion_angle_deg": None if self.completion_angle is None
                else float(np.degrees(self.completion_angle))}


def orientation_checks(orientation: Any, reference: Any, rotations: np.ndarray,
                       rotation_given: bool) -> OrientationCheck:
    """Judge the hand's rotations (T, 3, 3) against the skill of ``orientation`` (the learned
    OrientationPrior); ``reference`` the same chain conditioned on the plan's start, goal and
    via rotations; ``rotation_given``: the caller fixed the end rotation (not judged then)."""
    spread = angle_spread(orientation)
    angle = so3.angle_between(reference.mean_rotations, rotations)
    ratio = angle / spread
    worst = int(np.argmax(ratio))
    end = float(so3.angle_between(orientation.mean_rotations[-1], rotations[-1]))
    completion = None if rotation_given else COMPLETION_FACTOR * max(orientation.end_radius,
                                                                     ORIENTATION_FLOOR)
    check = OrientationCheck(angle, ratio, worst, end, completion, ())
    reasons = []
    T = len(ratio)
    if not check.within_tube:
        out = np.flatnonzero(ratio > TUBE_RATIO)
        reasons.append(
            f"turned away from the skill at states {out[0]}-{out[-1]} ({100 * out[0] / (T - 1):.0f}-"
            f"{100 * out[-1] / (T - 1):.0f} % of the skill): the hand {np.degrees(angle[worst]):.0f} "
            f"deg from how the skill turns it at state {worst}, {ratio[worst]:.1f} x the "
            f"demonstrations' orientation spread there ({np.degrees(spread[worst]):.1f} deg; limit "
            f"{TUBE_RATIO:g} x = {np.degrees(TUBE_RATIO * spread[worst]):.0f} deg)")
    if not check.completed:
        reasons.append(
            f"skill not completed in orientation: the hand ends {np.degrees(end):.0f} deg from "
            f"how the demonstrations end (limit {np.degrees(completion):.0f} deg)")
    return OrientationCheck(angle, ratio, worst, end, completion, tuple(reasons))
