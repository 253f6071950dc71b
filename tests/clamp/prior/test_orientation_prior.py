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
