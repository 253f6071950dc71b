"""The unit check before planning (clamp.planning.reach): skills far outside the arm's reach."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import errors, learn_prior, plan
from clamp.planning.reach import REACH_FACTOR, check_reach, reach_radius
from scenes import Demonstrations, make_demonstrations

START = [0.2054, -0.4722, 0.2625]


@pytest.fixture(scope="module")
def demos():
    return make_demonstrations("box_closing", num_demos=6, num_points=60, seed=0)


@pytest.mark.parametrize("arm", ["jaco", "sawyer"])
def test_reach_bounds_every_configuration(arm, request):
    robot = request.getfixturevalue(arm)
    rng = np.random.default_rng(7)
    q = np.stack([robot.random_configuration(rng) for _ in range(2000)])
    farthest = np.linalg.norm(robot.fk(q), axis=1).max()
    assert farthest <= reach_radius(robot) < 1.5 * farthest


@pytest.mark.parametrize("scale, message", [
    (1000.0, r"prior: positions reach .* m from the base of jaco, more than 3 x its reach of "
             r"1.26 m; positions look like millimetres: divide by 1000"),
    (100.0, r"positions look like centimetres: divide by 100"),
])
def test_priors_in_the_wrong_unit_are_refused_before_planning(jaco, demos, scale, message):
    scaled = Demonstrations(demos.positions * scale, demos.velocities * scale, demos.time)
    with pytest.raises(errors.InvalidParameterError, match=message):
        plan(learn_prior(scaled), jaco, None, START)


def test_skills_within_a_few_reaches_are_not_refused(jaco, demos):
    """Metres are accepted, also a skill moved out of reach by less than REACH_FACTOR reaches
    (a different base frame, say): planned, the verdict judges it."""
    check_reach(jaco, demos.positions, "demonstrations")
    assert plan(learn_prior(demos), jaco, None, START).success
    far = reach_radius(jaco) * (REACH_FACTOR - 0.5)
    moved = demos.translated([far - np.linalg.norm(demos.positions, axis=2).max(), 0, 0])
    check_reach(jaco, moved.positions, "demonstrations")
    assert plan(learn_prior(moved), jaco, None, START).q.shape == (60, 6)


def test_far_positions_without_a_unit_explanation(jaco):
    with pytest.raises(errors.InvalidParameterError,
                       match=r"demos: positions reach 2e\+04 m .*expected metres in the "
                             r"robot's base frame"):
        check_reach(jaco, [[2e4, 0.0, 0.0]], "demos")
    with raises_naming(errors.NonFiniteError, "demos positions"):
        check_reach(jaco, [[np.nan, 0.0, 0.0]], "demos")
