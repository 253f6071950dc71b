"""Reading and writing demonstration files.

Formats (chosen by suffix, then by content):

* ``.mat`` CLAMP reference: struct array ``dataset`` with fields ``pos`` (T,3), ``vel`` (T,3),
  ``time`` (T,) and optional ``obs`` (K,6) boxes [cx,cy,cz,sx,sy,sz]; scalar ``dt``.
  Missing ``time`` becomes ``arange(T) * dt``; missing ``vel`` is estimated (below).
* ``.mat`` TLGC reference: cell array ``smoothData`` of (N,3) positions without time; time is
  ``linspace(0, NOMINAL_DURATION, N)`` (10 s), velocities estimated.
* ``.npz``: written by :meth:`Demonstrations.save_npz`; or joint space: ``joint_positions``
  (M,T,n) [rad], ``time`` (T,) [s], ``joint_names`` (n,) (needs ``robot=``).
* ``.csv``: header ``demo,t,x,y,z`` or ``demo,t,x,y,z,vx,vy,vz``, one row per sample; ``demo`` is
  an integer label (order of first appearance), ``t`` in seconds, positions in metres,
  velocities in m/s. Without velocity columns they are estimated. Joint space (kinesthetic
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
(:mod:`scenes.joint_demonstrations`) and keep their joint trajectories.

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
from .scene import Scene
from .smoothing import as_smoothing, smooth_trajectory
from skillplan.validation import MAX_COORDINATE, as_array, as_file, as_instance, as_path, as_sequence, as_time

CSV_COLUMNS = ("demo", "t", "x", "y", "z")
CSV_VELOCITY_COLUMNS = ("vx", "vy", "vz")


def load_demonstrations(path: str | Path | Sequence[str | Path], scenes: Sequence[Any] | None = None,
                        *, robot: Any = None, smoothing: str = "auto", topic: str | None = None,
                        split: str = "bag", frames: Sequence[str] | None = None) -> Demonstrations:
    """Read demonstrations from a .mat (CLAMP or TLGC), .npz or .csv file, or from ROS 2 bags.

    ROS 2 bags: ``path`` is a bag (its folder, or a bare .mcap / .db3 file) or a list of bags;
    ``topic`` (required), ``split`` ("bag" or "rest") and ``frames`` ((parent, child) for a /tf
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
    if split != "bag":
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
                         joint_positions=demos.joint_positions, joint_names=demos.joint_names)
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
    positions, velocities, times, obstacles = [], [], [], []
    for m, item in enumerate(entries):
        where = f"dataset({m + 1})"
        pos = _trajectory(path, _field(path, item, m, "pos"), f"{where}.pos")
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
    has_obstacles = any(obstacles)
    return _assemble(positions, velocities, times, obstacles if has_obstacles else None, path.stem,
                     smoothing)


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


def _assemble(positions: list[np.ndarray], velocities: list[np.ndarray | None], times: list[np.ndarray],
              obstacles: list | None, name: str, smoothing: str) -> Demonstrations:
    """Demonstrations as they are when all share one time axis, else resampled; missing
    velocities estimated as ``smoothing`` says (positions smoothed alike)."""
    _check_recordings(positions, times)
    positions, velocities = list(positions), list(velocities)
    for m, (p, v, t) in enumerate(zip(positions, velocities, times)):
        if v is None:
            positions[m], velocities[m] = smooth_trajectory(t, p, smoothing, f"{name}[{m}]")
    same_time = all(len(t) == len(times[0]) and np.array_equal(t, times[0]) for t in times)
    if same_time and all(len(p) == len(times[0]) for p in positions):
        return Demonstrations(np.stack(positions), np.stack(velocities), times[0], obstacles, name)
    return Demonstrations.from_trajectories(positions, times, velocities=velocities,
                                            obstacles=obstacles, name=name)


def _needs_robot(path: Path, robot: Any, what: str) -> Any:
    if robot is None:
        raise DemonstrationFileError(f"{path}: {what} hold joint-space demonstrations; pass "
                                     "robot= (a robots.Robot, e.g. robots.load_robot('jaco')) "
                                     "whose forward kinematics gives the end-effector paths")
    return robot


def _load_npz(path: Path, robot: Any, smoothing: str) -> Demonstrations:
    try:
        with np.load(path, allow_pickle=False) as data:
            joint = "joint_positions" in data.files and "positions" not in data.files
            arrays = {k: data[k] for k in ("joint_positions", "time", "joint_names")
                      if joint and k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise DemonstrationFileError(f"{path}: not a readable demonstrations .npz ({exc})") from None
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
    workspace = header in (CSV_COLUMNS, CSV_COLUMNS + CSV_VELOCITY_COLUMNS)
    if header[:2] != CSV_COLUMNS[:2] or (not workspace and robot is None):
        if header[:2] == CSV_COLUMNS[:2] and len(header) > 2 and "x" not in header:
            _needs_robot(path, robot, f"the columns {','.join(header[2:])!r}")
        raise DemonstrationFileError(f"{path}: expected header {','.join(CSV_COLUMNS)}"
                                     f"[,{','.join(CSV_VELOCITY_COLUMNS)}] (or demo,t and one "
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
    velocities = [g[:, 5:8] if len(header) == 8 else None for g in groups]
    return _assemble(positions, velocities, times, None, path.stem, smoothing)


def save_csv(demos: Demonstrations, path: str | Path) -> list[Path]:
    """Write demonstrations as CSV with columns demo,t,x,y,z,vx,vy,vz (see module docstring).

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
    table = np.column_stack([np.repeat(np.arange(M), T), np.tile(demos.time, M),
                             demos.positions.reshape(-1, 3), demos.velocities.reshape(-1, 3)])
    np.savetxt(path, table, delimiter=",", header=",".join(CSV_COLUMNS + CSV_VELOCITY_COLUMNS),
               comments="", fmt=["%d"] + ["%.17g"] * 7)
    return scene_paths
