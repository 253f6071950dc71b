"""Two clocks (issue 38): a plan's figures against time are drawn on the skill's clock by
default and, given when the executable trajectory passes each support state, on the
trajectory's, their axis naming the clock and spanning that clock's times."""
from __future__ import annotations

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from clamp.cli.commands import write_trajectory                                  # noqa: E402
from clamp.viz.plan_plots import (CLOCK_AXES, plot_clearance, plot_joint_angles,  # noqa: E402
                                  plot_plan_uncertainty)


@pytest.fixture(scope="module")
def retimed(jaco, tmp_path_factory):
    """A plan of the synthetic skill on the Jaco, its trajectory record (retimed, as clamp plan
    writes it) and a box 6 cm above the plan's path half way along it."""
    from clamp import learn_prior, plan
    from scenes import Box, Scene, make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", num_points=30, seed=2))
    result = plan(prior, jaco, None, prior.mean[0, :3])
    assert result.success, result.reasons
    record = write_trajectory(tmp_path_factory.mktemp("clock"), "result", result, jaco, 2.0, True)
    middle = result.ee_path[len(result.ee_path) // 2]
    return result, record, Scene([Box(middle + [0.0, 0.0, 0.06], [0.04, 0.04, 0.02])])


def time_axes(fig):
    """(label, first and last x of the drawn lines) of every axis of ``fig`` with a time axis."""
    out = []
    for ax in fig.axes:
        xs = np.concatenate([np.asarray(line.get_xdata(), dtype=float) for line in ax.lines
                             if len(line.get_xdata()) > 2] or [np.empty(0)])
        if ax.get_xlabel() and xs.size:
            out.append((ax.get_xlabel(), xs.min(), xs.max()))
    return out


def test_figures_on_the_trajectory_clock_span_its_duration(jaco, retimed):
    result, record, scene = retimed
    times = np.asarray(record["state_times"])
    assert record["duration"] > 0 and not np.isclose(record["duration"], result.time[-1] - result.time[0])
    for fig in (plot_joint_angles(result, jaco, state_times=times),
                plot_clearance(result, jaco, scene, 0.02, state_times=times),
                plot_plan_uncertainty(result, state_times=times)):
        drawn = time_axes(fig)
        assert drawn
        for label, first, last in drawn:
            assert label == CLOCK_AXES["trajectory"] == "trajectory time [s]"
            assert first == pytest.approx(0.0, abs=1e-9)
            assert last == pytest.approx(record["duration"], rel=1e-9)
    marker = plot_clearance(result, jaco, scene, 0.02, state_times=times).axes[0].collections
    assert any("at trajectory time" in str(c.get_label()) for c in marker)


def test_figures_by_default_are_on_the_skill_clock(jaco, retimed):
    result, _, scene = retimed
    for fig in (plot_joint_angles(result, jaco), plot_clearance(result, jaco, scene, 0.02)):
        for label, first, last in time_axes(fig):
            assert label == "skill time [s]"
            assert (first, last) == pytest.approx((result.time[0], result.time[-1]))


def test_state_times_are_checked(jaco, retimed):
    from clamp.errors import InvalidParameterError, ShapeError
    result, record, _ = retimed
    with pytest.raises(ShapeError, match="state_times"):
        plot_joint_angles(result, jaco, state_times=record["state_times"][:-1])
    with pytest.raises(InvalidParameterError, match="state_times"):
        plot_joint_angles(result, jaco, state_times=np.asarray(record["state_times"])[::-1])
