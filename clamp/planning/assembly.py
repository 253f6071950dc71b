"""The parts of a planning model for a request (what :func:`clamp.planning.pipeline.model` assembles):
the planner's own factor families, the caller's extra factors, the initial trajectory (as
configured or given), the obstacle distance query and the tie to the free plan's posture."""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Union

import gtsam
import numpy as np

from clamp.config import PlannerConfig
from clamp.errors import InvalidParameterError
from clamp.factors import (EEPositionFamily, EERotationFamily, Family, JointGPFamily, JointLimitFamily,
                           JointTargetFamily, ObstacleFamily, PostureFamily, PostureMotionFamily,
                           OrientationGPFamily, OrientationStartFamily, PostureVelocityFamily,
                           WorkspaceGPFamily, WorkspaceStartFamily, shifted_start_mean)
from clamp.planning.initialisation import (Initialisation, joint_velocities, pose_refined,
                                           prior_mean_initialisation, straight_line_initialisation)
from clamp.graph.keys import state_key
from clamp.optim.optimizers import optimize
from clamp.graph.problem import PlanningProblem
from clamp.prior import so3
from clamp.factors import joint_limits
from clamp.planning.request import (IK_TOLERANCE, Request, Target, as_extras, as_sdf,
                                    has_obstacles)
from clamp.validation import as_array

PerStateFactorMaker = Callable[[int, int, int], Union[gtsam.NonlinearFactor, None]]
#: what ``extra_factors`` may hold: a family (fast path), any GTSAM factor on the planner's
#: state keys, or a maker(index, num_states, key) -> factor | None called for every state
ExtraFactor = Union[Family, gtsam.NonlinearFactor, PerStateFactorMaker]


def configured_initialisation(prior: Any, robot: Any, request: Request,
                              config: PlannerConfig) -> Initialisation:
    """The initial trajectory ``config.optimizer.initialisation`` asks for (T = the prior's
    support states): the prior mean's path followed by inverse kinematics ("prior_mean") or a
    straight line in joint space ("straight_line")."""
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    mean_path = np.asarray(prior.mean)[:, :3]
    opt, goal = config.optimizer, request.goal
    if opt.initialisation == "prior_mean":
        goal_position = None
        if goal is not None:
            goal_position = goal.value if goal.kind == "position" else robot.fk(goal.value)
        init = prior_mean_initialisation(robot, mean_path, dt, request.q_start, goal_position,
                                         True, IK_TOLERANCE)
        orientation = getattr(prior, "orientation", None)
        if orientation is None:
            return init
        return pose_refined(robot, init, orientation.mean_rotations, dt)
    first = request.q_start
    if goal is not None and goal.kind == "joint":
        last = goal.value
    else:
        end = goal.value if goal is not None else mean_path[-1]
        last = np.asarray(robot.ik(end, seed=first, tol=IK_TOLERANCE).q,
                          dtype=float)
    return straight_line_initialisation(robot, first, last, T, dt)



def given_initialisation(robot: Any, initial: Any, T: int, dt: float) -> Initialisation:
    """Initialisation from a given trajectory: q (T, n) or joint states [q, qdot] (T, 2n)."""
    n = robot.n
    if np.ndim(initial) == 2 and np.shape(initial)[1] == 2 * n:
        theta = as_array(initial, "initial", (T, 2 * n))
        q, qdot = theta[:, :n], theta[:, n:]
    else:
        q = as_array(initial, "initial", (T, n))
        qdot = joint_velocities(q, dt)
    return Initialisation(q, qdot, robot.fk(q), np.zeros(T))


def distance_query(scene: Any, sdf: Any = None, reach: float = math.inf) -> Callable | None:
    """The signed-distance query the obstacle family uses: ``sdf.query`` when given, else the
    scene's (exact for primitives, a grid cached by the scene otherwise), clipped at ``reach``
    [m] (the hinge's: epsilon + the largest sphere radius), so that only the obstacles near the
    arm are evaluated (a grid: of :data:`scenes.sdf.DEFAULT_CELL_SIZE`; pass ``sdf``, e.g.
    ``scene.sdf(cell_size)``, for another); None without obstacles."""
    sdf = as_sdf(sdf, scene)
    if not has_obstacles(scene):
        return None
    if sdf is not None:
        return sdf.query
    return scene.distance_query(max_distance=reach)


