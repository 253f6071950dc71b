"""GTSAM keys of the planner's variables and the stacking of their vectors to / from arrays.

The keys are computed without GTSAM (its encoding of a symbol, :func:`symbol_key`): the fast
solver's problems use them and never load it; the conversions load it when called."""
from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import gtsam

STATE_SYMBOL = "x"


def symbol_key(character: str, index: int) -> int:
    """GTSAM's key of the symbol (``character``, ``index``), as ``gtsam.symbol`` makes it: the
    character's code in the top 8 of 64 bits, the index (0 <= index < 2**56) below."""
    return (ord(character) << 56) | int(index)


def state_key(index: int) -> int:
    """Key of the joint state theta_i = [q, qdot] (2n,) of support state ``index``."""
    return symbol_key(STATE_SYMBOL, index)


@lru_cache(maxsize=8)
def state_keys(num_states: int) -> tuple[int, ...]:
    """Keys of the joint states of support states 0 .. num_states - 1 (the problems of one
    plan share them; a few lengths are kept)."""
    return tuple(state_key(i) for i in range(int(num_states)))


def values_to_states(values: gtsam.Values | gtsam.VectorValues, keys: Sequence[int]) -> np.ndarray:
    """Stack the vectors of ``keys`` (T, d) from GTSAM (Vector)Values.

    When ``values`` holds exactly ``keys`` (GTSAM stores them sorted), the vectors are read in
    one C++ call (Values: utilities.extractVectors of the keys' symbol; VectorValues: vector()).
    """
    import gtsam
    keys = list(keys)
    if values.size() == len(keys) and keys == sorted(keys):
        if isinstance(values, gtsam.VectorValues):
            if all(values.exists(k) for k in keys):
                return values.vector().reshape(len(keys), -1)
        elif list(values.keys()) == keys and \
                len({gtsam.Symbol(k).chr() for k in (keys[0], keys[-1])}) == 1:
            try:  # GTSAM refuses vectors of different sizes
                stacked = gtsam.utilities.extractVectors(values, chr(gtsam.Symbol(keys[0]).chr()))
            except RuntimeError:
                stacked = None
            if stacked is not None and stacked.shape[0] == len(keys):
                return stacked
    get = values.atVector if isinstance(values, gtsam.Values) else values.at
    return np.stack([get(k) for k in keys])


def states_to_values(theta: np.ndarray, keys: Sequence[int]) -> gtsam.Values:
    """GTSAM Values holding row i of theta (T, d) under keys[i]."""
    import gtsam
    values = gtsam.Values()
    for key, row in zip(keys, theta):
        values.insert(key, row)
    return values
