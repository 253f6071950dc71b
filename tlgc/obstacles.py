"""Obstacles and generalized cylinders (paper section 7).

* Known obstacles (7.1): a cylinder fitted to demonstrations that avoided an obstacle avoids it
  too, unless its cross-sections enclose more than the demonstrations did (circles can).
  :func:`cylinder_clearance` / :func:`cylinder_intersects` check this.
* Unknown obstacles, method I (7.2.1): the obstacle's bounding sphere (centre c_o, radius r_o)
  sets the final ratio eta_f and the decay constant gamma of the adaptive-ratio rule so the
  reproduction passes the sphere. In every cross-section k, the reproduction's ray from the
  directrix point c_k (at the start's angle) meets the sphere where
  x^2 - 2 x (u_k . (c_o - c_k)) + |c_o - c_k|^2 - r_o^2 = 0; the roots, as ratios x / r_k, bound
  the blocked band [entry_k, exit_k]. Passing between the directrix and the sphere needs
  eta_k <= entry_k at every blocked section, passing between the sphere and the boundary
  eta_k >= exit_k (the side whose eta_f is nearer eta0 is taken). The paper's eta_f is the
  tangent ratio (min entry / max exit), which eq. 10 only approaches, so its reproductions
  graze the sphere; here eta_f lies ``critical_fraction`` beyond that edge and gamma is the
  smallest decay that keeps every blocked sample on the safe side (closed form per section).
  Segments between samples are checked exactly; where one still cuts the sphere, the sphere
  is inflated (to sqrt(r^2 + h^2/4), h the step, which makes clearing samples imply clearing
  segments) and the parameters computed again. The result clears the sphere by the requested
  ``safety`` at every sample and segment, or ObstacleAvoidanceError names the start.
* Unknown obstacles, method II (7.2.2): the sphere becomes a positional constraint of Laplacian
  trajectory editing: the directrix point nearest the sphere's centre is moved away from it
  (within its cross-section plane), the start (first cross-section) and the end stay, and LTE
  spreads the deformation smoothly along the directrix; the cylinder is rebuilt along it
  (:func:`tlgc.generalization.lte_generalize`). The push grows until a lower bound of every
  cross-section region's distance to the sphere (:func:`section_clearance`) reaches what
  fixed-ratio samples and the segments between them need. (Constraining every section the
  sphere cuts instead makes steep shoulders, which LTE's shape preservation carries along the
  rest of the path as a large swing.)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .bounding_sphere import BoundingSphere, bounding_sphere
from .cylinder import GeneralizedCylinder, check_cylinder
from .errors import TLGCArgumentError, ObstacleAvoidanceError
from .generalization import ANCHORED_SECTIONS, lte_generalize
from .reproduction import PLANE_TOLERANCE, check_starts, reproduce
from .validation import as_count, as_points, as_scalar


def _distance_function(obstacle: Any):
    """Signed distance callable points (...,3) -> (...) [m] and a point inside the obstacle."""
    if hasattr(obstacle, "distance") and hasattr(obstacle, "center"):
        return obstacle.distance, np.asarray(obstacle.center, dtype=float)
    sphere = bounding_sphere(obstacle)
    return sphere.distance, sphere.center


def _solid_samples(cyl: GeneralizedCylinder, num_angles: int, num_radii: int, step: int
                   ) -> np.ndarray:
    """Points (K, A*R, 3) filling every ``step``-th cross-section (and the last one)."""
    idx = np.unique(np.r_[np.arange(0, cyl.num_sections, step), cyl.num_sections - 1])
    centre = cyl.directrix[idx][:, None, None]                                    # (K, 1, 1, 3)
    ring = cyl.boundary_points(num_angles, idx)[:, :, None]                       # (K, A, 1, 3)
    fractions = np.linspace(0.0, 1.0, num_radii)[:, None]                         # (R, 1)
    pts = centre + fractions * (ring - centre)                                    # (K, A, R, 3)
    return pts.reshape(len(idx), -1, 3)


def cylinder_clearance(cyl: GeneralizedCylinder, obstacle: Any, num_angles: int = 48,
                       num_radii: int = 6, step: int = 1) -> float:
    """Smallest signed distance [m] from the cylinder's solid to ``obstacle`` (negative: overlap).

    ``obstacle``: a scenes obstacle (its exact ``distance``), a BoundingSphere, a
    (center, radius) pair or points (P,3) (their bounding sphere). The solid is sampled on
    every ``step``-th section at ``num_angles`` angles and ``num_radii`` radial fractions, so
    the value is an upper bound of the exact clearance, tight to the sample spacing.
    """
    return _clearance_and_centre(cyl, obstacle, num_angles, num_radii, step)[0]


def _clearance_and_centre(cyl: GeneralizedCylinder, obstacle: Any, num_angles: int,
                          num_radii: int, step: int) -> tuple[float, np.ndarray]:
    """Sampled clearance [m] (see cylinder_clearance) and a point (3,) inside ``obstacle``."""
    check_cylinder(cyl)
    distance, centre = _distance_function(obstacle)
    pts = _solid_samples(cyl, as_count(num_angles, "num_angles", 3),
                         as_count(num_radii, "num_radii", 2), as_count(step, "step"))
    return float(np.min(distance(pts))), centre


def cylinder_intersects(cyl: GeneralizedCylinder, obstacle: Any, num_angles: int = 48,
                        num_radii: int = 6, step: int = 1) -> bool:
    """Whether the cylinder's solid and ``obstacle`` overlap (sampled; see cylinder_clearance).

    Also true when the obstacle's centre lies inside the cylinder, which catches obstacles
    smaller than the sample spacing.
    """
    clearance, centre = _clearance_and_centre(cyl, obstacle, num_angles, num_radii, step)
    if clearance < 0.0:
        return True
    return bool(cyl.contains(centre[None])[0])


# --------------------------------------------------------------------------------------------
# Clearance of paths (samples and the segments between them)
# --------------------------------------------------------------------------------------------
def path_clearance(paths: np.ndarray, sphere: BoundingSphere) -> np.ndarray | float:
    """Smallest distance [m] of polylines (R, N, 3) (or one (N, 3)) to the sphere's surface,
    over every sample and every straight segment between consecutive samples (negative:
    some part lies inside). Returns (R,) (or a float for one path)."""
    x = as_points(paths, "paths")
    if x.ndim not in (2, 3) or x.shape[-2] < 1:
        raise TLGCArgumentError(f"paths: expected shape (R, N, 3) or (N, 3), got {x.shape}")
    single = x.ndim == 2
    x = x[None] if single else x
    if x.shape[1] == 1:
        gap = sphere.distance(x[:, 0])
    else:
        a, d = x[:, :-1], np.diff(x, axis=1)                                    # (R, N-1, 3)
        length2 = np.einsum("rni,rni->rn", d, d)
        t = np.einsum("rni,rni->rn", sphere.center - a, d) / np.where(length2 > 0, length2, 1.0)
        closest = a + np.clip(t, 0.0, 1.0)[..., None] * d
        gap = np.linalg.norm(closest - sphere.center, axis=-1).min(axis=1) - sphere.radius
    return float(gap[0]) if single else gap


def _segment_inflation(sphere_radius: float, step: float) -> float:
    """Radius [m] a sample must clear so that a segment of length ``step`` between two such
    samples clears ``sphere_radius``: sqrt(radius^2 + step^2 / 4)."""
    return float(np.sqrt(sphere_radius**2 + 0.25 * step**2)) * (1.0 + 1e-9) + 1e-12


def _describe(start: np.ndarray) -> str:
    return "start [" + ", ".join(f"{v:.4g}" for v in start) + "]"


# --------------------------------------------------------------------------------------------
# Method I: adaptive ratio
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AdaptiveRatio:
    """Adaptive-ratio parameters for one start and one sphere.

    eta0: start ratio; eta_final, gamma: eq. 10 parameters; critical_arc_length u_c
    (normalised) where the sphere first blocks the start's ray; section: the cross-section
    whose tangent ratio ``edge`` sets eta_f; passes: "inside" (between directrix and sphere)
    or "outside" (between sphere and boundary); edge: the paper's eta_f (the ratio at which
    the reproduction would touch the sphere there).
    """

    eta0: float
    eta_final: float
    gamma: float
    critical_arc_length: float
    section: int
    passes: str
    edge: float = float("nan")


def _sphere_sections(cyl: GeneralizedCylinder, sphere: BoundingSphere) -> np.ndarray:
    """Boolean (N,): cross-section planes the sphere cuts near the directrix point."""
    w = sphere.center - cyl.directrix
    along = np.einsum("ni,ni->n", w, cyl.tangents)
    in_plane = np.linalg.norm(w - along[:, None] * cyl.tangents, axis=1)
    reach = cyl.largest_radius()
    return (np.abs(along) < sphere.radius) & (in_plane < sphere.radius + reach)


def _ray_bands(cyl: GeneralizedCylinder, angle: float, sphere: BoundingSphere
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sections (K,) whose ray from the centre at ``angle`` meets the sphere within ratios
    [0, 1], and the blocked ratio interval [entry (K,), exit (K,)] along each."""
    u = np.cos(angle) * cyl.normals + np.sin(angle) * cyl.binormals                 # (N, 3)
    w = sphere.center - cyl.directrix
    b = np.einsum("ni,ni->n", u, w)
    disc = b**2 - (np.einsum("ni,ni->n", w, w) - sphere.radius**2)
    radius = cyl.radius(np.arange(cyl.num_sections), np.full(cyl.num_sections, angle))
    root = np.sqrt(np.maximum(disc, 0.0))
    entry, exit_ = (b - root) / radius, (b + root) / radius
    hit = (disc > 0.0) & (exit_ > 0.0) & (entry < 1.0)
    k = np.flatnonzero(hit)
    return k, entry[k], exit_[k]


