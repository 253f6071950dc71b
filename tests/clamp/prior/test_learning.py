"""Tests of clamp.prior.learning: per-step ridge regression of the workspace / joint-space prior."""
from __future__ import annotations

import types
import warnings

import numpy as np
import pytest
import scipy.io

from bad_input import raises_naming
from clamp import errors
from clamp.prior.conditioning import condition_prior
from clamp.prior.learning import fit_transitions, learn_joint_prior, learn_prior, state_groups
from clamp.prior.linear_gaussian import LinearGaussianPrior, WorkspacePrior


def synthetic_states(num_demos: int = 8, num_points: int = 60, axes: int = 3, dt: float = 0.1,
                     seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Demonstrations with genuinely random dynamics: positions, velocities (M, T, A), time (T,).

    A smooth common motion plus per-demonstration amplitude, start offset and a velocity
    random walk, integrated so velocities are the positions' derivatives.
    """
    rng = np.random.default_rng(seed)
    time = dt * np.arange(num_points)
    phase = np.linspace(0.0, np.pi, num_points)
    base_vel = np.stack([np.cos(phase + k) for k in range(axes)], axis=1) * 0.2
    amplitude = 1.0 + 0.3 * rng.standard_normal((num_demos, 1, axes))
    walk = np.cumsum(0.02 * rng.standard_normal((num_demos, num_points, axes)), axis=1)
    velocities = amplitude * base_vel + walk
    start = 0.05 * rng.standard_normal((num_demos, 1, axes)) + np.arange(axes) * 0.1
    positions = start + dt * np.concatenate(
        [np.zeros((num_demos, 1, axes)), np.cumsum(velocities[:, :-1], axis=1)], axis=1)
    return positions, velocities, time


def box_closing(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    data = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)["dataset"]
    positions = np.stack([d.pos for d in data])
    velocities = np.stack([d.vel for d in data])
    return positions, velocities, np.asarray(data[0].time, dtype=float)


def biased_covariance(states: np.ndarray) -> np.ndarray:
    """Per-step 1/M covariance (T, D, D) of states (M, T, D)."""
    centred = states - states.mean(axis=0)
    return np.einsum("mti,mtj->tij", centred, centred) / states.shape[0]


def block_mask(axes: int) -> np.ndarray:
    mask = np.zeros((2 * axes, 2 * axes), bool)
    for d in range(axes):
        mask[np.ix_([d, d + axes], [d, d + axes])] = True
    return mask


def correlation_error(cov: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> float:
    """max |cov - reference| / sqrt(var_a var_b of reference) over masked entries."""
    sd = np.sqrt(np.einsum("tii->ti", reference))
    return float((np.abs(cov - reference) / (sd[:, :, None] * sd[:, None, :]))[:, mask].max())


@pytest.fixture
def synthetic():
    return synthetic_states()


# ---------------------------------------------------------------------- mean and covariance
@pytest.mark.parametrize("ridge", [1e-12, 1e-6, 1.0])
def test_mean_reproduces_demonstration_mean_synthetic(synthetic, ridge):
    positions, velocities, time = synthetic
    prior = learn_prior(positions=positions, velocities=velocities, time=time, ridge=ridge)
    assert isinstance(prior, WorkspacePrior)
    np.testing.assert_allclose(prior.mean[:, :3], positions.mean(axis=0), rtol=0, atol=1e-6)
    np.testing.assert_allclose(prior.mean[:, 3:], velocities.mean(axis=0), rtol=0, atol=1e-6)


@pytest.mark.parametrize("coupled", [False, True])
def test_mean_reproduces_demonstration_mean_box_closing(shared_dataset, coupled):
    positions, velocities, time = box_closing(shared_dataset("box_closing"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", errors.ClampWarning)
        prior = learn_prior(positions=positions, velocities=velocities, time=time,
                            ridge=1e-12, coupled=coupled)
    assert prior.T == 250 and prior.dt == pytest.approx(0.16)
    np.testing.assert_allclose(prior.mean[:, :3], positions.mean(axis=0), rtol=0, atol=1e-6)
    np.testing.assert_allclose(prior.mean[:, 3:], velocities.mean(axis=0), rtol=0, atol=1e-6)


def test_per_axis_covariance_equals_demonstration_covariance(synthetic, shared_dataset):
    """ridge = 0: Phi cov Phi^T + Q = Cov(x_{i+1}) exactly (eq. 13 with 1/M), per axis block."""
    for positions, velocities, time in (synthetic, box_closing(shared_dataset("box_closing"))):
        prior = learn_prior(positions=positions, velocities=velocities, time=time, ridge=0.0,
                            jitter=1e-24, start_shrinkage=0.0)
        reference = biased_covariance(np.concatenate([positions, velocities], axis=2))
        assert correlation_error(prior.cov, reference, block_mask(3)) < 1e-6
        # Per-axis learning makes the axes independent: no cross-axis covariance.
        assert np.all(prior.cov[:, ~block_mask(3)] == 0.0)


def test_coupled_covariance_equals_full_demonstration_covariance():
    positions, velocities, time = synthetic_states(num_demos=14, seed=3)
    prior = learn_prior(positions=positions, velocities=velocities, time=time, coupled=True,
                        ridge=0.0, jitter=1e-24, start_shrinkage=0.0)
    reference = biased_covariance(np.concatenate([positions, velocities], axis=2))
    assert correlation_error(prior.cov, reference, np.ones((6, 6), bool)) < 1e-6


def test_samples_reproduce_demonstration_covariance(shared_dataset):
    """4000 prior samples: covariance whitened by the demos' covariance ~ I (Wishart error)."""
    positions, velocities, time = box_closing(shared_dataset("box_closing"))
    prior = learn_prior(positions=positions, velocities=velocities, time=time, ridge=0.0,
                        jitter=1e-24, start_shrinkage=0.0)
    count = 4000
    samples = prior.sample(count, np.random.default_rng(7))
    reference = biased_covariance(np.concatenate([positions, velocities], axis=2))
    # Whitened sample covariance W = L^-1 S L^-T has sd(W_jj) = sqrt(2/N), sd(W_jk) = sqrt(1/N).
    tolerance = 5.0 * np.sqrt(2.0 / count)
    for step in (0, 40, 125, 200, 249):
        for d in range(3):
            idx = [d, d + 3]
            sample_cov = np.cov(samples[:, step, idx].T, bias=True)
            chol = np.linalg.cholesky(reference[step][np.ix_(idx, idx)])
            white = np.linalg.solve(chol, np.linalg.solve(chol, sample_cov).T)
            assert np.abs(white - np.eye(2)).max() < tolerance, (step, d)
        sd = np.sqrt(np.diag(prior.cov[step]))
        mean_error = samples[:, step].mean(axis=0) - prior.mean[step]
        assert np.all(np.abs(mean_error) < 5.0 * sd / np.sqrt(count))


# ---------------------------------------------------------------------- regression itself
def test_per_axis_regression_matches_least_squares(synthetic):
    """Each axis block of Phi_i, u_i against numpy lstsq of [p_d, v_d]_{i+1} on [1, p_d, v_d]_i."""
    positions, velocities, time = synthetic
    prior = learn_prior(positions=positions, velocities=velocities, time=time, ridge=0.0,
                        jitter=0.0 + 1e-15, start_shrinkage=0.0)
    states = np.concatenate([positions, velocities], axis=2)
    for step in (0, 17, 58):
        for d in range(3):
            idx = [d, d + 3]
            design = np.column_stack([np.ones(len(states)), states[:, step, idx]])
            coef, *_ = np.linalg.lstsq(design, states[:, step + 1, idx], rcond=None)
            np.testing.assert_allclose(prior.Phi[step][np.ix_(idx, idx)], coef[1:].T,
                                       rtol=1e-8, atol=1e-10)
            np.testing.assert_allclose(prior.u[step][idx], coef[0], rtol=1e-8, atol=1e-10)
            residual = states[:, step + 1, idx] - design @ coef
            np.testing.assert_allclose(prior.Q[step][np.ix_(idx, idx)],
                                       residual.T @ residual / len(states) + 1e-15 * np.eye(2),
                                       rtol=1e-7, atol=1e-14)


def test_ridge_matches_normal_equations_with_free_bias(synthetic):
    """Penalised slopes, unpenalised bias: (X^T X + ridge diag(0, 1, 1)) b = X^T y."""
    positions, velocities, time = synthetic
    ridge = 0.05
    prior = learn_prior(positions=positions, velocities=velocities, time=time, ridge=ridge,
                        start_shrinkage=0.0)
    states = np.concatenate([positions, velocities], axis=2)
    step, d = 23, 1
    idx = [d, d + 3]
    design = np.column_stack([np.ones(len(states)), states[:, step, idx]])
    coef = np.linalg.solve(design.T @ design + ridge * np.diag([0.0, 1.0, 1.0]),
                           design.T @ states[:, step + 1, idx])
    np.testing.assert_allclose(prior.Phi[step][np.ix_(idx, idx)], coef[1:].T, rtol=1e-9)
    np.testing.assert_allclose(prior.u[step][idx], coef[0], rtol=1e-9, atol=1e-12)


def test_coupled_regression_matches_least_squares():
    positions, velocities, time = synthetic_states(num_demos=12, seed=5)
    states = np.concatenate([positions, velocities], axis=2)
    Phi, u, Q = fit_transitions(states, state_groups(3, coupled=True), ridge=0.0, jitter=0.0)
    step = 31
    design = np.column_stack([np.ones(len(states)), states[:, step]])
    coef, *_ = np.linalg.lstsq(design, states[:, step + 1], rcond=None)
    np.testing.assert_allclose(Phi[step], coef[1:].T, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(u[step], coef[0], rtol=1e-7, atol=1e-9)


def test_per_axis_structure_is_block_diagonal(synthetic):
    positions, velocities, time = synthetic
    per_axis = learn_prior(positions=positions, velocities=velocities, time=time)
    mask = block_mask(3)
    for name in ("Phi", "Q", "cov"):
        assert np.all(getattr(per_axis, name)[:, ~mask] == 0.0), name
    assert np.all(per_axis.cov0[~mask] == 0.0)
    # The [p, v] ordering: x-axis position couples with x-axis velocity (indices 0 and 3).
    assert np.all(np.abs(per_axis.Phi[:, 0, 3]) > 0)
    coupled = learn_prior(positions=positions, velocities=velocities, time=time, coupled=True)
    assert np.abs(coupled.Phi[:, ~mask]).max() > 1e-3
    region = per_axis.info.pop("skill_region")       # where the demonstrations go (clamp.prior.skill)
    assert np.allclose(region["end_mean"], positions[:, -1].mean(axis=0))
    assert per_axis.info.pop("start_shrinkage")["setting"] == "auto"   # clamp.prior.shrinkage
    assert per_axis.info == {"method": "batch", "coupled": False, "ridge": 1e-6, "jitter": 1e-12,
                             "num_demos": 8, "obstacle_weighting": None}


def test_jitter_makes_covariances_positive_definite():
    positions, velocities, time = synthetic_states(num_demos=3)
    velocities[:, 0] = 0.0                              # degenerate first velocities
    prior = learn_prior(positions=positions, velocities=velocities, time=time, jitter=1e-9)
    assert np.linalg.eigvalsh(prior.Q).min() >= 1e-9 * (1 - 1e-6)
    assert np.linalg.eigvalsh(prior.cov0).min() >= 1e-9 * (1 - 1e-6)


# ---------------------------------------------------------------------- likelihood of demos
def test_demo_more_likely_than_shifted_demo(shared_dataset):
    positions, velocities, time = box_closing(shared_dataset("box_closing"))
    prior = learn_prior(positions=positions, velocities=velocities, time=time)
    states = np.concatenate([positions, velocities], axis=2)
    shifted = states.copy()
    shifted[:, :, :3] += np.array([0.02, -0.01, 0.01])
    assert np.all(prior.log_likelihood(states) > prior.log_likelihood(shifted))
    # A translated demo keeps its shape but not its start: with initial=False only the
    # transitions count (and Phi_i is not a pure shift, so they still penalise it a little).
    assert np.all(prior.log_likelihood(states, initial=False)
                  > prior.log_likelihood(shifted, initial=False))
    assert np.all(prior.mahalanobis(states) < prior.mahalanobis(shifted))


# ---------------------------------------------------------------------- inputs
def test_accepts_demonstrations_objects(synthetic):
    positions, velocities, time = synthetic
    duck = types.SimpleNamespace(positions=positions, velocities=velocities, time=time)
    reference = learn_prior(positions=positions, velocities=velocities, time=time)
    np.testing.assert_array_equal(learn_prior(duck).Phi, reference.Phi)
    scenes = pytest.importorskip("scenes")
    if not hasattr(scenes, "Demonstrations"):
        pytest.skip("scenes.Demonstrations not available yet")
    demos = scenes.Demonstrations(positions, velocities, time)
    prior = learn_prior(demos)
    np.testing.assert_allclose(prior.mean[:, :3], demos.positions.mean(axis=0), atol=1e-6)
    assert prior.dt == pytest.approx(demos.dt)


def test_joint_space_variant():
    q, qdot, time = synthetic_states(num_demos=6, axes=7, seed=11)
    prior = learn_joint_prior(q, qdot, time, ridge=1e-12)
    assert isinstance(prior, LinearGaussianPrior) and not isinstance(prior, WorkspacePrior)
    assert (prior.D, prior.num_axes, prior.kind) == (14, 7, "joint")
    assert prior.state_names[:2] == ("q0", "q1") and prior.state_names[7] == "qdot0"
    np.testing.assert_allclose(prior.mean, np.concatenate([q, qdot], 2).mean(0), atol=1e-6)
    assert np.all(prior.Phi[:, ~block_mask(7)] == 0.0)
    # The same learner as the workspace prior: a 3-joint "arm" equals the 3-axis workspace.
    p, v, t = synthetic_states()
    np.testing.assert_array_equal(learn_joint_prior(p, v, t).Phi,
                                  learn_prior(positions=p, velocities=v, time=t,
                                              start_shrinkage=0.0).Phi)
    samples = prior.sample(3, 0)
    assert samples.shape == (3, prior.T, 14)


def test_error_catalogue(synthetic):
    positions, velocities, time = synthetic
    kw = dict(positions=positions, velocities=velocities, time=time)
    cases = [
        (errors.InsufficientDemonstrationsError, "demonstrations",
         dict(kw, positions=positions[:1], velocities=velocities[:1])),
        (errors.InsufficientDemonstrationsError, "demonstrations",
         dict(kw, positions=positions[:2], velocities=velocities[:2], ridge=0.0)),
        (errors.InsufficientDemonstrationsError, "demonstrations",
         dict(kw, coupled=True, ridge=0.0, positions=positions[:6], velocities=velocities[:6])),
        (errors.NonFiniteError, "positions", dict(kw, positions=np.where(
            np.arange(positions.size).reshape(positions.shape) == 5, np.nan, positions))),
        (errors.NonFiniteError, "velocities", dict(kw, velocities=velocities + np.inf)),
        (errors.ShapeError, "velocities", dict(kw, velocities=velocities[:, :-1])),
        (errors.ShapeError, "positions", dict(kw, positions=positions[..., :2],
                                              velocities=velocities[..., :2])),
        (errors.ShapeError, "time", dict(kw, time=time[:-1])),
        (errors.InvalidParameterError, "time", dict(kw, time=time[::-1].copy())),
        (errors.InvalidParameterError, "ridge", dict(kw, ridge=-1.0)),
        (errors.InvalidParameterError, "jitter", dict(kw, jitter=float("nan"))),
        (errors.InvalidParameterError, "demos", dict(kw, positions=None)),
    ]
    for error, name, kwargs in cases:
        with raises_naming(error, name):
            learn_prior(**kwargs)
        assert issubclass(error, errors.ClampError) and issubclass(error, ValueError)
    with raises_naming(errors.InvalidParameterError, "demos"):
        learn_prior(types.SimpleNamespace(positions=positions, velocities=velocities,
                                          time=time), time=time)
    with raises_naming(errors.ShapeError, "demos"):
        learn_prior(types.SimpleNamespace(positions=positions))
    with raises_naming(errors.ShapeError, "qdot"):
        learn_joint_prior(positions, velocities[..., :2], time)
    with pytest.warns(errors.ClampWarning, match="underdetermined"):
        learn_prior(**dict(kw, coupled=True, positions=positions[:6], velocities=velocities[:6]))


# ------------------------------------------------- demonstrations that agree at some steps
def common_goal_at_rest(K: int = 40, blend: int = 60):
    """Synthetic box_closing whose six demonstrations glide (quintic smoothstep over ``blend``
    steps) into their mean end point and rest there for the last K steps: the demonstrations
    agree exactly (zero spread) at those steps. Returns (Demonstrations, goal (3,))."""
    from scipy.interpolate import CubicSpline

    from scenes import Demonstrations, make_demonstrations
    demos = make_demonstrations("box_closing", num_demos=6, seed=0)
    T = demos.T
    goal = demos.positions[:, -1].mean(axis=0)
    s = np.clip((np.arange(T) - (T - K - blend)) / blend, 0.0, 1.0)
    w = s ** 3 * (10.0 - 15.0 * s + 6.0 * s * s)
    positions = demos.positions + w[None, :, None] * (goal - demos.positions)
    velocities = CubicSpline(demos.time, positions, axis=1)(demos.time, 1)
    positions[:, -K:], velocities[:, -K:] = goal, 0.0
    return Demonstrations(positions, velocities, demos.time), goal


@pytest.mark.parametrize("method", ["batch", "incremental"])
def test_common_goal_at_rest_is_learned_and_planned(jaco, method):
    from clamp import plan
    from clamp.prior.learning import SPREAD_FLOOR
    demos, goal = common_goal_at_rest()
    assert np.all(demos.states[:, -40:].std(axis=0) == 0.0)
    prior = learn_prior(demos, method=method)
    # the agreeing steps are learned with the floor on Q's diagonal, the others as before
    variance = np.einsum("tii->ti", prior.Q)[-39:]
    np.testing.assert_allclose(variance, SPREAD_FLOOR ** 2, rtol=1e-6)
    np.testing.assert_allclose(prior.mean[-1, :3], goal, atol=1e-9)
    start = [0.25, -0.45, 0.30]                    # away from every demonstration's start
    assert np.linalg.norm(demos.positions[:, 0] - start, axis=1).min() > 0.02
    result = plan(prior, jaco, None, start)
    assert result.success, result.reasons
    assert np.linalg.norm(jaco.fk(result.q[-1]) - goal) < 2e-3
    assert np.linalg.norm(jaco.fk(result.q[0]) - start) < 2e-3


def test_common_start_floors_only_the_initial_covariance():
    from clamp.prior.learning import SPREAD_FLOOR
    positions, velocities, time = synthetic_states(num_demos=6)
    positions = positions - positions[:, :1] + positions[0, 0]     # one common start position
    velocities[:, 0] = velocities[0, 0]                             # ... and start velocity
    prior = learn_prior(positions=positions, velocities=velocities, time=time, ridge=0.0,
                        jitter=1e-15)
    np.testing.assert_allclose(np.diag(prior.cov0), SPREAD_FLOOR ** 2,
                               rtol=1e-4)
    np.testing.assert_allclose(prior.mean0, np.concatenate([positions[0, 0], velocities[0, 0]]))
    # the steps where the demonstrations vary keep the least-squares residual covariance
    states = np.concatenate([positions, velocities], axis=2)
    for step in (5, 40):
        for d in range(3):
            idx = [d, d + 3]
            design = np.column_stack([np.ones(len(states)), states[:, step, idx]])
            coef, *_ = np.linalg.lstsq(design, states[:, step + 1, idx], rcond=None)
            residual = states[:, step + 1, idx] - design @ coef
            np.testing.assert_allclose(prior.Q[step][np.ix_(idx, idx)],
                                       residual.T @ residual / len(states) + 1e-15 * np.eye(2),
                                       rtol=1e-7, atol=1e-14)


def test_only_demonstrations_identical_everywhere_are_refused():
    positions, velocities, time = synthetic_states(num_demos=4)
    same = np.broadcast_to(positions[:1], positions.shape)
    same_v = np.broadcast_to(velocities[:1], velocities.shape)
    with raises_naming(errors.DegenerateDemonstrationsError, "demonstrations"):
        learn_prior(positions=same, velocities=same_v, time=time)
    one_step = same.copy()
    one_step[1, 30, 0] += 1e-3                                      # differ at one step only
    assert learn_prior(positions=one_step, velocities=same_v, time=time).T == 60


def test_demonstrations_holding_still_are_learned_holding():
    """Each demonstration holds still at its own end for the last 20 steps (a pour turns the
    hand in place). Those steps are learned as holding (the positions carried exactly, zero
    velocity), and a prior conditioned on a start and a goal 1 cm off the demonstrations' holds
    its mean still through the hold, as every demonstration does; the steps before are learned
    as the plain ridge regression."""
    from clamp.prior.demonstration_states import held_steps
    positions, velocities, time = synthetic_states(num_demos=6, num_points=80)
    positions[:, -20:], velocities[:, -20:] = positions[:, -21:-20], 0.0
    held = held_steps(np.concatenate([positions, velocities], axis=2))
    assert np.array_equal(np.flatnonzero(held), np.arange(60, 79))
    prior = learn_prior(positions=positions, velocities=velocities, time=time)
    hold = np.zeros((6, 6))
    hold[:3, :3] = np.eye(3)
    for step in (60, 70, 78):                  # (the start shrinkage's correction: ~1e-16)
        np.testing.assert_allclose(prior.Phi[step], hold, atol=1e-12)
    plain = learn_prior(positions=positions[:, :60], velocities=velocities[:, :60],
                        time=time[:60], start_shrinkage=0.0)
    np.testing.assert_array_equal(
        learn_prior(positions=positions, velocities=velocities, time=time,
                    start_shrinkage=0.0).Phi[:59], plain.Phi)
    offset = np.array([0.01, -0.01, 0.005])
    moved = condition_prior(prior, [(0, positions[:, 0].mean(axis=0) + offset),
                                    (prior.T - 1, positions[:, -1].mean(axis=0) - offset)])
    through_hold = np.linalg.norm(moved.mean[-20:, :3] - moved.mean[-1, :3], axis=1)
    assert through_hold.max() < 1e-6, through_hold.max()
    started = condition_prior(prior, [(0, positions[:, 0].mean(axis=0) + offset)])
    assert np.linalg.norm(started.mean[-20:, :3] - started.mean[-1, :3], axis=1).max() < 1e-6
