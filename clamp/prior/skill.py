"""Is a plan still the skill? Where the demonstrations end, how tightly they agree at every
step, and a calibrated score of how far a path strays from them.

The demonstrations' *region* (:class:`SkillRegion`, learned with the prior and saved in
``prior.info["skill_region"]``):

- ``radius`` (T,) [m]: at every step, the largest distance of a demonstration from the
  demonstrations' mean position (the tube they sweep, as TLGC's cylinder); ``spread`` (T, 3)
  [m]: their per-axis standard deviation (1/M);
- ``end_mean`` (3,) [m] and ``end_radius`` [m]: where they end, and how far apart.

Both are floored at :data:`SKILL_FLOOR` (5 mm): demonstrations that agree exactly at a step
(a common goal at rest) still leave a placement tolerance of that size.

The two checks of the verdict (:func:`skill_checks`):

- **completed**: the path's last point lies within ``COMPLETION_FACTOR x max(end_radius,
  floor)`` (2x) of ``end_mean`` -- only when the caller gave no goal of their own (a goal
  replaces where the skill ends, and is checked as a goal);
- **with the skill**: at every step, the path's distance from the *reference* (the prior's
  mean conditioned on the plan's start, goal and via positions: where the skill goes from
  here) in units of that step's ``radius`` stays below ``TUBE_RATIO`` (4). Where the
  demonstrations agree (a lid's sliding part: radius ~5 mm) a 2 cm departure fails; where they
  vary (the reaching part: radius ~5 cm) a 20 cm detour passes.

Calibration (``tests/clamp/prior/test_skill.py``, leave-one-out: learn from all demonstrations but one,
judge the held-out one from its own start): on box_closing.mat the held-out demonstrations'
largest ratio is 1.0-2.5 and their end 0.3-1.6 end radii from the others' mean end; on the
synthetic skills (two seeds each) 0.7-3.5 and at most 1.97. Both limits pass every held-out
demonstration of these sets.

The *plausibility* (:func:`skill_plausibility`) is the same tube statistic turned into a
probability: S = the largest ratio above over the steps, or :data:`END_WEIGHT` (2) times the
end's distance from the reference's end in end radii when that is larger (:func:`statistic`),
and the score is the share of sampled executions of the skill (from the plan's start, meeting
its goal and via points) whose S is at least the path's. The sampled executions are the
conditioned prior's, rescaled step by step from the prior's own spread to the demonstrations'
spread inflated for a new execution (sqrt((M + 1) / (M - 1)): the predictive spread of one
more demonstration from M) and by :data:`CALIBRATION` (1.5: of 0.7, 1.0, 1.2, 1.5, 2, 2.5
and 3 the smallest at which every held-out demonstration above scores >= 0.05; at 1.2 the
least scored 0.03, at 1.0 0.01). The score is therefore uniform on such samples (by construction), has a resolution
of 1 / (:data:`PLAUSIBILITY_SAMPLES` + 1), and never saturates at 1.0 for a path that strays.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from clamp.errors import ShapeError
from clamp.validation import as_array

#: [m] smallest tube radius and end radius: the placement tolerance where the demonstrations
#: agree exactly
SKILL_FLOOR = 5e-3
#: a path completes the skill within this many end radii of the demonstrations' mean end
COMPLETION_FACTOR = 2.0
#: a path stays with the skill while it keeps within this many tube radii of the reference
TUBE_RATIO = 4.0
#: sampled executions behind the plausibility score (seeded: the score is deterministic)
PLAUSIBILITY_SAMPLES = 200
#: the plausibility counts the end's distance this many times (the end is the skill's purpose)
END_WEIGHT = 2.0
#: sampled executions spread this much wider than the conditioned prior says (calibrated)
CALIBRATION = 1.5
_SEED = 20261126
#: sorted sample statistics per prior and conditioning pattern (see _sample_statistic)
_STATISTICS: "weakref.WeakKeyDictionary[Any, dict]" = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class SkillRegion:
    """Where the demonstrations go: radius (T,) [m], spread (T, 3) [m], end_mean (3,) [m],
    end_radius [m] (all unfloored), num_demos."""

    radius: np.ndarray
    spread: np.ndarray
    end_mean: np.ndarray
    end_radius: float
    num_demos: int

    @classmethod
    def from_positions(cls, positions: Any) -> "SkillRegion":
        """The region of demonstrations' positions (M, T, 3) [m]."""
        positions = as_array(positions, "positions", (None, None, 3))
        mean = positions.mean(axis=0)
        offsets = np.linalg.norm(positions - mean, axis=2)                 # (M, T)
        return cls(radius=offsets.max(axis=0), spread=positions.std(axis=0),
                   end_mean=mean[-1], end_radius=float(offsets[:, -1].max()),
                   num_demos=int(positions.shape[0]))

    def to_info(self) -> dict[str, Any]:
        """JSON-ready form (stored in ``prior.info["skill_region"]``)."""
        return {"radius": self.radius.tolist(), "spread": self.spread.tolist(),
                "end_mean": self.end_mean.tolist(), "end_radius": self.end_radius,
                "num_demos": self.num_demos}

    @classmethod
    def from_info(cls, info: dict[str, Any], T: int) -> "SkillRegion":
        radius = np.asarray(info["radius"], dtype=float)
        spread = np.asarray(info["spread"], dtype=float)
        if radius.shape != (T,) or spread.shape != (T, 3):
            raise ShapeError(f"prior.info['skill_region']: expected radius ({T},) and spread "
                             f"({T}, 3), got {radius.shape} and {spread.shape}")
        return cls(radius, spread, np.asarray(info["end_mean"], dtype=float),
                   float(info["end_radius"]), int(info["num_demos"]))

    @classmethod
    def of(cls, prior: Any) -> "SkillRegion":
        """The region stored with ``prior``; for a prior learned without it (made from arrays,
        or saved by an older version) one implied by the prior's own marginals: per-axis
        spread = marginal std, radius = 2 x its norm (about the largest of six samples)."""
        info = getattr(prior, "info", {}).get("skill_region")
        if info is not None:
            return cls.from_info(info, prior.T)
        spread = np.asarray(prior.std)[:, :3]
        radius = 2.0 * np.linalg.norm(spread, axis=1)
        return cls(radius, spread, np.asarray(prior.mean)[-1, :3], float(radius[-1]), 6)

    def merged(self, other: "SkillRegion") -> "SkillRegion":
        """The region of both sets of demonstrations, bounded from the two (a prior updated
        with more demonstrations): the larger radius at every step, spreads pooled."""
        m, k = self.num_demos, other.num_demos
        spread = np.sqrt((m * self.spread**2 + k * other.spread**2) / (m + k))
        end_mean = (m * self.end_mean + k * other.end_mean) / (m + k)
        shift = max(np.linalg.norm(self.end_mean - end_mean),
                    np.linalg.norm(other.end_mean - end_mean))
        return SkillRegion(np.maximum(self.radius, other.radius), spread, end_mean,
                           max(self.end_radius, other.end_radius) + float(shift), m + k)

    @property
    def tube(self) -> np.ndarray:
        """Floored tube radius (T,) [m]."""
        return np.maximum(self.radius, SKILL_FLOOR)

    @property
    def completion_radius(self) -> float:
        """[m] how far from ``end_mean`` a completed skill may end."""
        return COMPLETION_FACTOR * max(self.end_radius, SKILL_FLOOR)


