"""Figures of generalized cylinders (headless matplotlib; callers save PNGs).

plot_cylinder: 3-D surface with demonstrations, directrix and reproductions.
plot_cross_sections: 2-D boundaries of chosen sections with their effective points and the
reproduction points that belong to them.
"""
from __future__ import annotations

from os import PathLike
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from skillplan.command_line import save_figure as _save_figure  # noqa: E402
from scenes.plotting import set_equal_axes_3d  # noqa: E402

from .cylinder import GeneralizedCylinder  # noqa: E402
from .errors import TLGCArgumentError  # noqa: E402
from .validation import as_count, as_points  # noqa: E402


def _as_reproductions(cyl: GeneralizedCylinder, reproductions: np.ndarray | None) -> np.ndarray | None:
    if reproductions is None:
        return None
    r = as_points(reproductions, "reproductions")
    r = r[None] if r.ndim == 2 else r
    if r.ndim != 3 or r.shape[1] != cyl.num_sections:
        raise TLGCArgumentError(
            f"reproductions: expected shape (R, {cyl.num_sections}, 3) or ({cyl.num_sections}, 3), got {r.shape}")
    return r


def plot_cylinder(cyl: GeneralizedCylinder, reproductions: np.ndarray | None = None,
                  num_angles: int = 36, num_rings: int = 120, title: str = "",
                  ax: plt.Axes | None = None) -> Figure:
    """3-D figure: cylinder surface, demonstrations (red), directrix (blue), reproductions (R, N, 3)."""
    reps = _as_reproductions(cyl, reproductions)
    num_rings = as_count(num_rings, "num_rings", minimum=2)
    if ax is None:
        fig = plt.figure(figsize=(8, 7))
        ax = fig.add_subplot(projection="3d")
    else:
        fig = ax.figure
    step = max(1, cyl.num_sections // num_rings)
    x, y, z = cyl.surface(num_angles, step)
    # draw in call order (surface first, paths over it): mplot3d's depth sorting would hide
    # the paths inside the cylinder behind its front faces
    ax.computed_zorder = False
    ax.plot_surface(x, y, z, color="tab:cyan", alpha=0.12, linewidth=0.15, edgecolor="tab:cyan",
                    rstride=1, cstride=1, shade=False, zorder=1)
    ax.plot([], [], color="tab:cyan", alpha=0.4, lw=6, label="cylinder surface")
    if cyl.demonstrations is not None:
        for m, demo in enumerate(cyl.demonstrations):
            ax.plot(*demo.T, color="tab:red", lw=1.2, label="demonstrations" if m == 0 else None, zorder=3)
    ax.plot(*cyl.directrix.T, color="tab:blue", lw=2.0, label="directrix", zorder=4)
    if reps is not None:
        for r, rep in enumerate(reps):
            ax.plot(*rep.T, color="tab:purple", lw=0.9, alpha=0.9,
                    label="reproductions" if r == 0 else None, zorder=5)
        ax.scatter(*reps[:, 0].T, color="k", s=8, label="starts", zorder=6)
    set_equal_axes_3d(ax, np.stack([x, y, z], axis=-1))
    ax.set_title(title or f"generalized cylinder ({cyl.cross_section} cross-sections)")
    ax.legend(loc="upper left", fontsize=8)
    return fig


def plot_cross_sections(cyl: GeneralizedCylinder, indices: Sequence[int],
                        reproductions: np.ndarray | None = None, num_angles: int = 256,
                        title: str = "") -> Figure:
    """2-D panels of sections ``indices`` in their [normal, binormal] plane [m]: boundary,
    directrix point, effective points and the matching points of reproductions (R, N, 3)."""
    idx = cyl.cross_sections.check_index(np.atleast_1d(np.asarray(indices)))
    if idx.ndim != 1 or len(idx) == 0:
        raise TLGCArgumentError(f"indices: expected a non-empty list of section indices, got {indices!r}")
    reps = _as_reproductions(cyl, reproductions)
    cols = min(len(idx), 4)
    rows = int(np.ceil(len(idx) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 3.4 * rows), squeeze=False)
    angles = np.linspace(0.0, 2.0 * np.pi, num_angles + 1)
    for ax, k in zip(axes.ravel(), idx):
        r = cyl.radius(np.full(angles.shape, k), angles)
        ax.plot(r * np.cos(angles), r * np.sin(angles), color="tab:cyan", lw=1.5, label="boundary")
        ax.plot(0.0, 0.0, "+", color="tab:blue", ms=10, label="directrix")
        if cyl.effective_points is not None:
            e = cyl.effective_points[:, k]
            ax.plot(e[:, 0], e[:, 1], "o", color="tab:red", ms=5, label="effective points")
        if reps is not None:
            q = cyl.to_local(reps[:, k], np.full(len(reps), k))
            ax.plot(q[:, 0], q[:, 1], ".", color="tab:purple", ms=3, label="reproductions")
        ax.set_aspect("equal")
        ax.set_title(f"section {k} (u = {cyl.arc_length[k]:.2f})", fontsize=9)
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[len(idx):]:
        ax.axis("off")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.suptitle(title or f"{cyl.cross_section} cross-sections (normal / binormal plane, m)")
    fig.tight_layout(rect=(0.0, 0.06, 1.0, 1.0))
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
    return fig


def save_figure(fig: Figure, path: str | PathLike, dpi: int = 120) -> None:
    """Write ``fig`` as PNG to ``path`` (atomically, no label clipped) and close it."""
    try:
        _save_figure(fig, path, dpi=dpi)
    finally:
        plt.close(fig)
