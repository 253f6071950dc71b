"""The nearest obstacle of many points: a spatial index over the obstacles' bounding balls.

:class:`Nearest` is the package kernel behind :meth:`scenes.Scene.query` / ``distance`` and the
grid builder: ``nearest(coords (3,P), gradient, max_distance=inf) -> (distance (P,), gradient
(P,3) or None)`` on validated points [m] gives the least signed distance over the obstacles
and the gradient of the nearest one (the first listed wins ties), clipped at ``max_distance``:
``min(d(p), max_distance)``, with a zero gradient where d(p) > max_distance (without
obstacles: +inf, or max_distance, and zero gradients).

Cost. Obstacle k lies between the balls (c_k, inner_k) and (c_k, outer_k)
(:meth:`Obstacle._balls`), so ``|p - c_k| - outer_k <= d_k(p) <= |p - c_k| - inner_k`` (with
no inner ball, ``d_k(p) <= |p - c_k| + outer_k``). With :data:`INDEX_FROM` obstacles or more,
the centres go into k-d trees (``scipy.spatial.cKDTree``; one per band of outer radii within a
factor :data:`RADIUS_BAND`, so one large obstacle does not widen every search), and a point
only evaluates the obstacles whose lower bound is at most its cap: ``max_distance``, or, when
that is infinite, the least upper bound over the trees' nearest centres. With a finite cap, the
obstacles that cannot come within it of the points' bounding box are dropped first (one
vectorised test), and when fewer than :data:`SEARCH_FROM` remain, one table of their distances
to the points picks, for each, the points within its outer ball grown by the cap (cheaper than
the trees' pair search). Every obstacle that can decide the answer is among those evaluated, so
the result equals evaluating every obstacle; a planner that only needs distances below its
hinge's reach pays only for the obstacles within that reach of its points. Below
:data:`INDEX_FROM` obstacles, each is evaluated at every point (the bookkeeping would cost more).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from .obstacles import Obstacle

#: Obstacle count from which :class:`Nearest` uses its spatial index (below, every obstacle is
#: evaluated at every point: on 7,500 points, 8 boxes cost about as much as the index's search).
INDEX_FROM = 8
#: With a bounded query, fewer obstacles near the points' bounding box than this are matched to
#: the points through one distance table (cheaper than a k-d tree pair search, ~10 ms on 7,500
#: points, until about this many).
SEARCH_FROM = 128
#: Largest table of obstacle-point distances (entries) made for that test.
_MAX_TABLE = 2_000_000
#: Outer radii within this factor share a k-d tree.
RADIUS_BAND = 4.0
#: [m] slack on the candidate tests (covers the rounding of |p - c|).
_SLACK = 1e-9


def ball_pairs(tree: cKDTree, points: np.ndarray, radius: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (point index (M,), tree index (M,)) of points (P,3) and tree points within radius
    (a scalar or (P,)) [m] of them, in no particular order."""
    lists = tree.query_ball_point(points, radius, return_sorted=False)
    counts = np.fromiter(map(len, lists), dtype=np.intp, count=len(lists))
    found = np.concatenate(lists).astype(np.intp) if counts.sum() else np.zeros(0, np.intp)
    return np.repeat(np.arange(len(points)), counts), found


class _Band:
    """A k-d tree over the centres (B,3) of the obstacles ``ids`` (B,) whose outer radii are at
    most ``reach`` [m]."""

    def __init__(self, ids: np.ndarray, centres: np.ndarray, outer: np.ndarray):
        self.ids = ids
        self.tree = cKDTree(centres[ids])
        self.reach = float(outer[ids].max())


