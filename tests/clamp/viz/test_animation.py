"""3-D animation (clamp.viz.animation): one offline HTML file; headless Chromium sees the arm move."""
from __future__ import annotations

import re

import numpy as np
import pytest

pytest.importorskip("meshcat", reason="the animation needs meshcat (pip install meshcat)")

from bad_input import raises_naming  # noqa: E402
from chromium import CHROMIUM, MISSING, screenshot  # noqa: E402
from clamp.viz.animation import AnimationError, surface_from_grid, write_animation  # noqa: E402
from scenes import Box, Capsule, Cylinder, Scene, Sphere  # noqa: E402

JACO_A = np.array([0.0, 3.5, 1.8, 0.0, 2.5, 0.0])
JACO_B = np.array([1.5, 2.5, 2.5, 1.0, 2.0, 1.0])
DURATION = 3.0
OVERLAY_TOP, OVERLAY_BOTTOM = 22, 45      # px: meshcat's "Open Controls" strip, our player bar
# namespace URIs inside three.js are names, not fetched resources
ALLOWED_URLS = {"http://www.w3.org/1999/xhtml", "http://www.w3.org/2000/svg"}


def plan(q0=JACO_A, q1=JACO_B, T=20):
    t = np.linspace(0.0, DURATION, T)
    s = 0.5 - 0.5 * np.cos(np.pi * t / DURATION)
    return t, q0 + s[:, None] * (q1 - q0)


def extras(robot, q):
    ee = robot.fk(q)
    demos = ee[None] + np.array([[0.0, 0.0, 0.03], [0.0, 0.03, 0.0], [0.03, 0.0, 0.0]])[:, None, :]
    angle = np.linspace(0.0, 2 * np.pi, 17)
    X = ee[:, 0, None] + 0.05 * np.cos(angle)
    Y = ee[:, 1, None] + 0.05 * np.sin(angle)
    Z = np.repeat(ee[:, 2, None], len(angle), axis=1)
    scene = Scene([Box([0.45, -0.3, 0.1], [0.2, 0.2, 0.2]), Sphere([-0.3, 0.3, 0.3], 0.08),
                   Cylinder([0.3, 0.4, 0.2], 0.05, 0.4, axis=[1.0, 0.0, 0.0]),
                   Capsule([-0.3, -0.3, 0.3], 0.04, 0.2, axis=[0.0, 1.0, 1.0])])
    return dict(obstacles=scene, demonstrations=demos, mean_path=demos.mean(axis=0),
                extra_surface=surface_from_grid(X, Y, Z))


@pytest.fixture(scope="module")
def page(jaco, tmp_path_factory):
    folder = tmp_path_factory.mktemp("animation")
    t, q = plan()
    path = write_animation(folder / "plan.html", jaco, t, q, **extras(jaco, q), title="test plan")
    return folder, path


def test_one_self_contained_file(page):
    folder, path = page
    assert [p.name for p in folder.iterdir()] == ["plan.html"]  # no side files, no temporary files
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and "MeshCat.Viewer" in text
    assert 'id="play"' in text and 'id="scrub"' in text      # our own player bar, always visible
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.IGNORECASE)
    assert not re.search(r"\b(?:src|href)\s*=\s*[\"']?\s*(?:https?:)?//", text, re.IGNORECASE)
    assert not re.search(r"(?:fetch|import)\s*\(\s*[\"'`]https?:", text)
    assert set(re.findall(r"https?://[^\s\"'<>()`\\]+", text)) <= ALLOWED_URLS
    # meshes, scene commands and meshcat's bundle are gzip-compressed (4.2 MB before on clamp demo)
    assert 0.3e6 < path.stat().st_size < 2.5e6


def test_sawyer_without_visual_elements_draws_collision_geometry(tmp_path):
    from robots import load_robot

    sawyer = load_robot("sawyer")
    q0 = np.array([0.0, -0.5, 0.0, 1.0, 0.0, 0.5, 0.0])
    t, q = plan(q0, q0 + 0.5, T=10)
    path = write_animation(tmp_path / "sawyer.html", sawyer, t, q, frame_rate=10.0)
    assert "MeshCat.Viewer" in path.read_text(encoding="utf-8")


def test_capsule_is_drawn_as_its_surface():
    """The capsule mesh's vertices lie on the capsule: radius from its segment (z in
    [-height/2, height/2]), both caps and the side present."""
    import meshcat.geometry as mg
    from clamp.viz.animation import _capsule_mesh
    radius, height = 0.04, 0.2
    mesh = _capsule_mesh(mg, radius, height)
    v = np.asarray(mesh.vertices)
    nearest = np.clip(v[:, 2], -height / 2, height / 2)
    distance = np.hypot(np.hypot(v[:, 0], v[:, 1]), v[:, 2] - nearest)
    np.testing.assert_allclose(distance, radius, atol=1e-12)
    assert v[:, 2].max() == pytest.approx(height / 2 + radius)
    assert v[:, 2].min() == pytest.approx(-height / 2 - radius)
    assert np.asarray(mesh.faces).max() < len(v)


def test_floor_lies_at_z_0_under_the_scene():
    import meshcat.geometry as mg
    from clamp.viz.animation import FLOOR_CELL, _floor
    low, high = np.array([-0.33, -0.51, 0.2]), np.array([0.62, 0.4, 0.9])
    points = np.asarray(_floor(mg, low, high).geometry.position)
    points = points.T if points.shape[0] == 3 else points
    assert np.all(points[:, 2] == 0.0)
    assert np.all(points[:, :2].min(axis=0) <= low[:2] - FLOOR_CELL + 1e-6)
    assert np.all(points[:, :2].max(axis=0) >= high[:2] + FLOOR_CELL - 1e-6)


