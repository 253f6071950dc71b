"""Primitive obstacles with exact, vectorised signed distance and gradient (metres, negative inside).

Each obstacle offers ``query(points (...,3)) -> (distance (...), gradient (...,3))``,
``distance(points (...,3)) -> (...)`` (the same kernel without the gradient), its axis-aligned
bounding box ``aabb() -> (2,3)``, ``translated(offset)`` and a JSON-ready ``to_dict()``;
:func:`obstacle_from_dict` is the inverse.

Gradient: the unit outward normal of the nearest surface point (|gradient| = 1 everywhere).
Where the distance is not differentiable a fixed unit subgradient is used, never NaN:

- inside a box, on a tie between faces, the face of the lowest local axis (x, then y, then z)
  wins; a point on a centre plane takes the face on the positive side;
- inside a cylinder, on a tie between the mantle and a cap, the mantle wins; on the axis the
  radial direction is the cylinder's local x axis (see :func:`axis_frame`); at mid-height the
  +axis cap is taken;
- at a sphere's centre +x; on a capsule's segment its local x axis.

"On" a centre plane, axis, centre or segment means within :data:`ON_MEDIAL` (1e-12 m): the
change to local coordinates of a tilted obstacle leaves rounding noise of that order, which
must not pick the direction.

Obstacles are immutable values: their arrays are read-only copies, so a scene may cache
anything derived from them.

Package-internal kernel: ``obstacle._evaluate(coords (3,P), gradient)`` works on points that
were already validated, in coordinate-major layout (a row per axis), and returns the distance
(P,) and the gradient (P,3) (often a transposed view of a (3,P) array; None when ``gradient``
is False). :class:`scenes.Scene` and the grid builder validate once and call it directly; use
:meth:`Obstacle.query` from outside. The kernels work in place on a few buffers: on this
project's machines a fresh 7500 x 3 temporary costs more (memory mapping) than its arithmetic.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from .errors import InvalidObstacleError
from skillplan.validation import MAX_COORDINATE, as_array, as_points, as_scalar, as_vector, unknown_names


def _frozen(arr: np.ndarray) -> np.ndarray:
    """A read-only copy of ``arr``."""
    out = np.array(arr, dtype=float)
    out.setflags(write=False)
    return out


#: Distance (m) from a centre plane, axis, centre or segment below which a point counts as on it
#: when picking the subgradient (see the module docstring).
ON_MEDIAL = 1e-12


def _point(x: Any, name: str) -> np.ndarray:
    """A centre (3,) [m] of magnitude <= MAX_COORDINATE (InvalidObstacleError naming it)."""
    return as_vector(x, name, 3, InvalidObstacleError, MAX_COORDINATE)


def _length(x: Any, name: str) -> float:
    """A radius / height [m] in (0, MAX_COORDINATE] (InvalidObstacleError naming it)."""
    return as_scalar(x, name, maximum=MAX_COORDINATE, strictly_positive=True,
                     error=InvalidObstacleError)


def as_coords(points: Any, name: str = "points") -> tuple[np.ndarray, tuple[int, ...]]:
    """Validate points (...,3) [m]; return them coordinate-major (3,P) (a transposed view when
    possible: the kernels' first operation writes a C-ordered copy anyway) and the leading shape."""
    pts = as_points(points, name)
    return pts.reshape(-1, 3).T, pts.shape[:-1]


def axis_frame(axis: np.ndarray) -> np.ndarray:
    """Right-handed orthonormal frame (3,3) whose columns are (e1, e2, axis) for a unit axis (3,).

    e1 is world x (or world y when the axis is within ~26 degrees of x) made orthogonal to the
    axis; for the +z axis the frame is exactly the identity.
    """
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = helper - (helper @ axis) * axis
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(axis, e1), axis])


