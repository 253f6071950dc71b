"""The README's Python blocks run: every ```python block of README.md, in order, in one
namespace (later blocks use what earlier ones made), in a scratch folder (they write files)."""
from __future__ import annotations

import re
import textwrap
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def python_blocks(path: Path = ROOT / "README.md") -> list[str]:
    """The ```python blocks of a Markdown file (the README by default), in order, each dedented
    (a block inside a list item is indented with it)."""
    text = path.read_text(encoding="utf-8")
    return [textwrap.dedent(b) for b in re.findall(r"^ *```python\n(.*?)^ *```", text, re.S | re.M)]


def test_readme_python_blocks_run_in_order_twice_in_one_folder(tmp_path, monkeypatch, caplog):
    """The tour, then the tour again in the same folder (a user running it twice): the second
    run overwrites what the first wrote on purpose and plans no problem again, saying so."""
    blocks = python_blocks()
    assert len(blocks) >= 5
    monkeypatch.chdir(tmp_path)
    for run in (1, 2):
        namespace: dict = {"__name__": "readme"}
        caplog.clear()
        for number, block in enumerate(blocks, 1):
            exec(compile(block, f"README.md python block {number} (run {run})", "exec"), namespace)  # noqa: S102
        # what the blocks say they make
        trajectory = namespace["trajectory"]
        assert np.abs(trajectory.velocities[[0, -1]]).max() == 0.0 and trajectory.verdict["retiming"]["within_limits"]
        assert (tmp_path / "plan_ros2.json").is_file() and (tmp_path / "problems.jsonl").is_file()
        assert namespace["result"].success and namespace["moved"].success
        problems = namespace["problems"]
        assert [r["status"] for r in namespace["records"]] == ["done"] * len(problems)
        assert len(namespace["new"]) == (len(problems) if run == 1 else 0)
    assert f"0 new problems; {len(problems)} already in results.jsonl" in caplog.text
