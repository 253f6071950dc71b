"""The sphere cache (robots.sphere_cache): a fit is stored and read back exactly, by any Robot
of the same URDF; a changed mesh, URDF or fit setting is fitted again; a damaged entry or a
folder that cannot be written costs a refit or a warning, never the spheres."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from robots import Robot, spheres
from robots.sphere_cache import CACHE_ENV, cache_folder
from tests.two_joint_arm import two_joint_arm_urdf

CUBE_FACES = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
              (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]


def write_cube(path: Path, half: float) -> None:
    """An ASCII STL cube of half side ``half`` [m], centred."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    lines = ["solid cube"]
    for face in CUBE_FACES:
        lines += ["facet normal 0 0 0", " outer loop", *(f"  vertex {x} {y} {z}" for x, y, z in corners[list(face)]),
                  " endloop", "endfacet"]
    path.write_text("\n".join([*lines, "endsolid cube", ""]))


def write_arm(folder: Path, length: float = 0.3) -> Path:
    """A two-joint arm: a cylinder of ``length`` [m] on its upper link, the cube mesh on its tool."""
    urdf = folder / "arm.urdf"
    mesh = folder / "cube.stl"
    urdf.write_text(two_joint_arm_urdf("arm", f'<mesh filename="{mesh}"/>', length))
    return urdf


@pytest.fixture
def arm(tmp_path, monkeypatch) -> Path:
    """The arm's URDF and cube mesh in a fresh folder, with its own empty sphere cache."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    write_cube(tmp_path / "cube.stl", 0.03)
    return write_arm(tmp_path)


@pytest.fixture
def fits(monkeypatch) -> list[int]:
    """Counts the fits robots.spheres.fit_spheres makes (one entry per call)."""
    calls: list[int] = []
    fit = spheres.fit_spheres

    def counted(*args, **kwargs):
        calls.append(1)
        return fit(*args, **kwargs)

    monkeypatch.setattr(spheres, "fit_spheres", counted)
    return calls


def fitted(urdf: Path, max_spheres: int = 4):
    """The spheres of a new Robot of ``urdf`` (few spheres: quick fits)."""
    return Robot.from_urdf(urdf, end_effector="tool").fit_spheres(max_spheres=max_spheres)


def entries() -> list[Path]:
    return sorted((cache_folder() / "spheres").glob("*.json"))


def test_a_fit_is_stored_and_read_back_exactly(arm, fits):
    first = Robot.from_urdf(arm, end_effector="tool").spheres
    assert len(fits) == 1 and len(entries()) == 1
    again = Robot.from_urdf(arm, end_effector="tool").spheres
    assert len(fits) == 1
    assert again.link_names == first.link_names and again.inflation == first.inflation
    assert np.array_equal(again.centres, first.centres) and np.array_equal(again.radii, first.radii)


def test_a_changed_mesh_or_urdf_or_setting_is_fitted_again(arm, fits):
    small = fitted(arm)
    write_cube(arm.parent / "cube.stl", 0.06)                       # the same file name, a bigger cube
    big = fitted(arm)
    assert len(fits) == 2
    _, small_tool = small.for_link("tool")
    _, big_tool = big.for_link("tool")
    assert big_tool.max() > small_tool.max() + 0.01                  # it covers the new cube
    write_arm(arm.parent, length=0.4)                                # a longer upper link
    fitted(arm)
    assert len(fits) == 3
    fitted(arm, max_spheres=3)
    assert len(fits) == 4 and len(entries()) == 4
    write_cube(arm.parent / "cube.stl", 0.03)                        # back as it was: read, not fitted
    write_arm(arm.parent)
    restored = fitted(arm)
    assert len(fits) == 4 and np.array_equal(restored.radii, small.radii)


def test_a_damaged_entry_is_fitted_again(arm, fits, caplog):
    first = fitted(arm)
    [entry] = entries()
    entry.write_text('{"spheres": [')
    with caplog.at_level(logging.WARNING, logger="robots"):
        refitted = fitted(arm)
    assert len(fits) == 2 and "sphere cache" in caplog.text and "fitting again" in caplog.text
    assert np.array_equal(refitted.radii, first.radii)
    fitted(arm)                                                      # the entry was written anew
    assert len(fits) == 2


def test_a_cache_folder_that_cannot_be_written_costs_a_warning_only(arm, fits, monkeypatch, caplog):
    blocker = arm.parent / "a_file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(CACHE_ENV, str(blocker))
    with caplog.at_level(logging.WARNING, logger="robots"):
        spheres_ = fitted(arm)
    assert spheres_.count >= 2 and blocker.read_text() == "not a folder"
    assert "cannot store" in caplog.text and CACHE_ENV in caplog.text


def test_the_cache_lives_in_the_users_cache_folder(monkeypatch, tmp_path):
    monkeypatch.delenv(CACHE_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_folder() == tmp_path / "xdg" / "skillplan"
    monkeypatch.setenv(CACHE_ENV, "~/elsewhere")
    assert cache_folder() == Path("~/elsewhere").expanduser()
