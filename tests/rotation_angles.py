"""The tests' one measure of how far apart two rotations are: the geodesic angle, through the
trace of the relative rotation (independent of clamp.prior.so3, which the tests check)."""
from __future__ import annotations

import numpy as np


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """[deg] the geodesic angle between rotations a and b (3, 3)."""
    return float(np.degrees(np.arccos(np.clip(0.5 * (np.trace(a.T @ b) - 1.0), -1.0, 1.0))))


def hand_angle(robot, q: np.ndarray, rotation: np.ndarray) -> float:
    """[deg] between the hand's rotation at q (n,) (the robot's kinematics) and ``rotation``."""
    return angle_deg(rotation, robot.ee_rotation(q)[0])
