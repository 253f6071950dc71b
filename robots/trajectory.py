"""Executable joint trajectories: the plan as a robot controller takes it.

:class:`JointTrajectory` is shaped like ROS ``trajectory_msgs/JointTrajectory``: joint names
(from the URDF, ``robot.joint_names``) and, per point, positions, velocities and accelerations
with a ``time_from_start``. Units: s, rad, rad/s, rad/s^2 (m, m/s, m/s^2 for prismatic joints;
the ``units`` header says which). A free-form ``verdict`` header carries what the planner
concluded (success, reasons, ...); a retimed trajectory's ``verdict["retiming"]`` records the
method and the velocity, acceleration and jerk limits it was made for
(:meth:`JointTrajectory.retiming_limits` reads them, also from files written before jerk limits
were recorded).

A plan's accelerations (:meth:`JointTrajectory.from_plan`; a retimed trajectory,
:func:`robots.retime`, carries its profile's exact ones) are finite differences of the velocity
samples over time,
:func:`finite_difference` (``numpy.gradient`` with ``edge_order=1``): second-order central
differences inside (also on uneven time steps), one-sided first-order differences at both
ends. Every value is a convex combination of the neighbouring difference quotients
``(v[i+1] - v[i]) / (t[i+1] - t[i])``, so it never exceeds the largest acceleration of any
smooth motion through the samples: a trajectory within acceleration limits stays within them
after this differencing.

Files: JSON (:meth:`JointTrajectory.to_json`, validated by the schema shipped in
``robots/schemas/joint_trajectory.schema.json``), CSV (:meth:`JointTrajectory.to_csv`,
one ``#``-line of JSON header, then one row per point) and the ROS 2
``trajectory_msgs/msg/JointTrajectory`` message as JSON (:meth:`JointTrajectory.to_ros2_json`,
schema ``robots/schemas/ros2_joint_trajectory.schema.json``: the message's fields only, times
as {sec, nanosec}). Floats are written with ``repr``
precision, so :meth:`JointTrajectory.load` gives back the same float64 values bit for bit.
Writes are atomic (a temporary file in the target folder, then ``os.replace`` / ``os.link``)
and refuse to overwrite an existing file unless ``overwrite=True``.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from skillplan import validation as _checks
from skillplan.command_line import atomic_write_text as _atomic_write_text

from .errors import RobotTypeError, TrajectoryError, TrajectoryExistsError, TrajectoryFileError

#: ``format`` field of every trajectory file; files from a later major version are refused.
FORMAT = "skillplan.joint_trajectory"
VERSION = 1
SCHEMA_PATH = Path(__file__).resolve().parent / "schemas" / "joint_trajectory.schema.json"
#: JSON schema of the ROS 2 ``trajectory_msgs/msg/JointTrajectory`` message as JSON (to_ros2_dict)
ROS2_SCHEMA_PATH = SCHEMA_PATH.with_name("ros2_joint_trajectory.schema.json")
_NANOSECONDS = 1_000_000_000
#: Units of revolute / continuous joints (prismatic joints: m, m/s, m/s^2).
DEFAULT_UNITS: dict[str, str] = {"time_from_start": "s", "positions": "rad", "velocities": "rad/s",
                                 "accelerations": "rad/s^2"}
_PRISMATIC_UNITS = {"positions": "m", "velocities": "m/s", "accelerations": "m/s^2"}
_CSV_MAGIC = "# " + FORMAT + " "
_FIELDS = ("positions", "velocities", "accelerations")


# --------------------------------------------------------------------------- helpers
def finite_difference(values: Any, time: Any) -> np.ndarray:
    """Time derivative of samples by finite differences: values (T, n) or (T,), time (T,) s.

    ``numpy.gradient(values, time, axis=0, edge_order=1)``: second-order central differences
    inside (exact for quadratics, also on uneven steps), first-order one-sided at the ends.
    Each result is a convex combination of adjacent difference quotients, so its magnitude is
    bounded by the largest derivative of any smooth curve through the samples. Needs T >= 2.
    """
    values = np.asarray(values, dtype=float)
    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or values.shape[:1] != time.shape or time.shape[0] < 2:
        raise TrajectoryError(f"values, time: expected values (T, ...) and time (T,) with T >= 2, "
                              f"got {values.shape} and {time.shape}")
    return np.gradient(values, time, axis=0, edge_order=1)


def interpolated_speed(positions: Any, velocities: Any, time: Any) -> np.ndarray:
    """Largest |velocity| (T-1, n) over each segment of the cubic Hermite interpolant of
    ``positions`` (T, n) with ``velocities`` (T, n) at ``time`` (T,) [s] (between support
    states the constant-velocity GP's interpolation, and what a trajectory controller given
    positions and velocities executes). The velocity along a segment is quadratic in time: its
    peak is at an end or at the vertex; it is at least the finite difference (the mean value
    theorem) and the ends' speeds."""
    q, qdot = np.asarray(positions, dtype=float), np.asarray(velocities, dtype=float)
    time = np.asarray(time, dtype=float)
    if q.ndim != 2 or qdot.shape != q.shape or time.shape != q.shape[:1] or len(time) < 2:
        raise TrajectoryError(f"positions, velocities, time: expected (T, n), (T, n) and (T,) "
                              f"with T >= 2, got {q.shape}, {qdot.shape} and {time.shape}")
    mean = np.diff(q, axis=0) / np.diff(time)[:, None]
    v0, v1 = qdot[:-1], qdot[1:]
    a = 3.0 * (v0 + v1) - 6.0 * mean           # v(s) = a s^2 + b s + v0, s in [0, 1]
    b = 6.0 * mean - 4.0 * v0 - 2.0 * v1
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.clip(np.where(a != 0.0, -b / (2.0 * a), 0.0), 0.0, 1.0)
    inside = np.abs((a * vertex + b) * vertex + v0)
    return np.maximum(np.maximum(np.abs(v0), np.abs(v1)), inside)


