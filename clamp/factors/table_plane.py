"""Table plane: every collision sphere of the arm kept above a horizontal plane (a table top).

One unary factor per support state, every sphere in one residual: for sphere s (centre c_s,
radius R_s = r_s + the sphere model's ``inflation``, the radius that encloses the link's
collision geometry, :mod:`robots.spheres`) the constraint g_s = h + m + R_s - z(c_s) <= 0 keeps
its lowest point at least m above the plane z = h (base frame, [m]); the hinge
e_s = max(0, g_s + shift) is the base class's (:meth:`clamp.factors.family.Family.residual`).
d g_s / d q = -d z(c_s) / d q (the third row of the sphere centre's Jacobian), 0 for qdot.
The margin m (default 5 mm) puts the optimum above the plane, not on it, so the check holds
between the support states too.

The check (:meth:`TablePlaneFamily.check`) is on the spheres, not on the URDF meshes: grown by
the inflation they enclose each link's collision geometry (the sphere fit covers every surface
sample, :mod:`robots.spheres`), so a clear check certifies the geometry above the plane, and it
is exactly what the hinge constrains (a mesh check could fail where no sphere is below the
plane, a violation the solve could never repair). It measures the support states and
:attr:`TablePlaneFamily.between` configurations on each step (linear in joint space, as the
collision checker's motion), without the margin: violated when a sphere's lowest point is below
the plane; amount [m]: the deepest.

Usage: ``clamp.plan(prior, robot, scene, start, extra_factors=[TablePlaneFamily(height=0.1)])``
(the family takes the plan's states and the robot's spheres when the model is built,
:meth:`TablePlaneFamily.for_plan`). Spheres whose height cannot change (on a link turning about
the vertical base axis) below the plane make the constraint unsatisfiable: choose the plane
below the shoulder.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from clamp.errors import InvalidParameterError
from clamp.validation import as_array, as_count, as_indices, as_scalar

from .family import CheckContext, Constraint, ConstraintCheck, Family
from .states import StateWindow


class TablePlaneFamily(Family):
    """Every collision sphere above the plane z = ``height`` [m] at the support states ``states``
    (None: all of the plan's), hinge noise ``sigma`` [m], ``margin`` [m] above the plane where
    the hinge starts; ``between`` configurations checked inside each step. Made without
    ``robot`` (or without states), it has no factors until :meth:`for_plan` gives them."""

    name = "table_plane"
    arity = 1
    kinematics = 2
    role = "constraint"

    def __init__(self, height: float, *, sigma: float = 1e-3, margin: float = 5e-3,
                 states: Sequence[int] | None = None, robot: Any = None, between: int = 4):
        self.height = as_scalar(height, "height")
        self.sigma = as_scalar(sigma, "sigma", strictly_positive=True)
        self.margin = as_scalar(margin, "margin", minimum=0.0)
        self.between = as_count(between, "between", minimum=0)
        self.indices = None if states is None else np.unique(as_indices(states, "states"))
        if self.indices is not None and not len(self.indices):
            raise InvalidParameterError("states: expected at least one support-state index, "
                                        "got none")
        bound = robot is not None and self.indices is not None
        if bound:
            spheres = getattr(robot, "spheres", None)
            if spheres is None or not len(spheres.radii):
                raise InvalidParameterError("robot: expected a robot with collision spheres")
            #: [m] (S,) radii enclosing the collision geometry: r_s + inflation
            self.radii = as_array(spheres.radii, "radii", (None,)) + float(spheres.inflation)
            #: [m] (S,) the plane's hinge: h + margin + R_s
            self._reach = self.height + self.margin + self.radii
            self._links = tuple(spheres.link_names)
        super().__init__(self.indices if bound else np.zeros(0, dtype=int),
                         len(self.radii) if bound else 1, sigma=self.sigma)

    def for_plan(self, num_states: int, robot: Any) -> TablePlaneFamily:
        """The family over ``states`` (all ``num_states`` when None) of ``robot``'s spheres."""
        if len(self):
            return self
        states = np.arange(num_states) if self.indices is None else self.indices
        return TablePlaneFamily(self.height, sigma=self.sigma, margin=self.margin, states=states,
                                robot=robot, between=self.between)

    def constraint(self, window: StateWindow, rows: np.ndarray, jacobians: bool) -> Constraint:
        i = window.local(self.first[rows])
        height = window.sphere_centres()[i][..., 2]                          # (R, S)

        def jacobian(states: np.ndarray, active: np.ndarray) -> np.ndarray:
            centre_jac = window.sphere_jacobians(i[states])                  # (A, S, 3, n)
            n = centre_jac.shape[-1]
            jac = np.zeros((len(states), len(self.radii), 2 * n))
            jac[:, :, :n] = -centre_jac[:, :, 2, :] * active[..., None]
            return jac
        return Constraint(self._reach - height, jacobian if jacobians else None)

    def clearance(self, robot: Any, q: np.ndarray) -> tuple[float, int, float]:
        """Least height [m] of a sphere's lowest point above the plane over the family's states
        and ``between`` configurations inside each of its steps (i -> i + 1 with both among
        them), for joint positions q (T, n) of the whole plan; the sphere and the (fractional)
        state where it is least."""
        states = self.first
        steps = states[np.isin(states + 1, states)]
        tau = np.linspace(0.0, 1.0, self.between + 2)[1:-1]
        index = np.concatenate([states.astype(float),
                                (steps[:, None] + tau[None, :]).reshape(-1)])
        configurations = np.concatenate([
            q[states], (q[steps, None] + tau[None, :, None] * (q[steps + 1] - q[steps])[:, None]
                        ).reshape(-1, q.shape[1])])
        centres, _ = robot.sphere_centres(configurations)
        gap = centres[..., 2] - self.radii - self.height                     # (K, S)
        k, s = np.unravel_index(int(np.argmin(gap)), gap.shape)
        return float(gap[k, s]), int(s), float(index[k])

    def check(self, context: CheckContext, theta: np.ndarray) -> ConstraintCheck:
        """The spheres' lowest points against the plane (module docstring); amount [m]: the
        deepest below it."""
        least, sphere, state = self.clearance(context.robot, theta[:, :context.robot.n])
        if least >= 0.0:
            return ConstraintCheck(self.name, False, 0.0, report=least)
        return ConstraintCheck(
            self.name, True, -least,
            (f"{self.name}: a sphere of link {self._links[sphere]} is {-1000 * least:.1f} mm "
             f"below the table plane at z = {self.height:.4g} m at state {round(state, 2):g}",),
            report=least)