def _required_gamma(eta0: float, eta_final: float, safe: np.ndarray, u: np.ndarray
                    ) -> float | None:
    """Smallest gamma >= 0 that keeps eq. 10 on the safe side of ``safe`` (K,) ratios at arc
    lengths u (K,) (below them when eta_f < safe, above when eta_f > safe), or None if the start
    itself (u = 0) is on the wrong side."""
    gap0 = eta0 - eta_final
    room = safe - eta_final                    # same sign as the side to stay on
    needs = gap0 / room > 1.0                  # eta0 beyond the limit: must decay to pass
    if not needs.any():
        return 0.0
    if np.any(needs & (u <= 0.0)):
        return None
    return float(max(0.0, np.max(np.log(gap0 / room[needs]) / u[needs])))


def adaptive_ratio_parameters(cyl: GeneralizedCylinder, start: np.ndarray, obstacle: Any,
                              critical_fraction: float = 0.03, margin: float = 0.0,
                              plane_tolerance: float = PLANE_TOLERANCE) -> AdaptiveRatio:
    """eta_f and gamma (section 7.2.1) that make every sample of the reproduction from
    ``start`` (3,) clear the bounding sphere of ``obstacle`` inflated by ``margin`` [m].

    Along the start's direction every section k the sphere meets blocks the ratios
    [entry_k, exit_k]. Passing inside needs eta_k <= entry_k, outside eta_k >= exit_k (and
    exit_k < 1). The paper's eta_f is the tangent ratio (min entry / max exit), which the
    adaptive rule only approaches; here eta_f lies ``critical_fraction`` of it beyond
    (eta_f = edge (1 - f) inside, edge (1 + f) outside, at most halfway to the boundary), and
    gamma is the smallest decay that keeps every blocked sample on the safe side,
    max_k ln((eta0 - eta_f) / (limit_k - eta_f)) / u_k (0 when eta0 is already safe). The
    ratio is then within the critical fraction of eta_f, at or beyond the edge, at the latest
    at the section that sets the edge. The side whose eta_f is nearer eta0 is taken. Raises
    ObstacleAvoidanceError naming the start if the sphere does not cut the cylinder along the
    start's direction, or leaves no gap on either side.
    """
    p0 = as_points(start, "start")
    if p0.shape != (3,):
        raise TLGCArgumentError(f"start: expected shape (3,), got {p0.shape}")
    frac = as_scalar(critical_fraction, "critical_fraction", minimum=1e-6, maximum=0.5)
    extra = as_scalar(margin, "margin", minimum=0.0)
    sphere = bounding_sphere(obstacle).inflated(extra)
    angle, eta0 = check_starts(cyl, p0[None], plane_tolerance, name="start")
    angle, eta0 = float(angle[0]), float(eta0[0])
    if not _sphere_sections(cyl, sphere).any():
        raise ObstacleAvoidanceError(
            f"obstacle: its bounding sphere does not cut the cylinder ({_describe(p0)})")
    cut, entry, exit_ = _ray_bands(cyl, angle, sphere)
    if cut.size == 0:
        raise ObstacleAvoidanceError(
            f"obstacle: the reproduction's direction from {_describe(p0)} never meets the "
            "bounding sphere; the fixed-ratio reproduction already avoids it")
    u = cyl.arc_length[cut]
    choices = []
    if entry.min() > 0.0:
        edge = float(entry.min())
        eta_f = edge * (1.0 - frac)
        gamma = _required_gamma(eta0, eta_f, entry, u)
        if gamma is not None:
            choices.append((eta_f, gamma, int(cut[np.argmin(entry)]), "inside", edge))
    if exit_.max() < 1.0:
        edge = float(exit_.max())
        eta_f = min(edge * (1.0 + frac), 0.5 * (edge + 1.0))
        gamma = _required_gamma(eta0, eta_f, exit_, u)
        if gamma is not None:
            choices.append((eta_f, gamma, int(cut[np.argmax(exit_)]), "outside", edge))
    if not choices:
        raise ObstacleAvoidanceError(
            f"obstacle: along the direction of {_describe(p0)} (ratio {eta0:.3g}) the bounding "
            "sphere covers the cylinder from the directrix to the boundary, or holds the start "
            "itself; try method II (avoid_with_deformation)")
    eta_f, gamma, section, passes, edge = min(choices, key=lambda c: abs(c[0] - eta0))
    u_c = float(u[0]) if u[0] > 0 else float(cyl.arc_length[1])
    return AdaptiveRatio(eta0, eta_f, gamma, u_c, section, passes, edge)


