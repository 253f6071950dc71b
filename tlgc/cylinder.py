"""The generalized cylinder: directrix, Bishop frames and cross-section boundaries.

``fit_cylinder`` resamples M demonstrations to N points, takes the pointwise mean as the
directrix, builds rotation-minimising frames along it and expresses the k-th point of every
demonstration in frame k's normal plane (the effective points of section k, whose centroid is
the directrix point). The cross-section boundaries enclose those points (see cross_sections).

Containment of arbitrary points interpolates the sections linearly between consecutive frames
and asks which section plane passes through the point (see
:meth:`GeneralizedCylinder.containment`): the boundary test is inclusive (ratio <= 1 +
INSIDE_TOLERANCE), points beyond the end caps are outside, and every effective point is inside
its own section by construction.
"""
from __future__ import annotations

import zipfile
from dataclasses import dataclass
from functools import cached_property
from os import PathLike
from typing import Any, BinaryIO, Sequence

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial import cKDTree

from .cross_sections import CROSS_SECTION_TYPES, CrossSections, cross_section_type, polar
from .errors import (CylinderFileError, TLGCArgumentError, CylinderDemonstrationsError,
                     TooFewDemonstrationsError)
from .frames import bishop_frames, unit_tangents
from skillplan.threads import single_blas_thread
from .validation import as_array, as_count, as_file, as_path, as_points, as_trailing

MIN_DEMONSTRATIONS = 2
MIN_SPREAD = 1e-6          # [m] smallest spread of the demonstrations about the directrix accepted
                           # at the first section (and somewhere along the cylinder)
CONTAINMENT_WINDOW = 4     # sections either side of the nearest directrix point searched first
CONTAINMENT_BLOCK = 512    # points per block in the full search (block x N offsets at a time)
INSIDE_TOLERANCE = 1e-9    # inclusive boundary test: inside when ratio <= 1 + this (round-off)
RADIUS_SAMPLES = 64        # angles at which largest_radius samples every boundary


def resample_demonstrations(trajectories: Sequence[np.ndarray] | np.ndarray,
                            num_points: int) -> np.ndarray:
    """Resample each trajectory (T_m, 3) to ``num_points`` by a cubic spline over its index.

    Trajectories are parameterised uniformly in [0, 1] over their samples (time-aligned
    resampling, as in the paper). Returns (M, num_points, 3) [m].
    """
    num_points = as_count(num_points, "num_points", minimum=2, error=CylinderDemonstrationsError)
    out = np.empty((len(trajectories), num_points, 3))
    target = np.linspace(0.0, 1.0, num_points)
    for m, traj in enumerate(trajectories):      # one spline per demonstration, not per point
        x = np.asarray(traj, dtype=float)
        if len(x) == num_points:
            out[m] = x
        else:
            out[m] = CubicSpline(np.linspace(0.0, 1.0, len(x)), x, axis=0)(target)
    return out


def as_demonstration_array(demos: Any, num_points: int | None = None) -> np.ndarray:
    """Demonstrations as an (M, N, 3) float array [m].

    ``demos``: an (M, T, 3) array, a sequence of (T_m, 3) arrays, or an object with a
    ``positions`` (M, T, 3) attribute (scenes.Demonstrations). ``num_points`` N: resample to N
    points (default: keep T, or the longest T_m for unequal lengths).
    """
    source = getattr(demos, "positions", demos)
    if isinstance(source, np.ndarray) or not isinstance(source, (list, tuple)):
        arr = as_points(source, "demos", error=CylinderDemonstrationsError)
        if arr.ndim != 3:
            raise CylinderDemonstrationsError(f"demos: expected shape (M, T, 3), got {arr.shape}")
        trajectories: list[np.ndarray] = list(arr)
    else:
        trajectories = []
        for m, traj in enumerate(source):
            x = as_points(traj, f"demos[{m}]", error=CylinderDemonstrationsError)
            if x.ndim != 2:
                raise CylinderDemonstrationsError(f"demos[{m}]: expected shape (T, 3), got {x.shape}")
            trajectories.append(x)
    if len(trajectories) < MIN_DEMONSTRATIONS:
        raise TooFewDemonstrationsError(
            f"demos: a generalized cylinder needs at least {MIN_DEMONSTRATIONS} demonstrations, "
            f"got {len(trajectories)}")
    lengths = [len(x) for x in trajectories]
    if min(lengths) < 2:
        raise CylinderDemonstrationsError(
            f"demos: every demonstration needs at least 2 points, got lengths {lengths}")
    if num_points is None:
        num_points = max(lengths)
    return resample_demonstrations(trajectories, num_points)


