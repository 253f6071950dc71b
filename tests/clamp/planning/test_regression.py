"""The rewritten planner reproduces the plans of the planner it replaced (fixtures made before
the rewrite by tests/regression/make_fixtures.py): each case's end-effector path within 1 mm
and joints within 1 mrad, or a graph error no higher than the old plan's on the same graph
(the old plan's error as pinned, or evaluated on today's graph of the case: the model has
changed since, e.g. the start factor's velocity, issue 28; on today's graph "no higher" up to
the solver's own stopping rule, a relative decrease of its ``relative_tol``: closer than that
the solver cannot tell two plans apart), with the same verdict."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import clamp
from tests.regression.cases import CASES, case_inputs, run_case

FIXTURES = np.load(Path(__file__).resolve().parents[3] / "tests" / "regression" / "plans.npz")


@pytest.mark.parametrize("name", CASES)
def test_plan_matches_the_pre_rewrite_plan(name, request):
    if f"{name}/q" not in FIXTURES:
        pytest.skip(f"no fixture for {name}")
    result = run_case(name)
    if result is None:
        pytest.skip("box_closing.mat not found in ../shared/datasets (set SKILLPLAN_DATASETS)")
    robot = request.getfixturevalue(name.split("_")[0])
    old_q = FIXTURES[f"{name}/q"]
    ee_gap = float(np.max(np.linalg.norm(robot.fk(result.q) - robot.fk(old_q), axis=1)))
    joint_gap = float(np.max(np.abs(result.q - old_q)))
    old_error = float(FIXTURES[f"{name}/final_error"])
    assert result.success == bool(FIXTURES[f"{name}/success"]), result.reasons
    same = ee_gap <= 1e-3 and joint_gap <= 1e-3
    tolerance = 1e-9
    if not same and name != "jaco_boundary":
        inputs = case_inputs(name)
        old_theta = np.hstack([old_q, FIXTURES[f"{name}/qdot"]])
        today = clamp.build(**inputs, initial=old_theta).error(old_theta)
        if today != old_error:
            old_error, tolerance = today, inputs["config"].optimizer.stopping_rule().relative_tol
    assert same or result.final_error <= old_error * (1 + tolerance), (
        f"{name}: end effector {ee_gap * 1e3:.3f} mm, joints {joint_gap * 1e3:.3f} mrad away; "
        f"error {result.final_error:.6g} vs {old_error:.6g}")
