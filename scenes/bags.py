"""Demonstrations recorded as ROS 2 bags (``ros2 bag record``), read with the ``rosbags`` library
(pure Python: no ROS installation).

A bag is the folder ``ros2 bag record`` writes (``metadata.yaml`` and its ``.mcap`` or ``.db3``
file), or the bare ``.mcap`` / ``.db3`` file alone (rosbags >= 0.11 reads a storage file
without its metadata). Messages are deserialised with the type definitions the bag carries,
else with the ROS 2 Humble definitions (the three types below are the same in every ROS 2
distribution).

One topic is read from every bag (``topic``), of one of these types:

* ``sensor_msgs/msg/JointState`` (joint recordings, needs ``robot=``): the joints are matched to
  ``robot.joint_names`` by name, in any order; joints the robot does not have (a gripper's) are
  ignored, messages holding none of the robot's joints (another publisher on the topic) are
  skipped. The end-effector paths and the hand's rotation are the robot's forward kinematics,
  as for joint-space CSV and .npz files (:mod:`scenes.joint_demonstrations`), and the joint
  trajectories are kept.
* ``geometry_msgs/msg/PoseStamped``: the end-effector position (``pose.position``) [m] and the
  hand's rotation (``pose.orientation``, a quaternion), in the frame it was published in
  (``header.frame_id``; the planner takes it as the robot's base frame).
* ``tf2_msgs/msg/TFMessage`` (``/tf``): the translation and rotation of the transform from
  ``frames[0]`` (parent, ``header.frame_id``) to ``frames[1]`` (``child_frame_id``), e.g.
  ``("base_link", "tool0")``. Only a pair published as one transform is read: no chain of transforms is composed
  (publish or record the direct pair, e.g. with a ``tf2`` listener republishing it).

Time is the messages' header stamps [s] (not the recording time): they must increase; a
publisher that does not stamp its messages (every stamp 0) is refused. ROS measures in metres
and radians (REP 103); the values are checked finite and below :data:`MAX_COORDINATE` like every
file format, and ``clamp`` refuses a prior beyond the arm's reach naming the likely unit.

Splitting (``split``):

* ``"auto"`` (default): one demonstration per bag, unless the bag holds rests that separate
  motions which repeat. A rest is judged against the recording's own motion, not a fixed
  speed or duration (:func:`auto_rests`): the arm slower than :data:`AUTO_REST_FRACTION` of
  the recording's 95th-percentile speed (and than three times its speed while stillest, the
  noise), for at least :data:`AUTO_REST_SHARE` of the median motion between such slow runs;
  a jump between two messages far beyond the recording's steps counts as a rest too (a
  recording concatenated or restarted). The bag is cut there only when the motions repeat:
  each starts where the others start and ends where they end (closer than
  :data:`AUTO_REPEAT_TOLERANCE` of their extent); otherwise (a deliberate pause inside one
  demonstration, a move back to the start between two) it stays one demonstration. Then
  ``"auto"`` keeps every motion whole: from the last still sample before it to the first
  still sample after it.
* ``"bag"``: one demonstration per bag, as recorded;
* ``"rest"``: each bag is cut at its rest phases: the end effector's speed (from the positions
  smoothed and differentiated as ``smoothing=`` says, :mod:`scenes.smoothing`) below
  ``rest_speed`` (default :data:`REST_SPEED`, 2 mm/s) for at least ``rest_duration`` (default
  :data:`REST_DURATION`, 2 s), and at pauses of the recording (no message for at least
  ``rest_duration``). Every motion between them becomes a demonstration, from the last sample
  of the rest before it to the first sample of the rest after it (the rests themselves are
  dropped). A move back to the start recorded between two demonstrations is a motion too:
  pause the recording for it, or record one bag per demonstration. The defaults keep the slow
  deliberate motions of the recorded box_closing set (a 3 s pause below 5 mm/s in every
  demonstration) in one piece.

Whatever the split, a demonstration lasting over :data:`LONG_DEMONSTRATION` times the median
of the others is warned about (it may hold several), with the cut :func:`auto_rests` would
suggest. The split is always logged (INFO; ``clamp`` prints it).

The quaternions are checked and repaired as :mod:`scenes.quaternions` says (not unit: an error
naming the bag and the message; sign flips made continuous; a turn faster than 2 pi rad/s: a
warning naming the sample). The demonstrations are then smoothed, differentiated and resampled
onto one time axis as every other format (:meth:`Demonstrations.from_trajectories` when their stamps differ). How
the bags were cut is logged (INFO) and attached to the result as ``demos.bag_split``
(:class:`BagSplit`: per demonstration its bag, start in the bag and duration); a resampled or
translated copy does not carry it.

Every problem is a :class:`~scenes.errors.DemonstrationFileError` naming the bag: a missing
path, an unreadable, empty, truncated or corrupt bag, a missing topic (the bag's topics are
listed), a message type that cannot serve, a joint of the robot missing from a message, stamps
that do not increase. No exception of rosbags escapes.
"""
from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .demonstrations import Demonstrations
from .errors import (ScenesTypeError, DemonstrationFileError, InvalidArgumentError,
                     InvalidDemonstrationsError)
