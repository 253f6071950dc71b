"""Location of the real recorded data sets (never shipped with the package)."""
from __future__ import annotations

import os
from pathlib import Path

from .errors import ScenesTypeError, InvalidArgumentError
from skillplan.validation import as_instance

#: Environment variable naming a folder that holds <name>.mat data sets.
DATASETS_ENV = "SKILLPLAN_DATASETS"


def shared_dataset(name: str) -> Path | None:
    """Path of <name>.mat (e.g. "box_closing"), or None when it is not on this machine.

    Looked up in $SKILLPLAN_DATASETS if set, else in ``shared/datasets`` beside the
    repository checkout (``Path(__file__).resolve().parents[2] / "shared" / "datasets"``).
    """
    as_instance(name, "name", str, "a data set name such as 'box_closing' (str)", ScenesTypeError)
    if not name or Path(name).name != name or name in (".", ".."):
        raise InvalidArgumentError(f"name: expected a plain data set name such as 'box_closing' "
                                   f"(no folders), got {name!r}")
    stem = name[:-4] if name.endswith(".mat") else name
    roots = []
    if os.environ.get(DATASETS_ENV):
        roots.append(Path(os.environ[DATASETS_ENV]))
    roots.append(Path(__file__).resolve().parents[2] / "shared" / "datasets")
    for root in roots:
        path = root / f"{stem}.mat"
        if path.is_file():
            return path
    return None
