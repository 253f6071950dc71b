"""Cross-section boundaries: enclosure, tightness, analytic shapes, spline continuity, edge cases."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from tlgc.cross_sections import (CROSS_SECTION_TYPES, MIN_RADIUS, CircleSections, EllipseSections,
                                 SplineSections, cross_section_type, fit_cross_sections, polar)
from tlgc.errors import TLGCArgumentError, UnknownCrossSectionError

KINDS = sorted(CROSS_SECTION_TYPES)


def centred_points(rng: np.random.Generator, num_demos: int = 5, num_sections: int = 40) -> np.ndarray:
    """Random effective points (M, N, 2) [m] whose centroid in every section is the origin."""
    scale = rng.uniform(0.01, 0.2, size=(1, num_sections, 2))
    p = rng.normal(size=(num_demos, num_sections, 2)) * scale
    return p - p.mean(axis=0)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("num_demos", [2, 3, 4, 7])
def test_boundary_encloses_every_point_and_touches_the_farthest(kind, num_demos):
    points = centred_points(np.random.default_rng(num_demos), num_demos)
    sections = fit_cross_sections(kind, points)
    ratio = sections.ratio(np.arange(points.shape[1])[None, :], points)
    assert ratio.max() <= 1.0 + 1e-9
    np.testing.assert_allclose(ratio.max(axis=0), 1.0, atol=1e-9)


@pytest.mark.parametrize("kind", KINDS)
def test_boundary_is_positive_and_radius_broadcasts(kind):
    points = centred_points(np.random.default_rng(1))
    sections = fit_cross_sections(kind, points)
    angles = np.linspace(0.0, 2 * np.pi, 721)
    r = sections.radius(np.arange(40)[:, None], angles[None, :])
    assert r.shape == (40, 721) and np.all(r > 0)
    np.testing.assert_allclose(r[:, 0], r[:, -1], rtol=1e-12)          # periodic
    assert sections.radius(3, 0.5).shape == ()
    np.testing.assert_allclose(sections.radius(np.array([3, 3]), np.array([0.5, 0.5 + 2 * np.pi])),
                               sections.radius(3, 0.5), rtol=1e-12)       # any angle is wrapped
    assert sections.boundary(16).shape == (40, 16, 2)


def test_circle_radius_is_the_farthest_point():
    points = centred_points(np.random.default_rng(2))
    sections = CircleSections.fit(points)
    np.testing.assert_allclose(sections.radii, np.linalg.norm(points, axis=2).max(axis=0))


def test_ellipse_recovers_an_ellipse_sampled_symmetrically():
    a, b, phi = 0.3, 0.1, 0.4
    v = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    local = np.stack([a * np.cos(v), b * np.sin(v)], axis=1)
    rot = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    points = (local @ rot.T)[:, None, :]                                  # (8, 1, 2)
    sections = EllipseSections.fit(points)
    np.testing.assert_allclose([sections.major[0], sections.minor[0]], [a, b], rtol=1e-12)
    assert np.isclose(np.mod(sections.orientation[0] - phi, np.pi), 0.0, atol=1e-12) or \
        np.isclose(np.mod(sections.orientation[0] - phi, np.pi), np.pi, atol=1e-12)
    theta = np.linspace(0.0, 2 * np.pi, 50)
    expected = a * b / np.hypot(b * np.cos(theta - phi), a * np.sin(theta - phi))
    np.testing.assert_allclose(sections.radius(np.zeros(50, int), theta), expected, rtol=1e-12)


def test_ellipse_of_collinear_points_is_thin_but_valid():
    points = np.array([[[0.1, 0.1]], [[-0.1, -0.1]]])
    sections = EllipseSections.fit(points)
    assert sections.minor[0] > 0 and sections.minor[0] / sections.major[0] < 2e-3
    np.testing.assert_allclose(sections.ratio(np.zeros((2, 1), int), points), 1.0, atol=1e-12)


def test_spline_passes_through_points_and_is_c2_periodic_at_the_knots():
    rng = np.random.default_rng(3)
    angles = np.sort(rng.uniform(0, 2 * np.pi, 6))
    radii = rng.uniform(0.05, 0.08, 6)
    points = (radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], 1))[:, None, :]
    sections = SplineSections.fit(points)
    np.testing.assert_allclose(sections.radius(np.zeros(6, int), angles), radii, rtol=1e-13)
    # Value, slope and curvature at the end of each piece equal those at the next piece's start.
    c, h = sections.coefficients[0], np.diff(sections.breaks[0])
    end_value = ((c[:, 3] * h + c[:, 2]) * h + c[:, 1]) * h + c[:, 0]
    end_slope = (3 * c[:, 3] * h + 2 * c[:, 2]) * h + c[:, 1]
    end_second = 6 * c[:, 3] * h + 2 * c[:, 2]
    scale = np.abs(c).max()
    np.testing.assert_allclose(end_value, np.roll(c[:, 0], -1), atol=1e-12 * scale)
    np.testing.assert_allclose(end_slope, np.roll(c[:, 1], -1), atol=1e-12 * scale)
    np.testing.assert_allclose(end_second, np.roll(2 * c[:, 2], -1), atol=1e-12 * scale)
    # The evaluated boundary is continuous across each knot.
    eps = 1e-9
    left = sections.radius(np.zeros(6, int), angles - eps)
    right = sections.radius(np.zeros(6, int), angles + eps)
    np.testing.assert_allclose(left, right, atol=1e-8 * radii.max())


def test_spline_stays_positive_when_one_point_is_near_the_centre():
    angles = np.array([0.1, 1.5, 1.7, 3.5, 5.0])
    radii = np.array([0.2, 0.2, 1e-4, 0.2, 0.2])
    points = (radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], 1))[:, None, :]
    sections = SplineSections.fit(points)
    r = sections.radius(np.zeros(20000, int), np.linspace(0, 2 * np.pi, 20000))
    assert r.min() > 0.5 * 1e-4
    np.testing.assert_allclose(sections.radius(np.zeros(5, int), angles), radii, rtol=1e-12)


def test_spline_handles_duplicates_centre_points_and_empty_sections():
    duplicate = np.array([[0.1, 0.0], [0.2, 0.0], [-0.15, 0.05], [0.0, -0.1], [0.0, 0.0]])
    empty = np.zeros((5, 2))
    points = np.stack([duplicate, empty, np.roll(duplicate, 1, axis=0)], axis=1)   # (5, 3, 2)
    sections = SplineSections.fit(points)
    ratio = sections.ratio(np.arange(3)[None, :], points)
    assert ratio[:, [0, 2]].max() <= 1 + 1e-12
    np.testing.assert_allclose(ratio[:, [0, 2]].max(axis=0), 1.0, atol=1e-12)
    np.testing.assert_allclose(ratio[0, 0], 0.5, atol=1e-12)          # the shadowed duplicate
    np.testing.assert_allclose(sections.radius(np.ones(7, int), np.linspace(0, 6, 7)), MIN_RADIUS)


FD_STEP = 1e-6     # [rad] central-difference step for the slope checks


def central_difference(sections, index: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(r(angle + h) - r(angle - h)) / 2h [m/rad]."""
    return (sections.radius(index, angle + FD_STEP) - sections.radius(index, angle - FD_STEP)) / (2 * FD_STEP)


