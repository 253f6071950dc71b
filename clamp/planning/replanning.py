"""Replanning: a new plan after the goal, the via points or the scene changed, warm-started
from the previous plan.

:func:`replan` keeps everything the previous :func:`clamp.plan` call was asked (its
``PlanResult.inputs``) except what is given, reuses the previous start configuration (no
inverse kinematics) and starts the optimiser from the previous joint trajectory moved by the
change of the planning prior: the new conditioned prior mean minus the previous one (zero
when only the scene changed) is added to the previous plan's workspace states, and a few
per-state Gauss-Newton updates (:class:`clamp.optim.solver.WorkspaceCorrection`) carry the joints
onto them. The previous plan's own deviations from its prior (around obstacles) are kept.
With obstacles, the free plan the new plan is tied to is the previous one's when only the
scene changed (the same free problem, ``PlanInputs.free_plan``), else solved again.
The fast solver then runs with its warm-start rule (:class:`clamp.optim.solver.WarmStart`: small
first damping, one small step or a small predicted decrease stops).
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from clamp.planning.reference import planning_prior
from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.factors.states import StateWindow
from clamp.planning.pipeline import build_model
from clamp.planning.planner import plan_model
from clamp.config import as_config
from clamp.planning.request import Request, Target, as_scene, make_request
from clamp.planning.result import PlanInputs, PlanResult
from clamp.optim.solver import WarmStart, WorkspaceCorrection
from clamp.validation import as_bool
from skillplan.threads import single_blas_thread
from skillplan.validation import as_instance, as_sequence

_KEEP = object()

#: per-state Gauss-Newton updates moving the previous plan onto the shifted workspace states
#: (1: the solver's own corrected steps do the rest; 3 gave the same iterations on box_closing)
CORRECTION_STEPS = 1


def shifted_plan(previous: PlanResult, robot: Any, shift: np.ndarray) -> np.ndarray:
    """The joint states (T, 2n) of ``previous`` (planned for ``robot``) moved so that their
    workspace states [p, v] gain ``shift`` (T, 6) [m, m/s]: the initial trajectory of a replan
    (``shift``: the new conditioned prior mean minus the previous one)."""
    theta = np.hstack([previous.q, previous.qdot])
    if not np.any(shift):
        return theta
    x = np.hstack([previous.ee_path, previous.ee_velocity])    # the plan's workspace states
    correction = WorkspaceCorrection(lambda t: StateWindow(robot, t), x + shift,
                                     np.zeros(x.shape + (theta.shape[1],)), CORRECTION_STEPS)
    return correction.apply(theta, np.zeros_like(theta))


def replanned_free_plan(inputs: PlanInputs, same: bool) -> dict[str, np.ndarray]:
    """The free plan of a replan as keywords of :func:`clamp.planning.pipeline.model`: the
    previous one (``inputs.free_plan``) when ``same`` (the same targets, configuration and
    extra factors: the same free problem, only the scene changed), ``{"free": it}``; else none
    (solved again from the replan's initial trajectory, as before: warm-starting it from the
    previous free plan moved to the new targets was measured slower, Sawyer goal moved 5 cm
    39 -> 52 ms, the tied solve 1 -> 4 iterations)."""
    if same and inputs.free_plan is not None:
        return {"free": inputs.free_plan}
    return {}


def _same_targets(request: Request, inputs: PlanInputs) -> bool:
    """Whether ``request`` has the goal and via points ``inputs`` planned for (same values)."""
    def same(target: Target | None, value: Any) -> bool:
        if target is None or value is None:
            return target is None and value is None
        return bool(np.array_equal(target.value, value))
    return (same(request.goal, inputs.goal) and len(request.vias) == len(inputs.via_points)
            and all(i == j and same(target, value)
                    for (i, target), (j, value) in zip(request.vias, inputs.via_points)))


def replan(previous: PlanResult, *, goal: Any = _KEEP, scene: Any = _KEEP,
           via_points: Sequence[tuple[int, Any]] | Any = _KEEP, config: Any = None,
           covariance: bool = True) -> PlanResult:
    """A new plan for the request of ``previous`` with ``goal``, ``scene`` and / or
    ``via_points`` replaced (same meaning as in :func:`clamp.plan`; left out: unchanged),
    warm-started from ``previous`` (see the module docstring). ``config`` replaces the
    previous configuration when given. The result is checked like any plan's."""
    as_instance(previous, "previous", PlanResult, "a clamp.PlanResult returned by clamp.plan",
                ClampTypeError)
    if via_points is not _KEEP:
        via_points = as_sequence(via_points, "via_points", "a list of pairs (index, position "
                                 "(3,) or configuration (n,))", ClampTypeError)
    inputs = previous.inputs
    if inputs is None:
        raise InvalidParameterError("previous: expected a PlanResult returned by clamp.plan "
                                    "(it keeps its request in .inputs), got one without")
    if previous.stop_reason == "not started":
        raise InvalidParameterError(f"previous: the plan never started ({previous.reasons}); "
                                    "plan afresh with clamp.plan")
    goal = inputs.goal if goal is _KEEP else goal
    scene = inputs.scene if scene is _KEEP else as_scene(scene)
    via_points = inputs.via_points if via_points is _KEEP else tuple(via_points)
    config = inputs.config if config is None else config
    started = time.perf_counter()
    with single_blas_thread():
        config = as_config(config)
        covariance = as_bool(covariance, "covariance")
        prior, robot = inputs.prior, inputs.robot
        request = make_request(prior, robot, inputs.start, goal, via_points, config,
                               q_start=previous.q[0])
        same = _same_targets(request, inputs)
        if same and config.model == inputs.config.model:
            model_prior = inputs.model_prior          # same targets: the same conditioned prior
        else:
            model_prior = planning_prior(prior, robot, request, config)
        shift = np.asarray(model_prior.mean) - np.asarray(inputs.model_prior.mean)
        free = replanned_free_plan(inputs, same and config == inputs.config)
        replanned = build_model(prior, robot, scene, request, config, inputs.extra_factors,
                                inputs.sdf if scene is inputs.scene else None,
                                shifted_plan(previous, robot, shift), model_prior=model_prior,
                                **free)
        result = plan_model(replanned, covariance, WarmStart(), started)
        result.time_scale = previous.time_scale   # the inputs are the scaled prior and config
        return result
