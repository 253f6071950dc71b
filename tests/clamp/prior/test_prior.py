"""Tests of clamp.prior.linear_gaussian: marginals, densities, sampling and files of linear-Gaussian priors."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from bad_input import raises_naming
from clamp import errors
from clamp.prior.linear_gaussian import FILE_FORMAT, LinearGaussianPrior, WorkspacePrior


def random_system(T: int = 5, D: int = 4, seed: int = 0) -> dict[str, np.ndarray]:
    """Random, well-conditioned prior parameters for T support states of size D."""
    rng = np.random.default_rng(seed)
    Phi = np.eye(D) + 0.3 * rng.standard_normal((T - 1, D, D))
    u = rng.standard_normal((T - 1, D))
    A = 0.5 * rng.standard_normal((T - 1, D, D))
    Q = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(D)
    B = rng.standard_normal((D, D))
    return dict(time=0.1 * np.arange(T), Phi=Phi, u=u, Q=Q, mean0=rng.standard_normal(D),
                cov0=B @ B.T + 0.2 * np.eye(D))


def dense_gaussian(p: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (8) densely: mu = A [mean0; u], K = A diag(cov0, Q) A^T, A^{-1} block bidiagonal."""
    Phi = p["Phi"]
    T, D = Phi.shape[0] + 1, Phi.shape[1]
    A_inv = np.eye(T * D)
    for i in range(T - 1):
        A_inv[(i + 1) * D:(i + 2) * D, i * D:(i + 1) * D] = -Phi[i]
    A = np.linalg.inv(A_inv)
    noise = np.zeros((T * D, T * D))
    noise[:D, :D] = p["cov0"]
    for i in range(T - 1):
        noise[(i + 1) * D:(i + 2) * D, (i + 1) * D:(i + 2) * D] = p["Q"][i]
    return A @ np.concatenate([p["mean0"], p["u"].ravel()]), A @ noise @ A.T


@pytest.fixture
def system():
    return random_system()


@pytest.fixture
def prior(system):
    return LinearGaussianPrior(**system)


def test_marginals_match_dense_eq8(system, prior):
    mu, K = dense_gaussian(system)
    T, D = prior.T, prior.D
    np.testing.assert_allclose(prior.mean, mu.reshape(T, D), rtol=1e-10, atol=1e-10)
    for i in range(T):
        np.testing.assert_allclose(prior.cov[i], K[i * D:(i + 1) * D, i * D:(i + 1) * D],
                                   rtol=1e-10, atol=1e-10)
    assert (prior.T, prior.D, prior.num_axes) == (5, 4, 2)
    assert prior.dt == pytest.approx(0.1)


def test_log_likelihood_and_mahalanobis_match_dense_gaussian(system, prior):
    mu, K = dense_gaussian(system)
    rng = np.random.default_rng(1)
    x = rng.multivariate_normal(mu, K, size=3).reshape(3, prior.T, prior.D)
    expected = stats.multivariate_normal(mu, K).logpdf(x.reshape(3, -1))
    np.testing.assert_allclose(prior.log_likelihood(x), expected, rtol=1e-9)
    diff = x.reshape(3, -1) - mu
    d2 = np.einsum("ki,ij,kj->k", diff, np.linalg.inv(K), diff)
    np.testing.assert_allclose(prior.mahalanobis(x) ** 2, d2, rtol=1e-8)
    # Single trajectory -> float; equals the batched entry.
    assert isinstance(prior.log_likelihood(x[1]), float)
    assert prior.log_likelihood(x[1]) == pytest.approx(expected[1], rel=1e-9)
    # initial=False: only the transition densities.
    transitions = sum(
        stats.multivariate_normal(system["Phi"][i] @ x[0, i] + system["u"][i],
                                  system["Q"][i]).logpdf(x[0, i + 1]) for i in range(prior.T - 1))
    assert prior.log_likelihood(x[0], initial=False) == pytest.approx(transitions, rel=1e-9)
    residuals = prior.transition_residuals(x[0])
    np.testing.assert_allclose(residuals[2], x[0, 3] - system["Phi"][2] @ x[0, 2] - system["u"][2])


def test_samples_follow_the_prior(system, prior):
    count = 4000
    samples = prior.sample(count, np.random.default_rng(3))
    assert samples.shape == (count, prior.T, prior.D)
    mu, K = dense_gaussian(system)
    flat = samples.reshape(count, -1)
    chol = np.linalg.cholesky(K)
    white = np.linalg.solve(chol, (flat - mu).T)
    # Whitened sample mean ~ N(0, 1/N); whitened covariance ~ I within Wishart error.
    assert np.abs(white.mean(axis=1)).max() < 5.0 / np.sqrt(count)
    assert np.abs(np.cov(white) - np.eye(len(mu))).max() < 5.0 * np.sqrt(2.0 / count)
    np.testing.assert_array_equal(prior.sample(4, 9), prior.sample(4, np.random.default_rng(9)))