@dataclass(frozen=True)
class SkillCheck:
    """The skill's verdict on one path.

    ratio (T,): distance from the reference in tube radii; worst: the step of the largest;
    end_distance [m] from the demonstrations' mean end; completion_radius [m] (None: not
    judged, the caller gave a goal); plausibility in (0, 1]; reasons: failed checks, each
    naming the part of the skill and how far out."""

    ratio: np.ndarray
    worst: int
    end_distance: float
    completion_radius: float | None
    plausibility: float
    reasons: tuple[str, ...]

    @property
    def max_ratio(self) -> float:
        return float(self.ratio[self.worst])

    @property
    def within_tube(self) -> bool:
        """Whether the path keeps within TUBE_RATIO tube radii of the reference everywhere."""
        return self.max_ratio <= TUBE_RATIO

    @property
    def completed(self) -> bool:
        """Whether the path ends within the completion radius (True when not judged)."""
        return self.completion_radius is None or self.end_distance <= self.completion_radius

    def to_dict(self) -> dict[str, Any]:
        return {"max_tube_ratio": self.max_ratio, "worst_state": self.worst,
                "end_distance": self.end_distance, "completion_radius": self.completion_radius,
                "tube_limit": TUBE_RATIO}


def tube_ratio(region: SkillRegion, reference: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance of ``path`` (..., T, 3) from ``reference`` (T, 3) in tube radii, (..., T)."""
    return np.linalg.norm(path - reference, axis=-1) / region.tube


def statistic(region: SkillRegion, reference: np.ndarray, path: np.ndarray) -> np.ndarray:
    """S of paths (..., T, 3): the largest tube ratio, or END_WEIGHT times the end's distance
    from the reference's end in end radii when larger, (...)."""
    end = np.linalg.norm(path[..., -1, :] - reference[-1], axis=-1)
    return np.maximum(tube_ratio(region, reference, path).max(axis=-1),
                      END_WEIGHT * end / max(region.end_radius, SKILL_FLOOR))


def sample_executions(region: SkillRegion, prior: Any, reference_prior: Any, count: int,
                      rng: np.random.Generator | int) -> np.ndarray:
    """Sampled executions of the skill, positions (count, T, 3) [m]: the conditioned prior's
    samples with their offsets from its mean rescaled, step by step and axis by axis, from the
    prior's own marginal std to the demonstrations' floored spread x sqrt((M + 1) / (M - 1))
    x CALIBRATION."""
    mean = np.asarray(reference_prior.mean)[:, :3]
    offsets = reference_prior.sample(count, rng)[..., :3] - mean
    own = np.maximum(np.asarray(prior.std)[:, :3], 1e-12)
    M = max(region.num_demos, 2)
    scale = (np.maximum(region.spread, SKILL_FLOOR / math.sqrt(3))
             * math.sqrt((M + 1) / (M - 1)) * CALIBRATION)
    return mean + offsets / own * scale


def _sample_statistic(region: SkillRegion, prior: Any, reference_prior: Any) -> np.ndarray:
    """S of PLAUSIBILITY_SAMPLES sampled executions (seeded), ascending.

    S measures the executions' offsets from the conditioned mean, and a Gaussian conditioned on
    exact positions at some states has the same covariance whatever the positions: S depends on
    which states are conditioned, not where, so it is computed once per prior and pattern."""
    info = getattr(reference_prior, "info", {})
    key = (tuple(int(i) for i, _ in info.get("conditioned_on", ())),
           info.get("conditioning_sigma"))
    per_prior = _STATISTICS.setdefault(prior, {})
    if key not in per_prior:
        executions = sample_executions(region, prior, reference_prior, PLAUSIBILITY_SAMPLES,
                                       _SEED)
        per_prior[key] = np.sort(statistic(region, np.asarray(reference_prior.mean)[:, :3],
                                           executions))
    return per_prior[key]


def skill_plausibility(region: SkillRegion, prior: Any, reference_prior: Any,
                       statistic: float | np.ndarray) -> float | np.ndarray:
    """Share (with the path counted among them) of sampled executions whose largest tube ratio
    is at least ``statistic``: (1 + #{S_k >= S}) / (N + 1)."""
    stats = _sample_statistic(region, prior, reference_prior)
    beyond = len(stats) - np.searchsorted(stats, statistic, side="left")
    return (1.0 + beyond) / (len(stats) + 1.0)


def skill_checks(prior: Any, reference_prior: Any, path: np.ndarray, goal_given: bool,
                 describe_pusher: Any = None, score: bool = True) -> SkillCheck:
    """Judge ``path`` (T, 3) [m] against the skill of ``prior``; ``reference_prior`` is the
    prior conditioned on the path's start (and the caller's goal / via positions);
    describe_pusher(state) -> str names what pushed the path there (e.g. the nearest
    obstacle), or None; score: compute the plausibility (else NaN: the checks alone)."""
    region = SkillRegion.of(prior)
    reference = np.asarray(reference_prior.mean)[:, :3]
    ratio = tube_ratio(region, reference, path)
    worst = int(np.argmax(ratio))
    end_distance = float(np.linalg.norm(path[-1] - region.end_mean))
    check = SkillCheck(ratio, worst, end_distance,
                       None if goal_given else region.completion_radius, float("nan"), ())
    reasons = []
    T = len(ratio)
    if not check.within_tube:
        out = np.flatnonzero(ratio > TUBE_RATIO)
        part = (f"states {out[0]}-{out[-1]} ({100 * out[0] / (T - 1):.0f}-"
                f"{100 * out[-1] / (T - 1):.0f} % of the skill)")
        why = describe_pusher(worst) if describe_pusher else None
        reasons.append(
            f"left the skill at {part}: {1000 * ratio[worst] * region.tube[worst]:.0f} mm from "
            f"where it goes at state {worst}, {ratio[worst]:.1f} x the demonstrations' spread "
            f"there ({1000 * region.tube[worst]:.0f} mm; limit {TUBE_RATIO:g} x)"
            + (f", pushed by {why}" if why else ""))
    if not check.completed:
        why = describe_pusher(T - 1) if describe_pusher else None
        reasons.append(
            f"skill not completed: ends {1000 * end_distance:.0f} mm from where the "
            f"demonstrations end (limit {1000 * check.completion_radius:.0f} mm)"
            + (f", pushed by {why}" if why else ""))
    value = (float(skill_plausibility(region, prior, reference_prior,
                                      statistic(region, reference, path)))
             if score else float("nan"))
    return replace(check, plausibility=value, reasons=tuple(reasons))
