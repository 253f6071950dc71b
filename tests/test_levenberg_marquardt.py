"""The lean Levenberg-Marquardt loop agrees with GTSAM's optimizer on a nonlinear problem."""
from __future__ import annotations

import gtsam
import numpy as np
import pytest

from clamp.levenberg_marquardt import (chain_ordering, jacobian_diagonal, levenberg_marquardt,
                                        solve_banded_damped)


def curve_fit_graph(rng):
    """Fit y = a exp(b t) + c over 3 chained 3-vector variables tied by priors and links."""
    t = np.linspace(0, 1, 30)
    truth = np.array([1.5, -0.8, 0.3])
    y = truth[0] * np.exp(truth[1] * t) + truth[2] + 0.001 * rng.normal(size=t.size)
    graph = gtsam.NonlinearFactorGraph()
    keys = [gtsam.symbol("p", i) for i in range(3)]

    def model(this, values, H):
        a, b, c = values.atVector(this.keys()[0])
        e = a * np.exp(b * t) + c - y
        if H is not None:
            H[0] = np.stack([np.exp(b * t), a * t * np.exp(b * t), np.ones_like(t)], axis=1)
        return e

    def link(this, values, H):
        if H is not None:
            H[0], H[1] = np.eye(3), -np.eye(3)
        return values.atVector(this.keys()[0]) - values.atVector(this.keys()[1])

    for key in keys:
        graph.add(gtsam.CustomFactor(gtsam.noiseModel.Isotropic.Sigma(30, 0.01), [key], model))
    for k0, k1 in zip(keys[:-1], keys[1:]):
        graph.add(gtsam.CustomFactor(gtsam.noiseModel.Isotropic.Sigma(3, 0.1), [k0, k1], link))
    initial = gtsam.Values()
    for i, key in enumerate(keys):
        initial.insert(key, np.array([1.0, 0.0, 0.0]) + 0.1 * i)
    return graph, initial, keys, truth


def test_matches_gtsam_levenberg_marquardt():
    graph, initial, keys, truth = curve_fit_graph(np.random.default_rng(0))
    ours = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3)
    params = gtsam.LevenbergMarquardtParams()
    params.setlambdaInitial(1e-3)
    reference = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    values = reference.optimize()
    assert ours.final_error < ours.initial_error
    assert ours.final_error == pytest.approx(reference.error(), rel=1e-6, abs=1e-9)
    for key in keys:
        np.testing.assert_allclose(ours.values.atVector(key), values.atVector(key), atol=1e-6)
        np.testing.assert_allclose(ours.values.atVector(key), truth, atol=0.02)
    assert ours.iterations >= 1 and ours.trials >= ours.iterations


def test_max_iterations_is_respected():
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(1))
    out = levenberg_marquardt(graph, initial, keys, [3, 3, 3], max_iterations=1,
                              relative_error_tol=0.0, absolute_error_tol=0.0)
    assert out.iterations == 1
    assert out.final_error < out.initial_error



def test_qr_solver_and_identity_correction_match_the_plain_loop():
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(2))
    plain = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3)
    calls = []

    def identity(values, delta, candidate):
        calls.append(1)
        return candidate

    qr = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3,
                             correction=identity, solver="qr")
    assert len(calls) == qr.trials
    assert qr.final_error == pytest.approx(plain.final_error, rel=1e-6, abs=1e-9)
    for key in keys:
        np.testing.assert_allclose(qr.values.atVector(key), plain.values.atVector(key), atol=1e-6)


def test_unknown_solver_raises():
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(3))
    with pytest.raises(ValueError, match="cholesky"):
        levenberg_marquardt(graph, initial, keys, [3, 3, 3], solver="lu")


def test_gain_ratio_damping_reaches_the_same_minimum():
    graph, initial, keys, truth = curve_fit_graph(np.random.default_rng(4))
    plain = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3)
    adaptive = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e3,
                                   damping_update="gain_ratio")
    assert adaptive.final_error == pytest.approx(plain.final_error, rel=1e-6, abs=1e-9)
    for key in keys:
        np.testing.assert_allclose(adaptive.values.atVector(key), truth, atol=0.02)
    with pytest.raises(ValueError, match="gain_ratio"):
        levenberg_marquardt(graph, initial, keys, [3, 3, 3], damping_update="nielsen")


def test_patience_needs_consecutive_small_steps():
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(5))
    # every accepted step counts as small: patience k stops after exactly k iterations
    for patience in (1, 3):
        out = levenberg_marquardt(graph, initial, keys, [3, 3, 3], relative_error_tol=1.0,
                                  patience=patience)
        assert out.iterations == patience
    with pytest.raises(ValueError, match="patience"):
        levenberg_marquardt(graph, initial, keys, [3, 3, 3], patience=0)


def test_jacobian_diagonal_equals_the_hessian_diagonal():
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(6))
    linear = graph.linearize(initial)
    reversed_keys = keys[::-1]  # any key order: GTSAM's columns follow sorted keys
    diagonal = jacobian_diagonal(linear, reversed_keys, [3, 3, 3],
                                 {k: i for i, k in enumerate(reversed_keys)}, np.arange(4) * 3)
    hessian, _ = linear.hessian(chain_ordering(reversed_keys))
    np.testing.assert_allclose(diagonal, np.diag(hessian), rtol=1e-12)


