"""Self-collision of a robot along a joint trajectory, on its URDF collision geometry, by coal.

    from robots.self_collision import self_collision_report, disabled_pairs
    report = self_collision_report(robot, q (T, n), time (T,) | None, max_motion=0.005)
    report.collision, report.min_distance, report.nearest, report.states_in_collision, report.reason

Geometry. Every collision object of ``robot.collision_model``, the base's (fixed to the world)
included, exactly as :mod:`robots.collision_check` loads it (``CollisionChecker`` with
``include_fixed=True``: its geometry, poses, convex hulls and motion bounds are reused); a robot
without URDF collision geometry falls back to its collision spheres. A geometry belongs to the
URDF link (frame) it is attached to.

Disabled pairs (the SRDF ``disable_collisions`` rule, computed once per URDF + end effector and
cached for the process; :func:`disabled_pairs`). A pair of links is never checked when

- ``"adjacent"``: one link's joint is the parent of the other's in the (reduced) kinematic tree,
  fixed joints included (parent and child links touch by construction);
- ``"rigid"``: both links move with the same joint (welded by fixed joints, e.g. the fingers on
  the Jaco's last link): their distance is the same in every configuration;
- ``"always"``: their geometry is in contact in at least ``ALWAYS_FRACTION`` (95 %) of
  ``ALWAYS_SAMPLES`` (N = 1000) configurations drawn uniformly within the joint limits with
  seed ``ALWAYS_SEED`` (0); MoveIt's setup assistant applies the same rule (at 95 %).

Every other pair of links is checked: its geometry pairs are the *checked pairs*.

Distances. ``d(a, b)`` is coal's signed distance of the two collision geometries: the distance
when apart; when they overlap, coal's depth: exact for two primitives (sphere, box, cylinder,
capsule), and where a mesh is involved (coal's mesh distance stops at 0) the deepest of coal's
triangle-pair contacts (``coal.collide``). Negative = overlap. A mesh is a surface: a geometry
wholly inside a closed mesh, touching no triangle, is seen by the hulls only; moving there
crosses the surface, which the in-between checks catch.

The search. Configurations are those of ``CollisionChecker.configurations``: the support states
and, between them (linear in joint space), enough to keep every link point's motion between
consecutive ones below ``max_motion`` (``report.max_step``). Bounds make the exact queries few:

- bounding spheres ``|c_a - c_b| - r_a - r_b`` at every configuration and pair (no query);
- convex hulls: coal's distance of the two geometries' convex bounds (a mesh's hull, a primitive
  itself) is a lower bound of ``d(a, b)`` (exact when both are primitives), ~5 microseconds;
- motion: a pair's distance changes by at most the summed motion of its two geometries, so a
  hull distance at one configuration bounds its neighbours (conservative advancement). Where
  every pair is measured on hulls, the bound is the pair's relative motion: only the joints
  between its two links count (those upstream move both rigidly), a few times tighter; which
  cells it leaves open changes, the result does not (every cell whose hull distance is below
  what must be resolved is queried whatever the bounds, and only those are measured).

Hull distances are computed where a bound is below the least exact distance found so far, and
exact distances where a hull distance is (nearest first); at every support state the pairs whose
hulls overlap are measured until one is found in collision. So ``min_distance`` and ``nearest``
are the least exact distance over every checked configuration and pair (to ``SLACK``),
``collision`` (``min_distance < 0``) and ``states_in_collision`` are exact, and the continuous
motion keeps at least ``lower_bound = min_distance - max_step`` (each of the two links is within
``max_step / 2`` of a checked configuration). With a ``tolerance`` (the planner's checks), the
search resolves only what could lie below ``min_distance - tolerance`` (not below 0): a clear
trajectory's ``min_distance`` is then within ``tolerance`` of the least distance and
``lower_bound = max(min_distance - tolerance, 0) - max_step``; collisions and depths as above.
"""
from __future__ import annotations

import math
import time as _clock
import weakref
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import coal
import numpy as np

from skillplan.validation import as_time

