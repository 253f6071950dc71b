"""How far a request's search has come, for a caller that shows it (the command line's progress
line): a callback set for the duration of a call (:func:`watching`) is told after every start
of the search (:func:`report`, called by :mod:`clamp.planning.search`). The planner itself
prints nothing; without a callback a report costs a lookup."""
from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass


@dataclass(frozen=True)
class SearchProgress:
    """A search after one of its starts: ``starts`` made, ``solves`` (optima solved and judged),
    ``work`` spent (solver trials and judged optima, the budget's count) against ``limit`` (the
    budget in the same count; None: unbounded, or not known before the second start), and
    whether a start has ``passed`` (the search then ends)."""

    starts: int
    solves: int
    work: int
    limit: float | None
    passed: bool


_listener: ContextVar[Callable[[SearchProgress], None] | None] = ContextVar("search_progress", default=None)


@contextmanager
def watching(callback: Callable[[SearchProgress], None]) -> Iterator[None]:
    """Within the block, every search of this thread (or task) reports to ``callback``."""
    token = _listener.set(callback)
    try:
        yield
    finally:
        _listener.reset(token)


def report(progress: SearchProgress) -> None:
    """Tell the callback set by :func:`watching`, if any, how far the search has come."""
    callback = _listener.get()
    if callback is not None:
        callback(progress)
