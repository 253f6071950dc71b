"""Built-in robots by name: the Kinova Jaco2 (6-DOF) and the Rethink Sawyer (7-DOF)."""
from __future__ import annotations

import importlib.metadata
from collections.abc import Callable
from pathlib import Path

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
