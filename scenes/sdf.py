"""Signed distance field sampled on a regular grid, with trilinear interpolation.

Grid nodes sit at ``origin + index * cell_size`` (index (i, j, k), shape ``values.shape``).
Values are signed distances in metres, negative inside obstacles.

Queries outside the grid box use the value at the nearest point of the box plus the distance
to the box; the gradient is the exact gradient of that function (the interpolant's gradient
along the axes that were not clamped, plus the unit vector pointing out of the box), so it is
finite everywhere and points away from the grid. An empty scene gives +inf values with zero
gradient.

Build one with :meth:`SignedDistanceField.from_obstacles` (obstacles, bounds, cell size) or, cached
per scene, :meth:`scenes.Scene.sdf`. This module depends on :mod:`scenes.obstacles` only (not on
:mod:`scenes.scene`). Scenes of primitive obstacles need no grid: :meth:`scenes.Scene.query` is
exact and, for a few obstacles, faster to query than a grid is to build.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .errors import InvalidArgumentError, InvalidObstacleError
from .obstacles import Obstacle
from skillplan.validation import as_bounds, as_points, as_positive

#: Largest allowed (and default) cell size in metres.
DEFAULT_CELL_SIZE = 0.01
#: Largest memory (bytes) a grid build may need; see :meth:`SignedDistanceField.from_obstacles`.
MAX_GRID_BYTES = 2 * 1024**3
#: Peak memory of a build per grid node (bytes), keyed by ``exact``; measured with tracemalloc
#: on the default workspace at 1 cm (1.8 M nodes: 50 and 16 B), rounded up. The EDT mode holds
#: the occupancy, scipy's feature transform (3 x int32 and temporaries) and the float64 result;
#: the exact mode the float64 values plus fixed-size blocks of node coordinates.
BUILD_BYTES_PER_NODE = {False: 56, True: 16}
#: Nodes evaluated per block in the exact mode (bounds the temporaries to a few MB).
_BLOCK_NODES = 200_000


def check_cell_size(cell_size: Any) -> float:
    """cell_size [m] as a float in (0, DEFAULT_CELL_SIZE]; InvalidArgumentError naming it."""
    h = as_positive(cell_size, "cell_size")
    if h > DEFAULT_CELL_SIZE + 1e-12:
        raise InvalidArgumentError(f"cell_size: expected at most {DEFAULT_CELL_SIZE} m, got {cell_size}")
    return h


def grid_shape(bounds: np.ndarray, cell_size: float) -> tuple[int, int, int]:
    """Nodes per axis of a grid starting at bounds[0] (2,3) [m] with spacing cell_size [m]
    that covers bounds[1]."""
    return tuple(int(n) for n in np.ceil((bounds[1] - bounds[0]) / cell_size - 1e-9).astype(int) + 1)


def _node_coordinates(origin: np.ndarray, cell_size: float, shape: Sequence[int],
                      block: tuple[slice, slice, slice]) -> np.ndarray:
    """Coordinates (3, bx*by*bz) [m] of the nodes in a block of index slices, C order."""
    axes = [origin[a] + np.arange(n)[block[a]] * cell_size for a, n in enumerate(shape)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=0).reshape(3, -1)


class SignedDistanceField:
    """Signed distance values (nx,ny,nz) on a grid with corner ``origin`` (3,) and isotropic ``cell_size`` (m)."""

    def __init__(self, values: Any, origin: Any, cell_size: float):
        values = np.ascontiguousarray(values, dtype=float)
        if values.ndim != 3 or min(values.shape) < 2:
            raise InvalidArgumentError(f"values: expected a 3-D grid with >= 2 nodes per axis, got shape {values.shape}")
        if np.any(np.isnan(values)):
            raise InvalidArgumentError("values: contains NaN")
        self.values = values
        self.origin = as_points(origin, "origin").reshape(3)
        self.cell_size = as_positive(cell_size, "cell_size")
        self._empty = bool(np.all(np.isposinf(values)))
        _, ny, nz = values.shape  # flat offsets of a cell's 8 corners, (x, y, z) bits
        self._corner_offsets = np.array([(a * ny + b) * nz + c
                                         for a in (0, 1) for b in (0, 1) for c in (0, 1)])

    @property
    def shape(self) -> tuple[int, int, int]:
        """Number of grid nodes per axis."""
        return self.values.shape  # type: ignore[return-value]

    @property
    def bounds(self) -> np.ndarray:
        """(2,3) box spanned by the grid nodes."""
        return np.stack([self.origin, self.origin + (np.array(self.shape) - 1) * self.cell_size])

    def grid_points(self) -> np.ndarray:
        """Coordinates (nx,ny,nz,3) [m] of every grid node."""
        return np.moveaxis(_node_coordinates(self.origin, self.cell_size, self.shape,
                                             (slice(None),) * 3).reshape(3, *self.shape), 0, -1)

    @staticmethod
    def estimate_build_bytes(bounds: Any, cell_size: float = DEFAULT_CELL_SIZE,
                             exact: bool = False) -> tuple[tuple[int, int, int], int]:
        """Grid shape (nodes per axis) and estimated peak memory (bytes) of
        :meth:`from_obstacles` over bounds (2,3) [m] at cell_size [m]; nothing is allocated."""
        h = as_positive(cell_size, "cell_size")
        shape = grid_shape(as_bounds(bounds, "bounds"), h)
        return shape, math.prod(shape) * BUILD_BYTES_PER_NODE[bool(exact)]

    @classmethod
    def from_obstacles(cls, obstacles: Sequence[Obstacle], bounds: Any,
                       cell_size: float = DEFAULT_CELL_SIZE, exact: bool = False,
                       max_bytes: int = MAX_GRID_BYTES) -> "SignedDistanceField":
        """Sample the signed distance of ``obstacles`` (min over them) on a grid covering
        ``bounds`` (2,3) [m].

        cell_size (m, at most 0.01; default 0.01) is the node spacing; the grid starts at
        bounds[0] and extends to cover bounds[1]. ``exact=False`` rasterises obstacle
        occupancy at the nodes (exact distance tests on each obstacle's bounding block) and
        takes Euclidean distance transforms outside and inside, shifted by half a cell so the
        zero crossing lies between occupied and free nodes (error about half a cell);
        ``exact=True`` evaluates the analytic distance at every node (cost grows with the number
        of obstacles). An obstacle too thin to contain a node marks the node nearest its centre;
        when no node is occupied (obstacles outside the bounds) the exact mode is used.

        Before allocating anything the peak memory is estimated
        (:meth:`estimate_build_bytes`); above ``max_bytes`` (default 2 GiB) an
        InvalidArgumentError names cell_size, the bounds, the grid shape and the estimate.
        The returned field's values are read-only (a scene caches and shares it).

        Accuracy at 1 cm (tests/scenes/test_sdf.py): both modes stay within one cell of the analytic
        distance inside the grid; near curved surfaces the EDT mode's staircase tilts the
        gradient by up to ~25 degrees (mean ~6 degrees at 3-10 cm), the exact mode by < 5.
        """
        obstacles = tuple(obstacles)
        for i, ob in enumerate(obstacles):
            if not isinstance(ob, Obstacle):
                raise InvalidObstacleError(f"obstacles[{i}]: expected a scenes Obstacle (Box, Sphere, "
                                           f"Cylinder, Capsule), got {type(ob).__name__}")
        h = check_cell_size(cell_size)
        bounds = as_bounds(bounds, "bounds")
        shape, need = cls.estimate_build_bytes(bounds, h, exact)
        if need > max_bytes:
            raise InvalidArgumentError(
                f"cell_size: {h} m over bounds {bounds.tolist()} gives a grid of {shape} = "
                f"{math.prod(shape):,} nodes ({math.prod(shape) * 8 / 2**30:.2f} GiB of values, about "
                f"{need / 2**30:.2f} GiB to build with exact={bool(exact)}); expected at most "
                f"{max_bytes / 2**30:.2f} GiB: shrink the bounds (cell_size is at most "
                f"{DEFAULT_CELL_SIZE} m) or use the scene's analytic query")
        lo = bounds[0]
        if not obstacles:
            return cls._frozen(np.full(shape, np.inf), lo, h)
        occupied = None if exact else _rasterise(obstacles, lo, h, shape)
        if occupied is None or not occupied.any() or occupied.all():
            # exact mode, or every obstacle outside the grid (or filling it): nothing for a
            # transform to measure from, so sample the analytic distance at every node
            values = np.empty(shape)
            flat = values.reshape(-1)
            from .nearest import Nearest    # deferred: SciPy's k-d tree loads when needed
            nearest = Nearest(obstacles)
            rows = max(1, _BLOCK_NODES // (shape[1] * shape[2]))
            for start in range(0, shape[0], rows):
                stop = min(start + rows, shape[0])
                block = (slice(start, stop), slice(None), slice(None))
                coords = _node_coordinates(lo, h, shape, block)
                flat[start * shape[1] * shape[2]:stop * shape[1] * shape[2]] = \
                    nearest(coords, False)[0]
            return cls._frozen(values, lo, h)
        from scipy.ndimage import distance_transform_edt   # deferred: SciPy loads when a field is built
        values = distance_transform_edt(~occupied, sampling=h)
        values -= 0.5 * h
        block, inside = _inside_distance(occupied, h)
        sub = values[block]
        sub[occupied[block]] = 0.5 * h - inside[occupied[block]]
        return cls._frozen(values, lo, h)

    @classmethod
    def _frozen(cls, values: np.ndarray, origin: np.ndarray, cell_size: float) -> "SignedDistanceField":
        """A field over values the caller gives up; they become read-only."""
        values.setflags(write=False)
        return cls(values, origin, cell_size)

    def query(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (...,) and its gradient (...,3) at points (...,3), trilinear.

        The gradient is the exact gradient of the trilinear interpolant (so it matches finite
        differences of the returned values). Outside the grid see the module docstring.
        """
        points = as_points(points, "points")
        lead = points.shape[:-1]
        if self._empty:
            return np.full(lead, np.inf), np.zeros(points.shape)
        flat = points.reshape(-1, 3)
        h = self.cell_size
        hi = self.bounds[1]
        # coordinate-major (3, P) and corner-major (8, P) layouts keep every operand contiguous
        clamped = np.clip(flat.T, self.origin[:, None], hi[:, None])
        u = (clamped - self.origin[:, None]) / h
        n = np.array(self.shape)
        i0 = np.clip(np.floor(u).astype(np.intp), 0, (n - 2)[:, None])
        fx, fy, fz = u - i0
        nx, ny, nz = self.shape
        base = (i0[0] * ny + i0[1]) * nz + i0[2]
        c000, c001, c010, c011, c100, c101, c110, c111 = \
            self.values.reshape(-1)[self._corner_offsets[:, None] + base[None, :]]
        # interpolate along z, then y, then x, keeping the differences for the gradient
        dz00, dz01, dz10, dz11 = c001 - c000, c011 - c010, c101 - c100, c111 - c110
        cz00, cz01 = c000 + fz * dz00, c010 + fz * dz01
        cz10, cz11 = c100 + fz * dz10, c110 + fz * dz11
        dy0, dy1 = cz01 - cz00, cz11 - cz10
        cy0, cy1 = cz00 + fy * dy0, cz10 + fy * dy1
        dx = cy1 - cy0
        value = cy0 + fx * dx
        dzy0, dzy1 = dz00 + fy * (dz01 - dz00), dz10 + fy * (dz11 - dz10)
        grad = np.empty((len(value), 3))
        grad[:, 0] = dx / h
        grad[:, 1] = (dy0 + fx * (dy1 - dy0)) / h
        grad[:, 2] = (dzy0 + fx * (dzy1 - dzy0)) / h
        offset = flat - clamped.T
        outside = np.any(offset != 0.0, axis=-1)
        if outside.any():
            grad[offset != 0.0] = 0.0
            dist = np.linalg.norm(offset[outside], axis=-1)
            value[outside] += dist
            grad[outside] += offset[outside] / dist[:, None]
        return value.reshape(lead), grad.reshape(*lead, 3)

    def distance(self, points: Any) -> np.ndarray:
        """Interpolated signed distance (...,) only; see :meth:`query`."""
        return self.query(points)[0]

    def save_npz(self, path: Any) -> None:
        """Write values, origin and cell_size to an .npz file."""
        np.savez_compressed(path, values=self.values, origin=self.origin, cell_size=self.cell_size)

    @classmethod
    def load_npz(cls, path: Any) -> "SignedDistanceField":
        """Read a field written by :meth:`save_npz`."""
        with np.load(path) as data:
            return cls(data["values"], data["origin"], float(data["cell_size"]))


def _rasterise(obstacles: Sequence[Obstacle], origin: np.ndarray, h: float,
               shape: tuple[int, int, int]) -> np.ndarray:
    """Boolean (nx,ny,nz) occupancy of the nodes, tested per obstacle on its bounding block."""
    dims = np.array(shape)
    top = origin + (dims - 1) * h
    occupied = np.zeros(shape, dtype=bool)
    for ob in obstacles:
        box = ob.aabb()
        if np.any(box[1] < origin) or np.any(box[0] > top):
            continue
        first = np.clip(np.floor((box[0] - origin) / h).astype(int), 0, dims - 1)
        last = np.clip(np.ceil((box[1] - origin) / h).astype(int), 0, dims - 1)
        block = tuple(slice(first[a], last[a] + 1) for a in range(3))
        inside = (ob._evaluate(_node_coordinates(origin, h, shape, block), False)[0] <= 0.0
                  ).reshape(occupied[block].shape)
        centre = np.rint((0.5 * (box[0] + box[1]) - origin) / h).astype(int)
        if not inside.any() and np.all((centre >= 0) & (centre < dims)):
            occupied[tuple(centre)] = True
        occupied[block] |= inside
    return occupied


def _inside_distance(occupied: np.ndarray, h: float) -> tuple[tuple[slice, ...], np.ndarray]:
    """Distance (m) from each occupied node to the nearest free node, computed by an EDT on the
    bounding block of the occupied nodes (plus one layer); returns the block and its distances."""
    idx = np.nonzero(occupied.any(axis=(1, 2)))[0], np.nonzero(occupied.any(axis=(0, 2)))[0], \
        np.nonzero(occupied.any(axis=(0, 1)))[0]
    block = tuple(slice(max(i[0] - 1, 0), i[-1] + 2) for i in idx)
    # The block has a layer of free nodes on every side not at the grid border; beyond the
    # array nothing counts as free, so the nearest free node is always a real one.
    from scipy.ndimage import distance_transform_edt
    return block, distance_transform_edt(occupied[block], sampling=h)
