"""Tests of clamp.prior.chain, the linear Gaussian chain's algebra, against dense Gaussian
algebra: the joint Gaussian over all the states of small random chains (tests.clamp.prior.test_prior's
dense_gaussian), its marginals, conditionals and conditioning on observations."""
from __future__ import annotations

import numpy as np
import pytest

from clamp.prior import chain
from tests.clamp.prior.test_prior import dense_gaussian, random_system

CHAINS = [(T, D, seed) for seed in range(3) for T, D in ((2, 2), (6, 4), (9, 6))]


def chain_and_joint(T: int, D: int, seed: int) -> tuple[dict[str, np.ndarray], np.ndarray,
                                                         np.ndarray]:
    p = random_system(T=T, D=D, seed=seed)
    mu, K = dense_gaussian(p)
    return p, mu.reshape(T, D), K


def block(K: np.ndarray, D: int, i: int, j: int) -> np.ndarray:
    return K[i * D:(i + 1) * D, j * D:(j + 1) * D]


def selector(D: int, count: int, states: list[int], T: int) -> np.ndarray:
    """H (count * len(states), T D): the leading ``count`` coordinates of the given states."""
    H = np.zeros((count * len(states), T * D))
    for k, i in enumerate(states):
        H[k * count:(k + 1) * count, i * D:i * D + count] = np.eye(count)
    return H


