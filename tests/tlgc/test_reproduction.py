"""Reproduction (fixed and adaptive ratio, eq. 8-10) and random starts."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import load_demonstrations, make_demonstrations
from tlgc import (CROSS_SECTION_TYPES, TLGCArgumentError, StartOffPlaneError, StartOutsideError,
                  fit_cylinder, random_starts, ratio_schedule, reproduce, start_coordinates)

KINDS = sorted(CROSS_SECTION_TYPES)


@pytest.fixture(scope="module")
def cylinders() -> dict:
    demos = make_demonstrations("needle_threading", num_demos=4, num_points=400, seed=2).positions
    return {kind: fit_cylinder(demos, kind) for kind in KINDS}


def own_ratios(cyl, reproductions: np.ndarray) -> np.ndarray:
    """Ratio (R, N) of reproduction point k to the boundary of section k."""
    return cyl.ratio(reproductions, np.arange(cyl.num_sections)[None, :])


def check_reproductions(cyl, starts: np.ndarray) -> None:
    """Fixed ratio is kept; convergent/divergent end on the directrix / boundary (1 mm)."""
    _, eta0 = start_coordinates(cyl, starts)
    fixed = reproduce(cyl, starts)
    ratio = own_ratios(cyl, fixed)
    assert ratio.max() <= 1.0
    np.testing.assert_allclose(ratio, np.broadcast_to(eta0[:, None], ratio.shape), atol=1e-9)
    np.testing.assert_allclose(fixed[:, 0], starts, atol=1e-12)
    convergent = reproduce(cyl, starts, eta_final=0.0)
    assert own_ratios(cyl, convergent).max() <= 1.0
    assert np.linalg.norm(convergent[:, -1] - cyl.directrix[-1], axis=1).max() < 1e-3
    divergent = reproduce(cyl, starts, eta_final=1.0)
    assert own_ratios(cyl, divergent).max() <= 1.0
    end = cyl.to_local(divergent[:, -1], np.full(len(starts), cyl.num_sections - 1))
    gap = cyl.radius(np.full(len(starts), cyl.num_sections - 1), np.arctan2(end[:, 1], end[:, 0])) \
        - np.linalg.norm(end, axis=1)
    assert gap.min() >= 0.0 and gap.max() < 1e-3


@pytest.mark.parametrize("dataset", ["needle_threading", "pick_place"])
@pytest.mark.parametrize("kind", KINDS)
def test_real_data_reproductions_stay_inside_and_converge_or_diverge(shared_dataset, dataset, kind):
    cyl = fit_cylinder(load_demonstrations(shared_dataset(dataset)), kind)
    check_reproductions(cyl, random_starts(cyl, 100, rng=np.random.default_rng(11)))


@pytest.mark.parametrize("kind", KINDS)
def test_synthetic_reproductions_stay_inside_and_converge_or_diverge(cylinders, kind):
    cyl = cylinders[kind]
    check_reproductions(cyl, random_starts(cyl, 100, rng=3))


def test_ratio_schedule_follows_equation_10():
    u = np.linspace(0.0, 1.0, 11)
    eta0 = np.array([0.2, 0.9])
    eta = ratio_schedule(eta0, u, 0.5, 3.0)
    np.testing.assert_allclose(eta, (eta0[:, None] - 0.5) * np.exp(-3.0 * u) + 0.5)
    np.testing.assert_allclose(ratio_schedule(eta0, u, None, 3.0), np.repeat(eta0[:, None], 11, 1))


def test_adaptive_reproduction_has_the_scheduled_ratio(cylinders):
    cyl = cylinders["spline"]
    starts = random_starts(cyl, 5, rng=0)
    _, eta0 = start_coordinates(cyl, starts)
    out = reproduce(cyl, starts, eta_final=0.3, gamma=4.0)
    np.testing.assert_allclose(own_ratios(cyl, out), ratio_schedule(eta0, cyl.arc_length, 0.3, 4.0),
                               atol=1e-9)


def test_reproduction_keeps_the_local_angle(cylinders):
    cyl = cylinders["ellipse"]
    starts = random_starts(cyl, 20, rng=5)
    angle, _ = start_coordinates(cyl, starts)
    out = reproduce(cyl, starts, eta_final=0.8)
    local = cyl.to_local(out, np.arange(cyl.num_sections)[None, :])
    np.testing.assert_allclose(np.cos(np.arctan2(local[..., 1], local[..., 0]) - angle[:, None]), 1.0,
                               atol=1e-9)


def test_single_start_and_starts_off_the_first_plane(cylinders):
    cyl = cylinders["circle"]
    start = random_starts(cyl, 1, rng=9)[0]
    single = reproduce(cyl, start)
    assert single.shape == (cyl.num_sections, 3)
    np.testing.assert_allclose(reproduce(cyl, cyl.directrix[0]), cyl.directrix, atol=1e-12)
    # Within the stated tolerance (1 mm) a start is taken in the plane ...
    near = reproduce(cyl, start + 0.5e-3 * cyl.tangents[0])
    np.testing.assert_allclose(near, single, atol=1e-12)
    # ... farther ones are refused with their distance, before or past the plane.
    with raises_naming(StartOffPlaneError, "starts[1]", "0.05 m"):
        reproduce(cyl, np.stack([start, start + 0.05 * cyl.tangents[0]]))
    with raises_naming(StartOffPlaneError, "starts[0]", "0.2 m"):
        reproduce(cyl, start - 0.2 * cyl.tangents[0])
    assert issubclass(StartOffPlaneError, StartOutsideError)
    # A caller who wants the old projection asks for it explicitly.
    lifted = reproduce(cyl, start + 0.05 * cyl.tangents[0], plane_tolerance=np.inf)
    np.testing.assert_allclose(lifted, single, atol=1e-12)
    looser = reproduce(cyl, start + 0.05 * cyl.tangents[0], plane_tolerance=0.06)
    np.testing.assert_allclose(looser, single, atol=1e-12)
    with raises_naming(TLGCArgumentError, "plane_tolerance"):
        reproduce(cyl, start, plane_tolerance=-1.0)


def test_reproduced_points_are_inside_the_cylinder_by_containment(cylinders):
    for kind, cyl in cylinders.items():
        reps = reproduce(cyl, random_starts(cyl, 20, rng=4), eta_final=1.0)
        c = cyl.containment(reps.reshape(-1, 3))
        assert c.inside.all(), kind
        np.testing.assert_array_equal(c.offset, 0.0)


def test_start_outside_is_refused_unless_allowed(cylinders):
    cyl = cylinders["spline"]
    inside = random_starts(cyl, 3, rng=1)
    outside = cyl.directrix[0] + 1.5 * (inside[0] - cyl.directrix[0]) / \
        cyl.ratio(inside[0], 0)
    with raises_naming(StartOutsideError, "starts[1]", "allow_outside"):
        reproduce(cyl, np.stack([inside[1], outside]))
    out = reproduce(cyl, outside, allow_outside=True)
    np.testing.assert_allclose(cyl.ratio(out, np.arange(cyl.num_sections)), 1.5, atol=1e-9)


def test_random_starts_are_seeded_inside_and_uniform_in_area(cylinders):
    cyl = cylinders["circle"]
    a = random_starts(cyl, 4000, rng=np.random.default_rng(1))
    np.testing.assert_array_equal(a, random_starts(cyl, 4000, rng=1))
    assert not np.array_equal(a, random_starts(cyl, 4000, rng=2))
    ratio = cyl.ratio(a, np.zeros(4000, int))
    assert ratio.max() <= 1.0
    # Uniform in a disc: P(ratio <= s) = s^2; 4000 samples -> standard error ~0.008.
    for s in (0.3, 0.5, 0.8):
        assert abs(np.mean(ratio <= s) - s**2) < 0.03
    np.testing.assert_allclose(cyl.to_local(a, np.zeros(4000, int)).mean(axis=0), 0.0,
                               atol=0.05 * cyl.radius(0, 0.0))
    spline = cylinders["spline"]
    later = random_starts(spline, 50, rng=0, index=100)
    assert spline.ratio(later, np.full(50, 100)).max() <= 1.0
    assert random_starts(spline, 0, rng=0).shape == (0, 3)


def test_bad_arguments_raise_clear_errors(cylinders):
    cyl = cylinders["circle"]
    start = cyl.directrix[0]
    with raises_naming(TLGCArgumentError, "starts"):
        reproduce(cyl, np.zeros((2, 2)))
    with raises_naming(TLGCArgumentError, "starts"):
        reproduce(cyl, np.array([np.nan, 0.0, 0.0]))
    with raises_naming(TLGCArgumentError, "gamma"):
        reproduce(cyl, start, eta_final=0.0, gamma=-1.0)
    with raises_naming(TLGCArgumentError, "eta_final"):
        reproduce(cyl, start, eta_final=1.5)
    with raises_naming(TLGCArgumentError, "cyl"):
        reproduce("cylinder", start)
    with raises_naming(TLGCArgumentError, "rng"):
        random_starts(cyl, 3, rng=None)
    with raises_naming(TLGCArgumentError, "count"):
        random_starts(cyl, -1, rng=0)
    with raises_naming(TLGCArgumentError, "index"):
        random_starts(cyl, 3, rng=0, index=cyl.num_sections)
