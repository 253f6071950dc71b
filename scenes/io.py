"""Reading and writing demonstration files.

Formats (chosen by suffix, then by content):

* ``.mat`` CLAMP reference: struct array ``dataset`` with fields ``pos`` (T,3), ``vel`` (T,3),
  ``time`` (T,) and optional ``obs`` (K,6) boxes [cx,cy,cz,sx,sy,sz]; scalar ``dt``.
  Missing ``time`` becomes ``arange(T) * dt``; missing ``vel`` is estimated (below). The hand's
  rotation, when recorded: field ``quat_xyzw`` (T,4) unit quaternions (x, y, z, w), or ``pose``
  (4,4,T) homogeneous transforms (MATLAB's stacking; their translation is the position and
  replaces ``pos``).
* ``.mat`` TLGC reference: cell array ``smoothData`` of (N,3) positions without time; time is
  ``linspace(0, NOMINAL_DURATION, N)`` (10 s), velocities estimated.
* ``.npz``: written by :meth:`Demonstrations.save_npz` (``orientations`` (M,T,4) when
  recorded); or joint space: ``joint_positions`` (M,T,n) [rad], ``time`` (T,) [s],
  ``joint_names`` (n,) (needs ``robot=``); or one recording per demonstration k = 0, 1, ...
  (``wiping_rim.npz``): ``demo<k>__pos`` (N_k,3) [m] with ``demo<k>__quat_xyzw`` (N_k,4), or
  ``demo<k>__pose`` (N_k,4,4) homogeneous transforms, and ``demo<k>__t`` (N_k,) [s] (optional:
  without it the recording lasts NOMINAL_DURATION).
* ``.csv``: header ``demo,t,x,y,z`` or ``demo,t,x,y,z,vx,vy,vz``, one row per sample; ``demo`` is
  an integer label (order of first appearance), ``t`` in seconds, positions in metres,
  velocities in m/s. Without velocity columns they are estimated. The pose CSV adds the hand's
  rotation as a unit quaternion in four last columns ``qx,qy,qz,qw`` (header
  ``demo,t,x,y,z,qx,qy,qz,qw`` or ``demo,t,x,y,z,vx,vy,vz,qx,qy,qz,qw``). Joint space (kinesthetic
  teaching): ``demo,t`` then one column per joint named as in the robot's URDF
  (``robot.joint_names``, any order) [rad], read with ``robot=``. UTF-8 with or without a
  byte-order mark (a spreadsheet's "CSV UTF-8"); quoted fields ("x") are read as their text.
  The obstacles of each demonstration come from scene JSON files (one per demonstration,
  ``scenes=`` of :func:`load_demonstrations`; :func:`save_csv` writes them as
  ``<stem>.scene<m>.json`` next to the CSV).
* ROS 2 bags (``ros2 bag record``: the folder with ``metadata.yaml``, or a bare ``.mcap`` /
  ``.db3`` file; one bag or a list): a ``topic`` of JointState (with ``robot=``), PoseStamped or
  /tf messages, one demonstration per bag or split at rests (:mod:`scenes.bags`).

Velocities missing from a file (and joint velocities) are estimated per demonstration as
``smoothing=`` chooses (:mod:`scenes.smoothing`: "auto" smooths noisy recordings with a
Savitzky-Golay filter and interpolates clean ones, "savgol" / "spline" always smooth, "none"
interpolates and warns when noise dominates); velocities given in the file are kept.
Joint recordings become end-effector demonstrations by the robot's forward kinematics
(:mod:`scenes.joint_demonstrations`), with the hand's rotation, and keep their joint
trajectories. Recorded rotations are checked and repaired as :mod:`scenes.quaternions` says (a
quaternion not unit or a matrix not a rotation: an error naming the file and the sample; sign
flips made continuous; a turn faster than 2 pi rad/s: a warning naming the sample).
Position-only files give position-only demonstrations (``orientations`` None).

Demonstrations sharing the same time stamps are taken as they are; otherwise they are
resampled with :meth:`Demonstrations.from_trajectories`.
"""
from __future__ import annotations

import csv
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .bags import is_bag, load_bag_demonstrations
from .demonstrations import NOMINAL_DURATION, Demonstrations
from .errors import (ScenesTypeError, DemonstrationFileError, InvalidDemonstrationsError,
                     InvalidObstacleError)
