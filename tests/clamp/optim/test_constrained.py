"""The augmented-Lagrangian solve of clamp.optim.constrained, on both arms at random points:

- a constraint family's shifts move its hinges: e = max(0, g + s) for the unshifted hinge g
  (measured from the unshifted kernel wherever it is active), Jacobians still those of g
  (central differences), the GTSAM adapters the same kernel; cost families have no shifts;
- one multiplier update (:func:`clamp.optim.constrained.update`): the shift of a violated family
  becomes its current residual, its noise is divided by the configuration's ``stiffen`` at its
  first update (and its shifts by stiffen^2, so lambda = mu s is the same multiplier), a family
  the checks did not name is left as it is, a lazy family joins unshifted at its configured
  noise and is stiffened at its first update after joining; the schedule is
  :class:`clamp.optim.constrained.ALConfig`;
- one start's outer loop (:func:`clamp.optim.constrained.solve_start`): updates until the judge
  passes or its rounds are spent, a stop between updates, every judged optimum in the ledger;
- the solver layer names no planning domain.
"""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from pathlib import Path

import clamp
from clamp.config import PlannerConfig
from clamp.optim.constrained import (ALConfig, Feasibility, Ledger, Start, chosen, resumed,
                                     solve_start, update)
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
    plain = ALConfig(update_active=False, margin_floor=1.0)
    new = update(problem, theta, ["obstacle", "self_collision"], previous, lazy, plain)
    STIFFEN, PROGRESS = ALConfig().stiffen, ALConfig().progress

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
    again = update(new, theta, ["obstacle"], previous, lazy, plain)
    np.testing.assert_allclose(again.family("obstacle").whitening, updated.whitening)
    np.testing.assert_allclose(again.family("obstacle").shift,
                               dense_residual(updated, robot, theta))
    assert previous["obstacle"] < PROGRESS * 1e9
    assert again.family(PostureFamily.name) is new.family(PostureFamily.name)
    assert not again.has("skill_tube")

    # the joined family's first update stiffens it, whatever its violation (issue 27: a lazy
    # constraint at its configured noise lost against the stiffened obstacle hinges)
    stiffer = update(new, theta, ["self_collision"], dict(previous), lazy, plain)
    np.testing.assert_allclose(stiffer.family("self_collision").whitening,
                               STIFFEN * joined.whitening)

    # the skill's tube joins (a lazy constraint), the rest as it was
    tube = update(again, theta, ["skill_tube"], previous, lazy, plain)
    assert tube.family("skill_tube").shift is None
    for name in ("obstacle", PostureFamily.name, "self_collision"):
        assert tube.family(name) is again.family(name)

    # another schedule: another stiffening factor
    softer = update(problem, theta, ["obstacle"], {}, lazy, ALConfig(stiffen=2.0))
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
    new = update(problem, theta, ["joint_limits"], {}, {}, ALConfig())
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
    floor = ALConfig(margin_floor=before.epsilon)
    assert update(problem, theta, ["joint_limits"], {}, {}, floor).family("obstacle") \
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
    plain = ALConfig(update_active=False)
    unseen = update(problem, theta, ["obstacle"], {}, {}, plain,
                       {"obstacle": 3.0 * seen + 0.01})
    assert unseen.family("obstacle").epsilon == pytest.approx(
        obstacle.epsilon + 2.0 * seen + 0.01)
    tiny = update(problem, theta, ["obstacle"], {}, {}, plain, {"obstacle": 2.0 * seen + 1e-6})
    assert tiny.family("obstacle").epsilon == pytest.approx(
        obstacle.epsilon + max(seen + 1e-6, obstacle.near))
    for amounts in ({"obstacle": 1.5 * seen}, {}, None):
        kept = update(problem, theta, ["obstacle"], {}, {}, plain, amounts)
        assert kept.family("obstacle").epsilon == obstacle.epsilon
    # a family without a margin to widen keeps its hinges
    limits = update(problem, theta, ["joint_limits"], {}, {}, plain, {"joint_limits": 1.0})
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


def _random_problem(robot, seed):
    rng = np.random.default_rng(seed)
    theta = random_theta(robot, rng)
    return PlanningProblem(robot, len(theta), make_families(robot, theta, rng), [], theta)


