"""Rotation-minimising (Bishop) frames along a polyline by the double-reflection method.

Each step from point i to i+1 maps the frame by two reflections: one in the plane bisecting the
chord x_{i+1} - x_i, one that turns the reflected tangent onto t_{i+1}. Their product is a
rotation R_i; the frames follow from the cumulative products R_{i-1} ... R_0, computed by a
parallel prefix scan (log2 N batched 3x3 products) instead of a loop over points.
"""
from __future__ import annotations

import numpy as np

from .errors import TLGCArgumentError
from .validation import as_points

_TINY = 1e-12


def unit_tangents(points: np.ndarray) -> np.ndarray:
    """Unit tangents (N,3) of a polyline (N,3) by central differences.

    Where the polyline stalls (repeated points) the tangent of the nearest moving stretch is
    used; a polyline that never moves raises TLGCArgumentError.
    """
    x = as_points(points, "points")
    if x.ndim != 2 or x.shape[0] < 2:
        raise TLGCArgumentError(f"points: expected shape (N, 3) with N >= 2, got {x.shape}")
    d = np.gradient(x, axis=0)
    if len(x) >= 3:
        # Second-order one-sided end differences where they agree with the end chords (they do
        # not at a start from rest, where the second-order formula is pure round-off).
        second = np.gradient(x[[0, 1, 2, -3, -2, -1]], axis=0, edge_order=2)[[0, -1]]
        agree = np.einsum("ij,ij->i", second, d[[0, -1]]) > 0
        d[[0, -1]] = np.where(agree[:, None], second, d[[0, -1]])
    norm = np.linalg.norm(d, axis=1)
    scale = max(float(np.ptp(x, axis=0).max()), 1.0) * _TINY
    moving = norm > scale
    if not moving.any():
        raise TLGCArgumentError("points: the polyline does not move (all points coincide)")
    if not moving.all():
        # Fill stalled points with the tangent of the nearest moving point (forward, then back).
        idx = np.arange(len(x))
        last = np.maximum.accumulate(np.where(moving, idx, -1))
        nxt = np.minimum.accumulate(np.where(moving, idx, len(x))[::-1])[::-1]
        use_next = (last < 0) | ((nxt < len(x)) & (nxt - idx < idx - last))
        source = np.where(use_next, nxt, last)
        d = d[source]
        norm = norm[source]
    return d / norm[:, None]


def _reflect(v: np.ndarray) -> np.ndarray:
    """Householder reflections (K,3,3) across the planes normal to v (K,3); identity for v ~ 0."""
    c = np.einsum("ij,ij->i", v, v)
    safe = c > _TINY**2
    coef = np.where(safe, 2.0 / np.where(safe, c, 1.0), 0.0)
    return np.eye(3) - coef[:, None, None] * v[:, :, None] * v[:, None, :]


def _cumulative_products(step: np.ndarray) -> np.ndarray:
    """Inclusive prefix products C_i = step_i @ ... @ step_0 of (K,3,3) matrices (log K passes)."""
    out = step.copy()
    shift = 1
    while shift < len(out):
        out[shift:] = out[shift:] @ out[:-shift]
        shift *= 2
    return out


def _default_normal(tangent: np.ndarray) -> np.ndarray:
    """A unit vector normal to ``tangent`` (3,), built from the axis least aligned with it."""
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(tangent)))] = 1.0
    n = axis - tangent * (axis @ tangent)
    return n / np.linalg.norm(n)


def bishop_frames(points: np.ndarray, initial_normal: np.ndarray | None = None) -> np.ndarray:
    """Rotation-minimising frames (N,3,3) along a polyline (N,3); rows = [tangent, normal, binormal].

    ``initial_normal`` (3,) fixes the first normal (projected onto the plane normal to the first
    tangent); by default it is built from the coordinate axis least aligned with that tangent.
    Frames are right-handed and orthonormal; a straight line gives constant frames.
    """
    x = as_points(points, "points")
    t = unit_tangents(x)
    if initial_normal is None:
        n0 = _default_normal(t[0])
    else:
        v = as_points(initial_normal, "initial_normal")
        if v.shape != (3,):
            raise TLGCArgumentError(f"initial_normal: expected shape (3,), got {v.shape}")
        n0 = v - t[0] * (v @ t[0])
        if np.linalg.norm(n0) < 1e-9 * max(np.linalg.norm(v), 1e-300):
            raise TLGCArgumentError("initial_normal: must not be parallel to the first tangent")
        n0 = n0 / np.linalg.norm(n0)

    chord = np.diff(x, axis=0)                                   # (N-1, 3)
    # Where the polyline stalls, reflect in the tangent instead: the pair of reflections is then
    # the minimal rotation turning t_i into t_{i+1} (never a lone, handedness-flipping one).
    scale = max(float(np.ptp(x, axis=0).max()), 1.0) * _TINY
    stalled = np.linalg.norm(chord, axis=1) <= scale
    chord[stalled] = t[:-1][stalled]
    first = _reflect(chord)                                      # (N-1, 3, 3)
    t_reflected = np.einsum("kij,kj->ki", first, t[:-1])
    second = _reflect(t[1:] - t_reflected)
    rotation = second @ first                                    # maps frame i to frame i+1
    normals = np.empty_like(x)
    normals[0] = n0
    if len(x) > 1:
        normals[1:] = np.einsum("kij,j->ki", _cumulative_products(rotation), n0)
    # Remove round-off: re-orthogonalise against the tangent and renormalise.
    normals -= t * np.einsum("ij,ij->i", normals, t)[:, None]
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    binormals = np.cross(t, normals)
    return np.stack([t, normals, binormals], axis=1)
