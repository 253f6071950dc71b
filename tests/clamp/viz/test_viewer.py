"""Live viewer (clamp.viz.viewer): viser on 127.0.0.1, replanning when a box moves, clean shutdown,
headless Chromium sees the page change.

Set SKILLPLAN_WRITE_DOCS=1 to save the first screenshot as docs/viewer.png (the README's).
"""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason="the live viewer needs viser (pip install 'skillplan[viewer]')")

from bad_input import raises_naming  # noqa: E402
from chromium import CHROMIUM, MISSING, screenshot  # noqa: E402
import clamp  # noqa: E402
from clamp import learn_prior, plan  # noqa: E402
from clamp.errors import ClampTypeError, InvalidParameterError  # noqa: E402
from clamp.viz.viewer import PlanViewer, tube_mesh  # noqa: E402
from scenes import Box, Scene, make_demonstrations  # noqa: E402

DOCS = Path(__file__).resolve().parents[3] / "docs"


@pytest.fixture(scope="module")
def planned(jaco):
    """box_closing on the Jaco with a box far from the path (the plan ignores it)."""
    demos = make_demonstrations("box_closing", num_demos=6, num_points=80, seed=0)
    prior = learn_prior(demos)
    scene = Scene([Box([-0.4, 0.4, 0.05], [0.08, 0.08, 0.08])])
    result = plan(prior, jaco, scene, start=prior.mean[0, :3])
    assert result.success and result.ee_covariance is not None
    return demos, result


