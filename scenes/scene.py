"""A scene: obstacles plus the workspace bounds over which signed distance fields are built.

Scene files are JSON::

    {"bounds": [[xmin, ymin, zmin], [xmax, ymax, zmax]],      # optional
     "obstacles": [{"type": "box", "center": [..], "size": [..], "rotation": [[..]x3]},
                   {"type": "box", "reference": [cx, cy, cz, sx, sy, sz]},
                   {"type": "sphere", "center": [..], "radius": r},
                   {"type": "cylinder", "center": [..], "radius": r, "height": h, "axis": [..]},
                   {"type": "capsule", "center": [..], "radius": r, "height": h, "axis": [..]},
                   {"type": "mesh", "vertices": [[x, y, z], ..], "faces": [[i, j, k], ..]},
                   {"type": "point_cloud", "points": [[x, y, z], ..], "radius": r or [r, ..]},
                   {"type": "mesh", "file": "table.npz"},
                   {"type": "depth_image", "file": "camera.png", "intrinsics": {"fx": .., "fy": ..,
                    "cx": .., "cy": ..}, "camera_pose": [[..]x4], "depth_scale": 0.001,
                    "roi": [[..], [..]], "voxel": 0.01, "radius": 0.01}]}

``rotation`` and ``axis`` are optional (default: axis aligned, +z); a capsule's ``height`` is the
length of its segment (overall length height + 2 radius). A mesh or point cloud gives its arrays
inline or in an ``.npz`` file beside the scene file (``"file"``, holding exactly the array
fields: ``vertices`` and ``faces``, or ``points`` and ``radius``); inline arrays are converted in
one vectorised step, an .npz is read as is (the fastest for clouds of millions of points).
A ``depth_image`` (a ``.npy`` or 16-bit ``.png`` file beside the scene file, with its camera's
intrinsics and pose and the optional depth_scale, roi, voxel and radius of
:meth:`PointCloud.from_depth`) becomes that point cloud when the scene is read (the arm's own
points are not removed there: that needs the robot's configuration, :meth:`PointCloud.from_depth`).

A Scene is immutable: ``obstacles`` is a tuple of immutable obstacles and ``bounds`` a read-only
array, both read-only properties. That is what lets a scene cache the grid fields it builds
(:meth:`Scene.sdf`): to change a scene, make a new one.
"""
from __future__ import annotations

import functools
import json
import math
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from skillplan.command_line import atomic_write, atomic_write_text
from .errors import (ScenesTypeError, InvalidArgumentError, InvalidObstacleError, OutputPathError,
                     SceneFileError)
from .depth import DEPTH_RADIUS, depth_entry_points
from .mesh import TriangleMesh
from .nearest import Nearest
from .obstacles import OBSTACLE_TYPES, Obstacle, as_coords, obstacle_from_dict
from .point_cloud import PointCloud
from .sdf import DEFAULT_CELL_SIZE, SignedDistanceField, check_cell_size
from skillplan.validation import (MAX_COORDINATE, as_bounds, as_instance, as_path, as_scalar, as_sequence,
                                 unknown_names)

#: query(points (..., 3)) -> (signed distance (...,) [m], gradient (..., 3))
DistanceQuery = Callable[[Any], tuple[np.ndarray, np.ndarray]]

#: Default workspace (2,3), metres: a box around a table-top arm with its base at the origin
#: (z up), |x|, |y| <= 0.75 and -0.1 <= z <= 0.7 (1.8 m^3).
DEFAULT_WORKSPACE = np.array([[-0.75, -0.75, -0.1], [0.75, 0.75, 0.7]])
#: Margin (m) kept around obstacles that stick out of the default workspace.
OBSTACLE_MARGIN = 0.1

