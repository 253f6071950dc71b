"""Every entry point answers bad input with one line on stderr and exit code 2, no traceback.

The catalogue feeds each command bad options, bad files and output paths it must not touch.
Every entry runs through the entry point's ``main`` with the process's file descriptors
captured (capfd: also what C++ libraries write to fd 2), and a sample of one or two entries
per entry point runs as ``python -m ...`` in a subprocess, as a user would (interpreter
start-up makes a subprocess per entry too slow for CI: ~1.5 s each).
"""
from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
CLAMP = ["-m", "clamp"]
TLGC = ["-m", "tlgc.cli"]
SPHERES = ["-m", "robots.sphere_cli"]
CYLINDER_DEMO = ["-m", "tlgc.demo_clamp_cylinder"]
START = ["--start", "0.2", "-0.47", "0.27"]


def python(args: list[str], cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """Working folder with good and bad input files and outputs that must survive."""
    from scenes import make_demonstrations
    work = tmp_path_factory.mktemp("catalogue")
    make_demonstrations("box_closing", num_points=40, seed=1).save_npz(work / "demos.npz")
    (work / "not_utf8.json").write_bytes(b"\xff\xfe{\"obstacles\": []}")
    (work / "not_json.json").write_text("{obstacles: [")
    (work / "bad_size.json").write_text('{"obstacles": [{"type": "box", "center": [0, 0, 0], "size": [-1, 1, 1]}]}')
    (work / "bad.csv").write_text("a,b\n1,2\n")
    (work / "empty.npz").write_bytes(b"")
    (work / "not_a_urdf.urdf").write_text("<robot name='x'><link name='a'/>")
    (work / "a_dir").mkdir()
    (work / "existing_file").write_text("keep me")
    (work / "full").mkdir()
    (work / "full" / "mine.txt").write_text("keep me too")
    from clamp.batch.problems import make_problem, write_problems
    write_problems([make_problem("p", {"skill": "box_closing", "num_points": 30}, "jaco",
                                 [0.2, -0.47, 0.27])], work / "problems.jsonl")
    return work


def jaco_urdf() -> str:
    from robots import load_robot
    return str(load_robot("jaco").urdf_path)


# (entry point + arguments, a word the error line must contain); {w} is the working folder
CATALOGUE: list[tuple[list[str], str]] = [
    # clamp: usage
    (CLAMP, "required"),
    (CLAMP + ["frobnicate"], "invalid choice"),
    (CLAMP + ["demo", "--num-points", "1", "--out", "o"], "--num-points"),
    (CLAMP + ["demo", "--num-points", "many", "--out", "o"], "many"),
    (CLAMP + ["demo", "--max-iterations", "0", "--out", "o"], "--max-iterations"),
    (CLAMP + ["demo", "--epsilon", "nan", "--out", "o"], "finite"),
    (CLAMP + ["demo", "--epsilon", "-0.1", "--out", "o"], "epsilon"),
    (CLAMP + ["demo", "--sigma-obs", "0", "--out", "o"], "--sigma-obs"),
    (CLAMP + ["demo", "--optimizer", "adam", "--out", "o"], "adam"),
    (CLAMP + ["demo", "--init", "random", "--out", "o"], "random"),
    (CLAMP + ["demo", "--robot", "nonexistent_robot", "--out", "o"], "jaco"),
    (CLAMP + ["demo", "--skill", "no_such_skill", "--out", "o"], "box_closing"),
    (CLAMP + ["demo", "--robot", "jaco", "--end-effector", "tool0", "--out", "o"], "--end-effector"),
    # clamp: outputs the user owns
    (CLAMP + ["demo", "--out", "{w}/existing_file"], "existing file"),
    (CLAMP + ["demo", "--out", "{w}/full"], "--force"),
    # clamp plan: inputs
    (CLAMP + ["plan", "--robot", "jaco", *START, "--out", "o"], "--demos"),
    (CLAMP + ["plan", "--demos", "{w}/missing.npz", "--robot", "jaco", *START, "--out", "o"], "missing.npz"),
    (CLAMP + ["plan", "--demos", "{w}/a_dir", "--robot", "jaco", *START, "--out", "o"], "a_dir"),
    (CLAMP + ["plan", "--demos", "{w}/bad.csv", "--robot", "jaco", *START, "--out", "o"], "header"),
    (CLAMP + ["plan", "--demos", "{w}/empty.npz", "--robot", "jaco", *START, "--out", "o"], "empty.npz"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", "--start", "1", "2", "--out", "o"], "start"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", "--start", "1", "x", "2", "--out", "o"],
     "'x'"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", *START, "--goal", *["0.1"] * 9,
              "--out", "o"], "goal"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", *START, "--translate", "1", "2",
              "--out", "o"], "--translate"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", *START, "--scene", "{w}/missing.json",
              "--out", "o"], "missing.json"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", *START, "--scene", "{w}/not_json.json",
              "--out", "o"], "not_json.json"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", *START, "--scene", "{w}/bad_size.json",
              "--out", "o"], "size"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", *START, "--scene", "{w}/not_utf8.json",
              "--out", "o"], "utf-8"),
    # clamp plan --urdf
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--urdf", "{w}/missing.urdf", "--end-effector", "x", *START,
              "--out", "o"], "missing.urdf"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--urdf", "{w}/not_a_urdf.urdf", "--end-effector", "x",
              *START, "--out", "o"], "not_a_urdf.urdf"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--urdf", "{jaco}", *START, "--out", "o"], "--end-effector"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--urdf", "{jaco}", "--end-effector", "no_such_frame",
              *START, "--out", "o"], "no_such_frame"),
    (CLAMP + ["plan", "--demos", "{w}/demos.npz", "--robot", "jaco", "--urdf", "{jaco}", *START, "--out", "o"],
     "not allowed"),
    # clamp batch (issue 14's command): problems file, results file, options
    (CLAMP + ["batch", "{w}/problems.jsonl"], "--out"),
    (CLAMP + ["batch", "{w}/no_such.jsonl", "--out", "{w}/r.jsonl"], "does not exist"),
    (CLAMP + ["batch", "{w}/a_dir", "--out", "{w}/r.jsonl"], "directory"),
    (CLAMP + ["batch", "{w}/not_json.json", "--out", "{w}/r.jsonl"], "not valid json"),
    (CLAMP + ["batch", "{w}/not_utf8.json", "--out", "{w}/r.jsonl"], "utf-8"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/existing_file"], "not a batch result"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/a_dir"], "a_dir"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/problems.jsonl"], "--out"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/nowhere/r.jsonl"], "--out"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/r.jsonl", "--workers", "0"], "--workers"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/r.jsonl", "--workers", "two"], "--workers"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/r.jsonl", "--retries", "-1"], "retries"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/r.jsonl", "--trajectories",
              "{w}/existing_file"], "--trajectories"),
    (CLAMP + ["batch", "{w}/problems.jsonl", "--out", "{w}/r.jsonl", "--workers", "2", "--scheduler",
              "tcp://nowhere:1"], "--scheduler"),
    # tlgc fit-reproduce
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--count", "0"], "--count"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--sections", "-3"], "--sections"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--sections", "1000"], "--sections"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--num-demos", "1"], "--num-demos"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--seed", "-1"], "--seed"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--gamma", "inf"], "finite"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--eta-final", "2"], "eta_final"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "o", "--cross-section", "square"], "square"),
    (TLGC + ["fit-reproduce", "--skill", "no_such_skill", "--out", "o"], "no_such_skill"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--demos", "{w}/demos.npz", "--out", "o"],
     "not allowed"),
    (TLGC + ["fit-reproduce", "--demos", "{w}/missing.mat", "--out", "o"], "missing.mat"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "{w}/existing_file"], "existing file"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach", "--out", "{w}/full"], "--force"),
    (TLGC + ["fit-reproduce", "--skill", "curved_reach"], "--out"),
    # sphere fitting
    (SPHERES, "required"),
    (SPHERES + ["--robot", "nonexistent_robot"], "jaco"),
    (SPHERES + ["--urdf", "{w}/missing.urdf", "--out", "s.json"], "missing.urdf"),
    (SPHERES + ["--urdf", "{w}/not_a_urdf.urdf", "--out", "s.json"], "not_a_urdf.urdf"),
    (SPHERES + ["--urdf", "{jaco}"], "--out"),
    (SPHERES + ["--robot", "jaco", "--out", "{w}/existing_file"], "--force"),
    (SPHERES + ["--robot", "jaco", "--out", "{w}/a_dir"], "folder"),
    (SPHERES + ["--robot", "jaco", "--out", "{w}/no_folder/s.json"], "no_folder"),
    (SPHERES + ["--robot", "jaco", "--out", "s.json", "--max-spheres", "0"], "--max-spheres"),
    (SPHERES + ["--robot", "jaco", "--out", "s.json", "--inflation", "-0.01"], "inflation"),
    (SPHERES + ["--robot", "jaco", "--out", "s.json", "--links", "no_such_link"], "no_such_link"),
    # CLAMP + TLGC boundary factor demo
    (CYLINDER_DEMO + ["--states", "1"], "--states"),
    (CYLINDER_DEMO + ["--robot", "nonexistent_robot"], "jaco"),
    (CYLINDER_DEMO + ["--skill", "no_such_skill"], "no_such_skill"),
    (CYLINDER_DEMO + ["--goal-offset", "inf"], "finite"),
]


