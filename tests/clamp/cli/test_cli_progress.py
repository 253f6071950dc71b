"""The search's progress line (issue 38): on a terminal, a plan that searches for over a second
shows its work against the budget, its starts and solves on stderr; never with -q, never when
stderr is not a terminal. The planner reports through :mod:`clamp.planning.progress` and
prints nothing."""
from __future__ import annotations

import sys

import pytest

import clamp.cli.commands as cli
from clamp.planning.progress import SearchProgress, report, watching


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from scenes import make_demonstrations
    folder = tmp_path_factory.mktemp("progress")
    demos = make_demonstrations("box_closing", num_points=20, seed=1)
    demos.save_npz(folder / "demos.npz")
    return folder, [str(x) for x in demos.positions[:, 0].mean(axis=0)]


def plan_args(folder, start, *more):
    return ["plan", "--robot", "jaco", "--demos", str(folder / "demos.npz"), "--start", *start,
            "--out", str(folder / f"out{len(list(folder.iterdir()))}"), *more]


def test_a_searching_plan_shows_its_starts_and_solves_on_a_terminal(files, capsys, monkeypatch):
    folder, start = files
    monkeypatch.setattr(cli, "SEARCH_PROGRESS_DELAY", 0.0)        # every search counts as long
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert cli.main(plan_args(folder, start)) == 0
    err = capsys.readouterr().err
    assert "searching 'plan'" in err and "1 start, 1 solve" in err, err
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert cli.main(plan_args(folder, start, "-q")) == 0
    assert capsys.readouterr().err == ""


def test_no_progress_line_when_stderr_is_not_a_terminal(files, capsys, monkeypatch):
    folder, start = files
    monkeypatch.setattr(cli, "SEARCH_PROGRESS_DELAY", 0.0)
    assert cli.main(plan_args(folder, start)) == 0
    assert "searching" not in capsys.readouterr().err


def test_the_planner_reports_every_start_to_the_caller_only(jaco, capsys):
    from clamp import learn_prior, plan
    from scenes import Box, Scene, make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", num_points=30, seed=2))
    free = plan(prior, jaco, None, prior.mean[0, :3], covariance=False)
    middle = free.ee_path[len(free.ee_path) // 2]
    events: list[SearchProgress] = []
    with watching(events.append):
        result = plan(prior, jaco, Scene([Box(middle, [0.06, 0.06, 0.06])]), prior.mean[0, :3],
                      covariance=False)
    assert capsys.readouterr() == ("", "")
    assert events and events[0].starts == 1
    for before, after in zip(events, events[1:]):     # start after start (a new search: from 1)
        assert (after.starts, after.work > before.work) == (before.starts + 1, True) or after.starts == 1
    assert all(e.solves >= e.starts and e.work >= e.solves for e in events)
    last = events[-1]
    assert (last.work, last.passed) == (result.search["work"], result.success)
    assert last.limit == result.search["limit"]
    told = len(events)
    report(last)                                  # outside watching(): nobody is told
    assert len(events) == told
