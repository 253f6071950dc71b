"""Pose demonstrations for the tests: joint-space trajectories through keyframes, turned into
the hand's positions and rotations by the arm's own forward kinematics (the way a joint
recording gives them), with a tilt of the wrist towards the end (a pour)."""
from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from clamp.prior import so3
from scenes import Demonstrations


#: the Jaco's home configuration (Kinova's, rad): its neutral one (straight up) is singular
JACO_HOME = np.radians([275.0, 167.5, 57.5, 240.0, 82.5, 75.0])


def pose_demonstrations(robot, num_demos: int = 6, T: int = 60, duration: float = 3.0,
                        seed: int = 0, tilt: float = 0.8, spread: float = 0.08,
                        base: np.ndarray | None = None) -> Demonstrations:
    """``num_demos`` demonstrations (T steps over ``duration`` s) of ``robot``: three joint
    keyframes about ``base`` (n,) [rad] (default: its home (the Jaco) or neutral
    configuration), jittered by ``spread`` [rad] per demonstration, the wrist's second-last
    joint turned by ``tilt`` [rad] towards the end (the hand tilts as it pours)."""
    rng = np.random.default_rng(seed)
    if base is None:
        base = JACO_HOME if robot.name == "jaco" else robot.neutral_configuration()
    n = robot.n
    offsets = np.array([np.zeros(n), 0.25 * np.sin(np.arange(n) + 1.0),
                        0.35 * np.cos(np.arange(n) + 0.5)])
    time = np.linspace(0.0, duration, T)
    knots = np.array([0.0, 0.6, 1.0]) * duration
    q = np.empty((num_demos, T, n))
    for m in range(num_demos):
        keys = base + offsets + rng.normal(scale=spread, size=(3, n))
        keys[2, -2] += tilt
        path = CubicSpline(knots, keys, bc_type="clamped")(time)
        q[m] = robot.clip_to_limits(path)
    positions = robot.fk(q)
    velocities = np.gradient(positions, time, axis=1)
    rotations, _ = robot.ee_rotation(q)
    quaternions = so3.to_quaternions(rotations)
    return Demonstrations(positions, velocities, time, name="pose test",
                          joint_positions=q, joint_names=[f"j{k}" for k in range(n)],
                          orientations=quaternions)
