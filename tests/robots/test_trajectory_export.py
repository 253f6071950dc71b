"""Executable plan export (robots.trajectory): exact JSON / CSV round trips, schema, safe writes."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from bad_input import raises_naming
from robots import RobotError
from robots.errors import RobotTypeError
from robots.trajectory import (SCHEMA_PATH, JointTrajectory, TrajectoryError, TrajectoryExistsError,
                               TrajectoryFileError, finite_difference, load_schema, load_trajectory)


def cosine_plan(q0, q1, duration=2.0, T=40):
    """Smooth rest-to-rest joint path q0 -> q1: time (T,), q, qdot (T, n)."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    t = np.linspace(0.0, duration, T)
    s = 0.5 - 0.5 * np.cos(np.pi * t / duration)
    sd = 0.5 * np.pi / duration * np.sin(np.pi * t / duration)
    return t, q0 + s[:, None] * (q1 - q0), sd[:, None] * (q1 - q0)


JACO_A = [0.0, 3.5, 1.8, 0.0, 2.5, 0.0]
JACO_B = [1.5, 2.5, 2.5, 1.0, 2.0, 1.0]


@pytest.fixture
def trajectory(jaco):
    t, q, qdot = cosine_plan(JACO_A, JACO_B)
    return JointTrajectory.from_plan(jaco, t, q, qdot, verdict={"success": True, "reasons": [],
                                                                 "min_clearance": np.float64(0.031)})


@pytest.fixture
def awkward():
    """Values whose decimal forms are long or special: repr precision must keep them exact."""
    rng = np.random.default_rng(3)
    T, n = 7, 3
    positions = rng.normal(size=(T, n)) * np.array([1.0, 1e-9, 1e12])
    positions[0] = [1.0 / 3.0, -0.0, 5e-324]
    positions[1] = [0.1 + 0.2, np.nextafter(1.0, 2.0), -1.7976931348623157e308]
    velocities = rng.normal(size=(T, n))
    time = np.cumsum(rng.uniform(0.01, 0.3, T)) - 0.001
    return JointTrajectory(joint_names=("a", "b", "c"), time_from_start=time, positions=positions,
                           velocities=velocities, accelerations=finite_difference(velocities, time),
                           robot="test", urdf=None, verdict={"success": False, "reasons": ["x", "y"],
                                                             "nested": {"k": [1, 2.5, None]}})


def assert_same(a: JointTrajectory, b: JointTrajectory) -> None:
    assert a.joint_names == b.joint_names
    for name in ("time_from_start", "positions", "velocities", "accelerations"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype == np.float64
        assert x.shape == y.shape
        assert x.tobytes() == y.tobytes(), name  # bit for bit, -0.0 included
    assert (a.robot, a.urdf, a.units, a.verdict) == (b.robot, b.urdf, b.units, b.verdict)


# ----------------------------------------------------------------------------- from_plan
def test_from_plan_fields(jaco, trajectory):
    t, q, qdot = cosine_plan(JACO_A, JACO_B)
    assert trajectory.joint_names == jaco.joint_names
    assert trajectory.robot == "jaco" and trajectory.urdf == str(jaco.urdf_path)
    assert trajectory.units == {"time_from_start": "s", "positions": "rad", "velocities": "rad/s",
                                "accelerations": "rad/s^2"}
    np.testing.assert_array_equal(trajectory.positions, q)
    np.testing.assert_array_equal(trajectory.velocities, qdot)
    np.testing.assert_array_equal(trajectory.accelerations, np.gradient(qdot, t, axis=0, edge_order=1))
    assert trajectory.verdict == {"success": True, "reasons": [], "min_clearance": 0.031}
    assert trajectory.duration == pytest.approx(2.0) and trajectory.num_points == 40 and trajectory.n == 6
    with pytest.raises(ValueError):
        trajectory.positions[0, 0] = 1.0  # read-only


def test_from_plan_shifts_time_to_zero(jaco):
    t, q, qdot = cosine_plan(JACO_A, JACO_B)
    traj = JointTrajectory.from_plan(jaco, t + 5.0, q, qdot)
    assert traj.time_from_start[0] == 0.0
    np.testing.assert_allclose(traj.time_from_start, t, atol=1e-12)


def test_finite_difference_is_exact_for_constant_acceleration_on_uneven_steps():
    t = np.cumsum(np.random.default_rng(0).uniform(0.05, 0.5, 30))
    v = np.column_stack((3.0 * t - 1.0, -0.5 * t))  # constant accelerations 3 and -0.5
    a = finite_difference(v, t)
    np.testing.assert_allclose(a, np.tile([3.0, -0.5], (30, 1)), rtol=1e-9)


def test_finite_difference_is_bounded_by_the_difference_quotients():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.01, 0.2, 50))
    v = rng.normal(size=(50, 4))
    quotients = np.abs(np.diff(v, axis=0) / np.diff(t)[:, None]).max(axis=0)
    assert np.all(np.abs(finite_difference(v, t)).max(axis=0) <= quotients * (1 + 1e-12))


