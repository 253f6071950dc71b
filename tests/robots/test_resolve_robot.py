"""One robot loader (robots.resolve_robot) for the command lines and the batch problems: a
registered name or any URDF with its end-effector frame."""
from __future__ import annotations

from pathlib import Path

import pytest

from bad_input import raises_naming
import robots
from robots import resolve_robot
from robots.errors import RobotError, RobotTypeError, UnknownRobotError

SAWYER_URDF = Path(robots.__file__).resolve().parent / "urdf" / "sawyer.urdf"


def test_a_name_or_a_urdf_relative_to_a_base():
    assert resolve_robot("sawyer").name == resolve_robot({"name": "sawyer"}).name == "sawyer"
    arm = resolve_robot({"urdf": SAWYER_URDF.name, "end_effector": "right_hand", "base_frame": None},
                        base=SAWYER_URDF.parent)
    assert arm.urdf_path == SAWYER_URDF and arm.end_effector == "right_hand"
    assert resolve_robot({"urdf": str(SAWYER_URDF), "end_effector": "right_hand"}).n == arm.n


def test_a_bad_spec_names_what_is_wrong():
    with pytest.raises(UnknownRobotError):
        resolve_robot("nonexistent_robot")
    with raises_naming(RobotError, "robot", "end_effector"):
        resolve_robot({"urdf": str(SAWYER_URDF)})
    with raises_naming(RobotError, "robot", "end_effector"):
        resolve_robot({"name": "sawyer", "end_effector": "right_hand"})
    with raises_naming(RobotError, "robot", "colour"):
        resolve_robot({"urdf": str(SAWYER_URDF), "end_effector": "right_hand", "colour": "red"})
    with pytest.raises(RobotTypeError):
        resolve_robot(3)