@dataclass(frozen=True)
class AdaptiveAvoidance:
    """Result of :func:`avoid_with_adaptive_ratio`.

    reproduction (N,3) adapted; fixed_reproduction (N,3) by the fixed-ratio rule; clearance,
    fixed_clearance [m]: smallest distance of each to the sphere surface over all samples and
    the segments between them (negative: inside); parameters: the AdaptiveRatio used (None
    when the fixed reproduction already clears); sphere: the obstacle's bounding sphere;
    inflation [m] added to the sphere radius (margin plus the segment allowance) to compute
    the parameters; margin [m]: the clearance that was asked for (``safety``).
    """

    reproduction: np.ndarray
    fixed_reproduction: np.ndarray
    clearance: float
    fixed_clearance: float
    parameters: AdaptiveRatio | None
    sphere: BoundingSphere
    inflation: float
    margin: float = 0.0


def _local_step(path: np.ndarray, sphere: BoundingSphere, reach: float) -> float:
    """Longest segment [m] of a polyline (N, 3) that comes within ``reach`` + its own length
    of the sphere's centre (the only segments that could dip into a sphere of that radius)."""
    d = np.linalg.norm(np.diff(path, axis=0), axis=1)
    near = np.linalg.norm(path[:-1] - sphere.center, axis=1) <= reach + d
    return float(d[near].max()) if near.any() else 0.0