class Obstacle(ABC):
    """An obstacle: a solid whose exact signed distance and its gradient can be evaluated."""

    kind: ClassVar[str] = ""
    #: True when :meth:`query` is exact and cheap (a closed form, or an indexed search: meshes,
    #: point clouds), so a scene made only of such obstacles needs no grid; False for shapes
    #: that should go through a grid.
    primitive: ClassVar[bool] = False

    @abstractmethod
    def _evaluate(self, coords: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Kernel on validated points coords (3,P) [m]: distance (P,) and gradient (P,3) or None."""

    @abstractmethod
    def aabb(self) -> np.ndarray:
        """Axis-aligned bounding box (2,3): [[xmin,ymin,zmin],[xmax,ymax,zmax]]."""

    @abstractmethod
    def translated(self, offset: np.ndarray) -> "Obstacle":
        """A copy moved by offset (3,) metres."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description with a ``"type"`` field."""

    def _balls(self) -> tuple[np.ndarray, float, float]:
        """Centre (3,) [m] and radii [m] of a ball inside the obstacle and a ball containing it
        (both about that centre), used to cull obstacles far from a point. This default (any
        shape) has no inner ball (-inf) and the ball around the bounding box."""
        box = self.aabb()
        return 0.5 * (box[0] + box[1]), -np.inf, 0.5 * float(np.linalg.norm(box[1] - box[0]))

    def _evaluate_within(self, coords: np.ndarray, gradient: bool, max_distance: float
                         ) -> tuple[np.ndarray, np.ndarray | None]:
        """:meth:`_evaluate`, exact where the distance is at most ``max_distance`` [m]; above
        it any value > max_distance may be returned (with any gradient). Shapes with their own
        index (meshes, point clouds) skip the far part of their geometry; this default (a
        primitive) evaluates everything."""
        return self._evaluate(coords, gradient)

    def query(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Exact signed distance (...,) [m] and its unit gradient (...,3) at points (...,3).

        Negative inside. Non-differentiable points get a fixed unit subgradient (module
        docstring). Raises InvalidArgumentError naming ``points`` on a bad shape or NaN/inf.
        """
        coords, lead = as_coords(points)
        d, g = self._evaluate(coords, True)
        return d.reshape(lead), g.reshape(*lead, 3)

    def distance(self, points: Any) -> np.ndarray:
        """Exact signed distance (...,) in metres of points (...,3); negative inside."""
        coords, lead = as_coords(points)
        return self._evaluate(coords, False)[0].reshape(lead)

    def contains(self, points: Any) -> np.ndarray:
        """Boolean (...,): points inside or on the surface."""
        return self.distance(points) <= 0.0

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        a, b = self.to_dict(), other.to_dict()
        return a.keys() == b.keys() and all(np.allclose(a[k], b[k]) if k != "type" else a[k] == b[k]
                                            for k in a)

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v}" for k, v in self.to_dict().items() if k != "type")
        return f"{type(self).__name__}({fields})"


class IndexedObstacle(Obstacle):
    """An obstacle of many parts (a mesh's triangles, a cloud's points) searched through its own
    spatial index: :meth:`_evaluate_within` measures only the parts within reach, and
    :meth:`_evaluate` is it without a bound. Exact, so a scene of them needs no grid."""

    primitive = True

    def _evaluate(self, coords: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
        return self._evaluate_within(coords, gradient, math.inf)

    @abstractmethod
    def _evaluate_within(self, coords: np.ndarray, gradient: bool, max_distance: float
                         ) -> tuple[np.ndarray, np.ndarray | None]:
        """Exact distance (P,) (and gradient (P,3)) where it is at most max_distance [m]; any
        value above it elsewhere (+inf where no part is within reach)."""


class _FramedObstacle(Obstacle):
    """An obstacle evaluated in a local frame: local = frame^T (world - center).

    ``_frame`` (3,3) has the local axes as columns, or is None for the identity (no matmul).
    """

    center: np.ndarray
    _frame: np.ndarray | None

    def _set_frame(self, frame: np.ndarray | None) -> None:
        if frame is not None and np.array_equal(frame, np.eye(3)):
            frame = None
        self._frame = None if frame is None else _frozen(frame)
        self._frame_t = None if frame is None else np.ascontiguousarray(frame.T)
        self._local_center = (self.center if frame is None else frame.T @ self.center)[:, None]

    def _local(self, coords: np.ndarray) -> np.ndarray:
        """Local coordinates (3,P) of world points coords (3,P)."""
        if self._frame_t is None:
            return np.subtract(coords, self._local_center, order="C")
        local = self._frame_t @ coords
        local -= self._local_center
        return local

    def _world(self, local_vectors: np.ndarray) -> np.ndarray:
        """World vectors (P,3) (a transposed view of a (3,P) array) of local vectors (3,P)."""
        if self._frame is None:
            return local_vectors.T
        return (self._frame @ local_vectors).T


class Box(_FramedObstacle):
    """Box of full edge lengths ``size`` (3,) [m] centred at ``center`` (3,) [m].

    ``rotation`` (3,3) maps box-local axes to world axes (world = center + rotation @ local);
    None means axis aligned.
    """

    kind = "box"
    primitive = True

    def __init__(self, center: Any, size: Any, rotation: Any | None = None):
        self.center = _frozen(_point(center, "Box center"))
        self.size = _frozen(as_vector(size, "Box size", 3, InvalidObstacleError, MAX_COORDINATE))
        if np.any(self.size <= 0):
            raise InvalidObstacleError(f"Box size: expected three positive edge lengths, got {self.size}")
        if rotation is None:
            self.rotation = None
        else:
            r = as_array(rotation, "Box rotation", InvalidObstacleError)
            if r.shape != (3, 3):
                raise InvalidObstacleError(f"Box rotation: expected shape (3, 3), got {r.shape}")
            if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
                raise InvalidObstacleError("Box rotation: expected a proper rotation matrix "
                                           "(orthonormal, determinant +1)")
            self.rotation = _frozen(r)
        self._half = (0.5 * self.size)[:, None]
        if self.rotation is None:
            self._set_frame(None)
        else:  # the nearest exact rotation (polar factor), so gradients are unit to round-off
            u, _, vt = np.linalg.svd(self.rotation)
            self._set_frame(u @ vt)

    @classmethod
    def from_reference(cls, row: Any) -> "Box":
        """Box from the reference format [cx, cy, cz, size_x, size_y, size_z] (metres)."""
        row = as_vector(row, "Box reference row [cx,cy,cz,sx,sy,sz]", 6, InvalidObstacleError)
        return cls(row[:3], row[3:])

    def _evaluate(self, coords: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
        # in place on one (3,P) buffer (see the module docstring)
        work = self._local(coords)                 # (3,P) local coordinates, reused below
        negative = work < -ON_MEDIAL if gradient else None
        np.abs(work, out=work)
        work -= self._half                         # excess over each face plane (> 0 beyond it)
        d = work.max(axis=0)
        inner = np.flatnonzero(d <= 0.0)           # inside or on the surface: nearest face
        faces = work[:, inner] if gradient and inner.size else None
        np.maximum(work, 0.0, out=work)            # the part of the offset outside the box
        outside = np.einsum("ij,ij->j", work, work)
        np.sqrt(outside, out=outside)
        np.minimum(d, 0.0, out=d)
        d += outside
        if not gradient:
            return d, None
        outside[inner] = 1.0
        work /= outside
        if faces is not None:
            ex, ey, ez = faces
            face = np.where((ex >= ey) & (ex >= ez), 0, np.where(ey >= ez, 1, 2))
            work[:, inner] = 0.0
            work[face, inner] = 1.0
        np.negative(work, out=work, where=negative)
        return d, self._world(work)

    def _balls(self) -> tuple[np.ndarray, float, float]:
        return self.center, 0.5 * float(self.size.min()), 0.5 * float(np.linalg.norm(self.size))

    def aabb(self) -> np.ndarray:
        half = 0.5 * self.size if self.rotation is None else 0.5 * np.abs(self.rotation) @ self.size
        return np.stack([self.center - half, self.center + half])

    def translated(self, offset: np.ndarray) -> "Box":
        return Box(self.center + as_vector(offset, "offset", 3), self.size, self.rotation)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"type": self.kind, "center": self.center.tolist(), "size": self.size.tolist()}
        if self.rotation is not None:
            d["rotation"] = self.rotation.tolist()
        return d

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Box):
            return NotImplemented
        ra = np.eye(3) if self.rotation is None else self.rotation
        rb = np.eye(3) if other.rotation is None else other.rotation
        return (np.allclose(self.center, other.center) and np.allclose(self.size, other.size)
                and np.allclose(ra, rb))


def _radial(offset: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Lengths (P,) of offsets (3, P) (modified in place) and, with ``gradient``, their unit
    directions (P, 3); a zero offset (within ON_MEDIAL) gets the first axis."""
    r = np.einsum("ij,ij->j", offset, offset)
    np.sqrt(r, out=r)
    if not gradient:
        return r, None
    medial = r <= ON_MEDIAL
    safe = np.where(medial, 1.0, r)
    offset /= safe
    offset[:, medial] = 0.0
    offset[0, medial] = 1.0
    return r, offset.T


class Sphere(Obstacle):
    """Ball of ``radius`` metres centred at ``center`` (3,) [m]."""

    kind = "sphere"
    primitive = True

    def __init__(self, center: Any, radius: Any):
        self.center = _frozen(_point(center, "Sphere center"))
        self.radius = _length(radius, "Sphere radius")
        self._column = self.center[:, None]

    def _evaluate(self, coords: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
        rel = np.subtract(coords, self._column, order="C")
        r, unit = _radial(rel, gradient)           # at the centre: +x
        return r - self.radius, unit

    def _balls(self) -> tuple[np.ndarray, float, float]:
        return self.center, self.radius, self.radius

    def aabb(self) -> np.ndarray:
        return np.stack([self.center - self.radius, self.center + self.radius])

    def translated(self, offset: np.ndarray) -> "Sphere":
        return Sphere(self.center + as_vector(offset, "offset", 3), self.radius)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "center": self.center.tolist(), "radius": self.radius}


def _unit_axis(axis: Any, name: str) -> np.ndarray:
    axis = as_vector(axis, f"{name} axis", 3, InvalidObstacleError)
    norm = np.linalg.norm(axis)
    if norm < 1e-12:
        raise InvalidObstacleError(f"{name} axis: expected a non-zero vector, got {axis.tolist()}")
    return axis / norm


class Cylinder(_FramedObstacle):
    """Solid circular cylinder: centre (3,) at mid-height [m], radius [m], full height [m], axis (3,).

    The axis is normalised; default +z.
    """

    kind = "cylinder"
    primitive = True

    def __init__(self, center: Any, radius: Any, height: Any, axis: Any = (0.0, 0.0, 1.0)):
        self.center = _frozen(_point(center, "Cylinder center"))
        self.radius = _length(radius, "Cylinder radius")
        self.height = _length(height, "Cylinder height")
        self.axis = _frozen(_unit_axis(axis, "Cylinder"))
        self._set_frame(axis_frame(self.axis))

    def _evaluate(self, coords: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
        work = self._local(coords)                 # (3,P) local coordinates, becomes the gradient
        x, y, z = work
        rho = np.einsum("ij,ij->j", work[:2], work[:2])
        np.sqrt(rho, out=rho)
        radial = rho - self.radius                 # > 0 outside the mantle
        axial = np.abs(z)
        axial -= 0.5 * self.height                 # > 0 beyond a cap
        d = np.maximum(radial, axial)
        inner = np.flatnonzero(d <= 0.0)           # inside or on the surface: mantle or cap
        mantle = radial[inner] >= axial[inner] if gradient else None
        np.maximum(radial, 0.0, out=radial)
        np.maximum(axial, 0.0, out=axial)
        outside = np.hypot(radial, axial)
        np.minimum(d, 0.0, out=d)
        d += outside
        if not gradient:
            return d, None
        outside[inner] = 1.0
        radial /= outside                          # weights of the radial and axial directions
        axial /= outside
        radial[inner] = mantle
        axial[inner] = ~mantle
        np.negative(axial, out=axial, where=z < -ON_MEDIAL)
        on_axis = rho <= ON_MEDIAL
        rho[on_axis] = 1.0
        radial /= rho
        x *= radial
        y *= radial
        x[on_axis] = radial[on_axis]               # on the axis: local x (rho is 1 there)
        y[on_axis] = 0.0
        z[:] = axial
        return d, self._world(work)

    def _balls(self) -> tuple[np.ndarray, float, float]:
        half = 0.5 * self.height
        return self.center, min(self.radius, half), float(np.hypot(self.radius, half))

    def aabb(self) -> np.ndarray:
        # Extent of the two end discs along each world axis.
        half = 0.5 * self.height * np.abs(self.axis) + self.radius * np.sqrt(
            np.clip(1.0 - self.axis**2, 0.0, None))
        return np.stack([self.center - half, self.center + half])

    def translated(self, offset: np.ndarray) -> "Cylinder":
        return Cylinder(self.center + as_vector(offset, "offset", 3), self.radius, self.height, self.axis)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "center": self.center.tolist(), "radius": self.radius,
                "height": self.height, "axis": self.axis.tolist()}


class Capsule(_FramedObstacle):
    """Capsule: every point within ``radius`` [m] of a segment.

    The segment has its midpoint at ``center`` (3,) [m], direction ``axis`` (3,) (normalised;
    default +z) and length ``height`` [m] >= 0 (the cylindrical part, as in coal's
    ``Capsule(radius, lz)``; overall length height + 2 radius; 0 gives a sphere).
    """

    kind = "capsule"
    primitive = True

    def __init__(self, center: Any, radius: Any, height: Any, axis: Any = (0.0, 0.0, 1.0)):
        self.center = _frozen(_point(center, "Capsule center"))
        self.radius = _length(radius, "Capsule radius")
        self.height = as_scalar(height, "Capsule height (segment length, m)", minimum=0.0,
                                maximum=MAX_COORDINATE, error=InvalidObstacleError)
        self.axis = _frozen(_unit_axis(axis, "Capsule"))
        self._set_frame(axis_frame(self.axis))

    @property
    def endpoints(self) -> np.ndarray:
        """The segment's two ends (2,3) [m]: center -/+ height/2 * axis."""
        half = 0.5 * self.height * self.axis
        return np.stack([self.center - half, self.center + half])

    def _evaluate(self, coords: np.ndarray, gradient: bool) -> tuple[np.ndarray, np.ndarray | None]:
        work = self._local(coords)
        half = 0.5 * self.height
        work[2] -= np.clip(work[2], -half, half)   # offset from the nearest segment point
        r, unit = _radial(work, gradient)          # on the segment: local x
        d = r - self.radius
        return (d, None) if not gradient else (d, self._world(unit.T))

    def _balls(self) -> tuple[np.ndarray, float, float]:
        return self.center, self.radius, 0.5 * self.height + self.radius

    def aabb(self) -> np.ndarray:
        half = 0.5 * self.height * np.abs(self.axis) + self.radius
        return np.stack([self.center - half, self.center + half])

    def translated(self, offset: np.ndarray) -> "Capsule":
        return Capsule(self.center + as_vector(offset, "offset", 3), self.radius, self.height, self.axis)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "center": self.center.tolist(), "radius": self.radius,
                "height": self.height, "axis": self.axis.tolist()}


OBSTACLE_TYPES: dict[str, type[Obstacle]] = {"box": Box, "sphere": Sphere, "cylinder": Cylinder,
                                             "capsule": Capsule}
_REQUIRED = {"box": {"center", "size"}, "sphere": {"center", "radius"},
             "cylinder": {"center", "radius", "height"}, "capsule": {"center", "radius", "height"}}
_OPTIONAL = {"box": {"rotation"}, "sphere": set(), "cylinder": {"axis"}, "capsule": {"axis"}}


def obstacle_from_dict(data: Any, where: str = "obstacle") -> Obstacle:
    """Obstacle from a dict with ``type`` in OBSTACLE_TYPES and that type's fields.

    A box may instead give ``reference``: [cx,cy,cz,sx,sy,sz]. Raises InvalidObstacleError
    whose message starts with ``where`` and names the bad field.
    """
    if not isinstance(data, dict):
        raise InvalidObstacleError(f"{where}: expected an object with a 'type' field, got {type(data).__name__}")
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in OBSTACLE_TYPES:
        raise InvalidObstacleError(f"{where}.type: expected one of {sorted(OBSTACLE_TYPES)}, got {kind!r}")
    fields = dict(data)
    fields.pop("type")
    if kind == "box" and "reference" in fields:
        if len(fields) != 1:
            raise InvalidObstacleError(f"{where}: a box with 'reference' takes no other fields, got {sorted(fields)}")
        try:
            return Box.from_reference(fields["reference"])
        except InvalidObstacleError as exc:
            raise InvalidObstacleError(f"{where}.reference: {exc}") from None
    required, optional = _REQUIRED[kind], _OPTIONAL[kind]
    extra = fields.keys() - required - optional
    if extra:
        raise InvalidObstacleError(f"{where}: unknown {kind} field(s) "
                                   f"{unknown_names(extra, required | optional)}; "
                                   f"expected {sorted(required | optional)}")
    missing = required - fields.keys()
    if missing:
        raise InvalidObstacleError(f"{where}: {kind} is missing field(s) {sorted(missing)}")
    try:
        return OBSTACLE_TYPES[kind](**fields)
    except InvalidObstacleError as exc:
        raise InvalidObstacleError(f"{where}: {exc}") from None
