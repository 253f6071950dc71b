"""Fit collision spheres to a URDF arm's collision geometry, and measure how well they cover it.

Fitting, per moving link (geometry grouped as in `robots.collision_geometry`): sample the surface
area-weighted and add its sharp edges (box edges, cylinder rims); for k spheres run a k-centre
Lloyd iteration (assign each point to the sphere whose surface it is deepest inside, replace each
sphere by the smallest ball enclosing its points) from a principal-axis start, a warm start (the
k-1 fit plus the farthest point) and a few farthest-point starts; keep the smallest total volume.
Each point then lies inside its sphere grown by `inflation`, so a radius is the enclosing radius
minus `inflation`. Spheres are handed out one at a time to the link whose total sphere volume
drops most, until `max_spheres` is reached or no link gains more than `min_gain` of the total
volume. Finally a fresh surface sample grows each sphere over the points it misses (closing the
gaps between fitting samples).

Regenerate the built-in sphere files with ``python -m robots.sphere_cli --robot jaco`` (and ``--robot sawyer``);
any URDF: ``python -m robots.sphere_cli --urdf PATH --out FILE.json [--package-dir D]``.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from skillplan import validation as _checks
from skillplan.progress import progress

from .collision_geometry import LinkSurface, link_surfaces
from .errors import CollisionGeometryError, UnknownFrameError
from .kinematics import frame_names
from .sphere_model import SphereModel
from .validation import as_generator

MIN_RADIUS = 1e-3  # [m] smallest radius a fitted sphere gets (tiny geometry, large inflation)
TOLERANCE = 1e-9  # [m] a point this close outside a grown sphere counts as covered (rounding)
MAX_SPHERES = 40  # default sphere budget of a fit (the planner's, robots.Robot.spheres)
INFLATION = 0.01  # [m] default growth that makes a fit cover the geometry exactly


@dataclass(frozen=True)
class CoverageReport:
    """How well spheres cover collision geometry.

    coverage: fraction of the surface area (estimated from samples) inside the union of spheres grown
    by `inflation`; link_names (L,), link_coverage (L,): the same per link; max_gap [m]: largest
    distance of a sample outside the grown union; mean_overshoot / max_overshoot [m]: mean and 95th
    percentile distance from the union's boundary to the geometry surface (how far the spheres stick
    out); num_spheres, mean_radius, max_radius [m], sphere_volume [m^3]: of the fitted model.
    """

    coverage: float
    link_names: tuple[str, ...]
    link_coverage: np.ndarray
    num_points: int
    inflation: float
    max_gap: float
    mean_overshoot: float
    max_overshoot: float
    num_spheres: int
    mean_radius: float
    max_radius: float
    sphere_volume: float


def _check_nonnegative(value: float, name: str) -> float:
    return _checks.as_scalar(value, name, minimum=0.0, error=CollisionGeometryError)


def _check_count(value: int, name: str, minimum: int) -> int:
    return _checks.as_count(value, name, minimum, CollisionGeometryError)


def enclosing_ball(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Smallest ball enclosing `points` (P, 3): centre (3,), radius [m].

    Active-set solution of the convex QP min |c|^2 + s s.t. 2 p.c + s >= |p|^2 (radius^2 = s + |c|^2):
    solve on a few extreme points, add the points left outside, repeat. The radius returned is the
    exact largest distance from the centre found to any point.
    """
    points = np.asarray(points, dtype=float)
    origin = points.mean(axis=0)
    local = points - origin
    squared = np.einsum("ij,ij->i", local, local)
    centre = np.zeros(3)
    active = np.unique(np.concatenate([np.argmax(local, axis=0), np.argmin(local, axis=0), [np.argmax(squared)]]))
    from scipy.optimize import minimize   # deferred: SciPy loads when spheres are fitted
    for _ in range(20):
        subset, subset_squared = local[active], squared[active]
        x0 = np.append(centre, np.max(subset_squared - 2.0 * subset @ centre))
        result = minimize(
            lambda x: x[:3] @ x[:3] + x[3], x0, jac=lambda x: np.append(2.0 * x[:3], 1.0), method="SLSQP",
            constraints=[{"type": "ineq", "fun": lambda x: 2.0 * subset @ x[:3] + x[3] - subset_squared,
                          "jac": lambda x: np.column_stack([2.0 * subset, np.ones(len(subset))])}],
            options={"maxiter": 200, "ftol": 1e-14})
        if np.all(np.isfinite(result.x)):
            centre = result.x[:3]
        distance = np.linalg.norm(local - centre, axis=1)
        radius = np.max(distance[active])
        outside = np.flatnonzero(distance > radius * (1.0 + 1e-6) + 1e-9)
        if len(outside) == 0:
            break
        active = np.union1d(active, outside[np.argsort(distance[outside])[-16:]])
    return centre + origin, float(np.max(np.linalg.norm(local - centre, axis=1)))


