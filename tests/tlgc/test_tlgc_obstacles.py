"""Obstacles and generalized cylinders (paper section 7): known obstacles, methods I and II."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from scenes import Box, Sphere, load_demonstrations, make_demonstrations
from tlgc.bounding_sphere import BoundingSphere
from tlgc.cylinder import fit_cylinder
from tlgc.errors import TLGCArgumentError
from tlgc.obstacles import (ObstacleAvoidanceError, adaptive_ratio_parameters,
                            avoid_with_adaptive_ratio, avoid_with_deformation, cylinder_clearance,
                            cylinder_intersects)
from tlgc.reproduction import random_starts, reproduce

RADIUS = 0.1          # [m] of the straight test cylinder
LENGTH = 1.0          # [m]


@pytest.fixture(scope="module")
def straight_cylinder():
    """Four straight demonstrations along x at (y, z) = (+-r, 0), (0, +-r): circle radius r."""
    x = np.linspace(0.0, LENGTH, 201)
    offsets = [(RADIUS, 0), (-RADIUS, 0), (0, RADIUS), (0, -RADIUS)]
    demos = np.stack([np.stack([x, np.full_like(x, a), np.full_like(x, b)], axis=1)
                      for a, b in offsets])
    return fit_cylinder(demos, "circle")


@pytest.fixture(scope="module")
def reach_cylinder():
    return fit_cylinder(make_demonstrations("reach_from_above", num_demos=5, num_points=300,
                                            seed=1), "spline")


def test_known_obstacle_circle_sections_can_enclose_what_demos_avoided():
    # Demonstrations spread along y and barely along z: a circle encloses space above them.
    x = np.linspace(0.0, 1.0, 101)
    offsets = [(0.1, 0.0), (-0.1, 0.0), (0.0, 0.02), (0.0, -0.02)]
    demos = np.stack([np.stack([x, np.full_like(x, a), np.full_like(x, b)], axis=1)
                      for a, b in offsets])
    obstacle = Sphere([0.5, 0.0, 0.06], 0.02)
    assert np.all(obstacle.distance(demos) > 0.0)           # the teacher avoided it
    assert cylinder_intersects(fit_cylinder(demos, "circle"), obstacle)
    spline = fit_cylinder(demos, "spline")
    assert not cylinder_intersects(spline, obstacle)
    assert cylinder_clearance(spline, obstacle) > 0.0
    assert not cylinder_intersects(spline, Box([0.5, 0.0, 0.3], [0.1, 0.1, 0.1]))


def test_clearance_matches_geometry(straight_cylinder):
    # A sphere above the straight cylinder: gap = centre height - radius - R.
    clear = cylinder_clearance(straight_cylinder, ([0.5, 0.0, 0.3], 0.05), num_angles=360)
    assert clear == pytest.approx(0.3 - 0.05 - RADIUS, abs=1e-4)
    assert cylinder_intersects(straight_cylinder, BoundingSphere(np.array([0.5, 0.0, 0.0]), 0.01))


def test_adaptive_ratio_parameters_match_the_plane_geometry(straight_cylinder):
    cyl = straight_cylinder
    k0 = 0
    start = cyl.directrix[k0] + 0.5 * RADIUS * cyl.normals[k0]
    # Sphere on the start's ray at 0.6 R from the axis, radius 0.2 R: passing inside touches it
    # at ratio 0.4 (the paper's eta_f, nearer eta0 = 0.5 than passing outside at 0.8); eta_f
    # lies the critical fraction below it, so every sample the sphere blocks stays below 0.4.
    mid = len(cyl.directrix) // 2
    centre = cyl.directrix[mid] + 0.6 * RADIUS * cyl.normals[mid]
    params = adaptive_ratio_parameters(cyl, start, (centre, 0.2 * RADIUS), critical_fraction=0.03)
    assert params.passes == "inside"
    assert params.eta0 == pytest.approx(0.5)
    assert params.edge == pytest.approx(0.4, abs=1e-9)
    assert params.eta_final == pytest.approx(0.4 * 0.97, abs=1e-9)
    u_c = (0.5 * LENGTH - 0.2 * RADIUS) / LENGTH          # normalised arc length where it begins
    assert u_c <= params.critical_arc_length <= u_c + 1.0 / 200 + 1e-12   # first section it cuts
    eta = params.eta_final + (params.eta0 - params.eta_final) * np.exp(-params.gamma * cyl.arc_length)
    assert eta[params.section] <= 0.4 + 1e-12                  # at the section that sets the edge
    # gamma is the smallest decay that does it: the schedule touches some blocked section's edge.
    x = cyl.directrix[:, 0]
    blocked = np.abs(x - 0.5 * LENGTH) < 0.2 * RADIUS
    entry = (0.6 * RADIUS - np.sqrt((0.2 * RADIUS) ** 2 - (x[blocked] - 0.5 * LENGTH) ** 2)) / RADIUS
    assert np.all(eta[blocked] <= entry + 1e-12)
    assert np.min(entry - eta[blocked]) < 1e-9
    outside = adaptive_ratio_parameters(cyl, cyl.directrix[0] + 0.75 * RADIUS * cyl.normals[0],
                                        (centre, 0.2 * RADIUS))
    assert outside.passes == "outside" and outside.edge == pytest.approx(0.8, abs=1e-9)
    assert outside.eta_final == pytest.approx(0.8 * 1.03, abs=1e-9)


def test_adaptive_ratio_errors(straight_cylinder):
    cyl = straight_cylinder
    start = cyl.directrix[0] + 0.5 * RADIUS * cyl.normals[0]
    with raises_naming(ObstacleAvoidanceError, "obstacle"):
        adaptive_ratio_parameters(cyl, start, ([0.5, 0.0, 1.0], 0.05))
    with raises_naming(ObstacleAvoidanceError, "obstacle"):
        adaptive_ratio_parameters(cyl, start, ([0.5, 0.0, 0.0], 0.15))
    with raises_naming(TLGCArgumentError, "critical_fraction"):
        adaptive_ratio_parameters(cyl, start, ([0.5, 0.0, 0.0], 0.01), critical_fraction=2.0)
    with raises_naming(TLGCArgumentError, "obstacle"):
        adaptive_ratio_parameters(cyl, start, "a rock")


def _check_method_one(cyl, starts, radius, index):
    fixed = reproduce(cyl, starts)
    for j, start in enumerate(starts):
        sphere = BoundingSphere(fixed[j, index], radius)
        result = avoid_with_adaptive_ratio(cyl, start, sphere)
        assert result.fixed_clearance < 0.0                        # the fixed-ratio one collides
        assert np.all(sphere.distance(result.fixed_reproduction) >= -radius - 1e-12)
        assert np.min(np.linalg.norm(result.reproduction - sphere.center, axis=1)) >= radius
        assert result.clearance >= 0.0
        np.testing.assert_allclose(result.reproduction[0], result.fixed_reproduction[0], atol=1e-12)
        ratio = cyl.ratio(result.reproduction, np.arange(cyl.num_sections))
        assert np.all(ratio <= 1.0 + 1e-9)                       # stays inside the cylinder


def test_method_one_clears_sphere_on_synthetic_skill(reach_cylinder):
    starts = random_starts(reach_cylinder, 4, rng=7)
    _check_method_one(reach_cylinder, starts, 0.006, 60)


def test_method_one_clears_sphere_on_pick_place(shared_dataset):
    cyl = fit_cylinder(load_demonstrations(shared_dataset("pick_place")), "spline")
    starts = random_starts(cyl, 3, rng=11)
    _check_method_one(cyl, starts, 0.03, 700)


def test_method_one_safety_distance(reach_cylinder):
    start = random_starts(reach_cylinder, 4, rng=7)[1]
    sphere = BoundingSphere(reproduce(reach_cylinder, start)[60], 0.005)
    result = avoid_with_adaptive_ratio(reach_cylinder, start, sphere, safety=0.003)
    assert np.min(np.linalg.norm(result.reproduction - sphere.center, axis=1)) >= 0.008


def test_method_two_deforms_cylinder_clear_of_sphere(reach_cylinder):
    cyl = reach_cylinder
    mid = cyl.num_sections // 2
    sphere = BoundingSphere(cyl.directrix[mid] + 0.02 * cyl.normals[mid], 0.02)
    result = avoid_with_deformation(cyl, sphere)
    assert result.original_clearance < 0.0
    assert result.clearance >= 0.0
    assert cylinder_clearance(result.cylinder, sphere) >= 0.0
    np.testing.assert_allclose(result.cylinder.directrix[[0, -1]], cyl.directrix[[0, -1]], atol=1e-12)
    # every reproduction of the deformed cylinder avoids the obstacle
    out = reproduce(result.cylinder, random_starts(result.cylinder, 20, rng=0))
    assert np.all(sphere.distance(out) >= 0.0)
    # an obstacle the cylinder already clears leaves it untouched
    far = avoid_with_deformation(cyl, BoundingSphere(cyl.directrix[mid] + [0, 0, 1.0], 0.02))
    assert far.cylinder is cyl and far.constraints == {}
