"""Demonstrations recorded in joint space (kinesthetic teaching) turned into end-effector
demonstrations by the robot's own forward kinematics.

Every recording q (T_m, n) [rad] at time (T_m,) [s] is smoothed and differentiated like an
end-effector recording (:mod:`scenes.smoothing`, in joint space), then mapped by the robot:
positions = FK(q) [m], velocities = J(q) qdot [m/s] (``robot.ee_kinematics``), the hand's
rotation = the end effector's rotation matrix (``robot.ee_rotation``) as unit quaternions
(x, y, z, w) in ``Demonstrations.orientations``. The joint trajectories are kept in
``Demonstrations.joint_positions`` so a planner can start from them.

``robot`` is any object with ``joint_names`` (n,), ``ee_kinematics(q, qdot, jacobians)`` and
``ee_rotation(q)`` (rotations (..., 3, 3), and None):
a ``robots.Robot`` (``robots.load_robot("jaco")``, ``Robot.from_urdf(...)``); scenes does
not import robots, the caller passes it.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .demonstrations import Demonstrations
from .errors import ScenesTypeError, InvalidDemonstrationsError
from .quaternions import quaternions_from_matrices
from .smoothing import smooth_trajectory
from skillplan.validation import MAX_COORDINATE, as_array, as_sequence, as_time

_E = InvalidDemonstrationsError


def check_robot(robot: Any) -> Any:
    """``robot`` when it has joint_names, ee_kinematics and ee_rotation (ScenesTypeError
    otherwise)."""
    if not hasattr(robot, "joint_names") or not all(
            callable(getattr(robot, method, None)) for method in ("ee_kinematics", "ee_rotation")):
        raise ScenesTypeError(f"robot: expected a robots.Robot (robots.load_robot('jaco') or "
                                f"robots.Robot.from_urdf(...)) to map joint-space "
                                f"demonstrations, got {type(robot).__name__} {robot!r:.60}")
    return robot


def column_order(columns: Sequence[str], robot: Any, where: str) -> np.ndarray:
    """Indices (n,) that put ``columns`` (joint names, any order) in the robot's joint order;
    InvalidDemonstrationsError naming the missing and unknown joints otherwise."""
    names = list(check_robot(robot).joint_names)
    missing = [n for n in names if n not in columns]
    unknown = [c for c in columns if c not in names]
    if missing or unknown or len(set(columns)) != len(columns):
        raise _E(f"{where}: expected one column per joint of {getattr(robot, 'name', 'the robot')} "
                 f"{names}; missing {missing}, not a joint of it {unknown}")
    return np.array([list(columns).index(n) for n in names])


def _radians(robot: Any, q: np.ndarray, where: str) -> None:
    """Refuse joint values (T, n) that look like degrees: beyond two turns (a continuous joint
    in radians may pass one), and within the robot's joint limits once converted to radians
    (InvalidDemonstrationsError naming them)."""
    within = getattr(robot, "within_limits", None)
    if np.max(np.abs(q)) > 4.0 * np.pi and within is not None and bool(np.all(within(np.radians(q)))):
        raise _E(f"{where}: joint values up to {np.max(np.abs(q)):.1f} look like degrees: radians "
                 f"expected (converted, every value is within the limits of "
                 f"{getattr(robot, 'name', 'the robot')})")


def from_joint_trajectories(robot: Any, joint_trajectories: Sequence[Any],
                            times: Sequence[Any], smoothing: str = "auto",
                            name: str = "") -> Demonstrations:
    """End-effector demonstrations of M joint recordings (T_m, n) [rad] at times (T_m,) [s]
    in the robot's joint order (see the module docstring; unequal time stamps are resampled
    by :meth:`Demonstrations.from_trajectories`)."""
    robot = check_robot(robot)
    n = len(robot.joint_names)
    joint_trajectories = as_sequence(joint_trajectories, "joint_trajectories",
                                     f"a list of (T_m, {n}) joint arrays", ScenesTypeError)
    times = as_sequence(times, "times", "one (T_m,) time array per recording", ScenesTypeError)
    if len(times) != len(joint_trajectories):
        raise _E(f"times: expected {len(joint_trajectories)} arrays (one per recording), got "
                 f"{len(times)}")
    q_list, positions, velocities, rotations, stamps = [], [], [], [], []
    for m, (q, t) in enumerate(zip(joint_trajectories, times)):
        q = as_array(q, f"joint_trajectories[{m}]", _E, MAX_COORDINATE)
        if q.ndim != 2 or q.shape[1] != n or len(q) < 2:
            raise _E(f"joint_trajectories[{m}]: expected shape (T_m >= 2, {n}) for the joints "
                     f"{list(robot.joint_names)}, got {q.shape}")
        t = as_time(t, f"times[{m}]", len(q), _E)
        _radians(robot, q, f"joint_trajectories[{m}]")
        q, qdot = smooth_trajectory(t, q, smoothing, f"{name or 'demonstrations'}[{m}] joints",
                                    unit="rad")
        kinematics = robot.ee_kinematics(q, qdot, jacobians=False)
        q_list.append(q)
        positions.append(np.asarray(kinematics.position, dtype=float))
        velocities.append(np.asarray(kinematics.velocity, dtype=float))
        rotations.append(quaternions_from_matrices(robot.ee_rotation(q)[0],
                                                   f"joint_trajectories[{m}] rotation", _E))
        stamps.append(t)
    names = tuple(robot.joint_names)
    if len(q_list) >= 2 and all(len(t) == len(stamps[0]) and np.array_equal(t, stamps[0])
                                for t in stamps):
        return Demonstrations(np.stack(positions), np.stack(velocities), stamps[0], None, name,
                              joint_positions=np.stack(q_list), joint_names=names,
                              orientations=np.stack(rotations))
    return Demonstrations.from_trajectories(positions, stamps, velocities=velocities, name=name,
                                            joint_positions=q_list, joint_names=names,
                                            orientations=rotations)
