"""The demonstrations' states as the learners read them, and the blocks a chain is built from.

Lower than both :mod:`clamp.prior.linear_gaussian` (whose ``update`` reads more demonstrations)
and :mod:`clamp.prior.learning`: the parsing of a ``scenes.Demonstrations`` or keyword arrays
into states (M, T, 2A) ``[positions, velocities]`` and time (T,), the obstacle weights of its
samples, and the assembly of per-group regression blocks into block-structured transitions and
covariances with the agreement floor (SPREAD_FLOOR, see :mod:`clamp.prior.learning`), and the
steps where every demonstration holds still (:func:`held_steps`).
"""
from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from clamp.errors import ClampWarning, InvalidParameterError, ShapeError
from clamp.prior.obstacle_weighting import ObstacleWeighting, demonstration_weights
from clamp.validation import as_array, as_time
from skillplan.validation import MAX_COORDINATE

__all__ = ["MIN_SPREAD", "SPREAD_FLOOR", "AXIS_FLOOR_RATIO", "stack_states", "demo_arrays", "sample_weights",
           "scatter_blocks", "assemble_blocks", "block_covariance", "floor_agreement",
           "HOLD_TOLERANCE", "held_steps", "floor_noise"]

#: Smallest spread (largest standard deviation over the state's coordinates, across the
#: demonstrations; m, m/s or rad, rad/s) that counts as "the demonstrations differ" at a step.
#: Demonstrations below it at every step are identical and refused (they teach no variation);
#: steps below it (a common start or goal) are learned with the SPREAD_FLOOR.
MIN_SPREAD = 1e-6

#: Standard deviation (m or rad for positions, m/s or rad/s for velocities): at a step where
#: the demonstrations' largest one over the coordinates is below it they agree, and the
#: diagonal of Q_i (of the initial covariance at step 0) is raised to at least SPREAD_FLOOR**2.
SPREAD_FLOOR = 1e-5

#: At a step where the demonstrations agree in some coordinates (variance below SPREAD_FLOOR**2)
#: but not in all, the agreeing coordinates' diagonal entries are raised to at least
#: (AXIS_FLOOR_RATIO * the largest standard deviation of the same kind, positions or velocities)
#: squared: two or three demonstrations that happen to share an axis (synthetic0's x and z)
#: do not make a start or goal off that axis unreachable.
AXIS_FLOOR_RATIO = 0.1

#: [m, m/s; rad, rad/s in a joint or orientation chain] a step where every demonstration's
#: positions move at most this much and its velocities stay within it is a held step
#: (:func:`held_steps`)
HOLD_TOLERANCE = 1e-9


