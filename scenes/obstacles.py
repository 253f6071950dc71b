"""Primitive obstacles with exact, vectorized signed distance (metres, negative inside).

Each obstacle offers ``distance(points (...,3)) -> (...)``, its axis-aligned bounding box
``aabb() -> (2,3)``, ``translated(offset)`` and a JSON-ready ``to_dict()``;
:func:`obstacle_from_dict` is the inverse.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from .errors import InvalidObstacleError
from .validation import as_array, as_points, as_positive, as_vector


class Obstacle(ABC):
    """An obstacle: a solid whose exact signed distance can be evaluated."""

    kind: str = ""

    @abstractmethod
    def distance(self, points: np.ndarray) -> np.ndarray:
        """Exact signed distance (...,) in metres of points (...,3); negative inside."""

    @abstractmethod
    def aabb(self) -> np.ndarray:
        """Axis-aligned bounding box (2,3): [[xmin,ymin,zmin],[xmax,ymax,zmax]]."""

    @abstractmethod
    def translated(self, offset: np.ndarray) -> "Obstacle":
        """A copy moved by offset (3,) metres."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description with a ``"type"`` field."""

    def contains(self, points: np.ndarray) -> np.ndarray:
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


class Box(Obstacle):
    """Box of full edge lengths ``size`` (3,) centred at ``center`` (3,).

    ``rotation`` (3,3) maps box-local axes to world axes (world = center + rotation @ local);
    None means axis aligned.
    """

    kind = "box"

    def __init__(self, center: Any, size: Any, rotation: Any | None = None):
        self.center = as_vector(center, "Box center", 3, InvalidObstacleError)
        self.size = as_vector(size, "Box size", 3, InvalidObstacleError)
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
            self.rotation = r

    @classmethod
    def from_reference(cls, row: Any) -> "Box":
        """Box from the reference format [cx, cy, cz, size_x, size_y, size_z] (metres)."""
        row = as_vector(row, "Box reference row [cx,cy,cz,sx,sy,sz]", 6, InvalidObstacleError)
        return cls(row[:3], row[3:])

    def _local(self, points: np.ndarray) -> np.ndarray:
        rel = as_points(points, "points") - self.center
        return rel if self.rotation is None else rel @ self.rotation

    def distance(self, points: np.ndarray) -> np.ndarray:
        q = np.abs(self._local(points)) - 0.5 * self.size
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
        inside = np.minimum(q.max(axis=-1), 0.0)
        return outside + inside

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


class Sphere(Obstacle):
    """Ball of ``radius`` metres centred at ``center`` (3,)."""

    kind = "sphere"

    def __init__(self, center: Any, radius: Any):
        self.center = as_vector(center, "Sphere center", 3, InvalidObstacleError)
        self.radius = as_positive(radius, "Sphere radius", InvalidObstacleError)

    def distance(self, points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(as_points(points, "points") - self.center, axis=-1) - self.radius

    def aabb(self) -> np.ndarray:
        return np.stack([self.center - self.radius, self.center + self.radius])

    def translated(self, offset: np.ndarray) -> "Sphere":
        return Sphere(self.center + as_vector(offset, "offset", 3), self.radius)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "center": self.center.tolist(), "radius": self.radius}


class Cylinder(Obstacle):
    """Solid circular cylinder: centre (3,) at mid-height, radius, full height, axis (3,).

    The axis is normalised; default +z.
    """

    kind = "cylinder"

    def __init__(self, center: Any, radius: Any, height: Any, axis: Any = (0.0, 0.0, 1.0)):
        self.center = as_vector(center, "Cylinder center", 3, InvalidObstacleError)
        self.radius = as_positive(radius, "Cylinder radius", InvalidObstacleError)
        self.height = as_positive(height, "Cylinder height", InvalidObstacleError)
        axis = as_vector(axis, "Cylinder axis", 3, InvalidObstacleError)
        norm = np.linalg.norm(axis)
        if norm < 1e-12:
            raise InvalidObstacleError("Cylinder axis: expected a non-zero vector, got [0, 0, 0]")
        self.axis = axis / norm

    def distance(self, points: np.ndarray) -> np.ndarray:
        rel = as_points(points, "points") - self.center
        along = rel @ self.axis
        radial = np.linalg.norm(rel - along[..., None] * self.axis, axis=-1)
        q = np.stack([radial - self.radius, np.abs(along) - 0.5 * self.height], axis=-1)
        return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)

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


OBSTACLE_TYPES: dict[str, type[Obstacle]] = {"box": Box, "sphere": Sphere, "cylinder": Cylinder}


def obstacle_from_dict(data: Any, where: str = "obstacle") -> Obstacle:
    """Obstacle from a dict with ``type`` in OBSTACLE_TYPES and that type's fields.

    A box may instead give ``reference``: [cx,cy,cz,sx,sy,sz]. Raises InvalidObstacleError
    whose message starts with ``where`` and names the bad field.
    """
    if not isinstance(data, dict):
        raise InvalidObstacleError(f"{where}: expected an object with a 'type' field, got {type(data).__name__}")
    kind = data.get("type")
    if kind not in OBSTACLE_TYPES:
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
    required = {"box": {"center", "size"}, "sphere": {"center", "radius"},
                "cylinder": {"center", "radius", "height"}}[kind]
    optional = {"box": {"rotation"}, "sphere": set(), "cylinder": {"axis"}}[kind]
    missing = required - fields.keys()
    if missing:
        raise InvalidObstacleError(f"{where}: {kind} is missing field(s) {sorted(missing)}")
    extra = fields.keys() - required - optional
    if extra:
        raise InvalidObstacleError(f"{where}: unknown {kind} field(s) {sorted(extra)}; "
                                   f"expected {sorted(required | optional)}")
    try:
        return OBSTACLE_TYPES[kind](**fields)
    except InvalidObstacleError as exc:
        raise InvalidObstacleError(f"{where}: {exc}") from None