@pytest.mark.parametrize("rounds, passes_at, passed, solves", [
    (1, 2, True, 2),        # the first update's optimum passes
    (0, 2, False, 1),       # no update allowed: the weighted solve alone, judged once
    (2, 10, False, 3)])     # the rounds spent (5 cm short: no polish)
def test_a_start_updates_until_the_judge_passes(jaco, rounds, passes_at, passed, solves):
    problem = _random_problem(jaco, 3)
    config = PlannerConfig().with_(max_iterations=5)
    judge, calls = scripted_judge(passes_at)
    ledger = Ledger()
    assert solve_start(Start("s", problem, rounds, polish=3), config, judge, ledger) is passed
    assert len(ledger.rounds) == len(calls) == solves
    assert [r.index for r in ledger.rounds] == list(range(solves))
    assert ledger.work == ledger.trials + solves and ledger.iterations == sum(
        r.iterations for r in ledger.rounds)
    assert (ledger.feasible is not None) is passed
    assert chosen(ledger).verdict.ok is passed
    # every update after the first solve stiffened the violated obstacle hinges
    if solves > 1:
        assert np.all(ledger.rounds[-1].problem.family("obstacle").whitening
                      > problem.family("obstacle").whitening)


def test_a_stop_ends_a_start_between_its_updates(jaco):
    problem = _random_problem(jaco, 3)
    judge, calls = scripted_judge(10)
    ledger = Ledger()
    assert not solve_start(Start("s", problem, 4), PlannerConfig().with_(max_iterations=5),
                           judge, ledger, stop=lambda: True)
    assert len(calls) == len(ledger.rounds) == 1


def test_a_halted_solve_is_judged_only_when_nothing_was(jaco):
    """A stop that halts the solve (a deadline): the ledger's first optimum is judged (a search
    always has a verdict); once one is, a halted solve costs no judgement and adds no round,
    though its work is counted."""
    problem = _random_problem(jaco, 3)
    judge, calls = scripted_judge(10)
    config = PlannerConfig().with_(max_iterations=5)
    ledger = Ledger()
    solve_start(Start("first", problem, 0), config, judge, ledger)
    trials = ledger.trials
    stops = iter([False, False, True])             # two iterations, then halted
    assert not solve_start(Start("late", problem, 4), config, judge, ledger,
                           stop=lambda: next(stops, True))
    assert len(calls) == len(ledger.rounds) == 1 and ledger.rounds[0].start == "first"
    assert ledger.trials > trials


def test_a_hair_short_start_gets_its_polish_rounds(jaco):
    """An optimum within ``reach`` times its family's ``near`` of passing gets ``polish`` more
    updates past its rounds; 5 cm short gets none."""
    problem = _random_problem(jaco, 3)
    near = problem.family("obstacle").near
    calls = []

    def judge(theta):
        calls.append(theta)
        return Feasibility(("obstacle",), True, (ConstraintCheck("obstacle", True, near),),
                           -near)
    ledger = Ledger()
    config = PlannerConfig().with_(max_iterations=5)
    assert not solve_start(Start("s", problem, 1, polish=2, reach=1.0), config, judge, ledger)
    assert len(calls) == 1 + 1 + 2


def test_a_resumed_start_continues_the_multipliers(jaco):
    problem = _random_problem(jaco, 3)
    judge, _ = scripted_judge(10)
    ledger = Ledger()
    solve_start(Start("s", problem, 0), PlannerConfig().with_(max_iterations=5), judge, ledger)
    last = ledger.rounds[-1]
    again = resumed(last, {})
    expected = update(last.problem, last.out.theta, ["obstacle"], {}, {}, ALConfig(),
                      {"obstacle": 0.05})
    np.testing.assert_allclose(again.family("obstacle").shift,
                               expected.family("obstacle").shift)
    np.testing.assert_array_equal(again.initial, last.out.theta)


def test_the_solver_names_no_planning_domain():
    """clamp.optim is a generic constrained solver (issue 36): no obstacle, skill or
    self-collision in its sources."""
    import re
    folder = Path(clamp.__file__).parent / "optim"
    for path in folder.glob("*.py"):
        assert not re.search(r"Obstacle|Skill|SelfCollision", path.read_text()), path.name


def test_the_schedule_defaults():
    """The schedule's defaults are the constants the solve used before it was its own group."""
    al = ALConfig()
    assert (al.progress, al.stiffen, al.margin_floor, al.update_active,
            al.soft_tolerance) == (0.25, 4.0, 0.005, True, 3e-2)
