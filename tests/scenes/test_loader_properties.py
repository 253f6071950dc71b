"""Property-based tests of the loaders (Hypothesis): on generated garbage every loader answers
with a valid object or the project's own error (scenes.errors.InvalidArgumentError and its
subclasses), nothing else. At least 2000 generated inputs per loader: scene JSON, demonstration
CSV, demonstration .mat (scipy.io.savemat of generated structs), prior .npz, robot name / URDF,
planning problems (JSON Lines) and batch results (JSON Lines, then summarized).
"""
from __future__ import annotations

import json
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.io

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from clamp.batch.runner import read_results  # noqa: E402
from clamp.batch.report import summarize  # noqa: E402
from clamp.prior.linear_gaussian import LinearGaussianPrior, WorkspacePrior  # noqa: E402
from clamp.batch.problems import Problem, make_problem, read_problems  # noqa: E402
from robots import Robot, load_robot  # noqa: E402
from scenes import Demonstrations, Scene, load_demonstrations  # noqa: E402
from scenes.errors import InvalidArgumentError  # noqa: E402

EXAMPLES = 2000
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])

_TMP = Path(tempfile.mkdtemp(prefix="skillplan-hypothesis-"))


def teardown_module() -> None:
    shutil.rmtree(_TMP, ignore_errors=True)


def _file(name: str, data: bytes) -> Path:
    path = _TMP / name
    path.write_bytes(data)
    return path


