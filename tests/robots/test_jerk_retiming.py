"""Jerk-limited retiming (robots.retime(method="ruckig", jerk_limits=...), issue 29): CLAMP plans
of a synthetic skill on both arms, checked here independently of the retimer's own report:
finite differences of the written samples within every limit, at rest at both ends, the end
effector on the planned path; the limits recorded in the file; ``clamp plan --jerk-limit``."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bad_input import raises_naming
from robots import RetimingError, check_limits, load_trajectory, retime
from robots import retiming as retiming_module
from robots.trajectory import JointTrajectory
from test_retiming import ee_distance_to_path

ACCELERATION = 1.0    # rad/s^2, the CLI's default
JERK = 5.0            # rad/s^3


@pytest.fixture(scope="module")
def plans(jaco, sawyer, prior):
    """{name: (robot, planned (not retimed) trajectory, PlanResult)}: on the Jaco the `clamp demo` plans of box_closing
    (free, and around a box under its path), on the Sawyer box_closing moved into its reach,
    around the skill's box."""
    from clamp import learn_prior, plan
    from clamp.cli.commands import DEMO_START_OFFSET, obstacle_below_path
    from scenes import Scene, builtin_scene, make_demonstrations
    start = prior.mean[0, :3] + DEMO_START_OFFSET
    free = plan(prior, jaco, None, start)
    around = plan(prior, jaco, Scene([obstacle_below_path(free)]), start)
    offset = np.array([0.3, 0.0, 0.2])
    moved = learn_prior(make_demonstrations("box_closing", seed=0).translated(offset))
    scene = Scene([box.translated(offset) for box in builtin_scene("box_closing").obstacles])
    sawyer_plan = plan(moved, sawyer, scene, start=moved.mean[0, :3])
    out = {}
    for name, robot, result in (("jaco-free", jaco, free), ("jaco-obstacle", jaco, around),
                                ("sawyer-box", sawyer, sawyer_plan)):
        assert result.success, name
        out[name] = (robot, result.to_joint_trajectory(robot, retime=False), result)
    return out


def max_jerk(traj: JointTrajectory) -> np.ndarray:
    """Largest |difference quotient of the written accelerations| per joint [rad/s^3]."""
    quotients = np.diff(traj.accelerations, axis=0) / np.diff(traj.time_from_start)[:, None]
    return np.abs(quotients).max(axis=0)


def assert_executable(robot, planned: JointTrajectory, retimed: JointTrajectory, vlim, alim, jlim) -> None:
    """Every limit on the written samples (jerk within 1 %, the rest within 1e-6), at rest at
    both ends at the plan's end points, the end effector within 1 mm of the planned path."""
    t = retimed.time_from_start
    slack = 1.0 + 1e-6
    assert np.all(max_jerk(retimed) <= np.broadcast_to(jlim, (robot.n,)) * 1.01)
    assert np.all(np.abs(retimed.velocities) <= vlim * slack)
    assert np.all(np.abs(np.diff(retimed.positions, axis=0) / np.diff(t)[:, None]) <= vlim * slack)
    assert np.all(np.abs(retimed.accelerations) <= alim * slack)
    assert np.all(np.abs(np.diff(retimed.velocities, axis=0) / np.diff(t)[:, None]) <= alim * slack)
    for end in (0, -1):
        np.testing.assert_allclose(retimed.velocities[end], 0.0, atol=1e-12)
        np.testing.assert_allclose(retimed.accelerations[end], 0.0, atol=1e-12)
        np.testing.assert_allclose(retimed.positions[end], planned.positions[end], atol=1e-12)
    assert ee_distance_to_path(robot, planned, retimed) <= 1e-3
    assert robot.within_limits(retimed.positions).all()


@pytest.mark.parametrize("name", ["jaco-free", "jaco-obstacle", "sawyer-box"])
def test_jerk_limited_plan_is_executable(plans, name):
    robot, planned, _ = plans[name]
    retimed, report = retime(planned, robot, ACCELERATION, method="ruckig", jerk_limits=JERK)
    assert_executable(robot, planned, retimed, robot.velocity_limits, ACCELERATION, JERK)
    assert np.diff(retimed.time_from_start).max() <= 0.01 + 1e-12
    assert report.method == "ruckig" and report.within_limits and report.max_ee_deviation <= 1e-3
    assert report.after.jerk_ok and report.after.peak_jerk.max() <= JERK * (1 + 1e-6)
    record = retimed.verdict["retiming"]
    assert record["method"] == "ruckig" and record["jerk_limits"] == [JERK] * robot.n
    # the plans need it: TOPP-RA's trajectory of the same plan jumps between acceleration bounds
    fast, _ = retime(planned, robot, ACCELERATION, method="toppra")
    assert max_jerk(fast).max() > 10 * JERK


