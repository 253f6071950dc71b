"""Independent orientation check of a plan for the skill-fidelity benchmark (issue 37): is the
hand still turned as the demonstrations turn it?

It judges a joint trajectory without the planner's verdict (``clamp.planning.verdict``,
``clamp.prior.orientation_skill``) and without the project's kinematics (``robots.Robot.fk`` /
``ee_rotation``, ``clamp.prior.so3``): the hand's rotation comes from Pinocchio's forward
kinematics of the robot's model (``pin.forwardKinematics`` + ``pin.updateFramePlacements``,
the end-effector frame expressed in the robot's base frame), for the plan and for the
demonstrations' joint recordings alike, and the angles from ``scipy.spatial.transform.Rotation``.

The rule is the verdict's, as ``clamp.prior.orientation_skill`` documents it, coded again:

- **with the skill**: at every state t, the geodesic angle between the plan's hand rotation and
  the demonstrations' mean rotation at t (scipy's ``Rotation.mean``, the chordal mean of their
  rotations at t) stays within ``TUBE_RATIO`` (4) x the demonstrations' orientation spread at t:
  the largest angle of a demonstration from that mean, at least ``ORIENTATION_FLOOR`` (5 deg);
- **completed**: the plan's last rotation lies within ``COMPLETION_FACTOR`` (2) x the
  demonstrations' end spread (floored alike) of their mean end rotation.

One difference, on purpose: the verdict's reference is the learned orientation chain
conditioned on the arm's start rotation; here the reference is the demonstrations' own mean,
unconditioned. For a start turned as the demonstrations start (the ``pose`` family of
``hard_problems``), the two agree; for a start turned far from them, this check is the stricter.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from scenes.errors import InvalidArgumentError

TUBE_RATIO = 4.0                      # the verdict's limit in orientation spreads
COMPLETION_FACTOR = 2.0               # the verdict's end limit in end spreads
ORIENTATION_FLOOR = np.radians(5.0)   # [rad] least orientation spread


def hand_rotations(robot: Any, q: np.ndarray) -> np.ndarray:
    """The hand's rotations (..., 3, 3) in the robot's base frame for joint positions q
    (..., n), by Pinocchio's forward kinematics of ``robot.model`` at ``robot.end_effector``
    (module docstring)."""
    q = np.asarray(q, dtype=float)
    if q.ndim == 0 or q.shape[-1] != robot.n:
        raise InvalidArgumentError(f"q: expected joint positions (..., {robot.n}), got shape "
                                   f"{q.shape}")
    model = robot.model
    data = model.createData()
    names = [f.name for f in model.frames]
    hand = names.index(robot.end_effector)
    base = None if robot.base_frame is None else names.index(robot.base_frame)
    out = np.empty(q.reshape(-1, robot.n).shape[:1] + (3, 3))
    for t, config in enumerate(q.reshape(-1, robot.n)):
        pin.forwardKinematics(model, data, robot.to_pinocchio(config))
        pin.updateFramePlacements(model, data)
        rotation = data.oMf[hand].rotation
        out[t] = rotation if base is None else data.oMf[base].rotation.T @ rotation
    return out.reshape(q.shape[:-1] + (3, 3))


def geodesic_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Geodesic angle (...,) [rad] between rotations a and b (..., 3, 3): |log(a^T b)|."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    relative = np.swapaxes(a, -1, -2) @ b
    return Rotation.from_matrix(relative.reshape(-1, 3, 3)).magnitude().reshape(relative.shape[:-2])


@dataclass(frozen=True)
class OrientationSkill:
    """The demonstrations' orientation, as the rule reads it: mean rotations (T, 3, 3), spread
    (T,) [rad] (largest angle of a demonstration from the mean at each state, floored), end
    spread [rad] (floored)."""

    mean: np.ndarray
    spread: np.ndarray
    end_spread: float

    @classmethod
    def of(cls, demo_rotations: np.ndarray) -> "OrientationSkill":
        """From the demonstrations' hand rotations (M, T, 3, 3), M >= 2."""
        demo_rotations = np.asarray(demo_rotations, dtype=float)
        if demo_rotations.ndim != 4 or demo_rotations.shape[-2:] != (3, 3) or len(demo_rotations) < 2:
            raise InvalidArgumentError(f"demo_rotations: expected (M >= 2, T, 3, 3), got shape "
                                       f"{demo_rotations.shape}")
        M, T = demo_rotations.shape[:2]
        mean = np.stack([Rotation.from_matrix(demo_rotations[:, t]).mean().as_matrix()
                         for t in range(T)])
        angle = geodesic_angle(mean[None], demo_rotations)           # (M, T)
        return cls(mean, np.maximum(angle.max(axis=0), ORIENTATION_FLOOR),
                   float(max(angle[:, -1].max(), ORIENTATION_FLOOR)))


@dataclass(frozen=True)
class OrientationJudgement:
    """The rule's verdict on one path: angle (T,) [rad] from the demonstrations' mean, limit
    (T,) [rad], worst state (largest angle / limit), end angle and end limit [rad], and the
    failures (empty when the path keeps the skill's orientation)."""

    angle: np.ndarray
    limit: np.ndarray
    worst: int
    end_angle: float
    end_limit: float
    failures: tuple[str, ...]

    @property
    def ratio(self) -> float:
        """The largest angle in units of its limit (<= 1: within the skill)."""
        return float(self.angle[self.worst] / self.limit[self.worst])

    @property
    def passed(self) -> bool:
        return not self.failures


def judge_orientation(rotations: np.ndarray, skill: OrientationSkill) -> OrientationJudgement:
    """Judge the hand's rotations (T, 3, 3) of a plan against ``skill`` (module docstring's
    rule; T must be the demonstrations')."""
    rotations = np.asarray(rotations, dtype=float)
    if rotations.shape != skill.mean.shape:
        raise InvalidArgumentError(f"rotations: expected {skill.mean.shape} (one per state of the "
                                   f"demonstrations), got shape {rotations.shape}")
    angle = geodesic_angle(skill.mean, rotations)
    limit = TUBE_RATIO * skill.spread
    worst = int(np.argmax(angle / limit))
    end_angle = float(angle[-1])
    end_limit = COMPLETION_FACTOR * skill.end_spread
    failures = []
    if angle[worst] > limit[worst]:
        out = np.flatnonzero(angle > limit)
        failures.append(f"hand turned {np.degrees(angle[worst]):.1f} deg from the demonstrations' "
                        f"mean at state {worst} (limit {np.degrees(limit[worst]):.1f} deg = "
                        f"{TUBE_RATIO:g} x spread; states {out[0]}-{out[-1]} out)")
    if end_angle > end_limit:
        failures.append(f"hand ends {np.degrees(end_angle):.1f} deg from the demonstrations' mean "
                        f"end rotation (limit {np.degrees(end_limit):.1f} deg)")
    return OrientationJudgement(angle, limit, worst, end_angle, end_limit, tuple(failures))


def added_rotation(rotations: np.ndarray, free_rotations: np.ndarray) -> float:
    """[deg] the largest geodesic angle, over the states, between a plan's hand rotations
    (T, 3, 3) and the free plan's at the same state index (both plans have the skill's T
    support states; state k is the same fraction k / (T - 1) of the skill in both)."""
    rotations, free_rotations = np.asarray(rotations, float), np.asarray(free_rotations, float)
    if rotations.shape != free_rotations.shape:
        raise InvalidArgumentError(f"free_rotations: expected shape {rotations.shape} like "
                                   f"rotations, got {free_rotations.shape}")
    return float(np.degrees(geodesic_angle(rotations, free_rotations).max()))
