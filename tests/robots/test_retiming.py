"""Retiming (robots.retiming): limits at every sample, the geometric path kept, uniform scaling."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bad_input import raises_naming
from robots import load_robot
from robots.retiming import (DEFAULT_ACCELERATION_LIMIT, RetimingError, check_limits, retime, scale_time,
                             toppra_available, uniform_scaling)
from robots.trajectory import JointTrajectory, finite_difference

TOL = 1e-6
# within the position limits of each arm; far enough apart that DURATION violates both limits
PATHS = {
    "jaco": ([0.0, 3.5, 1.8, 0.0, 2.5, 0.0], [1.5, 2.5, 2.5, 1.0, 2.0, 1.0]),
    "sawyer": ([0.0, -0.5, 0.0, 1.0, 0.0, 0.5, 0.0], [1.2, 0.3, -0.8, 1.8, 0.7, -0.5, 1.5]),
}
needs_toppra = pytest.mark.skipif(not toppra_available(), reason="toppra is not installed (pip install toppra)")


@pytest.fixture(scope="module")
def arms():
    return {name: load_robot(name) for name in PATHS}


DURATION = {"jaco": 2.0, "sawyer": 1.0}  # s


def synthetic(robot, kind: str) -> JointTrajectory:
    """A smooth joint path within the position limits: "cosine" rest-to-rest q0 -> q1, or
    "wavy": q0 -> q1 with a sinusoidal detour (non-zero velocity in the middle, uneven steps)."""
    q0, q1 = (np.asarray(v, float) for v in PATHS[robot.name])
    duration = DURATION[robot.name]
    T = 60 if kind == "cosine" else 90
    u = np.linspace(0.0, 1.0, T)
    if kind == "wavy":
        u = u + 0.02 * np.sin(6 * np.pi * u)  # uneven time steps
    t = duration * u
    s = 0.5 - 0.5 * np.cos(np.pi * u)
    ds = 0.5 * np.pi * np.sin(np.pi * u) / duration
    q = q0 + s[:, None] * (q1 - q0)
    qdot = ds[:, None] * (q1 - q0)
    if kind == "wavy":
        phase = np.linspace(0.0, 1.0, robot.n)
        bump = 0.25 * np.sin(np.pi * u)[:, None] * np.sin(3 * np.pi * u[:, None] + phase)
        dbump = 0.25 / duration * (np.pi * np.cos(np.pi * u)[:, None] * np.sin(3 * np.pi * u[:, None] + phase)
                                   + 3 * np.pi * np.sin(np.pi * u)[:, None] * np.cos(3 * np.pi * u[:, None] + phase))
        q, qdot = q + bump, qdot + dbump
    assert robot.within_limits(q).all()
    return JointTrajectory.from_plan(robot, t, q, qdot, verdict={"success": True, "reasons": []})


def assert_within_limits(traj: JointTrajectory, vlim, alim) -> None:
    """Every sample: |qdot| and |dq/dt| <= vlim (1 + 1e-6); the stored accelerations and the
    finite differences of qdot (as in the export) <= alim (1 + 1e-6)."""
    t = traj.time_from_start
    assert np.all(np.abs(traj.velocities) <= vlim * (1 + TOL))
    assert np.all(np.abs(np.diff(traj.positions, axis=0) / np.diff(t)[:, None]) <= vlim * (1 + TOL))
    assert np.all(np.abs(finite_difference(traj.velocities, t)) <= alim * (1 + TOL))
    assert np.all(np.abs(traj.accelerations) <= alim * (1 + TOL))


def ee_distance_to_path(robot, original: JointTrajectory, retimed: JointTrajectory, density: int = 40) -> float:
    """Max distance [m] from the retimed end-effector samples to the original end-effector path
    (original positions interpolated cubically with their velocities, `density` points per step)."""
    from scipy.interpolate import CubicHermiteSpline

    t = original.time_from_start
    dense_t = np.append((t[:-1, None] + np.diff(t)[:, None] * np.arange(density) / density).ravel(), t[-1])
    path = robot.fk(CubicHermiteSpline(t, original.positions, original.velocities)(dense_t))
    points = robot.fk(retimed.positions)
    a, b = path[:-1], path[1:]
    ab = b - a
    w = np.clip(np.einsum("psk,sk->ps", points[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-300),
                0.0, 1.0)
    nearest = a[None] + w[..., None] * ab[None]
    return float(np.linalg.norm(points[:, None, :] - nearest, axis=-1).min(axis=1).max())


# ----------------------------------------------------------------------------- limits
def test_synthetic_paths_violate_the_limits(arms):
    for robot in arms.values():
        for kind in ("cosine", "wavy"):
            check = check_limits(synthetic(robot, kind), robot.velocity_limits)
            assert not check.velocity_ok and not check.acceleration_ok
            assert check.violations()
            np.testing.assert_array_equal(check.acceleration_limits, DEFAULT_ACCELERATION_LIMIT)


def test_uniform_scaling_factor_is_the_smallest_that_fits(arms):
    robot = arms["jaco"]
    traj = synthetic(robot, "wavy")
    alim = np.linspace(0.8, 2.0, robot.n)
    check = check_limits(traj, robot.velocity_limits, alim)
    k = uniform_scaling(traj, robot.velocity_limits, alim)
    assert k == pytest.approx(max(check.velocity_ratio.max(), np.sqrt(check.acceleration_ratio.max())))
    assert k > 1.0
    scaled = scale_time(traj, k)
    assert_within_limits(scaled, robot.velocity_limits, alim)
    after = check_limits(scaled, robot.velocity_limits, alim)
    assert max(after.velocity_ratio.max(), after.acceleration_ratio.max()) == pytest.approx(1.0, abs=1e-9)
    assert not check_limits(scale_time(traj, 0.99 * k), robot.velocity_limits, alim).within_limits
    np.testing.assert_array_equal(scaled.positions, traj.positions)


# ----------------------------------------------------------------------------- retime
@pytest.mark.parametrize("name", ["jaco", "sawyer"])
@pytest.mark.parametrize("kind", ["cosine", "wavy"])
@pytest.mark.parametrize("method", ["uniform", pytest.param("toppra", marks=needs_toppra)])
def test_retime_respects_limits_and_keeps_the_path(arms, name, kind, method):
    robot = arms[name]
    traj = synthetic(robot, kind)
    alim = 1.5
    retimed, report = retime(traj, robot, acceleration_limits=alim, method=method)
    assert report.method == method
    assert report.violated_before and report.within_limits and report.within_position_limits
    assert_within_limits(retimed, robot.velocity_limits, alim)
    assert retimed.joint_names == traj.joint_names and retimed.time_from_start[0] == 0.0
    assert report.duration_before == traj.duration
    assert report.duration_after == pytest.approx(retimed.duration) and retimed.duration > traj.duration
    np.testing.assert_array_equal(retimed.positions[0], traj.positions[0])
    np.testing.assert_array_equal(retimed.positions[-1], traj.positions[-1])
    assert report.max_ee_deviation <= 1e-3 and report.max_joint_deviation <= 1e-2
    assert ee_distance_to_path(robot, traj, retimed) <= 1e-3  # independent of the report
    assert retimed.verdict["success"] is True and retimed.verdict["retiming"]["method"] == method
    if method == "toppra":
        assert_rest_to_rest(retimed)
        assert np.diff(retimed.time_from_start).max() <= 0.01 + 1e-12


def assert_rest_to_rest(traj: JointTrajectory) -> None:
    """Zero velocity and acceleration at both ends, and no jump next to them: the acceleration
    one sample in is at most a tenth of its peak (a ramp, not a step)."""
    np.testing.assert_allclose(traj.velocities[[0, -1]], 0.0, atol=1e-9)
    np.testing.assert_allclose(traj.accelerations[[0, -1]], 0.0, atol=1e-9)
    peak = np.abs(traj.accelerations).max()
    assert np.abs(traj.accelerations[[1, -2]]).max() <= 0.1 * peak


@needs_toppra
@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_toppra_is_not_slower_than_uniform_scaling(arms, name):
    robot = arms[name]
    traj = synthetic(robot, "wavy")
    fast, report = retime(traj, robot, method="toppra")
    slow, _ = retime(traj, robot, method="uniform")
    assert fast.duration <= slow.duration * 1.001
    assert report.scaling_factor < 1.01  # the final safety stretch is small


def test_uniform_option_and_allow_faster(arms):
    robot = arms["sawyer"]
    slow = scale_time(synthetic(robot, "cosine"), 5.0)  # now well within the limits
    assert check_limits(slow, robot.velocity_limits).within_limits
    same, report = retime(slow, robot, method="uniform", allow_faster=False)
    assert not report.violated_before and report.scaling_factor == 1.0
    assert same.duration == slow.duration
    faster, report = retime(slow, robot, method="uniform")
    assert faster.duration < slow.duration and report.scaling_factor < 1.0
    assert_within_limits(faster, robot.velocity_limits, DEFAULT_ACCELERATION_LIMIT)
    assert report.max_ee_deviation < 1e-9  # same samples, new times


@needs_toppra
def test_toppra_allow_faster_false_keeps_the_duration(arms):
    robot = arms["jaco"]
    slow = scale_time(synthetic(robot, "cosine"), 6.0)
    retimed, report = retime(slow, robot, method="toppra", allow_faster=False)
    assert retimed.duration == pytest.approx(slow.duration)
    assert_within_limits(retimed, robot.velocity_limits, DEFAULT_ACCELERATION_LIMIT)


def test_auto_method(arms):
    robot = arms["jaco"]
    _, report = retime(synthetic(robot, "cosine"), robot)
    assert report.method == ("toppra" if toppra_available() else "uniform")


def test_retimed_trajectory_exports(tmp_path, arms):
    robot = arms["jaco"]
    retimed, _ = retime(synthetic(robot, "cosine"), robot, method="uniform")
    loaded = JointTrajectory.load(retimed.to_json(tmp_path / "plan.json"))
    np.testing.assert_array_equal(loaded.positions, retimed.positions)
    assert loaded.verdict == json.loads(json.dumps(retimed.verdict))
    assert loaded.verdict["retiming"]["within_limits"] is True


def test_bad_arguments(arms):
    robot = arms["jaco"]
    traj = synthetic(robot, "cosine")
    with raises_naming(RetimingError, "method"):
        retime(traj, robot, method="fast")
    with raises_naming(RetimingError, "acceleration_limits"):
        retime(traj, robot, acceleration_limits=[1.0, 2.0])
    with raises_naming(RetimingError, "acceleration_limits"):
        retime(traj, robot, acceleration_limits=-1.0)
    with raises_naming(RetimingError, "traj", "joint_names"):
        retime(synthetic(arms["sawyer"], "cosine"), robot)
    with raises_naming(RetimingError, "sample_period"):
        retime(traj, robot, sample_period=0.0)
    with raises_naming(RetimingError, "ramp_time"):
        retime(traj, robot, ramp_time=-0.1)
    with raises_naming(RetimingError, "factor"):
        scale_time(traj, 0.0)
    with raises_naming(RetimingError, "traj") as info:
        retime("not a trajectory", robot)
    assert isinstance(info.value, ValueError)  # every robots error is a ValueError


def test_motionless_trajectory_is_left_alone(arms):
    robot = arms["jaco"]
    q = np.tile(PATHS["jaco"][0], (5, 1))
    traj = JointTrajectory.from_plan(robot, np.linspace(0, 1, 5), q, np.zeros_like(q))
    retimed, report = retime(traj, robot, method="uniform")
    assert retimed.duration == traj.duration and report.within_limits


def _urdf_velocity_limits(robot) -> np.ndarray:
    """The <limit velocity=...> of each of the robot's joints, read from its URDF file here."""
    import xml.etree.ElementTree as ET
    joints = {j.get("name"): j for j in ET.parse(robot.urdf_path).getroot().iter("joint")}
    return np.array([float(joints[name].find("limit").get("velocity")) for name in robot.joint_names])


