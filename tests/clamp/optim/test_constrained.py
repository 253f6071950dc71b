"""The augmented-Lagrangian solve of clamp.optim.constrained, on both arms at random points:

- a constraint family's shifts move its hinges: e = max(0, g + s) for the unshifted hinge g
  (measured from the unshifted kernel wherever it is active), Jacobians still those of g
  (central differences), the GTSAM adapters the same kernel; cost families have no shifts;
- one multiplier update (:func:`clamp.optim.constrained.augmented`): the shift of a violated family
  becomes its current residual, its noise is divided by the configuration's ``stiffen`` at its
  first update (and its shifts by stiffen^2, so lambda = mu s is the same multiplier), a family
  the checks did not name is left as it is, a lazy family joins unshifted at its configured
  noise and is stiffened at its first update after joining; the schedule's constants are the
  ``constraints`` group of PlannerConfig.
"""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp.config import ConstraintConfig, PlannerConfig
from clamp.optim.constrained import Candidate, Feasibility, augmented, solve_constrained
from clamp.errors import InvalidParameterError
from clamp.factors import ConstraintCheck, PostureFamily, SelfCollisionFamily
from clamp.graph.problem import PlanningProblem
from tests.clamp.factors.test_families import (assert_jacobians_match_finite_differences, dense_residual,
                                 make_families, random_theta, whitened_rows)


@pytest.fixture(params=["jaco", "sawyer"])
def setup(request):
    robot = request.getfixturevalue(request.param)
    rng = np.random.default_rng(7 if request.param == "jaco" else 8)   # as test_families: every hinge active somewhere
    theta = random_theta(robot, rng)
    return robot, theta, make_families(robot, theta, rng), rng


def constraints(families):
    return [f for f in families if f.role == "constraint"]


def test_the_constraint_families_are_the_hinges(setup):
    _, _, families, _ = setup
    assert {f.name for f in constraints(families)} == {
        "obstacle", "joint_limits", "orientation", "self_collision", "skill_tube"}


def test_a_shift_moves_the_hinge_and_keeps_its_jacobian(setup):
    robot, theta, families, rng = setup
    for family in constraints(families):
        unshifted = dense_residual(family, robot, theta)
        shift = rng.uniform(0.0, 0.02, size=(len(family), family.dim))
        shifted_family = family.with_shift(shift)
        shifted = dense_residual(shifted_family, robot, theta)
        active = unshifted > 0.0
        assert active.any(), family.name
        np.testing.assert_allclose(shifted[active], unshifted[active] + shift[active],
                                   rtol=1e-9, atol=1e-12, err_msg=family.name)
        # where the unshifted hinge is inactive (g <= 0), max(0, g + s) is at most s
        assert np.all(shifted[~active] <= shift[~active] + 1e-12), family.name
        assert np.all(shifted >= unshifted - 1e-12), family.name
        assert family.shift is None                         # the original is unchanged
        assert_jacobians_match_finite_differences(shifted_family, robot, theta)
        # the GTSAM adapter evaluates the same shifted kernel
        problem = PlanningProblem(robot, len(theta), [shifted_family], [], theta)
        _, b = whitened_rows(shifted_family, robot, theta)
        assert problem.graph().error(problem.values(theta)) == pytest.approx(
            0.5 * float(np.sum(b * b)), rel=1e-9)


def test_the_base_class_applies_every_shift(setup):
    """A constraint family gives its unshifted g (``constraint``); the hinge and its shift are
    Family.residual's alone: no constraint family overrides it."""
    from clamp.factors import Family
    _, _, families, _ = setup
    constraints = [f for f in families if f.role == "constraint"]
    assert {f.name for f in constraints} >= {"obstacle", "joint_limits", "orientation",
                                             "self_collision", "skill_tube"}
    for family in constraints:
        assert type(family).residual is Family.residual, family.name


def test_cost_families_have_no_shifts(setup):
    _, _, families, _ = setup
    cost = next(f for f in families if f.role == "cost")
    with raises_naming(InvalidParameterError, cost.name):
        cost.with_shift(np.zeros((len(cost), cost.dim)))
    obstacle = next(f for f in families if f.name == "obstacle")
    with raises_naming(InvalidParameterError, "obstacle shift"):
        obstacle.with_shift(-np.ones((len(obstacle), obstacle.dim)))


