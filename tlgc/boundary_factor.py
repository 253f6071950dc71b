"""The TLGC boundary factor for the CLAMP planner: keep the end effector inside the cylinder.

For support state i of T (normalised index s = i / (T - 1)) the matching cross-section is
k = round(s (N - 1)). The end-effector position p = fk(q_i) is expressed in that section's
frame: y = p - c_k, a = y . normal_k, b = y . binormal_k (the offset along the tangent is
ignored: the position is projected onto the normal plane), rho = sqrt(a^2 + b^2),
angle = atan2(b, a). The residual, in metres, is the hinge

    h = max(0, rho - r_k(angle) + margin),

zero inside the boundary shrunk by ``margin`` and growing with the distance outside it. Its
gradient with respect to p is d rho/dp - r_k'(angle) d angle/dp with
d rho/dp = (a n + b b)/rho and d angle/dp = (a b - b n)/rho^2, chained with the end-effector
position Jacobian to the joint state theta = [q, qdot] (velocity columns are zero).

The slope r_k'(angle) of the boundary comes from the cylinder's ``radius_derivative`` when it
has one, otherwise from a central difference of ``radius`` with a 1e-6 rad step (the shape
function only; everything else is analytic).

Residuals are vectorised numpy functions of many states at once; :class:`BoundaryFamily` is
the CLAMP factor family built on them (fast solver and GTSAM graph alike).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from clamp.factors import Family, Linearization, StateWindow

from .errors import TLGCArgumentError
from .validation import as_count, as_indices, as_points, as_scalar

ANGLE_STEP = 1e-6       # [rad] central-difference step for the boundary slope fallback
_RHO_MIN = 1e-12        # [m] below this the position sits on the directrix (inside)


def section_indices(index: Any, num_states: int, num_sections: int) -> np.ndarray:
    """Cross-section index round(i / (T - 1) * (N - 1)) (...,) of support states i (...,) of T."""
    num_states = as_count(num_states, "num_states")
    i = np.asarray(index)
    if i.dtype.kind not in "iu" or (i.size and (i.min() < 0 or i.max() >= num_states)):
        raise TLGCArgumentError(
            f"index: expected integers in [0, {num_states}), got {np.asarray(index)!r}")
    if num_states == 1:
        return np.zeros(i.shape, dtype=np.intp)
    return np.rint(i / (num_states - 1) * (num_sections - 1)).astype(np.intp)


def _radius_slope(cylinder: Any, sections: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """d r_k / d angle (...,) [m/rad] of the boundary at ``angle``."""
    exact = getattr(cylinder, "radius_derivative", None)
    if exact is not None:
        return np.asarray(exact(sections, angle), dtype=float)
    plus = cylinder.radius(sections, angle + ANGLE_STEP)
    minus = cylinder.radius(sections, angle - ANGLE_STEP)
    return (plus - minus) / (2.0 * ANGLE_STEP)


@dataclass(frozen=True)
class BoundaryDistance:
    """Signed distance outside the boundary in the normal plane, per state.

    ``distance`` (T,) [m] = rho - r_k(angle) (negative inside), ``gradient`` (T,3) its
    derivative with respect to the position, ``rho``, ``angle`` (T,), ``section`` (T,).
    """

    distance: np.ndarray
    gradient: np.ndarray | None
    rho: np.ndarray
    angle: np.ndarray
    section: np.ndarray


def boundary_distance(cylinder: Any, sections: Any, positions: Any) -> BoundaryDistance:
    """Distance outside cross-sections ``sections`` (T,) of positions (T,3) [m], with gradient."""
    p = as_points(positions, "positions")
    if p.ndim == 1:
        p = p[None]
    k = as_indices(sections, "sections")
    if p.ndim != 2 or k.shape != (len(p),):
        raise TLGCArgumentError(
            f"sections, positions: expected shapes (T,) and (T, 3), got {k.shape} and {p.shape}")
    N = len(cylinder.directrix)
    if k.size and k.max() >= N:
        raise TLGCArgumentError(f"sections: expected cross-section indices in [0, {N}), got "
                                   f"{int(k.max())}")
    return _distance(cylinder, k, p, gradient=True)


def _distance(cylinder: Any, k: np.ndarray, p: np.ndarray, gradient: bool) -> BoundaryDistance:
    """:func:`boundary_distance` of checked sections k (T,) and positions p (T, 3); the
    gradient (and the boundary's slope it needs) only when ``gradient``, else None."""
    frames = cylinder.frames[k]                                   # (T, 3, 3)
    normal, binormal = frames[:, 1], frames[:, 2]
    y = p - cylinder.directrix[k]
    a = np.einsum("ti,ti->t", y, normal)
    b = np.einsum("ti,ti->t", y, binormal)
    rho = np.hypot(a, b)
    angle = np.mod(np.arctan2(b, a), 2.0 * np.pi)
    radius = cylinder.radius(k, angle)
    grad = None
    if gradient:
        slope = _radius_slope(cylinder, k, angle)
        safe = rho > _RHO_MIN
        inv = np.where(safe, 1.0 / np.where(safe, rho, 1.0), 0.0)
        d_rho = (a[:, None] * normal + b[:, None] * binormal) * inv[:, None]
        d_angle = (a[:, None] * binormal - b[:, None] * normal) * (inv**2)[:, None]
        grad = d_rho - slope[:, None] * d_angle
    return BoundaryDistance(rho - radius, grad, rho, angle, k)


def boundary_residuals(cylinder: Any, sections: Any, positions: Any, margin: float = 0.0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Hinge h = max(0, rho - r + margin) (T,) [m] and dh/dp (T,3) for positions (T,3)."""
    m = as_scalar(margin, "margin")
    dist = boundary_distance(cylinder, sections, positions)
    active = dist.distance + m > 0.0
    h = np.where(active, dist.distance + m, 0.0)
    return h, np.where(active[:, None], dist.gradient, 0.0)


class BoundaryFamily(Family):
    """The boundary hinge as a CLAMP factor family: one factor per support state in ``states``
    (default all ``num_states``), residual (1,) [m], isotropic noise ``sigma`` [m]; ``margin``
    [m] shrinks the allowed region (positive) or widens it (negative).

    Pass it in ``clamp.plan(extra_factors=[BoundaryFamily(cylinder, T)])``: it is on the fast
    solver's path like the planner's own families and shares their end-effector kinematics
    (:meth:`clamp.factors.StateWindow.workspace`); ``problem.graph()`` gets one GTSAM factor
    per state from the same kernel.
    """

    name = "tlgc_boundary"
    arity = 1
    kinematics = 1

    def __init__(self, cylinder: Any, num_states: int, margin: float = 0.0,
                 sigma: float = 0.01, states: Any = None) -> None:
        for attr in ("directrix", "frames", "radius"):
            if not hasattr(cylinder, attr):
                raise TLGCArgumentError(
                    f"cylinder: expected a GeneralizedCylinder (missing .{attr}), got "
                    f"{type(cylinder).__name__}")
        num_states = as_count(num_states, "num_states")
        indices = np.arange(num_states)
        if states is not None:
            chosen = np.unique(np.asarray(states))
            if chosen.dtype.kind not in "iu":
                raise TLGCArgumentError(f"states: expected support-state indices, got {states!r}")
            indices = indices[np.isin(indices, chosen)]
        self.cylinder = cylinder
        self.sections = section_indices(indices, num_states, len(cylinder.directrix))
        self.margin = as_scalar(margin, "margin")
        super().__init__(indices, 1, sigma=as_scalar(sigma, "sigma", minimum=1e-12))

    def for_reference(self) -> "BoundaryFamily":
        """Itself: the hinge reads only the hand's position (``window.workspace()``), so the
        verdict judges a plan with it against where the skill goes inside the cylinder
        (:func:`clamp.planning.reference.skill_reference`)."""
        return self

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        """The hinge of the active factors among ``rows`` (inactive ones are exactly zero and
        left out); positions come from the window's kinematics, so no input checks here."""
        x, dx = window.workspace()
        i = window.local(self.first[rows])
        outside = _distance(self.cylinder, self.sections[rows], x[i, :3], False).distance \
            + self.margin
        active = outside > 0.0
        rows, i = rows[active], i[active]
        h = outside[active][:, None]
        jac = None
        if jacobians:
            gradient = _distance(self.cylinder, self.sections[rows], x[i, :3], True).gradient
            jac = np.einsum("ti,tij->tj", gradient, dx[i, :3])[:, None, :]
        return Linearization(rows, h, jac)