#: [rad] the start configuration's noise: the start is met to about this
START_SIGMA = 1e-6
#: [rad, rad/s] the joint-limit hinges' noise
LIMIT_SIGMA = 1e-3


def planner_families(prior: Any, robot: Any, request: Request, config: PlannerConfig,
                     query: Callable | None) -> list[Family]:
    """The planner's own factor families for ``request`` over the T support states of ``prior``
    (the conditioned prior); query: the obstacle distance (:func:`distance_query`) or None."""
    T, n, dt, model = prior.Phi.shape[0] + 1, robot.n, float(prior.dt), config.model
    families: list[Family] = [WorkspaceGPFamily(prior.Phi, prior.u, prior.Q)]
    families.append(WorkspaceStartFamily(
            shifted_start_mean(prior.mean0, prior.cov0, request.start_position),
            np.asarray(prior.cov0)))
    families += orientation_families(prior, robot, request, config)
    families.append(JointGPFamily(T, n, dt, model.Qc))
    start = request.start
    if start.kind == "position":
        # the IK solution becomes the start: a fully determined theta_0 keeps the problem
        # well conditioned (an end-effector start leaves the arm's self-motion free)
        start = Target("joint", request.q_start)
    targets = [(0, start, START_SIGMA)]
    if request.goal is not None:
        targets.append((T - 1, request.goal, model.goal_sigma))
    targets += [(i, target, model.goal_sigma) for i, target in request.vias]
    for kind, family in (("joint", JointTargetFamily), ("position", EEPositionFamily)):
        chosen = [(i, t.value, s) for i, t, s in targets if t.kind == kind]
        if chosen:
            index, value, sigma = zip(*chosen)
            families.append(family(index, np.array(value), sigma))
    if query is not None:
        families.append(ObstacleFamily(np.arange(T), robot.spheres.radii, query, model.epsilon,
                                       model.sigma_obs))
    families.append(JointLimitFamily(np.arange(T), robot.lower_limits, robot.upper_limits,
                                     robot.velocity_limits, LIMIT_SIGMA, 0.0,
                                     joint_limits.VELOCITY_MARGIN))
    return families


def orientation_families(prior: Any, robot: Any, request: Request,
                         config: PlannerConfig) -> list[Family]:
    """A pose prior's families: its orientation chain through the arm
    (:class:`~clamp.factors.OrientationGPFamily`) and its start at the arm's start rotation
    (:class:`~clamp.factors.OrientationStartFamily`, with the workspace start); for any prior
    the goal and via poses' rotations (:class:`~clamp.factors.EERotationFamily`, noise
    ``goal_sigma`` read in radians, for the goal and the via points alike). None for a
    position-only prior without poses."""
    orientation = getattr(prior, "orientation", None)
    model, T = config.model, prior.Phi.shape[0] + 1
    families: list[Family] = []
    if orientation is not None:
        families.append(OrientationGPFamily.of(orientation))
        start = so3.log_map(orientation.rotations[0].T @ robot.ee_rotation(request.q_start)[0])
        families.append(OrientationStartFamily(
            orientation.rotations[0], shifted_start_mean(orientation.mean0, orientation.cov0, start),
            np.asarray(orientation.cov0)))
    targets = [(T - 1, request.goal, model.goal_sigma)] if request.goal is not None else []
    targets += [(i, target, model.goal_sigma) for i, target in request.vias]
    chosen = [(i, t.rotation, s) for i, t, s in targets if t.rotation is not None]
    if chosen:
        index, rotation, sigma = zip(*chosen)
        families.append(EERotationFamily(index, np.array(rotation), sigma))
    return families