_DATA = Path(__file__).resolve().parent / "data"
#: a scene file's obstacle made from a depth image (scenes.depth), read as a PointCloud
DEPTH_IMAGE = "depth_image"


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
                                      "Sphere, Cylinder, Capsule) or one obstacle", ScenesTypeError))
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

    def query(self, points: Any, max_distance: float = math.inf, *, gradient: bool = True
              ) -> tuple[np.ndarray, np.ndarray | None]:
        """Exact signed distance (...,) [m] and its gradient (...,3) at points (...,3) [m]
        (``gradient=False``: None instead, the same distances at a fraction of the cost).

        The distance is the min over obstacles (negative inside); the gradient is the unit
        gradient of the nearest obstacle (the first one listed on ties; see
        :mod:`scenes.obstacles` for the subgradient at non-differentiable points). Without
        obstacles: +inf with zero gradient. ``max_distance`` [m] clips: the result is
        ``min(d, max_distance)`` with a zero gradient where d > max_distance, and only the
        obstacles within max_distance of a point are evaluated there (a spatial index,
        :mod:`scenes.nearest`): a planner whose hinge reaches max_distance pays only for the
        obstacles near the arm. Points are validated once (InvalidArgumentError naming
        ``points`` or ``max_distance``).
        """
        coords, lead = as_coords(points)
        d, g = self._nearest(coords, bool(gradient), _max_distance(max_distance))
        return d.reshape(lead), None if g is None else g.reshape(*lead, 3)

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
                       exact: bool = False, max_distance: float = math.inf) -> DistanceQuery:
        """The signed-distance query a planner should use: points (...,3) [m] ->
        (distance (...,) [m], gradient (...,3)).

        :meth:`query` (exact, no grid) when every obstacle is a primitive (:attr:`analytic`)
        and ``grid`` is False, clipped at ``max_distance`` [m] (see :meth:`query`: a planner
        passes the reach of its hinge, so only the obstacles near the arm cost anything);
        otherwise the ``query`` of the cached grid :meth:`sdf` with ``cell_size`` (default
        0.01 m) and ``exact`` (a grid query costs the same for any scene; it is not clipped).
        ``cell_size`` and ``max_distance`` are validated even when not used.
        """
        cell_size = DEFAULT_CELL_SIZE if cell_size is None else check_cell_size(cell_size)
        max_distance = _max_distance(max_distance)
        if self.analytic and not grid:
            if max_distance == math.inf:
                return self.query
            return functools.partial(self.query, max_distance=max_distance)
        return self.sdf(cell_size, exact).query

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (every array inline)."""
        return {"bounds": self._bounds.tolist(), "obstacles": [ob.to_dict() for ob in self._obstacles]}

    @classmethod
    def from_dict(cls, data: Any, source: str = "scene", folder: str | Path | None = None) -> "Scene":
        """Scene from a dict as in a scene file; SceneFileError names the bad field. ``folder``:
        where the ``.npz`` files that array obstacles name are read (default: the working
        directory)."""
        if not isinstance(data, dict):
            raise SceneFileError(f"{source}: expected a JSON object with 'obstacles', got {type(data).__name__}")
        extra = data.keys() - {"bounds", "obstacles", "name", "description"}
        if extra:
            raise SceneFileError(f"{source}: unknown field(s) "
                                 f"{unknown_names(extra, ('bounds', 'obstacles', 'name', 'description'))}; "
                                 "expected 'obstacles', 'bounds' (and optional 'name', 'description')")
        raw = data.get("obstacles", [])
        if not isinstance(raw, list):
            raise SceneFileError(f"{source}: field 'obstacles' must be a list, got {type(raw).__name__}")
        folder = Path(".") if folder is None else as_path(folder, "folder", ScenesTypeError)
        obstacles = []
        for i, item in enumerate(raw):
            where = f"obstacles[{i}]"
            try:
                kind = item.get("type") if isinstance(item, dict) else None
                if isinstance(kind, str) and kind in ARRAY_OBSTACLES:
                    obstacles.append(_array_obstacle(item, where, folder))
                elif kind == DEPTH_IMAGE:
                    obstacles.append(_depth_obstacle(item, where, folder))
                elif isinstance(kind, str) and kind not in OBSTACLE_TYPES:
                    raise InvalidObstacleError(f"{where}.type: expected one of "
                                               f"{sorted([*OBSTACLE_TYPES, *ARRAY_OBSTACLES, DEPTH_IMAGE])}, got {kind!r}")
                else:
                    obstacles.append(obstacle_from_dict(item, where=where))
            except InvalidObstacleError as exc:
                raise SceneFileError(f"{source}: {exc}") from None
        bounds = data.get("bounds")
        try:
            return cls(obstacles, bounds)
        except InvalidArgumentError as exc:
            raise SceneFileError(f"{source}: {exc}") from None

    @classmethod
    def load(cls, path: str | Path) -> "Scene":
        """Read a JSON scene file (and the .npz files it names, beside it); SceneFileError on
        unreadable or malformed content."""
        path = as_path(path, "path", ScenesTypeError)
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
        return cls.from_dict(data, source=str(path), folder=path.parent)

    def save(self, path: str | Path, overwrite: bool = True, arrays: str = "inline") -> None:
        """Write this scene as JSON, atomically (OutputPathError if a file exists and not
        ``overwrite``). ``arrays``: "inline" (every array in the JSON) or "npz": each mesh /
        point cloud's arrays go to ``<stem>.obstacle<i>.npz`` beside the JSON, which names it
        (``{"type": "mesh", "file": ...}``; written first, so the JSON never names a missing
        file). A scene with inline arrays is written unindented (a cloud's points would take
        a line per number)."""
        path = as_path(path, "path", ScenesTypeError)
        if arrays not in ("inline", "npz"):
            raise InvalidArgumentError(f"arrays: expected 'inline' or 'npz', got {arrays!r}")
        sidecars = {i: path.with_name(f"{path.stem}.obstacle{i}.npz") for i, ob in enumerate(self._obstacles)
                    if arrays == "npz" and ob.kind in ARRAY_OBSTACLES}
        for target in [path, *sidecars.values()]:   # refuse before writing anything
            if not overwrite and target.exists():
                raise OutputPathError(f"path: {str(target)!r} already exists; pass overwrite=True to replace it")
        entries = []
        for i, ob in enumerate(self._obstacles):
            if i in sidecars:
                sidecar = sidecars[i]
                atomic_write(sidecar, functools.partial(_write_npz, ob.arrays()), overwrite=overwrite)
                entries.append({"type": ob.kind, "file": sidecar.name})
            else:
                entries.append(ob.to_dict())
        text = json.dumps({"bounds": self._bounds.tolist(), "obstacles": entries},
                          indent=None if arrays == "inline" and _large(self) else 2)
        atomic_write_text(path, text + "\n", overwrite=overwrite)

    def __repr__(self) -> str:
        return f"Scene(obstacles={list(self._obstacles)!r}, bounds={self._bounds.tolist()})"


#: Obstacles made of arrays: kind -> (class, the array fields; in a scene file inline or in an
#: .npz file named by ``"file"``).
ARRAY_OBSTACLES: dict[str, tuple[type[Obstacle], tuple[str, ...]]] = {
    "mesh": (TriangleMesh, ("vertices", "faces")),
    "point_cloud": (PointCloud, ("points", "radius")),
}


def _as_numbers(value: Any, name: str) -> Any:
    """A JSON array as a numpy array (one vectorised conversion: a large cloud's nested lists
    would take seconds element by element); anything else as is (the constructor names it)."""
    if isinstance(value, list):
        try:
            arr = np.array(value)
        except ValueError:                        # ragged
            raise InvalidObstacleError(f"{name}: expected a regular (rectangular) array of numbers") from None
        if arr.dtype.kind not in "iuf":
            raise InvalidObstacleError(f"{name}: expected an array of numbers, got {arr.dtype.kind!r} "
                                       f"values ({str(arr.reshape(-1)[:3].tolist())[:60]})")
        return arr
    return value


def _array_obstacle(item: dict, where: str, folder: Path) -> Obstacle:
    """A mesh / point cloud from its scene-file entry: the array fields inline, or ``"file"``:
    an .npz (relative to ``folder``) holding exactly them."""
    kind = item["type"]
    cls, names = ARRAY_OBSTACLES[kind]
    fields = {k: v for k, v in item.items() if k != "type"}
    if "file" in fields:
        if len(fields) != 1:
            raise InvalidObstacleError(f"{where}: a {kind} with 'file' takes no other fields, got {sorted(fields)}")
        name = fields["file"]
        if not isinstance(name, str) or not name:
            raise InvalidObstacleError(f"{where}.file: expected the name of an .npz file, got {name!r:.60}")
        npz = folder / name
        try:
            with np.load(npz, allow_pickle=False) as data:
                fields = {k: data[k] for k in data.files}
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise InvalidObstacleError(f"{where}.file: cannot read {str(npz)!r} as an .npz file ({exc})") from None
        where = f"{where} ({npz.name})"
    if fields.keys() != set(names):
        raise InvalidObstacleError(f"{where}: a {kind} expects the fields {list(names)} (or 'file'), "
                                   f"got {sorted(fields)}")
    try:
        return cls(**{k: _as_numbers(fields[k], f"{cls.__name__} {k}") for k in names})
    except InvalidObstacleError as exc:
        raise InvalidObstacleError(f"{where}: {exc}") from None


def _depth_obstacle(item: dict, where: str, folder: Path) -> PointCloud:
    """The point cloud of a depth image entry (scenes.depth: file relative to ``folder``)."""
    try:
        points, radius = depth_entry_points(item, where, folder)
    except InvalidArgumentError as exc:
        raise InvalidObstacleError(str(exc)) from None
    radius = DEPTH_RADIUS if radius is None else _as_numbers(radius, f"{where}.radius")
    try:
        return PointCloud(points, radius)
    except InvalidObstacleError as exc:
        raise InvalidObstacleError(f"{where}: {exc}") from None


def _write_npz(arrays: dict[str, np.ndarray], handle: Any) -> None:
    np.savez(handle, **arrays)


def _large(scene: Scene) -> bool:
    """Whether the scene holds array obstacles (then its inline JSON is written unindented)."""
    return any(ob.kind in ARRAY_OBSTACLES for ob in scene.obstacles)


def _max_distance(value: Any) -> float:
    """max_distance [m]: a positive number or +inf (InvalidArgumentError naming it)."""
    if isinstance(value, float) and value == math.inf:
        return value
    return as_scalar(value, "max_distance", strictly_positive=True)


def available_scenes() -> tuple[str, ...]:
    """Names of the scene files shipped in scenes/data."""
    return tuple(sorted(p.stem for p in _DATA.glob("*.json")))


def builtin_scene(name: str) -> Scene:
    """A scene shipped with the package (see :func:`available_scenes`), e.g. ``"box_closing"``."""
    as_instance(name, "name", str, "a scene name (str)", ScenesTypeError)
    names = available_scenes()
    if name not in names:
        raise SceneFileError(f"scene name: unknown {name!r}; expected one of {list(names)}")
    return Scene.load(_DATA / f"{name}.json")
