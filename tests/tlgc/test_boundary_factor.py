"""The TLGC boundary factor for CLAMP: distance, hinge, the family's arguments, the demo.

The family's Jacobians and GTSAM adapters are checked with every other family in
tests/clamp/factors/test_families.py."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from robots import load_robot
from clamp.factors import StateWindow
from tlgc.boundary_factor import (BoundaryFamily, boundary_distance, boundary_residuals,
                                  section_indices)
from tlgc.cylinder import fit_cylinder
from tlgc.errors import TLGCArgumentError

T = 12


def _tube(path: np.ndarray, cross_section: str, spread: float = 0.02) -> object:
    """Cylinder around a path (N,3) from five offset copies (uneven, so shapes are not round)."""
    offsets = spread * np.array([[1, 0, 0], [0, 1.5, 0], [-0.7, -0.4, 1], [0, 0, -0.5], [-1, 0.3, 0]])
    return fit_cylinder(path[None] + offsets[:, None], cross_section)


def _robot_setup(name: str, seed: int, cross_section: str = "spline"):
    robot = load_robot(name)
    rng = np.random.default_rng(seed)
    a, b = robot.random_configuration(rng), robot.random_configuration(rng)
    q_path = a + np.linspace(0, 1, T)[:, None] * (b - a)
    cyl = _tube(robot.fk(q_path), cross_section)
    q = q_path + 0.15 * rng.standard_normal(q_path.shape)   # pushes the end effector outside
    return robot, cyl, q


def test_section_indices_match_normalised_index():
    np.testing.assert_array_equal(section_indices(np.arange(5), 5, 101), [0, 25, 50, 75, 100])
    np.testing.assert_array_equal(section_indices(np.arange(3), 3, 3), [0, 1, 2])
    assert section_indices(np.array(0), 1, 50) == 0
    with raises_naming(TLGCArgumentError, "index"):
        section_indices(np.array([5]), 5, 10)
    with raises_naming(TLGCArgumentError, "num_states"):
        section_indices(np.array([0]), 0, 10)


@pytest.mark.parametrize("cross_section", ["circle", "ellipse", "spline"])
def test_distance_gradient_matches_finite_differences(cross_section):
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, 40)
    path = np.stack([t, 0.2 * np.sin(2 * t), 0.1 * t], axis=1)
    cyl = _tube(path, cross_section)
    k = rng.integers(0, 40, 25)
    p = cyl.directrix[k] + rng.normal(scale=0.04, size=(25, 3))
    d = boundary_distance(cyl, k, p)
    step = 1e-6
    fd = np.stack([(boundary_distance(cyl, k, p + step * e).distance
                    - boundary_distance(cyl, k, p - step * e).distance) / (2 * step)
                   for e in np.eye(3)], axis=1)
    np.testing.assert_allclose(d.gradient, fd, atol=2e-6)
    # distance = rho - r(angle): points on the boundary have distance 0
    local = d.rho[:, None] * np.stack([np.cos(d.angle), np.sin(d.angle)], axis=1)
    on = cyl.to_world(local * (cyl.radius(k, d.angle) / d.rho)[:, None], k)
    np.testing.assert_allclose(boundary_distance(cyl, k, on).distance, 0.0, atol=1e-12)


def test_hinge_is_zero_inside_and_counts_margin():
    t = np.linspace(0, 1, 30)
    cyl = _tube(np.stack([t, 0 * t, 0 * t], axis=1), "circle")
    k = np.array([15, 15, 15])
    r = float(cyl.radius(15, 0.0))
    p = cyl.directrix[k] + np.array([[0, 0, 0.5 * r], [0, 0, 1.5 * r], [0, 0, 0.0]])
    h, grad = boundary_residuals(cyl, k, p)
    assert h[0] == 0.0 and h[2] == 0.0 and np.all(grad[[0, 2]] == 0.0)
    assert h[1] == pytest.approx(0.5 * r)
    h_margin, _ = boundary_residuals(cyl, k, p, margin=0.6 * r)
    assert h_margin[0] == pytest.approx(0.1 * r) and h_margin[1] == pytest.approx(1.1 * r)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_family_residual_is_the_hinge_of_the_end_effector_position(name):
    robot, cyl, q = _robot_setup(name, seed=1)
    family = BoundaryFamily(cyl, T, margin=0.004, sigma=0.02)
    theta = np.concatenate([q, np.zeros_like(q)], axis=1)
    lin = family.residual(StateWindow(robot, theta), np.arange(T), True)
    sections = section_indices(np.arange(T), T, cyl.num_sections)
    h, _ = boundary_residuals(cyl, sections, robot.fk(q), margin=0.004)
    full = np.zeros(T)
    full[lin.rows] = lin.error[:, 0]                    # inactive hinges may be left out
    np.testing.assert_allclose(full, h, atol=1e-12)
    assert np.all(lin.error[:, 0] > 0.0)
    assert np.count_nonzero(h) >= T // 2                # most states are outside: hinge active
    assert np.all(lin.jacobian[:, :, robot.n:] == 0.0)  # velocities do not enter
    assert family.error(StateWindow(robot, theta)) == pytest.approx(0.5 * np.sum((h / 0.02) ** 2))


def test_family_restricts_states_and_checks_arguments():
    robot, cyl, _ = _robot_setup("jaco", seed=3)
    family = BoundaryFamily(cyl, T, states=[0, 5, 5, 40])
    np.testing.assert_array_equal(family.first, [0, 5])
    np.testing.assert_array_equal(family.sections, section_indices(np.array([0, 5]), T,
                                                                  cyl.num_sections))
    with raises_naming(TLGCArgumentError, "cylinder"):
        BoundaryFamily("tube", T)
    with raises_naming(TLGCArgumentError, "sigma"):
        BoundaryFamily(cyl, T, sigma=0.0)
    with raises_naming(TLGCArgumentError, "num_states"):
        BoundaryFamily(cyl, 0)
    with raises_naming(TLGCArgumentError, "states"):
        BoundaryFamily(cyl, T, states=["a"])


def test_clamp_plan_stays_inside_cylinder_with_the_factor():
    pytest.importorskip("clamp.planning.planner", reason="needs the CLAMP planner")
    from tlgc.demo_clamp_cylinder import run_clamp_cylinder_demo

    demo = run_clamp_cylinder_demo("reach_from_above", "jaco", num_states=40, goal_offset=0.05)
    print(f"inside the cylinder: without factor {demo.fraction_inside_without:.3f}, "
          f"with factor {demo.fraction_inside_with:.3f}")
    assert demo.without_factor.success
    # the goal lies 5 cm outside where the demonstrations agree (5 mm): kept inside the
    # cylinder until the end, the plan jumps to it over the last states. Judged against the
    # prior conditioned on the goal (which spreads the goal's pull along the whole path) it
    # would leave the skill; it is judged against where the skill goes under the caller's
    # boundary (issue 27), which it follows
    assert demo.with_factor.success, demo.with_factor.reasons
    assert demo.with_factor.skill["reference"] == (
        "prior conditioned on start and goal, under the caller's families: tlgc_boundary")
    assert demo.without_factor.skill["reference"] == "prior conditioned on start and goal"
    assert demo.with_factor.skill["max_tube_ratio"] < 1.0
    assert demo.fraction_inside_with >= 0.85
    assert demo.fraction_inside_with > demo.fraction_inside_without + 0.3
    # with the factor, only the states near the (outside) goal leave the cylinder
    outside = np.flatnonzero(demo.outside_with > 1e-3)
    assert outside.min() >= 0.85 * len(demo.outside_with)


def test_the_boundary_reference_is_where_the_skill_goes_inside_the_cylinder():
    """The verdict's reference under the boundary (clamp.planning.reference.skill_reference):
    the MAP of the conditioned workspace prior and the hinge, inside the cylinder where the
    conditioned mean leaves it; a boundary that holds on the conditioned mean leaves the
    reference the conditioned prior itself (the verdict as without it)."""
    from clamp import PlannerConfig, learn_prior
    from clamp.planning.reference import ReferenceUnderFamilies, skill_reference
    from clamp.planning.request import make_request
    from robots import load_robot
    from scenes import make_demonstrations
    from tlgc.demo_clamp_cylinder import outside_distances

    T = 40
    demos = make_demonstrations("reach_from_above", num_demos=6, num_points=T,
                                dt=0.16 * 250 / T, seed=0)
    prior, robot, config = learn_prior(demos, jitter=1e-4), load_robot("jaco"), PlannerConfig()
    cyl = fit_cylinder(demos, "spline")
    start = cyl.directrix[0] + 0.3 * cyl.radius(0, 0.0) * cyl.normals[0]
    goal = cyl.directrix[-1] + (cyl.radius(cyl.num_sections - 1, 0.0) + 0.05) * cyl.normals[-1]
    request = make_request(prior, robot, start, goal, (), config)
    plain, name = skill_reference(prior, robot, request, config)
    assert name == "prior conditioned on start and goal"
    bounded, name = skill_reference(prior, robot, request, config,
                                    families=[BoundaryFamily(cyl, T, sigma=0.005)])
    assert isinstance(bounded, ReferenceUnderFamilies)
    assert name.endswith("under the caller's families: tlgc_boundary")
    inside_plain = np.mean(outside_distances(cyl, plain.mean[:, :3]) <= 1e-3)
    inside_bounded = np.mean(outside_distances(cyl, bounded.mean[:, :3]) <= 1e-3)
    assert inside_bounded >= 0.85 > inside_plain + 0.3
    # the same start and goal, the offsets of its samples the conditioned prior's
    np.testing.assert_allclose(bounded.mean[[0, -1], :3], plain.mean[[0, -1], :3], atol=2e-3)
    np.testing.assert_allclose(bounded.sample(3, 0) - bounded.mean, plain.sample(3, 0) - plain.mean)
    loose = BoundaryFamily(cyl, T, margin=-1.0)            # a boundary 1 m wider: holds
    same, name = skill_reference(prior, robot, request, config, families=[loose])
    assert not isinstance(same, ReferenceUnderFamilies)
    np.testing.assert_array_equal(same.mean, plain.mean)
    assert name.endswith("(the caller's families hold on it: tlgc_boundary)")
