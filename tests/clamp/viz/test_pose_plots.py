"""The pose prior's figures: the orientation prior against time (its band holds the
demonstrations it was learned from) and a plan's angle from the skill (the verdict's figures)."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import errors, learn_prior, plan
from clamp.prior import so3
from clamp.viz.plan_plots import plot_skill_orientation
from clamp.viz.prior_plots import plot_prior_orientation
from scenes import Demonstrations
from tests.pose_demos import pose_demonstrations


@pytest.fixture(scope="module")
def learned(sawyer):
    demos = pose_demonstrations(sawyer, T=30)
    return demos, learn_prior(demos)


def test_orientation_prior_figure_draws_its_band_and_the_demonstrations(learned, tmp_path):
    demos, prior = learned
    fig = plot_prior_orientation(prior, demos, path=tmp_path / "o.png")
    assert (tmp_path / "o.png").stat().st_size > 0
    ax = fig.axes[0]
    band = ax.collections[0].get_paths()[0].vertices[:, 1].max()
    demo_angles = np.degrees(so3.angle_between(prior.orientation.mean_rotations,
                                               so3.from_quaternions(demos.orientations)))
    assert band >= 0.5 * demo_angles.max()          # the band is of the demonstrations' size
    lines = [line for line in ax.get_lines() if line.get_label() == "demonstrations"]
    assert len(lines) == 1 and len(ax.get_lines()) == 1 + demos.M
    with raises_naming(errors.InvalidParameterError, "prior", "pose prior"):
        plot_prior_orientation(learn_prior(Demonstrations(demos.positions, demos.velocities,
                                                          demos.time)))


def test_plan_orientation_figure_reports_the_angle_against_the_skill(learned, sawyer):
    demos, prior = learned
    result = plan(prior, sawyer, None, demos.joint_positions[0, 0], covariance=False)
    fig = plot_skill_orientation(result, sawyer)
    plotted = fig.axes[0].get_lines()[0].get_ydata()
    assert np.isclose(plotted.max(), result.skill["max_angle_deg"])
    assert "limit" in fig.axes[0].get_title()
