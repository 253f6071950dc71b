"""Plan figures: PNG written, arm, path and every obstacle kind drawn."""
from __future__ import annotations


import numpy as np

from clamp.viz.plan_plots import plot_plan_3d


class FakeResult:
    """The fields of a PlanResult the figure reads."""

    def __init__(self, q, ee_path):
        self.q, self.ee_path = q, ee_path
        self.success, self.reasons = False, ["collision: minimum clearance -1.0 mm"]


def test_plot_plan_writes_png_with_obstacles(tmp_path, jaco):
    from scenes import Box, Cylinder, Scene, Sphere
    robot = jaco
    rng = np.random.default_rng(0)
    q0 = robot.random_configuration(rng)
    q = q0 + np.linspace(0, 0.5, 30)[:, None]
    result = FakeResult(q, robot.fk(q))
    scene = Scene([Box([0.3, -0.3, 0.1], [0.1, 0.1, 0.2]), Sphere([0.2, 0.2, 0.3], 0.05),
                   Cylinder([0.0, 0.4, 0.2], 0.05, 0.2)])
    path = tmp_path / "plan.png"
    fig = plot_plan_3d(result, robot, scene, arm_states=4, path=path)
    assert path.is_file() and path.stat().st_size > 10_000
    ax = fig.axes[0]
    assert len(ax.lines) >= 1 + 4  # end-effector path and the arm at 4 states
    assert len(ax.collections) >= 3  # box faces, sphere and cylinder surfaces (+ markers)
    assert "failed" in ax.get_title()


def test_clearance_figure_draws_the_collision_geometry_distance(jaco):
    """The arm's line of the clearance figure is the distance of the URDF collision geometry to
    the obstacle at every support state (below its cap), checked against coal on every
    geometry-obstacle pair (brute force, no pruning); the spheres' line is drawn beside it."""
    from clamp.planning.clearance import checker
    from clamp.viz.plan_plots import plot_clearance
    from scenes import Box, Scene
    robot = jaco
    rng = np.random.default_rng(3)
    q0 = robot.random_configuration(rng)
    q = q0 + np.linspace(0, 0.6, 12)[:, None]
    result = FakeResult(q, robot.fk(q))
    result.time = np.linspace(0.0, 2.0, len(q))
    ee = result.ee_path[6]
    scene = Scene([Box(ee + np.array([0.0, 0.0, 0.12]), [0.1, 0.1, 0.05])])
    fig = plot_clearance(result, robot, scene, epsilon=0.05)
    lines = {line.get_label().split(" ")[0]: np.asarray(line.get_ydata())
             for line in fig.axes[0].lines}
    arm, spheres = lines["arm"], lines["collision"]
    exact = checker(robot, scene).distances(q).min(axis=(1, 2))
    cap = 0.15
    assert np.allclose(arm, np.minimum(exact, cap), atol=1e-5)
    assert np.any(exact < cap)
    assert not np.allclose(arm, spheres)
