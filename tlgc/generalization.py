"""Generalization of a generalized cylinder to new landmark positions (paper section 4.3).

Two methods, both returning a new :class:`~tlgc.cylinder.GeneralizedCylinder`:

* Thin-plate-spline registration (Algorithm 3, eq. 11): a map z(x) = b + A x + sum_n w_n ||x - L_n||
  from the source landmarks to the target landmarks (in 3-D the thin-plate kernel is ||x - L||),
  applied to the directrix and to the cross-sections' effective points; the new cylinder is
  built on the mapped directrix with the mapped effective points projected onto its normal
  planes.
* Laplacian trajectory editing (Algorithm 4, eq. 12-15): the directrix's Laplacian
  coordinates delta = L P (uniform umbrella weights) are kept in the least-squares sense while
  chosen directrix points are moved to new positions (hard constraints). Large deformations
  rotate and scale a path, which Laplacian coordinates do not follow; as in Nierhoff et al.
  the best similarity (scale s, rotation R; eq. 15, by SVD) between the original and the
  edited path is estimated and the coordinates are replaced by s R delta, until it settles. The
  cross-sections keep their shape in the new frames, scaled by s.

Too few landmarks for the affine part: an affine map in 3-D needs at least 4 landmarks that
are not coplanar. :func:`tps_generalize` adds explicit *anchors* to the landmarks, points that
map to themselves (by default the start of the directrix, so a reproduction still starts where
the robot is; the paper's pick-and-place keeps the object's landmark fixed the same way). If
landmarks and anchors still do not span 3-D (e.g. one fixed and one moved landmark), the
polynomial part is reduced to a translation: the kernel ||x - L|| only needs a constant for a
unique solution. :attr:`TPSMap.degree` reports which was used.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.interpolate import RBFInterpolator

from .cross_sections import fit_cross_sections
from .cylinder import GeneralizedCylinder
from .errors import InvalidArgumentError
from .validation import as_points, as_scalar, as_count

#: landmarks closer than this (metres) to an anchor are considered the same point
ANCHOR_TOLERANCE = 1e-3


# --------------------------------------------------------------------------------------------
# Similarity transform (eq. 15)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Similarity:
    """x -> scale * rotation @ x + translation; rotation (3,3) proper, scale > 0, translation (3,)."""

    scale: float
    rotation: np.ndarray
    translation: np.ndarray

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Map points (..., 3) -> (..., 3)."""
        return self.scale * points @ self.rotation.T + self.translation


def fit_similarity(source: np.ndarray, target: np.ndarray, translation: bool = True) -> Similarity:
    """Least-squares similarity mapping source (K,3) onto target (K,3) (SVD, Umeyama 1991).

    Minimises sum ||target_k - (s R source_k + t)||^2 over s > 0, proper rotations R and t
    (t = 0 when ``translation`` is False).
    """
    src = as_points(source, "source")
    dst = as_points(target, "target")
    if src.ndim != 2 or src.shape != dst.shape:
        raise InvalidArgumentError(
            f"source, target: expected equal shapes (K, 3), got {src.shape} and {dst.shape}")
    mu_s = src.mean(axis=0) if translation else np.zeros(3)
    mu_d = dst.mean(axis=0) if translation else np.zeros(3)
    a, b = src - mu_s, dst - mu_d
    var_s = float(np.einsum("ij,ij->", a, a))
    if var_s <= 0.0:
        return Similarity(1.0, np.eye(3), mu_d - mu_s)
    u, sing, vt = np.linalg.svd(b.T @ a)
    d = np.ones(3)
    d[2] = np.sign(np.linalg.det(u) * np.linalg.det(vt)) or 1.0
    rotation = (u * d) @ vt
    scale = float(sing @ d) / var_s
    if scale <= 0.0:
        scale = 1.0
    return Similarity(scale, rotation, mu_d - scale * rotation @ mu_s)