from .joint_demonstrations import check_robot, column_order, from_joint_trajectories
from .obstacles import Box
from .quaternions import (QUATERNION_TOLERANCE, checked_quaternions, off_unit,
                          quaternions_from_matrices, unit_quaternions)
from .scene import Scene
from .smoothing import as_smoothing, smooth_trajectory
from skillplan.validation import MAX_COORDINATE, as_array, as_file, as_instance, as_path, as_sequence, as_time

CSV_COLUMNS = ("demo", "t", "x", "y", "z")
CSV_VELOCITY_COLUMNS = ("vx", "vy", "vz")
CSV_ORIENTATION_COLUMNS = ("qx", "qy", "qz", "qw")
#: the headers of workspace CSV files: positions, then velocities and / or the hand's rotation
CSV_HEADERS = tuple(CSV_COLUMNS + v + o for o in ((), CSV_ORIENTATION_COLUMNS)
                    for v in ((), CSV_VELOCITY_COLUMNS))


def load_demonstrations(path: str | Path | Sequence[str | Path], scenes: Sequence[Any] | None = None,
                        *, robot: Any = None, smoothing: str = "auto", topic: str | None = None,
                        split: str = "auto", frames: Sequence[str] | None = None) -> Demonstrations:
    """Read demonstrations from a .mat (CLAMP or TLGC), .npz or .csv file, or from ROS 2 bags.

    ROS 2 bags: ``path`` is a bag (its folder, or a bare .mcap / .db3 file) or a list of bags;
    ``topic`` (required), ``split`` ("auto", "bag" or "rest") and ``frames`` ((parent, child) for a /tf
    topic) are passed to :func:`scenes.bags.load_bag_demonstrations` (its defaults for what
    counts as a rest). ``topic``, ``split`` and ``frames`` are for bags only.

    scenes: per demonstration the scene it was recorded in (a scene JSON path or a
    scenes.Scene), whose obstacles become that demonstration's ``obstacles`` (replacing any
    the file records). robot: a robots.Robot, needed for joint-space files (their end-effector
    paths are its forward kinematics). smoothing: "auto", "savgol", "spline" or "none", how velocities
    missing from the file are estimated (module docstring). Raises DemonstrationFileError
    (missing/unreadable file, unknown suffix or content, malformed fields, joint columns
    without a robot, a scene count that is not the demonstration count) naming the file and
    what was expected; SceneFileError for a bad scene file.
    """
    if isinstance(path, (list, tuple)) or is_bag(path):
        if topic is None:
            raise ScenesTypeError(f"topic: expected the topic to read from the ROS 2 bag(s) "
                                    f"{_shown(path)} (e.g. '/joint_states'), got None")
        demos = load_bag_demonstrations(path, topic, robot=robot, split=split, frames=frames,
                                        smoothing=smoothing)
        return _with_scenes(demos, scenes, _shown(path))
    bag_options = {k: v for k, v in (("topic", topic), ("frames", frames)) if v is not None}
    if split != "auto":
        bag_options["split"] = split
    if bag_options:
        raise ScenesTypeError(f"{', '.join(bag_options)}: only for ROS 2 bags (a folder with "
                                f"metadata.yaml, a .mcap or .db3 file), got the file {path!r:.80}")
    path = as_file(path, "path", DemonstrationFileError, ScenesTypeError)
    smoothing = as_smoothing(smoothing)
    if robot is not None:
        check_robot(robot)
    suffix = path.suffix.lower()
    readers = {".mat": _load_mat, ".npz": _load_npz, ".csv": _load_csv}
    if suffix not in readers:
        raise DemonstrationFileError(f"{path}: unknown suffix {suffix!r}; expected one of {sorted(readers)}")
    try:
        demos = readers[suffix](path, robot, smoothing)
    except (InvalidDemonstrationsError, InvalidObstacleError) as exc:
        raise DemonstrationFileError(f"{path}: {exc}") from None
    return _with_scenes(demos, scenes, str(path))


def _shown(path: Any) -> str:
    """A path or a list of paths as text for messages."""
    if isinstance(path, (list, tuple)):
        return ", ".join(str(p) for p in path)[:200]
    return str(path)


