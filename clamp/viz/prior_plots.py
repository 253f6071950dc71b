"""Figures of a learned trajectory prior: the mean with its 95 % envelope, with demonstrations.

- :func:`plot_prior_3d`: workspace prior in 3-D, mean path, demonstrations and a tube whose
  cross-section at every support state is the ``z sigma`` ellipse (z = 1.96 for 95 %) of the
  position covariance projected on the plane normal to the mean path.
- :func:`plot_weighted_priors`: the priors learned from cluttered demonstrations without and
  with obstacle weighting, side by side (sample weights, obstacles, clutter-free reference).
- :func:`plot_prior_time`: every coordinate against time (rows positions / velocities, one
  column per axis), demonstrations, mean and the marginal envelope ``mean -+ z sigma``.
Both build a bare ``matplotlib.figure.Figure`` (no pyplot, no GUI backend: headless) and
write a PNG when given ``path``.
"""
from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from clamp.errors import ShapeError
from clamp.prior.linear_gaussian import LinearGaussianPrior, check_prior, envelope_quantile
from clamp.validation import as_array, as_count
from skillplan.command_line import save_figure
from scenes.plotting import draw_obstacle

__all__ = ["plot_prior_3d", "plot_prior_time", "plot_weighted_priors", "envelope_tube"]

#: Mean-path steps shorter than this fraction of the longest step count as stationary: the
#: tube keeps the neighbouring direction there instead of following a noisy tangent.
STATIONARY_FRACTION = 0.05


def _demo_states(demos: object, prior: LinearGaussianPrior) -> np.ndarray | None:
    """Demonstrations as states (M, T, D): a Demonstrations-like object or an array."""
    if demos is None:
        return None
    if hasattr(demos, "positions") and hasattr(demos, "velocities"):
        states = np.concatenate([np.asarray(demos.positions, dtype=float),
                                 np.asarray(demos.velocities, dtype=float)], axis=2)
    else:
        states = demos
    return as_array(states, "demos", (None, prior.T, prior.D))


def _finish(fig: Figure, path: str | os.PathLike[str] | None, dpi: int) -> Figure:
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=dpi)
    return fig


def _transported_normals(tangent: np.ndarray) -> np.ndarray:
    """Unit normals (T, 3) carried along unit tangents (T, 3) without twisting.

    Parallel transport: each normal is the previous one rotated by the rotation taking the
    previous tangent to the current one (a cheap O(T) recursion, plotting only).
    """
    first = np.eye(3)[np.argmin(np.abs(tangent[0]))]
    normals = np.empty_like(tangent)
    normals[0] = np.cross(tangent[0], first) / np.linalg.norm(np.cross(tangent[0], first))
    for i in range(1, len(tangent)):
        n = normals[i - 1] - tangent[i] * (tangent[i] @ normals[i - 1])
        norm = np.linalg.norm(n)
        if norm < 1e-9:  # tangent turned onto the old normal: restart from a fixed helper
            n = np.cross(tangent[i], np.eye(3)[np.argmin(np.abs(tangent[i]))])
            norm = np.linalg.norm(n)
        normals[i] = n / norm
    return normals


def envelope_tube(prior: LinearGaussianPrior, level: float = 0.95,
                  resolution: int = 24) -> np.ndarray:
    """Surface points (T, resolution, 3) of the position envelope tube of a prior
    (:func:`covariance_tube` of its mean path and position covariances)."""
    if prior.num_axes != 3:
        raise ShapeError(f"prior: expected a workspace prior with 3 position axes, "
                         f"got {prior.num_axes}")
    return covariance_tube(prior.mean[:, :3], prior.cov[:, :3, :3], level, resolution)


