"""Demonstrations carry the hand's rotation from every recording that has it (issue 37, items 1
and 5): each format written with orientation is read back with it (pose CSV, joint CSV,
JointState / PoseStamped / TF bags, per-demonstration .npz, .mat with quaternions or 4x4
poses); the loaded orientation mean is the one computed independently (scipy's chordal mean
of the written rotations, pinocchio's forward kinematics of the written joints); bad
quaternions are one-line errors naming the file and the sample (exit 2 on the command line);
sign flips are repaired, implausible turns warned about; position-only files stay position-only."""
from __future__ import annotations

import logging

import numpy as np
import pinocchio as pin
import pytest
import scipy.io
from scipy.spatial.transform import Rotation

from bad_input import raises_naming
from clamp.cli.commands import main
from scenes import DemonstrationFileError, Demonstrations, load_demonstrations, make_demonstrations, save_csv
from scenes.errors import InvalidDemonstrationsError
from tests.scenes.test_bags import TYPES, joint_bag, write_bag, _header
from tests.scenes.test_joint_demonstrations import write_joint_csv


# ------------------------------------------------------------------------------ helpers
def turning_demonstrations(num_demos: int = 4, num_points: int = 60, seed: int = 0) -> Demonstrations:
    """Synthetic box_closing positions with a hand that turns up to 70 deg about a tilted
    axis over the motion, differently in every demonstration (unit quaternions x, y, z, w)."""
    demos = make_demonstrations("box_closing", num_demos=num_demos, num_points=num_points, seed=seed)
    rng = np.random.default_rng(seed)
    phase = np.linspace(0.0, 1.0, num_points)[:, None]
    turns = []
    for _ in range(num_demos):
        start = Rotation.from_rotvec(rng.normal(0.0, 0.2, 3))
        axis = np.array([0.3, -0.5, 1.0]) + rng.normal(0.0, 0.1, 3)
        sweep = Rotation.from_rotvec(phase * np.radians(70.0 + rng.normal(0, 5)) * axis / np.linalg.norm(axis))
        turns.append((start * sweep).as_quat())
    return Demonstrations(demos.positions, demos.velocities, demos.time, None, "turning",
                          orientations=np.array(turns))


def chordal_mean_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle [deg] between scipy's chordal means of two sets of quaternions (..., 4)."""
    ma, mb = Rotation.from_quat(a.reshape(-1, 4)).mean(), Rotation.from_quat(b.reshape(-1, 4)).mean()
    return float(np.degrees((ma.inv() * mb).magnitude()))


def per_step_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Largest angle [deg] between two sets of rotations (..., 4), sample by sample."""
    ra, rb = Rotation.from_quat(a.reshape(-1, 4)), Rotation.from_quat(b.reshape(-1, 4))
    return float(np.degrees((ra.inv() * rb).magnitude()).max())


def pinocchio_quaternions(robot, q: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions of the end effector's rotation in the base frame, by pinocchio's own
    frame placements (independent of robots.kinematics)."""
    model = robot.model
    data = model.createData()
    ee = model.getFrameId(robot.end_effector, pin.FrameType.BODY)
    base = None if robot.base_frame is None else model.getFrameId(robot.base_frame, pin.FrameType.BODY)
    out = []
    for row in q.reshape(-1, q.shape[-1]):
        pin.framesForwardKinematics(model, data, robot.to_pinocchio(row))
        R = data.oMf[ee].rotation
        if base is not None:
            R = data.oMf[base].rotation.T @ R
        out.append(Rotation.from_matrix(R).as_quat())
    return np.array(out).reshape(q.shape[:-1] + (4,))


def pose_message(stamp_ns: int, position, quaternion) -> object:
    T = TYPES.types
    point = T["geometry_msgs/msg/Point"](x=float(position[0]), y=float(position[1]), z=float(position[2]))
    x, y, z, w = (float(v) for v in quaternion)
    return T["geometry_msgs/msg/PoseStamped"](
        header=_header(stamp_ns, "base_link"),
        pose=T["geometry_msgs/msg/Pose"](position=point,
                                         orientation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)))


