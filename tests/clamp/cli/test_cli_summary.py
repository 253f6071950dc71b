"""What ``clamp plan`` tells about a plan: the summary's columns (verdict, clearance, errors, the
time scale, the executable trajectory's duration; the solver's figures only with -v) and the two
clocks (a support state's time on the skill's clock and on the trajectory's)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from clamp import learn_prior, plan
from clamp.cli.commands import (contact_summary, on_trajectory_clock, state_times, summary_table, write_plan,
                            write_trajectory)
from robots.trajectory import load_trajectory
from scenes import Box, Scene, make_demonstrations


@pytest.fixture(scope="module")
def planned(jaco, tmp_path_factory):
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, num_points=30, seed=1))
    start = prior.mean[0, :3] + np.array([0.0, -0.03, 0.03])
    free = plan(prior, jaco, None, start, covariance=False)
    middle = free.ee_path[len(free.ee_path) // 2]
    result = plan(prior, jaco, Scene([Box(middle - [0.0, 0.0, 0.02], [0.08, 0.08, 0.08])]), start,
                  covariance=False)
    assert result.success, result.reasons
    out = tmp_path_factory.mktemp("summary")
    record = write_trajectory(out, "result", result, jaco, 1.5, True)
    return result, record, out


def test_summary_columns_and_verbose_figures(planned):
    result, record, _ = planned
    table = summary_table([("p", result)], {"p": record})
    head, _, row = table.splitlines()
    for column in ("verdict", "clear mm", "end mm", "goal mm", "goal deg", "orient deg", "k", "traj s"):
        assert column in head, head
    assert "log-lik" not in head and "final err" not in head
    fields = row.split()
    assert fields[:3] == ["p", "success", f"{result.min_clearance * 1e3:.1f}"], row
    assert fields[3] == f"{result.skill['end_distance'] * 1e3:.1f}" and fields[4:7] == ["-"] * 3
    assert fields[7] == f"{result.time_scale:.2f}" and fields[8] == f"{record['duration']:.2f}"
    verbose = summary_table([("p", result)], {"p": record}, verbose=True)
    assert "log-lik" in verbose.splitlines()[0] and f"{result.log_likelihood:.4g}" in verbose


def test_state_times_put_each_support_state_on_the_trajectory_clock(planned, jaco):
    """The trajectory passes each support state at its state time: its positions there (linearly
    interpolated between its samples) are the plan's q within 0.02 rad."""
    result, record, out = planned
    trajectory = load_trajectory(out / "trajectory_result.json")
    t, positions = trajectory.time_from_start, trajectory.positions
    times = np.array(record["state_times"])
    assert times[0] == 0.0 and times[-1] == pytest.approx(record["duration"])
    assert np.all(np.diff(times) >= 0.0)
    passed = np.stack([np.interp(times, t, positions[:, j]) for j in range(jaco.n)], axis=1)
    assert np.abs(passed - result.q).max() < 0.02
    np.testing.assert_allclose(state_times(result.q, _identity(result)), result.time - result.time[0])


def test_the_nearest_contact_is_dated_on_both_clocks(planned):
    result, record, out = planned
    write_plan(result, out / "plan.json", trajectory=record)
    contact = json.loads((out / "plan.json").read_text())["nearest_contact"]
    assert contact["skill_time"] == pytest.approx(np.interp(contact["index"], np.arange(len(result.time)),
                                                            result.time))
    assert contact["trajectory_time"] == pytest.approx(
        np.interp(contact["index"], np.arange(len(record["state_times"])), record["state_times"]))
    assert 0.0 < contact["trajectory_time"] < record["duration"]
    assert contact["time_clock"] == "skill" and contact["time"] == contact["skill_time"]


def test_the_summary_says_the_nearest_contact_on_both_clocks(planned):
    result, record, _ = planned
    contact = on_trajectory_clock(result, record)
    line = contact_summary("p", contact)
    assert line == (f"nearest contact p: {result.min_clearance * 1e3:.1f} mm, link {contact['link']} to "
                    f"{contact['obstacle']} at trajectory time {contact['trajectory_time']:.2f} s "
                    f"(skill time t = {contact['skill_time']:.2f} s)")
    assert "trajectory time" not in contact_summary("p", on_trajectory_clock(result, {"files": []}))
    assert contact_summary("p", None) is None


def _identity(result):
    """The plan's own timing as a trajectory-like object (not retimed)."""
    class Plain:
        positions = result.q
        time_from_start = result.time - result.time[0]
    return Plain
