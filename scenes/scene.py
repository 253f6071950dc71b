"""A scene: obstacles plus the workspace bounds over which signed distance fields are built.

Scene files are JSON::

    {"bounds": [[xmin, ymin, zmin], [xmax, ymax, zmax]],      # optional
     "obstacles": [{"type": "box", "center": [..], "size": [..], "rotation": [[..]x3]},
                   {"type": "box", "reference": [cx, cy, cz, sx, sy, sz]},
                   {"type": "sphere", "center": [..], "radius": r},
                   {"type": "cylinder", "center": [..], "radius": r, "height": h, "axis": [..]},
                   {"type": "capsule", "center": [..], "radius": r, "height": h, "axis": [..]}]}

``rotation`` and ``axis`` are optional (default: axis aligned, +z); a capsule's ``height`` is the
length of its segment (overall length height + 2 radius).

A Scene is immutable: ``obstacles`` is a tuple of immutable obstacles and ``bounds`` a read-only
array, both read-only properties. That is what lets a scene cache the grid fields it builds
(:meth:`Scene.sdf`): to change a scene, make a new one.
"""
from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .command_line import atomic_write_text
from .errors import ArgumentTypeError, InvalidArgumentError, InvalidObstacleError, SceneFileError
from .obstacles import Nearest, Obstacle, as_coords, obstacle_from_dict
from .sdf import DEFAULT_CELL_SIZE, SignedDistanceField, check_cell_size
from .validation import MAX_COORDINATE, as_bounds, as_instance, as_path, as_sequence

#: query(points (..., 3)) -> (signed distance (...,) [m], gradient (..., 3))
DistanceQuery = Callable[[Any], tuple[np.ndarray, np.ndarray]]

#: Default workspace (2,3), metres: a box around a table-top arm with its base at the origin
#: (z up), |x|, |y| <= 0.75 and -0.1 <= z <= 0.7 (1.8 m^3).
DEFAULT_WORKSPACE = np.array([[-0.75, -0.75, -0.1], [0.75, 0.75, 0.7]])
#: Margin (m) kept around obstacles that stick out of the default workspace.
OBSTACLE_MARGIN = 0.1

_DATA = Path(__file__).resolve().parent / "data"


