"""skillplan.command_line: atomic writes, output folders, one-line usage errors, logging restored."""
from __future__ import annotations

import logging

import pytest

from bad_input import raises_naming
from skillplan.command_line import (CommandLineParser, atomic_write, atomic_write_text, output_directory,
                                 output_file, run)
from scenes.errors import InvalidArgumentError, OutputPathError


def test_interrupted_write_keeps_the_old_file(tmp_path):
    target = tmp_path / "plan.json"
    target.write_text("old")

    def half_then_fail(handle):
        handle.write(b"new, but only half")
        raise KeyboardInterrupt  # the user pressed Ctrl-C mid-write

    with pytest.raises(KeyboardInterrupt):
        atomic_write(target, half_then_fail, overwrite=True)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.json"]
    atomic_write_text(target, "new", overwrite=True)
    assert target.read_text() == "new"


def test_existing_file_is_not_replaced_without_overwrite(tmp_path):
    target = tmp_path / "a.txt"
    target.write_text("mine")
    with raises_naming(OutputPathError, "a.txt"):
        atomic_write_text(target, "theirs")
    assert target.read_text() == "mine"
    with raises_naming(OutputPathError, "missing"):
        atomic_write_text(tmp_path / "missing" / "a.txt", "x")
    assert isinstance(OutputPathError("x"), (InvalidArgumentError, FileExistsError))


def test_output_directory_new_empty_or_force(tmp_path):
    assert output_directory(tmp_path / "new" / "deeper").is_dir()
    (tmp_path / "empty").mkdir()
    assert output_directory(tmp_path / "empty") == tmp_path / "empty"
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    with raises_naming(OutputPathError, "--out", "full"):
        output_directory(tmp_path / "full")
    assert output_directory(tmp_path / "full", force=True) == tmp_path / "full"
    (tmp_path / "file").write_text("x")
    with raises_naming(OutputPathError, "--out", "file"):
        output_directory(tmp_path / "file", force=True)
    with raises_naming(OutputPathError, "--out", "file"):
        output_file(tmp_path / "file")
    assert output_file(tmp_path / "file", force=True) == tmp_path / "file"


def _parser(action):
    parser = CommandLineParser(prog="tool")
    parser.add_argument("--n", type=int, required=True)
    parser.set_defaults(run=action)
    return parser


def test_usage_errors_are_one_line(capfd):
    assert run(_parser(lambda args: 0), ["--n", "x"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tool: error: argument --n")


@pytest.mark.parametrize("exc, code, word", [
    (InvalidArgumentError("start: expected 3 numbers, got 2"), 2, "start"),
    (FileNotFoundError(2, "No such file or directory", "demos.npz"), 2, "demos.npz"),
    (RuntimeError("boom\nsecond line"), 1, "internal error"),
])
def test_errors_become_one_line(capfd, exc, code, word):
    def action(args):
        raise exc
    assert run(_parser(action), ["--n", "1"]) == code
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and word in err and "Traceback" not in err


def test_logging_is_restored_after_a_run(capfd):
    logger = logging.getLogger("clamp")
    before = (logger.handlers[:], logger.level, logger.propagate)

    def action(args):
        logging.getLogger("clamp.x").info("shown with -v")
        return 0
    assert run(_parser(action), ["--n", "1", "-v"]) == 0
    assert "INFO clamp.x: shown with -v" in capfd.readouterr().err
    assert (logger.handlers, logger.level, logger.propagate) == before
    assert run(_parser(action), ["--n", "1"]) == 0
    assert capfd.readouterr().err == ""


def test_progress_bars_follow_the_setting(capfd):
    from skillplan.progress import progress, set_progress
    previous = set_progress(True)
    try:
        for _ in progress(range(3), description="counting"):
            pass
        assert "counting" in capfd.readouterr().err
        set_progress(False)
        for _ in progress(range(3), description="silent"):
            pass
        assert capfd.readouterr().err == ""
    finally:
        set_progress(previous)