def avoid_with_adaptive_ratio(cyl: GeneralizedCylinder, start: np.ndarray, obstacle: Any,
                              critical_fraction: float = 0.03, safety: float = 0.0,
                              max_rounds: int = 8,
                              plane_tolerance: float = PLANE_TOLERANCE) -> AdaptiveAvoidance:
    """Method I: reproduce from ``start`` (3,) clear of the bounding sphere of ``obstacle``.

    Guarantee: every sample and every segment between consecutive samples of the returned
    reproduction is at least ``safety`` [m] outside the sphere (``clearance >= safety``), or
    ObstacleAvoidanceError is raised naming the start (never a silent gamma = 0: a start whose
    ratio is near eta_f gets the gamma its samples need). The fixed-ratio reproduction is
    returned when it already clears. Otherwise the parameters (:func:`adaptive_ratio_parameters`)
    make every sample clear the sphere inflated by ``safety``; if a segment between two
    samples still cuts it, the inflation grows to sqrt((R + safety)^2 + h^2 / 4) (h the longest
    nearby step, so samples clearing it imply segments clearing R + safety) or by the
    shortfall, whichever is more, up to ``max_rounds`` times.
    """
    p0 = as_points(start, "start")
    if p0.shape != (3,):
        raise TLGCArgumentError(f"start: expected shape (3,), got {p0.shape}")
    margin = as_scalar(safety, "safety", minimum=0.0)
    rounds = as_count(max_rounds, "max_rounds")
    sphere = bounding_sphere(obstacle)
    target = sphere.radius + margin
    fixed = reproduce(cyl, p0, plane_tolerance=plane_tolerance)
    fixed_clear = path_clearance(fixed, sphere)
    if fixed_clear >= margin:
        return AdaptiveAvoidance(fixed, fixed, fixed_clear, fixed_clear, None, sphere, 0.0, margin)
    radius = target * (1.0 + 1e-9) + 1e-12
    clear = fixed_clear
    for _ in range(rounds):
        params = adaptive_ratio_parameters(cyl, p0, (sphere.center, radius), critical_fraction,
                                           plane_tolerance=plane_tolerance)
        adapted = reproduce(cyl, p0, eta_final=params.eta_final, gamma=params.gamma,
                            plane_tolerance=plane_tolerance)
        clear = path_clearance(adapted, sphere)
        if clear >= margin:
            return AdaptiveAvoidance(adapted, fixed, clear, fixed_clear, params, sphere,
                                     radius - sphere.radius, margin)
        step = _local_step(adapted, sphere, radius)
        radius = max(_segment_inflation(target, step), radius + (margin - clear))
    raise ObstacleAvoidanceError(
        f"obstacle: the adapted reproduction from {_describe(p0)} clears the bounding sphere by "
        f"{clear:.4g} m after {rounds} rounds, less than the requested safety {margin:g} m")