def transform_message(stamp_ns: int, position, quaternion) -> object:
    T = TYPES.types
    translation = T["geometry_msgs/msg/Vector3"](x=float(position[0]), y=float(position[1]), z=float(position[2]))
    x, y, z, w = (float(v) for v in quaternion)
    transform = T["geometry_msgs/msg/TransformStamped"](
        header=_header(stamp_ns, "base_link"), child_frame_id="tool0",
        transform=T["geometry_msgs/msg/Transform"](translation=translation,
                                                   rotation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)))
    return T["tf2_msgs/msg/TFMessage"](transforms=[transform])


def pose_bags(tmp_path, demos: Demonstrations, kind: str, quaternions=None) -> list[str]:
    """One bag per demonstration of PoseStamped (kind "pose") or /tf (kind "tf") messages."""
    quaternions = demos.orientations if quaternions is None else quaternions
    bags = []
    for m in range(demos.M):
        stamps = [int(round((50.0 + t) * 1e9)) for t in demos.time]
        if kind == "pose":
            messages = [pose_message(s, p, o) for s, p, o in zip(stamps, demos.positions[m], quaternions[m])]
            topics = {"/hand": ("geometry_msgs/msg/PoseStamped", messages)}
        else:
            messages = [transform_message(s, p, o) for s, p, o in zip(stamps, demos.positions[m], quaternions[m])]
            topics = {"/tf": ("tf2_msgs/msg/TFMessage", messages)}
        bags.append(str(write_bag(tmp_path / f"{kind}{m}", topics)))
    return bags


def one_line(message: str) -> str:
    assert "\n" not in message, message
    return message


# ------------------------------------------------------------------------------ round trips
def test_pose_csv_round_trip(tmp_path):
    demos = turning_demonstrations()
    path = tmp_path / "poses.csv"
    save_csv(demos, path)
    assert path.read_text().splitlines()[0] == "demo,t,x,y,z,vx,vy,vz,qx,qy,qz,qw"
    loaded = load_demonstrations(path)
    np.testing.assert_array_equal(loaded.positions, demos.positions)
    assert per_step_angle(loaded.orientations, demos.orientations) < 1e-6
    assert chordal_mean_angle(loaded.orientations, demos.orientations) < 0.5


def test_pose_csv_without_velocities_and_uneven_recordings(tmp_path):
    """demo,t,x,y,z,qx,qy,qz,qw with recordings of different lengths: resampled by slerp on
    the positions' phases; each demonstration's mean rotation is the recording's."""
    demos = turning_demonstrations(num_demos=3, num_points=80)
    rows = []
    for m, keep in enumerate([80, 55, 70]):
        index = np.linspace(0, 79, keep).round().astype(int)
        for k in index:
            rows.append([m, demos.time[k] * (1 + 0.2 * m), *demos.positions[m, k], *demos.orientations[m, k]])
    path = tmp_path / "uneven.csv"
    np.savetxt(path, np.array(rows), delimiter=",", header="demo,t,x,y,z,qx,qy,qz,qw", comments="",
               fmt="%.17g")
    loaded = load_demonstrations(path)
    assert loaded.orientations.shape == (3, 80, 4)
    for m, keep in enumerate([80, 55, 70]):
        written = demos.orientations[m, np.linspace(0, 79, keep).round().astype(int)]
        np.testing.assert_allclose(loaded.orientations[m, [0, -1]], written[[0, -1]], atol=1e-9)
        assert chordal_mean_angle(loaded.orientations[m], written) < 0.5


def test_joint_csv_carries_the_forward_kinematics_rotation(tmp_path, jaco):
    """Joint CSV on the Jaco: the hand's rotation is pinocchio's forward kinematics of the
    recorded joints, sample by sample and in the mean."""
    rng = np.random.default_rng(3)
    base = np.array([1.2, 2.6, 5.2, -1.1, -0.1, -1.8])
    time = np.linspace(0.0, 4.0, 50)
    q = np.stack([base + rng.normal(0, 0.05, 6) + np.outer(np.sin(time / 4.0 * np.pi / 2), rng.normal(0, 0.4, 6))
                  for _ in range(3)])
    path = write_joint_csv(tmp_path / "joints.csv", jaco, time, q, order=np.arange(6)[::-1])
    loaded = load_demonstrations(path, robot=jaco, smoothing="none")
    expected = pinocchio_quaternions(jaco, loaded.joint_positions)
    assert per_step_angle(loaded.orientations, expected) < 1e-6
    assert chordal_mean_angle(loaded.orientations, pinocchio_quaternions(jaco, q)) < 0.5


