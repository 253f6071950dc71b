"""Demonstrations from ROS 2 bags (scenes.bags): bags written with rosbags' own Writer (MCAP and
SQLite .db3, folders and bare files), read back as demonstrations; every bad bag gives a
DemonstrationFileError naming it."""
from __future__ import annotations

import logging
import shutil
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from bad_input import raises_naming
from clamp import learn_prior
from scenes import (DemonstrationFileError, InvalidArgumentError, load_bag_demonstrations,
                    load_demonstrations, make_demonstrations)
from scenes.bags import REST_SPEED
from scenes.errors import ScenesTypeError
from tests.scenes.test_joint_demonstrations import joint_recordings

TYPES = get_typestore(Stores.ROS2_HUMBLE)
EXTRA_JOINTS = ("j2s6s200_joint_finger_1", "j2s6s200_joint_finger_2")
STORAGE = {"mcap": StoragePlugin.MCAP, "db3": StoragePlugin.SQLITE3}


# ------------------------------------------------------------------------------ bag writing
def _header(stamp_ns: int, frame: str = "") -> object:
    Time = TYPES.types["builtin_interfaces/msg/Time"]
    Header = TYPES.types["std_msgs/msg/Header"]
    return Header(stamp=Time(sec=int(stamp_ns // 10**9), nanosec=int(stamp_ns % 10**9)), frame_id=frame)


def joint_state(stamp_ns: int, names, positions) -> object:
    JointState = TYPES.types["sensor_msgs/msg/JointState"]
    empty = np.zeros(0)
    return JointState(header=_header(stamp_ns), name=list(names),
                      position=np.asarray(positions, dtype=float), velocity=empty, effort=empty)


def pose_stamped(stamp_ns: int, position) -> object:
    T = TYPES.types
    point = T["geometry_msgs/msg/Point"](x=float(position[0]), y=float(position[1]), z=float(position[2]))
    quaternion = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    return T["geometry_msgs/msg/PoseStamped"](header=_header(stamp_ns, "base_link"),
                                              pose=T["geometry_msgs/msg/Pose"](position=point,
                                                                              orientation=quaternion))


def tf_message(stamp_ns: int, pairs: dict) -> object:
    """A TFMessage with one transform per (parent, child): translation."""
    T = TYPES.types
    transforms = []
    for (parent, child), t in pairs.items():
        translation = T["geometry_msgs/msg/Vector3"](x=float(t[0]), y=float(t[1]), z=float(t[2]))
        rotation = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        transforms.append(T["geometry_msgs/msg/TransformStamped"](
            header=_header(stamp_ns, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](translation=translation, rotation=rotation)))
    return T["tf2_msgs/msg/TFMessage"](transforms=transforms)


def write_bag(path: Path, topics: dict, storage: str = "mcap", bare: bool = False) -> Path:
    """A bag at ``path`` (a folder) with topics {name: (msgtype, [message, ...])}; the log time
    of a message is its index in ms (the demonstrations' time comes from the header stamps).
    ``bare``: only the storage file, moved out of its folder (path.with_suffix('.mcap'/'.db3'))."""
    with Writer(path, version=9, storage_plugin=STORAGE[storage]) as writer:
        for topic, (msgtype, messages) in topics.items():
            connection = writer.add_connection(topic, msgtype, typestore=TYPES)
            for k, msg in enumerate(messages):
                writer.write(connection, (k + 1) * 1_000_000, TYPES.serialize_cdr(msg, msgtype))
    if not bare:
        return path
    [storage_file] = [p for p in path.iterdir() if p.suffix == f".{storage}"]
    target = path.with_name(path.name + f".{storage}")
    shutil.move(storage_file, target)
    shutil.rmtree(path)
    return target


def joint_bag(path: Path, robot, time, q, *, storage="mcap", bare=False, seed=0, t0=1_700_000_000.0):
    """JointState messages of q (T, n) at time (T,) [s] + t0, with the fingers' extra joints and
    the joints in a new random order in every message."""
    rng = np.random.default_rng(seed)
    names = list(robot.joint_names) + list(EXTRA_JOINTS)
    messages = []
    for t, row in zip(time, q):
        values = np.concatenate([row, [0.3, 0.4]])
        order = rng.permutation(len(names))
        messages.append(joint_state(int(round((t0 + t) * 1e9)), [names[i] for i in order], values[order]))
    return write_bag(path, {"/joint_states": ("sensor_msgs/msg/JointState", messages)}, storage, bare)


def prior_gap(a, b) -> float:
    """Mean over the support states of the distance [m] between two priors' position means."""
    return float(np.linalg.norm(a.position_mean - b.position_mean, axis=1).mean())


# ------------------------------------------------------------------------------ acceptance
def test_box_closing_bags_learn_the_mat_prior(jaco, shared_dataset, tmp_path):
    """Acceptance (issue 29): the recorded box_closing set as JointState bags (IK on the Jaco,
    gripper joints added, joint order shuffled per message; MCAP and .db3, folders and bare
    files), one demonstration per bag: the prior's mean is the .mat prior's within 1 mm."""
    demos = load_demonstrations(shared_dataset("box_closing"))
    q = joint_recordings(jaco, demos)
    kinds = [("mcap", False), ("mcap", True), ("db3", False), ("db3", True), ("mcap", False), ("db3", False)]
    bags = [joint_bag(tmp_path / f"demo{m}", jaco, demos.time, q[m], storage=s, bare=b, seed=m)
            for m, (s, b) in enumerate(kinds)]
    loaded = load_demonstrations([str(b) for b in bags], topic="/joint_states", robot=jaco)
    assert loaded.M == 6 and loaded.joint_names == jaco.joint_names
    assert loaded.bag_split.count == 6
    np.testing.assert_allclose(loaded.positions, demos.positions, atol=1e-5)
    gap = prior_gap(learn_prior(loaded), learn_prior(demos))
    assert gap < 1e-3, gap


def test_box_closing_two_demonstrations_in_one_bag_split_at_the_rest(jaco, shared_dataset, tmp_path,
                                                                      caplog):
    """Two recorded demonstrations in one bag: the second follows a rest of 3 s, a pause of the
    recording (the arm taken back) and another 3 s rest. split='rest' finds both; each is its
    recording without its own rests (the slow starts and ends below 2 mm/s for 2 s or more)."""
    demos = load_demonstrations(shared_dataset("box_closing"))
    q = joint_recordings(jaco, demos)[4:6]
    dt = demos.dt
    hold = np.arange(1, int(3.0 / dt) + 1) * dt
    first_end = demos.time[-1]
    time = np.concatenate([demos.time, first_end + hold])
    joints = np.concatenate([q[0], np.repeat(q[0][-1:], len(hold), axis=0)])
    second_start = time[-1] + 5.0                                # the paused recording
    time = np.concatenate([time, second_start + np.r_[0.0, hold], second_start + hold[-1] + dt + demos.time])
    joints = np.concatenate([joints, np.repeat(q[1][:1], len(hold) + 1, axis=0), q[1]])
    bag = joint_bag(tmp_path / "two", jaco, time, joints, storage="mcap", bare=True)
    with caplog.at_level(logging.INFO, logger="scenes.bags"):
        loaded = load_bag_demonstrations(bag, "/joint_states", robot=jaco, split="rest")
    record = loaded.bag_split
    assert record.count == 2 and loaded.M == 2
    assert "2 demonstration(s)" in caplog.text
    for m, (start, duration) in enumerate(zip(record.starts, record.durations)):
        speed = np.linalg.norm(demos.velocities[4 + m], axis=1)
        moving = demos.time[speed >= REST_SPEED]
        offset = 0.0 if m == 0 else second_start + hold[-1] + dt
        # the motion's span, within two samples at either end (the speeds are re-estimated)
        assert abs(start - offset - moving[0]) <= 2 * dt + 1e-6
        assert abs(duration - (moving[-1] - moving[0])) <= 4 * dt + 1e-6
        assert duration < 0.9 * demos.duration


def test_synthetic_joint_bags_learn_the_synthetic_prior(jaco, tmp_path):
    """Self-contained (no ../shared): synthetic box_closing as JointState bags, the prior within
    1 mm of the prior of the synthetic demonstrations."""
    demos = make_demonstrations("box_closing", num_demos=3, num_points=60, seed=3)
    q = joint_recordings(jaco, demos)
    bags = [joint_bag(tmp_path / f"d{m}", jaco, demos.time, q[m], storage=("db3", "mcap")[m % 2],
                      bare=m == 1, seed=m) for m in range(3)]
    loaded = load_bag_demonstrations(bags, "/joint_states", robot=jaco)
    np.testing.assert_allclose(loaded.joint_positions, q, atol=1e-12)
    assert prior_gap(learn_prior(loaded), learn_prior(demos)) < 1e-3


def test_pose_bag_split_at_rests_without_a_pause(tmp_path):
    """One PoseStamped bag: demonstration A, a 4 s rest, then B moved to start where A ended
    (no pause: only the rest separates them). split='rest' gives A and B back."""
    demos = make_demonstrations("box_closing", num_demos=2, num_points=120, seed=5)
    a, b = demos.positions
    b = b - b[0] + a[-1]
    t = demos.time
    dt = float(t[1] - t[0])
    hold = np.arange(1, int(4.0 / dt) + 1) * dt
    time = np.concatenate([t, t[-1] + hold, t[-1] + hold[-1] + dt + t[1:]])
    path = np.concatenate([a, np.repeat(a[-1:], len(hold), axis=0), b[1:]])
    messages = [pose_stamped(int(round((100.0 + s) * 1e9)), p) for s, p in zip(time, path)]
    bag = write_bag(tmp_path / "poses", {"/ee_pose": ("geometry_msgs/msg/PoseStamped", messages),
                                         "/other": ("geometry_msgs/msg/PoseStamped", messages[:3])})
    loaded = load_demonstrations(bag, topic="/ee_pose", split="rest")
    assert loaded.bag_split.count == 2
    # each piece starts and ends near its demonstration's own ends (synthetic skills start and
    # end at rest: the slow ends below 2 mm/s go with the rests)
    np.testing.assert_allclose(loaded.positions[0, 0], a[0], atol=5e-3)
    np.testing.assert_allclose(loaded.positions[0, -1], a[-1], atol=5e-3)
    np.testing.assert_allclose(loaded.positions[1, 0], b[0], atol=5e-3)
    np.testing.assert_allclose(loaded.positions[1, -1], b[-1], atol=5e-3)
    whole = load_demonstrations([bag, bag], topic="/ee_pose", split="bag")      # as recorded
    assert whole.bag_split.count == 2 and whole.bag_split.durations[0] == pytest.approx(time[-1])


def test_tf_pair_is_read_from_tf(tmp_path):
    demos = make_demonstrations("curved_reach", num_demos=2, num_points=50, seed=2)
    bags = []
    for m, path in enumerate(demos.positions):
        messages = [tf_message(int(round((5.0 + s) * 1e9)), {("world", "base_link"): [0, 0, 1.0],
                                                              ("base_link", "tool0"): p})
                    for s, p in zip(demos.time, path)]
        bags.append(write_bag(tmp_path / f"tf{m}", {"/tf": ("tf2_msgs/msg/TFMessage", messages)}, "db3"))
    loaded = load_demonstrations(bags, topic="/tf", frames=("base_link", "tool0"))
    np.testing.assert_allclose(loaded.positions, demos.positions, atol=1e-3)
    with raises_naming(DemonstrationFileError, "tf0", "world->tool0", "base_link->tool0"):
        load_demonstrations(bags, topic="/tf", frames=("world", "tool0"))


# ------------------------------------------------------------------------------ bad bags
@pytest.fixture(scope="module")
def good(tmp_path_factory, jaco):
    """Two small JointState bags (folder MCAP and bare .db3) of the synthetic box_closing."""
    folder = tmp_path_factory.mktemp("good")
    demos = make_demonstrations("box_closing", num_demos=2, num_points=20, seed=1)
    q = np.stack([jaco.ik_trajectory(p, seed=jaco.ik(p[0]).q).q for p in demos.positions])
    return (joint_bag(folder / "a", jaco, demos.time, q[0]),
            joint_bag(folder / "b", jaco, demos.time, q[1], storage="db3", bare=True), demos, q)


def bad_joint_bag(tmp_path, jaco, good, change) -> Path:
    """A JointState bag like ``good``'s first whose messages ``change`` (k, names, q) rewrites."""
    _, _, demos, q = good
    messages = []
    for k, (t, row) in enumerate(zip(demos.time, q[0])):
        stamp, names, values = change(k, int(round((10.0 + t) * 1e9)), list(jaco.joint_names), row)
        messages.append(joint_state(stamp, names, values))
    return write_bag(tmp_path / "bad", {"/joint_states": ("sensor_msgs/msg/JointState", messages)})


def expect_error(bag: Path, pattern: str, **kwargs) -> str:
    with pytest.raises(DemonstrationFileError) as info:
        load_bag_demonstrations(bag, **{"topic": "/joint_states", "split": "rest", **kwargs})
    message = str(info.value)
    assert bag.name in message, message
    assert pattern.lower() in message.lower(), message
    return message


def test_missing_topic_lists_the_bags_topics(good, jaco):
    message = expect_error(good[0], "/joint_states", topic="/joint_state", robot=jaco)
    assert "/joint_state'" in message and "sensor_msgs/msg/JointState" in message


def test_a_message_type_that_gives_no_path(tmp_path):
    String = TYPES.types["std_msgs/msg/String"]
    bag = write_bag(tmp_path / "text", {"/chatter": ("std_msgs/msg/String", [String(data="hi")] * 3)})
    expect_error(bag, "std_msgs/msg/String", topic="/chatter")


def test_joint_state_needs_the_robot(good):
    expect_error(good[0], "robot=")


def test_a_joint_missing_from_the_messages(tmp_path, jaco, good):
    def drop(k, stamp, names, row):
        return stamp, names[1:], row[1:]
    expect_error(bad_joint_bag(tmp_path, jaco, good, drop), jaco.joint_names[0], robot=jaco)


def test_messages_of_other_joints_are_skipped_but_partial_ones_refused(tmp_path, jaco, good):
    def other(k, stamp, names, row):     # every third message: a gripper's own joint state
        return (stamp, ["gripper"], [0.1]) if k % 3 == 1 else (stamp, names, row)
    bag = bad_joint_bag(tmp_path, jaco, good, other)
    recording = load_bag_demonstrations([bag, good[0]], "/joint_states", robot=jaco)
    assert recording.M == 2


def test_stamps_going_backwards(tmp_path, jaco, good):
    def swap(k, stamp, names, row):
        return stamp - (3 * 10**9 if k == 7 else 0), names, row
    expect_error(bad_joint_bag(tmp_path, jaco, good, swap), "backwards", robot=jaco)


def test_unstamped_messages(tmp_path, jaco, good):
    def zero(k, stamp, names, row):
        return 0, names, row
    expect_error(bad_joint_bag(tmp_path, jaco, good, zero), "stamp", robot=jaco)


def test_a_bag_without_messages(tmp_path, jaco):
    bag = write_bag(tmp_path / "empty", {"/joint_states": ("sensor_msgs/msg/JointState", [])})
    expect_error(bag, "no messages", robot=jaco)


@pytest.mark.parametrize("damage", ["truncated", "empty", "garbage"])
@pytest.mark.parametrize("storage", ["mcap", "db3"])
def test_damaged_storage_files(tmp_path, jaco, good, damage, storage):
    source = good[0] if storage == "mcap" else good[1]
    data = (next(source.glob("*.mcap")) if source.is_dir() else source).read_bytes()
    bag = tmp_path / f"{damage}.{storage}"
    bag.write_bytes({"truncated": data[: len(data) // 2], "empty": b"", "garbage": b"\x01x" * 300}[damage])
    expect_error(bag, "not a readable ROS 2 bag", robot=jaco)


def test_a_truncated_bag_folder(tmp_path, jaco, good):
    bag = tmp_path / "cut"
    shutil.copytree(good[0], bag)
    storage = next(bag.glob("*.mcap"))
    storage.write_bytes(storage.read_bytes()[:-100])
    expect_error(bag, "truncated", robot=jaco)


def test_paths_that_are_no_bags(tmp_path, jaco):
    (tmp_path / "folder").mkdir()
    expect_error(tmp_path / "folder", "metadata.yaml", robot=jaco)
    expect_error(tmp_path / "missing.mcap", "does not exist", robot=jaco)
    (tmp_path / "notes.txt").write_text("x")
    with raises_naming(DemonstrationFileError, "notes.txt"):
        load_bag_demonstrations([tmp_path / "notes.txt"], "/joint_states", robot=jaco)


def test_one_demonstration_is_not_enough(good, jaco):
    expect_error(good[0], "at least 2", robot=jaco, split="bag")


def test_bad_arguments(good, jaco, tmp_path):
    with raises_naming(ScenesTypeError, "topic"):
        load_demonstrations(good[0], robot=jaco)                    # a bag needs its topic
    with raises_naming(ScenesTypeError, "topic"):
        load_demonstrations(tmp_path / "d.csv", topic="/joint_states")   # not a bag
    with raises_naming(InvalidArgumentError, "split"):
        load_bag_demonstrations(good[0], "/joint_states", robot=jaco, split="pause")
    with raises_naming(InvalidArgumentError, "rest_speed"):
        load_bag_demonstrations(good[0], "/joint_states", robot=jaco, rest_speed=-1.0)
    with raises_naming(ScenesTypeError, "frames"):
        load_bag_demonstrations(good[0], "/tf", frames="base_link->tool0")


# ------------------------------------------------------------------------------ command line
def test_clamp_plan_bad_bag_is_one_line_and_exit_2(tmp_path, capfd, jaco, good):
    from clamp.cli.commands import main
    bag = tmp_path / "broken.mcap"
    bag.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 50)
    code = main(["plan", "--demos", str(bag), str(good[1]), "--topic", "/joint_states", "--robot", "jaco",
                 "--start", "0.2", "-0.47", "0.27", "--out", str(tmp_path / "out")])
    captured = capfd.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert "broken.mcap" in lines[0] and "error" in lines[0]
    assert not (tmp_path / "out").exists()


def test_clamp_plan_learns_from_bags(tmp_path, jaco):
    """``clamp plan --demos a.mcap b.db3 --topic /joint_states --robot jaco`` plans."""
    import json

    from clamp.cli.commands import main
    demos = make_demonstrations("box_closing", num_demos=4, num_points=60, seed=0)
    q = joint_recordings(jaco, demos)
    bags = [joint_bag(tmp_path / f"rec{m}", jaco, demos.time, q[m], storage=("mcap", "db3")[m % 2],
                      bare=True, seed=m) for m in range(4)]
    out = tmp_path / "out"
    assert main(["plan", "--robot", "jaco", "--demos", *map(str, bags), "--topic", "/joint_states",
                 "--start", *map(str, demos.positions[0, 0] + [0.02, 0.0, 0.0]),
                 "--out", str(out), "-q"]) == 0
    plan_json = json.loads((out / "plan.json").read_text())
    assert plan_json["success"]


# ------------------------------------------------------------------------------ split "auto"
def _chained_bag(path: Path, robot, q, dt: float, rest: float) -> Path:
    """One JointState bag of the recordings q (K, T, n) at interval dt [s], one after the other,
    each followed by ``rest`` s of the arm holding still at its end (the next starts at once)."""
    hold = int(round(rest / dt))
    joints = np.concatenate([np.concatenate([qk, np.repeat(qk[-1:], hold, axis=0)]) for qk in q])
    return joint_bag(path, robot, np.arange(len(joints)) * dt, joints, seed=7)


def test_auto_split_finds_the_demonstrations_of_a_bag_separated_by_short_rests(jaco, tmp_path, caplog,
                                                                               capsys):
    """Acceptance (issue 38): a bag of 5 demonstrations separated by 1.5 s rests at 46 Hz plus 5
    single-demonstration bags: the default split finds 10 demonstrations, and the prior is the
    one learned from the same data as 10 arrays (mean within 1 mm)."""
    from scenes.joint_demonstrations import from_joint_trajectories
    dt = 1.0 / 46.0
    demos = make_demonstrations("box_closing", num_demos=10, num_points=249, dt=dt, seed=4)
    q = joint_recordings(jaco, demos)
    bags = [_chained_bag(tmp_path / "five", jaco, q[:5], dt, rest=1.5)]
    bags += [joint_bag(tmp_path / f"one{m}", jaco, demos.time, q[m], seed=m) for m in range(5, 10)]
    with caplog.at_level(logging.INFO, logger="scenes.bags"):
        loaded = load_demonstrations([str(b) for b in bags], topic="/joint_states", robot=jaco)
    assert loaded.M == 10 and loaded.bag_split.count == 10
    assert "10 demonstration(s) (split 'auto')" in caplog.text
    assert "it may hold several" not in caplog.text
    durations = np.array(loaded.bag_split.durations)
    assert np.all(np.abs(durations - demos.duration) < 0.05 * demos.duration), durations
    arrays = from_joint_trajectories(jaco, list(q), [demos.time] * 10)
    gap = prior_gap(learn_prior(loaded.resample(demos.T)), learn_prior(arrays))
    assert gap < 1e-3, gap
    # the default command: clamp learn on the same bags says the split and learns that prior
    from clamp import WorkspacePrior
    from clamp.cli.commands import main
    capsys.readouterr()
    assert main(["learn", "--demos", *map(str, bags), "--topic", "/joint_states", "--robot", "jaco",
                 "--num-points", str(demos.T), "--out", str(tmp_path / "prior.npz")]) == 0
    assert "--demos: 10 demonstration(s) (split 'auto')" in capsys.readouterr().out
    assert prior_gap(WorkspacePrior.load(tmp_path / "prior.npz"), learn_prior(arrays)) < 1e-3


def test_auto_split_keeps_a_demonstration_with_a_pause_whole(jaco, tmp_path):
    """A demonstration that pauses on its way (a rest between two different motions) is one
    demonstration: its motions do not repeat."""
    dt = 1.0 / 46.0
    demos = make_demonstrations("box_closing", num_demos=2, num_points=120, dt=dt, seed=2)
    q = joint_recordings(jaco, demos)
    half = 60
    paused = np.concatenate([q[:, :half], np.repeat(q[:, half - 1:half], 80, axis=1), q[:, half:]], axis=1)
    bags = [joint_bag(tmp_path / f"p{m}", jaco, np.arange(paused.shape[1]) * dt, paused[m], seed=m)
            for m in range(2)]
    loaded = load_bag_demonstrations(bags, "/joint_states", robot=jaco)
    assert loaded.bag_split.count == 2
    np.testing.assert_allclose(loaded.bag_split.durations, (paused.shape[1] - 1) * dt)


def test_a_long_demonstration_is_warned_about_with_the_suggested_split(jaco, tmp_path, caplog):
    """split='bag' on a bag of 3 demonstrations beside 2 single ones: the long one is named with
    its length against the others' and where its rests would cut it."""
    dt = 1.0 / 46.0
    demos = make_demonstrations("box_closing", num_demos=5, num_points=150, dt=dt, seed=6)
    q = joint_recordings(jaco, demos)
    bags = [_chained_bag(tmp_path / "three", jaco, q[:3], dt, rest=1.5)]
    bags += [joint_bag(tmp_path / f"s{m}", jaco, demos.time, q[m], seed=m) for m in (3, 4)]
    with caplog.at_level(logging.WARNING, logger="scenes.bags"):
        loaded = load_bag_demonstrations(bags, "/joint_states", robot=jaco, split="bag")
    assert loaded.M == 3
    warning = caplog.text
    assert "demonstration 0 (three" in warning and "it may hold several" in warning, warning
    assert "--split auto" in warning and "3 repeated motions" in warning, warning
