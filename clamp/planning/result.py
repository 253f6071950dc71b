"""What :func:`clamp.plan` returns: the plan, its verdict and its uncertainty, as plain data."""
from __future__ import annotations

from copy import deepcopy
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from robots.errors import RetimingError
from robots.retiming import retime as retime_trajectory
from robots.trajectory import JointTrajectory


@dataclass(frozen=True)
class PlanInputs:
    """What a plan was asked (kept by :func:`clamp.plan` on ``PlanResult.inputs`` for
    :func:`clamp.replan`): the arguments of the call (start, goal and via points as validated:
    arrays (n,) [rad] or (3,) [m]) and the prior it planned with (``model_prior``: the learned
    prior conditioned on the start, goal and via points); ``free_plan``: the free plan (T, 2n)
    the plan was tied to (None without obstacles or the tie), a replan's start of its own."""

    prior: Any
    robot: Any
    scene: Any
    start: Any
    goal: Any
    via_points: tuple
    extra_factors: tuple
    config: Any
    sdf: Any
    model_prior: Any
    free_plan: Any = None


@dataclass
class PlanResult:
    """Outcome of :func:`clamp.plan`.

    q, qdot (T, n) [rad, rad/s]; ee_path, ee_velocity (T, 3) [m, m/s]; time (T,) [s];
    timings [s] ("build" (incl. initialisation and distance field), "optimize", "marginals",
    "total"; the fast solver adds its phases "linearize", "solve", "correction", "error" (of
    the chosen solve); with obstacles "constraint_loop" (every solve and check) and "clearance"
    (the real-geometry checks, the verdict's included));
    iterations accepted steps, trials solved steps (0 for GTSAM's optimizers; both summed over
    the constraint loop's solves), stop_reason (the optimizer's, or "infeasible" when the plan
    fails its verdict: never "converged" on a failing plan);
    errors are graph errors in nats (0.5 sum of squared whitened residuals); family_errors per
    factor family; collision_cost = error of the obstacle factors; min_clearance [m] smallest
    distance between the robot's collision geometry and any obstacle, at every state and in
    between (no link point moves more than 5 mm between checks; negative: penetration depth;
    +inf without obstacles), measured on ``collision_geometry`` ("urdf": the URDF's collision
    meshes; "spheres": the robot has none, its collision spheres; None without obstacles);
    nearest_contact: where min_clearance occurs (link, geometry, obstacle, fractional state
    index, time [s], distance [m]); attempts: the solves of the constrained solve
    (:mod:`clamp.optim.constrained`: candidate, round, obstacle hinge sigma [m] (nan without),
    min_distance [m] (inf without obstacles), feasible, prior_cost [nats], iterations, the
    constraint families found violated; one entry when the first solve met every check);
    initial_error / final_error: the graph errors of the first problem at its initial
    trajectory and of the problem solved at the plan (``problem``: shifts and weights of its
    constraint families included); start_error, goal_error [m] (rad for joint targets; None without goal),
    via_errors [m or rad] one per via point; goal_rotation_error, via_rotation_errors [rad] the
    hand's angle from a goal or via pose's rotation (None without one);
    log_likelihood of the plan's workspace path under the prior (initial-state term left out);
    plausibility: the share of sampled executions of the skill (from the plan's start, meeting
    its goal and via points) that stray from it at least as far as the plan
    (:func:`clamp.prior.skill.skill_plausibility`: uniform on such samples, >= 0.05 for held-out
    demonstrations, resolution 1/201; threshold it like a p-value);
    skill: the skill checks' figures (:class:`clamp.prior.skill.SkillCheck`: max_tube_ratio, the
    plan's largest distance from where the skill goes in units of the demonstrations' spread
    there, limit tube_limit; worst_state; end_distance [m] from where the demonstrations end
    and completion_radius [m], None when a goal was given; with a pose prior the orientation
    figures too (:class:`clamp.prior.orientation_skill.OrientationCheck`: max_angle_ratio,
    worst_angle_state, max_angle_deg, angle_at_worst_deg, end_angle_deg, completion_angle_deg);
    reference: what the plan is judged
    against, in words: "prior conditioned on start and goal", or with caller families that act
    on the hand's path "..., under the caller's families: tlgc_boundary",
    :func:`clamp.planning.reference.skill_reference`); self_clearance [m]: least distance
    between two of the robot's own links that may touch (:mod:`robots.self_collision`: URDF
    collision geometry, adjacent / rigid / always-touching pairs left out; at and between
    states; negative: overlap depth), self_contact: where; fixed_overlaps: (link, obstacle,
    depth [m]) of the robot's world-fixed links (its base) overlapping an obstacle (a warning,
    not a failure: such links never move; :mod:`robots.collision_check`); within_limits;
    success and reasons (why it failed);
    state_covariance (T, 2n, 2n) and ee_covariance (T, 3, 3) [m^2]: Laplace posterior
    covariance of every joint state and end-effector position at the optimum (None when not
    computed); inputs: what the plan was asked (:class:`PlanInputs`); violations: per
    constraint family (e.g. "orientation") how far beyond its tolerance the plan goes [rad for
    orientation] (0.0: met); covariance_floor: information [1/rad^2] added to every coordinate
    because the graph left a direction unconstrained (0.0: the exact Laplace covariance; see
    :mod:`clamp.optim.uncertainty`).
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
    plausibility: float
    within_limits: bool
    success: bool
    reasons: list[str] = field(default_factory=list)
    initialisation: str = "prior_mean"
    initial_q: np.ndarray | None = None
    trials: int = 0
    optimizer: str = "fast"
    stop_reason: str = ""
    state_covariance: np.ndarray | None = None
    ee_covariance: np.ndarray | None = None
    via_errors: list[float] = field(default_factory=list)
    covariance_floor: float = 0.0
    violations: dict[str, float] = field(default_factory=dict)
    collision_geometry: str | None = None
    nearest_contact: dict[str, Any] | None = None
    attempts: list[dict[str, Any]] = field(default_factory=list)
    #: what the search spent: ``work`` (solver trials and judged optima), ``unit`` (the work of
    #: the first solves: the budget's unit), ``limit`` (the budget in the same units, None:
    #: unbounded), ``budget_ended`` (the budget stopped it),
    #: ``left`` (the strategies it did not run; :mod:`clamp.planning.search`)
    search: dict[str, Any] = field(default_factory=dict)
    skill: dict[str, Any] = field(default_factory=dict)
    self_clearance: float = float("inf")
    self_contact: dict[str, Any] | None = None
    fixed_overlaps: list[tuple[str, str, float]] = field(default_factory=list)
    #: [rad] the angle between the hand's rotation and the goal pose's at the end (None
    #: without a goal rotation), and at every via point (None where it gives no rotation)
    goal_rotation_error: float | None = None
    via_rotation_errors: list[float | None] = field(default_factory=list)
    #: uniform time scale k >= 1 the skill was planned at (``time`` is the demonstrations'
    #: times k; :mod:`clamp.planning.time_scale`)
    time_scale: float = 1.0
    #: what the plan was asked (for clamp.replan and the viewer; left out of to_dict)
    inputs: PlanInputs | None = field(default=None, compare=False, repr=False)
    #: the clamp.PlanningProblem the plan solves: ``problem.graph()`` at the plan is the graph
    #: the solver finished on (left out of to_dict)
    problem: Any = field(default=None, compare=False, repr=False)

    @property
    def ee_std(self) -> np.ndarray | None:
        """Posterior standard deviation (T, 3) [m] of the end-effector position per axis."""
        if self.ee_covariance is None:
            return None
        return np.sqrt(np.clip(np.einsum("tii->ti", self.ee_covariance), 0.0, None))

    def verdict(self) -> dict[str, Any]:
        """The verdict as JSON-ready data: success, reasons and the figures they rest on."""
        def number(value: float | None) -> float | None:
            return None if value is None or not np.isfinite(value) else float(value)
        return {"success": bool(self.success), "reasons": list(self.reasons),
                "min_clearance_m": number(self.min_clearance),
                "collision_geometry": self.collision_geometry,
                "nearest_contact": self.nearest_contact,
                "start_error": number(self.start_error), "goal_error": number(self.goal_error),
                "via_errors": [float(e) for e in self.via_errors],
                "goal_rotation_error": number(self.goal_rotation_error),
                "via_rotation_errors": [number(e) for e in self.via_rotation_errors],
                "violations": {k: float(v) for k, v in self.violations.items()},
                "within_limits": bool(self.within_limits),
                "self_clearance_m": number(self.self_clearance),
                "self_contact": self.self_contact,
                "fixed_overlaps": [list(item) for item in self.fixed_overlaps],
                "time_scale": float(self.time_scale),
                "duration_s": float(self.time[-1] - self.time[0]),
                "skill": {k: number(v) if isinstance(v, float) else v
                          for k, v in self.skill.items()}}

    def to_joint_trajectory(self, robot: Any, *, retime: bool = True,
                            acceleration_limits: Any = None, jerk_limits: Any = None) -> Any:
        """The plan as an executable ``robots.JointTrajectory`` of ``robot`` (the arm it was
        planned for): joint names, time from start [s], positions, velocities, accelerations
        (rad, rad/s, rad/s^2), and the verdict in its header; ``.to_json(path)`` /
        ``.to_ros2_json(path)`` / ``.to_csv(path)`` write it for a robot driver.

        By default retimed (TOPP-RA, :func:`robots.retime`) within ``robot.velocity_limits``
        and ``acceleration_limits`` (rad/s^2, a number or one per joint; None =
        ``robots.retiming.DEFAULT_ACCELERATION_LIMIT``), from rest to rest (zero velocity and
        acceleration at both ends), sampled every 10 ms; the retiming report is
        ``verdict["retiming"]``. ``jerk_limits`` (rad/s^3, a number or one per joint): retimed
        jerk-limited along the same path by ruckig instead (``method="ruckig"``); not with
        ``retime=False``. ``retime=False``: the plan's own T samples and timing (not
        necessarily within the limits nor at rest). Check ``success`` first: a failed plan's
        trajectory is no motion to execute (its verdict says so).
        """
        planned = JointTrajectory.from_plan(robot, self.time, self.q, self.qdot, self.verdict())
        if not retime:
            if jerk_limits is not None:
                raise RetimingError("jerk_limits: only with retime=True (the limits are what the plan is retimed to)")
            return planned
        retimed, _ = retime_trajectory(planned, robot, acceleration_limits,
                                       method="toppra" if jerk_limits is None else "ruckig", jerk_limits=jerk_limits)
        return retimed

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (arrays as nested lists, non-finite floats as None); the joint
        state covariance (T, 2n, 2n) is left out (the end-effector one is kept)."""
        out: dict[str, Any] = {}
        for item in fields(self):
            key = item.name
            if key in ("state_covariance", "inputs", "problem"):
                continue
            value = deepcopy(getattr(self, key))
            if isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, float) and not np.isfinite(value):
                value = None
            out[key] = value
        return out