def stack_states(positions: object, velocities: object, time: object, names: tuple[str, str],
                 axes: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate (M, T, A) positions and velocities and (T,) time -> states (M, T, 2A), time."""
    p = as_array(positions, names[0], (None, None, axes), MAX_COORDINATE)
    v = as_array(velocities, names[1], p.shape, MAX_COORDINATE)
    t = as_time(time, "time", p.shape[1])
    return np.concatenate([p, v], axis=2), t


def demo_arrays(demos: object, positions: object, velocities: object,
                time: object) -> tuple[object, object, object, object]:
    """(positions, velocities, time, obstacles) from a Demonstrations or the keyword arrays."""
    if demos is not None:
        if any(a is not None for a in (positions, velocities, time)):
            raise InvalidParameterError("demos: give either a Demonstrations object or the "
                                        "positions/velocities/time arrays, not both")
        missing = [a for a in ("positions", "velocities", "time") if not hasattr(demos, a)]
        if missing:
            raise ShapeError(f"demos: expected a scenes.Demonstrations with attributes "
                             f"positions, velocities, time; {type(demos).__name__} lacks {missing}")
        return demos.positions, demos.velocities, demos.time, getattr(demos, "obstacles", None)
    if positions is None or velocities is None or time is None:
        raise InvalidParameterError("demos: expected a Demonstrations object, or all of "
                                    "positions (M, T, 3), velocities (M, T, 3), time (T,)")
    return positions, velocities, time, None


def sample_weights(states: np.ndarray, obstacles: Any,
                   weighting: ObstacleWeighting | None) -> np.ndarray | None:
    """Per-sample weights (M, T) of states (M, T, 2A) by their distance to each demonstration's
    recorded obstacles (None without a weighting; a warning when there are no obstacles)."""
    if weighting is not None and not obstacles:
        warnings.warn("obstacle_weighting: the demonstrations carry no recorded obstacles; "
                      "every sample keeps weight 1", ClampWarning, stacklevel=3)
    return demonstration_weights(states[..., :3], obstacles, weighting)


def scatter_blocks(blocks: np.ndarray, groups: np.ndarray, size: int) -> np.ndarray:
    """Place per-group blocks (..., G, k, k) into block-structured matrices (..., D, D)."""
    out = np.zeros(blocks.shape[:-3] + (size, size))
    out[..., groups[:, :, None], groups[:, None, :]] = blocks
    return out


def assemble_blocks(Phi_g: np.ndarray, u_g: np.ndarray, Q_g: np.ndarray, groups: np.ndarray,
                    D: int, jitter: float, variance_g: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-group Phi (S, G, k, k), u (S, G, k), Q (S, G, k, k) -> block-structured (S, D, D),
    (S, D), (S, D, D) with ``jitter`` on Q's diagonal, floored where the next states'
    variance (S, G, k) shows the demonstrations agree (:func:`floor_agreement`)."""
    Phi = scatter_blocks(Phi_g, groups, D)
    variance = np.zeros((Phi.shape[0], D))
    variance[:, groups] = variance_g
    Q = floor_agreement(scatter_blocks(Q_g, groups, D) + jitter * np.eye(D), variance)
    Q = 0.5 * (Q + np.swapaxes(Q, -1, -2))
    u = np.zeros((Phi.shape[0], D))
    u[:, groups] = u_g
    return Phi, u, Q


def block_covariance(full: np.ndarray, groups: np.ndarray, jitter: float) -> np.ndarray:
    """full (D, D) (the first states' covariance) with entries outside the groups' blocks
    zeroed, plus jitter I, floored where the first states agree."""
    mask = scatter_blocks(np.ones((groups.shape[0],) + (groups.shape[1],) * 2), groups,
                          full.shape[0]).astype(bool)
    return floor_agreement(np.where(mask, full, 0.0) + jitter * np.eye(full.shape[0]),
                           np.diag(full))


def floor_agreement(cov: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """Covariances (..., D, D) over ``[positions (D/2), velocities (D/2)]`` whose diagonal
    entries are raised where the demonstrations' variance (..., D) shows they agree: to at least
    SPREAD_FLOOR**2 where it is below SPREAD_FLOOR**2 in every coordinate; where only some
    coordinates agree, those to at least (AXIS_FLOOR_RATIO x the largest standard deviation of
    the same kind on the diagonal)**2 (a non-negative diagonal added: still symmetric positive
    semi-definite)."""
    floor = SPREAD_FLOOR ** 2
    diagonal = np.einsum("...ii->...i", cov)
    agree = variance < floor
    everywhere = np.all(agree, axis=-1, keepdims=True)
    lift = np.where(everywhere, np.maximum(floor - diagonal, 0.0), 0.0)
    D = cov.shape[-1]
    if D % 2 == 0:
        for kind in (slice(0, D // 2), slice(D // 2, D)):
            part = diagonal[..., kind]
            least = AXIS_FLOOR_RATIO ** 2 * part.max(axis=-1, keepdims=True)
            some = agree[..., kind] & ~everywhere
            lift[..., kind] = np.where(some, np.maximum(least - part, lift[..., kind]),
                                       lift[..., kind])
    return cov + lift[..., :, None] * np.eye(D)


def held_steps(states: np.ndarray) -> np.ndarray:
    """(T-1,) bool: the steps i -> i+1 where every demonstration holds still where it is: of
    states (M, T, 2A) ``[positions, velocities]``, every position moves at most HOLD_TOLERANCE
    and every velocity stays within HOLD_TOLERANCE at both ends, while the demonstrations are
    apart (some position's variance at x_{i+1} at least SPREAD_FLOOR**2; where they all agree
    the agreement floor applies instead). A pour turns the hand in place: its positions are
    held for the last third of the skill. How the learners treat them:
    :mod:`clamp.prior.learning`."""
    states = np.asarray(states, dtype=float)
    A = states.shape[2] // 2
    still = (np.all(np.abs(np.diff(states[..., :A], axis=1)) <= HOLD_TOLERANCE, axis=(0, 2))
             & np.all(np.abs(states[:, :-1, A:]) <= HOLD_TOLERANCE, axis=(0, 2))
             & np.all(np.abs(states[:, 1:, A:]) <= HOLD_TOLERANCE, axis=(0, 2)))
    apart = np.any(states[:, 1:, :A].var(axis=0) >= SPREAD_FLOOR ** 2, axis=1)
    return still & apart


def floor_noise(cov: np.ndarray, floor: float) -> np.ndarray:
    """Covariances (..., D, D) over ``[positions (D/2), velocities (D/2)]`` with the positions'
    diagonal entries raised to at least ``floor``**2 (a non-negative diagonal added: still
    symmetric positive semi-definite); the velocities' and the off-diagonal entries as they are.
    Floored twice, the same numbers. The floor of a chain whose targets are observed much more
    closely than its demonstrations vary: see
    :data:`clamp.planning.reference.ROTATION_NOISE_FLOOR`."""
    out = np.array(cov, dtype=float)
    positions = np.arange(out.shape[-1] // 2)
    out[..., positions, positions] = np.maximum(out[..., positions, positions], floor ** 2)
    return out
