"""Shared pytest fixtures.

Real recorded data sets live in ../shared/datasets (next to the checkout) or wherever
$SKILLPLAN_DATASETS points; tests that need them skip with a reason naming the file when absent.
"""
from __future__ import annotations

import os
from pathlib import Path

import matplotlib
import pytest

from scenes import shared_dataset as _find_dataset
from scenes.datasets import DATASET_SUFFIXES, DATASETS_ENV

matplotlib.use("Agg")

_SHARED = Path(__file__).resolve().parents[2] / "shared" / "datasets"


def dataset_path(name: str) -> Path | None:
    """Path of <name>.mat (or .npz) in $SKILLPLAN_DATASETS, else in ../shared/datasets beside
    this checkout (also when the package is installed elsewhere), or None when it is absent."""
    if not os.environ.get(DATASETS_ENV) and _SHARED.is_dir():
        paths = [_SHARED / f"{name}{suffix}" for suffix in DATASET_SUFFIXES]
        return next((p for p in paths if p.is_file()), None)
    return _find_dataset(name)


@pytest.fixture
def shared_dataset():
    """Return a function name -> Path that skips the test when the data set is absent."""

    def get(name: str) -> Path:
        path = dataset_path(name)
        if path is None:
            pytest.skip(f"{name}.mat / .npz not found in ../shared/datasets (set SKILLPLAN_DATASETS)")
        return path

    return get


@pytest.fixture(scope="session", autouse=True)
def sphere_cache_folder(tmp_path_factory):
    """The run's own sphere cache (robots.sphere_cache), shared by its tests and by the command
    lines they start (the variable is inherited): the user's cache is never read or written."""
    from robots.sphere_cache import CACHE_ENV
    folder = tmp_path_factory.mktemp("cache")
    previous = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(folder)
    yield folder
    if previous is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = previous


@pytest.fixture(scope="session")
def jaco():
    """The built-in Kinova Jaco2 (robots.load_robot), loaded once for the whole run."""
    from robots import load_robot
    return load_robot("jaco")


@pytest.fixture(scope="session")
def sawyer():
    """The built-in Rethink Sawyer (robots.load_robot), loaded once for the whole run."""
    from robots import load_robot
    return load_robot("sawyer")


@pytest.fixture(scope="session")
def prior():
    """The synthetic box_closing prior (6 demonstrations, seed 0, T = 250), learned once for the
    whole run; a module that needs another defines its own ``prior``. Read it, never change it."""
    from clamp import learn_prior
    from scenes import make_demonstrations
    return learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
