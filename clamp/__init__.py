"""CLAMP: learned workspace trajectory priors and factor-graph skill reproduction.

Learning (:mod:`clamp.learning`) turns demonstrations into a :class:`WorkspacePrior`
(:mod:`clamp.prior`); the planner (:mod:`clamp.planner`) reproduces the skill on a robot.
"""
from clamp.errors import (ClampError, ClampWarning, InsufficientDemonstrationsError,
                          InvalidParameterError, NonFiniteError, PriorFileError, ShapeError)
from clamp.learning import learn_joint_prior, learn_prior
from clamp.prior import LinearGaussianPrior, WorkspacePrior
from clamp.planner import PlannerConfig, PlanResult, build, plan

__all__ = [
    "learn_prior", "learn_joint_prior", "WorkspacePrior", "LinearGaussianPrior",
    "PlannerConfig", "plan", "build", "PlanResult",
    "ClampError", "ClampWarning", "InsufficientDemonstrationsError", "InvalidParameterError",
    "NonFiniteError", "PriorFileError", "ShapeError",
]
