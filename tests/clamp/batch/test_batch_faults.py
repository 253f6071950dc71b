"""Batch runs that never duplicate or lose work (clamp.batch.runner, clamp batch): one run per results
file, no worker outliving its batch, a dead worker costing only its own problem, strict JSON
lines, output trouble refused before any work, one-line messages naming the user's path."""
from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from bad_input import raises_naming
from clamp.batch.runner import LocalPool, ResultsFile, pending_problems, plan_many, read_results
from clamp.batch.report import reason_key, summarize
from clamp.errors import InvalidParameterError
from clamp.batch.problems import make_problem, write_problems
from test_batch import SHORT, _problems

ROOT = Path(__file__).resolve().parents[3]
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}


def _clamp(args: list, cwd: Path, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "clamp", *map(str, args)], cwd=cwd, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs)


def _lines(path: Path) -> list[bytes]:
    return path.read_bytes().splitlines() if path.exists() else []


def _wait_for_lines(path: Path, count: int, process: subprocess.Popen) -> None:
    while len(_lines(path)) < count:
        assert process.poll() is None, process.communicate()
        time.sleep(0.1)


def _one_line_error(code: int, stderr: str, *words: str, exit_code: int = 2) -> str:
    lines = stderr.strip().splitlines()
    assert code == exit_code and len(lines) == 1 and "Traceback" not in stderr, (code, stderr)
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


def _strict(line: bytes) -> dict:
    def refuse(constant: str) -> None:
        raise AssertionError(f"non-standard JSON constant {constant} in {line[:80]!r}")
    return json.loads(line, parse_constant=refuse)


# --------------------------------------------------------------------- one run per results file
def test_second_run_on_the_same_out_refuses(tmp_path):
    problems = write_problems(_problems(30, seed=11), tmp_path / "p.jsonl")
    out = tmp_path / "r.jsonl"
    args = ["batch", problems, "--out", out, "--trajectories", "none", "-q"]
    first, second = _clamp(args, tmp_path), _clamp(args, tmp_path)   # started together
    answers = {p.pid: (p.wait(timeout=600), p.communicate()[1]) for p in (first, second)}
    codes = sorted(code for code, _ in answers.values())
    assert codes == [0, 2], answers
    [(winner, _)] = [(pid, a) for pid, a in answers.items() if a[0] == 0]
    [(_, stderr)] = [a for a in answers.values() if a[0] == 2]
    _one_line_error(2, stderr, str(out), f"pid {winner}")
    records = [_strict(line) for line in _lines(out)]
    assert len(records) == 30 == len({r["id"] for r in records})   # one line per problem
    assert not (tmp_path / ".r.jsonl.lock").exists()                  # released at the end


def test_a_held_results_file_is_refused_naming_the_holder(tmp_path):
    problems = write_problems(_problems(3, seed=12), tmp_path / "p.jsonl")
    out = tmp_path / "r.jsonl"
    with ResultsFile(out) as held:
        assert held.finished == set()
        run = subprocess.run([sys.executable, "-m", "clamp", "batch", str(problems), "--out",
                              "r.jsonl"], cwd=tmp_path, env=ENV, capture_output=True, text=True,
                             timeout=300)                             # named as the user typed it
        _one_line_error(run.returncode, run.stderr, "--out: 'r.jsonl'", f"pid {os.getpid()}")
        with raises_naming(InvalidParameterError, "out", f"pid {os.getpid()}"):
            list(plan_many(_problems(3), out=out))                    # in this process too
    assert _lines(out) == []


