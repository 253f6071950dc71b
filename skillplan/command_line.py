"""What every command line of the project shares, in one place.

- :class:`CommandLineParser`: an ``argparse`` parser whose usage errors are one line on stderr
  (exit 2) and which carries ``--version``, ``-v/--verbose``, ``-q/--quiet`` and ``--debug``
  (sub-command parsers get them too, so ``clamp demo -v`` and ``clamp -v demo`` both work).
- :func:`run`: parse, set up logging and progress bars, run ``args.run(args)`` and turn errors
  into one line on stderr: exit 2 for bad input (the project's :class:`InvalidArgumentError`,
  unreadable files), 1 for an unexpected failure; ``--debug`` shows the traceback instead.
  Exit codes: :data:`EXIT_OK` 0, :data:`EXIT_FAILED` 1 (e.g. a plan computed but failed),
  :data:`EXIT_USAGE` 2.
- :func:`output_directory`, :func:`output_file`, :func:`writable_file`: outputs go to a new or
  empty folder, or replace files only with ``--force``; a folder or file that cannot be
  written (read-only, a device, a FIFO, a symbolic link to nothing) is refused before any work.
  An output that fails part-way (:class:`~scenes.errors.OutputWriteError`: disk full) exits 1.
- :func:`atomic_write` / :func:`atomic_write_text`: a temporary file in the target folder,
  flushed, then renamed into place, so an interrupted run leaves the old file or the new one.

Kept in ``scenes`` (the package the others build on) so ``robots``' command lines can use it
without importing ``clamp`` or ``tlgc``.
"""
from __future__ import annotations

import argparse
import contextlib
import logging
import os
import secrets
import stat
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import IO, Any, NoReturn

from .errors import ArgumentTypeError, InvalidArgumentError, OutputPathError, OutputWriteError
from skillplan.progress import set_progress
from skillplan.validation import as_instance, as_path
from skillplan.version import package_version

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
#: loggers of the project's packages (the command lines set their level)
PACKAGE_LOGGERS = ("robots", "scenes", "clamp", "tlgc")

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- atomic writes
def atomic_write(path: str | os.PathLike[str], write: Callable[[IO[bytes]], Any], overwrite: bool = False,
                 exists_error: Callable[[str], Exception] = OutputPathError,
                 folder_error: Callable[[str], Exception] = OutputPathError) -> Path:
    """Write a file atomically: ``write(handle)`` fills a binary temporary file
    ``.<name>.<random>.tmp`` in the target folder, which is flushed to disk and moved into place
    (``os.replace`` when overwriting, else ``os.link``, which fails if the target appeared
    meanwhile; filesystems without hard links fall back to a check and ``os.replace``). The
    temporary file is removed whatever happens. Returns the path.

    Raises ``exists_error(message)`` when the target exists and not ``overwrite``,
    ``folder_error(message)`` when its folder does not exist, OutputWriteError naming ``path``
    when writing fails (read-only folder, disk full; the old file, if any, is untouched).
    """
    path = as_path(path, "path", ArgumentTypeError)
    if not callable(write):
        raise ArgumentTypeError(f"write: expected a function write(handle), got "
                                f"{type(write).__name__}")
    message = f"path: {str(path)!r} already exists; pass overwrite=True (--force) to replace it"
    if not overwrite and path.exists():
        raise exists_error(message)
    folder = path.parent
    if not folder.is_dir():
        raise folder_error(f"path: folder {str(folder)!r} does not exist")
    tmp = folder / f".{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
            with os.fdopen(fd, "wb") as handle:
                write(handle)
                handle.flush()
                os.fsync(handle.fileno())
        except OSError as exc:  # read-only folder, disk full: name the user's file, not tmp
            raise OutputWriteError(f"{str(path)!r}: cannot write ({exc.strerror or exc}); "
                                   f"{'the old file is untouched' if path.exists() else 'nothing written'}") \
                from None
        if overwrite:
            os.replace(tmp, path)
        else:
            try:
                os.link(tmp, path)
            except FileExistsError:
                raise exists_error(message) from None
            except OSError:  # no hard links on this filesystem
                if path.exists():
                    raise exists_error(message) from None
                os.replace(tmp, path)
    finally:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
    return path


