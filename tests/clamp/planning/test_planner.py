"""CLAMP planner: box_closing on the Jaco (empty scene and with the reference's new obstacle),
failure reporting, input errors, extra factors, initialisations."""
from __future__ import annotations


import gtsam
import numpy as np
import pytest

from bad_input import raises_naming
from clamp.errors import (ClampError, ClampTypeError, InvalidParameterError, NonFiniteError,
                          ShapeError)
from clamp.prior.learning import learn_prior
from clamp import PlannerConfig, build, plan
from clamp.factors.joint_limits import LIMIT_TOLERANCE
from clamp.optim.stopping import StoppingRule
from clamp.planning.clearance import check_clearance
from clamp.planning.verdict import sphere_clearance

REFERENCE_START = np.array([0.2054, -0.4722, 0.2625])
REFERENCE_BOX = [0.32, -0.32, 0.13, 0.09, 0.06, 0.28]
# the defaults (reference graph with sigma_obs 0.005, fast solver with the workspace correction)
# clear the box in ~15 iterations; the reference's plain LM needs ~500 against the stiff
# learned prior (see benchmarks/bench_clamp.py)
OBSTACLE_CONFIG = PlannerConfig()


@pytest.fixture(scope="module")
def box_closing(request):
    from scenes import load_demonstrations
    from tests.conftest import dataset_path
    path = dataset_path("box_closing")
    if path is None:
        pytest.skip("box_closing.mat not found in ../shared/datasets (set SKILLPLAN_DATASETS)")
    demos = load_demonstrations(path)
    return demos, learn_prior(demos)


@pytest.fixture(scope="module")
def synthetic():
    from scenes import make_demonstrations
    demos = make_demonstrations("box_closing", num_demos=6, num_points=120, seed=3)
    return demos, learn_prior(demos)


@pytest.fixture(scope="module")
def obstacle_scene():
    from scenes import Box, Scene
    scene = Scene([Box.from_reference(REFERENCE_BOX)])
    return scene, scene.sdf(0.01)


@pytest.fixture(scope="module")
def empty_plan(jaco, box_closing):
    return plan(box_closing[1], jaco, None, REFERENCE_START)


def assert_reproduces_skill(result, demos, robot):
    assert result.success, result.reasons
    assert result.start_error <= 1e-3
    final = demos.positions[:, -1].mean(axis=0)
    assert np.linalg.norm(result.ee_path[-1] - final) <= 0.02
    # the limit factors are soft: allow the success check's tolerance (1e-4 rad)
    assert np.all(robot.within_limits(result.q, LIMIT_TOLERANCE))
    assert np.all(np.abs(result.qdot) <= robot.velocity_limits + 1e-3)
    # the reported end-effector path is the forward kinematics of the plan
    np.testing.assert_allclose(result.ee_path, robot.fk(result.q), atol=1e-9)


def test_box_closing_empty_scene(jaco, box_closing, empty_plan):
    demos, _ = box_closing
    assert_reproduces_skill(empty_plan, demos, jaco)
    assert np.linalg.norm(empty_plan.ee_path[0] - REFERENCE_START) <= 1e-3
    assert empty_plan.q.shape == (demos.T, jaco.n)
    assert empty_plan.final_error < empty_plan.initial_error
    assert np.isinf(empty_plan.min_clearance)
    assert 0.0 <= empty_plan.plausibility <= 1.0


def test_box_closing_with_obstacle(jaco, box_closing, obstacle_scene, empty_plan):
    demos, prior = box_closing
    scene, sdf = obstacle_scene
    result = plan(prior, jaco, scene, REFERENCE_START, config=OBSTACLE_CONFIG, sdf=sdf)
    assert_reproduces_skill(result, demos, jaco)
    # the optimiser's spheres keep to within millimetres of the box (the constrained solve
    # stops once the meshes are clear: the spheres reach past them in places) ...
    clearance = sphere_clearance(jaco, scene, result.q)
    assert clearance.min() >= -0.005
    # ... the verdict measures the URDF collision meshes (at and between states)
    from robots.collision_check import CollisionChecker
    from scenes.coal_shapes import coal_obstacles
    at_states = CollisionChecker(jaco, coal_obstacles(scene)).distances(result.q).min()
    assert result.collision_geometry == "urdf" and 0.0 < result.min_clearance <= at_states + 1e-9
    # on the same problem from the same start (the reference's graph: no posture tie, from the
    # prior mean), plain LM (the reference's method: no workspace correction, lambda0 1e3) gets
    # far less far in as many iterations (it crawls for ~500)
    from clamp.optim.solver import levenberg_marquardt
    built = build(prior, jaco, scene, REFERENCE_START, sdf=sdf,
                  config=OBSTACLE_CONFIG.with_(posture_sigma=0.0))
    ours = levenberg_marquardt(built, built.initial, max_iterations=5)
    plain = levenberg_marquardt(built, built.initial, max_iterations=5, workspace_correction=0,
                                lambda_initial=1e3)
    assert ours.final_error < 0.5 * plain.final_error
    # the same skill unaware of the box (its plan in the empty scene) runs through it
    assert sphere_clearance(jaco, scene, empty_plan.q).min() < 0.0
    assert check_clearance(jaco, scene, empty_plan.q).collision


