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


def _skill_scene(skill: str, at: float, size: float, offset) -> dict:
    """plan() arguments for the synthetic ``skill`` (6 demonstrations, 250 states, seed 0) on
    the Jaco: a cube of edge ``size`` [m] centred on the prior's mean path at ``at`` of it, the
    start ``offset`` (3,) [m] from the demonstrations' mean start, the skill's own end."""
    from clamp import learn_prior
    from robots import load_robot
    from scenes import make_demonstrations
    prior = learn_prior(make_demonstrations(skill, num_demos=6, num_points=250, seed=0))
    mean = np.asarray(prior.mean)[:, :3]
    box = Box(mean[int(round(at * (len(mean) - 1)))], [size] * 3)
    return {"prior": prior, "robot": load_robot("jaco"), "scene": Scene([box]),
            "start": mean[0] + np.asarray(offset, dtype=float)}


def _collides(robot, scene, q) -> bool:
    """The URDF collision geometry of q (T, n) meets the scene (independent of the verdict)."""
    from robots.collision_check import CollisionChecker
    from scenes.coal_shapes import coal_obstacles
    return bool(CollisionChecker(robot, coal_obstacles(scene.obstacles)).check(q).collision)


def test_the_motion_ties_smooth_the_detour():
    """reach_from_above with a 6 cm cube on its mean path at 50 % and the start 6 cm off: the
    free plan runs through the cube; without the motion and velocity ties the wrist swings out
    and back around it; with them the detour is smooth: less joint travel, smaller velocity
    changes, collision-free and with the skill."""
    kwargs = _skill_scene("reach_from_above", 0.5, 0.06, [-0.06, 0.0, 0.0])
    robot, scene = kwargs["robot"], kwargs["scene"]
    free = plan(**{**kwargs, "scene": None}, covariance=False)
    assert _collides(robot, scene, free.q)
    smooth = plan(**kwargs, covariance=False)
    swing = plan(**kwargs, covariance=False,
                 config=PlannerConfig().with_(posture_Qc=0.0, posture_velocity_sigma=0.0))
    assert smooth.success, smooth.reasons
    assert not _collides(robot, scene, smooth.q)
    jerk = lambda r: float(np.abs(np.diff(r.qdot, axis=0)).max())   # rad/s per step
    print(f"joint travel {_travel(smooth.q):.2f} vs {_travel(swing.q):.2f} rad, largest velocity "
          f"change per step {jerk(smooth):.3f} vs {jerk(swing):.3f} rad/s")
    assert _travel(smooth.q) < 0.75 * _travel(swing.q)
    assert jerk(smooth) < jerk(swing)


def test_a_hand_pushed_out_of_the_skill_keeps_within_its_tube():
    """pick_place with an 8 cm cube on its mean path at 45 % and the start 3 cm off: the free
    plan runs through the cube, and going around it pushes the hand towards the edge of the
    skill's tube where the demonstrations agree (the untied restart's optimum leaves it: the
    tube's hinges join that solve). The plan completes, clear of the cube on the URDF geometry,
    and its own end-effector path keeps within the tube, measured by the skill checks."""
    from clamp.planning.pipeline import model
    from clamp.planning.request import make_request
    from clamp.prior.skill import TUBE_RATIO, skill_checks
    kwargs = _skill_scene("pick_place", 0.45, 0.08, [-0.03, 0.0, 0.0])
    prior, robot, scene = kwargs["prior"], kwargs["robot"], kwargs["scene"]
    free = plan(**{**kwargs, "scene": None}, covariance=False)
    assert _collides(robot, scene, free.q)
    result = plan(**kwargs, covariance=False)
    assert result.success, result.reasons
    assert not _collides(robot, scene, result.q)
    built = model(prior, robot, scene, make_request(prior, robot, kwargs["start"]),
                  PlannerConfig())
    check = skill_checks(prior, built.reference, robot.fk(result.q), False, score=False)
    assert check.max_ratio <= TUBE_RATIO
