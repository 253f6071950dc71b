"""One judge: every constraint's check runs once per final plan.

The solve judges each optimum with the constraint families' own checks
(:mod:`clamp.factors.family`: obstacles on the robot's collision geometry, self-collision, the
joint limits, orientation, the skill); the verdict reuses the chosen optimum's records and makes
only what the solve did not (the checks after a collision, the skill's score). Counted here with
counters on the functions behind the checks, keyed by the joint positions they were given:
for the final plan's q, each ran exactly once. And the declarations: the lazy families are found
in the package, the checks run in their declared order.
"""
from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import clamp.factors.joint_limits as joint_limits
import clamp.factors.self_collision as self_collision
import clamp.factors.skill_tube as skill_tube
import clamp.planning.pipeline as pipeline
import clamp.prior.skill as skill
from clamp import PlannerConfig, plan
from clamp.factors import (JointLimitFamily, ObstacleFamily, OrientationFamily,
                           SelfCollisionFamily, SkillOrientationFamily, SkillTubeFamily,
                           lazy_families)
from scenes import Box, Scene

START = [0.2054, -0.4722, 0.2625]
README_BOX = Scene([Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])])


@pytest.fixture
def counted(monkeypatch):
    """Counter of (check, bytes of the joint positions or path it measured) for every call."""
    calls: Counter = Counter()
    plausibility = {"calls": 0}

    def wrap(module, name, check, position):
        original = getattr(module, name)

        def counting(*args, **kwargs):
            calls[check, np.ascontiguousarray(args[position]).tobytes()] += 1
            return original(*args, **kwargs)
        monkeypatch.setattr(module, name, counting)

    wrap(pipeline, "check_clearance", "obstacle", 2)
    wrap(joint_limits, "limit_violations", "joint_limits", 1)
    wrap(self_collision, "self_collision_report", "self_collision", 1)
    wrap(skill_tube, "skill_checks", "skill", 2)
    violation = OrientationFamily.violation

    def counted_violation(self, robot, q):
        calls["orientation", np.ascontiguousarray(q).tobytes()] += 1
        return violation(self, robot, q)
    monkeypatch.setattr(OrientationFamily, "violation", counted_violation)
    for module in (skill, skill_tube):       # the score: skill_checks(score=True) or the reuse
        original = module.skill_plausibility

        def scoring(*args, original=original, **kwargs):
            plausibility["calls"] += 1
            return original(*args, **kwargs)
        monkeypatch.setattr(module, "skill_plausibility", scoring)
    return calls, plausibility


def once_each(calls: Counter, robot, result, checks) -> None:
    q = np.ascontiguousarray(result.q)
    keys = {"skill": np.ascontiguousarray(robot.fk(q)).tobytes()}
    for check in checks:
        assert calls[check, keys.get(check, q.tobytes())] == 1, (check, result.reasons)


def test_each_check_runs_once_on_the_final_plan_with_obstacles(prior, jaco, counted):
    calls, plausibility = counted
    down = OrientationFamily.window(prior.T, 0.4, axis=[0, 0, 1], direction=[0, 0, -1],
                                    tolerance=np.radians(60))
    result = plan(prior, jaco, README_BOX, START, extra_factors=[down], covariance=False)
    assert result.success, result.reasons
    once_each(calls, jaco, result, ("obstacle", "joint_limits", "self_collision", "orientation",
                                    "skill"))
    assert plausibility["calls"] == 1
    assert set(result.violations) == {"orientation"}


def test_each_check_runs_once_after_a_collision(prior, jaco, counted):
    """The final optimum collides (a box on the skill's path, no constraint rounds, a loose
    hinge): the solve stopped at the obstacle check, the verdict makes the others, once."""
    calls, plausibility = counted
    config = PlannerConfig().with_(constraint_rounds=0, sigma_obs=0.5,
                                   epsilon=0.0, posture_sigma=0.0)
    on_path = Scene([Box(np.asarray(prior.mean)[125, :3].tolist(), [0.05, 0.05, 0.05])])
    result = plan(prior, jaco, on_path, START, config=config, covariance=False)
    assert not result.success and result.min_clearance < 0.0
    assert any(r.startswith("collision: ") for r in result.reasons), result.reasons
    once_each(calls, jaco, result, ("obstacle", "joint_limits", "self_collision", "skill"))
    assert plausibility["calls"] == 1


def test_each_check_runs_once_without_obstacles(prior, sawyer, counted):
    calls, plausibility = counted
    result = plan(prior, sawyer, None, np.asarray(prior.mean)[0, :3] + [0.3, 0.0, 0.2],
                  covariance=False)
    # the obstacle check is the verdict's alone (no obstacle hinges), and finds no obstacles
    once_each(calls, sawyer, result, ("obstacle", "joint_limits", "self_collision", "skill"))
    assert result.min_clearance == np.inf and result.nearest_contact is None
    assert plausibility["calls"] == 1


def test_the_declared_checks():
    """The lazy families are found in the package without a list; the checks' order (the
    verdict's reasons) and gates are declared by the families."""
    assert lazy_families() == (SelfCollisionFamily, SkillTubeFamily, SkillOrientationFamily)
    order = sorted([SkillOrientationFamily, SkillTubeFamily, OrientationFamily,
                    JointLimitFamily, SelfCollisionFamily, ObstacleFamily],
                   key=lambda cls: cls.check_rank)
    assert order == [ObstacleFamily, SelfCollisionFamily, JointLimitFamily, OrientationFamily,
                     SkillTubeFamily, SkillOrientationFamily]
    assert ObstacleFamily.decisive and SkillTubeFamily.only_if_clear
    assert SkillOrientationFamily.only_if_clear
    assert ObstacleFamily.always_checked and JointLimitFamily.always_checked