def test_joint_npz_carries_the_forward_kinematics_rotation(tmp_path, jaco):
    rng = np.random.default_rng(8)
    base = np.array([1.2, 2.6, 5.2, -1.1, -0.1, -1.8])
    time = np.linspace(0.0, 3.0, 30)
    q = np.stack([base + np.outer(time / 3.0, rng.normal(0, 0.4, 6)) for _ in range(2)])
    np.savez(tmp_path / "joints.npz", joint_positions=q, time=time, joint_names=np.array(jaco.joint_names))
    loaded = load_demonstrations(tmp_path / "joints.npz", robot=jaco, smoothing="none")
    assert per_step_angle(loaded.orientations, pinocchio_quaternions(jaco, loaded.joint_positions)) < 1e-6
    # resampled and DTW-aligned, the rotations stay those of the arm at the resampled joints
    # (slerp against the joints' spline: within the turn of one step)
    again = loaded.resample(45)
    assert per_step_angle(again.orientations, pinocchio_quaternions(jaco, again.joint_positions)) < 2.0


def test_joint_state_bag_carries_the_forward_kinematics_rotation(tmp_path, sawyer):
    """JointState bags (rosbags' writer) on the Sawyer: the rotation is pinocchio's FK."""
    rng = np.random.default_rng(5)
    time = np.linspace(0.0, 3.0, 40)
    home = sawyer.neutral_configuration()
    q = [home + rng.normal(0, 0.05, 7) + np.outer(time / 3.0, rng.normal(0, 0.5, 7)) for _ in range(3)]
    bags = [str(joint_bag(tmp_path / f"joints{m}", sawyer, time, q[m], seed=m)) for m in range(3)]
    loaded = load_demonstrations(bags, topic="/joint_states", robot=sawyer, smoothing="none")
    assert per_step_angle(loaded.orientations, pinocchio_quaternions(sawyer, loaded.joint_positions)) < 1e-6
    assert chordal_mean_angle(loaded.orientations, pinocchio_quaternions(sawyer, np.array(q))) < 0.5


@pytest.mark.parametrize("kind", ["pose", "tf"])
def test_pose_and_tf_bags_keep_the_quaternion(tmp_path, kind):
    demos = turning_demonstrations(num_demos=3, num_points=40)
    flipped = demos.orientations * np.where(np.arange(40) % 3 == 0, -1.0, 1.0)[None, :, None]
    topic, frames = ("/hand", None) if kind == "pose" else ("/tf", ("base_link", "tool0"))
    loaded = load_demonstrations(pose_bags(tmp_path, demos, kind, flipped), topic=topic,
                                 frames=frames, smoothing="none")
    assert per_step_angle(loaded.orientations, demos.orientations) < 1e-5
    assert chordal_mean_angle(loaded.orientations, demos.orientations) < 0.5
    dots = np.einsum("mti,mti->mt", loaded.orientations[:, 1:], loaded.orientations[:, :-1])
    assert dots.min() > 0.9                      # the written sign flips made continuous


def test_a_pose_bag_split_at_rests_keeps_each_motions_rotations(tmp_path):
    """One PoseStamped bag: motion A, a 4 s rest, motion B; split='rest' cuts the rotations
    with the positions: each demonstration's rotations are its own motion's."""
    demos = turning_demonstrations(num_demos=2, num_points=120, seed=5)
    a, b = demos.positions
    b = b - b[0] + a[-1]
    qa, qb = demos.orientations
    qb = (Rotation.from_quat(qa[-1]) * Rotation.from_quat(qb[0]).inv() * Rotation.from_quat(qb)).as_quat()
    t = demos.time
    hold = np.arange(1, int(4.0 / demos.dt) + 1) * demos.dt
    time = np.concatenate([t, t[-1] + hold, t[-1] + hold[-1] + demos.dt + t[1:]])
    path = np.concatenate([a, np.repeat(a[-1:], len(hold), axis=0), b[1:]])
    turns = np.concatenate([qa, np.repeat(qa[-1:], len(hold), axis=0), qb[1:]])
    messages = [pose_message(int(round((100.0 + s) * 1e9)), p, o) for s, p, o in zip(time, path, turns)]
    bag = write_bag(tmp_path / "poses", {"/hand": ("geometry_msgs/msg/PoseStamped", messages)})
    loaded = load_demonstrations(bag, topic="/hand", split="rest")
    assert loaded.M == 2
    for m, written in enumerate([qa, qb]):
        # the piece's rotations are the motion's (its slow ends go with the rests)
        assert chordal_mean_angle(loaded.orientations[m], written) < 3.0
        nearest = [per_step_angle(q, written[np.argmin(np.linalg.norm(
            (a if m == 0 else b) - p, axis=1))]) for q, p in zip(loaded.orientations[m], loaded.positions[m])]
        assert max(nearest) < 1.0


