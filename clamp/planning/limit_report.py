"""Joint-limit violations of a trajectory in words (used by the plan verdict): the joint-limit
family's own report, :func:`clamp.factors.joint_limits.limit_violations`."""
from __future__ import annotations

from clamp.factors.joint_limits import limit_violations

__all__ = ["limit_violations"]