def test_per_joint_jerk_limits(plans):
    robot, planned, _ = plans["sawyer-box"]
    jlim = np.linspace(2.0, 12.0, robot.n)
    alim = np.linspace(0.8, 1.6, robot.n)
    retimed, report = retime(planned, robot, alim, method="ruckig", jerk_limits=jlim)
    assert_executable(robot, planned, retimed, robot.velocity_limits, alim, jlim)
    assert report.within_limits


def test_allow_faster_false_keeps_the_duration(plans):
    robot, planned, _ = plans["jaco-free"]
    slow = planned.replace(time_from_start=planned.time_from_start * 0.5,
                           velocities=planned.velocities * 2.0)       # ~20 s, still slower than needed
    retimed, report = retime(slow, robot, ACCELERATION, method="ruckig", jerk_limits=JERK, allow_faster=False)
    assert retimed.duration == pytest.approx(slow.duration)
    assert report.scaling_factor > 1.0
    assert_executable(robot, slow, retimed, robot.velocity_limits, ACCELERATION, JERK)


def test_a_violating_timing_is_redone_or_refused(plans, monkeypatch, caplog):
    """Bounds that promise too much: the sampled check fails, the timing is redone (bounds
    that lie only the first time), or RetimingError (bounds that always lie): never a
    violating result."""
    robot, planned, _ = plans["jaco-obstacle"]
    honest = retiming_module._path_bounds
    first_attempt = len(retiming_module._RUCKIG_SETTINGS)
    calls = []

    def lying(times):
        def bounds(*args):
            calls.append(None)
            return tuple((3.0 if len(calls) <= times else 1.0) * bound for bound in honest(*args))
        return bounds

    monkeypatch.setattr(retiming_module, "_path_bounds", lying(first_attempt))
    with caplog.at_level("INFO", logger="robots.retiming"):
        retimed, report = retime(planned, robot, ACCELERATION, method="ruckig", jerk_limits=JERK)
    assert "attempt 1 violates" in caplog.text and len(calls) > first_attempt
    assert report.within_limits
    assert_executable(robot, planned, retimed, robot.velocity_limits, ACCELERATION, JERK)
    monkeypatch.setattr(retiming_module, "_path_bounds", lying(10**9))
    with raises_naming(RetimingError, "traj"):
        retime(planned, robot, ACCELERATION, method="ruckig", jerk_limits=JERK)


def test_check_limits_measures_jerk(plans):
    robot, planned, _ = plans["jaco-free"]
    fast, _ = retime(planned, robot, ACCELERATION, method="toppra")
    unlimited = check_limits(fast, robot.velocity_limits, ACCELERATION)
    assert unlimited.within_limits and unlimited.to_dict()["max_jerk_ratio"] is None
    np.testing.assert_allclose(unlimited.peak_jerk, max_jerk(fast))
    limited = check_limits(fast, robot.velocity_limits, ACCELERATION, jerk_limits=JERK)
    assert not limited.within_limits and not limited.jerk_ok
    assert any("jerk" in violation for violation in limited.violations())


def test_the_file_records_the_limits(plans, tmp_path):
    robot, planned, _ = plans["sawyer-box"]
    retimed, _ = retime(planned, robot, ACCELERATION, method="ruckig", jerk_limits=JERK)
    limits = load_trajectory(retimed.to_json(tmp_path / "jerk.json")).retiming_limits()
    assert limits.method == "ruckig"
    np.testing.assert_array_equal(limits.jerk, np.full(robot.n, JERK))
    np.testing.assert_array_equal(limits.acceleration, np.full(robot.n, ACCELERATION))
    np.testing.assert_array_equal(limits.velocity, robot.velocity_limits)
    jsonschema = pytest.importorskip("jsonschema")
    from robots.trajectory import load_schema
    data = json.loads((tmp_path / "jerk.json").read_text())
    jsonschema.Draft202012Validator(load_schema()).validate(data)
    # a file written before jerk limits were recorded: still valid, read without them
    del data["header"]["verdict"]["retiming"]["jerk_limits"]
    data["header"]["verdict"]["retiming"]["method"] = "toppra"
    jsonschema.Draft202012Validator(load_schema()).validate(data)
    (tmp_path / "old.json").write_text(json.dumps(data))
    old = load_trajectory(tmp_path / "old.json").retiming_limits()
    assert old.method == "toppra" and old.jerk is None
    assert planned.retiming_limits() is None