def test_one_multiplier_update(setup):
    robot, theta, families, _ = setup
    kept = [f for f in families if f.name not in ("self_collision", "skill_tube")]
    problem = PlanningProblem(robot, len(theta), kept, [], theta)
    lazy = {name: (lambda name=name: next(f for f in families if f.name == name))
            for name in ("self_collision", "skill_tube")}
    previous: dict[str, float] = {}
    # the violated families alone: no multiplier update nor margin relaxed elsewhere
    plain = ConstraintConfig(update_active=False, margin_floor=1.0)
    new = augmented(problem, theta, ["obstacle", "self_collision"], previous, lazy, plain)
    STIFFEN, PROGRESS = ConstraintConfig().stiffen, ConstraintConfig().progress

    obstacle, updated = problem.family("obstacle"), new.family("obstacle")
    # first update: noise / STIFFEN, shift = the residual now / STIFFEN^2 (same multiplier)
    np.testing.assert_allclose(updated.whitening, STIFFEN * obstacle.whitening)
    np.testing.assert_allclose(updated.shift, dense_residual(obstacle, robot, theta) / STIFFEN ** 2)
    # families the checks did not name are the same objects (the posture tie among them);
    # the lazy one joins as made
    for name in ("joint_limits", "orientation", "workspace_gp", "joint_gp", PostureFamily.name):
        assert new.family(name) is problem.family(name)
    joined = new.family("self_collision")
    assert isinstance(joined, SelfCollisionFamily) and joined.shift is None
    assert previous["self_collision"] == 0.0     # its first update will stiffen it
    np.testing.assert_array_equal(new.initial, theta)

    # a second update that made progress (violation below PROGRESS x the last) keeps the
    # noise: the shift accumulates the residual of the shifted hinge, i.e. max(0, g + s)
    previous["obstacle"] = 1e9
    again = augmented(new, theta, ["obstacle"], previous, lazy, plain)
    np.testing.assert_allclose(again.family("obstacle").whitening, updated.whitening)
    np.testing.assert_allclose(again.family("obstacle").shift,
                               dense_residual(updated, robot, theta))
    assert previous["obstacle"] < PROGRESS * 1e9
    assert again.family(PostureFamily.name) is new.family(PostureFamily.name)
    assert not again.has("skill_tube")

    # the joined family's first update stiffens it, whatever its violation (issue 27: a lazy
    # constraint at its configured noise lost against the stiffened obstacle hinges)
    stiffer = augmented(new, theta, ["self_collision"], dict(previous), lazy, plain)
    np.testing.assert_allclose(stiffer.family("self_collision").whitening,
                               STIFFEN * joined.whitening)

    # the skill's tube joins (a lazy constraint), the rest as it was
    tube = augmented(again, theta, ["skill_tube"], previous, lazy, plain)
    assert tube.family("skill_tube").shift is None
    for name in ("obstacle", PostureFamily.name, "self_collision"):
        assert tube.family(name) is again.family(name)

    # the schedule comes from the configuration: another stiffening factor
    config = PlannerConfig().with_(stiffen=2.0)
    assert config.constraints.stiffen == 2.0 and config.optimizer == PlannerConfig().optimizer
    softer = augmented(problem, theta, ["obstacle"], {}, lazy, config.constraints)
    np.testing.assert_allclose(softer.family("obstacle").whitening, 2.0 * obstacle.whitening)