# --------------------------------------------------------------------- workers die with the batch
def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (from /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _alive(pid: int) -> bool:
    """Running (a zombie waiting to be reaped is not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_kill_9_of_the_batch_leaves_no_worker(tmp_path):
    problems = write_problems(_problems(400, seed=13), tmp_path / "p.jsonl")
    out = tmp_path / "r.jsonl"
    main = _clamp(["batch", problems, "--out", out, "--workers", 2, "--trajectories", "none",
                   "-q"], tmp_path)
    children: list[int] = []
    try:
        _wait_for_lines(out, 4, main)                  # both workers have planned
        children = _children(main.pid)
        workers = [p for p in children if b"spawn_main" in Path(f"/proc/{p}/cmdline").read_bytes()]
        assert len(workers) == 2, children
        main.kill()
        main.wait()
        time.sleep(5)
        assert [p for p in children if _alive(p)] == []    # workers and resource tracker
    finally:
        main.kill()
        for pid in filter(_alive, children):
            os.kill(pid, signal.SIGKILL)
    with ResultsFile(out) as results:       # the stale lock is free; whole lines were kept
        assert len(results.finished) == len(_lines(out)) >= 4


# --------------------------------------------------------------------- a dead worker: one problem
def test_dead_worker_costs_only_its_problem_and_a_rerun_plans_exactly_it(tmp_path):
    problems = _problems(12, seed=14)
    out = tmp_path / "r.jsonl"
    with LocalPool(2) as pool:
        pool.start()
        victim, other = pool.pids
        records = []
        for record in plan_many(problems, pool, out=out, retries=0, trajectories="none"):
            records.append(record)
            if len(records) == 4:
                os.kill(victim, signal.SIGKILL)
        assert pool.restarts == 1 and other in pool.pids and victim not in pool.pids
    lost = [r for r in records if r["status"] == "lost"]
    assert len(lost) == 1 and lost[0]["error"]["type"] == "WorkerDied", lost
    assert str(victim) in lost[0]["error"]["message"]
    assert sum(r["status"] == "done" for r in records) == 11
    assert pending_problems(problems, out) == [p for p in problems if p.id == lost[0]["id"]]
    again = list(plan_many(problems, out=out, trajectories="none"))
    assert [r["id"] for r in again] == [lost[0]["id"]] and again[0]["status"] == "done"
    lines = [_strict(line) for line in _lines(out)]          # the "lost" line was superseded
    assert len(lines) == 12 == len({r["hash"] for r in lines})
    assert all(r["status"] == "done" for r in lines)


def test_reader_takes_the_latest_line_of_a_problem(tmp_path):
    out = tmp_path / "r.jsonl"       # a run killed after retrying a problem, before compacting
    rows = [{"id": "a", "hash": "h1", "status": "lost"}, {"id": "b", "hash": "h2", "status": "done"},
            {"id": "a", "hash": "h1", "status": "done"}]
    out.write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert [(r["id"], r["status"]) for r in read_results(out)] == [("b", "done"), ("a", "done")]
    out.write_text("".join(json.dumps(r) + "\n" for r in rows[:2]))
    with ResultsFile(out) as results:
        assert results.finished == {"h2"}                  # lost: not finished


# --------------------------------------------------------------------- strict JSON
def test_every_line_is_strict_json(tmp_path):
    problems = [make_problem("far", SHORT, "jaco", [2.0, 0.0, 0.3],           # fails before planning
                             meta={"score": float("nan"), "range": [1.0, float("-inf")]}),
                *_problems(3, seed=15)[:2]]
    out = tmp_path / "r.jsonl"
    records = {r["id"]: r for r in plan_many(problems, out=out, trajectories=tmp_path / "traj")}
    lines = [_strict(line) for line in _lines(out)]
    assert len(lines) == 3
    far = {r["id"]: r for r in lines}["far"]
    assert far == records["far"] and far["metrics"]["stop_reason"] == "not started"
    assert far["metrics"]["final_error"] is None and far["meta"] == {"score": None, "range": [1.0, None]}
    assert far["non_finite"] == {"meta.score": "NaN", "meta.range[1]": "-inf",
                                 "metrics.final_error": "NaN", "metrics.plausibility": "NaN"}
    for r in lines:
        _strict(Path(r["trajectory"]).read_bytes())
        assert r["id"] == "far" or r["non_finite"] == {}


# --------------------------------------------------------------------- output trouble, up front
def _writable(folder: Path) -> bool:
    try:
        fd, probe = tempfile.mkstemp(dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(probe)
    return True


@pytest.fixture
def read_only_folder(tmp_path) -> Iterator[Path]:
    """An empty folder nobody can write in: chmod, and for root (whom permissions do not stop)
    the immutable attribute."""
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o555)
    immutable = _writable(folder) and subprocess.run(
        ["chattr", "+i", str(folder)], capture_output=True).returncode == 0
    try:
        if _writable(folder):
            pytest.skip("cannot make a read-only folder here (root without chattr +i)")
        yield folder
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
        folder.chmod(0o755)


def _main(args: list, capfd) -> tuple[int, str]:
    from clamp.cli.commands import main
    code = main([str(a) for a in args])
    return code, capfd.readouterr().err


@pytest.mark.parametrize("kind", ["/dev/full", "fifo", "read-only folder", "dangling link"])
def test_output_trouble_is_refused_before_any_work(tmp_path, capfd, request, kind):
    problems = write_problems(_problems(3), tmp_path / "p.jsonl")
    if kind == "/dev/full":
        out, words = Path("/dev/full"), ["/dev/full", "character device"]
    elif kind == "fifo":
        out = tmp_path / "results.fifo"
        os.mkfifo(out)
        words = [str(out), "FIFO"]
    elif kind == "read-only folder":
        folder = request.getfixturevalue("read_only_folder")
        out, words = folder / "r.jsonl", [str(folder), "cannot write"]
    else:
        out = tmp_path / "link.jsonl"
        out.symlink_to(tmp_path / "gone" / "r.jsonl")
        words = [str(out), "symbolic link", "does not exist"]
    before = sorted(tmp_path.rglob("*"))
    code, err = _main(["batch", problems, "--out", out, "--trajectories", tmp_path / "traj"], capfd)
    line = _one_line_error(code, err, "--out", *words)
    assert "File exists" not in line
    assert sorted(tmp_path.rglob("*")) == before           # nothing written, nothing planned


def test_plan_into_a_read_only_folder_is_refused_before_planning(read_only_folder, capfd):
    code, err = _main(["plan", "--demos", "never_read.csv", "--robot", "jaco", "--start", 0.2,
                       -0.47, 0.26, "--out", read_only_folder], capfd)
    _one_line_error(code, err, "--demos", "never_read.csv")   # inputs first: nothing computed
    from scenes import make_demonstrations
    demos = read_only_folder.parent / "demos.npz"
    make_demonstrations("box_closing", num_points=30, seed=1).save_npz(demos)
    code, err = _main(["plan", "--demos", demos, "--robot", "jaco", "--start", 0.2, -0.47, 0.26,
                       "--out", read_only_folder], capfd)
    line = _one_line_error(code, err, "--out", str(read_only_folder), "cannot write")
    assert ".tmp" not in line and list(read_only_folder.iterdir()) == []


def test_dangling_link_as_output_folder(tmp_path, capfd):
    link = tmp_path / "plots"
    link.symlink_to(tmp_path / "nowhere")
    code, err = _main(["demo", "--out", link], capfd)
    line = _one_line_error(code, err, "--out", str(link), "symbolic link")
    assert "File exists" not in line and not (tmp_path / "nowhere").exists()


def _file_size_limit(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # write() fails with EFBIG instead
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_write_failure_mid_run_names_the_file_and_keeps_whole_lines(tmp_path):
    problems = write_problems(_problems(8, seed=16), tmp_path / "p.jsonl")
    out = tmp_path / "r.jsonl"
    cmd = [sys.executable, "-m", "clamp", "batch", str(problems), "--out", str(out),
           "--trajectories", "none", "-q"]
    run = subprocess.run(cmd, cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=600,
                         preexec_fn=_file_size_limit(3000))
    _one_line_error(run.returncode, run.stderr, "--out", str(out), "File too large", exit_code=1)
    data = out.read_bytes()
    assert 0 < len(data) <= 3000 and data.endswith(b"\n")      # the half-written line was cut
    kept = [_strict(line) for line in data.splitlines()]
    assert 0 < len(kept) < 8
    again = subprocess.run(cmd, cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert len(_lines(out)) == 8 == len({r["id"] for r in read_results(out)})


# --------------------------------------------------------------------- messages
def test_missing_demonstrations_are_named_by_their_option(tmp_path, capfd):
    code, err = _main(["plan", "--demos", tmp_path / "nope.csv", "--robot", "jaco", "--start",
                       0.2, -0.47, 0.26, "--out", tmp_path / "out"], capfd)
    line = _one_line_error(code, err, "--demos", "nope.csv")
    assert "path:" not in line and not (tmp_path / "out").exists()


def test_summary_keeps_the_digits_of_names():
    reasons = ["collision: j2s6s200_link_finger_2 hits box_0 at state 12 (depth -3.1 mm)",
               "collision: j2s6s200_link_finger_2 hits box_0 at state 87 (depth -9.0 mm)",
               "collision: j2s6s200_link_finger_1 hits box_0 at state 40 (depth -1.2 mm)"]
    assert reason_key(reasons[0]) == "collision: j2s6s200_link_finger_2 hits box_0 at state #"
    records = [{"id": str(k), "hash": str(k), "status": "done", "success": False,
                "reasons": [r], "timings": {"total": 0.1}} for k, r in enumerate(reasons)]
    assert list(summarize(records)["reasons"].values()) == [2, 1]
    assert reason_key("clearance -9.1 mm after 1e-3 s") == "clearance # mm after # s"