MAINS = {"clamp": "clamp.cli.commands", "tlgc.cli": "tlgc.cli", "robots.sphere_cli": "robots.sphere_cli",
         "tlgc.demo_clamp_cylinder": "tlgc.demo_clamp_cylinder"}


def entries():
    for entry in CATALOGUE:
        if _plain(entry):
            args, word = entry
            yield pytest.param(args, word, id=" ".join(args[1:])[:80])
        else:
            yield pytest.param(*entry.values, marks=entry.marks, id=" ".join(entry.values[0][1:])[:80])


def _plain(entry) -> bool:
    """A plain (args, word) entry, not a pytest.param with marks (itself a named tuple)."""
    return not hasattr(entry, "marks")


def substitute(args: list[str], work: Path) -> list[str]:
    return [a.replace("{w}", str(work)).replace("{jaco}", jaco_urdf()) for a in args]


def check_answer(code: int, stderr: str, word: str) -> None:
    lines = stderr.strip().splitlines()
    assert "Traceback" not in stderr, stderr
    assert code == 2, (code, stderr)
    assert len(lines) == 1, stderr
    assert word.lower() in lines[0].lower(), lines[0]
    assert "error" in lines[0]


@pytest.mark.parametrize("args, word", list(entries()))
def test_bad_input_gives_one_line_and_exit_2(files, capfd, monkeypatch, args, word):
    import importlib
    monkeypatch.chdir(files)
    main = importlib.import_module(MAINS[args[1]]).main
    code = main(substitute(args, files)[2:])
    captured = capfd.readouterr()
    check_answer(code, captured.err, word)


