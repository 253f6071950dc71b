"""Time is its own stage (issues 27, 36): a skill demonstrated faster than the arm can follow
is planned slower, on the same geometry, at a time scale chosen before the constrained path
solve.

A uniform time scale k >= 1 reparametrises the skill: time t -> k t, workspace velocities
v -> v / k. For the learned prior x = [p, v] this is the linear change of state x' = S x,
S = diag(1, 1, 1, 1/k, 1/k, 1/k), which maps the LTV-SDE exactly (:func:`time_scaled_prior`:
Phi' = S Phi S^-1, u' = S u, Q' = S Q S, mean0' = S mean0, cov0' = S cov0 S): the same
distribution of paths, traversed k times slower. The joint-space factors are scaled alike
(:func:`time_scaled_config`: the constant-velocity GP's Qc and posture_Qc / k^3, the posture
velocity tie's sigma / k), so the scaled problem is the original one in slower time, except
for what is physical: the arm's joint velocity limits (the limit hinges and the verdict), the
obstacles, the tolerances.

The stage (:func:`clamp.plan` runs it): the caller's scale (``time_scale``) is taken as it is;
otherwise k is chosen from the free plan's peaks (:func:`needed_scale`: joint velocities
between the states and accelerations against the limits, :func:`peak_ratios`), k = that need
x :data:`MARGIN`, at most ``max_duration`` / the skill's duration. The free plan is the model's
(with obstacles, solved when the model is built: a skill shown too fast costs one more
free-plan solve, the model built again at k, never a path search); in an empty scene the plan
itself, whose need the initial trajectory (the skill followed at the demonstrations' speed)
predicts. A path that still moves faster than its scale allows (a detour) is retimed once at
its own need, without a solve: the same states in slower time, which the scaled problem
allows exactly (:func:`clamp.planning.planner._retimed`). The solve's judge does not check
joint velocities (:meth:`clamp.factors.JointLimitFamily.check`); the verdict does, and
:func:`timing_reasons` adds the accelerations and, when the scale was bounded, why. The scale is
``PlanResult.time_scale``; the result's time stamps, velocities and verdict are the scaled
plan's.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from clamp.config import as_max_duration, as_time_scale
from clamp.errors import InvalidParameterError
from clamp.factors import joint_limits
from clamp.factors.joint_limits import VELOCITY_TOLERANCE, speeds
from clamp.prior.linear_gaussian import WorkspacePrior
from clamp.prior.orientation_prior import OrientationPrior

log = logging.getLogger(__name__)

#: the scale computed from the free plan's peak ratios is multiplied by this (the plan at that
#: scale moves a little: its peaks are not exactly the free plan's divided by k)
MARGIN = 1.05


def time_scaled_prior(prior: Any, k: float) -> Any:
    """The workspace ``prior`` (T states, x = [p (3) m, v (3) m/s]) traversed ``k`` times slower
    (module docstring): time * k, velocities / k, noise scaled alike; ``prior`` itself for
    k == 1. ``info["time_scale"]`` records k (times any scale the prior already had)."""
    k = float(as_time_scale(k, "k"))
    if k == 1.0:
        return prior
    orientation = getattr(prior, "orientation", None)
    if orientation is not None:       # a pose prior: its rotation chain [r, w] alike
        orientation = OrientationPrior(*_scaled_chain(orientation, k),
                                       info=_scaled_info(orientation, k))
    return WorkspacePrior(*_scaled_chain(prior, k), state_names=tuple(prior.state_names),
                          info=_scaled_info(prior, k), orientation=orientation)


def _scaled_info(prior: Any, k: float) -> dict[str, Any]:
    info = dict(getattr(prior, "info", {}) or {})
    return {**info, "time_scale": k * float(info.get("time_scale", 1.0))}


def _scaled_chain(prior: Any, k: float) -> tuple[np.ndarray, ...]:
    """(time, Phi, u, Q, mean0, cov0) of a chain over [positions (3), velocities (3)] traversed
    ``k`` times slower."""
    s = np.array([1.0, 1.0, 1.0, 1.0 / k, 1.0 / k, 1.0 / k])
    S, S_inv = np.diag(s), np.diag(1.0 / s)
    return (np.asarray(prior.time) * k, S @ np.asarray(prior.Phi) @ S_inv,
            np.asarray(prior.u) * s, S @ np.asarray(prior.Q) @ S,
            np.asarray(prior.mean0) * s, S @ np.asarray(prior.cov0) @ S)


def _joint_noises(model: Any, k: float) -> dict[str, float]:
    """The joint-space noises of the time-dependent factors for the same motion traversed
    ``k`` times slower (k < 1: faster), as ``model`` fields: Qc and posture_Qc / k^3,
    posture_velocity_sigma / k."""
    return {"Qc": model.Qc / k**3, "posture_Qc": model.posture_Qc / k**3,
            "posture_velocity_sigma": model.posture_velocity_sigma / k}


def time_scaled_config(config: Any, k: float) -> Any:
    """``config`` (a PlannerConfig) with the joint-space noise of time-dependent factors scaled
    for a plan ``k`` times slower: Qc, posture_Qc / k^3, posture_velocity_sigma / k; its time
    scale fixed at 1 (the scaled problem is planned as it is, e.g. by :func:`clamp.replan`)."""
    if k == 1.0:
        return config
    return config.with_(**_joint_noises(config.model, k), time_scale=1.0, max_duration=None)


def demonstrated_speed_config(config: Any, prior: Any) -> Any:
    """``config`` (a PlannerConfig) for a skill ``prior`` demonstrated over D seconds, faster
    than ``config.model.Qc_duration`` (docs/decisions.md#qc_duration): the same problem as a
    skill of Qc_duration seconds traversed Qc_duration / D times faster, so its joint-space
    noises are :func:`time_scaled_config`'s for
    k = D / Qc_duration < 1: Qc and posture_Qc / k^3, posture_velocity_sigma / k; Qc_duration
    then None (applied once). ``config`` itself for a skill of Qc_duration or longer, or
    Qc_duration None. D is the demonstrated duration: a time-scaled prior's
    (``info["time_scale"]``) over its scale."""
    m = config.model
    if m.Qc_duration is None:
        return config
    scale = float((getattr(prior, "info", {}) or {}).get("time_scale", 1.0))
    demonstrated = float(prior.time[-1] - prior.time[0]) / scale
    k = demonstrated / m.Qc_duration
    if k >= 1.0:
        return config
    return config.derived(**_joint_noises(m, k), Qc_duration=None)


def peak_ratios(robot: Any, q: np.ndarray, qdot: np.ndarray, time: np.ndarray,
                acceleration_limit: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per joint (n,), the largest velocity [rad/s] and acceleration [rad/s^2] of a plan q, qdot
    (T, n) [rad, rad/s] at ``time`` (T,) [s] over its limits (velocity: ``robot.velocity_limits``;
    acceleration: ``acceleration_limit``, zeros without one). Velocities are the peaks between
    the states (the verdict's, :func:`clamp.factors.joint_limits.speeds`: at least the states'
    and the finite differences of q), accelerations the finite differences of qdot."""
    q, qdot, time = np.asarray(q, float), np.asarray(qdot, float), np.asarray(time, float)
    step = np.diff(time)[:, None]
    vmax = np.asarray(robot.velocity_limits, dtype=float)
    velocity = speeds(q, qdot, time).max(axis=0)
    if acceleration_limit is None:
        return velocity / vmax, np.zeros_like(velocity)
    return velocity / vmax, (np.abs(np.diff(qdot, axis=0)) / step).max(axis=0) / acceleration_limit


@dataclass(frozen=True)
class TimeRequest:
    """What the caller asked of the plan's time: ``fixed`` the scale they gave (None:
    automatic); ``largest`` the largest scale ``max_duration`` allows (inf: unbounded);
    ``max_duration`` [s] or None."""

    fixed: float | None
    largest: float
    max_duration: float | None


def time_request(prior: Any, config: Any, time_scale: float | None = None,
                 max_duration: float | None = None) -> TimeRequest:
    """The caller's ``time_scale`` / ``max_duration`` [s] (None: ``config.model``'s) for the
    skill ``prior``, checked against each other and the skill's duration
    (InvalidParameterError naming the argument)."""
    time_scale = as_time_scale(config.model.time_scale if time_scale is None else time_scale,
                               "time_scale")
    max_duration = as_max_duration(config.model.max_duration if max_duration is None
                                   else max_duration, "max_duration")
    duration = float(prior.time[-1] - prior.time[0])
    largest = np.inf if max_duration is None else max_duration / duration
    if largest < 1.0:
        raise InvalidParameterError(f"max_duration: expected at least the skill's duration "
                                    f"{duration:.4g} s (a plan is never faster than its "
                                    f"demonstrations), got {max_duration:.4g} s")
    if time_scale is not None and time_scale > largest * (1 + 1e-12):
        raise InvalidParameterError(f"time_scale, max_duration: time_scale {time_scale:.4g} makes "
                                    f"the plan last {time_scale * duration:.4g} s, more than "
                                    f"max_duration {max_duration:.4g} s")
    return TimeRequest(time_scale, largest, max_duration)


def needed_scale(robot: Any, theta: np.ndarray, time: np.ndarray, config: Any,
                 initial_q: np.ndarray | None = None) -> float:
    """The scale (>= 1) a plan theta (T, 2n) [rad, rad/s] at ``time`` (T,) [s] needs to keep
    the arm's limits: max(peak velocity ratio, sqrt(peak acceleration ratio)) (:func:`peak_ratios`;
    1.0 when within ``config.checks``' tolerances). Where the plan's velocities reach the
    velocity hinges (``joint_limits.VELOCITY_MARGIN`` inside the limits: they may have bent it,
    hiding the skill's speed), the initial trajectory ``initial_q`` (T, n) (the skill followed
    at the demonstrations' speed) is measured too, and the larger need counts."""
    n, checks = robot.n, config.checks
    vmax = np.asarray(robot.velocity_limits, dtype=float)
    q, qdot = theta[:, :n], theta[:, n:]

    def need(q: np.ndarray, qdot: np.ndarray) -> float:
        velocity, acceleration = peak_ratios(robot, q, qdot, time, checks.acceleration_limit)
        if not (np.any(velocity > 1.0 + VELOCITY_TOLERANCE / vmax)
                or np.any(acceleration > 1.0)):
            return 1.0
        return max(1.0, float(velocity.max()), float(np.sqrt(acceleration.max())))

    needed = need(q, qdot)
    band = vmax - joint_limits.VELOCITY_MARGIN - VELOCITY_TOLERANCE
    if initial_q is not None and np.any(np.abs(qdot) > band):
        initial = np.asarray(initial_q, dtype=float)
        needed = max(needed, need(initial, np.gradient(initial, time, axis=0)))
    return needed


def chosen_scale(request: TimeRequest, needed: float) -> float:
    """The automatic scale for a free plan that needs ``needed`` (:func:`needed_scale`): 1.0
    when it needs none, else needed x :data:`MARGIN`, at most ``request.largest``."""
    if needed <= 1.0:
        return 1.0
    k = min(request.largest, needed * MARGIN)
    log.info("skill faster than the arm: planned %.3g times slower", k)
    return k


def timing_reasons(result: Any, robot: Any, config: Any, request: TimeRequest,
                   needed: float) -> list[str]:
    """What the time stage adds to the verdict of ``result`` (planned at ``result.time_scale``
    for a skill that needs scale ``needed``, :func:`needed_scale` of its free plan at the
    demonstrations' speed, or of the plan at the caller's scale times that scale):
    accelerations beyond ``config.checks.acceleration_limit`` (the joint-limit check holds the
    velocities), and, when the plan fails while the caller's scale or ``max_duration`` kept it
    faster than the skill needs, that bound."""
    reasons = []
    limit = config.checks.acceleration_limit
    if limit is not None:
        _, acceleration = peak_ratios(robot, result.q, result.qdot, result.time, limit)
        if np.any(acceleration > 1.0):
            joint = int(np.argmax(acceleration))
            reasons.append(f"joint {robot.joint_names[joint]} accelerates "
                           f"{acceleration[joint]:.3g} x the limit {limit:.4g} rad/s^2 at time "
                           f"scale {result.time_scale:.3g}")
    k = result.time_scale
    if (reasons or not result.success) and needed > k * (1 + 1e-9):
        bound = ("time_scale fixed by the caller" if request.fixed is not None else
                 f"max_duration {request.max_duration:.4g} s allows at most {request.largest:.3g}")
        reasons.append(f"planned at time scale {k:.3g} where the skill needs {needed:.3g} "
                       f"({bound})")
    return reasons


def fail(result: Any, reasons: list[str]) -> Any:
    """``result`` with failure ``reasons`` added to its verdict (never a success it has not
    checked); ``result`` itself when there are none."""
    if reasons:
        result.success = False
        result.reasons.extend(reasons)
        if result.stop_reason == "converged":
            result.stop_reason = "infeasible"
    return result