class Scene:
    """Obstacles and workspace bounds (2,3) [m]; immutable (see the module docstring).

    Default bounds (``bounds=None``): :data:`DEFAULT_WORKSPACE`, grown where needed to contain
    every obstacle's bounding box plus :data:`OBSTACLE_MARGIN`. ``obstacles`` may also be a
    single obstacle.
    """

    def __init__(self, obstacles: Sequence[Obstacle] | Obstacle = (), bounds: Any | None = None):
        if isinstance(obstacles, Obstacle):
            obstacles = (obstacles,)
        obstacles = tuple(as_sequence(obstacles, "obstacles", "a list of scenes obstacles (Box, "
                                      "Sphere, Cylinder, Capsule) or one obstacle", ArgumentTypeError))
        for i, ob in enumerate(obstacles):
            if not isinstance(ob, Obstacle):
                raise InvalidObstacleError(f"obstacles[{i}]: expected a scenes Obstacle (Box, Sphere, "
                                           f"Cylinder, Capsule), got {type(ob).__name__}")
        self._obstacles: tuple[Obstacle, ...] = obstacles
        self._nearest = Nearest(obstacles)
        if bounds is None:
            bounds = DEFAULT_WORKSPACE.copy()
            for ob in obstacles:
                box = ob.aabb()
                bounds[0] = np.minimum(bounds[0], box[0] - OBSTACLE_MARGIN)
                bounds[1] = np.maximum(bounds[1], box[1] + OBSTACLE_MARGIN)
        bounds = np.array(as_bounds(bounds, "bounds"))
        if np.max(np.abs(bounds)) > MAX_COORDINATE:
            raise InvalidArgumentError(f"bounds: expected coordinates of magnitude <= "
                                       f"{MAX_COORDINATE:g} m, got {bounds.tolist()}")
        bounds.setflags(write=False)
        self._bounds = bounds
        self._grids: dict[tuple[float, bool], SignedDistanceField] = {}

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        """The obstacles (a tuple; read-only)."""
        return self._obstacles

    @property
    def bounds(self) -> np.ndarray:
        """Workspace bounds (2,3) [m] [[xmin,ymin,zmin],[xmax,ymax,zmax]] (read-only)."""
        return self._bounds

    @property
    def analytic(self) -> bool:
        """True when every obstacle is a primitive with an exact closed-form query (or there
        are none): :meth:`distance_query` then needs no grid."""
        return all(ob.primitive for ob in self._obstacles)

    def distance(self, points: Any) -> np.ndarray:
        """Exact signed distance (...,) [m] of points (...,3): min over obstacles, +inf with none."""
        coords, lead = as_coords(points)
        return self._nearest(coords, False)[0].reshape(lead)

    def query(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Exact signed distance (...,) [m] and its gradient (...,3) at points (...,3) [m].

        The distance is the min over obstacles (negative inside); the gradient is the unit
        gradient of the nearest obstacle (the first one listed on ties; see
        :mod:`scenes.obstacles` for the subgradient at non-differentiable points). Without
        obstacles: +inf with zero gradient. Points are validated once (InvalidArgumentError
        naming ``points``).
        """
        coords, lead = as_coords(points)
        d, g = self._nearest(coords, True)
        return d.reshape(lead), g.reshape(*lead, 3)

    def sdf(self, cell_size: float = DEFAULT_CELL_SIZE, exact: bool = False) -> SignedDistanceField:
        """Signed distance field on a grid over ``bounds`` (see
        :meth:`SignedDistanceField.from_obstacles`), built once per (cell_size [m], exact) and
        cached by this scene: later calls return the same object (its values are read-only).
        The cache lives as long as the scene (one entry per distinct key).

        Raises InvalidArgumentError naming cell_size when it is not in (0, 0.01] m or when the
        grid would need more than :data:`scenes.sdf.MAX_GRID_BYTES` to build.
        """
        key = (check_cell_size(cell_size), bool(exact))
        grid = self._grids.get(key)
        if grid is None:
            grid = SignedDistanceField.from_obstacles(self._obstacles, self._bounds, key[0], key[1])
            self._grids[key] = grid
        return grid

    def distance_query(self, cell_size: float | None = None, *, grid: bool = False,
                       exact: bool = False) -> DistanceQuery:
        """The signed-distance query a planner should use: points (...,3) [m] ->
        (distance (...,) [m], gradient (...,3)).

        :meth:`query` (exact, no grid) when every obstacle is a primitive (:attr:`analytic`)
        and ``grid`` is False; otherwise the ``query`` of the cached grid :meth:`sdf` with
        ``cell_size`` (default 0.01 m) and ``exact``. ``cell_size`` is validated even when no
        grid is needed.
        """
        cell_size = DEFAULT_CELL_SIZE if cell_size is None else check_cell_size(cell_size)
        if self.analytic and not grid:
            return self.query
        return self.sdf(cell_size, exact).query

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        return {"bounds": self._bounds.tolist(), "obstacles": [ob.to_dict() for ob in self._obstacles]}

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
        path = as_path(path, "path", ArgumentTypeError)
        if path.is_dir():
            raise SceneFileError(f"{path}: is a directory, expected a scene JSON file")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except OSError as exc:
            raise SceneFileError(f"{path}: cannot read scene file ({exc})") from None
        except UnicodeDecodeError as exc:
            raise SceneFileError(f"{path}: not UTF-8 text, expected a JSON scene file ({exc})") from None
        except (json.JSONDecodeError, RecursionError) as exc:
            raise SceneFileError(f"{path}: not valid JSON ({exc})") from None
        return cls.from_dict(data, source=str(path))

    def save(self, path: str | Path, overwrite: bool = True) -> None:
        """Write this scene as JSON, atomically (OutputPathError if the file exists and not
        ``overwrite``)."""
        atomic_write_text(as_path(path, "path", ArgumentTypeError), json.dumps(self.to_dict(), indent=2) + "\n", overwrite=overwrite)

    def __repr__(self) -> str:
        return f"Scene(obstacles={list(self._obstacles)!r}, bounds={self._bounds.tolist()})"


def available_scenes() -> tuple[str, ...]:
    """Names of the scene files shipped in scenes/data."""
    return tuple(sorted(p.stem for p in _DATA.glob("*.json")))


def builtin_scene(name: str) -> Scene:
    """A scene shipped with the package (see :func:`available_scenes`), e.g. ``"box_closing"``."""
    as_instance(name, "name", str, "a scene name (str)", ArgumentTypeError)
    names = available_scenes()
    if name not in names:
        raise SceneFileError(f"scene name: unknown {name!r}; expected one of {list(names)}")
    return Scene.load(_DATA / f"{name}.json")