def atomic_write_text(path: str | os.PathLike[str], text: str, overwrite: bool = False,
                      exists_error: Callable[[str], Exception] = OutputPathError,
                      folder_error: Callable[[str], Exception] = OutputPathError) -> Path:
    """:func:`atomic_write` of UTF-8 text (written as is: no newline translation)."""
    data = as_instance(text, "text", str, "text (str)", ArgumentTypeError).encode("utf-8")
    return atomic_write(path, lambda handle: handle.write(data), overwrite, exists_error, folder_error)


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: int = 120, overwrite: bool = True) -> Path:
    """Save a matplotlib figure atomically (format from the suffix, tight bounding box so no
    label is clipped)."""
    fmt = Path(path).suffix.lstrip(".") or "png"
    return atomic_write(path, lambda handle: fig.savefig(handle, format=fmt, dpi=dpi, bbox_inches="tight"),
                        overwrite)


@contextlib.contextmanager
def native_stderr_logged(logger: logging.Logger = log) -> Iterator[None]:
    """Capture what C/C++ code writes straight to file descriptor 2 (e.g. urdfdom's parse
    errors) inside the block and log it at debug level instead, so an error stays one line."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no real stderr (embedded interpreters): nothing to capture
        yield
        return
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            text = sink.read().decode("utf-8", "replace").strip()
            if text:
                logger.debug("native library output: %s", " | ".join(text.splitlines()))


# --------------------------------------------------------------------------- output folders
_SPECIAL_FILES = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                  (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def writable_folder(folder: Path, option: str,
                    error: Callable[[str], Exception] = OutputPathError) -> None:
    """Raises ``error`` naming ``option`` unless a file can be created in ``folder`` (checked by
    creating and removing an empty hidden file: permissions, read-only mounts, ACLs)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".write-check-", dir=folder)
    except OSError as exc:
        raise error(f"{option}: cannot write in folder {str(folder)!r} "
                    f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


def _no_dangling_link(path: Path, option: str, error: Callable[[str], Exception]) -> None:
    if path.is_symlink() and not path.exists():
        raise error(f"{option}: {str(path)!r} is a symbolic link to {os.readlink(path)!r}, "
                    f"which does not exist; expected a new path or an existing one")


def output_directory(path: str | os.PathLike[str], force: bool = False, option: str = "--out") -> Path:
    """The output folder, created if needed: it must be new or empty, or ``force`` (files in it
    are then replaced), and writable. Raises OutputPathError naming ``option`` otherwise; all
    is checked before any work starts."""
    folder = as_path(path, option, ArgumentTypeError)
    _no_dangling_link(folder, option, OutputPathError)
    if folder.exists() and not folder.is_dir():
        raise OutputPathError(f"{option}: expected a folder, got the existing file {str(folder)!r}")
    if folder.is_dir() and not force and any(folder.iterdir()):
        raise OutputPathError(f"{option}: folder {str(folder)!r} is not empty; choose a new folder "
                              f"or pass --force to replace the files in it")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{option}: cannot create folder {str(folder)!r}: {exc.strerror}") from None
    writable_folder(folder, option, OutputPathError)
    return folder


def writable_file(path: str | os.PathLike[str], option: str = "--out",
                  error: Callable[[str], Exception] = OutputPathError) -> Path:
    """An output file path that can be created, replaced or appended to: new or an existing
    regular file, in an existing folder where files can be created. Raises ``error`` naming
    ``option`` and the path for a folder, a device (``/dev/full``), a FIFO or socket, a
    symbolic link to nothing, a missing or read-only folder, a read-only file."""
    target = as_path(path, option, ArgumentTypeError)
    shown = repr(str(target))
    _no_dangling_link(target, option, error)
    if target.is_dir():
        raise error(f"{option}: expected a file, got the folder {shown}")
    if target.exists():
        mode = target.stat().st_mode
        for test, kind in _SPECIAL_FILES:
            if test(mode):
                raise error(f"{option}: {shown} is {kind}, not a regular file; expected a new "
                            f"path or a regular file")
    if not target.parent.is_dir():
        raise error(f"{option}: folder {str(target.parent)!r} does not exist")
    writable_folder(target.parent, option, error)
    if target.exists() and not os.access(target, os.W_OK):
        raise error(f"{option}: {shown} is read-only")
    return target


def output_file(path: str | os.PathLike[str], force: bool = False, option: str = "--out") -> Path:
    """An output file path (see :func:`writable_file`); an existing file only with ``force``."""
    target = writable_file(path, option)
    if target.exists() and not force:
        raise OutputPathError(f"{option}: {str(target)!r} already exists; pass --force to replace it")
    return target


# --------------------------------------------------------------------------- parser and run
class CommandLineParser(argparse.ArgumentParser):
    """ArgumentParser with one-line usage errors (exit 2) and the common options
    ``--version``, ``-v/--verbose`` (repeat for debug messages), ``-q/--quiet`` and ``--debug``.

    Sub-command parsers (``add_subparsers().add_parser``) are CommandLineParsers too.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.add_argument("--version", action="version", version=f"%(prog)s {package_version()}")
        common = self.add_argument_group("output and diagnostics")
        # SUPPRESS: a sub-command's parser leaves what the main parser read untouched
        common.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                            help="more messages (-vv: debug messages)")
        common.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                            help="only errors: no progress bars, no summary")
        common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                            help="show the traceback of an error")

    def error(self, message: str) -> NoReturn:
        """One line on stderr, exit 2 (argparse prints the whole usage first)."""
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def integer_at_least(minimum: int) -> Callable[[str], int]:
    """argparse ``type``: an integer >= ``minimum`` (argparse names the option in the error)."""
    as_instance(minimum, "minimum", int, "an integer", ArgumentTypeError)
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {value}")
        return value
    return parse


def number(text: str) -> float:
    """argparse ``type``: a finite float."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


@contextlib.contextmanager
def cli_logging(verbose: int = 0, quiet: bool = False) -> Iterator[None]:
    """Inside the block, messages of the project's loggers go to stderr, one line each:
    warnings by default, info with ``verbose`` 1, debug with 2, errors only when ``quiet``;
    Python warnings are logged. The loggers' previous set-up is restored afterwards (a
    command run in-process leaves the caller's logging alone)."""
    level = logging.ERROR if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    loggers = [logging.getLogger(name) for name in (*PACKAGE_LOGGERS, "py.warnings")]
    saved = [(lg.handlers[:], lg.level, lg.propagate) for lg in loggers]
    for logger in loggers:
        logger.handlers[:] = [handler]
        logger.setLevel(level)
        logger.propagate = False
    logging.captureWarnings(True)
    try:
        yield
    finally:
        logging.captureWarnings(False)
        for logger, (handlers, old_level, propagate) in zip(loggers, saved):
            logger.handlers[:] = handlers
            logger.setLevel(old_level)
            logger.propagate = propagate


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def run(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` and call ``args.run(args)``; returns the exit code.

    Bad input (the project's errors, files that cannot be read, decoded or written) gives one line
    ``<prog>: error: ...`` on stderr and exit 2; any other exception one line and exit 1;
    ``--debug`` re-raises with the traceback. Ctrl-C exits 130.
    """
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # --help, --version, usage errors (already printed)
        return stop.code if isinstance(stop.code, int) else EXIT_USAGE
    debug, silent = getattr(args, "debug", False), getattr(args, "quiet", False)
    previous_progress = set_progress(False if silent else None)
    prog = " ".join(filter(None, [parser.prog, getattr(args, "command", None)]))
    try:
        with cli_logging(getattr(args, "verbose", 0) or 0, silent):
            return int(args.run(args))
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except OutputWriteError as exc:  # an output failed part-way: not bad input
        if debug:
            raise
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_FAILED
    except (InvalidArgumentError, OSError, UnicodeDecodeError) as exc:  # a user file not in UTF-8
        if debug:
            raise
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - a bug: say so in one line, the traceback on --debug
        if debug:
            raise
        print(f"{prog}: internal error: {type(exc).__name__}: {_one_line(exc)} "
              f"(run with --debug for the traceback)", file=sys.stderr)
        return EXIT_FAILED
    finally:
        set_progress(previous_progress)


def quiet(args: argparse.Namespace) -> bool:
    """True when ``-q`` was given (the command prints no summary)."""
    return bool(getattr(args, "quiet", False))
