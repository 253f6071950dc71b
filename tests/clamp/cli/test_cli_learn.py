"""Learn once, plan many (issue 29, item 4): ``clamp learn`` saves the prior, ``clamp plan --prior``
and ``clamp batch`` plan from the file, with the same plan as learning again; bad prior files
exit 2 with one line and leave nothing behind."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from clamp.cli.commands import main
from clamp.prior.linear_gaussian import FILE_FORMAT_NAME, FILE_FORMAT_VERSION, WorkspacePrior
from scenes import Box, Scene, make_demonstrations

START = ["0.2054", "-0.4722", "0.2625"]
LEARNING = ["--num-points", "60", "--translate", "0", "0.01", "0"]


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


@pytest.fixture(scope="module")
def learned(tmp_path_factory):
    """demos.npz and scene.json, the prior `clamp learn` saved from them, and the outputs of
    `clamp plan --prior` and `clamp plan --demos` (same learning options, start and scene)."""
    folder = tmp_path_factory.mktemp("learn")
    make_demonstrations("box_closing", num_demos=6, num_points=80, seed=0).save_npz(folder / "demos.npz")
    Scene([Box([-0.4, 0.4, 0.05], [0.08, 0.08, 0.08])]).save(folder / "scene.json")
    codes = {"learn": main(["learn", "--demos", str(folder / "demos.npz"), *LEARNING,
                            "--out", str(folder / "prior.npz")])}
    common = ["--robot", "jaco", "--start", *START, "--scene", str(folder / "scene.json"), "--sigma-obs", "0.02"]
    codes["prior"] = main(["-q", "plan", "--prior", str(folder / "prior.npz"), *common, "--figures",
                           "--out", str(folder / "from_prior")])
    codes["demos"] = main(["-q", "plan", "--demos", str(folder / "demos.npz"), *LEARNING, *common,
                           "--out", str(folder / "from_demos")])
    return folder, codes


def test_learn_saves_the_prior_and_prints_its_summary(learned, capsys):
    folder, codes = learned
    assert codes["learn"] == 0
    prior = WorkspacePrior.load(folder / "prior.npz")
    assert prior.T == 60 and prior.info["num_demos"] == 6
    with np.load(folder / "prior.npz") as data:
        assert str(data["format"]) == f"{FILE_FORMAT_NAME}/{FILE_FORMAT_VERSION}"
    # the same summary as the saved prior's, and the demonstrations moved by --translate
    demos = make_demonstrations("box_closing", num_demos=6, num_points=80, seed=0).resample(60)
    np.testing.assert_allclose(prior.mean[0, :3], demos.positions[:, 0].mean(axis=0) + [0, 0.01, 0], atol=1e-9)
    code = main(["learn", "--demos", str(folder / "demos.npz"), *LEARNING, "--out", str(folder / "again")])
    out = capsys.readouterr().out
    assert code == 0 and (folder / "again.npz").is_file()          # the suffix added, as prior.save does
    assert out.startswith(prior.summary() + "\n") and "6 demonstrations, 60 states" in out
    assert "spread about their mean" in out and "wrote the prior to" in out


def test_plan_from_the_saved_prior_is_the_plan_from_the_demonstrations(learned):
    """Acceptance: the same q (plan JSON) within 1e-9, learning once or every time."""
    folder, codes = learned
    assert codes["prior"] == codes["demos"] == 0
    from_prior = json.loads((folder / "from_prior" / "plan.json").read_text())
    from_demos = json.loads((folder / "from_demos" / "plan.json").read_text())
    q_prior, q_demos = np.array(from_prior["q"]), np.array(from_demos["q"])
    assert q_prior.shape == (60, 6)
    assert np.max(np.abs(q_prior - q_demos)) <= 1e-9
    assert from_prior["prior"] == str(folder / "prior.npz") and "demos" not in from_prior
    # the figures are drawn from the prior alone; no demonstrations are recorded for the view
    for name in ("prior_3d.png", "prior_time.png", "plan_result.png", "plan_result_top.png",
                 "animation_result.html", "trajectory_result.json", "prior.npz"):
        assert (folder / "from_prior" / name).is_file(), name
    assert not (folder / "from_prior" / "demos.npz").exists()
    problem = json.loads((folder / "from_prior" / "problem_plan.json").read_text())
    assert problem["prior"] == {"file": "prior.npz"} and problem["meta"] == {}


def test_view_of_a_plan_from_a_saved_prior(learned):
    from clamp.cli.viewer import load_view
    folder, _ = learned
    result, demos = load_view(folder / "from_prior")
    written = np.array(json.loads((folder / "from_prior" / "plan.json").read_text())["q"])
    assert demos is None and np.max(np.abs(result.q - written)) <= 1e-9


def test_batch_plans_from_a_saved_prior_named_relative_to_the_problems_file(learned, tmp_path, monkeypatch):
    """Acceptance: a problems.jsonl naming the saved prior ({"file": "prior.npz"}, beside it)
    plans what learning from the demonstrations plans; the same name read from elsewhere."""
    import shutil

    from clamp.batch.problems import make_problem, write_problems
    from clamp.batch.runner import read_results
    folder, _ = learned
    batch = tmp_path / "batch"
    batch.mkdir()
    shutil.copyfile(folder / "prior.npz", batch / "prior.npz")
    demos = make_demonstrations("box_closing", num_demos=6, num_points=80, seed=0).resample(60)
    demos.translated(np.array([0.0, 0.01, 0.0])).save_npz(batch / "learned_from.npz")
    start = [float(s) for s in START]
    write_problems([make_problem("saved", {"file": "prior.npz"}, "jaco", start),
                    make_problem("learned", {"demos": "learned_from.npz"}, "jaco", start),
                    make_problem("old spelling", {"path": "prior.npz"}, "jaco", start),
                    make_problem("missing", {"file": "nowhere.npz"}, "jaco", start)], batch / "problems.jsonl")
    monkeypatch.chdir(tmp_path)                                      # not the problems' folder
    code = main(["-q", "batch", str(batch / "problems.jsonl"), "--out", "results.jsonl"])
    records = {r["id"]: r for r in read_results(tmp_path / "results.jsonl")}
    assert code == 1                                                 # the missing file is an error
    for name in ("saved", "learned", "old spelling"):
        assert records[name]["status"] == "done" and records[name]["success"], records[name]
    positions = {name: np.array([p["positions"] for p in records[name]["trajectory"]["points"]])
                 for name in ("saved", "learned", "old spelling")}
    assert np.max(np.abs(positions["saved"] - positions["learned"])) <= 1e-9
    assert np.array_equal(positions["saved"], positions["old spelling"])
    missing = records["missing"]
    assert missing["status"] == "error" and missing["error"]["type"] == "PriorFileError"
    assert str(batch / "nowhere.npz") in missing["error"]["message"]


def _write(folder: Path, name: str, **arrays) -> str:
    np.savez(folder / name, **arrays)
    return str(folder / name)


@pytest.mark.parametrize("case, message", [
    ("missing", "--prior: {tmp}/nowhere.npz does not exist"),
    ("text", "--prior: '{tmp}/text.npz' is not a readable .npz prior file"),
    ("demos", "--prior: '{tmp}/demos.npz' is not a CLAMP prior file: it has no format entry"),
    ("newer", f"--prior: '{{tmp}}/newer.npz' has format version {FILE_FORMAT_VERSION + 1}"),
    ("other", "--prior: '{tmp}/other.npz' has format 'someone-else/1'"),
    ("no_cov0", "--prior: '{tmp}/no_cov0.npz' lacks entries ['cov0']"),
])
def test_bad_prior_files_exit_2_with_one_line_and_leave_nothing(learned, tmp_path, capsys, case, message):
    folder, _ = learned
    with np.load(folder / "prior.npz") as data:
        saved = {k: data[k] for k in data.files}
    (tmp_path / "text.npz").write_text("not a prior")
    files = {"missing": str(tmp_path / "nowhere.npz"), "text": str(tmp_path / "text.npz"),
             "demos": str(folder / "demos.npz"),
             "newer": _write(tmp_path, "newer.npz", **{**saved, "format": np.array(
                 f"{FILE_FORMAT_NAME}/{FILE_FORMAT_VERSION + 1}")}),
             "other": _write(tmp_path, "other.npz", **{**saved, "format": np.array("someone-else/1")}),
             "no_cov0": _write(tmp_path, "no_cov0.npz", **{k: v for k, v in saved.items() if k != "cov0"})}
    if case == "demos":
        message = message.replace("{tmp}", str(folder))
    out = tmp_path / "out"
    code = main(["plan", "--prior", files[case], "--robot", "jaco", "--start", *START, "--out", str(out)])
    assert code == 2
    line = one_error_line(capsys)
    assert line.startswith("clamp plan: error: ") and message.format(tmp=tmp_path) in line, line
    assert not out.exists()


def test_prior_files_written_in_the_old_layout_plan_the_same(learned, tmp_path, capsys):
    """A prior saved before the format entry (the six arrays, written here with numpy) is read
    as version 1 and plans as the saved file does."""
    folder, _ = learned
    prior = WorkspacePrior.load(folder / "prior.npz")
    old = _write(tmp_path, "old.npz", **{k: np.asarray(getattr(prior, k))
                                          for k in ("time", "Phi", "u", "Q", "mean0", "cov0")})
    common = ["-q", "plan", "--robot", "jaco", "--start", *START, "--no-retime", "--max-iterations", "30"]
    assert main([*common, "--prior", old, "--out", str(tmp_path / "old")]) == 0
    assert main([*common, "--prior", str(folder / "prior.npz"), "--out", str(tmp_path / "new")]) == 0
    q_old, q_new = (np.array(json.loads((tmp_path / name / "plan.json").read_text())["q"]) for name in ("old", "new"))
    # the old layout has no skill region (info is empty): the same prior, the same free plan
    assert np.max(np.abs(q_old - q_new)) <= 1e-9


@pytest.mark.parametrize("argv, message", [
    (["plan", "--prior", "{prior}", "--num-points", "40"], "--num-points: only with --demos"),
    (["plan", "--prior", "{prior}", "--translate", "0", "0", "0"], "--translate: only with --demos"),
    (["plan", "--prior", "{prior}", "--topic", "/tf"], "--topic: only with --demos"),
    (["plan", "--prior", "{prior}", "--demos", "{demos}"], "not allowed with argument"),
])
def test_plan_options_of_learning_are_refused_with_a_prior(learned, tmp_path, capsys, argv, message):
    folder, _ = learned
    out = tmp_path / "out"
    argv = [a.format(prior=folder / "prior.npz", demos=folder / "demos.npz") for a in argv]
    code = main([*argv, "--robot", "jaco", "--start", *START, "--out", str(out)])
    assert code == 2 and message in one_error_line(capsys) and not out.exists()


def test_learn_keeps_what_the_user_owns(learned, tmp_path, capsys):
    folder, _ = learned
    target = tmp_path / "mine.npz"
    target.write_bytes(b"the user's file")
    argv = ["learn", "--demos", str(folder / "demos.npz"), "--num-points", "30", "--out", str(target)]
    assert main(argv) == 2
    assert "--out: " in one_error_line(capsys) and target.read_bytes() == b"the user's file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.npz"]        # no temporary left
    assert main(["-q", *argv, "--force"]) == 0
    assert WorkspacePrior.load(target).T == 30
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.npz"]
    assert main([*argv[:-2], "--out", str(tmp_path / "no_folder" / "p.npz")]) == 2
    assert "does not exist" in one_error_line(capsys)


def test_learn_joint_space_demonstrations_needs_the_arm(tmp_path, capsys):
    from robots import load_robot
    jaco = load_robot("jaco")
    t = np.linspace(0.0, 4.0, 30)
    rows = []
    for m in range(4):
        q = jaco.neutral_configuration() + (0.3 + 0.02 * m) * np.sin(np.outer(t / 4.0, np.arange(1, 7)) * 0.5)
        rows += [[m, tk, *qk] for tk, qk in zip(t, q)]
    csv = tmp_path / "joints.csv"
    csv.write_text("demo,t," + ",".join(jaco.joint_names) + "\n"
                   + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in rows))
    assert main(["learn", "--demos", str(csv), "--out", str(tmp_path / "p.npz")]) == 2
    assert "--robot: " in one_error_line(capsys) and not (tmp_path / "p.npz").exists()
    assert main(["learn", "--demos", str(csv), "--end-effector", "tool", "--out", str(tmp_path / "p.npz")]) == 2
    assert "--end-effector: only with --urdf" in one_error_line(capsys) and not (tmp_path / "p.npz").exists()
    assert main(["-q", "learn", "--demos", str(csv), "--robot", "jaco", "--out", str(tmp_path / "p.npz")]) == 0
    assert WorkspacePrior.load(tmp_path / "p.npz").info["num_demos"] == 4