def test_interpolated_speed_is_the_peak_of_the_hermite_segments():
    """Against SciPy's cubic Hermite spline sampled densely (an independent interpolant): the
    peak speed of each segment, never below the ends' speeds or the finite differences."""
    from scipy.interpolate import CubicHermiteSpline
    from robots.trajectory import interpolated_speed
    rng = np.random.default_rng(11)
    time = np.cumsum(rng.uniform(0.05, 0.3, size=9))
    q = np.cumsum(rng.normal(scale=0.2, size=(9, 4)), axis=0)
    qdot = rng.normal(scale=1.0, size=(9, 4))
    peaks = interpolated_speed(q, qdot, time)
    spline = CubicHermiteSpline(time, q, qdot).derivative()
    for i in range(len(time) - 1):
        samples = np.abs(spline(np.linspace(time[i], time[i + 1], 2001)))
        np.testing.assert_allclose(peaks[i], samples.max(axis=0), rtol=1e-5)
    mean = np.abs(np.diff(q, axis=0)) / np.diff(time)[:, None]
    assert np.all(peaks >= mean - 1e-12) and np.all(peaks >= np.abs(qdot[1:]) - 1e-12)
    with pytest.raises(TrajectoryError, match="positions, velocities, time"):
        interpolated_speed(q, qdot[:-1], time)


def test_invalid_input_names_the_argument(jaco):
    t, q, qdot = cosine_plan(JACO_A, JACO_B)
    with raises_naming(TrajectoryError, "q"):
        JointTrajectory.from_plan(jaco, t, q[:, :5], qdot)
    with raises_naming(TrajectoryError, "time"):
        JointTrajectory.from_plan(jaco, t[::-1], q, qdot)
    with raises_naming(TrajectoryError, "qdot"):
        JointTrajectory.from_plan(jaco, t, q, np.where(qdot > 0.1, np.nan, qdot))
    with raises_naming(TrajectoryError, "verdict['bad']"):
        JointTrajectory.from_plan(jaco, t, q, qdot, verdict={"bad": object()})
    with raises_naming(TrajectoryError, "joint_names"):
        JointTrajectory(("a", "a"), t, q[:, :2], q[:, :2], q[:, :2])


# ----------------------------------------------------------------------------- files
@pytest.mark.parametrize("fmt", ["json", "csv"])
def test_round_trip_is_exact(tmp_path, trajectory, awkward, fmt):
    for i, traj in enumerate((trajectory, awkward)):
        path = tmp_path / f"plan{i}.{fmt}"
        getattr(traj, f"to_{fmt}")(path)
        assert_same(traj, JointTrajectory.load(path))
        assert_same(traj, load_trajectory(path))


def test_load_detects_the_format_from_the_content(tmp_path, trajectory):
    trajectory.to_csv(tmp_path / "a.txt")
    trajectory.to_json(tmp_path / "b.txt")
    assert_same(JointTrajectory.load(tmp_path / "a.txt"), JointTrajectory.load(tmp_path / "b.txt"))


