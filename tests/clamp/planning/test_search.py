"""The declared search (clamp.planning.search) under its budget (issue 36), by its outcomes:

- a box on the skill's mean path at 50 % is avoided (both arms): the plan passes, measured
  independently (coal distances of the URDF geometry, the joint limits, the skill's tube);
- a request the scene does not allow (a box over the skill's end) fails honestly, and the
  budget bounds its work: with no budget past the first two starts the result says the
  budget ended the search and which strategies it left; the counted budget gives the same
  plan, bit for bit, in two runs; a deadline ends the search too;
- the strategies are one declared list, with names, in order; other IK branches of an
  end-effector start reach it, apart from the start configuration and within the limits.
"""
from __future__ import annotations

import numpy as np
import pytest

from clamp import PlannerConfig, learn_prior, plan
from clamp.planning.request import IK_TOLERANCE
from clamp.planning.search import BRANCH_APART, STRATEGIES, Budget, other_branches
from clamp.prior.skill import TUBE_RATIO
from robots import load_robot
from robots.collision_check import CollisionChecker
from scenes import Box, Scene, make_demonstrations
from scenes.coal_shapes import coal_obstacles


@pytest.fixture(scope="module")
def skill():
    return learn_prior(make_demonstrations("pick_place", num_demos=6, num_points=120, seed=0))


def box_on_the_path(prior, at: float, size: float = 0.06) -> Scene:
    """A cube of edge ``size`` [m] centred on the prior's mean path at ``at`` of it."""
    mean = np.asarray(prior.mean)[:, :3]
    return Scene([Box(mean[int(round(at * (len(mean) - 1)))], [size] * 3)])


def assert_passes_on_its_own(robot, scene, result) -> None:
    report = CollisionChecker(robot, coal_obstacles(scene.obstacles)).check(result.q)
    assert not report.collision and report.min_distance > 0.0
    assert np.all(robot.within_limits(result.q, tolerance=0.0))
    assert result.skill["max_tube_ratio"] <= TUBE_RATIO


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_a_box_on_the_path_is_avoided(skill, arm):
    robot = load_robot(arm)
    prior = skill
    if arm == "sawyer":
        prior = learn_prior(make_demonstrations("pick_place", num_demos=6, num_points=120,
                                                seed=0).translated([0.3, 0.0, 0.2]))
    scene = box_on_the_path(prior, 0.5)
    start = np.asarray(prior.mean)[0, :3]
    result = plan(prior, robot, scene, start, covariance=False)
    assert result.success, result.reasons
    assert not result.search["budget_ended"]
    assert_passes_on_its_own(robot, scene, result)


@pytest.fixture(scope="module")
def impossible(skill):
    """The skill's end inside a box: no plan completes it."""
    return skill, load_robot("jaco"), box_on_the_path(skill, 1.0, 0.12), \
        np.asarray(skill.mean)[0, :3]


def test_a_search_cut_by_its_budget_says_so(impossible):
    prior, robot, scene, start = impossible
    cut = plan(prior, robot, scene, start, covariance=False, budget=0.0)
    assert not cut.success
    assert cut.search["budget_ended"] and cut.search["left"]
    assert cut.search["work"] > cut.search["limit"] == 0.0 < cut.search["unit"]
    assert any("budget" in reason for reason in cut.reasons)
    again = plan(prior, robot, scene, start, covariance=False, budget=0.0)
    np.testing.assert_array_equal(again.q, cut.q)            # counted work: the same plan
    assert again.search == cut.search
    wider = plan(prior, robot, scene, start, covariance=False, budget=4.0)
    assert not wider.success and wider.search["work"] > cut.search["work"]
    assert wider.search["work"] <= wider.search["limit"] + 3 * cut.search["work"]


def test_a_deadline_ends_the_search(impossible):
    prior, robot, scene, start = impossible
    late = plan(prior, robot, scene, start, covariance=False, budget=None, deadline=0.0)
    assert not late.success and late.search["budget_ended"]
    assert late.search["limit"] is None
    assert any("deadline" in reason for reason in late.reasons)


def test_bad_budgets_are_refused_by_name(skill):
    for bad in ({"budget": -1.0}, {"deadline": -0.5}):
        name = next(iter(bad))
        with pytest.raises(ValueError, match=f"config.optimizer.{name}"):
            PlannerConfig(**bad)
        with pytest.raises(ValueError, match=name):
            plan(skill, load_robot("jaco"), None, np.asarray(skill.mean)[0, :3], **bad)
    with pytest.raises(ValueError, match="budget"):
        Budget(work=-2.0)


def test_the_strategies_are_declared_in_order():
    names = [s.name for s in STRATEGIES]
    assert names == ["tied", "configured", "untied", "tied_resumed", "to_end", "detours",
                     "ik_branches", "straight_line", "resumed", "wide"]
    assert len(set(names)) == len(names)


def test_other_ik_branches_of_the_start(skill):
    """Other inverse-kinematics solutions of an end-effector start, each reaching the start
    position, BRANCH_APART from the planner's start configuration and from each other, within
    the limits; none for a joint start."""
    from clamp.planning.pipeline import model
    from clamp.planning.request import make_request
    robot = load_robot("jaco")
    scene = box_on_the_path(skill, 0.5)
    start = np.asarray(skill.mean)[0, :3]
    config = PlannerConfig()
    request = make_request(skill, robot, start, config=config)
    branches = other_branches(model(skill, robot, scene, request, config), 2)
    assert 1 <= len(branches) <= 2
    for k, q0 in enumerate(branches):
        assert np.linalg.norm(robot.fk(q0[None])[0] - start) <= IK_TOLERANCE
        assert np.max(np.abs(q0 - request.q_start)) >= BRANCH_APART
        assert all(np.max(np.abs(q0 - q)) >= BRANCH_APART for q in branches[:k])
        assert np.all(robot.within_limits(q0[None]))
    joint = make_request(skill, robot, request.q_start, config=config)
    assert other_branches(model(skill, robot, scene, joint, config), 2) == []
