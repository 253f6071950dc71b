"""Importers and exporters of demonstration files; location of the shared data sets."""
import numpy as np
import pytest
import scipy.io
from scipy.integrate import cumulative_trapezoid

from bad_input import raises_naming
from scenes import (NOMINAL_DURATION, Box, DemonstrationFileError, Demonstrations, load_demonstrations,
                    make_demonstrations, save_csv)
from scenes import shared_dataset as find_shared_dataset


@pytest.mark.parametrize("name, shape", [("box_closing", (6, 250, 3)), ("needle_threading", (4, 1500, 3)),
                                         ("pick_place", (4, 1500, 3)), ("synthetic0", (3, 300, 3))])
def test_shared_datasets_import_with_the_right_shapes(shared_dataset, name, shape):
    demos = load_demonstrations(shared_dataset(name))
    assert demos.positions.shape == shape and demos.velocities.shape == shape
    assert demos.name == name
    assert np.all(np.isfinite(demos.positions))


def test_box_closing_keeps_recorded_time_and_velocities(shared_dataset):
    path = shared_dataset("box_closing")
    demos = load_demonstrations(path)
    raw = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    assert np.isclose(demos.dt, 0.16) and np.isclose(raw["dt"], 0.16)
    assert np.array_equal(demos.time, raw["dataset"][0].time)
    assert np.array_equal(demos.velocities[3], raw["dataset"][3].vel)
    # the recorded velocities are the time derivative of the positions
    derivative = np.gradient(demos.positions, demos.time, axis=1)
    assert np.abs(derivative - demos.velocities)[:, 1:-1].max() < 1e-3
    # the demonstrations start near the reference's new start position
    assert np.linalg.norm(demos.positions[:, 0].mean(axis=0) - [0.2054, -0.4722, 0.2625]) < 0.15


def test_tlgc_files_get_nominal_time_and_spline_velocities(shared_dataset):
    demos = load_demonstrations(shared_dataset("needle_threading"))
    assert np.allclose(demos.time, np.linspace(0, NOMINAL_DURATION, 1500))
    # velocities integrate back to the positions
    integrated = demos.positions[:, :1] + cumulative_trapezoid(demos.velocities, demos.time, axis=1, initial=0)
    assert np.abs(integrated - demos.positions).max() < 1e-3
    assert demos.obstacles is None


def write_clamp_mat(path, demos, obstacles=None, drop=None, dt=0.16):
    fields = [("pos", "O"), ("vel", "O"), ("time", "O")] + ([("obs", "O")] if obstacles is not None else [])
    fields = [f for f in fields if f[0] != drop]
    dataset = np.zeros((1, demos.M), dtype=fields)
    for m in range(demos.M):
        values = {"pos": demos.positions[m], "vel": demos.velocities[m], "time": demos.time[:, None]}
        if obstacles is not None:
            values["obs"] = obstacles[m]
        for name, _ in fields:
            dataset[0, m][name] = values[name]
    scipy.io.savemat(path, {"dataset": dataset, "dt": dt, "numPts": demos.T, "numDim": 3, "numStates": 2})


def test_clamp_format_with_obstacles_and_missing_fields(tmp_path):
    demos = make_demonstrations("box_closing", num_demos=3, num_points=40)
    rows = [np.array([0.32, -0.32, 0.13, 0.09, 0.06, 0.28]), np.zeros((0, 6)),
            np.array([[0.3, -0.3, 0.1, 0.1, 0.1, 0.1], [0.4, -0.2, 0.1, 0.05, 0.05, 0.2]])]
    write_clamp_mat(tmp_path / "a.mat", demos, rows)
    loaded = load_demonstrations(tmp_path / "a.mat")
    assert np.allclose(loaded.positions, demos.positions) and np.allclose(loaded.velocities, demos.velocities)
    assert loaded.obstacles[0] == [Box([0.32, -0.32, 0.13], [0.09, 0.06, 0.28])]
    assert loaded.obstacles[1] == [] and len(loaded.obstacles[2]) == 2
    # without velocities: spline derivative; without time: arange(T) * dt
    write_clamp_mat(tmp_path / "b.mat", demos, drop="vel")
    no_vel = load_demonstrations(tmp_path / "b.mat")
    assert np.abs(no_vel.velocities - demos.velocities)[:, 3:-3].max() < 0.01 * np.abs(demos.velocities).max()
    write_clamp_mat(tmp_path / "c.mat", demos, drop="time", dt=0.5)
    assert np.allclose(load_demonstrations(tmp_path / "c.mat").time, np.arange(40) * 0.5)