from .joint_demonstrations import check_robot, from_joint_trajectories
from .quaternions import unit_quaternions
from .smoothing import as_smoothing, smooth_trajectory
from skillplan.validation import MAX_COORDINATE, as_array, as_path, as_positive, as_sequence
from .bag_split import SPLITS

log = logging.getLogger(__name__)

#: storage files rosbags reads without their metadata.yaml
BAG_SUFFIXES = (".mcap", ".db3")
#: split "auto": a rest is slower than this fraction of the recording's 95th-percentile speed
AUTO_REST_FRACTION = 0.002
#: split "auto": ... and lasts at least this share of the median motion between slow runs
AUTO_REST_SHARE = 0.2
#: split "auto": motions repeat when any two of their starts (and of their ends) lie closer than
#: this share of their median extent (largest distance from their start)
AUTO_REPEAT_TOLERANCE = 0.6
#: a step between two messages longer than this many times the recording's 95th-percentile
#: step is a jump (no motion): a boundary like a rest
JUMP_FACTOR = 20.0
#: a demonstration lasting more than this many times the median of the others is warned about
LONG_DEMONSTRATION = 3.0
#: default end-effector speed [m/s] below which the arm counts as resting
REST_SPEED = 0.002
#: default shortest rest [s] that separates two demonstrations
REST_DURATION = 2.0

JOINT_STATE = "sensor_msgs/msg/JointState"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
MESSAGE_TYPES = (JOINT_STATE, POSE_STAMPED, TF_MESSAGE)


@dataclass(frozen=True)
class BagSplit:
    """How bags became demonstrations: ``split`` ("bag" or "rest") and, per demonstration m,
    ``bags[m]`` (the bag's path), ``starts[m]`` (its first header stamp, in seconds after the
    first stamp of its bag) and ``durations[m]`` [s]."""

    split: str
    bags: tuple[str, ...]
    starts: tuple[float, ...]
    durations: tuple[float, ...]

    @property
    def count(self) -> int:
        """Number of demonstrations."""
        return len(self.bags)

    def __str__(self) -> str:
        parts = ", ".join(f"{Path(b).name} @ {s:.2f} s: {d:.2f} s"
                          for b, s, d in zip(self.bags, self.starts, self.durations))
        return f"{self.count} demonstration(s) (split {self.split!r}): {parts}"


