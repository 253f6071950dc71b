"""CLAMP: learned workspace trajectory priors and factor-graph skill reproduction.

Learning (:mod:`clamp.learning`) turns demonstrations into a :class:`WorkspacePrior`
(:mod:`clamp.prior`); the planner (:mod:`clamp.planner`) reproduces the skill on a robot.
"""
from clamp.errors import (ClampError, ClampWarning, InsufficientDemonstrationsError,
                          InvalidParameterError, NonFiniteError, PriorFileError, ShapeError)
from clamp.learning import learn_joint_prior, learn_prior
from clamp.prior import LinearGaussianPrior, WorkspacePrior

__all__ = [
    "learn_prior", "learn_joint_prior", "WorkspacePrior", "LinearGaussianPrior",
    "ClampError", "ClampWarning", "InsufficientDemonstrationsError", "InvalidParameterError",
    "NonFiniteError", "PriorFileError", "ShapeError",
]

try:  # the planner is written concurrently; import it plainly once clamp/planner.py exists
    from clamp.planner import PlanResult, PlannerConfig, build, plan
except ModuleNotFoundError as _exc:  # pragma: no cover - only before clamp.planner lands
    if _exc.name != "clamp.planner":
        raise
else:
    __all__ += ["PlannerConfig", "plan", "build", "PlanResult"]
