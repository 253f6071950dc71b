"""Replanning: a new plan after the goal, the via points or the scene changed, warm-started
from the previous plan.

:func:`replan` keeps everything the previous :func:`clamp.plan` call was asked (its
``PlanResult.inputs``) except what is given, reuses the previous start configuration (no
inverse kinematics) and starts the optimiser from the previous joint trajectory moved by the
change of the planning prior: the new conditioned prior mean minus the previous one (zero
when only the scene changed) is added to the previous plan's workspace states, and a few
per-state Gauss-Newton updates (:class:`clamp.optim.solver.WorkspaceCorrection`) carry the joints
onto them. The previous plan's own deviations from its prior (around obstacles) are kept.
With obstacles, the free plan the new plan is tied to is the previous one's when the free
problem is the same (the same targets and model configuration: only the scene or the
solver's settings changed, e.g. ``PlannerConfig.fast()``; ``PlanInputs.free_plan``); else it
is solved as configured from the previous free plan moved the same way
(:func:`clamp.planning.assembly.free_plan`), and the moved previous plan follows that solve's
correction (:func:`replan_start`): where the previous plan was its free plan, the tied solve
starts at the new free plan.
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


def shifted_states(robot: Any, theta: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Joint states theta (K, 2n) of ``robot`` moved so that their workspace states [p, v]
    gain ``shift`` (K, 6) [m, m/s] (``theta`` itself when the shift is zero). Every state is
    moved on its own: K may stack several trajectories."""
    if not np.any(shift):
        return theta
    x, jacobian = StateWindow(robot, theta).workspace()        # the states' [p, v] (K, 6)
    correction = WorkspaceCorrection(lambda t: StateWindow(robot, t), x + shift,
                                     np.zeros(x.shape + (theta.shape[1],)), CORRECTION_STEPS - 1)
    out = correction.update(theta, jacobian, shift)            # the first update: x known
    return correction.apply(out, np.zeros_like(out)) if CORRECTION_STEPS > 1 else out


def replan_start(previous: PlanResult, robot: Any, shift: np.ndarray,
                 same_free_problem: bool) -> dict[str, np.ndarray]:
    """Where a replan starts, as keywords of :func:`clamp.planning.pipeline.model`: ``initial``,
    the previous plan (planned for ``robot``) with its workspace states moved by ``shift``
    (T, 6) [m, m/s] (the new conditioned prior mean minus the previous one); with a previous
    free plan (``previous.inputs.free_plan``), ``free``: it, when ``same_free_problem`` (the
    same targets and ``config.model``: the same free problem, solved as the previous
    configuration asked; the solver's settings only say how closely); else ``free_start``:
    it moved the same way, the guess the new free plan is solved from; the moved previous
    plan then follows that solve's correction (:func:`clamp.planning.pipeline.build_model`):
    where the previous plan was its free plan, the tied solve starts at its optimum."""
    theta = np.hstack([previous.q, previous.qdot])
    free = previous.inputs.free_plan
    if free is None or same_free_problem:
        start = {"initial": shifted_states(robot, theta, shift)}
        return start if free is None else {**start, "free": free}
    moved = shifted_states(robot, np.vstack([theta, free]), np.vstack([shift, shift]))
    return {"initial": moved[:len(theta)], "free_start": moved[len(theta):]}


def _same_targets(request: Request, inputs: PlanInputs) -> bool:
    """Whether ``request`` has the goal and via points ``inputs`` planned for (same values)."""
    def same(target: Target | None, value: Any) -> bool:
        if target is None or value is None:
            return target is None and value is None
        given = target.given()
        if isinstance(given, tuple) or isinstance(value, tuple):    # a pose
            return (isinstance(given, tuple) and isinstance(value, tuple)
                    and all(np.array_equal(a, b) for a, b in zip(given, value)))
        return bool(np.array_equal(given, value))
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
            model_prior = planning_prior(prior, robot, request, config, inputs.model_prior)
        shift = np.asarray(model_prior.mean) - np.asarray(inputs.model_prior.mean)
        replanned = build_model(prior, robot, scene, request, config, inputs.extra_factors,
                                inputs.sdf if scene is inputs.scene else None,
                                model_prior=model_prior,
                                **replan_start(previous, robot, shift,
                                               same and config.model == inputs.config.model))
        result = plan_model(replanned, covariance, WarmStart(), started)
        result.time_scale = previous.time_scale   # the inputs are the scaled prior and config
        return result