def dense_condition(mu: np.ndarray, K: np.ndarray, H: np.ndarray, y: np.ndarray,
                    noise: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Mean, covariance of x | H x + N(0, noise I) = y, and the squared Mahalanobis distance
    of y under its marginal."""
    S = H @ K @ H.T + noise * np.eye(len(y))
    gain = K @ H.T @ np.linalg.inv(S)
    r = y - H @ mu
    return mu + gain @ r, K - gain @ H @ K, float(r @ np.linalg.solve(S, r))


def dense_step(mu: np.ndarray, K: np.ndarray, D: int, i: int, j: int) -> chain.Step:
    """x_j | x_i of the joint as a step (A, b, B)."""
    A = np.linalg.solve(block(K, D, i, i), block(K, D, i, j)).T
    return A, mu[j] - A @ mu[i], block(K, D, j, j) - A @ block(K, D, i, j)


def assert_close(actual, expected, tol: float = 1e-9) -> None:
    expected = np.asarray(expected)
    np.testing.assert_allclose(actual, expected, rtol=tol,
                               atol=tol * max(1.0, np.abs(expected).max()))


def random_observations(count: int, states: list[int], paths: int, seed: int):
    """(state, target (paths, count)) pairs at the given states, standard normal targets."""
    rng = np.random.default_rng(100 + seed)
    return [(i, rng.standard_normal((paths, count))) for i in states]


# ------------------------------------------------------------------------------ steps
@pytest.mark.parametrize("T, D, seed", CHAINS)
def test_marginals_are_the_joint_marginals(T, D, seed):
    p, mu, K = chain_and_joint(T, D, seed)
    mean, cov = chain.marginals(p["Phi"], p["u"], p["Q"], p["mean0"], p["cov0"])
    assert_close(mean, mu)
    assert_close(cov, np.stack([block(K, D, i, i) for i in range(T)]))


@pytest.mark.parametrize("T, D, seed", CHAINS)
def test_compositions_are_the_joint_conditionals(T, D, seed):
    p, mu, K = chain_and_joint(T, D, seed)
    steps = (p["Phi"], p["u"], p["Q"])
    for i in range(T - 1):
        prefix = chain.prefix_compose(*(a[i:] for a in steps))
        suffix = chain.suffix_compose(*(a[i:] for a in steps))
        for j in range(i + 1, T):
            expected = dense_step(mu, K, D, i, j)
            for got in (tuple(a[j - i - 1] for a in prefix),
                        chain.total_compose(*(a[i:j] for a in steps))):
                for g, e in zip(got, expected):
                    assert_close(g, e)
            for g, e in zip((a[j - 1 - i] for a in suffix), dense_step(mu, K, D, j - 1, T - 1)):
                assert_close(g, e)


def test_composition_is_associative():
    rng = np.random.default_rng(5)
    S, D = 4, 3
    steps = [(rng.standard_normal((S, D, D)), rng.standard_normal((S, D)),
              rng.standard_normal((S, D, D))) for _ in range(3)]
    left = chain.compose(chain.compose(steps[0], steps[1]), steps[2])
    right = chain.compose(steps[0], chain.compose(steps[1], steps[2]))
    for a, b in zip(left, right):
        assert_close(a, b, 1e-12)


@pytest.mark.parametrize("steps", [1, 2, 7, 256, 300])
def test_prefix_scan_equals_sequential_recursion(steps):
    p = random_system(T=steps + 1, D=6, seed=steps)
    p["Phi"] = 0.9 * p["Phi"] / np.linalg.norm(p["Phi"], ord=2, axis=(1, 2))[:, None, None]
    A, b, B = chain.prefix_compose(p["Phi"], p["u"], p["Q"])
    mean, cov, product = p["mean0"], p["cov0"], np.eye(6)
    for i in range(steps):
        mean = p["Phi"][i] @ mean + p["u"][i]
        cov = p["Phi"][i] @ cov @ p["Phi"][i].T + p["Q"][i]
        product = p["Phi"][i] @ product
        np.testing.assert_allclose(A[i], product, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(A[i] @ p["mean0"] + b[i], mean, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(A[i] @ p["cov0"] @ A[i].T + B[i], cov, rtol=1e-10,
                                   atol=1e-10)
    total = chain.total_compose(p["Phi"], p["u"], p["Q"])
    for t, last in zip(total, (A[-1], b[-1], B[-1])):
        np.testing.assert_allclose(t, last, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("steps", [1, 2, 7, 256, 300])
def test_suffix_scan_equals_sequential_recursion_from_every_state(steps):
    p = random_system(T=steps + 1, D=6, seed=steps)
    p["Phi"] = 0.9 * p["Phi"] / np.linalg.norm(p["Phi"], ord=2, axis=(1, 2))[:, None, None]
    A, b, B = chain.suffix_compose(p["Phi"], p["u"], p["Q"])
    # backwards: the map from state i to the last state is the map from i + 1 after step i
    product, offset, noise = np.eye(6), np.zeros(6), np.zeros((6, 6))
    for i in range(steps - 1, -1, -1):
        offset = product @ p["u"][i] + offset
        noise = product @ p["Q"][i] @ product.T + noise
        product = product @ p["Phi"][i]
        np.testing.assert_allclose(A[i], product, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(b[i], offset, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(B[i], noise, rtol=1e-10, atol=1e-10)


# ------------------------------------------------------------------------------ exact observations
OBSERVED = {2: [[0], [1], [0, 1]], 6: [[0, 5], [3], [0, 2, 4], [1, 5]],
            9: [[0, 8], [4], [0, 3, 6], [2, 7, 8]]}


@pytest.mark.parametrize("T, D, seed", CHAINS)
def test_filter_and_smoother_are_dense_exact_conditioning(T, D, seed):
    p, mu, K = chain_and_joint(T, D, seed)
    count, paths = D // 2, 3
    flat_mu = mu.reshape(-1)
    for states in OBSERVED[T]:
        obs = random_observations(count, states, paths, seed)
        mf, mp, Pf, Pp = chain.kalman_filter(p["Phi"], p["u"], p["Q"], p["mean0"], p["cov0"],
                                             obs, count)
        smoothed = chain.rts_smooth(p["Phi"], mf, mp, Pf, Pp)
        d2 = chain.observation_d2(
            p["mean0"], p["cov0"], obs, count,
            lambda i, j: chain.total_compose(p["Phi"][i:j], p["u"][i:j], p["Q"][i:j]))
        for k in range(paths):
            def given(upto: int) -> tuple[np.ndarray, np.ndarray, float]:
                """The joint conditioned on the observations at states < upto."""
                seen = [(i, t[k]) for i, t in obs if i < upto]
                if not seen:
                    return flat_mu, K, 0.0
                H = selector(D, count, [i for i, _ in seen], T)
                return dense_condition(flat_mu, K, H, np.concatenate([t for _, t in seen]))

            mean, cov, dense_d2 = given(T)
            assert_close(smoothed[k], mean.reshape(T, D), 1e-8)
            assert_close(d2[k], dense_d2, 1e-8)
            for i in range(T):
                before, after = given(i), given(i + 1)
                assert_close(mp[k, i], before[0].reshape(T, D)[i], 1e-8)
                assert_close(mf[k, i], after[0].reshape(T, D)[i], 1e-8)
                if k == 0:
                    assert_close(Pp[i], block(before[1], D, i, i), 1e-8)
                    assert_close(Pf[i], block(after[1], D, i, i), 1e-8)


def test_observe_leading_meets_the_target_and_zeroes_its_covariance():
    rng = np.random.default_rng(3)
    M = rng.standard_normal((4, 4))
    P, m, target = M @ M.T + np.eye(4), rng.standard_normal((2, 4)), rng.standard_normal((2, 2))
    m_c, P_c, d2 = chain.observe_leading(m, P, target, 2)
    np.testing.assert_array_equal(m_c[:, :2], target)
    assert np.all(P_c[:2] == 0.0) and np.all(P_c[:, :2] == 0.0)
    for k in range(2):
        mean, cov, dense_d2 = dense_condition(m[k], P, np.eye(4)[:2], target[k])
        assert_close(m_c[k], mean)
        assert_close(d2[k], dense_d2)
    assert_close(P_c[2:, 2:], cov[2:, 2:])


# ------------------------------------------------------------------------------ information form
def information(T: int, D: int, obs: list[tuple[int, np.ndarray]],
                sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Each state's own observations of its leading D/2 coordinates with noise sigma, in
    information form (L_obs (T, D, D), e_obs (T, D))."""
    A = D // 2
    L_obs, e_obs = np.zeros((T, D, D)), np.zeros((T, D))
    for i, y in obs:
        L_obs[i, np.arange(A), np.arange(A)] += 1.0 / sigma**2
        e_obs[i, :A] += y / sigma**2
    return L_obs, e_obs


def noisy_cases(T: int, D: int, seed: int, sigma: float):
    """For each set of observed states: the chain, its joint (mean (T, D), covariance), the
    observations (index, y (D/2,)) of noise sigma and their backward messages (L, e)."""
    p, mu, K = chain_and_joint(T, D, seed)
    for states in OBSERVED[T]:
        obs = [(i, y[0]) for i, y in random_observations(D // 2, states, 1, seed)]
        messages = chain.backward_messages(p["Phi"], p["u"], p["Q"],
                                           *information(T, D, obs, sigma))
        yield p, mu, K, obs, messages


NOISY = [(*c, sigma) for c in CHAINS for sigma in (0.05, 1.0)]


@pytest.mark.parametrize("T, D, seed, sigma", NOISY)
def test_backward_messages_are_the_likelihood_of_later_observations(T, D, seed, sigma):
    for p, mu, K, obs, (L, e) in noisy_cases(T, D, seed, sigma):
        for i in range(T):
            later = [(j, y) for j, y in obs if j >= i]
            if not later:
                np.testing.assert_array_equal(L[i], 0.0)
                np.testing.assert_array_equal(e[i], 0.0)
                continue
            # y = H x + v given x_i: N(C x_i + d, R), so the likelihood is
            # exp(-0.5 x' C' R^-1 C x + (C' R^-1 (y - d))' x) up to a constant
            H = selector(D, D // 2, [j for j, _ in later], T)
            cross = H @ K[:, i * D:(i + 1) * D]
            C = np.linalg.solve(block(K, D, i, i), cross.T).T
            R = H @ K @ H.T - C @ cross.T + sigma**2 * np.eye(len(H))
            y = np.concatenate([y for _, y in later])
            assert_close(L[i], C.T @ np.linalg.solve(R, C), 1e-7)
            assert_close(e[i], C.T @ np.linalg.solve(R, y - H @ mu.reshape(-1) + C @ mu[i]),
                         1e-7)


@pytest.mark.parametrize("T, D, seed, sigma", NOISY)
def test_conditioned_chain_is_the_dense_posterior(T, D, seed, sigma):
    for p, mu, K, obs, messages in noisy_cases(T, D, seed, sigma):
        Phi, u, Q, mean0, cov0 = chain.conditioned_chain(p["Phi"], p["u"], p["Q"], p["mean0"],
                                                         p["cov0"], *messages)
        got_mu, got_K = dense_gaussian(dict(Phi=Phi, u=u, Q=Q, mean0=mean0, cov0=cov0))
        H = selector(D, D // 2, [i for i, _ in obs], T)
        mean, cov, _ = dense_condition(mu.reshape(-1), K, H,
                                       np.concatenate([y for _, y in obs]), sigma**2)
        assert_close(got_mu, mean, 1e-8)
        assert_close(got_K, cov, 1e-8)