def test_npz_round_trip_keeps_everything(tmp_path):
    demos = make_demonstrations("curved_reach", num_demos=3, num_points=30)
    demos.save_npz(tmp_path / "d.npz")
    loaded = load_demonstrations(tmp_path / "d.npz")
    assert np.array_equal(loaded.positions, demos.positions)
    assert np.array_equal(loaded.velocities, demos.velocities)
    assert np.array_equal(loaded.time, demos.time)
    assert loaded.name == "curved_reach" and loaded.obstacles == demos.obstacles


@pytest.mark.parametrize("with_velocity", [True, False])
def test_csv_round_trip(tmp_path, with_velocity):
    demos = make_demonstrations("two_target_press", num_demos=3, num_points=60)
    path = tmp_path / "d.csv"
    save_csv(demos, path)
    if not with_velocity:
        lines = path.read_text().splitlines()
        path.write_text("\n".join(",".join(line.split(",")[:5]) for line in lines) + "\n")
    loaded = load_demonstrations(path)
    assert np.allclose(loaded.positions, demos.positions, atol=1e-12)
    assert np.allclose(loaded.time, demos.time)
    tol = 1e-12 if with_velocity else 0.02 * np.abs(demos.velocities).max()
    assert np.abs(loaded.velocities - demos.velocities)[:, 2:-2].max() < tol


def test_csv_with_unequal_lengths_is_resampled(tmp_path):
    rows = ["demo,t,x,y,z"]
    for demo, n in ((0, 30), (1, 45)):
        t = np.linspace(0, 2 + demo, n)
        rows += [f"{demo},{ti},{0.1 + 0.1 * ti},{-0.4},{0.2 + 0.01 * ti}" for ti in t]
    path = tmp_path / "u.csv"
    path.write_text("\n".join(rows) + "\n")
    demos = load_demonstrations(path)
    assert demos.positions.shape == (2, 45, 3) and np.isclose(demos.duration, 2.5)


@pytest.mark.parametrize("name, content, named", [
    ("x.csv", "a,b,c\n1,2,3\n", ("header",)),
    ("x.csv", "demo,t,x,y,z\n0,0,1,2,oops\n", ()),
    ("x.csv", "demo,t,x,y,z\n", ()),
    ("x.csv", "demo,t,x,y,z\n0,0,1,2,3\n0,1,1,2,3\n", ()),
    ("x.csv", "demo,t,x,y,z\n0,0,1,2,3\n0,0,1,2,3\n1,0,1,2,3\n1,1,1,2,3\n", ("demonstrations[0].time",)),
    ("x.csv", "demo,t,x,y,z\n0,0,1,2,nan\n0,1,1,2,3\n", ()),
    ("x.mat", "this is not a MATLAB file", ()),
    ("x.npz", "not a zip", ()),
    ("x.txt", "1 2 3", (".txt",)),
])
def test_malformed_files_raise(tmp_path, name, content, named):
    path = tmp_path / name
    path.write_text(content)
    with raises_naming(DemonstrationFileError, name, *named):
        load_demonstrations(path)


