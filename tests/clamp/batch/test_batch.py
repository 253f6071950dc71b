"""Many plans (clamp.batch.runner, clamp batch): executors agree, a killed worker loses nothing, a
stopped batch resumes, bad problems are recorded, the command line works."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from clamp.batch.runner import LocalPool, plan_many, read_results
from clamp.batch.problem_sets import start_problems
from clamp.batch.problems import make_problem, write_problems
from scenes import Box, Scene

SHORT = {"skill": "box_closing", "seed": 0, "num_demos": 6, "num_points": 40}
ROOT = Path(__file__).resolve().parents[3]


def _problems(count: int, seed: int = 0) -> list:
    base = make_problem("b", SHORT, "jaco", [0.2, -0.47, 0.26])
    problems = start_problems(base, count, seed=seed)
    # a few with an obstacle near the path, one on Sawyer
    box = Scene([Box([0.36, -0.30, 0.47], [0.05, 0.05, 0.05])])
    problems[1] = problems[1].replace(scene=box.to_dict())
    problems[2] = problems[2].replace(robot="sawyer")
    return problems


def _positions(record: dict) -> np.ndarray:
    return np.array([p["positions"] for p in record["trajectory"]["points"]])


def _same_results(a: list[dict], b: list[dict]) -> None:
    by_id = {r["id"]: r for r in b}
    assert sorted(by_id) == sorted(r["id"] for r in a)
    for r in a:
        other = by_id[r["id"]]
        assert (r["status"], r["success"], r["reasons"]) == \
            (other["status"], other["success"], other["reasons"]), r["id"]
        np.testing.assert_allclose(_positions(r), _positions(other), atol=1e-9, rtol=0)


@pytest.fixture(scope="module")
def small_batch():
    problems = _problems(6)
    return problems, list(plan_many(problems))


def test_in_process_records(small_batch):
    problems, records = small_batch
    assert [r["id"] for r in records] == [p.id for p in problems]   # in order, one each
    assert [r["hash"] for r in records] == [p.hash for p in problems]
    for r in records:
        assert r["status"] == "done" and r["attempts"] == 1
        assert r["timings"]["total"] > 0 and r["timings"]["wall"] >= r["timings"]["total"]
        assert r["verdict"]["success"] == r["success"]
    assert len(records[2]["trajectory"]["joint_names"]) == 7          # the Sawyer one
    assert any(r["success"] for r in records)


def test_process_pool_and_executor_agree(small_batch):
    problems, serial = small_batch
    with LocalPool(2) as pool:
        assert pool.start() > 0 and len(pool.pids) == 2
        pooled = list(plan_many(problems, pool))
        assert {r["worker"].split(":")[1] for r in pooled} <= {str(p) for p in pool.pids}
    _same_results(serial, pooled)
    with ThreadPoolExecutor(2) as executor:
        _same_results(serial, list(plan_many(problems, executor)))


def test_dask_local_cluster_agrees(small_batch):
    distributed = pytest.importorskip("distributed", reason="Dask not installed: pip install '.[dask]'")
    problems, serial = small_batch
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=40) as cluster, \
            distributed.Client(cluster) as client:
        records = list(plan_many(problems, client))
    _same_results(serial, records)
    assert len({r["worker"] for r in records}) >= 1


def test_killed_worker_loses_nothing(tmp_path):
    problems = _problems(50, seed=1)
    out = tmp_path / "results.jsonl"
    with LocalPool(2) as pool:
        pool.start()
        victim = pool.pids[0]
        records = []
        for record in plan_many(problems, pool, out=out, trajectories="none"):
            records.append(record)
            if len(records) == 5:
                os.kill(victim, signal.SIGKILL)
        assert pool.restarts >= 1
    lines = read_results(out)
    assert len(lines) == 50 == len({r["id"] for r in lines})
    assert {r["hash"] for r in lines} == {p.hash for p in problems}
    assert all(r["status"] == "done" for r in lines)
    assert any(r["attempts"] > 1 for r in lines)        # the ones in flight were run again


def test_stopped_batch_resumes(tmp_path):
    problems = _problems(50, seed=2)
    out = tmp_path / "results.jsonl"
    batch = plan_many(problems, out=out, trajectories="none")
    first = [next(batch) for _ in range(20)]
    batch.close()
    before = out.read_bytes()
    assert before.count(b"\n") == 20
    with open(out, "ab") as handle:                      # a crash in the middle of a write
        handle.write(b'{"id": "torn", "ha')
    rest = list(plan_many(problems, out=out, trajectories="none"))
    assert len(rest) == 30 and not {r["id"] for r in rest} & {r["id"] for r in first}
    after = out.read_bytes()
    assert after.startswith(before)                     # the first 20 lines untouched
    lines = read_results(out)
    assert len(lines) == 50 == len({r["hash"] for r in lines}) and after.endswith(b"\n")
    assert list(plan_many(problems, out=out)) == []     # nothing left to do


def test_bad_problems_are_recorded(tmp_path):
    good = _problems(3, seed=3)
    bad_scene = {"obstacles": [{"type": "box", "center": [0.3, -0.3, 0.2], "size": [0.1, -0.1, 0.1]}]}
    problems = [good[0],
                good[1].replace(id="unknown robot", robot="nao"),
                good[1].replace(id="malformed scene", scene=bad_scene),
                good[1].replace(id="nan start", start=[float("nan"), -0.47, 0.26]),
                good[1].replace(id="missing prior", prior={"path": "nowhere.npz"}),
                good[2]]
    records = {r["id"]: r for r in plan_many(problems, out=tmp_path / "r.jsonl",
                                             base_dir=tmp_path)}
    assert len(read_results(tmp_path / "r.jsonl")) == 6
    assert records[good[0].id]["status"] == records[good[2].id]["status"] == "done"
    expected = {"unknown robot": ("UnknownRobotError", "unknown robot 'nao'"),
                "malformed scene": ("SceneFileError", "size"),
                "nan start": ("NonFiniteError", "start"),
                "missing prior": ("PriorFileError", "nowhere.npz")}
    for name, (kind, words) in expected.items():
        r = records[name]
        assert r["status"] == "error" and not r["success"] and r["trajectory"] is None
        assert r["error"]["type"] == kind and words in r["error"]["message"], r["error"]


def test_command_line(tmp_path):
    problems = _problems(4, seed=4)
    problems[3] = problems[3].replace(robot="nao")
    path = write_problems(problems, tmp_path / "problems.jsonl")
    out = tmp_path / "results.jsonl"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    cmd = [sys.executable, "-m", "clamp", "batch", str(path), "--out", str(out),
           "--trajectories", str(tmp_path / "traj")]
    run = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert run.returncode == 1, run.stderr               # one problem recorded as an error
    assert "success" in run.stdout and "error: UnknownRobotError" in run.stdout
    lines = read_results(out)
    assert len(lines) == 4
    done = [r for r in lines if r["status"] == "done"]
    for r in done:
        data = json.loads(Path(r["trajectory"]).read_text())
        assert data["format"] and data["header"]["verdict"]["retiming"]["within_limits"]  # retimed (issue 21)
        assert not any(data["points"][0]["velocities"] + data["points"][-1]["velocities"])   # at rest
    again = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert "4 of 4 problems already done" in again.stderr and len(read_results(out)) == 4
    silent = subprocess.run(cmd + ["-q"], capture_output=True, text=True, env=env, timeout=300)
    assert (silent.returncode, silent.stdout) == (1, "")                       # -q: errors only:
    assert silent.stderr.splitlines() == [                                     # the one that failed
        f"clamp batch: problem {problems[3].id!r}: error: UnknownRobotError: "
        f"{lines[[r['id'] for r in lines].index(problems[3].id)]['error']['message']}"]
    bad = subprocess.run([sys.executable, "-m", "clamp", "batch", str(tmp_path / "none.jsonl"),
                          "--out", str(out)], capture_output=True, text=True, env=env, timeout=300)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and "none.jsonl" in bad.stderr


def test_a_plan_failing_its_verdict_exits_1_with_its_first_reason_on_stderr_under_quiet(tmp_path):
    problems = start_problems(make_problem("b", SHORT, "jaco", [0.2, -0.47, 0.26]), 2, seed=4)
    start = np.array(problems[0].start, dtype=float)        # a box around the start: planned, failed
    problems[0] = problems[0].replace(id="start in a box",
                                      scene=Scene([Box(start, [0.1, 0.1, 0.1])]).to_dict())
    path = write_problems(problems, tmp_path / "problems.jsonl")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, "-m", "clamp", "batch", str(path), "--out", "r.jsonl",
                          "--trajectories", "none", "-q"], capture_output=True, text=True, env=env,
                         cwd=tmp_path, timeout=300)
    records = {r["id"]: r for r in read_results(tmp_path / "r.jsonl")}
    assert records[problems[1].id]["success"], records[problems[1].id]["reasons"]
    failed = records["start in a box"]
    assert failed["status"] == "done" and not failed["success"] and failed["reasons"]
    assert (run.returncode, run.stdout) == (1, "")
    assert run.stderr.splitlines() == [f"clamp batch: problem 'start in a box' failed: {failed['reasons'][0]}"]


def _on_a_terminal(args: list[str], cwd: Path) -> str:
    """Run ``clamp ARGS`` with stderr on a pseudo-terminal; what it wrote there."""
    import fcntl
    import pty
    import struct
    import termios
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))   # 100 columns
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    with subprocess.Popen([sys.executable, "-m", "clamp", *args], stdout=subprocess.DEVNULL,
                          stderr=slave, env=env, cwd=cwd) as child:
        os.close(slave)
        chunks = []
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:                              # EIO: the child closed the terminal
                break
            if not chunk:
                break
            chunks.append(chunk)
        child.wait(timeout=300)
    os.close(master)
    return b"".join(chunks).decode("utf-8", "replace")


def test_progress_bar_on_a_terminal_and_not_with_quiet(tmp_path):
    path = write_problems(_problems(3, seed=5), tmp_path / "problems.jsonl")
    drawn = _on_a_terminal(["batch", str(path), "--out", "a.jsonl", "--trajectories", "none"],
                           tmp_path)
    assert "planning:" in drawn and "/3 [" in drawn and "plan/s" in drawn, drawn
    quiet = _on_a_terminal(["batch", str(path), "--out", "b.jsonl", "--trajectories", "none",
                            "-q"], tmp_path)
    assert quiet == "" and len(read_results(tmp_path / "b.jsonl")) == 3
