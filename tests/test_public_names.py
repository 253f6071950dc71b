"""The public names the docs promise still import: every dotted name of the project's packages
in docs/interfaces.md (``clamp.plan``, ``clamp.prior.conditioning.condition_prior``,
``robots.retime``, ...) resolves to a module or an attribute, and every name a package's
``__all__`` lists is there."""
from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("skillplan", "scenes", "robots", "clamp", "tlgc")
DOTTED = re.compile(r"(?<![\w.])((?:%s)(?:\.[A-Za-z_]\w*)+)" % "|".join(PACKAGES))


def documented_names() -> list[str]:
    text = (ROOT / "docs" / "interfaces.md").read_text(encoding="utf-8")
    return sorted({m.group(1).rstrip(".") for m in DOTTED.finditer(text)})


def resolve(dotted: str) -> object:
    """The module or attribute ``dotted`` names (the longest importable module prefix, then
    attributes); raises when it does not exist."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attribute in parts[cut:]:
            obj = getattr(obj, attribute)
        return obj
    raise ModuleNotFoundError(dotted)


def test_interfaces_names_are_listed():
    assert len(documented_names()) > 50


@pytest.mark.parametrize("dotted", documented_names())
def test_documented_name_imports(dotted):
    pytest.importorskip("viser") if dotted.startswith("clamp.viz.viewer") else None
    resolve(dotted)


@pytest.mark.parametrize("package", PACKAGES)
def test_every_name_in_all_is_there(package):
    module = importlib.import_module(package)
    for name in getattr(module, "__all__", ()):
        assert hasattr(module, name), f"{package}.__all__ lists {name}, which is not there"
