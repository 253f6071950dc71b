"""Seeded synthetic demonstrations of named skills in a Kinova Jaco2's workspace.

Base at the origin, z up. Every skill stays in the region the real box-closing demonstrations
use (x 0.1..0.5, y -0.6..-0.2, z 0.05..0.45), more than 0.2 m from the base axis and above
z = 0.02. A skill is a list of nominal waypoints with a spread (m) per waypoint: each
demonstration perturbs the waypoints with seeded Gaussian offsets of that spread (small where
the skill is constrained), passes a cubic spline through them (knots at the nominal chord-length
fractions) and traverses it with a minimum-jerk timing law, itself warped per demonstration
by w = tau + a tau (1 - tau), a uniform in [-timing, timing]. The skills of the TLGC
experiments (needle_threading, pick_place, curved_reach) have no timing warp: like the TLGC
reference's smoothData they come phase-aligned, so a narrow part stays narrow step by step and
cross-sections taken at equal indices do not overlap near the resting ends. Velocities are the exact time derivative of the positions (chain rule).
:func:`make_cluttered_demonstrations` records the same demonstrations each bending around a
box of its own (for learning with obstacle weighting).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from .demonstrations import Demonstrations
from .errors import InvalidArgumentError, UnknownSkillError
from .obstacles import Box, Obstacle
from skillplan.validation import as_count, as_positive, as_seed


@dataclass(frozen=True)
class SkillSpec:
    """Nominal waypoints (K,3) m, spread per waypoint (K,) m, largest timing warp ``timing``
    (dimensionless, < 1; 0 keeps every waypoint at the same time step in all demonstrations),
    obstacles shown with the skill."""

    waypoints: np.ndarray
    spread: np.ndarray
    timing: float = 0.1
    obstacles: tuple[Obstacle, ...] = field(default_factory=tuple)


def _spec(rows: list[tuple[float, float, float, float]], timing: float = 0.1,
          obstacles: tuple[Obstacle, ...] = ()) -> SkillSpec:
    table = np.array(rows, dtype=float)
    return SkillSpec(table[:, :3], table[:, 3], timing, obstacles)


#: Obstacle the curved_reach demonstrations go around (also their recorded obstacle).
CURVED_REACH_OBSTACLE = Box([0.32, -0.40, 0.14], [0.08, 0.08, 0.26])

_SPECS: dict[str, SkillSpec] = {
    # reach up and over to the lid, then slide it shut (ends constrained).
    "box_closing": _spec([(0.20, -0.47, 0.26, 0.030), (0.26, -0.42, 0.37, 0.020),
                          (0.36, -0.33, 0.41, 0.010), (0.42, -0.29, 0.29, 0.006),
                          (0.44, -0.27, 0.14, 0.004)]),
    # approach a target from straight above.
    "reach_from_above": _spec([(0.15, -0.52, 0.27, 0.040), (0.28, -0.42, 0.36, 0.020),
                               (0.35, -0.35, 0.30, 0.008), (0.35, -0.35, 0.20, 0.004),
                               (0.35, -0.35, 0.10, 0.002)]),
    # wide start, narrow middle (the needle's eye), wide end.
    "needle_threading": _spec([(0.14, -0.55, 0.32, 0.040), (0.24, -0.46, 0.26, 0.015),
                               (0.31, -0.39, 0.22, 0.002), (0.38, -0.31, 0.25, 0.015),
                               (0.46, -0.22, 0.33, 0.040)], timing=0.0),
    # pick at one place, carry over, put down at another.
    "pick_place": _spec([(0.25, -0.52, 0.30, 0.030), (0.21, -0.46, 0.17, 0.010),
                         (0.20, -0.45, 0.07, 0.003), (0.25, -0.41, 0.26, 0.015),
                         (0.42, -0.28, 0.22, 0.010), (0.42, -0.28, 0.08, 0.003)], timing=0.0),
    # go around the obstacle region on the side away from the base.
    "curved_reach": _spec([(0.17, -0.53, 0.20, 0.020), (0.30, -0.52, 0.21, 0.008),
                           (0.42, -0.45, 0.21, 0.008), (0.46, -0.30, 0.20, 0.015)],
                          timing=0.0, obstacles=(CURVED_REACH_OBSTACLE,)),
    # press one target, then a second one.
    "two_target_press": _spec([(0.20, -0.50, 0.30, 0.030), (0.25, -0.40, 0.22, 0.010),
                               (0.25, -0.40, 0.10, 0.002), (0.32, -0.35, 0.24, 0.010),
                               (0.40, -0.28, 0.10, 0.002), (0.42, -0.26, 0.26, 0.020)], timing=0.05),
}

#: Names of the synthetic skills.
SKILLS: tuple[str, ...] = ("box_closing", "reach_from_above", "needle_threading", "pick_place",
                           "curved_reach", "two_target_press")


def skill_spec(skill: str) -> SkillSpec:
    """Waypoints and spreads of a named skill; UnknownSkillError lists the valid names."""
    if not isinstance(skill, str) or skill not in _SPECS:
        raise UnknownSkillError(f"skill: unknown {skill!r}; expected one of {list(SKILLS)}")
    return _SPECS[skill]


def minimum_jerk_phase(tau: np.ndarray, warp: float) -> tuple[np.ndarray, np.ndarray]:
    """Phase s (T,) of a minimum-jerk motion from rest to rest at normalised times tau (T,) in
    [0, 1], warped by w = tau + warp tau (1 - tau) (|warp| < 1 keeps it monotone), and its
    derivative ds / dtau (T,)."""
    w = tau + warp * tau * (1.0 - tau)
    dw = 1.0 + warp * (1.0 - 2.0 * tau)
    s = w**3 * (10.0 - 15.0 * w + 6.0 * w**2)
    ds = 30.0 * w**2 * (1.0 - w) ** 2
    return s, ds * dw


def _skill_paths(spec: SkillSpec, M: int, T: int, step: float,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities (M, T, 3) and phase tau (T,) of M demonstrations of ``spec``."""
    duration = (T - 1) * step
    chord = np.linalg.norm(np.diff(spec.waypoints, axis=0), axis=1)
    knots = np.concatenate([[0.0], np.cumsum(chord)]) / chord.sum()
    tau = np.linspace(0.0, 1.0, T)
    positions = np.empty((M, T, 3))
    velocities = np.empty((M, T, 3))
    for m in range(M):
        points = spec.waypoints + rng.normal(size=spec.waypoints.shape) * spec.spread[:, None]
        path = CubicSpline(knots, points, axis=0, bc_type="natural")
        s, ds = minimum_jerk_phase(tau, rng.uniform(-spec.timing, spec.timing))
        positions[m] = path(s)
        velocities[m] = path(s, 1) * (ds / duration)[:, None]
    return positions, velocities, tau


