"""SphereModel validation and the JSON sphere-file round trip / error messages."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bad_input import raises_naming
from robots.errors import InvalidArrayError, RobotError, SphereFileError
from robots.sphere_model import SphereModel, load_sphere_file, save_sphere_file


GOOD = {"link": "l", "centre": [0.0, 0.0, 0.1], "radius": 0.05}


def _model() -> SphereModel:
    rng = np.random.default_rng(3)
    return SphereModel(("a", "b", "a"), rng.normal(size=(3, 3)) * 0.1, rng.uniform(0.01, 0.1, 3), inflation=0.01)


def test_round_trip_is_exact(tmp_path):
    model = _model()
    path = tmp_path / "spheres.json"
    save_sphere_file(model, path)
    loaded = load_sphere_file(path)
    assert loaded.link_names == model.link_names
    np.testing.assert_array_equal(loaded.centres, model.centres)
    np.testing.assert_array_equal(loaded.radii, model.radii)
    assert loaded.inflation == 0.01
    assert json.loads(path.read_text())["format"] == "skillplan-spheres"


def test_empty_model_round_trip_and_default_inflation(tmp_path):
    empty = SphereModel((), np.zeros((0, 3)), np.zeros(0))
    save_sphere_file(empty, tmp_path / "e.json")
    assert load_sphere_file(tmp_path / "e.json").count == 0
    (tmp_path / "old.json").write_text(json.dumps({"spheres": [GOOD]}))
    assert load_sphere_file(tmp_path / "old.json").inflation == 0.0


def test_per_link_access():
    model = _model()
    centres, radii = model.for_link("a")
    np.testing.assert_array_equal(centres, model.centres[[0, 2]])
    np.testing.assert_array_equal(radii, model.radii[[0, 2]])
    assert model.links() == ("a", "b") and len(model) == 3
    assert model.for_link("zzz")[0].shape == (0, 3)


@pytest.mark.parametrize("kwargs, name", [
    (dict(link_names=("a", "b"), centres=np.zeros((3, 3)), radii=np.ones(2)), "centres"),
    (dict(link_names=("a",), centres=np.zeros((1, 3)), radii=np.ones(2)), "radii"),
    (dict(link_names=("a",), centres=[[0, np.nan, 0]], radii=[1.0]), "centres/radii"),
    (dict(link_names=("a",), centres=[[0, 0, 0]], radii=[-1.0]), "radii"),
    (dict(link_names="ab", centres=np.zeros((2, 3)), radii=np.ones(2)), "link_names"),
    (dict(link_names=("a",), centres=[[0, 0, 0]], radii=[1.0], inflation=-0.1), "inflation"),
])
def test_constructor_rejects_bad_arrays(kwargs, name):
    with raises_naming(InvalidArrayError, name):
        SphereModel(**kwargs)


@pytest.mark.parametrize("content, names", [
    ("{not json", ()),
    ("[1, 2]", ()),
    (json.dumps({"spheres": 3}), ("spheres",)),
    (json.dumps({"format": "other", "spheres": []}), ("format",)),
    (json.dumps({"version": 7, "spheres": []}), ("version",)),
    (json.dumps({"inflation": "1cm", "spheres": []}), ("inflation",)),
    (json.dumps({"spheres": [GOOD, {"link": "l", "radius": 0.1}]}), ("spheres[1]",)),
    (json.dumps({"spheres": [{**GOOD, "centre": [0, 1]}]}), ("spheres[0].centre",)),
    (json.dumps({"spheres": [{**GOOD, "centre": [0, "x", 1]}]}), ("spheres[0].centre",)),
    ('{"spheres": [{"link": "l", "centre": [0, NaN, 0], "radius": 0.1}]}', ("spheres[0].centre",)),
    (json.dumps({"spheres": [{**GOOD, "radius": 0}]}), ("spheres[0].radius",)),
    (json.dumps({"spheres": [{**GOOD, "radius": True}]}), ("spheres[0].radius",)),
    (json.dumps({"spheres": [{**GOOD, "link": ""}]}), ("spheres[0].link",)),
])
def test_malformed_files_raise_clear_errors(tmp_path, content, names):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with raises_naming(SphereFileError, str(path), *names) as info:
        load_sphere_file(path)
    assert isinstance(info.value, RobotError) and isinstance(info.value, ValueError)


def test_missing_file_names_the_path(tmp_path):
    with raises_naming(SphereFileError, "absent.json"):
        load_sphere_file(tmp_path / "absent.json")


def test_save_rejects_non_models(tmp_path):
    with raises_naming(SphereFileError, "model"):
        save_sphere_file({"spheres": []}, tmp_path / "x.json")
