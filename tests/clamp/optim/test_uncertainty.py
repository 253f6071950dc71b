"""Block-tridiagonal selected inverse against a dense inverse; the plan's covariance output."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp.errors import InvalidParameterError, NonFiniteError
from clamp.optim.uncertainty import block_tridiagonal_inverse


def random_information(T: int, d: int, rng, spread: float, ridge: float = 1.0) -> np.ndarray:
    """Dense SPD block-tridiagonal H = J^T J + ridge I, J block bidiagonal with block scales
    10^+-spread (the ridge keeps the dense reference inverse accurate)."""
    J = np.zeros((T * d + d, T * d))
    for i in range(T):
        J[i * d:(i + 1) * d, i * d:(i + 1) * d] = rng.normal(size=(d, d)) * 10 ** rng.uniform(-spread, spread)
        if i + 1 < T:
            J[(i + 1) * d:(i + 2) * d, i * d:(i + 1) * d] = rng.normal(size=(d, d))
    return J.T @ J + ridge * np.eye(T * d)


def blocks(H: np.ndarray, T: int, d: int):
    D = np.stack([H[i * d:(i + 1) * d, i * d:(i + 1) * d] for i in range(T)])
    E = np.stack([H[i * d:(i + 1) * d, (i + 1) * d:(i + 2) * d] for i in range(T - 1)]) \
        if T > 1 else np.zeros((0, d, d))
    return D, E


@pytest.mark.parametrize("T, d", [(1, 2), (2, 3), (5, 12), (50, 12)])
def test_selected_inverse_equals_the_dense_inverse(T, d):
    rng = np.random.default_rng(T * 100 + d)
    H = random_information(T, d, rng, spread=1.0)
    D, E = blocks(H, T, d)
    dense = np.linalg.inv(H)
    expected = np.stack([dense[i * d:(i + 1) * d, i * d:(i + 1) * d] for i in range(T)])
    np.testing.assert_allclose(block_tridiagonal_inverse(D, E), expected, rtol=1e-8,
                               atol=1e-10 * np.abs(expected).max())


def test_badly_scaled_coordinates_keep_their_relative_accuracy():
    """One state's coordinates scaled by 1e6 (a stiff learned prior next to soft joints)."""
    T, d = 20, 4
    rng = np.random.default_rng(1)
    H = random_information(T, d, rng, spread=0.5)
    scale = np.tile([1e6, 1.0, 1e-3, 1.0], T)
    Hs = H * scale[:, None] * scale[None, :]
    D, E = blocks(Hs, T, d)
    dense = np.linalg.inv(H) / scale[:, None] / scale[None, :]
    C = block_tridiagonal_inverse(D, E)
    for i in range(T):
        ref = dense[i * d:(i + 1) * d, i * d:(i + 1) * d]
        np.testing.assert_allclose(np.diag(C[i]), np.diag(ref), rtol=1e-8)


def test_singular_information_names_the_state():
    T, d = 6, 3
    rng = np.random.default_rng(2)
    J = rng.normal(size=(T * d + d, T * d)) * (np.abs(np.subtract.outer(
        np.arange(T * d + d) // d, np.arange(T * d) // d)) <= 1)
    J[:, -1] = J[:, -2]                                 # the last state's two coordinates alias
    H = J.T @ J
    D, E = blocks(H, T, d)
    with raises_naming(InvalidParameterError, "state 5"):
        block_tridiagonal_inverse(D, E)
    with raises_naming(NonFiniteError, "D"):
        block_tridiagonal_inverse(np.full((2, 2, 2), np.nan), np.zeros((1, 2, 2)))
