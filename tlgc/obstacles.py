"""Obstacles and generalized cylinders (paper section 7).

* Known obstacles (7.1): a cylinder fitted to demonstrations that avoided an obstacle avoids it
  too, unless its cross-sections enclose more than the demonstrations did (circles can).
  :func:`cylinder_clearance` / :func:`cylinder_intersects` check this.
* Unknown obstacles, method I (7.2.1): the obstacle's bounding sphere (centre c_o, radius r_o)
  sets the final ratio eta_f and the decay constant gamma of the adaptive-ratio rule so the
  reproduction passes the sphere: in every cross-section k the sphere cuts, the reproduction's
  ray from the directrix point c_k (at the start's angle) meets the sphere where
  x^2 - 2 x (u_k . (c_o - c_k)) + |c_o - c_k|^2 - r_o^2 = 0. Roots x inside the cylinder
  (0 <= x <= r_k) give the ratios x / r_k of passing between the directrix and the sphere
  (the smallest entry root over the sections) or between the sphere and the boundary (the
  largest exit root); the one nearer the start's ratio eta_0 is taken. The critical ratio
  eta_c, within ``critical_fraction`` (2-5 %) of eta_f, must be reached at the arc length u_c
  where the sphere begins: gamma = ln((eta_0 - eta_f) / (eta_c - eta_f)) / u_c.
  Arc lengths are the cylinder's normalised ones (those :func:`tlgc.reproduction.reproduce`
  uses). The paper notes the result is tangent to the sphere; since eta only comes within
  eta_c of eta_f, the sphere is inflated by any remaining penetration and the parameters
  computed again (a few rounds at most) so the reproduction clears it.
* Unknown obstacles, method II (7.2.2): the sphere becomes a positional constraint of Laplacian
  trajectory editing: the directrix point nearest the sphere's centre is moved away from it
  (within its cross-section plane) until that section clears the sphere, the two ends stay
  fixed, and LTE spreads the deformation smoothly along the directrix; the cylinder is rebuilt
  along it (:func:`tlgc.generalization.lte_generalize`). Frames turn with the edited
  directrix, so the push grows by any remaining overlap until the sampled cylinder clears.
  (Constraining every section the sphere cuts instead makes steep shoulders, which LTE's
  shape preservation carries along the rest of the path as a large swing.)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .bounding_sphere import BoundingSphere, bounding_sphere
from .cylinder import GeneralizedCylinder
from .errors import InvalidArgumentError, TLGCError
from .generalization import lte_generalize
from .reproduction import reproduce, start_coordinates
from .validation import as_count, as_points, as_scalar


class ObstacleAvoidanceError(TLGCError):
    """The obstacle cannot be avoided by the requested strategy (e.g. it blocks the cylinder)."""


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
    if not isinstance(cyl, GeneralizedCylinder):
        raise InvalidArgumentError(f"cyl: expected a GeneralizedCylinder, got {type(cyl).__name__}")
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
    c = cyl.containment(centre[None])
    spacing = float(np.linalg.norm(np.diff(cyl.directrix, axis=0), axis=1).max())
    return bool(c.inside[0] and abs(c.offset[0]) <= spacing)


# --------------------------------------------------------------------------------------------
# Method I: adaptive ratio
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AdaptiveRatio:
    """Adaptive-ratio parameters for one start and one sphere.

    eta0: start ratio; eta_final, gamma: eq. 10 parameters; critical_arc_length u_c
    (normalised) where the sphere begins; section: index of the cross-section that sets eta_f;
    passes: "inside" (between directrix and sphere) or "outside" (between sphere and boundary).
    """

    eta0: float
    eta_final: float
    gamma: float
    critical_arc_length: float
    section: int
    passes: str


def _sphere_sections(cyl: GeneralizedCylinder, sphere: BoundingSphere) -> np.ndarray:
    """Boolean (N,): cross-section planes the sphere cuts near the directrix point."""
    w = sphere.center - cyl.directrix
    along = np.einsum("ni,ni->n", w, cyl.tangents)
    in_plane = np.linalg.norm(w - along[:, None] * cyl.tangents, axis=1)
    reach = cyl.radius(np.arange(cyl.num_sections)[:, None],
                       np.linspace(0, 2 * np.pi, 16, endpoint=False)[None]).max(axis=1)
    return (np.abs(along) < sphere.radius) & (in_plane < sphere.radius + reach)


def adaptive_ratio_parameters(cyl: GeneralizedCylinder, start: np.ndarray, obstacle: Any,
                              critical_fraction: float = 0.03) -> AdaptiveRatio:
    """eta_f and gamma (section 7.2.1) that make the reproduction from ``start`` (3,) pass the
    bounding sphere of ``obstacle``; ``critical_fraction`` in [0.02, 0.05] in the paper.

    Raises ObstacleAvoidanceError if the sphere does not cut the cylinder along the start's
    direction, or leaves no gap inside the cylinder on either side.
    """
    p0 = as_points(start, "start")
    if p0.shape != (3,):
        raise InvalidArgumentError(f"start: expected shape (3,), got {p0.shape}")
    frac = as_scalar(critical_fraction, "critical_fraction", minimum=1e-6, maximum=0.5)
    sphere = bounding_sphere(obstacle)
    angle, eta0 = start_coordinates(cyl, p0[None])
    angle, eta0 = float(angle[0]), float(eta0[0])
    cut = np.flatnonzero(_sphere_sections(cyl, sphere))
    if cut.size == 0:
        raise ObstacleAvoidanceError("obstacle: its bounding sphere does not cut the cylinder")
    u = np.cos(angle) * cyl.normals[cut] + np.sin(angle) * cyl.binormals[cut]       # (K, 3)
    w = sphere.center - cyl.directrix[cut]
    b = np.einsum("ki,ki->k", u, w)
    disc = b**2 - (np.einsum("ki,ki->k", w, w) - sphere.radius**2)
    hit = (disc > 0.0) & (b + np.sqrt(np.maximum(disc, 0.0)) > 0.0)   # meets the positive ray
    if not hit.any():
        raise ObstacleAvoidanceError(
            "obstacle: the reproduction's direction never meets the bounding sphere; "
            "the fixed-ratio reproduction already avoids it")
    cut, b, disc = cut[hit], b[hit], disc[hit]
    root = np.sqrt(disc)
    radius = cyl.radius(cut, np.full(len(cut), angle))
    entry, exit_ = (b - root) / radius, (b + root) / radius       # ratios of the two crossings
    choices = []
    if entry.min() >= 0.0:
        k = int(np.argmin(entry))
        choices.append((float(entry[k]), int(cut[k]), "inside"))
    if exit_.max() <= 1.0:
        k = int(np.argmax(exit_))
        choices.append((float(exit_[k]), int(cut[k]), "outside"))
    if not choices:
        raise ObstacleAvoidanceError(
            "obstacle: the bounding sphere covers the cylinder from the directrix to the "
            "boundary along the start's direction; try method II (avoid_with_deformation)")
    eta_f, section, passes = min(choices, key=lambda c: abs(c[0] - eta0))
    arc = cyl.arc_length
    u_c = float(arc[cut[0]]) if cut[0] > 0 else float(arc[1])
    gap = frac * max(eta_f, 1e-3)
    gamma = 0.0 if abs(eta0 - eta_f) <= gap else float(np.log(abs(eta0 - eta_f) / gap) / u_c)
    return AdaptiveRatio(eta0, eta_f, gamma, u_c, section, passes)


@dataclass(frozen=True)
class AdaptiveAvoidance:
    """Result of :func:`avoid_with_adaptive_ratio`.

    reproduction (N,3) adapted; fixed_reproduction (N,3) by the fixed-ratio rule; clearance,
    fixed_clearance [m]: smallest distance of each to the sphere surface (negative: inside);
    parameters: the AdaptiveRatio used (None when the fixed reproduction already clears);
    sphere: the obstacle's bounding sphere; inflation [m] added to reach clearance.
    """

    reproduction: np.ndarray
    fixed_reproduction: np.ndarray
    clearance: float
    fixed_clearance: float
    parameters: AdaptiveRatio | None
    sphere: BoundingSphere
    inflation: float


def avoid_with_adaptive_ratio(cyl: GeneralizedCylinder, start: np.ndarray, obstacle: Any,
                              critical_fraction: float = 0.03, safety: float = 0.0,
                              max_rounds: int = 6) -> AdaptiveAvoidance:
    """Method I: reproduce from ``start`` (3,) passing the bounding sphere of ``obstacle``.

    ``safety`` [m] is added to the sphere radius (the paper's "from a safe distance"). If the
    reproduction still dips into the (safety-inflated) sphere, the sphere is inflated by the
    depth and the parameters recomputed, up to ``max_rounds`` times.
    """
    margin = as_scalar(safety, "safety", minimum=0.0)
    rounds = as_count(max_rounds, "max_rounds")
    sphere = bounding_sphere(obstacle).inflated(margin)
    fixed = reproduce(cyl, start)
    fixed_clear = float(sphere.distance(fixed).min())
    if fixed_clear >= 0.0:
        return AdaptiveAvoidance(fixed, fixed, fixed_clear, fixed_clear, None, sphere, 0.0)
    inflation = 0.0
    for _ in range(rounds):
        params = adaptive_ratio_parameters(cyl, start, sphere.inflated(inflation), critical_fraction)
        adapted = reproduce(cyl, start, eta_final=params.eta_final, gamma=params.gamma)
        clear = float(sphere.distance(adapted).min())
        if clear >= 0.0:
            break
        inflation += -clear + 1e-6 * max(sphere.radius, 1e-3)
    return AdaptiveAvoidance(adapted, fixed, clear, fixed_clear, params, sphere, inflation)


# --------------------------------------------------------------------------------------------
# Method II: deformation by Laplacian trajectory editing
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DeformationAvoidance:
    """Result of :func:`avoid_with_deformation`: the deformed cylinder, its sampled clearance
    [m] to the sphere (before: ``original_clearance``), the constraints {index: position} used
    and the sphere."""

    cylinder: GeneralizedCylinder
    clearance: float
    original_clearance: float
    constraints: dict[int, np.ndarray]
    sphere: BoundingSphere


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
    reach = float(cyl.radius(np.full(64, i), np.linspace(0, 2 * np.pi, 64, endpoint=False)).max())
    return i, away, max(disc + reach - dist, 0.0)


def avoid_with_deformation(cyl: GeneralizedCylinder, obstacle: Any, safety: float = 0.0,
                           max_rounds: int = 10, iterations: int = 0) -> DeformationAvoidance:
    """Method II: deform the cylinder by LTE so its solid clears the bounding sphere.

    ``safety`` [m] inflates the sphere. The directrix point nearest the sphere's centre is
    pushed away from it (within its cross-section plane) until that section's largest radius
    clears the sphere; the two ends stay fixed and LTE spreads the deformation along the
    path. While the rebuilt cylinder (whose frames turn with the edited directrix) still
    overlaps the sphere, the push grows by the overlap, up to ``max_rounds`` rounds.
    ``iterations`` is passed to :func:`lte_deform` (0: no re-estimated rotation, the
    deformation stays local). ``clearance`` < 0 in the result means it did not succeed.
    """
    margin = as_scalar(safety, "safety", minimum=0.0)
    rounds = as_count(max_rounds, "max_rounds")
    sphere = bounding_sphere(obstacle).inflated(margin)
    before = cylinder_clearance(cyl, sphere)
    if before >= 0.0:
        return DeformationAvoidance(cyl, before, before, {}, sphere)
    n = cyl.num_sections
    index, away, push = _push_direction(cyl, sphere)
    if index in (0, n - 1):
        raise ObstacleAvoidanceError(
            "obstacle: its bounding sphere is nearest the first or last cross-section of the "
            "skill, which deformation keeps fixed")
    push += 1e-3 * sphere.radius
    for _ in range(rounds):
        constraints = {0: cyl.directrix[0].copy(), n - 1: cyl.directrix[-1].copy(),
                       index: cyl.directrix[index] + push * away}
        current = lte_generalize(cyl, constraints, iterations=iterations, scale_cross_sections=False)
        clear = cylinder_clearance(current, sphere)
        if clear >= 0.0:
            break
        push += -clear + 1e-3 * sphere.radius
    return DeformationAvoidance(current, clear, before, constraints, sphere)
