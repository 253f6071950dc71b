"""Every factor family, on both arms, at random points:

- analytic Jacobians against central finite differences of the kernel;
- the GTSAM adapters (``problem.graph()``) against the kernel: error and whitened linearization
  per factor, also evaluated alone on values holding only the factor's own states;
- the whole problem: GTSAM's graph error and Hessian equal the fast path's error and
  block-tridiagonal normal equations, with a caller's own CustomFactor included;
- nothing a problem builds outlives it (reference counting alone frees graph and families).
"""
from __future__ import annotations

import gc
import weakref

import gtsam
import numpy as np
import pytest

from bad_input import raises_naming
from clamp.factors import (EEPositionFamily, EERotationFamily, JointGPFamily, JointLimitFamily, JointTargetFamily,
                           ObstacleFamily, OrientationFamily, PostureFamily, PostureMotionFamily,
                           PostureVelocityFamily, SelfCollisionFamily, SkillTubeFamily,
                           StateWindow, WorkspaceGPFamily, WorkspaceStartFamily,
                           OrientationGPFamily, OrientationStartFamily)
from clamp.prior import so3
from clamp.errors import InvalidParameterError
from clamp.graph.keys import state_key
from clamp.graph.problem import PlanningProblem
from tlgc.boundary_factor import BoundaryFamily
from tlgc.cylinder import fit_cylinder

T = 6
STEP = 1e-6


def random_theta(robot, rng) -> np.ndarray:
    """Joint states (T, 2n) along a random segment inside the limits, velocities ~0.3 rad/s."""
    a, b = robot.random_configuration(rng), robot.random_configuration(rng)
    q = a + np.linspace(0.0, 0.3, T)[:, None] * (b - a)
    return np.concatenate([q, rng.normal(scale=0.3, size=q.shape)], axis=1)


def sphere_query(centre: np.ndarray, radius: float):
    """Exact signed distance (and gradient) of a ball: an obstacle independent of scenes/."""
    def query(points):
        offset = points - centre
        norm = np.linalg.norm(offset, axis=-1)
        return norm - radius, offset / norm[..., None]
    return query


