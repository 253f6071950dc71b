"""The command line's small faults (issue 21 item 4): plain help texts, errors that say what to
do instead (--urdf for an unregistered robot, --package-dir for package:// meshes, xacro for a
xacro file), and no empty --out folder left behind by a run that exits 2."""
from __future__ import annotations

import pytest

from clamp.cli.commands import main, parser
from robots import Robot, URDFParseError
from robots.registry import example_robot_data_share

START = ["--start", "0.2", "-0.47", "0.27"]


def ur5_urdf() -> str:
    return str(example_robot_data_share() / "example-robot-data/robots/ur_description/urdf/ur5_robot.urdf")


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    from scenes import make_demonstrations
    path = tmp_path_factory.mktemp("messages") / "demos.npz"
    make_demonstrations("box_closing", num_points=30, seed=1).save_npz(path)
    return str(path)


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


@pytest.mark.parametrize("command", [[], ["demo"], ["learn"], ["plan"], ["batch"]])
def test_help_texts_are_plain_text(command, capsys):
    with pytest.raises(SystemExit) as stop:
        parser().parse_args([*command, "--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    assert "usage: clamp" in text and "``" not in text and ":mod:" not in text


def test_unknown_robot_points_at_urdf(tmp_path, capsys):
    out = tmp_path / "new" / "out"
    assert main(["demo", "--robot", "ur5", "--out", str(out)]) == 2
    line = one_error_line(capsys)
    assert "'ur5'" in line and "jaco, sawyer" in line and "--urdf FILE --end-effector FRAME" in line
    assert not (tmp_path / "new").exists()  # the folders the run made are gone again


def test_exit_2_leaves_an_existing_folder_alone(tmp_path, demos, capsys):
    (tmp_path / "out").mkdir()
    assert main(["plan", "--robot", "jaco", "--demos", demos, *START, "--goal", "1", "2",
                 "--out", str(tmp_path / "out")]) == 2
    assert "goal" in one_error_line(capsys)
    assert (tmp_path / "out").is_dir()  # the user's (empty) folder stays


def test_package_meshes_without_package_dir_suggest_it(tmp_path, demos, capsys):
    with pytest.raises(URDFParseError, match=r"package://.*'example-robot-data'.*--package-dir DIR"):
        Robot.from_urdf(ur5_urdf(), "tool0").collision_model
    from scenes import Box, Scene
    Scene([Box([0.6, 0.3, 0.2], [0.1, 0.1, 0.1])]).save(tmp_path / "scene.json")
    out = tmp_path / "out"
    assert main(["plan", "--urdf", ur5_urdf(), "--end-effector", "tool0", "--demos", demos, *START,
                 "--scene", str(tmp_path / "scene.json"), "--out", str(out)]) == 2
    assert "--package-dir" in one_error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize("name", ["arm.urdf.xacro", "arm.urdf"])
def test_xacro_file_says_expand_it_first(tmp_path, demos, capsys, name):
    xacro = tmp_path / name
    xacro.write_text('<?xml version="1.0"?>\n<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="arm">\n'
                     '  <xacro:property name="l" value="0.3"/>\n  <link name="base"/>\n</robot>\n')
    assert main(["plan", "--urdf", str(xacro), "--end-effector", "base", "--demos", demos, *START,
                 "--out", str(tmp_path / "out")]) == 2
    line = one_error_line(capsys)
    assert "xacro file" in line and f"xacro {name} > robot.urdf" in line
    assert not (tmp_path / "out").exists()
