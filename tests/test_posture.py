"""The posture tie: with obstacles, the plan keeps the free plan's posture and moves only as far
as the obstacles demand (issue 19: no flailing wrist to dodge a box)."""
import numpy as np

from clamp import PlannerConfig, build, plan
from scenes import Box, Scene

START = [0.2054, -0.4722, 0.2625]


def _travel(q):
    return float(np.abs(np.diff(q, axis=0)).sum())


def test_the_box_plan_keeps_the_free_plans_posture(prior, jaco):
    scene = Scene([Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])])
    free = plan(prior, jaco, None, START, covariance=False)
    tied = plan(prior, jaco, scene, START, covariance=False)
    loose = plan(prior, jaco, scene, START, covariance=False,
                 config=PlannerConfig().with_(posture_sigma=0.0))
    assert tied.success and free.success
    print(f"joint travel: free {_travel(free.q):.2f}, tied {_travel(tied.q):.2f}, "
          f"untied {_travel(loose.q):.2f} rad")
    assert _travel(tied.q) <= 1.5 * _travel(free.q)
    assert _travel(tied.q) < _travel(loose.q)
    assert "posture" in tied.family_errors


def test_a_plan_clear_of_the_obstacles_is_the_free_plan(prior, jaco):
    far = Scene([Box([-0.5, 0.5, 0.1], [0.1, 0.1, 0.1])])
    free = plan(prior, jaco, None, START, covariance=False)
    clear = plan(prior, jaco, far, START, covariance=False)
    assert clear.success
    np.testing.assert_allclose(clear.q, free.q, atol=1e-6)
    assert clear.family_errors["posture"] < 1e-9


def test_the_graph_holds_the_tie(prior, jaco):
    scene = Scene([Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])])
    names = [f.name for f in build(prior, jaco, scene, START).families]
    assert "posture" in names
    assert "posture" not in [f.name for f in build(prior, jaco, None, START).families]
    off = PlannerConfig().with_(posture_sigma=0.0)
    assert "posture" not in [f.name for f in build(prior, jaco, scene, START, config=off).families]