def moved_box_centre(result) -> np.ndarray:
    """A centre putting the 8 cm box under the middle of the path, 2 cm into it."""
    return result.ee_path[len(result.ee_path) // 2] - np.array([0.0, 0.0, 0.04 - 0.02])


def port_is_closed(port: int) -> bool:
    with socket.socket() as probe:
        probe.settimeout(1.0)
        return probe.connect_ex(("127.0.0.1", port)) != 0


def wait_for_threads(before: set[threading.Thread], timeout: float = 10.0) -> set[str]:
    """Names of threads started since ``before`` still alive after up to ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while True:
        left = {t for t in threading.enumerate() if t not in before and t.is_alive()}
        if not left or time.monotonic() > deadline:
            return {t.name for t in left}
        time.sleep(0.1)


def test_tube_vertices_lie_on_the_sigma_ellipsoids():
    rng = np.random.default_rng(3)
    T = 7
    path = rng.normal(size=(T, 3))
    A = rng.normal(size=(T, 3, 3)) * 0.01
    cov = A @ np.swapaxes(A, 1, 2) + 1e-6 * np.eye(3)
    vertices, faces = tube_mesh(path, cov, sigmas=2.0, states=T)
    per = len(vertices) // T
    assert len(vertices) == per * T and faces.max() == len(vertices) - 1
    for i in range(T):
        d = vertices[i * per:(i + 1) * per] - path[i]
        mahalanobis = np.einsum("vi,ij,vj->v", d, np.linalg.inv(cov[i]), d)
        np.testing.assert_allclose(mahalanobis, 4.0, rtol=1e-6)
    with raises_naming(InvalidParameterError, "ee_covariance"):
        tube_mesh(path, cov[:3])


def test_bad_input(planned):
    _, result = planned
    with raises_naming(InvalidParameterError, "host"):
        PlanViewer(result, host="0.0.0.0")
    with raises_naming(ClampTypeError, "result"):
        PlanViewer(result.to_dict())
    with raises_naming(InvalidParameterError, "port"):
        PlanViewer(result, port=70000)


def test_api_replans_when_a_box_moves_and_shuts_down_cleanly(planned):
    demos, result = planned
    before = set(threading.enumerate())
    viewer = clamp.show(result, demonstrations=demos)
    port = viewer.port
    try:
        assert viewer.url == f"http://127.0.0.1:{port}" and not port_is_closed(port)
        viewer.set_time(1e9)
        assert viewer.time == pytest.approx(viewer.duration)
        with raises_naming(InvalidParameterError, "index"):
            viewer.move_obstacle(3, [0.0, 0.0, 0.0])
        with raises_naming(InvalidParameterError, "center"):
            viewer.move_obstacle(0, [0.0, 0.0])
        centre = moved_box_centre(result)
        new = viewer.move_obstacle(0, centre)
        assert viewer.result is new and new is not result
        np.testing.assert_allclose(viewer.scene.obstacles[0].center, centre)
        # independent check: the new plan keeps the moved box clear, the old one went through it
        box = viewer.scene.obstacles[0]
        assert np.min(box.distance(result.ee_path)) < 0
        # (its end-effector frame may pass through the box: it lies between the Jaco's open
        # fingers; the real-geometry check keeps the hand clear)
        assert new.success and new.min_clearance > 0
        assert np.max(np.linalg.norm(new.ee_path - result.ee_path, axis=1)) > 0.01
        goal = new.ee_path[-1] + np.array([0.0, 0.03, 0.02])
        moved = viewer.move_goal(goal)
        assert viewer.result is moved and np.linalg.norm(moved.ee_path[-1] - goal) < 0.003
        np.testing.assert_allclose(viewer.scene.obstacles[0].center, centre)      # the box stays
    finally:
        viewer.close()
    viewer.close()                     # idempotent
    assert port_is_closed(port)
    assert wait_for_threads(before) == set()


def test_the_arm_is_a_viser_urdf_following_set_time(planned):
    """The viewer draws the robot through viser's URDF support (a ViserUrdf of the yourdfpy
    URDF of the robot); the joint configuration it is given at a time is the plan's q there
    (matched by joint name, the Jaco's continuous joints as plain angles)."""
    from viser.extras import ViserUrdf

    _, result = planned
    robot = result.inputs.robot
    with clamp.show(result) as viewer:
        drawn = viewer.robot_urdf
        assert isinstance(drawn, ViserUrdf)
        names = drawn.get_actuated_joint_names()
        assert set(robot.joint_names) <= set(names)
        given = []
        update = drawn.update_cfg
        drawn.update_cfg = lambda configuration: (given.append(np.array(configuration)), update(configuration))
        time = result.time - result.time[0]
        for t in (0.0, 0.37 * viewer.duration, float(time[5]), viewer.duration, 1e9):
            viewer.set_time(t)
            expected = np.array([np.interp(min(t, time[-1]), time, column) for column in result.q.T])
            by_name = dict(zip(names, given[-1]))
            np.testing.assert_allclose([by_name[n] for n in robot.joint_names], expected, atol=1e-12)
        assert len(given) == 5
        np.testing.assert_array_equal(given[2][[names.index(n) for n in robot.joint_names]], result.q[5])
        # the URDF model drawn is at that configuration: its end-effector frame where the plan's is
        urdf = drawn._urdf
        ee = urdf.get_transform(robot.end_effector, robot.base_frame)[:3, 3]
        np.testing.assert_allclose(ee, result.ee_path[-1], atol=1e-6)


def arm_drawn(image: np.ndarray) -> bool:
    """The arm is drawn: many dark grey pixels on the light page."""
    return int((image.max(axis=2) < 120).sum()) > 3000


@pytest.mark.skipif(CHROMIUM is None, reason=MISSING)
def test_headless_chromium_sees_the_replanned_arm(planned, tmp_path):
    demos, result = planned
    before = set(threading.enumerate())
    with clamp.show(result, demonstrations=demos) as viewer:
        port = viewer.port
        viewer.set_time(0.5 * viewer.duration)
        first = screenshot(viewer.url, tmp_path / "before.png", (1000, 700), ready=arm_drawn)
        new = viewer.move_obstacle(0, moved_box_centre(result))
        second = screenshot(viewer.url, tmp_path / "after.png", (1000, 700), ready=arm_drawn)
    assert port_is_closed(port) and wait_for_threads(before) == set()
    assert np.max(np.abs(new.q - result.q)) > 0.01
    assert first.shape == second.shape == (700, 1000, 3)
    assert arm_drawn(first) and arm_drawn(second)
    changed = np.abs(first - second).max(axis=2) > 40
    assert changed.sum() > 1000, "the page looks the same after the box moved and the plan changed"
    if os.environ.get("SKILLPLAN_VIEWER_PNG"):           # a copy to look at (e.g. /tmp/viewer_urdf.png)
        shutil.copyfile(tmp_path / "before.png", os.environ["SKILLPLAN_VIEWER_PNG"])
    if os.environ.get("SKILLPLAN_WRITE_DOCS"):
        DOCS.mkdir(exist_ok=True)
        shutil.copyfile(tmp_path / "after.png", DOCS / "viewer.png")



@pytest.fixture(scope="module")
def plan_folder(tmp_path_factory):
    """The output folder of ``clamp plan`` (small problem: 60 states, a box off the path)."""
    from clamp.cli.commands import main
    folder = tmp_path_factory.mktemp("view")
    make_demonstrations("box_closing", num_demos=6, num_points=60, seed=0).save_npz(folder / "demos_in.npz")
    Scene([Box([-0.4, 0.4, 0.05], [0.08, 0.08, 0.08])]).save(folder / "scene_in.json")
    code = main(["-q", "plan", "--robot", "jaco", "--demos", str(folder / "demos_in.npz"), "--scene",
                 str(folder / "scene_in.json"), "--start", "0.2054", "-0.4722", "0.2625", "--goal", "0.45", "-0.25",
                 "0.15", "--sigma-obs", "0.02", "--out", str(folder / "out")])
    assert code == 0
    return folder / "out"


def test_view_plans_the_recorded_problem_again(plan_folder):
    """The folder's problem file gives the same plan as the command wrote (independent of
    the viewer: plan.json's q), with the goal, the scene and the changed setting kept."""
    import json

    from clamp.cli.viewer import load_view
    written = json.loads((plan_folder / "plan.json").read_text())
    result, demos = load_view(plan_folder)
    np.testing.assert_allclose(result.q, np.array(written["q"]), atol=1e-9)
    assert demos.M == 6 and result.inputs.config.model.sigma_obs == 0.02
    np.testing.assert_allclose(result.inputs.goal, [0.45, -0.25, 0.15])
    assert written["q"] and json.loads((plan_folder / "problem_plan.json").read_text())["config"] == {"sigma_obs": 0.02}


def test_clamp_view_serves_until_interrupted(plan_folder, tmp_path):
    import signal
    import sys
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])}
    # stderr to a file, not a pipe nobody reads while the server runs: a full pipe would block
    # the process on a write and keep it from exiting
    with open(tmp_path / "stderr.txt", "w+") as stderr:
        # as from a terminal: SIGINT at its default (a shell's background job, e.g. a test run
        # started with &, ignores it, and that disposition is inherited)
        process = subprocess.Popen([sys.executable, "-m", "clamp", "view", str(plan_folder), "--port", "0"],
                                   stdout=subprocess.PIPE, stderr=stderr, text=True, env=env,
                                   preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        try:
            line = process.stdout.readline()
            assert line.startswith("clamp view: http://127.0.0.1:"), (line, stderr.seek(0) or stderr.read())
            port = int(line.split("127.0.0.1:")[1].split()[0])
            assert not port_is_closed(port)
            process.send_signal(signal.SIGINT)
            assert process.wait(timeout=30) == 130, stderr.seek(0) or stderr.read()
        finally:
            process.kill()
            process.wait()
    assert port_is_closed(port)


@pytest.mark.parametrize("argv, message", [
    (["view", "{missing}"], "FOLDER: expected the output folder"),
    (["view", "{empty}"], "holds no problem_*.json"),
    (["view", "{folder}", "--plan", "nope"], "--plan: no plan 'nope'"),
    (["view", "{folder}", "--port", "-1"], "--port"),
])
def test_clamp_view_bad_input_is_one_line_exit_2(plan_folder, tmp_path, capsys, argv, message):
    from clamp.cli.commands import main
    names = {"missing": tmp_path / "missing", "empty": tmp_path, "folder": plan_folder}
    assert main([a.format(**names) for a in argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]


def test_mesh_and_point_cloud_obstacles_are_drawn_and_moved_by_their_box_centre(planned):
    from clamp import replan
    from clamp.viz.viewer import obstacle_anchor
    from scenes import PointCloud, TriangleMesh
    from scenes.mesh import box_triangles
    _, result = planned
    cloud = PointCloud(np.random.default_rng(0).uniform([-0.5, 0.3, 0.0], [-0.4, 0.4, 0.1], (50, 3)), 0.01)
    mesh = TriangleMesh(*box_triangles([-0.4, -0.5, 0.05], [0.1, 0.1, 0.1]))
    start = replan(result, scene=Scene([mesh, cloud]))
    with clamp.show(start) as viewer:
        target = np.array([-0.35, -0.45, 0.1])
        viewer.move_obstacle(0, target)
        moved = viewer.scene.obstacles[0]
        np.testing.assert_allclose(obstacle_anchor(moved), target, atol=1e-12)
        np.testing.assert_allclose(moved.vertices - np.asarray(mesh.vertices), np.broadcast_to(
            target - obstacle_anchor(mesh), np.shape(mesh.vertices)), atol=1e-12)
        viewer.move_obstacle(1, [-0.45, 0.3, 0.2])
        np.testing.assert_allclose(obstacle_anchor(viewer.scene.obstacles[1]), [-0.45, 0.3, 0.2], atol=1e-12)