@needs_toppra
def test_toppra_retimes_the_sawyer_box_closing_plan(arms):
    """The Sawyer's box_closing plan creeps out of its start (the demonstrations' timing); TOPP-RA
    used to call it "not controllable" and retime fell back to uniform scaling. Now TOPP-RA
    itself retimes it: every sample within the URDF's velocity limits and 1.5 rad/s^2 (measured
    here), the end effector within 1 mm of the planned path, faster than uniform scaling."""
    from clamp import learn_prior, plan
    from scenes import Scene, builtin_scene, make_demonstrations
    robot, offset = arms["sawyer"], np.array([0.3, 0.0, 0.2])
    prior = learn_prior(make_demonstrations("box_closing", seed=0).translated(offset))
    scene = Scene([box.translated(offset) for box in builtin_scene("box_closing").obstacles])
    result = plan(prior, robot, scene, start=prior.mean[0, :3])
    assert result.success
    planned = result.to_joint_trajectory(robot, retime=False)
    speed = np.abs(planned.velocities).max(axis=1)
    assert speed[0] < 1e-5 and speed[:10].max() < 1e-3 < speed.max()   # the slow start
    retimed, report = retime(planned, robot, acceleration_limits=1.5, method="toppra")
    assert report.method == "toppra"
    assert_within_limits(retimed, _urdf_velocity_limits(robot), 1.5)
    assert_rest_to_rest(retimed)
    assert ee_distance_to_path(robot, planned, retimed) <= 1e-3
    assert robot.within_limits(retimed.positions).all()
    uniform, _ = retime(planned, robot, acceleration_limits=1.5, method="uniform")
    assert retimed.duration < uniform.duration