def test_camera_distance_frames_every_point_tightly():
    """Projected with a look-at camera (z up), every point lies within CAMERA_FILL of the
    view's half extents and one reaches it."""
    from clamp.viz.animation import CAMERA_ASPECT, CAMERA_FILL, CAMERA_FOV, camera_distance
    rng = np.random.default_rng(1)
    points = rng.uniform(-0.5, 0.8, size=(200, 3))
    centre, direction = points.mean(axis=0), np.array([1.0, 0.75, 0.6]) / np.linalg.norm([1.0, 0.75, 0.6])
    eye = centre + camera_distance(points, centre, direction) * direction
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    side = np.cross(forward, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    upward = np.cross(side, forward)
    depth = (points - eye) @ forward
    tan_v = np.tan(np.radians(CAMERA_FOV / 2))
    u = np.abs((points - eye) @ side) / depth / (tan_v * CAMERA_ASPECT)
    v = np.abs((points - eye) @ upward) / depth / tan_v
    assert np.all(depth > 0)
    assert np.max(np.maximum(u, v)) == pytest.approx(CAMERA_FILL, rel=1e-9)


def test_surface_from_grid():
    X, Y = np.meshgrid(np.arange(4.0), np.arange(3.0), indexing="ij")
    vertices, faces = surface_from_grid(X, Y, X + Y)
    assert vertices.shape == (12, 3) and faces.shape == (2 * 3 * 2, 3)
    assert faces.min() == 0 and faces.max() == 11


def test_bad_input_raises_clamp_errors(jaco, tmp_path):
    t, q = plan()
    with raises_naming(AnimationError, "q"):
        write_animation(tmp_path / "a.html", jaco, t, q[:, :3])
    with raises_naming(AnimationError, "time"):
        write_animation(tmp_path / "a.html", jaco, t[::-1], q)
    with raises_naming(AnimationError, "extra_surface"):
        write_animation(tmp_path / "a.html", jaco, t, q, extra_surface=(np.zeros((3, 3)), np.array([[0, 1, 7]])))
    with raises_naming(AnimationError, "demonstrations"):
        write_animation(tmp_path / "a.html", jaco, t, q, demonstrations=np.zeros((4, 3)))
    (tmp_path / "a.html").write_text("keep")
    with raises_naming(AnimationError, "a.html"):
        write_animation(tmp_path / "a.html", jaco, t, q, overwrite=False)
    assert (tmp_path / "a.html").read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.html"]


@pytest.mark.skipif(CHROMIUM is None, reason=MISSING)
def test_headless_chromium_shows_the_arm_moving(page, tmp_path):
    _, path = page
    first = screenshot(f"file://{path}#t=0.0", tmp_path / "t0.png")
    last = screenshot(f"file://{path}#t={DURATION}", tmp_path / "t1.png")
    assert first.shape == last.shape == (600, 800, 3)
    # the background is a light gradient (>= 200 in every channel); the arm's links are dark grey
    dark = [(image.max(axis=2) < 110) for image in (first, last)]
    assert dark[0].sum() > 2000 and dark[1].sum() > 2000, "no arm pixels in the screenshots"
    moved = np.abs(first - last).max(axis=2) > 60
    assert moved.sum() > 2000, "the two animation times look the same"
    # what changed is the arm: many changed pixels are arm pixels in one frame or the other
    assert (moved & (dark[0] | dark[1])).sum() > 0.5 * moved.sum()
    # the camera frames the scene: the bounding box of what is drawn (the arm: dark pixels; the
    # obstacles, paths, demonstrations and surface: coloured pixels; not the grey floor, not the
    # overlays: meshcat's controls strip at the top, the player bar at the bottom), over both
    # frames, is not cut by the frame's edges and spans >= 70 % of its height or width (a tall
    # arm in a wide window cannot span both). main before the camera fit: cut at the top, 60 %.
    rows = slice(OVERLAY_TOP, first.shape[0] - OVERLAY_BOTTOM)
    drawn = np.zeros(first[rows].shape[:2], dtype=bool)
    for image in (first[rows], last[rows]):
        drawn |= (image.max(axis=2) < 110) | (np.ptp(image, axis=2) > 50)
    ys, xs = np.nonzero(drawn)
    height, width = drawn.shape
    assert ys.min() > 0 and xs.min() > 0 and ys.max() < height - 1 and xs.max() < width - 1, "the scene is cut"
    fill = max((ys.max() - ys.min() + 1) / height, (xs.max() - xs.min() + 1) / width)
    assert fill >= 0.7, f"the scene spans {fill:.0%} of the frame"


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_arm_is_drawn_in_the_planning_frame(name):
    """The viewer places Pinocchio's world poses under the base-frame inverse: the end effector
    drawn there must be where robot.fk (the planner's frame) puts it."""
    import pinocchio as pin

    from clamp.viz.animation import planning_frame_transform
    from robots import load_robot

    robot = load_robot(name)
    q = robot.random_configuration(np.random.default_rng(0))
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.to_pinocchio(q))
    world_ee = data.oMf[robot.model.getFrameId(robot.end_effector, pin.FrameType.BODY)].homogeneous
    np.testing.assert_allclose((planning_frame_transform(robot, pin) @ world_ee)[:3, 3], robot.fk(q), atol=1e-9)
