"""Time scaled to the arm (issue 27): a skill demonstrated faster than the arm can follow is
planned slower, on the same geometry.

A uniform time scale k >= 1 reparametrises the skill: time t -> k t, workspace velocities
v -> v / k. For the learned prior x = [p, v] this is the linear change of state x' = S x,
S = diag(1, 1, 1, 1/k, 1/k, 1/k), which maps the LTV-SDE exactly (:func:`time_scaled_prior`:
Phi' = S Phi S^-1, u' = S u, Q' = S Q S, mean0' = S mean0, cov0' = S cov0 S): the same
distribution of paths, traversed k times slower. The joint-space factors are scaled alike
(:func:`time_scaled_config`: the constant-velocity GP's Qc and posture_Qc / k^3, the posture
velocity tie's sigma / k), so the scaled problem is the original one in slower time, except
for what is physical: the arm's joint velocity limits (the limit hinges and the verdict), the
obstacles, the tolerances.

:func:`plan_time_scaled` (what :func:`clamp.plan` runs) plans once at scale 1 (nothing
changes for a skill within the limits: the plan is bit-identical), and when that plan fails
while a joint moves faster than its velocity limit (or, with ``config.checks``'
``acceleration_limit``, accelerates beyond it), computes the smallest scale the free
optimum needs, k = max(peak velocity ratio, sqrt(peak acceleration ratio)) x
:data:`MARGIN`, and plans again at k (up to :data:`MAX_RESCALES` times, the scale growing by
the new plan's ratios). The caller may instead fix the scale (``time_scale``) or bound the
duration (``max_duration`` [s]: k <= max_duration / the skill's duration). The scale is
``PlanResult.time_scale``; the result's time stamps, velocities and verdict are the scaled
plan's.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from clamp.config import QC_FACTOR_LIMIT, as_max_duration, as_time_scale
from clamp.errors import InvalidParameterError
from clamp.factors.joint_limits import speeds
from clamp.prior.linear_gaussian import WorkspacePrior
from clamp.prior.orientation_prior import OrientationPrior

log = logging.getLogger(__name__)

#: the scale computed from a plan's peak ratios is multiplied by this (the re-planned optimum
#: moves a little: its peaks are not exactly the first plan's divided by k)
MARGIN = 1.05
#: re-plans at a larger scale at most (each from the previous plan's peak ratios)
MAX_RESCALES = 3


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
    skill of Qc_duration seconds traversed Qc_duration / D times faster (its cube at most
    QC_FACTOR_LIMIT), so its joint-space noises are :func:`time_scaled_config`'s for
    k = D / Qc_duration < 1: Qc and posture_Qc / k^3, posture_velocity_sigma / k; Qc_duration
    then None (applied once). ``config`` itself for a skill of Qc_duration or longer, or
    Qc_duration None. D is the demonstrated duration: a time-scaled prior's
    (``info["time_scale"]``) over its scale."""
    m = config.model
    if m.Qc_duration is None:
        return config
    scale = float((getattr(prior, "info", {}) or {}).get("time_scale", 1.0))
    demonstrated = float(prior.time[-1] - prior.time[0]) / scale
    k = max(demonstrated / m.Qc_duration, QC_FACTOR_LIMIT ** (-1.0 / 3.0))
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


def _too_fast(result: Any, robot: Any, checks: Any) -> tuple[bool, bool, float]:
    """Whether a plan moves beyond the arm's limits (a velocity between its states, as the
    verdict sees it, beyond its limit by more than ``checks.velocity_tolerance``, an
    acceleration beyond ``checks.acceleration_limit``); whether it is to be planned slower
    (it is beyond a limit, or it failed and its initial trajectory, the skill followed at the
    demonstrations' speed, exceeds a limit: the limit hinges may be what bent it); and the
    scale (>= 1) the larger of the plan's and the initial trajectory's peaks need."""
    vmax = np.asarray(robot.velocity_limits, dtype=float)
    tolerance = checks.velocity_tolerance / vmax
    velocity, acceleration = peak_ratios(robot, result.q, result.qdot, result.time,
                                         checks.acceleration_limit)
    fast = slower = bool(np.any(velocity > 1.0 + tolerance) or np.any(acceleration > 1.0))
    needed = max(float(velocity.max()), float(np.sqrt(acceleration.max())))
    if result.initial_q is not None:
        initial = np.asarray(result.initial_q, dtype=float)
        qdot = np.gradient(initial, np.asarray(result.time, dtype=float), axis=0)
        v0, a0 = peak_ratios(robot, initial, qdot, result.time, checks.acceleration_limit)
        skill = max(float(v0.max()), float(np.sqrt(a0.max())))
        slower = slower or (not result.success and skill > 1.0)
        needed = max(needed, skill)
    return fast, slower, max(1.0, needed)


def _fail(result: Any, reason: str) -> None:
    """Add a failure reason to a verdict (never a success it has not checked)."""
    result.success = False
    result.reasons.append(reason)
    if result.stop_reason == "converged":
        result.stop_reason = "infeasible"


def plan_time_scaled(plan_at: Callable[[Any, Any], Any], prior: Any, robot: Any, config: Any,
                     time_scale: float | None = None, max_duration: float | None = None) -> Any:
    """The plan of ``prior`` at the time scale the arm needs (module docstring).

    plan_at(prior, config) -> PlanResult plans the request with a (scaled) prior and config;
    time_scale / max_duration: the caller's (None: ``config.model``'s; both None: automatic,
    unbounded). Returns the PlanResult with ``time_scale`` set; a plan still beyond the limits
    at the largest scale allowed says so in its reasons (never a success)."""
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
    if time_scale is not None:          # the caller's scale: planned at it, never changed
        k = largest = time_scale
    else:
        k = 1.0
    result = _at(plan_at, prior, config, k)
    for _ in range(MAX_RESCALES):
        _, blocked, needed = _too_fast(result, robot, config.checks)
        if not blocked or k >= largest:
            break
        k = min(largest, k * needed * MARGIN)
        log.info("skill faster than the arm: planning again %.3g times slower", k)
        result = _at(plan_at, prior, config, k)
    fast, _, needed = _too_fast(result, robot, config.checks)
    if fast and k != 1.0:     # at the demonstrations' speed the verdict's own limit check stands
        velocity, acceleration = peak_ratios(robot, result.q, result.qdot, result.time,
                                             config.checks.acceleration_limit)
        bound = ("time_scale fixed by the caller" if time_scale is not None else
                 f"max_duration {max_duration:.4g} s allows at most {largest:.3g}"
                 if k >= largest else f"after {MAX_RESCALES} re-plans")
        _fail(result, f"joint velocities up to {velocity.max():.3g} x their limits"
                      + (f", accelerations {acceleration.max():.3g} x the limit"
                         if config.checks.acceleration_limit is not None else "")
                      + f" at time scale {k:.3g} (the skill needs {needed * k:.3g}; {bound})")
    return result


def _at(plan_at: Callable[[Any, Any], Any], prior: Any, config: Any, k: float) -> Any:
    """plan_at with the prior and config scaled by k; ``time_scale`` set on the result."""
    result = plan_at(time_scaled_prior(prior, k), time_scaled_config(config, k))
    result.time_scale = k
    return result
