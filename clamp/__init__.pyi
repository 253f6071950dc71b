# The public names of clamp, read by static type checkers and, at run time, by
# lazy_loader.attach_stub in __init__.py (each submodule is imported on first use).
from .config import CheckConfig, ModelConfig, OptimizerConfig, PlannerConfig
from .errors import (ClampError, ClampWarning, InsufficientDemonstrationsError,
                          InvalidParameterError, NonFiniteError, PriorFileError, ShapeError)
from .prior.learning import learn_joint_prior, learn_prior
from .optim.optimizers import optimize
from .planning.pipeline import Model, Posterior, Solution, model, posterior, solve
from .planning.planner import build, plan, plan_model
from .planning.request import Request, make_request
from .planning.verdict import evaluate
from .prior.linear_gaussian import LinearGaussianPrior, WorkspacePrior
from .graph.problem import PlanningProblem
from .planning.replanning import replan
from .planning.result import PlanResult
from .prior.obstacle_weighting import ObstacleWeighting
from .prior.conditioning import condition_prior

__all__ = [
    "learn_prior", "learn_joint_prior", "WorkspacePrior", "LinearGaussianPrior",
    "PlannerConfig", "ModelConfig", "OptimizerConfig", "CheckConfig",
    "plan", "build", "replan",
    "make_request", "Request", "model", "Model", "solve", "Solution", "posterior", "Posterior",
    "evaluate", "plan_model", "condition_prior", "ObstacleWeighting", "optimize",
    "PlanningProblem", "PlanResult", "show",
    "ClampError", "ClampWarning", "InsufficientDemonstrationsError", "InvalidParameterError",
    "NonFiniteError", "PriorFileError", "ShapeError",
]


def show(result: PlanResult, demonstrations: object = None, **options: object) -> object: ...
