"""Graph error and linearization of the planner's factor families without per-factor calls.

GTSAM evaluates a NonlinearFactorGraph by calling every Python factor (~750 round trips per
linearization and ~1000 per error for a 250-state plan). :class:`VectorizedGraph` splits a graph
into the factors made by :func:`clamp.factors.evaluation.custom_factors` on one
:class:`~clamp.factors.evaluation.TrajectoryEvaluator` (recorded in ``evaluator.blocks``) and
the rest (pure C++ linear factors, callers' extra factors), which GTSAM keeps handling.

For the families, everything comes from one vectorized residual call per family:
error = 0.5 sum ||R_f e_f||^2 (R_f the factor's square-root information), exactly GTSAM's
Gaussian-noise error. The linearization is the whitened system A_fk = R_f de_f/dtheta_k,
b_f = -R_f e_f that GTSAM builds per factor, with the rows of all factors on the same pair of
consecutive states (i, i+1) stacked into one JacobianFactor (unary factors of state i < T-1
joined to the pair (i, i+1) with a zero block for i+1 when the graph has factors on that pair,
else stacked into one unary factor; those of the last state into one unary factor). Stacking rows of a least-squares system leaves it unchanged (same A^T A and A^T b,
same error for every delta), and ~T factors instead of ~750 make building and eliminating it
cheaper; rows that are entirely zero (inactive obstacle and joint-limit hinges: most of them)
are left out, which shortens the QR elimination several-fold. Factors of other shapes (non-consecutive pairs, more keys) are emitted one by one.

:meth:`VectorizedGraph.normal_equations` returns the same system as banded normal equations
(H = A^T A block-tridiagonal, g = A^T b), formed from the stacked rows with batched products
and from the other factors' constant Hessian when they are all linear (the joint GP prior),
for :func:`clamp.levenberg_marquardt.levenberg_marquardt`'s ``solver="banded"``.
"""
from __future__ import annotations

from collections import defaultdict

import gtsam
import numpy as np

from clamp.factors.evaluation import FamilyBlock, TrajectoryEvaluator
from clamp.keys import values_to_states


