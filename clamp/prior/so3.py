"""Rotations as the pose prior and the pose factors read them: the log and exp maps of SO(3),
the inverse right Jacobian of the log map, the chordal mean and angular velocities of sampled
rotations. Batched over leading axes; angles in radians, quaternions (x, y, z, w).

The log and exp maps are scipy's (:class:`scipy.spatial.transform.Rotation`); the right Jacobian
is the closed form (e.g. Forster et al., "On-Manifold Preintegration", eq. 8):
Log(Exp(r) Exp(d)) = r + Jr^-1(r) d + O(|d|^2), with
Jr^-1(r) = I + [r]x / 2 + (1 / a^2 - (1 + cos a) / (2 a sin a)) [r]x^2, a = |r|.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["log_map", "exp_map", "right_jacobian_inverse", "chordal_mean", "world_rates",
           "from_quaternions", "to_quaternions", "angle_between", "nearest_branch",
           "continuous_in_time"]

#: [rad] below this angle the inverse right Jacobian uses its Taylor coefficient (1/12)
_SMALL = 1e-4


def from_quaternions(quaternions: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4) (x, y, z, w)."""
    q = np.array(quaternions, dtype=float)
    return Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(q.shape[:-1] + (3, 3))


def to_quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) (x, y, z, w) of rotation matrices R (..., 3, 3), w >= 0."""
    R = np.array(R, dtype=float)
    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat().reshape(R.shape[:-2] + (4,))
    return np.where(q[..., 3:] < 0, -q, q)


#: [rad] beyond pi minus this angle the log map is scipy's (the axis from the symmetric part)
_NEAR_PI = 1e-3


def _vee(R: np.ndarray) -> np.ndarray:
    """vee(R - R^T) (..., 3) of matrices R (..., 3, 3): for a rotation, 2 sin(angle) times
    its axis."""
    vee = np.empty(R.shape[:-2] + (3,))
    np.subtract(R[..., 2, 1], R[..., 1, 2], out=vee[..., 0])
    np.subtract(R[..., 0, 2], R[..., 2, 0], out=vee[..., 1])
    np.subtract(R[..., 1, 0], R[..., 0, 1], out=vee[..., 2])
    return vee


def log_map(R: np.ndarray) -> np.ndarray:
    """Rotation vectors r (..., 3) [rad] with Exp(r) = R (..., 3, 3), |r| <= pi: the angle
    from the trace and the skew part, r = a / (2 sin a) vee(R - R^T); near pi, scipy's."""
    R = np.asarray(R, dtype=float)
    vee = _vee(R)
    sine2 = np.sqrt(np.einsum("...i,...i->...", vee, vee))               # 2 sin a
    angle = np.arctan2(sine2, R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    small = sine2 < 1e-12
    scale = np.where(small, 0.5, angle / np.where(small, 1.0, sine2))
    r = scale[..., None] * vee
    near_pi = angle > np.pi - _NEAR_PI
    if np.any(near_pi):
        r[near_pi] = Rotation.from_matrix(np.array(R[near_pi])).as_rotvec()
    return r


def nearest_branch(r: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The rotation vectors (..., 3) [rad] of the rotations Exp(r) nearest ``reference``
    (..., 3) among r's equivalents r + 2 pi k r / |r| (k integer, the same rotation): the one
    whose angle along r's axis is closest to the reference's projection on that axis,
    k = round((n . reference - |r|) / 2 pi), n = r / |r|. Exactly r where k = 0 (and r = 0)."""
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    axis = np.divide(r, angle, out=np.zeros_like(r), where=angle > 0)
    turns = np.round((np.sum(axis * reference, axis=-1, keepdims=True) - angle) / (2 * np.pi))
    return np.where(turns != 0, r + 2 * np.pi * turns * axis, r)


def continuous_in_time(r: np.ndarray) -> np.ndarray:
    """Rotation vectors r (..., T, 3) [rad] of sampled rotations, each made continuous along
    the time axis -2 (the log map's branch followed from the first sample: every sample the
    equivalent nearest its predecessor, :func:`nearest_branch`). The principal log wraps where
    a rotation passes pi from the reference (a jump of up to 2 pi between two samples of a
    smooth motion); the followed branch does not, and its vectors can exceed pi. Unchanged
    where no sample wraps."""
    r = np.array(r, dtype=float)
    for t in range(1, r.shape[-2]):
        r[..., t, :] = nearest_branch(r[..., t, :], r[..., t - 1, :])
    return r


def exp_map(r: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors r (..., 3) [rad]."""
    r = np.array(r, dtype=float)
    return Rotation.from_rotvec(r.reshape(-1, 3)).as_matrix().reshape(r.shape[:-1] + (3, 3))


def right_jacobian_inverse(r: np.ndarray) -> np.ndarray:
    """Jr^-1(r) (..., 3, 3) of rotation vectors r (..., 3) [rad] (module docstring)."""
    r = np.asarray(r, dtype=float)
    a2 = np.einsum("...i,...i->...", r, r)
    a = np.sqrt(a2)
    small = a < _SMALL
    safe = np.where(small, 1.0, a)
    coefficient = np.where(small, 1.0 / 12.0,
                           1.0 / safe**2 - (1.0 + np.cos(safe)) / (2.0 * safe * np.sin(safe)))
    # [r]x^2 = r r^T - |r|^2 I: no batched 3x3 product
    out = coefficient[..., None, None] * (r[..., :, None] * r[..., None, :])
    diagonal = 1.0 - coefficient * a2
    for i in range(3):
        out[..., i, i] += diagonal
    half = 0.5 * r
    out[..., 0, 1] -= half[..., 2]
    out[..., 0, 2] += half[..., 1]
    out[..., 1, 2] -= half[..., 0]
    out[..., 1, 0] += half[..., 2]
    out[..., 2, 0] -= half[..., 1]
    out[..., 2, 1] += half[..., 0]
    return out


def chordal_mean(R: np.ndarray) -> np.ndarray:
    """The chordal L2 mean (T, 3, 3) over axis 0 of rotations R (M, T, 3, 3): the rotation
    nearest (Frobenius) the arithmetic mean of the matrices, by its SVD (proper: det +1)."""
    U, _, Vt = np.linalg.svd(np.asarray(R, dtype=float).mean(axis=0))
    sign = np.sign(np.linalg.det(U @ Vt))
    U[..., :, 2] *= sign[..., None]
    return U @ Vt


def world_rates(R: np.ndarray, time: np.ndarray) -> np.ndarray:
    """Angular velocities (..., T, 3) [rad/s] in the base frame of rotations R (..., T, 3, 3)
    sampled at ``time`` (T,) [s]: log(R_{t+1} R_{t-1}^T) / (t_{t+1} - t_{t-1}) inside, one-sided
    at the ends (the rotations' counterpart of numpy.gradient)."""
    R = np.asarray(R, dtype=float)
    t = np.asarray(time, dtype=float)
    after = np.concatenate([R[..., 1:, :, :], R[..., -1:, :, :]], axis=-3)
    before = np.concatenate([R[..., :1, :, :], R[..., :-1, :, :]], axis=-3)
    span = np.concatenate([[t[1] - t[0]], t[2:] - t[:-2], [t[-1] - t[-2]]])
    return log_map(after @ np.swapaxes(before, -1, -2)) / span[:, None]


def angle_between(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Geodesic angle (...) [rad] between rotations A and B (..., 3, 3), in [0, pi]."""
    E = np.swapaxes(np.asarray(A, dtype=float), -1, -2) @ np.asarray(B, dtype=float)
    cosine = 0.5 * (np.trace(E, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(0.5 * np.linalg.norm(_vee(E), axis=-1), cosine)
