"""The one definition of a factor family, from which every view of the problem is derived.

A family is F factors of the same kind. Factor f connects the ``arity`` consecutive support
states ``first[f] .. first[f] + arity - 1`` (arity 1: unary; 2: a step i -> i+1), has a
residual e_f (m,) and Gaussian noise given by its square-root information R_f (m, m), so its
error is 0.5 ||R_f e_f||^2 (GTSAM's convention). A subclass implements one vectorized kernel,
:meth:`Family.residual`, returning the residuals and analytic Jacobians of any set of its
factors at a :class:`~clamp.factors.states.StateWindow`. From it come:

- the fast solver's stacked whitened system (:mod:`clamp.graph.problem`),
- the per-factor GTSAM adapters (:mod:`clamp.graph.gtsam_adapter`), which call the same
  kernel for one factor,
- the errors reported per family.

Weighting lives only in the noise (the square-root information); kernels return unwhitened
residuals.

A family's ``role`` says how the solve treats it: ``"cost"`` (a term of the posterior) or
``"constraint"``: a hinge family whose residual components are e = max(0, g(theta) + s) for a
constraint g(theta) <= 0 (a sphere's reach into an obstacle, a joint beyond its limit) and a
shift s >= 0 (:attr:`Family.shift`, zero unless set), which the augmented-Lagrangian solve of
:mod:`clamp.optim.constrained` sets to lambda / mu (the multiplier over the penalty weight mu, the
squared whitening). A constraint family implements :meth:`Family.constraint` (g and its
Jacobian) instead of :meth:`Family.residual`: the base class adds the shift and takes the hinge,
in one place for every constraint family. A kernel may leave out factors whose residual and
Jacobian are exactly zero (inactive hinges): :class:`Linearization` lists the rows it describes.

A constraint is declared once, in its family's class:

- ``role = "constraint"`` and the kernel (:meth:`Family.constraint`);
- how its violation is measured: :meth:`Family.check` (context, theta) ->
  :class:`ConstraintCheck` (violated or not, by how much in its units, the reasons in words and
  the report to reuse), on whatever the verdict trusts (the real collision geometry, the
  limits, the tool's angle); ``check_rank`` orders the checks (the order of the verdict's
  reasons), ``decisive`` stops the judgement at a violation (a colliding plan is not checked
  further), ``only_if_clear`` runs a check only when every earlier one holds;
- whether it joins the solve lazily: ``lazy = True`` and :meth:`Family.joining` (context) -> the
  family, made when its check first fails (its check is then a classmethod: it runs before the
  family exists). Every such class defined in the :mod:`clamp.factors` package is found there
  (:func:`clamp.factors.lazy_families`), with no list to register it in.

The planner's judge (:mod:`clamp.planning.pipeline`) runs the checks of the constraint families
a problem holds and of the lazy ones, each once per optimum; the verdict reuses the final
plan's records (:mod:`clamp.planning.verdict`).
"""
from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.validation import as_array, as_count, as_covariance, as_indices, cholesky

from .states import StateWindow

if TYPE_CHECKING:       # the GTSAM face (noise_model) loads GTSAM when it is used
    import gtsam


@dataclass(frozen=True)
class Linearization:
    """Residuals of some factors of a family at one window of states.

    rows (F',) factor indices described (any factor of the request not listed has zero
    residual and zero Jacobian); error (F', m) unwhitened residuals; jacobian (F', m, arity 2n)
    d e / d [theta_first, ..., theta_first+arity-1], or None when not requested.
    """

    rows: np.ndarray
    error: np.ndarray
    jacobian: np.ndarray | None


@dataclass(frozen=True)
class Constraint:
    """Unshifted constraint values of some factors of a constraint family (the hinge's g).

    value (R, m): g of the R factors requested (-inf where a hinge cannot be active, e.g. an
    infinite joint limit); jacobian(states, active) -> (A, m, arity 2n): d g / d [theta_first,
    ...] of the requested factors ``states`` (A,) (indices into the R), zero where ``active``
    (A, m) is False; None when Jacobians were not requested.
    """

    value: np.ndarray
    jacobian: Callable[[np.ndarray, np.ndarray], np.ndarray] | None


