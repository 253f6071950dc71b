"""The tests' independent measures of the hand: the geodesic angle between two rotations,
through the trace of the relative rotation (not clamp.prior.so3, which the tests check), and
the hand's pose by Pinocchio's forward kinematics (not the planner's kinematics)."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """[deg] the geodesic angle between rotations a and b (3, 3)."""
    return float(np.degrees(np.arccos(np.clip(0.5 * (np.trace(a.T @ b) - 1.0), -1.0, 1.0))))


def hand_angle(robot, q: np.ndarray, rotation: np.ndarray) -> float:
    """[deg] between the hand's rotation at q (n,) (the robot's kinematics) and ``rotation``."""
    return angle_deg(rotation, robot.ee_rotation(q)[0])


def hand_pose(robot, q: np.ndarray) -> tuple[np.ndarray, Rotation]:
    """The hand's position (3,) [m] and rotation at q (n,) in the robot's base frame, by
    Pinocchio's forward kinematics of the robot's model at its end-effector frame."""
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.to_pinocchio(np.asarray(q, dtype=float)))
    pin.updateFramePlacements(model, data)
    names = [frame.name for frame in model.frames]                 # the first of a name
    hand = data.oMf[names.index(robot.end_effector)]
    if robot.base_frame is not None:
        hand = data.oMf[names.index(robot.base_frame)].actInv(hand)
    return np.array(hand.translation), Rotation.from_matrix(np.array(hand.rotation))
