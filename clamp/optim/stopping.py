"""When a Levenberg-Marquardt solve stops: its first damping and its stopping tolerances, as one
rule (``OptimizerConfig.stopping``) chosen by name or given whole.

The fast solver (:func:`clamp.optim.solver.levenberg_marquardt`) stops after ``patience``
consecutive accepted steps that each decrease the error (a negative log posterior, nats) by at
most ``relative_tol`` times it or by at most ``absolute_tol`` nats; GTSAM's optimizers take the
same tolerances and first damping (:func:`clamp.optim.optimizers.gtsam_params`). The named
rules (docs/decisions.md#stopping):

- ``"default"``: the planner's (lambda0 0.1, docs/decisions.md#lambda_initial; 1e-3 relative,
  1e-2 nats, i.e. a 1 % change of the posterior density; 2 steps);
- ``"fast"``: for control loops, one step below a 5 % relative decrease (a less polished plan);
- ``"reference"``: the reference implementation's GTSAM Levenberg-Marquardt (lambda0 1e3,
  1e-5 relative and absolute, one step).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

from clamp.errors import InvalidParameterError
from clamp.validation import as_count, as_scalar


@dataclass(frozen=True)
class StoppingRule:
    """A solve's first damping and stopping tolerances (see the module docstring).

    lambda_initial: first Levenberg-Marquardt damping (dimensionless, on the Jacobi-scaled
    system); relative_tol: a small step's error decrease as a fraction of the error;
    absolute_tol [nats]: ... or in nats; patience: consecutive small accepted steps that stop.
    Checked when made (InvalidParameterError naming the field)."""

    lambda_initial: float = 0.1
    relative_tol: float = 1e-3
    absolute_tol: float = 1e-2
    patience: int = 2

    def __post_init__(self) -> None:
        as_scalar(self.lambda_initial, "stopping.lambda_initial", strictly_positive=True)
        for name in ("relative_tol", "absolute_tol"):
            as_scalar(getattr(self, name), f"stopping.{name}", minimum=0.0)
        as_count(self.patience, "stopping.patience", minimum=1)

    def with_(self, **changes: Any) -> "StoppingRule":
        """A copy with fields changed by name (checked)."""
        return replace(self, **changes)

    def solver_arguments(self) -> dict[str, Any]:
        """The rule as :func:`clamp.optim.solver.levenberg_marquardt`'s keyword arguments."""
        return {"lambda_initial": self.lambda_initial, "relative_tol": self.relative_tol,
                "absolute_tol": self.absolute_tol, "patience": self.patience}


#: the rules ``OptimizerConfig.stopping`` may name
STOPPING_RULES = {
    "default": StoppingRule(),
    "fast": StoppingRule(relative_tol=0.05, patience=1),
    "reference": StoppingRule(lambda_initial=1e3, relative_tol=1e-5, absolute_tol=1e-5,
                              patience=1),
}


def as_stopping_rule(value: Any, name: str = "stopping") -> StoppingRule:
    """``value`` (a name of :data:`STOPPING_RULES`, a :class:`StoppingRule`, or a mapping of
    its fields as a JSON file gives them, the others the default rule's) as a rule;
    InvalidParameterError naming ``name`` otherwise."""
    if isinstance(value, StoppingRule):
        return value
    if isinstance(value, str) and value in STOPPING_RULES:
        return STOPPING_RULES[value]
    valid = [f.name for f in fields(StoppingRule)]
    if isinstance(value, Mapping):
        unknown = [str(key) for key in value if key not in valid]
        if unknown:
            raise InvalidParameterError(f"{name}: unknown {', '.join(unknown)}; a stopping rule "
                                        f"has {', '.join(valid)}")
        return StoppingRule(**value)
    raise InvalidParameterError(f"{name}: expected one of {', '.join(map(repr, STOPPING_RULES))}, "
                                f"a clamp.optim.stopping.StoppingRule or a mapping of its fields "
                                f"({', '.join(valid)}), got {value!r:.60}")