@dataclass(frozen=True)
class ConstraintCheck:
    """What one constraint's check says of a plan: ``name`` the family's; ``violated``;
    ``amount`` how far beyond the constraint, in the family's units (0.0: met); ``reasons`` the
    verdict's reasons in words (empty when met); ``report`` the check's own report, reused by
    the verdict (e.g. a collision report); ``accepted`` False when the plan is refused without a
    constraint to tighten (the skill not completed: another start is needed); ``clearance`` [m]
    the least real-geometry clearance to the obstacles when the check measures it (inf
    otherwise; the solve ranks infeasible optima by it); ``listed``: ``amount`` is one of
    ``PlanResult.violations`` (False: the result reports the check's figures elsewhere)."""

    name: str
    violated: bool
    amount: float = 0.0
    reasons: tuple[str, ...] = ()
    report: Any = None
    accepted: bool = True
    clearance: float = math.inf
    listed: bool = True

    @property
    def reason(self) -> str | None:
        """The first reason, or None when the constraint is met."""
        return self.reasons[0] if self.reasons else None


#: how the verdict's reasons name a support state's time: on the skill's clock (the
#: demonstrations' time times the time scale), not the executable trajectory's
SKILL_CLOCK = "skill time t"


@dataclass(frozen=True)
class CheckContext:
    """What a check (and a lazy family's :meth:`Family.joining`) may use, made by the planner
    for one model: ``robot``; ``scene`` (None: no obstacles); ``prior`` the learned workspace
    prior and ``reference`` it conditioned on the plan's targets (where the skill goes);
    ``config`` the PlannerConfig; ``time`` (T,) [s] of the support states; ``num_states`` T;
    ``goal_given``: the caller gave a goal; ``obstacles``: the problem holds obstacle hinges;
    ``families`` the problem's families as built; ``clearance(q)`` the real-geometry check of
    joint positions q (T, n) against the scene (a robots.collision_check.CollisionReport, None
    without obstacles); ``pusher(path)`` -> describe(state) naming what pushed an end-effector
    path (T, 3) off the skill there (or None); ``final``: the check is the final plan's verdict
    (True) rather than the solve's judgement of a candidate."""

    robot: Any
    scene: Any
    prior: Any
    reference: Any
    config: Any
    time: np.ndarray
    num_states: int
    goal_given: bool
    obstacles: bool
    families: tuple = ()
    clearance: Callable[[np.ndarray], Any] = lambda q: None
    pusher: Callable[[np.ndarray], Any] = lambda path: None
    final: bool = False