def test_success_probability_is_calibrated(prior):
    samples = prior.sample(3000, np.random.default_rng(4))
    for initial in (False, True):
        p = prior.success_probability(samples, initial=initial)
        assert p.shape == (3000,)
        assert stats.kstest(p, "uniform").pvalue > 1e-3
    steps = prior.step_success_probabilities(samples)
    assert steps.shape == (3000, prior.T)
    assert stats.kstest(steps.ravel(), "uniform").pvalue > 1e-3
    assert prior.degrees_of_freedom(initial=False) == prior.D * (prior.T - 1)
    # The mean follows the dynamics exactly; a trajectory off the dynamics scores low.
    assert prior.success_probability(prior.mean) == pytest.approx(1.0)
    wrong = prior.mean + 10.0 * np.sqrt(prior.Q.diagonal(axis1=1, axis2=2)).max() * \
        np.sin(np.arange(prior.T))[:, None]
    assert prior.success_probability(wrong) < 1e-6
    # Start elsewhere: the plan keeps its transitions' score when initial=False.
    moved = prior.mean.copy()
    moved[0] += 100.0
    assert prior.success_probability(moved, initial=True) < 1e-6


def test_envelope_covers_95_percent(prior):
    lower, upper = prior.envelope(0.95)
    np.testing.assert_allclose(upper - prior.mean, 1.959964 * prior.std, rtol=1e-6)
    samples = prior.sample(4000, np.random.default_rng(5))
    inside = ((samples >= lower) & (samples <= upper)).mean(axis=0)
    assert np.abs(inside - 0.95).max() < 5.0 * np.sqrt(0.95 * 0.05 / 4000)


def test_workspace_prior_save_load_round_trip(tmp_path):
    system = random_system(T=7, D=6, seed=2)
    prior = WorkspacePrior(**system, info={"ridge": 1e-6, "coupled": False})
    path = prior.save(tmp_path / "prior")
    assert path.name == "prior.npz"
    for loaded in (WorkspacePrior.load(path), LinearGaussianPrior.load(path)):
        assert type(loaded) is WorkspacePrior
        for name in ("time", "Phi", "u", "Q", "mean0", "cov0", "mean", "cov"):
            np.testing.assert_array_equal(getattr(loaded, name), getattr(prior, name))
        assert loaded.info == prior.info and loaded.kind == "workspace"
        assert loaded.state_names == ("px", "py", "pz", "vx", "vy", "vz")
    np.testing.assert_array_equal(loaded.position_mean, prior.mean[:, :3])
    joint = LinearGaussianPrior(**random_system(), kind="joint")
    loaded_joint = LinearGaussianPrior.load(joint.save(tmp_path / "joint.npz"))
    assert type(loaded_joint) is LinearGaussianPrior and loaded_joint.kind == "joint"
    with raises_naming(errors.PriorFileError, "joint.npz"):
        WorkspacePrior.load(tmp_path / "joint.npz")


def test_load_rejects_bad_files(tmp_path, prior):
    with raises_naming(errors.PriorFileError, "missing.npz"):
        LinearGaussianPrior.load(tmp_path / "missing.npz")
    text = tmp_path / "text.npz"
    text.write_text("not a zip archive")
    with raises_naming(errors.PriorFileError, "text.npz"):
        LinearGaussianPrior.load(text)
    good = {k: getattr(prior, k) for k in ("time", "Phi", "u", "Q", "mean0", "cov0")}
    meta = dict(format=np.array(FILE_FORMAT), kind=np.array("generic"), info=np.array("{}"),
                state_names=np.array(prior.state_names))
    np.savez(tmp_path / "old.npz", **{**good, **meta, "format": np.array("other/0")})
    with raises_naming(errors.PriorFileError, "old.npz", "format"):
        LinearGaussianPrior.load(tmp_path / "old.npz")
    np.savez(tmp_path / "short.npz", **{k: v for k, v in {**good, **meta}.items() if k != "Q"})
    with raises_naming(errors.PriorFileError, "short.npz", "Q"):
        LinearGaussianPrior.load(tmp_path / "short.npz")
    nan_phi = good["Phi"].copy()
    nan_phi[1, 0, 0] = np.nan
    np.savez(tmp_path / "nan.npz", **{**good, **meta, "Phi": nan_phi})
    with raises_naming(errors.PriorFileError, "nan.npz", "Phi"):
        LinearGaussianPrior.load(tmp_path / "nan.npz")


