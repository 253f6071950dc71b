"""The results file of a batch (:mod:`clamp.batch.runner`): one strict-JSON line per problem, written
by one run at a time.

- Lock: :class:`ResultsFile` holds an exclusive ``fcntl.flock`` on a sidecar file
  ``.NAME.lock`` beside ``NAME`` (holding the run's pid) for as long as it is open; a second
  run on the same file is refused at once, naming the file and the holder's pid. The sidecar
  (not the results file itself) carries the lock because the results file may be replaced by a
  compacted copy at the end of a run.
- Resume: a problem counts as finished when its latest line is "done" or "error"; a "lost"
  line (its worker died) does not, so a rerun plans it again and appends its new line.
- One line per problem: the reader (:func:`read_results`) takes the latest line of each
  problem (by hash), and a run that appended a line superseding an earlier one rewrites the
  file at its end, atomically, keeping only the latest line per problem (byte for byte, in the
  order they were written). A run killed before that leaves the superseded lines, which the
  reader and the next run skip.
- Strict JSON: :func:`strict_json` writes every NaN / +-inf as null and lists where it did
  (the record's ``non_finite``: {"metrics.final_error": "NaN", "meta.score": "inf"}); lines are
  written with ``allow_nan=False``.
- Write failures (disk full, file too large) are :class:`scenes.errors.OutputWriteError` naming
  the file; a line that was half-written is cut back, so the file holds whole lines.
"""
from __future__ import annotations

import fcntl
import json
import logging
import math
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from clamp.errors import InvalidParameterError
from clamp.batch.problems import json_lines
from skillplan.command_line import atomic_write, writable_file
from scenes.errors import OutputWriteError

log = logging.getLogger(__name__)

#: how every record line starts (``json.dumps`` of a record, "id" first): a torn last line
#: that does not is not the batch's own and is never cut
RECORD_START = b'{"id":'
#: the status of a problem whose worker died: not finished, planned again on a rerun
LOST = "lost"


def strict_json(value: Any, where: str = "") -> tuple[Any, dict[str, str]]:
    """``value`` (JSON data) with every non-finite float replaced by None, and {dotted path:
    "NaN" | "inf" | "-inf"} of what was replaced (lists indexed as ``a[2]``)."""
    replaced: dict[str, str] = {}

    def clean(x: Any, path: str) -> Any:
        if isinstance(x, float) and not math.isfinite(x):
            replaced[path] = "NaN" if x != x else ("inf" if x > 0 else "-inf")
            return None
        if isinstance(x, dict):
            return {k: clean(v, f"{path}.{k}" if path else str(k)) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v, f"{path}[{i}]") for i, v in enumerate(x)]
        return x

    return clean(value, where), replaced


def _latest_lines(path: Path, name: str = "path") -> list[tuple[str, dict[str, Any], bytes]]:
    """(hash, record, raw line) of the latest complete line of each problem, in the order
    those lines were written; InvalidParameterError naming ``name`` for a line that is not a
    batch record."""
    latest: dict[str, tuple[dict[str, Any], bytes]] = {}
    for k, raw, record in json_lines(path):
        if not {"hash", "status"} <= record.keys() or not isinstance(record["hash"], str):
            raise InvalidParameterError(f"{name}: {str(path)!r} line {k} is not a batch result "
                                        "(no 'hash' / 'status'); expected a results file")
        latest.pop(record["hash"], None)       # re-inserted: the order of the latest lines
        latest[record["hash"]] = (record, raw)
    return [(h, record, raw) for h, (record, raw) in latest.items()]


def read_results(path: str | Path) -> list[dict[str, Any]]:
    """The records of a results file: the latest line of each problem (a retried problem's
    earlier "lost" line is superseded), complete lines only."""
    return [record for _, record, _ in _latest_lines(path)]


def finished_hashes(path: str | Path) -> set[str]:
    """Hashes of the problems a results file holds as finished ("done" or "error"); read
    without the lock (whole lines only)."""
    return {h for h, record, _ in _latest_lines(path, "out") if record["status"] != LOST}


class _Lock:
    """An exclusive flock on ``.NAME.lock`` beside the results file ``results`` (errors name
    it as the user gave it, ``shown``), holding this pid."""

    WAIT_FOR_PID = 0.5          # [s] a holder writes its pid just after taking the lock

    def __init__(self, results: Path, option: str, shown: Path):
        self.path = results.with_name(f".{results.name}.lock")
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = self._holder(fd)
                os.close(fd)
                raise InvalidParameterError(
                    f"{option}: {str(shown)!r} is being written by another batch (pid "
                    f"{holder}); wait for it to end or choose another results file") from None
            try:
                current = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                current = False
            if current:
                break
            os.close(fd)        # the holder removed the sidecar as it ended: take a new one
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd: int | None = fd

    def _holder(self, fd: int) -> str:
        deadline = time.monotonic() + self.WAIT_FOR_PID
        while True:
            text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
            if text.isdigit() or time.monotonic() > deadline:
                return text or "unknown"
            time.sleep(0.02)

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            os.unlink(self.path)            # still holding the lock: nobody else has it
        except FileNotFoundError:
            pass
        os.close(self._fd)
        self._fd = None