@dataclass
class _Recording:
    """One topic of one bag: stamps (T,) [s after the bag's first stamp], end-effector positions (T, 3) [m] and, for joint
    recordings, joints (T, n) [rad] in the robot's order, else the hand's rotations (T, 4)
    unit quaternions (x, y, z, w)."""

    bag: Path
    stamps: np.ndarray
    positions: np.ndarray
    joints: np.ndarray | None
    rotations: np.ndarray | None = None

    def part(self, a: int, b: int) -> "_Recording":
        """Samples [a, b) of the recording."""
        return _Recording(self.bag, self.stamps[a:b], self.positions[a:b],
                          None if self.joints is None else self.joints[a:b],
                          None if self.rotations is None else self.rotations[a:b])


def is_bag(path: Any) -> bool:
    """Whether ``path`` names a ROS 2 bag: a folder holding ``metadata.yaml``, or a file name
    ending in .mcap / .db3 (existing or not: a missing one is then reported as a missing bag)."""
    if not isinstance(path, (str, Path)):
        return False
    path = Path(path)
    return path.suffix.lower() in BAG_SUFFIXES or (path.is_dir() and (path / "metadata.yaml").is_file())


def load_bag_demonstrations(paths: str | Path | Sequence[str | Path], topic: str, *,
                            robot: Any = None, split: str = "auto", frames: Sequence[str] | None = None,
                            rest_speed: float = REST_SPEED, rest_duration: float = REST_DURATION,
                            smoothing: str = "auto") -> Demonstrations:
    """Demonstrations from one or more ROS 2 bags (folders or bare .mcap / .db3 files; see the
    module docstring).

    topic: the topic to read (JointState, PoseStamped or TFMessage). robot: a robots.Robot,
    needed for JointState (forward kinematics). split: "auto" (one demonstration per bag unless
    its rests separate repeated motions), "bag" (one demonstration per bag) or "rest" (cut at
    rests and pauses of ``rest_speed`` and ``rest_duration``). frames: (parent, child) of the transform read from a
    TFMessage topic. rest_speed [m/s], rest_duration [s]: what counts as a rest (split "rest").
    smoothing: how velocities are estimated (:mod:`scenes.smoothing`). The result carries
    ``bag_split`` (:class:`BagSplit`). Raises DemonstrationFileError naming the bag and what is
    wrong; InvalidArgumentError (ScenesTypeError) for a bad argument.
    """
    bags = _bag_paths(paths)
    if not isinstance(topic, str) or not topic:
        raise ScenesTypeError(f"topic: expected the name of the topic to read (str, e.g. "
                                f"'/joint_states'), got {topic!r:.60}")
    if split not in SPLITS:
        raise InvalidArgumentError(f"split: expected one of {list(SPLITS)}, got {split!r:.60}")
    frames = _frames(frames)
    rest_speed = as_positive(rest_speed, "rest_speed")
    rest_duration = as_positive(rest_duration, "rest_duration")
    smoothing = as_smoothing(smoothing)
    if robot is not None:
        check_robot(robot)
    pieces: list[_Recording] = []
    for bag in bags:
        recording = _read(bag, topic, robot, frames)
        if split == "bag":
            pieces.append(recording)
        elif split == "auto":
            pieces.extend(_split_auto(recording))
        else:
            pieces.extend(_split_at_rests(recording, rest_speed, rest_duration, smoothing))
    record = BagSplit(split, tuple(str(p.bag) for p in pieces),
                      tuple(float(p.stamps[0]) for p in pieces),
                      tuple(float(p.stamps[-1] - p.stamps[0]) for p in pieces))
    log.info("%s: %s", _names(bags), record)
    _warn_long(pieces)
    name = bags[0].stem
    demos = _assemble(pieces, robot, smoothing, name, bags)
    demos.bag_split = record  # type: ignore[attr-defined]  # the attached record (docstring)
    return demos