@dataclass(frozen=True)
class Containment:
    """Where points (P,) lie relative to a cylinder (see :meth:`GeneralizedCylinder.containment`).

    section (P,): continuous section parameter s = k + lambda in [0, N-1] of the (interpolated)
    cross-section whose plane passes through the point; index (P,): the nearest whole section
    round(s); angle [rad] in that section's plane (from the normal towards the binormal);
    distance [m] from the section's centre within the plane; radius [m] of the (interpolated)
    boundary at that angle; ratio = distance / radius; offset [m]: 0 when the reported
    section's plane passes through the point, otherwise the signed distance beyond an end cap
    (negative before the first plane, positive past the last), with angle, distance, radius
    and ratio then taken in that end section's plane. A point is reported beyond a cap when no
    section plane passes through it, or when it is outside, its nearest directrix point is
    that end and it lies past that end's plane. ``section`` is None only for hand-built
    results.
    """

    index: np.ndarray
    angle: np.ndarray
    distance: np.ndarray
    radius: np.ndarray
    ratio: np.ndarray
    offset: np.ndarray
    section: np.ndarray | None = None

    @property
    def inside(self) -> np.ndarray:
        """Boolean (P,): a section plane passes through the point (offset 0) and the point is
        within its boundary, inclusive: ratio <= 1 + INSIDE_TOLERANCE."""
        return (self.offset == 0.0) & (self.ratio <= 1.0 + INSIDE_TOLERANCE)

    @property
    def beyond(self) -> np.ndarray:
        """Distance (P,) [m] beyond the nearer end cap (0 for points between the caps)."""
        return np.abs(self.offset)


@dataclass
class _Chosen:
    """Per-point evaluation in a chosen section (internal to containment)."""

    found: np.ndarray
    section: np.ndarray
    angle: np.ndarray
    distance: np.ndarray
    radius: np.ndarray
    ratio: np.ndarray

    @classmethod
    def empty(cls, count: int) -> "_Chosen":
        return cls(np.zeros(count, dtype=bool), *(np.full(count, np.nan) for _ in range(5)))

    @property
    def inside(self) -> np.ndarray:
        return self.found & (self.ratio <= 1.0 + INSIDE_TOLERANCE)

    def take(self, rows: np.ndarray) -> "_Chosen":
        return _Chosen(*(getattr(self, f)[rows] for f in self.__dataclass_fields__))

    def assign(self, rows: np.ndarray, other: "_Chosen") -> None:
        """Overwrite ``rows`` (R,) with the points of ``other`` (R,) that were found."""
        use = other.found
        for name in self.__dataclass_fields__:
            getattr(self, name)[rows[use]] = getattr(other, name)[use]

    def containment(self, offset: np.ndarray) -> Containment:
        index = np.rint(self.section).astype(np.intp)
        return Containment(index=index, angle=self.angle, distance=self.distance,
                           radius=self.radius, ratio=self.ratio, offset=offset,
                           section=self.section)


