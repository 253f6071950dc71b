"""The hand's orientation as a learned chain: the rotation part of CLAMP's pose prior.

Where demonstrations carry the hand's rotation R^m_t (``scenes.Demonstrations.orientations``),
every step t has a mean rotation Rbar_t (the chordal mean over the M demonstrations,
:func:`clamp.prior.so3.chordal_mean`), and a demonstration's orientation state there is

    y^m_t = [r^m_t, w^m_t],   r = log(Rbar_t^T R^m_t) (3,) [rad],   w = Rbar_t^T omega^m_t (3,) [rad/s]

(omega the base-frame angular velocity, :func:`clamp.prior.so3.world_rates`): tangent
coordinates at the mean rotation and the angular velocity in the mean's frame. Each
demonstration's r follows one branch of the log map in time
(:func:`clamp.prior.so3.continuous_in_time`): real recordings can be turned far from the mean
(wiping_rim: 100-178 deg from the others' mean), and where one passes pi the principal log
jumps by 2 pi between two samples; the per-step regression read that jump as the step's motion
and its composed start gain fell to ~0 there, so a start or goal rotation's response faded
before mid-skill (measured in docs/decisions.md#pose-prior). These are
ordered [positions, velocities] like a workspace state, so the same linear-Gaussian learner
(:func:`clamp.prior.learning.learn_orientation`: per-axis ridge regression, start shrinkage,
the incremental conjugate model, conditioning, sampling) learns an :class:`OrientationPrior`
over them. With the default per-axis learning the 12-number pose chain [p, v, r, w] is block
diagonal between position and rotation, so the two chains kept side by side
(``WorkspacePrior.orientation``) are that chain exactly (docs/decisions.md#pose-prior).

The mean rotations are stored in ``info["mean_rotations"]`` (T quaternions x, y, z, w), so a
saved, conditioned or updated orientation prior keeps the tangent spaces it was learned in.
``info["orientation_region"]`` holds the demonstrations' spread: ``radius`` (T,) [rad] the
largest angle of a demonstration from the mean rotation at every step, ``spread`` (T, 3) [rad]
the per-axis standard deviation of r, ``end_radius`` [rad] at the last step.

A learned chain keeps its own noise, however closely the demonstrations agree; a plan floors it
where a goal or via rotation conditions it (:data:`clamp.planning.reference.ROTATION_NOISE_FLOOR`).
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from clamp.errors import InvalidParameterError, ShapeError
from clamp.prior import so3
from clamp.prior.conjugate import ConjugatePosterior
from clamp.prior.linear_gaussian import LinearGaussianPrior
from clamp.validation import as_array

__all__ = ["OrientationPrior", "orientation_states", "orientation_region"]


def orientation_states(rotations: np.ndarray, mean_rotations: np.ndarray,
                       time: np.ndarray) -> np.ndarray:
    """Orientation states y (M, T, 6) = [log(Rbar_t^T R_t), Rbar_t^T omega_t] of rotations
    (M, T, 3, 3) at mean rotations (T, 3, 3), sampled at ``time`` (T,) [s]. Each
    demonstration's log follows one branch in time (:func:`clamp.prior.so3.continuous_in_time`):
    a demonstration turned near pi from the mean would otherwise jump by up to 2 pi between two
    samples, and the per-step regression would read the jump as the step's motion."""
    rotations = np.asarray(rotations, dtype=float)
    Rbar_T = np.swapaxes(np.asarray(mean_rotations, dtype=float), -1, -2)
    r = so3.continuous_in_time(so3.log_map(Rbar_T @ rotations))
    w = np.einsum("tij,mtj->mti", Rbar_T, so3.world_rates(rotations, time))
    return np.concatenate([r, w], axis=-1)


def orientation_region(states: np.ndarray) -> dict[str, Any]:
    """``info["orientation_region"]`` of orientation states (M, T, 6) (module docstring)."""
    turned = np.linalg.norm(states[..., :3], axis=-1) % (2 * np.pi)   # a followed branch's
    angle = np.minimum(turned, 2 * np.pi - turned)                    # (M, T) from the mean
    return {"radius": angle.max(axis=0).tolist(), "spread": states[..., :3].std(axis=0).tolist(),
            "end_radius": float(angle[:, -1].max()), "num_demos": int(states.shape[0])}


