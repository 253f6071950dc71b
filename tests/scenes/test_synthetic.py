"""Synthetic skill demonstrations: workspace, smoothness, variation, errors."""
import numpy as np
import pytest

from bad_input import raises_naming
from scenes import SKILLS, InvalidArgumentError, UnknownSkillError, make_demonstrations
from scenes.synthetic import CURVED_REACH_OBSTACLE


@pytest.mark.parametrize("skill", SKILLS)
def test_shapes_time_and_reproducibility(skill):
    demos = make_demonstrations(skill, num_demos=5, num_points=120, dt=0.2, seed=3)
    assert demos.positions.shape == (5, 120, 3) and demos.velocities.shape == (5, 120, 3)
    assert np.allclose(demos.time, np.arange(120) * 0.2) and np.isclose(demos.dt, 0.2)
    assert demos.name == skill
    again = make_demonstrations(skill, num_demos=5, num_points=120, dt=0.2, seed=3)
    assert np.array_equal(again.positions, demos.positions)
    other = make_demonstrations(skill, num_demos=5, num_points=120, dt=0.2, seed=4)
    assert not np.allclose(other.positions, demos.positions)


@pytest.mark.parametrize("skill", SKILLS)
def test_inside_the_jaco_workspace(skill):
    p = make_demonstrations(skill, num_demos=10, seed=7).positions
    assert np.all(np.linalg.norm(p[..., :2], axis=-1) > 0.2)      # away from the base column
    assert np.all(np.linalg.norm(p[..., :2], axis=-1) < 0.7)      # within reach
    assert np.all((p[..., 2] > 0.02) & (p[..., 2] < 0.6))
    assert np.all((p[..., 0] > 0.05) & (p[..., 0] < 0.55) & (p[..., 1] > -0.65) & (p[..., 1] < -0.15))


@pytest.mark.parametrize("skill", SKILLS)
def test_velocities_are_the_time_derivative_and_motion_is_rest_to_rest(skill):
    demos = make_demonstrations(skill)
    derivative = np.gradient(demos.positions, demos.time, axis=1, edge_order=2)
    scale = np.abs(demos.velocities).max()
    assert np.abs(derivative - demos.velocities).max() < 0.01 * scale
    assert np.allclose(demos.velocities[:, [0, -1]], 0.0)
    # smooth: no jumps between consecutive samples
    steps = np.linalg.norm(np.diff(demos.positions, axis=1), axis=-1)
    assert steps.max() < 5 * np.median(steps)
    assert 0.01 < scale < 0.2      # slow kinesthetic-teaching speeds (m/s), like box_closing.mat


@pytest.mark.parametrize("skill", SKILLS)
def test_demonstrations_differ_realistically(skill):
    p = make_demonstrations(skill, num_demos=8).positions
    spread = np.linalg.norm(p - p.mean(axis=0), axis=-1).max(axis=0)      # (T,)
    assert spread.max() > 0.01           # visible variation
    assert spread.max() < 0.15           # but the same skill


def test_needle_threading_is_wide_narrow_wide():
    p = make_demonstrations("needle_threading", num_demos=10).positions
    spread = np.linalg.norm(p - p.mean(axis=0), axis=-1).max(axis=0)
    T = p.shape[1]
    middle = spread[int(0.4 * T):int(0.6 * T)].min()
    assert spread[0] > 4 * middle and spread[-1] > 4 * middle
    assert middle < 0.01


def test_curved_reach_goes_around_its_recorded_obstacle():
    demos = make_demonstrations("curved_reach", num_demos=10, seed=11)
    assert all(group == [CURVED_REACH_OBSTACLE] for group in demos.obstacles)
    assert CURVED_REACH_OBSTACLE.distance(demos.positions).min() > 0.02
    # the straight line from start to end would go through the obstacle
    start, end = demos.positions[0, 0], demos.positions[0, -1]
    line = start + np.linspace(0, 1, 100)[:, None] * (end - start)
    assert CURVED_REACH_OBSTACLE.distance(line).min() < 0


def test_other_skills_record_no_obstacles():
    assert make_demonstrations("box_closing").obstacles is None


def test_box_closing_resembles_the_recorded_skill():
    demos = make_demonstrations("box_closing")
    start = demos.positions[:, 0].mean(axis=0)
    assert np.linalg.norm(start - [0.2054, -0.4722, 0.2625]) < 0.03
    assert demos.positions.shape == (6, 250, 3) and np.isclose(demos.dt, 0.16)


def test_unknown_skill_lists_valid_names():
    with raises_naming(UnknownSkillError, "skill", "juggling", "box_closing", "two_target_press"):
        make_demonstrations("juggling")


@pytest.mark.parametrize("kwargs, name", [
    (dict(num_demos=1), "num_demos"), (dict(num_points=2), "num_points"),
    (dict(dt=0.0), "dt"), (dict(num_demos=2.5), "num_demos"),
])
def test_bad_arguments_raise(kwargs, name):
    with raises_naming(InvalidArgumentError, name):
        make_demonstrations("pick_place", **kwargs)
