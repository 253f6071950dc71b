"""The collision check at scale and at its resolution: the broad phase against brute force on
10,000 obstacles; the certified bound between checked configurations."""
from __future__ import annotations

import numpy as np
import pytest

from robots import collision_check
from robots.collision_check import RESOLUTION, SLACK, CollisionChecker
from scenes import Box, Sphere
from scenes.coal_shapes import coal_obstacles

START = np.array([-0.52, 2.97, 4.80, 0.0, 2.14, 0.0])


def test_broad_phase_with_10000_obstacles_agrees_with_brute_force_on_the_near_ones(jaco):
    rng = np.random.default_rng(11)
    q = np.linspace(START, START + [0.6, 0.2, -0.2, 0.3, 0.2, 0.0], 6)
    path = jaco.frame_positions(q)[:, 2:].reshape(-1, 3)
    near = [Sphere(path[rng.integers(len(path))] + rng.normal(0.0, 0.08, 3), rng.uniform(0.01, 0.03))
            for _ in range(12)]
    far_centres = rng.uniform(-10.0, 10.0, (10_000 - len(near), 3))
    far_centres[:, 2] = np.abs(far_centres[:, 2]) + 2.0          # at least 2 m above the base: far
    far = [Box(c, [0.05, 0.05, 0.05]) for c in far_centres]
    big = CollisionChecker(jaco, coal_obstacles(near + far))
    measured = []
    distance = big._distance

    def spy(shape, transform, g, o, cutoff=np.inf):
        measured.append(o)
        return distance(shape, transform, g, o, cutoff)

    big._distance = spy
    report = big.check(q, max_motion=0.05, resolution=None)
    sub = big.configurations(q, max_motion=0.05)
    brute = CollisionChecker(jaco, coal_obstacles(near)).distances(sub.q)   # every pair, near ones
    assert report.min_distance == pytest.approx(brute.min(), abs=SLACK)
    assert report.nearest.obstacle.startswith("sphere_")
    assert max(measured) < len(near)                     # no coal query on a far obstacle


def test_thin_obstacle_at_the_resolution_between_two_states_is_found(jaco):
    """A plate RESOLUTION thick across the fingertip's arc half way between two states (1 rad
    of the base joint apart): the certified bound refines the segment until it is found."""
    end = START + np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    middle = 0.5 * (START + end) + np.array([0.013, 0.0, 0.0, 0.0, 0.0, 0.0])  # off any bisection point
    tip = jaco.frame_position(middle, "j2s6s200_link_finger_tip_1")
    radial = np.array([tip[0], tip[1], 0.0]) / np.hypot(tip[0], tip[1])
    tangent = np.cross([0.0, 0.0, 1.0], radial)
    plate = Box(tip, [0.04, RESOLUTION, 0.04], np.column_stack([radial, tangent, [0.0, 0.0, 1.0]]))
    checker = CollisionChecker(jaco, coal_obstacles([plate], names=["plate"]))
    q = np.stack([START, end])
    report = checker.check(q)
    assert report.collision and report.nearest.obstacle == "plate" and 0.0 < report.nearest.index < 1.0
    assert np.all(report.state_distance > 0.03)
    # a clear motion: the certified bound holds at 50 subdivisions per segment (independent check)
    clear = CollisionChecker(jaco, coal_obstacles([Box(tip + 0.02 * radial + [0, 0, 0.1], [0.01, 0.01, 0.01])]))
    ok = clear.check(q)
    assert not ok.collision and ok.lower_bound >= -RESOLUTION / 2
    dense = clear.distances(np.linspace(START, end, 51)).min()
    assert dense >= ok.lower_bound - SLACK


def test_windows_of_segments_give_the_same_report(jaco, monkeypatch):
    """Memory is bounded by searching windows of consecutive segments: the same result."""
    rng = np.random.default_rng(12)
    q = np.linspace(START, START + [0.8, 0.3, -0.3, 0.4, 0.2, 0.1], 8)
    path = jaco.frame_positions(q)[:, 2:].reshape(-1, 3)
    obstacles = [Sphere(path[rng.integers(len(path))] + rng.normal(0.0, 0.05, 3), rng.uniform(0.01, 0.04))
                 for _ in range(8)]
    checker = CollisionChecker(jaco, coal_obstacles(obstacles))
    whole = checker.check(q, margin=0.01)
    monkeypatch.setattr(collision_check, "WINDOW_PAIRS", 200)
    windows = checker._windows(*_broad_inputs(checker, q))
    assert len(windows) > 2
    split = checker.check(q, margin=0.01)
    assert split.min_distance == pytest.approx(whole.min_distance, abs=SLACK)
    assert split.collision == whole.collision and split.nearest.obstacle == whole.nearest.obstacle
    below = whole.state_distance < 0.01
    np.testing.assert_array_equal(split.state_distance < 0.01, below)
    np.testing.assert_allclose(split.state_distance[below], whole.state_distance[below], atol=SLACK)


def _broad_inputs(checker: CollisionChecker, q: np.ndarray):
    """(near, support) of the checker's broad phase for q at the default motion and reach."""
    sub = checker.configurations(q)
    geo = checker._geo
    moving = np.flatnonzero(geo.joints != 0)
    R, t = checker._poses(sub.q)
    centre = collision_check._transform(R[:, moving], t[:, moving], geo.sphere_centre[moving])
    near, _ = checker._near_pairs(centre, sub.support, moving, collision_check.REACH)
    return near, sub.support
