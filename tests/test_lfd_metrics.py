"""The reproduction metrics of bench_lfd (benchmarks/lfd_metrics.py) against independent
computations: the DTW alignment against a plain dynamic programme of the least total cost, the
geodesic angle and the orientation error against scipy's Rotation."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import lfd_metrics as lm  # noqa: E402


def least_total_cost(a: np.ndarray, b: np.ndarray) -> float:
    """The least sum of point distances over monotone alignments of a and b (plain loops)."""
    cost = np.full((len(a) + 1, len(b) + 1), np.inf)
    cost[0, 0] = 0.0
    for i in range(1, len(a) + 1):
        for j in range(1, len(b) + 1):
            cost[i, j] = (np.linalg.norm(a[i - 1] - b[j - 1])
                          + min(cost[i - 1, j - 1], cost[i - 1, j], cost[i, j - 1]))
    return float(cost[-1, -1])


def random_walk(rng: np.random.Generator, length: int) -> np.ndarray:
    return np.cumsum(rng.normal(scale=0.01, size=(length, 3)), axis=0)


@pytest.mark.parametrize("seed", range(5))
def test_dtw_alignment_is_a_least_cost_monotone_alignment(seed):
    rng = np.random.default_rng(seed)
    a, b = random_walk(rng, int(rng.integers(5, 40))), random_walk(rng, int(rng.integers(5, 40)))
    pairs, mean = lm.dtw_alignment(a, b)
    assert tuple(pairs[0]) == (0, 0) and tuple(pairs[-1]) == (len(a) - 1, len(b) - 1)
    moves = np.diff(pairs, axis=0)
    assert {tuple(m) for m in moves} <= {(1, 1), (1, 0), (0, 1)}
    distances = np.linalg.norm(a[pairs[:, 0]] - b[pairs[:, 1]], axis=1)
    assert distances.sum() == pytest.approx(least_total_cost(a, b), rel=1e-12)
    assert mean == pytest.approx(distances.mean(), rel=1e-12)
    assert lm.dtw_mean(a, b) == mean


def test_dtw_of_a_path_and_its_retimed_copy_is_zero():
    s = np.linspace(0.0, 1.0, 60)
    path = np.column_stack([np.cos(3 * s), np.sin(3 * s), s])
    slow = np.repeat(path, 2, axis=0)                   # every point held twice
    assert lm.dtw_mean(path, slow) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("seed", range(3))
def test_geodesic_angle_is_scipys_relative_rotation_angle(seed):
    rng = np.random.default_rng(seed)
    r1, r2 = Rotation.random(50, random_state=rng), Rotation.random(50, random_state=rng)
    q1, q2 = r1.as_quat(), r2.as_quat()
    expected = (r1.inv() * r2).magnitude()
    assert np.allclose(lm.geodesic_angle(q1, q2), expected, atol=1e-7)
    assert np.allclose(lm.geodesic_angle(-q1, q2), expected, atol=1e-7)   # q and -q: one rotation
    assert np.allclose(lm.geodesic_angle(q1, q1), 0.0, atol=1e-7)


def test_orientation_error_averages_the_angle_over_the_position_alignment():
    rng = np.random.default_rng(7)
    demo = random_walk(rng, 40)
    turns = Rotation.from_rotvec(np.cumsum(rng.normal(scale=0.05, size=(40, 3)), axis=0))
    # the reproduction passes every place of the demonstration on another timing (some held
    # longer), each rotation turned 10 deg about a random axis: aligned on position, every
    # pair differs by exactly 10 deg
    index = np.sort(np.concatenate([np.arange(40), rng.integers(0, 40, size=15)]))
    axes = rng.normal(size=(55, 3))
    offsets = Rotation.from_rotvec(np.radians(10.0) * axes / np.linalg.norm(axes, axis=1,
                                                                            keepdims=True))
    path, quaternions = demo[index], (turns[index] * offsets).as_quat()
    error = lm.orientation_error(path, quaternions, demo, turns.as_quat())
    assert np.degrees(error) == pytest.approx(10.0, abs=1e-6)
    # and in general: the mean of scipy's angles over the DTW pairs
    other = Rotation.random(55, random_state=rng)
    pairs, _ = lm.dtw_alignment(path, demo)
    expected = (other[pairs[:, 0]].inv() * turns[pairs[:, 1]]).magnitude().mean()
    assert lm.orientation_error(path, other.as_quat(), demo, turns.as_quat()) == \
        pytest.approx(expected, abs=1e-7)