# --------------------------------------------------------------------------------------------
# Method II: deformation by Laplacian trajectory editing
# --------------------------------------------------------------------------------------------
SECTION_SAMPLES = 512     # boundary samples per section for the solid's clearance bound


@dataclass(frozen=True)
class DeformationAvoidance:
    """Result of :func:`avoid_with_deformation`: the deformed cylinder; clearance [m], a
    lower bound of the distance from every cross-section's region to the sphere surface
    (before: ``original_clearance``); the constraints {index: position} used; the sphere;
    required [m]: the clearance the section with the least slack had to reach so that every
    segment between consecutive fixed-ratio samples next to it clears sphere + safety
    (every section meets its own requirement); reproductions (R, N, 3) from the
    given starts (None without starts), each verified clear by ``safety`` at samples and
    segments."""

    cylinder: GeneralizedCylinder
    clearance: float
    original_clearance: float
    constraints: dict[int, np.ndarray]
    sphere: BoundingSphere
    required: float = 0.0   # requirement [m] of the least-slack section (safety + segment allowance)
    reproductions: np.ndarray | None = None


def section_clearance(cyl: GeneralizedCylinder, sphere: BoundingSphere,
                      num_angles: int = SECTION_SAMPLES) -> np.ndarray:
    """Lower bound (N,) [m] of the distance from each cross-section's region (the part of its
    plane within the boundary) to the sphere's surface; negative: they overlap.

    In-plane distance from the sphere centre's projection to the region: 0 inside it, else,
    over the arcs between ``num_angles`` boundary samples, the nearer end of the arc less half
    its length (taken as 1.05 chord), which cannot exceed the true distance.
    """
    n = cyl.num_sections
    idx = np.arange(n)
    w = sphere.center - cyl.directrix
    along = np.einsum("ni,ni->n", w, cyl.tangents)
    local = cyl.to_local(sphere.center[None].repeat(n, 0), idx)
    rho, theta = np.hypot(local[:, 0], local[:, 1]), np.arctan2(local[:, 1], local[:, 0])
    inside = rho <= cyl.radius(idx, theta)
    angles = np.linspace(0.0, 2.0 * np.pi, num_angles, endpoint=False)
    r = cyl.radius(idx[:, None], angles[None, :])                                 # (N, A)
    ring = r[..., None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)     # (N, A, 2)
    chord = np.linalg.norm(ring - np.roll(ring, -1, axis=1), axis=-1)            # (N, A)
    gap = np.linalg.norm(ring - local[:, None, :], axis=-1)
    # The nearest boundary point lies on some arc j (samples j, j+1), within half its length
    # (<= 1.05 chord) of one of its ends.
    nearest = (np.minimum(gap, np.roll(gap, -1, axis=1)) - 0.525 * chord).min(axis=1)
    in_plane = np.where(inside, 0.0, np.maximum(nearest, 0.0))
    return np.hypot(along, in_plane) - sphere.radius