def check_slope_matches_finite_differences(sections, rng: np.random.Generator) -> None:
    """Analytic slope vs central differences at random angles (N, 25), tolerance 1e-6 of r."""
    n = sections.num_sections
    index = np.arange(n)[:, None]
    angle = rng.uniform(-1.0, 2 * np.pi + 1.0, size=(n, 25))       # also outside [0, 2 pi)
    slope = sections.radius_derivative(index, angle)
    assert slope.shape == (n, 25) and np.all(np.isfinite(slope))
    scale = sections.radius(index, angle).max(axis=1, keepdims=True)
    np.testing.assert_allclose(slope / scale, central_difference(sections, index, angle) / scale,
                               rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("kind", KINDS)
def test_radius_derivative_matches_central_differences(kind):
    rng = np.random.default_rng(6)
    sections = fit_cross_sections(kind, centred_points(rng))
    check_slope_matches_finite_differences(sections, rng)
    assert sections.radius_derivative(3, 0.5).shape == ()
    if kind != "circle":                                           # a real slope is tested
        assert np.abs(sections.radius_derivative(np.arange(40), 0.5)).max() > 1e-3


@pytest.mark.parametrize("kind", KINDS)
def test_radius_derivative_is_periodic(kind):
    sections = fit_cross_sections(kind, centred_points(np.random.default_rng(7)))
    index = np.arange(40)
    np.testing.assert_allclose(sections.radius_derivative(index, 2 * np.pi),
                               sections.radius_derivative(index, 0.0), rtol=1e-9, atol=1e-12)
    # The one-sided slopes just below 2 pi and just above 0 agree (no kink at the wrap).
    scale = sections.radius(index, 0.0).max()
    np.testing.assert_allclose(sections.radius_derivative(index, 2 * np.pi - 1e-9),
                               sections.radius_derivative(index, 1e-9), atol=1e-6 * scale)


def test_ellipse_radius_derivative_matches_its_closed_form():
    a, b, phi = 0.3, 0.1, 0.4
    sections = EllipseSections(np.array([a]), np.array([b]), np.array([phi]))
    theta = np.linspace(0.0, 2 * np.pi, 50)
    u = theta - phi      # r = a b / sqrt(b^2 cos^2 u + a^2 sin^2 u)
    expected = -a * b * (a * a - b * b) * np.sin(u) * np.cos(u) / (
        (b * np.cos(u)) ** 2 + (a * np.sin(u)) ** 2) ** 1.5
    np.testing.assert_allclose(sections.radius_derivative(np.zeros(50, int), theta), expected,
                               rtol=1e-12, atol=1e-14)


def test_spline_radius_derivative_of_shape_preserving_and_degenerate_sections():
    # Section 0 falls back to the C1 shape-preserving spline (a point near the centre);
    # section 1 is regular (C2); section 2 holds duplicate and centre points (zero-width pieces).
    angles = np.array([0.1, 1.5, 1.7, 3.5, 5.0])
    radii = np.array([0.2, 0.2, 1e-4, 0.2, 0.2])
    c1 = radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], 1)
    c2 = np.roll(c1, 2, axis=0) * np.array([1.0, 0.5]) + 0.3 * np.ones(2)
    c2 -= c2.mean(axis=0)
    duplicate = np.array([[0.1, 0.0], [0.2, 0.0], [-0.15, 0.05], [0.0, -0.1], [0.0, 0.0]])
    sections = SplineSections.fit(np.stack([c1, c2, duplicate], axis=1))
    rng = np.random.default_rng(8)
    check_slope_matches_finite_differences(sections, rng)
    # The C1 section: its slope is continuous at the knots, although its curvature is not.
    knots = np.sort(angles)
    left = sections.radius_derivative(np.zeros(5, int), knots - 1e-9)
    right = sections.radius_derivative(np.zeros(5, int), knots + 1e-9)
    np.testing.assert_allclose(left, right, atol=1e-6)