# --------------------------------------------------------------------------------------------
# Thin-plate spline (eq. 11)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TPSMap:
    """A fitted 3-D thin-plate-spline map z (R^3 -> R^3); call it on points (..., 3).

    ``source``/``target`` (K,3) are the interpolated pairs (landmarks then anchors),
    ``degree`` is 1 (affine part) or 0 (translation only, too few landmarks), ``num_anchors``
    how many of the pairs are added anchors.
    """

    source: np.ndarray
    target: np.ndarray
    degree: int
    num_anchors: int
    _interpolator: RBFInterpolator

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Mapped points (..., 3) of points (..., 3)."""
        x = np.asarray(points, dtype=float)
        flat = x.reshape(-1, 3)
        return (flat + self._interpolator(flat)).reshape(x.shape)


def _affine_rank(points: np.ndarray) -> int:
    """Dimension of the affine span of points (K,3): 0 to 3."""
    if len(points) < 2:
        return 0
    centred = points - points.mean(axis=0)
    sing = np.linalg.svd(centred, compute_uv=False)
    scale = max(float(sing[0]), 1e-300)
    return int(np.count_nonzero(sing > 1e-6 * scale))


def fit_tps(source_landmarks: np.ndarray, target_landmarks: np.ndarray, smoothing: float = 0.0,
            anchors: np.ndarray | None = None) -> TPSMap:
    """Thin-plate-spline map (kernel ||x - L||, affine part) taking source (L,3) to target (L,3).

    ``smoothing`` >= 0 is lambda of eq. 11 (0 interpolates exactly). ``anchors`` (A,3) are
    extra points mapped to themselves; anchors within 1 mm of a source landmark are dropped.
    With fewer than 4 non-coplanar pairs the polynomial part is a translation (degree 0).
    """
    src = as_points(source_landmarks, "source_landmarks")
    dst = as_points(target_landmarks, "target_landmarks")
    if src.ndim == 1:
        src = src[None]
    if dst.ndim == 1:
        dst = dst[None]
    if src.ndim != 2 or src.shape != dst.shape or len(src) == 0:
        raise InvalidArgumentError(
            "source_landmarks, target_landmarks: expected equal shapes (L, 3) with L >= 1, got "
            f"{np.shape(source_landmarks)} and {np.shape(target_landmarks)}")
    lam = as_scalar(smoothing, "smoothing", minimum=0.0)
    gap = np.linalg.norm(src[:, None] - src[None], axis=-1)
    np.fill_diagonal(gap, np.inf)
    if gap.min() < 1e-9:
        raise InvalidArgumentError("source_landmarks: two landmarks coincide; expected distinct points")
    extra = np.zeros((0, 3))
    if anchors is not None:
        a = as_points(anchors, "anchors").reshape(-1, 3)
        far = np.linalg.norm(a[:, None] - src[None], axis=-1).min(axis=1) > ANCHOR_TOLERANCE
        extra = a[far]
    pts = np.concatenate([src, extra])
    vals = np.concatenate([dst - src, np.zeros_like(extra)])
    degree = 1 if (len(pts) >= 4 and _affine_rank(pts) == 3) else 0
    interp = RBFInterpolator(pts, vals, kernel="linear", degree=degree, smoothing=lam)
    return TPSMap(pts, np.concatenate([dst, extra]), degree, len(extra), interp)


# --------------------------------------------------------------------------------------------
# Laplacian trajectory editing (eq. 12-15)
# --------------------------------------------------------------------------------------------
def laplacian_matrix(num_points: int) -> sp.csr_matrix:
    """Uniform umbrella Laplacian (N,N) of a path graph (eq. 13): 1 on the diagonal, -1/deg_i on neighbours."""
    n = as_count(num_points, "num_points", minimum=2)
    deg = np.full(n, 2.0)
    deg[[0, -1]] = 1.0
    off = -1.0 / deg
    rows = np.concatenate([np.arange(n), np.arange(1, n), np.arange(n - 1)])
    cols = np.concatenate([np.arange(n), np.arange(n - 1), np.arange(1, n)])
    data = np.concatenate([np.ones(n), off[1:], off[:-1]])
    return sp.csr_matrix((data, (rows, cols)), shape=(n, n))


def laplacian_coordinates(path: np.ndarray) -> np.ndarray:
    """Laplacian coordinates delta (N,3) = L P of a path (N,3) (eq. 12)."""
    p = as_points(path, "path")
    if p.ndim != 2:
        raise InvalidArgumentError(f"path: expected shape (N, 3), got {p.shape}")
    return laplacian_matrix(len(p)) @ p


def _check_constraints(constraints: Mapping[int, np.ndarray], num_points: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Sorted constraint indices (C,) and positions (C,3); negative indices count from the end."""
    if not isinstance(constraints, Mapping) or len(constraints) == 0:
        raise InvalidArgumentError(
            "constraints: expected a non-empty mapping {directrix index: position (3,)}")
    idx, pos = [], []
    for k, v in constraints.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not -num_points <= k < num_points:
            raise InvalidArgumentError(
                f"constraints: index {k!r} is not an integer in [-{num_points}, {num_points - 1}]")
        p = as_points(v, f"constraints[{k}]")
        if p.shape != (3,):
            raise InvalidArgumentError(f"constraints[{k}]: expected shape (3,), got {p.shape}")
        idx.append(int(k) % num_points)
        pos.append(p)
    idx_arr = np.asarray(idx)
    if len(np.unique(idx_arr)) != len(idx_arr):
        raise InvalidArgumentError("constraints: two keys name the same directrix index")
    order = np.argsort(idx_arr)
    return idx_arr[order], np.asarray(pos)[order]


