"""Time scaled to the arm (issue 27, clamp.planning.time_scale): a skill demonstrated faster than the arm
can follow is planned slower on the same geometry; a skill within the limits is untouched."""
from __future__ import annotations

import numpy as np
import pytest

from clamp import PlannerConfig, learn_prior, plan
from clamp.errors import ClampError
from clamp.factors.joint_limits import LIMIT_TOLERANCE, VELOCITY_TOLERANCE
from clamp.planning.time_scale import time_scaled_prior
from scenes import make_demonstrations

SKILL, STATES, STEP = "reach_from_above", 60, 0.16     # 60 states of 0.16 s: ~9.4 s
FASTER = 3.0                # the fast demonstrations need this many times the arm's speed


def _demos(dt: float):
    return make_demonstrations(SKILL, num_demos=6, num_points=STATES, dt=dt, seed=0)


@pytest.fixture(scope="module")
def slow(jaco):
    """The skill at its demonstrated speed (well within the Jaco's limits) and its plan."""
    prior = learn_prior(_demos(STEP))
    return prior, plan(prior, jaco, None, np.asarray(prior.mean)[0, :3])


@pytest.fixture(scope="module")
def fast(jaco, slow):
    """The same skill demonstrated so fast that following it needs FASTER x the arm's velocity
    limit (the time step shrunk by the slow plan's peak velocity ratio / FASTER), and its plan."""
    _, result = slow
    step = np.abs(np.diff(result.q, axis=0)) / np.diff(result.time)[:, None]
    ratio = float((step / np.asarray(jaco.velocity_limits)).max())
    demos = _demos(STEP * ratio / FASTER)
    prior = learn_prior(demos)
    return demos, prior, plan(prior, jaco, None, np.asarray(prior.mean)[0, :3])


def _finite_difference_velocities(q: np.ndarray, time: np.ndarray) -> np.ndarray:
    return np.abs(np.diff(q, axis=0)) / np.diff(time)[:, None]


def test_a_skill_faster_than_the_arm_is_planned_slower_within_the_limits(jaco, fast):
    demos, prior, result = fast
    assert result.success, result.reasons
    assert 2.5 <= result.time_scale <= 3.5
    # the time stamps are the demonstrations' times the scale, in the result and the trajectory
    np.testing.assert_allclose(result.time, np.asarray(prior.time) * result.time_scale)
    trajectory = result.to_joint_trajectory(jaco, retime=False)
    np.testing.assert_allclose(trajectory.time_from_start, result.time - result.time[0])
    assert result.verdict()["time_scale"] == result.time_scale
    assert result.verdict()["duration_s"] == pytest.approx(prior.time[-1] * result.time_scale)
    # independent check: finite differences of q over the scaled time, the arm's limits
    vmax = np.asarray(jaco.velocity_limits)
    assert np.all(_finite_difference_velocities(result.q, result.time) <= vmax + VELOCITY_TOLERANCE)
    assert np.all(np.abs(result.qdot) <= vmax + VELOCITY_TOLERANCE)
    # it ends where the demonstrations end (forward kinematics of q, not the planner's path)
    ends = np.asarray(demos.positions)[:, -1]
    radius = 2.0 * max(float(np.linalg.norm(ends - ends.mean(axis=0), axis=1).max()), 0.005)
    assert np.linalg.norm(jaco.fk(result.q)[-1] - ends.mean(axis=0)) <= radius


def test_at_the_demonstrated_speed_the_fast_skill_exceeds_the_limits(jaco, fast):
    _, prior, _ = fast
    result = plan(prior, jaco, None, np.asarray(prior.mean)[0, :3], time_scale=1.0)
    assert result.time_scale == 1.0
    np.testing.assert_array_equal(result.time, prior.time)
    assert not result.success and result.reasons        # the limits bend it off the skill


def test_a_skill_within_the_limits_keeps_scale_one_bit_identical(jaco, slow):
    from clamp.planning.pipeline import model
    from clamp.planning.planner import plan_model
    from clamp.planning.request import make_request
    prior, result = slow
    assert result.success, result.reasons
    assert result.time_scale == 1.0
    assert np.array_equal(result.time, prior.time)
    start = np.asarray(prior.mean)[0, :3]
    direct = plan_model(model(prior, jaco, None, make_request(prior, jaco, start), None))
    assert np.array_equal(direct.q, result.q) and np.array_equal(direct.qdot, result.qdot)


def test_a_requested_scale_and_a_maximum_duration(jaco, slow, fast):
    prior, result = slow
    start = np.asarray(prior.mean)[0, :3]
    doubled = plan(prior, jaco, None, start, config=PlannerConfig(time_scale=2.0))
    assert doubled.success and doubled.time_scale == 2.0
    np.testing.assert_allclose(doubled.time, 2.0 * np.asarray(prior.time))
    np.testing.assert_allclose(jaco.fk(doubled.q), jaco.fk(result.q), atol=0.01)   # same path
    _, fast_prior, _ = fast
    duration = float(fast_prior.time[-1])
    # 1.2x the demonstrated duration for a skill demonstrated 3x too fast (at 2x the planner
    # finds a motion within the limits on the skill's tube: that is a success, not this test)
    bounded = plan(fast_prior, jaco, None, np.asarray(fast_prior.mean)[0, :3],
                   max_duration=1.2 * duration)
    assert bounded.time_scale <= 1.2 + 1e-12
    assert not bounded.success
    assert any("max_duration" in reason for reason in bounded.reasons), bounded.reasons


