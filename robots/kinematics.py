"""Vectorized forward kinematics of a serial arm, batched over many configurations.

The serial chain (joint placements, joint axes, frame placements) is read once from a Pinocchio
model; positions, velocities and their Jacobians are then computed with numpy for a whole batch
of B configurations at once (the loop runs over the n joints, never over the batch).
Joint values are angles (revolute, continuous) or displacements (prismatic); all results are in
the chain's base frame (metres, metres per second).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import RobotError, UnsupportedJointError

REVOLUTE = "revolute"
CONTINUOUS = "continuous"
PRISMATIC = "prismatic"


@dataclass(frozen=True)
class EndEffectorKinematics:
    """End-effector position and linear velocity over a batch of configurations.

    position (..., 3) [m]; velocity (..., 3) = J(q) qdot [m/s];
    jacobian (..., 3, n) = d position / d q (= d velocity / d qdot);
    velocity_jacobian (..., 3, n) = d (J(q) qdot) / d q. Both Jacobians are None when not requested.
    """

    position: np.ndarray
    velocity: np.ndarray
    jacobian: np.ndarray | None
    velocity_jacobian: np.ndarray | None


@dataclass(frozen=True)
class FrameAttachment:
    """Where a frame sits on the chain: joint index (0 = base, k = after the k-th chain joint)
    and its placement (rotation (3,3), translation (3,)) in that joint's axis-aligned frame
    (the joint frame turned by a constant rotation so that its z axis is the joint axis)."""

    joint: int
    rotation: np.ndarray
    translation: np.ndarray


@dataclass(frozen=True)
class JointFrames:
    """Joint frames for a batch of B configurations, in the base frame.

    rotations (B, n+1, 3, 3) and origins (B, n+1, 3): index 0 is the model's root frame,
    index k the axis-aligned frame of the k-th chain joint after its motion (z = joint axis);
    axes (B, n, 3) joint axes in the base frame.
    """

    rotations: np.ndarray
    origins: np.ndarray
    axes: np.ndarray


_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product along the last axis with broadcasting (faster than np.cross for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def frame_index(model: pin.Model, name: str) -> int:
    """Index of the frame called `name` in `model`, preferring a body frame; -1 when absent."""
    if model.existFrame(name, pin.FrameType.BODY):
        return model.getFrameId(name, pin.FrameType.BODY)
    return model.getFrameId(name) if model.existFrame(name) else -1


def frame_names(model: pin.Model) -> tuple[str, ...]:
    """Names of all frames of `model` (links, joints, fixed frames), without repeats."""
    return tuple(dict.fromkeys(f.name for f in model.frames))


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) whose third column is the unit vector `axis`."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = helper - axis * (helper @ axis)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(axis, x), axis))


def _classify_joint(model: pin.Model, joint_id: int) -> tuple[str, np.ndarray]:
    """Kind and unit axis (3,) in the joint frame of a one-degree-of-freedom joint."""
    joint = model.joints[joint_id]
    name = model.names[joint_id]
    if joint.nv != 1 or joint.nq not in (1, 2):
        raise UnsupportedJointError(
            f"joint {name!r} ({joint.shortname()}) has nq={joint.nq}, nv={joint.nv}; only revolute, "
            "continuous and prismatic joints are supported")
    data = joint.createData()
    q_joint = pin.neutral(model)[joint.idx_q:joint.idx_q + joint.nq]
    joint.calc(data, q_joint)
    motion = np.asarray(data.S).reshape(6)
    linear, angular = motion[:3], motion[3:]
    if np.linalg.norm(linear) < 1e-12 and abs(np.linalg.norm(angular) - 1.0) < 1e-9:
        return (CONTINUOUS if joint.nq == 2 else REVOLUTE), angular / np.linalg.norm(angular)
    if joint.nq == 1 and np.linalg.norm(angular) < 1e-12 and abs(np.linalg.norm(linear) - 1.0) < 1e-9:
        return PRISMATIC, linear / np.linalg.norm(linear)
    raise UnsupportedJointError(
        f"joint {name!r} ({joint.shortname()}) is neither a revolute, continuous nor prismatic joint")


class SerialChain:
    """The kinematic chain of a Pinocchio model whose joints 1..n form one serial chain.

    Built once from the model; expresses everything in `base_frame` (a frame fixed to the
    model's root; None = the root itself).
    """

    def __init__(self, model: pin.Model, base_frame: str | None = None):
        self.model = model
        n = model.njoints - 1
        if n < 1:
            raise RobotError("model: the robot has no movable joints")
        for k in range(1, model.njoints):
            if model.parents[k] != k - 1:
                raise RobotError(
                    f"model: joints do not form a serial chain (joint {model.names[k]!r} hangs off "
                    f"{model.names[model.parents[k]]!r}, expected {model.names[k - 1]!r})")
        self.n = n
        self.joint_names: tuple[str, ...] = tuple(model.names[1:])
        kinds, axes = zip(*(_classify_joint(model, k) for k in range(1, model.njoints)))
        self.kinds: tuple[str, ...] = tuple(kinds)
        self.axes = np.array(axes)                                            # (n, 3) joint frame
        self.is_prismatic = np.array([k == PRISMATIC for k in self.kinds])
        self.idx_q = np.array([model.joints[k].idx_q for k in range(1, model.njoints)])
        self.nq = model.nq
        self._pinocchio_index: tuple[np.ndarray, ...] | None = None   # see to_pinocchio
        placement_rotations = np.array([model.jointPlacements[k].rotation for k in range(1, n + 1)])
        placement_translations = np.array([model.jointPlacements[k].translation for k in range(1, n + 1)])
        # Internally every joint frame is turned by a constant rotation U_k so that its z axis is
        # the joint axis (U_0 = I for the root); placements are re-expressed accordingly.
        aligned = np.concatenate((np.eye(3)[None], np.array([_axis_frame(a) for a in self.axes])))
        self._aligned = aligned                                               # (n+1, 3, 3)
        steps = np.einsum("kji,kjl,klm->kim", aligned[:-1], placement_rotations, aligned[1:])
        offsets = np.einsum("kji,kj->ki", aligned[:-1], placement_translations)
        self._step_offsets = np.concatenate((steps, offsets[:, :, None]), axis=2)  # (n, 3, 4)
        self.base_frame = base_frame
        self._last_frames: tuple[np.ndarray, JointFrames] | None = None  # see joint_frames
        if base_frame is None:
            self.base_rotation, self.base_translation = np.eye(3), np.zeros(3)
        else:
            att = self.attachment(base_frame)
            if att.joint != 0:
                raise RobotError(f"base_frame: frame {base_frame!r} moves with joint "
                                 f"{self.joint_names[att.joint - 1]!r}; it must be fixed to the root")
            # pose of the root expressed in the base frame = inverse of the base frame's placement
            self.base_rotation = att.rotation.T.copy()
            self.base_translation = -att.rotation.T @ att.translation

    # ----------------------------------------------------------------- frames
    def frame_id(self, name: str) -> int:
        """Index of the frame called `name`, preferring a body frame; -1 when absent."""
        return frame_index(self.model, name)

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Names of all frames of the model (links, joints, fixed frames), without repeats."""
        return frame_names(self.model)

    def attachment(self, name: str) -> FrameAttachment:
        """Where frame `name` sits on the chain; raises KeyError when it does not exist."""
        fid = self.frame_id(name)
        if fid < 0:
            raise KeyError(name)
        frame = self.model.frames[fid]
        joint = int(frame.parentJoint)
        to_aligned = self._aligned[joint].T
        rotation = to_aligned @ np.array(frame.placement.rotation)
        translation = to_aligned @ np.array(frame.placement.translation)
        return FrameAttachment(joint, rotation, translation)

    # ------------------------------------------------------ joint conversions
    def to_pinocchio(self, q: np.ndarray) -> np.ndarray:
        """Joint values (..., n) -> Pinocchio configuration (..., nq) with (cos, sin) pairs."""
        if self._pinocchio_index is None:
            continuous = np.array([kind == CONTINUOUS for kind in self.kinds])
            self._pinocchio_index = (np.flatnonzero(continuous), self.idx_q[continuous],
                                     np.flatnonzero(~continuous), self.idx_q[~continuous])
        cont, at, plain, plain_at = self._pinocchio_index
        out = np.zeros(q.shape[:-1] + (self.nq,))
        angles = q[..., cont]
        out[..., at] = np.cos(angles)
        out[..., at + 1] = np.sin(angles)
        out[..., plain_at] = q[..., plain]
        return out

    def from_pinocchio(self, q_pin: np.ndarray) -> np.ndarray:
        """Pinocchio configuration (..., nq) -> joint values (..., n); angles of continuous joints in (-pi, pi]."""
        out = np.zeros(q_pin.shape[:-1] + (self.n,))
        for k, kind in enumerate(self.kinds):
            i = self.idx_q[k]
            out[..., k] = np.arctan2(q_pin[..., i + 1], q_pin[..., i]) if kind == CONTINUOUS else q_pin[..., i]
        return out

    # ------------------------------------------------------------ kinematics
    def joint_frames(self, q: np.ndarray) -> JointFrames:
        """Frames of all chain joints for q (B, n), in the base frame.

        The frames of the most recent batch are kept (read-only arrays): a repeated call
        with equal q, e.g. end-effector kinematics then collision spheres of the same
        trajectory, returns them without recomputation.
        """
        last = self._last_frames
        if last is not None and last[0].shape == q.shape and np.array_equal(last[0], q):
            return last[1]
        frames = self._joint_frames(q)
        for array in (frames.rotations, frames.origins, frames.axes):  # shared between callers
            array.flags.writeable = False
        self._last_frames = (np.array(q, dtype=float, copy=True), frames)
        return frames

    def _joint_frames(self, q: np.ndarray) -> JointFrames:
        B = q.shape[0]
        rotations = np.empty((B, self.n + 1, 3, 3))
        origins = np.empty((B, self.n + 1, 3))
        rotations[:, 0] = self.base_rotation
        origins[:, 0] = self.base_translation
        cos, sin = np.cos(q), np.sin(q)
        for k in range(self.n):
            # one 2-D product for the placed rotation (z column = joint axis) and the offset
            placed_offset = (rotations[:, k].reshape(3 * B, 3) @ self._step_offsets[k]).reshape(B, 3, 4)
            placed = placed_offset[:, :, :3]
            origin = origins[:, k] + placed_offset[:, :, 3]
            if self.is_prismatic[k]:
                rotations[:, k + 1] = placed
                origins[:, k + 1] = origin + placed[:, :, 2] * q[:, k, None]
            else:
                c, s = cos[:, k, None], sin[:, k, None]
                x, y = placed[:, :, 0], placed[:, :, 1]
                rotations[:, k + 1, :, 0] = c * x + s * y                  # rotation about the local z axis
                rotations[:, k + 1, :, 1] = c * y - s * x
                rotations[:, k + 1, :, 2] = placed[:, :, 2]
                origins[:, k + 1] = origin
        return JointFrames(rotations, origins, rotations[:, 1:, :, 2])

    def point(self, frames: JointFrames, joint: int, local: np.ndarray,
              jacobians: bool) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Position (B, 3) of one point fixed to chain joint `joint` (0 = base) at `local` (3,) in
        that joint's axis-aligned frame, its Jacobian columns (B, n, 3) (transposed Jacobian) and
        the angular joint axes (B, n, 3); both None without jacobians. Layout suited to
        velocity_and_derivative; for many points use `points`."""
        pos = frames.origins[:, joint] + frames.rotations[:, joint] @ local
        if not jacobians:
            return pos, None, None
        angular = np.where(self.is_prismatic[:, None], 0.0, frames.axes)       # (B, n, 3)
        columns = _cross(angular, pos[:, None] - frames.origins[:, 1:])
        if self.is_prismatic.any():
            columns += np.where(self.is_prismatic[:, None], frames.axes, 0.0)
        columns[:, joint:] = 0.0                                               # joints after the point
        return pos, columns, angular

    def points(self, frames: JointFrames, joints: np.ndarray, local: np.ndarray,
               jacobians: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Positions of P points fixed to chain joints, and their Jacobians.

        joints (P,) chain joint index of each point (0 = base); local (P, 3) point in that joint's
        axis-aligned frame. Returns positions (B, P, 3) and Jacobians (B, P, 3, n) = d position / d q
        (or None). Column k is w_k x (p - o_k) for a revolute joint and the axis for a prismatic
        one, and zero unless the point moves with joint k.
        """
        B, J, P = frames.rotations.shape[0], frames.rotations.shape[1], len(joints)
        # every point in every joint frame with one matrix product, then each point's own joint
        everywhere = (frames.rotations.reshape(-1, 3) @ local.T).reshape(B, J, 3, P)
        pos = everywhere[:, joints, :, np.arange(P)].transpose(1, 0, 2) + frames.origins[:, joints]
        if not jacobians:
            return pos, None
        moves = np.arange(1, self.n + 1)[None, :] <= joints[:, None]           # (P, n)
        angular = np.where(self.is_prismatic[:, None], 0.0, frames.axes)       # (B, n, 3)
        # column k = w_k x p - w_k x o_k (+ axis for a prismatic joint): one batched product
        # [p, 1] (B, P, 4) @ cross-product matrices (B, 4, 3n), few temporaries
        shift = _cross(angular, frames.origins[:, 1:])
        if self.is_prismatic.any():
            shift -= np.where(self.is_prismatic[:, None], frames.axes, 0.0)
        factors = np.empty((B, 4, 3, self.n))
        factors[:, :3] = np.einsum("ijl,bkj->blik", _LEVI_CIVITA, angular)   # (w x p)_i = eps_ijl w_j p_l
        factors[:, 3] = -shift.transpose(0, 2, 1)
        homogeneous = np.empty((B, P, 4))
        homogeneous[:, :, :3] = pos
        homogeneous[:, :, 3] = 1.0
        jac = (homogeneous @ factors.reshape(B, 4, 3 * self.n)).reshape(B, P, 3, self.n)
        jac *= moves[None, :, None, :]
        return pos, jac

    @staticmethod
    def velocity_and_derivative(columns: np.ndarray, angular: np.ndarray,
                                qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Velocity J qdot (B, 3) and d(J qdot)/dq (B, 3, n) of one point.

        columns (B, n, 3) Jacobian columns (transposed Jacobian) of the point; angular (B, n, 3)
        angular joint axes.
        Uses d col_i / d q_k = w_k x col_i for k <= i and w_i x col_k for k > i.
        """
        weighted = columns * qdot[:, :, None]                                  # qdot_i col_i
        partial = np.cumsum(weighted, axis=1)
        velocity = partial[:, -1]
        downstream = velocity[:, None] - partial + weighted                    # sum over i >= k
        spin = angular * qdot[:, :, None]
        upstream = np.cumsum(spin, axis=1) - spin                              # sum over i < k
        derivative = _cross(angular, downstream) + _cross(upstream, columns)   # (B, n, 3)
        return velocity, derivative.transpose(0, 2, 1)