def split_extras(extra_factors: Sequence[ExtraFactor], T: int, robot: Any = None
                 ) -> tuple[list[Family], list[gtsam.NonlinearFactor]]:
    """The caller's ``extra_factors`` checked against T states: (families, GTSAM factors), the
    makers called for every state, every family for this plan (:meth:`Family.for_plan` with T
    and ``robot``); InvalidParameterError naming the bad entry."""
    families, factors = [], []
    for k, extra in enumerate(as_extras(extra_factors)):
        if isinstance(extra, Family):
            extra = extra.for_plan(T, robot)
            if len(extra) and (extra.first.min() < 0 or extra.first.max() + extra.arity > T):
                raise InvalidParameterError(f"extra_factors[{k}]: family {extra.name!r} uses "
                                            f"states outside 0..{T - 1}")
            families.append(extra)
        elif isinstance(extra, gtsam.NonlinearFactor):
            factors.append(extra)
        elif callable(extra):
            for i in range(T):
                made = extra(i, T, state_key(i))
                if made is None:
                    continue
                if not isinstance(made, gtsam.NonlinearFactor):
                    raise InvalidParameterError(f"extra_factors[{k}]: the maker returned "
                                                f"{type(made).__name__} for state {i}, expected "
                                                "a gtsam.NonlinearFactor or None")
                factors.append(made)
        else:
            raise InvalidParameterError(f"extra_factors[{k}]: expected a clamp Family, a "
                                        f"gtsam.NonlinearFactor or a callable maker(index, "
                                        f"num_states, key), got {type(extra).__name__}")
    return families, factors



def free_plan(problem: PlanningProblem, config: PlannerConfig,
              start: np.ndarray | None = None) -> np.ndarray:
    """The free plan (T, 2n): ``problem`` without its obstacle hinges, optimised as configured
    from ``problem.initial`` (one extra solve, ~10 ms), or from ``start`` (T, 2n), a guess of
    it (a replan: the previous free plan moved to the new targets). Solved to the configured
    tolerances either way: the warm-start rule's early stop left the Jaco's wrist elsewhere
    along the directions the empty scene hardly constrains (goal moved 10 cm: 1.3 rad from
    the fresh free plan's, 0.14 nats higher; moved -10 cm in x, a tied solve that failed and
    a plan 25 mm from the fresh one)."""
    initial = problem.initial if start is None else start
    return optimize(without_family(problem, ObstacleFamily.name, initial), config).theta


def tied_to_free_plan(problem: PlanningProblem, config: PlannerConfig,
                      keep_initial: bool = False, free: np.ndarray | None = None
                      ) -> PlanningProblem:
    """``problem`` tied to the free plan: every state's configuration (a
    :class:`~clamp.factors.PostureFamily` of noise ``config.model.posture_sigma``), unless
    ``config.model.posture_Qc`` is 0 the motion of the deviation from it (a
    :class:`~clamp.factors.PostureMotionFamily`: a smooth detour, not a swing out and back)
    and unless ``config.model.posture_velocity_sigma`` is 0 every joint velocity (a
    :class:`~clamp.factors.PostureVelocityFamily`: no joint keeps turning after a detour),
    starting from the free plan unless ``keep_initial``. The free plan is ``free`` (T, 2n)
    when given, else :func:`free_plan` of ``problem``: where it keeps clear of every
    obstacle by ``epsilon`` it is the tied problem's optimum as it is."""
    theta = free_plan(problem, config) if free is None else free
    T, n, model = problem.num_states, problem.robot.n, config.model
    ties: list[Family] = [PostureFamily(np.arange(T), theta[:, :n], np.full(T, model.posture_sigma))]
    if model.posture_Qc > 0:
        dt = float(problem.family(JointGPFamily.name).Phi[0, n])
        ties.append(PostureMotionFamily(theta, dt, model.posture_Qc))
    if model.posture_velocity_sigma > 0:
        ties.append(PostureVelocityFamily(theta, model.posture_velocity_sigma))
    return problem.with_families([*problem.families, *ties],
                                 problem.initial if keep_initial else theta)


def without_family(problem: PlanningProblem, name: str, initial: np.ndarray) -> PlanningProblem:
    """``problem`` without the family called ``name``, starting at initial (T, 2n)."""
    return problem.with_families([f for f in problem.families if f.name != name], initial)
