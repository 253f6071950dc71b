"""Initial joint trajectories for the planner.

``prior_mean`` (default): inverse kinematics, with continuity, of the prior's mean end-effector
path shifted to start at the requested start position; the offset is blended out along the path
(cosine ramp) so the end of the skill is kept (or, with a goal, blended onto the goal).
``straight_line``: a straight line in joint space between two configurations.
:func:`demonstration_initialisation`: the joint trajectory of the recorded demonstration
(kinesthetic teaching, ``scenes.Demonstrations.joint_positions``) that starts nearest the
start, shifted to start there (the offset blended out, so it ends where the demonstration
ended); pass its ``theta`` as ``plan(..., initial=...)``.
Velocities are finite differences of the joint positions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from clamp.errors import ShapeError
from clamp.prior import so3
from clamp.validation import as_array, as_count, as_scalar



@dataclass(frozen=True)
class Initialisation:
    """Initial joint trajectory: q (T, n) [rad], qdot (T, n) [rad/s], target path (T, 3) [m].

    ik_error (T,) IK position error [m] per state (zeros for straight lines).
    """

    q: np.ndarray
    qdot: np.ndarray
    path: np.ndarray
    ik_error: np.ndarray

    @property
    def theta(self) -> np.ndarray:
        """Joint states [q, qdot] (T, 2n)."""
        return np.concatenate([self.q, self.qdot], axis=1)


def blend_weights(T: int) -> np.ndarray:
    """Cosine ramp (T,) from 1 at the first state to 0 at the last."""
    s = np.linspace(0.0, 1.0, T)
    return 0.5 * (1.0 + np.cos(np.pi * s))


def shifted_mean_path(mean_path: np.ndarray, start: np.ndarray, goal: np.ndarray | None = None,
                      blend: bool = True) -> np.ndarray:
    """The mean path (T, 3) moved so it starts at ``start`` (3,) and, with ``goal``, ends there.

    With ``blend`` the start offset fades out along the path; without, the whole path is shifted.
    """
    T = len(mean_path)
    w = blend_weights(T) if blend else np.ones(T)
    path = mean_path + w[:, None] * (start - mean_path[0])
    if goal is not None:
        path = path + (1.0 - blend_weights(T))[:, None] * (goal - path[-1])
    return path


def joint_velocities(q: np.ndarray, dt: float) -> np.ndarray:
    """Finite-difference velocities (T, n) of joint positions q (T, n) at step dt [s]."""
    return np.gradient(q, dt, axis=0)


def prior_mean_initialisation(robot, mean_path: np.ndarray, dt: float, q_start: np.ndarray,
                              goal: np.ndarray | None = None, blend: bool = True,
                              tolerance: float = 1e-4) -> Initialisation:
    """IK of the shifted mean path (T, 3) [m], seeded at ``q_start`` (n,) whose end effector is
    the start; goal (3,) [m] or None; dt [s]."""
    mean_path = as_array(mean_path, "mean_path", (None, 3))
    dt = as_scalar(dt, "dt", strictly_positive=True)
    q_start = as_array(q_start, "q_start", (robot.n,))
    goal = None if goal is None else as_array(goal, "goal", (3,))
    start = robot.fk(q_start)
    path = shifted_mean_path(mean_path, start, goal, blend)
    ik = robot.ik_trajectory(path, seed=q_start, tol=tolerance)
    q = np.array(ik.q, dtype=float)
    q[0] = q_start
    errors = np.array(ik.errors, dtype=float)
    errors[0] = 0.0
    return Initialisation(q, joint_velocities(q, dt), path, errors)


def straight_line_initialisation(robot, q_first: np.ndarray, q_last: np.ndarray, T: int,
                                 dt: float) -> Initialisation:
    """q_i on the straight line from q_first to q_last (n,) [rad], constant velocity; T >= 2
    states dt [s] apart."""
    q_first = as_array(q_first, "q_first", (robot.n,))
    q_last = as_array(q_last, "q_last", (robot.n,))
    T = as_count(T, "T", minimum=2)
    dt = as_scalar(dt, "dt", strictly_positive=True)
    s = np.linspace(0.0, 1.0, T)[:, None]
    q = (1.0 - s) * q_first + s * q_last
    qdot = np.broadcast_to((q_last - q_first) / (dt * (T - 1)), q.shape).copy()
    return Initialisation(q, qdot, robot.fk(q), np.zeros(T))


def demonstration_initialisation(robot, joint_positions: np.ndarray, dt: float,
                                 start: np.ndarray, tolerance: float = 1e-4) -> Initialisation:
    """The recorded joint trajectory (M, T, n) [rad] whose first configuration is nearest the
    start, moved to start there with the offset faded out (cosine ramp); dt [s] its step.

    start: a joint configuration (n,) [rad] or an end-effector position (3,) [m] (then the
    demonstration whose first end-effector position is nearest, the start solved by IK seeded
    at its first configuration). Continuous joints are compared modulo 2 pi.
    """
    joint_positions = as_array(joint_positions, "joint_positions", (None, None, robot.n))
    if joint_positions.shape[0] < 1 or joint_positions.shape[1] < 2:
        raise ShapeError(f"joint_positions: expected (M >= 1, T >= 2, {robot.n}), got "
                         f"{joint_positions.shape}")
    dt = as_scalar(dt, "dt", strictly_positive=True)
    first = joint_positions[:, 0]
    if np.size(start) == robot.n:
        q_start = as_array(start, "start", (robot.n,))
        offsets = _wrapped(robot, q_start - first)
        m = int(np.argmin(np.linalg.norm(offsets, axis=1)))
    else:
        position = as_array(start, "start", (3,))
        m = int(np.argmin(np.linalg.norm(robot.fk(first) - position, axis=1)))
        q_start = np.asarray(robot.ik(position, seed=first[m], tol=tolerance).q, dtype=float)
        offsets = _wrapped(robot, q_start - first)
    q = joint_positions[m] + blend_weights(joint_positions.shape[1])[:, None] * offsets[m]
    q[0] = q_start
    path = robot.fk(q)
    return Initialisation(q, joint_velocities(q, dt), path, np.zeros(len(q)))


def _wrapped(robot, dq: np.ndarray) -> np.ndarray:
    """Joint differences (..., n) with continuous joints (infinite limits) wrapped to
    [-pi, pi)."""
    continuous = ~np.isfinite(np.asarray(robot.lower_limits)) | ~np.isfinite(
        np.asarray(robot.upper_limits))
    return np.where(continuous, (dq + np.pi) % (2 * np.pi) - np.pi, dq)


#: [m / rad] how much a radian of the hand's rotation error weighs against a metre of position
#: in :func:`pose_refined` (the position stays first: 0.1 m per rad, 1.7 mm per degree)
ROTATION_WEIGHT = 0.1
#: [rad] the largest joint change of one step of :func:`pose_refined` (3 steps of 0.3 rad:
#: as few LM iterations as 6 of 0.1 rad, or fewer, on 20 free pose plans and the bench_clamp
#: --pose cases, at half the cost; docs/decisions.md#pose-prior)
MAX_STEP = 0.3
#: [rad] a state of :func:`pose_refined`'s per-state steps turned farther than this from its
#: rotation is on another branch of the arm (a flipped wrist: 79-90 deg on the UR5, a few
#: degrees where the steps converge), and the refinement goes along the path instead
STUCK = np.radians(45.0)
#: :func:`pose_refined`'s pass along the path: every STRIDE-th state, at most SEQUENTIAL_STEPS
#: steps each from the one before, until no joint moves more than SETTLED [rad] in a step
STRIDE, SEQUENTIAL_STEPS, SETTLED = 8, 10, 1e-3


def pose_refined(robot, initialisation: Initialisation, rotations: np.ndarray, dt: float,
                 iterations: int = 3, damping: float = 1e-3) -> Initialisation:
    """``initialisation`` (IK of a position path) turned towards the hand's rotations
    (T, 3, 3) (a pose prior's conditioned mean): damped least squares on the pose error
    [p(q_i) - path_i, ROTATION_WEIGHT log(R_i^T R(q_i))], ``iterations`` steps of every state
    but the first (the arm's start) at once, within the joint limits; velocities from the new
    joint path. The planner's initial guess only: the solve does the rest.

    Where a state is then still turned more than STUCK [rad] from its rotation, the per-state
    steps stopped in a local minimum of the rotation error: position IK may put the arm's
    wrist on a branch that turns the hand up to 180 deg from the rotations (a start turned far
    from the skill's, a UR5's flipped wrist). Then the refinement is done again, first along
    the path from the arm's start (every STRIDE-th state, SEQUENTIAL_STEPS steps each from the
    state before; joint-space interpolation in between), which keeps the arm on one branch as
    the hand turns (docs/decisions.md#a-position-start-of-a-pose-skill)."""
    q = np.array(initialisation.q, dtype=float)
    path = np.asarray(initialisation.path, dtype=float)
    targets = np.swapaxes(np.asarray(rotations, dtype=float), -1, -2)
    refined = q.copy()
    refined[1:] = _pose_steps(robot, q[1:], path[1:], targets[1:], iterations, damping)
    if np.max(so3.angle_between(rotations, robot.ee_rotation(refined)[0])) > STUCK:
        coarse = np.unique(np.append(np.arange(0, len(q), STRIDE), len(q) - 1))
        for before, after in zip(coarse[:-1], coarse[1:]):
            q[after] = _pose_steps(robot, q[before][None], path[after][None], targets[after][None],
                                   SEQUENTIAL_STEPS, damping, SETTLED)[0]
        steps = np.arange(len(q))
        refined = np.column_stack([np.interp(steps, coarse, q[coarse, j]) for j in range(robot.n)])
        refined[1:] = _pose_steps(robot, refined[1:], path[1:], targets[1:], iterations, damping)
    return Initialisation(refined, joint_velocities(refined, dt), path,
                          np.linalg.norm(robot.fk(refined) - path, axis=1))


def _pose_steps(robot, q: np.ndarray, path: np.ndarray, targets: np.ndarray, iterations: int,
                damping: float, settled: float = 0.0) -> np.ndarray:
    """q (B, n) after ``iterations`` damped least-squares steps of :func:`pose_refined`'s pose
    error towards positions ``path`` (B, 3) [m] and transposed rotations ``targets`` (B, 3, 3),
    every step at most MAX_STEP rad per joint, within the joint limits; fewer once a step moves
    no joint more than ``settled`` [rad]. One configuration (B = 1) goes through the robot's
    C++ kinematics (the many small calls of the pass along the path)."""
    q = np.array(q, dtype=float)
    eye = damping * np.eye(6)
    for _ in range(iterations):
        error, jac = _pose_error(robot, q, path, targets)
        step = np.swapaxes(jac, -1, -2) @ np.linalg.solve(jac @ np.swapaxes(jac, -1, -2) + eye,
                                                          error[..., None])
        step = step[..., 0]
        largest = np.abs(step).max(axis=1, keepdims=True)
        q = robot.clip_to_limits(q - step * np.minimum(1.0, MAX_STEP / np.maximum(
            largest, 1e-12)))
        if largest.max() <= settled:
            break
    return q


def _pose_error(robot, q: np.ndarray, path: np.ndarray,
                targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pose_refined`'s pose error (B, 6) of q (B, n) and its Jacobian (B, 6, n)."""
    if len(q) == 1:           # Pinocchio's log and its Jacobian: 50x less overhead for one
        position, R, jacobian = robot.ee_pose_jacobian(q[0])
        turn = targets[0] @ R
        r, inverse = pin.log3(turn)[None], pin.Jlog3(turn)[None]
        position, R, linear, W = position[None], R[None], jacobian[None, :3], jacobian[None, 3:]
    else:
        kin = robot.ee_kinematics(q, None, jacobians=True)
        R, W = robot.ee_rotation(q, jacobians=True)
        position, linear = kin.position, kin.jacobian
        r = so3.log_map(targets @ R)
        inverse = so3.right_jacobian_inverse(r)
    error = np.concatenate([position - path, ROTATION_WEIGHT * r], axis=1)
    jac = np.concatenate([linear, ROTATION_WEIGHT * inverse @ np.swapaxes(R, -1, -2) @ W],
                         axis=1)                                                     # (B, 6, n)
    return error, jac
