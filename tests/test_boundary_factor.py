"""The TLGC boundary factor for CLAMP: residual, Jacobians, GTSAM adapter."""
from __future__ import annotations

import gtsam
import numpy as np
import pytest

from robots import load_robot
from tlgc.boundary_factor import (BoundaryFactorMaker, boundary_distance, boundary_residuals,
                                  boundary_state_residuals, section_indices)
from tlgc.cylinder import fit_cylinder
from tlgc.errors import InvalidArgumentError

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
    with pytest.raises(InvalidArgumentError, match="index"):
        section_indices(np.array([5]), 5, 10)
    with pytest.raises(InvalidArgumentError, match="num_states"):
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
def test_state_jacobian_matches_finite_differences(name):
    robot, cyl, q = _robot_setup(name, seed=1)
    sections = section_indices(np.arange(T), T, cyl.num_sections)
    h, jac = boundary_state_residuals(cyl, robot, sections, q)
    assert np.count_nonzero(h) >= T // 2                # most states are outside: hinge active
    assert np.all(jac[:, robot.n:] == 0.0)              # velocities do not enter
    step = 1e-6
    fd = np.zeros((T, robot.n))
    for j in range(robot.n):
        e = np.zeros(robot.n)
        e[j] = step
        fd[:, j] = (boundary_state_residuals(cyl, robot, sections, q + e)[0]
                    - boundary_state_residuals(cyl, robot, sections, q - e)[0]) / (2 * step)
    active = h > 1e-4                                   # away from the hinge's kink
    np.testing.assert_allclose(jac[active, : robot.n], fd[active], atol=1e-6)


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_gtsam_adapter_matches_numpy_residual(name):
    robot, cyl, q = _robot_setup(name, seed=2)
    sigma = 0.02
    maker = BoundaryFactorMaker(cyl, robot, margin=0.005, sigma=sigma)
    sections = section_indices(np.arange(T), T, cyl.num_sections)
    h, jac = boundary_state_residuals(cyl, robot, sections, q, margin=0.005)
    values = gtsam.Values()
    rng = np.random.default_rng(0)
    # values grow one state at a time: until the last, the shared cache cannot be refilled and
    # each factor falls back to evaluating its own state
    for i in range(T):
        key = gtsam.symbol("x", i)
        values.insert(key, np.concatenate([q[i], rng.normal(size=robot.n)]))
        factor = maker(i, T, key)
        assert factor.dim() == 1
        np.testing.assert_allclose(factor.unwhitenedError(values), [h[i]], atol=1e-12)
        a, b = factor.linearize(values).jacobian()
        np.testing.assert_allclose(a, jac[i][None] / sigma, atol=1e-9)
        np.testing.assert_allclose(b, [-h[i] / sigma], atol=1e-9)
        assert factor.error(values) == pytest.approx(0.5 * (h[i] / sigma) ** 2)


class _CountingRobot:
    """A robot whose end-effector kinematics calls are counted."""

    def __init__(self, robot):
        self.robot, self.n, self.calls = robot, robot.n, 0

    def ee_kinematics(self, q, qdot=None, jacobians=True):
        self.calls += 1
        return self.robot.ee_kinematics(q, qdot, jacobians=jacobians)


def _graph(maker: BoundaryFactorMaker, num_states: int = T) -> gtsam.NonlinearFactorGraph:
    graph = gtsam.NonlinearFactorGraph()
    for i in range(num_states):
        factor = maker(i, num_states, gtsam.symbol("x", i))
        if factor is not None:
            graph.add(factor)
    return graph


def _values(theta: np.ndarray) -> gtsam.Values:
    values = gtsam.Values()
    for i, row in enumerate(theta):
        values.insert(gtsam.symbol("x", i), row)
    return values


