"""Reproduction from new start points by the fixed- and adaptive-ratio rules (paper eq. 8-10).

A start p0 is expressed in the first section's plane (projected onto it if off the plane): its
angle theta and its ratio eta0 = |p0 - c0| / r_0(theta). Point i of the reproduction keeps the
angle in frame i (Bishop frames carry it without twist) at ratio eta_i of that section's
boundary: p_i = c_i + eta_i r_i(theta) (cos theta n_i + sin theta b_i), with
eta_i = eta0 (fixed ratio) or eta_i = (eta0 - eta_f) exp(-gamma u_i) + eta_f (adaptive ratio,
u_i the normalised arc length of the directrix; eta_f = 0 convergent, 1 divergent).
All R reproductions are one broadcast over (R, N).
"""
from __future__ import annotations

import numpy as np

from .cross_sections import polar
from .cylinder import GeneralizedCylinder
from .errors import InvalidArgumentError, StartOutsideError
from .validation import as_count, as_generator, as_points, as_scalar

DEFAULT_GAMMA = 10.0     # decay constant of eq. 10: exp(-10) = 4.5e-5 of the gap is left at the end
OUTSIDE_TOLERANCE = 1e-9
BLOCK = 64               # reproductions per block: keeps the (B, N) temporaries in cache


def start_coordinates(cyl: GeneralizedCylinder, starts: np.ndarray,
                      index: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Angle (R,) [rad] and ratio eta0 (R,) of starts (R, 3) projected onto section ``index``."""
    p = as_points(starts, "starts")
    if p.ndim != 2:
        raise InvalidArgumentError(f"starts: expected shape (R, 3) or (3,), got {p.shape}")
    distance, angle = polar(cyl.to_local(p, np.full(len(p), index)))
    return angle, distance / cyl.radius(np.full(len(p), index), angle)


def ratio_schedule(eta0: np.ndarray, arc_length: np.ndarray, eta_final: float | None,
                   gamma: float) -> np.ndarray:
    """Ratios (R, N) along the cylinder: fixed eta0 (R,) if eta_final is None, else eq. 10."""
    eta0 = np.asarray(eta0, dtype=float)[:, None]
    if eta_final is None:
        return np.broadcast_to(eta0, (eta0.shape[0], len(arc_length)))
    return (eta0 - eta_final) * np.exp(-gamma * arc_length)[None, :] + eta_final


def reproduce(cyl: GeneralizedCylinder, starts: np.ndarray, eta_final: float | None = None,
              gamma: float = DEFAULT_GAMMA, allow_outside: bool = False) -> np.ndarray:
    """Reproductions (R, N, 3) [m] from starts (R, 3), or (N, 3) from a single start (3,).

    eta_final: None for the fixed-ratio rule, else the target ratio of the adaptive rule
    (0 convergent, 1 divergent); gamma: decay constant (>= 0) over the normalised arc length.
    A start outside the first boundary (ratio > 1) raises StartOutsideError unless
    ``allow_outside``.
    """
    if not isinstance(cyl, GeneralizedCylinder):
        raise InvalidArgumentError(f"cyl: expected a GeneralizedCylinder, got {type(cyl).__name__}")
    p = as_points(starts, "starts")
    single = p.ndim == 1
    if p.ndim not in (1, 2):
        raise InvalidArgumentError(f"starts: expected shape (R, 3) or (3,), got {p.shape}")
    p = np.atleast_2d(p)
    gamma = as_scalar(gamma, "gamma", minimum=0.0)
    if eta_final is not None:
        eta_final = as_scalar(eta_final, "eta_final", minimum=0.0,
                              maximum=None if allow_outside else 1.0)
    angle, eta0 = start_coordinates(cyl, p)
    outside = eta0 > 1.0 + OUTSIDE_TOLERANCE
    if outside.any() and not allow_outside:
        bad = np.flatnonzero(outside)
        raise StartOutsideError(
            f"starts: {len(bad)} start(s) lie outside the first cross-section (ratio > 1), "
            f"e.g. starts[{bad[0]}] with ratio {eta0[bad[0]]:.4g}; pass allow_outside=True "
            f"to reproduce from them anyway")
    # p = c + eta r(theta) (cos theta n + sin theta b), in cache-sized blocks of starts.
    sections = np.arange(cyl.num_sections)[None, :]
    basis = cyl.frames[:, 1:].transpose(1, 0, 2).reshape(2, -1)                 # (2, N*3)
    directions = np.stack([np.cos(angle), np.sin(angle)], axis=1)                 # (R, 2)
    out = np.empty((len(p), cyl.num_sections, 3))
    for block in range(0, len(p), BLOCK):
        rows = slice(block, block + BLOCK)
        scale = cyl.radius(sections, angle[rows, None])                           # (B, N)
        scale *= ratio_schedule(eta0[rows], cyl.arc_length, eta_final, gamma)
        chunk = out[rows]
        np.matmul(directions[rows], basis, out=chunk.reshape(len(scale), -1))
        chunk *= scale[..., None]
        chunk += cyl.directrix
    return out[0] if single else out


def random_starts(cyl: GeneralizedCylinder, count: int, rng: np.random.Generator | int,
                  index: int = 0) -> np.ndarray:
    """``count`` points (count, 3) [m] uniform in area inside section ``index``'s boundary.

    Angles are drawn with density proportional to r(angle)^2 (rejection), radii as
    r(angle) sqrt(U); ``rng`` is a numpy Generator or an integer seed.
    """
    count = as_count(count, "count", minimum=0)
    rng = as_generator(rng)
    idx = int(cyl.cross_sections.check_index(np.asarray(index)))
    grid = np.linspace(0.0, 2.0 * np.pi, 4096, endpoint=False)
    bound = 1.05 * float(cyl.radius(np.full(grid.shape, idx), grid).max()) ** 2
    angles = np.empty(0)
    while len(angles) < count:
        trial = rng.uniform(0.0, 2.0 * np.pi, max(2 * (count - len(angles)), 16))
        r2 = cyl.radius(np.full(trial.shape, idx), trial) ** 2
        angles = np.concatenate([angles, trial[rng.uniform(0.0, bound, len(trial)) < r2]])
    angles = angles[:count]
    radii = cyl.radius(np.full(count, idx), angles) * np.sqrt(rng.uniform(0.0, 1.0, count))
    local = radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    return cyl.to_world(local, np.full(count, idx))
