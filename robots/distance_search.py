"""The bound-driven distance search of the robot's checks, one for the obstacle check
(:mod:`robots.collision_check`) and the self-collision check (:mod:`robots.self_collision`).

A check's cells are (configuration k, column c): k one of the checked configurations (support
states and those in between), c a pair of geometries (a link geometry and an obstacle, or two
link geometries). Every cell has a lower bound of its distance, improved three ways:

- the caller's bounds without any query (bounding spheres, boxes): ``lower`` (K, P);
- coal's distance of the convex bounds (a mesh's hull, a primitive itself; exact for a column
  whose bound is the geometry itself): :meth:`PairSearch.hulls`;
- motion: the signed distance of a column changes by at most the accumulated motion of its
  geometries between two configurations (``travel`` (K, P)), so each hull distance raises the
  bounds of the column's other configurations (:func:`motion_lower_bounds`, conservative
  advancement).

Exact distances (coal on the geometry itself, :meth:`PairSearch.measure`) are made only where
the bounds leave a cell open; the least of them is ``best`` at ``nearest``. Which cells are open
is the check's policy (a subclass): what must be resolved below the best distance so far, at
the support states, within a tolerance. The subclass gives the coal queries
(:meth:`PairSearch.bound_values`, :meth:`PairSearch.exact_values`) and where a cell is
(:meth:`PairSearch.where`).
"""
from __future__ import annotations

import math

import numpy as np


def motion_lower_bounds(known: np.ndarray, travel: np.ndarray) -> np.ndarray:
    """Lower bounds (K, P) of every configuration's distance from the known ones: a distance h
    at configuration a bounds the distance at every k by h - |travel(k) - travel(a)|. known
    (K, P) distances, -inf where unknown; travel (K, P) accumulated motion [m] along the
    configurations of the column's geometry."""
    forward = np.maximum.accumulate(known + travel, axis=0) - travel
    backward = np.maximum.accumulate((known - travel)[::-1], axis=0)[::-1] + travel
    return np.maximum(forward, backward)


class PairSearch:
    """Lower bounds, hull and exact distances of the cells (K, P) of one check.

    lower (K, P): bounds without a query (raised in place by every hull distance); travel
    (K, P): accumulated motion bound of each column's geometries; exact_columns (P,) bool: the
    column's convex bound is its geometry (a hull distance is exact); best, nearest: the least
    exact distance found before (e.g. in an earlier window) and where (:meth:`where`)."""

    def __init__(self, lower: np.ndarray, travel: np.ndarray, exact_columns: np.ndarray,
                 best: float = math.inf, nearest: tuple | None = None):
        self.lower, self.travel = lower, travel
        self.col_exact = exact_columns
        self.hull = np.full(lower.shape, np.nan)
        self.exact = np.full(lower.shape, np.nan)
        self.queried = np.zeros(lower.shape, dtype=bool)
        self.measured = np.zeros(lower.shape, dtype=bool)
        self.best, self.nearest = best, nearest

    # ------------------------------------------------------------------ the check's queries
    def bound_values(self, k: np.ndarray, c: np.ndarray) -> np.ndarray:
        """coal's distances (M,) of the convex bounds of cells (k, c)."""
        raise NotImplementedError

    def exact_values(self, k: np.ndarray, c: np.ndarray) -> np.ndarray:
        """coal's distances (M,) of the geometries of cells (k, c)."""
        raise NotImplementedError

    def where(self, k: int, c: int) -> tuple:
        """What ``nearest`` holds for cell (k, c)."""
        return k, c

    # ------------------------------------------------------------------ the search
    def _record(self, k: np.ndarray, c: np.ndarray, values: np.ndarray) -> None:
        self.exact[k, c] = values
        self.measured[k, c] = True
        if len(values):
            m = int(np.argmin(values))
            if values[m] < self.best:
                self.best, self.nearest = float(values[m]), self.where(int(k[m]), int(c[m]))

    def measure(self, k: np.ndarray, c: np.ndarray) -> None:
        """Exact distances of cells (k, c)."""
        self._record(k, c, self.exact_values(k, c))

    def hulls(self, k: np.ndarray, c: np.ndarray, cols: np.ndarray | None = None) -> None:
        """Hull distances of cells (k, c) (exact in exact columns); then the motion bound raises
        the lower bounds of their columns (``cols``: those columns, sorted, when known)."""
        values = self.bound_values(k, c)
        self.hull[k, c] = values
        self.queried[k, c] = True
        on_exact = self.col_exact[c]
        if on_exact.any():
            self._record(k[on_exact], c[on_exact], values[on_exact])
        cols = np.unique(c) if cols is None else cols
        known = np.where(self.queried[:, cols], self.hull[:, cols], -np.inf)
        self.lower[:, cols] = np.maximum(self.lower[:, cols], motion_lower_bounds(known, self.travel[:, cols]))

    def advance(self, candidate: np.ndarray, rows: np.ndarray | None = None,
                cols: np.ndarray | None = None) -> None:
        """Hull distances of candidate cells (K, P) bool: both ends of every run of candidates
        of a column (conservative advancement: each answer's motion bound may rule out the
        rest of the run) and the candidate of least bound of each of ``rows`` (the support
        states), or of each column when rows is None. ``cols``: when given, ``candidate`` is
        (K, len(cols)), the candidates of those columns only (every other column has none);
        the work is then done on them alone (a search narrows to a few columns)."""
        if cols is None:
            cols = np.flatnonzero(candidate.any(axis=0))
            candidate = candidate[:, cols]
        inner = np.zeros_like(candidate)
        inner[1:-1] = candidate[:-2] & candidate[2:]
        pick = candidate & ~inner
        lower = self.lower[:, cols]
        if rows is None:
            pick[np.argmin(np.where(candidate, lower, np.inf), axis=0), np.arange(len(cols))] = True
        else:
            rows = rows[candidate[rows].any(axis=1)]
            pick[rows, np.argmin(np.where(candidate[rows], lower[rows], np.inf), axis=1)] = True
        k, c = np.nonzero(pick)
        # every column has a candidate, so a pick: the columns queried are ``cols``
        self.hulls(k, cols[c], cols)

    def bounds(self) -> np.ndarray:
        """Best lower bound (K, P) of every cell's exact distance known so far."""
        return np.where(self.measured, self.exact, np.where(self.queried, np.fmax(self.hull, self.lower), self.lower))