def _cluster_balls(points: np.ndarray, labels: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Enclosing ball of each label's points: centres (k, 3), radii (k,); empty labels get radius -inf."""
    centres, radii = np.zeros((k, 3)), np.full(k, -np.inf)
    for j in range(k):
        members = points[labels == j]
        if len(members):
            centres[j], radii[j] = enclosing_ball(members)
    return centres, radii


def _split_into_empty(points: np.ndarray, labels: np.ndarray, k: int) -> np.ndarray:
    """Labels (P,) where each empty label takes the far half of the most spread-out cluster."""
    labels = labels.copy()
    for j in np.flatnonzero(np.bincount(labels, minlength=k) == 0):
        best, best_spread = -1, 0.0
        for c in range(k):
            members = points[labels == c]
            spread = np.max(np.linalg.norm(members - members.mean(axis=0), axis=1)) if len(members) > 1 else 0.0
            if spread > best_spread:
                best, best_spread = c, spread
        if best < 0:
            break
        index = np.flatnonzero(labels == best)
        mean = points[index].mean(axis=0)
        far = points[index[np.argmax(np.linalg.norm(points[index] - mean, axis=1))]]
        moved = np.linalg.norm(points[index] - far, axis=1) < np.linalg.norm(points[index] - mean, axis=1)
        labels[index[moved]] = j
    return labels


def _fit_balls(points: np.ndarray, starts: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """k-centre Lloyd iteration from start centres (k, 3): balls (m, 3), (m,), m <= k, enclosing all points.

    Each round replaces every cluster by its enclosing ball, then moves each point to the ball it is
    deepest inside (smallest distance minus radius); a cluster left empty takes over part of another.
    """
    k = len(starts)
    labels = _split_into_empty(points, np.argmin(np.linalg.norm(points[:, None] - starts[None], axis=2), axis=1), k)
    for _ in range(iterations):
        centres, radii = _cluster_balls(points, labels, k)
        depth = np.linalg.norm(points[:, None] - centres[None], axis=2) - radii[None]
        new_labels = _split_into_empty(points, np.argmin(depth, axis=1), k)
        if np.array_equal(new_labels, labels):
            break
        labels = new_labels
    else:
        centres, radii = _cluster_balls(points, labels, k)
    keep = np.isfinite(radii)
    return centres[keep], radii[keep]


def _starts(points: np.ndarray, k: int, restarts: int, rng: np.random.Generator,
            previous: np.ndarray | None = None) -> list[np.ndarray]:
    """Start centres (k, 3): segment centroids along the principal axis, the `previous` (k-1, 3) fit's
    centres plus the point farthest from them, and `restarts` farthest-point seeds."""
    mean = points.mean(axis=0)
    axis = np.linalg.svd(points - mean, full_matrices=False)[2][0]
    t = (points - mean) @ axis
    edges = np.linspace(t.min(), t.max(), k + 1)
    segment = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, k - 1)
    axial = np.array([points[segment == j].mean(axis=0) if np.any(segment == j)
                      else mean + 0.5 * (edges[j] + edges[j + 1]) * axis for j in range(k)])
    starts = [axial]
    if previous is not None and len(previous) == k - 1:
        far = np.argmax(np.min(np.linalg.norm(points[:, None] - previous[None], axis=2), axis=1))
        starts.append(np.vstack([previous, points[far]]))
    for _ in range(restarts):
        chosen = [points[rng.integers(len(points))]]
        nearest = np.linalg.norm(points - chosen[0], axis=1)
        for _ in range(k - 1):
            chosen.append(points[np.argmax(nearest)])
            nearest = np.minimum(nearest, np.linalg.norm(points - chosen[-1], axis=1))
        starts.append(np.array(chosen))
    return starts


@dataclass(frozen=True)
class _LinkFit:
    centres: np.ndarray
    radii: np.ndarray  # already reduced by the inflation
    volume: float


def _fit_link(points: np.ndarray, k: int, inflation: float, rng: np.random.Generator,
              restarts: int, iterations: int, previous: _LinkFit | None = None) -> _LinkFit:
    """Best of several k-sphere fits of one link's surface points (by total sphere volume);
    `previous` is the (k-1)-sphere fit, a warm start."""
    best = None
    warm = None if previous is None else previous.centres
    for start in _starts(points, k, restarts if k > 1 else 0, rng, warm):
        centres, enclosing = _fit_balls(points, start, iterations)
        radii = np.maximum(enclosing - inflation, MIN_RADIUS)
        volume = float(4.0 / 3.0 * np.pi * np.sum(radii**3))
        if best is None or volume < best.volume:
            best = _LinkFit(centres, radii, volume)
    return best


def fit_spheres(model: pin.Model, collision_model: pin.GeometryModel, links: Sequence[str] | None = None,
                max_spheres: int = MAX_SPHERES, inflation: float = INFLATION,
                rng: np.random.Generator | int | None = None, *, samples_per_link: int = 1500, min_gain: float = 0.01, restarts: int = 2,
                iterations: int = 25) -> SphereModel:
    """Spheres covering the collision geometry of the moving links (see the module docstring).

    links: frame names whose geometry to cover (None: all geometry that moves with a joint; fixed
    base geometry only when named); each sphere's link name is the frame of the joint that moves it
    (`robots.collision_geometry.link_frame_name`), so finger geometry on fixed joints lands on the
    last link. max_spheres >= number of moving links; inflation [m] >= 0: the covering is exact for
    the sampled points once every sphere is grown by it; rng: Generator or seed (None = seed 0).
    samples_per_link: surface points per link (for fitting, then as many again to close gaps);
    min_gain: stop adding spheres when the best addition shrinks the total sphere volume by less
    than this fraction; restarts: extra random starts; iterations: Lloyd rounds per start.
    Raises CollisionGeometryError / UnknownFrameError (RobotError) on bad arguments or geometry.
    """
    inflation = _check_nonnegative(inflation, "inflation")
    max_spheres = _check_count(max_spheres, "max_spheres", 1)
    samples_per_link = _check_count(samples_per_link, "samples_per_link", 10)
    min_gain = _check_nonnegative(min_gain, "min_gain")
    restarts = _check_count(restarts, "restarts", 0)
    iterations = _check_count(iterations, "iterations", 1)
    generator = as_generator(rng, CollisionGeometryError)  # None: seed 0, fitting is deterministic
    surfaces = link_surfaces(model, collision_model, links)
    if max_spheres < len(surfaces):
        raise CollisionGeometryError(
            f"max_spheres: {max_spheres} is fewer than the {len(surfaces)} links with collision geometry "
            f"({', '.join(s.link_name for s in surfaces)}); each needs at least one sphere")
    points = [np.vstack([surface.sample_surface(samples_per_link, generator), surface.extreme_points()])
              for surface in surfaces]
    seeds = generator.integers(0, 2**32, size=len(surfaces))

    def fit(index: int, k: int, previous: _LinkFit | None) -> _LinkFit:
        # one seed per (link, k): results do not depend on the order in which links are refined
        link_rng = np.random.default_rng([int(seeds[index]), k])
        return _fit_link(points[index], k, inflation, link_rng, restarts, iterations, previous)

    # progress in spheres placed (at most max_spheres; the fit may stop earlier)
    with progress(description="fitting collision spheres", total=max_spheres, unit="sphere") as bar:
        current = [fit(i, 1, None) for i in range(len(surfaces))]
        following = [fit(i, 2, current[i]) for i in range(len(surfaces))]
        bar.update(len(current))
        while True:
            total = sum(len(c.radii) for c in current)
            gains = np.array([cur.volume - nxt.volume if total - len(cur.radii) + len(nxt.radii) <= max_spheres
                              else -np.inf for cur, nxt in zip(current, following)])
            best = int(np.argmax(gains))
            if not gains[best] > min_gain * sum(c.volume for c in current):
                break
            current[best] = following[best]
            following[best] = fit(best, len(current[best].radii) + 1, current[best])
            bar.update(1)
    counts = [len(c.radii) for c in current]
    radii = [_grow_to_cover(surface.sample_surface(samples_per_link, generator), fitted.centres, fitted.radii,
                            inflation) for surface, fitted in zip(surfaces, current)]
    names = [surfaces[i].link_name for i in range(len(surfaces)) for _ in range(counts[i])]
    return SphereModel(tuple(names), np.concatenate([c.centres for c in current]), np.concatenate(radii), inflation)


def _grow_to_cover(points: np.ndarray, centres: np.ndarray, radii: np.ndarray, inflation: float) -> np.ndarray:
    """Radii (k,) grown so that fresh surface points (P, 3) missed by all grown spheres are covered.

    Each missed point enlarges the sphere whose grown surface it is closest to; this closes the gaps
    between the fitting samples.
    """
    excess = np.linalg.norm(points[:, None] - centres[None], axis=2) - radii[None] - inflation
    nearest = np.argmin(excess, axis=1)
    missed = excess[np.arange(len(points)), nearest] > TOLERANCE
    grown = radii.copy()
    np.maximum.at(grown, nearest[missed], radii[nearest[missed]] + excess[missed, nearest[missed]])
    return grown


def sphere_coverage(model: pin.Model, collision_model: pin.GeometryModel, spheres: SphereModel,
                    inflation: float = 0.01, samples: int = 20000, rng: np.random.Generator | int | None = None,
                    links: Sequence[str] | None = None) -> CoverageReport:
    """Measure how well `spheres` cover the collision geometry of `links` (None: all moving links).

    Draws about `samples` surface points spread over the links by area (at least 200 per link), and
    counts a point covered when it lies within `inflation` [m] of a sphere that moves with the same
    joint. Sphere link names may be any frames of `model`. rng: Generator or seed (None = seed 1,
    independent of the fitting default).
    """
    inflation = _check_nonnegative(inflation, "inflation")
    samples = _check_count(samples, "samples", 1)
    if not isinstance(spheres, SphereModel):
        raise CollisionGeometryError(f"spheres: expected a SphereModel, got {type(spheres).__name__}")
    generator = as_generator(rng, CollisionGeometryError, default_seed=1)
    surfaces = link_surfaces(model, collision_model, links)
    sphere_joints = _sphere_joints(model, spheres)
    areas = np.array([s.area for s in surfaces])
    counts = np.maximum(np.round(samples * areas / areas.sum()).astype(int), 200)
    link_coverage, gaps, boundary_distances = [], [0.0], []
    for surface, count in zip(surfaces, counts):
        points = surface.sample_surface(int(count), generator)
        centres, radii = _spheres_in_link_frame(model, spheres, sphere_joints, surface)
        if len(radii) == 0:
            link_coverage.append(0.0)
            gaps.append(math.inf)
            continue
        outside = np.min(np.linalg.norm(points[:, None] - centres[None], axis=2) - radii[None], axis=1) - inflation
        link_coverage.append(float(np.mean(outside <= TOLERANCE)))
        gaps.append(float(max(outside.max(), 0.0)))
        boundary_distances.append(_boundary_to_surface(centres, radii, points, generator))
    link_coverage = np.array(link_coverage)
    distances = np.concatenate(boundary_distances) if boundary_distances else np.zeros(0)
    return CoverageReport(
        coverage=float(np.sum(link_coverage * areas) / areas.sum()),
        link_names=tuple(s.link_name for s in surfaces),
        link_coverage=link_coverage,
        num_points=int(counts.sum()),
        inflation=inflation,
        max_gap=float(max(gaps)),
        mean_overshoot=float(distances.mean()) if len(distances) else 0.0,
        max_overshoot=float(np.percentile(distances, 95)) if len(distances) else 0.0,
        num_spheres=spheres.count,
        mean_radius=float(spheres.radii.mean()) if spheres.count else 0.0,
        max_radius=float(spheres.radii.max()) if spheres.count else 0.0,
        sphere_volume=float(4.0 / 3.0 * np.pi * np.sum(spheres.radii**3)),
    )


def _sphere_joints(model: pin.Model, spheres: SphereModel) -> np.ndarray:
    """Parent joint id of each sphere's link frame (S,); UnknownFrameError for unknown names."""
    joints = []
    for name in spheres.link_names:
        if not model.existFrame(name):
            raise UnknownFrameError("spheres.link_names", name, frame_names(model))
        joints.append(model.frames[model.getFrameId(name)].parentJoint)
    return np.array(joints, dtype=int)


def _spheres_in_link_frame(model: pin.Model, spheres: SphereModel, sphere_joints: np.ndarray,
                           surface: LinkSurface) -> tuple[np.ndarray, np.ndarray]:
    """Centres (k, 3) in the surface's joint frame and radii (k,) of the spheres moving with its joint."""
    mask = sphere_joints == surface.joint_id
    names = [n for n, m in zip(spheres.link_names, mask) if m]
    placements = [model.frames[model.getFrameId(n)].placement for n in names]  # frame relative to its joint
    centres = np.array([p.rotation @ c + p.translation for p, c in zip(placements, spheres.centres[mask])])
    return centres.reshape(-1, 3), spheres.radii[mask]


def _boundary_to_surface(centres: np.ndarray, radii: np.ndarray, surface_points: np.ndarray,
                         rng: np.random.Generator, per_sphere: int = 300) -> np.ndarray:
    """Distances [m] from sample points on the boundary of the union of balls to the nearest surface sample."""
    directions = rng.standard_normal((len(radii), per_sphere, 3))
    directions /= np.linalg.norm(directions, axis=2, keepdims=True)
    boundary = (centres[:, None] + radii[:, None, None] * directions).reshape(-1, 3)
    owner = np.repeat(np.arange(len(radii)), per_sphere)
    depth = np.linalg.norm(boundary[:, None] - centres[None], axis=2) - radii[None]
    depth[np.arange(len(boundary)), owner] = np.inf
    exposed = boundary[np.all(depth > 0.0, axis=1)]
    from scipy.spatial import cKDTree
    return cKDTree(surface_points).query(exposed)[0] if len(exposed) else np.zeros(0)
