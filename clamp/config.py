"""Planner settings in three small groups: the model (factor graph), the optimizer (and the
search's budget), the checks.

``PlannerConfig()`` holds the one set of defaults used by the Python API and the command line.
Every group is a frozen dataclass; ``dataclasses.replace`` or :meth:`PlannerConfig.with_` make
variants. Units: metres, radians, seconds; errors in nats (negative log posterior).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

from clamp.errors import ClampTypeError, InvalidParameterError
from clamp.validation import as_bool, as_count, as_scalar
from clamp.optim.stopping import StoppingRule, as_stopping_rule


#: the optimizers a config may name ("fast": our Levenberg-Marquardt on the state array; the
#: others GTSAM's on ``problem.graph()``, :mod:`clamp.optim.optimizers`)
OPTIMIZERS = ("fast", "gtsam", "gtsam_dogleg", "gtsam_gauss_newton")
#: the initialisations a config may name (:mod:`clamp.planning.initialisation`)
INITIALISATIONS = ("prior_mean", "straight_line")

@dataclass(frozen=True)
class ModelConfig:
    """The factor graph (paper eq. 14-20; defaults are the reference implementation's except
    ``sigma_obs`` and ``epsilon``; see docs/decisions.md#model-defaults-clampconfigmodelconfig)."""

    #: [m] obstacle safety distance: spheres closer than this to an obstacle are penalised
    #: (see docs/decisions.md#epsilon)
    epsilon: float = 0.02
    #: [m] obstacle hinge noise (smaller = stronger avoidance; see docs/decisions.md#sigma_obs)
    sigma_obs: float = 0.002
    #: joint GP power spectral density [rad^2 / s^3] (for a skill demonstrated over
    #: ``Qc_duration`` seconds or longer)
    Qc: float = 1.0
    #: [s] the demonstrated duration Qc, posture_Qc and posture_velocity_sigma are stated for: a
    #: skill demonstrated over D seconds, faster than this, is planned as one of Qc_duration
    #: seconds in faster time (Qc and posture_Qc times (Qc_duration / D)^3,
    #: posture_velocity_sigma times Qc_duration / D), so that the joint-space
    #: factors do not weigh more against the learned prior because the skill was shown fast
    #: (clamp.planning.time_scale.demonstrated_speed_config, docs/decisions.md#qc_duration);
    #: None: as they are
    Qc_duration: float | None = 20.0
    #: [m or rad] goal and via-point factors
    goal_sigma: float = 1e-3
    #: plan with the learned prior conditioned exactly on the start, goal and via positions
    #: (:mod:`clamp.prior.conditioning`) when a goal or via points are given
    condition_on_targets: bool = True
    #: [rad] with obstacles, every state's configuration is tied to the plan the skill makes in
    #: the empty scene (the free plan) with this noise (``clamp.factors.posture``; 0 = off; see
    #: docs/decisions.md#posture_sigma)
    posture_sigma: float = 0.1
    #: [rad^2 / s^3] with obstacles (and posture_sigma > 0), the deviation from the free plan
    #: is also a constant-velocity GP of this power spectral density
    #: (``clamp.factors.posture_motion``; 0 = off; see docs/decisions.md#posture_qc)
    posture_Qc: float = 1e-4
    #: [rad/s] with obstacles (and posture_sigma > 0), every state's joint velocity is also
    #: held this near the free plan's (``clamp.factors.posture_velocity``; 0 = off; see
    #: docs/decisions.md#posture_velocity_sigma)
    posture_velocity_sigma: float = 0.03
    #: uniform time scale k >= 1 of the skill (the plan lasts k times the demonstrations; None:
    #: automatic, 1 unless the arm cannot follow the demonstrations' speed, see
    #: :mod:`clamp.planning.time_scale`)
    time_scale: float | None = None
    #: [s] the plan lasts at most this long (bounds the automatic time scale; None: unbounded)
    max_duration: float | None = None


@dataclass(frozen=True)
class OptimizerConfig:
    """How the graph is optimised (see :mod:`clamp.optim.solver` for the fast solver's rules)."""

    #: one of :data:`OPTIMIZERS` ("fast": our Levenberg-Marquardt on the
    #: state array; the others GTSAM's optimizers on ``problem.graph()``)
    optimizer: str = "fast"
    #: "prior_mean" (IK of the prior mean moved to the start) or "straight_line" (joint space)
    initialisation: str = "prior_mean"
    #: when a solve stops: a name of :data:`clamp.optim.stopping.STOPPING_RULES` ("default",
    #: "fast", "reference") or a :class:`clamp.optim.stopping.StoppingRule` (first damping,
    #: relative and absolute [nats] tolerances, patience; given to ``with_`` as a mapping of its
    #: fields, e.g. from a JSON file, it is made one)
    stopping: str | StoppingRule = "default"
    #: accepted iterations at most
    max_iterations: int = 500
    #: constraints inside the solve (:mod:`clamp.optim.constrained`, an augmented Lagrangian):
    #: at most this many multiplier / penalty updates per start of the search while the
    #: optimum fails a check; 0: the weighted solve only, one start at the configured
    #: weights (see
    #: docs/decisions.md#constraint_rounds)
    constraint_rounds: int = 2
    #: work a request's search may spend (solver trials and judged optima: counted, not timed,
    #: so a plan is the same at any load), in units of its first solves; no start past the
    #: second begins once it is spent (None: unbounded; :mod:`clamp.planning.search`)
    budget: float | None = 50.0
    #: [s] wall-clock deadline of a request's search, from the start of the call (None: none)
    deadline: float | None = None

    def stopping_rule(self) -> StoppingRule:
        """The :class:`~clamp.optim.stopping.StoppingRule` ``stopping`` names (or is)."""
        return as_stopping_rule(self.stopping, "config.optimizer.stopping")


@dataclass(frozen=True)
class CheckConfig:
    """Tolerances of the verdict (``PlanResult.success``)."""

    #: [m] required clearance: a plan whose robot collision geometry comes closer than this to
    #: an obstacle (at or between states) fails its verdict, and the solve treats it as a
    #: violated constraint; 0: only a collision fails (``ModelConfig.epsilon`` is the soft
    #: safety distance the obstacle factors aim for, not a guarantee)
    min_clearance: float = 0.0

    #: [m] end-effector start (or [rad] joint start) error
    start_tolerance: float = 1e-3
    #: [m] end-effector goal (or [rad] joint goal) error
    goal_tolerance: float = 0.002
    #: [m] end-effector via-point (or [rad] joint via-point) error
    via_tolerance: float = 0.002
    #: [rad] the hand's rotation error at a goal or via pose (1 deg)
    rotation_tolerance: float = 0.017453292519943295
    #: [rad/s^2] joint acceleration limit the automatic time scale also keeps (finite
    #: differences of the plan's velocities; None: velocity limits only, URDFs carry none)
    acceleration_limit: float | None = None


@dataclass(frozen=True, init=False)
class PlannerConfig:
    """All planner settings: ``model``, ``optimizer`` and ``checks`` groups.

    ``PlannerConfig(sigma_obs=0.01)`` is ``PlannerConfig().with_(sigma_obs=0.01)``: any field
    of any group by name. Every configuration is checked when made (InvalidParameterError
    naming the field).
    """

    model: ModelConfig
    optimizer: OptimizerConfig
    checks: CheckConfig

    def __init__(self, model: ModelConfig | None = None, optimizer: OptimizerConfig | None = None,
                 checks: CheckConfig | None = None, **changes: Any) -> None:
        if isinstance(optimizer, str):   # PlannerConfig(optimizer="gtsam"): the optimizer's name
            optimizer, changes = None, {**changes, "optimizer": optimizer}
        self._assign({"model": ModelConfig() if model is None else model,
                      "optimizer": OptimizerConfig() if optimizer is None else optimizer,
                      "checks": CheckConfig() if checks is None else checks},
                     changes)

    def _assign(self, groups: dict[str, Any], changes: dict[str, Any]) -> None:
        """Set the groups with ``changes`` (field name -> value) applied, then validate."""
        for group, value in groups.items():
            if not isinstance(value, GROUPS[group]):
                raise InvalidParameterError(f"config.{group}: expected {GROUPS[group].__name__}, "
                                            f"got {type(value).__name__}")
        owner = {f.name: g for g, obj in groups.items() for f in fields(obj)}
        updates: dict[str, dict[str, Any]] = {g: {} for g in groups}
        for name, value in changes.items():
            if name in REMOVED:
                raise InvalidParameterError(f"config field {name!r} is no longer a setting "
                                            f"(issue 36): {REMOVED[name]}")
            if name not in owner:
                raise InvalidParameterError(f"config field: unknown {name!r}; valid: "
                                            f"{', '.join(sorted(owner))}")
            if name == "stopping" and isinstance(value, Mapping):   # e.g. a saved problem's
                value = as_stopping_rule(value, "config.optimizer.stopping")
            updates[owner[name]][name] = value
        for group, value in groups.items():
            object.__setattr__(self, group, replace(value, **updates[group]) if updates[group]
                               else value)
        self.validate()

    def with_(self, **changes: Any) -> "PlannerConfig":
        """A copy with fields of any group changed by name, e.g. ``with_(sigma_obs=0.005)``."""
        new = object.__new__(PlannerConfig)
        new._assign({group: getattr(self, group) for group in GROUPS}, changes)
        return new

    def derived(self, **model_changes: Any) -> "PlannerConfig":
        """A copy with ``model`` fields changed to values the planner derived from this
        (validated) config, e.g. noises scaled by positive factors: not validated again (the
        one validation is at the boundary)."""
        new = object.__new__(PlannerConfig)
        for group in GROUPS:
            object.__setattr__(new, group, getattr(self, group))
        object.__setattr__(new, "model", replace(self.model, **model_changes))
        return new

    @classmethod
    def reference(cls, **changes: Any) -> "PlannerConfig":
        """The reference implementation's optimizer: GTSAM's Levenberg-Marquardt with
        lambda0 1e3 and 1e-5 relative / absolute tolerances; ``changes`` override fields."""
        return cls().with_(**{"optimizer": "gtsam", "stopping": "reference", **changes})

    @classmethod
    def fast(cls, **changes: Any) -> "PlannerConfig":
        """For control loops: a loose stopping rule (one step below a 5 % relative decrease),
        fewer iterations, a less polished plan."""
        return cls().with_(**{"stopping": "fast", **changes})

    def validate(self) -> "PlannerConfig":
        """Check every field; raises InvalidParameterError naming the bad one."""
        m, o, c = self.model, self.optimizer, self.checks
        for name in ("epsilon", "posture_sigma", "posture_Qc", "posture_velocity_sigma"):
            as_scalar(getattr(m, name), f"config.model.{name}", minimum=0.0)
        for name in ("sigma_obs", "Qc", "goal_sigma"):
            as_scalar(getattr(m, name), f"config.model.{name}", strictly_positive=True)
        if m.Qc_duration is not None:
            as_scalar(m.Qc_duration, "config.model.Qc_duration", strictly_positive=True)
        as_bool(m.condition_on_targets, "config.model.condition_on_targets")
        o.stopping_rule()
        as_count(o.max_iterations, "config.optimizer.max_iterations", minimum=0)
        as_count(o.constraint_rounds, "config.optimizer.constraint_rounds", minimum=0)
        for name, valid in (("optimizer", OPTIMIZERS), ("initialisation", INITIALISATIONS)):
            if getattr(o, name) not in valid:
                raise InvalidParameterError(f"config.optimizer.{name}: unknown "
                                            f"{getattr(o, name)!r}; valid: {', '.join(valid)}")
        as_time_scale(m.time_scale, "config.model.time_scale")
        as_max_duration(m.max_duration, "config.model.max_duration")
        if c.acceleration_limit is not None:
            as_scalar(c.acceleration_limit, "config.checks.acceleration_limit",
                      strictly_positive=True)
        as_scalar(c.min_clearance, "config.checks.min_clearance", minimum=0.0)
        for name in ("start_tolerance", "goal_tolerance", "via_tolerance", "rotation_tolerance"):
            as_scalar(getattr(c, name), f"config.checks.{name}", strictly_positive=True)
        for name in ("budget", "deadline"):
            if getattr(o, name) is not None:
                as_scalar(getattr(o, name), f"config.optimizer.{name}", minimum=0.0)
        return self


#: the groups of a :class:`PlannerConfig`: attribute name -> class
GROUPS = {"model": ModelConfig, "optimizer": OptimizerConfig, "checks": CheckConfig}

_STOPPING = ("part of the stopping rule: set stopping=\"default\", \"fast\", \"reference\", "
             "a clamp.optim.stopping.StoppingRule(lambda_initial, relative_tol, absolute_tol, "
             "patience) or (in a JSON file) a mapping of those fields")
#: the settings issue 36 removed -> where each went (docs/decisions.md#settings-issue-36): a config
#: naming one, e.g. an older saved problem file, is refused with this, never silently changed
REMOVED = {
    "lambda_initial": _STOPPING, "relative_error_tol": _STOPPING,
    "absolute_error_tol": _STOPPING, "convergence_patience": _STOPPING,
    "velocity_margin": "the velocity hinges' margin is clamp.factors.joint_limits.VELOCITY_MARGIN "
                       "(0.01 rad/s)",
    "limit_tolerance": "the verdict's joint position tolerance is "
                       "clamp.factors.joint_limits.LIMIT_TOLERANCE (1e-4 rad)",
    "velocity_tolerance": "the verdict's joint velocity tolerance is "
                          "clamp.factors.joint_limits.VELOCITY_TOLERANCE (1e-3 rad/s)",
    "ik_tolerance": "the start IK's accuracy is clamp.planning.request.IK_TOLERANCE (1e-4 m)",
    "sdf_cell_size": "a scene that needs a grid uses scenes.sdf.DEFAULT_CELL_SIZE (0.01 m); for "
                     "another cell pass plan(..., sdf=scene.sdf(cell_size))",
    "obstacle_factors": "the obstacle family comes with a scene that has obstacles: plan "
                        "without the scene (scene=None) for a plan unaware of it",
    "joint_limits": "the joint limit hinges are always built (the verdict checks the limits)",
}


def as_config(config: Any) -> PlannerConfig:
    """``config``, or the default config for None. A PlannerConfig is validated when it is built
    (:meth:`PlannerConfig.with_` and the constructor), so it is only checked for its type here."""
    if config is None:
        return PlannerConfig()
    if not isinstance(config, PlannerConfig):
        raise ClampTypeError(f"config: expected a clamp.PlannerConfig (e.g. "
                                f"PlannerConfig().with_(sigma_obs=0.005)), got "
                                f"{type(config).__name__}")
    return config


def as_time_scale(value: Any, name: str = "time_scale") -> float | None:
    """``value`` as a time scale: None (automatic) or a finite number >= 1 (1: the
    demonstrations' speed; a plan is never faster); a ClampError naming ``name`` otherwise."""
    return None if value is None else as_scalar(value, name, minimum=1.0)


def as_max_duration(value: Any, name: str = "max_duration") -> float | None:
    """``value`` as a maximum plan duration [s]: None or a finite number > 0; a ClampError
    naming ``name`` otherwise."""
    return None if value is None else as_scalar(value, name, strictly_positive=True)
