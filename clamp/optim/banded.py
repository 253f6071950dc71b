"""Block-tridiagonal matrices (T blocks of d x d) and LAPACK's lower band storage.

The planner's Gauss-Newton information matrix H is block-tridiagonal: diagonal blocks
D (T, d, d), upper blocks E (T-1, d, d) (E[i] = H[i, i+1]). LAPACK's banded routines take the
lower band storage (2d, T d): H[r, c] at band[r - c, c] for r >= c (bandwidth 2d - 1).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np


class BandLayout:
    """Index maps from block-tridiagonal blocks (T blocks of d x d) to LAPACK lower band storage
    (2d, T d): H[r, c] at band[r - c, c] for r >= c."""

    def __init__(self, T: int, d: int):
        self.T, self.d = T, d
        a, b = np.meshgrid(np.arange(d), np.arange(d), indexing="ij")    # row a, column b
        lower = a >= b
        t = np.arange(T)[:, None]
        self.diag_target = ((a[lower] - b[lower])[None] * (T * d) + t * d + b[lower][None]).ravel()
        self.diag_source = (t * d * d + (a[lower] * d + b[lower])[None]).ravel()
        # block (t+1, t) = E[t]^T: H[(t+1)d + a, t d + b] = E[t][b, a]; r - c = d + a - b
        t1 = np.arange(T - 1)[:, None]
        off = (d + a - b) < 2 * d
        self.off_target = (((d + a - b)[off])[None] * (T * d) + t1 * d + b[off][None]).ravel()
        self.off_source = (t1 * d * d + (b[off] * d + a[off])[None]).ravel()
        N = T * d
        #: row index (2d, T d) of every band entry (clipped at the last row past the end)
        self.rows = np.minimum(np.arange(N)[None, :] + np.arange(2 * d)[:, None], N - 1)

    def band(self, D: np.ndarray, E: np.ndarray) -> np.ndarray:
        """Lower band storage (2d, T d) of the symmetric block-tridiagonal (D, E)."""
        out = np.zeros(2 * self.d * self.T * self.d)
        out[self.diag_target] = D.reshape(-1)[self.diag_source]
        out[self.off_target] = E.reshape(-1)[self.off_source]
        return out.reshape(2 * self.d, self.T * self.d)

    def blocks(self, band: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The lower triangle of the band (2d, T d) as blocks: diagonal blocks (T, d, d) (their
        upper triangles zero) and sub-diagonal blocks L[i+1, i] (T-1, d, d)."""
        d, T = self.d, self.T
        flat = band.reshape(-1)
        D = np.zeros(T * d * d)
        D[self.diag_source] = flat[self.diag_target]
        E = np.zeros((T - 1) * d * d)
        E[self.off_source] = flat[self.off_target]
        return D.reshape(T, d, d), np.swapaxes(E.reshape(T - 1, d, d), 1, 2)


@lru_cache(maxsize=2)
def band_layout(T: int, d: int) -> BandLayout:
    """The (shared, read-only) layout for T blocks of d x d; the two most recent shapes are
    kept (a few MB at T = 2000), so repeated plans of one skill do not rebuild it."""
    layout = BandLayout(T, d)
    for array in (layout.diag_target, layout.diag_source, layout.off_target, layout.off_source,
                  layout.rows):
        array.flags.writeable = False
    return layout
