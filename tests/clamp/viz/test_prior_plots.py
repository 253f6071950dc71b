"""Tests of clamp.viz.prior_plots: envelope tube geometry and headless PNG output."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import errors
from clamp.prior.learning import learn_joint_prior, learn_prior
from clamp.viz.prior_plots import STATIONARY_FRACTION, envelope_tube, plot_prior_3d, plot_prior_time
from scenes import make_demonstrations


@pytest.fixture
def learned():
    demos = make_demonstrations("box_closing", num_demos=6, num_points=40, seed=1)
    return learn_prior(demos), demos.states


def test_envelope_tube_is_the_projected_covariance_ellipse(learned):
    prior, _ = learned
    tube = envelope_tube(prior, level=0.95, resolution=16)
    assert tube.shape == (prior.T, 16, 3)
    offsets = tube - prior.mean[:, None, :3]
    tangent = np.gradient(prior.mean[:, :3], axis=0)
    length = np.linalg.norm(tangent, axis=1)
    moving = length > STATIONARY_FRACTION * length.max()
    tangent /= length[:, None]
    # Cross-sections lie in the plane normal to the mean path where it moves ...
    assert moving.sum() > prior.T // 2
    assert np.abs(np.einsum("trk,tk->tr", offsets, tangent)[moving]).max() < 1e-12
    # ... and consecutive cross-sections do not twist (same angle -> nearby points).
    jumps = np.linalg.norm(np.diff(tube, axis=0), axis=2).max(axis=1)
    assert jumps.max() < 0.5 * np.linalg.norm(np.ptp(tube.reshape(-1, 3), axis=0))
    # ... on the ellipse with squared Mahalanobis radius 1.96^2 in that plane.
    step = 20
    helper = np.linalg.svd(tangent[step][None])[2][1:]         # (2, 3) basis of the plane
    cov2 = helper @ prior.cov[step, :3, :3] @ helper.T
    local = offsets[step] @ helper.T
    radius2 = np.einsum("ri,ij,rj->r", local, np.linalg.inv(cov2), local)
    np.testing.assert_allclose(radius2, 1.959964 ** 2, rtol=1e-5)


def test_plots_write_png(tmp_path, learned):
    prior, states = learned
    for name, plot in (("prior3d.png", plot_prior_3d), ("prior_time.png", plot_prior_time)):
        fig = plot(prior, states, path=tmp_path / name)
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert len(fig.axes) >= 1
    plot_prior_time(prior, path=tmp_path / "no_demos.png")
    assert (tmp_path / "no_demos.png").stat().st_size > 1000
    rng = np.random.default_rng(0)
    time = 0.1 * np.arange(30)
    qdot = 0.5 + 0.1 * rng.standard_normal((5, 30, 4)).cumsum(axis=1)
    q = 0.1 * qdot.cumsum(axis=1)
    joint = learn_joint_prior(q, qdot, time)
    fig = plot_prior_time(joint, np.concatenate([q, qdot], axis=2), path=tmp_path / "joint.png")
    assert len(fig.axes) == 8
    with raises_naming(errors.ShapeError, "prior"):
        plot_prior_3d(joint)
    with raises_naming(errors.ShapeError, "demos"):
        plot_prior_time(prior, states[:, :-1])
