"""A triangle mesh obstacle (a scanned table, a fixture's CAD model): exact signed distance.

``TriangleMesh(vertices (V,3) [m], faces (F,3) vertex indices)``. The distance of a point is
its distance to the nearest triangle (closest point on a triangle: Ericson, *Real-Time
Collision Detection*, 5.1.5, vectorised over point-triangle pairs). A closed mesh (every edge
shared by exactly two faces, in opposite directions) has an inside: the sign comes from the
angle-weighted pseudonormal of the nearest feature (face, edge or vertex; Baerentzen and
Aanaes 2005), exact for a closed manifold mesh; faces are turned outward if the mesh encloses
a negative volume. An open mesh (a surface) has no inside: its distance is unsigned.

Only the triangles that can be nearest are measured: a k-d tree over the triangles' bounding
balls selects those within the query's reach (``max_distance``, the hinge's reach in a plan)
or, for an exact distance, within the distance to the nearest vertex. The gradient is the unit
vector from the nearest surface point (the feature's pseudonormal on the surface itself).

Measured against the alternatives (``benchmarks/bench_scene_scale.py``, section 3; the 7,500
sphere centres of box_closing's path by a 12-triangle pedestal table): this kernel costs no more
than one coal BVH distance per point (5-9 us a point, and unsigned: coal measures the surface,
so a point inside reads as outside); a 1 cm grid queries ~25-40x faster but costs a build of
0.25-0.5 s per scene and up to a cell of error. The exact kernel keeps a scene of meshes, clouds and
primitives on one exact, indexed query.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .errors import InvalidObstacleError
from .nearest import ball_pairs
from .obstacles import IndexedObstacle
from skillplan.validation import MAX_COORDINATE, as_array, as_shaped

# regions of a triangle's closest point (Ericson's order of tests: A, B, AB, C, AC, BC, face)
_A, _B, _C, _AB, _BC, _CA, _FACE = range(7)


#: Corners of the unit cube about the origin (8,3), index = 4 x_bit + 2 y_bit + z_bit, and its
#: twelve outward triangles (12,3).
_CUBE = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
_CUBE_FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                        [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


def box_triangles(center: Any, size: Any) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (8,3) [m] and outward faces (12,3) of an axis-aligned box of full edge lengths
    ``size`` (3,) [m] about ``center`` (3,) [m] (e.g. to assemble a table's mesh)."""
    center = as_shaped(center, "center", (3,), InvalidObstacleError, MAX_COORDINATE)
    size = as_shaped(size, "size", (3,), InvalidObstacleError, MAX_COORDINATE)
    return _CUBE * size + center, _CUBE_FACES.copy()


def as_faces(faces: Any, num_vertices: int) -> np.ndarray:
    """Faces (F,3) as vertex indices in [0, num_vertices); InvalidObstacleError naming
    ``TriangleMesh faces`` otherwise."""
    name = "TriangleMesh faces"
    arr = np.asarray(faces) if not isinstance(faces, (str, bytes, dict, set)) and faces is not None else None
    if arr is None or arr.dtype == bool or arr.dtype.kind not in "iuf" or arr.ndim != 2 \
            or arr.shape[1] != 3 or not arr.size:
        got = f"shape {arr.shape} of {arr.dtype}" if arr is not None else type(faces).__name__
        raise InvalidObstacleError(f"{name}: expected integer vertex indices of shape (F, 3), F >= 1, "
                                   f"got {got}")
    if arr.dtype.kind == "f" and not (np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))):
        raise InvalidObstacleError(f"{name}: expected integer vertex indices, got non-integer values")
    out = arr.astype(np.intp)
    bad = np.flatnonzero((out < 0).any(axis=1) | (out >= num_vertices).any(axis=1))
    if bad.size:
        raise InvalidObstacleError(f"{name}: face {int(bad[0])} = {out[bad[0]].tolist()} has a vertex "
                                   f"index out of range; expected 0 <= index < {num_vertices} "
                                   f"(the number of vertices)")
    return out


