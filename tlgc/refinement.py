"""Skill refinement (paper section 6).

Incremental refinement (6.1): a corrected trajectory (any length; resampled to the set's N
points) replaces a demonstration or joins the set, and the cylinder is fitted again
(:func:`refine_incrementally`).

Constraint-based refinement (6.2): from a reproduction (N,3) and the teacher's correction of it
(N,3), the refinement matrix V = [v_1 ... v_N] (v_k = corrected_k - original_k) is formed.
Where v_k is not negligible it defines a constraining plane through the corrected point
corrected_k with normal v_k / ||v_k||: the side the original reproduction was pushed away from
is forbidden. A later reproduction (its k-th point lies in cross-section k, like the
correction's) *crosses* the constraint where its k-th point lies on the forbidden side; those
points are corrected, all other points and all reproductions that never cross are returned
unchanged (bit for bit). Two ways to correct a crossing point r_k:

* ``"project"`` (default): onto the constraining plane, r_k + ((corrected_k - r_k) . u_k) u_k,
  which keeps the path continuous where the constraint starts to act;
* ``"translate"``: by the refinement vector itself, r_k + v_k, as the paper describes (the path
  may jump where the constraint first applies, see the paper's remark).

Constraints never touch the cylinder: a :class:`RefinementSet` holds any number of them, which
can be added, removed and combined (applied in order) without fitting anything again.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, Iterator, Sequence

import numpy as np

from .cylinder import GeneralizedCylinder, as_demonstration_array, fit_cylinder, resample_demonstrations
from .errors import TLGCArgumentError
from .validation import as_points, as_scalar

CORRECTION_MODES = ("project", "translate")


def _as_path(x: np.ndarray, name: str) -> np.ndarray:
    p = as_points(x, name)
    if p.ndim != 2 or len(p) < 2:
        raise TLGCArgumentError(f"{name}: expected shape (N, 3) with N >= 2, got {p.shape}")
    return p


@dataclass(frozen=True)
class RefinementConstraint:
    """A correction of one reproduction, as a per-cross-section plane constraint.

    ``corrected`` (N,3) corrected path [m], ``vectors`` (N,3) refinement matrix V^T [m],
    ``active`` (N,) where ||v_k|| exceeds the tolerance, ``mode`` one of CORRECTION_MODES.
    """

    corrected: np.ndarray
    vectors: np.ndarray
    active: np.ndarray
    mode: str = "project"

    @classmethod
    def from_correction(cls, original: np.ndarray, corrected: np.ndarray,
                        tolerance: float = 1e-4, mode: str = "project") -> "RefinementConstraint":
        """Constraint from a reproduction (N,3) and its correction (N,3) [m].

        Points moved by less than ``tolerance`` metres carry no constraint.
        """
        o = _as_path(original, "original")
        c = _as_path(corrected, "corrected")
        if o.shape != c.shape:
            raise TLGCArgumentError(
                f"original, corrected: expected equal shapes (N, 3), got {o.shape} and {c.shape}")
        tol = as_scalar(tolerance, "tolerance", minimum=0.0)
        if mode not in CORRECTION_MODES:
            raise TLGCArgumentError(
                f"mode: unknown correction mode {mode!r}; expected one of {', '.join(CORRECTION_MODES)}")
        v = c - o
        active = np.linalg.norm(v, axis=1) > tol
        if not active.any():
            raise TLGCArgumentError(
                f"corrected: differs from original by at most {tol:g} m everywhere; no constraint")
        return cls(c, v, active, mode)

    @property
    def num_points(self) -> int:
        """Number N of points (cross-sections) of the paths it applies to."""
        return len(self.corrected)

    @property
    def matrix(self) -> np.ndarray:
        """The refinement matrix V (3, N) [m] of the paper."""
        return self.vectors.T

    def _check(self, reproductions: np.ndarray) -> np.ndarray:
        r = as_points(reproductions, "reproductions")
        if r.ndim not in (2, 3) or r.shape[-2] != self.num_points:
            raise TLGCArgumentError(
                f"reproductions: expected shape ({self.num_points}, 3) or (R, {self.num_points}, 3) "
                f"(one point per cross-section, like the correction), got {r.shape}")
        return r

    @cached_property
    def _unit_normals(self) -> np.ndarray:
        """Unit plane normals v_k / ||v_k|| (N,3); zero rows where the constraint is inactive."""
        unit = np.zeros_like(self.vectors)
        unit[self.active] = self.vectors[self.active] / np.linalg.norm(
            self.vectors[self.active], axis=1, keepdims=True)
        return unit

    def _depth(self, r: np.ndarray) -> np.ndarray:
        """:meth:`violation` of checked reproductions ``r``."""
        depth = np.einsum("...ni,ni->...n", self.corrected - r, self._unit_normals)
        return np.where(self.active & (depth > 0.0), depth, 0.0)

    def violation(self, reproductions: np.ndarray) -> np.ndarray:
        """How far [m] each point of reproductions (R,N,3) or (N,3) lies on the forbidden side
        of its constraining plane; 0 where it does not or where the constraint is inactive."""
        return self._depth(self._check(reproductions))

    def crosses(self, reproductions: np.ndarray) -> np.ndarray:
        """Boolean (R,) (or scalar for one path): does the reproduction cross the constraint?"""
        return np.any(self.violation(reproductions) > 0.0, axis=-1)

    def apply(self, reproductions: np.ndarray) -> np.ndarray:
        """Corrected copy of reproductions (R,N,3) or (N,3); points that do not cross are unchanged."""
        r = self._check(reproductions)
        depth = self._depth(r)
        hit = depth > 0.0
        if self.mode == "project":
            shifted = r + depth[..., None] * self._unit_normals
        else:
            shifted = r + self.vectors
        return np.where(hit[..., None], shifted, r)


class RefinementSet:
    """An ordered, editable collection of refinement constraints applied to reproductions."""

    def __init__(self, constraints: Sequence[RefinementConstraint] = ()) -> None:
        self._constraints: list[RefinementConstraint] = []
        for c in constraints:
            self.add(c)

    def add(self, constraint: RefinementConstraint) -> int:
        """Append a constraint; returns its position (usable with :meth:`remove`)."""
        if not isinstance(constraint, RefinementConstraint):
            raise TLGCArgumentError(
                f"constraint: expected a RefinementConstraint, got {type(constraint).__name__}")
        if self._constraints and constraint.num_points != self._constraints[0].num_points:
            raise TLGCArgumentError(
                f"constraint: has {constraint.num_points} points, the set's constraints have "
                f"{self._constraints[0].num_points}")
        self._constraints.append(constraint)
        return len(self._constraints) - 1

    def add_correction(self, original: np.ndarray, corrected: np.ndarray,
                       tolerance: float = 1e-4, mode: str = "project") -> int:
        """Build a constraint from a reproduction and its correction and append it."""
        return self.add(RefinementConstraint.from_correction(original, corrected, tolerance, mode))

    def remove(self, position: int) -> RefinementConstraint:
        """Remove and return the constraint at ``position``."""
        if not isinstance(position, (int, np.integer)) or not -len(self) <= position < len(self):
            raise TLGCArgumentError(
                f"position: expected an integer in [0, {len(self)}), got {position!r}")
        return self._constraints.pop(position)

    def __len__(self) -> int:
        return len(self._constraints)

    def __iter__(self) -> Iterator[RefinementConstraint]:
        return iter(self._constraints)

    def crosses(self, reproductions: np.ndarray) -> np.ndarray:
        """Boolean (R,): does a reproduction cross any constraint (before correction)?"""
        if not self._constraints:
            r = np.asarray(reproductions)
            return np.zeros(r.shape[:-2], dtype=bool)
        return np.any([c.crosses(reproductions) for c in self._constraints], axis=0)

    def apply(self, reproductions: np.ndarray) -> np.ndarray:
        """Reproductions (R,N,3) or (N,3) corrected by every constraint in order."""
        out = np.array(reproductions, dtype=float, copy=True)
        for c in self._constraints:
            out = c.apply(out)
        return out


def refine_incrementally(demos: Any, corrected: np.ndarray, replace: int | None = None,
                         cross_section: str = "spline") -> tuple[np.ndarray, GeneralizedCylinder]:
    """Incremental refinement: the demonstrations (M, N, 3) with ``corrected`` (T, 3) [m]
    (resampled to N points) replacing demonstration ``replace``, or appended when None, and
    the cylinder fitted to them (same ``cross_section`` type)."""
    x = as_demonstration_array(demos)
    c = _as_path(corrected, "corrected")
    new = resample_demonstrations([c], x.shape[1])
    if replace is None:
        x = np.concatenate([x, new])
    else:
        if isinstance(replace, bool) or not isinstance(replace, (int, np.integer)) or not -len(x) <= replace < len(x):
            raise TLGCArgumentError(
                f"replace: expected None or a demonstration index in [0, {len(x)}), got {replace!r}")
        x = x.copy()
        x[replace] = new[0]
    return x, fit_cylinder(x, cross_section)