def covariance_tube(centre: np.ndarray, cov: np.ndarray, level: float = 0.95,
                    resolution: int = 24) -> np.ndarray:
    """Surface points (T, resolution, 3) of the tube around a path centre (T, 3) [m] with
    position covariances cov (T, 3, 3) [m^2].

    At state i the cross-section is the ellipse ``centre_i + z L_i [cos a, sin a]`` in the
    plane normal to the path (frames carried by parallel transport so the surface does not
    twist), L_i the Cholesky factor of the covariance projected on that plane, z the two-sided
    normal quantile of ``level`` (1.96 for 0.95).
    """
    z = envelope_quantile(level)
    resolution = as_count(resolution, "resolution", minimum=3)
    T = len(centre)
    tangent = np.gradient(centre, axis=0)
    length = np.linalg.norm(tangent, axis=1)
    valid = length > STATIONARY_FRACTION * max(float(length.max()), 1e-300)
    if not np.any(valid):
        tangent, valid = np.tile([0.0, 0.0, 1.0], (T, 1)), np.ones(T, bool)
    # Carry the last valid tangent over stationary stretches (forward, then backward fill).
    idx = np.maximum.accumulate(np.where(valid, np.arange(T), 0))
    idx = np.where(valid[idx], idx, np.argmax(valid))
    tangent = tangent[idx] / np.linalg.norm(tangent[idx], axis=1, keepdims=True)
    normal = _transported_normals(tangent)
    binormal = np.cross(tangent, normal)
    basis = np.stack([normal, binormal], axis=2)                  # (T, 3, 2)
    cov2 = np.swapaxes(basis, 1, 2) @ cov @ basis                 # (T, 2, 2)
    scale = max(float(np.trace(cov2, axis1=1, axis2=2).max()), 1e-300)
    root = np.linalg.cholesky(cov2 + 1e-12 * scale * np.eye(2))   # continuous in cov2
    angle = np.linspace(0.0, 2.0 * np.pi, resolution)
    circle = np.stack([np.cos(angle), np.sin(angle)])             # (2, R)
    offsets = basis @ root @ circle                               # (T, 3, R)
    return centre[:, None, :] + z * np.swapaxes(offsets, 1, 2)


def plot_prior_3d(prior: LinearGaussianPrior, demos: object = None, *, level: float = 0.95,
                  path: str | os.PathLike[str] | None = None, title: str | None = None,
                  dpi: int = 120) -> Figure:
    """3-D figure of a workspace prior: mean path, demonstrations, ``level`` envelope tube.

    demos: Demonstrations-like object or states (M, T, 6), optional. Writes a PNG to ``path``
    if given; returns the figure.
    """
    check_prior(prior)
    fig = Figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    _draw_prior_3d(ax, prior, _demo_states(demos, prior), level)
    ax.set_title(title or f"{prior.kind} prior (T = {prior.T})")
    ax.legend(loc="upper left", fontsize=8)
    return _finish(fig, path, dpi)


def _draw_prior_3d(ax, prior: LinearGaussianPrior, states: np.ndarray | None, level: float,
                   weights: np.ndarray | None = None) -> None:
    """Envelope tube, demonstrations (faded where their weights (M, T) are small), mean."""
    tube = envelope_tube(prior, level)
    ax.plot_surface(tube[..., 0], tube[..., 1], tube[..., 2], color="tab:blue", alpha=0.18,
                    linewidth=0, shade=False)
    if states is not None:
        for m, demo in enumerate(states):
            ax.plot(*demo[:, :3].T, color="0.4", lw=0.8,
                    label="demonstrations" if m == 0 else None)
        if weights is not None:
            points = states[..., :3].reshape(-1, 3)
            ax.scatter(*points.T, c=weights.reshape(-1), cmap="viridis", vmin=0.0, vmax=1.0,
                       s=1, alpha=0.6, label="sample weight")
    ax.plot(*prior.mean[:, :3].T, color="tab:blue", lw=2.2, label="prior mean")
    ax.plot([], [], color="tab:blue", alpha=0.3, lw=6, label=f"{100 * level:.0f} % envelope")
    ax.scatter(*prior.mean[0, :3], color="tab:green", s=30, label="start")
    ax.scatter(*prior.mean[-1, :3], color="tab:red", s=30, label="end")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")


