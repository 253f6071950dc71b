"""GTSAM optimizers report each iteration (log, progress bar) and still give exactly what
GTSAM's own ``optimize()`` gives."""
from __future__ import annotations

import logging

import gtsam
import numpy as np
import pytest

from clamp import PlannerConfig, build, learn_prior
from clamp.config import OPTIMIZERS
from clamp.optim import optimizers
from clamp.optim.stopping import StoppingRule
from clamp.graph.keys import values_to_states
from robots import load_robot
from scenes import Box, Scene, make_demonstrations
from skillplan.progress import set_progress

GTSAM_OPTIMIZERS = [name for name in OPTIMIZERS if name.startswith("gtsam")]


@pytest.fixture(scope="module")
def problem_and_config():
    robot = load_robot("jaco")
    prior = learn_prior(make_demonstrations("box_closing", seed=0, num_demos=6, num_points=30))
    scene = Scene([Box([0.36, -0.30, 0.47], [0.05, 0.05, 0.05])])
    problem = build(prior, robot, scene, prior.mean[0, :3])
    return problem, PlannerConfig().with_(stopping=StoppingRule(absolute_tol=1e-6),
                                          max_iterations=40), prior, scene


@pytest.mark.parametrize("name", GTSAM_OPTIMIZERS)
def test_reported_run_equals_gtsam_optimize(problem_and_config, name, caplog):
    problem, config = problem_and_config[:2]
    config = config.with_(optimizer=name)
    plain = optimizers._gtsam_optimizer(problem, config)         # no hook: GTSAM alone
    initial = plain.error()
    reference = plain.optimize()
    with caplog.at_level(logging.DEBUG, logger="clamp.optim.optimizers"):
        out = optimizers.optimize(problem, config)
    np.testing.assert_array_equal(out.theta, values_to_states(reference, problem.keys))
    assert out.iterations == plain.iterations() >= (1 if name == "gtsam_gauss_newton" else 2)
    assert (out.initial_error, out.final_error) == (initial, plain.error())
    steps = [r.args for r in caplog.records if "iteration" in r.getMessage()]
    assert [s[1] for s in steps] == list(range(1, out.iterations + 1))   # one line per iteration
    assert steps[0][2] == initial and steps[-1][3] == out.final_error
    for (_, _, _, after), (_, _, before, _) in zip(steps, steps[1:]):
        assert before == after                                       # consecutive iterations
    if name != "gtsam_gauss_newton":                                 # damped: never worse
        assert all(s[3] <= s[2] for s in steps)


@pytest.mark.parametrize("name", GTSAM_OPTIMIZERS)
def test_one_linearization_hands_every_factor_the_same_values(problem_and_config, name):
    """GTSAM's linearizations inside optimize() give every Python factor the optimizer's own
    Values (one object per linearization), not a copy per factor call; the errors of its trial
    points are still evaluated on copies."""
    problem, config, prior, scene = problem_and_config
    seen: list[tuple[int, object]] = []

    def recorder(which):
        def error(this, values, H):
            if H is not None:
                seen.append((which, values))     # kept alive: copies cannot share an id
                H[0] = np.zeros((1, problem.dim))
            return np.zeros(1)
        return error

    extra = [gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(1), [key], recorder(k))
             for k, key in enumerate((problem.keys[3], problem.keys[-4]))]
    foreign = build(prior, problem.robot, scene, prior.mean[0, :3], extra_factors=extra)
    seen.clear()                      # build solved the free plan (the posture tie) with them
    out = optimizers.optimize(foreign, config.with_(optimizer=name, max_iterations=4))
    pairs = [(seen[i], seen[i + 1]) for i in range(0, len(seen), 2)]
    assert len(pairs) == out.iterations >= 1 and all(a[0] == 0 and b[0] == 1 for a, b in pairs)
    assert all(a[1] is b[1] for a, b in pairs)
    seen.clear()


def test_progress_bar_drawn_only_when_enabled(problem_and_config, capsys, monkeypatch):
    problem, config = problem_and_config[:2]
    monkeypatch.setattr(optimizers, "PROGRESS_DELAY", 0.0)
    previous = set_progress(True)
    try:
        out = optimizers.optimize(problem, config.with_(optimizer="gtsam"))
        drawn = capsys.readouterr().err
        set_progress(False)
        optimizers.optimize(problem, config.with_(optimizer="gtsam"))
        hidden = capsys.readouterr().err
    finally:
        set_progress(previous)
    assert "optimizing (gtsam)" in drawn and f"/{config.optimizer.max_iterations}" in drawn
    assert out.iterations >= 2
    assert hidden == ""
