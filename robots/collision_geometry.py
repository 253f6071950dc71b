"""Collision geometry of a Pinocchio model, gathered per moving link and sampled on its surface.

Geometry objects are grouped by the joint they move with; each group is expressed in that joint's
*link frame*: the Pinocchio BODY frame of the link the joint carries (its placement relative to the
joint is the identity, so oMf[link] = oMi[joint]). Geometry on links welded to it by fixed joints
(for example fingers on the last link) joins the same group. Supported shapes: coal Sphere, Box,
Cylinder, Capsule and triangle meshes (BVH models read from .dae/.stl/.obj). Lengths in metres.
"""
from __future__ import annotations

import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from skillplan.command_line import native_stderr_logged

from .errors import CollisionGeometryError, UnknownFrameError, URDFParseError
from .kinematics import frame_names

log = logging.getLogger(__name__)

GEOMETRY_KINDS = {"collision": pin.GeometryType.COLLISION, "visual": pin.GeometryType.VISUAL}
SUPPORTED_SHAPES = ("Sphere", "Box", "Cylinder", "Capsule", "BVHModel (triangle mesh)")


@dataclass(frozen=True)
class Shape:
    """One collision shape placed in its link frame.

    kind: "sphere" | "box" | "cylinder" | "capsule" | "mesh"; rotation (3,3) and translation (3,)
    map shape coordinates to link coordinates; size: sphere (r,), box half sides (hx, hy, hz),
    cylinder/capsule (r, half length along z); triangles (F,3,3) vertex coordinates for a mesh.
    """

    name: str
    kind: str
    rotation: np.ndarray
    translation: np.ndarray
    size: tuple[float, ...] = ()
    triangles: np.ndarray | None = None

    @property
    def area(self) -> float:
        """Surface area [m^2]."""
        return float(_AREA[self.kind](self))

    def sample_surface(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """`count` points uniformly distributed over the surface, in the link frame (count, 3)."""
        local = _SAMPLERS[self.kind](self, count, rng)
        return local @ self.rotation.T + self.translation

    def extreme_points(self) -> np.ndarray:
        """Sharp edges of a primitive (F, 3), link frame: box corners and edges, cylinder rims;
        (0, 3) for smooth shapes and meshes (dense surface samples stand in for their vertices).
        Enclosing them besides the surface samples makes covers exact at corners."""
        if self.kind == "box":
            t = np.linspace(-1.0, 1.0, 17)
            signs = np.array([[a, b] for a in (-1.0, 1.0) for b in (-1.0, 1.0)])
            edges = []
            for axis in range(3):
                others = [i for i in range(3) if i != axis]
                edge = np.zeros((4, len(t), 3))
                edge[:, :, axis] = t
                edge[:, :, others] = signs[:, None, :]
                edges.append(edge.reshape(-1, 3))
            local = np.concatenate(edges) * np.array(self.size)
        elif self.kind == "cylinder":
            angle = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)
            radius, half_length = self.size
            rim = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.full(64, half_length)])
            local = np.vstack([rim, rim * [1.0, 1.0, -1.0]])
        else:
            local = np.zeros((0, 3))
        return local @ self.rotation.T + self.translation