class GeneralizedCylinder:
    """Directrix (N,3) [m], frames (N,3,3) rows [tangent, normal, binormal], cross-sections.

    ``effective_points`` (M, N, 2) [m] and ``demonstrations`` (M, N, 3) [m] are kept when known
    (fitted cylinders) and may be None for cylinders built from a bare boundary.
    """

    def __init__(self, directrix: np.ndarray, frames: np.ndarray, cross_sections: CrossSections,
                 effective_points: np.ndarray | None = None,
                 demonstrations: np.ndarray | None = None) -> None:
        self.directrix = as_points(directrix, "directrix")
        n = len(self.directrix)
        if self.directrix.shape != (n, 3) or n < 2:
            raise TLGCArgumentError(f"directrix: expected shape (N, 3), N >= 2, got {self.directrix.shape}")
        self.frames = as_array(frames, "frames")
        if self.frames.shape != (n, 3, 3):
            raise TLGCArgumentError(f"frames: expected shape ({n}, 3, 3), got {self.frames.shape}")
        if not isinstance(cross_sections, CrossSections) or cross_sections.num_sections != n:
            raise TLGCArgumentError(
                f"cross_sections: expected a CrossSections object with {n} sections")
        self.cross_sections = cross_sections
        self.effective_points = None if effective_points is None else as_array(effective_points, "effective_points")
        if self.effective_points is not None and self.effective_points.shape[1:] != (n, 2):
            raise TLGCArgumentError(
                f"effective_points: expected shape (M, {n}, 2), got {self.effective_points.shape}")
        self.demonstrations = None if demonstrations is None else as_points(demonstrations, "demonstrations")
        if self.demonstrations is not None and self.demonstrations.shape[1:] != (n, 3):
            raise TLGCArgumentError(
                f"demonstrations: expected shape (M, {n}, 3), got {self.demonstrations.shape}")

    # ------------------------------------------------------------------ basic geometry
    @property
    def num_sections(self) -> int:
        """Number N of cross-sections (= directrix points)."""
        return len(self.directrix)

    @property
    def cross_section(self) -> str:
        """Cross-section type name ("circle", "ellipse" or "spline")."""
        return self.cross_sections.kind

    @property
    def tangents(self) -> np.ndarray:
        """Unit tangents (N, 3)."""
        return self.frames[:, 0]

    @property
    def normals(self) -> np.ndarray:
        """Unit normals (N, 3) (angle 0 of every section)."""
        return self.frames[:, 1]

    @property
    def binormals(self) -> np.ndarray:
        """Unit binormals (N, 3) (angle pi/2 of every section)."""
        return self.frames[:, 2]

    @cached_property
    def arc_length(self) -> np.ndarray:
        """Normalised arc length u (N,) of the directrix, 0 at the start and 1 at the end."""
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.directrix, axis=0), axis=1))])
        return s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(s))

    def radius(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Boundary radius [m] of sections ``index`` (...) at ``angle`` (...) [rad], broadcast."""
        return self.cross_sections.radius(index, as_array(angle, "angle"))

    def largest_radius(self, indices: np.ndarray | None = None) -> np.ndarray:
        """Largest boundary radius (K,) [m] of sections ``indices`` (K,) (default all N),
        sampled at RADIUS_SAMPLES equally spaced angles (exact for circles)."""
        if indices is None:
            return self._largest_radii.copy()
        return self._largest_radii[self.cross_sections.check_index(np.atleast_1d(indices))]

    @cached_property
    def _largest_radii(self) -> np.ndarray:
        angles = np.linspace(0.0, 2.0 * np.pi, RADIUS_SAMPLES, endpoint=False)
        return self.radius(np.arange(self.num_sections)[:, None], angles[None, :]).max(axis=1)

    def radius_derivative(self, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """Slope d radius / d angle [m/rad] of sections ``index`` (...) at ``angle`` (...) [rad]."""
        return self.cross_sections.radius_derivative(index, as_array(angle, "angle"))

    # ------------------------------------------------------------------ coordinates
    def to_local(self, points: np.ndarray, index: np.ndarray) -> np.ndarray:
        """In-plane coordinates (..., 2) [m] of points (..., 3) in sections ``index`` (...)."""
        idx = self.cross_sections.check_index(index)
        d = as_points(points, "points") - self.directrix[idx]
        return np.stack([np.einsum("...i,...i->...", d, self.normals[idx]),
                         np.einsum("...i,...i->...", d, self.binormals[idx])], axis=-1)

    def to_world(self, local: np.ndarray, index: np.ndarray) -> np.ndarray:
        """World points (..., 3) [m] of in-plane coordinates (..., 2) in sections ``index`` (...)."""
        idx = self.cross_sections.check_index(index)
        q = as_trailing(local, "local", (2,))
        return (self.directrix[idx] + q[..., :1] * self.normals[idx]
                + q[..., 1:2] * self.binormals[idx])

    def ratio(self, points: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Ratio (...) of points (..., 3) to the boundary of their given sections ``index`` (...).

        The point is projected onto the section's plane; <= 1 means inside.
        """
        return self.cross_sections.ratio(index, self.to_local(points, index))

    def plane_offset(self, points: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Signed distance (...) [m] of points (..., 3) from the planes of sections ``index``
        (...), positive along the section's tangent."""
        idx = self.cross_sections.check_index(index)
        return self._plane_offsets(as_points(points, "points"), idx)

    def containment(self, points: np.ndarray) -> Containment:
        """Section, angle and boundary ratio of many points (P, 3) at once (see Containment).

        Geometry: between frames k and k+1 the section is interpolated linearly in
        lambda in [0, 1]: plane offset, in-plane coordinates and boundary radius at a given
        angle are (1 - lambda) times those of section k plus lambda times those of section
        k+1. The plane of section s = k + lambda passes through a point where its interpolated
        plane offset vanishes, lambda = f_k / (f_k - f_{k+1}) with f_k = t_k . (p - c_k); a
        point on a frame's own plane (|f_k| <= round-off) belongs to that frame exactly, so
        every effective point and every reproduced point is evaluated in its own section.

        Choice: a point is inside when some section plane through it holds it within the
        boundary, inclusive (ratio <= 1 + INSIDE_TOLERANCE). Among the sections through the
        point, one holding it inside wins, then the one nearest (in section index) to the
        point's nearest directrix point, then the smaller ratio. A point that no section plane
        passes through lies beyond an end cap: it is outside, ``offset`` says how far beyond.
        The search looks at the sections around the nearest directrix point first (KD-tree)
        and scans all N sections only for points not found inside there; both give the same
        answer because any section outside the window is farther in index than any inside it.
        """
        p = as_points(points, "points")
        if p.ndim != 2:
            raise TLGCArgumentError(f"points: expected shape (P, 3), got {p.shape}")
        with single_blas_thread():
            return self._containment(p)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Boolean (P,): whether points (P, 3) lie inside the cylinder (see :meth:`containment`)."""
        return self.containment(points).inside

    def _containment(self, p: np.ndarray) -> Containment:
        """:meth:`containment` of checked points (P, 3)."""
        n, count = self.num_sections, len(p)
        result = _Chosen.empty(count)
        if count == 0:
            return result.containment(np.zeros(0))
        nearest = self._tree.query(p)[1]
        width = min(2 * CONTAINMENT_WINDOW + 1, n)
        first = np.clip(nearest - CONTAINMENT_WINDOW, 0, n - width)
        window = first[:, None] + np.arange(width)                                   # (P, W)
        t = self._tangent_matrix                                                     # (3, N)
        offsets = -self._plane_constants[window]
        for i in range(3):                    # t_k . p - t_k . c_k, no (P, W, 3) temporary
            offsets += p[:, i, None] * t[i][window]
        found = self._choose(p, window, offsets, nearest)
        result.assign(np.arange(count), found)
        offset = np.zeros(count)
        rest = np.flatnonzero(~result.inside)
        sections = np.arange(n)
        for block in range(0, len(rest), CONTAINMENT_BLOCK):
            rows = rest[block:block + CONTAINMENT_BLOCK]
            offsets = p[rows] @ self._tangent_matrix
            offsets -= self._plane_constants                                          # (B, N)
            found = self._choose(p[rows], sections, offsets, nearest[rows])
            result.assign(rows, found)
            # Beyond an end cap: no plane passes through the point (all offsets share one
            # sign), or it is outside, nearest to an end point and past that end's plane.
            tol = self._plane_tolerance
            before = (offsets[:, 0] < -tol) & (~found.found | (nearest[rows] == 0))
            after = (offsets[:, -1] > tol) & (~found.found | (nearest[rows] == n - 1))
            cap = (before | after) & ~found.inside          # (never both: N >= 2)
            if cap.any():
                beyond = rows[cap]
                end = np.where(after[cap], n - 1, 0)
                offset[beyond] = np.where(after[cap], offsets[cap, -1], offsets[cap, 0])
                result.assign(beyond, self._evaluate(p[beyond], end, np.zeros(len(beyond))))
        return result.containment(offset)

    def _evaluate(self, q: np.ndarray, k: np.ndarray, lam: np.ndarray) -> "_Chosen":
        """Points q (C, 3) in interpolated sections s = k + lam (C,), lam in [0, 1]."""
        k1 = np.minimum(k + 1, self.num_sections - 1)
        w0 = 1.0 - lam
        here, there = self.frames[k], self.frames[k1]                               # (C, 3, 3)
        local = (w0[:, None] * np.einsum("cji,ci->cj", here[:, 1:], q - self.directrix[k])
                 + lam[:, None] * np.einsum("cji,ci->cj", there[:, 1:], q - self.directrix[k1]))
        distance, angle = polar(local)                         # interpolated (a, b) (C, 2)
        radius = w0 * self.radius(k, angle) + lam * self.radius(k1, angle)
        ratio = distance / radius
        return _Chosen(np.ones(len(q), dtype=bool), k + lam, angle, distance, radius, ratio)

    def _choose(self, p: np.ndarray, sections: np.ndarray, offsets: np.ndarray,
                anchor: np.ndarray) -> "_Chosen":
        """Best section of points p (B, 3) among consecutive ``sections`` (B, K) or (K,) with
        plane offsets (B, K); ``anchor`` (B,) the nearest directrix point (see containment)."""
        sections = np.broadcast_to(sections, offsets.shape)
        tol = self._plane_tolerance
        above, below = offsets > tol, offsets < -tol
        on_point, on_col = np.nonzero(~(above | below))
        crossing = (above[:, :-1] & below[:, 1:]) | (below[:, :-1] & above[:, 1:])
        cross_point, cross_col = np.nonzero(crossing)
        f0, f1 = offsets[cross_point, cross_col], offsets[cross_point, cross_col + 1]
        point = np.concatenate([on_point, cross_point])
        k = np.concatenate([sections[on_point, on_col], sections[cross_point, cross_col]])
        lam = np.concatenate([np.zeros(len(on_point)), f0 / (f0 - f1)])
        chosen = _Chosen.empty(len(p))
        if len(point) == 0:
            return chosen
        cand = self._evaluate(p[point], k, lam)
        inside = cand.ratio <= 1.0 + INSIDE_TOLERANCE
        along = np.abs(cand.section - anchor[point])
        order = np.lexsort((cand.ratio, along, ~inside, point))  # per point: inside, near, small
        best = order[np.r_[True, point[order][1:] != point[order][:-1]]]
        chosen.assign(point[best], cand.take(best))
        return chosen

    def _plane_offsets(self, points: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Signed distances (...) [m] of points (..., 3) from the planes of sections ``index``."""
        return np.einsum("...i,...i->...", points - self.directrix[index], self.tangents[index])

    @cached_property
    def _tree(self) -> cKDTree:
        return cKDTree(self.directrix)

    @cached_property
    def _tangent_matrix(self) -> np.ndarray:
        """Tangents as a contiguous (3, N) matrix (a strided one defeats BLAS)."""
        return np.ascontiguousarray(self.tangents.T)

    @cached_property
    def _plane_constants(self) -> np.ndarray:
        """t_k . c_k (N,) [m], so that t_k . (p - c_k) = t_k . p - constant_k."""
        return np.einsum("ni,ni->n", self.directrix, self.tangents)

    @cached_property
    def _plane_tolerance(self) -> float:
        """Round-off level [m] of plane offsets."""
        return 1e-12 * max(1.0, float(np.abs(self.directrix).max()))

    # ------------------------------------------------------------------ surfaces
    def boundary_points(self, num_angles: int = 64, indices: np.ndarray | None = None) -> np.ndarray:
        """Boundary curves (K, A, 3) [m] of sections ``indices`` (default all N), A angles."""
        num_angles = as_count(num_angles, "num_angles", minimum=3)
        idx = np.arange(self.num_sections) if indices is None else self.cross_sections.check_index(
            np.atleast_1d(indices))
        angles = np.linspace(0.0, 2.0 * np.pi, num_angles, endpoint=False)
        r = self.radius(idx[:, None], angles[None, :])
        local = r[..., None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
        return self.to_world(local, idx[:, None])

    def surface(self, num_angles: int = 48, step: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Surface grid X, Y, Z each (K, A+1) [m] over every ``step``-th section (closed in angle)."""
        step = as_count(step, "step")
        idx = np.unique(np.r_[np.arange(0, self.num_sections, step), self.num_sections - 1])
        ring = self.boundary_points(num_angles, idx)
        ring = np.concatenate([ring, ring[:, :1]], axis=1)
        return ring[..., 0], ring[..., 1], ring[..., 2]

    # ------------------------------------------------------------------ derived cylinders
    def with_cross_sections(self, cross_sections: CrossSections) -> "GeneralizedCylinder":
        """Same directrix and frames, new boundaries (N sections); effective points kept."""
        return GeneralizedCylinder(self.directrix, self.frames, cross_sections,
                                   self.effective_points, self.demonstrations)

    def with_directrix(self, directrix: np.ndarray,
                       initial_normal: np.ndarray | None = None) -> "GeneralizedCylinder":
        """A cylinder whose cross-sections (same 2-D shapes) follow a new directrix (N, 3).

        Frames are rebuilt as Bishop frames along the new directrix. The first normal is this
        cylinder's first normal carried by the minimal rotation that turns the old first tangent
        into the new one, unless ``initial_normal`` (3,) is given. Demonstrations are mapped
        along (effective points placed in the new frames).
        """
        new = as_points(directrix, "directrix")
        if new.shape != self.directrix.shape:
            raise TLGCArgumentError(
                f"directrix: expected shape {self.directrix.shape} (same number of sections), got {new.shape}")
        if initial_normal is None:
            first_tangent = unit_tangents(new)[0]
            initial_normal = _minimal_rotation(self.tangents[0], first_tangent) @ self.normals[0]
        frames = bishop_frames(new, initial_normal)
        moved = GeneralizedCylinder(new, frames, self.cross_sections, self.effective_points)
        if self.effective_points is not None:
            moved.demonstrations = moved.to_world(self.effective_points, np.arange(len(new)))
        return moved

    # ------------------------------------------------------------------ files
    def save(self, path: str | PathLike | BinaryIO) -> None:
        """Write the cylinder to an .npz file (a path, or a binary file opened for writing)."""
        arrays = {f"section_{k}": v for k, v in self.cross_sections.to_arrays().items()}
        if self.effective_points is not None:
            arrays["effective_points"] = self.effective_points
        if self.demonstrations is not None:
            arrays["demonstrations"] = self.demonstrations
        target = path if hasattr(path, "write") else as_path(path)
        np.savez(target, directrix=self.directrix, frames=self.frames,
                 cross_section=np.array(self.cross_section), **arrays)

    @classmethod
    def load(cls, path: str | PathLike) -> "GeneralizedCylinder":
        """Read a cylinder written by :meth:`save`."""
        path = as_file(path, CylinderFileError)
        try:
            with np.load(path, allow_pickle=False) as data:
                files = {k: data[k] for k in data.files}
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise CylinderFileError(f"path: cannot read cylinder file {path}: {exc}") from None
        missing = {"directrix", "frames", "cross_section"} - files.keys()
        if missing:
            raise CylinderFileError(f"path: {path} lacks arrays {sorted(missing)}")
        kind = str(files["cross_section"])
        if kind not in CROSS_SECTION_TYPES:
            raise CylinderFileError(f"path: {path} has unknown cross_section {kind!r}")
        sections = {k[len("section_"):]: v for k, v in files.items() if k.startswith("section_")}
        try:
            cross = cross_section_type(kind).from_arrays(sections)
        except KeyError as exc:
            raise CylinderFileError(f"path: {path} lacks cross-section array {exc}") from None
        return cls(files["directrix"], files["frames"], cross,
                   files.get("effective_points"), files.get("demonstrations"))

    def __repr__(self) -> str:
        m = None if self.effective_points is None else len(self.effective_points)
        return f"GeneralizedCylinder(N={self.num_sections}, cross_section={self.cross_section!r}, M={m})"


def check_cylinder(cyl: object, name: str = "cyl") -> GeneralizedCylinder:
    """``cyl`` itself when it is a GeneralizedCylinder (TLGCArgumentError naming it)."""
    if not isinstance(cyl, GeneralizedCylinder):
        raise TLGCArgumentError(f"{name}: expected a GeneralizedCylinder (tlgc.fit_cylinder), "
                                   f"got {type(cyl).__name__}")
    return cyl


def _minimal_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation (3,3) turning unit vector a into unit vector b about a x b (identity if equal)."""
    k = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:                         # opposite: any half-turn about a normal of a
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + skew + skew @ skew / (1.0 + c)


def fit_cylinder(demos: Any, cross_section: str = "spline",
                 num_points: int | None = None) -> GeneralizedCylinder:
    """Fit a generalized cylinder to demonstrations.

    demos: (M, T, 3) array [m], a sequence of (T_m, 3) arrays, or scenes.Demonstrations;
    cross_section: "circle", "ellipse" or "spline" (closed periodic cubic spline);
    num_points: N sections after cubic-spline resampling (default: keep T / longest T_m).
    """
    kind = cross_section_type(cross_section)       # check the name before any work
    x = as_demonstration_array(demos, num_points)
    directrix = x.mean(axis=0)
    try:
        frames = bishop_frames(directrix)
    except TLGCArgumentError as exc:
        raise CylinderDemonstrationsError(f"demos: the mean trajectory is degenerate ({exc})") from None
    d = x - directrix
    effective = np.stack([np.einsum("mni,ni->mn", d, frames[:, 1]),
                          np.einsum("mni,ni->mn", d, frames[:, 2])], axis=-1)
    spread = np.linalg.norm(effective, axis=-1).max(axis=0)          # (N,) [m]
    if spread[0] < MIN_SPREAD or np.all(spread < MIN_SPREAD):
        where = "every section" if np.all(spread < MIN_SPREAD) else "the first section"
        raise CylinderDemonstrationsError(
            f"demos: the demonstrations coincide at {where} (largest distance from their mean "
            f"{spread[0]:.3g} m at section 0); a cylinder needs demonstrations that differ by at "
            f"least {MIN_SPREAD:g} m there (starts are taken in the first section)")
    return GeneralizedCylinder(directrix, frames, kind.fit(effective), effective, x)