def _with_scenes(demos: Demonstrations, scenes: Sequence[Any] | None, source: str) -> Demonstrations:
    """``demos`` with each demonstration's obstacles from its scene (module docstring)."""
    if scenes is None:
        return demos
    scenes = as_sequence(scenes, "scenes", "one scene (a scene JSON path or a scenes.Scene) per "
                         "demonstration", ScenesTypeError)
    if len(scenes) != demos.M:
        raise DemonstrationFileError(f"scenes: expected one scene per demonstration of {source} "
                                     f"({demos.M}), got {len(scenes)}")
    loaded = [s if isinstance(s, Scene) else Scene.load(s) for s in scenes]
    out = Demonstrations(demos.positions, demos.velocities, demos.time,
                         [list(s.obstacles) for s in loaded], demos.name,
                         joint_positions=demos.joint_positions, joint_names=demos.joint_names,
                         orientations=demos.orientations)
    if hasattr(demos, "bag_split"):
        out.bag_split = demos.bag_split  # type: ignore[attr-defined]
    return out


def _load_mat(path: Path, robot: Any, smoothing: str) -> Demonstrations:
    import scipy.io                    # deferred: only MATLAB files need it
    try:
        data = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except Exception as exc:  # scipy raises several types for corrupt files
        raise DemonstrationFileError(f"{path}: not a readable MATLAB file ({exc})") from None
    if "dataset" in data:
        return _from_clamp(path, data, smoothing)
    if "smoothData" in data:
        return _from_tlgc(path, data, smoothing)
    keys = sorted(k for k in data if not k.startswith("__"))
    raise DemonstrationFileError(f"{path}: expected variable 'dataset' (CLAMP) or 'smoothData' (TLGC), "
                                 f"found {keys}")


def _field(path: Path, item: Any, index: int, field: str, required: bool = True) -> Any:
    """Field ``field`` of dataset(index + 1); an optional field that is absent or empty (a
    struct array element without it, as MATLAB stores it) is None."""
    if not required and hasattr(item, field) and np.size(getattr(item, field)) == 0:
        return None
    if not hasattr(item, field):
        if required:
            raise DemonstrationFileError(f"{path}: dataset({index + 1}) has no field '{field}'")
        return None
    return getattr(item, field)


def _numbers(path: Path, value: Any, name: str) -> np.ndarray:
    """A finite float array read from a file (DemonstrationFileError naming the file and field)."""
    return as_array(value, f"{path}: {name}", DemonstrationFileError, MAX_COORDINATE)


def _trajectory(path: Path, value: Any, name: str, length: int | None = None,
                rows: str = "T") -> np.ndarray:
    """A (T, 3) array read from a file (T = ``length`` when given), finite, |x| <= MAX_COORDINATE."""
    arr = _numbers(path, value, name)
    if arr.ndim != 2 or arr.shape[1] != 3 or (length is not None and len(arr) != length):
        expected = f"({length}, 3) like pos" if length is not None else f"({rows}, 3)"
        raise DemonstrationFileError(f"{path}: {name}: expected shape {expected}, got {arr.shape}")
    return arr