@dataclass(frozen=True)
class LinkSurface:
    """All collision shapes that move rigidly with one joint, in the frame `link_name`."""

    link_name: str
    joint_id: int
    shapes: tuple[Shape, ...]

    @property
    def area(self) -> float:
        """Total surface area of the shapes [m^2]."""
        return float(sum(shape.area for shape in self.shapes))

    def sample_surface(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """`count` points spread over all shapes in proportion to their areas, link frame (count, 3)."""
        areas = np.array([shape.area for shape in self.shapes])
        counts = rng.multinomial(count, areas / areas.sum()) if areas.sum() > 0 else np.zeros(len(areas), int)
        parts = [shape.sample_surface(int(k), rng) for shape, k in zip(self.shapes, counts) if k > 0]
        return np.concatenate(parts) if parts else np.zeros((0, 3))

    def extreme_points(self) -> np.ndarray:
        """Extreme points (F, 3) of all shapes (see Shape.extreme_points), link frame."""
        return np.concatenate([shape.extreme_points() for shape in self.shapes])


def _one_line(error: Exception) -> str:
    """A native library's (coal / assimp) multi-line error as one line: its "message:" part
    when it has one (not the C++ file, function and line), every line joined by "; "."""
    text = str(error).strip()
    if "message:" in text:
        text = text.split("message:", 1)[1]
    return "; ".join(line.strip() for line in text.splitlines() if line.strip())


def _package_hint(message: str, package_dirs: Sequence[str]) -> str:
    """How to resolve a package:// mesh the loader could not find: the folder that holds the
    package (``package_dirs``; on the command lines ``--package-dir DIR``)."""
    match = re.search(r"package://([^/\s]+)/", message)
    if match is None:
        return ""
    return (f"; the URDF's meshes are package:// URIs: pass the folder that holds the package "
            f"{match.group(1)!r} as package_dirs (command line: --package-dir DIR)"
            + (", in addition to the folders given" if package_dirs else ""))


def load_geometry(model: pin.Model, urdf_path: str | Path, package_dirs: Sequence[str], kind: str = "collision"
                  ) -> pin.GeometryModel:
    """The URDF's collision or visual geometry (``kind``) as a Pinocchio GeometryModel (meshes
    read by coal / assimp). Raises URDFParseError with a one-line reason (e.g. an empty or
    missing mesh file); what the native loaders print is logged at debug level."""
    try:
        with native_stderr_logged(log):
            return pin.buildGeomFromUrdf(model, str(urdf_path), GEOMETRY_KINDS[kind], package_dirs=list(package_dirs))
    except Exception as exc:
        raise URDFParseError(f"cannot load {kind} geometry of {str(urdf_path)!r} (package_dirs="
                             f"{list(package_dirs)}): {_one_line(exc).rstrip('.')}"
                             f"{_package_hint(str(exc), package_dirs)}") from exc


def moves(geometry: pin.GeometryModel) -> bool:
    """Whether any geometry object moves with a joint (is not fixed to the world)."""
    return any(obj.parentJoint != 0 for obj in geometry.geometryObjects)


def link_frame_name(model: pin.Model, joint_id: int) -> str:
    """Name of the frame that carries joint `joint_id`'s link (BODY frame at the joint, else the joint frame)."""
    candidates = [f for f in model.frames if f.parentJoint == joint_id and f.placement.isIdentity(1e-9)]
    for wanted in (pin.FrameType.BODY, pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT):
        for frame in candidates:
            if frame.type == wanted:
                return frame.name
    raise CollisionGeometryError(
        f"model: joint {model.names[joint_id]!r} has no frame at its origin to express collision spheres in; "
        "add one with model.addJointFrame or model.addBodyFrame")


def link_surfaces(model: pin.Model, collision_model: pin.GeometryModel,
                  links: Sequence[str] | None = None) -> tuple[LinkSurface, ...]:
    """Collision shapes grouped per moving joint, in each joint's link frame (see module docstring).

    links: names of the frames (URDF links) whose geometry to use; None takes every geometry that
    moves with a joint (geometry fixed to the world, parent joint 0, is left out unless named).
    Raises UnknownFrameError for unknown names, CollisionGeometryError for a named link without
    geometry or an unsupported shape.
    """
    if not isinstance(model, pin.Model) or not isinstance(collision_model, pin.GeometryModel):
        raise CollisionGeometryError(
            f"model, collision_model: expected pinocchio.Model and pinocchio.GeometryModel, got "
            f"{type(model).__name__} and {type(collision_model).__name__}")
    objects = list(collision_model.geometryObjects)
    for obj in objects:
        if obj.parentJoint >= model.njoints or obj.parentFrame >= model.nframes:
            raise CollisionGeometryError(
                f"collision_model: geometry {obj.name!r} refers to a joint/frame the model does not have")
    if links is None:
        selected = [obj for obj in objects if obj.parentJoint != 0]
    else:
        if isinstance(links, str):
            links = [links]
        valid = frame_names(model)
        by_frame = {}
        for obj in objects:
            by_frame.setdefault(model.frames[obj.parentFrame].name, []).append(obj)
        selected = []
        for name in links:
            if name not in valid:
                raise UnknownFrameError("links", name, valid)
            if name not in by_frame:
                raise CollisionGeometryError(
                    f"links: {name!r} has no collision geometry; links with geometry: {', '.join(by_frame)}")
            selected.extend(by_frame[name])
    if not selected:
        raise CollisionGeometryError("collision_model: no collision geometry on the selected (moving) links")
    groups: dict[int, list[Shape]] = {}
    for obj in selected:
        groups.setdefault(obj.parentJoint, []).append(_shape_of(obj))
    return tuple(LinkSurface(link_frame_name(model, j), j, tuple(groups[j])) for j in sorted(groups))


def _shape_of(obj: pin.GeometryObject) -> Shape:
    """Convert a Pinocchio geometry object into a Shape in its parent joint's frame."""
    geometry = obj.geometry
    rotation = np.array(obj.placement.rotation, dtype=float)
    translation = np.array(obj.placement.translation, dtype=float)
    cls = type(geometry).__name__
    if cls == "Sphere":
        size = (float(geometry.radius),)
        kind = "sphere"
    elif cls == "Box":
        size = tuple(float(x) for x in geometry.halfSide)
        kind = "box"
    elif cls in ("Cylinder", "Capsule"):
        size = (float(geometry.radius), float(geometry.halfLength))
        kind = cls.lower()
    elif cls.startswith("BVHModel"):
        vertices = np.asarray(geometry.vertices(), dtype=float)
        indices = np.array([[t[0], t[1], t[2]] for t in map(geometry.tri_indices, range(geometry.num_tris))],
                           dtype=np.int64).reshape(-1, 3)
        if len(indices) == 0:
            raise CollisionGeometryError(f"collision_model: mesh {obj.name!r} has no triangles")
        return Shape(obj.name, "mesh", rotation, translation, (), vertices[indices])
    else:
        raise CollisionGeometryError(
            f"collision_model: geometry {obj.name!r} is a {cls}; supported shapes: {', '.join(SUPPORTED_SHAPES)}")
    if min(size) < 0 or not np.all(np.isfinite(size)):
        raise CollisionGeometryError(f"collision_model: geometry {obj.name!r} has invalid size {size}")
    return Shape(obj.name, kind, rotation, translation, size)


def _unit_vectors(count: int, rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal((count, 3))
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(norm > 0, norm, 1.0)


def _sample_sphere(shape: Shape, count: int, rng: np.random.Generator) -> np.ndarray:
    return shape.size[0] * _unit_vectors(count, rng)


def _box_face_areas(half: np.ndarray) -> np.ndarray:
    """Area of one face normal to x, y, z (4 * product of the other two half sides)."""
    return 4.0 * np.array([half[1] * half[2], half[0] * half[2], half[0] * half[1]])


def _sample_box(shape: Shape, count: int, rng: np.random.Generator) -> np.ndarray:
    half = np.array(shape.size)
    areas = _box_face_areas(half)
    axis = rng.choice(3, size=count, p=areas / areas.sum()) if areas.sum() > 0 else rng.integers(0, 3, count)
    points = rng.uniform(-1.0, 1.0, (count, 3)) * half
    sign = rng.choice((-1.0, 1.0), size=count)
    points[np.arange(count), axis] = sign * half[axis]
    return points


def _sample_cylinder(shape: Shape, count: int, rng: np.random.Generator) -> np.ndarray:
    radius, half_length = shape.size
    side, cap = 4.0 * np.pi * radius * half_length, np.pi * radius**2
    on_side = rng.random(count) < side / (side + 2.0 * cap)
    angle = rng.uniform(0.0, 2.0 * np.pi, count)
    rho = np.where(on_side, radius, radius * np.sqrt(rng.random(count)))
    z = np.where(on_side, rng.uniform(-half_length, half_length, count),
                 rng.choice((-half_length, half_length), size=count))
    return np.column_stack([rho * np.cos(angle), rho * np.sin(angle), z])


def _sample_capsule(shape: Shape, count: int, rng: np.random.Generator) -> np.ndarray:
    radius, half_length = shape.size
    side, ends = 4.0 * np.pi * radius * half_length, 4.0 * np.pi * radius**2
    on_side = rng.random(count) < side / (side + ends)
    direction = _unit_vectors(count, rng)
    angle = rng.uniform(0.0, 2.0 * np.pi, count)
    lateral = np.column_stack([radius * np.cos(angle), radius * np.sin(angle),
                               rng.uniform(-half_length, half_length, count)])
    cap = radius * direction
    cap[:, 2] += np.where(direction[:, 2] >= 0, half_length, -half_length)
    return np.where(on_side[:, None], lateral, cap)


def _triangle_areas(triangles: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1)


def _sample_mesh(shape: Shape, count: int, rng: np.random.Generator) -> np.ndarray:
    triangles = shape.triangles
    areas = _triangle_areas(triangles)
    if areas.sum() <= 0:
        raise CollisionGeometryError(f"collision_model: mesh {shape.name!r} has zero surface area")
    chosen = triangles[rng.choice(len(triangles), size=count, p=areas / areas.sum())]
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1.0
    u, v = np.where(flip, 1.0 - u, u), np.where(flip, 1.0 - v, v)
    return chosen[:, 0] + u[:, None] * (chosen[:, 1] - chosen[:, 0]) + v[:, None] * (chosen[:, 2] - chosen[:, 0])


_SAMPLERS = {
    "sphere": _sample_sphere, "box": _sample_box, "cylinder": _sample_cylinder,
    "capsule": _sample_capsule, "mesh": _sample_mesh,
}
_AREA = {
    "sphere": lambda s: 4.0 * np.pi * s.size[0] ** 2,
    "box": lambda s: 2.0 * _box_face_areas(np.array(s.size)).sum(),
    "cylinder": lambda s: 4.0 * np.pi * s.size[0] * s.size[1] + 2.0 * np.pi * s.size[0] ** 2,
    "capsule": lambda s: 4.0 * np.pi * s.size[0] * s.size[1] + 4.0 * np.pi * s.size[0] ** 2,
    "mesh": lambda s: _triangle_areas(s.triangles).sum(),
}
