"""What a plan is conditioned on and judged against: the learned prior conditioned on the
request's start, goal and via positions (:func:`clamp.prior.conditioning.condition_prior`),
and, when the caller adds families that act on the hand's path (e.g. TLGC's boundary, see
:meth:`clamp.factors.Family.for_reference`), where the skill goes under them: the MAP of that
conditioned workspace prior times those families (:func:`skill_reference`). Its inputs are the
checked records of :func:`clamp.planning.request.make_request`.

Why the workspace MAP (docs/concepts.md#the-verdict): the skill's reference is a workspace
path (where the hand goes), so it is solved in the workspace, on the learned chain itself,
without the arm: the same judge for every arm, no solver of the plan's own in it (a joint-space
solve of the plan's problem in the empty scene would be the plan itself there, and the check
void). Where the caller's families hold on the conditioned mean (every hinge inactive) the MAP
is that mean: the reference is exactly today's. The solve is T states of 6 (the hand's position
and velocity as the "joints" of :class:`HandPoint`), banded, a few Levenberg-Marquardt steps
(~2-20 ms at T = 40-250).

**A goal or via rotation floors the orientation chain** (:func:`with_rotation_targets`,
:data:`ROTATION_NOISE_FLOOR`). Demonstrations often agree on the hand's rotation far more
closely than on its position (inserting keeps a fixed tool axis: the six demonstrations' end
rotations within 2e-8 rad; pouring tilts about one axis and holds the other two within 8e-8
rad), and where they do, the per-step regression's ridge sets Phi ~ 0 there and the learned Q is
the agreement floor (1e-5 rad, :data:`CONDITIONING_SIGMA`) or the residual (1e-6 rad and less).
The chain's end rotation then is as certain as a goal observation (inserting) or more (pouring's
held axes), and a goal rotation away from the demonstrations' mean is met only in part (half
for inserting on both arms, 99 % missed on the Jaco's pouring; issue 37). Floored, the goal
takes 1 - 1e-4 of the weight (a 10 deg turn is met to 0.001 deg). A plan with only the arm's
start rotation keeps the learned noise: the floor softens the chain wherever its learned noise
was smaller, which cost rotation around obstacles (docs/decisions.md#pose-prior). Position
chains are never floored: demonstrations rarely agree on positions to micrometres.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from clamp.factors import Family, WorkspaceGPFamily, WorkspaceStartFamily
from clamp.graph.problem import PlanningProblem
from clamp.optim.solver import levenberg_marquardt
from clamp.prior.conditioning import (conditioned, conditioned_orientation, retargeted,
                                      same_pattern)
from clamp.prior.demonstration_states import floor_noise
from clamp.prior.orientation_prior import OrientationPrior
from clamp.optim.optimizers import LAMBDA_UPPER_BOUND


#: [m] observation noise of the conditioning on the targets (the conditioned mean meets them
#: to about this)
CONDITIONING_SIGMA = 1e-5

#: [rad] least standard deviation of an orientation chain's step noise and initial state on r
#: where a goal or via rotation conditions it (module docstring): 100x CONDITIONING_SIGMA,
#: 0.06 deg a step
ROTATION_NOISE_FLOOR = 1e-3


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


def rotation_observations(robot: Any, request: Any, T: int) -> list[tuple[int, np.ndarray]]:
    """(state index, rotation (3, 3)) of the hand at the request's start (the arm's), goal and
    via points that fix it: poses, and joint targets through forward kinematics (a position
    target leaves the rotation free)."""
    def rotation(target: Any) -> np.ndarray | None:
        if target.kind == "joint":
            return robot.ee_rotation(target.value)[0]
        return target.rotation
    observations = [(0, robot.ee_rotation(request.q_start)[0])]
    if request.goal is not None and rotation(request.goal) is not None:
        observations.append((T - 1, rotation(request.goal)))
    return observations + [(i, rotation(t)) for i, t in request.vias if rotation(t) is not None]


def with_rotation_targets(conditioned_prior: Any, prior: Any, robot: Any, request: Any,
                          config: Any) -> Any:
    """``conditioned_prior`` (a conditioning of ``prior``) with ``prior``'s orientation chain
    conditioned on the hand's start rotation and the request's goal and via rotations
    (:func:`rotation_observations`), floored first where it has any of the latter
    (:func:`noise_floored`); as it is for a position-only prior."""
    orientation = getattr(prior, "orientation", None)
    if orientation is None:
        return conditioned_prior
    observations = rotation_observations(robot, request, orientation.T)
    if len(observations) > 1:
        orientation = noise_floored(orientation)
    return conditioned_prior.with_orientation(conditioned_orientation(
        orientation, observations, CONDITIONING_SIGMA))


def noise_floored(orientation: OrientationPrior) -> OrientationPrior:
    """``orientation`` with its step noise Q_i and initial covariance at least
    :data:`ROTATION_NOISE_FLOOR` ** 2 on r's diagonal (module docstring). Flooring twice
    changes nothing: a prior saved when the floor was applied at learning plans as before."""
    return OrientationPrior(orientation.time, orientation.Phi, orientation.u,
                            floor_noise(np.asarray(orientation.Q), ROTATION_NOISE_FLOOR),
                            orientation.mean0,
                            floor_noise(np.asarray(orientation.cov0), ROTATION_NOISE_FLOOR),
                            state_names=tuple(orientation.state_names), info=orientation.info)


def planning_prior(prior: Any, robot: Any, request: Any, config: Any,
                   previous: Any = None) -> Any:
    """:func:`position_planning_prior`; for a pose prior (``config.model.condition_on_targets``)
    conditioned on the start position even without a goal or via points (the start factor's
    optimum, docs/decisions.md#pose-prior), and its orientation chain on the start, goal and
    via rotations (:func:`with_rotation_targets`)."""
    position = position_planning_prior(prior, robot, request, config, previous)
    if getattr(prior, "orientation", None) is None or not config.model.condition_on_targets:
        return position
    if position is prior:
        position = conditioned(prior, target_observations(prior, robot, request),
                               CONDITIONING_SIGMA)
    return with_rotation_targets(position, prior, robot, request, config)


def position_planning_prior(prior: Any, robot: Any, request: Any, config: Any,
                            previous: Any = None) -> Any:
    """The prior a plan for ``request`` uses: ``prior`` conditioned on the start position and
    on the goal and via positions (joint targets through forward kinematics) when the request
    has any and ``config.model.condition_on_targets``; otherwise ``prior`` itself.
    ``previous``: the planning prior of ``prior`` for another request (a replan's previous
    plan's) or None; when it is conditioned at the same states with the same sigma, only
    its offsets are moved (:func:`clamp.prior.conditioning.retargeted`, the same prior to
    rounding, ~0.8 instead of ~2.5 ms)."""
    model = config.model
    if not model.condition_on_targets or (request.goal is None and not request.vias):
        return prior
    observations = target_observations(prior, robot, request)
    if (previous is not None and previous is not prior
            and same_pattern(previous, observations, CONDITIONING_SIGMA)):
        return retargeted(previous, observations)
    return conditioned(prior, observations, CONDITIONING_SIGMA)


def conditioned_reference(prior: Any, robot: Any, request: Any, config: Any,
                          model_prior: Any = None) -> Any:
    """``prior`` conditioned on the start, goal and via positions (``model_prior``, the
    :func:`planning_prior`, when it already is)."""
    if model_prior is not None and model_prior is not prior:
        return model_prior
    return with_rotation_targets(conditioned(prior, target_observations(prior, robot, request),
                                             CONDITIONING_SIGMA),
                                 prior, robot, request, config)


class _HandKinematics:
    """End-effector kinematics of :class:`HandPoint`: the state is the hand's own."""

    __slots__ = ("position", "velocity", "jacobian", "velocity_jacobian")

    def __init__(self, q: np.ndarray, qdot: np.ndarray):
        self.position, self.velocity = q, qdot
        self.jacobian = np.broadcast_to(np.eye(3), (len(q), 3, 3))
        self.velocity_jacobian = np.zeros((len(q), 3, 3))


class HandPoint:
    """The hand alone as a "robot" of 3 joints: q = its position [m], qdot = its velocity
    [m/s], fk the identity. A :class:`~clamp.graph.problem.PlanningProblem` over it is a
    problem in the workspace: the learned prior's families are linear Gaussian there, and a
    family that reads only ``window.workspace()`` acts on the hand's path as it does in a plan."""

    n = 3
    name = "hand"

    def fk(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(q, dtype=float)

    def ee_kinematics(self, q: np.ndarray, qdot: np.ndarray, jacobians: bool = True
                      ) -> _HandKinematics:
        return _HandKinematics(np.asarray(q, dtype=float), np.asarray(qdot, dtype=float))


class ReferenceUnderFamilies:
    """Where the skill goes under the caller's families: ``mean`` (T, 6) the workspace MAP
    (:func:`skill_reference`) with the spread of ``base`` (the conditioned prior): its
    samples, moved by the same offset (the plausibility's executions scatter about this mean
    as they scatter about the conditioned one); ``info`` and ``cov`` are the base's."""

    def __init__(self, base: Any, mean: np.ndarray):
        self.base = base
        self.mean = mean
        self.info = base.info
        self.time, self.dt = base.time, base.dt

    @property
    def T(self) -> int:
        return self.base.T

    @property
    def cov(self) -> np.ndarray:
        return self.base.cov

    @property
    def orientation(self) -> Any:
        """The base's orientation chain (a pose prior's; the caller's families act on the
        hand's path, not on its rotation)."""
        return getattr(self.base, "orientation", None)

    @property
    def std(self) -> np.ndarray:
        return self.base.std

    def sample(self, count: int, rng: Any) -> np.ndarray:
        return self.base.sample(count, rng) + (self.mean - np.asarray(self.base.mean))


def reference_families(families: Any) -> list[Family]:
    """The caller's families as they act on the hand's path (:meth:`Family.for_reference`),
    those that do not left out."""
    out = []
    for family in families:
        hand = family.for_reference()
        if hand is not None and len(hand):
            out.append(hand)
    return out


def _targets(request: Any) -> str:
    parts = ["start"] + (["goal"] if request.goal is not None else [])
    vias = len(request.vias)
    if vias:
        parts.append(f"{vias} via point{'s' if vias > 1 else ''}")
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def skill_reference(prior: Any, robot: Any, request: Any, config: Any,
                    model_prior: Any = None, families: Any = ()) -> tuple[Any, str]:
    """Where the skill goes for ``request`` and what that is, in words: ``prior`` conditioned
    on the start, goal and via positions (``model_prior``, the :func:`planning_prior`, when it
    already is); with caller ``families`` that act on the hand's path
    (:func:`reference_families`) and are active on its mean, the MAP of that conditioned
    workspace prior times them (:class:`ReferenceUnderFamilies`; see the module docstring)."""
    base = conditioned_reference(prior, robot, request, config, model_prior)
    name = f"prior conditioned on {_targets(request)}"
    hand = reference_families(families)
    if not hand:
        return base, name
    names = ", ".join(dict.fromkeys(f.name for f in hand))
    mean = np.asarray(base.mean)
    T = len(mean)
    problem = PlanningProblem(HandPoint(), T, [
        WorkspaceGPFamily(base.Phi, base.u, base.Q),
        WorkspaceStartFamily(np.asarray(base.mean0), np.asarray(base.cov0)), *hand], (), mean)
    window = problem.window(mean)
    if all(f.error(window) == 0.0 for f in hand):
        return base, f"{name} (the caller's families hold on it: {names})"
    opt = config.optimizer
    out = levenberg_marquardt(problem, mean, lambda_max=LAMBDA_UPPER_BOUND,
                              max_iterations=opt.max_iterations,
                              **opt.stopping_rule().solver_arguments(), workspace_correction=0)
    return (ReferenceUnderFamilies(base, out.theta),
            f"{name}, under the caller's families: {names}")
