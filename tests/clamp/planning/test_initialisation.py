"""Initial trajectories: shifted prior mean (blend, goal), IK continuity, straight lines."""
from __future__ import annotations


import numpy as np
import pytest

from clamp.planning.initialisation import (blend_weights, joint_velocities, prior_mean_initialisation,
                                  shifted_mean_path, straight_line_initialisation)


def mean_path(T=80):
    s = np.linspace(0, 1, T)[:, None]
    return np.hstack([0.25 + 0.2 * s, -0.4 + 0.3 * s, 0.25 - 0.15 * s ** 2])


def test_blend_weights_ramp_from_one_to_zero():
    w = blend_weights(11)
    assert w[0] == pytest.approx(1.0) and w[-1] == pytest.approx(0.0, abs=1e-15)
    assert np.all(np.diff(w) <= 0)
    np.testing.assert_allclose(w + w[::-1], 1.0)  # symmetric cosine ramp


def test_shifted_path_starts_at_start_and_keeps_the_end():
    path = mean_path()
    start = path[0] + [0.05, -0.02, 0.03]
    shifted = shifted_mean_path(path, start)
    np.testing.assert_allclose(shifted[0], start)
    np.testing.assert_allclose(shifted[-1], path[-1])
    rigid = shifted_mean_path(path, start, blend=False)
    np.testing.assert_allclose(rigid - path, np.broadcast_to(start - path[0], path.shape))
    goal = path[-1] + [0.0, 0.03, 0.0]
    np.testing.assert_allclose(shifted_mean_path(path, start, goal)[-1], goal)
    np.testing.assert_allclose(shifted_mean_path(path, start, goal)[0], start)


def test_joint_velocities_are_exact_for_quadratics():
    t = np.arange(20) * 0.1
    q = np.stack([t ** 2, 3 * t], axis=1)
    qdot = joint_velocities(q, 0.1)
    np.testing.assert_allclose(qdot[1:-1, 0], 2 * t[1:-1])
    np.testing.assert_allclose(qdot[:, 1], 3.0)


def test_prior_mean_initialisation_tracks_the_shifted_path(jaco):
    path = mean_path()
    q_start = jaco.ik(path[0] + [0.02, 0.0, 0.02]).q
    init = prior_mean_initialisation(jaco, path, 0.1, q_start)
    np.testing.assert_allclose(init.q[0], q_start)
    np.testing.assert_allclose(jaco.fk(init.q), init.path, atol=1e-3)
    assert np.max(np.abs(np.diff(init.q, axis=0))) < 0.2  # continuity, no branch flips
    assert init.theta.shape == (80, 2 * jaco.n)


def test_straight_line_initialisation(jaco):
    q0, q1 = np.zeros(jaco.n), np.linspace(0.1, 0.6, jaco.n)
    init = straight_line_initialisation(jaco, q0, q1, 11, 0.2)
    np.testing.assert_allclose(init.q[[0, -1]], [q0, q1])
    np.testing.assert_allclose(init.qdot, np.broadcast_to((q1 - q0) / 2.0, init.qdot.shape))
