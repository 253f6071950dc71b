"""The command lines: ``clamp demo`` / ``clamp plan`` (:mod:`.main`), ``clamp view``
(:mod:`.viewer`), ``clamp show`` (:mod:`.show`) and ``clamp batch`` (:mod:`.batch`)."""
from clamp.cli.main import main

__all__ = ["main"]
