"""The GTSAM face loads GTSAM when it is used: the keys are GTSAM's own, computed without it, and
the factor families and the fast solver's problem load no GTSAM (issue 38: import time)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gtsam
import pytest

from clamp.graph.keys import STATE_SYMBOL, state_key, symbol_key

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("character, index", [(STATE_SYMBOL, 0), (STATE_SYMBOL, 249), ("q", 2**40), ("a", 2**56 - 1)])
def test_keys_are_gtsams_symbols(character, index):
    assert symbol_key(character, index) == gtsam.symbol(character, index)
    assert gtsam.Symbol(state_key(index % 1000)).index() == index % 1000


def test_the_families_and_the_fast_problem_load_no_gtsam_and_the_graph_does(tmp_path):
    code = ("import sys\nimport numpy as np\nfrom robots import load_robot\n"
            "from clamp.factors import JointTargetFamily\n"
            "from clamp.graph.problem import PlanningProblem\n"
            "robot = load_robot('jaco')\nT = 5\n"
            "theta = np.zeros((T, 2 * robot.n)); theta[:, :robot.n] = robot.neutral_configuration()\n"
            "target = JointTargetFamily([0, T - 1], theta[[0, T - 1], :robot.n] + 0.1, [1e-3, 2e-3])\n"
            "problem = PlanningProblem(robot, T, [target], initial=theta)\n"
            "assert problem.error(theta) > 0\nproblem.normal_equations(theta)\n"
            "before = 'gtsam' in sys.modules\n"
            "graph = problem.graph(); values = problem.values()\n"
            "print(before, 'gtsam' in sys.modules, graph.size(), values.size())")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "True", "2", "5"]