def closest_points(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Closest point (M,3) on triangle (a, b, c) (each (M,3)) to points (M,3), and its region
    (M,) (_A, _B, _C vertices, _AB, _BC, _CA edges, _FACE interior)."""
    ab, ac = b - a, c - a
    def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.einsum("ij,ij->i", u, v)
    ap, bp, cp = points - a, points - b, points - c
    d1, d2, d3, d4, d5, d6 = dot(ab, ap), dot(ac, ap), dot(ab, bp), dot(ac, bp), dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    region = np.full(len(points), _FACE)
    # lowest priority first, so that Ericson's earlier tests win
    region[(va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)] = _BC
    region[(vb <= 0) & (d2 >= 0) & (d6 <= 0)] = _CA
    region[(d6 >= 0) & (d5 <= d6)] = _C
    region[(vc <= 0) & (d1 >= 0) & (d3 <= 0)] = _AB
    region[(d3 >= 0) & (d4 <= d3)] = _B
    region[(d1 <= 0) & (d2 <= 0)] = _A
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        v = np.select([region == _B, region == _AB, region == _BC, region == _FACE],
                      [1.0, d1 / (d1 - d3), 1.0 - bc, vb / denom], 0.0)
        w = np.select([region == _C, region == _CA, region == _BC, region == _FACE],
                      [1.0, d2 / (d2 - d6), bc, vc / denom], 0.0)
    return a + v[:, None] * ab + w[:, None] * ac, region


class TriangleMesh(IndexedObstacle):
    """Triangles ``faces`` (F,3) (vertex indices) over ``vertices`` (V,3) [m] (module docstring)."""

    kind = "mesh"

    def __init__(self, vertices: Any, faces: Any):
        vertices = as_shaped(vertices, "TriangleMesh vertices", (None, 3), InvalidObstacleError,
                             MAX_COORDINATE)
        faces = as_faces(faces, len(vertices))
        a, b, c = (vertices[faces[:, k]] for k in range(3))
        cross = np.cross(b - a, c - a)
        area2 = np.linalg.norm(cross, axis=1)
        scale = np.max(np.linalg.norm(np.stack([b - a, c - b, a - c]), axis=2), axis=0)
        flat = np.flatnonzero(area2 <= 1e-12 * scale**2)
        if flat.size:
            raise InvalidObstacleError(f"TriangleMesh faces: face {int(flat[0])} = "
                                       f"{faces[flat[0]].tolist()} has no area (repeated or collinear "
                                       f"vertices; {len(flat)} such face(s)); expected triangles of "
                                       f"positive area")
        directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)          # AB, BC, CA per face
        key = directed[:, 0] * len(vertices) + directed[:, 1]
        reverse = directed[:, 1] * len(vertices) + directed[:, 0]
        self.closed = bool(len(np.unique(key)) == len(key) and np.isin(reverse, key).all())
        if self.closed and np.einsum("ij,ij->", a, cross) < 0:             # 6 x enclosed volume
            faces = faces[:, [0, 2, 1]]
            b, c, cross = c, b, -cross
            directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        vertices.setflags(write=False)
        faces.setflags(write=False)
        self.vertices, self.faces = vertices, faces
        self._corners = np.stack([a, b, c])                                  # (3,F,3)
        normals = self._normals = cross / area2[:, None]
        centre = (a + b + c) / 3.0
        radius = np.max(np.linalg.norm(self._corners - centre, axis=2), axis=0)
        self._tree, self._largest = cKDTree(centre), float(radius.max())
        self._centre, self._radius = centre, radius
        used = np.unique(faces)
        self._vertex_tree = cKDTree(vertices[used])
        self._box = np.stack([vertices[used].min(axis=0), vertices[used].max(axis=0)])
        # per face, the normal of each region's feature (the face normal for an open mesh)
        self._feature_normals = np.repeat(normals[:, None, :], 7, axis=1)
        if self.closed:
            edge, edge_id = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True)
            edge_id = edge_id.reshape(-1, 3)
            edge_normals = np.zeros((len(edge), 3))
            np.add.at(edge_normals, edge_id.reshape(-1), np.repeat(normals, 3, axis=0))
            vertex_normals = np.zeros((len(vertices), 3))
            for k, (u, v) in enumerate(((b - a, c - a), (c - b, a - b), (a - c, b - c))):
                cosine = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
                np.add.at(vertex_normals, faces[:, k], np.arccos(np.clip(cosine, -1.0, 1.0))[:, None] * normals)
            for region, k in ((_A, 0), (_B, 1), (_C, 2)):
                self._feature_normals[:, region] = vertex_normals[faces[:, k]]
            for region, k in ((_AB, 0), (_BC, 1), (_CA, 2)):
                self._feature_normals[:, region] = edge_normals[edge_id[:, k]]
        self._feature_normals /= np.linalg.norm(self._feature_normals, axis=2, keepdims=True)

    def _pairs(self, points: np.ndarray, reach: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """(point index, face index) pairs whose face may lie within reach (scalar or (P,)) [m]."""
        p, f = ball_pairs(self._tree, points, reach + self._largest + 1e-9)
        reach = (reach if np.ndim(reach) == 0 else reach[p]) + 1e-9
        offset = points[p] - self._centre[f]
        keep = np.einsum("ij,ij->i", offset, offset) <= (self._radius[f] + reach) ** 2
        p, f, offset, reach = p[keep], f[keep], offset[keep], reach if np.ndim(reach) == 0 else reach[keep]
        # the distance to a face's plane is at most that to the face: a cheap second cut
        keep = np.abs(np.einsum("ij,ij->i", offset, self._normals[f])) <= reach
        return p[keep], f[keep]

    def _nearest(self, points: np.ndarray, p: np.ndarray, f: np.ndarray, d: np.ndarray,
                 g: np.ndarray | None) -> None:
        """Signed distance d[p] (and gradient g[p]) from the nearest face among the pairs."""
        if not len(p):
            return
        q, region = closest_points(points[p], *self._corners[:, f])
        offset = points[p] - q
        length = np.linalg.norm(offset, axis=1)
        order = np.lexsort((length, p))
        first = order[np.r_[True, p[order][1:] != p[order][:-1]]]
        p, length, offset = p[first], length[first], offset[first]
        normal = self._feature_normals[f[first], region[first]]
        sign = np.where(np.einsum("ij,ij->i", offset, normal) < 0.0, -1.0, 1.0) if self.closed else 1.0
        d[p] = sign * length
        if g is not None:
            on = length <= 0.0
            unit = offset / np.where(on, 1.0, length)[:, None]
            if self.closed:
                unit *= sign[:, None]
            unit[on] = normal[on]
            g[p] = unit

    def _evaluate_within(self, coords: np.ndarray, gradient: bool, max_distance: float
                         ) -> tuple[np.ndarray, np.ndarray | None]:
        points = np.ascontiguousarray(coords.T)
        d = np.full(len(points), np.inf)
        g = np.zeros((len(points), 3)) if gradient else None
        if math.isfinite(max_distance):
            near = np.flatnonzero(np.all((points >= self._box[0] - max_distance)
                                         & (points <= self._box[1] + max_distance), axis=1))
            p, f = self._pairs(points[near], max_distance)
            self._nearest(points, near[p], f, d, g)
            # a closed mesh's inside may lie beyond the reach of every face: search those too
            far = np.flatnonzero(np.isinf(d) & np.all((points >= self._box[0]) & (points <= self._box[1]),
                                                      axis=1)) if self.closed else np.zeros(0, np.intp)
        else:
            far = np.arange(len(points))
        if far.size:
            bound = self._vertex_tree.query(points[far], k=1)[0]            # >= the distance
            p, f = self._pairs(points[far], bound)
            sub_d = np.full(len(far), np.inf)
            sub_g = np.zeros((len(far), 3)) if gradient else None
            self._nearest(points[far], p, f, sub_d, sub_g)
            d[far] = sub_d
            if gradient:
                g[far] = sub_g
        return d, g

    def aabb(self) -> np.ndarray:
        return self._box.copy()

    def translated(self, offset: np.ndarray) -> "TriangleMesh":
        return TriangleMesh(self.vertices + as_array(offset, "offset").reshape(3), self.faces)

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays that define the mesh: vertices (V,3) [m] and faces (F,3)."""
        return {"vertices": self.vertices, "faces": self.faces}

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "vertices": self.vertices.tolist(), "faces": self.faces.tolist()}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TriangleMesh):
            return NotImplemented
        return (self.vertices.shape == other.vertices.shape and np.allclose(self.vertices, other.vertices)
                and np.array_equal(self.faces, other.faces))

    def __repr__(self) -> str:
        return (f"TriangleMesh({len(self.vertices)} vertices, {len(self.faces)} faces, "
                f"{'closed' if self.closed else 'open'})")