@pytest.mark.parametrize("name, states", [("jaco", None), ("sawyer", [0, 3, 4, 9, 11, 40])])
def test_shared_family_matches_per_state_factors(name, states):
    robot, cyl, q = _robot_setup(name, seed=4)
    shared = BoundaryFactorMaker(cyl, robot, margin=0.003, sigma=0.01, states=states)
    alone = BoundaryFactorMaker(cyl, robot, margin=0.003, sigma=0.01, states=states,
                                shared_evaluation=False)
    shared_graph, alone_graph = _graph(shared), _graph(alone)
    assert shared_graph.size() == alone_graph.size() == (T if states is None else 5)
    rng = np.random.default_rng(5)
    thetas = [np.concatenate([q + 0.1 * rng.standard_normal(q.shape),
                              rng.standard_normal(q.shape)], axis=1) for _ in range(3)]
    # revisit earlier states and visit factors in random order: the cache must follow
    for theta in [thetas[0], thetas[1], thetas[0], thetas[2]]:
        values = _values(theta)
        order = rng.permutation(shared_graph.size())
        for k in order:
            f_shared, f_alone = shared_graph.at(int(k)), alone_graph.at(int(k))
            np.testing.assert_allclose(f_shared.unwhitenedError(values),
                                       f_alone.unwhitenedError(values), rtol=0, atol=1e-12)
            a_shared, b_shared = f_shared.linearize(values).jacobian()
            a_alone, b_alone = f_alone.linearize(values).jacobian()
            np.testing.assert_allclose(a_shared, a_alone, rtol=0, atol=1e-9)
            np.testing.assert_allclose(b_shared, b_alone, rtol=0, atol=1e-10)
        assert shared_graph.error(values) == pytest.approx(alone_graph.error(values), rel=1e-12)
    evaluator, family = shared.shared(T)
    assert evaluator.reloads == 4
    if states is not None:
        np.testing.assert_array_equal(family.indices, [0, 3, 4, 9, 11])


def test_shared_family_runs_one_kinematics_call_per_linearisation():
    robot, cyl, q = _robot_setup("jaco", seed=6)
    counting = _CountingRobot(robot)
    graph = _graph(BoundaryFactorMaker(cyl, counting))
    values = _values(np.concatenate([q, np.zeros_like(q)], axis=1))
    graph.linearize(values)
    assert counting.calls == 1
    graph.error(values)                          # same states: served from the cache
    assert counting.calls == 1
    graph.error(_values(np.concatenate([q + 0.01, np.zeros_like(q)], axis=1)))
    assert counting.calls == 2
    per_state = _CountingRobot(robot)
    _graph(BoundaryFactorMaker(cyl, per_state, shared_evaluation=False)).linearize(values)
    assert per_state.calls == T
    other_key = BoundaryFactorMaker(cyl, counting)(2, T, gtsam.symbol("y", 2))
    assert other_key.keys()[0] == gtsam.symbol("y", 2)   # not a planner key: evaluated alone


def test_maker_restricts_states_and_checks_arguments():
    robot, cyl, _ = _robot_setup("jaco", seed=3)
    maker = BoundaryFactorMaker(cyl, robot, states=[0, 5])
    assert maker(3, T, gtsam.symbol("x", 3)) is None
    assert maker(5, T, gtsam.symbol("x", 5)) is not None
    assert maker.section(T - 1, T) == cyl.num_sections - 1
    with pytest.raises(InvalidArgumentError, match="cylinder"):
        BoundaryFactorMaker("tube", robot)
    with pytest.raises(InvalidArgumentError, match="robot"):
        BoundaryFactorMaker(cyl, "arm")
    with pytest.raises(InvalidArgumentError, match="sigma"):
        BoundaryFactorMaker(cyl, robot, sigma=0.0)
    with pytest.raises(InvalidArgumentError, match="q"):
        boundary_state_residuals(cyl, robot, np.zeros(2, dtype=int), np.zeros((2, 3)))


def test_clamp_plan_stays_inside_cylinder_with_the_factor():
    pytest.importorskip("clamp.planner", reason="needs the CLAMP planner")
    from tlgc.demo_clamp_cylinder import run_clamp_cylinder_demo

    demo = run_clamp_cylinder_demo("reach_from_above", "jaco", num_states=40, goal_offset=0.05)
    print(f"inside the cylinder: without factor {demo.fraction_inside_without:.3f}, "
          f"with factor {demo.fraction_inside_with:.3f}")
    assert demo.without_factor.success and demo.with_factor.success
    assert demo.fraction_inside_with >= 0.85
    assert demo.fraction_inside_with > demo.fraction_inside_without + 0.3
    # with the factor, only the states near the (outside) goal leave the cylinder
    outside = np.flatnonzero(demo.outside_with > 1e-3)
    assert outside.min() >= 0.85 * len(demo.outside_with)
