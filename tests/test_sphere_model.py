"""SphereModel validation and the JSON sphere-file round trip / error messages."""
from __future__ import annotations

import json

import numpy as np
import pytest

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


@pytest.mark.parametrize("kwargs, message", [
    (dict(link_names=("a", "b"), centres=np.zeros((3, 3)), radii=np.ones(2)), "centres: expected shape (2, 3)"),
    (dict(link_names=("a",), centres=np.zeros((1, 3)), radii=np.ones(2)), "radii: expected shape (1,)"),
    (dict(link_names=("a",), centres=[[0, np.nan, 0]], radii=[1.0]), "NaN"),
    (dict(link_names=("a",), centres=[[0, 0, 0]], radii=[-1.0]), "radii: expected positive"),
    (dict(link_names="ab", centres=np.zeros((2, 3)), radii=np.ones(2)), "link_names"),
    (dict(link_names=("a",), centres=[[0, 0, 0]], radii=[1.0], inflation=-0.1), "inflation: expected a finite"),
])
def test_constructor_rejects_bad_arrays(kwargs, message):
    with pytest.raises(InvalidArrayError, match=message.replace("(", r"\(").replace(")", r"\)")):
        SphereModel(**kwargs)


@pytest.mark.parametrize("content, message", [
    ("{not json", "not valid JSON"),
    ("[1, 2]", "expected a JSON object"),
    (json.dumps({"spheres": 3}), "'spheres' holding a list"),
    (json.dumps({"format": "other", "spheres": []}), "'format' must be"),
    (json.dumps({"version": 7, "spheres": []}), "unsupported 'version'"),
    (json.dumps({"inflation": "1cm", "spheres": []}), "'inflation' must be a finite number"),
    (json.dumps({"spheres": [GOOD, {"link": "l", "radius": 0.1}]}), r"spheres\[1\]: expected an object with keys"),
    (json.dumps({"spheres": [{**GOOD, "centre": [0, 1]}]}), r"spheres\[0\]\.centre: expected 3 finite numbers"),
    (json.dumps({"spheres": [{**GOOD, "centre": [0, "x", 1]}]}), r"spheres\[0\]\.centre"),
    ('{"spheres": [{"link": "l", "centre": [0, NaN, 0], "radius": 0.1}]}', r"spheres\[0\]\.centre"),
    (json.dumps({"spheres": [{**GOOD, "radius": 0}]}), r"spheres\[0\]\.radius: expected a positive"),
    (json.dumps({"spheres": [{**GOOD, "radius": True}]}), r"spheres\[0\]\.radius"),
    (json.dumps({"spheres": [{**GOOD, "link": ""}]}), r"spheres\[0\]\.link: expected a non-empty string"),
])
def test_malformed_files_raise_clear_errors(tmp_path, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(SphereFileError, match=message) as info:
        load_sphere_file(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, RobotError) and isinstance(info.value, ValueError)


def test_missing_file_names_the_path(tmp_path):
    with pytest.raises(SphereFileError, match="cannot read sphere file"):
        load_sphere_file(tmp_path / "absent.json")


def test_save_rejects_non_models(tmp_path):
    with pytest.raises(SphereFileError, match="model: expected a SphereModel"):
        save_sphere_file({"spheres": []}, tmp_path / "x.json")
