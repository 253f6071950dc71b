"""The pose prior's orientation chain (clamp.prior.orientation_prior) against the demonstrations'
own statistics, computed independently (scipy's rotation mean, angles by hand): its mean
rotations, spread, marginal spread, conditioning on a rotation, files old and new, the
incremental update, and bad input."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bad_input import raises_naming
from clamp import errors, learn_prior
from clamp.prior.learning import learn_orientation
from clamp.prior import so3
from clamp.prior.conditioning import conditioned_orientation
from clamp.prior.linear_gaussian import WorkspacePrior
from scenes import Demonstrations
from tests.pose_demos import pose_demonstrations

V1_FILE = Path(__file__).parent / "data" / "workspace_prior_v1.npz"


@pytest.fixture(scope="module")
def demos(sawyer):
    return pose_demonstrations(sawyer, seed=1)


@pytest.fixture(scope="module")
def prior(demos):
    return learn_prior(demos, start_shrinkage=0.0)


def angles(A, B):
    """Geodesic angles [deg] between rotations, through quaternions (independent of so3)."""
    qa, qb = Rotation.from_matrix(A).as_quat(), Rotation.from_matrix(B).as_quat()
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(qa * qb, axis=-1)), 0.0, 1.0)))


def test_mean_orientation_is_the_demonstrations_mean_rotation(prior, demos):
    """The learned mean within 0.5 deg of scipy's rotation mean of the demonstrations at every
    step (the prior's own mean, not only the tangent spaces' centres)."""
    independent = np.stack([Rotation.from_quat(demos.orientations[:, t]).mean().as_matrix()
                            for t in range(demos.T)])
    learned = so3.from_quaternions(prior.mean_quaternions())
    assert np.max(angles(learned, independent)) <= 0.5
    q = prior.mean_quaternions()
    assert q.shape == (demos.T, 4) and np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert np.all(np.sum(q[1:] * q[:-1], axis=1) > 0)                      # sign-continuous


def test_orientation_spread_and_marginals_match_the_demonstrations(prior, demos):
    R = Rotation.from_quat(demos.orientations.reshape(-1, 4)).as_matrix().reshape(demos.M, demos.T, 3, 3)
    mean = np.stack([Rotation.from_quat(demos.orientations[:, t]).mean().as_matrix()
                     for t in range(demos.T)])
    farthest = angles(R, np.broadcast_to(mean, R.shape)).max(axis=0)          # (T,) deg
    np.testing.assert_allclose(np.degrees(prior.orientation.angle_radius), farthest, atol=0.5)
    summary = prior.summary()
    assert f"farthest {farthest.max():.1f} deg" in summary or \
        abs(float(summary.split("farthest ")[1].split(" deg")[0]) - farthest.max()) <= 0.5
    # per-axis learning without shrinkage: the chain's marginal std of the tangent coordinates
    # is the demonstrations' own (1/M), step by step, to the agreement floor's lift where the
    # demonstrations start and end at rest (their angular velocities agree: within 10 %)
    r = prior.orientation.tangent(R)
    np.testing.assert_allclose(prior.orientation.std[:, :3], r.std(axis=0), rtol=0.1, atol=1e-4)
    np.testing.assert_allclose(prior.orientation.mean[:, :3], r.mean(axis=0), atol=1e-6)


def test_conditioned_orientation_meets_the_rotation(prior):
    o = prior.orientation
    goal = o.mean_rotations[-1] @ so3.exp_map([0.0, 0.2, 0.1])
    c = conditioned_orientation(o, [(0, o.mean_rotations[0]), (o.T - 1, goal)], 1e-5)
    assert angles(c.mean_rotations[-1], goal) <= 1e-3
    assert angles(c.mean_rotations[0], o.mean_rotations[0]) <= 1e-3


def test_pose_prior_file_round_trips_and_a_file_of_the_position_prior_still_loads(prior, tmp_path):
    loaded = WorkspacePrior.load(prior.save(tmp_path / "pose.npz"))
    for name in ("Phi", "u", "Q", "mean0", "cov0", "mean"):
        assert np.array_equal(getattr(loaded.orientation, name), getattr(prior.orientation, name))
        assert np.array_equal(getattr(loaded, name), getattr(prior, name))
    assert np.array_equal(loaded.mean_quaternions(), prior.mean_quaternions())
    old = WorkspacePrior.load(V1_FILE)             # saved before the pose prior existed
    assert old.orientation is None and old.T == 30 and old.posterior is not None
    with raises_naming(errors.InvalidParameterError, "prior", "orientation"):
        old.mean_quaternions()


def test_position_only_demonstrations_give_a_position_prior(demos):
    plain = Demonstrations(demos.positions, demos.velocities, demos.time)
    prior = learn_prior(plain)
    assert prior.orientation is None and "orientation" not in prior.summary()
    same = learn_prior(demos)
    assert np.array_equal(prior.Phi, same.Phi) and np.array_equal(prior.mean, same.mean)


def test_incremental_update_continues_the_orientation(sawyer, demos):
    first = learn_prior(demos, method="incremental")
    more = pose_demonstrations(sawyer, seed=2)
    updated = first.update(more)
    assert updated.orientation is not None
    assert updated.orientation.info["num_demos"] == demos.M + more.M
    assert np.array_equal(updated.orientation.rotations, first.orientation.rotations)
    # the updated chain's mean tangent coordinates are the pooled demonstrations' (it learned both)
    R = so3.from_quaternions(np.concatenate([demos.orientations, more.orientations]))
    np.testing.assert_allclose(updated.orientation.mean[:, :3],
                               first.orientation.tangent(R).mean(axis=0), atol=2e-3)
    with raises_naming(errors.InvalidParameterError, "demos", "orientations"):
        first.update(Demonstrations(more.positions, more.velocities, more.time))


def test_a_goal_rotation_never_turns_a_state_farther_than_itself(sawyer):
    """Three demonstrations fit each step of the orientation chain exactly, so the chain
    conditioned exactly on a goal rotation 3 deg off carries it back amplified. Capped as a
    goal position is (clamp.prior.goal_response), no state's tangent coordinates move farther
    from where the start alone puts them than the goal's did, and start and goal are met."""
    o = learn_prior(pose_demonstrations(sawyer, num_demos=3, seed=2)).orientation
    start = [(0, o.mean_rotations[0])]
    alone = conditioned_orientation(o, start, 1e-5)
    capped_somewhere = False
    for axis in np.eye(3):
        goal = alone.mean_rotations[-1] @ so3.exp_map(np.radians(3.0) * axis)
        moved = conditioned_orientation(o, start + [(o.T - 1, goal)], 1e-5)
        offset = np.linalg.norm(moved.mean[-1, :3] - alone.mean[-1, :3])
        shift = np.linalg.norm(moved.mean[:, :3] - alone.mean[:, :3], axis=1)
        assert shift.max() <= offset * (1 + 1e-6)
        assert angles(moved.mean_rotations[-1], goal) <= 1e-3
        assert angles(moved.mean_rotations[0], o.mean_rotations[0]) <= 1e-3
        capped_somewhere |= moved.info["goal_response"]["capped_states"] > 0
    assert capped_somewhere


