"""Obstacle weighting of demonstrations recorded in clutter (the reference's weighted prior).

A sample of demonstration m at step t lies at signed distance d from the obstacles recorded
with that demonstration (its own, not the planning scene's); it gets the weight

    w = exp(-0.5 c^2 / sigma),   c = max(0, eps - d)

(eps 0.3 m and sigma 0.001 m^2 by default, as in the reference), so the bends a demonstration
makes around its clutter hardly enter the learned skill. A transition i -> i+1 is weighted by
the smaller of its two samples' weights (see :mod:`clamp.prior.conjugate`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError, ShapeError
from clamp.validation import ERRORS, as_array, as_scalar
from scenes import Scene
from skillplan import validation as checks


@dataclass(frozen=True)
class ObstacleWeighting:
    """eps [m] distance below which a sample loses weight; sigma [m^2] width of the decay."""

    eps: float = 0.3
    sigma: float = 0.001

    def __post_init__(self) -> None:
        as_scalar(self.eps, "obstacle_weighting.eps", minimum=0.0)
        as_scalar(self.sigma, "obstacle_weighting.sigma", strictly_positive=True)

    def weight(self, distance: np.ndarray) -> np.ndarray:
        """Weights (...,) of samples at signed distances (...,) [m] from their obstacles."""
        distance = checks.as_array(distance, "distance", ERRORS, allow_infinite=True)
        c = np.maximum(0.0, self.eps - distance)
        return np.exp(-0.5 * c * c / self.sigma)

    def to_dict(self) -> dict[str, float]:
        return {"eps": float(self.eps), "sigma": float(self.sigma)}


def as_weighting(value: Any) -> ObstacleWeighting | None:
    """None / False (no weighting), True (defaults), a dict of eps / sigma or an
    ObstacleWeighting -> an ObstacleWeighting or None."""
    if value is None or value is False:
        return None
    if value is True:
        return ObstacleWeighting()
    if isinstance(value, ObstacleWeighting):
        return value
    if isinstance(value, dict) and set(value) <= {"eps", "sigma"}:
        return ObstacleWeighting(**value)
    raise InvalidParameterError(f"obstacle_weighting: expected None, True, a dict with eps / "
                                f"sigma or a clamp.ObstacleWeighting, got {value!r}")


def demonstration_weights(positions: np.ndarray, obstacles: Any,
                          weighting: ObstacleWeighting | None) -> np.ndarray | None:
    """Sample weights (M, T) of positions (M, T, 3) [m] given per-demonstration obstacle lists
    (M lists; a demonstration without obstacles keeps weight 1); None when nothing is weighted."""
    if weighting is None or obstacles is None:
        return None
    positions = as_array(positions, "positions", (None, None, 3), limit=checks.MAX_COORDINATE)
    obstacles = checks.as_sequence(obstacles, "obstacles", "one list of obstacles per "
                                   "demonstration", ClampTypeError)
    if len(obstacles) != len(positions):
        raise ShapeError(f"obstacles: expected one list of obstacles per demonstration "
                         f"({len(positions)}), got {len(obstacles)}")
    weighting = checks.as_instance(weighting, "weighting", ObstacleWeighting,
                                   "a clamp.ObstacleWeighting or None", ClampTypeError)
    weights = np.ones(positions.shape[:2])
    for m, group in enumerate(obstacles):
        if group:
            weights[m] = weighting.weight(Scene(list(group)).distance(positions[m]))
    return weights
