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

A learned orientation chain's step noise Q_i and initial covariance are at least
ROTATION_NOISE_FLOOR**2 on r's diagonal (:func:`clamp.prior.demonstration_states.floor_noise`).
Demonstrations often agree on the hand's rotation far more closely than on its position
(inserting keeps a fixed tool axis: the six demonstrations' end rotations within 2e-8 rad;
pouring tilts about one axis and holds the other two within 8e-8 rad), and where they do, the
per-step regression's ridge sets Phi ~ 0 there and Q is the agreement floor (1e-5 rad, the
planner's conditioning noise) or the residual (1e-6 rad and less). The chain's end rotation then
is as certain as the goal observation itself (inserting) or more (pouring's held axes), and a goal
rotation away from the demonstrations' mean was met only in part: a fixed fraction of the ask
(half for inserting on both arms, 99 % missed on the Jaco's pouring; issue 37). With the floor
(100x the conditioning noise) the goal takes 1 - 1e-4 of the weight (a 10 deg turn is met to
0.001 deg). The floor also softens the chain wherever its learned noise was smaller: 3e-4 rad cost
less orientation error in bench_lfd's pouring goal cell (0.25 deg more than without a floor, 1e-3:
0.63 deg more) but the Jaco then missed goal positions moved 2 cm more often
(docs/decisions.md#pose-prior). Position chains keep their
own noise (their plans bit-identical): demonstrations rarely agree on positions to micrometres.
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from clamp.errors import InvalidParameterError, ShapeError
from clamp.prior import so3
from clamp.prior.conjugate import ConjugatePosterior
from clamp.prior.demonstration_states import floor_noise
from clamp.prior.linear_gaussian import LinearGaussianPrior
from clamp.validation import as_array

__all__ = ["OrientationPrior", "orientation_states", "orientation_region", "ROTATION_NOISE_FLOOR"]

#: [rad] least standard deviation of a learned orientation chain's step noise and initial
#: state on r (module docstring): 100x the planner's conditioning noise (1e-5,
#: ``clamp.planning.reference.CONDITIONING_SIGMA``), 0.06 deg a step
ROTATION_NOISE_FLOOR = 1e-3


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
                "orientation_region": orientation_region(states),
                "noise_floor": ROTATION_NOISE_FLOOR}
        return cls(chain.time, chain.Phi, chain.u, *_floored(chain), info=info,
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
        return type(self)(chain.time, chain.Phi, chain.u, *_floored(chain),
                          info={**chain.info, "orientation_region": region,
                                "noise_floor": ROTATION_NOISE_FLOOR},
                          posterior=chain.posterior)


def _floored(chain: LinearGaussianPrior) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Q, mean0, cov0) of a learned chain, Q and cov0 floored on r (module docstring)."""
    return (floor_noise(np.asarray(chain.Q), ROTATION_NOISE_FLOOR), np.asarray(chain.mean0),
            floor_noise(np.asarray(chain.cov0), ROTATION_NOISE_FLOOR))


class _States:
    """Orientation states (M, T, 6) seen as demonstrations' positions and velocities (what
    :meth:`LinearGaussianPrior.update` reads), on the prior's time steps."""

    def __init__(self, states: np.ndarray, time: np.ndarray):
        self.positions, self.velocities = states[..., :3], states[..., 3:]
        self.time = time