def test_npz_recordings_with_quaternions_or_poses(tmp_path):
    demos = turning_demonstrations(num_demos=3, num_points=50)
    arrays, poses = {}, {}
    for m in range(3):
        keep = 50 - 7 * m
        arrays[f"demo{m}__pos"] = demos.positions[m, :keep]
        arrays[f"demo{m}__quat_xyzw"] = demos.orientations[m, :keep]
        arrays[f"demo{m}__t"] = demos.time[:keep]
        transforms = np.tile(np.eye(4), (keep, 1, 1))
        transforms[:, :3, :3] = Rotation.from_quat(demos.orientations[m, :keep]).as_matrix()
        transforms[:, :3, 3] = demos.positions[m, :keep]
        poses[f"demo{m}__pose"] = transforms
        poses[f"demo{m}__t"] = demos.time[:keep]
    np.savez(tmp_path / "quats.npz", **arrays)
    np.savez(tmp_path / "poses.npz", **poses)
    a, b = load_demonstrations(tmp_path / "quats.npz"), load_demonstrations(tmp_path / "poses.npz")
    assert per_step_angle(a.orientations, b.orientations) < 1e-6
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-12)
    for m in range(3):
        assert chordal_mean_angle(a.orientations[m], arrays[f"demo{m}__quat_xyzw"]) < 0.5


def test_mat_with_quaternions_or_poses(tmp_path):
    demos = turning_demonstrations(num_demos=3, num_points=40)
    with_quat = np.empty(3, dtype=[("pos", object), ("quat_xyzw", object), ("time", object)])
    with_pose = np.empty(3, dtype=[("pose", object), ("time", object)])
    for m in range(3):
        with_quat[m] = (demos.positions[m], demos.orientations[m], demos.time)
        transforms = np.tile(np.eye(4), (40, 1, 1))
        transforms[:, :3, :3] = Rotation.from_quat(demos.orientations[m]).as_matrix()
        transforms[:, :3, 3] = demos.positions[m]
        with_pose[m] = (np.moveaxis(transforms, 0, -1), demos.time)     # MATLAB's 4 x 4 x T
    scipy.io.savemat(tmp_path / "quat.mat", {"dataset": with_quat})
    scipy.io.savemat(tmp_path / "pose.mat", {"dataset": with_pose})
    for name in ("quat.mat", "pose.mat"):
        loaded = load_demonstrations(tmp_path / name)
        np.testing.assert_allclose(loaded.positions, demos.positions, atol=1e-12)
        assert per_step_angle(loaded.orientations, demos.orientations) < 1e-6


def test_wiping_rim_loads_with_orientation(shared_dataset):
    """The real wiping set: 6 demonstrations of 9-51 s, each demonstration's mean rotation the
    chordal mean of its raw samples (scipy), its first and last rotations kept."""
    path = shared_dataset("wiping_rim")
    demos = load_demonstrations(path)
    assert demos.M == 6 and demos.orientations.shape == (6, demos.T, 4)
    with np.load(path) as raw:
        durations = [float(raw[f"demo{m}__t"][-1]) for m in range(6)]
        assert min(durations) > 9.0 and max(durations) < 52.0
        for m in range(6):
            written = raw[f"demo{m}__quat_xyzw"]
            assert chordal_mean_angle(demos.orientations[m], written) < 0.5
            assert per_step_angle(demos.orientations[m, [0, -1]], written[[0, -1]]) < 1e-6


