"""Incremental (conjugate Bayesian) learning of the workspace prior (clamp.prior.conjugate)."""
from __future__ import annotations

import types

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import WorkspacePrior, errors, learn_prior
from clamp.prior.conjugate import K0_SCALE, N0_SCALE
from scenes import Demonstrations, make_demonstrations


@pytest.fixture(scope="module")
def demos() -> Demonstrations:
    return make_demonstrations("box_closing", num_demos=8, num_points=120, seed=3)


def subset(demos: Demonstrations, idx) -> types.SimpleNamespace:
    return types.SimpleNamespace(positions=demos.positions[idx], velocities=demos.velocities[idx],
                                 time=demos.time)


def regularised_regression(demos: Demonstrations) -> tuple[np.ndarray, np.ndarray]:
    """Per step and axis, the posterior mean M = Y X' (X X' + K0)^-1 and the scale
    S = Y Y' - M (X X' + K0) M' + S0 solved directly from all demonstrations (normal equations
    in extended precision), independently of the library's QR recursion."""
    s = demos.states.astype(np.longdouble)
    T = s.shape[1]
    Ms, Ss = np.zeros((T - 1, 3, 2, 3)), np.zeros((T - 1, 3, 2, 2))
    for i in range(T - 1):
        for d in range(3):
            X = np.stack([s[:, i, d], s[:, i, d + 3], np.ones(len(s), dtype=np.longdouble)])
            Y = np.stack([s[:, i + 1, d], s[:, i + 1, d + 3]])
            Sxx = X @ X.T + K0_SCALE * np.eye(3)
            M = np.linalg.solve(Sxx.astype(float), (Y @ X.T).T.astype(float)).T
            Ms[i, d] = M
            Ss[i, d] = (Y @ Y.T - (Y @ X.T) @ M.T).astype(float) + N0_SCALE * np.eye(2)
    return Ms, Ss


def test_incremental_equals_batch_in_any_order(demos):
    batch = learn_prior(demos, method="incremental")
    M_ref, _ = regularised_regression(demos)
    scale = np.abs(M_ref).max(axis=(-1, -2), keepdims=True)
    assert np.max(np.abs(batch.posterior.M - M_ref) / scale) < 1e-6
    for seed in range(3):
        order = np.random.default_rng(seed).permutation(demos.M)
        prior = learn_prior(subset(demos, order[:2]), method="incremental")
        for k in range(2, demos.M):
            prior = prior.update(subset(demos, order[k:k + 1]))
        assert np.max(np.abs(prior.posterior.M - batch.posterior.M)) < 1e-6
        assert np.max(np.abs(prior.posterior.M - M_ref) / scale) < 1e-6
        np.testing.assert_allclose(prior.posterior.S, batch.posterior.S, rtol=1e-6,
                                   atol=1e-12 * np.abs(batch.posterior.S).max())
        np.testing.assert_allclose(prior.posterior.N, batch.posterior.N)
        np.testing.assert_allclose(prior.mean0, batch.mean0, atol=1e-12)
        np.testing.assert_allclose(prior.cov0, batch.cov0, atol=1e-15)
        np.testing.assert_allclose(prior.Q, batch.Q, rtol=1e-6, atol=1e-18)


def test_noise_is_the_inverse_wishart_mode(demos):
    jitter = 1e-12
    prior = learn_prior(demos, method="incremental", jitter=jitter)
    post = prior.posterior
    np.testing.assert_allclose(post.N, demos.M + N0_SCALE)
    for d in range(3):
        block = prior.Q[:, [d, d + 3]][:, :, [d, d + 3]]
        expected = post.S[:, d] / (post.N + 3)[:, None, None] + jitter * np.eye(2)
        np.testing.assert_allclose(block, expected,
                                   rtol=1e-12, atol=1e-30)
    # the mean reproduces the batch learner's (same data, ridge ~ K0) to round-off
    ridge = learn_prior(demos, ridge=K0_SCALE)
    assert np.max(np.abs(prior.mean[:, :3] - ridge.mean[:, :3])) < 1e-6


def test_posterior_survives_save_and_load(demos, tmp_path):
    prior = learn_prior(subset(demos, slice(0, 4)), method="incremental")
    path = prior.save(tmp_path / "skill")
    loaded = WorkspacePrior.load(path)
    with np.load(path) as data:
        assert {"posterior_M", "posterior_K", "posterior_S", "posterior_N"} <= set(data.files)
    more = subset(demos, slice(4, 8))
    np.testing.assert_array_equal(loaded.update(more).Phi, prior.update(more).Phi)
    np.testing.assert_allclose(loaded.update(more).Phi, learn_prior(demos, method="incremental").Phi,
                               atol=1e-6)


def test_update_needs_an_incremental_prior_and_matching_steps(demos):
    with raises_naming(errors.InvalidParameterError, "prior"):
        learn_prior(demos).update(demos)
    prior = learn_prior(demos, method="incremental")
    with raises_naming(errors.ShapeError, "demos.positions"):
        prior.update(demos.resample(60))
    with raises_naming(errors.InvalidParameterError, "method"):
        learn_prior(demos, method="online")