def _from_clamp(path: Path, data: dict[str, Any], smoothing: str) -> Demonstrations:
    entries = np.atleast_1d(data["dataset"])
    if entries.dtype != object or not all(hasattr(e, "_fieldnames") for e in entries):
        raise DemonstrationFileError(f"{path}: 'dataset' must be a struct array with fields pos, vel, time")
    dt = data.get("dt")
    positions, velocities, times, obstacles, rotations = [], [], [], [], []
    for m, item in enumerate(entries):
        where = f"dataset({m + 1})"
        pose = _field(path, item, m, "pose", required=False)
        if pose is not None:
            if _field(path, item, m, "pos", required=False) is not None:
                raise DemonstrationFileError(f"{path}: {where}: expected either 'pos' (with an "
                                             "optional 'quat_xyzw') or 'pose', got both")
            transforms = _numbers(path, pose, f"{where}.pose")
            if transforms.ndim == 2:                  # one sample: MATLAB squeezes (4,4,1)
                transforms = transforms[:, :, None]
            if transforms.ndim != 3 or transforms.shape[:2] != (4, 4):
                raise DemonstrationFileError(f"{path}: {where}.pose: expected shape (4, 4, T) "
                                             f"homogeneous transforms, got {transforms.shape}")
            transforms = np.moveaxis(transforms, -1, 0)
            pos, turns = _pose_parts(path, transforms, f"{where}.pose")
        else:
            pos = _trajectory(path, _field(path, item, m, "pos"), f"{where}.pos")
            turns = _field(path, item, m, "quat_xyzw", required=False)
            if turns is not None:
                turns = _quaternion_rows(path, turns, f"{where}.quat_xyzw", len(pos))
        vel = _field(path, item, m, "vel", required=False)
        if vel is not None:
            vel = _trajectory(path, vel, f"{where}.vel", len(pos))
        time = _field(path, item, m, "time", required=False)
        if time is None:
            if dt is None:
                raise DemonstrationFileError(f"{path}: {where} has neither 'time' nor a file-level 'dt'")
            step = _numbers(path, dt, "dt")
            if step.shape != () or not step > 0:
                raise DemonstrationFileError(f"{path}: dt: expected one positive number [s], got {dt!r:.60}")
            time = np.arange(len(pos)) * float(step)
        time = as_array(time, f"{path}: {where}.time", DemonstrationFileError).reshape(-1)
        obs = _field(path, item, m, "obs", required=False)
        boxes = []
        if obs is not None and np.size(obs):
            rows = np.atleast_2d(_numbers(path, obs, f"{where}.obs"))
            if rows.ndim != 2 or rows.shape[1] != 6:
                raise DemonstrationFileError(f"{path}: dataset({m + 1}).obs: expected shape (K, 6) "
                                             f"[cx,cy,cz,sx,sy,sz], got {rows.shape}")
            for k, row in enumerate(rows):
                try:
                    boxes.append(Box.from_reference(row))
                except InvalidObstacleError as exc:
                    raise DemonstrationFileError(f"{path}: dataset({m + 1}).obs row {k + 1}: {exc}") from None
        positions.append(pos)
        velocities.append(vel)
        times.append(time)
        obstacles.append(boxes)
        rotations.append(turns)
    has_obstacles = any(obstacles)
    return _assemble(positions, velocities, times, obstacles if has_obstacles else None, path.stem,
                     smoothing, _all_or_none(path, rotations, "dataset(m).quat_xyzw or pose"))


def _from_tlgc(path: Path, data: dict[str, Any], smoothing: str) -> Demonstrations:
    cells = np.atleast_1d(data["smoothData"])
    if cells.dtype != object:
        if cells.dtype.kind not in "fiu" or cells.ndim not in (2, 3):
            raise DemonstrationFileError(f"{path}: smoothData: expected a cell array of (N, 3) "
                                         f"position arrays, got {cells.dtype} of shape {cells.shape}")
        cells = cells[None] if cells.ndim == 2 else cells
    positions = [_trajectory(path, cell, f"smoothData{{{m + 1}}}", rows="N") for m, cell in enumerate(cells)]
    times = [np.linspace(0.0, NOMINAL_DURATION, len(p)) for p in positions]
    return _assemble(positions, [None] * len(positions), times, None, path.stem, smoothing)


def _check_recordings(positions: list[np.ndarray], times: list[np.ndarray]) -> None:
    """At least 2 recordings, each of >= 2 samples at strictly increasing times."""
    if len(positions) < 2:
        raise InvalidDemonstrationsError(f"expected at least 2 demonstrations, got {len(positions)}")
    for m, (p, t) in enumerate(zip(positions, times)):
        if len(p) < 2:
            raise InvalidDemonstrationsError(f"demonstrations[{m}]: has {len(p)} sample(s), "
                                             "expected at least 2 (a trajectory needs two time stamps)")
        as_time(t, f"demonstrations[{m}].time", len(p), InvalidDemonstrationsError)


def _quaternion_rows(path: Path, value: Any, name: str, length: int) -> np.ndarray:
    """A (T, 4) unit quaternion array (x, y, z, w) read from a file, T = ``length`` (the
    positions'); DemonstrationFileError naming the file, ``name`` and the sample otherwise."""
    arr = _numbers(path, value, name)
    if arr.ndim != 2 or arr.shape != (length, 4):
        raise DemonstrationFileError(f"{path}: {name}: expected shape ({length}, 4) quaternions "
                                     f"(x, y, z, w), one per position, got {arr.shape}")
    return unit_quaternions(arr, f"{path}: {name}", DemonstrationFileError)


