"""Reproduction from new start points by the fixed- and adaptive-ratio rules (paper eq. 8-10).

A start p0 must lie on the first section's plane (within ``plane_tolerance``, default 1 mm;
farther starts are refused with StartOffPlaneError, never silently projected). Its angle theta
and ratio eta0 = |p0 - c0| / r_0(theta) are taken in that plane. Point i of the reproduction
keeps the angle in frame i (Bishop frames carry it without twist) at ratio eta_i of that
section's boundary: p_i = c_i + eta_i r_i(theta) (cos theta n_i + sin theta b_i), with
eta_i = eta0 (fixed ratio) or eta_i = (eta0 - eta_f) exp(-gamma u_i) + eta_f (adaptive ratio,
u_i the normalised arc length of the directrix; eta_f = 0 convergent, 1 divergent).
All R reproductions are one broadcast over (R, N).

Threads: the per-block products have inner dimension 2; they are written as element-wise
operations (no BLAS call) and the whole call runs under :func:`skillplan.threads.single_blas_thread`,
so the time does not depend on the caller's BLAS thread setting.
"""
from __future__ import annotations

import numpy as np

from .cross_sections import polar
from .cylinder import GeneralizedCylinder, check_cylinder
from .errors import TLGCArgumentError, StartOffPlaneError, StartOutsideError
from skillplan.threads import single_blas_thread
from .validation import as_array, as_bool, as_count, as_generator, as_points, as_scalar

DEFAULT_GAMMA = 10.0     # decay constant of eq. 10: exp(-10) = 4.5e-5 of the gap is left at the end
OUTSIDE_TOLERANCE = 1e-9  # a start is inside the first section when its ratio <= 1 + this
PLANE_TOLERANCE = 1e-3   # [m] default largest distance of a start from the first section's plane
BLOCK = 64               # reproductions per block: keeps the (B, N) temporaries in cache