def test_diagonal_damping_reaches_the_same_minimum_and_reports_phase_timings():
    graph, initial, keys, truth = curve_fit_graph(np.random.default_rng(7))
    plain = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3)
    scaled = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3,
                                 diagonal_damping=True)
    assert scaled.final_error == pytest.approx(plain.final_error, rel=1e-6, abs=1e-9)
    for key in keys:
        np.testing.assert_allclose(scaled.values.atVector(key), truth, atol=0.02)
    assert set(scaled.timings) == {"linearize", "solve", "correction", "error"}
    assert all(t >= 0.0 for t in scaled.timings.values()) and scaled.timings["solve"] > 0.0


def test_system_replaces_graph_evaluation():
    """A system object is used for every error and linearization (the graph is not)."""
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(8))
    calls = {"error": 0, "linearize": 0, "error_below": 0}

    class Counting:
        def error(self, values):
            calls["error"] += 1
            return graph.error(values)

        def error_below(self, values, bound):
            calls["error_below"] += 1
            return graph.error(values)

        def linearize(self, values):
            calls["linearize"] += 1
            return graph.linearize(values)

    plain = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3)
    out = levenberg_marquardt(gtsam.NonlinearFactorGraph(), initial, keys, [3, 3, 3],
                              lambda_initial=1e-3, system=Counting())
    assert out.final_error == pytest.approx(plain.final_error, rel=1e-12)
    assert calls["error"] == 1 and calls["error_below"] == out.trials
    # one linearization per accepted step (+ one when the last point admits no decrease)
    assert calls["linearize"] in (out.iterations, out.iterations + 1)


def band_of(H: np.ndarray, width: int) -> np.ndarray:
    """LAPACK lower band storage (width + 1, N) of a symmetric matrix H (N, N)."""
    N = H.shape[0]
    band = np.zeros((width + 1, N))
    for u in range(width + 1):
        band[u, :N - u] = np.diagonal(H, -u)
    return band


def test_solve_banded_damped_matches_a_dense_solve_and_refuses_indefinite_systems():
    rng = np.random.default_rng(9)
    N, width = 40, 5
    A = rng.normal(size=(60, N)) * np.exp(rng.uniform(-6, 6, size=N))  # columns of 1e-3..1e3
    H = A.T @ A
    H[np.abs(np.subtract.outer(np.arange(N), np.arange(N))) > width] = 0.0
    H += np.diag(np.abs(H).sum(axis=1))  # diagonally dominant: positive definite
    g = rng.normal(size=N)
    damping = np.full(N, 0.1)
    delta = solve_banded_damped(band_of(H, width), g, damping)
    np.testing.assert_allclose(delta, np.linalg.solve(H + np.diag(damping), g), rtol=1e-9)
    assert solve_banded_damped(band_of(-H, width), g, damping) is None


class GraphSystem:
    """The lean loop's `system` protocol served by a plain GTSAM graph (tests add
    normal_equations)."""

    def __init__(self, graph, keys):
        self.graph, self.keys = graph, keys

    def error(self, values):
        return self.graph.error(values)

    def linearize(self, values):
        return self.graph.linearize(values)


def test_banded_solver_reaches_the_qr_minimum():
    """solver="banded" uses the system's normal equations and ends where QR ends."""
    graph, initial, keys, truth = curve_fit_graph(np.random.default_rng(10))
    ordering = chain_ordering(keys)
    calls = {"normal_equations": 0}

    class Banded(GraphSystem):
        def normal_equations(self, values):
            calls["normal_equations"] += 1
            augmented = graph.linearize(values).augmentedHessian(ordering)
            return band_of(augmented[:-1, :-1], 5), augmented[:-1, -1]

    qr = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3, solver="qr",
                             damping_update="gain_ratio")
    banded = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3,
                                 solver="banded", damping_update="gain_ratio", system=Banded(graph, keys))
    assert calls["normal_equations"] >= banded.iterations > 0
    assert banded.final_error == pytest.approx(qr.final_error, rel=1e-6, abs=1e-9)
    for key in keys:
        np.testing.assert_allclose(banded.values.atVector(key), truth, atol=0.02)


def test_banded_solver_falls_back_to_qr_when_the_band_is_not_positive_definite():
    graph, initial, keys, _ = curve_fit_graph(np.random.default_rng(11))

    class Indefinite(GraphSystem):
        def normal_equations(self, values):
            return np.full((6, 9), -1e12), np.ones(9)  # negative definite at any damping

    qr = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3, solver="qr")
    out = levenberg_marquardt(graph, initial, keys, [3, 3, 3], lambda_initial=1e-3,
                              solver="banded", system=Indefinite(graph, keys))
    assert out.iterations == qr.iterations
    assert out.final_error == pytest.approx(qr.final_error, rel=1e-12)
