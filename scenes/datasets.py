"""Location of the real recorded data sets (never shipped with the package)."""
from __future__ import annotations

import os
from pathlib import Path

from .errors import ScenesTypeError, InvalidArgumentError
from skillplan.validation import as_instance

#: Environment variable naming a folder that holds <name>.mat / <name>.npz data sets.
DATASETS_ENV = "SKILLPLAN_DATASETS"

#: the suffixes of the recorded data sets (MATLAB files of the reference tools, numpy archives)
DATASET_SUFFIXES = (".mat", ".npz")


def shared_dataset(name: str) -> Path | None:
    """Path of <name>.mat or <name>.npz (e.g. "box_closing", "wiping_rim"), or None when it is
    not on this machine.

    Looked up in $SKILLPLAN_DATASETS if set, else in ``shared/datasets`` beside the
    repository checkout (``Path(__file__).resolve().parents[2] / "shared" / "datasets"``).
    """
    as_instance(name, "name", str, "a data set name such as 'box_closing' (str)", ScenesTypeError)
    if not name or Path(name).name != name or name in (".", ".."):
        raise InvalidArgumentError(f"name: expected a plain data set name such as 'box_closing' "
                                   f"(no folders), got {name!r}")
    stem = name[:-4] if name.endswith(DATASET_SUFFIXES) else name
    roots = []
    if os.environ.get(DATASETS_ENV):
        roots.append(Path(os.environ[DATASETS_ENV]))
    roots.append(Path(__file__).resolve().parents[2] / "shared" / "datasets")
    for root in roots:
        for suffix in DATASET_SUFFIXES:
            path = root / f"{stem}{suffix}"
            if path.is_file():
                return path
    return None