def _pose_parts(path: Path, transforms: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, 3) [m] and quaternions (T, 4) (x, y, z, w) of homogeneous transforms
    (T, 4, 4); DemonstrationFileError naming the file and the sample when one is not a pose."""
    bottom = np.abs(transforms[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1)
    if np.any(bottom > 1e-6):
        k = int(np.argmax(bottom > 1e-6))
        raise DemonstrationFileError(f"{path}: {name}[{k}]: expected a homogeneous transform "
                                     f"(last row 0 0 0 1), got last row {transforms[k, 3].tolist()}")
    positions = _trajectory(path, transforms[:, :3, 3], f"{name} translation")
    return positions, quaternions_from_matrices(transforms[:, :3, :3], f"{path}: {name} rotation",
                                                DemonstrationFileError)


def _all_or_none(path: Path, rotations: list[np.ndarray | None], name: str) -> list[np.ndarray] | None:
    """The recordings' rotations when every one has them, None when none has; a file giving
    them for some demonstrations only is refused (DemonstrationFileError naming the first
    without)."""
    missing = [m for m, r in enumerate(rotations) if r is None]
    if len(missing) == len(rotations):
        return None
    if missing:
        raise DemonstrationFileError(f"{path}: {name}: the hand's rotation is recorded for some "
                                     f"demonstrations but not for demonstration {missing[0]}; "
                                     "expected it for all or none")
    return rotations  # type: ignore[return-value]


def _assemble(positions: list[np.ndarray], velocities: list[np.ndarray | None], times: list[np.ndarray],
              obstacles: list | None, name: str, smoothing: str,
              orientations: list[np.ndarray] | None = None) -> Demonstrations:
    """Demonstrations as they are when all share one time axis, else resampled; missing
    velocities estimated as ``smoothing`` says (positions smoothed alike); ``orientations``
    (T_m, 4) per recording checked as :mod:`scenes.quaternions` says (warnings naming ``name``,
    the file's stem, and the sample)."""
    _check_recordings(positions, times)
    positions, velocities = list(positions), list(velocities)
    for m, (p, v, t) in enumerate(zip(positions, velocities, times)):
        if v is None:
            positions[m], velocities[m] = smooth_trajectory(t, p, smoothing, f"{name}[{m}]")
    same_time = all(len(t) == len(times[0]) and np.array_equal(t, times[0]) for t in times)
    if same_time and all(len(p) == len(times[0]) for p in positions):
        turns = None if orientations is None else np.stack([
            checked_quaternions(o, times[0], f"orientations[{m}]", InvalidDemonstrationsError, name)
            for m, o in enumerate(orientations)])
        return Demonstrations(np.stack(positions), np.stack(velocities), times[0], obstacles, name,
                              orientations=turns)
    return Demonstrations.from_trajectories(positions, times, velocities=velocities,
                                            obstacles=obstacles, name=name,
                                            orientations=orientations)


def _needs_robot(path: Path, robot: Any, what: str) -> Any:
    if robot is None:
        raise DemonstrationFileError(f"{path}: {what} hold joint-space demonstrations; pass "
                                     "robot= (a robots.Robot, e.g. robots.load_robot('jaco')) "
                                     "whose forward kinematics gives the end-effector paths")
    return robot


#: the per-demonstration .npz fields (module docstring): demo<k>__<field>
NPZ_RECORDING_FIELDS = ("pos", "quat_xyzw", "pose", "t")


def _load_npz(path: Path, robot: Any, smoothing: str) -> Demonstrations:
    try:
        with np.load(path, allow_pickle=False) as data:
            joint = "joint_positions" in data.files and "positions" not in data.files
            arrays = {k: data[k] for k in ("joint_positions", "time", "joint_names")
                      if joint and k in data.files}
            recordings = {k: data[k] for k in data.files
                          if k.startswith("demo") and k.split("__")[-1] in NPZ_RECORDING_FIELDS}
            per_demonstration = "positions" not in data.files and not joint and bool(recordings)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise DemonstrationFileError(f"{path}: not a readable demonstrations .npz ({exc})") from None
    if per_demonstration:
        return _from_npz_recordings(path, recordings, smoothing)
    if not joint:
        return Demonstrations.load_npz(path)
    robot = _needs_robot(path, robot, "its arrays joint_positions, time, joint_names")
    missing = {"time", "joint_names"} - set(arrays)
    if missing:
        raise DemonstrationFileError(f"{path}: joint_positions without {sorted(missing)}; a "
                                     "joint-space .npz holds joint_positions (M, T, n) [rad], "
                                     "time (T,) [s] and joint_names (n,)")
    q = as_array(arrays["joint_positions"], f"{path}: joint_positions", DemonstrationFileError,
                 MAX_COORDINATE)
    names = [str(n) for n in np.atleast_1d(arrays["joint_names"])]
    if q.ndim != 3 or q.shape[2] != len(names):
        raise DemonstrationFileError(f"{path}: joint_positions: expected shape (M, T, "
                                     f"{len(names)}) (one column per joint name), got {q.shape}")
    order = column_order(names, robot, "joint_names")
    time = as_array(arrays["time"], f"{path}: time", DemonstrationFileError).reshape(-1)
    _check_recordings(list(q), [time] * len(q))
    return from_joint_trajectories(robot, list(q[:, :, order]), [time] * len(q), smoothing,
                                   path.stem)


def _from_npz_recordings(path: Path, arrays: dict[str, np.ndarray], smoothing: str) -> Demonstrations:
    """Demonstrations of a .npz holding one recording per demonstration: ``demo<k>__pos`` with
    ``demo<k>__quat_xyzw``, or ``demo<k>__pose``, and ``demo<k>__t`` (module docstring)."""
    labels = sorted({k.split("__")[0] for k in arrays})
    indices = sorted(int(label[4:]) for label in labels if label[4:].isdigit())
    if [f"demo{k}" for k in indices] != labels or indices != list(range(len(indices))):
        raise DemonstrationFileError(f"{path}: expected recordings demo0__*, demo1__*, ... numbered "
                                     f"from 0 without gaps, got {labels}")
    positions, times, rotations = [], [], []
    for k in indices:
        key = f"demo{k}__"
        if f"{key}pose" in arrays:
            if f"{key}pos" in arrays or f"{key}quat_xyzw" in arrays:
                raise DemonstrationFileError(f"{path}: {key}pose: expected either {key}pos (with "
                                             f"{key}quat_xyzw) or {key}pose, got both")
            transforms = _numbers(path, arrays[f"{key}pose"], f"{key}pose")
            if transforms.ndim != 3 or transforms.shape[1:] != (4, 4):
                raise DemonstrationFileError(f"{path}: {key}pose: expected shape (N, 4, 4) "
                                             f"homogeneous transforms, got {transforms.shape}")
            pos, turns = _pose_parts(path, transforms, f"{key}pose")
        elif f"{key}pos" in arrays:
            pos = _trajectory(path, arrays[f"{key}pos"], f"{key}pos", rows="N")
            turns = (None if f"{key}quat_xyzw" not in arrays else
                     _quaternion_rows(path, arrays[f"{key}quat_xyzw"], f"{key}quat_xyzw", len(pos)))
        else:
            raise DemonstrationFileError(f"{path}: demonstration {k}: expected {key}pos (N, 3) [m] "
                                         f"or {key}pose (N, 4, 4), got {sorted(a for a in arrays if a.startswith(key))}")
        if f"{key}t" in arrays:
            time = as_array(arrays[f"{key}t"], f"{path}: {key}t", DemonstrationFileError).reshape(-1)
        else:
            time = np.linspace(0.0, NOMINAL_DURATION, len(pos))
        positions.append(pos)
        times.append(time)
        rotations.append(turns)
    return _assemble(positions, [None] * len(positions), times, None, path.stem, smoothing,
                     _all_or_none(path, rotations, "demo<k>__quat_xyzw or demo<k>__pose"))


def _read_csv(path: Path) -> tuple[tuple[str, ...], np.ndarray]:
    """Header (names, quotes and spaces stripped) and the numbers (rows, columns) of a CSV
    file in UTF-8 with or without a byte-order mark."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            rows = [row for row in csv.reader(handle) if any(cell.strip() for cell in row)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DemonstrationFileError(f"{path}: not a readable text CSV file ({exc})") from None
    if not rows:
        raise DemonstrationFileError(f"{path}: empty; expected header {','.join(CSV_COLUMNS)}"
                                     f"[,{','.join(CSV_VELOCITY_COLUMNS)}] and data rows")
    header = tuple(cell.strip() for cell in rows[0])
    if len(rows) == 1:
        raise DemonstrationFileError(f"{path}: no data rows after the header")
    for k, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise DemonstrationFileError(f"{path}: line {k}: expected {len(header)} columns "
                                         f"like the header, got {len(row)}")
    try:
        table = np.array([[float(cell) for cell in row] for row in rows[1:]])
    except ValueError as exc:
        raise DemonstrationFileError(f"{path}: malformed CSV row ({exc})") from None
    return header, table


def _load_csv(path: Path, robot: Any, smoothing: str) -> Demonstrations:
    header, table = _read_csv(path)
    workspace = header in CSV_HEADERS
    positional = set(header[2:]) & set(CSV_COLUMNS[2:] + CSV_VELOCITY_COLUMNS
                                       + CSV_ORIENTATION_COLUMNS)
    if not workspace and positional:        # position columns, robot or not: say their header
        missing = [c for c in CSV_COLUMNS if c not in header]
        raise DemonstrationFileError(f"{path}: expected header {','.join(CSV_COLUMNS)}"
                                     f"[,{','.join(CSV_VELOCITY_COLUMNS)}]"
                                     f"[,{','.join(CSV_ORIENTATION_COLUMNS)}] for end-effector "
                                     f"positions, got {','.join(header)!r}"
                                     + (f" (missing {', '.join(missing)})" if missing else ""))
    if header[:2] != CSV_COLUMNS[:2] or (not workspace and robot is None):
        if header[:2] == CSV_COLUMNS[:2] and len(header) > 2 and "x" not in header:
            _needs_robot(path, robot, f"the columns {','.join(header[2:])!r}")
        raise DemonstrationFileError(f"{path}: expected header {','.join(CSV_COLUMNS)}"
                                     f"[,{','.join(CSV_VELOCITY_COLUMNS)}]"
                                     f"[,{','.join(CSV_ORIENTATION_COLUMNS)}] (or demo,t and one "
                                     f"column per joint with robot=), got {','.join(header)!r}")
    if not np.all(np.isfinite(table)):
        raise DemonstrationFileError(f"{path}: contains NaN/inf values")
    if np.any(table[:, 0] != np.round(table[:, 0])):
        raise DemonstrationFileError(f"{path}: column demo: expected integer labels")
    labels, first = np.unique(table[:, 0], return_index=True)
    order = labels[np.argsort(first)]
    groups = [table[table[:, 0] == label] for label in order]
    times = [g[:, 1] for g in groups]
    if not workspace:
        columns = 2 + column_order(header[2:], robot, "header")
        _check_recordings(groups, times)
        return from_joint_trajectories(robot, [g[:, columns] for g in groups], times,
                                       smoothing, path.stem)
    positions = [g[:, 2:5] for g in groups]
    velocities = [g[:, 5:8] if CSV_VELOCITY_COLUMNS[0] in header else None for g in groups]
    rotations = None
    if CSV_ORIENTATION_COLUMNS[0] in header:
        length, bad = off_unit(table[:, -4:])
        if bad.any():
            row = int(np.argmax(bad))
            raise DemonstrationFileError(
                f"{path}: line {row + 2} (demo {table[row, 0]:.0f}, t = {table[row, 1]:g} s): "
                f"{','.join(CSV_ORIENTATION_COLUMNS)}: expected a unit quaternion within "
                f"{QUATERNION_TOLERANCE:g} of length 1, got length {length[row]:.4g}")
        rotations = [g[:, -4:] for g in groups]
    return _assemble(positions, velocities, times, None, path.stem, smoothing, rotations)


def save_csv(demos: Demonstrations, path: str | Path) -> list[Path]:
    """Write demonstrations as CSV with columns demo,t,x,y,z,vx,vy,vz, and qx,qy,qz,qw when they
    carry the hand's rotation (the pose CSV; see module docstring).

    Demonstrations with recorded obstacles also get one scene file per demonstration,
    ``<stem>.scene<m>.json`` beside the CSV; returns their paths (empty without obstacles),
    in the order :func:`load_demonstrations` takes them as ``scenes``.
    """
    as_instance(demos, "demos", Demonstrations, "a scenes.Demonstrations", ScenesTypeError)
    path = as_path(path, "path", ScenesTypeError)
    scene_paths = []
    for m, group in enumerate(demos.obstacles or []):
        scene_paths.append(path.with_name(f"{path.stem}.scene{m}.json"))
        Scene(group).save(scene_paths[-1])
    M, T = demos.M, demos.T
    columns = [np.repeat(np.arange(M), T), np.tile(demos.time, M),
               demos.positions.reshape(-1, 3), demos.velocities.reshape(-1, 3)]
    header = CSV_COLUMNS + CSV_VELOCITY_COLUMNS
    if demos.orientations is not None:
        columns.append(demos.orientations.reshape(-1, 4))
        header += CSV_ORIENTATION_COLUMNS
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=",".join(header),
               comments="", fmt=["%d"] + ["%.17g"] * (len(header) - 1))
    return scene_paths