def test_catalogue_left_user_files_alone(files):
    assert (files / "existing_file").read_text() == "keep me"
    assert sorted(p.name for p in (files / "full").iterdir()) == ["mine.txt"]
    assert not (files / "o").exists() or not any((files / "o").iterdir())
    assert not list(files.rglob("*.tmp"))
    assert not (files / "r.jsonl").exists()


def _sample(per_entry_point: int = 2) -> list[tuple[list[str], str]]:
    """The first catalogue entries of each entry point with an output path (files the user
    owns) preferred."""
    chosen: list[tuple[list[str], str]] = []
    for module in MAINS:  # keys: the module after ``python -m``
        mine = [e for e in CATALOGUE if _plain(e) and e[0][1] == module]
        owned = [e for e in mine if any("existing_file" in a or "{w}/full" in a for a in e[0])]
        chosen.extend((owned + [e for e in mine if e not in owned])[:per_entry_point])
    return chosen


SAMPLE = _sample(per_entry_point=1)


def test_sample_as_subprocesses(files):
    """The same answers from ``python -m ...`` (parallel: start-up dominates)."""
    with ThreadPoolExecutor(max_workers=3) as pool:
        done = list(pool.map(lambda entry: python(substitute(entry[0], files), files), SAMPLE))
    for (args, word), answer in zip(SAMPLE, done):
        check_answer(answer.returncode, answer.stderr, word)
    assert {args[1] for args, _ in SAMPLE} == set(MAINS)

@pytest.mark.parametrize("entry", [CLAMP, TLGC, SPHERES, CYLINDER_DEMO])
def test_version_prints_the_package_version(entry, capsys):
    import importlib
    import importlib.metadata
    assert importlib.import_module(MAINS[entry[1]]).main(["--version"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out.split()[-1] == importlib.metadata.version("skillplan")


def test_debug_shows_the_traceback(tmp_path):
    from clamp.cli.commands import main
    from clamp.errors import InvalidParameterError
    from bad_input import raises_naming
    with raises_naming(InvalidParameterError, "epsilon"):
        main(["demo", "--epsilon", "-1", "--out", str(tmp_path / "o"), "--debug"])
