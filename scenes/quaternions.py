"""The hand's recorded rotation: unit quaternions (x, y, z, w), the ROS and scipy order.

Every recorded rotation passes :func:`checked_quaternions` at the boundary (files, bags,
arrays given to :meth:`Demonstrations.from_trajectories`):

* not unit within :data:`QUATERNION_TOLERANCE` (|q| - 1): an error naming the sample;
* normalised, and each sample's sign chosen nearest the previous one (q and -q are one rotation,
  :func:`continuous_quaternions`);
* a turn between two samples faster than :data:`MAX_ANGULAR_SPEED` (2 pi rad/s, a full turn in a
  second: no wrist a person guides turns that fast, so it is a glitch of the recording, a frame
  swap or a dropped sample): a ``logging`` warning naming the sample, the angle and the speed.

Rotation matrices (4x4 poses' upper-left 3x3) pass :func:`quaternions_from_matrices`: orthonormal
with determinant +1 within :data:`ROTATION_TOLERANCE`, or an error naming the sample.
The rotation algebra itself is scipy's (``scipy.spatial.transform``).
"""
from __future__ import annotations

import logging
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from skillplan.validation import as_array

log = logging.getLogger(__name__)

#: how far from unit length a recorded quaternion may be before it is refused (|q| - 1)
QUATERNION_TOLERANCE = 1e-2
#: how far a recorded rotation matrix may be from orthonormal (max |R^T R - I|) before refused
ROTATION_TOLERANCE = 1e-2
#: fastest plausible turn of a guided hand between two samples [rad/s]; faster warns
#: (see docs/decisions.md#max_angular_speed)
MAX_ANGULAR_SPEED = 2.0 * np.pi


def continuous_quaternions(quaternions: np.ndarray) -> np.ndarray:
    """(..., T, 4) quaternions with each sample's sign chosen nearest the previous one along
    the second-to-last axis (the same rotations, no jump from q to -q)."""
    q = np.array(quaternions, dtype=float, copy=True)
    dots = np.einsum("...i,...i->...", q[..., 1:, :], q[..., :-1, :])
    flips = np.cumsum(dots < 0, axis=-1) % 2 == 1
    q[..., 1:, :][flips] *= -1.0
    return q


def slerp_quaternions(time: np.ndarray, quaternions: np.ndarray,
                      new_time: np.ndarray) -> np.ndarray:
    """(T',4) quaternions (x, y, z, w) at ``new_time`` (T',) by spherical linear interpolation
    of (T,4) ``quaternions`` at strictly increasing ``time`` (T,); sign-continuous."""
    at = np.clip(np.asarray(new_time, float), time[0], time[-1])
    return continuous_quaternions(Slerp(time, Rotation.from_quat(quaternions))(at).as_quat())


def off_unit(quaternions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths (...) of quaternions (..., 4) and whether each is off unit length by more than
    QUATERNION_TOLERANCE (bool (...))."""
    norm = np.linalg.norm(quaternions, axis=-1)
    return norm, np.abs(norm - 1.0) > QUATERNION_TOLERANCE


def unit_quaternions(values: Any, name: str, error: type[ValueError]) -> np.ndarray:
    """(..., 4) ``values`` as unit quaternions (x, y, z, w), normalised; ``error`` naming
    ``name[index]`` (the first sample that is not unit within QUATERNION_TOLERANCE) otherwise."""
    q = as_array(values, name, error)
    if q.ndim < 1 or q.shape[-1] != 4:
        raise error(f"{name}: expected quaternions (x, y, z, w) in the last dimension (..., 4), "
                    f"got shape {q.shape}")
    norm, bad = off_unit(q)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise error(f"{_at(name, index)}: expected a unit quaternion (x, y, z, w) "
                    f"within {QUATERNION_TOLERANCE:g} of length 1, got {_shown(q[index])} of length "
                    f"{norm[index]:.4g}")
    return q / norm[..., None]


def checked_quaternions(values: Any, time: np.ndarray, name: str, error: type[ValueError],
                        source: str = "") -> np.ndarray:
    """The (T,4) rotations of one recording at ``time`` (T,) [s] checked and repaired as the
    module docstring says: unit (``error`` naming ``name[k]`` otherwise), normalised,
    sign-continuous; a turn faster than MAX_ANGULAR_SPEED warns naming ``source: name[k]``
    (``source``: the file or data set, for the log)."""
    q = unit_quaternions(values, name, error)
    if q.ndim != 2 or len(q) != len(time):
        raise error(f"{name}: expected shape ({len(time)}, 4), one quaternion per time stamp, "
                    f"got {q.shape}")
    q = continuous_quaternions(q)
    angle = 2.0 * np.arctan2(np.linalg.norm(_relative(q[:-1], q[1:])[:, :3], axis=1),
                             np.abs(np.einsum("ij,ij->i", q[:-1], q[1:])))
    speed = angle / np.diff(np.asarray(time, dtype=float))
    fast = np.flatnonzero(speed > MAX_ANGULAR_SPEED)
    if fast.size:
        k = int(fast[0])
        log.warning("%s%s[%d] (t = %.4g s): the hand turns %.1f deg in %.4g s since the sample before "
                    "(%.3g rad/s, more than the plausible %.3g rad/s); a glitch of the recording?%s",
                    f"{source}: " if source else "", name, k + 1, time[k + 1], np.degrees(angle[k]), time[k + 1] - time[k], speed[k],
                    MAX_ANGULAR_SPEED,
                    f" ({fast.size - 1} more such step(s))" if fast.size > 1 else "")
    return q


def quaternions_from_matrices(values: Any, name: str, error: type[ValueError]) -> np.ndarray:
    """(..., 4) unit quaternions (x, y, z, w) of rotation matrices (..., 3, 3) (columns: the
    tool's axes in the base frame); ``error`` naming ``name[index]`` when a matrix is not a
    rotation (orthonormal, determinant +1) within ROTATION_TOLERANCE."""
    R = as_array(values, name, error)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise error(f"{name}: expected rotation matrices (..., 3, 3), got shape {R.shape}")
    gap = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-2, -1))
    bad = (gap > ROTATION_TOLERANCE) | (np.linalg.det(R) < 0)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise error(f"{_at(name, index)}: expected a rotation matrix (orthonormal "
                    f"within {ROTATION_TOLERANCE:g}, determinant +1), got max |R^T R - I| "
                    f"{gap[index]:.3g} and determinant {np.linalg.det(R[index]):.3g}")
    flat = R.reshape(-1, 3, 3)
    q = Rotation.from_matrix(flat).as_quat() if len(flat) else np.zeros((0, 4))
    return q.reshape(R.shape[:-2] + (4,))


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quaternions (N,4) of the rotations a^-1 b (x, y, z, w) for unit quaternions a, b (N,4)."""
    return (Rotation.from_quat(a).inv() * Rotation.from_quat(b)).as_quat()


def _at(name: str, index: tuple[int, ...]) -> str:
    """``name[i, j]`` of one sample of an array (``name`` for a single one)."""
    return f"{name}[{', '.join(map(str, index))}]" if index else name


def _shown(q: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in np.atleast_1d(q)) + ")"