def test_file_format_versions(tmp_path):
    """A file in the layout before the format entry (the six arrays only, written here with
    numpy) loads as version 1; a newer version, another format or a missing array is refused
    with PriorFileError naming the file and what was wrong."""
    from clamp import learn_prior
    from clamp.prior.linear_gaussian import FILE_FORMAT_NAME, FILE_FORMAT_VERSION
    from scenes import make_demonstrations

    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, num_points=40, seed=0))
    saved = prior.save(tmp_path / "prior.npz")
    with np.load(saved) as data:
        assert str(data["format"]) == f"{FILE_FORMAT_NAME}/{FILE_FORMAT_VERSION}" == FILE_FORMAT
    arrays = {k: np.asarray(getattr(prior, k)) for k in ("time", "Phi", "u", "Q", "mean0", "cov0")}
    np.savez(tmp_path / "old.npz", **arrays)                       # the old key layout
    for loaded in (WorkspacePrior.load(tmp_path / "old.npz"), LinearGaussianPrior.load(tmp_path / "old.npz")):
        assert type(loaded) is WorkspacePrior and loaded.kind == "workspace" and loaded.info == {}
        assert loaded.state_names == ("px", "py", "pz", "vx", "vy", "vz")
        for name in ("time", "Phi", "u", "Q", "mean0", "cov0", "mean", "cov"):
            np.testing.assert_array_equal(getattr(loaded, name), getattr(prior, name))
    assert "not recorded" in loaded.summary()
    np.savez(tmp_path / "old_meta.npz", **arrays, kind=np.array("workspace"), info=np.array('{"ridge": 0.5}'))
    assert WorkspacePrior.load(tmp_path / "old_meta.npz").info == {"ridge": 0.5}
    joint = LinearGaussianPrior(**random_system(D=4))
    np.savez(tmp_path / "old_joint.npz", **{k: getattr(joint, k) for k in arrays})
    assert type(LinearGaussianPrior.load(tmp_path / "old_joint.npz")) is LinearGaussianPrior

    meta = dict(kind=np.array("workspace"), info=np.array("{}"), state_names=np.array(prior.state_names))
    cases = {
        "newer.npz": ({**arrays, **meta, "format": np.array(f"{FILE_FORMAT_NAME}/{FILE_FORMAT_VERSION + 1}")},
                      f"format version {FILE_FORMAT_VERSION + 1}.*newer than this version reads"),
        "other.npz": ({**arrays, **meta, "format": np.array("someone-elses-prior/1")}, "not a CLAMP prior file"),
        "garbled.npz": ({**arrays, **meta, "format": np.array(f"{FILE_FORMAT_NAME}/x")}, "not a CLAMP prior file"),
        "no_q.npz": ({k: v for k, v in arrays.items() if k != "Q"}, r"no format entry .*lacks entries \['Q'\]"),
        "no_info.npz": ({**arrays, "format": np.array(FILE_FORMAT), "kind": meta["kind"],
                         "state_names": meta["state_names"]}, r"lacks entries \['info'\]"),
        "demos.npz": ({"positions": np.zeros((2, 3, 3)), "time": np.arange(3.0)}, "not a CLAMP prior file"),
    }
    for name, (contents, message) in cases.items():
        np.savez(tmp_path / name, **contents)
        with pytest.raises(errors.PriorFileError, match=message) as caught:
            WorkspacePrior.load(tmp_path / name)
        assert str(tmp_path / name) in str(caught.value)


def test_summary_reports_what_was_learned():
    from clamp import learn_prior
    from scenes import make_demonstrations

    demos = make_demonstrations("box_closing", num_demos=5, num_points=30, seed=1)
    text = learn_prior(demos, ridge=1e-4).summary()
    assert text.startswith("WorkspacePrior(kind='workspace', T=30") and "5 demonstrations, 30 states" in text
    assert "method batch" in text and "ridge 0.0001" in text and "spread about their mean" in text
    offsets = np.linalg.norm(demos.positions - demos.positions.mean(axis=0), axis=2)
    assert f"farthest {1e3 * offsets.max():.1f} mm" in text


def test_constructor_and_argument_errors(system, prior):
    bad = dict(system, Q=system["Q"] - 10.0 * np.eye(4))
    with raises_naming(errors.InvalidParameterError, "Q"):
        LinearGaussianPrior(**bad)
    asym = system["cov0"].copy()
    asym[0, 1] += 1.0
    with raises_naming(errors.InvalidParameterError, "cov0"):
        LinearGaussianPrior(**dict(system, cov0=asym))
    with raises_naming(errors.ShapeError, "Phi"):
        LinearGaussianPrior(**random_system(D=3))
    with raises_naming(errors.ShapeError, "time"):
        LinearGaussianPrior(**dict(system, time=system["time"][:-1]))
    with raises_naming(errors.ShapeError, "u"):
        LinearGaussianPrior(**dict(system, u=system["u"][:, :3]))
    with raises_naming(errors.ShapeError, "Phi"):
        WorkspacePrior(**system)
    with raises_naming(errors.ShapeError, "x"):
        prior.log_likelihood(np.zeros((prior.T + 1, prior.D)))
    with raises_naming(errors.NonFiniteError, "x"):
        prior.mahalanobis(np.full((prior.T, prior.D), np.nan))
    with raises_naming(errors.InvalidParameterError, "count"):
        prior.sample(0, 1)
    with raises_naming(errors.InvalidParameterError, "rng"):
        prior.sample(2, None)  # type: ignore[arg-type]
    with raises_naming(errors.InvalidParameterError, "level"):
        prior.envelope(1.5)


def test_parameters_are_read_only_copies(system):
    phi = system["Phi"].copy()
    prior = LinearGaussianPrior(**dict(system, Phi=phi))
    phi[0] = 0.0                                      # the caller's array stays theirs
    assert np.any(prior.Phi[0] != 0.0)
    for name in ("time", "Phi", "u", "Q", "mean0", "cov0", "mean", "cov"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(prior, name)[...] = 0.0