def turning_demonstrations(num_steps: int = 80):
    """Quaternions (5, T, 4) and time (T,) [s]: five hands turning together about z, four a
    few degrees apart and one held about 170 deg round from them, wobbling by +-25 deg, so
    that it passes pi from the mean rotation and back (the principal log wraps there)."""
    time = np.linspace(0.0, 4.0, num_steps)
    s = time / time[-1]
    common = np.radians(90.0) * s
    offsets = np.radians([[0.0], [8.0], [-6.0], [14.0], [170.0]])
    wobble = np.radians([[2.0], [-3.0], [4.0], [-2.0], [25.0]]) * np.sin(2 * np.pi * s + [[0.0], [1.0], [2.0], [3.0], [0.5]])
    angle = common + offsets + wobble                                        # (5, T) about z
    tilt = np.radians(5.0) * np.cos(np.pi * s + np.arange(5)[:, None])       # about x
    R = Rotation.from_euler("zx", np.stack([angle, tilt], -1).reshape(-1, 2)).as_matrix()
    return Rotation.from_matrix(R).as_quat().reshape(5, num_steps, 4), time


def test_a_hand_turned_past_pi_from_the_mean_is_learned_continuously():
    """The log map wraps where a demonstration passes pi from the mean rotation: its tangent
    coordinates jump by 2 pi between two samples of a smooth turn, and the prior's mean (their
    average) with them. The learned states follow one branch instead: they are the same
    rotations, they move between samples by no more than the hand and the mean rotation turn,
    the prior's mean rotation turns between steps no more than a demonstration does, the
    spread stays an angle in [0, pi], and the chain conditioned on that demonstration's start
    rotation follows it within its wobble."""
    q, time = turning_demonstrations()
    o = learn_orientation(q, time, start_shrinkage=0.0)
    R = so3.from_quaternions(q)
    at_mean = np.swapaxes(o.rotations, -1, -2) @ R
    step = np.degrees(np.linalg.norm(np.diff(so3.log_map(at_mean), axis=1), axis=-1))
    assert step.max() > 300.0                                   # the scene does wrap
    states = o.states_of(q)
    np.testing.assert_allclose(so3.exp_map(states[..., :3]), at_mean, atol=1e-9)
    followed = np.degrees(np.linalg.norm(np.diff(states[..., :3], axis=1), axis=-1))
    turn = angles(R[:, 1:], R[:, :-1]).max()                    # a hand's largest step [deg]
    assert followed.max() <= turn + angles(o.rotations[1:], o.rotations[:-1]).max()
    assert angles(o.mean_rotations[1:], o.mean_rotations[:-1]).max() <= turn
    truth = angles(R, np.broadcast_to(o.rotations, R.shape)).max(axis=0)
    np.testing.assert_allclose(np.degrees(o.angle_radius), truth, atol=1e-6)
    c = conditioned_orientation(o, [(0, R[-1, 0])], 1e-5)
    assert angles(c.mean_rotations, R[-1]).max() <= 25.0        # its wobble is +-25 deg


def test_nearest_branch_is_the_same_rotation_nearest_the_reference():
    rng = np.random.default_rng(3)
    r = so3.log_map(so3.exp_map(rng.normal(size=(50, 3)) * 2.0))
    reference = rng.normal(size=(50, 3)) * 6.0
    near = so3.nearest_branch(r, reference)
    np.testing.assert_allclose(so3.exp_map(near), so3.exp_map(r), atol=1e-9)
    axis = r / np.linalg.norm(r, axis=1, keepdims=True)
    for k in (-2, -1, 1, 2):                       # no other equivalent on the axis is nearer
        other = near + 2 * np.pi * k * axis
        assert np.all(np.linalg.norm(near - reference, axis=1)
                      <= np.linalg.norm(other - reference, axis=1) + 1e-9)
    assert np.array_equal(so3.nearest_branch(r, r), r)            # unchanged where k = 0
    assert np.array_equal(so3.nearest_branch(np.zeros(3), reference[0]), np.zeros(3))