@needs_toppra
def test_toppra_through_a_pause(arms):
    """A plan that stops half-way (repeated samples) is retimed through the pause by TOPP-RA."""
    robot = arms["sawyer"]
    traj = synthetic(robot, "cosine")
    half = traj.num_points // 2
    t = np.concatenate([traj.time_from_start[:half], traj.time_from_start[half - 1] + 0.05 * np.arange(1, 6),
                        traj.time_from_start[half:] + 0.25])
    q = np.concatenate([traj.positions[:half], np.repeat(traj.positions[half - 1:half], 5, axis=0),
                        traj.positions[half:]])
    qdot = np.concatenate([traj.velocities[:half], np.zeros((5, robot.n)), traj.velocities[half:]])
    qdot[half - 1] = 0.0
    paused = JointTrajectory.from_plan(robot, t, q, qdot)
    retimed, report = retime(paused, robot, acceleration_limits=1.5, method="toppra")
    assert_within_limits(retimed, robot.velocity_limits, 1.5)
    assert_rest_to_rest(retimed)
    assert ee_distance_to_path(robot, paused, retimed) <= 1e-3 and report.max_ee_deviation <= 1e-3
    np.testing.assert_array_equal(retimed.positions[-1], paused.positions[-1])


@needs_toppra
def test_ramps_start_and_stop_a_moving_plan_without_a_jump(arms):
    """A plan that starts and ends moving (0.3 of the velocity limit): the retimed trajectory
    starts and ends at rest, its acceleration ramps up over ramp_time (linearly: half-way
    through the ramp it is half of the ramp's end value) and stays within the limits."""
    robot = arms["jaco"]
    q0, q1 = (np.asarray(v, float) for v in PATHS["jaco"])
    t = np.linspace(0.0, 4.0, 50)
    velocity = (q1 - q0) / 4.0
    moving = JointTrajectory.from_plan(robot, t, q0 + t[:, None] * velocity, np.tile(velocity, (50, 1)))
    assert np.abs(moving.velocities[[0, -1]]).min() > 0.0
    retimed, report = retime(moving, robot, acceleration_limits=1.5, method="toppra", ramp_time=0.2,
                             sample_period=0.01)
    assert report.within_limits
    assert_within_limits(retimed, robot.velocity_limits, 1.5)
    assert_rest_to_rest(retimed)
    acceleration = np.linalg.norm(retimed.accelerations, axis=1)
    assert acceleration[10] == pytest.approx(acceleration[20] / 2.0, rel=0.05)  # 0.1 s, 0.2 s
