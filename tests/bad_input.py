"""Shared helper of the bad-input catalogues (tests/test_bad_input_*.py).

A catalogue is a table of :class:`Case` rows: a call that is fed one bad input, the project
error class it must raise (a subclass of ``scenes.errors.InvalidArgumentError``, itself a
ValueError) and the argument name the message must contain. :func:`cases` turns the table
into pytest parameters (a row may carry an ``xfail`` reason: strict, so a fix is noticed).
"""
from __future__ import annotations

from collections.abc import Callable
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
    assert case.name in message, f"{case.name!r} not named in {message!r}"
    assert "\n" not in message.strip() or len(message) < 2000, message
