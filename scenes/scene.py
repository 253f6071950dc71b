"""A scene: obstacles plus the workspace bounds over which signed distance fields are built.

Scene files are JSON::

    {"bounds": [[xmin, ymin, zmin], [xmax, ymax, zmax]],      # optional
     "obstacles": [{"type": "box", "center": [..], "size": [..], "rotation": [[..]x3]},
                   {"type": "box", "reference": [cx, cy, cz, sx, sy, sz]},
                   {"type": "sphere", "center": [..], "radius": r},
                   {"type": "cylinder", "center": [..], "radius": r, "height": h, "axis": [..]}]}

``rotation`` and ``axis`` are optional (default: axis aligned, +z).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from .errors import InvalidArgumentError, InvalidObstacleError, SceneFileError
from .obstacles import Obstacle, obstacle_from_dict
from .validation import as_bounds, as_points

if TYPE_CHECKING:
    from .sdf import SignedDistanceField

#: Default workspace (2,3), metres: a box around a table-top arm with its base at the origin
#: (z up), |x|, |y| <= 0.75 and -0.1 <= z <= 0.7 (1.8 m^3).
DEFAULT_WORKSPACE = np.array([[-0.75, -0.75, -0.1], [0.75, 0.75, 0.7]])
#: Margin (m) kept around obstacles that stick out of the default workspace.
OBSTACLE_MARGIN = 0.1

_DATA = Path(__file__).resolve().parent / "data"


class Scene:
    """Obstacles and workspace bounds (2,3).

    Default bounds (``bounds=None``): :data:`DEFAULT_WORKSPACE`, grown where needed to contain
    every obstacle's bounding box plus :data:`OBSTACLE_MARGIN`.
    """

    def __init__(self, obstacles: Sequence[Obstacle] = (), bounds: Any | None = None):
        obstacles = list(obstacles)
        for i, ob in enumerate(obstacles):
            if not isinstance(ob, Obstacle):
                raise InvalidObstacleError(f"obstacles[{i}]: expected a Box, Sphere or Cylinder, "
                                           f"got {type(ob).__name__}")
        self.obstacles: list[Obstacle] = obstacles
        if bounds is None:
            bounds = DEFAULT_WORKSPACE.copy()
            for ob in obstacles:
                box = ob.aabb()
                bounds[0] = np.minimum(bounds[0], box[0] - OBSTACLE_MARGIN)
                bounds[1] = np.maximum(bounds[1], box[1] + OBSTACLE_MARGIN)
        self.bounds: np.ndarray = as_bounds(bounds, "bounds")

    def distance(self, points: Any) -> np.ndarray:
        """Exact signed distance (...,) of points (...,3): min over obstacles, +inf with none."""
        points = as_points(points, "points")
        result = np.full(points.shape[:-1], np.inf)
        for ob in self.obstacles:
            result = np.minimum(result, ob.distance(points))
        return result

    def sdf(self, cell_size: float = 0.01, exact: bool = False) -> "SignedDistanceField":
        """Signed distance field on a grid over ``bounds`` (see SignedDistanceField.from_scene)."""
        from .sdf import SignedDistanceField

        return SignedDistanceField.from_scene(self, cell_size=cell_size, exact=exact)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        return {"bounds": self.bounds.tolist(), "obstacles": [ob.to_dict() for ob in self.obstacles]}

    @classmethod
    def from_dict(cls, data: Any, source: str = "scene") -> "Scene":
        """Scene from a dict as in a scene file; SceneFileError names the bad field."""
        if not isinstance(data, dict):
            raise SceneFileError(f"{source}: expected a JSON object with 'obstacles', got {type(data).__name__}")
        extra = data.keys() - {"bounds", "obstacles", "name", "description"}
        if extra:
            raise SceneFileError(f"{source}: unknown field(s) {sorted(extra)}; "
                                 "expected 'obstacles', 'bounds' (and optional 'name', 'description')")
        raw = data.get("obstacles", [])
        if not isinstance(raw, list):
            raise SceneFileError(f"{source}: field 'obstacles' must be a list, got {type(raw).__name__}")
        obstacles = []
        for i, item in enumerate(raw):
            try:
                obstacles.append(obstacle_from_dict(item, where=f"obstacles[{i}]"))
            except InvalidObstacleError as exc:
                raise SceneFileError(f"{source}: {exc}") from None
        bounds = data.get("bounds")
        try:
            return cls(obstacles, bounds)
        except InvalidArgumentError as exc:
            raise SceneFileError(f"{source}: {exc}") from None

    @classmethod
    def load(cls, path: str | Path) -> "Scene":
        """Read a JSON scene file; SceneFileError on unreadable or malformed content."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except OSError as exc:
            raise SceneFileError(f"{path}: cannot read scene file ({exc})") from None
        except json.JSONDecodeError as exc:
            raise SceneFileError(f"{path}: not valid JSON ({exc})") from None
        return cls.from_dict(data, source=str(path))

    def save(self, path: str | Path) -> None:
        """Write this scene as JSON."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    def __repr__(self) -> str:
        return f"Scene(obstacles={self.obstacles!r}, bounds={self.bounds.tolist()})"


def available_scenes() -> tuple[str, ...]:
    """Names of the scene files shipped in scenes/data."""
    return tuple(sorted(p.stem for p in _DATA.glob("*.json")))


def builtin_scene(name: str) -> Scene:
    """A scene shipped with the package (see :func:`available_scenes`), e.g. ``"box_closing"``."""
    names = available_scenes()
    if name not in names:
        raise SceneFileError(f"scene name: unknown {name!r}; expected one of {list(names)}")
    return Scene.load(_DATA / f"{name}.json")
