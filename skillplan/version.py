"""The installed version of the project (the ``skillplan`` distribution), read without loading
anything else: ``clamp --version`` answers with it before NumPy loads."""
from __future__ import annotations

import importlib.metadata


def package_version() -> str:
    """Installed version of the ``skillplan`` distribution ("unknown" when not installed)."""
    try:
        return importlib.metadata.version("skillplan")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"
