"""The command lines: ``clamp demo`` / ``clamp plan`` (:mod:`.commands`), ``clamp view``
(:mod:`.viewer`), ``clamp show`` (:mod:`.show`) and ``clamp batch`` (:mod:`.batch`)."""
from __future__ import annotations

import sys
from collections.abc import Sequence

from skillplan.version import package_version

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``clamp`` (the console script and ``python -m clamp``); returns the exit
    code. ``clamp --version`` alone is answered here, as the parser answers it, before the
    parser and NumPy load (half of its time); everything else runs
    :func:`clamp.cli.commands.main`."""
    arguments = sys.argv[1:] if argv is None else list(argv)
    if arguments == ["--version"]:
        print(f"clamp {package_version()}")
        return 0
    from clamp.cli.commands import main as run
    return run(arguments)
