"""Dynamic time warping of one trajectory onto another's time axis."""
from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist

from skillplan.validation import as_points


def dtw_cost(reference: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Accumulated DTW cost (Ta,Tb) of Euclidean point distances between (Ta,3) and (Tb,3).

    The local cost matrix is one vectorized call; the accumulation runs over anti-diagonals,
    each updated in one vectorized step.
    """
    a = as_points(reference, "reference")
    b = as_points(other, "other")
    local = cdist(a, b)
    ta, tb = local.shape
    acc = np.full((ta + 1, tb + 1), np.inf)
    acc[0, 0] = 0.0
    for k in range(2, ta + tb + 1):
        i = np.arange(max(1, k - tb), min(ta, k - 1) + 1)
        j = k - i
        best = np.minimum(np.minimum(acc[i - 1, j - 1], acc[i - 1, j]), acc[i, j - 1])
        acc[i, j] = local[i - 1, j - 1] + best
    return acc[1:, 1:]


def dtw_path(reference: np.ndarray, other: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Optimal monotone DTW matching: index arrays (L,) into reference and other, from (0,0) to the ends."""
    acc = dtw_cost(reference, other)
    padded = np.full((acc.shape[0] + 1, acc.shape[1] + 1), np.inf)
    padded[1:, 1:] = acc
    padded[0, 0] = 0.0
    i, j = acc.shape
    path = [(i - 1, j - 1)]
    steps = np.array([[-1, -1], [-1, 0], [0, -1]])
    while i > 1 or j > 1:
        choice = int(np.argmin([padded[i - 1, j - 1], padded[i - 1, j], padded[i, j - 1]]))
        i, j = i + steps[choice, 0], j + steps[choice, 1]
        path.append((i - 1, j - 1))
    idx = np.array(path[::-1])
    return idx[:, 0], idx[:, 1]


def dtw_warp(reference: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Fractional indices (Ta,) into ``other`` matching each reference point, non-decreasing.

    The DTW match of each reference index (mean of its matched indices) is refined to sub-sample
    precision by projecting the reference point onto the two segments of ``other`` around it.
    """
    a = as_points(reference, "reference")
    b = as_points(other, "other")
    ia, ib = dtw_path(a, b)
    counts = np.bincount(ia, minlength=len(a))
    centre = np.rint(np.bincount(ia, weights=ib, minlength=len(a)) / counts).astype(int)
    best_index = centre.astype(float)
    best_dist = np.linalg.norm(a - b[centre], axis=-1)
    for start in (centre - 1, centre):
        start = np.clip(start, 0, len(b) - 2)
        p0, seg = b[start], b[start + 1] - b[start]
        length2 = np.einsum("ij,ij->i", seg, seg)
        t = np.where(length2 > 0, np.einsum("ij,ij->i", a - p0, seg) / np.where(length2 > 0, length2, 1.0), 0.0)
        t = np.clip(t, 0.0, 1.0)
        dist = np.linalg.norm(p0 + t[:, None] * seg - a, axis=-1)
        better = dist < best_dist
        best_index = np.where(better, start + t, best_index)
        best_dist = np.where(better, dist, best_dist)
    return np.clip(np.maximum.accumulate(best_index), 0.0, len(b) - 1.0)