class Nearest:
    """Least signed distance over ``obstacles`` and the nearest one's gradient (module docstring)."""

    def __init__(self, obstacles: Sequence[Obstacle]):
        self.obstacles = tuple(obstacles)
        self._bands: list[_Band] = []
        if len(self.obstacles) < INDEX_FROM:
            return
        balls = [ob._balls() for ob in self.obstacles]
        self._centres = np.array([b[0] for b in balls], dtype=float)            # (K,3)
        inner = np.array([b[1] for b in balls], dtype=float)
        self._outer = np.array([b[2] for b in balls], dtype=float)              # (K,)
        # upper bound of d_k(p) = |p - c_k| + _above[k]
        self._above = np.where(np.isfinite(inner), -inner, self._outer)
        level = np.floor(np.log(np.maximum(self._outer, 1e-9)) / math.log(RADIUS_BAND)).astype(int)
        for value in np.unique(level):
            self._bands.append(_Band(np.flatnonzero(level == value), self._centres, self._outer))

    def _caps(self, points: np.ndarray, max_distance: float) -> np.ndarray | float:
        """Per point (P,) the least upper bound of its distance from each tree's nearest
        centre, capped at max_distance; max_distance itself when finite (no search needed)."""
        if math.isfinite(max_distance):
            return max_distance
        cap = np.full(len(points), np.inf)
        for band in self._bands:
            dist, j = band.tree.query(points, k=1)
            np.minimum(cap, dist + self._above[band.ids[j]], out=cap)
        return cap

    def _near_box(self, points: np.ndarray, cap: np.ndarray | float) -> np.ndarray | None:
        """The obstacles (ascending) whose outer ball comes within cap (a scalar) of the points'
        bounding box: those that may be within cap of some point; None for per-point caps."""
        if np.ndim(cap) != 0:
            return None
        lo, hi = points.min(axis=0) - cap, points.max(axis=0) + cap
        outside = np.maximum(np.maximum(lo - self._centres, self._centres - hi), 0.0)
        return np.flatnonzero(np.einsum("ij,ij->i", outside, outside) <= (self._outer + _SLACK) ** 2)

    def _candidates(self, points: np.ndarray, cap: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point index (M,), obstacle index (M,)) with |p - c_k| - outer_k <= cap(p),
        sorted by obstacle."""
        pairs_p, pairs_k = [], []
        scalar = np.ndim(cap) == 0
        point_tree = cKDTree(points) if scalar else None
        for band in self._bands:
            if scalar:
                found = point_tree.sparse_distance_matrix(band.tree, cap + band.reach + _SLACK,
                                                          output_type="ndarray")
                p, j = found["i"].astype(np.intp), found["j"].astype(np.intp)
            else:
                p, j = ball_pairs(band.tree, points, cap + band.reach + _SLACK)
            k = band.ids[j]
            gap = np.linalg.norm(points[p] - self._centres[k], axis=1) - self._outer[k]
            keep = gap <= (cap if scalar else cap[p]) + _SLACK
            pairs_p.append(p[keep])
            pairs_k.append(k[keep])
        p, k = np.concatenate(pairs_p), np.concatenate(pairs_k)
        order = np.lexsort((p, k))
        return p[order], k[order]

    def __call__(self, coords: np.ndarray, gradient: bool, max_distance: float = math.inf
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        count = coords.shape[1]
        d = np.full(count, np.inf)
        rows = np.zeros((3, count)) if gradient else None
        if not self._bands:                       # few obstacles: each at every point
            for ob in self.obstacles:
                _lower(d, rows, None, *ob._evaluate_within(coords, gradient, max_distance))
        else:
            points = np.ascontiguousarray(coords.T)
            cap = self._caps(points, max_distance)
            near = self._near_box(points, cap)
            if near is not None and len(near) < SEARCH_FROM and len(near) * count <= _MAX_TABLE:
                # one table (K,P) of |p - c_k|^2 (an expansion about the points' mean: no
                # cancellation worth the slack), then each obstacle at the points within its
                # outer ball grown by the cap
                origin = points.mean(axis=0)
                rel, centres = points - origin, self._centres[near] - origin
                table = np.einsum("kj,pj->kp", -2.0 * centres, rel)      # no BLAS: its threads
                table += np.einsum("ij,ij->i", rel, rel)                  # stall on a busy machine
                table += np.einsum("ij,ij->i", centres, centres)[:, None]
                within = table <= ((self._outer[near] + cap + _SLACK) ** 2)[:, None]
                for k, row in zip(near, within):
                    idx = np.flatnonzero(row)
                    if idx.size:
                        _lower(d, rows, idx, *self.obstacles[k]._evaluate_within(
                            coords[:, idx], gradient, max_distance))
            else:
                p, k = self._candidates(points, cap)
                starts = np.flatnonzero(np.r_[True, k[1:] != k[:-1]]) if len(k) else np.zeros(0, int)
                for first, last in zip(starts, np.r_[starts[1:], len(k)]):
                    idx = p[first:last]
                    _lower(d, rows, idx, *self.obstacles[k[first]]._evaluate_within(
                        coords[:, idx], gradient, max_distance))
        if math.isfinite(max_distance):
            beyond = d > max_distance
            d[beyond] = max_distance
            if gradient:
                rows[:, beyond] = 0.0
        return d, (None if rows is None else rows.T)


def _lower(d: np.ndarray, rows: np.ndarray | None, idx: np.ndarray | None, dk: np.ndarray,
           gk: np.ndarray | None) -> None:
    """Where an obstacle's distances dk at points idx (None: every point) are below d, take
    them and (rows (3,P), when not None) their gradients gk (M,3); ties keep the earlier."""
    if idx is None:
        if rows is not None:                      # row-wise index copies: a masked copyto is slow
            closer = np.flatnonzero(dk < d)
            rows[:, closer] = gk.T[:, closer]
        np.minimum(d, dk, out=d)
        return
    closer = np.flatnonzero(dk < d[idx])
    d[idx[closer]] = dk[closer]
    if rows is not None:
        rows[:, idx[closer]] = gk.T[:, closer]
