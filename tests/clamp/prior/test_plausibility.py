"""Tests of clamp.prior.plausibility: the conditioned chi-square tail score of a workspace path.

Self-contained checks use small random chains (against a dense Gaussian computation) and the
synthetic box-closing skill; the leave-one-out, departure and planner checks on the recorded
box_closing.mat skip with a reason when ../shared/datasets is absent. Run with ``-s`` to see
the figures (KS p-values, leave-one-out scores, plan scores).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from bad_input import raises_naming
from clamp import errors, learn_prior
from clamp.prior.plausibility import (DEFAULT_FLOOR_STD, PlausibilityResult, conditional_mean,
                                floored_prior, plausibility, plausibility_details,
                                sample_conditioned)
from clamp.prior.linear_gaussian import LinearGaussianPrior
from scenes import Demonstrations, load_demonstrations, make_demonstrations

PLAN_START = np.array([0.2054, -0.4722, 0.2625])
BOX = [0.32, -0.32, 0.13, 0.09, 0.06, 0.28]


# ------------------------------------------------------------------------------ fixtures
def random_system(T: int, D: int, seed: int) -> dict[str, np.ndarray]:
    """Random, well-conditioned prior parameters for T support states of size D."""
    rng = np.random.default_rng(seed)
    Phi = np.eye(D) + 0.3 * rng.standard_normal((T - 1, D, D))
    A = 0.5 * rng.standard_normal((T - 1, D, D))
    B = rng.standard_normal((D, D))
    return dict(time=0.1 * np.arange(T), Phi=Phi, u=rng.standard_normal((T - 1, D)),
                Q=A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(D), mean0=rng.standard_normal(D),
                cov0=B @ B.T + 0.2 * np.eye(D))


def dense_gaussian(p: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The chain as one dense Gaussian (mean (T D,), covariance (T D, T D)), eq. (8)."""
    Phi = p["Phi"]
    T, D = Phi.shape[0] + 1, Phi.shape[1]
    A_inv = np.eye(T * D)
    noise = np.zeros((T * D, T * D))
    noise[:D, :D] = p["cov0"]
    for i in range(T - 1):
        A_inv[(i + 1) * D:(i + 2) * D, i * D:(i + 1) * D] = -Phi[i]
        noise[(i + 1) * D:(i + 2) * D, (i + 1) * D:(i + 2) * D] = p["Q"][i]
    A = np.linalg.inv(A_inv)
    return A @ np.concatenate([p["mean0"], p["u"].ravel()]), A @ noise @ A.T


@pytest.fixture(scope="module")
def synthetic_prior():
    return learn_prior(make_demonstrations("box_closing", seed=0))


@pytest.fixture(scope="module")
def other_skill_prior():
    return learn_prior(make_demonstrations("reach_from_above", seed=1))


@pytest.fixture
def box_closing(shared_dataset):
    return load_demonstrations(shared_dataset("box_closing"))


def dense_conditional(prior, floors, constraints):
    """Dense mean, covariance of the floored prior given exact positions {index: target}."""
    fp = floored_prior(prior, *floors)
    mu, K = dense_gaussian(dict(Phi=fp.Phi, u=fp.u, Q=fp.Q, mean0=fp.mean0, cov0=fp.cov0))
    D, A = prior.D, prior.num_axes
    rows = [i * D + a for i in sorted(constraints) for a in range(A)]
    c = np.concatenate([constraints[i] for i in sorted(constraints)])
    H = np.zeros((len(rows), mu.size))
    H[np.arange(len(rows)), rows] = 1.0
    gain = K @ H.T @ np.linalg.inv(H @ K @ H.T)
    return mu + gain @ (c - H @ mu), K - gain @ H @ K


def bumped_mean(prior, amplitude, axis=2):
    """The prior mean with a smooth sin^2 bump of ``amplitude`` m on ``axis`` over the middle
    40 % of the motion, velocities moved consistently (the bump's time derivative)."""
    s = np.linspace(0.0, 1.0, prior.T)
    w = np.where(np.abs(s - 0.5) < 0.2, np.sin(np.pi * (s - 0.3) / 0.4) ** 2, 0.0)
    x = prior.mean.copy()
    x[:, axis] += amplitude * w
    x[:, 3 + axis] += amplitude * np.gradient(w, prior.time)
    return x