def test_start_inside_obstacle_fails_with_reason(jaco, synthetic):
    from scenes import Box, Scene
    _, prior = synthetic
    start = prior.mean[0, :3]
    scene = Scene([Box(start, [0.1, 0.1, 0.1])])
    result = plan(prior, jaco, scene, start)
    assert not result.success
    assert any("inside an obstacle" in r or "collision" in r for r in result.reasons)


def test_start_out_of_reach_fails_with_reason(jaco, synthetic):
    _, prior = synthetic
    result = plan(prior, jaco, None, [2.0, 2.0, 2.0])
    assert not result.success
    assert any("out of reach" in r for r in result.reasons)


def test_synthetic_skill_from_new_start_and_joint_goal(jaco, synthetic):
    demos, prior = synthetic
    start = prior.mean[0, :3] + np.array([0.02, -0.02, 0.01])
    result = plan(prior, jaco, None, start)
    assert result.success, result.reasons
    assert result.start_error <= 1e-3
    # a joint-space start and goal are honoured too
    goal = result.q[-1] + 0.02
    again = plan(prior, jaco, None, result.q[0], goal=goal, config=PlannerConfig().with_(goal_sigma=1e-5))
    np.testing.assert_allclose(again.q[0], result.q[0], atol=1e-4)
    assert again.goal_error is not None and again.goal_error <= 0.01


def test_end_effector_goal_and_via_point(jaco, synthetic):
    _, prior = synthetic
    start = prior.mean[0, :3]
    goal = prior.mean[-1, :3] + np.array([0.0, 0.0, 0.03])
    via = prior.mean[60, :3] + np.array([0.0, 0.0, 0.02])
    config = PlannerConfig().with_(goal_sigma=1e-4)
    result = plan(prior, jaco, None, start, goal=goal, via_points=[(60, via)], config=config)
    assert result.goal_error <= 2e-3
    assert np.linalg.norm(result.ee_path[60] - via) <= 2e-3


def test_straight_line_initialisation(jaco, synthetic):
    _, prior = synthetic
    config = PlannerConfig().with_(initialisation="straight_line")
    problem = build(prior, jaco, None, prior.mean[0, :3], config=config)
    q = problem.initial[:, :jaco.n]
    second_difference = q[2:] - 2 * q[1:-1] + q[:-2]
    np.testing.assert_allclose(second_difference, 0.0, atol=1e-12)
    result = plan(prior, jaco, None, prior.mean[0, :3], config=config)
    assert result.success, result.reasons


def test_warm_start_from_previous_plan_converges_at_once(jaco, synthetic):
    _, prior = synthetic
    start = prior.mean[0, :3]
    first = plan(prior, jaco, None, start)
    again = plan(prior, jaco, None, start, initial=np.hstack([first.q, first.qdot]))
    assert again.success
    assert again.iterations <= 2
    assert again.initial_error <= first.final_error * 1.01
    np.testing.assert_allclose(again.ee_path, first.ee_path, atol=2e-3)
    with raises_naming(ShapeError, "initial"):
        plan(prior, jaco, None, start, initial=first.q[:-1])


def test_gtsam_optimizer_agrees_with_fast_solver(jaco, synthetic):
    _, prior = synthetic
    start = prior.mean[0, :3]
    # the whole error here is below the default absolute tolerance (0.01): compare converged runs
    lean_rule = StoppingRule(absolute_tol=1e-5)
    lean = plan(prior, jaco, None, start, config=PlannerConfig(stopping=lean_rule))
    reference = plan(prior, jaco, None, start,
                     config=PlannerConfig(optimizer="gtsam", stopping=lean_rule))
    assert reference.final_error == pytest.approx(lean.final_error, rel=1e-2)
    np.testing.assert_allclose(reference.ee_path, lean.ee_path, atol=2e-3)