from .collision_check import SLACK, CollisionChecker
from .contact import Contact, collision_reason, time_at
from .distance_search import PairSearch
from .errors import CollisionCheckError
from .robot import Robot
from .validation import as_array, as_scalar
from robots.sphere_cache import cached_fit

#: configurations sampled for the "always in contact" rule
ALWAYS_SAMPLES = 1000
#: a pair in contact in at least this fraction of the samples is never checked
ALWAYS_FRACTION = 0.95
#: seed of the sampled configurations (the rule is deterministic)
ALWAYS_SEED = 0
#: a sphere pair (for the planner's hinge) is kept when its gap comes below this [m] in a sample
SPHERE_REACH = 0.1
#: spheres fitted to the geometry fixed to the world (the base), at most
FIXED_SPHERES = 6
#: contacts coal reports per mesh overlap (the deepest of them is the depth)
_MAX_CONTACTS = 100_000
DISABLE_REASONS = ("adjacent", "rigid", "always")

_DISABLED: dict[tuple, tuple[tuple[str, str, str], ...]] = {}      # per URDF + end effector
_GEOMETRY: "weakref.WeakKeyDictionary[Robot, tuple]" = weakref.WeakKeyDictionary()
_SPHERE_PAIRS: "weakref.WeakKeyDictionary[Robot, tuple]" = weakref.WeakKeyDictionary()


# =================================================================================== report
#: the self-collision check's contact is the one contact record of the robot's checks
#: (link, geometry, other = the other link, other_geometry, index, time, distance; link_a,
#: link_b, geometry_a, geometry_b read the same fields)
SelfContact = Contact


