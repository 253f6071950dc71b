"""The posture tie: with obstacles, the plan keeps the free plan's posture and moves only as far
as the obstacles demand (issue 19: no flailing wrist to dodge a box)."""
import numpy as np
import pytest

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
    assert "posture_motion" in names
    off = PlannerConfig().with_(posture_Qc=0.0)
    names = [f.name for f in build(prior, jaco, scene, START, config=off).families]
    assert "posture" in names and "posture_motion" not in names
    assert "posture_velocity" in names
    off = PlannerConfig().with_(posture_velocity_sigma=0.0)
    names = [f.name for f in build(prior, jaco, scene, START, config=off).families]
    assert "posture_motion" in names and "posture_velocity" not in names


def test_the_velocity_tie_is_the_excess_joint_speed(jaco):
    """PostureVelocityFamily(reference, sigma) at theta costs 0.5 sum |qdot - qdot_ref|^2 /
    sigma^2 over the states, whatever the positions, and nothing at the reference."""
    from clamp.factors import PostureVelocityFamily, StateWindow
    rng = np.random.default_rng(4)
    T, n = 12, jaco.n
    reference = rng.normal(size=(T, 2 * n))
    theta = reference + rng.normal(scale=0.1, size=reference.shape)
    tie = PostureVelocityFamily(reference, 0.03)
    excess = theta[:, n:] - reference[:, n:]
    assert tie.error(StateWindow(jaco, theta)) == pytest.approx(
        0.5 * float(np.sum(excess ** 2)) / 0.03 ** 2, rel=1e-12)
    assert tie.error(StateWindow(jaco, reference)) == 0.0


def test_the_motion_tie_is_the_joint_gp_of_the_deviation(jaco):
    """PostureMotionFamily(reference, dt, Qc) at theta has the joint GP's error of
    theta - reference (same Qc), and none at the reference itself."""
    from clamp.factors import JointGPFamily, PostureMotionFamily, StateWindow
    rng = np.random.default_rng(3)
    T, n, dt = 12, jaco.n, 0.16
    reference = rng.normal(size=(T, 2 * n))
    theta = reference + rng.normal(scale=0.1, size=reference.shape)
    tie, gp = PostureMotionFamily(reference, dt, 1e-4), JointGPFamily(T, n, dt, 1e-4)
    assert tie.error(StateWindow(jaco, theta)) == pytest.approx(
        gp.error(StateWindow(jaco, theta - reference)), rel=1e-9)
    assert tie.error(StateWindow(jaco, reference)) == pytest.approx(0.0, abs=1e-18)


def _benchmark_problem(index: int) -> dict:
    """plan() arguments of scene-benchmark problem ``index`` (Jaco, the default config)."""
    from pathlib import Path

    from clamp.batch.runner import resolve
    from clamp.batch.problem_sets import scene_benchmark
    problem = scene_benchmark(index + 1, "jaco", 0, skills=["box_closing", "reach_from_above",
                                                             "pick_place", "two_target_press"],
                              impossible_share=0.0, start_offset=0.08)[index]
    kwargs = resolve(problem, Path("."))
    kwargs.pop("config", None)
    return kwargs


def test_the_motion_ties_smooth_the_detour(jaco):
    """Fidelity-benchmark problem 45 (reach_from_above, Jaco, no goal): without the motion and
    velocity ties the wrist swings out and back around the box (joint travel ~5x the free
    plan's); with them the detour is smooth: less joint travel, smaller velocity changes, still
    collision-free and with the skill."""
    kwargs = _benchmark_problem(45)
    smooth = plan(**kwargs, covariance=False)
    swing = plan(**kwargs, covariance=False,
                 config=PlannerConfig().with_(posture_Qc=0.0, posture_velocity_sigma=0.0))
    assert smooth.success, smooth.reasons
    jerk = lambda r: float(np.abs(np.diff(r.qdot, axis=0)).max())   # rad/s per step
    print(f"joint travel {_travel(smooth.q):.2f} vs {_travel(swing.q):.2f} rad, largest velocity "
          f"change per step {jerk(smooth):.3f} vs {jerk(swing):.3f} rad/s")
    assert _travel(smooth.q) < 0.75 * _travel(swing.q)
    assert jerk(smooth) < jerk(swing)


def test_a_hand_pushed_out_of_the_skill_gets_the_tube_as_a_constraint(jaco):
    """Fidelity-benchmark problem 78 (Jaco): the tied problem's optimum touches the box; the
    untied restart's goes around it with the hand, out of the skill's tube where the
    demonstrations agree; the tube's hinges join that candidate's constrained solve and its
    next optimum keeps within the tube, measured by the skill checks on the plan's own
    end-effector path."""
    from clamp.planning.pipeline import model
    from clamp.planning.request import make_request
    from clamp.prior.skill import TUBE_RATIO, skill_checks
    kwargs = {**_benchmark_problem(78), "goal": None, "via_points": ()}  # the skill's own end
    result = plan(**kwargs, covariance=False)
    assert result.success, result.reasons
    assert "skill_tube" in [f.name for f in result.problem.families]
    built = model(kwargs["prior"], jaco, kwargs["scene"],
                  make_request(kwargs["prior"], jaco, kwargs["start"]), PlannerConfig())
    check = skill_checks(kwargs["prior"], built.reference, jaco.fk(result.q), False, score=False)
    assert check.max_ratio <= TUBE_RATIO
