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

Residuals are vectorised numpy functions of many states at once; :class:`BoundaryFactorMaker`
adapts them to GTSAM as the planner's per-state factor maker
``maker(index, num_states, key) -> gtsam.CustomFactor``. The factors share one
``clamp.factors.evaluation.TrajectoryEvaluator`` per number of states: the first factor called
at new joint states reloads all support states and :class:`BoundaryFamily` computes every
residual and Jacobian in one vectorized kinematics call; the other factors return their rows.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import gtsam
import numpy as np

from clamp.factors.evaluation import ResidualFamily, Residuals, TrajectoryEvaluator
from clamp.keys import state_key

from .errors import InvalidArgumentError
from .validation import as_array, as_count, as_points, as_scalar

ANGLE_STEP = 1e-6       # [rad] central-difference step for the boundary slope fallback
_RHO_MIN = 1e-12        # [m] below this the position sits on the directrix (inside)


def section_indices(index: Any, num_states: int, num_sections: int) -> np.ndarray:
    """Cross-section index round(i / (T - 1) * (N - 1)) (...,) of support states i (...,) of T."""
    num_states = as_count(num_states, "num_states")
    i = np.asarray(index)
    if i.dtype.kind not in "iu" or (i.size and (i.min() < 0 or i.max() >= num_states)):
        raise InvalidArgumentError(
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
    gradient: np.ndarray
    rho: np.ndarray
    angle: np.ndarray
    section: np.ndarray


def boundary_distance(cylinder: Any, sections: Any, positions: Any) -> BoundaryDistance:
    """Distance outside cross-sections ``sections`` (T,) of positions (T,3) [m], with gradient."""
    p = as_points(positions, "positions")
    if p.ndim == 1:
        p = p[None]
    k = np.atleast_1d(np.asarray(sections))
    if p.ndim != 2 or k.shape != (len(p),):
        raise InvalidArgumentError(
            f"sections, positions: expected shapes (T,) and (T, 3), got {k.shape} and {p.shape}")
    frames = cylinder.frames[k]                                   # (T, 3, 3)
    normal, binormal = frames[:, 1], frames[:, 2]
    y = p - cylinder.directrix[k]
    a = np.einsum("ti,ti->t", y, normal)
    b = np.einsum("ti,ti->t", y, binormal)
    rho = np.hypot(a, b)
    angle = np.mod(np.arctan2(b, a), 2.0 * np.pi)
    radius = cylinder.radius(k, angle)
    slope = _radius_slope(cylinder, k, angle)
    safe = rho > _RHO_MIN
    inv = np.where(safe, 1.0 / np.where(safe, rho, 1.0), 0.0)
    d_rho = (a[:, None] * normal + b[:, None] * binormal) * inv[:, None]
    d_angle = (a[:, None] * binormal - b[:, None] * normal) * (inv**2)[:, None]
    gradient = d_rho - slope[:, None] * d_angle
    return BoundaryDistance(rho - radius, gradient, rho, angle, k)


def boundary_residuals(cylinder: Any, sections: Any, positions: Any, margin: float = 0.0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Hinge h = max(0, rho - r + margin) (T,) [m] and dh/dp (T,3) for positions (T,3)."""
    m = as_scalar(margin, "margin")
    dist = boundary_distance(cylinder, sections, positions)
    active = dist.distance + m > 0.0
    h = np.where(active, dist.distance + m, 0.0)
    return h, np.where(active[:, None], dist.gradient, 0.0)


def boundary_state_residuals(cylinder: Any, robot: Any, sections: Any, q: Any,
                             margin: float = 0.0, jacobians: bool = True
                             ) -> tuple[np.ndarray, np.ndarray | None]:
    """Hinge residuals (T,) [m] of joint configurations q (T,n) and Jacobians (T, 2n) w.r.t.
    theta = [q, qdot] (the velocity half is zero); None instead of Jacobians if not jacobians."""
    q = as_array(q, "q")
    if q.ndim != 2 or q.shape[1] != robot.n:
        raise InvalidArgumentError(f"q: expected shape (T, {robot.n}), got {q.shape}")
    kin = robot.ee_kinematics(q, None, jacobians=jacobians)
    h, dh_dp = boundary_residuals(cylinder, sections, kin.position, margin)
    if not jacobians:
        return h, None
    jac = np.zeros((len(q), 2 * robot.n))
    jac[:, : robot.n] = np.einsum("ti,tij->tj", dh_dp, kin.jacobian)
    return h, jac


class BoundaryFamily(ResidualFamily):
    """Boundary hinge of support states ``indices`` (F,) of ``num_states``, all in one call.

    Residuals (F, 1) [m] and Jacobians (F, 1, 2n) w.r.t. theta at the evaluator's states.
    """

    name = "tlgc_boundary"

    def __init__(self, cylinder: Any, indices: Any, num_states: int, margin: float) -> None:
        self.cylinder = cylinder
        self.indices = np.asarray(indices, dtype=np.intp)
        self.sections = section_indices(self.indices, num_states, len(cylinder.directrix))
        self.margin = float(margin)

    def compute(self, evaluator: TrajectoryEvaluator, jacobians: bool) -> Residuals:
        n = evaluator.robot.n
        h, jac = boundary_state_residuals(self.cylinder, evaluator.robot, self.sections,
                                          evaluator.theta[self.indices, :n], self.margin, jacobians)
        return Residuals(h[:, None], None if jac is None else (jac[:, None, :],))


def _boundary_error(cylinder: Any, robot: Any, section: int, margin: float,
                    this: gtsam.CustomFactor, values: gtsam.Values, H: list | None) -> np.ndarray:
    """GTSAM CustomFactor error function (1,) of one support state, evaluated on its own."""
    theta = values.atVector(this.keys()[0])
    h, jac = boundary_state_residuals(cylinder, robot, np.array([section]),
                                      theta[None, : robot.n], margin, H is not None)
    if H is not None:
        H[0] = jac
    return h


def _shared_boundary_error(evaluator: TrajectoryEvaluator, family: BoundaryFamily, row: int,
                           index: int, this: gtsam.CustomFactor, values: gtsam.Values,
                           H: list | None) -> np.ndarray:
    """GTSAM CustomFactor error function (1,): row ``row`` of the family's shared residuals.

    Values lacking some support state (not the planner's graph) cannot refill the shared
    cache; this state is then evaluated on its own.
    """
    try:
        evaluator.sync(values, (index,))
    except RuntimeError:                     # GTSAM: a support state's key is not in values
        return _boundary_error(family.cylinder, evaluator.robot, int(family.sections[row]),
                               family.margin, this, values, H)
    result = evaluator.residuals(family, H is not None)
    if H is not None:
        H[0] = result.jacobians[0][row]
    return result.error[row]


class BoundaryFactorMaker:
    """Per-state factor maker for ``clamp.plan(extra_factors=[...])``.

    ``maker(index, num_states, key)`` returns a 1-D ``gtsam.CustomFactor`` on theta_index with
    the boundary hinge residual (metres) and isotropic noise ``sigma`` [m]; ``margin`` [m]
    shrinks the allowed region (positive) or widens it (negative). ``states`` optionally
    restricts the factor to some support-state indices (others give None).

    With ``shared_evaluation`` (default) the factors on planner keys (``clamp.keys.state_key``)
    share one evaluator and :class:`BoundaryFamily` per ``num_states`` (see :meth:`shared`);
    otherwise, or for other keys, every factor runs its own kinematics call.
    """

    def __init__(self, cylinder: Any, robot: Any, margin: float = 0.0, sigma: float = 0.01,
                 states: Any = None, shared_evaluation: bool = True) -> None:
        for attr in ("directrix", "frames", "radius"):
            if not hasattr(cylinder, attr):
                raise InvalidArgumentError(
                    f"cylinder: expected a GeneralizedCylinder (missing .{attr}), got "
                    f"{type(cylinder).__name__}")
        if not hasattr(robot, "ee_kinematics") or not hasattr(robot, "n"):
            raise InvalidArgumentError(
                f"robot: expected a robots.Robot (with .n and .ee_kinematics), got {type(robot).__name__}")
        self.cylinder = cylinder
        self.robot = robot
        self.margin = as_scalar(margin, "margin")
        self.sigma = as_scalar(sigma, "sigma", minimum=1e-12)
        self.states = None if states is None else set(int(s) for s in np.atleast_1d(states))
        self.shared_evaluation = bool(shared_evaluation)
        self._noise = gtsam.noiseModel.Isotropic.Sigma(1, self.sigma)
        self._shared: dict[int, tuple[TrajectoryEvaluator, BoundaryFamily]] = {}

    def section(self, index: int, num_states: int) -> int:
        """Cross-section index matching support state ``index`` of ``num_states``."""
        return int(section_indices(np.asarray(index), num_states, len(self.cylinder.directrix)))

    def shared(self, num_states: int) -> tuple[TrajectoryEvaluator, BoundaryFamily]:
        """Evaluator and family shared by the factors of ``num_states`` states (made on first use)."""
        if num_states not in self._shared:
            as_count(num_states, "num_states")
            indices = np.arange(num_states)
            if self.states is not None:
                indices = indices[np.isin(indices, sorted(self.states))]
            self._shared[num_states] = (TrajectoryEvaluator(self.robot, num_states),
                                        BoundaryFamily(self.cylinder, indices, num_states, self.margin))
        return self._shared[num_states]

    def __call__(self, index: int, num_states: int, key: int) -> gtsam.CustomFactor | None:
        if self.states is not None and int(index) not in self.states:
            return None
        section = self.section(index, num_states)
        if self.shared_evaluation and key == state_key(int(index)):
            evaluator, family = self.shared(num_states)
            row = int(np.searchsorted(family.indices, int(index)))
            error = partial(_shared_boundary_error, evaluator, family, row, int(index))
        else:
            error = partial(_boundary_error, self.cylinder, self.robot, section, self.margin)
        return gtsam.CustomFactor(self._noise, gtsam.KeyVector([key]), error)
