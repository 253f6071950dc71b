"""Collision-sphere model of an arm: spheres fixed in named link frames, and its JSON file format.

A sphere file is a JSON object::

    {"format": "skillplan-spheres", "version": 1, "inflation": 0.01,
     "spheres": [{"link": "j2s6s200_link_2", "centre": [x, y, z], "radius": r}, ...]}

Centres are in metres in the link's (Pinocchio frame's) coordinates; radii in metres. The optional
"inflation" [m] (default 0) says how much the spheres must grow to cover the geometry they were
fitted to: a planner's collision margin should be at least that.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from skillplan.command_line import atomic_write_text

from .errors import RobotTypeError, InvalidArrayError, SphereFileError

FILE_FORMAT = "skillplan-spheres"
FILE_VERSION = 1


@dataclass(frozen=True)
class SphereModel:
    """S spheres, each rigidly attached to a link frame.

    link_names: (S,) frame names; centres: (S, 3) in each sphere's link frame [m];
    radii: (S,) [m], positive. The world centre of sphere s is oMf[link_names[s]] * centres[s].
    inflation [m] >= 0: growth of every radius needed to cover the geometry the spheres stand for.
    """

    link_names: tuple[str, ...]
    centres: np.ndarray
    radii: np.ndarray
    inflation: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.link_names, str) or not all(isinstance(n, str) and n for n in self.link_names):
            raise InvalidArrayError("link_names: expected a sequence of non-empty strings, one per sphere")
        names = tuple(self.link_names)
        try:
            centres = np.array(self.centres, dtype=float)
            radii = np.array(self.radii, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InvalidArrayError(f"centres/radii: expected numeric arrays ({exc})") from exc
        if centres.size == 0 and not names:
            centres = centres.reshape(0, 3)
        if centres.shape != (len(names), 3):
            raise InvalidArrayError(
                f"centres: expected shape ({len(names)}, 3) for {len(names)} link names, got {centres.shape}")
        if radii.shape != (len(names),):
            raise InvalidArrayError(f"radii: expected shape ({len(names)},), got {radii.shape}")
        if not (np.all(np.isfinite(centres)) and np.all(np.isfinite(radii))):
            raise InvalidArrayError("centres/radii: contain NaN or inf values")
        if np.any(radii <= 0.0):
            raise InvalidArrayError(f"radii: expected positive values in metres, got minimum {radii.min():.6g}")
        if not _is_finite_number(self.inflation) or self.inflation < 0:
            raise InvalidArrayError(f"inflation: expected a finite number >= 0 in metres, got {self.inflation!r}")
        object.__setattr__(self, "inflation", float(self.inflation))
        centres.setflags(write=False)
        radii.setflags(write=False)
        object.__setattr__(self, "link_names", names)
        object.__setattr__(self, "centres", centres)
        object.__setattr__(self, "radii", radii)

    @property
    def count(self) -> int:
        """Number of spheres S."""
        return len(self.link_names)

    def __len__(self) -> int:
        return self.count

    def links(self) -> tuple[str, ...]:
        """Distinct link names in order of first appearance."""
        return tuple(dict.fromkeys(self.link_names))

    def for_link(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Centres (k, 3) and radii (k,) of the spheres on `link` (k may be 0)."""
        if not isinstance(link, str):
            raise RobotTypeError(f"link: expected a link name (str), got {type(link).__name__}")
        mask = np.array([name == link for name in self.link_names], dtype=bool)
        return self.centres[mask], self.radii[mask]

    def to_dict(self) -> dict:
        """Plain JSON-ready dictionary (the sphere file's content)."""
        return {
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "inflation": self.inflation,
            "spheres": [
                {"link": name, "centre": [float(x) for x in centre], "radius": float(radius)}
                for name, centre, radius in zip(self.link_names, self.centres, self.radii)
            ],
        }

    @classmethod
    def from_dict(cls, data: object, source: str = "sphere data") -> SphereModel:
        """Build from the dictionary layout of a sphere file; raise SphereFileError naming `source`."""
        if not isinstance(data, dict):
            raise SphereFileError(f"{source}: expected a JSON object with a 'spheres' list, got {type(data).__name__}")
        if data.get("format", FILE_FORMAT) != FILE_FORMAT:
            raise SphereFileError(f"{source}: 'format' must be {FILE_FORMAT!r}, got {data.get('format')!r}")
        if data.get("version", FILE_VERSION) != FILE_VERSION:
            raise SphereFileError(f"{source}: unsupported 'version' {data.get('version')!r}; expected {FILE_VERSION}")
        inflation = data.get("inflation", 0.0)
        if not _is_finite_number(inflation) or inflation < 0:
            raise SphereFileError(f"{source}: 'inflation' must be a finite number >= 0 in metres, got {inflation!r}")
        entries = data.get("spheres")
        if not isinstance(entries, list):
            raise SphereFileError(f"{source}: expected key 'spheres' holding a list, got {type(entries).__name__}")
        names, centres, radii = [], [], []
        for index, entry in enumerate(entries):
            where = f"{source}: spheres[{index}]"
            if not isinstance(entry, dict) or not {"link", "centre", "radius"} <= set(entry):
                raise SphereFileError(
                    f"{where}: expected an object with keys 'link', 'centre', 'radius', got {entry!r}")
            link, centre, radius = entry["link"], entry["centre"], entry["radius"]
            if not isinstance(link, str) or not link:
                raise SphereFileError(f"{where}.link: expected a non-empty string, got {link!r}")
            if (not isinstance(centre, list) or len(centre) != 3
                    or not all(_is_finite_number(x) for x in centre)):
                raise SphereFileError(f"{where}.centre: expected 3 finite numbers [x, y, z] in metres, got {centre!r}")
            if not _is_finite_number(radius) or radius <= 0:
                raise SphereFileError(f"{where}.radius: expected a positive finite number in metres, got {radius!r}")
            names.append(link)
            centres.append([float(x) for x in centre])
            radii.append(float(radius))
        return cls(tuple(names), np.array(centres, dtype=float).reshape(-1, 3), np.array(radii, dtype=float),
                   float(inflation))


def _is_finite_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def load_sphere_file(path: str | Path) -> SphereModel:
    """Read a sphere file (JSON, layout in the module docstring); SphereFileError if missing or malformed."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SphereFileError(f"path: cannot read sphere file {str(path)!r} ({exc.strerror or exc})") from exc
    except UnicodeDecodeError as exc:
        raise SphereFileError(f"path: {str(path)!r} is not UTF-8 text, expected a JSON sphere "
                              f"file ({exc})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SphereFileError(f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from exc
    return SphereModel.from_dict(data, source=str(path))


def save_sphere_file(model: SphereModel, path: str | Path) -> None:
    """Write `model` as a JSON sphere file, one sphere per line (parent folders must exist)."""
    if not isinstance(model, SphereModel):
        raise SphereFileError(f"model: expected a SphereModel, got {type(model).__name__}")
    data = model.to_dict()
    spheres = ",\n  ".join(json.dumps(entry) for entry in data.pop("spheres"))
    header = json.dumps(data)[:-1]
    atomic_write_text(path, f'{header}, "spheres": [\n  {spheres}\n]}}\n', overwrite=True)
