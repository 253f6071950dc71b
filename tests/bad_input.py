"""Shared helper of the bad-input catalogues (tests/test_bad_input_*.py).

A catalogue is a table of :class:`Case` rows: a call that is fed one bad input, the project
error class it must raise (a subclass of ``scenes.errors.InvalidArgumentError``, itself a
ValueError) and the argument name the message must contain. :func:`cases` turns the table
into pytest parameters (a row may carry an ``xfail`` reason: strict, so a fix is noticed).

Error tests outside the catalogues use :func:`raises_naming`: the same check (the class, the
argument's name in the message) as a context manager; a whole sentence is pinned with
``pytest.raises(..., match=...)`` only where the sentence is the feature (a verdict's reason, a
documented hint such as "positions look like millimetres: divide by 1000").
"""
from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest

from scenes.errors import InvalidArgumentError


@dataclass(frozen=True)
class Case:
    """One bad input: ``call(fixtures)`` must raise ``error`` with ``name`` in its message."""

    id: str
    call: Callable[[Any], Any]
    error: type[Exception]
    name: str
    xfail: str | None = None


def cases(table: list[Case]) -> list[Any]:
    """pytest parameters of a catalogue (ids unique; xfail rows strict)."""
    ids = [c.id for c in table]
    duplicates = {i for i in ids if ids.count(i) > 1}
    assert not duplicates, f"duplicate case ids {sorted(duplicates)}"
    return [pytest.param(c, id=c.id, marks=[pytest.mark.xfail(strict=True, reason=c.xfail)]
                         if c.xfail else []) for c in table]


def check(case: Case, fixtures: Any) -> None:
    """Run one case: the project's error of the stated class, naming the argument."""
    assert issubclass(case.error, InvalidArgumentError), case.error
    with pytest.raises(case.error) as info:
        case.call(fixtures)
    message = str(info.value)
    assert names(message, case.name), f"{case.name!r} not named in {message!r}"
    assert "\n" not in message.strip() or len(message) < 2000, message


def names(message: str, name: str) -> bool:
    """Whether ``message`` names ``name`` as written: the exact text, not inside a longer word
    (``q`` is not named by ``qdot``, ``points`` not by ``waypoints``)."""
    before = r"(?<!\w)" if re.match(r"\w", name) else ""
    after = r"(?!\w)" if re.search(r"\w$", name) else ""
    return re.search(before + re.escape(name) + after, message) is not None


@contextmanager
def raises_naming(error: type[BaseException], *named: str) -> Iterator[pytest.ExceptionInfo]:
    """``pytest.raises(error)`` whose message must name each of ``named``: the argument as the
    user typed it (``"goal"``, ``"--acc-limit"``, ``"observations[0] position"``), or the file's
    name, or a value the test is about (the valid choices, the offending index)."""
    assert named, "name the argument the message must contain"
    with pytest.raises(error) as info:
        yield info
    message = str(info.value)
    for name in named:
        assert names(message, name), f"{name!r} not named in {message!r}"
