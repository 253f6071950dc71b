"""Bad-input catalogue of ``scenes``: every public function of docs/interfaces.md fed bad
input answers with the project's error naming the argument (see tests/bad_input.py)."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from skillplan.errors import ArgumentTypeError
import scipy.io

from bad_input import Case, cases, check
from scenes import (Box, Capsule, Cylinder, Demonstrations, Scene, SignedDistanceField, Sphere,
                    builtin_scene, load_demonstrations, make_cluttered_demonstrations,
                    make_demonstrations, save_csv, shared_dataset)
from skillplan.command_line import (atomic_write, atomic_write_text, integer_at_least,
                                 output_directory, output_file)
from scenes.errors import (ScenesTypeError, DemonstrationFileError, InvalidArgumentError,
                           InvalidDemonstrationsError, InvalidObstacleError, OutputPathError,
                           SceneFileError, UnknownSkillError)
from scenes.obstacles import obstacle_from_dict
from skillplan.progress import progress, set_progress
from skillplan.validation import as_array, as_file, as_indices, as_instance, as_path, as_seed, as_sequence

BOX = Box([0.3, -0.3, 0.2], [0.1, 0.1, 0.1])


def _demos() -> Demonstrations:
    return make_demonstrations("box_closing", num_demos=3, num_points=20)


def _npz(fx) -> Path:
    """Three demonstrations saved as .npz (written once per module)."""
    path = fx.tmp / "three.npz"
    if not path.exists():
        _demos().save_npz(path)
    return path


def _write(fx, name: str, text: str | bytes) -> Path:
    path = fx.tmp / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


def _scene_file(fx, name: str, data) -> Path:
    return _write(fx, name, json.dumps(data))


def _box_json(**fields) -> dict:
    return {"obstacles": [{"type": "box", "center": [0, 0, 0], "size": [0.1, 0.1, 0.1], **fields}]}


def _clamp_mat(fx, name: str, edit) -> Path:
    """A CLAMP .mat of 3 synthetic demonstrations, one of them edited by edit(fields dict)."""
    d = _demos()
    rows = []
    for m in range(d.M):
        fields = {"pos": d.positions[m].copy(), "vel": d.velocities[m].copy(), "time": d.time.copy()}
        if m == 1:
            edit(fields)
        rows.append(fields)
    names = sorted(set().union(*rows))
    table = np.zeros((len(rows),), dtype=[(k, "O") for k in names])
    for m, fields in enumerate(rows):
        table[m] = tuple(fields.get(k, np.zeros((0, 3))) for k in names)
    path = fx.tmp / name
    scipy.io.savemat(path, {"dataset": table})
    return path


def _edit(key, value):
    def edit(fields):
        if value is None:
            fields.pop(key)
        else:
            fields[key] = value(fields[key]) if callable(value) else value
    return edit


def _nan_at(a):
    a = np.array(a, dtype=float)
    a[3, 1] = np.nan
    return a


def _repeat_time(t):
    t = np.array(t, dtype=float)
    t[5] = t[4]
    return t


def _csv(rows: list[str], header: str = "demo,t,x,y,z") -> str:
    return "\n".join([header, *rows]) + "\n"


def _csv_demo(label: int, count: int, step: float = 0.1, t0: float = 0.0) -> list[str]:
    return [f"{label},{t0 + k * step},{0.1 + 0.01 * k},{-0.3 + label * 0.01},{0.2}"
            for k in range(count)]


AT = ArgumentTypeError          # skillplan's: the plumbing's own wrong-kind error
E, IA, O, SF, DF, DE = (ScenesTypeError, InvalidArgumentError, InvalidObstacleError,
                         SceneFileError, DemonstrationFileError, InvalidDemonstrationsError)

CATALOGUE: list[Case] = [
    # --- obstacles
    Case("box-center-shape", lambda fx: Box([0, 0], [1, 1, 1]), O, "center"),
    Case("box-center-nan", lambda fx: Box([0, np.nan, 0], [1, 1, 1]), O, "center"),
    Case("box-center-1e200", lambda fx: Box([1e200, 0, 0], [1, 1, 1]), O, "center"),
    Case("box-center-text", lambda fx: Box("abc", [1, 1, 1]), O, "center"),
    Case("box-size-negative", lambda fx: Box([0, 0, 0], [1, -1, 1]), O, "size"),
    Case("box-size-zero", lambda fx: Box([0, 0, 0], [1, 0, 1]), O, "size"),
    Case("box-size-bools", lambda fx: Box([0, 0, 0], [True, True, True]), O, "size"),
    Case("box-size-mixed-bool", lambda fx: Box([0, 0, 0], [True, 0.1, 0.1]), O, "size"),
    Case("box-size-inf", lambda fx: Box([0, 0, 0], [np.inf, 1, 1]), O, "size"),
    Case("box-rotation-shape", lambda fx: Box([0, 0, 0], [1, 1, 1], np.eye(2)), O, "rotation"),
    Case("box-rotation-reflection", lambda fx: Box([0, 0, 0], [1, 1, 1], -np.eye(3)), O, "rotation"),
    Case("box-rotation-scaled", lambda fx: Box([0, 0, 0], [1, 1, 1], 2 * np.eye(3)), O, "rotation"),
    Case("box-reference-length", lambda fx: Box.from_reference([0, 0, 0, 1, 1]), O, "reference"),
    Case("sphere-radius-zero", lambda fx: Sphere([0, 0, 0], 0.0), O, "radius"),
    Case("sphere-radius-bool", lambda fx: Sphere([0, 0, 0], True), O, "radius"),
    Case("sphere-radius-text", lambda fx: Sphere([0, 0, 0], "0.1"), O, "radius"),
    Case("sphere-radius-1e200", lambda fx: Sphere([0, 0, 0], 1e200), O, "radius"),
    Case("cylinder-axis-zero", lambda fx: Cylinder([0, 0, 0], 0.1, 0.2, [0, 0, 0]), O, "axis"),
    Case("cylinder-height-negative", lambda fx: Cylinder([0, 0, 0], 0.1, -0.2), O, "height"),
    Case("capsule-height-negative", lambda fx: Capsule([0, 0, 0], 0.1, -0.2), O, "height"),
    Case("capsule-radius-nan", lambda fx: Capsule([0, 0, 0], np.nan, 0.2), O, "radius"),
    Case("distance-points-shape", lambda fx: BOX.distance(np.zeros((4, 2))), IA, "points"),
    Case("distance-points-nan", lambda fx: BOX.distance([np.nan, 0, 0]), IA, "points"),
    Case("query-points-text", lambda fx: BOX.query("here"), IA, "points"),
    Case("translated-offset-shape", lambda fx: BOX.translated([1, 2]), IA, "offset"),
    Case("from-dict-not-dict", lambda fx: obstacle_from_dict([1, 2]), O, "obstacle"),
    Case("from-dict-type-list", lambda fx: obstacle_from_dict({"type": ["box"]}), O, "type"),
    Case("from-dict-unknown-type", lambda fx: obstacle_from_dict({"type": "cone"}), O, "type"),
    Case("from-dict-missing", lambda fx: obstacle_from_dict({"type": "sphere", "center": [0, 0, 0]}),
         O, "radius"),
    Case("from-dict-extra", lambda fx: obstacle_from_dict({"type": "sphere", "center": [0, 0, 0],
                                                           "radius": 1, "colour": "red"}), O, "colour"),
    # --- scenes
    Case("scene-not-obstacles", lambda fx: Scene([BOX, "wall"]), O, "obstacles[1]"),
    Case("scene-obstacles-number", lambda fx: Scene(3), E, "obstacles"),
    Case("scene-obstacles-dict", lambda fx: Scene({"type": "box"}), E, "obstacles"),
    Case("scene-bounds-shape", lambda fx: Scene([BOX], bounds=[0, 0, 0]), IA, "bounds"),
    Case("scene-bounds-order", lambda fx: Scene([BOX], bounds=[[1, 1, 1], [0, 0, 0]]), IA, "bounds"),
    Case("scene-bounds-nan", lambda fx: Scene([BOX], bounds=[[0, 0, np.nan], [1, 1, 1]]), IA, "bounds"),
    Case("scene-bounds-bools", lambda fx: Scene([], bounds=[[False] * 3, [True] * 3]), IA, "bounds"),
    Case("scene-distance-points", lambda fx: Scene([BOX]).distance([[1, 2]]), IA, "points"),
    Case("scene-query-points-inf", lambda fx: Scene([BOX]).query([np.inf, 0, 0]), IA, "points"),
    Case("scene-sdf-cell-zero", lambda fx: Scene([BOX]).sdf(0.0), IA, "cell_size"),
    Case("scene-sdf-cell-large", lambda fx: Scene([BOX]).sdf(0.5), IA, "cell_size"),
    Case("scene-sdf-cell-1e-4", lambda fx: Scene([BOX]).sdf(1e-4), IA, "GiB"),
    Case("scene-sdf-cell-text", lambda fx: Scene([BOX]).sdf("fine"), IA, "cell_size"),
    Case("scene-distance-query-cell", lambda fx: Scene([BOX]).distance_query(-1.0), IA, "cell_size"),
    Case("sdf-from-obstacles-not-obstacle",
         lambda fx: SignedDistanceField.from_obstacles([1], [[0, 0, 0], [1, 1, 1]]), O, "obstacles[0]"),
    Case("sdf-from-obstacles-bounds",
         lambda fx: SignedDistanceField.from_obstacles([BOX], [[0, 0, 0]]), IA, "bounds"),
    Case("sdf-estimate-cell", lambda fx: SignedDistanceField.estimate_build_bytes(
        [[0, 0, 0], [1, 1, 1]], 0), IA, "cell_size"),
    Case("sdf-query-points", lambda fx: Scene([BOX]).sdf().query(np.zeros((2, 4))), IA, "points"),
    Case("scene-save-path-type", lambda fx: Scene([BOX]).save(None), E, "path"),
    Case("sdf-distance-points", lambda fx: Scene([BOX]).sdf().distance([[np.nan, 0, 0]]), IA, "points"),
    Case("contains-points", lambda fx: BOX.contains(np.zeros((2, 2))), IA, "points"),
    Case("scene-load-missing", lambda fx: Scene.load(fx.tmp / "none.json"), SF, "none.json"),
    Case("scene-load-directory", lambda fx: Scene.load(fx.tmp), SF, "directory"),
    Case("scene-load-not-json", lambda fx: Scene.load(_write(fx, "bad.json", "{obstacles")), SF,
         "bad.json"),
    Case("scene-load-latin1", lambda fx: Scene.load(_write(fx, "latin.json", '{"name": "caf\xe9"}'
                                                          .encode("latin-1"))), SF, "UTF-8"),
    Case("scene-load-list", lambda fx: Scene.load(_scene_file(fx, "list.json", [1, 2])), SF, "object"),
    Case("scene-load-type-list", lambda fx: Scene.load(_scene_file(
        fx, "tl.json", {"obstacles": [{"type": ["box"]}]})), SF, "obstacles[0].type"),
    Case("scene-load-size-bools", lambda fx: Scene.load(_scene_file(
        fx, "sb.json", _box_json(size=[True, True, True]))), SF, "size"),
    Case("scene-load-size-text", lambda fx: Scene.load(_scene_file(
        fx, "st.json", _box_json(size="big"))), SF, "size"),
    Case("scene-load-nan", lambda fx: Scene.load(_write(
        fx, "nan.json", '{"obstacles": [{"type": "sphere", "center": [NaN, 0, 0], "radius": 1}]}')),
         SF, "center"),
    Case("scene-load-obstacles-dict", lambda fx: Scene.load(_scene_file(
        fx, "od.json", {"obstacles": {"type": "box"}})), SF, "obstacles"),
    Case("scene-load-unknown-field", lambda fx: Scene.load(_scene_file(
        fx, "uf.json", {"obstacle": []})), SF, "obstacle"),
    Case("scene-load-bounds", lambda fx: Scene.load(_scene_file(
        fx, "bd.json", {"obstacles": [], "bounds": [1, 2]})), SF, "bounds"),
    Case("scene-load-path-type", lambda fx: Scene.load(3.5), E, "path"),
    Case("builtin-scene-unknown", lambda fx: builtin_scene("kitchen"), SF, "kitchen"),
    Case("builtin-scene-type", lambda fx: builtin_scene(["box_closing"]), E, "name"),
    # --- demonstrations
    Case("demos-rank", lambda fx: Demonstrations(np.zeros((3, 4)), np.zeros((3, 4)), np.arange(3.0)),
         DE, "positions"),
    Case("demos-one", lambda fx: Demonstrations(np.zeros((1, 4, 3)), np.zeros((1, 4, 3)),
                                                np.arange(4.0)), DE, "positions"),
    Case("demos-one-step", lambda fx: Demonstrations(np.zeros((2, 1, 3)), np.zeros((2, 1, 3)),
                                                     np.arange(1.0)), DE, "positions"),
    Case("demos-nan", lambda fx: Demonstrations(np.stack([_nan_at(np.zeros((4, 3)))] * 2), np.zeros((2, 4, 3)),
                                                np.arange(4.0)), DE, "positions"),
    Case("demos-1e200", lambda fx: Demonstrations(np.full((2, 4, 3), 1e200), np.zeros((2, 4, 3)),
                                                  np.arange(4.0)), DE, "positions"),
    Case("demos-bools", lambda fx: Demonstrations(np.ones((2, 4, 3), bool), np.zeros((2, 4, 3)),
                                                  np.arange(4.0)), DE, "positions"),
    Case("demos-velocity-shape", lambda fx: Demonstrations(np.zeros((2, 4, 3)), np.zeros((2, 3, 3)),
                                                           np.arange(4.0)), DE, "velocities"),
    Case("demos-time-order", lambda fx: Demonstrations(np.zeros((2, 4, 3)), np.zeros((2, 4, 3)),
                                                       [0, 1, 1, 2]), DE, "time"),
    Case("demos-time-length", lambda fx: Demonstrations(np.zeros((2, 4, 3)), np.zeros((2, 4, 3)),
                                                        np.arange(5.0)), DE, "time"),
    Case("demos-obstacles-count", lambda fx: Demonstrations(
        np.zeros((2, 4, 3)), np.zeros((2, 4, 3)), np.arange(4.0), [[BOX]]), DE, "obstacles"),
    Case("demos-obstacles-item", lambda fx: Demonstrations(
        np.zeros((2, 4, 3)), np.zeros((2, 4, 3)), np.arange(4.0), [[BOX], ["box"]]), DE, "obstacles[1][0]"),
    Case("demos-obstacles-flat", lambda fx: Demonstrations(
        np.zeros((2, 4, 3)), np.zeros((2, 4, 3)), np.arange(4.0), [BOX, BOX]), DE, "obstacles[0]"),
    Case("resample-one", lambda fx: _demos().resample(1), DE, "T"),
    Case("resample-float", lambda fx: _demos().resample(10.5), DE, "T"),
    Case("align-dtw-reference", lambda fx: _demos().align_dtw(reference=7), DE, "reference"),
    Case("translated-shape", lambda fx: _demos().translated([0, 1]), DE, "offset"),
    Case("from-trajectories-one", lambda fx: Demonstrations.from_trajectories([np.zeros((4, 3))]),
         DE, "trajectories"),
    Case("from-trajectories-short", lambda fx: Demonstrations.from_trajectories(
        [np.zeros((4, 3)), np.zeros((1, 3))]), DE, "trajectories[1]"),
    Case("from-trajectories-not-list", lambda fx: Demonstrations.from_trajectories(5), E, "trajectories"),
    Case("from-trajectories-times", lambda fx: Demonstrations.from_trajectories(
        [np.zeros((4, 3))] * 2, times=[np.arange(4.0)]), DE, "times"),
    Case("from-trajectories-time-order", lambda fx: Demonstrations.from_trajectories(
        [np.zeros((4, 3))] * 2, times=[np.arange(4.0), [0, 2, 1, 3]]), DE, "times[1]"),
    Case("from-trajectories-num-points", lambda fx: Demonstrations.from_trajectories(
        [np.zeros((4, 3))] * 2, num_points=1), DE, "num_points"),
    Case("from-trajectories-duration", lambda fx: Demonstrations.from_trajectories(
        [np.zeros((4, 3))] * 2, duration=-1.0), DE, "duration"),
    Case("save-npz-path-type", lambda fx: _demos().save_npz(3.5), E, "path"),
    Case("save-csv-not-demos", lambda fx: save_csv(np.zeros((2, 4, 3)), fx.tmp / "x.csv"), E, "demos"),
    Case("make-unknown-skill", lambda fx: make_demonstrations("juggling"), UnknownSkillError, "juggling"),
    Case("make-num-demos", lambda fx: make_demonstrations("box_closing", num_demos=1), IA, "num_demos"),
    Case("make-num-points-bool", lambda fx: make_demonstrations("box_closing", num_points=True), IA,
         "num_points"),
    Case("make-dt", lambda fx: make_demonstrations("box_closing", dt=0.0), IA, "dt"),
    Case("make-seed-negative", lambda fx: make_demonstrations("box_closing", seed=-1), IA, "seed"),
    Case("make-seed-text", lambda fx: make_demonstrations("box_closing", seed="a"), IA, "seed"),
    Case("make-skill-type", lambda fx: make_demonstrations(["box_closing"]), IA, "skill"),
    Case("shared-dataset-type", lambda fx: shared_dataset(3), E, "name"),
    Case("shared-dataset-path", lambda fx: shared_dataset("../secret"), IA, "name"),
    # --- demonstration files
    Case("load-missing", lambda fx: load_demonstrations(fx.tmp / "none.mat"), DF, "none.mat"),
    Case("load-directory", lambda fx: load_demonstrations(fx.tmp), DF, "directory"),
    Case("load-suffix", lambda fx: load_demonstrations(_write(fx, "d.txt", "1,2")), DF, "suffix"),
    Case("load-path-type", lambda fx: load_demonstrations(12), E, "path"),
    Case("csv-header", lambda fx: load_demonstrations(_write(fx, "h.csv", "a,b\n1,2\n")), DF, "header"),
    Case("csv-empty", lambda fx: load_demonstrations(_write(fx, "e.csv", "")), DF, "header"),
    Case("csv-one-sample", lambda fx: load_demonstrations(_write(
        fx, "one.csv", _csv(_csv_demo(0, 1) + _csv_demo(1, 1)))), DF, "demonstrations[0]"),
    Case("csv-one-demo", lambda fx: load_demonstrations(_write(
        fx, "onedemo.csv", _csv(_csv_demo(0, 5)))), DF, "demonstrations"),
    Case("csv-nan", lambda fx: load_demonstrations(_write(
        fx, "nan.csv", _csv(_csv_demo(0, 4) + _csv_demo(1, 3) + ["1,0.3,nan,0,0"]))), DF, "NaN"),
    Case("csv-time-order", lambda fx: load_demonstrations(_write(
        fx, "order.csv", _csv(_csv_demo(0, 4) + _csv_demo(1, 4, step=-0.1)))), DF, "time"),
    Case("csv-text-cell", lambda fx: load_demonstrations(_write(
        fx, "text.csv", _csv(_csv_demo(0, 4) + ["1,0,a,b,c"]))), DF, "row"),
    Case("csv-latin1", lambda fx: load_demonstrations(_write(
        fx, "latin.csv", "demo,t,x,y,z\n0,0,1,1,\xe9\n".encode("latin-1"))), DF, "latin.csv"),
    Case("csv-1e200", lambda fx: load_demonstrations(_write(
        fx, "huge.csv", _csv(_csv_demo(0, 4) + _csv_demo(1, 3) + ["1,0.3,1e200,0,0"]))), DF, "magnitude"),
    Case("csv-identical-time-other-labels", lambda fx: load_demonstrations(_write(
        fx, "dup.csv", _csv(_csv_demo(0, 4) + _csv_demo(0, 4, t0=5)))), DF, "demonstrations"),
    Case("mat-garbage", lambda fx: load_demonstrations(_write(fx, "g.mat", b"MATLAB garbage")), DF, "g.mat"),
    Case("mat-no-variable", lambda fx: load_demonstrations(_savemat(fx, "nv.mat", {"x": 1.0})), DF,
         "dataset"),
    Case("mat-nan", lambda fx: load_demonstrations(_clamp_mat(fx, "nan.mat", _edit("pos", _nan_at))),
         DF, "pos"),
    Case("mat-time-repeat-no-vel", lambda fx: load_demonstrations(_clamp_mat(
        fx, "tr.mat", lambda f: (f.pop("vel"), f.update(time=_repeat_time(f["time"]))))), DF, "time"),
    Case("mat-pos-shape", lambda fx: load_demonstrations(_clamp_mat(
        fx, "ps.mat", _edit("pos", lambda p: p[:, :2]))), DF, "pos"),
    Case("mat-vel-shape", lambda fx: load_demonstrations(_clamp_mat(
        fx, "vs.mat", _edit("vel", lambda v: v[:4]))), DF, "vel"),
    Case("mat-pos-text", lambda fx: load_demonstrations(_clamp_mat(fx, "pt.mat", _edit("pos", "abc"))),
         DF, "pos"),
    Case("mat-time-text", lambda fx: load_demonstrations(_clamp_mat(fx, "tt.mat", _edit("time", "abc"))),
         DF, "time"),
    Case("mat-smooth-shape", lambda fx: load_demonstrations(_savemat(
        fx, "sm.mat", {"smoothData": np.array([np.zeros((5, 2)), np.zeros((5, 2))], dtype=object)})),
         DF, "smoothData"),
    Case("mat-smooth-text", lambda fx: load_demonstrations(_savemat(
        fx, "st.mat", {"smoothData": "abc"})), DF, "smoothData"),
    Case("npz-garbage", lambda fx: load_demonstrations(_write(fx, "g.npz", b"PK garbage")), DF, "g.npz"),
    Case("npz-missing", lambda fx: load_demonstrations(_savez(fx, "m.npz", positions=np.zeros((2, 3, 3))))
         , DF, "velocities"),
    Case("npz-obstacles", lambda fx: load_demonstrations(_savez(
        fx, "o.npz", positions=np.zeros((2, 3, 3)), velocities=np.zeros((2, 3, 3)),
        time=np.arange(3.0), obstacles=np.array("[[{\"type\": 1}], []]"))), DF, "obstacles"),
    Case("npz-obstacles-json", lambda fx: load_demonstrations(_savez(
        fx, "oj.npz", positions=np.zeros((2, 3, 3)), velocities=np.zeros((2, 3, 3)),
        time=np.arange(3.0), obstacles=np.array("[[{"))), DF, "obstacles"),
    # --- cluttered demonstrations, per-demonstration scenes, .npz demonstrations
    Case("clutter-skill", lambda fx: make_cluttered_demonstrations("juggling"), UnknownSkillError,
         "juggling"),
    Case("clutter-num-demos", lambda fx: make_cluttered_demonstrations("box_closing", num_demos=0), IA,
         "num_demos"),
    Case("clutter-seed", lambda fx: make_cluttered_demonstrations("box_closing", seed=-1), IA, "seed"),
    Case("clutter-detour", lambda fx: make_cluttered_demonstrations("box_closing", detour=-1), IA, "detour"),
    Case("clutter-detour-nan", lambda fx: make_cluttered_demonstrations("box_closing", detour=np.nan), IA,
         "detour"),
    Case("clutter-box-size", lambda fx: make_cluttered_demonstrations("box_closing", box_size=0), IA,
         "box_size"),
    Case("clutter-width-text", lambda fx: make_cluttered_demonstrations("box_closing", width="a"), IA,
         "width"),
    Case("clutter-dt", lambda fx: make_cluttered_demonstrations("box_closing", dt=0), IA, "dt"),
    Case("clutter-num-points", lambda fx: make_cluttered_demonstrations("box_closing", num_points=1), IA,
         "num_points"),
    Case("load-scenes-count", lambda fx: load_demonstrations(_npz(fx), scenes=[Scene()]), DF, "scenes"),
    Case("load-scenes-number", lambda fx: load_demonstrations(_npz(fx), scenes=42), E, "scenes"),
    Case("load-scenes-text", lambda fx: load_demonstrations(_npz(fx), scenes="scene.json"), E, "scenes"),
    Case("load-scenes-item", lambda fx: load_demonstrations(_npz(fx), scenes=[42] * 3), E, "path"),
    Case("load-scenes-missing", lambda fx: load_demonstrations(_npz(fx), scenes=["none.json"] * 3), SF,
         "none.json"),
    Case("load-npz-missing", lambda fx: Demonstrations.load_npz(fx.tmp / "none.npz"), DF, "path"),
    Case("load-npz-type", lambda fx: Demonstrations.load_npz(42), E, "path"),
    Case("load-npz-directory", lambda fx: Demonstrations.load_npz(fx.tmp), DF, "directory"),
    Case("load-npz-junk", lambda fx: Demonstrations.load_npz(_write(fx, "junk.npz", b"junk")), DF,
         "junk.npz"),
    # --- command-line helpers and progress bars (skillplan.command_line, skillplan.progress)
    Case("output-directory-type", lambda fx: output_directory(42), AT, "--out"),
    Case("output-directory-file", lambda fx: output_directory(_write(fx, "a.txt", "x")), OutputPathError,
         "--out"),
    Case("output-directory-not-empty", lambda fx: output_directory(fx.tmp), OutputPathError, "--out"),
    Case("output-file-type", lambda fx: output_file(42), AT, "--out"),
    Case("output-file-exists", lambda fx: output_file(_write(fx, "b.txt", "x")), OutputPathError, "--out"),
    Case("output-file-folder", lambda fx: output_file(fx.tmp), OutputPathError, "--out"),
    Case("output-file-no-parent", lambda fx: output_file(fx.tmp / "none" / "c.txt"), OutputPathError,
         "--out"),
    Case("atomic-write-type", lambda fx: atomic_write(42, lambda handle: handle.write(b"y")), AT, "path"),
    Case("atomic-write-exists", lambda fx: atomic_write(_write(fx, "d.txt", "x"),
                                                        lambda handle: handle.write(b"y")),
         OutputPathError, "path"),
    Case("atomic-write-function", lambda fx: atomic_write(fx.tmp / "e.txt", b"y"), AT, "write"),
    Case("atomic-write-no-folder", lambda fx: atomic_write(fx.tmp / "none" / "f.txt",
                                                           lambda handle: handle.write(b"y")),
         OutputPathError, "folder"),
    Case("atomic-write-text-type", lambda fx: atomic_write_text(fx.tmp / "g.txt", 42), AT, "text"),
    Case("integer-at-least-minimum", lambda fx: integer_at_least("1"), AT, "minimum"),
    Case("progress-description", lambda fx: progress([1], description=5), AT, "description"),
    Case("progress-total", lambda fx: progress([1], description="x", total=-1), IA, "total"),
    Case("set-progress-text", lambda fx: set_progress("yes"), AT, "enabled"),
    # --- skillplan.validation helpers (the one helper the packages wrap)
    Case("validation-seed-negative", lambda fx: as_seed(-1, "seed"), IA, "seed"),
    Case("validation-seed-float", lambda fx: as_seed(1.5, "seed"), IA, "seed"),
    Case("validation-instance", lambda fx: as_instance("x", "scene", Scene, "a Scene", E), E, "scene"),
    Case("validation-sequence-text", lambda fx: as_sequence("abc", "items", "a list", E), E, "items"),
    Case("validation-path-number", lambda fx: as_path(42, "path", E), E, "path"),
    Case("validation-file-missing", lambda fx: as_file(fx.tmp / "none.txt", "path", IA), IA, "does not exist"),
    Case("validation-file-directory", lambda fx: as_file(fx.tmp, "path", IA), IA, "directory"),
    Case("validation-indices-negative", lambda fx: as_indices([0, -1], "indices"), IA, "indices"),
    Case("validation-array-nan-allowing-inf", lambda fx: as_array([np.inf, np.nan], "limits",
                                                                  allow_infinite=True), IA, "limits"),
]


def _savemat(fx, name: str, data: dict) -> Path:
    path = fx.tmp / name
    scipy.io.savemat(path, data)
    return path


def _savez(fx, name: str, **arrays) -> Path:
    path = fx.tmp / name
    np.savez(path, **arrays)
    return path


@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    return SimpleNamespace(tmp=tmp_path_factory.mktemp("bad_scenes"))


@pytest.mark.parametrize("case", cases(CATALOGUE))
def test_bad_input(case: Case, fx) -> None:
    check(case, fx)


def test_catalogue_size() -> None:
    assert len(CATALOGUE) >= 100


def test_reasonable_inputs_are_accepted(tmp_path) -> None:
    """What a user would reasonably pass is taken properly, not ignored."""
    assert Scene(BOX).obstacles == (BOX,)                      # a single obstacle
    path = tmp_path / "scene.json"
    Scene([BOX]).save(path)
    assert Scene.load(str(path)).obstacles == (BOX,)           # str or Path
    assert Box([0, 0, 0], (1, 2, 3)).size.tolist() == [1, 2, 3]
    demos = make_demonstrations("box_closing", num_demos=2, num_points=10, seed=np.int64(3))
    assert demos.M == 2


def test_identical_time_in_csv_means_one_axis(tmp_path) -> None:
    """Two CSV demonstrations with different time stamps but equal lengths are resampled to a
    common phase axis (documented), not rejected."""
    path = tmp_path / "d.csv"
    path.write_text(_csv(_csv_demo(0, 5) + _csv_demo(1, 5, step=0.2)))
    demos = load_demonstrations(path)
    assert demos.M == 2 and demos.T == 5