def test_json_layout_is_ros_like(tmp_path, trajectory):
    data = json.loads(trajectory.to_json(tmp_path / "plan.json").read_text())
    assert data["joint_names"] == list(trajectory.joint_names)
    assert set(data["points"][0]) == {"positions", "velocities", "accelerations", "time_from_start"}
    assert data["header"]["verdict"]["success"] is True
    first_line = (trajectory.to_csv(tmp_path / "plan.csv").read_text().splitlines())
    assert first_line[0].startswith("# skillplan.joint_trajectory {")
    assert first_line[1].split(",")[:2] == ["time_from_start", f"position:{trajectory.joint_names[0]}"]


def test_json_validates_against_the_shipped_schema(tmp_path, trajectory, awkward):
    jsonschema = pytest.importorskip("jsonschema", reason="schema validation needs jsonschema (test extra)")
    assert SCHEMA_PATH.is_file()
    schema = load_schema()
    validator = jsonschema.Draft202012Validator
    validator.check_schema(schema)
    for i, traj in enumerate((trajectory, awkward)):
        validator(schema).validate(json.loads(traj.to_json(tmp_path / f"p{i}.json").read_text()))
    broken = json.loads((tmp_path / "p0.json").read_text())
    del broken["points"][3]["velocities"]
    assert not validator(schema).is_valid(broken)
    broken = json.loads((tmp_path / "p0.json").read_text())
    broken["points"][0]["time_from_start"] = -1.0
    assert not validator(schema).is_valid(broken)


def test_refuses_to_overwrite(tmp_path, trajectory, awkward):
    for fmt in ("json", "csv"):
        path = tmp_path / f"plan.{fmt}"
        getattr(trajectory, f"to_{fmt}")(path)
        before = path.read_bytes()
        with raises_naming(TrajectoryExistsError, path.name) as info:
            getattr(awkward, f"to_{fmt}")(path)
        assert isinstance(info.value, FileExistsError) and isinstance(info.value, RobotError)
        assert path.read_bytes() == before
        getattr(awkward, f"to_{fmt}")(path, overwrite=True)
        assert_same(awkward, JointTrajectory.load(path))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv", "plan.json"]


def test_failed_write_leaves_no_temporary_file(tmp_path, trajectory, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "link", broken)
    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError, match="disk full"):
        trajectory.to_json(tmp_path / "plan.json")
    with pytest.raises(OSError, match="disk full"):
        trajectory.to_csv(tmp_path / "plan.csv", overwrite=True)
    assert list(tmp_path.iterdir()) == []


def test_successful_writes_leave_only_the_targets(tmp_path, trajectory):
    trajectory.to_json(tmp_path / "plan.json")
    trajectory.to_json(tmp_path / "plan.json", overwrite=True)
    trajectory.to_csv(tmp_path / "plan.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv", "plan.json"]
    mode = (tmp_path / "plan.json").stat().st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    assert mode == 0o666 & ~umask  # like a file written with open()


def test_bad_files_raise_trajectory_file_error(tmp_path, trajectory):
    with raises_naming(TrajectoryFileError, "missing.json"):
        JointTrajectory.load(tmp_path / "missing.json")
    (tmp_path / "junk.json").write_text("not json")
    with raises_naming(TrajectoryFileError, "junk.json"):
        JointTrajectory.load(tmp_path / "junk.json")
    data = trajectory.to_dict()
    data["points"][2]["positions"] = data["points"][2]["positions"][:3]
    (tmp_path / "ragged.json").write_text(json.dumps(data))
    with raises_naming(TrajectoryFileError, "ragged.json"):
        JointTrajectory.load(tmp_path / "ragged.json")
    data = trajectory.to_dict()
    data["version"] = 99
    (tmp_path / "future.json").write_text(json.dumps(data))
    with raises_naming(TrajectoryFileError, "future.json", "version"):
        JointTrajectory.load(tmp_path / "future.json")
    text = trajectory.to_csv(tmp_path / "plan.csv").read_text().splitlines()
    text[1] = text[1].replace("position:", "pos:", 1)
    (tmp_path / "renamed.csv").write_text("\n".join(text))
    with raises_naming(TrajectoryFileError, "renamed.csv"):
        JointTrajectory.load(tmp_path / "renamed.csv")


