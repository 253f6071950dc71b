"""Collision spheres fitted for a URDF, kept on disk and reused by every process.

A fit (:func:`robots.spheres.fit_spheres`) takes seconds; its result depends only on what it
reads and how it fits. The cache key is the SHA-256 of all of that: the URDF file's bytes, the
bytes of every mesh file its geometry reads, which geometry (``collision`` or ``visual``), the
arm's planning chain (the joints of the reduced model), the fit's settings, the project's
version and the source of the fitting code (:mod:`robots.spheres`,
:mod:`robots.collision_geometry`), and the Pinocchio and coal versions that read the meshes.
A changed URDF or mesh is a new key, so a stale entry is never read (it is left behind).

Folder: ``$SKILLPLAN_CACHE_DIR`` when set, else the user's cache folder (``platformdirs``:
``~/.cache/skillplan`` on Linux, ``$XDG_CACHE_HOME`` honoured), then ``spheres/``. One sphere
file (:mod:`robots.sphere_model` format) per key, written atomically: a process that reads
meets the old file or the whole new one. The cache only saves time: an entry that cannot be
read is fitted again, and a folder that cannot be written costs a warning, never the plan.
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
from collections.abc import Sequence
from pathlib import Path

import coal
import pinocchio as pin

from skillplan.version import package_version

from .errors import SphereFileError
from .sphere_model import SphereModel, load_sphere_file, save_sphere_file

log = logging.getLogger(__name__)

#: environment variable naming the cache folder (tests and CI point it at a temporary folder)
CACHE_ENV = "SKILLPLAN_CACHE_DIR"
#: bumped when the key's recipe changes
KEY_FORMAT = 1
#: the modules whose source is part of the key (a changed fit is a new key, whatever the version)
FITTING_CODE = ("spheres.py", "collision_geometry.py")


def cache_folder() -> Path:
    """The folder of the project's caches: ``$SKILLPLAN_CACHE_DIR``, else the user's cache
    folder for ``skillplan`` (may not exist yet)."""
    given = os.environ.get(CACHE_ENV)
    if given:
        return Path(given).expanduser()
    import platformdirs
    return Path(platformdirs.user_cache_dir("skillplan", appauthor=False))


def _file_digest(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def fit_key(urdf_path: str | Path, model: pin.Model, geometry: pin.GeometryModel, kind: str,
            settings: dict) -> str:
    """SHA-256 (hex) naming one fit: the URDF's and its meshes' content, the geometry ``kind``,
    the chain's joints, the fit's ``settings`` (JSON-able) and the code and library versions
    (see the module docstring)."""
    meshes = sorted({obj.meshPath for obj in geometry.geometryObjects
                     if obj.meshPath and Path(obj.meshPath).is_file()})
    recipe = {
        "key_format": KEY_FORMAT, "skillplan": package_version(),
        "pinocchio": pin.__version__, "coal": getattr(coal, "__version__", "unknown"),
        "code": [_file_digest(Path(__file__).with_name(module)) for module in FITTING_CODE],
        "urdf": _file_digest(urdf_path), "meshes": [_file_digest(mesh) for mesh in meshes],
        "kind": kind, "joints": list(model.names), "settings": settings,
    }
    return hashlib.sha256(json.dumps(recipe, sort_keys=True, default=repr).encode("utf-8")).hexdigest()


def cached_fit(urdf_path: str | Path, model: pin.Model, geometry: pin.GeometryModel, kind: str,
               links: Sequence[str] | None, max_spheres: int, inflation: float, seed: int) -> SphereModel:
    """:func:`robots.spheres.fit_spheres` ``(model, geometry, links, max_spheres, inflation, seed)``,
    or the spheres the same fit stored in the cache before; a new fit is stored. ``urdf_path``:
    the URDF ``model`` and ``geometry`` (of ``kind``: "collision" or "visual") were read from."""
    settings = {"links": None if links is None else list(links), "max_spheres": max_spheres,
                "inflation": inflation, "seed": seed}
    path = cache_folder() / "spheres" / f"{fit_key(urdf_path, model, geometry, kind, settings)}.json"
    if path.is_file():
        try:
            found = load_sphere_file(path)
        except SphereFileError as exc:     # damaged (a disk error, a hand edit): fit again
            log.warning("sphere cache: %s; fitting again", exc)
        else:
            log.info("collision spheres of %s read from the cache (%s)", Path(urdf_path).name, path)
            return found
    from . import spheres              # deferred: SciPy's optimizer loads only for a new fit
    fitted = spheres.fit_spheres(model, geometry, links, max_spheres, inflation, seed)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        save_sphere_file(fitted, path)
    except OSError as exc:             # read-only, full disk: OutputPathError, OutputWriteError
        log.warning("sphere cache: cannot store the fitted spheres in %s (%s); they will be fitted "
                    "again next time (set %s to a writable folder)", path.parent, exc, CACHE_ENV)
    else:
        log.info("collision spheres of %s fitted and cached (%s)", Path(urdf_path).name, path)
    return fitted