def test_families_that_hold_give_way_to_one_that_fails(setup):
    """With ``update_active`` (the default), a constraint family the checks did not name but
    whose hinges are active keeps its noise and takes its current residuals as shifts (its
    multipliers are updated as the textbook augmented Lagrangian does), and the obstacle
    hinges' safety distance halves (down to ``margin_floor``) while another constraint fails;
    cost families are the same objects."""
    robot, theta, families, _ = setup
    kept = [f for f in families if f.name not in ("self_collision", "skill_tube")]
    problem = PlanningProblem(robot, len(theta), kept, [], theta)
    new = augmented(problem, theta, ["joint_limits"], {}, {}, ConstraintConfig())
    for name in ("workspace_gp", "joint_gp", PostureFamily.name):
        assert new.family(name) is problem.family(name)
    before, after = problem.family("obstacle"), new.family("obstacle")
    np.testing.assert_allclose(after.whitening, before.whitening)
    assert after.epsilon == pytest.approx(max(0.5 * before.epsilon, 0.005))
    np.testing.assert_allclose(after.shift, dense_residual(before.relaxed(0.005), robot, theta))
    orientation = new.family("orientation")
    np.testing.assert_allclose(orientation.whitening, problem.family("orientation").whitening)
    np.testing.assert_allclose(orientation.shift,
                               dense_residual(problem.family("orientation"), robot, theta))
    # at the floor the margin stays
    floor = ConstraintConfig(margin_floor=before.epsilon)
    assert augmented(problem, theta, ["joint_limits"], {}, {}, floor).family("obstacle") \
        .epsilon == before.epsilon


def test_a_violation_the_hinges_do_not_see_widens_the_family(setup):
    """The obstacle check measures the collision geometry between the support states too; the
    hinges only the spheres at them. When the check's violation is more than twice what the
    hinges see, the obstacle family's safety distance grows by the difference (at least by its
    ``near``); when the hinges see it, only the multipliers move."""
    robot, theta, families, _ = setup
    problem = PlanningProblem(robot, len(theta), families, [], theta)
    obstacle = problem.family("obstacle")
    seen = float(np.max(dense_residual(obstacle, robot, theta)))
    assert seen > 0.0
    plain = ConstraintConfig(update_active=False)
    unseen = augmented(problem, theta, ["obstacle"], {}, {}, plain,
                       {"obstacle": 3.0 * seen + 0.01})
    assert unseen.family("obstacle").epsilon == pytest.approx(
        obstacle.epsilon + 2.0 * seen + 0.01)
    tiny = augmented(problem, theta, ["obstacle"], {}, {}, plain, {"obstacle": 2.0 * seen + 1e-6})
    assert tiny.family("obstacle").epsilon == pytest.approx(
        obstacle.epsilon + max(seen + 1e-6, obstacle.near))
    for amounts in ({"obstacle": 1.5 * seen}, {}, None):
        kept = augmented(problem, theta, ["obstacle"], {}, {}, plain, amounts)
        assert kept.family("obstacle").epsilon == obstacle.epsilon
    # a family without a margin to widen keeps its hinges
    limits = augmented(problem, theta, ["joint_limits"], {}, {}, plain, {"joint_limits": 1.0})
    assert type(limits.family("joint_limits")) is type(problem.family("joint_limits"))


def scripted_judge(passes_at: int):
    """A judge that finds the obstacle violated (by 5 cm: not a hair short, no polish rounds)
    until its ``passes_at``-th call."""
    calls = []

    def judge(theta: np.ndarray) -> Feasibility:
        calls.append(theta)
        if len(calls) >= passes_at:
            return Feasibility((), True, (ConstraintCheck("obstacle", False),), 0.01)
        return Feasibility(("obstacle",), True, (ConstraintCheck("obstacle", True, 0.05),),
                           -0.05)
    return judge, calls


