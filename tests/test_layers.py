"""The layers of the project hold: import-linter's contracts in pyproject.toml (packages
skillplan < scenes < robots < clamp < tlgc; clamp's stages; the prior knows no planner; nothing
below imports the command lines, the batch runner or the pictures), no import circle among the
project's modules, and ``import robots`` loads no part of ``scenes``."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import grimp            # comes with import-linter (the test extra)
import importlinter     # noqa: F401 - the test extra's; run below as lint-imports

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("skillplan", "scenes", "robots", "clamp", "tlgc")


def test_import_linter_contracts_hold():
    run = subprocess.run([sys.executable, "-c", "from importlinter.cli import lint_imports_command;"
                          " lint_imports_command()"], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "0 broken" in run.stdout


def _cycles(graph) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    adjacency = {m: graph.find_modules_directly_imported_by(m) for m in graph.modules}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in adjacency[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for module in sorted(graph.modules):
        if module not in index:
            visit(module)
    return found


def test_no_import_circle():
    graph = grimp.build_graph(*PACKAGES)
    assert _cycles(graph) == []


def test_robots_loads_no_scenes():
    run = subprocess.run([sys.executable, "-c", "import robots, sys; print('scenes' in sys.modules)"],
                         cwd=ROOT, capture_output=True, text=True)
    assert run.stdout.strip() == "False", run.stdout + run.stderr
