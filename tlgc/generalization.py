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
  rotate and scale a path, which Laplacian coordinates do not follow, so the coordinates are
  replaced by s R delta (eq. 15). The similarity (s, R) is solved in closed form from the
  constraint pairs alone (Umeyama's SVD for three or more points that span a plane; for two
  points, or collinear ones, the chord-length ratio and the minimal rotation of the chord),
  so there is no fixed-point iteration that could settle on a runaway scale. Modes:
  ``"similarity"`` (s and R), ``"rigid"`` (R only, s = 1) and ``"laplacian"`` (neither: a
  purely local edit). Path-level editing (:func:`lte_solve`, :func:`lte_deform`) defaults to
  ``"similarity"``: eq. 15 includes the scale, and a path moved, turned and stretched as a
  whole is reproduced exactly (zero shape distortion). :func:`lte_generalize` defaults to
  ``"laplacian"`` when the start is kept (its default) and ``"similarity"`` otherwise: a kept
  start can neither turn nor scale, and forcing the rest to do so bends the skill right after
  the start (see :func:`lte_generalize` for figures).
  Bounded deformation: the largest displacement of any directrix point is at most
  ``max_amplification`` (default 2) times the largest constraint displacement. Where the
  constraints determine (s, R) poorly (a loop whose ends almost meet, letter-like shapes with
  a short chord) the full similarity would move the path by far more; it is then tempered
  towards the identity, (s^a, R^a) with a in [0, 1] found by bisection so that the bound holds
  (reported as ``strength``). If even the local edit (a = 0) breaks the bound,
  GeneralizationError is raised.

The start stays anchored (``keep_start=True``, the default of both methods): a robot standing
inside the first cross-section must still be inside it after generalization. The first
cross-section (centre, plane and boundary) is then unchanged exactly, and the deformation fades
in smoothly from it:

* TPS: the map is applied with a weight, x -> x + w(u) (z(x) - x), where u is the normalised
  arc length of the section the point belongs to (directrix point k and the effective points
  of section k share u_k). w = 0 on the first ANCHORED_SECTIONS = 3 sections (they fix the
  first tangent) and rises as a C1 smoothstep to 1 over ``fade`` (default 0.1) of the arc
  length; beyond it the map is the plain TPS, so landmarks there are met exactly. A moved
  landmark nearer the start than the fade shortens the fade to end at it; one attached to
  the first three sections raises GeneralizationError. The directrix start is also an anchor
  of the TPS itself, so the map has no reason to move it.
* LTE: the first three directrix points are hard constraints at their old positions (the
  first point and the first tangent do not move), the solved displacement is faded in with the
  same weight w(u) (the uniform Laplacian works in index space, and a path that starts from
  rest has micrometre spacing there that index-space displacements would fold), the first
  frame keeps its old normal (no turn by R), and the cross-sections' scale rises from 1 to s
  with the same smoothstep.

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
from scipy.spatial.transform import Rotation

from .cross_sections import fit_cross_sections
from .cylinder import GeneralizedCylinder, check_cylinder
from .errors import GeneralizationError, TLGCArgumentError
from .validation import as_points, as_scalar, as_count

