"""scenes.plotting: obstacles drawn on 3-D axes, equal-aspect limits."""
import matplotlib.pyplot as plt
import numpy as np

from scenes import Box, Cylinder, Sphere
from scenes.plotting import draw_obstacle, set_equal_axes_3d


def test_every_obstacle_type_adds_an_artist():
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    obstacles = [Box([0, 0, 0], [0.1, 0.2, 0.3]), Sphere([0.3, 0, 0], 0.05),
                 Cylinder([0, 0.3, 0], 0.05, 0.2)]
    for count, obstacle in enumerate(obstacles, start=1):
        draw_obstacle(ax, obstacle)
        assert len(ax.collections) == count
    plt.close(fig)


def test_equal_axes_span_the_largest_extent_around_the_midpoint():
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.1]])
    set_equal_axes_3d(ax, points, scale=2.0)
    limits = np.array([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()])
    np.testing.assert_allclose(limits[:, 1] - limits[:, 0], 2.0)
    np.testing.assert_allclose(limits.mean(axis=1), [0.5, 0.1, 0.05])
    plt.close(fig)