def test_position_only_files_stay_position_only(tmp_path):
    demos = make_demonstrations("box_closing", num_demos=3, num_points=30)
    save_csv(demos, tmp_path / "positions.csv")
    assert load_demonstrations(tmp_path / "positions.csv").orientations is None
    demos.save_npz(tmp_path / "positions.npz")
    assert load_demonstrations(tmp_path / "positions.npz").orientations is None


def test_from_trajectories_resamples_rotations_by_slerp_on_the_phases():
    """Two recordings of unequal length and duration: each rotation is slerped at the same
    phases as the positions (a constant-rate turn stays a constant-rate turn)."""
    axis = np.array([0.0, 0.0, 1.0])
    paths, turns, times = [], [], []
    for m, (count, duration) in enumerate([(30, 3.0), (45, 6.0)]):
        phase = np.linspace(0.0, 1.0, count)
        paths.append(np.column_stack([phase, 0 * phase, 0 * phase + m]))
        turns.append(Rotation.from_rotvec(np.outer(phase, axis) * np.radians(80.0)).as_quat())
        times.append(phase * duration)
    demos = Demonstrations.from_trajectories(paths, times, num_points=21, orientations=turns)
    angles = np.degrees(Rotation.from_quat(demos.orientations.reshape(-1, 4)).magnitude()).reshape(2, 21)
    np.testing.assert_allclose(angles, np.tile(np.linspace(0.0, 80.0, 21), (2, 1)), atol=1e-9)


# ------------------------------------------------------------------------------ repair and warnings
def test_an_implausible_turn_warns_naming_the_sample(tmp_path, caplog):
    demos = turning_demonstrations(num_demos=2, num_points=40)
    turns = demos.orientations.copy()
    turns[1, 25] = (Rotation.from_quat(turns[1, 25]) * Rotation.from_rotvec([0, 2.0, 0])).as_quat()
    path = tmp_path / "glitch.csv"
    save_csv(Demonstrations(demos.positions, demos.velocities, demos.time, orientations=turns), path)
    with caplog.at_level(logging.WARNING, logger="scenes.quaternions"):
        load_demonstrations(path)
    [record] = [r for r in caplog.records if r.name == "scenes.quaternions"]
    assert "orientations[1][25]" in record.getMessage() and "rad/s" in record.getMessage()
    caplog.clear()
    smooth = tmp_path / "smooth.csv"
    save_csv(demos, smooth)
    with caplog.at_level(logging.WARNING, logger="scenes.quaternions"):
        load_demonstrations(smooth)
    assert not caplog.records                  # the smooth recording: no warning


# ------------------------------------------------------------------------------ bad input
def test_bad_quaternion_in_a_pose_csv_names_the_file_and_line(tmp_path):
    demos = turning_demonstrations(num_demos=2, num_points=20)
    path = tmp_path / "bad.csv"
    save_csv(demos, path)
    lines = path.read_text().splitlines()
    cells = lines[7].split(",")
    cells[-4:] = ["0.5", "0", "0", "0.5"]
    lines[7] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with raises_naming(DemonstrationFileError, str(path), "line 8", "qx,qy,qz,qw") as info:
        load_demonstrations(path)
    one_line(str(info.value))


def test_bad_quaternion_in_npz_and_mat_names_the_file_and_sample(tmp_path):
    demos = turning_demonstrations(num_demos=2, num_points=20)
    arrays = {}
    for m in range(2):
        arrays[f"demo{m}__pos"], arrays[f"demo{m}__t"] = demos.positions[m], demos.time
        arrays[f"demo{m}__quat_xyzw"] = demos.orientations[m].copy()
    arrays["demo1__quat_xyzw"][13] *= 1.5
    np.savez(tmp_path / "bad.npz", **arrays)
    with raises_naming(DemonstrationFileError, str(tmp_path / "bad.npz"), "demo1__quat_xyzw[13]") as info:
        load_demonstrations(tmp_path / "bad.npz")
    one_line(str(info.value))
    entries = np.empty(2, dtype=[("pose", object), ("time", object)])
    for m in range(2):
        transforms = np.tile(np.eye(4), (20, 1, 1))
        transforms[:, :3, :3] = Rotation.from_quat(demos.orientations[m]).as_matrix()
        transforms[:, :3, 3] = demos.positions[m]
        if m == 1:
            transforms[4, :3, :3] *= 1.2                          # not a rotation
        entries[m] = (np.moveaxis(transforms, 0, -1), demos.time)
    scipy.io.savemat(tmp_path / "bad.mat", {"dataset": entries})
    with raises_naming(DemonstrationFileError, str(tmp_path / "bad.mat"), "dataset(2).pose rotation[4]") as info:
        load_demonstrations(tmp_path / "bad.mat")
    one_line(str(info.value))


