"""bench_lfd's peers on poses (benchmarks/lfd_peers.py): each reproduction is unit quaternions
that start at the given start pose and end at the given goal pose, and CartesianDMP imitates
the training mean's rotations (its quaternion order converted both ways). Needs the bench
extra (movement_primitives, pytransform3d, gmr)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

pytest.importorskip("movement_primitives", reason="the peers need pip install '.[bench]'")
pytest.importorskip("gmr", reason="the GMR peer needs pip install '.[bench]'")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import lfd_metrics as lm  # noqa: E402
import lfd_peers  # noqa: E402

from scenes import Demonstrations, make_demonstrations  # noqa: E402


@pytest.fixture(scope="module")
def pose_demos() -> Demonstrations:
    """A synthetic reach whose hand turns 60 deg about a tilted axis, each demonstration by a
    slightly different angle and axis (seeded)."""
    demos = make_demonstrations("reach_from_above", num_demos=5, num_points=60, seed=3)
    rng = np.random.default_rng(3)
    phase = np.linspace(0.0, 1.0, demos.T)[:, None]
    turns = []
    for _ in range(demos.M):
        axis = np.array([0.3, 0.2, 1.0]) + rng.normal(scale=0.05, size=3)
        angle = np.radians(60.0 + rng.normal(scale=3.0))
        rotvec = angle * phase * axis / np.linalg.norm(axis)
        turns.append((Rotation.from_rotvec(rotvec) * Rotation.from_euler("x", 180, degrees=True))
                     .as_quat())
    return Demonstrations(demos.positions, demos.velocities, demos.time,
                          orientations=np.array(turns))


@pytest.mark.parametrize("peer", ["promp", "dmp", "gmr"])
@pytest.mark.parametrize("setting", ["start", "goal"])
def test_a_peer_reproduces_poses_from_the_start_to_the_goal(pose_demos, peer, setting):
    train = Demonstrations(pose_demos.positions[1:], pose_demos.velocities[1:], pose_demos.time,
                           orientations=pose_demos.orientations[1:])
    held = np.column_stack([pose_demos.positions[0], pose_demos.orientations[0]])
    start = held[0].copy()
    start[3:] *= -1.0                                  # the same rotation, the other sign
    goal = held[-1] if setting == "goal" else None
    y = getattr(lfd_peers, peer)(train, start, goal)
    assert y.shape == (pose_demos.T, 7)
    assert np.allclose(np.linalg.norm(y[:, 3:], axis=1), 1.0, atol=1e-9)
    assert np.all(np.sum(y[1:, 3:] * y[:-1, 3:], axis=1) > 0)         # sign-continuous
    assert np.linalg.norm(y[0, :3] - start[:3]) < 1e-3
    assert np.degrees(lm.geodesic_angle(y[0, 3:], start[3:])) < 0.5
    if goal is not None:
        assert np.linalg.norm(y[-1, :3] - goal[:3]) < 2e-3   # DMP approaches its goal
        assert np.degrees(lm.geodesic_angle(y[-1, 3:], goal[3:])) < 1.0


def test_cartesian_dmp_imitates_the_training_mean_rotation(pose_demos):
    mean = lfd_peers.training_poses(pose_demos).mean(axis=0)
    mean[:, 3:] /= np.linalg.norm(mean[:, 3:], axis=1, keepdims=True)
    y = lfd_peers.dmp(pose_demos, mean[0], mean[-1])
    angles = np.degrees(lm.geodesic_angle(y[:, 3:], mean[:, 3:]))
    assert angles.max() < 3.0, f"CartesianDMP's rotation {angles.max():.2f} deg off the mean"


def test_position_only_peers_keep_three_columns(pose_demos):
    train = Demonstrations(pose_demos.positions, pose_demos.velocities, pose_demos.time)
    for peer in (lfd_peers.promp, lfd_peers.dmp, lfd_peers.gmr):
        y = peer(train, train.positions[0, 0], None)
        assert y.shape == (train.T, 3)
        assert np.linalg.norm(y[0] - train.positions[0, 0]) < 1e-3
