"""Noisy recordings (scenes.smoothing): noise estimate, smoothing spline, the loaders' choice,
and what they mean for CLAMP priors and plans (issue 21 item 2)."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import learn_prior, plan
from scenes import Demonstrations, load_demonstrations
from scenes.errors import InvalidArgumentError
from scenes.smoothing import NOISE_RATIO, estimate_noise, savgol_window, smooth_trajectory

START = [0.2054, -0.4722, 0.2625]


def minimum_jerk_reaches(num_demos: int = 5, duration: float = 10.0, rate: float = 100.0,
                         seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum-jerk reaches from near the box_closing start to near its end: time (T,),
    positions and velocities (M, T, 3), exact (no noise)."""
    rng = np.random.default_rng(seed)
    time = np.linspace(0.0, duration, int(round(duration * rate)) + 1)
    s = time / duration
    shape = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
    rate_of_shape = (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / duration
    start = np.array([0.21, -0.47, 0.26]) + 0.01 * rng.standard_normal((num_demos, 3))
    goal = np.array([0.44, -0.27, 0.14]) + 0.01 * rng.standard_normal((num_demos, 3))
    positions = start[:, None] + (goal - start)[:, None] * shape[None, :, None]
    velocities = (goal - start)[:, None] * rate_of_shape[None, :, None]
    return time, positions, velocities


def write_csv(path, time, positions):
    """The recording as a CSV without velocities (demo,t,x,y,z)."""
    M, T, _ = positions.shape
    rows = np.column_stack([np.repeat(np.arange(M), T), np.tile(time, M), positions.reshape(-1, 3)])
    np.savetxt(path, rows, delimiter=",", header="demo,t,x,y,z", comments="", fmt="%.10g")
    return path


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """The recipe: five 10 s minimum-jerk reaches at 100 Hz, with and without 1 mm noise."""
    time, positions, velocities = minimum_jerk_reaches()
    noisy = positions + 1e-3 * np.random.default_rng(1).standard_normal(positions.shape)
    folder = tmp_path_factory.mktemp("recordings")
    return {"time": time, "positions": positions, "velocities": velocities,
            "clean": write_csv(folder / "clean.csv", time, positions),
            "noisy": write_csv(folder / "noisy.csv", time, noisy)}


def test_noise_estimate_recovers_the_added_noise():
    time, positions, _ = minimum_jerk_reaches(num_demos=1)
    rng = np.random.default_rng(2)
    for sigma in (1e-4, 1e-3):
        estimate = estimate_noise(time, positions[0] + sigma * rng.standard_normal((len(time), 3)))
        np.testing.assert_allclose(estimate.sigma, sigma, rtol=0.15)
        assert estimate.noisy
    clean = estimate_noise(time, positions[0])
    assert clean.sigma.max() < 1e-8 and not clean.noisy and clean.ratio < NOISE_RATIO / 100


@pytest.mark.parametrize("method", ["savgol", "spline"])
def test_smoothers_recover_velocities_where_interpolation_cannot(method):
    time, positions, velocities = minimum_jerk_reaches(num_demos=1)
    noisy = positions[0] + 1e-3 * np.random.default_rng(3).standard_normal((len(time), 3))
    smoothed, rate = smooth_trajectory(time, noisy, method)
    raw, raw_rate = smooth_trajectory(time, noisy, "none")
    peak = np.abs(velocities[0]).max()
    assert np.sqrt(np.mean((rate - velocities[0]) ** 2)) < 0.02 * peak
    assert np.sqrt(np.mean((raw_rate - velocities[0]) ** 2)) > 0.5 * peak
    assert np.sqrt(np.mean((smoothed - positions[0]) ** 2)) < 0.3e-3   # closer than the noise
    np.testing.assert_array_equal(raw, noisy)


def test_auto_interpolates_clean_recordings_exactly():
    time, positions, velocities = minimum_jerk_reaches(num_demos=1)
    kept, rate = smooth_trajectory(time, positions[0], "auto")
    np.testing.assert_array_equal(kept, positions[0])
    np.testing.assert_allclose(rate, velocities[0], atol=1e-6)


def test_bad_arguments_name_the_argument():
    time = np.linspace(0.0, 1.0, 20)
    with raises_naming(InvalidArgumentError, "smoothing"):
        smooth_trajectory(time, np.zeros((20, 3)), "gcv")
    with raises_naming(InvalidArgumentError, "values"):
        estimate_noise(time, np.zeros(20))


def test_noisy_recordings_learn_the_noise_free_prior_and_plan(recordings, jaco, caplog):
    """Acceptance (issue 21 item 2): the prior's velocity mean within 20 % of the noise-free
    one, the plan's peak end-effector speed within 20 % of the noise-free plan's."""
    truth = Demonstrations(recordings["positions"], recordings["velocities"],
                           recordings["time"]).resample(250)
    with caplog.at_level(logging.WARNING, logger="scenes"):
        noisy = load_demonstrations(recordings["noisy"]).resample(250)
    assert not caplog.records                       # smoothed: nothing to warn about
    reference, prior = learn_prior(truth), learn_prior(noisy)
    peak = np.abs(reference.mean[:, 3:]).max()
    assert np.abs(prior.mean[:, 3:] - reference.mean[:, 3:]).max() < 0.2 * peak
    speeds = [np.linalg.norm(plan(p, jaco, None, START).ee_velocity, axis=1).max()
              for p in (reference, prior)]
    assert abs(speeds[1] - speeds[0]) < 0.2 * speeds[0]


def test_unsmoothed_noisy_recordings_warn_with_the_numbers(recordings, caplog):
    with caplog.at_level(logging.WARNING, logger="scenes"):
        raw = load_demonstrations(recordings["noisy"], smoothing="none")
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 5 and all("velocity noise dominates" in w for w in warnings)
    assert "noise up to 0.001" in warnings[0] and "0.01 s" in warnings[0]
    # and they are right to: the interpolated velocities are several times the motion's
    assert np.abs(raw.velocities).max() > 5 * np.abs(recordings["velocities"]).max()
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="scenes"):
        clean = load_demonstrations(recordings["clean"], smoothing="none")
    assert not caplog.records
    np.testing.assert_allclose(clean.velocities, recordings["velocities"], atol=1e-6)


def test_savgol_window_grows_with_the_noise():
    """GCV picks a wider window for noisier samples, and never one longer than the recording."""
    time, positions, _ = minimum_jerk_reaches(num_demos=1)
    rng = np.random.default_rng(4)
    quiet, loud = (savgol_window(positions[0] + s * rng.standard_normal((len(time), 3)))
                   for s in (1e-5, 1e-3))
    assert np.all(loud >= quiet) and loud.sum() > quiet.sum()
    assert np.all(loud % 2 == 1) and loud.max() <= len(time) // 2 + 1
    short = np.linspace(0.0, 1.0, 8)[:, None] + 1e-3 * rng.standard_normal((8, 1))
    assert savgol_window(short).tolist() == [5]