class OrientationPrior(LinearGaussianPrior):
    """A learned chain over y = [r (3) rad, w (3) rad/s] about mean rotations ``rotations``
    (T, 3, 3) (module docstring); same attributes and methods as
    :class:`~clamp.prior.linear_gaussian.LinearGaussianPrior`, D = 6."""

    default_kind: ClassVar[str] = "orientation"

    def __init__(self, time: np.ndarray, Phi: np.ndarray, u: np.ndarray, Q: np.ndarray,
                 mean0: np.ndarray, cov0: np.ndarray, *, state_names: tuple[str, ...] | None = None,
                 kind: str | None = None, info: dict[str, Any] | None = None,
                 posterior: ConjugatePosterior | None = None) -> None:
        Phi = as_array(Phi, "Phi", (None, 6, 6))
        super().__init__(time, Phi, u, Q, mean0, cov0, state_names=state_names,
                         kind=kind or self.default_kind, info=info, posterior=posterior)
        quaternions = self.info.get("mean_rotations")
        if quaternions is None:
            raise InvalidParameterError("info: an orientation prior needs 'mean_rotations' (T "
                                        "quaternions x, y, z, w), the rotations it was learned at")
        quaternions = np.asarray(quaternions, dtype=float)
        if quaternions.shape != (self.T, 4):
            raise ShapeError(f"info['mean_rotations']: expected ({self.T}, 4) quaternions, got "
                             f"shape {quaternions.shape}")
        rotations = so3.from_quaternions(quaternions)
        rotations.flags.writeable = False
        #: mean rotations Rbar_t (T, 3, 3): the tangent space of every step
        self.rotations = rotations

    def _default_state_names(self) -> tuple[str, ...]:
        return ("rx", "ry", "rz", "wx", "wy", "wz")

    @classmethod
    def learned_at(cls, chain: LinearGaussianPrior, mean_rotations: np.ndarray,
                   states: np.ndarray) -> "OrientationPrior":
        """The orientation prior of a chain learned from orientation ``states`` (M, T, 6) at
        ``mean_rotations`` (T, 3, 3): its info records both (module docstring)."""
        info = {**chain.info, "mean_rotations": so3.to_quaternions(mean_rotations).tolist(),
                "orientation_region": orientation_region(states)}
        return cls(chain.time, chain.Phi, chain.u, chain.Q, chain.mean0, chain.cov0, info=info,
                   posterior=chain.posterior)

    def tangent(self, rotations: np.ndarray) -> np.ndarray:
        """r (..., T, 3) [rad] of rotations (..., T, 3, 3): log(Rbar_t^T R_t)."""
        return so3.log_map(np.swapaxes(self.rotations, -1, -2) @ np.asarray(rotations, float))

    def states_of(self, quaternions: np.ndarray) -> np.ndarray:
        """Orientation states (M, T, 6) of quaternions (M, T, 4) (x, y, z, w) at this prior's
        time steps and mean rotations."""
        q = as_array(quaternions, "orientations", (None, self.T, 4))
        return orientation_states(so3.from_quaternions(q), self.rotations, self.time)

    @property
    def mean_rotations(self) -> np.ndarray:
        """The prior's mean orientation (T, 3, 3): Rbar_t Exp(mean r_t)."""
        return self.rotations @ so3.exp_map(np.asarray(self.mean)[:, :3])

    @property
    def angle_radius(self) -> np.ndarray:
        """(T,) [rad] the demonstrations' largest angle from the mean rotation at every step
        (``info["orientation_region"]``); without it, 2 x the prior's marginal angular std."""
        region = self.info.get("orientation_region")
        if region is not None:
            return np.asarray(region["radius"], dtype=float)
        return 2.0 * np.linalg.norm(self.std[:, :3], axis=1)

    @property
    def end_radius(self) -> float:
        """[rad] how far apart the demonstrations end in rotation (largest angle from the mean
        end rotation ``rotations[-1]``)."""
        region = self.info.get("orientation_region")
        return float(region["end_radius"]) if region is not None else float(self.angle_radius[-1])

    def updated(self, quaternions: np.ndarray) -> "OrientationPrior":
        """This prior after more demonstrations' orientations (M', T, 4), by the conjugate
        update at the same mean rotations (the tangent spaces stay; method="incremental")."""
        states = self.states_of(quaternions)
        before = self.info.get("orientation_region")
        chain = LinearGaussianPrior.update(self, _States(states, self.time))
        region = orientation_region(states)
        if before is not None:
            region["radius"] = np.maximum(before["radius"], region["radius"]).tolist()
            region["end_radius"] = max(before["end_radius"], region["end_radius"])
            region["num_demos"] += int(before.get("num_demos", 0))
        return type(self)(chain.time, chain.Phi, chain.u, chain.Q, chain.mean0, chain.cov0,
                          info={**chain.info, "orientation_region": region},
                          posterior=chain.posterior)


class _States:
    """Orientation states (M, T, 6) seen as demonstrations' positions and velocities (what
    :meth:`LinearGaussianPrior.update` reads), on the prior's time steps."""

    def __init__(self, states: np.ndarray, time: np.ndarray):
        self.positions, self.velocities = states[..., :3], states[..., 3:]
        self.time = time
