"""Regenerate the planner regression fixtures (plans of the pre-refactor planner, issue 8).

Run from the repository root: ``python tests/regression/make_fixtures.py``. Writes
``tests/regression/plans.npz``: for every case the planned q, qdot (T, n), the graph error and the verdict.
The cases are defined in :mod:`tests.regression.cases` so the test and this script agree.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.regression.cases import CASES, run_case  # noqa: E402


def main() -> int:
    out = {}
    for name in CASES:
        result = run_case(name)
        if result is None:
            print(f"{name}: skipped (data set not found)")
            continue
        out[f"{name}/q"] = result.q
        out[f"{name}/qdot"] = result.qdot
        out[f"{name}/final_error"] = np.array(result.final_error)
        out[f"{name}/success"] = np.array(result.success)
        print(f"{name}: success {result.success}, error {result.final_error:.6g}, "
              f"iterations {result.iterations}")
    np.savez_compressed(Path(__file__).with_name("plans.npz"), **out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