def test_the_time_scaled_prior_is_the_same_skill_slower(slow):
    prior, _ = slow
    scaled = time_scaled_prior(prior, 2.5)
    np.testing.assert_allclose(scaled.time, 2.5 * np.asarray(prior.time))
    np.testing.assert_allclose(scaled.mean[:, :3], prior.mean[:, :3], atol=1e-12)
    np.testing.assert_allclose(scaled.mean[:, 3:], prior.mean[:, 3:] / 2.5, atol=1e-12)
    np.testing.assert_allclose(scaled.cov[:, :3, :3], prior.cov[:, :3, :3], atol=1e-15)
    np.testing.assert_allclose(scaled.cov[:, 3:, 3:], prior.cov[:, 3:, 3:] / 2.5**2, atol=1e-15)
    assert time_scaled_prior(prior, 1.0) is prior


@pytest.mark.parametrize("options, name", [
    ({"time_scale": 0.5}, "time_scale"), ({"time_scale": -2.0}, "time_scale"),
    ({"time_scale": float("nan")}, "time_scale"), ({"time_scale": "slow"}, "time_scale"),
    ({"max_duration": -1.0}, "max_duration"), ({"max_duration": 0.0}, "max_duration"),
    ({"max_duration": 1.0}, "max_duration"),        # shorter than the skill's 9.4 s
])
def test_bad_time_scale_or_duration_raises_naming_the_argument(jaco, slow, options, name):
    prior, _ = slow
    with pytest.raises(ClampError, match=name):
        plan(prior, jaco, None, np.asarray(prior.mean)[0, :3], **options)


@pytest.mark.parametrize("changes, name", [
    ({"time_scale": 0.9}, "config.model.time_scale"),
    ({"max_duration": -3.0}, "config.model.max_duration"),
    ({"acceleration_limit": 0.0}, "config.checks.acceleration_limit"),
    ({"Qc_duration": 0.0}, "config.model.Qc_duration"),
    ({"Qc_duration": "20 s"}, "config.model.Qc_duration"),
])
def test_bad_config_fields_raise_naming_the_field(changes, name):
    with pytest.raises(ClampError, match=name):
        PlannerConfig(**changes)


def test_a_replan_keeps_the_time_scale(jaco, fast):
    from clamp import replan
    _, prior, result = fast
    again = replan(result)
    assert again.time_scale == result.time_scale
    np.testing.assert_allclose(again.time, result.time)


@pytest.mark.parametrize("step", [0.32, 0.16, 0.12, 0.04])
def test_the_joint_space_factors_are_stated_for_a_20_s_skill(jaco, step):
    """A skill demonstrated over D < 20 s is planned as a 20 s one in faster time (k = 20 s / D,
    a slower one as it is; docs/decisions.md#qc_duration): the joint GP's and
    the posture motion tie's densities times k^3, the posture velocity tie's sigma times k. The
    built problem's information is that of those factors at those values, computed here from
    their definitions; a plan at time scale 2 keeps them, divided by 2^3 (by 2 for the sigma)."""
    from clamp import build
    from clamp.factors.family import square_root_information
    from scenes import Box, Scene
    demos = make_demonstrations(SKILL, num_demos=6, num_points=120, dt=step, seed=0)
    prior = learn_prior(demos)
    cube = max(1.0, (20.0 / float(prior.time[-1] - prior.time[0])) ** 3)
    start = np.asarray(prior.mean)[0, :3]
    defaults = PlannerConfig().model
    box = Scene([Box(np.asarray(prior.mean)[60, :3] + [0.0, 0.0, -0.12], [0.04, 0.04, 0.04])])

    def gap(problem, dt, scale):
        """The largest relative difference from the factors' information (those present)."""
        block = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        worst = 0.0
        for name, density in (("joint_gp", defaults.Qc), ("posture_motion", defaults.posture_Qc)):
            if problem.has(name):
                exact = square_root_information(np.kron(block, density * scale * np.eye(jaco.n)))
                given = problem.family(name).whitening[0]
                worst = max(worst, np.abs(given.T @ given - exact.T @ exact).max()
                            / np.abs(exact.T @ exact).max())
        if problem.has("posture_velocity"):
            sigma = defaults.posture_velocity_sigma * scale ** (1 / 3)
            velocity = problem.family("posture_velocity").whitening[0]
            worst = max(worst, abs(np.abs(velocity).max() * sigma - 1.0))
        return worst

    problem = build(prior, jaco, box, start)
    assert problem.has("posture_motion") and problem.has("posture_velocity")    # tied
    assert gap(problem, prior.dt, cube) < 1e-9
    raw = build(prior, jaco, box, start, config=PlannerConfig(Qc_duration=None))
    assert gap(raw, prior.dt, 1.0) < 1e-9
    slower = plan(prior, jaco, box, start, time_scale=2.0, covariance=False)
    assert gap(slower.problem, 2.0 * prior.dt, cube / 8.0) < 1e-9


