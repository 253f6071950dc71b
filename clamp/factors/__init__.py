"""Factor families of the CLAMP planner, one module per family (see :mod:`clamp.factors.family`).

A new family is one file in this package with a :class:`Family` subclass: every module here is
imported with the package and its families exported (``from clamp.factors import MyFamily``),
with no list to edit. Pass an instance in ``clamp.plan(extra_factors=[...])`` (or add it to
:func:`clamp.planning.assembly.planner_families` for a built-in one). A constraint family
(``role = "constraint"``: a hinge max(0, g + shift), see :mod:`clamp.factors.family`) declares
its own check, which the planner's judge runs and the verdict reports, and one that should join
the solve only once its check fails sets ``lazy = True`` (as self-collision and the skill tube
do): :func:`lazy_families` finds it.
"""
import importlib
import inspect
import pkgutil

from .ee_position import EEPositionFamily
from .family import (CheckContext, Constraint, ConstraintCheck, Family, Linearization,
                     square_root_information)
from .joint_gp import JointGPFamily, joint_gp_covariance, joint_gp_transition
from .joint_limits import JointLimitFamily
from .joint_target import JointTargetFamily
from .obstacle import DistanceQuery, ObstacleFamily
from .orientation import OrientationFamily
from .posture import PostureFamily
from .posture_motion import PostureMotionFamily
from .posture_velocity import PostureVelocityFamily
from .self_collision import SelfCollisionFamily
from .skill_tube import SkillTubeFamily
from .states import StateWindow
from .workspace_gp import WorkspaceGPFamily
from .workspace_start import WorkspaceStartFamily, shifted_start_mean

__all__ = [
    "Family", "Linearization", "Constraint", "ConstraintCheck", "CheckContext", "StateWindow",
    "square_root_information", "lazy_families", "declared_families",
    "WorkspaceGPFamily", "WorkspaceStartFamily", "shifted_start_mean",
    "JointGPFamily", "joint_gp_transition", "joint_gp_covariance",
    "JointTargetFamily", "EEPositionFamily", "ObstacleFamily", "DistanceQuery",
    "JointLimitFamily", "OrientationFamily", "PostureFamily", "PostureMotionFamily", "PostureVelocityFamily", "SelfCollisionFamily",
    "SkillTubeFamily",
]

#: the Family subclasses defined in this package, in module then source order
_DECLARED: list[type[Family]] = []
for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    _loaded = importlib.import_module(f"{__name__}.{_module}")
    for _name, _cls in inspect.getmembers(_loaded, inspect.isclass):
        if issubclass(_cls, Family) and _cls is not Family and _cls.__module__ == _loaded.__name__:
            _DECLARED.append(_cls)
            if _name not in globals():              # a new family file: exported as well
                globals()[_name] = _cls
                __all__.append(_name)


def declared_families() -> tuple[type[Family], ...]:
    """Every Family subclass defined in the clamp.factors package."""
    return tuple(_DECLARED)


def lazy_families() -> tuple[type[Family], ...]:
    """The lazy constraint families declared in the package (``lazy = True``; one per name),
    in check order: the planner judges every plan with their checks and adds a family to the
    solve (:meth:`Family.joining`) when its check first fails."""
    found: dict[str, type[Family]] = {}
    for cls in _DECLARED:
        if cls.role == "constraint" and cls.__dict__.get("lazy", False):
            found.setdefault(cls.name, cls)
    return tuple(sorted(found.values(), key=lambda cls: (cls.check_rank, cls.name)))
