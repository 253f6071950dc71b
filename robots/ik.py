"""Inverse kinematics of the end-effector position (and, for one configuration, of its whole
pose, or of its position turned as near a rotation as reachable there): damped least squares
within joint limits.

The solver works on a batch of B independent problems at once (restarts, or all steps of a
path), so a whole trajectory is refined in one vectorized loop over iterations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import RobotError
from .validation import as_array, as_generator, as_joint_array, as_point, as_points


@dataclass(frozen=True)
class IKResult:
    """q (n,) joint values; error [m] distance from the end effector to the target; success = error <= tol."""

    q: np.ndarray
    error: float
    success: bool


@dataclass(frozen=True)
class IKTrajectoryResult:
    """q (T, n) joint trajectory; errors (T,) [m] per step; success = every error <= tol."""

    q: np.ndarray
    errors: np.ndarray
    success: bool


def _check_settings(tol: float, max_iter: int) -> None:
    if not (np.isfinite(tol) and tol > 0):
        raise RobotError(f"tol: expected a positive tolerance in metres, got {tol!r}")
    if int(max_iter) != max_iter or max_iter < 0:
        raise RobotError(f"max_iter: expected a non-negative integer, got {max_iter!r}")


def _position_jacobian(robot, att, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (B, 3) and Jacobians (B, 3, n) of the point at attachment `att` (the end effector)
    for validated q (B, n); a single configuration goes through Pinocchio's C++ kinematics
    (3x cheaper than the vectorized chain's per-call overhead, equal to round-off)."""
    if len(q) == 1:
        pos, jac = robot.ee_position_jacobian(q[0])
        return pos[None], jac[None]
    frames = robot.chain.joint_frames(q)
    pos, columns, _ = robot.chain.point(frames, att.joint, att.translation, True)
    return pos, columns.transpose(0, 2, 1)


