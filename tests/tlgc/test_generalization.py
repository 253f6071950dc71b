"""Generalization of generalized cylinders: TPS (Algorithm 3) and LTE (Algorithm 4)."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import load_demonstrations, make_demonstrations
from tlgc.cylinder import fit_cylinder
from tlgc.errors import TLGCArgumentError
from tlgc.generalization import (fit_similarity, fit_tps, landmark_constraints, laplacian_matrix,
                                 lte_deform, lte_generalize, shape_distortion, tps_generalize)
from tlgc.reproduction import random_starts, reproduce


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@pytest.fixture(scope="module")
def synthetic_cylinder():
    demos = make_demonstrations("pick_place", num_demos=5, num_points=200, seed=3)
    return fit_cylinder(demos, "spline")


# ---------------------------------------------------------------------------- array parts
def test_similarity_recovers_known_transform():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(30, 3))
    rot, scale, shift = _rotation(rng), 1.7, rng.normal(size=3)
    fit = fit_similarity(src, scale * src @ rot.T + shift)
    assert fit.scale == pytest.approx(scale, rel=1e-12)
    np.testing.assert_allclose(fit.rotation, rot, atol=1e-12)
    np.testing.assert_allclose(fit.translation, shift, atol=1e-12)
    assert np.linalg.det(fit.rotation) == pytest.approx(1.0)


def test_laplacian_rows_are_umbrella_weights():
    lap = laplacian_matrix(5).toarray()
    np.testing.assert_allclose(lap.sum(axis=1), 0.0)
    np.testing.assert_allclose(lap[2], [0, -0.5, 1, -0.5, 0])
    np.testing.assert_allclose(lap[0], [1, -1, 0, 0, 0])


def test_tps_interpolates_landmarks_and_reproduces_affine_maps():
    rng = np.random.default_rng(1)
    src = rng.normal(size=(8, 3))
    affine = np.eye(3) + 0.2 * rng.normal(size=(3, 3))
    dst = src @ affine.T + [0.1, -0.2, 0.3]
    z = fit_tps(src, dst)
    assert z.degree == 1
    np.testing.assert_allclose(z(src), dst, atol=1e-9)
    x = rng.normal(size=(50, 3))      # an affine map has zero bending energy: exact everywhere
    np.testing.assert_allclose(z(x), x @ affine.T + [0.1, -0.2, 0.3], atol=1e-8)


def test_tps_with_too_few_landmarks_uses_translation_part_and_anchors():
    src = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    dst = np.array([[0.0, 0, 0], [1.0, 0.5, 0]])
    z = fit_tps(src[1:], dst[1:], anchors=src[:1])
    assert z.degree == 0 and z.num_anchors == 1
    np.testing.assert_allclose(z(src), dst, atol=1e-12)
    z2 = fit_tps(src, dst, anchors=src[:1])            # anchor equal to a landmark is dropped
    assert z2.num_anchors == 0


def test_tps_smoothing_trades_interpolation_for_smoothness():
    rng = np.random.default_rng(2)
    src = rng.normal(size=(10, 3))
    dst = src + 0.3 * rng.normal(size=(10, 3))
    exact, smooth = fit_tps(src, dst), fit_tps(src, dst, smoothing=10.0)
    err_exact = np.abs(exact(src) - dst).max()
    err_smooth = np.abs(smooth(src) - dst).max()
    assert err_exact < 1e-9 < err_smooth


def test_lte_meets_constraints_and_is_exact_for_similarities():
    rng = np.random.default_rng(4)
    t = np.linspace(0, 1, 120)
    path = np.stack([t, 0.2 * np.sin(3 * t), 0.1 * t**2], axis=1)
    rot, scale, shift = _rotation(rng), 1.3, np.array([0.2, 0.1, -0.3])
    target = scale * path @ rot.T + shift
    edited, transform = lte_deform(path, {0: target[0], 60: target[60], -1: target[-1]})
    np.testing.assert_allclose(edited, target, atol=1e-9)      # the similarity in closed form
    assert transform.scale == pytest.approx(scale, rel=1e-9)
    assert shape_distortion(path, edited) < 1e-9
    bent, _ = lte_deform(path, {0: path[0], 60: path[60] + [0, 0, 0.2], -1: path[-1]})
    np.testing.assert_allclose(bent[60], path[60] + [0, 0, 0.2], atol=1e-12)
    assert shape_distortion(path, bent) > 1e-3


def test_bad_inputs_raise_clear_errors(synthetic_cylinder):
    with raises_naming(TLGCArgumentError, "source_landmarks", "target_landmarks"):
        fit_tps(np.zeros((2, 3)), np.zeros((3, 3)))
    with raises_naming(TLGCArgumentError, "source_landmarks"):
        fit_tps(np.zeros((2, 3)), np.ones((2, 3)))
    with raises_naming(TLGCArgumentError, "source_landmarks"):
        fit_tps(np.full((1, 3), np.nan), np.zeros((1, 3)))
    with raises_naming(TLGCArgumentError, "constraints"):
        lte_deform(synthetic_cylinder.directrix, {})
    with raises_naming(TLGCArgumentError, "constraints", "999"):
        lte_deform(synthetic_cylinder.directrix, {999: np.zeros(3)})
    with raises_naming(TLGCArgumentError, "cyl"):
        tps_generalize("cylinder", np.zeros((1, 3)), np.ones((1, 3)))


# ---------------------------------------------------------------------------- cylinders
def test_generalized_cylinders_keep_shape_and_start(synthetic_cylinder):
    cyl = synthetic_cylinder
    src = cyl.directrix[[0, -1]]
    dst = src + [[0, 0, 0], [0.05, -0.08, 0.03]]
    for new in (tps_generalize(cyl, src, dst),
                lte_generalize(cyl, landmark_constraints(cyl, src, dst))):
        assert new.cross_section == cyl.cross_section and new.num_sections == cyl.num_sections
        np.testing.assert_allclose(new.directrix[[0, -1]], dst, atol=1e-9)
        # a small move keeps the section sizes close to the original ones
        a = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        k = np.arange(cyl.num_sections)[:, None]
        ratio = new.radius(k, a) / cyl.radius(k, a)
        assert 0.7 < np.median(ratio) < 1.3
        starts = random_starts(new, 6, rng=5)
        out = reproduce(new, starts)
        ratio = new.ratio(out, np.arange(new.num_sections)[None, :])
        assert np.all(ratio <= 1.0 + 1e-9)


def test_tps_with_enough_landmarks_maps_the_directrix_affinely(synthetic_cylinder):
    cyl = synthetic_cylinder
    rng = np.random.default_rng(6)
    src = cyl.directrix[[0, 50, 120, 199]] + rng.normal(scale=0.05, size=(4, 3))
    affine = np.eye(3) + 0.1 * rng.normal(size=(3, 3))
    shift = np.array([0.02, -0.03, 0.01])
    new = tps_generalize(cyl, src, src @ affine.T + shift, keep_start=False)
    np.testing.assert_allclose(new.directrix, cyl.directrix @ affine.T + shift, atol=1e-9)
    if cyl.demonstrations is not None:
        np.testing.assert_allclose(new.demonstrations, cyl.demonstrations @ affine.T + shift, atol=1e-9)


def test_lte_scales_cross_sections_with_the_path(synthetic_cylinder):
    cyl = synthetic_cylinder
    start, end = cyl.directrix[0], cyl.directrix[-1]
    doubled = {0: start, -1: start + 2.0 * (end - start)}
    a = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    k = np.arange(cyl.num_sections)[:, None]
    # Start free: the whole skill is scaled by 2, sections included.
    free = lte_generalize(cyl, doubled, mode="similarity", keep_start=False)
    np.testing.assert_allclose(free.radius(k, a), 2.0 * cyl.radius(k, a), rtol=1e-6)
    np.testing.assert_allclose(free.directrix, start + 2.0 * (cyl.directrix - start), atol=1e-9)
    # Start kept: the first section stays, the scale fades in and is 2 after the fade.
    kept = lte_generalize(cyl, doubled, mode="similarity")
    np.testing.assert_allclose(kept.radius(k[:3], a), cyl.radius(k[:3], a), rtol=1e-12)
    after = cyl.arc_length >= cyl.arc_length[2] + 0.1
    np.testing.assert_allclose(kept.radius(k[after], a), 2.0 * cyl.radius(k[after], a), rtol=1e-6)
    ratio = kept.radius(k, a) / cyl.radius(k, a)
    assert np.all(np.diff(ratio[:, 0]) >= -1e-9)                      # monotone fade-in
    unscaled = lte_generalize(cyl, doubled, mode="similarity", scale_cross_sections=False)
    np.testing.assert_allclose(unscaled.radius(k, a), cyl.radius(k, a), rtol=1e-9)
    # The default mode with a kept start is the local edit: sections keep their size.
    default = lte_generalize(cyl, doubled)
    np.testing.assert_allclose(default.radius(k, a), cyl.radius(k, a), rtol=1e-9)


# ---------------------------------------------------------------------------- paper 5.2
def _pick_place_cylinder(shared_dataset):
    return fit_cylinder(load_demonstrations(shared_dataset("pick_place")), "spline")


PLACE_OFFSETS = np.array([[0.06, 0.04, 0.0], [-0.05, 0.08, 0.02], [0.10, -0.06, 0.05],
                          [-0.08, -0.05, 0.10]])


def test_pick_place_generalizes_to_four_new_place_positions(shared_dataset):
    cyl = _pick_place_cylinder(shared_dataset)
    source = cyl.directrix[[0, -1]]                      # object (stays) and box (moves)
    for offset in PLACE_OFFSETS:
        target = source + np.stack([np.zeros(3), offset])
        tps = tps_generalize(cyl, source, target)
        lte = lte_generalize(cyl, landmark_constraints(cyl, source, target))
        for new in (tps, lte):
            assert np.linalg.norm(new.directrix[-1] - target[1]) < 1e-3
            assert np.linalg.norm(new.directrix[0] - source[0]) < 1e-3
            out = reproduce(new, random_starts(new, 4, rng=0))
            assert np.all(np.linalg.norm(out[:, -1] - target[1], axis=1) < 0.05)


def test_far_target_lte_preserves_shape_better_than_tps(shared_dataset):
    cyl = _pick_place_cylinder(shared_dataset)
    source = cyl.directrix[[0, -1]]
    target = source + np.array([[0.0, 0.0, 0.0], [0.45, 0.25, 0.15]])
    tps = tps_generalize(cyl, source, target)
    lte = lte_generalize(cyl, landmark_constraints(cyl, source, target))
    d_tps = shape_distortion(cyl.directrix, tps.directrix)
    d_lte = shape_distortion(cyl.directrix, lte.directrix)
    print(f"far target (0.54 m): shape distortion TPS {d_tps:.4f}, LTE {d_lte:.2e}")
    assert np.linalg.norm(tps.directrix[-1] - target[1]) < 1e-3
    assert np.linalg.norm(lte.directrix[-1] - target[1]) < 1e-3
    assert d_lte < 0.1 * d_tps