def plot_weighted_priors(unweighted: LinearGaussianPrior, weighted: LinearGaussianPrior,
                         demos: object, *, weights: np.ndarray | None = None,
                         reference: np.ndarray | None = None, level: float = 0.95,
                         path: str | os.PathLike[str] | None = None, dpi: int = 120) -> Figure:
    """Side by side: the prior learned from cluttered demonstrations without and with obstacle
    weighting. demos: Demonstrations-like (its recorded obstacles are drawn);
    weights (M, T) sample weights shown on the right; reference (T, 3) [m] e.g. the
    clutter-free skill's mean, dashed on both. Writes a PNG to ``path`` if given."""
    check_prior(unweighted, "unweighted")
    states = _demo_states(demos, check_prior(weighted, "weighted"))
    if weights is not None:
        weights = as_array(weights, "weights", (len(states), weighted.T))
    fig = Figure(figsize=(13, 6))
    obstacles = [ob for group in (getattr(demos, "obstacles", None) or []) for ob in group]
    for k, (prior, name, w) in enumerate(((unweighted, "unweighted", None),
                                          (weighted, "obstacle-weighted", weights))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        _draw_prior_3d(ax, prior, _demo_states(demos, prior), level, w)
        if reference is not None:
            ref = as_array(reference, "reference", (prior.T, 3))
            ax.plot(*ref.T, color="k", ls="--", lw=1.2, label="clutter-free skill")
            gap = float(np.sqrt(np.mean(np.sum((prior.mean[:, :3] - ref) ** 2, axis=1))))
            name += f" prior: rms {1000 * gap:.1f} mm from the clutter-free skill"
        for obstacle in obstacles:
            draw_obstacle(ax, obstacle, alpha=0.15)
        ax.set_title(name if reference is not None else f"{name} prior", fontsize=10)
        ax.legend(loc="upper left", fontsize=7)
    return _finish(fig, path, dpi)


def plot_prior_time(prior: LinearGaussianPrior, demos: object = None, *, level: float = 0.95,
                    path: str | os.PathLike[str] | None = None, title: str | None = None,
                    dpi: int = 120) -> Figure:
    """Prior against time: rows positions / velocities, one column per axis (or joint).

    Shows demonstrations (optional; Demonstrations-like or states (M, T, D)), the prior mean
    and its marginal ``level`` envelope. Writes a PNG to ``path`` if given.
    """
    lower, upper = check_prior(prior).envelope(level)
    states = _demo_states(demos, prior)
    A = prior.num_axes
    fig = Figure(figsize=(3.2 * A, 5.2))
    axes = fig.subplots(2, A, sharex=True, squeeze=False)
    unit = ("m", "m/s") if prior.kind == "workspace" else ("rad", "rad/s")
    for k in range(prior.D):
        ax = axes[k // A, k % A]
        ax.fill_between(prior.time, lower[:, k], upper[:, k], color="tab:blue", alpha=0.2,
                        lw=0, label=f"{100 * level:.0f} % envelope")
        if states is not None:
            for m, demo in enumerate(states[:, :, k]):
                ax.plot(prior.time, demo, color="0.4", lw=0.7,
                        label="demonstrations" if m == 0 else None)
        ax.plot(prior.time, prior.mean[:, k], color="tab:blue", lw=1.8, label="prior mean")
        ax.set_ylabel(f"{prior.state_names[k]} [{unit[k // A]}]")
        if k // A == 1:
            ax.set_xlabel("skill time [s]")
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(title or f"{prior.kind} prior against time")
    return _finish(fig, path, dpi)


def plot_prior_orientation(prior: LinearGaussianPrior, demos: object = None, *,
                           level: float = 0.95, samples: int = 400,
                           path: str | os.PathLike[str] | None = None, title: str | None = None,
                           dpi: int = 120) -> Figure:
    """A pose prior's orientation against time: the angle [deg] of the hand from the prior's
    mean rotation, with the band holding ``level`` of the chain's rotations at every step
    (quantiles of ``samples`` seeded draws of its orientation chain), the demonstrations'
    angles from it (optional: a Demonstrations with ``orientations``) and their spread (the
    largest angle, :attr:`~clamp.prior.orientation_prior.OrientationPrior.angle_radius`).
    Writes a PNG to ``path`` if given; InvalidParameterError for a position-only prior."""
    from clamp.errors import InvalidParameterError
    from clamp.prior import so3
    orientation = getattr(check_prior(prior), "orientation", None)
    if orientation is None:
        raise InvalidParameterError("prior: expected a pose prior (learned from demonstrations "
                                    "with orientations), got a position-only prior")
    mean = orientation.mean_rotations
    drawn = orientation.sample(as_count(samples, "samples"), 20261129)[..., :3]
    angle = np.degrees(so3.angle_between(mean, orientation.rotations @ so3.exp_map(drawn)))
    band = np.quantile(angle, level, axis=0)
    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.add_subplot()
    ax.fill_between(prior.time, 0.0, band, color="tab:blue", alpha=0.2, lw=0,
                    label=f"{100 * level:.0f} % of the prior's rotations")
    ax.plot(prior.time, np.degrees(orientation.angle_radius), color="tab:orange", lw=1.2,
            ls="--", label="demonstrations' spread (largest angle)")
    quaternions = getattr(demos, "orientations", None)
    if quaternions is not None:
        rotations = so3.from_quaternions(as_array(quaternions, "demos.orientations",
                                                  (None, prior.T, 4)))
        for m, demo in enumerate(np.degrees(so3.angle_between(mean, rotations))):
            ax.plot(prior.time, demo, color="0.4", lw=0.7,
                    label="demonstrations" if m == 0 else None)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("angle from the mean rotation [deg]")
    ax.legend(fontsize=7, loc="best")
    ax.set_title(title or "orientation prior against time", fontsize=9)
    return _finish(fig, path, dpi)