# ----------------------------------------------------------------------------- ROS 2 message shape
def test_ros2_message_validates_against_its_schema_and_round_trips(tmp_path, trajectory, awkward):
    """The ROS 2 file holds exactly the message's fields, validates against its schema (not the
    skillplan one), and loads back: joint names, positions, velocities, accelerations bit for
    bit, times to 1 ns; writing it again gives the same file."""
    jsonschema = pytest.importorskip("jsonschema", reason="schema validation needs jsonschema (test extra)")
    from robots.trajectory import ROS2_SCHEMA_PATH
    schema = load_schema(ros2=True)
    assert ROS2_SCHEMA_PATH.is_file()
    validator = jsonschema.Draft202012Validator
    validator.check_schema(schema)
    for i, traj in enumerate((trajectory, awkward)):
        path = traj.to_ros2_json(tmp_path / f"ros{i}.json", frame_id="base")
        data = json.loads(path.read_text())
        validator(schema).validate(data)
        assert not validator(load_schema()).is_valid(data)  # not the skillplan format
        assert data["header"] == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base"}
        assert set(data["points"][0]) == {"positions", "velocities", "accelerations", "effort", "time_from_start"}
        stamp = data["points"][-1]["time_from_start"]
        assert stamp["sec"] + stamp["nanosec"] * 1e-9 == pytest.approx(traj.duration, abs=1e-9)
        back = JointTrajectory.load(path)
        assert back.joint_names == traj.joint_names
        for name in ("positions", "velocities", "accelerations"):
            assert getattr(back, name).tobytes() == getattr(traj, name).tobytes(), name
        np.testing.assert_allclose(back.time_from_start, traj.time_from_start, rtol=0, atol=0.51e-9)
        again = back.to_ros2_json(tmp_path / f"again{i}.json", frame_id="base")
        assert again.read_text() == path.read_text()
    broken = json.loads((tmp_path / "ros0.json").read_text())
    broken["points"][1]["time_from_start"] = 0.5  # a float, as in the skillplan format
    assert not validator(schema).is_valid(broken)
    broken["points"][1]["time_from_start"] = {"sec": 0, "nanosec": 1_000_000_000}
    assert not validator(schema).is_valid(broken)


def test_ros2_duration_carries_nanoseconds_into_seconds():
    from robots.trajectory import ros2_duration
    assert ros2_duration(1.9999999999) == {"sec": 2, "nanosec": 0}
    assert ros2_duration(0.25) == {"sec": 0, "nanosec": 250_000_000}
    assert ros2_duration(3.000000001) == {"sec": 3, "nanosec": 1}


def test_bad_ros2_files_name_the_field(tmp_path, trajectory):
    data = trajectory.to_ros2_dict()
    data["points"][2]["time_from_start"] = {"sec": 1, "nanosec": -5}
    (tmp_path / "a.json").write_text(json.dumps(data))
    with raises_naming(TrajectoryFileError, "a.json", "points[2].time_from_start"):
        JointTrajectory.load(tmp_path / "a.json")
    data = trajectory.to_ros2_dict()
    data["points"][4]["velocities"] = []  # allowed by ROS, but not executable here
    (tmp_path / "b.json").write_text(json.dumps(data))
    with raises_naming(TrajectoryFileError, "b.json", "points[4].velocities"):
        JointTrajectory.load(tmp_path / "b.json")
    with raises_naming(RobotTypeError, "frame_id"):
        trajectory.to_ros2_dict(frame_id=3)