def _outcome(call, valid: type | tuple[type, ...]):
    """Run a loader: its result must be a ``valid`` object, its error the project's."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # scipy / numpy warnings on odd files are fine
        try:
            result = call()
        except InvalidArgumentError as exc:
            assert str(exc), "empty error message"
            event(f"refused: {type(exc).__name__}")
            return None
    assert isinstance(result, valid), type(result)
    event("valid object")
    return result


# ------------------------------------------------------------------------ values
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
                    st.sampled_from([0, 1, -1, 0.1, 1e200, -1e-300]))
scalars = st.one_of(numbers, st.booleans(), st.none(), st.text(max_size=5))
json_values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=12)
vectors = st.one_of(st.lists(scalars, max_size=5), st.lists(numbers, min_size=3, max_size=3),
                    st.lists(st.floats(-2, 2), min_size=3, max_size=3), scalars,
                    st.lists(st.lists(numbers, min_size=3, max_size=3), max_size=3))
positive = st.one_of(st.floats(1e-3, 1.0), numbers, scalars)


# ------------------------------------------------------------------------ scene JSON
def _obstacle():
    fields = {"type": st.one_of(st.sampled_from(["box", "sphere", "cylinder", "capsule", "cone"]),
                                json_values),
              "center": vectors, "size": vectors, "radius": positive, "height": positive,
              "axis": vectors, "rotation": st.one_of(vectors, st.just(np.eye(3).tolist())),
              "reference": st.one_of(vectors, st.lists(st.floats(-1, 1), min_size=6, max_size=6))}
    return st.fixed_dictionaries({"type": fields["type"]},
                                 optional={k: v for k, v in fields.items() if k != "type"})


scene_documents = st.one_of(
    json_values,
    st.fixed_dictionaries({}, optional={"obstacles": st.one_of(st.lists(_obstacle(), max_size=3),
                                                               json_values),
                                        "bounds": st.one_of(vectors, st.just([[-1, -1, -1], [1, 1, 1]])),
                                        "name": json_values}))


def _scene_bytes(document, encoding: str, tail: bytes) -> bytes:
    text = json.dumps(document, allow_nan=True)
    return text.encode(encoding, errors="replace") + tail


@SETTINGS
@given(document=scene_documents, encoding=st.sampled_from(["utf-8", "latin-1", "utf-16"]),
       tail=st.one_of(st.just(b""), st.binary(max_size=4)))
def test_scene_json_parser(document, encoding, tail) -> None:
    path = _file("scene.json", _scene_bytes(document, encoding, tail))
    scene = _outcome(lambda: Scene.load(path), Scene)
    if scene is not None:
        assert np.all(np.isfinite(scene.bounds))
        for ob in scene.obstacles:
            assert np.all(np.isfinite(ob.aabb()))


# ------------------------------------------------------------------------ CSV
csv_cells = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                      st.integers(-3, 3).map(str), st.floats(-1, 1).map(repr),
                      st.sampled_from(["", "a", "1e400", " ", "nan", "0x1"]))
csv_headers = st.one_of(st.just("demo,t,x,y,z"), st.just("demo,t,x,y,z,vx,vy,vz"),
                        st.text(max_size=20), st.just("demo,t,x,y"))


@st.composite
def csv_texts(draw) -> bytes:
    if draw(st.integers(0, 3)):                # mostly a header that fits the rows
        width = draw(st.sampled_from([5, 8]))
        header = "demo,t,x,y,z" if width == 5 else "demo,t,x,y,z,vx,vy,vz"
    else:
        header, width = draw(csv_headers), draw(st.sampled_from([5, 8, 4, 6]))
    rows = []
    if draw(st.booleans()):        # well-formed numbers: demos with random times
        ordered = draw(st.integers(0, 3)) > 0      # mostly increasing time stamps
        for label in range(draw(st.integers(0, 3))):
            count = draw(st.sampled_from([0, 1, 2, 3, 4, 5, 3, 4]))
            times = draw(st.lists(st.floats(-1, 10), min_size=count, max_size=count,
                                  unique=ordered))
            times = sorted(times) if ordered else times
            for t in times:
                values = draw(st.lists(st.floats(-1, 1), min_size=width - 2, max_size=width - 2))
                rows.append(",".join([str(label), repr(t), *map(repr, values)]))
    else:
        rows = [",".join(draw(st.lists(csv_cells, min_size=1, max_size=9)))
                for _ in range(draw(st.integers(0, 6)))]
    text = "\n".join([header, *rows]) + "\n"
    return text.encode(draw(st.sampled_from(["utf-8", "latin-1"])), errors="replace")


@SETTINGS
@given(data=csv_texts())
def test_demonstration_csv_loader(data) -> None:
    path = _file("demos.csv", data)
    demos = _outcome(lambda: load_demonstrations(path), Demonstrations)
    if demos is not None:
        assert demos.M >= 2 and demos.T >= 2 and np.all(np.diff(demos.time) > 0)
        assert np.all(np.isfinite(demos.positions)) and np.all(np.isfinite(demos.velocities))


# ------------------------------------------------------------------------ .mat
mat_arrays = st.one_of(
    st.integers(0, 6).flatmap(lambda T: st.lists(st.floats(-1, 1, width=32), min_size=3 * T,
                                                  max_size=3 * T).map(lambda v: np.reshape(v, (-1, 3)))),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=8).map(np.array),
    st.integers(0, 6).map(lambda T: np.arange(float(T))),
    st.integers(0, 6).map(lambda T: np.arange(float(T))[::-1]),
    st.text(max_size=4), st.floats(allow_nan=True), st.integers(-5, 5),
    st.just(np.zeros((0, 3))), st.just(np.ones((4, 2))), st.just(np.full((4, 3), np.nan)))


@st.composite
def mat_contents(draw) -> dict:
    kind = draw(st.sampled_from(["near", "near", "dataset", "smoothData", "other"]))
    if kind == "near":                       # a valid CLAMP struct array, one field replaced
        T, count = draw(st.integers(2, 6)), draw(st.integers(1, 3))
        names = ["pos", "vel", "time"]
        table = np.zeros((count,), dtype=[(n, "O") for n in names])
        rng = np.random.default_rng(draw(st.integers(0, 9)))
        for m in range(count):
            table[m] = (rng.normal(size=(T, 3)), rng.normal(size=(T, 3)), np.arange(T) * 0.1)
        if draw(st.booleans()):
            table[draw(st.integers(0, count - 1))][draw(st.sampled_from(names))] = draw(mat_arrays)
        return {"dataset": table}
    if kind == "dataset":
        names = draw(st.lists(st.sampled_from(["pos", "vel", "time", "obs", "junk"]), min_size=1,
                              max_size=5, unique=True))
        count = draw(st.integers(1, 3))
        table = np.zeros((count,), dtype=[(n, "O") for n in names])
        for m in range(count):
            table[m] = tuple(draw(mat_arrays) for _ in names)
        data = {"dataset": table}
        if draw(st.booleans()):
            data["dt"] = draw(st.one_of(st.floats(allow_nan=True), st.text(max_size=3), st.just(0.1)))
        return data
    if kind == "smoothData":
        cells = np.empty((draw(st.integers(0, 3)),), dtype=object)
        for m in range(len(cells)):
            cells[m] = draw(mat_arrays)
        return {"smoothData": draw(st.one_of(st.just(cells), mat_arrays))}
    return {draw(st.sampled_from(["x", "data", "pos"])): draw(mat_arrays)}


@SETTINGS
@given(contents=mat_contents(), corrupt=st.one_of(st.none(), st.integers(0, 400)))
def test_demonstration_mat_loader(contents, corrupt) -> None:
    path = _TMP / "demos.mat"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scipy.io.savemat(path, contents)
    if corrupt is not None:                  # truncate the file: a half-written download
        data = path.read_bytes()
        path.write_bytes(data[:corrupt])
    demos = _outcome(lambda: load_demonstrations(path), Demonstrations)
    if demos is not None:
        assert demos.M >= 2 and np.all(np.isfinite(demos.positions))


# ------------------------------------------------------------------------ prior .npz
def _valid_prior_arrays(T: int) -> dict:
    rng = np.random.default_rng(T)
    A = np.tile(np.eye(6), (T - 1, 1, 1))
    return {"format": np.array("clamp-linear-gaussian-prior/1"), "kind": np.array("workspace"),
            "state_names": np.array(["px", "py", "pz", "vx", "vy", "vz"]), "info": np.array("{}"),
            "time": np.arange(float(T)), "Phi": A, "u": rng.normal(size=(T - 1, 6)),
            "Q": A * 1e-3, "mean0": np.zeros(6), "cov0": np.eye(6) * 1e-3}


npz_values = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(np.array),
                       st.text(max_size=6).map(np.array), st.lists(st.floats(-1, 1), max_size=7).map(np.array),
                       st.sampled_from([np.zeros((2, 6, 6)), -np.ones((2, 6, 6)), np.eye(6), np.zeros((3, 6)),
                                        np.array("joint"), np.array("[1]"), np.array("{"),
                                        np.array(["a", "b"]), np.zeros((2, 4, 4)), np.ones(6)]))


@SETTINGS
@given(T=st.integers(2, 6), drop=st.sets(st.sampled_from(sorted(_valid_prior_arrays(3))), max_size=2),
       changes=st.dictionaries(st.sampled_from(sorted(_valid_prior_arrays(3))), npz_values, max_size=3),
       cls=st.sampled_from([WorkspacePrior, LinearGaussianPrior]),
       corrupt=st.one_of(st.none(), st.integers(0, 300)))
def test_prior_npz_loader(T, drop, changes, cls, corrupt) -> None:
    arrays = {k: v for k, v in _valid_prior_arrays(T).items() if k not in drop}
    arrays.update(changes)
    path = _TMP / "prior.npz"
    np.savez(path, **arrays)
    if corrupt is not None:
        path.write_bytes(path.read_bytes()[:corrupt])
    prior = _outcome(lambda: cls.load(path), LinearGaussianPrior)
    if prior is not None:
        assert np.all(np.isfinite(prior.cov)) and prior.T >= 2


# ------------------------------------------------------------------------ robots
URDF_LINK = '<link name="{0}"/>'
URDF_JOINT = ('<joint name="{0}" type="{1}"><parent link="{2}"/><child link="{3}"/>'
              '<axis xyz="{4}"/><limit lower="{5}" upper="{6}" velocity="{7}" effort="1"/></joint>')


@st.composite
def urdf_texts(draw) -> tuple[bytes, str]:
    if draw(st.integers(0, 5)) == 0:
        return draw(st.binary(max_size=60)), draw(st.text(max_size=5))

    def pick(good: str, *bad: str) -> str:   # the valid value half of the time
        return draw(st.sampled_from([good] * len(bad) + list(bad)))

    links = [f"l{k}" for k in range(draw(st.integers(1, 4)))]
    parts = [URDF_LINK.format(n) for n in links]
    for k in range(1, len(links)):
        parts.append(URDF_JOINT.format(
            f"j{k}", pick("revolute", "continuous", "prismatic", "fixed", "planar", "floating",
                          "bogus"),
            links[k - 1], pick(links[k], "nowhere", links[0]),
            pick("0 0 1", "1 0 0", "0 0 0", "a b c", "1e400 0 0"),
            pick("-1", "nan", "x", "1"), pick("1", "-2", "inf"), pick("1", "0", "-1", "nan")))
    name = pick('name="r"', "", 'name=""')
    text = f"<robot {name}>{''.join(parts)}</robot>"
    if draw(st.integers(0, 3)) == 0:
        text = text[:draw(st.integers(0, len(text)))]
    end_effector = draw(st.one_of(st.sampled_from(links[-1:] * 3 + links + ["tool0", ""]),
                                  st.text(max_size=3)))
    return text.encode(draw(st.sampled_from(["utf-8", "latin-1"])), errors="replace"), end_effector


@SETTINGS
@given(urdf=urdf_texts(), as_directory=st.integers(0, 20))
def test_robot_urdf_loader(urdf, as_directory) -> None:
    data, end_effector = urdf
    path = _TMP if as_directory == 0 else _file("arm.urdf", data)
    robot = _outcome(lambda: Robot.from_urdf(path, end_effector=end_effector,
                                            spheres=_TMP / "no-spheres.json" if as_directory == 1 else None),
                     Robot)
    if robot is not None:
        q = robot.neutral_configuration()
        assert np.all(np.isfinite(robot.fk(q)))


robot_names = st.one_of(st.text(max_size=8), st.sampled_from(["jaco", "sawyer", "JACO", "jaco ", ""]),
                        st.integers(), st.none(), st.lists(st.just("jaco"), max_size=2),
                        st.floats(allow_nan=True), st.binary(max_size=4))


@SETTINGS
@given(name=robot_names)
def test_robot_name_loader(name) -> None:
    if name in ("jaco", "sawyer"):
        return                                   # loading the real models is tested elsewhere
    _outcome(lambda: load_robot(name), Robot)


# ------------------------------------------------------------------------ problems (JSON Lines)
_GOOD_PROBLEM = make_problem("scenes/jaco/0001", {"skill": "box_closing", "seed": 0}, "jaco",
                             [0.2, -0.47, 0.26], scene={"obstacles": [{"type": "sphere", "center":
                                                                       [0.3, 0, 0.2], "radius": 0.02}]},
                             goal=[0.4, -0.3, 0.1], via_points=[(5, [0.3, -0.3, 0.3])],
                             config={"sigma_obs": 0.005}, expected="feasible",
                             meta={"note": "x"}).to_dict()
_PROBLEM_FIELDS = sorted(_GOOD_PROBLEM) + ["colour"]
# flat JSON values (cheaper to draw than small_json: keeps these two tests fast)
small_json = st.one_of(scalars, st.lists(scalars, max_size=3),
                       st.dictionaries(st.text(max_size=4), scalars, max_size=2))
_GARBAGE_LINES = st.one_of(st.text(max_size=30), st.sampled_from(
    ["", "   ", "# a comment", "{", "[" * 100_000, "NaN", "{}", "null", '{"id": ""}']))


@st.composite
def problem_lines(draw) -> str:
    """One line: mostly the valid problem with a few fields replaced or dropped, else any JSON
    value or text."""
    kind = draw(st.integers(0, 5))
    if kind >= 2:
        data = dict(_GOOD_PROBLEM)
        data["id"] = draw(st.one_of(st.sampled_from(["a", "b", "c"]), small_json))
        for key in draw(st.sets(st.sampled_from(_PROBLEM_FIELDS), max_size=2)):
            data.pop(key, None)
        for key, value in draw(st.dictionaries(st.sampled_from(_PROBLEM_FIELDS), small_json,
                                               max_size=3)).items():
            data[key] = value
        return json.dumps(data, allow_nan=True)
    if kind == 1:
        return json.dumps(draw(small_json), allow_nan=True)
    return draw(_GARBAGE_LINES)


@SETTINGS
@given(lines=st.lists(problem_lines(), max_size=4), encoding=st.sampled_from(["utf-8", "latin-1"]),
       tail=st.one_of(st.just(b""), st.binary(max_size=4)))
def test_problems_file_reader(lines, encoding, tail) -> None:
    path = _file("problems.jsonl", "\n".join(lines).encode(encoding, errors="replace") + tail)
    problems = _outcome(lambda: read_problems(path), list)
    if problems is not None:
        assert all(isinstance(p, Problem) for p in problems)
        assert len({p.id for p in problems}) == len(problems)
        for p in problems:                   # what was read can be written and read again
            again = Problem.from_json(p.to_json())
            assert again.hash == p.hash


# ------------------------------------------------------------------------ results (JSON Lines)
_STATUS = st.one_of(st.sampled_from(["done", "error", "lost", "done"]), small_json)
results_records = st.fixed_dictionaries({}, optional={
    "id": st.one_of(st.text(max_size=4), small_json), "hash": st.text(max_size=4),
    "status": _STATUS, "success": st.one_of(st.booleans(), small_json),
    "reasons": st.one_of(st.lists(st.text(max_size=30), max_size=2), small_json),
    "expected": st.one_of(st.sampled_from([None, "feasible", "impossible"]), small_json),
    "timings": st.one_of(st.fixed_dictionaries({"total": st.one_of(numbers, small_json)}),
                         small_json),
    "error": st.one_of(st.fixed_dictionaries({"type": st.one_of(st.text(max_size=8),
                                                                small_json)}), small_json)})


@st.composite
def results_texts(draw) -> bytes:
    lines = [json.dumps(draw(st.one_of(results_records, results_records, small_json)),
                        allow_nan=True) if draw(st.integers(0, 5)) else draw(_GARBAGE_LINES)
             for _ in range(draw(st.integers(0, 4)))]
    text = "\n".join(lines) + ("\n" if draw(st.integers(0, 3)) else "")  # sometimes a torn line
    return text.encode(draw(st.sampled_from(["utf-8", "latin-1"])), errors="replace") \
        + draw(st.one_of(st.just(b""), st.binary(max_size=4)))


@SETTINGS
@given(data=results_texts())
def test_results_file_reader_and_summary(data) -> None:
    path = _file("results.jsonl", data)
    records = _outcome(lambda: read_results(path), list)
    if records is not None:
        assert all(isinstance(r, dict) for r in records)
        summary = _outcome(lambda: summarize(records), dict)
        if summary is not None:
            assert summary["problems"] == len(records)
