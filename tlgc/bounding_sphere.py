"""Smallest enclosing sphere of obstacles and point sets (paper section 7.2: obstacles are
approximated by a bounding sphere before the avoidance strategies are applied).

Point sets use Welzl's randomised algorithm in its incremental form (expected linear time):
points are visited in random order, and when one lies outside the current sphere the sphere
is rebuilt with it on the boundary. The nesting depth is bounded by the 4 boundary points of a
sphere in 3-D, so no recursion over the points occurs, and each scan is vectorised.
Primitive obstacles (:mod:`scenes` Sphere, Box, Cylinder) use their exact closed forms.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import TLGCArgumentError
from .validation import as_points, as_scalar

_REL_TOL = 1e-10


@dataclass(frozen=True)
class BoundingSphere:
    """A sphere: ``center`` (3,) [m], ``radius`` [m]."""

    center: np.ndarray
    radius: float

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (...,) [m] of points (..., 3) to the sphere surface (negative inside)."""
        return np.linalg.norm(np.asarray(points, dtype=float) - self.center, axis=-1) - self.radius

    def inflated(self, amount: float) -> "BoundingSphere":
        """The same sphere with ``amount`` metres added to the radius."""
        return BoundingSphere(self.center, self.radius + float(amount))


def _circumsphere(support: np.ndarray) -> tuple[np.ndarray, float]:
    """Smallest sphere with the 1-4 points ``support`` (k,3) on its surface."""
    a = support[0]
    if len(support) == 1:
        return a.copy(), 0.0
    edges = support[1:] - a                                   # (k-1, 3)
    # centre = a + edges^T x with 2 (edges edges^T) x = |edges|^2: the centre lies in the
    # affine span of the points, equidistant from all of them.
    gram = edges @ edges.T
    rhs = 0.5 * np.einsum("ij,ij->i", edges, edges)
    x, *_ = np.linalg.lstsq(gram, rhs, rcond=1e-12)
    center = a + x @ edges
    return center, float(np.linalg.norm(support - center, axis=1).max())


def _enclose(points: np.ndarray, limit: int, support: list[np.ndarray], tol: float
             ) -> tuple[np.ndarray, float]:
    """Smallest sphere enclosing points[:limit] with every ``support`` point on its surface."""
    if support:
        center, radius = _circumsphere(np.asarray(support))
        start = 0
    else:
        center, radius = points[0].copy(), 0.0
        start = 1
    if len(support) == 4:
        return center, radius
    i = start
    while i < limit:
        outside = np.flatnonzero(np.linalg.norm(points[i:limit] - center, axis=1) > radius + tol)
        if outside.size == 0:
            break
        j = i + int(outside[0])
        center, radius = _enclose(points, j, support + [points[j]], tol)
        i = j + 1
    return center, radius


def minimal_bounding_sphere(points: np.ndarray, seed: int = 0) -> BoundingSphere:
    """Smallest sphere enclosing points (P,3) [m] (Welzl; ``seed`` fixes the visiting order)."""
    p = as_points(points, "points")
    p = p.reshape(-1, 3)
    if len(p) == 0:
        raise TLGCArgumentError("points: expected at least one point, got none")
    p = np.unique(p, axis=0)
    p = p[np.random.default_rng(seed).permutation(len(p))]
    tol = _REL_TOL * max(float(np.ptp(p, axis=0).max()), 1.0)
    center, radius = _enclose(p, len(p), [], tol)
    return BoundingSphere(center, radius)


def bounding_sphere(obstacle: Any) -> BoundingSphere:
    """Smallest sphere enclosing ``obstacle`` [m].

    Accepts a :class:`BoundingSphere`, a ``(center (3,), radius)`` pair, a point set (P,3)
    (e.g. a detected obstacle's point cloud), or a :mod:`scenes` obstacle: Sphere (itself),
    Box (centre, half diagonal), Cylinder (centre, sqrt(radius^2 + (height/2)^2)).
    """
    if isinstance(obstacle, BoundingSphere):
        return obstacle
    kind = getattr(obstacle, "kind", None)
    if kind == "sphere":
        return BoundingSphere(np.asarray(obstacle.center, float), float(obstacle.radius))
    if kind == "box":
        return BoundingSphere(np.asarray(obstacle.center, float),
                              0.5 * float(np.linalg.norm(obstacle.size)))
    if kind == "cylinder":
        return BoundingSphere(np.asarray(obstacle.center, float),
                              float(np.hypot(obstacle.radius, 0.5 * obstacle.height)))
    if isinstance(obstacle, tuple) and len(obstacle) == 2:
        center = as_points(obstacle[0], "obstacle center")
        if center.shape != (3,):
            raise TLGCArgumentError(f"obstacle center: expected shape (3,), got {center.shape}")
        return BoundingSphere(center, as_scalar(obstacle[1], "obstacle radius", minimum=0.0))
    try:
        pts = np.asarray(obstacle, dtype=float)
    except (TypeError, ValueError):
        pts = None
    if pts is not None and pts.ndim == 2 and pts.shape[1] == 3:
        return minimal_bounding_sphere(pts)
    raise TLGCArgumentError(
        "obstacle: expected a scenes Sphere/Box/Cylinder, a BoundingSphere, a (center, radius) "
        f"pair or points (P, 3), got {type(obstacle).__name__}")