def start_coordinates(cyl: GeneralizedCylinder, starts: np.ndarray,
                      index: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Angle (R,) [rad] and ratio eta0 (R,) of starts (R, 3) in section ``index``'s plane
    (the in-plane part of each start; see :func:`check_starts` for the distance off it)."""
    p = as_points(starts, "starts")
    if p.ndim != 2:
        raise TLGCArgumentError(f"starts: expected shape (R, 3) or (3,), got {p.shape}")
    distance, angle = polar(cyl.to_local(p, np.full(len(p), index)))
    return angle, distance / cyl.radius(np.full(len(p), index), angle)


def check_starts(cyl: GeneralizedCylinder, starts: np.ndarray,
                 plane_tolerance: float = PLANE_TOLERANCE, allow_outside: bool = False,
                 name: str = "starts") -> tuple[np.ndarray, np.ndarray]:
    """Angle (R,) [rad] and ratio eta0 (R,) of starts (R, 3), refusing bad ones.

    A start farther than ``plane_tolerance`` [m] from the first section's plane raises
    StartOffPlaneError (with its distance); one outside the first boundary (ratio > 1 + 1e-9)
    raises StartOutsideError unless ``allow_outside``.
    """
    if isinstance(plane_tolerance, (float, np.floating)) and plane_tolerance == np.inf:
        tol = np.inf
    else:
        tol = as_scalar(plane_tolerance, "plane_tolerance", minimum=0.0)
    off = cyl.plane_offset(starts, np.zeros(len(starts), dtype=np.intp))
    far = np.abs(off) > tol
    if far.any():
        bad = np.flatnonzero(far)
        j = bad[np.argmax(np.abs(off[bad]))]
        side = "before" if off[j] < 0 else "past"
        raise StartOffPlaneError(
            f"{name}: {len(bad)} start(s) lie farther than plane_tolerance={tol:g} m from the "
            f"first cross-section's plane, e.g. {name}[{j}] at {abs(off[j]):.4g} m {side} it; "
            f"expected starts on that plane (move them onto it or raise plane_tolerance)")
    angle, eta0 = start_coordinates(cyl, starts)
    outside = eta0 > 1.0 + OUTSIDE_TOLERANCE
    if outside.any() and not allow_outside:
        bad = np.flatnonzero(outside)
        raise StartOutsideError(
            f"{name}: {len(bad)} start(s) lie outside the first cross-section (ratio > 1), "
            f"e.g. {name}[{bad[0]}] with ratio {eta0[bad[0]]:.4g}; pass allow_outside=True "
            f"to reproduce from them anyway")
    return angle, eta0


def ratio_schedule(eta0: np.ndarray, arc_length: np.ndarray, eta_final: float | None,
                   gamma: float) -> np.ndarray:
    """Ratios (R, N) along the cylinder: fixed eta0 (R,) if eta_final is None, else eq. 10."""
    eta0 = as_array(eta0, "eta0").reshape(-1)[:, None]
    arc_length = as_array(arc_length, "arc_length")
    gamma = as_scalar(gamma, "gamma", minimum=0.0)
    if eta_final is not None:
        eta_final = as_scalar(eta_final, "eta_final", minimum=0.0)
    if eta_final is None:
        return np.broadcast_to(eta0, (eta0.shape[0], len(arc_length)))
    return (eta0 - eta_final) * np.exp(-gamma * arc_length)[None, :] + eta_final


def reproduce(cyl: GeneralizedCylinder, starts: np.ndarray, eta_final: float | None = None,
              gamma: float = DEFAULT_GAMMA, allow_outside: bool = False,
              plane_tolerance: float = PLANE_TOLERANCE) -> np.ndarray:
    """Reproductions (R, N, 3) [m] from starts (R, 3), or (N, 3) from a single start (3,).

    eta_final: None for the fixed-ratio rule, else the target ratio of the adaptive rule
    (0 convergent, 1 divergent); gamma: decay constant (>= 0) over the normalised arc length.
    A start farther than ``plane_tolerance`` [m] from the first section's plane raises
    StartOffPlaneError (pass ``np.inf`` to project any start onto the plane); a start outside
    the first boundary (ratio > 1) raises StartOutsideError unless ``allow_outside``.
    Point i of every reproduction lies on section i's plane.
    """
    check_cylinder(cyl)
    allow_outside = as_bool(allow_outside, "allow_outside")
    p = as_points(starts, "starts")
    single = p.ndim == 1
    if p.ndim not in (1, 2):
        raise TLGCArgumentError(f"starts: expected shape (R, 3) or (3,), got {p.shape}")
    p = np.atleast_2d(p)
    gamma = as_scalar(gamma, "gamma", minimum=0.0)
    if eta_final is not None:
        eta_final = as_scalar(eta_final, "eta_final", minimum=0.0,
                              maximum=None if allow_outside else 1.0)
    with single_blas_thread():
        angle, eta0 = check_starts(cyl, p, plane_tolerance, allow_outside)
        out = _place(cyl, angle, ratio_schedule(eta0, cyl.arc_length, eta_final, gamma))
    return out[0] if single else out


def _place(cyl: GeneralizedCylinder, angle: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Points (R, N, 3) [m] at angles (R,) [rad] and ratios eta (R, N) of every section:
    p = c + eta r(theta) (cos theta n + sin theta b), in cache-sized blocks of starts."""
    sections = np.arange(cyl.num_sections)[None, :]
    normals = np.ascontiguousarray(cyl.normals)            # (N, 3); strided views are slow
    binormals = np.ascontiguousarray(cyl.binormals)
    cos, sin = np.cos(angle), np.sin(angle)
    out = np.empty((len(angle), cyl.num_sections, 3))
    spare = np.empty((min(BLOCK, len(angle)), cyl.num_sections, 3))
    for block in range(0, len(angle), BLOCK):
        rows = slice(block, block + BLOCK)
        scale = cyl.radius(sections, angle[rows, None])                           # (B, N)
        scale *= eta[rows]
        chunk = out[rows]
        other = spare[:len(chunk)]
        np.multiply(cos[rows, None, None], normals, out=chunk)                    # (B, N, 3)
        np.multiply(sin[rows, None, None], binormals, out=other)
        chunk += other
        chunk *= scale[..., None]
        chunk += cyl.directrix
    return out


def random_starts(cyl: GeneralizedCylinder, count: int, rng: np.random.Generator | int,
                  index: int = 0) -> np.ndarray:
    """``count`` points (count, 3) [m] uniform in area inside section ``index``'s boundary
    (on its plane).

    Angles are drawn with density proportional to r(angle)^2 (rejection), radii as
    r(angle) sqrt(U); ``rng`` is a numpy Generator or an integer seed.
    """
    check_cylinder(cyl)
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
