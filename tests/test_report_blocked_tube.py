"""The sound hand bound of benchmarks/report_blocked_tube.py: an upper bound on the clearance
of the hand's own geometry over every pose the skill checks allow. A box that fills the tube
(or the skill's end) is certified blocked; a box a plan passes is not, and the passing plan's
real clearance stays under the bound at every state."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import report_blocked_tube as rbt  # noqa: E402

from clamp import learn_prior, plan  # noqa: E402
from clamp.planning.clearance import state_clearance  # noqa: E402
from scenes import Box, Scene, make_demonstrations  # noqa: E402


@pytest.fixture(scope="module")
def skill():
    return learn_prior(make_demonstrations("pick_place", num_demos=6, num_points=120, seed=0))


def box_at(prior, at: float, size: float) -> Scene:
    """A cube of edge ``size`` [m] centred on the prior's mean path at ``at`` of it."""
    mean = np.asarray(prior.mean)[:, :3]
    return Scene([Box(mean[int(round(at * (len(mean) - 1)))], [size] * 3)])


def bounds(prior, robot, scene):
    start = np.asarray(prior.mean)[0, :3]
    centre, limit, reference = rbt.tube(prior, robot, start)
    points = rbt.hand_points(robot)
    return (rbt.hand_bound(scene, prior, centre, limit, reference, points),
            rbt.end_bound(scene, prior, points), limit, points)


def test_the_hand_points_lie_on_the_hand_near_its_end_effector_point(jaco):
    points = rbt.hand_points(jaco)
    assert points.shape[1] == 3 and 0 < len(points) <= rbt.MAX_POINTS
    assert np.all(np.isfinite(points))
    assert np.linalg.norm(points, axis=1).min() < 0.2      # the hand, not the arm's base


def test_a_box_that_fills_the_tube_is_blocked(skill, jaco):
    _, _, limit, points = bounds(skill, jaco, Scene())
    middle = len(limit) // 2
    reach = np.linalg.norm(points, axis=1).min()
    size = 2.0 * (limit[middle] + reach) + 0.02               # 1 cm deeper than the hand reaches
    hand, _, _, _ = bounds(skill, jaco, box_at(skill, 0.5, size))
    assert hand[middle] < -rbt.TOLERANCE
    assert np.all(hand[[0, -1]] > 0.0)                          # blocked where the box is only


def test_a_box_over_the_skills_end_is_blocked(skill, jaco):
    _, end, _, _ = bounds(skill, jaco, box_at(skill, 1.0, 0.12))
    assert end < -rbt.TOLERANCE


def test_a_box_a_plan_passes_is_not_blocked_and_bounds_its_clearance(skill, jaco):
    scene = box_at(skill, 0.5, 0.06)
    hand, end, _, _ = bounds(skill, jaco, scene)
    assert hand.min() > -rbt.TOLERANCE and end > -rbt.TOLERANCE
    result = plan(skill, jaco, scene, np.asarray(skill.mean)[0, :3], covariance=False)
    assert result.success, result.reasons
    clearance, _ = state_clearance(jaco, scene, result.q, 10.0)
    assert np.all(clearance <= hand + 1e-9)                     # the bound holds for the plan