def _required_clearance(cyl: GeneralizedCylinder, sphere_radius: float,
                        num_angles: int = 64) -> np.ndarray:
    """Clearance (N,) [m] each section's region must keep from a sphere of ``sphere_radius``
    so that every segment between consecutive samples of a fixed-ratio reproduction clears it:
    sqrt(R^2 + h^2 / 4) - R with h the longest step next to the section (the step is affine
    in the ratio, so the longest is at ratio 0 or 1; sampled over angles, +10 % for angles
    between samples)."""
    ring = cyl.boundary_points(num_angles)                                        # (N, A, 3)
    outer = np.linalg.norm(np.diff(ring, axis=0), axis=-1).max(axis=1)
    centre = np.linalg.norm(np.diff(cyl.directrix, axis=0), axis=-1)
    step = 1.1 * np.maximum(outer, centre)                                        # (N-1,)
    near = np.maximum(np.r_[step, 0.0], np.r_[0.0, step])                         # (N,)
    return np.sqrt(sphere_radius**2 + 0.25 * near**2) * (1.0 + 1e-9) - sphere_radius + 1e-12


def _push_direction(cyl: GeneralizedCylinder, sphere: BoundingSphere) -> tuple[int, np.ndarray, float]:
    """Section i nearest the sphere's centre, the unit direction (3,) in its plane pointing
    away from the centre, and the push [m] that moves its largest radius clear of the sphere."""
    i = int(np.argmin(np.linalg.norm(cyl.directrix - sphere.center, axis=1)))
    w = sphere.center - cyl.directrix[i]
    t = cyl.tangents[i]
    along = float(w @ t)
    in_plane = w - along * t
    dist = float(np.linalg.norm(in_plane))
    away = -in_plane / dist if dist > 1e-9 else cyl.normals[i]
    disc = np.sqrt(max(sphere.radius**2 - along**2, 0.0))
    reach = float(cyl.largest_radius(i)[0])
    return i, away, max(disc + reach - dist, 0.0)