def targets_by_state(indices: Sequence[int], targets: np.ndarray, sigmas: Sequence[float],
                     shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The targets of a one-state family ordered by state: indices (K,), ``targets`` (K, *shape)
    and ``sigmas`` (K,), each checked, sorted by index (stable)."""
    indices = as_indices(indices, "indices")
    order = np.argsort(indices, kind="stable")
    targets = as_array(targets, "targets", (len(order), *shape))[order]
    sigmas = as_array(sigmas, "sigmas", (len(order),))
    return indices[order], targets, sigmas[order]


def square_root_information(cov: np.ndarray) -> np.ndarray:
    """Upper-triangular R (..., m, m) with R^T R = cov^-1, for covariances (..., m, m)."""
    info = np.linalg.inv(cov)
    info = 0.5 * (info + np.swapaxes(info, -1, -2))
    lower = np.linalg.cholesky(info)
    return np.swapaxes(lower, -1, -2)


def covariance_root(cov: object, name: str, shape: tuple) -> np.ndarray:
    """:func:`square_root_information` of covariances ``cov`` of ``shape``, checked: finite and
    symmetric, and positive definite (InvalidParameterError naming ``name``, the worst matrix
    and its smallest eigenvalue otherwise: found by the factorisation itself, at no extra cost)."""
    cov = as_covariance(cov, name, shape, positive_definite=False)
    try:
        return square_root_information(cov)
    except np.linalg.LinAlgError:
        cholesky(cov, name)                       # raises, naming the worst matrix
        raise InvalidParameterError(f"{name}: covariances too ill-conditioned to invert") \
            from None


class Family:
    """Base class of a factor family (see the module docstring).

    first (F,) first support state of every factor; dim m residual size; sigma: isotropic noise
    standard deviation (scalar, or (F,) per factor) in the residual's units, or
    sqrt_information (F, m, m) / (m, m) for correlated noise (exactly one of the two).
    Subclasses set ``name``, ``arity`` and ``kinematics`` (the kinematics tier its kernel
    needs: 0 none, 1 end-effector, 2 collision spheres; a problem's error sums the cheapest
    tiers first) and implement :meth:`residual`; ``linear = True`` declares
    a residual affine in theta (constant Jacobian, every requested row returned), whose
    Jacobian and J^T J the fast solver then assembles once.
    """

    name: str = "family"
    arity: int = 1
    #: kinematics its kernel needs: 0 none (joint space), 1 end-effector, 2 collision spheres
    kinematics: int = 1
    linear: bool = False
    #: "cost" or "constraint" (a hinge family with a shift; see the module docstring)
    role: str = "cost"
    #: (F, m) shifts s >= 0 of a constraint family's hinges (None: all zero)
    shift: np.ndarray | None = None
    #: the judge checks it from the start and the family joins the solve only when its check
    #: first fails (:meth:`joining`; its :meth:`check` is then a classmethod)
    lazy: bool = False
    #: order of the checks (lower first; the problem's order among equals): the order of the
    #: verdict's reasons
    check_rank: int = 30
    #: a violation ends the judgement (nothing after it is checked: a colliding plan)
    decisive: bool = False
    #: checked only when every check before it holds (the skill: a plan that meets the rest)
    only_if_clear: bool = False
    #: the verdict checks every plan with it, whether or not the problem holds the family (its
    #: :meth:`check` is a classmethod); the solve's judge only when the problem holds it
    always_checked: bool = False
    #: a constraint family violated by at most this (its check's ``amount``, in its units) is
    #: a hair short of passing: the constrained solve keeps updating the start that came this
    #: near (``polish_rounds``; 0.0: never; see docs/decisions.md#polish-rounds)
    near: float = 0.0
    #: the family holds the hand's rotation through a stiff learned chain (a pose prior's):
    #: the solver's correction moves trial points onto the rotation its linear model predicts,
    #: as it does onto the workspace states (:mod:`clamp.optim.solver`)
    stiff_rotation: bool = False

    def relaxed(self, floor: float) -> "Family | None":
        """A copy whose hinges start nearer the constraint (a smaller safety margin, never
        below ``floor`` in its units), or None when it has none to give: the constrained solve
        relaxes a constraint that holds while another fails against it (see
        docs/decisions.md#relaxed-margins-and-active-multipliers)."""
        return None

    def widened(self, amount: float) -> "Family | None":
        """A copy whose hinges hold a wider safety margin, by about ``amount`` (the check's
        violation, in its units), or None when it has none: the constrained solve widens a
        constraint its check finds violated where none of its hinges is (the check measures
        what the hinges do not see, e.g. the collision geometry between support states; see
        docs/decisions.md#widened-margins)."""
        return None

    def __init__(self, first: np.ndarray, dim: int, sigma: float | np.ndarray | None = None,
                 sqrt_information: np.ndarray | None = None):
        self.first = as_indices(first, f"{self.name} indices")
        self.dim = as_count(dim, f"{self.name} dim")
        F = len(self.first)
        if (sigma is None) == (sqrt_information is None):
            raise InvalidParameterError(f"{self.name}: give exactly one of sigma and "
                                        "sqrt_information")
        if sigma is not None:
            s = as_array(sigma, f"{self.name} sigma", (F,) if np.ndim(sigma) else ())
            if np.any(s <= 0):
                raise InvalidParameterError(f"{self.name} sigma: expected positive finite "
                                            f"values, got {np.asarray(sigma)!r:.80}")
            #: whitening weights (F,) (isotropic) or (F, m, m) (correlated)
            self.whitening = 1.0 / np.broadcast_to(s, (F,))
        else:
            R = as_array(sqrt_information, f"{self.name} sqrt_information",
                         (F, self.dim, self.dim) if np.ndim(sqrt_information) == 3
                         else (self.dim, self.dim))
            self.whitening = np.ascontiguousarray(np.broadcast_to(R, (F, self.dim, self.dim)))
        #: every factor on its own first state: direct (not accumulating) scatter is safe
        self.distinct = bool(F <= 1 or np.all(np.diff(self.first) > 0))

    def __len__(self) -> int:
        return len(self.first)

    def reweighted(self, factor: float) -> "Family":
        """A copy of this family with every noise sigma divided by ``factor`` (> 0; the
        whitening multiplied by it), everything else shared: e.g. a stiffer hinge."""
        if not factor > 0.0 or not np.isfinite(factor):
            raise InvalidParameterError(f"factor: expected a positive finite number, got "
                                        f"{factor!r}")
        new = copy.copy(self)
        new.whitening = self.whitening * factor
        return new

    def with_shift(self, shift: np.ndarray) -> "Family":
        """A copy of this constraint family with hinge shifts ``shift`` (F, m) >= 0 (see the
        module docstring), everything else shared."""
        if self.role != "constraint":
            raise InvalidParameterError(f"{self.name}: only a constraint family has hinge "
                                        f"shifts (its role is {self.role!r})")
        shift = as_array(shift, f"{self.name} shift", (len(self), self.dim))
        if np.any(shift < 0):
            raise InvalidParameterError(f"{self.name} shift: expected values >= 0, got "
                                        f"{float(shift.min())}")
        new = copy.copy(self)
        new.shift = None if not np.any(shift) else shift
        return new

    def offset(self, rows: np.ndarray) -> np.ndarray | float:
        """The shifts (F', m) of factors ``rows`` to add to their hinges before the max(0, .)
        (0.0 when none is set)."""
        return 0.0 if self.shift is None else self.shift[rows]

    @property
    def isotropic(self) -> bool:
        """Whether every factor's noise is isotropic (whitening is a per-factor weight)."""
        return self.whitening.ndim == 1

    def residual(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Linearization:
        """Residuals (and Jacobians) of factors ``rows`` at ``window`` (which holds their states).

        A cost family implements it. A constraint family's is the hinge of its
        :meth:`constraint`, made here: e = max(0, g + s) with the shifts s (the one place they
        are applied), factors with no active component left out, the Jacobian of g where a
        component is active (zero elsewhere)."""
        if self.role != "constraint":
            raise NotImplementedError(f"{type(self).__name__}: a cost family implements residual")
        g = self.constraint(window, rows, jacobians)
        hinge = g.value + self.offset(rows)
        active = hinge > 0.0
        states = np.flatnonzero(np.any(active, axis=1))
        error = np.where(active[states], hinge[states], 0.0)
        if not jacobians:
            return Linearization(rows[states], error, None)
        if not len(states):
            return Linearization(rows[states], error,
                                 np.zeros((0, self.dim, self.arity * window.theta.shape[1])))
        return Linearization(rows[states], error, g.jacobian(states, active[states]))

    def for_plan(self, num_states: int, robot: Any) -> "Family":
        """This family for a plan of ``num_states`` support states of ``robot``: itself, or for
        one made without them (e.g. ``TablePlaneFamily(height=0.1)`` in
        ``clamp.plan(extra_factors=...)``) the family over that plan's states and robot."""
        return self

    def for_reference(self) -> "Family | None":
        """This family as it acts on the hand's path, for the verdict's reference of a plan it
        is an extra factor of (:func:`clamp.planning.reference.skill_reference`: where the
        skill goes under the caller's families), or None (the default): it does not change
        where the hand goes (an orientation window), or needs more of the arm than the hand's
        workspace state. A family whose kernel reads only ``window.workspace()`` (the hand's
        position and velocity) may return itself: it is then evaluated on the reference's
        states, the hand's own (:class:`clamp.planning.reference.HandPoint`)."""
        return None

    def check(self, context: CheckContext, theta: np.ndarray) -> ConstraintCheck | None:
        """The constraint's own check of the plan theta (T, 2n) (see the module docstring);
        None: nothing to check (a cost family, or the check does not apply: no obstacles)."""
        return None

    @classmethod
    def for_verdict(cls, context: CheckContext, theta: np.ndarray,
                    record: ConstraintCheck) -> ConstraintCheck:
        """The final plan's record from the solve's ``record`` of it: what the verdict adds
        (e.g. the skill's score), nothing by default."""
        return record

    @classmethod
    def joining(cls, context: CheckContext) -> "Family":
        """A lazy family as it joins the solve, made from the planning context."""
        raise NotImplementedError(f"{cls.__name__} is not a lazy family")

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        """A constraint family's unshifted g of factors ``rows`` at ``window`` (see
        :class:`Constraint`): the hinge, shift and activity are :meth:`residual`'s. A kernel may
        read the shifts (:meth:`offset`) to skip work no active hinge needs, never add them."""
        raise NotImplementedError

    def whiten(self, rows: np.ndarray, values: np.ndarray) -> np.ndarray:
        """R_f values_f for residuals (F', m) or Jacobians (F', m, c) of factors ``rows``."""
        w = self.whitening[rows]
        if w.ndim == 1:
            return w.reshape((-1,) + (1,) * (values.ndim - 1)) * values
        if values.ndim == 2:
            return np.einsum("fij,fj->fi", w, values)
        return w @ values

    def error(self, window: StateWindow, rows: np.ndarray | None = None) -> float:
        """0.5 sum of squared whitened residuals of factors ``rows`` (all by default)."""
        rows = np.arange(len(self)) if rows is None else rows
        lin = self.residual(window, rows, jacobians=False)
        white = self.whiten(lin.rows, lin.error)
        return 0.5 * float(np.sum(white * white))

    def noise_model(self, row: int) -> gtsam.noiseModel.Base:
        """GTSAM noise model of factor ``row`` (isotropic or Gaussian square-root information)."""
        import gtsam
        w = self.whitening[row]
        if np.ndim(w) == 0:
            return gtsam.noiseModel.Isotropic.Sigma(self.dim, 1.0 / float(w))
        return gtsam.noiseModel.Gaussian.SqrtInformation(np.asarray(w))

    def states(self, row: int) -> range:
        """Support-state indices factor ``row`` connects, in key order."""
        start = int(self.first[row])
        return range(start, start + self.arity)
