"""What a plan is conditioned on and judged against: the learned prior conditioned on the
request's start, goal and via positions (:func:`clamp.prior.conditioning.condition_prior`).
Its inputs are the checked records of :func:`clamp.planning.request.make_request`."""
from __future__ import annotations

from typing import Any

import numpy as np

from clamp.prior.conditioning import conditioned


def target_observations(prior: Any, robot: Any, request: Any) -> list[tuple[int, np.ndarray]]:
    """(state index, position (3,) [m]) of the request's start, goal and via points (joint
    targets through forward kinematics)."""
    T = len(prior.Phi) + 1

    def position(target: Any) -> np.ndarray:
        return target.value if target.kind == "position" else robot.fk(target.value)
    observations = [(0, request.start_position)]
    if request.goal is not None:
        observations.append((T - 1, position(request.goal)))
    return observations + [(i, position(t)) for i, t in request.vias]


def planning_prior(prior: Any, robot: Any, request: Any, config: Any) -> Any:
    """The prior a plan for ``request`` uses: ``prior`` conditioned on the start position and
    on the goal and via positions (joint targets through forward kinematics) when the request
    has any and ``config.model.condition_on_targets``; otherwise ``prior`` itself."""
    model = config.model
    if not model.condition_on_targets or (request.goal is None and not request.vias):
        return prior
    return conditioned(prior, target_observations(prior, robot, request),
                           model.conditioning_sigma)


def skill_reference(prior: Any, robot: Any, request: Any, config: Any,
                    model_prior: Any = None) -> Any:
    """Where the skill goes for ``request``: ``prior`` conditioned on the start, goal and via
    positions (``model_prior``, the :func:`planning_prior`, when it already is)."""
    if model_prior is not None and model_prior is not prior:
        return model_prior
    return conditioned(prior, target_observations(prior, robot, request),
                           config.model.conditioning_sigma)
