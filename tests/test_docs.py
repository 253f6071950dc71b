"""The docs pages' Python blocks run: every ```python block of each docs/*.md page, in order, in
one namespace per page (later blocks use what earlier ones made), in a scratch folder (they
write files). A block that only shows a signature is fenced ```text and is not collected. The
README's blocks are run by tests/test_readme.py."""
from __future__ import annotations

from pathlib import Path

import pytest

from test_readme import python_blocks

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted(p.name for p in (ROOT / "docs").glob("*.md"))


def test_the_pages_are_there():
    assert {"concepts.md", "adding_a_family.md", "benchmarks.md", "decisions.md",
            "interfaces.md", "guide.md", "file_formats.md"} <= set(PAGES)


@pytest.mark.parametrize("page", PAGES)
def test_docs_python_blocks_run_in_order(page, tmp_path, monkeypatch):
    blocks = python_blocks(ROOT / "docs" / page)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"docs_{page[:-3]}"}
    for number, block in enumerate(blocks, 1):
        exec(compile(block, f"docs/{page} python block {number}", "exec"), namespace)  # noqa: S102


def test_docs_links_point_to_pages_that_exist():
    """Every docs/NAME.md the README and the pages name exists."""
    import re
    for source in [ROOT / "README.md", *(ROOT / "docs").glob("*.md")]:
        for name in re.findall(r"docs/([\w-]+\.md)", source.read_text(encoding="utf-8")):
            assert (ROOT / "docs" / name).is_file(), f"{source.name} names docs/{name}"


def _slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces -> -."""
    import re
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_docs_anchors_exist():
    """Every docs/NAME.md#anchor named by the README, the pages and the code (comments pointing
    to docs/decisions.md) is a heading of that page."""
    import re
    pages = [ROOT / "README.md", *(ROOT / "docs").glob("*.md")]
    anchors = {p.name: {_slug(h) for h in re.findall(r"^#+ (.*)$", p.read_text(encoding="utf-8"), re.M)}
               for p in pages}
    sources = pages + [p for package in ("skillplan", "scenes", "robots", "clamp", "tlgc")
                       for p in (ROOT / package).rglob("*.py")]
    missing = [(source.name, page, anchor) for source in sources
               for page, anchor in re.findall(r"docs/([\w-]+\.md)#([\w\-]+)",
                                              source.read_text(encoding="utf-8"))
               if anchor not in anchors.get(page, set())]
    assert not missing


def test_every_setting_is_listed_with_its_default_in_concepts():
    """docs/concepts.md#settings lists exactly PlannerConfig's fields (at most 25, issue 36), each
    with its default."""
    from dataclasses import fields

    from clamp.config import GROUPS, PlannerConfig
    text = (ROOT / "docs" / "concepts.md").read_text().split("## Settings", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:4] for line in text.splitlines() if line.startswith("| ")][1:]
    listed = {(group.strip(), name.strip(" `")): default.strip() for group, name, default in rows}
    config = PlannerConfig()
    actual = {(group, f.name): getattr(getattr(config, group), f.name)
              for group in GROUPS for f in fields(GROUPS[group])}
    assert set(listed) == set(actual)
    assert len(actual) <= 25
    for key, value in actual.items():
        written = listed[key].strip('"')
        assert written == str(value) or float(written) == pytest.approx(value, rel=1e-3), key