# ------------------------------------------------------------------------------ exactness
@pytest.mark.parametrize("floors", [(0.0, 0.0), (0.3, 0.2)])
def test_matches_the_dense_conditional_gaussian(floors):
    prior = LinearGaussianPrior(**random_system(T=7, D=4, seed=2))
    rng = np.random.default_rng(0)
    start, via, goal = rng.standard_normal((3, 2))
    cases = [({0: start}, dict(start=start)),
             ({0: start, 6: goal}, dict(start=start, goal=goal)),
             ({0: start, 3: via, 6: goal}, dict(start=start, goal=goal, via=[(3, via)])),
             ({0: start, 3: via}, dict(start=start, via=[(3, via)]))]
    for constraints, kwargs in cases:
        mean, cov = dense_conditional(prior, floors, constraints)
        x = mean.reshape(prior.T, prior.D) + rng.standard_normal((prior.T, prior.D))
        for i, target in constraints.items():
            x[i, :2] = target
        r = x.ravel() - mean
        d2 = r @ np.linalg.pinv(cov, rcond=1e-9, hermitian=True) @ r
        res = plausibility_details(prior, x, floor_std=floors[0],
                                   velocity_floor_std=floors[1], **kwargs)
        assert isinstance(res, PlausibilityResult)
        assert res.d2 == pytest.approx(d2, rel=1e-8)
        eig = np.linalg.eigvalsh(cov)
        assert res.dof == int(np.sum(eig > 1e-9 * eig.max())) == prior.D * prior.T - 2 * len(
            constraints)
        assert res.score == pytest.approx(stats.chi2.sf(d2, res.dof), rel=1e-6)
        assert res.z == pytest.approx((d2 - res.dof) / np.sqrt(2 * res.dof))
        assert res.constrained == tuple(sorted(constraints))
        assert res.target_error == 0.0
        cmean = conditional_mean(prior, floor_std=floors[0], velocity_floor_std=floors[1],
                                 **kwargs)
        np.testing.assert_allclose(cmean.ravel(), mean, rtol=1e-9, atol=1e-9)
        assert plausibility(prior, cmean, floor_std=floors[0], velocity_floor_std=floors[1],
                            **kwargs) == pytest.approx(1.0)


def test_conditioned_samples_have_the_dense_moments():
    prior = LinearGaussianPrior(**random_system(T=6, D=4, seed=5))
    start, goal = np.array([0.5, -1.0]), np.array([2.0, 0.0])
    mean, cov = dense_conditional(prior, (0.1, 0.1), {0: start, 5: goal})
    x = sample_conditioned(prior, 40000, 3, start, goal, floor_std=0.1, velocity_floor_std=0.1)
    flat = x.reshape(len(x), -1)
    scale = np.sqrt(np.diag(cov).max())
    assert np.abs(flat.mean(axis=0) - mean).max() < 5 * scale / np.sqrt(len(x))
    assert np.abs(np.cov(flat.T) - cov).max() < 5 * scale**2 * np.sqrt(2 / len(x))
    np.testing.assert_allclose(x[:, 0, :2], np.broadcast_to(start, (len(x), 2)))
    np.testing.assert_allclose(x[:, -1, :2], np.broadcast_to(goal, (len(x), 2)))


def test_vectorised_equals_one_path_at_a_time(synthetic_prior):
    x = floored_prior(synthetic_prior).sample(5, 1)
    goals = x[:, -1, :3] + 0.002
    batch = plausibility_details(synthetic_prior, x, goal=goals, via=[(80, x[:, 80, :3])])
    assert batch.score.shape == batch.d2.shape == batch.target_error.shape == (5,)
    for k in range(5):
        one = plausibility_details(synthetic_prior, x[k], goal=goals[k],
                                   via=[(80, x[k, 80, :3])])
        assert isinstance(one.score, float)
        assert one.d2 == pytest.approx(batch.d2[k], rel=1e-10)
        assert one.target_error == pytest.approx(0.002 * np.sqrt(3))
    # a start given once applies to every path; the default is each path's own start
    own = plausibility(synthetic_prior, x)
    shared = plausibility(synthetic_prior, x, start=x[0, 0, :3])
    assert own[0] == shared[0] and np.all(shared[1:] < own[1:])