def _box_on_mean_path(prior):
    """A 6 cm cube centred on the prior's mean path at 50 %."""
    from scenes import Box, Scene
    mean = np.asarray(prior.mean)[:, :3]
    return Scene([Box(mean[len(mean) // 2], [0.06, 0.06, 0.06])])


@pytest.fixture
def solves(monkeypatch):
    """The time scale of every path solve's model (clamp.planning.pipeline.solve as the planner
    calls it) and the number of velocity checks made (any caller)."""
    import clamp.factors.joint_limits as joint_limits
    import clamp.planning.planner as planner
    seen = {"scales": [], "velocity_checks": 0}
    solve, velocities = planner.solve, joint_limits.velocity_violations

    def counted_solve(model, *args, **kwargs):
        seen["scales"].append(float((model.prior.info or {}).get("time_scale", 1.0)))
        return solve(model, *args, **kwargs)

    def counted_velocities(*args, **kwargs):
        seen["velocity_checks"] += 1
        return velocities(*args, **kwargs)
    monkeypatch.setattr(planner, "solve", counted_solve)
    monkeypatch.setattr(joint_limits, "velocity_violations", counted_velocities)
    return seen


def _within_limits(robot, result) -> None:
    """Independent check: the plan's velocities and the finite differences of its positions
    over its time stamps within the robot's velocity limits (the checks' tolerance)."""
    vmax = np.asarray(robot.velocity_limits)
    assert np.all(np.abs(result.qdot) <= vmax + VELOCITY_TOLERANCE)
    assert np.all(_finite_difference_velocities(result.q, result.time) <= vmax + VELOCITY_TOLERANCE)
    assert np.all(robot.within_limits(result.q, tolerance=LIMIT_TOLERANCE))


def test_with_obstacles_the_scale_is_chosen_before_the_one_path_solve(jaco, fast, solves):
    """A skill shown 3x too fast, a box on its mean path: the free plan's peaks choose k > 1,
    and the path is solved once, at k (velocity limits never start a path search)."""
    _, prior, _ = fast
    result = plan(prior, jaco, _box_on_mean_path(prior), np.asarray(prior.mean)[0, :3],
                  covariance=False)
    assert result.time_scale > 2.0
    assert solves["scales"] == [pytest.approx(result.time_scale)]
    np.testing.assert_allclose(result.time, np.asarray(prior.time) * result.time_scale)
    assert result.success, result.reasons
    _within_limits(jaco, result)


def test_in_an_empty_scene_a_too_fast_skill_is_solved_slower_from_the_start(jaco, fast, solves):
    """The empty scene's plan is its free plan: the skill's speed chooses k > 1 before it is
    solved (once, or once more at its own peaks' need; never at the demonstrations' speed);
    the velocities are checked by the verdict alone."""
    _, prior, _ = fast
    result = plan(prior, jaco, None, np.asarray(prior.mean)[0, :3], covariance=False)
    assert 1 <= len(solves["scales"]) <= 2 and min(solves["scales"]) > 1.0
    assert solves["scales"][-1] == pytest.approx(result.time_scale) and result.time_scale > 2.0
    assert solves["velocity_checks"] == 1
    assert result.success, result.reasons
    _within_limits(jaco, result)


def test_requested_scales_are_honoured_and_limits_checked_by_the_verdict(jaco, fast, solves):
    """A fixed scale is planned once at it; at the demonstrations' speed the verdict says which
    joint is too fast (no solve repairs it), at 4x it holds the limits."""
    _, prior, _ = fast
    start = np.asarray(prior.mean)[0, :3]
    at_one = plan(prior, jaco, None, start, time_scale=1.0, covariance=False)
    assert solves["scales"] == [1.0] and at_one.time_scale == 1.0
    assert not at_one.success and any("time_scale fixed by the caller" in r
                                      for r in at_one.reasons), at_one.reasons
    slower = plan(prior, jaco, None, start, config=PlannerConfig(time_scale=4.0),
                  covariance=False)
    assert solves["scales"][1:] == [pytest.approx(4.0)] and slower.time_scale == 4.0
    assert slower.success, slower.reasons
    _within_limits(jaco, slower)
    duration = float(prior.time[-1] - prior.time[0])
    bounded = plan(prior, jaco, None, start, max_duration=5.0 * duration, covariance=False)
    assert 2.0 < bounded.time_scale <= 5.0
    assert bounded.time[-1] - bounded.time[0] <= 5.0 * duration * (1 + 1e-12)