def _checked(skill: str, num_demos: int, num_points: int, dt: float,
             seed: Any) -> tuple[SkillSpec, int, int, float, int]:
    spec = skill_spec(skill)
    M = as_count(num_demos, "num_demos", 2, InvalidArgumentError)
    T = as_count(num_points, "num_points", 4, InvalidArgumentError)
    return spec, M, T, as_positive(dt, "dt"), as_seed(seed, "seed")


def make_demonstrations(skill: str, num_demos: int = 6, num_points: int = 250, dt: float = 0.16,
                        seed: int = 0) -> Demonstrations:
    """num_demos seeded demonstrations of ``skill`` (see SKILLS) with num_points steps of dt s.

    Returns Demonstrations (M=num_demos, T=num_points), time = arange(T) * dt, named after the
    skill; skills shown around an obstacle record it for every demonstration.
    """
    spec, M, T, step, seed = _checked(skill, num_demos, num_points, dt, seed)
    positions, velocities, tau = _skill_paths(spec, M, T, step, np.random.default_rng(seed))
    obstacles = [list(spec.obstacles) for _ in range(M)] if spec.obstacles else None
    return Demonstrations(positions, velocities, tau * (T - 1) * step, obstacles, skill)


def make_cluttered_demonstrations(skill: str, num_demos: int = 10, num_points: int = 250,
                                  dt: float = 0.16, seed: int = 0, detour: float = 0.08,
                                  box_size: float = 0.05, width: float = 0.06) -> Demonstrations:
    """The demonstrations of :func:`make_demonstrations` (same arguments and seed) recorded in
    clutter: each one meets its own cube (edge ``box_size`` m) placed on its path at a random
    phase in [0.3, 0.7] and lifts over it (upwards, perpendicular to its velocity, as a hand
    lifts over clutter) by a Gaussian bump of height ``detour`` m and phase width
    ``width``; velocities include the bump's time derivative. Every demonstration records its
    own box as its obstacles. The clutter-free skill is ``make_demonstrations`` with the
    same arguments.
    """
    spec, M, T, step, seed = _checked(skill, num_demos, num_points, dt, seed)
    detour = as_positive(detour, "detour")
    box_size = as_positive(box_size, "box_size")
    width = as_positive(width, "width")
    positions, velocities, tau = _skill_paths(spec, M, T, step, np.random.default_rng(seed))
    duration = (T - 1) * step
    rng = np.random.default_rng([seed, 1])           # the clean paths stay those of the seed
    obstacles = []
    for m in range(M):
        centre = rng.uniform(0.3, 0.7)
        index = int(np.argmin(np.abs(tau - centre)))
        heading = velocities[m, index] / max(float(np.linalg.norm(velocities[m, index])), 1e-12)
        side = np.array([0.0, 0.0, 1.0]) - heading[2] * heading   # up, across the motion
        side /= max(float(np.linalg.norm(side)), 1e-12)
        bump = np.exp(-0.5 * ((tau - tau[index]) / width) ** 2)
        dbump = bump * (-(tau - tau[index]) / width**2) / duration
        obstacles.append([Box(positions[m, index], [box_size] * 3)])
        positions[m] += detour * bump[:, None] * side
        velocities[m] += detour * dbump[:, None] * side
    return Demonstrations(positions, velocities, tau * duration, obstacles, f"{skill}_cluttered")
