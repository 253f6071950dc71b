"""Reproduction metrics of benchmarks/bench_lfd.py: a reproduced path (and its hand rotations)
against a held-out demonstration.

  dtw_alignment      the optimal DTW alignment of two position paths (index pairs) and the mean
                     point distance along it [m];
  geodesic_angle     the angle between rotations given as unit quaternions (x, y, z, w) [rad]:
                     2 arccos |<q1, q2>| (q and -q are one rotation);
  orientation_error  the mean geodesic angle over the DTW pairs aligned on position [rad];
  swept_area         the area between two planar paths on equal-time points [m^2].
"""
from __future__ import annotations

import numpy as np

# the order in which equal accumulated costs are resolved (diagonal first), as in the DTW
# that bench_lfd has used since issue 28: its figures stay comparable
_MOVES = np.array([[1, 1], [1, 0], [0, 1]])


def dtw_alignment(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Optimal DTW alignment of paths a (Ta, 3) and b (Tb, 3) [m]: (pairs (L, 2) of indices
    (i into a, j into b) from (0, 0) to (Ta-1, Tb-1), mean point distance along them [m])."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    local = np.linalg.norm(a[:, None] - b[None], axis=-1)
    ta, tb = local.shape
    acc = np.full((ta + 1, tb + 1), np.inf)
    steps = np.zeros((ta + 1, tb + 1), dtype=np.int64)    # path length to each cell
    came = np.zeros((ta + 1, tb + 1), dtype=np.int8)      # the move into each cell (_MOVES)
    acc[0, 0] = 0.0
    for k in range(2, ta + tb + 1):                     # anti-diagonals, vectorised
        i = np.arange(max(1, k - tb), min(ta, k - 1) + 1)
        j = k - i
        options = np.stack([acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1]])
        lengths = np.stack([steps[i - 1, j - 1], steps[i - 1, j], steps[i, j - 1]])
        best = np.argmin(options, axis=0)
        cols = np.arange(len(i))
        acc[i, j] = local[i - 1, j - 1] + options[best, cols]
        steps[i, j] = lengths[best, cols] + 1
        came[i, j] = best
    pairs = np.empty((steps[ta, tb], 2), dtype=np.int64)
    i, j = ta, tb
    for n in range(len(pairs) - 1, -1, -1):
        pairs[n] = i - 1, j - 1
        di, dj = _MOVES[came[i, j]]
        i, j = i - di, j - dj
    return pairs, float(acc[ta, tb] / steps[ta, tb])


def dtw_mean(a: np.ndarray, b: np.ndarray) -> float:
    """Mean point distance [m] along the optimal DTW alignment of paths a (Ta, 3), b (Tb, 3)."""
    return dtw_alignment(a, b)[1]


def geodesic_angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Rotation angle [rad] between unit quaternions (..., 4) (x, y, z, w), in [0, pi]."""
    dots = np.abs(np.sum(np.asarray(q1, float) * np.asarray(q2, float), axis=-1))
    return 2.0 * np.arccos(np.clip(dots, 0.0, 1.0))


def orientation_error(path: np.ndarray, quaternions: np.ndarray, demo: np.ndarray,
                      demo_quaternions: np.ndarray) -> float:
    """Mean geodesic angle [rad] between the rotations of a reproduction (path (Ta, 3) [m],
    quaternions (Ta, 4)) and of a demonstration (demo (Tb, 3), demo_quaternions (Tb, 4)) over
    the pairs of their DTW alignment on position."""
    pairs, _ = dtw_alignment(path, demo)
    return float(np.mean(geodesic_angle(np.asarray(quaternions)[pairs[:, 0]],
                                        np.asarray(demo_quaternions)[pairs[:, 1]])))


def swept_area(a: np.ndarray, b: np.ndarray) -> float:
    """Area [m^2] between planar paths a, b (T, >=2) on equal-time points (x, y)."""
    def triangle(p, q, r):
        u, v = q - p, r - p
        return 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    a, b = a[:, :2], b[:, :2]
    return float(np.sum(triangle(a[:-1], a[1:], b[:-1]) + triangle(a[1:], b[1:], b[:-1])))
