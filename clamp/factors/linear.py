"""Linear Gaussian factors in pure C++: a whitened JacobianFactor inside a LinearContainerFactor.

The factor's error is 0.5 || R (sum_k A_k theta_k - b) ||^2; it is linearized around zero so
GTSAM evaluates it at any point without calling Python.
"""
from __future__ import annotations

from collections.abc import Sequence

import gtsam
import numpy as np


def linear_factor(keys: Sequence[int], matrices: Sequence[np.ndarray], b: np.ndarray,
                  sqrt_information: np.ndarray) -> gtsam.LinearContainerFactor:
    """sum_k A_k theta_k - b with noise of square-root information R (m, m).

    matrices: one A_k (m, d_k) per key; b (m,).
    """
    R = np.asarray(sqrt_information, dtype=float)
    whitened = [np.ascontiguousarray(R @ A) for A in matrices]
    rhs = R @ np.asarray(b, dtype=float)
    unit = gtsam.noiseModel.Unit.Create(len(rhs))
    args: list = []
    for key, A in zip(keys, whitened):
        args += [key, A]
    jacobian_factor = gtsam.JacobianFactor(*args, rhs, unit)
    zero = gtsam.Values()
    for key, A in zip(keys, whitened):
        zero.insert(key, np.zeros(A.shape[1]))
    return gtsam.LinearContainerFactor(jacobian_factor, zero)