def avoid_with_deformation(cyl: GeneralizedCylinder, obstacle: Any, safety: float = 0.0,
                           max_rounds: int = 20, mode: str = "laplacian",
                           starts: np.ndarray | None = None,
                           plane_tolerance: float = PLANE_TOLERANCE) -> DeformationAvoidance:
    """Method II: deform the cylinder by LTE so its solid clears the bounding sphere.

    The directrix point nearest the sphere's centre is pushed away from it (within its
    cross-section plane); the start (first section, kept exactly) and the end stay, and LTE
    spreads the deformation along the path (``mode``: :func:`lte_generalize`'s; "laplacian",
    the local edit, by default). The push grows by any shortfall, up to ``max_rounds`` rounds,
    until every cross-section's region clears the sphere by ``required`` =
    sqrt((R + safety)^2 + h^2 / 4) - R (a lower bound, :func:`section_clearance`; h the longest
    step of a fixed-ratio reproduction), so every sample and every segment of every
    fixed-ratio reproduction clears the sphere by ``safety``. ``starts`` (S,3): also reproduce
    from them (fixed ratio) and verify samples and segments. Raises ObstacleAvoidanceError
    when the sphere is nearest the first sections or the last one (which stay), when the
    clearance is not reached, or naming the first start whose reproduction falls short.
    """
    margin = as_scalar(safety, "safety", minimum=0.0)
    rounds = as_count(max_rounds, "max_rounds")
    sphere = bounding_sphere(obstacle)
    points = None if starts is None else as_points(starts, "starts").reshape(-1, 3)

    def shortfall(c: GeneralizedCylinder) -> tuple[float, float, np.ndarray, int]:
        """Largest shortfall [m] of any section, the smallest clearance [m], the per-section
        requirements (N,) [m] and the section with the least slack."""
        clear = section_clearance(c, sphere)
        need = _required_clearance(c, sphere.radius + margin) + margin
        k = int(np.argmax(need - clear))
        return float(need[k] - clear[k]), float(clear.min()), need, k

    def verified(c: GeneralizedCylinder) -> np.ndarray | None:
        if points is None:
            return None
        reps = reproduce(c, points, plane_tolerance=plane_tolerance)
        gaps = path_clearance(reps, sphere)
        bad = np.flatnonzero(gaps < margin)
        if len(bad):
            raise ObstacleAvoidanceError(
                f"starts[{bad[0]}]: the reproduction from {_describe(points[bad[0]])} clears the "
                f"bounding sphere by {gaps[bad[0]]:.4g} m, less than the requested safety {margin:g} m")
        return reps

    missing, before, need, binding = shortfall(cyl)
    if missing <= 0.0:
        return DeformationAvoidance(cyl, before, before, {}, sphere, float(need[binding]),
                                    verified(cyl))
    n = cyl.num_sections
    index, away, push = _push_direction(cyl, sphere)
    if index < ANCHORED_SECTIONS or index == n - 1:
        raise ObstacleAvoidanceError(
            "obstacle: its bounding sphere is nearest the first or last cross-section of the "
            "skill, which deformation keeps fixed")
    # what the pushed section needs (not the largest need anywhere: a section far from the
    # sphere with long steps needs much more and has it, and would swing the whole skill)
    push += float(need[index]) + 1e-3 * sphere.radius
    for _ in range(rounds):
        constraints = {0: cyl.directrix[0].copy(), n - 1: cyl.directrix[-1].copy(),
                       index: cyl.directrix[index] + push * away}
        current = lte_generalize(cyl, constraints, scale_cross_sections=False, mode=mode)
        missing, clear, need, binding = shortfall(current)
        if missing <= 0.0:
            return DeformationAvoidance(current, clear, before, constraints, sphere,
                                        float(need[binding]), verified(current))
        push += missing + 1e-3 * sphere.radius
    raise ObstacleAvoidanceError(
        f"obstacle: after {rounds} rounds the deformed cylinder's sections still miss the "
        f"clearance their samples and segments need by {missing:.4g} m (smallest clearance "
        f"{clear:.4g} m)")