@dataclass(frozen=True)
class SelfCollisionReport:
    """Result of :func:`self_collision_report` (lengths in metres).

    geometry: "urdf" or "spheres" (fallback); min_distance: least signed distance over every
    checked configuration and pair (+inf with no checked pair), negative = depth; nearest: where
    (None with no checked pair); collision: min_distance < 0; states_in_collision (T,) bool:
    support states where some checked pair overlaps; num_configurations: configurations checked;
    num_pairs: checked geometry pairs; num_hull / num_exact: coal queries on the convex bounds /
    the geometry itself; max_step: largest motion of a link point between consecutive checked
    configurations; lower_bound = min_distance - max_step: kept by the continuous motion;
    timings [s].
    """

    geometry: str
    max_motion: float
    min_distance: float
    nearest: Contact | None
    collision: bool
    states_in_collision: np.ndarray
    num_configurations: int
    num_pairs: int
    num_hull: int
    num_exact: int
    max_step: float
    lower_bound: float
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def reason(self) -> str | None:
        """One line naming both links, the state and the depth in mm; None when clear
        (:func:`robots.contact.collision_reason`)."""
        return collision_reason(self)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (states in collision as a list of indices)."""
        return {"geometry": self.geometry, "max_motion": self.max_motion, "min_distance": self.min_distance,
                "collision": self.collision, "nearest": None if self.nearest is None else self.nearest.to_dict(),
                "states_in_collision": np.flatnonzero(self.states_in_collision).tolist(),
                "num_configurations": self.num_configurations, "num_pairs": self.num_pairs,
                "num_hull": self.num_hull, "num_exact": self.num_exact, "max_step": self.max_step,
                "lower_bound": self.lower_bound, "reason": self.reason}


# ================================================================================ geometry
class _PairQueries:
    """coal queries on pairs of the robot's geometries at given poses R (K, G, 3, 3), t (K, G, 3)."""

    def __init__(self, checker: CollisionChecker):
        geo = checker._geo
        self.shapes, self.bounds = geo.shapes, geo.bounds
        self.exact = geo.exact
        self.meshes = np.array([type(s).__name__.startswith("BVHModel") for s in geo.shapes])
        self._distance = coal.DistanceRequest()
        self._distance.enable_signed_distance = True
        self._distance.gjk_tolerance = checker._request.gjk_tolerance
        self._contacts = coal.CollisionRequest()
        self._contacts.enable_contact = True
        self._contacts.num_max_contacts = _MAX_CONTACTS
        self._collide = coal.CollisionRequest()
        self._ta, self._tb = coal.Transform3s(), coal.Transform3s()

    def _place(self, R: np.ndarray, t: np.ndarray, k: int, a: int, b: int) -> None:
        self._ta.setRotation(R[k, a])
        self._ta.setTranslation(t[k, a])
        self._tb.setRotation(R[k, b])
        self._tb.setTranslation(t[k, b])

    def hull(self, R, t, k: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Signed distance (M,) of the convex bounds of geometries a and b at configurations k."""
        out = np.empty(len(k))
        for m, (kk, aa, bb) in enumerate(zip(k.tolist(), a.tolist(), b.tolist())):
            self._place(R, t, kk, aa, bb)
            out[m] = coal.distance(self.bounds[aa], self._ta, self.bounds[bb], self._tb, self._distance,
                                   coal.DistanceResult())
        return out

    def signed(self, R, t, k: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """coal's signed distance (M,) of the geometries themselves (module docstring)."""
        out = np.empty(len(k))
        for m, (kk, aa, bb) in enumerate(zip(k.tolist(), a.tolist(), b.tolist())):
            self._place(R, t, kk, aa, bb)
            d = coal.distance(self.shapes[aa], self._ta, self.shapes[bb], self._tb, self._distance,
                              coal.DistanceResult())
            if d <= 0.0 and (self.meshes[aa] or self.meshes[bb]):
                result = coal.CollisionResult()
                if coal.collide(self.shapes[aa], self._ta, self.shapes[bb], self._tb, self._contacts, result):
                    d = min(min(c.penetration_depth for c in result.getContacts()), 0.0)
            out[m] = d
        return out

    def in_contact(self, R, t, k: int, a: int, b: int) -> bool:
        """Whether geometries a and b touch or overlap at configuration k (hull first)."""
        self._place(R, t, k, a, b)
        if coal.distance(self.bounds[a], self._ta, self.bounds[b], self._tb, self._distance,
                         coal.DistanceResult()) > 0.0:
            return False
        return bool(coal.collide(self.shapes[a], self._ta, self.shapes[b], self._tb, self._collide,
                                 coal.CollisionResult()))


def _sphere_lower(geo, R: np.ndarray, t: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bounding-sphere lower bound (K, P) of the distance of geometry pairs (a, b)."""
    centre = np.einsum("kgij,gj->kgi", R, geo.sphere_centre) + t              # (K, G, 3)
    gap = np.linalg.norm(centre[:, a] - centre[:, b], axis=2)
    return gap - geo.sphere_radius[a] - geo.sphere_radius[b]


def _pair_travel(checker: CollisionChecker, q: np.ndarray, sub, a: np.ndarray, b: np.ndarray
                 ) -> np.ndarray:
    """Accumulated bound (K, P) of how far the two geometries of each pair (a, b) move relative
    to each other along the checked configurations: their distance changes by at most that.
    The joints upstream of both move them rigidly together, so only the joints between them
    count: sum over j in (L_up, L_down] of |dq_j| rho_j(down), the downstream geometry's motion
    radius (docs/decisions.md#verdict-geometry); the sum of both geometries' own motion
    bounds counted every joint up to each (twice the upstream ones)."""
    geo = checker._geo
    ja, jb = geo.joints[a], geo.joints[b]
    down = np.where(ja >= jb, a, b)
    joint = np.arange(1, geo.motion_radius.shape[1] + 1)[:, None]           # (n, 1)
    weights = np.where(joint > np.minimum(ja, jb)[None], geo.motion_radius[down].T, 0.0)
    if len(q) == 1:
        return np.zeros((1, len(a)))
    counts = np.diff(sub.support)
    step = (np.abs(np.diff(q, axis=0)) @ weights) / counts[:, None]       # (T-1, P)
    return np.concatenate([np.zeros((1, len(a))), np.cumsum(np.repeat(step, counts, axis=0), axis=0)])


def _link_relations(robot: Robot, geo) -> dict[tuple[str, str], str]:
    """"adjacent" / "rigid" per pair of links (sorted names) by the kinematic tree."""
    joint_of = {}
    for link, joint in zip(geo.links, geo.joints.tolist()):
        joint_of[link] = joint
    parents = robot.model.parents
    relations = {}
    for la, lb in combinations(sorted(joint_of), 2):
        ja, jb = joint_of[la], joint_of[lb]
        if ja == jb:
            relations[(la, lb)] = "rigid"
        elif (ja > 0 and parents[ja] == jb) or (jb > 0 and parents[jb] == ja):
            relations[(la, lb)] = "adjacent"
    return relations


def _samples(robot: Robot) -> np.ndarray:
    """The ALWAYS_SAMPLES seeded configurations (N, n) within the joint limits."""
    rng = np.random.default_rng(ALWAYS_SEED)
    return np.array([robot.random_configuration(rng) for _ in range(ALWAYS_SAMPLES)])


def _always_in_contact(robot: Robot, checker: CollisionChecker, queries: _PairQueries,
                       link_pairs: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """Link pairs in contact in at least ALWAYS_FRACTION of ALWAYS_SAMPLES random configurations."""
    geo = checker._geo
    R, t = checker._poses(_samples(robot))
    allowed_misses = ALWAYS_SAMPLES - math.ceil(ALWAYS_FRACTION * ALWAYS_SAMPLES)
    always = []
    for la, lb in link_pairs:
        ga = [g for g, link in enumerate(geo.links) if link == la]
        gb = [g for g, link in enumerate(geo.links) if link == lb]
        pairs = [(a, b) for a in ga for b in gb]
        a_idx, b_idx = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
        lower = _sphere_lower(geo, R, t, a_idx, b_idx)                  # (N, pairs)
        misses = 0
        for k in range(ALWAYS_SAMPLES):
            touching = any(lower[k, m] <= 0.0 and queries.in_contact(R, t, k, a, b)
                           for m, (a, b) in enumerate(pairs))
            misses += not touching
            if misses > allowed_misses:
                break
        else:
            always.append((la, lb))
    return always


def _geometry(robot: Robot) -> tuple[CollisionChecker, _PairQueries, np.ndarray, np.ndarray,
                                     tuple[tuple[str, str, str], ...]]:
    """Checker (no obstacles, base included), queries, checked geometry pairs (a (P,), b (P,))
    and the disabled link pairs of a robot; cached per robot (disabled pairs per URDF + EE)."""
    if not isinstance(robot, Robot):
        raise CollisionCheckError(f"robot: expected a robots.Robot, got {type(robot).__name__}")
    cached = _GEOMETRY.get(robot)
    if cached is not None and (cached[0].geometry != "spheres" or cached[5] is robot.spheres):
        return cached[:5]
    checker = CollisionChecker(robot, (), include_fixed=True)
    geo = checker._geo
    queries = _PairQueries(checker)
    # the URDF's own geometry is shared by every Robot of that URDF and end effector; a sphere
    # fallback is the robot's own (cached per robot only)
    key = (str(robot.urdf_path), robot.end_effector) if checker.geometry == "urdf" else None
    disabled = _DISABLED.get(key) if key is not None else None
    if disabled is None:
        relations = _link_relations(robot, geo)
        others = [pair for pair in combinations(sorted(set(geo.links)), 2) if pair not in relations]
        always = _always_in_contact(robot, checker, queries, others)
        disabled = tuple(sorted([(la, lb, why) for (la, lb), why in relations.items()]
                                + [(la, lb, "always") for la, lb in always]))
        if key is not None:
            _DISABLED[key] = disabled
    off = {(la, lb) for la, lb, _ in disabled}
    checked = [(a, b) for a, b in combinations(range(len(geo.names)), 2)
               if geo.links[a] != geo.links[b] and tuple(sorted((geo.links[a], geo.links[b]))) not in off]
    a_idx = np.array([p[0] for p in checked], dtype=np.int64)
    b_idx = np.array([p[1] for p in checked], dtype=np.int64)
    spheres = robot.spheres if checker.geometry == "spheres" else None
    _GEOMETRY[robot] = (checker, queries, a_idx, b_idx, disabled, spheres)
    return checker, queries, a_idx, b_idx, disabled


def disabled_pairs(robot: Robot) -> tuple[tuple[str, str, str], ...]:
    """Link pairs never checked, ``(link_a, link_b, why)`` with link_a < link_b and why one of
    "adjacent", "rigid", "always" (see the module docstring for the rule). Computed once per
    URDF + end effector (the "always" sampling takes up to a few seconds), then cached."""
    return _geometry(robot)[4]


def checked_pairs(robot: Robot) -> tuple[tuple[str, str], ...]:
    """Geometry (collision object) pairs checked for self-collision, (geometry_a, geometry_b)."""
    checker, _, a, b, _ = _geometry(robot)
    names = checker.geometry_names
    return tuple((names[i], names[j]) for i, j in zip(a.tolist(), b.tolist()))


@dataclass(frozen=True)
class SelfCollisionSpheres:
    """Sphere pairs for a planner's self-collision hinge (see :func:`self_collision_spheres`).

    radii (S + B,) [m]: the robot's collision spheres (``robot.spheres``, S) then B spheres
    fitted to the geometry fixed to the world (the base); fixed_centres (B, 3) [m] those B in
    the base frame (constant); first, second (P,) indices into the S + B spheres of each pair;
    motion_radius (S + B, n): a sphere's centre moves at most ``|dq| @ motion_radius[s]`` [m]
    along a joint-space segment dq (the bound of :mod:`robots.collision_check`; 0 when fixed);
    clearance (P,) [m]: the gap each pair keeps in ALWAYS_FRACTION (95 %) of the sampled
    configurations (its 5 % quantile, at least 0): a hinge asking for more than that would push
    almost every plan, so a planner asks for at most this much.
    """

    radii: np.ndarray
    fixed_centres: np.ndarray
    first: np.ndarray
    second: np.ndarray
    motion_radius: np.ndarray
    clearance: np.ndarray


def _fixed_spheres(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Spheres (centres (B, 3) base frame, radii (B,)) covering the geometry fixed to the world."""
    if robot.urdf_path is None:
        return np.zeros((0, 3)), np.zeros(0)
    model = robot.model
    fixed = sorted({model.frames[o.parentFrame].name for o in robot.collision_model.geometryObjects
                    if o.parentJoint == 0})
    if not fixed:
        return np.zeros((0, 3)), np.zeros(0)
    spheres = cached_fit(robot.urdf_path, model, robot.collision_model, "collision", fixed,
                         max(FIXED_SPHERES, len(fixed)), robot.spheres.inflation, 0)   # fitted once per URDF
    local = np.array([att.rotation @ centre + att.translation for att, centre in
                      zip(map(robot.attachment, spheres.link_names), spheres.centres)])
    frames = robot.chain.joint_frames(robot.neutral_configuration()[None])
    centres, _ = robot.chain.points(frames, np.zeros(spheres.count, dtype=int), local, False)
    return np.asarray(centres).reshape(-1, 3), np.asarray(spheres.radii, dtype=float)


def self_collision_spheres(robot: Robot) -> SelfCollisionSpheres:
    """The sphere pairs a planner keeps apart, computed once per robot and sphere model.

    Spheres: ``robot.spheres`` plus up to FIXED_SPHERES (6) fitted to the base's geometry (by
    ``robots.spheres.fit_spheres``, through the sphere cache, same inflation). A pair (s, t) is
    kept when the joints that move them are neither the same nor parent and child (the "rigid"
    and "adjacent" rules of :func:`disabled_pairs`), their gap ``|c_s - c_t| - r_s - r_t``
    comes below SPHERE_REACH (0.1 m) in at least one of the ALWAYS_SAMPLES seeded configurations
    (pairs that never come near are left out), and they do not overlap in ALWAYS_FRACTION of
    them (the "always" rule on spheres). Each pair's ``clearance`` is the gap it keeps in ALWAYS_FRACTION of them.
    """
    if not isinstance(robot, Robot):
        raise CollisionCheckError(f"robot: expected a robots.Robot, got {type(robot).__name__}")
    spheres = robot.spheres
    cached = _SPHERE_PAIRS.get(robot)
    if cached is not None and cached[0] is spheres:
        return cached[1]
    joints, _ = robot.sphere_attachments()
    fixed_centres, fixed_radii = _fixed_spheres(robot)
    B = len(fixed_radii)
    joints = np.concatenate([joints, np.zeros(B, dtype=joints.dtype)])
    radii = np.concatenate([spheres.radii, fixed_radii])
    parents = np.asarray(robot.model.parents)
    first, second = np.triu_indices(len(radii), k=1)
    ja, jb = joints[first], joints[second]
    related = (ja == jb) | ((ja > 0) & (parents[ja] == jb)) | ((jb > 0) & (parents[jb] == ja))
    first, second = first[~related], second[~related]
    centres, _ = robot.sphere_centres(_samples(robot))                             # (N, S, 3)
    centres = np.concatenate([centres, np.broadcast_to(fixed_centres, (len(centres), B, 3))], axis=1)
    gap = np.linalg.norm(centres[:, first] - centres[:, second], axis=2) - radii[first] - radii[second]
    keep = (gap.min(axis=0) < SPHERE_REACH) & ((gap < 0.0).mean(axis=0) < ALWAYS_FRACTION)
    motion = CollisionChecker(robot, (), geometry="spheres", include_fixed=True)._geo.motion_radius
    motion = np.concatenate([motion, np.zeros((B, robot.n))])
    clearance = np.maximum(np.quantile(gap[:, keep], 1.0 - ALWAYS_FRACTION, axis=0), 0.0)
    result = SelfCollisionSpheres(radii, fixed_centres, first[keep], second[keep], motion, clearance)
    _SPHERE_PAIRS[robot] = (spheres, result)
    return result


# ================================================================================== search
class _Search(PairSearch):
    """The self-collision check's :class:`robots.distance_search.PairSearch`: configurations (K)
    x checked pairs (P), column c the geometries (a[c], b[c]) at poses R, t; nearest (k, c).
    Its policy: :meth:`run` (within a tolerance), :meth:`settle_states`."""

    def __init__(self, queries: _PairQueries, R, t, a, b, lower, travel, tolerance: float = 0.0):
        super().__init__(lower, travel, queries.exact[a] & queries.exact[b])
        self.q, self.R, self.t, self.a, self.b = queries, R, t, a, b
        self.tolerance = tolerance
        self.count = {"hull": 0, "exact": 0}

    def bound_values(self, k: np.ndarray, c: np.ndarray) -> np.ndarray:
        exact = int(np.count_nonzero(self.col_exact[c]))
        self.count["hull"] += len(c) - exact
        self.count["exact"] += exact
        return self.q.hull(self.R, self.t, k, self.a[c], self.b[c])

    def exact_values(self, k: np.ndarray, c: np.ndarray) -> np.ndarray:
        self.count["exact"] += len(k)
        return self.q.signed(self.R, self.t, k, self.a[c], self.b[c])

    def target(self) -> float:
        """The distance [m] below which a pair must be resolved: the best exact distance found,
        less the tolerance while it is positive (never below 0: an overlap is always found)."""
        if self.tolerance <= 0.0 or self.best <= 0.0:
            return self.best
        return max(self.best - self.tolerance, 0.0)

    def run(self) -> None:
        """Hull queries where a bound is below the target (:meth:`target`), exact ones where a
        hull distance is, until neither is left (module docstring). The target never rises and
        the bounds never fall, so a column without candidates never gets one again: each round
        looks only at the columns that still had candidates (a search soon narrows to a few)."""
        batch = 1
        active = np.arange(self.lower.shape[1])
        while True:
            candidate = ~self.queried[:, active] & (self.lower[:, active] < self.target() + SLACK)
            some = candidate.any(axis=0)
            if not some.all():
                active, candidate = active[some], candidate[:, some]
            if active.size:
                # both ends of every run of candidates of a pair, and each pair's lowest bound
                self.advance(candidate, cols=active)
                if math.isfinite(self.best):
                    continue
            pending = self.queried & ~self.measured & (self.hull < self.target() - SLACK)
            if not pending.any():
                if active.size:
                    continue
                return
            k, c = np.nonzero(pending)
            order = np.argsort(self.hull[k, c], kind="stable")[:batch]
            self.measure(k[order], c[order])
            batch = min(2 * batch, 64)

    def settle_states(self, S: np.ndarray) -> np.ndarray:
        """(T,) bool: support states where a checked pair overlaps (exact)."""
        lower = self.lower[S]
        need = ~self.queried[S] & (lower < SLACK)
        rows, cols = np.nonzero(need)
        if rows.size:
            self.hulls(S[rows], cols)
        colliding = np.any(self.measured[S] & (self.exact[S] < 0.0), axis=1)
        # each state's open pairs (hull overlapping, not yet measured); measuring one state's
        # pairs changes no other state's row
        open_all = self.queried[S] & ~self.measured[S] & (self.hull[S] < 0.0)
        for i in np.flatnonzero(~colliding & open_all.any(axis=1)):
            k = S[i]
            open_ = np.flatnonzero(open_all[i])
            for c in open_[np.argsort(self.hull[k, open_])]:
                self.measure(np.array([k]), np.array([c]))
                if self.exact[k, c] < 0.0:
                    colliding[i] = True
                    break
        return colliding


def self_collision_report(robot: Robot, q: Any, time: Any = None, max_motion: float = 0.005,
                          tolerance: float = 0.0) -> SelfCollisionReport:
    """Check a joint trajectory q (T, n) (linear in joint space between support states) for
    self-collision of the robot's collision geometry (module docstring: disabled pairs, what
    is exact). time (T,) [s] strictly increasing or None: only used to say when the nearest
    contact happens. max_motion [m]: largest motion of any link point between two checked
    configurations. tolerance [m]: a clear trajectory's ``min_distance`` may exceed the least
    distance by up to this much (``lower_bound`` accounts for it); ``collision``,
    ``states_in_collision`` and a depth stay exact. The planner's checks pass 1 cm: a clearance
    far from zero is certified with few exact mesh queries (~1 ms each). Raises
    CollisionCheckError (a RobotError) on bad input."""
    start = _clock.perf_counter()
    checker, queries, a, b, _ = _geometry(robot)
    sub = checker.configurations(q, max_motion)       # checks q and max_motion
    q = checker._trajectory(q)
    T = len(q)
    if time is not None:
        time = as_time(time, "time", T, CollisionCheckError) if T > 1 else as_array(time, "time", (1,), 0)
    max_motion = float(max_motion)
    tolerance = as_scalar(tolerance, "tolerance", 0.0, CollisionCheckError)
    geo = checker._geo
    K, P = len(sub.q), len(a)
    max_step = float(sub.step.max()) if sub.step.size else 0.0
    if P == 0:
        return SelfCollisionReport(geo.source, max_motion, math.inf, None, False, np.zeros(T, dtype=bool), K, 0,
                                   0, 0, max_step, math.inf, {"total": _clock.perf_counter() - start})
    R, t = checker._poses(sub.q)
    travel = checker._travel(q, sub)                               # (K, G)
    lower = _sphere_lower(geo, R, t, a, b)
    t_broad = _clock.perf_counter()
    if (queries.exact[a] | queries.exact[b]).any():
        pair_travel = travel[:, a] + travel[:, b]
    else:
        # every pair measured on hulls: the relative motion bound (tighter) narrows the search
        # without changing its result (every cell whose hull distance is below the target is
        # queried whatever the bounds, and only those are measured); an exact column's hull
        # distance would be a result of its own, so there the plain sum is kept
        pair_travel = _pair_travel(checker, q, sub, a, b)
    search = _Search(queries, R, t, a, b, lower, pair_travel, tolerance)
    search.run()
    states = search.settle_states(sub.support)
    kk, c = search.nearest
    index = float(sub.index[kk])
    ga, gb = int(a[c]), int(b[c])
    contact = Contact(geo.links[ga], geo.names[ga], geo.links[gb], index, time_at(index, time), search.best,
                      geo.names[gb])
    end = _clock.perf_counter()
    timings = {"broad_phase": t_broad - start, "search": end - t_broad, "total": end - start}
    return SelfCollisionReport(geo.source, max_motion, search.best, contact, search.best < 0.0, states, K, P,
                               search.count["hull"], search.count["exact"], max_step, search.target() - max_step,
                               timings)