def test_extra_factor_maker_called_per_state(jaco, synthetic):
    _, prior = synthetic
    calls = []
    target = prior.mean[-1, :3] + np.array([0.0, 0.0, 0.05])

    def lift_last_state(index, num_states, key):
        calls.append((index, num_states))
        if index != num_states - 1:
            return None
        robot = jaco

        def error(this, values, H):
            theta = values.atVector(key)
            kin = robot.ee_kinematics(theta[None, :robot.n], None)
            if H is not None:
                H[0] = np.hstack([kin.jacobian[0], np.zeros((3, robot.n))])
            return kin.position[0] - target
        return gtsam.CustomFactor(gtsam.noiseModel.Isotropic.Sigma(3, 1e-4), [key], error)

    result = plan(prior, jaco, None, prior.mean[0, :3], extra_factors=[lift_last_state])
    assert [c[0] for c in calls] == list(range(prior.T))
    assert np.linalg.norm(result.ee_path[-1] - target) <= 2e-3
    assert "foreign" in result.family_errors


@pytest.mark.parametrize("kwargs, error, name", [
    ({"start": [0.1, 0.2]}, ShapeError, "start"),
    ({"start": [np.nan, 0.2, 0.3]}, NonFiniteError, "start"),
    ({"start": [0.3, -0.3, 0.2], "goal": np.zeros(5)}, ShapeError, "goal"),
    ({"start": [0.3, -0.3, 0.2], "via_points": [(10_000, [0.3, 0.2, 0.1])]}, InvalidParameterError,
     "via_points[0]"),
    ({"start": [0.3, -0.3, 0.2], "config": lambda: PlannerConfig().with_(initialisation="magic")},
     InvalidParameterError, "initialisation"),
    ({"start": [0.3, -0.3, 0.2], "config": lambda: PlannerConfig().with_(sigma_obs=-1.0)},
     InvalidParameterError, "sigma_obs"),
    ({"start": [0.3, -0.3, 0.2], "config": lambda: PlannerConfig().with_(optimizer="lu")},
     InvalidParameterError, "optimizer"),
    ({"start": [0.3, -0.3, 0.2], "config": {"sigma_obs": 0.005}}, ClampTypeError, "config"),
    ({"start": [0.3, -0.3, 0.2], "scene": 42}, ClampTypeError, "scene"),
    ({"start": [0.3, -0.3, 0.2], "config": lambda: PlannerConfig().with_(
        stopping=StoppingRule(patience=0))}, InvalidParameterError, "stopping.patience"),
    ({"start": [0.3, -0.3, 0.2], "config": lambda: PlannerConfig().with_(stopping="quick")},
     InvalidParameterError, "config.optimizer.stopping"),
    ({"start": [0.3, -0.3, 0.2], "config": lambda: PlannerConfig().with_(limit_tolerance=1e-3)},
     InvalidParameterError, "LIMIT_TOLERANCE"),
    ({"start": [0.3, -0.3, 0.2], "extra_factors": [42]}, InvalidParameterError, "extra_factors[0]"),
    ({"start": [0.3, -0.3, 0.2], "extra_factors": [gtsam.PriorFactorVector(
        gtsam.symbol("y", 0), np.zeros(12), gtsam.noiseModel.Unit.Create(12))]}, InvalidParameterError,
     "extra_factors[0]"),
    ({"start": [0.3, -0.3, 0.2], "extra_factors": [lambda i, n, key: "factor"]}, InvalidParameterError,
     "extra_factors[0]"),
])
def test_bad_input_raises_clamp_error(jaco, synthetic, kwargs, error, name):
    kwargs = dict(kwargs)
    _, prior = synthetic
    assert issubclass(error, ClampError)
    with raises_naming(error, name):
        if callable(kwargs.get("config")):   # configurations are checked when made
            kwargs["config"] = kwargs["config"]()
        plan(prior, jaco, kwargs.pop("scene", None), **kwargs)


def test_unknown_config_field_lists_the_valid_ones():
    with raises_naming(InvalidParameterError, "sigma_obstacle", "sigma_obs"):
        PlannerConfig().with_(sigma_obstacle=0.1)


def test_prior_robot_mismatch_raises(jaco):
    from clamp.prior.learning import learn_joint_prior
    rng = np.random.default_rng(0)
    q = rng.normal(size=(4, 20, 2))
    joint_prior = learn_joint_prior(q, np.gradient(q, axis=1), np.arange(20) * 0.1)
    with raises_naming(ShapeError, "prior"):
        plan(joint_prior, jaco, None, [0.3, -0.3, 0.2])


def test_box_closing_on_sawyer(box_closing, sawyer):
    demos = box_closing[0].translated(np.array([0.3, 0.0, 0.2]))
    prior = learn_prior(demos)
    result = plan(prior, sawyer, None, prior.mean[0, :3] + np.array([0.0, -0.03, 0.02]))
    assert_reproduces_skill(result, demos, sawyer)