def _nonzero_rows(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of all groups (A (G, M, c), b (G, M)) that are not entirely zero, concatenated
    group after group (A (K, c), b (K,)), and each group's row offsets (G + 1,) into them.

    Zero rows (inactive hinges, absent factors of a stacked family) add nothing to the
    least-squares system but cost the QR elimination time. A group without nonzero rows keeps
    its first row, so that every group keeps its keys.
    """
    keep = np.any(A != 0.0, axis=2) | (b != 0.0)
    keep[:, 0] |= ~np.any(keep, axis=1)
    offsets = np.concatenate([[0], np.cumsum(np.count_nonzero(keep, axis=1))])
    return A[keep], b[keep], offsets


class VectorizedGraph:
    """Error and linearization of ``graph`` equal to GTSAM's, computed per family in numpy.

    graph: a NonlinearFactorGraph whose factors are the evaluator's adapters (any subset, in any
    order, repeats allowed) and any other factors (evaluated by GTSAM).
    """

    def __init__(self, graph: gtsam.NonlinearFactorGraph, evaluator: TrajectoryEvaluator):
        self.graph = graph
        self.evaluator = evaluator
        lookup = {id(f): (b, row) for b, block in enumerate(evaluator.blocks)
                  for row, f in enumerate(block.factors)}
        rows: dict[int, list[int]] = defaultdict(list)
        self.rest = gtsam.NonlinearFactorGraph()
        for i in range(graph.size()):
            factor = graph.at(i)
            hit = lookup.get(id(factor))
            if hit is None:
                self.rest.add(factor)
            else:
                rows[hit[0]].append(hit[1])
        self.parts: list[tuple[FamilyBlock, np.ndarray, np.ndarray]] = []
        by_cost = sorted(rows, key=lambda b: (getattr(evaluator.blocks[b].family, "cost", 1), b))
        for b in by_cost:
            r = rows[b]
            block, r = evaluator.blocks[b], np.array(r, dtype=int)
            R = block.sqrt_information[r]
            diagonal = np.einsum("fii->fi", R)
            if np.array_equal(R, diagonal[:, :, None] * np.eye(R.shape[1])):
                R = diagonal  # isotropic / diagonal noise: whiten by scaling rows
            self.parts.append((block, r, R))
        self.num_vectorized = sum(len(r) for _, r, _ in self.parts)
        self._unit: dict[int, gtsam.noiseModel.Base] = {}
        self._rest_blocks: tuple | None = None  # see _rest_hessian; () = not banded
        self._band: tuple | None = None

    @property
    def keys(self) -> list[int]:
        """The state keys, in the order of :meth:`normal_equations`."""
        return self.evaluator.keys

    # ------------------------------------------------------------------------------ states
    def _load(self, values: gtsam.Values) -> None:
        self.evaluator.set_states(values_to_states(values, self.evaluator.keys))

    def _whitened(self, block: FamilyBlock, rows: np.ndarray, R: np.ndarray, jacobians: bool):
        """Whitened errors (F, m) and Jacobians [(F, m, 2n)] of ``rows``; R (F, m, m) or its
        diagonal (F, m)."""
        res = self.evaluator.residuals(block.family, jacobians)
        if R.ndim == 2:
            error = R * res.error[rows]
            jacs = None if not jacobians else [R[:, :, None] * j[rows] for j in res.jacobians]
        else:
            error = (R @ res.error[rows][:, :, None])[:, :, 0]
            jacs = None if not jacobians else [R @ j[rows] for j in res.jacobians]
        return error, jacs

    # ------------------------------------------------------------------------------ error
    def family_error(self, values: gtsam.Values, bound: float = np.inf) -> float:
        """0.5 sum of squared whitened residuals of the vectorized factors at ``values``.

        Families are summed from the cheapest (``ResidualFamily.cost``) and the sum is
        returned as soon as it reaches ``bound``: every term is >= 0, so the result is then a
        lower bound of the error that is itself >= bound (exact when below bound).
        """
        self._load(values)
        total = 0.0
        for block, rows, R in self.parts:
            if total >= bound:
                break
            error, _ = self._whitened(block, rows, R, False)
            total += 0.5 * float(np.sum(error * error))
        return total

    def error(self, values: gtsam.Values) -> float:
        """The graph error at ``values`` (= graph.error(values))."""
        return self.family_error(values) + float(self.rest.error(values))

    def error_below(self, values: gtsam.Values, bound: float) -> float:
        """The graph error at ``values`` if it is below ``bound``, else a value >= bound
        (evaluation stops early: a trial point that cannot be accepted costs less)."""
        rest = float(self.rest.error(values))
        return rest + self.family_error(values, bound - rest)

    # ------------------------------------------------------------------------------ linearize
    def _unit_noise(self, m: int) -> gtsam.noiseModel.Base:
        if m not in self._unit:
            self._unit[m] = gtsam.noiseModel.Unit.Create(m)
        return self._unit[m]

    def _stacked(self, values: gtsam.Values):
        """Whitened rows of the vectorized families at ``values``: pair rows A (T-1, M, 2d),
        b (T-1, M) (row i acts on states (i, i+1); unary factors of i < T-1 with a zero right
        block), has_pair / has_unary (T-1,) bool, rows of the last state (K, d), (K,), and the
        factors of other shapes as GTSAM JacobianFactors."""
        self._load(values)
        keys = self.evaluator.keys
        T, d = self.evaluator.num_states, self.evaluator.theta.shape[1]
        pair_A, pair_b, last_A, last_b, general = [], [], [], [], []
        has_pair, has_unary = np.zeros(T - 1, bool), np.zeros(T - 1, bool)
        for block, rows, R in self.parts:
            error, jacs = self._whitened(block, rows, R, True)
            states = block.states[rows]
            m = error.shape[1]
            k = states.shape[1]
            pair = (k == 2) and bool(np.all(states[:, 1] == states[:, 0] + 1))
            first = states[:, 0]
            inner = first < T - 1 if k == 1 else np.ones(len(first), bool)
            if k > 2 or (k == 2 and not pair) or \
                    len(np.unique(first[inner])) != int(np.count_nonzero(inner)):
                for f in range(len(rows)):  # general shape: one factor each
                    args: list = []
                    for slot in range(k):
                        args += [keys[states[f, slot]], jacs[slot][f]]
                    general.append(gtsam.JacobianFactor(*args, -error[f], self._unit_noise(m)))
                continue
            A = np.zeros((T - 1, m, 2 * d))
            b = np.zeros((T - 1, m))
            idx = first[inner]
            A[idx, :, :d] = jacs[0][inner]
            if k == 2:
                A[idx, :, d:] = jacs[1][inner]
            b[idx] = -error[inner]
            (has_pair if k == 2 else has_unary)[idx] = True
            pair_A.append(A)
            pair_b.append(b)
            if k == 1 and not np.all(inner):
                last_A.append(jacs[0][~inner].reshape(-1, d))
                last_b.append(-error[~inner].reshape(-1))
        A = np.concatenate(pair_A, axis=1) if pair_A else np.zeros((T - 1, 0, 2 * d))
        b = np.concatenate(pair_b, axis=1) if pair_b else np.zeros((T - 1, 0))
        LA = np.concatenate(last_A) if last_A else np.zeros((0, d))
        Lb = np.concatenate(last_b) if last_b else np.zeros(0)
        return A, b, has_pair, has_unary, LA, Lb, general

    def linearize(self, values: gtsam.Values) -> gtsam.GaussianFactorGraph:
        """Whitened linear system at ``values``, equal to graph.linearize(values) up to row
        stacking (see the module docstring)."""
        pair_A, pair_b, has_pair, has_unary, last_A, last_b, general = self._stacked(values)
        keys = self.evaluator.keys
        T, d = self.evaluator.num_states, self.evaluator.theta.shape[1]
        linear = self.rest.linearize(values) if self.rest.size() else gtsam.GaussianFactorGraph()
        for factor in general:
            linear.push_back(factor)
        if pair_A.shape[1]:
            A, b, offsets = _nonzero_rows(pair_A, pair_b)
            left, right = A[:, :d].copy(), A[:, d:].copy()
            for i in np.flatnonzero(has_pair | has_unary):  # GTSAM factors: one call each
                r0, r1 = offsets[i], offsets[i + 1]
                if has_pair[i]:
                    factor = gtsam.JacobianFactor(keys[i], left[r0:r1], keys[i + 1],
                                                  right[r0:r1], b[r0:r1], self._unit_noise(r1 - r0))
                else:  # no factor on (i, i+1): unary
                    factor = gtsam.JacobianFactor(keys[i], left[r0:r1], b[r0:r1],
                                                  self._unit_noise(r1 - r0))
                linear.push_back(factor)
        if len(last_b):
            A, b, _ = _nonzero_rows(last_A[None], last_b[None])
            linear.push_back(gtsam.JacobianFactor(keys[T - 1], A, b, self._unit_noise(len(b))))
        return linear

    # ------------------------------------------------------------------------------ normal equations
    def _rest_hessian(self, rest_linear: gtsam.GaussianFactorGraph):
        """Constant block-tridiagonal A^T A (D (T, d, d), E (T-1, d, d)) of the other factors
        when all are linear (LinearContainerFactor) on one state or two consecutive states;
        None otherwise. Computed once."""
        if self._rest_blocks is not None:
            return self._rest_blocks or None
        self._rest_blocks = ()
        keys = self.evaluator.keys
        T, d = self.evaluator.num_states, self.evaluator.theta.shape[1]
        position = {k: i for i, k in enumerate(keys)}
        D, E = np.zeros((T, d, d)), np.zeros((T - 1, d, d))
        for j in range(self.rest.size()):
            if not isinstance(self.rest.at(j), gtsam.LinearContainerFactor):
                return None
        for j in range(rest_linear.size()):
            factor = rest_linear.at(j)
            fkeys = [position.get(k, -1) for k in factor.keys()]
            A = np.asarray(factor.augmentedJacobian())[:, :-1]
            if A.shape[1] != d * len(fkeys) or min(fkeys) < 0:
                return None
            if len(fkeys) == 1:
                D[fkeys[0]] += A.T @ A
            elif len(fkeys) == 2 and abs(fkeys[0] - fkeys[1]) == 1:
                order = np.argsort(fkeys)
                A = np.concatenate([A[:, d * o:d * (o + 1)] for o in order], axis=1)
                i = min(fkeys)
                H = A.T @ A
                D[i] += H[:d, :d]
                D[i + 1] += H[d:, d:]
                E[i] += H[:d, d:]
            else:
                return None
        self._rest_blocks = (D, E)
        return self._rest_blocks

    def normal_equations(self, values: gtsam.Values) -> tuple[np.ndarray, np.ndarray] | None:
        """Banded normal equations of the whitened linear system at ``values``.

        Returns H = A^T A in LAPACK lower band storage (2d, T d) (H[r, c] at [r - c, c],
        r >= c; the chain makes H block-tridiagonal with d x d blocks) and g = A^T b (T d,), the
        same system as :meth:`linearize` (0.5 ||A delta - b||^2 = error - g.delta + 0.5 delta.H.delta);
        None when the graph has factors that are not on one or two consecutive states, or other
        factors that are not linear (the caller then uses :meth:`linearize`).
        """
        keys = self.evaluator.keys
        T, d = self.evaluator.num_states, self.evaluator.theta.shape[1]
        if self._rest_blocks == ():
            return None
        rest_linear = self.rest.linearize(values) if self.rest.size() else None
        D, E = np.zeros((T, d, d)), np.zeros((T - 1, d, d))
        g = np.zeros((T, d))
        if rest_linear is not None:
            blocks = self._rest_hessian(rest_linear)
            if blocks is None:
                return None
            gradient = rest_linear.gradientAtZero()  # -A^T b
            if gradient.size() != T or not all(gradient.exists(k) for k in keys):
                return None
            D += blocks[0]
            E += blocks[1]
            g -= values_to_states(gradient, keys)
        self._load(values)
        for block, rows, R in self.parts:  # each family's own J^T J: no zero blocks multiplied
            states = block.states[rows]
            k = states.shape[1]
            first = states[:, 0]
            if k > 2 or (k == 2 and not np.all(states[:, 1] == first + 1)):
                return None
            error, jacs = self._whitened(block, rows, R, True)
            J = jacs[0] if k == 1 else np.concatenate(jacs, axis=2)          # (F, m, k d)
            Jt = np.swapaxes(J, 1, 2)
            H = Jt @ J
            gf = -(Jt @ error[:, :, None])[:, :, 0]                          # J^T b, b = -error
            F = len(first)
            if np.array_equal(first, np.arange(first[0], first[0] + F)):   # consecutive states
                at = slice(int(first[0]), int(first[0]) + F)
                following = slice(at.start + 1, at.stop + 1)
                D[at] += H[:, :d, :d]
                g[at] += gf[:, :d]
                if k == 2:
                    D[following] += H[:, d:, d:]
                    E[at] += H[:, :d, d:]
                    g[following] += gf[:, d:]
            else:
                np.add.at(D, first, H[:, :d, :d])
                np.add.at(g, first, gf[:, :d])
                if k == 2:
                    np.add.at(D, first + 1, H[:, d:, d:])
                    np.add.at(E, first, H[:, :d, d:])
                    np.add.at(g, first + 1, gf[:, d:])
        band = np.zeros((2 * d, T * d))
        rows, cols, diag_flat, off_flat = self._band_index(T, d)
        band.flat[diag_flat] = D[:, rows, cols].reshape(-1)  # lower triangles of diagonal blocks
        band.flat[off_flat] = E.reshape(-1)  # E_i = H[block i, block i+1] = H[block i+1, block i]^T
        return band, g.reshape(-1)

    def _band_index(self, T: int, d: int):
        """Flat positions in the (2d, T d) lower band storage of the lower triangles of the
        diagonal blocks (with their (row, col) in the block) and of the transposed
        off-diagonal blocks E_i^T (in E_i's row-major order)."""
        if self._band is None or self._band[0] != (T, d):
            N = T * d
            rows, cols = np.tril_indices(d)
            start = (np.arange(T) * d)[:, None]
            r, c = start + rows, start + cols
            diag_flat = ((r - c) * N + c).reshape(-1)
            a, bb = np.meshgrid(np.arange(d), np.arange(d), indexing="ij")  # E_i[a, b]
            start = (np.arange(T - 1) * d)[:, None, None]
            r, c = start + d + bb, start + a  # = H[(i+1) d + b, i d + a]
            off_flat = ((r - c) * N + c).reshape(-1)
            self._band = ((T, d), (rows, cols, diag_flat, off_flat))
        return self._band[1]