# ------------------------------------------------------------------------------ arguments
def _bag_paths(paths: Any) -> list[Path]:
    if isinstance(paths, (str, Path)):
        paths = [paths]
    paths = as_sequence(paths, "paths", "a ROS 2 bag (folder, .mcap or .db3) or a list of them",
                        ScenesTypeError)
    if not paths:
        raise ScenesTypeError("paths: expected at least one ROS 2 bag, got an empty list")
    bags = [as_path(p, f"paths[{i}]", ScenesTypeError) for i, p in enumerate(paths)]
    for bag in bags:
        if not bag.exists():
            raise DemonstrationFileError(f"{bag}: does not exist (expected a ROS 2 bag: the folder "
                                         "ros2 bag record writes, or its .mcap / .db3 file)")
        if bag.is_dir() and not (bag / "metadata.yaml").is_file():
            raise DemonstrationFileError(f"{bag}: a folder without metadata.yaml, not a ROS 2 bag "
                                         "(pass the bag folder, or its .mcap / .db3 file)")
        if bag.is_file() and bag.suffix.lower() not in BAG_SUFFIXES:
            raise DemonstrationFileError(f"{bag}: expected a ROS 2 bag (a folder with metadata.yaml, "
                                         f"or a file ending in {' or '.join(BAG_SUFFIXES)})")
    return bags


def _frames(frames: Any) -> tuple[str, str] | None:
    if frames is None:
        return None
    if (not isinstance(frames, (list, tuple)) or len(frames) != 2
            or not all(isinstance(f, str) and f for f in frames)):
        raise ScenesTypeError(f"frames: expected (parent, child) frame names of the /tf "
                                f"transform to read, e.g. ('base_link', 'tool0'), got {frames!r:.80}")
    return str(frames[0]).lstrip("/"), str(frames[1]).lstrip("/")


def _names(bags: Sequence[Path]) -> str:
    return str(bags[0]) if len(bags) == 1 else f"{len(bags)} bags ({', '.join(b.name for b in bags)})"


# ------------------------------------------------------------------------------ reading
def _read(bag: Path, topic: str, robot: Any, frames: tuple[str, str] | None) -> _Recording:
    """The topic of one bag as stamps and positions (joints for JointState); every rosbags
    error becomes a DemonstrationFileError naming the bag."""
    # deferred: rosbags loads only when a bag is read (start-up of scenes)
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            topics = {name: info.msgtype for name, info in reader.topics.items()}
            if topic not in topics:
                listed = ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "none"
                raise DemonstrationFileError(f"{bag}: no topic {topic!r}; the bag's topics: {listed}")
            msgtype = topics[topic]
            if msgtype not in MESSAGE_TYPES:
                raise DemonstrationFileError(f"{bag}: topic {topic!r} carries {msgtype}, which gives "
                                             f"no end-effector path; expected one of {list(MESSAGE_TYPES)}")
            if msgtype == JOINT_STATE and robot is None:
                raise DemonstrationFileError(f"{bag}: topic {topic!r} holds joint states; pass robot= (a "
                                             "robots.Robot, e.g. robots.load_robot('jaco')) whose forward "
                                             "kinematics gives the end-effector paths")
            if msgtype == TF_MESSAGE and frames is None:
                raise DemonstrationFileError(f"{bag}: topic {topic!r} holds transforms; pass frames="
                                             "(parent, child), e.g. ('base_link', 'tool0')")
            connections = [c for c in reader.connections if c.topic == topic]
            messages = ((reader.deserialize(raw, c.msgtype), c.msgtype)
                        for c, _, raw in reader.messages(connections=connections))
            rotations = None
            if msgtype == JOINT_STATE:
                stamps, joints = _joint_states(bag, topic, messages, robot)
                positions = np.asarray(robot.fk(joints), dtype=float)
            elif msgtype == POSE_STAMPED:
                stamps, positions, rotations = _poses(messages)
                joints = None
            else:
                stamps, positions, rotations = _transforms(bag, topic, messages, frames)
                joints = None
    except DemonstrationFileError:
        raise
    except InvalidArgumentError as exc:   # e.g. the robot refusing joint values
        raise DemonstrationFileError(f"{bag}: {exc}") from None
    except Exception as exc:  # rosbags (and sqlite / mcap below it) raise many kinds
        raise DemonstrationFileError(f"{bag}: not a readable ROS 2 bag: empty, truncated or corrupt "
                                     f"({type(exc).__name__}: {exc}); a bag whose recording was cut "
                                     "short may be repaired with 'ros2 bag reindex'") from None
    return _checked(bag, topic, stamps, positions, joints, rotations)


