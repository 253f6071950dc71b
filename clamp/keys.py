"""GTSAM keys of the planner's variables."""
from __future__ import annotations

import gtsam

STATE_SYMBOL = "x"


def state_key(index: int) -> int:
    """Key of the joint state theta_i = [q, qdot] (2n,) of support state ``index``."""
    return gtsam.symbol(STATE_SYMBOL, int(index))
