"""Workspace correction: per-state projection onto target workspace states, and the LM trial
point correction built on it (Jaco, random seeded states)."""
from __future__ import annotations


import gtsam
import numpy as np

from clamp.factors.evaluation import workspace_states
from clamp.keys import state_key
from clamp.workspace_correction import (WorkspaceCorrection, project_to_workspace,
                                        states_to_values, values_to_states)


def random_states(robot, rng, T=7):
    q = rng.uniform(-1.0, 1.0, size=(T, robot.n))
    return np.concatenate([q, rng.normal(scale=0.3, size=(T, robot.n))], axis=1)


def test_projection_reaches_reachable_targets(jaco):
    rng = np.random.default_rng(0)
    theta = random_states(jaco, rng)
    target = workspace_states(jaco, theta + 0.02 * rng.normal(size=theta.shape), False).x
    projected = project_to_workspace(jaco, theta, target, iterations=4)
    reached = workspace_states(jaco, projected, False).x
    np.testing.assert_allclose(reached, target, atol=1e-8)
    # minimum-norm updates: the projection stays near the start
    assert np.max(np.abs(projected - theta)) < 0.2


def test_correction_restores_the_linearised_workspace_prediction(jaco):
    rng = np.random.default_rng(1)
    theta = random_states(jaco, rng)
    keys = [state_key(i) for i in range(len(theta))]
    step = 0.1 * rng.normal(size=theta.shape)
    values = states_to_values(theta, keys)
    delta = gtsam.VectorValues()
    for key, row in zip(keys, step):
        delta.insert(key, row)
    candidate = values.retract(delta)
    base = workspace_states(jaco, theta, True)
    predicted = base.x + np.einsum("tij,tj->ti", base.jacobian, step)

    unchanged = WorkspaceCorrection(jaco, keys, iterations=0)(values, delta, candidate)
    np.testing.assert_array_equal(values_to_states(unchanged, keys), theta + step)
    corrected = WorkspaceCorrection(jaco, keys, iterations=3)(values, delta, candidate)
    before = np.abs(workspace_states(jaco, theta + step, False).x - predicted).max()
    after = np.abs(workspace_states(jaco, values_to_states(corrected, keys), False).x
                   - predicted).max()
    assert before > 1e-4  # the step is large enough for the curvature to show
    assert after < 1e-3 * before


def test_values_to_states_fast_path_matches_per_key_reads():
    import gtsam
    from clamp.keys import state_key
    rng = np.random.default_rng(0)
    theta = rng.normal(size=(7, 4))
    keys = [state_key(i) for i in range(7)]
    values = states_to_values(theta, keys)
    np.testing.assert_array_equal(values_to_states(values, keys), theta)       # one C++ call
    np.testing.assert_array_equal(values_to_states(values, keys[2:5]), theta[2:5])  # subset
    values.insert(gtsam.symbol("y", 0), np.zeros(4))                           # foreign key
    np.testing.assert_array_equal(values_to_states(values, keys), theta)
    delta = gtsam.VectorValues()
    for key, row in zip(keys, theta):
        delta.insert(key, row)
    np.testing.assert_array_equal(values_to_states(delta, keys), theta)
    np.testing.assert_array_equal(values_to_states(delta, keys[::-1]), theta[::-1])
