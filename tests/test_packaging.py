"""Every third-party module the packages import is declared in pyproject.toml (issue 21: coal
was imported directly but only installed as Pinocchio's dependency)."""
from __future__ import annotations

import ast
import importlib.metadata
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("skillplan", "robots", "scenes", "clamp", "tlgc")


def imported_modules() -> set[str]:
    """Top-level names of the modules imported (at any depth) by the project's packages."""
    names: set[str] = set()
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    names.update(alias.name.split(".")[0] for alias in node.names)
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names.add(node.module.split(".")[0])
    return {name for name in names if name not in sys.stdlib_module_names and name not in PACKAGES}


def providers() -> dict[str, set[str]]:
    """{top-level module: normalised names of the installed distributions holding it}, also for
    cmeel's distributions, which install under cmeel.prefix/ where packages_distributions()
    does not look."""
    found: dict[str, set[str]] = {}
    for dist in importlib.metadata.distributions():
        name = re.sub(r"[-_.]+", "-", dist.metadata["Name"]).lower()
        for file in dist.files or ():
            parts = Path(str(file)).parts
            if "site-packages" in parts:  # cmeel.prefix/lib/pythonX.Y/site-packages/<module>/...
                parts = parts[len(parts) - parts[::-1].index("site-packages"):]
            if parts and parts[-1].endswith(".py"):
                top = parts[0][:-3] if len(parts) == 1 else parts[0]
                found.setdefault(top, set()).add(name)
    return found


def declared() -> set[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    requirements = list(project["dependencies"])
    for extra in project.get("optional-dependencies", {}).values():
        requirements.extend(extra)
    names = set()
    for requirement in requirements:  # "dask[distributed]>=2023.1" declares dask and its extra
        name, extras = re.match(r"([A-Za-z0-9_.-]+)(?:\[([^]]*)\])?", requirement).groups()
        names.update([name, *(extras or "").split(",")])
    return {re.sub(r"[-_.]+", "-", name.strip()).lower() for name in names if name.strip()}


def test_every_imported_package_is_declared():
    names = declared()
    modules = imported_modules()
    assert {"coal", "pinocchio", "gtsam", "toppra"} <= modules   # the scan sees the real imports
    index = providers()
    # an installed module: one of the distributions holding it is declared; a module of an
    # extra that is not installed here (e.g. viser without '.[viewer]'): declared by its name
    missing = {module: sorted(index[module]) if module in index else "not installed"
               for module in modules
               if not (index[module] & names if module in index
                       else re.sub(r"[-_.]+", "-", module).lower() in names)}
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"
