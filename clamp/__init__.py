"""CLAMP: learned workspace trajectory priors and factor-graph skill reproduction.

Learning (:mod:`clamp.learning`) turns demonstrations into a :class:`WorkspacePrior`
(:mod:`clamp.prior`); :func:`build` makes the planning problem (:mod:`clamp.problem`: factor
families of :mod:`clamp.factors`, a GTSAM graph on demand) and :func:`plan` solves and checks
it (:mod:`clamp.planner`, :mod:`clamp.solver`), returning a :class:`PlanResult`; its stages
(:mod:`clamp.pipeline`: :func:`make_request` -> :func:`model` -> :func:`solve` ->
:func:`posterior` -> :func:`evaluate`) can be run one by one.
"""
from clamp.config import CheckConfig, ModelConfig, OptimizerConfig, PlannerConfig
from clamp.errors import (ClampError, ClampWarning, InsufficientDemonstrationsError,
                          InvalidParameterError, NonFiniteError, PriorFileError, ShapeError)
from clamp.learning import learn_joint_prior, learn_prior
from clamp.optimizers import optimize
from clamp.pipeline import Model, Posterior, Solution, model, posterior, solve
from clamp.planner import build, plan, plan_model
from clamp.request import Request, make_request
from clamp.verdict import evaluate
from clamp.prior import LinearGaussianPrior, WorkspacePrior
from clamp.problem import PlanningProblem
from clamp.replanning import replan
from clamp.result import PlanResult
from clamp.obstacle_weighting import ObstacleWeighting
from clamp.conditioning import condition_prior

__all__ = [
    "learn_prior", "learn_joint_prior", "WorkspacePrior", "LinearGaussianPrior",
    "PlannerConfig", "ModelConfig", "OptimizerConfig", "CheckConfig",
    "plan", "build", "replan",
    "make_request", "Request", "model", "Model", "solve", "Solution", "posterior", "Posterior",
    "evaluate", "plan_model", "condition_prior", "ObstacleWeighting", "optimize",
    "PlanningProblem", "PlanResult",
    "ClampError", "ClampWarning", "InsufficientDemonstrationsError", "InvalidParameterError",
    "NonFiniteError", "PriorFileError", "ShapeError",
]