def _stamp(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _joint_states(bag: Path, topic: str, messages: Any, robot: Any) -> tuple[list[int], np.ndarray]:
    names = list(robot.joint_names)
    stamps: list[int] = []
    rows: list[np.ndarray] = []
    skipped = 0
    for k, (msg, _) in enumerate(messages):
        have = list(msg.name)
        position = np.asarray(msg.position, dtype=float)
        if len(position) != len(have):
            raise DemonstrationFileError(f"{bag}: {topic} message {k}: {len(have)} joint names but "
                                         f"{len(position)} positions")
        index = {n: i for i, n in enumerate(have)}
        missing = [n for n in names if n not in index]
        if len(missing) == len(names):
            skipped += 1                   # another publisher's joints (a gripper's)
            continue
        if missing:
            raise DemonstrationFileError(f"{bag}: {topic} message {k}: joint(s) {missing} of "
                                         f"{getattr(robot, 'name', 'the robot')} missing; the message "
                                         f"names {have}")
        stamps.append(_stamp(msg.header))
        rows.append(position[[index[n] for n in names]])
    if skipped:
        log.info("%s: %d %s message(s) hold none of the joints %s: skipped", bag, skipped, topic, names)
    if not rows:
        raise DemonstrationFileError(f"{bag}: no {topic} message holds the joints {names} of "
                                     f"{getattr(robot, 'name', 'the robot')}" + (
                                         f" ({skipped} message(s) name other joints)" if skipped else
                                         " (the topic has no messages)"))
    q = as_array(np.array(rows), f"{bag}: {topic} joint positions", DemonstrationFileError,
                 MAX_COORDINATE)
    return stamps, q


def _poses(messages: Any) -> tuple[list[int], np.ndarray, np.ndarray]:
    stamps, rows, turns = [], [], []
    for msg, _ in messages:
        stamps.append(_stamp(msg.header))
        p, o = msg.pose.position, msg.pose.orientation
        rows.append((p.x, p.y, p.z))
        turns.append((o.x, o.y, o.z, o.w))
    return (stamps, np.array(rows, dtype=float).reshape(-1, 3),
            np.array(turns, dtype=float).reshape(-1, 4))


def _transforms(bag: Path, topic: str, messages: Any,
                frames: tuple[str, str]) -> tuple[list[int], np.ndarray, np.ndarray]:
    stamps, rows, turns = [], [], []
    pairs: set[tuple[str, str]] = set()
    for msg, _ in messages:
        for transform in msg.transforms:
            pair = (transform.header.frame_id.lstrip("/"), transform.child_frame_id.lstrip("/"))
            pairs.add(pair)
            if pair == frames:
                stamps.append(_stamp(transform.header))
                t, r = transform.transform.translation, transform.transform.rotation
                rows.append((t.x, t.y, t.z))
                turns.append((r.x, r.y, r.z, r.w))
    if not rows:
        listed = ", ".join(f"{a}->{b}" for a, b in sorted(pairs)) or "none (no messages)"
        raise DemonstrationFileError(f"{bag}: {topic} has no transform {frames[0]}->{frames[1]} "
                                     f"(only a directly published pair is read, no chain is "
                                     f"composed); its pairs: {listed}")
    return stamps, np.array(rows, dtype=float), np.array(turns, dtype=float)


def _checked(bag: Path, topic: str, stamps: list[int], positions: np.ndarray,
             joints: np.ndarray | None, rotations: np.ndarray | None) -> _Recording:
    """Stamps [ns] that increase (DemonstrationFileError naming the bag otherwise), as seconds;
    rotations unit (DemonstrationFileError naming the bag and the message otherwise)."""
    if len(stamps) == 0:
        raise DemonstrationFileError(f"{bag}: topic {topic!r} has no messages")
    if len(stamps) < 2:
        raise DemonstrationFileError(f"{bag}: topic {topic!r} has {len(stamps)} message, expected "
                                     "at least 2 (a trajectory needs two time stamps)")
    ns = np.array(stamps, dtype=np.int64)
    if not np.any(ns):
        raise DemonstrationFileError(f"{bag}: every {topic} header stamp is 0: the publisher does "
                                     "not stamp its messages, and the time comes from the stamps")
    steps = np.diff(ns)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        how = "go backwards" if steps[k] < 0 else "repeat"
        raise DemonstrationFileError(f"{bag}: {topic} header stamps {how} at message {k + 1}: "
                                     f"{ns[k] * 1e-9:.9f} s then {ns[k + 1] * 1e-9:.9f} s; expected "
                                     "increasing stamps")
    positions = as_array(positions, f"{bag}: {topic} positions", DemonstrationFileError,
                         MAX_COORDINATE)
    seconds = (ns - ns[0]) * 1e-9      # from the bag's first stamp (float64 keeps ns over days)
    if rotations is not None:       # unit here (naming the message); the rest in from_trajectories
        rotations = unit_quaternions(rotations, f"{bag}: {topic} message", DemonstrationFileError)
    return _Recording(bag, seconds, positions, joints, rotations)


# ------------------------------------------------------------------------------ splitting
def _speed(recording: _Recording, smoothing: str) -> np.ndarray:
    """End-effector speed (T,) [m/s] of a recording, smoothed as ``smoothing`` says."""
    t = recording.stamps - recording.stamps[0]
    _, velocity = smooth_trajectory(t, recording.positions, smoothing,
                                    f"{recording.bag.name} (rest detection)")
    return np.linalg.norm(velocity, axis=1)


def _split_at_rests(recording: _Recording, rest_speed: float, rest_duration: float,
                    smoothing: str) -> list[_Recording]:
    """The motions of one recording between its rests and pauses (module docstring)."""
    t = recording.stamps
    gaps = np.flatnonzero(np.diff(t) >= rest_duration)
    bounds = np.concatenate([[0], gaps + 1, [len(t)]])
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a < 2:
            continue
        part = recording.part(a, b)
        out.extend(_motions(part, rest_speed, rest_duration, smoothing))
    if not out:
        raise DemonstrationFileError(f"{recording.bag}: no motion: the end effector stays below "
                                     f"rest_speed {rest_speed:g} m/s throughout")
    return out


def _motions(part: _Recording, rest_speed: float, rest_duration: float,
             smoothing: str) -> list[_Recording]:
    t = part.stamps
    moving = _speed(part, smoothing) >= rest_speed
    resting = np.zeros(len(t), dtype=bool)
    edges = np.flatnonzero(np.diff(np.r_[0, (~moving).astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):          # runs [a, b) of slow samples
        if t[b - 1] - t[a] >= rest_duration:
            resting[a:b] = True
    edges = np.flatnonzero(np.diff(np.r_[0, (~resting).astype(int), 0]))
    out = []
    for a, b in zip(edges[::2], edges[1::2]):          # motions [a, b) between rests
        a, b = max(a - 1, 0), min(b + 1, len(t))        # from the rest before to the rest after
        if b - a < 2:
            continue
        out.append(part.part(a, b))
    return out


# ------------------------------------------------------------------------------ split "auto"
@dataclass(frozen=True)
class AutoRests:
    """The rests :func:`auto_rests` finds in one recording: ``threshold`` [m/s] (the speed
    below which the arm is still), ``rests`` [(first, last + 1)] sample runs and ``motions``
    [(first, last + 1)] the sample runs between them, each from the last still sample before
    it to the first still sample after it."""

    threshold: float
    rests: tuple[tuple[int, int], ...]
    motions: tuple[tuple[int, int], ...]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs [(a, b)] of True in a boolean array."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def auto_rests(stamps: np.ndarray, positions: np.ndarray) -> AutoRests:
    """Rests of one recording, stamps (T,) [s] and positions (T, 3) [m], judged against its own
    motion (module docstring, split "auto"). A step is still when it is a jump (longer than
    :data:`JUMP_FACTOR` times the 95th-percentile step) or a pause (over 5 times the median
    interval); a sample's speed is the slower of its two steps, median-filtered over 5 samples
    (noise). Rests at the recording's ends are rests whatever their length."""
    from scipy.ndimage import median_filter
    t = np.asarray(stamps, dtype=float)
    step = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    interval = np.diff(t)
    still = (step > JUMP_FACTOR * max(np.percentile(step, 95), 1e-12)) | (interval > 5 * np.median(interval))
    velocity = np.where(still, 0.0, step / interval)
    speed = np.minimum(np.r_[velocity[0], velocity], np.r_[velocity, velocity[-1]])
    speed = median_filter(speed, size=min(5, len(speed)), mode="nearest")
    threshold = max(AUTO_REST_FRACTION * np.percentile(speed, 95), 3.0 * np.percentile(speed, 5))
    slow = _runs(speed <= threshold)
    jumps = set(np.flatnonzero(still).tolist())
    moving = _runs(speed > threshold)
    if not moving:
        return AutoRests(float(threshold), ((0, len(t)),), ())
    typical = float(np.median([t[b - 1] - t[a] for a, b in moving]))
    rests = tuple((a, b) for a, b in slow
                  if a == 0 or b == len(t) or t[b - 1] - t[a] >= AUTO_REST_SHARE * typical
                  or any(a - 1 <= k < b for k in jumps))
    resting = np.zeros(len(t), dtype=bool)
    for a, b in rests:
        resting[a:b] = True
    # the arm still within a rest: its steps no longer than twice the rest's median step
    # (0 for a recording that holds exactly still, its noise otherwise)
    level = np.full(len(step), np.inf)
    for a, b in rests:
        inside = [k for k in range(a, b - 1) if k not in jumps]
        level[max(a - 1, 0):b] = 2.0 * np.median(step[inside]) if inside else 0.0
    motions = []
    for a, b in _runs(~resting):             # each motion grown into its rests while it moves
        while a > 0 and resting[a - 1] and (a - 1) not in jumps and step[a - 1] > level[a - 1]:
            a -= 1
        while b < len(t) and resting[b] and (b - 1) not in jumps and step[b - 1] > level[b - 1]:
            b += 1
        first = a - 1 if a > 0 and (a - 1) not in jumps else a      # the still samples around it
        last = b + 1 if b < len(t) and (b - 1) not in jumps else b
        motions.append((first, last))
    return AutoRests(float(threshold), rests, tuple(motions))


def _repeat(pieces: list[_Recording]) -> bool:
    """Whether motions repeat: two or more, any two of their starts (and of their ends) closer
    than :data:`AUTO_REPEAT_TOLERANCE` times their median extent (largest distance from
    their start). A pause inside one demonstration fails it: the motion after the pause starts
    where the one before it ends."""
    if len(pieces) < 2:
        return False
    extent = np.median([np.linalg.norm(p.positions - p.positions[0], axis=1).max() for p in pieces])
    for ends in (np.array([p.positions[0] for p in pieces]), np.array([p.positions[-1] for p in pieces])):
        spread = np.linalg.norm(ends[:, None] - ends[None], axis=2).max()
        if spread > AUTO_REPEAT_TOLERANCE * extent:
            return False
    return bool(extent > 0.0)


def _cut(recording: _Recording, runs: Sequence[tuple[int, int]]) -> list[_Recording]:
    return [_Recording(recording.bag, recording.stamps[a:b], recording.positions[a:b],
                       None if recording.joints is None else recording.joints[a:b]) for a, b in runs]


def _split_auto(recording: _Recording) -> list[_Recording]:
    """Split "auto" of one recording: its repeated motions, or the recording as it is."""
    found = auto_rests(recording.stamps, recording.positions)
    pieces = _cut(recording, found.motions)
    if _repeat(pieces):
        return pieces
    if len(pieces) > 1:
        log.info("%s: %d motions between rests, which do not repeat (a pause inside one "
                 "demonstration): kept as one demonstration", recording.bag, len(pieces))
    return [recording]


def _warn_long(pieces: list[_Recording]) -> None:
    """Warn about a demonstration lasting over :data:`LONG_DEMONSTRATION` times the median of
    the others, with the cut :func:`auto_rests` suggests."""
    if len(pieces) < 2:
        return
    durations = np.array([p.stamps[-1] - p.stamps[0] for p in pieces])
    for m, piece in enumerate(pieces):
        others = np.median(np.delete(durations, m))
        if durations[m] <= LONG_DEMONSTRATION * others:
            continue
        found = auto_rests(piece.stamps, piece.positions)
        t = piece.stamps
        inner = [(a, b) for a, b in found.rests if 0 < a and b < len(t)]
        if _repeat(_cut(piece, found.motions)):
            cut = (f"split 'auto' (clamp: --split auto) cuts it into {len(found.motions)} "
                   f"repeated motions")
        elif inner:
            shortest = np.floor(min(t[b - 1] - t[a] for a, b in inner) * 10) / 10
            cut = (f"its rests at {', '.join(f'{t[a]:.2f}-{t[b - 1]:.2f} s' for a, b in inner)} "
                   f"cut it into {len(found.motions)} motions, which do not repeat; if they are "
                   f"demonstrations, record one bag each or pass split='rest' with "
                   f"rest_speed={found.threshold:.2g}, rest_duration={shortest:g}")
        else:
            cut = "it has no rest to cut it at (record one bag per demonstration)"
        log.warning("demonstration %d (%s @ %.2f s) lasts %.2f s, %.1fx the median %.2f s of the "
                    "others: it may hold several demonstrations; %s", m, piece.bag.name, t[0],
                    durations[m], durations[m] / others, others, cut)


# ------------------------------------------------------------------------------ assembly
def _assemble(pieces: list[_Recording], robot: Any, smoothing: str, name: str,
              bags: list[Path]) -> Demonstrations:
    if len(pieces) < 2:
        raise DemonstrationFileError(f"{_names(bags)}: {len(pieces)} demonstration(s), expected at "
                                     "least 2 (pass more bags, or split='rest' for a bag holding "
                                     "several demonstrations between rests)")
    kinds = {p.joints is not None for p in pieces}
    if len(kinds) > 1:
        raise DemonstrationFileError(f"{_names(bags)}: the topic holds joint states in some bags and "
                                     "end-effector poses in others; expected one kind")
    times = [p.stamps - p.stamps[0] for p in pieces]
    try:
        if pieces[0].joints is not None:
            return from_joint_trajectories(robot, [p.joints for p in pieces], times, smoothing, name)
        positions, velocities = [], []
        for m, (p, t) in enumerate(zip(pieces, times)):
            pos, vel = smooth_trajectory(t, p.positions, smoothing, f"{name}[{m}]")
            positions.append(pos)
            velocities.append(vel)
        rotations = None if pieces[0].rotations is None else [p.rotations for p in pieces]
        return Demonstrations.from_trajectories(positions, times, velocities=velocities, name=name,
                                                orientations=rotations)
    except InvalidDemonstrationsError as exc:
        raise DemonstrationFileError(f"{_names(bags)}: {exc}") from None
    except InvalidArgumentError as exc:     # e.g. stamps closer than the time resolution
        raise DemonstrationFileError(f"{_names(bags)}: {exc}") from None
