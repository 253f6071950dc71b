"""CLAMP: learned workspace trajectory priors and factor-graph skill reproduction.

Learning (:mod:`clamp.prior.learning`) turns demonstrations into a :class:`WorkspacePrior`
(:mod:`clamp.prior.linear_gaussian`); :func:`build` makes the planning problem (:mod:`clamp.graph.problem`: factor
families of :mod:`clamp.factors`, a GTSAM graph on demand) and :func:`plan` solves and checks
it (:mod:`clamp.planning.planner`, :mod:`clamp.optim.solver`), returning a :class:`PlanResult`; its stages
(:mod:`clamp.planning.pipeline`: :func:`make_request` -> :func:`model` -> :func:`solve` ->
:func:`posterior` -> :func:`evaluate`) can be run one by one.
"""
from clamp.config import CheckConfig, ModelConfig, OptimizerConfig, PlannerConfig
from clamp.errors import (ClampError, ClampWarning, InsufficientDemonstrationsError,
                          InvalidParameterError, NonFiniteError, PriorFileError, ShapeError)
from clamp.prior.learning import learn_joint_prior, learn_prior
from clamp.optim.optimizers import optimize
from clamp.planning.pipeline import Model, Posterior, Solution, model, posterior, solve
from clamp.planning.planner import build, plan, plan_model
from clamp.planning.request import Request, make_request
from clamp.planning.verdict import evaluate
from clamp.prior.linear_gaussian import LinearGaussianPrior, WorkspacePrior
from clamp.graph.problem import PlanningProblem
from clamp.planning.replanning import replan
from clamp.planning.result import PlanResult
from clamp.prior.obstacle_weighting import ObstacleWeighting
from clamp.prior.conditioning import condition_prior

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


def show(result: PlanResult, demonstrations: object = None, **options: object) -> object:
    """Show a plan live in the browser (:class:`clamp.viz.viewer.PlanViewer`: arm, paths,
    posterior tube, obstacles; drag a box or the goal to replan) and return the viewer:
    ``viewer.url``, ``set_time(t)``, ``move_obstacle(k, center)``, ``result``, ``close()``.
    ``options``: port (0: a free one), host (loopback only), sigmas, tube_states."""
    from clamp.viz.viewer import PlanViewer   # deferred: viser is the optional "viewer" extra
    return PlanViewer(result, demonstrations=demonstrations, **options)