def test_motionless_trajectory_is_left_alone(jaco):
    q = np.tile(jaco.neutral_configuration(), (5, 1))
    still = JointTrajectory.from_plan(jaco, np.linspace(0, 1, 5), q, np.zeros_like(q))
    retimed, report = retime(still, jaco, method="ruckig", jerk_limits=JERK)
    assert retimed.duration == still.duration and report.within_limits


@pytest.mark.parametrize("options", [
    {"method": "ruckig", "jerk_limits": -1.0},
    {"method": "ruckig", "jerk_limits": [1.0, 2.0]},
    {"method": "ruckig", "jerk_limits": float("nan")},
    {"method": "ruckig", "jerk_limits": "fast"},
    {"method": "ruckig"},                              # ruckig needs jerk limits
    {"method": "toppra", "jerk_limits": 5.0},          # only ruckig limits the jerk
    {"method": "uniform", "jerk_limits": 5.0},
])
def test_bad_jerk_limits(plans, options):
    robot, planned, _ = plans["jaco-free"]
    with raises_naming(RetimingError, "jerk_limits"):
        retime(planned, robot, **options)


def test_auto_with_jerk_limits_is_ruckig(plans):
    robot, planned, _ = plans["jaco-free"]
    _, report = retime(planned, robot, method="auto", jerk_limits=JERK)
    assert report.method == "ruckig"


def test_plan_result_to_joint_trajectory_with_jerk_limits(plans):
    robot, planned, result = plans["jaco-obstacle"]
    retimed = result.to_joint_trajectory(robot, jerk_limits=JERK)
    assert retimed.verdict["retiming"]["method"] == "ruckig"
    assert_executable(robot, planned, retimed, robot.velocity_limits, ACCELERATION, JERK)
    with raises_naming(RetimingError, "jerk_limits"):
        result.to_joint_trajectory(robot, retime=False, jerk_limits=JERK)


# ----------------------------------------------------------------------------- command line
def test_cli_plan_with_jerk_limit(tmp_path, capsys):
    from clamp.cli.commands import main
    from scenes import make_demonstrations
    demos = make_demonstrations("box_closing", num_points=60, seed=1)
    demos.save_npz(tmp_path / "demos.npz")
    start = demos.positions[:, 0].mean(axis=0)
    out = tmp_path / "out"
    code = main(["plan", "--demos", str(tmp_path / "demos.npz"), "--robot", "jaco",
                 "--start", *map(str, start), "--jerk-limit", "5", "--out", str(out), "-q"])
    assert code == 0
    data = json.loads((out / "trajectory_result.json").read_text())
    t = np.array([point["time_from_start"] for point in data["points"]])
    accelerations = np.array([point["accelerations"] for point in data["points"]])
    assert np.abs(np.diff(accelerations, axis=0) / np.diff(t)[:, None]).max() <= 5.0 * 1.01
    velocities = np.array([point["velocities"] for point in data["points"]])
    np.testing.assert_allclose(velocities[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(accelerations[[0, -1]], 0.0, atol=1e-12)
    assert data["header"]["verdict"]["retiming"]["jerk_limits"] == [5.0] * 6
    record = json.loads((out / "plan.json").read_text())["trajectory"]
    assert record["jerk_limits"] == [5.0] * 6 and record["files"]


@pytest.mark.parametrize("extra", [["--jerk-limit", "-5"], ["--jerk-limit", "5", "--no-retime"],
                                   ["--jerk-limit", "1", "2"]])
def test_cli_bad_jerk_limit(tmp_path, capsys, extra):
    from clamp.cli.commands import main
    argv = ["plan", "--demos", str(tmp_path / "demos.npz"), "--robot", "jaco", "--start", "0.3", "0", "0.2"]
    from scenes import make_demonstrations
    make_demonstrations("box_closing", num_points=20, seed=1).save_npz(tmp_path / "demos.npz")
    assert main(argv + extra + ["--out", str(tmp_path / "out")]) == 2
    assert "--jerk-limit" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
