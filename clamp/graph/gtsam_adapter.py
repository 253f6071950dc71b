"""GTSAM factors derived from a family: one thin adapter per factor, calling the family's kernel.

Nonlinear families become ``gtsam.CustomFactor`` s whose error function evaluates
:meth:`Family.residual` for their own row; linear families (``Family.linear``) become pure C++
``LinearContainerFactor`` s built from the same kernel's Jacobian and residual at theta = 0.

GTSAM calls every factor separately, each with the same ``values``. The adapters of one graph
share a :class:`SharedStates`: the first adapter called at new values reads all support states
(one C++ call), and each family's kernel then runs once for all its factors; the other adapters
return their rows. Values that lack some support state (a user evaluating one factor on its
own) get a window of just the factor's states. The shared object references the robot and the
families only, never the factors, so a graph and everything it holds are freed by reference
counting as soon as the caller drops it (a cycle through GTSAM's C++ side would never be).
"""
from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import gtsam
import numpy as np

from clamp.graph.keys import values_to_states

from clamp.factors.family import Family, Linearization
from clamp.factors.states import StateWindow


class _Rows:
    """One family's linearization at the shared window, indexed by factor: ``at[row]`` its
    position (-1: an exactly zero factor left out), ``error[pos]`` (m,) and ``blocks[k][pos]``
    (m, d) contiguous, the Jacobian block of its k-th state (None when not computed)."""

    __slots__ = ("at", "error", "blocks")

    def __init__(self, lin: Linearization, size: int, arity: int, d: int):
        at = np.full(size, -1)
        at[lin.rows] = np.arange(len(lin.rows))
        self.at: list[int] = at.tolist()
        self.error = lin.error
        self.blocks = None if lin.jacobian is None else np.ascontiguousarray(
            lin.jacobian.reshape(len(lin.rows), lin.jacobian.shape[1], arity, d).transpose(2, 0, 1, 3))


class SharedStates:
    """The latest support states read from GTSAM values and the families' results at them."""

    def __init__(self, robot, keys: Sequence[int]):
        self.robot = robot
        self.keys = list(keys)
        self.window: StateWindow | None = None
        self._bytes: list[bytes] = []
        self._results: dict[int, _Rows] = {}

    def window_for(self, values: gtsam.Values, states: range) -> StateWindow:
        """The shared window if it agrees with ``values`` on ``states``, else a fresh one."""
        try:
            own = [values.atVector(self.keys[s]) for s in states]
        except RuntimeError as exc:  # a state of this factor is missing: GTSAM's own error
            raise RuntimeError(f"values lack a support state of this factor: {exc}") from None
        if self.window is not None:
            for v, s in zip(own, states):
                if v.tobytes() != self._bytes[s]:
                    break
            else:
                return self.window
        try:
            theta = values_to_states(values, self.keys)
        except RuntimeError:  # not all support states in values: the factor's own states only
            return StateWindow(self.robot, np.stack(own), first=states[0])
        self.window = StateWindow(self.robot, theta)
        self._bytes = [row.tobytes() for row in theta]
        self._results = {}
        return self.window

    def rows(self, family: Family, jacobians: bool) -> _Rows:
        """All factors of ``family`` at the shared window (memoised until the states change)."""
        hit = self._results.get(id(family))
        if hit is None or (jacobians and hit.blocks is None):
            lin = family.residual(self.window, np.arange(len(family)), jacobians)
            hit = _Rows(lin, len(family), family.arity, self.window.theta.shape[1])
            self._results[id(family)] = hit
        return hit


def _error(shared: SharedStates, family: Family, row: int, states: range,
           this: gtsam.CustomFactor, values: gtsam.Values, H: list | None) -> np.ndarray:
    """CustomFactor error function: factor ``row`` of ``family`` (unwhitened, (m,))."""
    window = shared.window_for(values, states)
    if window is not shared.window:  # a window of this factor's states only
        lin = family.residual(window, np.array([row]), H is not None)
        rows = _Rows(lin, row + 1, family.arity, window.theta.shape[1])
    else:
        rows = shared.rows(family, H is not None)
    pos = rows.at[row]
    if pos < 0:
        if H is not None:
            for k in range(family.arity):
                H[k] = np.zeros((family.dim, window.theta.shape[1]))
        return np.zeros(family.dim)
    if H is not None:
        for k in range(family.arity):
            H[k] = rows.blocks[k, pos]
    return rows.error[pos]


def _linear_factor(family: Family, robot, row: int, keys: list[int],
                   d: int) -> gtsam.LinearContainerFactor:
    """The linear factor ``row`` as a whitened JacobianFactor around theta = 0."""
    zero = StateWindow(robot, np.zeros((family.arity, d)), first=int(family.first[row]))
    lin = family.residual(zero, np.array([row]), True)
    A = family.whiten(lin.rows, lin.jacobian)[0]
    b = -family.whiten(lin.rows, lin.error)[0]
    args: list = []
    point = gtsam.Values()
    for k, key in enumerate(keys):
        args += [key, np.ascontiguousarray(A[:, k * d:(k + 1) * d])]
        point.insert(key, np.zeros(d))
    factor = gtsam.JacobianFactor(*args, b, gtsam.noiseModel.Unit.Create(family.dim))
    return gtsam.LinearContainerFactor(factor, point)


def gtsam_factors(family: Family, shared: SharedStates, d: int) -> list[gtsam.NonlinearFactor]:
    """One GTSAM factor per factor of ``family`` on the state keys of ``shared`` (state size d)."""
    out: list[gtsam.NonlinearFactor] = []
    for row in range(len(family)):
        keys = [shared.keys[s] for s in family.states(row)]
        if family.linear:
            out.append(_linear_factor(family, shared.robot, row, keys, d))
        else:
            out.append(gtsam.CustomFactor(family.noise_model(row), gtsam.KeyVector(keys),
                                          partial(_error, shared, family, row,
                                                  family.states(row))))
    return out