def make_families(robot, theta: np.ndarray, rng) -> list:
    """One instance of every family, with parameters that make the hinges partly active."""
    n = robot.n
    Phi = np.eye(6) + 0.1 * rng.normal(size=(T - 1, 6, 6))
    A = rng.normal(size=(T - 1, 6, 6))
    Q = A @ np.swapaxes(A, 1, 2) * 1e-3 + 1e-4 * np.eye(6)
    path = robot.fk(theta[:, :n])
    offsets = 0.02 * np.array([[1, 0, 0], [0, 1.5, 0], [-0.7, -0.4, 1], [0, 0, -0.5], [-1, 0.3, 0]])
    cylinder = fit_cylinder(path[None] + offsets[:, None], "spline")
    q = theta[:, :n]
    span = np.ptp(q, axis=0) + 0.2
    return [
        WorkspaceGPFamily(Phi, 0.05 * rng.normal(size=(T - 1, 6)), Q),
        WorkspaceStartFamily(rng.normal(size=6), Q[0]),
        JointGPFamily(T, n, 0.16, 1.0),
        JointTargetFamily([0, T - 2], q[[0, T - 2]] + 0.1, [1e-3, 2e-3]),
        PostureFamily(np.arange(T), q + 0.05 * rng.normal(size=q.shape), np.full(T, 0.1)),
        PostureMotionFamily(theta + 0.05 * rng.normal(size=theta.shape), 0.16, 1e-4),
        PostureVelocityFamily(theta + 0.05 * rng.normal(size=theta.shape), 0.03),
        SkillTubeFamily(path + 0.03 * rng.normal(size=path.shape), rng.uniform(0.01, 0.08, T),
                        0.0025),
        EEPositionFamily([1, T - 1], path[[1, T - 1]] + 0.05, [1e-3, 1e-2]),
        ObstacleFamily(np.arange(T), robot.spheres.radii,
                       sphere_query(path[T // 2] + [0.05, 0.0, 0.0], 0.05), 0.1, 0.05),
        JointLimitFamily(np.arange(T), q.mean(axis=0) - 0.3 * span, q.mean(axis=0) + 0.3 * span,
                         np.full(n, 0.3), 1e-3),
        BoundaryFamily(cylinder, T, margin=0.03, sigma=0.01),
        OrientationFamily(np.arange(1, T), axis=[0, 0, 1], direction=[0.3, -0.2, -1.0],
                          tolerance=0.05, sigma=0.01),
        SelfCollisionFamily.for_robot(robot, np.arange(T - 1), epsilon=0.1, sigma=0.02, between=2),
        *pose_families(robot, q, Phi, Q, rng),
    ]


def pose_families(robot, q: np.ndarray, Phi: np.ndarray, Q: np.ndarray, rng) -> list:
    """The pose prior's families (orientation chain, its start, rotation targets) about mean
    rotations ~17 deg from the hand's at q (T, n): the log map well inside its range."""
    R, _ = robot.ee_rotation(q)
    mean = R @ so3.exp_map(0.3 * rng.normal(size=(len(q), 3)))
    return [OrientationGPFamily(mean, Phi, 0.05 * rng.normal(size=(len(q) - 1, 6)), Q),
            OrientationStartFamily(mean[0], 0.1 * rng.normal(size=6), Q[0]),
            EERotationFamily([1, len(q) - 1], mean[[1, -1]], [1e-3, 1e-2])]


@pytest.fixture(params=["jaco", "sawyer"])
def setup(request):
    robot = request.getfixturevalue(request.param)
    rng = np.random.default_rng(7 if request.param == "jaco" else 8)
    theta = random_theta(robot, rng)
    return robot, theta, make_families(robot, theta, rng)


def dense_residual(family, robot, theta: np.ndarray) -> np.ndarray:
    """Residuals (F, m) of all factors, zeros where the kernel leaves a factor out."""
    lin = family.residual(StateWindow(robot, theta), np.arange(len(family)), False)
    out = np.zeros((len(family), family.dim))
    out[lin.rows] = lin.error
    return out


def test_every_family_has_an_active_factor(setup):
    robot, theta, families = setup
    for family in families:
        assert np.any(dense_residual(family, robot, theta) != 0.0), family.name


def assert_jacobians_match_finite_differences(family, robot, theta: np.ndarray) -> None:
    """The family's analytic Jacobian against central differences of its kernel, wherever no
    hinge switches within the difference step."""
    base = dense_residual(family, robot, theta)
    lin = family.residual(StateWindow(robot, theta), np.arange(len(family)), True)
    analytic = np.zeros((len(family), family.dim, family.arity * theta.shape[1]))
    analytic[lin.rows] = lin.jacobian
    for f in range(len(family)):
        for slot, state in enumerate(family.states(f)):
            for k in range(theta.shape[1]):
                plus, minus = theta.copy(), theta.copy()
                plus[state, k] += STEP
                minus[state, k] -= STEP
                e_plus = dense_residual(family, robot, plus)[f]
                e_minus = dense_residual(family, robot, minus)[f]
                numeric = (e_plus - e_minus) / (2 * STEP)
                smooth = ((e_plus == 0) == (e_minus == 0)) & ((e_plus == 0) == (base[f] == 0))
                col = slot * theta.shape[1] + k
                np.testing.assert_allclose(analytic[f, smooth, col], numeric[smooth],
                                           rtol=1e-5, atol=1e-5,
                                           err_msg=f"{family.name} factor {f} column {col}")


def test_jacobians_match_finite_differences(setup):
    robot, theta, families = setup
    for family in families:
        assert_jacobians_match_finite_differences(family, robot, theta)


def whitened_rows(family, robot, theta):
    """Whitened A (F, m, arity d) and b = -R e (F, m) of all factors (zeros where left out)."""
    lin = family.residual(StateWindow(robot, theta), np.arange(len(family)), True)
    A = np.zeros((len(family), family.dim, family.arity * theta.shape[1]))
    b = np.zeros((len(family), family.dim))
    A[lin.rows] = family.whiten(lin.rows, lin.jacobian)
    b[lin.rows] = -family.whiten(lin.rows, lin.error)
    return A, b


def values_of(theta: np.ndarray, states=None) -> gtsam.Values:
    values = gtsam.Values()
    for i in range(len(theta)) if states is None else states:
        values.insert(state_key(i), theta[i])
    return values


def test_gtsam_adapters_equal_the_kernel(setup):
    robot, theta, families = setup
    d = theta.shape[1]
    for family in families:
        problem = PlanningProblem(robot, T, [family])
        graph = problem.graph()
        assert graph.size() == len(family)
        values = values_of(theta)
        A, b = whitened_rows(family, robot, theta)
        expected_error = 0.5 * float(np.sum(b * b))
        assert graph.error(values) == pytest.approx(expected_error, rel=1e-9, abs=1e-12)
        assert problem.error(theta) == pytest.approx(expected_error, rel=1e-12, abs=1e-14)
        for f in range(len(family)):
            factor = graph.at(f)
            for own in (values, values_of(theta, family.states(f))):  # shared and alone
                a_f, b_f = factor.linearize(own).jacobian()
                order = [list(family.states(f)).index(gtsam.Symbol(k).index())
                         for k in factor.keys()]
                expected = np.concatenate([A[f][:, s * d:(s + 1) * d] for s in order], axis=1)
                np.testing.assert_allclose(a_f, expected, rtol=1e-9, atol=1e-9 * (1 + abs(A[f]).max()))
                np.testing.assert_allclose(b_f, b[f], rtol=1e-9, atol=1e-12)


def user_factor(robot, index: int, height: float, sigma: float = 1e-3) -> gtsam.CustomFactor:
    """A caller's own factor: the end effector at least ``height`` [m] high at state ``index``
    (hinge noise ``sigma`` [m])."""
    n = robot.n

    def error(this, values, H):
        theta = values.atVector(this.keys()[0])
        kin = robot.ee_kinematics(theta[None, :n], None, jacobians=True)
        gap = height - kin.position[0, 2]
        if H is not None:
            H[0] = np.zeros((1, 2 * n))
            if gap > 0:
                H[0][0, :n] = -kin.jacobian[0, 2]
        return np.array([max(gap, 0.0)])

    return gtsam.CustomFactor(gtsam.noiseModel.Isotropic.Sigma(1, sigma),
                              gtsam.KeyVector([state_key(index)]), error)


def test_whole_problem_equals_gtsam_graph(setup):
    robot, theta, families = setup
    d = theta.shape[1]
    height = float(robot.fk(theta[2, :robot.n])[2]) + 0.01            # active at state 2
    problem = PlanningProblem(robot, T, families, foreign=[user_factor(robot, 2, height)])
    assert problem.banded
    values = values_of(theta)
    graph = problem.graph()
    assert problem.error(theta) == pytest.approx(graph.error(values), rel=1e-9)
    H_gtsam, g_gtsam = graph.linearize(values).hessian()     # columns in key order x0..x(T-1)
    system = problem.normal_equations(theta)
    H = np.zeros((T * d, T * d))
    for i in range(T):
        H[i * d:(i + 1) * d, i * d:(i + 1) * d] = system.D[i]
    for i in range(T - 1):
        H[i * d:(i + 1) * d, (i + 1) * d:(i + 2) * d] = system.E[i]
        H[(i + 1) * d:(i + 2) * d, i * d:(i + 1) * d] = system.E[i].T
    scale = np.abs(H_gtsam).max()
    np.testing.assert_allclose(H, H_gtsam, rtol=1e-9, atol=1e-9 * scale)
    np.testing.assert_allclose(system.g.reshape(-1), g_gtsam, rtol=1e-9,
                               atol=1e-9 * np.abs(g_gtsam).max())
    assert system.error == pytest.approx(graph.error(values), rel=1e-9)
    assert set(problem.family_errors(theta)) == {f.name for f in families} | {"foreign"}


def test_foreign_factor_on_distant_states_is_not_banded(jaco):
    between = gtsam.BetweenFactorVector(state_key(0), state_key(3), np.zeros(2 * jaco.n),
                                        gtsam.noiseModel.Isotropic.Sigma(2 * jaco.n, 1.0))
    problem = PlanningProblem(jaco, T, [JointGPFamily(T, jaco.n, 0.1)], foreign=[between])
    assert not problem.banded


def test_problem_and_graph_are_freed_without_the_cycle_collector(jaco):
    rng = np.random.default_rng(3)
    theta = random_theta(jaco, rng)
    families = make_families(jaco, theta, rng)
    problem = PlanningProblem(jaco, T, families)
    graph = problem.graph()
    graph.linearize(values_of(theta))
    watch = [weakref.ref(f) for f in families] + [weakref.ref(problem)]
    gc.disable()
    try:
        del families, problem, graph
        assert all(ref() is None for ref in watch)
    finally:
        gc.enable()


def test_a_reweighted_family_scales_its_noise_and_nothing_else(setup):
    """Family.reweighted(k): the whitened residuals (and so the GTSAM noise) scale by k, the
    error by k^2; the original family is unchanged."""
    robot, theta, families = setup
    window = StateWindow(robot, theta)
    for family in families:
        before = family.error(window)
        stiffer = family.reweighted(4.0)
        assert stiffer.error(StateWindow(robot, theta)) == pytest.approx(16.0 * before,
                                                                          rel=1e-12, abs=1e-300)
        assert family.error(StateWindow(robot, theta)) == before
        assert type(stiffer) is type(family) and stiffer.name == family.name
        sigma = family.noise_model(0).sigmas()
        assert np.allclose(stiffer.noise_model(0).sigmas(), sigma / 4.0, rtol=1e-12)
    with raises_naming(InvalidParameterError, "factor"):
        families[0].reweighted(0.0)


def test_obstacle_penetration_is_the_deepest_sphere(setup):
    """ObstacleFamily.penetration: max over its states and spheres of r_s - d(c_s), from the
    robot's sphere centres and the ball's distance computed here."""
    robot, theta, families = setup
    family = next(f for f in families if isinstance(f, ObstacleFamily))
    centres, _ = robot.sphere_centres(theta[:, :robot.n])
    distance, _ = family.query(centres[family.first])
    expected = float(np.max(np.asarray(robot.spheres.radii) - distance))
    assert family.penetration(StateWindow(robot, theta)) == pytest.approx(expected, abs=1e-12)
