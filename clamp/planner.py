"""CLAMP planner: MAP inference of a joint trajectory under the learned workspace prior.

The factor graph (paper eq. 14-20) over joint states theta_i = [q_i, qdot_i] of the T support
states of the prior holds: the learned workspace GP factors, the workspace start factor
(learned initial velocity, position moved to the requested start), the constant-velocity joint
GP prior, start / goal / via-point factors, one obstacle factor per support state, joint-limit
factors, and any extra factors of the caller. Levenberg-Marquardt (the lean loop of
:mod:`clamp.levenberg_marquardt` by default, or GTSAM's) optimises it from an initial trajectory
(see :mod:`clamp.initialisation`).
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Union

import gtsam
import numpy as np

from clamp.errors import InvalidParameterError, ShapeError
from clamp.factors import (TrajectoryEvaluator, ee_position_factors, joint_gp_factors,
                           joint_limit_factors, joint_position_factor, obstacle_factors,
                           shifted_start_mean, workspace_gp_factors, workspace_start_factor)
from clamp.initialisation import (INITIALISATIONS, Initialisation, joint_velocities,
                                  prior_mean_initialisation, straight_line_initialisation)
from clamp.keys import state_key, states_to_values, values_to_states
from clamp.levenberg_marquardt import DAMPING_UPDATES, SOLVERS, levenberg_marquardt
from clamp.validation import as_array, as_count, as_scalar
from clamp.vectorized_graph import VectorizedGraph
from clamp.workspace_correction import WorkspaceCorrection

OPTIMIZERS = ("lean", "gtsam")
PerStateFactorMaker = Callable[[int, int, int], Union[gtsam.NonlinearFactor, None]]
ExtraFactor = Union[gtsam.NonlinearFactor, PerStateFactorMaker]


@dataclass
class PlannerConfig:
    """Planner settings. The factor graph's defaults are the reference implementation's
    (box_closing demo); the optimizer's defaults add the workspace correction and banded solver and
    stop after two consecutive steps below a 0.1 % relative decrease (:meth:`reference` gives
    the reference's optimizer).

    epsilon [m] obstacle safety distance; sigma_obs obstacle noise; Qc joint GP power spectral
    density; start_sigma [m or rad] start fix; goal_sigma / via_sigma for goal and via-points;
    limit_sigma, limit_margin [rad], velocity_margin [rad/s] for joint limits;
    sdf_cell_size [m]; initialisation "prior_mean" (IK of the shifted prior mean) or
    "straight_line" (between the start configuration and IK of the prior's mean final
    position, or the given goal; ``straight_line_configurations`` overrides both ends);
    optimizer "lean" (:mod:`clamp.levenberg_marquardt` on the numpy linearization of
    :mod:`clamp.vectorized_graph`, cheaper per iteration) or "gtsam" (gtsam's optimizer);
    Levenberg-Marquardt: lambda_initial, lambda_upper_bound, max_iterations, relative and
    absolute error tolerances; lean optimizer only: workspace_correction, the number of
    per-state Gauss-Newton updates that move every trial point back onto the workspace states
    the linear model predicts (:mod:`clamp.workspace_correction`; 0 = the reference's plain
    LM, which crawls against stiff learned priors), linear_solver "banded" (banded
    Cholesky of the scaled normal equations, QR where that fails; cheapest), "qr" or
    "cholesky" (the reference's; it fails at the small damping the corrected steps allow) and
    damping_update "gain_ratio" (lambda follows the ratio of actual to predicted decrease) or
    "gtsam" (the reference's fixed factor 10); convergence_patience, the number of consecutive
    accepted steps below the tolerances that stop the loop (the reference's: 1; 2 tolerates
    one small step on a non-monotone descent). The graph error is a negative log posterior
    in nats, so the default absolute tolerance 0.01 stops once steps change the posterior
    density by less than 1 % (the reference's 1e-5 keeps polishing the joint-space
    smoothness of an already converged end-effector path: 13 instead of 3 iterations on
    box_closing in an empty scene). With the correction the linear model is accurate
    from the first step, hence the small default lambda_initial (reference: 1e3).
    Success checks: start_tolerance [m], goal_tolerance [m or rad], ik_tolerance [m] for
    reaching the start, limit_tolerance [rad] on position limits (the
    limit factors are soft, sigma limit_sigma) and velocity_tolerance [rad/s] on velocity limits.
    """

    epsilon: float = 0.05
    sigma_obs: float = 0.05
    Qc: float = 1.0
    start_sigma: float = 1e-6
    goal_sigma: float = 1e-3
    via_sigma: float = 1e-3
    workspace_start: bool = True
    fix_start_configuration: bool = True
    obstacle_factors: bool = True
    joint_limits: bool = True
    limit_sigma: float = 1e-3
    limit_margin: float = 0.0
    velocity_margin: float = 0.0
    sdf_cell_size: float = 0.01
    initialisation: str = "prior_mean"
    blend_start_offset: bool = True
    straight_line_configurations: tuple[Any, Any] | None = None
    optimizer: str = "lean"
    lambda_initial: float = 0.1
    lambda_upper_bound: float = 1e10
    max_iterations: int = 500
    relative_error_tol: float = 1e-3
    absolute_error_tol: float = 1e-2
    workspace_correction: int = 2
    convergence_patience: int = 2
    linear_solver: str = "banded"
    damping_update: str = "gain_ratio"
    start_tolerance: float = 1e-3
    goal_tolerance: float = 0.02
    ik_tolerance: float = 1e-4
    limit_tolerance: float = 1e-4
    velocity_tolerance: float = 1e-3

    @classmethod
    def reference(cls, **changes: Any) -> "PlannerConfig":
        """The reference implementation's optimizer: plain LM (no workspace correction,
        Cholesky) stopping at a 1e-5 relative or absolute decrease. ``changes`` override fields."""
        return cls(**{"workspace_correction": 0, "linear_solver": "cholesky",
                      "damping_update": "gtsam", "lambda_initial": 1e3,
                      "relative_error_tol": 1e-5, "absolute_error_tol": 1e-5,
                      "convergence_patience": 1, **changes})

    @classmethod
    def fast(cls, **changes: Any) -> "PlannerConfig":
        """Settings for planning inside a control loop: a stronger obstacle term (sigma_obs
        0.005: with the reference's 0.05 the optimum may still touch obstacles that overlap
        the learned path) and a loose stopping rule (one step below a 5 % relative decrease),
        giving a collision-free but less polished plan in under ten iterations: its
        workspace-prior cost is higher, so check ``success_probability`` (or warm-start a full
        run from it). ``changes`` override fields."""
        return cls(**{"sigma_obs": 0.005, "relative_error_tol": 0.05, "convergence_patience": 1,
                      **changes})

    def validate(self) -> "PlannerConfig":
        """Check every field; raises InvalidParameterError naming the bad one."""
        for name in ("epsilon", "limit_margin", "velocity_margin", "relative_error_tol",
                     "absolute_error_tol", "limit_tolerance", "velocity_tolerance"):
            as_scalar(getattr(self, name), f"config.{name}", minimum=0.0)
        for name in ("sigma_obs", "Qc", "start_sigma", "goal_sigma", "via_sigma", "limit_sigma",
                     "sdf_cell_size", "lambda_initial", "lambda_upper_bound", "start_tolerance",
                     "goal_tolerance", "ik_tolerance"):
            as_scalar(getattr(self, name), f"config.{name}", strictly_positive=True)
        as_count(self.max_iterations, "config.max_iterations", minimum=0)
        as_count(self.workspace_correction, "config.workspace_correction", minimum=0)
        as_count(self.convergence_patience, "config.convergence_patience", minimum=1)
        if self.damping_update not in DAMPING_UPDATES:
            raise InvalidParameterError(f"config.damping_update: unknown "
                                        f"{self.damping_update!r}; valid: "
                                        f"{', '.join(DAMPING_UPDATES)}")
        if self.linear_solver not in SOLVERS:
            raise InvalidParameterError(f"config.linear_solver: unknown {self.linear_solver!r}; "
                                        f"valid: {', '.join(SOLVERS)}")
        if self.optimizer not in OPTIMIZERS:
            raise InvalidParameterError(f"config.optimizer: unknown {self.optimizer!r}; "
                                        f"valid: {', '.join(OPTIMIZERS)}")
        if self.initialisation not in INITIALISATIONS:
            raise InvalidParameterError(f"config.initialisation: unknown {self.initialisation!r};"
                                        f" valid: {', '.join(INITIALISATIONS)}")
        return self


@dataclass
class Target:
    """A start / goal / via-point: kind "joint" (value (n,) rad) or "position" (value (3,) m)."""

    kind: str
    value: np.ndarray


@dataclass
class PlanningProblem:
    """What :func:`build` returns: the factor graph, its initial values and bookkeeping.

    families maps a factor family name to the indices of its factors in ``graph``;
    q_start (n,) start configuration; start_position (3,) its end-effector position.
    """

    graph: gtsam.NonlinearFactorGraph
    initial: gtsam.Values
    evaluator: TrajectoryEvaluator
    families: dict[str, list[int]]
    initialisation: Initialisation
    q_start: np.ndarray
    start_position: np.ndarray
    goal: Target | None
    sdf: Any
    dt: float
    build_seconds: float


@dataclass
class PlanResult:
    """Outcome of :func:`plan` (plain data).

    q, qdot (T, n) [rad, rad/s]; ee_path, ee_velocity (T, 3) [m, m/s]; time (T,) [s];
    timings [s] ("sdf", "build" (incl. initialisation), "optimize", "total"; the lean
    optimizer adds its phases "linearize", "solve", "correction", "error"); trials = solved
    trial steps (accepted or rejected; 0 for the gtsam optimizer);
    errors are GTSAM graph errors (0.5 sum of squared whitened residuals); family_errors per
    factor family; collision_cost = error of the obstacle factors; min_clearance [m] = smallest
    exact distance (scene's analytic geometry) between any collision sphere and any obstacle
    over all states (+inf without obstacles); start_error, goal_error [m] (goal_error in rad for
    a joint goal; None without goal); log_likelihood and success_probability of the plan's
    workspace trajectory under the prior (initial-state term left out: the plan starts
    elsewhere); within_limits: joint position and velocity limits hold at every state;
    success and reasons (why it failed).
    """

    q: np.ndarray
    qdot: np.ndarray
    ee_path: np.ndarray
    ee_velocity: np.ndarray
    time: np.ndarray
    timings: dict[str, float]
    iterations: int
    initial_error: float
    final_error: float
    family_errors: dict[str, float]
    collision_cost: float
    min_clearance: float
    start_error: float
    goal_error: float | None
    log_likelihood: float
    success_probability: float
    within_limits: bool
    success: bool
    reasons: list[str] = field(default_factory=list)
    initialisation: str = "prior_mean"
    initial_q: np.ndarray | None = None
    trials: int = 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (arrays as nested lists, +inf as None)."""
        out: dict[str, Any] = {}
        for key, value in asdict(self).items():
            if isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, float) and not np.isfinite(value):
                value = None
            out[key] = value
        return out


# ---------------------------------------------------------------------------------- inputs
def _check_prior(prior: Any) -> None:
    for attr in ("Phi", "u", "Q", "mean0", "cov0", "mean", "dt"):
        if not hasattr(prior, attr):
            raise InvalidParameterError(f"prior: expected a clamp.WorkspacePrior, "
                                        f"got {type(prior).__name__} without '{attr}'")
    if np.shape(prior.Phi)[1:] != (6, 6):
        raise ShapeError(f"prior: expected a workspace prior over x = [p, v] (D = 6), "
                         f"got Phi of shape {np.shape(prior.Phi)}")


def _check_robot(robot: Any) -> None:
    for attr in ("n", "ee_kinematics", "sphere_centres", "fk", "ik", "ik_trajectory"):
        if not hasattr(robot, attr):
            raise InvalidParameterError(f"robot: expected a robots.Robot, got "
                                        f"{type(robot).__name__} without '{attr}'")


def as_target(value: Any, name: str, n: int) -> Target:
    """A joint configuration (n,) or an end-effector position (3,) (joint wins when n == 3)."""
    size = np.size(value) if np.ndim(value) == 1 else -1
    if size == n:
        return Target("joint", as_array(value, name, (n,)))
    if size == 3:
        return Target("position", as_array(value, name, (3,)))
    raise ShapeError(f"{name}: expected a joint configuration ({n},) or an end-effector "
                     f"position (3,), got shape {np.shape(value)}")


def _via_targets(via_points: Sequence[tuple[int, Any]], T: int, n: int) -> list[tuple[int, Target]]:
    out = []
    for k, item in enumerate(via_points):
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ShapeError(f"via_points[{k}]: expected a pair (index, position (3,) or "
                             f"configuration ({n},)), got {item!r}")
        index = as_count(item[0], f"via_points[{k}] index", minimum=0)
        if index >= T:
            raise InvalidParameterError(f"via_points[{k}] index: expected 0 <= index < {T}, "
                                        f"got {index}")
        out.append((index, as_target(item[1], f"via_points[{k}] target", n)))
    return out


def _has_obstacles(scene: Any) -> bool:
    return scene is not None and len(getattr(scene, "obstacles", ())) > 0


# ---------------------------------------------------------------------------------- building
def resolve_start(robot: Any, start: Target, config: PlannerConfig) -> tuple[np.ndarray, float]:
    """Start configuration (n,) and its end-effector position error [m] (IK for a position)."""
    if start.kind == "joint":
        return start.value, 0.0
    ik = robot.ik(start.value, tol=min(config.ik_tolerance, config.start_tolerance))
    return np.asarray(ik.q, dtype=float), float(ik.error)


def _initialise(prior: Any, robot: Any, q_start: np.ndarray, goal: Target | None,
                config: PlannerConfig) -> Initialisation:
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    mean_path = np.asarray(prior.mean)[:, :3]
    if config.initialisation == "prior_mean":
        goal_position = None
        if goal is not None:
            goal_position = goal.value if goal.kind == "position" else robot.fk(goal.value)
        return prior_mean_initialisation(robot, mean_path, dt, q_start, goal_position,
                                         config.blend_start_offset, config.ik_tolerance)
    if config.straight_line_configurations is not None:
        first = as_array(config.straight_line_configurations[0],
                         "config.straight_line_configurations[0]", (robot.n,))
        last = as_array(config.straight_line_configurations[1],
                        "config.straight_line_configurations[1]", (robot.n,))
    else:
        first = q_start
        if goal is not None and goal.kind == "joint":
            last = goal.value
        else:
            end = goal.value if goal is not None else mean_path[-1]
            last = np.asarray(robot.ik(end, seed=q_start, tol=config.ik_tolerance).q, dtype=float)
    return straight_line_initialisation(robot, first, last, T, dt)


def warm_start(robot: Any, initial: Any, T: int, dt: float) -> Initialisation:
    """Initialisation from a given trajectory: q (T, n) or joint states [q, qdot] (T, 2n)."""
    n = robot.n
    if np.ndim(initial) == 2 and np.shape(initial)[1] == 2 * n:
        theta = as_array(initial, "initial", (T, 2 * n))
        q, qdot = theta[:, :n], theta[:, n:]
    else:
        q = as_array(initial, "initial", (T, n))
        qdot = joint_velocities(q, dt)
    return Initialisation(q, qdot, robot.fk(q), np.zeros(T))


def build(prior: Any, robot: Any, scene: Any = None, start: Any = None, goal: Any = None,
          via_points: Sequence[tuple[int, Any]] = (), extra_factors: Sequence[ExtraFactor] = (),
          config: PlannerConfig | None = None, sdf: Any = None,
          q_start: np.ndarray | None = None, initial: np.ndarray | None = None) -> PlanningProblem:
    """Factor graph and initial values for reproducing ``prior`` with ``robot`` from ``start``.

    prior: clamp.WorkspacePrior (T support states, step dt); robot: robots.Robot (n joints);
    scene: scenes.Scene or None; start: joint configuration (n,) [rad] or end-effector
    position (3,) [m]; goal: the same kinds, or None; via_points: (index, position (3,) or
    configuration (n,)); extra_factors: gtsam.NonlinearFactor or
    maker(index, num_states, key) -> factor | None called for every support state;
    sdf: a precomputed scenes.SignedDistanceField of ``scene`` (built otherwise);
    q_start: start configuration to use for a position start (IK otherwise);
    initial: a warm start, joint positions (T, n) (velocities by finite differences) or joint
    states (T, 2n), replacing ``config.initialisation`` (e.g. the previous plan).
    Raises ClampError subclasses on bad input.
    """
    t0 = time.perf_counter()
    config = (config or PlannerConfig()).validate()
    _check_prior(prior)
    _check_robot(robot)
    n = robot.n
    if start is None:
        raise InvalidParameterError("start: expected a joint configuration "
                                    f"({n},) or an end-effector position (3,), got None")
    start_target = as_target(start, "start", n)
    goal_target = None if goal is None else as_target(goal, "goal", n)
    T, dt = prior.Phi.shape[0] + 1, float(prior.dt)
    vias = _via_targets(via_points, T, n)
    for k, extra in enumerate(extra_factors):
        if not isinstance(extra, gtsam.NonlinearFactor) and not callable(extra):
            raise InvalidParameterError(f"extra_factors[{k}]: expected a gtsam.NonlinearFactor "
                                        f"or a callable maker(index, num_states, key), "
                                        f"got {type(extra).__name__}")
    if q_start is None:
        q_start, _ = resolve_start(robot, start_target, config)
    else:
        q_start = as_array(q_start, "q_start", (n,))
    start_position = start_target.value if start_target.kind == "position" else robot.fk(q_start)

    if sdf is None and config.obstacle_factors and _has_obstacles(scene):
        sdf = scene.sdf(config.sdf_cell_size)
    init = (_initialise(prior, robot, q_start, goal_target, config) if initial is None
            else warm_start(robot, initial, T, dt))

    evaluator = TrajectoryEvaluator(robot, T)
    graph = gtsam.NonlinearFactorGraph()
    families: dict[str, list[int]] = {}

    def add(name: str, factors: Sequence[gtsam.NonlinearFactor]) -> None:
        first = graph.size()
        for f in factors:
            graph.add(f)
        families.setdefault(name, []).extend(range(first, graph.size()))

    add("workspace_gp", workspace_gp_factors(evaluator, np.asarray(prior.Phi),
                                             np.asarray(prior.u), np.asarray(prior.Q)))
    if config.workspace_start:
        mean = shifted_start_mean(np.asarray(prior.mean0), start_position)
        add("workspace_start", [workspace_start_factor(evaluator, mean, np.asarray(prior.cov0))])
    add("joint_gp", joint_gp_factors(T, n, dt, config.Qc))

    ee_indices, ee_targets, ee_sigmas = [], [], []
    endpoint_joint = []
    if start_target.kind == "position" and config.fix_start_configuration:
        # the IK solution becomes the start: a fully determined theta_0 keeps the problem
        # well conditioned (an end-effector start leaves the arm's self-motion free)
        start_target = Target("joint", q_start)
    targets = [(0, start_target, config.start_sigma)]
    if goal_target is not None:
        targets.append((T - 1, goal_target, config.goal_sigma))
    targets += [(i, tgt, config.via_sigma) for i, tgt in vias]
    for index, target, sigma in targets:
        if target.kind == "joint":
            endpoint_joint.append(joint_position_factor(index, target.value, sigma))
        else:
            ee_indices.append(index)
            ee_targets.append(target.value)
            ee_sigmas.append(sigma)
    if ee_indices:
        endpoint_joint += ee_position_factors(evaluator, ee_indices, np.array(ee_targets), ee_sigmas)
    add("endpoint", endpoint_joint)

    if sdf is not None and config.obstacle_factors:
        add("obstacle", obstacle_factors(evaluator, range(T), np.asarray(robot.spheres.radii),
                                         sdf.query, config.epsilon, config.sigma_obs))
    if config.joint_limits:
        add("joint_limits", joint_limit_factors(
            evaluator, range(T), np.asarray(robot.lower_limits), np.asarray(robot.upper_limits),
            np.asarray(robot.velocity_limits), config.limit_sigma, config.limit_margin,
            config.velocity_margin))
    extras: list[gtsam.NonlinearFactor] = []
    for extra in extra_factors:
        if isinstance(extra, gtsam.NonlinearFactor):
            extras.append(extra)
        else:
            extras += [f for f in (extra(i, T, state_key(i)) for i in range(T)) if f is not None]
    known = set(evaluator.keys)
    for k, factor in enumerate(extras):
        if not isinstance(factor, gtsam.NonlinearFactor):
            raise InvalidParameterError(f"extra_factors: a maker returned {type(factor).__name__}, "
                                        "expected a gtsam.NonlinearFactor or None")
        unknown = [gtsam.DefaultKeyFormatter(key) for key in factor.keys() if key not in known]
        if unknown:
            raise InvalidParameterError(f"extra_factors: factor {k} uses keys {unknown} that are "
                                        f"not planner states (state_key(0..{T - 1}))")
    if extras:
        add("extra", extras)

    initial = states_to_values(init.theta, evaluator.keys)
    return PlanningProblem(graph, initial, evaluator, families, init, q_start, start_position,
                           goal_target, sdf, dt, time.perf_counter() - t0)


# ---------------------------------------------------------------------------------- solving
def optimizer_parameters(config: PlannerConfig) -> gtsam.LevenbergMarquardtParams:
    """GTSAM Levenberg-Marquardt parameters from the config."""
    params = gtsam.LevenbergMarquardtParams()
    params.setlambdaInitial(config.lambda_initial)
    params.setlambdaUpperBound(config.lambda_upper_bound)
    params.setMaxIterations(config.max_iterations)
    params.setRelativeErrorTol(config.relative_error_tol)
    params.setAbsoluteErrorTol(config.absolute_error_tol)
    return params


def optimize(problem: PlanningProblem, config: PlannerConfig,
             details: dict[str, float] | None = None) -> tuple[gtsam.Values, int, float, float]:
    """Run Levenberg-Marquardt on ``problem``: (values, iterations, initial error, final error).

    details: optional dict that receives the lean optimizer's seconds per phase ("linearize",
    "solve", "correction", "error") and its number of trial steps ("trials").
    """
    if config.optimizer == "gtsam":
        optimizer = gtsam.LevenbergMarquardtOptimizer(problem.graph, problem.initial,
                                                      optimizer_parameters(config))
        initial_error = float(optimizer.error())
        values = optimizer.optimize()
        return values, int(optimizer.iterations()), initial_error, float(optimizer.error())
    T, n = problem.evaluator.num_states, problem.evaluator.robot.n
    out = levenberg_marquardt(problem.graph, problem.initial, problem.evaluator.keys, [2 * n] * T,
                              config.lambda_initial, config.lambda_upper_bound,
                              max_iterations=config.max_iterations,
                              relative_error_tol=config.relative_error_tol,
                              absolute_error_tol=config.absolute_error_tol,
                              correction=WorkspaceCorrection(problem.evaluator.robot,
                                                             problem.evaluator.keys,
                                                             config.workspace_correction),
                              solver=config.linear_solver,
                              damping_update=config.damping_update,
                              patience=config.convergence_patience,
                              system=VectorizedGraph(problem.graph, problem.evaluator))
    if details is not None:
        details.update(out.timings, trials=out.trials)
    return out.values, out.iterations, out.initial_error, out.final_error


def family_errors(problem: PlanningProblem, values: gtsam.Values) -> dict[str, float]:
    """Graph error of every factor family at ``values``."""
    return {name: float(sum(problem.graph.at(i).error(values) for i in idx))
            for name, idx in problem.families.items()}


def sphere_clearance(robot: Any, scene: Any, q: np.ndarray) -> np.ndarray:
    """Exact clearance (T, S) [m] of every collision sphere at q (T, n); +inf without obstacles."""
    centres, _ = robot.sphere_centres(q)
    if not _has_obstacles(scene):
        return np.full(centres.shape[:2], np.inf)
    return scene.distance(centres) - np.asarray(robot.spheres.radii)


def _failed(prior: Any, robot: Any, q: np.ndarray, reasons: list[str], t0: float,
            start_error: float, config: PlannerConfig) -> PlanResult:
    T, n = q.shape
    kin = robot.ee_kinematics(q, np.zeros_like(q), jacobians=False)
    return PlanResult(q=q, qdot=np.zeros_like(q), ee_path=kin.position,
                      ee_velocity=kin.velocity, time=np.asarray(prior.time, dtype=float),
                      timings={"sdf": 0.0, "build": 0.0, "optimize": 0.0,
                               "total": time.perf_counter() - t0},
                      iterations=0, initial_error=float("nan"), final_error=float("nan"),
                      family_errors={}, collision_cost=float("nan"),
                      min_clearance=float("nan"), start_error=start_error, goal_error=None,
                      log_likelihood=float("nan"), success_probability=0.0,
                      within_limits=bool(np.all(robot.within_limits(q))), success=False,
                      reasons=reasons, initialisation=config.initialisation)


def plan(prior: Any, robot: Any, scene: Any = None, start: Any = None, goal: Any = None,
         via_points: Sequence[tuple[int, Any]] = (), extra_factors: Sequence[ExtraFactor] = (),
         config: PlannerConfig | None = None, sdf: Any = None,
         initial: np.ndarray | None = None) -> PlanResult:
    """Reproduce the skill of ``prior`` with ``robot`` from ``start`` in ``scene``.

    Arguments as for :func:`build`. A start that is out of reach or in collision gives
    ``success=False`` with a reason (no exception); bad input raises ClampError subclasses.
    """
    t0 = time.perf_counter()
    config = (config or PlannerConfig()).validate()
    _check_prior(prior)
    _check_robot(robot)
    n, T = robot.n, prior.Phi.shape[0] + 1
    if start is None:
        raise InvalidParameterError(f"start: expected a joint configuration ({n},) or an "
                                    "end-effector position (3,), got None")
    start_target = as_target(start, "start", n)
    q_start, ik_error = resolve_start(robot, start_target, config)
    reasons = []
    if start_target.kind == "position" and ik_error > config.start_tolerance:
        reasons.append(f"start position {np.round(start_target.value, 4).tolist()} is out of "
                       f"reach (IK error {ik_error * 1000:.1f} mm)")
    elif _has_obstacles(scene):
        if start_target.kind == "position" and float(scene.distance(start_target.value)) < 0:
            reasons.append("start position is inside an obstacle")
        clearance = sphere_clearance(robot, scene, q_start[None])
        if np.min(clearance) < 0:
            reasons.append(f"start configuration is in collision (clearance "
                           f"{np.min(clearance) * 1000:.1f} mm)")
    if reasons:
        return _failed(prior, robot, np.repeat(q_start[None], T, axis=0), reasons, t0,
                       ik_error, config)

    t_sdf = time.perf_counter()
    if sdf is None and config.obstacle_factors and _has_obstacles(scene):
        sdf = scene.sdf(config.sdf_cell_size)
    sdf_seconds = time.perf_counter() - t_sdf
    problem = build(prior, robot, scene, start, goal, via_points, extra_factors, config,
                    sdf=sdf, q_start=q_start, initial=initial)

    t_opt = time.perf_counter()
    details: dict[str, float] = {}
    values, iterations, initial_error, final_error = optimize(problem, config, details)
    optimize_seconds = time.perf_counter() - t_opt
    total = time.perf_counter() - t0
    trials = int(details.pop("trials", iterations))
    result = _evaluate(prior, robot, scene, problem, values, config, start_target,
                       {"sdf": sdf_seconds, "build": problem.build_seconds,
                        "optimize": optimize_seconds, "total": total, **details},
                       iterations, initial_error, final_error)
    result.trials = trials
    return result


def _evaluate(prior: Any, robot: Any, scene: Any, problem: PlanningProblem, values: gtsam.Values,
              config: PlannerConfig, start: Target, timings: dict[str, float], iterations: int,
              initial_error: float, final_error: float) -> PlanResult:
    """Metrics and success checks of an optimised plan."""
    n = robot.n
    theta = values_to_states(values, problem.evaluator.keys)
    q, qdot = theta[:, :n], theta[:, n:]
    kin = robot.ee_kinematics(q, qdot, jacobians=False)
    x = np.concatenate([kin.position, kin.velocity], axis=1)
    families = family_errors(problem, values)
    clearance = float(np.min(sphere_clearance(robot, scene, q)))
    if start.kind == "position":
        start_error = float(np.linalg.norm(kin.position[0] - start.value))
    else:
        start_error = float(np.linalg.norm(q[0] - start.value))
    goal_error = None
    if problem.goal is not None:
        reached = kin.position[-1] if problem.goal.kind == "position" else q[-1]
        goal_error = float(np.linalg.norm(reached - problem.goal.value))
    within = bool(np.all(robot.within_limits(q, config.limit_tolerance)) and np.all(
        np.abs(qdot) <= np.asarray(robot.velocity_limits) + config.velocity_tolerance))
    log_likelihood = float(prior.log_likelihood(x, initial=False))
    probability = float(prior.success_probability(x)) if hasattr(prior, "success_probability") \
        else float("nan")

    reasons = []
    if not np.isfinite(final_error):
        reasons.append("optimisation diverged (non-finite error)")
    if start_error > config.start_tolerance:
        reasons.append(f"start error {start_error:.4g} exceeds {config.start_tolerance:.4g}")
    if goal_error is not None and goal_error > config.goal_tolerance:
        reasons.append(f"goal error {goal_error:.4g} exceeds {config.goal_tolerance:.4g}")
    if clearance < 0:
        reasons.append(f"collision: minimum clearance {clearance * 1000:.1f} mm")
    if not within:
        reasons.append("joint position or velocity limits violated")
    return PlanResult(q=q, qdot=qdot, ee_path=kin.position, ee_velocity=kin.velocity,
                      time=np.asarray(prior.time, dtype=float), timings=timings,
                      iterations=iterations, initial_error=initial_error, final_error=final_error,
                      family_errors=families, collision_cost=families.get("obstacle", 0.0),
                      min_clearance=clearance, start_error=start_error, goal_error=goal_error,
                      log_likelihood=log_likelihood, success_probability=probability,
                      within_limits=within, success=not reasons, reasons=reasons,
                      initialisation=config.initialisation, initial_q=problem.initialisation.q)