def lte_deform(path: np.ndarray, constraints: Mapping[int, np.ndarray], iterations: int = 100,
               tolerance: float = 1e-7) -> tuple[np.ndarray, Similarity]:
    """Laplacian trajectory editing of a path (N,3) under hard positional constraints.

    ``constraints`` maps point indices to new positions (3,). Returns the edited path (N,3),
    which passes exactly through the constraints, and the similarity (s, R) by which its
    Laplacian coordinates were rotated and scaled (eq. 15). The similarity is re-estimated
    between the original and the edited path until no point moves by more than ``tolerance``
    metres, at most ``iterations`` times (0 keeps the original coordinates: a purely local
    edit).
    """
    p = as_points(path, "path")
    if p.ndim != 2 or len(p) < 3:
        raise InvalidArgumentError(f"path: expected shape (N, 3) with N >= 3, got {p.shape}")
    iterations = as_count(iterations, "iterations", minimum=0)
    tol = as_scalar(tolerance, "tolerance", minimum=0.0)
    n = len(p)
    idx, pos = _check_constraints(constraints, n)
    lap = laplacian_matrix(n)
    delta = lap @ p
    free = np.ones(n, dtype=bool)
    free[idx] = False
    if not free.any():
        return pos.copy(), fit_similarity(p, pos)
    lap_free_t = lap[:, free].T.tocsr()
    fixed_part = lap[:, idx] @ pos
    solver = spla.splu((lap_free_t @ lap_free_t.T).tocsc())

    def edit(coords: np.ndarray) -> np.ndarray:
        out = np.empty_like(p)
        out[idx] = pos
        out[free] = solver.solve(lap_free_t @ (coords - fixed_part))
        return out

    edited = edit(delta)
    transform = Similarity(1.0, np.eye(3), np.zeros(3))
    for _ in range(iterations):
        previous = edited
        transform = fit_similarity(p, edited)
        edited = edit(transform.scale * delta @ transform.rotation.T)
        if np.abs(edited - previous).max() <= tol:
            break
    return edited, transform


def shape_distortion(original: np.ndarray, deformed: np.ndarray) -> float:
    """Relative change of a path's Laplacian coordinates, up to a similarity (dimensionless).

    ||delta' - s R delta||_F / ||delta||_F for paths (N,3) with delta = L P, delta' = L P',
    where s, R is the best scale and rotation taking delta to delta'. 0 for any similarity
    transform of the path; grows with bending, shearing and non-uniform stretching.
    """
    a = laplacian_coordinates(original)
    b = laplacian_coordinates(deformed)
    if a.shape != b.shape:
        raise InvalidArgumentError(
            f"original, deformed: expected equal shapes (N, 3), got {a.shape} and {b.shape}")
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise InvalidArgumentError("original: a straight, evenly spaced path has no shape to compare")
    fit = fit_similarity(a, b, translation=False)
    return float(np.linalg.norm(b - fit(a))) / norm


# --------------------------------------------------------------------------------------------
# Cylinders
# --------------------------------------------------------------------------------------------
SECTION_SAMPLES = 32      # boundary samples standing in for effective points when a cylinder has none


def _check_cylinder(cyl: Any) -> None:
    if not isinstance(cyl, GeneralizedCylinder):
        raise InvalidArgumentError(f"cyl: expected a GeneralizedCylinder, got {type(cyl).__name__}")


def _section_points(cyl: GeneralizedCylinder) -> np.ndarray:
    """In-plane points (M, N, 2) [m] that define the cross-sections: the effective points, or
    boundary samples (one per angle) for a cylinder built without them."""
    if cyl.effective_points is not None:
        return cyl.effective_points
    return np.moveaxis(cyl.cross_sections.boundary(SECTION_SAMPLES), 1, 0)


def _rebuilt(frame_source: GeneralizedCylinder, sections: str, points: np.ndarray,
             demonstrations: np.ndarray | None) -> GeneralizedCylinder:
    """Cylinder on frame_source's directrix/frames with ``sections`` fitted to points (M,N,2)."""
    return GeneralizedCylinder(frame_source.directrix, frame_source.frames,
                               fit_cross_sections(sections, points), points, demonstrations)