# ------------------------------------------------------------------------------ calibration
def _calibration(prior, seed, label):
    x = floored_prior(prior).sample(500, seed)
    T = prior.T
    pvalues = {
        "own start": plausibility(prior, x),
        "own start + goal": plausibility(prior, x, goal=x[:, -1, :3]),
        "own start + goal + 2 vias": plausibility(
            prior, x, goal=x[:, -1, :3], via=[(T // 3, x[:, T // 3, :3]),
                                              (2 * T // 3, x[:, 2 * T // 3, :3])]),
    }
    goal = prior.mean[-1, :3] + 0.01
    y = sample_conditioned(prior, 500, seed + 1, PLAN_START, goal)
    pvalues["sample_conditioned(plan start, goal + 1 cm)"] = plausibility(
        prior, y, start=PLAN_START, goal=goal)
    out = {}
    for name, scores in pvalues.items():
        assert scores.shape == (500,)
        out[name] = stats.kstest(scores, "uniform").pvalue
    print(f"\nKS p-values ({label}, 500 samples): "
          + ", ".join(f"{k}: {v:.3f}" for k, v in out.items()))
    return out


def test_uniform_on_samples_of_the_synthetic_prior(synthetic_prior):
    for name, p in _calibration(synthetic_prior, 11, "synthetic box_closing").items():
        assert p > 0.01, name


def test_uniform_on_samples_of_the_box_closing_prior(box_closing):
    prior = learn_prior(box_closing)
    for name, p in _calibration(prior, 21, "box_closing.mat").items():
        assert p > 0.01, name


def test_uniform_without_floor_on_exact_samples(synthetic_prior):
    # Round-off is not what the floor is for: samples of the learned prior itself score
    # uniformly under it even with floor_std = 0 (the floor is for real paths).
    x = synthetic_prior.sample(500, 4)
    scores = plausibility(synthetic_prior, x, goal=x[:, -1, :3], floor_std=0.0,
                          velocity_floor_std=0.0)
    assert stats.kstest(scores, "uniform").pvalue > 0.01


# ------------------------------------------------------------------------------ real data
def test_leave_one_out_box_closing(box_closing):
    demos = box_closing
    scores, unfloored = [], []
    for k in range(demos.M):
        keep = [j for j in range(demos.M) if j != k]
        prior = learn_prior(Demonstrations(demos.positions[keep], demos.velocities[keep],
                                           demos.time))
        scores.append(plausibility(prior, demos.states[k]))
        unfloored.append(plausibility_details(prior, demos.states[k], floor_std=0.0))
    print("\nleave-one-out scores (floor 0.5 mm):", np.round(scores, 4),
          "\n  without floor: scores", [u.score for u in unfloored],
          "d2 / dof", [round(u.d2 / u.dof, 1) for u in unfloored])
    assert sum(s >= 0.05 for s in scores) >= 5
    # the learned noise alone rejects every held-out demonstration (why the floor exists)
    assert all(u.score < 1e-6 and u.d2 > 3 * u.dof for u in unfloored)


def test_departures_score_lower(box_closing, other_skill_prior):
    prior = learn_prior(box_closing)
    amplitudes = [0.0, 0.03, 0.06, 0.10, 0.15]
    res = [plausibility_details(prior, bumped_mean(prior, a)) for a in amplitudes]
    print("\nbump amplitude [m] -> score, d2:",
          [(a, f"{r.score:.3g}", round(r.d2, 1)) for a, r in zip(amplitudes, res)])
    assert res[0].score == pytest.approx(1.0) and res[0].d2 < 1e-9
    assert all(b.d2 > a.d2 for a, b in zip(res, res[1:]))
    assert all(b.score <= a.score for a, b in zip(res, res[1:]))
    assert all(b.z > a.z for a, b in zip(res, res[1:]))
    assert res[-1].score < 0.01
    # a tighter floor makes the same departure visible sooner
    assert plausibility(prior, bumped_mean(prior, 0.06), floor_std=1.6e-4) < 0.01
    # paths of a different skill, from their own starts
    other = other_skill_prior.sample(20, 5)
    assert plausibility(prior, other).max() < 0.01
    assert plausibility(prior, other_skill_prior.mean) < 0.01


def test_other_skill_scores_low_synthetic(synthetic_prior, other_skill_prior):
    other = other_skill_prior.sample(20, 6)
    assert plausibility(synthetic_prior, other).max() < 0.01
    own = floored_prior(synthetic_prior).sample(20, 6)
    assert np.median(plausibility(synthetic_prior, own)) > 0.05


def test_start_missed_is_penalised(synthetic_prior):
    # the score takes the start as met: the path's own first position is replaced by it, so
    # a miss becomes a jump into state 1 (and is reported as target_error)
    x = synthetic_prior.mean
    near = plausibility_details(synthetic_prior, x, start=x[0, :3] + [0.01, 0.0, 0.0])
    far = plausibility_details(synthetic_prior, x, start=x[0, :3] + [0.03, 0.0, 0.0])
    assert near.target_error == pytest.approx(0.01) and far.target_error == pytest.approx(0.03)
    assert plausibility_details(synthetic_prior, x).d2 < 1e-9 < near.d2 < far.d2
    assert far.score < 1e-6


def test_plan_scores_box_closing(box_closing, jaco):
    from clamp import plan
    from scenes import Box
    prior = learn_prior(box_closing)
    results = {}
    for name, scene in (("empty", None), ("box", Box.from_reference(BOX))):
        result = plan(prior, jaco, scene, start=PLAN_START, covariance=False)
        assert result.success, result.reasons
        x = np.concatenate([result.ee_path, result.ee_velocity], axis=1)
        results[name] = plausibility_details(prior, x, start=PLAN_START)
    print("\nplan scores:", {k: (r.score, round(r.d2, 2), round(r.z, 1), r.dof)
                             for k, r in results.items()})
    empty, box = results["empty"], results["box"]
    assert empty.target_error < 1e-4 and box.target_error < 1e-4
    assert empty.score >= 0.05 and box.score >= 0.05
    assert box.d2 > empty.d2 and box.score <= empty.score


def test_plan_forced_around_an_obstacle_on_the_path_scores_lower(synthetic_prior, jaco):
    # a cube on the demonstrated (mean) path: the plan has to leave the skill to avoid it
    from clamp import plan
    from scenes import Box, Scene
    prior, start = synthetic_prior, synthetic_prior.mean[0, :3]
    empty = plan(prior, jaco, None, start=start, covariance=False)
    mean_path = prior.mean[:, :3]
    assert np.linalg.norm(empty.ee_path - mean_path, axis=1).max() < 0.01
    box = Box(mean_path[len(mean_path) // 2], [0.05, 0.05, 0.05])
    forced = plan(prior, jaco, Scene([box]), start=start, covariance=False)
    assert forced.success, forced.reasons
    # it did go around (the end-effector frame itself may pass through: it lies between the
    # Jaco's open fingers, which the real-geometry check keeps clear)
    assert forced.min_clearance > 0.0
    assert np.linalg.norm(forced.ee_path - empty.ee_path, axis=1).max() > 0.01
    print(f"\nempty plan: {empty.plausibility:.3g} (tube {empty.skill['max_tube_ratio']:.2f}); "
          f"around the box: {forced.plausibility:.3g} "
          f"(tube {forced.skill['max_tube_ratio']:.2f})")
    # the plan's score (clamp.prior.skill) does not saturate: the detour scores strictly lower
    assert forced.skill["max_tube_ratio"] > empty.skill["max_tube_ratio"]
    assert forced.plausibility < empty.plausibility


# ------------------------------------------------------------------------------ arguments
def test_floored_prior(synthetic_prior):
    fp = floored_prior(synthetic_prior, 1e-3, 2e-3)
    np.testing.assert_allclose(np.einsum("tii->ti", fp.Q - synthetic_prior.Q),
                               np.broadcast_to([1e-6] * 3 + [4e-6] * 3, (fp.T - 1, 6)))
    assert fp.info["noise_floor"] == {"position_std": 1e-3, "velocity_std": 2e-3}
    default = floored_prior(synthetic_prior)
    assert default.info["noise_floor"]["velocity_std"] == pytest.approx(
        DEFAULT_FLOOR_STD / synthetic_prior.dt)
    assert type(default) is type(synthetic_prior)


def test_argument_errors(synthetic_prior):
    prior, x = synthetic_prior, synthetic_prior.mean
    T = prior.T
    cases = [
        (dict(prior="prior", x=x), errors.ClampTypeError, "prior"),
        (dict(x=x[:-1]), errors.ShapeError, "x"),
        (dict(x=x[:, :3]), errors.ShapeError, "x"),
        (dict(x=np.zeros((2, 2, T, 6))), errors.ShapeError, "x"),
        (dict(x=np.where(np.arange(6) == 2, np.nan, x)), errors.NonFiniteError, "x"),
        (dict(start=[0.0, 0.0]), errors.ShapeError, "start"),
        (dict(goal=np.zeros((3, 3))), errors.ShapeError, "goal"),
        (dict(via=[(0, x[0, :3])]), errors.InvalidParameterError, "via[0] index"),
        (dict(via=[(T - 1, x[-1, :3])], goal=x[-1, :3]), errors.InvalidParameterError,
         "via[0] index"),
        (dict(via=[(T, x[-1, :3])]), errors.InvalidParameterError, "via[0] index"),
        (dict(via=[(5, x[5, :3]), (5, x[5, :3])]), errors.InvalidParameterError,
         "via[1] index"),
        (dict(via=[(5.5, x[5, :3])]), errors.InvalidParameterError, "via[0] index"),
        (dict(via=[(5, [0.0])]), errors.ShapeError, "via[0] position"),
        (dict(via=(5, x[5, :3])), errors.InvalidParameterError, "via[0]"),
        (dict(via="5"), errors.InvalidParameterError, "via"),
        (dict(floor_std=-1e-3), errors.InvalidParameterError, "floor_std"),
        (dict(floor_std="a"), errors.InvalidParameterError, "floor_std"),
        (dict(velocity_floor_std=np.inf), errors.InvalidParameterError, "velocity_floor_std"),
    ]
    for kwargs, error, name in cases:
        kwargs = {"prior": prior, "x": x, **kwargs}
        with raises_naming(error, name):
            plausibility(**kwargs)
    with raises_naming(errors.InvalidParameterError, "start"):
        conditional_mean(prior, None)
    # a prior whose learned noise is singular needs a positive floor
    p = random_system(T=4, D=2, seed=1)
    p["Q"] = np.zeros((3, 2, 2))
    p["Q"][:, 0, 0] = 1.0
    singular = LinearGaussianPrior.__new__(LinearGaussianPrior)   # the constructor refuses it
    singular.__dict__.update(LinearGaussianPrior(**random_system(T=4, D=2, seed=1)).__dict__,
                             Q=p["Q"])
    with raises_naming(errors.InvalidParameterError, "floor_std"):
        plausibility(singular, singular.mean, floor_std=0.0, velocity_floor_std=0.0)
    assert 0.0 <= plausibility(singular, singular.mean, floor_std=0.1) <= 1.0


def test_a_via_index_out_of_range_gets_one_message_whatever_side(synthetic_prior):
    """Issue 20: index 0 said "expected an integer >= 1" and -1 ">= 0"."""
    x = synthetic_prior.mean
    messages = set()
    for index in (0, -1, synthetic_prior.T, 2.5):
        with pytest.raises(errors.InvalidParameterError) as caught:
            plausibility(synthetic_prior, x, start=x[0, :3], via=[(index, x[5, :3])])
        messages.add(str(caught.value).rsplit(", got", 1)[0])
    assert messages == {f"via[0] index: expected an integer state index in 1..{synthetic_prior.T - 1} "
                        "(0 is the start)"}
