"""BLAS thread control for the hot loops of every package (scenes is the base they all import).

The products inside the planners' and reproductions' hot loops are tiny (d <= 14 for CLAMP's
blocks, 2 or 3 for TLGC's points); a threaded BLAS (OpenBLAS defaults to one thread per core)
spends longer waking and synchronising its threads than computing, and gets slower still under
load. Hot loops therefore run inside :func:`single_blas_thread`, which limits every loaded
BLAS to one thread for the duration and restores the caller's setting afterwards
(threadpoolctl; a few microseconds per entry with the cached controller, against ~2 ms for
``threadpool_limits``, which scans the loaded libraries on every call).
"""
from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from threadpoolctl import ThreadpoolController

_CONTROLLER: ThreadpoolController | None = None


def _controller() -> ThreadpoolController:
    """The process-wide ThreadpoolController (built once: scanning the libraries is slow)."""
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER


@contextmanager
def single_blas_thread() -> Iterator[None]:
    """Context manager: every BLAS library uses one thread inside, the old setting after."""
    with _controller().limit(limits=1, user_api="blas"):
        yield
