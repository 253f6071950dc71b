"""Generalized cylinder: fitting (real and synthetic data), containment, derived cylinders, files."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import load_demonstrations, make_demonstrations
from tlgc import (CROSS_SECTION_TYPES, GeneralizedCylinder, TLGCArgumentError,
                  CylinderDemonstrationsError, TooFewDemonstrationsError, UnknownCrossSectionError,
                  fit_cylinder)
from tlgc.errors import CylinderFileError

KINDS = sorted(CROSS_SECTION_TYPES)


def load_smooth_data(path) -> np.ndarray:
    """TLGC .mat file -> demonstrations (M, N, 3)."""
    return load_demonstrations(path).positions


@pytest.fixture(scope="module")
def synthetic() -> np.ndarray:
    return make_demonstrations("curved_reach", num_demos=5, num_points=300, seed=0).positions


def effective_ratios(cyl: GeneralizedCylinder) -> np.ndarray:
    """Ratios (M, N) of every effective point to the boundary of its own section."""
    return cyl.cross_sections.ratio(np.arange(cyl.num_sections)[None, :], cyl.effective_points)


@pytest.mark.parametrize("dataset", ["needle_threading", "pick_place"])
@pytest.mark.parametrize("kind", KINDS)
def test_real_data_boundaries_enclose_and_touch_the_effective_points(shared_dataset, dataset, kind):
    demos = load_smooth_data(shared_dataset(dataset))
    cyl = fit_cylinder(demos, kind)
    assert cyl.num_sections == demos.shape[1] == 1500
    ratio = effective_ratios(cyl)
    assert ratio.max() <= 1.0 + 1e-9
    np.testing.assert_allclose(ratio.max(axis=0), 1.0, atol=1e-9)


@pytest.mark.parametrize("kind", KINDS)
def test_synthetic_boundaries_enclose_and_touch_the_effective_points(synthetic, kind):
    cyl = fit_cylinder(synthetic, kind)
    ratio = effective_ratios(cyl)
    assert ratio.max() <= 1.0 + 1e-9
    np.testing.assert_allclose(ratio.max(axis=0), 1.0, atol=1e-9)


def check_radius_derivative(cyl: GeneralizedCylinder, rng: np.random.Generator) -> None:
    """cyl.radius_derivative vs central differences (step 1e-6 rad) of cyl.radius at random
    sections and angles (200,), relative to the section's radius; periodic at 0 and 2 pi."""
    step = 1e-6
    index = rng.integers(0, cyl.num_sections, size=200)
    angle = rng.uniform(0.0, 2 * np.pi, size=200)
    slope = cyl.radius_derivative(index, angle)
    assert slope.shape == (200,)
    fd = (cyl.radius(index, angle + step) - cyl.radius(index, angle - step)) / (2 * step)
    scale = cyl.radius(index, angle)
    np.testing.assert_allclose(slope / scale, fd / scale, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(cyl.radius_derivative(index, 2 * np.pi),
                               cyl.radius_derivative(index, 0.0), rtol=1e-9, atol=1e-12)
    assert cyl.radius_derivative(index[:4, None], angle[None, :3]).shape == (4, 3)


@pytest.mark.parametrize("kind", KINDS)
def test_synthetic_radius_derivative_matches_central_differences(synthetic, kind):
    check_radius_derivative(fit_cylinder(synthetic, kind), np.random.default_rng(11))


@pytest.mark.parametrize("kind", KINDS)
def test_needle_threading_radius_derivative_matches_central_differences(shared_dataset, kind):
    cyl = fit_cylinder(load_smooth_data(shared_dataset("needle_threading")), kind)
    check_radius_derivative(cyl, np.random.default_rng(12))


def test_directrix_is_the_mean_and_the_centroid_of_the_effective_points(synthetic):
    cyl = fit_cylinder(synthetic, "spline")
    np.testing.assert_allclose(cyl.directrix, synthetic.mean(axis=0), atol=1e-15)
    np.testing.assert_allclose(cyl.effective_points.mean(axis=0), 0.0, atol=1e-14)
    # Effective points plus the along-tangent offset give back the demonstrations.
    along = np.einsum("mni,ni->mn", synthetic - cyl.directrix, cyl.tangents)
    rebuilt = cyl.to_world(cyl.effective_points, np.arange(300)[None, :]) + along[..., None] * cyl.tangents
    np.testing.assert_allclose(rebuilt, synthetic, atol=1e-14)
    np.testing.assert_allclose(cyl.arc_length[[0, -1]], [0.0, 1.0])
    assert np.all(np.diff(cyl.arc_length) >= 0)


def test_accepts_demonstration_objects_lists_and_resamples():
    demos = make_demonstrations("pick_place", num_demos=4, num_points=120, seed=1)
    from_object = fit_cylinder(demos, "circle")
    from_array = fit_cylinder(demos.positions, "circle")
    np.testing.assert_array_equal(from_object.directrix, from_array.directrix)
    assert fit_cylinder(SimpleNamespace(positions=demos.positions), "circle").num_sections == 120
    # Unequal lengths: each resampled by a cubic spline to the longest; a cubic is reproduced.
    s = np.linspace(0.0, 1.0, 50)
    cubic = np.stack([s, s**2, s**3], axis=1)
    trajectories = [cubic + 0.01 * k for k in range(3)]
    trajectories[1] = np.stack([np.linspace(0, 1, 80), np.linspace(0, 1, 80) ** 2,
                                np.linspace(0, 1, 80) ** 3], axis=1) + 0.01
    cyl = fit_cylinder(trajectories, "ellipse")
    assert cyl.num_sections == 80
    u = np.linspace(0, 1, 80)
    np.testing.assert_allclose(cyl.demonstrations[0], np.stack([u, u**2, u**3], axis=1), atol=1e-12)
    assert fit_cylinder(trajectories, "spline", num_points=33).num_sections == 33


def local_points(cyl: GeneralizedCylinder, index: np.ndarray, angle: np.ndarray, ratio: np.ndarray):
    r = ratio * cyl.radius(index, angle)
    return cyl.to_world(np.stack([r * np.cos(angle), r * np.sin(angle)], axis=-1), index)


@pytest.mark.parametrize("kind", KINDS)
def test_containment_recovers_section_angle_and_ratio(synthetic, kind):
    cyl = fit_cylinder(synthetic, kind)
    rng = np.random.default_rng(7)
    index = rng.integers(1, 299, 500)
    angle = rng.uniform(0, 2 * np.pi, 500)
    ratio = rng.uniform(0.0, 1.5, 500)
    c = cyl.containment(local_points(cyl, index, angle, ratio))
    np.testing.assert_array_equal(c.index, index)
    np.testing.assert_allclose(c.ratio, ratio, atol=1e-9)
    keep = ratio > 1e-6
    np.testing.assert_allclose(np.cos(c.angle[keep] - angle[keep]), 1.0, atol=1e-9)
    np.testing.assert_array_equal(c.inside, ratio <= 1.0)
    np.testing.assert_allclose(c.offset, 0.0, atol=1e-12)
    np.testing.assert_allclose(c.distance, c.ratio * c.radius, rtol=1e-12)


@pytest.mark.parametrize("dataset", ["needle_threading", "pick_place"])
def test_containment_on_fat_real_cylinders_finds_points_inside(shared_dataset, dataset):
    # Where several section planes pass through a point, one that holds it inside wins.
    cyl = fit_cylinder(load_smooth_data(shared_dataset(dataset)), "spline")
    rng = np.random.default_rng(8)
    index = rng.integers(0, cyl.num_sections, 3000)
    angle = rng.uniform(0, 2 * np.pi, 3000)
    ratio = rng.uniform(0.0, 0.999, 3000)
    c = cyl.containment(local_points(cyl, index, angle, ratio))
    assert c.inside.all()
    assert np.mean(c.index == index) > 0.95
    np.testing.assert_allclose(c.ratio[c.index == index], ratio[c.index == index], atol=1e-9)


def test_points_beyond_the_ends_belong_to_the_end_sections(synthetic):
    cyl = fit_cylinder(synthetic, "circle")
    before = cyl.directrix[0] - 0.05 * cyl.tangents[0]
    after = cyl.directrix[-1] + 0.05 * cyl.tangents[-1]
    c = cyl.containment(np.stack([before, after]))
    np.testing.assert_array_equal(c.index, [0, cyl.num_sections - 1])
    np.testing.assert_allclose(c.offset, [-0.05, 0.05], atol=1e-12)
    np.testing.assert_allclose(c.distance, 0.0, atol=1e-12)
    assert not c.inside.any()                      # end caps are closed


def test_ratio_per_index_matches_the_effective_points(synthetic):
    cyl = fit_cylinder(synthetic, "ellipse")
    ratio = cyl.ratio(cyl.demonstrations, np.arange(300)[None, :])
    np.testing.assert_allclose(ratio, effective_ratios(cyl), atol=1e-12)


def test_with_directrix_moves_rigidly_and_keeps_the_sections(synthetic):
    cyl = fit_cylinder(synthetic, "spline")
    angle = 0.7
    rot = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    offset = np.array([0.3, -0.1, 0.2])
    moved = cyl.with_directrix(cyl.directrix @ rot.T + offset, initial_normal=rot @ cyl.normals[0])
    np.testing.assert_allclose(moved.frames, np.einsum("ij,nkj->nki", rot, cyl.frames), atol=1e-6)
    np.testing.assert_allclose(moved.demonstrations, synthetic @ rot.T + offset
                               - np.einsum("mni,ni->mn", synthetic - cyl.directrix, cyl.tangents)[..., None]
                               * moved.tangents, atol=1e-6)
    shifted = cyl.with_directrix(cyl.directrix + offset)
    np.testing.assert_allclose(shifted.frames, cyl.frames, atol=1e-9)
    np.testing.assert_allclose(shifted.boundary_points(12), cyl.boundary_points(12) + offset, atol=1e-12)
    # Without an initial normal the old one is carried by the minimal rotation of the tangent.
    default = cyl.with_directrix(cyl.directrix @ rot.T + offset)
    t_old, t_new = cyl.tangents[0], default.tangents[0]
    axis = np.cross(t_old, t_new)
    axis /= np.linalg.norm(axis)
    np.testing.assert_allclose(default.normals[0] @ axis, cyl.normals[0] @ axis, atol=1e-12)
    np.testing.assert_allclose(default.normals[0] @ t_new, 0.0, atol=1e-12)
    with raises_naming(TLGCArgumentError, "directrix"):
        cyl.with_directrix(cyl.directrix[:10])


def test_with_cross_sections_replaces_only_the_boundary(synthetic):
    cyl = fit_cylinder(synthetic, "spline")
    circles = fit_cylinder(synthetic, "circle").cross_sections
    swapped = cyl.with_cross_sections(circles)
    assert swapped.cross_section == "circle"
    np.testing.assert_array_equal(swapped.directrix, cyl.directrix)


@pytest.mark.parametrize("kind", KINDS)
def test_save_load_round_trip(tmp_path, synthetic, kind):
    cyl = fit_cylinder(synthetic, kind)
    path = tmp_path / "cyl.npz"
    cyl.save(path)
    back = GeneralizedCylinder.load(path)
    assert back.cross_section == kind
    np.testing.assert_array_equal(back.frames, cyl.frames)
    np.testing.assert_array_equal(back.effective_points, cyl.effective_points)
    angles = np.linspace(0, 6, 25)
    np.testing.assert_array_equal(back.radius(np.arange(300)[:, None], angles),
                                  cyl.radius(np.arange(300)[:, None], angles))
    with raises_naming(CylinderFileError, "missing.npz"):
        GeneralizedCylinder.load(tmp_path / "missing.npz")
    np.savez(tmp_path / "bad.npz", directrix=cyl.directrix)
    with raises_naming(CylinderFileError, "bad.npz"):
        GeneralizedCylinder.load(tmp_path / "bad.npz")


def test_surface_and_boundary_shapes(synthetic):
    cyl = fit_cylinder(synthetic, "ellipse")
    x, y, z = cyl.surface(num_angles=20, step=7)
    assert x.shape == y.shape == z.shape == (len(range(0, 300, 7)) + 1, 21)
    ring = cyl.boundary_points(16, indices=[0, 5])
    np.testing.assert_allclose(cyl.ratio(ring, np.array([[0], [5]])), 1.0, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_identical_demonstrations_are_refused(kind):
    """Identical demonstrations have no spread to learn a tube from (issue 10: refuse, do not
    guess a radius)."""
    t = np.linspace(0.0, 1.0, 100)
    demo = np.stack([t, np.sin(t), t**2], axis=1)
    with raises_naming(CylinderDemonstrationsError, "demos"):
        fit_cylinder(np.stack([demo, demo, demo]), kind)


def test_error_catalogue(synthetic):
    with raises_naming(TooFewDemonstrationsError, "demos"):
        fit_cylinder(synthetic[:1])
    bad = synthetic.copy()
    bad[1, 5, 2] = np.nan
    with raises_naming(CylinderDemonstrationsError, "demos"):
        fit_cylinder(bad)
    with raises_naming(CylinderDemonstrationsError, "demos"):
        fit_cylinder(synthetic[None])
    with raises_naming(CylinderDemonstrationsError, "demos"):
        fit_cylinder(synthetic[:, :, :2])
    with raises_naming(UnknownCrossSectionError, "cross_section"):
        fit_cylinder(synthetic, "hexagon")
    with raises_naming(CylinderDemonstrationsError, "demos"):
        fit_cylinder(np.ones((3, 10, 3)))
    with raises_naming(CylinderDemonstrationsError, "num_points"):
        fit_cylinder(synthetic, num_points=1)
    cyl = fit_cylinder(synthetic, "circle")
    with raises_naming(TLGCArgumentError, "points"):
        cyl.containment(np.zeros(3))


@pytest.mark.parametrize("kind", KINDS)
def test_largest_radius_is_the_sampled_maximum_of_the_boundary(synthetic, kind):
    cyl = fit_cylinder(synthetic, kind)
    fine = cyl.radius(np.arange(cyl.num_sections)[:, None],
                      np.linspace(0.0, 2.0 * np.pi, 4096, endpoint=False)[None, :]).max(axis=1)
    largest = cyl.largest_radius()
    assert np.all(largest <= fine * (1 + 1e-12)) and np.all(largest >= 0.99 * fine)
    norms = np.linalg.norm(cyl.effective_points, axis=-1).max(axis=0)   # on the boundary or in
    assert np.all(largest >= 0.99 * norms)
    np.testing.assert_array_equal(cyl.largest_radius([3, 7]), largest[[3, 7]])
    if kind == "circle":
        np.testing.assert_allclose(largest, norms, rtol=1e-12)
