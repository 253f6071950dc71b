"""Validation happens once, at the boundary: one plan() call checks its prior once and
validates no config again (a PlannerConfig is validated when it is built)."""
from __future__ import annotations

import sys

import numpy as np

from bad_input import raises_naming
import clamp
from clamp import PlannerConfig, learn_prior, plan
from clamp.prior import linear_gaussian
from scenes import Box, Scene, make_demonstrations


def _count_check_prior(monkeypatch) -> list[int]:
    """Wrap check_prior wherever a clamp module imported it; returns the call counter."""
    calls = [0]
    original = linear_gaussian.check_prior

    def counted(*args, **kwargs):
        calls[0] += 1
        return original(*args, **kwargs)

    for name, module in list(sys.modules.items()):
        if name.startswith("clamp") and getattr(module, "check_prior", None) is original:
            monkeypatch.setattr(module, "check_prior", counted)
    return calls


def test_plan_checks_its_prior_and_config_once(jaco, monkeypatch):
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0, num_points=60))
    config = PlannerConfig().with_(max_iterations=60)
    validations = [0]
    validate = PlannerConfig.validate

    def counted_validate(self):
        validations[0] += 1
        return validate(self)

    calls = _count_check_prior(monkeypatch)
    monkeypatch.setattr(PlannerConfig, "validate", counted_validate)
    start = np.asarray(prior.mean)[0, :3]
    for scene in (None, Scene([Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])])):
        calls[0] = validations[0] = 0
        result = plan(prior, jaco, scene, start, config=config)
        assert result.q.shape == (prior.T, jaco.n)
        assert calls[0] == 1, f"check_prior ran {calls[0]} times in one plan()"
        assert validations[0] == 0, f"the config was validated {validations[0]} times again"


def test_a_config_is_validated_when_built(monkeypatch):
    validations = [0]
    validate = PlannerConfig.validate

    def counted_validate(self):
        validations[0] += 1
        return validate(self)

    monkeypatch.setattr(PlannerConfig, "validate", counted_validate)
    config = PlannerConfig()
    assert validations[0] == 1
    changed = config.with_(sigma_obs=0.01)
    assert validations[0] == 2
    assert clamp.config.as_config(changed) is changed and validations[0] == 2   # trusted as built
    with raises_naming(clamp.InvalidParameterError, "sigma_obs"):
        config.with_(sigma_obs=-1.0)
