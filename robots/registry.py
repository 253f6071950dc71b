"""Built-in robots by name: the Kinova Jaco2 (6-DOF) and the Rethink Sawyer (7-DOF)."""
from __future__ import annotations

import importlib.metadata
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from skillplan.validation import as_instance

from .errors import RobotTypeError, RobotError, UnknownRobotError
from .robot import Robot

_HERE = Path(__file__).resolve().parent
SPHERE_OVERRIDE_DIR = _HERE / "spheres"


def example_robot_data_share() -> Path:
    """The share/ folder of the installed example-robot-data package (its package:// root)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:
        raise RobotError("the Jaco model needs the example-robot-data package (pip install example-robot-data)") from exc
    share = Path(str(dist.locate_file("cmeel.prefix/share")))
    if not (share / "example-robot-data").is_dir():
        raise RobotError(f"example-robot-data is installed but {share / 'example-robot-data'} is missing")
    return share


def sphere_override_path(name: str) -> Path:
    """Path of the hand-tuned sphere model robots/spheres/<name>.json (it may not exist)."""
    return SPHERE_OVERRIDE_DIR / f"{name}.json"


def _jaco() -> Robot:
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "kinova_description" / "robots" / "kinova.urdf"
    return Robot.from_urdf(urdf, end_effector="j2s6s200_end_effector", package_dirs=[share],
                           name="jaco", base_frame="j2s6s200_link_base")


def _sawyer() -> Robot:
    return Robot.from_urdf(_HERE / "urdf" / "sawyer.urdf", end_effector="right_hand", name="sawyer",
                           base_frame="right_arm_base_link")


_BUILTIN: dict[str, Callable[[], Robot]] = {"jaco": _jaco, "sawyer": _sawyer}


def available_robots() -> tuple[str, ...]:
    """Names accepted by load_robot."""
    return tuple(_BUILTIN)


def load_robot(name: str) -> Robot:
    """A built-in robot by name ("jaco", "sawyer"); UnknownRobotError lists the valid names.

    Collision spheres come from robots/spheres/<name>.json when present, otherwise they are
    fitted from the URDF's collision geometry on first use.
    """
    as_instance(name, "name", str, f"a robot name (str), one of {', '.join(available_robots())}; "
                "for another arm use Robot.from_urdf(path, end_effector=...)", RobotTypeError)
    if name not in _BUILTIN:
        raise UnknownRobotError(name, available_robots())
    robot = _BUILTIN[name]()
    override = sphere_override_path(name)
    if override.is_file():
        robot.spheres = override
    return robot


#: the fields of a robot spec naming an arm by its URDF (resolve_robot)
URDF_FIELDS = ("urdf", "end_effector", "base_frame", "package_dirs", "spheres")


def resolve_robot(spec: str | Mapping[str, Any], base: str | Path | None = None) -> Robot:
    """The robot a command line or a problem names, the one loader of both: a registered name
    (``"jaco"`` or ``{"name": "jaco"}``, :func:`load_robot`) or any arm from its URDF,
    ``{"urdf": PATH, "end_effector": FRAME}`` with optional ``"base_frame"`` (planning frame,
    default the URDF root), ``"package_dirs"`` (folders of package:// meshes) and ``"spheres"``
    (a collision sphere file; default fitted from the URDF), see :meth:`Robot.from_urdf`. A
    relative URDF path (``~`` expanded) is read against ``base`` when given. A spec naming
    neither raises RobotError; a bad name UnknownRobotError; a bad file URDFParseError."""
    if isinstance(spec, str):
        spec = {"name": spec}
    as_instance(spec, "robot", Mapping, "a robot name or a {'name': ..} / {'urdf': .., 'end_effector': ..} "
                "mapping", RobotTypeError)
    if "name" in spec:
        if set(spec) != {"name"}:
            raise RobotError(f"robot: a registered robot takes no other fields, got {sorted(set(spec) - {'name'})}")
        return load_robot(spec["name"])
    if "urdf" not in spec or "end_effector" not in spec:
        raise RobotError(f"robot: expected {{'name': NAME}} or {{'urdf': PATH, 'end_effector': FRAME}}, "
                         f"got fields {sorted(spec)}")
    extra = set(spec) - set(URDF_FIELDS)
    if extra:
        raise RobotError(f"robot: unknown field(s) {sorted(extra)}")
    urdf = spec["urdf"]
    if base is not None:
        urdf = Path(urdf).expanduser()
        urdf = urdf if urdf.is_absolute() else Path(base) / urdf
    return Robot.from_urdf(urdf, spec["end_effector"], package_dirs=spec.get("package_dirs"),
                           spheres=spec.get("spheres"), base_frame=spec.get("base_frame"))