@pytest.mark.parametrize("kind", KINDS)
def test_arrays_round_trip_and_select(kind):
    points = centred_points(np.random.default_rng(4))
    sections = fit_cross_sections(kind, points)
    copy = cross_section_type(kind).from_arrays(sections.to_arrays())
    angles = np.random.default_rng(5).uniform(0, 7, size=(40, 9))
    np.testing.assert_array_equal(copy.radius(np.arange(40)[:, None], angles),
                                  sections.radius(np.arange(40)[:, None], angles))
    part = sections.select(np.array([5, 2]))
    np.testing.assert_array_equal(part.radius(np.array([0, 1]), angles[0, :2]),
                                  sections.radius(np.array([5, 2]), angles[0, :2]))


def test_errors_name_the_argument():
    with raises_naming(UnknownCrossSectionError, "cross_section"):
        cross_section_type("square")
    sections = CircleSections(np.ones(3))
    with raises_naming(TLGCArgumentError, "index"):
        sections.radius(3, 0.0)
    with raises_naming(TLGCArgumentError, "index"):
        sections.radius(0.5, 0.0)
    with raises_naming(TLGCArgumentError, "index"):
        sections.radius_derivative(np.array([0, 3]), 0.0)
    with raises_naming(TLGCArgumentError, "radii"):
        CircleSections(np.array([1.0, -1.0]))
    with raises_naming(TLGCArgumentError, "breaks"):
        SplineSections(np.zeros((2, 3)), np.zeros((2, 2, 4)))


def test_polar_angles_lie_in_zero_two_pi():
    r, a = polar(np.array([[1.0, 0.0], [0.0, -2.0], [-1.0, -1e-300]]))
    np.testing.assert_allclose(r, [1.0, 2.0, 1.0])
    assert np.all((a >= 0) & (a < 2 * np.pi))
