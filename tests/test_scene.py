"""Scenes: distance over obstacles, default bounds, JSON files and their errors."""
import json

import numpy as np
import pytest

from scenes import (DEFAULT_WORKSPACE, Box, Cylinder, InvalidArgumentError, Scene, SceneFileError,
                    Sphere, available_scenes, builtin_scene)


def make_scene():
    return Scene([Box([0.3, -0.3, 0.1], [0.1, 0.1, 0.2]), Sphere([0.0, 0.4, 0.3], 0.1),
                  Cylinder([-0.3, 0.0, 0.2], 0.05, 0.4, axis=[0, 1, 1])])


def test_distance_is_min_over_obstacles_and_inf_when_empty():
    scene = make_scene()
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.5, 0.5, (7, 11, 3))
    expected = np.min([ob.distance(pts) for ob in scene.obstacles], axis=0)
    assert np.allclose(scene.distance(pts), expected)
    assert np.all(np.isposinf(Scene().distance(pts)))
    assert Scene().distance(np.zeros(3)).shape == ()


def test_default_bounds_cover_workspace_and_obstacles():
    assert np.allclose(Scene().bounds, DEFAULT_WORKSPACE)
    far = Scene([Sphere([1.5, 0.0, 0.2], 0.1)])
    assert np.isclose(far.bounds[1, 0], 1.7)
    assert np.allclose(far.bounds[0], DEFAULT_WORKSPACE[0])
    with pytest.raises(InvalidArgumentError, match="bounds"):
        Scene(bounds=[[0, 0, 0], [1, -1, 1]])
    with pytest.raises(InvalidArgumentError, match="bounds"):
        Scene(bounds=[0, 0, 0, 1, 1, 1])


def test_save_load_round_trip(tmp_path):
    scene = Scene(make_scene().obstacles, bounds=[[-1, -1, -0.5], [1, 1, 1]])
    path = tmp_path / "scene.json"
    scene.save(path)
    loaded = Scene.load(path)
    assert loaded.obstacles == scene.obstacles
    assert np.allclose(loaded.bounds, scene.bounds)
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 1, (50, 3))
    assert np.allclose(loaded.distance(pts), scene.distance(pts))


def test_builtin_box_closing_scene_is_the_reference_obstacle():
    assert "box_closing" in available_scenes()
    scene = builtin_scene("box_closing")
    assert scene.obstacles == [Box.from_reference([0.32, -0.32, 0.13, 0.09, 0.06, 0.28])]
    with pytest.raises(SceneFileError, match="box_closing"):
        builtin_scene("nope")


@pytest.mark.parametrize("content, message", [
    ("{not json", "not valid JSON"),
    ("[1, 2]", "expected a JSON object"),
    ('{"obstacles": {}}', "'obstacles' must be a list"),
    ('{"obstacles": [], "colour": 1}', r"unknown field\(s\) \['colour'\]"),
    ('{"obstacles": [{"type": "sphere", "center": [0,0,0], "radius": 0.1}, '
     '{"type": "sphere", "center": [0,0,0], "radius": -0.1}]}', r"obstacles\[1\].*Sphere radius"),
    ('{"obstacles": [{"type": "box", "center": [0,0,0], "size": [0.1, 0, 0.1]}]}', r"obstacles\[0\].*Box size"),
    ('{"obstacles": [{"type": "cone"}]}', r"obstacles\[0\]\.type.*'box'"),
    ('{"obstacles": [{"type": "box", "center": [0,0,0]}]}', r"obstacles\[0\].*missing.*size"),
    ('{"obstacles": [{"type": "sphere", "center": [0,0], "radius": 1}]}', r"obstacles\[0\].*Sphere center"),
    ('{"obstacles": [{"type": "sphere", "center": [0,0,0], "radius": 1, "mass": 2}]}', r"obstacles\[0\].*mass"),
    ('{"obstacles": [{"type": "box", "reference": [0,0,0,1,1]}]}', r"obstacles\[0\]\.reference"),
    ('{"obstacles": [], "bounds": [[0,0,0],[1,1]]}', "bounds"),
])
def test_malformed_scene_files_raise_naming_the_field(tmp_path, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(SceneFileError, match=message):
        Scene.load(path)


def test_missing_scene_file_raises(tmp_path):
    with pytest.raises(SceneFileError, match="cannot read"):
        Scene.load(tmp_path / "absent.json")


def test_reference_box_rows_in_scene_file(tmp_path):
    path = tmp_path / "ref.json"
    path.write_text(json.dumps({"obstacles": [{"type": "box", "reference": [0.32, -0.32, 0.13, 0.09, 0.06, 0.28]}]}))
    assert Scene.load(path).obstacles[0] == Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])


def test_scene_rejects_non_obstacles():
    with pytest.raises(ValueError, match=r"obstacles\[0\]"):
        Scene([[0, 0, 0]])
