"""Planning problems as plain data: one JSON object per problem, exact round trip, content hash.

A :class:`Problem` says everything :func:`clamp.plan` needs, by reference or inline, so it can
be stored in a file, sent to another process or machine and kept next to its result::

    {"format": "clamp-problem", "version": 1,
     "id": "box_closing/jaco/0007",
     "prior": {"skill": "box_closing", "seed": 0, "num_demos": 6, "num_points": 250},
     "robot": {"name": "jaco"},
     "scene": {"obstacles": [{"type": "box", "center": [0.3, -0.4, 0.2], "size": [0.05, 0.05, 0.05]}]},
     "start": [0.2054, -0.4722, 0.2625], "goal": null, "via_points": [],
     "config": {"sigma_obs": 0.005}, "expected": null, "meta": {}}

- ``prior``: ``{"file": "prior.npz"}`` (a saved prior: ``clamp learn``, ``WorkspacePrior.save``;
  ``{"path": ...}`` is read the same), ``{"demos": "d.npz"}`` (a
  demonstration file, learned with ``learn_prior``) or ``{"skill": NAME, "seed": S,
  "num_demos": M, "num_points": T}`` (``scenes.make_demonstrations``; defaults 0, 6, 250);
- ``robot``: ``{"name": "jaco"}`` (``robots.load_robot``; the string ``"jaco"`` is read as
  that) or ``{"urdf": PATH, "end_effector": FRAME, "base_frame": FRAME | null}``, optionally
  with ``"package_dirs": [DIR, ...]`` (folders of package:// meshes) and ``"spheres": FILE``
  (a collision sphere file) (``Robot.from_urdf``); both loaded by ``robots.resolve_robot``, as the command lines' robots;
- ``scene``: null, a scene object in the scene-file format of :mod:`scenes.scene`, or the path
  of a scene file;
- ``start``, ``goal``: an end-effector position [x, y, z] (m) or a joint configuration (n,)
  (rad), goal null for none; the goal may be a pose ``{"position": [x, y, z], "quaternion":
  [qx, qy, qz, qw]}`` (a unit quaternion, x y z w as ROS ``geometry_msgs/Quaternion``; only for
  a prior learned with orientation); ``via_points``: [[index, [..]], ...];
- ``config``: planner settings by field name, as ``PlannerConfig().with_(**config)`` takes them
  (a file naming a setting issue 36 removed is refused when planned, with where it went:
  ``clamp.config.REMOVED``);
- ``expected``: null, ``"feasible"`` or ``"impossible"`` (a benchmark's label: e.g. an obstacle
  over the start); ``meta``: free JSON data (what generated the problem), kept with the result.

Relative paths are resolved against a base folder given when the problem is planned (the
problems file's folder for ``clamp batch``). :attr:`Problem.hash` is the SHA-256 of the
canonical JSON of the whole problem (id included: two problems with the same content under
different ids are two problems); a file named by path enters the hash by its path, not its
content. Reading checks the structure (field names and types, ids); values (a NaN start, an
unknown robot, a malformed scene) are checked when the problem is planned, so one bad problem
is recorded with its error instead of stopping a batch.
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from clamp.errors import ClampTypeError, ClampError
from clamp.validation import as_bool
from skillplan.validation import as_file, as_path, as_sequence, unknown_names
from skillplan.command_line import atomic_write_text

FORMAT = "clamp-problem"
VERSION = 1
EXPECTED = (None, "feasible", "impossible")
_FIELDS = ("format", "version", "id", "prior", "robot", "scene", "start", "goal", "via_points",
           "config", "expected", "meta")
#: the forms of a problem's prior: a saved prior ("file", or "path" as written before), a
#: demonstration file to learn from, a synthetic skill
_PRIOR_KINDS = {"file": (), "path": (), "demos": (), "skill": ("seed", "num_demos", "num_points")}
_SKILL_DEFAULTS = {"seed": 0, "num_demos": 6, "num_points": 250}


class ProblemFormatError(ClampError):
    """A planning problem (or a problems file) whose structure is not the documented format."""


class _Frozen(tuple):
    """A JSON object kept immutable: a tuple of (key, value) pairs that thaws back to a dict."""


def _freeze(value: Any) -> Any:
    """JSON data as immutable values (objects -> _Frozen, keeping their key order; lists -> tuples)."""
    if isinstance(value, Mapping):
        return _Frozen((str(k), _freeze(v)) for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return tuple(_freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    """Inverse of :func:`_freeze`: plain dicts and lists."""
    if isinstance(value, _Frozen):
        return {k: _thaw(v) for k, v in value}
    if isinstance(value, tuple):
        return [_thaw(v) for v in value]
    return value


def _numbers(value: Any, where: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise ProblemFormatError(f"{where}: expected a list of numbers, got {value!r}")
    return tuple(float(v) for v in value)


def _object(value: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ProblemFormatError(f"{where}: expected a JSON object, got {type(value).__name__}")
    return value


#: the fields of a goal pose, and how many numbers each holds
GOAL_POSE = {"position": 3, "quaternion": 4}


def _goal(value: Any, where: str) -> tuple[float, ...] | _Frozen:
    """A goal: a list of numbers (a position or a configuration), or a pose object
    ``{"position": [x, y, z], "quaternion": [qx, qy, qz, qw]}`` (its values, such as the
    quaternion's length, are checked when planned)."""
    if not isinstance(value, Mapping):
        return _numbers(value, where)
    if set(value) != set(GOAL_POSE):
        raise ProblemFormatError(f"{where}: expected a pose {{\"position\": [x, y, z], "
                                 f"\"quaternion\": [qx, qy, qz, qw]}}, got fields {sorted(value)}")
    pose = {}
    for key, size in GOAL_POSE.items():
        pose[key] = _numbers(value[key], f"{where}.{key}")
        if len(pose[key]) != size:
            raise ProblemFormatError(f"{where}.{key}: expected {size} numbers, got "
                                     f"{len(pose[key])}: {list(pose[key])}")
    return _freeze(pose)


def _prior_spec(value: Any, where: str) -> _Frozen:
    spec = dict(_object(value, where))
    kinds = [k for k in _PRIOR_KINDS if k in spec]
    if len(kinds) != 1:
        raise ProblemFormatError(f"{where}: expected exactly one of 'file' (prior .npz), 'demos' "
                                 f"(demonstration file) or 'skill' (synthetic skill), got "
                                 f"{sorted(spec)}")
    kind = kinds[0]
    extra = spec.keys() - {kind, *_PRIOR_KINDS[kind]}
    if extra:
        raise ProblemFormatError(f"{where}: unknown field(s) "
                                 f"{unknown_names(extra, {kind, *_PRIOR_KINDS[kind]})} for a {kind!r} prior")
    if not isinstance(spec[kind], str) or not spec[kind]:
        raise ProblemFormatError(f"{where}.{kind}: expected a non-empty string, got {spec[kind]!r}")
    if kind == "skill":
        spec = {"skill": spec["skill"], **{k: spec.get(k, d) for k, d in _SKILL_DEFAULTS.items()}}
        for key in _SKILL_DEFAULTS:
            if not isinstance(spec[key], int) or isinstance(spec[key], bool):
                raise ProblemFormatError(f"{where}.{key}: expected an integer, got {spec[key]!r}")
    return _freeze(spec)


def _robot_spec(value: Any, where: str) -> _Frozen:
    if isinstance(value, str):
        value = {"name": value}
    spec = dict(_object(value, where))
    if "name" in spec:
        if set(spec) != {"name"} or not isinstance(spec["name"], str):
            raise ProblemFormatError(f"{where}: expected {{'name': NAME}} for a built-in robot, "
                                     f"got {spec!r}")
        return _freeze(spec)
    if "urdf" not in spec or "end_effector" not in spec:
        raise ProblemFormatError(f"{where}: expected {{'name': NAME}} or {{'urdf': PATH, "
                                 f"'end_effector': FRAME}}, got fields {sorted(spec)}")
    extra = spec.keys() - {"urdf", "end_effector", "base_frame", "package_dirs", "spheres"}
    if extra:
        raise ProblemFormatError(f"{where}: unknown field(s) "
                                 f"{unknown_names(extra, ('urdf', 'end_effector', 'base_frame'))}")
    spec.setdefault("base_frame", None)
    for key in ("urdf", "end_effector"):
        if not isinstance(spec[key], str) or not spec[key]:
            raise ProblemFormatError(f"{where}.{key}: expected a non-empty string, got {spec[key]!r}")
    for key in ("base_frame", "spheres"):
        if spec.get(key) is not None and not isinstance(spec[key], str):
            raise ProblemFormatError(f"{where}.{key}: expected a string or null, got {spec[key]!r}")
    folders = spec.get("package_dirs", [])
    if not isinstance(folders, (list, tuple)) or not all(isinstance(f, str) and f for f in folders):
        raise ProblemFormatError(f"{where}.package_dirs: expected a list of folder paths, got {folders!r}")
    # the optional fields only when given: problems without them read and write as before
    optional = [key for key in ("package_dirs", "spheres") if spec.get(key)]
    return _freeze({k: spec[k] for k in ("urdf", "end_effector", "base_frame", *optional)})


@dataclass(frozen=True)
class Problem:
    """One planning problem as plain data (see the module docstring for every field).

    Build one with :meth:`from_dict` (or :func:`make_problem`), vary it with
    :meth:`replace`; ``to_dict`` / ``to_json`` / ``from_json`` round-trip it exactly.
    """

    id: str
    prior: Any
    robot: Any
    start: tuple[float, ...]
    scene: Any = None
    goal: tuple[float, ...] | _Frozen | None = None
    via_points: tuple[tuple[int, tuple[float, ...]], ...] = ()
    config: Any = field(default_factory=_Frozen)
    expected: str | None = None
    meta: Any = field(default_factory=_Frozen)

    # ------------------------------------------------------------------- conversion
    def to_dict(self) -> dict[str, Any]:
        """The JSON object of this problem (plain dicts and lists)."""
        scene = self.scene if self.scene is None or isinstance(self.scene, str) else _thaw(self.scene)
        return {"format": FORMAT, "version": VERSION, "id": self.id, "prior": _thaw(self.prior),
                "robot": _thaw(self.robot), "scene": scene, "start": list(self.start),
                "goal": None if self.goal is None else _thaw(self.goal) if isinstance(
                    self.goal, _Frozen) else list(self.goal),
                "via_points": [[i, list(v)] for i, v in self.via_points],
                "config": _thaw(self.config), "expected": self.expected, "meta": _thaw(self.meta)}

    def to_json(self) -> str:
        """One line of JSON (no newline); NaN / inf written as JavaScript literals."""
        return json.dumps(self.to_dict(), separators=(", ", ": "))

    @classmethod
    def from_json(cls, text: str, source: str = "problem") -> "Problem":
        """A problem from one line of JSON (str or UTF-8 bytes)."""
        return cls.from_dict(parse_json(text, source), source)

    @classmethod
    def from_dict(cls, data: Any, source: str = "problem") -> "Problem":
        """A problem from its JSON object; ProblemFormatError names the bad field."""
        data = _object(data, source)
        extra = data.keys() - set(_FIELDS)
        if extra:
            raise ProblemFormatError(f"{source}: unknown field(s) {unknown_names(extra, _FIELDS)}; expected "
                                     f"{', '.join(_FIELDS)}")
        if data.get("format", FORMAT) != FORMAT or data.get("version", VERSION) != VERSION:
            raise ProblemFormatError(f"{source}: expected format {FORMAT!r} version {VERSION}, "
                                     f"got {data.get('format')!r} version {data.get('version')!r}")
        for key in ("id", "prior", "robot", "start"):
            if key not in data:
                raise ProblemFormatError(f"{source}: missing field {key!r}")
        if not isinstance(data["id"], str) or not data["id"]:
            raise ProblemFormatError(f"{source}.id: expected a non-empty string, got {data['id']!r}")
        where = f"{source} ({data['id']})"
        scene = data.get("scene")
        if scene is not None and not isinstance(scene, str):
            scene = _freeze(_object(scene, f"{where}.scene"))
        goal = data.get("goal")
        vias = []
        via_points = data.get("via_points") or []
        if not isinstance(via_points, (list, tuple)):
            raise ProblemFormatError(f"{where}.via_points: expected a list of [index, [values]], "
                                     f"got {type(via_points).__name__}")
        for k, item in enumerate(via_points):
            if (not isinstance(item, (list, tuple)) or len(item) != 2 or not isinstance(item[0], int)
                    or isinstance(item[0], bool)):
                raise ProblemFormatError(f"{where}.via_points[{k}]: expected [index, [values]], "
                                         f"got {item!r}")
            vias.append((item[0], _numbers(item[1], f"{where}.via_points[{k}]")))
        expected = data.get("expected")
        if expected not in EXPECTED:
            raise ProblemFormatError(f"{where}.expected: expected one of {list(EXPECTED)}, got "
                                     f"{expected!r}")
        return cls(id=data["id"], prior=_prior_spec(data["prior"], f"{where}.prior"),
                   robot=_robot_spec(data["robot"], f"{where}.robot"),
                   start=_numbers(data["start"], f"{where}.start"), scene=scene,
                   goal=None if goal is None else _goal(goal, f"{where}.goal"),
                   via_points=tuple(vias),
                   config=_freeze(_object(data.get("config") or {}, f"{where}.config")),
                   expected=expected,
                   meta=_freeze(_object(data.get("meta") or {}, f"{where}.meta")))

    def replace(self, **changes: Any) -> "Problem":
        """A copy with fields changed; values in JSON form (e.g. ``start=[...]``,
        ``scene={...}``), checked like :meth:`from_dict`."""
        data = self.to_dict()
        data.update(changes)
        return Problem.from_dict(data)

    # ------------------------------------------------------------------- identity
    @cached_property
    def hash(self) -> str:
        """SHA-256 (hex, first 16 digits) of the canonical JSON of the problem."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def config_changes(self) -> dict[str, Any]:
        """``config`` as keyword arguments of ``PlannerConfig().with_``."""
        return _thaw(self.config)

    def scene_data(self) -> dict[str, Any] | str | None:
        """The scene as written: None, a scene object (dict) or a scene-file path."""
        return self.scene if self.scene is None or isinstance(self.scene, str) else _thaw(self.scene)


def make_problem(id: str, prior: Any, robot: Any, start: Sequence[float], scene: Any = None,
                 goal: Any = None, via_points: Sequence = (),
                 config: Mapping[str, Any] | None = None, expected: str | None = None,
                 meta: Mapping[str, Any] | None = None) -> Problem:
    """A :class:`Problem` from Python values: ``scene`` may also be a ``scenes.Scene`` (stored
    inline), numbers may be numpy arrays, ``goal`` a pose as ``clamp.plan`` takes it: a pair
    (position (3,) [m], quaternion (4,) x, y, z, w)."""
    if hasattr(scene, "to_dict"):
        scene = scene.to_dict()
    if (isinstance(goal, (tuple, list)) and len(goal) == 2
            and [_length(part) for part in goal] == list(GOAL_POSE.values())):
        goal = dict(zip(GOAL_POSE, goal))
    via_points = as_sequence(via_points, "via_points", "a list of pairs (index, values)",
                             ClampTypeError)
    data = {"id": id, "prior": prior, "robot": robot, "scene": scene, "start": start,
            "goal": goal, "via_points": via_points, "config": config or {},
            "expected": expected, "meta": meta or {}}
    return Problem.from_dict({key: _json_value(value, key) for key, value in data.items()})


def _length(value: Any) -> int | None:
    """The length of a flat list or 1-D array, None for anything else."""
    shape = getattr(value, "shape", None)
    if shape is not None:
        return shape[0] if len(shape) == 1 else None
    return len(value) if isinstance(value, (list, tuple)) else None


def _json_value(value: Any, name: str) -> Any:
    """``value`` as JSON data (numpy arrays and scalars as lists and numbers, tuples as
    lists); ProblemFormatError naming ``name`` when it cannot be written as JSON."""
    def plain(x: Any) -> Any:
        if hasattr(x, "tolist"):
            return x.tolist()
        if isinstance(x, Path):
            return str(x)
        raise TypeError(f"{type(x).__name__} {x!r:.40} is not JSON data")
    try:
        return json.loads(json.dumps(value, default=plain))
    except (TypeError, ValueError, RecursionError) as exc:
        raise ProblemFormatError(f"{name}: expected JSON data (numbers, text, lists, "
                                 f"objects), got {type(value).__name__} ({exc})") from None


def parse_json(text: Any, source: str) -> Any:
    """One JSON value from ``text`` (str or UTF-8 bytes); ProblemFormatError naming
    ``source`` when it is not valid JSON (nesting too deep included)."""
    if not isinstance(text, (str, bytes, bytearray)):
        raise ClampTypeError(f"{source}: expected JSON text (str or bytes), got "
                                f"{type(text).__name__} {text!r:.60}")
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:    # JSONDecodeError, UnicodeDecodeError
        raise ProblemFormatError(f"{source}: not valid JSON ({type(exc).__name__}: "
                                 f"{str(exc)[:120]})") from None


# ----------------------------------------------------------------------- files
def read_problems(path: str | Path) -> list[Problem]:
    """Problems of a JSON Lines file (one problem per line; blank lines and lines starting
    with ``#`` ignored). ProblemFormatError names the line of the first bad one and the
    first repeated id."""
    path = as_file(path, "path", ProblemFormatError, ClampTypeError)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemFormatError(f"problems: cannot read {str(path)!r} ({exc})") from None
    problems = [Problem.from_json(line, f"{path}:{k}") for k, line in enumerate(lines, 1)
                if line.strip() and not line.lstrip().startswith("#")]
    check_unique_ids(problems)
    return problems


def write_problems(problems: Iterable[Problem], path: str | Path, overwrite: bool = False) -> Path:
    """Write problems as JSON Lines (atomic; ProblemFormatError if ``path`` exists and not
    ``overwrite``, or if its folder does not exist)."""
    problems = as_sequence(problems, "problems", "a list of clamp.batch.problems.Problem",
                           ClampTypeError)
    for k, problem in enumerate(problems):
        if not isinstance(problem, Problem):
            raise ClampTypeError(f"problems[{k}]: expected a clamp.batch.problems.Problem, got "
                                    f"{type(problem).__name__} {problem!r:.60}")
    check_unique_ids(problems)
    path = as_path(path, "path", ClampTypeError)
    overwrite = as_bool(overwrite, "overwrite")
    text = "".join(p.to_json() + "\n" for p in problems)
    return atomic_write_text(path, text, overwrite, ProblemFormatError, ProblemFormatError)


def check_unique_ids(problems: Sequence[Problem]) -> None:
    seen: dict[str, int] = {}
    for k, problem in enumerate(problems):
        if problem.id in seen:
            raise ProblemFormatError(f"problems[{k}]: id {problem.id!r} already used by "
                                     f"problems[{seen[problem.id]}]; ids must be unique")
        seen[problem.id] = k


def iter_json_lines(path: str | Path) -> Iterator[dict[str, Any]]:
    """The JSON objects of a file's complete lines (a last line without its newline, left by a
    crash mid-write, is skipped); ProblemFormatError names a line that is not a JSON object."""
    return (record for _, _, record in json_lines(path))


def json_lines(path: str | Path) -> Iterator[tuple[int, bytes, dict[str, Any]]]:
    """(line number, raw line, JSON object) of each complete non-blank line, as
    :func:`iter_json_lines` reads them."""
    path = as_file(path, "path", ProblemFormatError, ClampTypeError)
    with open(path, "rb") as handle:
        for k, raw in enumerate(handle, 1):
            if not raw.endswith(b"\n"):
                return
            if raw.strip():
                record = parse_json(raw, f"{path}:{k}")
                if not isinstance(record, dict):
                    raise ProblemFormatError(f"{path}:{k}: expected a JSON object, got "
                                             f"{type(record).__name__}")
                yield k, raw, record