def test_the_closest_starts_continue_only_when_none_passes(jaco):
    """After the search (here: the problem as built alone, one update), the closest start
    continues for ``resume_rounds`` more rounds ("+resumed"), then once more with the
    obstacles' safety distance ``wide_margin`` times the model's ("+wide"); a search that
    passes is left as it is; ``resumed`` 0 turns both off."""
    rng = np.random.default_rng(3)
    theta = random_theta(jaco, rng)
    problem = PlanningProblem(jaco, len(theta), make_families(jaco, theta, rng), [], theta)
    config = PlannerConfig().with_(constraint_rounds=1, max_iterations=5)
    rounds = config.constraints.resume_rounds

    def names(solved):
        return [a.candidate for a in solved.attempts]

    passed, calls = scripted_judge(2)                  # the search's own second round passes
    solved = solve_constrained(problem, config, passed)
    assert solved.feasibility.ok and names(solved) == ["configured"] * 2
    resumed, calls = scripted_judge(4)                 # the second round of the resumed start
    solved = solve_constrained(problem, config, resumed)
    assert solved.feasibility.ok
    assert names(solved) == ["configured"] * 2 + ["configured+resumed"] * 2
    assert len(calls) == 4
    wide, calls = scripted_judge(2 + rounds + 1)       # the first solve of the widened start
    # (20 x 2 cm: wider than the rounds before widened the hinges seeing less than the check)
    solved = solve_constrained(problem, config.with_(wide_margin=20.0), wide)
    assert solved.feasibility.ok
    assert names(solved) == (["configured"] * 2 + ["configured+resumed"] * rounds
                             + ["configured+resumed+wide"])
    assert solved.problem.family("obstacle").epsilon == pytest.approx(20.0 * config.model.epsilon)
    never, calls = scripted_judge(10 ** 6)
    solved = solve_constrained(problem, config.with_(resumed=0), never)
    assert not solved.feasibility.ok and names(solved) == ["configured"] * 2


def test_the_tied_problem_leads_the_resumed_starts(jaco):
    """The problem as built that had one solve only (``first_rounds`` 0: the planner's tied
    problem, whose rounds went to the restarts) continues first when no start passes, before
    the ``resumed`` closest starts and whatever its own clearance (hard/sawyer/0170: the tied
    problem's rounds passed where the closest starts traded the obstacle for the skill's tube);
    a problem as built that had its rounds is resumed only when it is among the closest."""
    rng = np.random.default_rng(5)
    theta = random_theta(jaco, rng)
    problem = PlanningProblem(jaco, len(theta), make_families(jaco, theta, rng), [], theta)
    config = PlannerConfig().with_(constraint_rounds=1, max_iterations=5, resumed=1)
    #: clearance [m] of each judged optimum, by call: the problem as built farthest, then b,
    #: a; continued (calls 6-9 the problem as built, 10-13 a), a still the closest
    clearances = {1: -0.05, 2: -0.01, 3: -0.01, 4: -0.02, 5: -0.02,
                  **{k: -0.012 for k in range(10, 14)}}

    def restarts(_):
        for name in ("a", "b"):
            yield Candidate(name, problem.with_families(problem.families, theta))

    def distinct(solved):
        return list(dict.fromkeys(a.candidate for a in solved.attempts))

    for first_rounds, expected in (
            (0, ["configured", "a", "b", "configured+resumed", "a+resumed",
                 "configured+resumed+wide", "a+resumed+wide"]),
            (None, ["configured", "a", "b", "a+resumed", "a+resumed+wide"])):
        calls = []

        def judge(theta: np.ndarray) -> Feasibility:
            calls.append(theta)
            if first_rounds is None and len(calls) == 2:    # the as-built's own round: farther
                clearance = -0.06
            else:
                k = len(calls) - (1 if first_rounds is None and len(calls) > 2 else 0)
                clearance = clearances.get(k, -0.015)
            return Feasibility(("obstacle",), True, (ConstraintCheck("obstacle", True, 0.05),),
                               clearance)
        solved = solve_constrained(problem, config, judge, restarts, first_rounds=first_rounds)
        assert not solved.feasibility.ok
        assert distinct(solved) == expected, first_rounds


def test_constraint_config_defaults_and_checks():
    """The schedule's defaults are the constants the solve used before the group existed."""
    defaults = PlannerConfig().constraints
    assert (defaults.progress, defaults.stiffen, defaults.wanted,
            defaults.soft_start_tolerance) == (0.25, 4.0, 1, 3e-2)
    for bad in ({"progress": 0.0}, {"stiffen": 0.5}, {"wanted": 0},
                {"soft_start_tolerance": -1.0}, {"resumed": -1}, {"resume_rounds": 0},
                {"wide_margin": -1.0}):
        with raises_naming(InvalidParameterError, f"config.constraints.{next(iter(bad))}"):
            PlannerConfig().with_(**bad)