def _as_matrix(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    return _checks.as_shaped(value, name, shape, TrajectoryError).copy()


def _check_time(time: Any, name: str) -> np.ndarray:
    return _checks.as_time(time, name, error=TrajectoryError).copy()


def _jsonable(value: Any, where: str) -> Any:
    """Plain JSON data from a verdict: numpy scalars/arrays become Python numbers/lists."""
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise TrajectoryError(f"{where}: keys must be strings, got {key!r}")
            out[key] = _jsonable(item, f"{where}[{key!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [_jsonable(item, f"{where}[{i}]") for i, item in enumerate(value)]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist(), where)
    if isinstance(value, np.generic):
        return _jsonable(value.item(), where)
    if isinstance(value, float) and not math.isfinite(value):
        raise TrajectoryError(f"{where}: non-finite number {value!r} cannot be written to JSON")
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TrajectoryError(f"{where}: expected JSON data (dict, list, str, number, bool, None), "
                          f"got {type(value).__name__}")


def joint_units(kinds: Sequence[str]) -> dict[str, str | list[str]]:
    """Units header for joints of the given kinds ("revolute", "continuous", "prismatic"):
    one string per field when all joints share it, else one entry per joint."""
    units: dict[str, str | list[str]] = {"time_from_start": "s"}
    for name in _FIELDS:
        per_joint = [_PRISMATIC_UNITS[name] if kind == "prismatic" else DEFAULT_UNITS[name] for kind in kinds]
        units[name] = per_joint[0] if len(set(per_joint)) == 1 else per_joint
    return units


def atomic_write_text(path: str | Path, text: str, overwrite: bool = False,
                      exists_error: Callable[[str], Exception] | None = None) -> Path:
    """Write `text` (UTF-8) to `path` atomically (:func:`skillplan.command_line.atomic_write`);
    ``exists_error(message)`` builds the error for an existing target (default
    TrajectoryExistsError), a missing folder raises TrajectoryFileError."""
    return _atomic_write_text(path, text, overwrite, exists_error or TrajectoryExistsError, TrajectoryFileError)


def load_schema(ros2: bool = False) -> dict[str, Any]:
    """The JSON schema (draft 2020-12) that trajectory JSON files validate against (``ros2``:
    the one of the ROS 2 message shape, :meth:`JointTrajectory.to_ros2_dict`)."""
    return json.loads((ROS2_SCHEMA_PATH if ros2 else SCHEMA_PATH).read_text(encoding="utf-8"))


def ros2_duration(seconds: float) -> dict[str, int]:
    """``builtin_interfaces/Duration`` of a time >= 0 s: {"sec", "nanosec"}, rounded to 1 ns."""
    total = int(round(float(seconds) * _NANOSECONDS))
    return {"sec": total // _NANOSECONDS, "nanosec": total % _NANOSECONDS}


def _ros2_seconds(value: Any, where: str) -> float:
    """Seconds of a {"sec", "nanosec"} object (TrajectoryFileError naming ``where`` otherwise)."""
    ok = isinstance(value, dict) and set(value) == {"sec", "nanosec"} and all(
        isinstance(value[k], int) and not isinstance(value[k], bool) for k in ("sec", "nanosec"))
    if not ok or not 0 <= value["nanosec"] < _NANOSECONDS:
        raise TrajectoryFileError(f"{where}: expected {{\"sec\": int, \"nanosec\": 0..999999999}}, got {value!r}")
    return value["sec"] + value["nanosec"] / _NANOSECONDS


# --------------------------------------------------------------------------- the trajectory
@dataclass(frozen=True)
class RetimingLimits:
    """The limits a retimed trajectory was made for, from its ``verdict["retiming"]``
    (:func:`robots.retime`): method ("uniform", "toppra", "ruckig"); velocity (n,) rad/s,
    acceleration (n,) rad/s^2 and jerk (n,) rad/s^3 limits, None where the file records none
    (jerk: not limited, or a file written before jerk limits were recorded)."""

    method: str
    velocity: np.ndarray | None
    acceleration: np.ndarray | None
    jerk: np.ndarray | None


def _recorded_limits(record: Mapping[str, Any], key: str, n: int) -> np.ndarray | None:
    """Limits (n,) recorded under ``key`` of a verdict's "retiming" entry, None when absent."""
    value = record.get(key)
    if value is None:
        return None
    array = _float_array(value, f"verdict['retiming'][{key!r}]")
    if array.shape != (n,):
        raise TrajectoryError(f"verdict['retiming'][{key!r}]: expected {n} limits, got shape {array.shape}")
    return array


@dataclass(frozen=True, eq=False)
class JointTrajectory:
    """A time-stamped joint trajectory, like ROS ``trajectory_msgs/JointTrajectory``.

    joint_names (n,) from the URDF; time_from_start (T,) s, strictly increasing, >= 0;
    positions, velocities, accelerations (T, n) in rad, rad/s, rad/s^2 (see ``units``);
    robot: robot name; urdf: URDF source path (str) or None; units: unit of each field
    (a string, or one per joint); verdict: free-form JSON header (success, reasons, ...).
    Arrays are copied and made read-only.
    """

    joint_names: tuple[str, ...]
    time_from_start: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    robot: str = ""
    urdf: str | None = None
    units: dict[str, Any] = field(default_factory=lambda: dict(DEFAULT_UNITS))
    verdict: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = self.joint_names
        if isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise TrajectoryError(f"joint_names: expected a sequence of str, got {names!r}")
        names = tuple(names)
        if len(names) == 0 or len(set(names)) != len(names):
            raise TrajectoryError(f"joint_names: expected at least one name and no duplicates, got {names!r}")
        time = _check_time(self.time_from_start, "time_from_start")
        if time[0] < 0.0:
            raise TrajectoryError(f"time_from_start: expected values >= 0 s, got {time[0]!r}")
        shape = (time.shape[0], len(names))
        arrays = {name: _as_matrix(getattr(self, name), name, shape) for name in _FIELDS}
        if not isinstance(self.robot, str):
            raise TrajectoryError(f"robot: expected a str, got {type(self.robot).__name__}")
        if self.urdf is not None and not isinstance(self.urdf, (str, os.PathLike)):
            raise TrajectoryError(f"urdf: expected a path (str) or None, got {type(self.urdf).__name__}")
        units = _jsonable(dict(self.units), "units")
        for key in ("time_from_start",) + _FIELDS:
            unit = units.get(key)
            ok = isinstance(unit, str) or (key != "time_from_start" and isinstance(unit, list)
                                           and len(unit) == len(names) and all(isinstance(u, str) for u in unit))
            if not ok:
                raise TrajectoryError(f"units[{key!r}]: expected a unit string"
                                      f"{'' if key == 'time_from_start' else ' or one per joint'}, got {unit!r}")
        verdict = _jsonable(dict(self.verdict), "verdict")
        for array in (time, *arrays.values()):
            array.setflags(write=False)
        setter = object.__setattr__
        setter(self, "joint_names", names)
        setter(self, "time_from_start", time)
        for name, array in arrays.items():
            setter(self, name, array)
        setter(self, "urdf", None if self.urdf is None else str(self.urdf))
        setter(self, "units", units)
        setter(self, "verdict", verdict)

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.joint_names)

    @property
    def num_points(self) -> int:
        """Number of points T."""
        return int(self.time_from_start.shape[0])

    @property
    def duration(self) -> float:
        """Execution time [s]: last time_from_start."""
        return float(self.time_from_start[-1])

    def retiming_limits(self) -> RetimingLimits | None:
        """The method and limits this trajectory was retimed for (verdict["retiming"]), or None
        when it was not retimed; older files without jerk limits read with ``jerk`` None.
        TrajectoryError when the record is malformed."""
        record = self.verdict.get("retiming")
        if record is None:
            return None
        if not isinstance(record, Mapping) or not isinstance(record.get("method"), str):
            raise TrajectoryError("verdict['retiming']: expected an object with a 'method' (str)")
        return RetimingLimits(record["method"], *(_recorded_limits(record, key, self.n) for key in
                                                  ("velocity_limits", "acceleration_limits", "jerk_limits")))

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_plan(cls, robot, time: Any, q: Any, qdot: Any,
                  verdict: Mapping[str, Any] | None = None) -> "JointTrajectory":
        """Trajectory of a plan for `robot` (a robots.Robot): time (T,) s, q, qdot (T, n).

        time_from_start = time - time[0]; accelerations = finite_difference(qdot, time)
        (see the module docstring). joint_names, robot name, URDF path and units come from
        the robot; verdict is a JSON-ready dict (e.g. {"success": ..., "reasons": [...]}).
        """
        if not all(hasattr(robot, a) for a in ("n", "joint_names", "name")):
            raise RobotTypeError(f"robot: expected a robots.Robot (n, joint_names, name), got "
                                    f"{type(robot).__name__} {robot!r:.40}")
        n = int(robot.n)
        time = _check_time(time, "time")
        q = _as_matrix(q, "q", (time.shape[0], n))
        qdot = _as_matrix(qdot, "qdot", (time.shape[0], n))
        kinds = getattr(getattr(robot, "chain", None), "kinds", ("revolute",) * n)
        urdf = getattr(robot, "urdf_path", None)
        return cls(joint_names=tuple(robot.joint_names), time_from_start=time - time[0], positions=q,
                   velocities=qdot, accelerations=finite_difference(qdot, time), robot=str(robot.name),
                   urdf=None if urdf is None else str(urdf), units=joint_units(kinds),
                   verdict=dict(verdict or {}))

    def replace(self, **changes: Any) -> "JointTrajectory":
        """A copy with some fields changed (validated again)."""
        fields = {name: getattr(self, name) for name in ("joint_names", "time_from_start", "positions",
                                                        "velocities", "accelerations", "robot", "urdf",
                                                        "units", "verdict")}
        fields.update(changes)
        return JointTrajectory(**fields)

    # ------------------------------------------------------------------------ JSON
    def header(self) -> dict[str, Any]:
        """Everything but the points: robot, urdf, units, verdict."""
        return {"robot": self.robot, "urdf": self.urdf, "units": self.units, "verdict": self.verdict}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict in the file layout (see the schema)."""
        points = [{"positions": p, "velocities": v, "accelerations": a, "time_from_start": t}
                  for p, v, a, t in zip(self.positions.tolist(), self.velocities.tolist(),
                                        self.accelerations.tolist(), self.time_from_start.tolist())]
        return {"format": FORMAT, "version": VERSION, "header": self.header(),
                "joint_names": list(self.joint_names), "points": points}

    @classmethod
    def from_dict(cls, data: Any, source: str = "data") -> "JointTrajectory":
        """Inverse of to_dict; TrajectoryFileError names what is missing or malformed."""
        if not isinstance(data, dict):
            raise TrajectoryFileError(f"{source}: expected a JSON object, got {type(data).__name__}")
        _check_format(data.get("format"), data.get("version"), source)
        header = data.get("header")
        names = data.get("joint_names")
        points = data.get("points")
        if not isinstance(header, dict) or not isinstance(names, list) or not isinstance(points, list):
            raise TrajectoryFileError(f"{source}: expected fields 'header' (object), 'joint_names' and "
                                      "'points' (arrays)")
        try:
            columns = {key: [point[key] for point in points] for key in ("time_from_start",) + _FIELDS}
        except (KeyError, TypeError) as exc:
            raise TrajectoryFileError(f"{source}: every point needs time_from_start, positions, velocities "
                                      f"and accelerations ({exc!r} missing)") from None
        try:
            return cls(joint_names=tuple(names), robot=header.get("robot", ""), urdf=header.get("urdf"),
                       units=header.get("units", dict(DEFAULT_UNITS)), verdict=header.get("verdict", {}),
                       **{key: _float_array(value, f"{source}: {key}") for key, value in columns.items()})
        except TrajectoryFileError:
            raise
        except TrajectoryError as exc:
            raise TrajectoryFileError(f"{source}: {exc}") from None

    def to_json(self, path: str | Path, overwrite: bool = False, indent: int | None = None) -> Path:
        """Write the JSON file (atomic; TrajectoryExistsError if it exists and not overwrite)."""
        text = json.dumps(self.to_dict(), indent=indent, allow_nan=False) + "\n"
        return atomic_write_text(path, text, overwrite)

    # ----------------------------------------------------------------- ROS 2 message
    def to_ros2_dict(self, frame_id: str = "") -> dict[str, Any]:
        """The trajectory as a ROS 2 ``trajectory_msgs/msg/JointTrajectory`` message in JSON form
        (the fields of the message, nothing else; schema ``ROS2_SCHEMA_PATH``): header (stamp
        0 = start on receipt, frame_id), joint_names, points with positions, velocities,
        accelerations, effort (empty: not commanded) and time_from_start {sec, nanosec}
        (rounded to 1 ns). Robot, URDF, units and verdict stay in the skillplan format."""
        if not isinstance(frame_id, str):
            raise RobotTypeError(f"frame_id: expected a str, got {type(frame_id).__name__}")
        points = [{"positions": p, "velocities": v, "accelerations": a, "effort": [],
                   "time_from_start": ros2_duration(t)}
                  for p, v, a, t in zip(self.positions.tolist(), self.velocities.tolist(),
                                        self.accelerations.tolist(), self.time_from_start.tolist())]
        return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame_id},
                "joint_names": list(self.joint_names), "points": points}

    def to_ros2_json(self, path: str | Path, overwrite: bool = False, frame_id: str = "") -> Path:
        """Write :meth:`to_ros2_dict` as JSON (atomic; TrajectoryExistsError if it exists and not
        overwrite); ``ros2 topic pub`` / a rclpy node fill the message from it field by field."""
        text = json.dumps(self.to_ros2_dict(frame_id), allow_nan=False) + "\n"
        return atomic_write_text(path, text, overwrite)

    @classmethod
    def from_ros2_dict(cls, data: Any, source: str = "data") -> "JointTrajectory":
        """A trajectory from a ROS 2 JointTrajectory message in JSON form (inverse of
        to_ros2_dict, times to 1 ns; every point needs positions, velocities and accelerations;
        robot and URDF unknown, units rad / rad/s / rad/s^2)."""
        if not isinstance(data, dict) or not isinstance(data.get("header"), dict) \
                or not isinstance(data.get("joint_names"), list) or not isinstance(data.get("points"), list):
            raise TrajectoryFileError(f"{source}: expected a ROS 2 JointTrajectory object with 'header', "
                                      "'joint_names' and 'points'")
        names, points = data["joint_names"], data["points"]
        columns: dict[str, list[Any]] = {key: [] for key in ("time_from_start",) + _FIELDS}
        for i, point in enumerate(points):
            if not isinstance(point, dict):
                raise TrajectoryFileError(f"{source}: points[{i}]: expected an object, got {type(point).__name__}")
            columns["time_from_start"].append(_ros2_seconds(point.get("time_from_start"),
                                                            f"{source}: points[{i}].time_from_start"))
            for key in _FIELDS:
                value = point.get(key)
                if not isinstance(value, list) or len(value) != len(names):
                    raise TrajectoryFileError(f"{source}: points[{i}].{key}: expected {len(names)} values "
                                              f"(one per joint name), got {value!r:.60}")
                columns[key].append(value)
        try:
            return cls(joint_names=tuple(names),
                       **{key: _float_array(value, f"{source}: {key}") for key, value in columns.items()})
        except TrajectoryFileError:
            raise
        except TrajectoryError as exc:
            raise TrajectoryFileError(f"{source}: {exc}") from None

    # ------------------------------------------------------------------------- CSV
    def csv_columns(self) -> list[str]:
        """CSV column names: time_from_start, then position:/velocity:/acceleration:<joint>."""
        columns = ["time_from_start"]
        for prefix in ("position", "velocity", "acceleration"):
            columns.extend(f"{prefix}:{name}" for name in self.joint_names)
        return columns

    def to_csv(self, path: str | Path, overwrite: bool = False) -> Path:
        """Write the CSV file (atomic; TrajectoryExistsError if it exists and not overwrite).

        Line 1: ``# skillplan.joint_trajectory {json}`` with format, version, header and
        joint_names; line 2: column names; then one row per point, floats in repr precision.
        """
        meta = {"format": FORMAT, "version": VERSION, "header": self.header(), "joint_names": list(self.joint_names)}
        buffer = io.StringIO()
        buffer.write(_CSV_MAGIC + json.dumps(meta, allow_nan=False) + "\n")
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(self.csv_columns())
        table = np.column_stack((self.time_from_start, self.positions, self.velocities, self.accelerations))
        for row in table.tolist():
            writer.writerow([repr(value) for value in row])
        return atomic_write_text(path, buffer.getvalue(), overwrite)

    @classmethod
    def _from_csv_text(cls, text: str, source: str) -> "JointTrajectory":
        first, _, rest = text.partition("\n")
        if not first.startswith(_CSV_MAGIC):
            raise TrajectoryFileError(f"{source}: first line must start with {_CSV_MAGIC.strip()!r}")
        try:
            meta = json.loads(first[len(_CSV_MAGIC):])
        except json.JSONDecodeError as exc:
            raise TrajectoryFileError(f"{source}: header line is not valid JSON: {exc}") from None
        if not isinstance(meta, dict):
            raise TrajectoryFileError(f"{source}: header line must hold a JSON object")
        _check_format(meta.get("format"), meta.get("version"), source)
        names, header = meta.get("joint_names"), meta.get("header")
        if not isinstance(names, list) or not isinstance(header, dict):
            raise TrajectoryFileError(f"{source}: header line needs 'joint_names' (array) and 'header' (object)")
        rows = list(csv.reader(io.StringIO(rest)))
        if not rows:
            raise TrajectoryFileError(f"{source}: missing the column-name line")
        n = len(names)
        expected = ["time_from_start"] + [f"{p}:{name}" for p in ("position", "velocity", "acceleration")
                                          for name in names]
        if rows[0] != expected:
            raise TrajectoryFileError(f"{source}: expected columns {expected}, got {rows[0]}")
        body = [row for row in rows[1:] if row]
        table = _float_array(body, f"{source}: rows") if body else np.zeros((0, 1 + 3 * n))
        if table.ndim != 2 or table.shape[1] != 1 + 3 * n:
            raise TrajectoryFileError(f"{source}: expected {1 + 3 * n} values per row")
        try:
            return cls(joint_names=tuple(names), time_from_start=table[:, 0], positions=table[:, 1:1 + n],
                       velocities=table[:, 1 + n:1 + 2 * n], accelerations=table[:, 1 + 2 * n:],
                       robot=header.get("robot", ""), urdf=header.get("urdf"),
                       units=header.get("units", dict(DEFAULT_UNITS)), verdict=header.get("verdict", {}))
        except TrajectoryError as exc:
            raise TrajectoryFileError(f"{source}: {exc}") from None

    # ------------------------------------------------------------------------ load
    @classmethod
    def load(cls, path: str | Path) -> "JointTrajectory":
        """Read a trajectory written by to_json, to_csv or to_ros2_json (format from the content)."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise TrajectoryFileError(f"path: trajectory file {str(path)!r} does not exist") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise TrajectoryFileError(f"path: cannot read {str(path)!r}: {exc}") from None
        source = str(path)
        if text.startswith(_CSV_MAGIC):
            return cls._from_csv_text(text, source)
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise TrajectoryFileError(f"{source}: neither a trajectory CSV (first line {_CSV_MAGIC.strip()!r}) "
                                      f"nor valid JSON: {exc}") from None
        if isinstance(data, dict) and "format" not in data and isinstance(data.get("header"), dict) \
                and "stamp" in data["header"]:
            return cls.from_ros2_dict(data, source)
        return cls.from_dict(data, source)

    def __repr__(self) -> str:
        return (f"JointTrajectory(robot={self.robot!r}, n={self.n}, points={self.num_points}, "
                f"duration={self.duration:.3f} s)")


def _float_array(value: Any, where: str) -> np.ndarray:
    try:
        return np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TrajectoryFileError(f"{where}: expected numbers in a rectangular table: {exc}") from None


def _check_format(fmt: Any, version: Any, source: str) -> None:
    if fmt != FORMAT:
        raise TrajectoryFileError(f"{source}: expected format {FORMAT!r}, got {fmt!r}")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= VERSION:
        raise TrajectoryFileError(f"{source}: expected version 1..{VERSION}, got {version!r}")


def load_trajectory(path: str | Path) -> JointTrajectory:
    """Read a JSON or CSV trajectory file (same as JointTrajectory.load)."""
    return JointTrajectory.load(path)
