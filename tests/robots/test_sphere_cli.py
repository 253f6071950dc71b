"""``python -m robots.sphere_cli`` agrees with the planner: with --end-effector it writes the fit
``Robot.spheres`` makes (fingers beyond the end effector locked onto it), and a package:// mesh
it cannot find is one line that suggests --package-dir. Run as a user would (subprocess)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from robots import Robot
from robots.sphere_cache import CACHE_ENV
from robots.sphere_model import load_sphere_file
from test_sphere_cache import write_cube
from tests.two_joint_arm import two_joint_arm_urdf

ROOT = Path(__file__).resolve().parents[2]


def sphere_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "robots.sphere_cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def write_hand(folder: Path, mesh: str) -> Path:
    """An arm whose tool carries a finger on a prismatic joint (beyond the end effector "tool");
    the tool's geometry is the mesh ``mesh`` (a path or a package:// URI)."""
    urdf = folder / "hand.urdf"
    finger = """  <link name="finger"><collision><origin xyz="0 0 0.04"/><geometry><box size="0.01 0.02 0.08"/></geometry>
    </collision></link>
"""
    finger_joint = """  <joint name="finger_joint" type="prismatic"><parent link="tool"/><child link="finger"/>
    <origin xyz="0.02 0 0.03"/><axis xyz="1 0 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
"""
    urdf.write_text(two_joint_arm_urdf("hand", f'<mesh filename="{mesh}"/>', links=finger,
                                       joints=finger_joint))
    return urdf


def test_the_sphere_file_is_the_planners_fit(tmp_path, monkeypatch):
    write_cube(tmp_path / "cube.stl", 0.03)
    urdf = write_hand(tmp_path, str(tmp_path / "cube.stl"))
    done = sphere_cli("--urdf", str(urdf), "--end-effector", "tool", "--out", "spheres.json", "--max-spheres", "6",
                      cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    written = load_sphere_file(tmp_path / "spheres.json")
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "own_cache"))        # fitted here, not read
    planner = Robot.from_urdf(urdf, end_effector="tool").fit_spheres(max_spheres=6)
    assert written.link_names == planner.link_names and "finger" not in written.link_names
    # the same fit to the last digits: two processes may differ in the last bits (the suite's
    # earlier tests leave another BLAS kernel or thread count); another fit differs by mm
    np.testing.assert_allclose(written.centres, planner.centres, rtol=0, atol=1e-9)
    np.testing.assert_allclose(written.radii, planner.radii, rtol=0, atol=1e-9)


def test_urdf_needs_the_end_effector(tmp_path):
    write_cube(tmp_path / "cube.stl", 0.03)
    urdf = write_hand(tmp_path, str(tmp_path / "cube.stl"))
    done = sphere_cli("--urdf", str(urdf), "--out", "spheres.json", cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    [line] = done.stderr.splitlines()
    assert "--end-effector: required with --urdf" in line
    assert not (tmp_path / "spheres.json").exists()


def test_a_package_mesh_not_found_suggests_package_dir(tmp_path):
    package = tmp_path / "description" / "my_hand" / "meshes"
    package.mkdir(parents=True)
    write_cube(package / "cube.stl", 0.03)
    urdf = write_hand(tmp_path, "package://my_hand/meshes/cube.stl")
    done = sphere_cli("--urdf", str(urdf), "--end-effector", "tool", "--out", "spheres.json", cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    [line] = done.stderr.splitlines()
    assert "package://my_hand" in line and "--package-dir DIR" in line
    assert not (tmp_path / "spheres.json").exists()
    done = sphere_cli("--urdf", str(urdf), "--end-effector", "tool", "--out", "spheres.json", "--max-spheres", "4",
                      "--package-dir", str(tmp_path / "description"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "tool" in load_sphere_file(tmp_path / "spheres.json").link_names
