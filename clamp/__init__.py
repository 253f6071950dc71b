"""CLAMP: learned workspace trajectory priors and factor-graph skill reproduction.

Learning (:mod:`clamp.prior.learning`) turns demonstrations into a :class:`WorkspacePrior`
(:mod:`clamp.prior.linear_gaussian`); :func:`build` makes the planning problem (:mod:`clamp.graph.problem`: factor
families of :mod:`clamp.factors`, a GTSAM graph on demand) and :func:`plan` solves and checks
it (:mod:`clamp.planning.planner`, :mod:`clamp.optim.solver`), returning a :class:`PlanResult`; its stages
(:mod:`clamp.planning.pipeline`: :func:`make_request` -> :func:`model` -> :func:`solve` ->
:func:`posterior` -> :func:`evaluate`) can be run one by one.
"""
from __future__ import annotations

import lazy_loader

# the names and where they live: __init__.pyi (submodules load on first use: ``import clamp``
# and ``clamp --version`` do not load GTSAM, SciPy or the planner)
__getattr__, _lazy_dir, _lazy_names = lazy_loader.attach_stub(__name__, __file__)
__all__ = [*_lazy_names, "show"]


def __dir__() -> list[str]:
    return __all__


def show(result: PlanResult, demonstrations: object = None, **options: object) -> object:
    """Show a plan live in the browser (:class:`clamp.viz.viewer.PlanViewer`: arm, paths,
    posterior tube, obstacles; drag a box or the goal to replan) and return the viewer:
    ``viewer.url``, ``set_time(t)``, ``move_obstacle(k, center)``, ``result``, ``close()``.
    ``options``: port (0: a free one), host (loopback only), sigmas, tube_states."""
    from clamp.viz.viewer import PlanViewer   # deferred: viser is the optional "viewer" extra
    return PlanViewer(result, demonstrations=demonstrations, **options)