def damped_least_squares(robot, targets: np.ndarray, q0: np.ndarray, tol: float, max_iter: int,
                         damping: float = 1e-2, max_step: float = 0.5,
                         until_any: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Solve B position IK problems together; returns q (B, n) within limits and errors (B,) [m].

    targets (B, 3), q0 (B, n) seeds (projected onto the limits). Each step is
    dq = J^T (J J^T + lambda^2 I)^-1 e with joints held at a limit that the step would push
    through removed from J, scaled to at most `max_step` rad, and projected onto the limits;
    a step is kept only if it lowers the error (lambda halves) else lambda grows fourfold.
    With `until_any` the iteration stops as soon as one problem is solved (restarts).
    """
    lower, upper = robot.lower_limits, robot.upper_limits
    q = np.clip(np.array(q0, dtype=float), lower, upper)
    ee = robot.attachment(robot.end_effector)
    pos, jac = _position_jacobian(robot, ee, q)
    residual = targets - pos
    error = np.linalg.norm(residual, axis=1)
    lam = np.full(len(q), float(damping))
    eye = np.eye(3)
    if len(q) == 1:
        return _single(robot, ee, targets, q, jac, residual, error, lam, eye, tol, int(max_iter),
                       max_step)
    for _ in range(int(max_iter)):
        active = np.flatnonzero(error > tol)
        if active.size == 0 or (until_any and active.size < len(error)):
            break
        la = lam[active]
        q_new = _step(q[active], jac[active], residual[active], la, lower, upper, eye, max_step)
        pos_new, jac_new = _position_jacobian(robot, ee, q_new)
        res_new = targets[active] - pos_new
        err_new = np.linalg.norm(res_new, axis=1)
        better = err_new < error[active]
        keep = active[better]
        q[keep], jac[keep], residual[keep], error[keep] = q_new[better], jac_new[better], res_new[better], err_new[better]
        lam[active] = np.where(better, np.maximum(la * 0.5, 1e-6), np.minimum(la * 4.0, 1e3))
    return q, error


def _step(q, jac, residual, lam, lower, upper, eye, max_step):
    """The damped least-squares step of problems q (B, n): joints at a limit the step would push
    through held, the step scaled to at most ``max_step`` rad, the result projected onto the
    limits (the new configurations (B, n))."""
    gradient = np.einsum("bin,bi->bn", jac, residual)                  # descent direction J^T e
    blocked = ((q <= lower + 1e-12) & (gradient < 0)) | ((q >= upper - 1e-12) & (gradient > 0))
    jf = jac * ~blocked[:, None, :]
    system = jf @ jf.transpose(0, 2, 1) + (lam ** 2)[:, None, None] * eye
    step = np.einsum("bin,bi->bn", jf, np.linalg.solve(system, residual[..., None])[..., 0])
    size = np.abs(step).max(axis=1, keepdims=True)
    step *= np.minimum(1.0, max_step / np.maximum(size, 1e-300))
    return np.clip(q + step, lower, upper)


def _single(robot, ee, targets, q, jac, residual, error, lam, eye, tol, max_iter, max_step):
    """:func:`damped_least_squares` of one problem (B = 1): the same steps on the same (1, ...)
    arrays, without the bookkeeping of which problems are still active (the many small calls
    of a trajectory's sequential pass)."""
    lower, upper = robot.lower_limits, robot.upper_limits
    for _ in range(max_iter):
        if not error[0] > tol:
            break
        q_new = _step(q, jac, residual, lam, lower, upper, eye, max_step)
        pos_new, jac_new = _position_jacobian(robot, ee, q_new)
        res_new = targets - pos_new
        err_new = np.linalg.norm(res_new, axis=1)
        if err_new[0] < error[0]:
            q, jac, residual, error = q_new, jac_new, res_new, err_new
            lam = np.maximum(lam * 0.5, 1e-6)
        else:
            lam = np.minimum(lam * 4.0, 1e3)
    return q, error


def solve_ik(robot, target, seed=None, tol: float = 1e-4, max_iter: int = 200, restarts: int = 8,
             rng: np.random.Generator | int | None = 0) -> IKResult:
    """Joint values (n,) that put the end effector at `target` (3,) [m], within the limits.

    Starts from `seed` (n,) (default: middle of the limits); if that fails, `restarts` random
    configurations drawn from `rng` are solved together in one batch until one succeeds, and the
    best solution is returned.
    """
    _check_settings(tol, max_iter)
    target = as_point(target, "target")
    seed = robot.neutral_configuration() if seed is None else as_joint_array(seed, "seed", robot.n)
    if seed.ndim != 1:
        raise RobotError(f"seed: expected shape ({robot.n},), got {seed.shape}")
    if int(restarts) != restarts or restarts < 0:
        raise RobotError(f"restarts: expected a non-negative integer, got {restarts!r}")
    generator = as_generator(rng)
    q, errors = damped_least_squares(robot, target[None], seed[None], tol, max_iter)
    if errors[0] > tol and restarts > 0:
        starts = np.array([robot.random_configuration(generator) for _ in range(int(restarts))])
        q_more, errors_more = damped_least_squares(robot, np.broadcast_to(target, (len(starts), 3)), starts,
                                                   tol, max_iter, until_any=True)
        q, errors = np.vstack((q, q_more)), np.concatenate((errors, errors_more))
    best = int(np.argmin(errors))
    return IKResult(q[best], float(errors[best]), bool(errors[best] <= tol))


def solve_ik_trajectory(robot, targets, seed=None, tol: float = 1e-4, max_iter: int = 100,
                        rng: np.random.Generator | int | None = 0, stride: int = 8,
                        sequential_iter: int = 10) -> IKTrajectoryResult:
    """Joint trajectory (T, n) following the end-effector path `targets` (T, 3) [m].

    The first step is solved with solve_ik from `seed` (plus restarts). A sequential pass then
    walks every `stride`-th step, each seeded by the previous one (`sequential_iter` iterations),
    which fixes the branch; the steps in between start from joint-space linear interpolation, and
    finally all T steps are refined together in one batch (`max_iter` iterations), each from its
    own start, so neighbouring configurations stay on the same branch.
    """
    _check_settings(tol, max_iter)
    targets = as_points(targets, "targets")
    if len(targets) == 0:
        raise RobotError("targets: expected at least one point, got shape (0, 3)")
    if int(stride) != stride or stride < 1:
        raise RobotError(f"stride: expected a positive integer, got {stride!r}")
    first = solve_ik(robot, targets[0], seed=seed, tol=tol, max_iter=max(200, int(max_iter)), rng=rng)
    T = len(targets)
    coarse = np.unique(np.append(np.arange(0, T, int(stride)), T - 1))
    q_coarse = np.empty((len(coarse), robot.n))
    q_coarse[0] = first.q
    for i in range(1, len(coarse)):
        t = coarse[i]
        q_coarse[i], _ = damped_least_squares(robot, targets[t:t + 1], q_coarse[i - 1:i], tol, sequential_iter)
    steps = np.arange(T)
    q = np.column_stack([np.interp(steps, coarse, q_coarse[:, j]) for j in range(robot.n)])
    q, errors = damped_least_squares(robot, targets, q, tol, max_iter)
    return IKTrajectoryResult(q, errors, bool(np.all(errors <= tol)))


@dataclass(frozen=True)
class PoseIKResult:
    """q (n,) joint values; position_error [m] and angle_error [rad] from the target pose;
    success = both within their tolerances."""

    q: np.ndarray
    position_error: float
    angle_error: float
    success: bool


def solve_pose_ik(robot, position, rotation, seed, tol: float = 1e-6, angle_tol: float = 1e-6,
                  max_iter: int = 300, damping: float = 1e-2, max_step: float = 0.3) -> PoseIKResult:
    """Joint values (n,) near ``seed`` (n,) that put the end effector at ``position`` (3,) [m]
    turned as ``rotation`` (3, 3) (columns: the tool's axes in the base frame), within limits.

    Damped least squares on the 6-vector [p* - p, log(R* R^T)] (metres, radians) with the
    stacked position and angular Jacobians (``robot.ee_pose_jacobian``),
    as :func:`damped_least_squares` steps (limits held, steps of at most ``max_step`` rad, a step
    kept only when it lowers the error). No restarts: the seed chooses the branch.
    """
    _check_settings(tol, max_iter)
    target = as_point(position, "position")
    goal = as_array(rotation, "rotation", (3, 3), max_leading=0)
    q = np.clip(as_joint_array(seed, "seed", robot.n).reshape(robot.n), robot.lower_limits,
                robot.upper_limits)[None]
    eye = np.eye(6)

    def residual_and_jacobian(q):
        position, R, jacobian = robot.ee_pose_jacobian(q[0])
        residual = np.concatenate([target - position, pin.log3(goal @ R.T)])[None]
        return residual, jacobian[None]

    residual, jac = residual_and_jacobian(q)
    error = np.linalg.norm(residual, axis=1)
    lam = np.full(1, float(damping))
    for _ in range(int(max_iter)):
        if np.linalg.norm(residual[0, :3]) <= tol and np.linalg.norm(residual[0, 3:]) <= angle_tol:
            break
        q_new = _step(q, jac, residual, lam, robot.lower_limits, robot.upper_limits, eye, max_step)
        res_new, jac_new = residual_and_jacobian(q_new)
        err_new = np.linalg.norm(res_new, axis=1)
        if err_new[0] < error[0]:
            q, residual, jac, error = q_new, res_new, jac_new, err_new
            lam = np.maximum(lam * 0.5, 1e-6)
        elif lam[0] >= 1e3:               # no step lowers the error: a local minimum
            break
        else:
            lam = np.minimum(lam * 4.0, 1e3)
    position_error = float(np.linalg.norm(residual[0, :3]))
    angle_error = float(np.linalg.norm(residual[0, 3:]))
    return PoseIKResult(q[0], position_error, angle_error,
                        position_error <= tol and angle_error <= angle_tol)



def solve_ik_turned(robot, target, rotation, seed=None, tol: float = 1e-4, max_iter: int = 200,
                    restarts: int = 8, rng: np.random.Generator | int | None = 0) -> IKResult:
    """Joint values (n,) that put the end effector at ``target`` (3,) [m] within ``tol``, the
    hand turned as near ``rotation`` (3, 3) as is reachable there (within the limits).

    :func:`solve_ik` (same arguments) gives a configuration at the position, on whatever branch
    its seed leads to; :func:`solve_pose_ik` then seeks the whole pose from that configuration
    and from ``seed`` (default: the middle of the limits), and where the rotation is out of
    reach at the position (the pose solve stops at a compromise) position steps
    (:func:`damped_least_squares`) bring it back onto the position. Of the configurations at
    the position, the one whose hand is nearest ``rotation`` (geodesic angle) is returned;
    :func:`solve_ik`'s when none is nearer or none reaches the position.
    """
    target = as_point(target, "target")
    goal = as_array(rotation, "rotation", (3, 3), max_leading=0)
    first = solve_ik(robot, target, seed=seed, tol=tol, max_iter=max_iter, restarts=restarts,
                     rng=rng)
    seeds = [first.q, robot.neutral_configuration() if seed is None
             else as_joint_array(seed, "seed", robot.n)]

    def angle(q: np.ndarray) -> float:
        return float(np.linalg.norm(pin.log3(goal.T @ robot.ee_rotation(q)[0])))

    best, best_angle = first, angle(first.q)
    for start in seeds:
        pose = solve_pose_ik(robot, target, goal, start, tol=tol, max_iter=max_iter)
        q, errors = damped_least_squares(robot, target[None], pose.q[None], tol, max_iter)
        turned = angle(q[0])
        if errors[0] <= tol and turned < best_angle:
            best, best_angle = IKResult(q[0], float(errors[0]), True), turned
        if best_angle <= 1e-6:
            break
    return best