def test_bad_quaternion_in_a_pose_bag_names_the_bag_and_message(tmp_path):
    demos = turning_demonstrations(num_demos=2, num_points=20)
    turns = demos.orientations.copy()
    turns[0, 6] = [0.0, 0.0, 0.0, 0.0]
    bags = pose_bags(tmp_path, demos, "pose", turns)
    with raises_naming(DemonstrationFileError, bags[0], "/hand message[6]") as info:
        load_demonstrations(bags, topic="/hand")
    one_line(str(info.value))


def test_bad_quaternion_arrays_name_the_argument_and_sample():
    demos = turning_demonstrations(num_demos=2, num_points=20)
    turns = list(demos.orientations.copy())
    turns[1][3] = [1.0, 1.0, 0.0, 0.0]
    with raises_naming(InvalidDemonstrationsError, "orientations[1][3]"):
        Demonstrations.from_trajectories(list(demos.positions), orientations=turns)
    with raises_naming(InvalidDemonstrationsError, "orientations"):
        Demonstrations.from_trajectories(list(demos.positions), orientations=turns[:1])


def test_command_line_bad_quaternion_file_is_one_line_and_exit_2(tmp_path, capsys):
    demos = turning_demonstrations(num_demos=2, num_points=20)
    path = tmp_path / "bad.csv"
    save_csv(demos, path)
    lines = path.read_text().splitlines()
    lines[3] = ",".join(lines[3].split(",")[:-4] + ["2", "0", "0", "0"])
    path.write_text("\n".join(lines) + "\n")
    code = main(["learn", "--demos", str(path), "--out", str(tmp_path / "prior.npz")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "Traceback" not in err[0], err
    assert str(path) in err[0] and "line 4" in err[0]
    assert not (tmp_path / "prior.npz").exists()


# ------------------------------------------------------------------------------ moving the set
def test_transformed_turns_positions_velocities_and_rotations_together():
    """A rigid transform of the whole set (placing a recorded set in an arm's workspace): the
    hand's rotation relative to its path is unchanged, and so are the distances."""
    demos = turning_demonstrations(num_demos=2, num_points=30)
    R = Rotation.from_rotvec([0.3, -0.2, 1.1])
    moved = demos.transformed(R.as_matrix(), [0.1, -0.2, 0.3])
    np.testing.assert_allclose(moved.positions, R.apply(demos.positions.reshape(-1, 3)).reshape(2, 30, 3)
                               + [0.1, -0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(moved.velocities, R.apply(demos.velocities.reshape(-1, 3)).reshape(2, 30, 3),
                               atol=1e-12)
    expected = (R * Rotation.from_quat(demos.orientations.reshape(-1, 4))).as_quat()
    assert per_step_angle(moved.orientations, expected) < 1e-6
    with raises_naming(InvalidDemonstrationsError, "rotation"):
        demos.transformed(np.diag([1.0, 1.0, -1.0]), [0, 0, 0])


def test_scenes_of_a_pose_file_keep_the_rotations(tmp_path):
    from scenes import Box, Scene
    demos = turning_demonstrations(num_demos=2, num_points=20)
    save_csv(demos, tmp_path / "poses.csv")
    scene = Scene([Box([0.3, -0.3, 0.1], [0.05, 0.05, 0.05])])
    loaded = load_demonstrations(tmp_path / "poses.csv", scenes=[scene, scene])
    assert loaded.obstacles is not None
    assert per_step_angle(loaded.orientations, demos.orientations) < 1e-6