def tps_generalize(cyl: GeneralizedCylinder, source_landmarks: np.ndarray,
                   target_landmarks: np.ndarray, smoothing: float = 0.0,
                   anchors: np.ndarray | None = None, keep_start: bool = True
                   ) -> GeneralizedCylinder:
    """Generalize ``cyl`` by a thin-plate-spline map of source (L,3) to target (L,3) landmarks.

    Algorithm 3: z = fit_tps(...) maps the directrix m -> z(m) and the effective points of
    every section (in 3-D) -> z(points); the new cylinder has Bishop frames along z(m), and
    its cross-sections (same type) are fitted to the mapped points expressed in the new normal
    planes. ``anchors`` (A,3) are points that must not move; ``keep_start`` adds the directrix
    start to them (a reproduction starting where the robot is stays valid). See the module
    docstring for too few landmarks.
    """
    _check_cylinder(cyl)
    extra = [] if anchors is None else [as_points(anchors, "anchors").reshape(-1, 3)]
    if keep_start:
        extra.append(cyl.directrix[:1])
    z = fit_tps(source_landmarks, target_landmarks, smoothing,
                np.concatenate(extra) if extra else None)
    idx = np.arange(cyl.num_sections)
    points3 = cyl.to_world(_section_points(cyl), idx[None, :])          # (M, N, 3)
    moved = cyl.with_directrix(z(cyl.directrix))
    local = moved.to_local(z(points3), idx[None, :])
    demos = None if cyl.demonstrations is None else z(cyl.demonstrations)
    return _rebuilt(moved, cyl.cross_section, local, demos)


def landmark_constraints(cyl: GeneralizedCylinder, source_landmarks: np.ndarray,
                         target_landmarks: np.ndarray, keep_start: bool = True
                         ) -> dict[int, np.ndarray]:
    """LTE constraints {directrix index: position} from landmark pairs (L,3), (L,3).

    Each source landmark is attached to its nearest directrix point, which is moved by the
    landmark's displacement. ``keep_start`` pins the directrix start unless a landmark is
    attached to it (with one moving landmark alone, LTE could only translate the path).
    """
    _check_cylinder(cyl)
    src = as_points(source_landmarks, "source_landmarks").reshape(-1, 3)
    dst = as_points(target_landmarks, "target_landmarks").reshape(-1, 3)
    if src.shape != dst.shape or len(src) == 0:
        raise InvalidArgumentError(
            "source_landmarks, target_landmarks: expected equal shapes (L, 3) with L >= 1, got "
            f"{np.shape(source_landmarks)} and {np.shape(target_landmarks)}")
    nearest = np.argmin(np.linalg.norm(cyl.directrix[None] - src[:, None], axis=-1), axis=1)
    if len(np.unique(nearest)) != len(nearest):
        raise InvalidArgumentError(
            "source_landmarks: two landmarks are nearest to the same directrix point")
    constraints = {int(k): cyl.directrix[k] + (d - s) for k, s, d in zip(nearest, src, dst)}
    if keep_start and 0 not in constraints:
        constraints[0] = cyl.directrix[0].copy()
    return constraints


def lte_generalize(cyl: GeneralizedCylinder, constraints: Mapping[int, np.ndarray],
                   iterations: int = 100, scale_cross_sections: bool = True) -> GeneralizedCylinder:
    """Generalize ``cyl`` by Laplacian trajectory editing of its directrix (Algorithm 4).

    ``constraints`` {directrix index: new position (3,)} (see :func:`landmark_constraints`);
    the edited directrix passes through them exactly. The cross-sections keep their 2-D shape
    in Bishop frames along the edited directrix (first normal turned by the estimated rotation
    R), scaled by the estimated scale s when ``scale_cross_sections``.
    """
    _check_cylinder(cyl)
    edited, transform = lte_deform(cyl.directrix, constraints, iterations)
    normal = transform.rotation @ cyl.normals[0]
    try:
        moved = cyl.with_directrix(edited, normal)
    except InvalidArgumentError:             # turned normal parallel to the new tangent
        moved = cyl.with_directrix(edited)
    scale = transform.scale if scale_cross_sections else 1.0
    points = scale * _section_points(cyl)
    demos = moved.to_world(points, np.arange(cyl.num_sections)[None, :])
    return _rebuilt(moved, cyl.cross_section, points, demos)
