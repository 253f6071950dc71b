"""Inverse kinematics: reaching targets within limits, following paths with continuity."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from bad_input import raises_naming
from robots import IKResult, IKTrajectoryResult, RobotError, load_robot
from robots.errors import InvalidArrayError
from tests.hand_measures import hand_angle


@pytest.fixture(scope="module", params=["jaco", "sawyer"])
def robot(request):
    return load_robot(request.param)


def test_ik_reaches_random_reachable_targets_within_limits(robot):
    rng = np.random.default_rng(11)
    for _ in range(8):
        target = robot.fk(robot.random_configuration(rng))
        result = robot.ik(target, tol=1e-5, rng=rng)
        assert isinstance(result, IKResult)
        assert result.success and result.error <= 1e-5
        assert np.linalg.norm(robot.fk(result.q) - target) == pytest.approx(result.error, abs=1e-12)
        assert robot.within_limits(result.q)


def test_ik_from_a_nearby_seed_stays_nearby(robot):
    rng = np.random.default_rng(12)
    q_true = robot.clip_to_limits(robot.random_configuration(rng) * 0.5)
    seed = robot.clip_to_limits(q_true + rng.normal(0.0, 0.05, robot.n))
    result = robot.ik(robot.fk(q_true), seed=seed, restarts=0)
    assert result.success
    assert np.abs(result.q - seed).max() < 0.5


def test_ik_reports_failure_for_an_unreachable_target(robot):
    result = robot.ik([3.0, 0.0, 0.0], max_iter=50, restarts=2)
    assert not result.success and result.error > 1.0
    assert robot.within_limits(result.q)


def _smooth_joint_path(robot, T: int, rng) -> np.ndarray:
    start = robot.clip_to_limits(0.5 * robot.random_configuration(rng) + 0.5 * robot.neutral_configuration())
    end = robot.clip_to_limits(start + rng.uniform(-0.4, 0.4, robot.n))
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, T))
    return start + s[:, None] * (end - start)


def test_trajectory_ik_follows_a_synthetic_path_continuously(robot):
    rng = np.random.default_rng(13)
    q_path = _smooth_joint_path(robot, 120, rng)
    targets = robot.fk(q_path)
    result = robot.ik_trajectory(targets, seed=q_path[0], tol=1e-4)
    assert isinstance(result, IKTrajectoryResult)
    assert result.q.shape == (120, robot.n) and result.errors.shape == (120,)
    assert result.success and result.errors.max() <= 1e-4
    np.testing.assert_allclose(np.linalg.norm(robot.fk(result.q) - targets, axis=1), result.errors, atol=1e-12)
    assert robot.within_limits(result.q).all()
    # continuity: consecutive targets are < 1 cm apart, so joints move by a small amount per step
    assert np.abs(np.diff(result.q, axis=0)).max() < 0.1


def test_trajectory_ik_follows_box_closing_mean_path_on_jaco(jaco, shared_dataset):
    data = scipy.io.loadmat(shared_dataset("box_closing"), squeeze_me=True, struct_as_record=False)
    mean_path = np.mean([demo.pos for demo in data["dataset"]], axis=0)
    assert mean_path.shape == (250, 3)
    result = jaco.ik_trajectory(mean_path, tol=1e-4)
    assert result.errors.max() <= 1e-3  # within 1 mm at every step
    assert jaco.within_limits(result.q).all()
    assert np.abs(np.diff(result.q, axis=0)).max() < 0.2


def test_ik_rejects_bad_input(robot):
    with raises_naming(InvalidArrayError, "target"):
        robot.ik([0.1, 0.2])
    with raises_naming(InvalidArrayError, "target"):
        robot.ik([0.1, np.nan, 0.2])
    with raises_naming(InvalidArrayError, "seed"):
        robot.ik([0.1, 0.2, 0.3], seed=np.zeros(robot.n + 1))
    with raises_naming(InvalidArrayError, "targets"):
        robot.ik_trajectory(np.zeros((5, 2)))
    with raises_naming(RobotError, "tol"):
        robot.ik([0.1, 0.2, 0.3], tol=-1.0)
    with raises_naming(RobotError, "rng"):
        robot.ik([0.1, 0.2, 0.3], rng="seed")



def _angle(robot, q, rotation) -> float:
    """[rad] between the hand's rotation at q and ``rotation`` (3, 3)."""
    return float(np.radians(hand_angle(robot, q, rotation)))


def test_ik_turned_reaches_the_position_with_the_hand_turned_as_asked_where_it_can(robot):
    """solve_ik_turned: at a pose the arm can take, the position within tol and the rotation
    met (to 0.01 deg); with any rotation, the position met and the hand no further from the
    rotation than plain position IK leaves it."""
    from robots.ik import solve_ik_turned
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(13)
    for _ in range(4):
        q = robot.random_configuration(rng)
        position, rotation = robot.fk(q), robot.ee_rotation(q)[0]
        result = solve_ik_turned(robot, position, rotation, tol=1e-5)
        assert result.success and np.linalg.norm(robot.fk(result.q) - position) <= 1e-5
        assert robot.within_limits(result.q)
        assert np.degrees(_angle(robot, result.q, rotation)) <= 0.01

        rotation = Rotation.random(random_state=rng.integers(1 << 31)).as_matrix()
        plain = robot.ik(position, tol=1e-5)
        result = solve_ik_turned(robot, position, rotation, tol=1e-5)
        assert result.success and np.linalg.norm(robot.fk(result.q) - position) <= 1e-5
        assert robot.within_limits(result.q)
        assert _angle(robot, result.q, rotation) <= _angle(robot, plain.q, rotation) + 1e-12
