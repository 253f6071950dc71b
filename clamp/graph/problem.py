"""The planning problem: factor families over T support states, plus any GTSAM factors of the caller.

One model, two faces (see docs/concepts.md#two-faces-gtsam-and-the-fast-solver):

- :meth:`PlanningProblem.graph` / :meth:`PlanningProblem.values` give a real
  ``gtsam.NonlinearFactorGraph`` and ``gtsam.Values`` (adapters from
  :mod:`clamp.graph.gtsam_adapter` plus the caller's factors) for GTSAM's optimizers,
  ``gtsam.Marginals`` and inspection;
- :meth:`PlanningProblem.error` and :meth:`PlanningProblem.normal_equations` evaluate the same
  objective on the (T, 2n) state array for the fast solver (:mod:`clamp.optim.solver`): the whitened
  rows of every family's kernel, accumulated into block-tridiagonal normal equations
  H = A^T A (diagonal blocks D (T, d, d), upper blocks E (T-1, d, d)) and g = -A^T b... i.e.
  the gradient side of H delta = g for the Gauss-Newton step. The two faces agree to round-off.

Caller factors ("foreign", any ``gtsam.NonlinearFactor`` on the planner's state keys) are
linearized by GTSAM itself (``factor.linearize``) at every fast-solver iteration and their
blocks added to the same system, which is possible when each connects one state or two
neighbouring states; a foreign factor on other keys or non-neighbouring states makes
:attr:`PlanningProblem.banded` False, and the planner then runs GTSAM's optimizer on the
graph instead (logged).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.factors.family import Family
from clamp.factors.states import StateWindow
from clamp.graph.keys import state_keys, states_to_values
from clamp.validation import as_array

if TYPE_CHECKING:       # the GTSAM face loads GTSAM when it is used: the fast solver never does
    import gtsam


@dataclass(frozen=True)
class NormalEquations:
    """Gauss-Newton system at a point: H delta = g with H = J^T J (whitened), g = -J^T e.

    D (T, d, d) diagonal blocks; E (T-1, d, d) upper blocks H[i, i+1]; g (T, d); error the
    graph error (0.5 sum of squared whitened residuals) at the point.
    """

    D: np.ndarray
    E: np.ndarray
    g: np.ndarray
    error: float


class PlanningProblem:
    """Families (and foreign GTSAM factors) over T support states of a robot with n joints.

    robot: robots.Robot; families: the factor families; foreign: caller factors on
    :func:`clamp.graph.keys.state_key` keys; initial (T, 2n) initial joint states.
    """

    def __init__(self, robot, num_states: int, families: Sequence[Family],
                 foreign: Sequence[gtsam.NonlinearFactor] = (), initial: np.ndarray | None = None):
        self.robot = robot
        self.num_states = int(num_states)
        self.dim = 2 * robot.n
        self.families = list(families)
        names = [f.name for f in self.families]
        if len(set(names)) != len(names):
            raise InvalidParameterError(f"families: names must be unique, got {names}")
        self.keys = list(state_keys(self.num_states))
        self.foreign = list(foreign)
        self._foreign_states = self._check_foreign()
        self.initial = initial
        self._window: StateWindow | None = None
        self._family_errors: tuple[np.ndarray, dict[str, float]] | None = None
        #: [the constant blocks of the linear families] (see _linear_hessian), computed on first
        #: use; a holder shared with the problems made by with_families with the same linear
        #: families (the same objects in the same order)
        self._constant: list = [None]
        self._by_kinematics = sorted(self.families, key=lambda f: f.kinematics)

    # ------------------------------------------------------------------------------ structure
    def _check_foreign(self) -> list[list[int]] | None:
        """State indices of every foreign factor, or None when one is not banded."""
        if not self.foreign:
            return []
        import gtsam
        position = {k: i for i, k in enumerate(self.keys)}
        out = []
        for k, factor in enumerate(self.foreign):
            unknown = [gtsam.DefaultKeyFormatter(key) for key in factor.keys()
                       if key not in position]
            if unknown:
                raise InvalidParameterError(
                    f"extra_factors[{k}]: uses keys {unknown} that are not planner states "
                    f"(clamp.graph.keys.state_key(0..{self.num_states - 1}))")
            states = sorted(position[key] for key in factor.keys())
            if len(states) > 2 or (len(states) == 2 and states[1] - states[0] != 1):
                return None
            out.append(states)
        return out

    @property
    def banded(self) -> bool:
        """Whether every factor connects one state or two neighbouring states (fast solver)."""
        return self._foreign_states is not None

    @property
    def rotation_reference(self) -> np.ndarray | None:
        """The mean rotations (T, 3, 3) of the family that reads the hand's rotation through a
        stiff learned chain (:attr:`clamp.factors.Family.stiff_rotation`; its ``rotations``,
        the chain's tangent points), None without one: the solver's correction then moves trial
        points onto the orientation states that chain reads, as predicted."""
        return next((f.rotations for f in self.families if f.stiff_rotation), None)

    def has(self, name: str) -> bool:
        """Whether a family is called ``name``."""
        return any(f.name == name for f in self.families)

    def with_families(self, families: Sequence[Family], initial: np.ndarray) -> "PlanningProblem":
        """The same robot, states and foreign factors with ``families`` instead, starting at
        ``initial`` (T, 2n)."""
        new = PlanningProblem(self.robot, self.num_states, families, self.foreign, initial)
        mine = [f for f in self.families if f.linear]
        theirs = [f for f in new.families if f.linear]
        if len(mine) == len(theirs) and all(a is b for a, b in zip(mine, theirs)):
            new._constant = self._constant          # the same linear blocks: computed once
        return new

    def family(self, name: str) -> Family:
        """The family called ``name``."""
        for f in self.families:
            if f.name == name:
                return f
        raise InvalidParameterError(f"family: unknown {name!r}; valid: "
                                    f"{', '.join(f.name for f in self.families)}")

    # ------------------------------------------------------------------------------ GTSAM face
    def graph(self) -> gtsam.NonlinearFactorGraph:
        """A new GTSAM graph: every family's factors (in family order), then the foreign ones."""
        import gtsam
        from clamp.graph.gtsam_adapter import SharedStates, gtsam_factors
        shared = SharedStates(self.robot, self.keys)
        graph = gtsam.NonlinearFactorGraph()
        for family in self.families:
            for factor in gtsam_factors(family, shared, self.dim):
                graph.add(factor)
        for factor in self.foreign:
            graph.add(factor)
        return graph

    def values(self, theta: np.ndarray | None = None) -> gtsam.Values:
        """GTSAM Values of joint states theta (T, 2n) (default: the initial trajectory)."""
        theta = self.initial if theta is None else as_array(theta, "theta", self.initial.shape)
        return states_to_values(theta, self.keys)

    # ------------------------------------------------------------------------------ fast face
    def window(self, theta: np.ndarray) -> StateWindow:
        """The window of all states at theta (T, 2n); the last one is kept for reuse."""
        if self._window is None or not (self._window.theta is theta or
                                        np.array_equal(self._window.theta, theta)):
            self._window = StateWindow(self.robot, theta)
        return self._window

    def _foreign_values(self, theta: np.ndarray, states: Sequence[int]) -> gtsam.Values:
        import gtsam
        values = gtsam.Values()
        for s in states:
            values.insert(self.keys[s], theta[s])
        return values

    def family_errors(self, theta: np.ndarray) -> dict[str, float]:
        """Error of every family (and "foreign" if any) at theta (T, 2n). The last answer is
        kept: the constrained solve's prior cost and the verdict ask it of the same optimum."""
        last = self._family_errors
        if last is not None and np.array_equal(last[0], theta):
            return dict(last[1])
        window = self.window(theta)
        out = {f.name: f.error(window) for f in self.families}
        if self.foreign:
            out["foreign"] = self._foreign_error(theta)
        self._family_errors = (np.array(theta, dtype=float), out)        # a copy: theta may change
        return dict(out)

    def _foreign_error(self, theta: np.ndarray) -> float:
        if self._foreign_states is None:
            values = self.values(theta)
            return float(sum(f.error(values) for f in self.foreign))
        return float(sum(f.error(self._foreign_values(theta, s))
                         for f, s in zip(self.foreign, self._foreign_states)))

    def error(self, theta: np.ndarray, bound: float = np.inf) -> float:
        """Graph error at theta (T, 2n); once the partial sum reaches ``bound`` the remaining
        families are skipped (cheapest first) and a value >= bound is returned."""
        total = self._foreign_error(theta) if self.foreign else 0.0
        window = self.window(theta)
        for family in self._by_kinematics:
            if total >= bound:
                break
            total += family.error(window)
        return total

    def normal_equations(self, theta: np.ndarray) -> NormalEquations:
        """Block-tridiagonal Gauss-Newton system at theta (T, 2n) (requires :attr:`banded`)."""
        if not self.banded:
            raise InvalidParameterError("extra_factors: a factor connects states that are not "
                                        "neighbours; use a GTSAM optimizer")
        T, d = self.num_states, self.dim
        window = self.window(theta)
        if self._constant[0] is None:
            self._constant[0] = self._linear_hessian(window)
        D, E, linear_jacobians = self._constant[0]
        D, E = D.copy(), E.copy()
        g = np.zeros((T, d))
        error = 0.0
        for family in self.families:
            lin = family.residual(window, np.arange(len(family)), not family.linear)
            if not len(lin.rows):
                continue
            e = family.whiten(lin.rows, lin.error)
            J = linear_jacobians[family.name] if family.linear else \
                family.whiten(lin.rows, lin.jacobian)
            error += 0.5 * float(np.sum(e * e))
            Jt = np.swapaxes(J, 1, 2)
            gf = -(Jt @ e[:, :, None])[:, :, 0]
            first = family.first[lin.rows]
            H = None if family.linear else Jt @ J
            _scatter(D, E, g, first, family.arity, d, H, gf, family.distinct)
        for factor, states in zip(self.foreign, self._foreign_states):
            values = self._foreign_values(theta, states)
            error += float(factor.error(values))
            A, b = factor.linearize(values).jacobian()
            order = np.argsort([self.keys.index(k) for k in factor.keys()])
            A = np.concatenate([A[:, k * d:(k + 1) * d] for k in order], axis=1)
            _scatter(D, E, g, np.array([states[0]]), len(states), d, (A.T @ A)[None],
                     (A.T @ b)[None], True)
        return NormalEquations(D, E, g, error)

    def _linear_hessian(self, window: StateWindow
                        ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Constant blocks of J^T J of the linear families and their whitened Jacobians
        (F, m, arity d) by family name (computed once; a linear kernel returns every row)."""
        T, d = self.num_states, self.dim
        D, E = np.zeros((T, d, d)), np.zeros((T - 1, d, d))
        g = np.zeros((T, d))
        jacobians = {}
        for family in self.families:
            if not family.linear:
                continue
            rows = np.arange(len(family))
            lin = family.residual(window, rows, True)
            J = np.ascontiguousarray(family.whiten(lin.rows, lin.jacobian))
            jacobians[family.name] = J
            H = np.swapaxes(J, 1, 2) @ J
            _scatter(D, E, g, family.first[lin.rows], family.arity, d, H,
                     np.zeros(H.shape[:2]), family.distinct)
        return D, E, jacobians


def _scatter(D: np.ndarray, E: np.ndarray, g: np.ndarray, first: np.ndarray, arity: int, d: int,
             H: np.ndarray | None, gf: np.ndarray, distinct: bool) -> None:
    """Add factor blocks H (F, k d, k d) (None: already in D, E) and gradients gf (F, k d) of
    factors on states first .. first + k - 1 (k = arity) into the block-tridiagonal system."""
    if distinct and len(first) and first[-1] - first[0] == len(first) - 1:
        first = slice(int(first[0]), int(first[-1]) + 1)      # consecutive states: a view
        shifted = slice(first.start + 1, first.stop + 1)
    else:
        shifted = first + 1

    def add(a: np.ndarray, i, v: np.ndarray) -> None:
        if distinct:
            a[i] += v
        else:
            np.add.at(a, i, v)
    if arity == 1:
        add(g, first, gf)
        if H is not None:
            add(D, first, H)
        return
    add(g, first, gf[:, :d])
    add(g, shifted, gf[:, d:])
    if H is not None:
        add(D, first, H[:, :d, :d])
        add(D, shifted, H[:, d:, d:])
        add(E, first, H[:, :d, d:])