#: landmarks closer than this (metres) to an anchor are considered the same point; a landmark
#: or constraint that moves by at most this much counts as unmoved
ANCHOR_TOLERANCE = 1e-3
#: sections (directrix points) kept exactly when the start is kept: they fix the first tangent
ANCHORED_SECTIONS = 3
#: default fade-in length of a start-keeping deformation (fraction of the normalised arc length)
DEFAULT_FADE = 0.1


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
        raise TLGCArgumentError(
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
        raise TLGCArgumentError(
            "source_landmarks, target_landmarks: expected equal shapes (L, 3) with L >= 1, got "
            f"{np.shape(source_landmarks)} and {np.shape(target_landmarks)}")
    lam = as_scalar(smoothing, "smoothing", minimum=0.0)
    gap = np.linalg.norm(src[:, None] - src[None], axis=-1)
    np.fill_diagonal(gap, np.inf)
    if gap.min() < 1e-9:
        raise TLGCArgumentError("source_landmarks: two landmarks coincide; expected distinct points")
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
        raise TLGCArgumentError(f"path: expected shape (N, 3), got {p.shape}")
    return laplacian_matrix(len(p)) @ p


def _check_constraints(constraints: Mapping[int, np.ndarray], num_points: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Sorted constraint indices (C,) and positions (C,3); negative indices count from the end."""
    if not isinstance(constraints, Mapping) or len(constraints) == 0:
        raise TLGCArgumentError(
            "constraints: expected a non-empty mapping {directrix index: position (3,)}")
    idx, pos = [], []
    for k, v in constraints.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not -num_points <= k < num_points:
            raise TLGCArgumentError(
                f"constraints: index {k!r} is not an integer in [-{num_points}, {num_points - 1}]")
        p = as_points(v, f"constraints[{k}]")
        if p.shape != (3,):
            raise TLGCArgumentError(f"constraints[{k}]: expected shape (3,), got {p.shape}")
        idx.append(int(k) % num_points)
        pos.append(p)
    idx_arr = np.asarray(idx)
    if len(np.unique(idx_arr)) != len(idx_arr):
        raise TLGCArgumentError("constraints: two keys name the same directrix index")
    order = np.argsort(idx_arr)
    return idx_arr[order], np.asarray(pos)[order]


LTE_MODES = ("similarity", "rigid", "laplacian")
DEFAULT_MAX_AMPLIFICATION = 2.0   # largest point displacement / largest constraint displacement
_BISECTION_STEPS = 30             # tempering strength resolved to 2^-30


@dataclass(frozen=True)
class LTEResult:
    """Result of :func:`lte_solve`.

    path (N,3) [m] edited path (through every constraint); transform: the similarity applied
    to the Laplacian coordinates (scale s^a, rotation R^a; translation unused); estimated: the
    similarity (s, R, t) solved from the constraint pairs; strength a in [0, 1] (1: the full
    estimate, less where it was tempered to keep the bound); amplification: largest point
    displacement over the largest constraint displacement (0 when nothing moves); mode.
    """

    path: np.ndarray
    transform: Similarity
    estimated: Similarity
    strength: float
    amplification: float
    mode: str


def _arc_length(path: np.ndarray) -> np.ndarray:
    """Normalised arc length (N,) of a path (N,3), 0 at the start and 1 at the end."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    return s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(s))


def _check_mode(mode: Any) -> str:
    if mode not in LTE_MODES:
        raise TLGCArgumentError(f"mode: unknown LTE mode {mode!r}; expected one of {', '.join(LTE_MODES)}")
    return mode


def _minimal_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation (3,3) turning unit vector a into unit vector b about a x b (identity if equal)."""
    k = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:                         # opposite: a half-turn about a normal of a
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + skew + skew @ skew / (1.0 + c)


def constraint_similarity(source: np.ndarray, target: np.ndarray, mode: str = "similarity"
                          ) -> Similarity:
    """Closed-form similarity (C,3) -> (C,3) from constraint pairs, for LTE (eq. 15).

    Points spanning a plane or more: Umeyama's least-squares similarity. One or collinear
    points: the scale is the ratio of their spread along the line and the rotation the minimal
    one turning that line onto the targets' (a chord fixes no rotation about itself). A single
    point or coinciding points: the identity. ``mode`` "rigid" fixes the scale at 1,
    "laplacian" returns the identity. The translation maps the source centroid's image onto
    the target centroid.
    """
    mode = _check_mode(mode)
    src, dst = np.asarray(source, dtype=float), np.asarray(target, dtype=float)
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    identity = Similarity(1.0, np.eye(3), mu_d - mu_s)
    if mode == "laplacian" or len(src) < 2:
        return identity
    a, b = src - mu_s, dst - mu_d
    spread = np.linalg.svd(a, compute_uv=False)
    scale_ref = max(float(np.abs(src).max()), 1.0)
    if spread[0] <= 1e-12 * scale_ref:                    # coinciding source points
        return identity
    if len(src) >= 3 and spread[1] > 1e-6 * spread[0]:    # spans a plane: Umeyama
        fit = fit_similarity(src, dst)
        scale, rotation = fit.scale, fit.rotation
    else:                                                  # a line: chord ratio + minimal turn
        direction = np.linalg.svd(a)[2][0]
        along = a @ direction
        v = along @ b
        length = float(np.linalg.norm(v))
        if length <= 1e-12 * scale_ref:
            raise GeneralizationError(
                "constraints: the moved constraint points coincide; a path cannot be scaled to a point")
        scale = length / float(along @ along)
        rotation = _minimal_rotation(direction, v / length)
    if mode == "rigid":
        scale = 1.0
    return Similarity(float(scale), rotation, mu_d - scale * rotation @ mu_s)


def lte_solve(path: np.ndarray, constraints: Mapping[int, np.ndarray], mode: str = "similarity",
              max_amplification: float = DEFAULT_MAX_AMPLIFICATION,
              anchor_start: bool = False, fade: float = DEFAULT_FADE) -> LTEResult:
    """Laplacian trajectory editing of a path (N,3) under hard positional constraints.

    ``constraints`` {index: position (3,)}; the similarity (s, R) of eq. 15 is solved in
    closed form from the constraint pairs (:func:`constraint_similarity`, ``mode``), the
    Laplacian coordinates are replaced by s R delta and the path solved once (sparse least
    squares with the constraints eliminated). If some point would move more than
    ``max_amplification`` times the largest constraint displacement, the similarity is tempered
    to (s^a, R^a), a in [0, 1] found by bisection to 2^-30 (the bound holds at a and fails just
    above it); if even a = 0 breaks the bound, GeneralizationError. ``anchor_start``: the first ANCHORED_SECTIONS points also keep their
    positions (so the first tangent does not turn; a constraint among them must keep its
    point within ANCHOR_TOLERANCE), and the displacement is faded in along the arc length,
    p + w(u) (p' - p) with :func:`fade_weights` over ``fade`` (shortened to end at the first
    moved constraint). The uniform Laplacian works in index space; where a path starts from
    rest its first samples are micrometres apart, and without the fade the solve's
    displacements there (growing with the index) would exceed the spacing and fold the path.
    """
    p = as_points(path, "path")
    if p.ndim != 2 or len(p) < 3:
        raise TLGCArgumentError(f"path: expected shape (N, 3) with N >= 3, got {p.shape}")
    mode = _check_mode(mode)
    bound = as_scalar(max_amplification, "max_amplification", minimum=1.0)
    n = len(p)
    idx, pos = _check_constraints(constraints, n)
    estimated = constraint_similarity(p[idx], pos, mode)
    move = float(np.linalg.norm(pos - p[idx], axis=1).max())
    if anchor_start:
        if n <= ANCHORED_SECTIONS:
            raise TLGCArgumentError(
                f"path: anchoring the start keeps {ANCHORED_SECTIONS} points; expected N > "
                f"{ANCHORED_SECTIONS}, got {n}")
        early = idx < ANCHORED_SECTIONS
        shift = np.linalg.norm(pos[early] - p[idx[early]], axis=1)
        if np.any(shift > ANCHOR_TOLERANCE):
            k = int(idx[early][np.argmax(shift)])
            raise GeneralizationError(
                f"constraints[{k}]: moves directrix point {k} by {shift.max():.4g} m while the "
                f"start is kept (its first {ANCHORED_SECTIONS} points stay); expected at most "
                f"{ANCHOR_TOLERANCE:g} m, or pass keep_start=False")
        fade = as_scalar(fade, "fade", minimum=0.0, maximum=1.0)
        arc = _arc_length(p)
        moved = idx[np.linalg.norm(pos - p[idx], axis=1) > ANCHOR_TOLERANCE]
        if len(moved):
            fade = min(fade, float(arc[moved.min()] - arc[ANCHORED_SECTIONS - 1]))
        weight = fade_weights(arc, fade)[:, None]
        keep = np.setdiff1d(np.arange(ANCHORED_SECTIONS), idx)
        idx = np.concatenate([idx, keep])
        pos = np.concatenate([pos, p[keep]])
        order = np.argsort(idx)
        idx, pos = idx[order], pos[order]
    else:
        weight = np.ones((n, 1))
    identity = Similarity(1.0, np.eye(3), np.zeros(3))
    scale_ref = max(float(np.abs(p).max()), 1.0)
    if move <= 1e-12 * scale_ref:                          # nothing moves: the path itself
        return LTEResult(p.copy(), identity, estimated, 1.0, 0.0, mode)

    lap = laplacian_matrix(n)
    delta = lap @ p
    free = np.ones(n, dtype=bool)
    free[idx] = False
    if not free.any():
        return LTEResult(pos.copy(), identity, estimated, 1.0,
                         float(np.linalg.norm(pos - p, axis=1).max()) / move, mode)
    lap_free_t = lap[:, free].T.tocsr()
    fixed_part = lap[:, idx] @ pos
    solver = spla.splu((lap_free_t @ lap_free_t.T).tocsc())
    rotvec = Rotation.from_matrix(estimated.rotation).as_rotvec()

    def edit(alpha: float) -> tuple[np.ndarray, Similarity, float]:
        scale = estimated.scale**alpha
        rotation = Rotation.from_rotvec(alpha * rotvec).as_matrix()
        out = np.empty_like(p)
        out[idx] = pos
        out[free] = solver.solve(lap_free_t @ (scale * delta @ rotation.T - fixed_part))
        out = p + weight * (out - p)
        out[idx] = pos
        amplification = float(np.linalg.norm(out - p, axis=1).max()) / move
        return out, Similarity(scale, rotation, np.zeros(3)), amplification

    full = edit(1.0)
    if full[2] <= bound:
        return LTEResult(full[0], full[1], estimated, 1.0, full[2], mode)
    local = edit(0.0)
    if local[2] > bound:
        raise GeneralizationError(
            f"constraints: even the local Laplacian edit would move a directrix point by "
            f"{local[2] * move:.4g} m, {local[2]:.3g} times the largest constraint displacement "
            f"{move:.4g} m; expected at most max_amplification={bound:g} times (add constraints "
            f"that hold the path, or raise max_amplification)")
    low, high, best = 0.0, 1.0, local
    for _ in range(_BISECTION_STEPS):
        mid = 0.5 * (low + high)
        trial = edit(mid)
        if trial[2] <= bound:
            low, best = mid, trial
        else:
            high = mid
    return LTEResult(best[0], best[1], estimated, low, best[2], mode)


def lte_deform(path: np.ndarray, constraints: Mapping[int, np.ndarray],
               mode: str = "similarity",
               max_amplification: float = DEFAULT_MAX_AMPLIFICATION) -> tuple[np.ndarray, Similarity]:
    """Laplacian trajectory editing of a path (N,3): :func:`lte_solve` (the similarity in
    closed form) returning only the edited path (N,3) and the similarity applied to its
    Laplacian coordinates (``mode="laplacian"``: keep the original coordinates, a purely local
    edit)."""
    result = lte_solve(path, constraints, mode, max_amplification)
    return result.path, result.transform


def shape_distortion(original: np.ndarray, deformed: np.ndarray) -> float:
    """Relative change of a path's Laplacian coordinates, up to a similarity (dimensionless).

    ||delta' - s R delta||_F / ||delta||_F for paths (N,3) with delta = L P, delta' = L P',
    where s, R is the best scale and rotation taking delta to delta'. 0 for any similarity
    transform of the path; grows with bending, shearing and non-uniform stretching.
    """
    a = laplacian_coordinates(original)
    b = laplacian_coordinates(deformed)
    if a.shape != b.shape:
        raise TLGCArgumentError(
            f"original, deformed: expected equal shapes (N, 3), got {a.shape} and {b.shape}")
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise TLGCArgumentError("original: a straight, evenly spaced path has no shape to compare")
    fit = fit_similarity(a, b, translation=False)
    return float(np.linalg.norm(b - fit(a))) / norm


# --------------------------------------------------------------------------------------------
# Cylinders
# --------------------------------------------------------------------------------------------
SECTION_SAMPLES = 32      # boundary samples standing in for effective points when a cylinder has none


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


def fade_weights(arc_length: np.ndarray, fade: float) -> np.ndarray:
    """Weights w (N,) of a deformation that keeps the start: 0 on the first ANCHORED_SECTIONS
    sections, then a C1 smoothstep in the normalised arc length u that reaches 1 at
    u_2 + ``fade`` (u_2 the arc length of section 2) and stays 1 after it."""
    u = np.asarray(arc_length, dtype=float)
    origin = u[min(ANCHORED_SECTIONS, len(u)) - 1]
    x = np.clip((u - origin) / fade, 0.0, 1.0) if fade > 0 else (u > origin).astype(float)
    return x * x * (3.0 - 2.0 * x)


def _fade_length(cyl: GeneralizedCylinder, source: np.ndarray, target: np.ndarray,
                 fade: float) -> float:
    """The fade, shortened to end at the section nearest the nearest moved landmark."""
    moved = np.linalg.norm(target - source, axis=1) > ANCHOR_TOLERANCE
    if not moved.any():
        return fade
    nearest = np.argmin(np.linalg.norm(cyl.directrix[None] - source[moved][:, None], axis=-1), axis=1)
    early = nearest < ANCHORED_SECTIONS
    if early.any():
        j = int(np.flatnonzero(moved)[np.flatnonzero(early)[0]])
        raise GeneralizationError(
            f"target_landmarks[{j}]: moves a landmark at directrix point {int(nearest[early][0])}, "
            f"within the first {ANCHORED_SECTIONS} sections that keep_start=True holds fixed; "
            f"expected it unmoved (within {ANCHOR_TOLERANCE:g} m) or keep_start=False")
    origin = cyl.arc_length[ANCHORED_SECTIONS - 1]
    return float(min(fade, (cyl.arc_length[nearest] - origin).min()))


def tps_generalize(cyl: GeneralizedCylinder, source_landmarks: np.ndarray,
                   target_landmarks: np.ndarray, smoothing: float = 0.0,
                   anchors: np.ndarray | None = None, keep_start: bool = True,
                   fade: float = DEFAULT_FADE) -> GeneralizedCylinder:
    """Generalize ``cyl`` by a thin-plate-spline map of source (L,3) to target (L,3) landmarks.

    Algorithm 3: z = fit_tps(...) maps the directrix m -> z(m) and the effective points of
    every section (in 3-D) -> z(points); the new cylinder has Bishop frames along z(m), and
    its cross-sections (same type) are fitted to the mapped points expressed in the new normal
    planes. ``anchors`` (A,3) are points that must not move. ``keep_start`` (default) keeps
    the first cross-section exactly (centre, plane, boundary): the directrix start is a TPS
    anchor and the map fades in over ``fade`` of the arc length (module docstring); landmarks
    beyond the fade are met exactly. See the module docstring for too few landmarks.
    """
    check_cylinder(cyl)
    fade = as_scalar(fade, "fade", minimum=0.0, maximum=1.0)
    extra = [] if anchors is None else [as_points(anchors, "anchors").reshape(-1, 3)]
    if keep_start:
        extra.append(cyl.directrix[:1])
    z = fit_tps(source_landmarks, target_landmarks, smoothing,
                np.concatenate(extra) if extra else None)
    idx = np.arange(cyl.num_sections)
    points3 = cyl.to_world(_section_points(cyl), idx[None, :])          # (M, N, 3)
    if keep_start:
        src = as_points(source_landmarks, "source_landmarks").reshape(-1, 3)
        dst = as_points(target_landmarks, "target_landmarks").reshape(-1, 3)
        weight = fade_weights(cyl.arc_length, _fade_length(cyl, src, dst, fade))[:, None]
    else:
        weight = np.ones((cyl.num_sections, 1))

    def mapped(x: np.ndarray) -> np.ndarray:               # x (..., N, 3): section k on axis -2
        return x + weight * (z(x) - x)

    moved = cyl.with_directrix(mapped(cyl.directrix),
                               cyl.normals[0] if keep_start else None)
    local = moved.to_local(mapped(points3), idx[None, :])
    if keep_start:
        local[:, 0] = _section_points(cyl)[:, 0]       # bit-exact first section
    demos = None if cyl.demonstrations is None else mapped(cyl.demonstrations)
    return _rebuilt(moved, cyl.cross_section, local, demos)


def landmark_constraints(cyl: GeneralizedCylinder, source_landmarks: np.ndarray,
                         target_landmarks: np.ndarray, keep_start: bool = True
                         ) -> dict[int, np.ndarray]:
    """LTE constraints {directrix index: position} from landmark pairs (L,3), (L,3).

    Each source landmark is attached to its nearest directrix point, which is moved by the
    landmark's displacement. ``keep_start`` pins the directrix start unless a landmark is
    attached to it (with one moving landmark alone, LTE could only translate the path).
    """
    check_cylinder(cyl)
    src = as_points(source_landmarks, "source_landmarks").reshape(-1, 3)
    dst = as_points(target_landmarks, "target_landmarks").reshape(-1, 3)
    if src.shape != dst.shape or len(src) == 0:
        raise TLGCArgumentError(
            "source_landmarks, target_landmarks: expected equal shapes (L, 3) with L >= 1, got "
            f"{np.shape(source_landmarks)} and {np.shape(target_landmarks)}")
    nearest = np.argmin(np.linalg.norm(cyl.directrix[None] - src[:, None], axis=-1), axis=1)
    if len(np.unique(nearest)) != len(nearest):
        raise TLGCArgumentError(
            "source_landmarks: two landmarks are nearest to the same directrix point")
    constraints = {int(k): cyl.directrix[k] + (d - s) for k, s, d in zip(nearest, src, dst)}
    if keep_start and 0 not in constraints:
        constraints[0] = cyl.directrix[0].copy()
    return constraints


def lte_generalize(cyl: GeneralizedCylinder, constraints: Mapping[int, np.ndarray],
                   scale_cross_sections: bool = True, *,
                   mode: str | None = None, keep_start: bool = True,
                   fade: float = DEFAULT_FADE,
                   max_amplification: float = DEFAULT_MAX_AMPLIFICATION) -> GeneralizedCylinder:
    """Generalize ``cyl`` by Laplacian trajectory editing of its directrix (Algorithm 4).

    ``constraints`` {directrix index: new position (3,)} (see :func:`landmark_constraints`);
    the edited directrix passes through them exactly (:func:`lte_solve` with ``mode`` and
    ``max_amplification``). The cross-sections
    keep their 2-D shape in Bishop frames along the edited directrix, scaled by the applied
    scale s when ``scale_cross_sections``. ``keep_start`` (default): the start must not be
    moved by the constraints; the first three directrix points stay, the first frame keeps its
    normal and the section scale fades in from 1 over ``fade`` of the arc length, so the first
    cross-section is unchanged exactly. Otherwise the first normal turns with R and every
    section is scaled by s.

    ``mode`` None (default) picks ``"laplacian"`` when the start is kept and ``"similarity"``
    otherwise. Why: with the start kept, its position and tangent cannot follow a rotation or
    scale, so rotated/scaled Laplacian coordinates force a bend right after the start that
    distorts the skill more than the translation-only edit (pick_place, end moved 0.54 m:
    shape distortion 0.11 similarity, 0.020 rigid, 0.004 laplacian, 0.075 TPS); without that
    constraint the similarity is exact for a skill moved, turned and scaled as a whole. Pass
    ``mode="similarity"`` or ``"rigid"`` to have a kept-start skill turn (and scale) anyway.
    """
    check_cylinder(cyl)
    fade = as_scalar(fade, "fade", minimum=0.0, maximum=1.0)
    constraints = dict(constraints) if isinstance(constraints, Mapping) else constraints
    if keep_start and isinstance(constraints, dict) and len(constraints) > 0:
        constraints.setdefault(0, cyl.directrix[0].copy())
    if mode is None:
        mode = "laplacian" if keep_start else "similarity"
    result = lte_solve(cyl.directrix, constraints, mode, max_amplification,
                       anchor_start=keep_start, fade=fade)
    if keep_start:
        moved = cyl.with_directrix(result.path, cyl.normals[0])
    else:
        normal = result.transform.rotation @ cyl.normals[0]
        try:
            moved = cyl.with_directrix(result.path, normal)
        except TLGCArgumentError:             # turned normal parallel to the new tangent
            moved = cyl.with_directrix(result.path)
    scale = result.transform.scale if scale_cross_sections else 1.0
    if keep_start:
        sizes = 1.0 + (scale - 1.0) * fade_weights(cyl.arc_length, fade)
    else:
        sizes = np.full(cyl.num_sections, scale)
    points = sizes[None, :, None] * _section_points(cyl)
    demos = moved.to_world(points, np.arange(cyl.num_sections)[None, :])
    return _rebuilt(moved, cyl.cross_section, points, demos)
