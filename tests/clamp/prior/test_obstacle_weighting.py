"""Obstacle-weighted learning from cluttered demonstrations (clamp.prior.obstacle_weighting) and the
per-demonstration obstacles it needs (loaders, synthetic cluttered generator)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from bad_input import raises_naming
from clamp import ClampWarning, errors, learn_prior, plan
from clamp.prior.obstacle_weighting import ObstacleWeighting, demonstration_weights
from clamp.viz.prior_plots import plot_weighted_priors
from scenes import (Box, DemonstrationFileError, Demonstrations, Scene, load_demonstrations,
                    make_cluttered_demonstrations, make_demonstrations, save_csv)

DETOUR = 0.08
#: the synthetic skill spans ~0.4 m: at the reference's eps = 0.3 m every sample lies within
#: eps of its demonstration's box, so weights at this scale use eps 0.15 m, sigma 2.5e-4 m^2
SCALED = ObstacleWeighting(eps=0.15, sigma=0.00025)


@pytest.fixture(scope="module")
def cluttered() -> Demonstrations:
    return make_cluttered_demonstrations("box_closing", num_demos=10, seed=0, detour=DETOUR)


def box_distance(points: np.ndarray, centre: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Signed distance of points (N, 3) to an axis-aligned box, written out independently."""
    q = np.abs(points - centre) - size / 2
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return outside + inside


def test_weights_equal_the_formula_at_random_points():
    rng = np.random.default_rng(4)
    points = rng.uniform(-0.5, 0.5, size=(3, 200, 3))
    boxes = [[Box(rng.uniform(-0.3, 0.3, 3), rng.uniform(0.05, 0.3, 3)) for _ in range(k)]
             for k in (1, 2, 0)]
    for weighting in (ObstacleWeighting(), ObstacleWeighting(eps=0.1, sigma=0.01)):
        weights = demonstration_weights(points, boxes, weighting)
        for m, group in enumerate(boxes):
            d = np.full(200, np.inf)
            for box in group:
                d = np.minimum(d, box_distance(points[m], box.center, box.size))
            c = np.maximum(0.0, weighting.eps - d)
            np.testing.assert_allclose(weights[m], np.exp(-0.5 * c**2 / weighting.sigma),
                                       rtol=1e-12, atol=1e-300)
        if weighting == ObstacleWeighting():                    # the points span both regimes
            assert weights[0].min() < 1e-3 < 0.999 < weights[0].max()


def test_cluttered_demonstrations_detour_around_their_own_boxes(cluttered):
    clean = make_demonstrations("box_closing", num_demos=10, seed=0)
    offset = np.linalg.norm(cluttered.positions - clean.positions, axis=2)
    np.testing.assert_allclose(offset.max(axis=1), DETOUR, rtol=0.02)
    for m, group in enumerate(cluttered.obstacles):
        assert len(group) == 1
        assert Scene(group).distance(cluttered.positions[m]).min() > 0.0     # goes around it
        assert Scene(group).distance(clean.positions[m]).min() < 0.0         # it blocks the skill
    # velocities stay the positions' time derivative
    numeric = np.gradient(cluttered.positions, cluttered.time, axis=1)
    assert np.abs(numeric - cluttered.velocities)[:, 2:-2].max() < 2e-3


def test_weighted_prior_is_closer_to_the_clutter_free_skill(cluttered):
    for seed in range(3):
        demos = make_cluttered_demonstrations("box_closing", num_demos=10, seed=seed)
        reference = make_demonstrations("box_closing", num_demos=10, seed=seed).mean_position()
        rms = {}
        for name, weighting in (("unweighted", None), ("weighted", SCALED)):
            prior = learn_prior(demos, obstacle_weighting=weighting)
            gap = np.linalg.norm(prior.position_mean - reference, axis=1)
            rms[name] = float(np.sqrt(np.mean(gap**2)))
        assert rms["weighted"] < 0.8 * rms["unweighted"], rms
    incremental = learn_prior(cluttered, obstacle_weighting=SCALED, method="incremental")
    assert incremental.info["obstacle_weighting"] == {"eps": 0.15, "sigma": 0.00025}


def test_plan_from_weighted_prior_does_not_reproduce_the_detours(cluttered, jaco):
    reference = make_demonstrations("box_closing", num_demos=10, seed=0).mean_position()
    lift = {}
    for name, weighting in (("unweighted", None), ("weighted", SCALED)):
        prior = learn_prior(cluttered, obstacle_weighting=weighting)
        result = plan(prior, jaco, None, start=prior.mean[0, :3], covariance=False)
        assert result.success, result.reasons
        lift[name] = float(np.max(result.ee_path[:, 2] - reference[:, 2]))
    assert lift["weighted"] < 0.25 * DETOUR
    assert lift["weighted"] < 0.5 * lift["unweighted"], lift


def test_weighting_without_obstacles_warns_and_bad_settings_fail():
    demos = make_demonstrations("box_closing", num_demos=4, num_points=30, seed=0)
    with pytest.warns(ClampWarning, match="no recorded obstacles"):
        learn_prior(demos, obstacle_weighting=True)
    with raises_naming(errors.InvalidParameterError, "obstacle_weighting.sigma"):
        learn_prior(demos, obstacle_weighting={"sigma": 0.0})
    with raises_naming(errors.InvalidParameterError, "obstacle_weighting"):
        learn_prior(demos, obstacle_weighting="yes")


def test_obstacles_load_from_reference_mat_csv_scene_json_and_npz(cluttered, tmp_path):
    small = make_cluttered_demonstrations("box_closing", num_demos=3, num_points=20, seed=1)
    rows = [np.concatenate([g[0].center, g[0].size]) for g in small.obstacles]
    dataset = np.array([{"pos": small.positions[m], "vel": small.velocities[m],
                         "time": small.time, "obs": rows[m][None]} for m in range(3)],
                       dtype=object)
    scipy.io.savemat(tmp_path / "ref.mat", {"dataset": dataset})
    csv = tmp_path / "demos.csv"
    scene_paths = save_csv(small, csv)
    assert len(scene_paths) == 3
    small.save_npz(tmp_path / "demos.npz")
    for loaded in (load_demonstrations(tmp_path / "ref.mat"),
                   load_demonstrations(csv, scenes=scene_paths),
                   load_demonstrations(tmp_path / "demos.npz")):
        for group, expected in zip(loaded.obstacles, small.obstacles):
            np.testing.assert_allclose(group[0].center, expected[0].center)
            np.testing.assert_allclose(group[0].size, expected[0].size)
    assert load_demonstrations(csv).obstacles is None
    with raises_naming(DemonstrationFileError, "scenes", "demos.csv"):
        load_demonstrations(csv, scenes=scene_paths[:2])


def test_side_by_side_figure(cluttered, tmp_path):
    weights = demonstration_weights(cluttered.positions, cluttered.obstacles, SCALED)
    fig = plot_weighted_priors(learn_prior(cluttered), learn_prior(cluttered,
                               obstacle_weighting=SCALED), cluttered, weights=weights,
                               reference=make_demonstrations("box_closing", num_demos=10,
                                                             seed=0).mean_position(),
                               path=tmp_path / "weighted.png")
    assert len(fig.axes) >= 2 and (tmp_path / "weighted.png").stat().st_size > 10_000
