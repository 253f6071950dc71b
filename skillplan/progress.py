"""Progress bars (tqdm) for work that can take more than a couple of seconds.

The library calls :func:`progress`; whether bars are drawn is decided in one place,
:func:`set_progress`: ``None`` (default) draws them only when stderr is a terminal, ``False``
never (the command lines' ``-q``), ``True`` always. Bars go to stderr, never stdout.
"""
from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from .errors import ArgumentTypeError
from skillplan.validation import as_instance, as_scalar

_state: dict[str, bool | None] = {"enabled": None}


def set_progress(enabled: bool | None) -> bool | None:
    """Draw progress bars always (True), never (False) or on a terminal only (None); returns
    the previous setting."""
    if not (enabled is None or isinstance(enabled, bool)):
        raise ArgumentTypeError(f"enabled: expected True, False or None, got {enabled!r:.40}")
    previous, _state["enabled"] = _state["enabled"], enabled
    return previous


def progress(iterable: Iterable[Any] | None = None, *, description: str, total: float | None = None,
             unit: str = "it", delay: float = 0.0) -> Any:
    """A tqdm bar over ``iterable`` (or a manual bar: ``bar.update(n)``), ``total`` steps of
    ``unit``, drawn once the work has lasted ``delay`` seconds (so work that is usually quick
    draws nothing); use as a context manager for manual bars so they close."""
    as_instance(description, "description", str, "text (str)", ArgumentTypeError)
    if total is not None:
        as_scalar(total, "total", minimum=0.0)
    as_scalar(delay, "delay", minimum=0.0)
    from tqdm.auto import tqdm      # deferred: importing the project stays light
    enabled = _state["enabled"]
    return tqdm(iterable, desc=description, total=total, unit=unit, leave=False, delay=delay,
                disable=None if enabled is None else not enabled, dynamic_ncols=True)
