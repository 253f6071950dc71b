"""Shared pytest fixtures.

Real recorded data sets live in ../shared/datasets (next to the checkout) or wherever
$SKILLPLAN_DATASETS points; tests that need them skip with a reason naming the file when absent.
"""
from __future__ import annotations

import os
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

_REPO = Path(__file__).resolve().parents[1]


def dataset_path(name: str) -> Path | None:
    """Path of ../shared/datasets/<name>.mat, or None when it is not on this machine."""
    root = Path(os.environ.get("SKILLPLAN_DATASETS", _REPO.parent / "shared" / "datasets"))
    path = root / f"{name}.mat"
    return path if path.is_file() else None


@pytest.fixture
def shared_dataset():
    """Return a function name -> Path that skips the test when the data set is absent."""

    def get(name: str) -> Path:
        path = dataset_path(name)
        if path is None:
            pytest.skip(f"{name}.mat not found in ../shared/datasets (set SKILLPLAN_DATASETS)")
        return path

    return get