def test_malformed_mat_contents_raise(tmp_path):
    scipy.io.savemat(tmp_path / "a.mat", {"other": np.zeros(3)})
    with raises_naming(DemonstrationFileError, "a.mat", "other"):
        load_demonstrations(tmp_path / "a.mat")
    demos = make_demonstrations("pick_place", num_demos=2, num_points=20)
    write_clamp_mat(tmp_path / "b.mat", demos, drop="pos")
    with raises_naming(DemonstrationFileError, "b.mat", "dataset(1)", "pos"):
        load_demonstrations(tmp_path / "b.mat")
    write_clamp_mat(tmp_path / "c.mat", demos, [np.array([0, 0, 0, 1, 1]), np.zeros((0, 6))])
    with raises_naming(DemonstrationFileError, "c.mat", "dataset(1).obs"):
        load_demonstrations(tmp_path / "c.mat")
    write_clamp_mat(tmp_path / "d.mat", demos, [np.array([0, 0, 0, 1, -1, 1]), np.zeros((0, 6))])
    with raises_naming(DemonstrationFileError, "d.mat", "dataset(1).obs row 1"):
        load_demonstrations(tmp_path / "d.mat")
    cells = np.empty((1, 2), dtype=object)
    cells[0, 0], cells[0, 1] = np.zeros((10, 3)), np.zeros((10, 2))
    scipy.io.savemat(tmp_path / "e.mat", {"smoothData": cells})
    with raises_naming(DemonstrationFileError, "e.mat", "smoothData{2}"):
        load_demonstrations(tmp_path / "e.mat")
    with raises_naming(DemonstrationFileError, "absent.mat"):
        load_demonstrations(tmp_path / "absent.mat")


def test_shared_dataset_location(tmp_path, monkeypatch):
    monkeypatch.setenv("SKILLPLAN_DATASETS", str(tmp_path))
    (tmp_path / "mine.mat").write_bytes(b"")
    assert find_shared_dataset("mine") == tmp_path / "mine.mat"
    assert find_shared_dataset("mine.mat") == tmp_path / "mine.mat"
    assert find_shared_dataset("definitely_not_here") is None
    monkeypatch.delenv("SKILLPLAN_DATASETS")
    from pathlib import Path

    import scenes
    expected = Path(scenes.__file__).resolve().parents[2] / "shared" / "datasets" / "box_closing.mat"
    assert find_shared_dataset("box_closing") == (expected if expected.is_file() else None)


def test_demonstrations_constructed_directly_round_trip_through_npz(tmp_path):
    rng = np.random.default_rng(0)
    demos = Demonstrations(rng.normal(size=(2, 5, 3)), rng.normal(size=(2, 5, 3)), np.arange(5.0), name="x")
    demos.save_npz(tmp_path / "x.npz")
    assert load_demonstrations(tmp_path / "x.npz").obstacles is None


@pytest.mark.parametrize("encoding, quoted", [("utf-8-sig", False), ("utf-8", True),
                                              ("utf-8-sig", True)])
def test_spreadsheet_csv_with_byte_order_mark_or_quoted_header_loads(tmp_path, encoding, quoted):
    """A spreadsheet's "CSV UTF-8" starts with a byte-order mark; many quote every field."""
    demos = make_demonstrations("two_target_press", num_demos=3, num_points=30)
    plain = tmp_path / "plain.csv"
    save_csv(demos, plain)
    lines = plain.read_text().splitlines()
    if quoted:
        lines = [",".join(f'"{cell}"' for cell in line.split(",")) for line in lines]
    path = tmp_path / "spreadsheet.csv"
    path.write_bytes("\r\n".join(lines).encode(encoding) + b"\r\n")
    assert path.read_bytes().startswith(b"\xef\xbb\xbf") == (encoding == "utf-8-sig")
    loaded, reference = load_demonstrations(path), load_demonstrations(plain)
    np.testing.assert_array_equal(loaded.positions, reference.positions)
    np.testing.assert_array_equal(loaded.velocities, reference.velocities)
    np.testing.assert_array_equal(loaded.time, reference.time)


@pytest.mark.parametrize("content, named", [
    ('"demo","t","x","y"\n0,0,1,2\n', "header"),
    ("demo,t,x,y,z\n0,0,1,2\n", "line 2"),
    ("demo,t,j1,j2\n0,0,1,2\n0,1,1,2\n1,0,1,2\n1,1,1,3\n", "robot"),
])
def test_csv_header_and_row_errors_name_the_problem(tmp_path, content, named):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with raises_naming(DemonstrationFileError, "bad.csv", named):
        load_demonstrations(path)


def test_smoothing_choice_is_checked(tmp_path):
    from scenes.errors import InvalidArgumentError
    path = tmp_path / "d.csv"
    save_csv(make_demonstrations("two_target_press", num_demos=3, num_points=30), path)
    with raises_naming(InvalidArgumentError, "smoothing"):
        load_demonstrations(path, smoothing="gcv")