class ResultsFile:
    """The JSON Lines output of a batch, open for one run: locked (see the module docstring),
    its finished problems read (:attr:`finished`), a torn last line cut; :meth:`append` writes
    whole strict-JSON lines; :meth:`close` compacts superseded lines and releases the lock.
    ``option``: how errors name the file (``"out"``, ``"--out"``). A context manager."""

    FSYNC_SECONDS = 5.0

    def __init__(self, path: str | Path, option: str = "out"):
        self.option = option
        self.path = writable_file(path, option, InvalidParameterError)
        self._real = self.path.resolve()     # a symbolic link: lock and rewrite its target
        self._lock = _Lock(self._real, option, shown=self.path)
        try:
            latest = _latest_lines(self.path, option) if self.path.exists() else []
            self._repair()
        except BaseException:
            self._lock.release()
            raise
        self.finished = {h for h, record, _ in latest if record["status"] != LOST}
        self._lost = {h for h, record, _ in latest if record["status"] == LOST}
        self._superseded = 0
        self._fd: int | None = None
        self._synced = time.monotonic()

    def _repair(self) -> None:
        """Cut a torn last line (a crash in the middle of a write) so appending stays valid."""
        if not self.path.exists():
            return
        with open(self.path, "rb+") as handle:
            data = handle.read()
            if data and not data.endswith(b"\n"):
                keep = data.rfind(b"\n") + 1
                if not data[keep:].startswith(RECORD_START[:len(data) - keep]):
                    raise InvalidParameterError(
                        f"{self.option}: {str(self.path)!r} ends in a line that is not a batch "
                        f"result ({data[keep:keep + 30]!r}); expected a results file or a new path")
                log.warning("%s: removing a torn last line (%d bytes)", self.path, len(data) - keep)
                handle.truncate(keep)

    def _failed(self, exc: OSError, doing: str) -> OutputWriteError:
        return OutputWriteError(f"{self.option}: cannot {doing} {str(self.path)!r} "
                                f"({exc.strerror or exc}); the complete lines written so far "
                                f"are kept: rerun to resume once it can be written")

    def append(self, record: dict[str, Any]) -> None:
        """Append ``record`` (strict JSON already, see :func:`strict_json`) as one write of a
        whole line; a failed write is cut back and raises OutputWriteError."""
        line = (json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n").encode()
        try:
            if self._fd is None:
                self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
            size = os.fstat(self._fd).st_size
        except OSError as exc:
            raise self._failed(exc, "open") from None
        view = memoryview(line)
        try:
            while view:
                view = view[os.write(self._fd, view):]
        except OSError as exc:
            try:
                os.ftruncate(self._fd, size)    # no half line
            except OSError:
                pass
            raise self._failed(exc, "write to") from None
        self._superseded += record["hash"] in self._lost
        if record["status"] != LOST:
            self.finished.add(record["hash"])
        if time.monotonic() - self._synced > self.FSYNC_SECONDS:
            os.fsync(self._fd)
            self._synced = time.monotonic()

    def pending(self, problems: Iterable[Any]) -> list[Any]:
        """The problems not finished in this file."""
        return [p for p in problems if p.hash not in self.finished]

    def close(self) -> None:
        """Flush, drop superseded lines (atomic rewrite) and release the lock."""
        try:
            if self._fd is not None:
                fd, self._fd = self._fd, None
                try:
                    os.fsync(fd)
                except OSError as exc:
                    raise self._failed(exc, "write to") from None
                finally:
                    os.close(fd)
            if self._superseded:
                self._compact()
        finally:
            self._lock.release()

    def _compact(self) -> None:
        lines = [raw for _, _, raw in _latest_lines(self.path, self.option)]
        mode = self._real.stat().st_mode & 0o7777

        def write(handle: Any) -> None:
            os.fchmod(handle.fileno(), mode)        # the file keeps its permissions
            handle.writelines(lines)
        try:
            atomic_write(self._real, write, overwrite=True)
        except OSError as exc:
            raise OutputWriteError(f"{self.option}: cannot rewrite {str(self.path)!r} without "
                                   f"the lines of retried problems ({exc}); the file is "
                                   f"unchanged and readers take each problem's latest line") \
                from None
        log.info("%s: %d superseded line(s) removed", self.path, self._superseded)

    def __enter__(self) -> "ResultsFile":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
