"""Faults of the collision check become reports, never crashes: obstacles overlapping the
fixed base (a warning and report.fixed_overlaps), a coal failure (report.fault, the verdict's
reason), a URDF without collision geometry (spheres fitted to its visual geometry), an empty
mesh file (a one-line error, raised: the URDF is bad input)."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from bad_input import raises_naming
from clamp.planning.clearance import collision_reason
from robots import Robot, RobotError, collision_check
from robots.collision_check import CollisionChecker
from robots.errors import URDFParseError
from scenes import Box, Sphere
from scenes.coal_shapes import coal_obstacles
from test_collision_check import URDF_WITHOUT_COLLISION

START = np.array([-0.52, 2.97, 4.80, 0.0, 2.14, 0.0])

VISUAL = '<visual><geometry><box size="0.1 0.1 0.3"/></geometry></visual>'
assert VISUAL in URDF_WITHOUT_COLLISION


def arm(geometry: str) -> str:
    """The two-link arm of test_collision_check with ``geometry`` on its upper link instead."""
    return URDF_WITHOUT_COLLISION.replace(VISUAL, geometry)


def test_obstacle_through_the_fixed_base_is_reported(jaco, caplog):
    table = Box([0.0, 0.0, 0.05], [1.0, 1.0, 0.1])                  # a slab at z 0-0.1 through the base
    q = np.stack([START, START])
    with caplog.at_level(logging.WARNING, logger="robots"):
        report = CollisionChecker(jaco, coal_obstacles([table], names=["table"])).check(q)
    assert [(link, name) for link, name, _ in report.fixed_overlaps] == [("j2s6s200_link_base", "table")]
    assert report.fixed_overlaps[0][2] > 0.0
    assert "table" in caplog.text and "j2s6s200_link_base" in caplog.text
    assert report.to_dict()["fixed_overlaps"][0][:2] == ["j2s6s200_link_base", "table"]
    around = Box([0.0, 0.0, 0.05], [0.4, 0.4, 0.4])                 # a box around the whole base
    report = CollisionChecker(jaco, coal_obstacles([around], names=["crate"])).check(q)
    assert ("j2s6s200_link_base", "crate") in [(link, name) for link, name, _ in report.fixed_overlaps]
    apart = CollisionChecker(jaco, coal_obstacles([Box([0.6, 0.0, 0.3], [0.05, 0.05, 0.05])])).check(q)
    assert apart.fixed_overlaps == ()


def test_a_coal_failure_is_a_fault_in_the_report_and_a_verdict_reason(jaco, monkeypatch):
    checker = CollisionChecker(jaco, coal_obstacles([Sphere([0.3, -0.3, 0.2], 0.05)]))
    checker.fixed_overlaps                                          # measured before coal breaks

    def broken(*args):
        raise RuntimeError("GJK did not converge")

    monkeypatch.setattr(collision_check.coal, "distance", broken)
    report = checker.check(np.stack([START, START + 0.1]))
    assert report.fault is not None and "GJK did not converge" in report.fault
    assert report.collision and np.isnan(report.min_distance)
    assert collision_reason(report).startswith("collision check failed: ")


def test_urdf_without_collision_geometry_fits_spheres_to_its_visual_geometry(tmp_path, caplog):
    path = tmp_path / "arm.urdf"
    path.write_text(URDF_WITHOUT_COLLISION)              # a 0.1 x 0.1 x 0.3 m visual box, centred
    robot = Robot.from_urdf(path, end_effector="tool")
    with caplog.at_level(logging.WARNING, logger="robots"):
        spheres = robot.spheres
    assert "visual geometry" in caplog.text
    centres, _ = robot.sphere_centres(np.zeros((1, 2)))
    assert np.all(np.abs(centres[0, :, 2]) <= 0.15 + 1e-9)           # inside the box's height
    inside = Sphere([0.0, 0.07, 0.0], 0.03)                          # touches the box's side face
    report = CollisionChecker(robot, coal_obstacles([inside])).check(np.zeros((2, 2)))
    assert report.geometry == "spheres" and report.collision
    assert len(spheres.radii) >= 1
    path.write_text(arm(""))
    with raises_naming(RobotError, "spheres", "arm.urdf"):
        Robot.from_urdf(path, end_effector="tool").spheres


def test_an_empty_mesh_file_is_one_clear_line(tmp_path):
    mesh = tmp_path / "empty.stl"
    mesh.write_text("")
    path = tmp_path / "arm.urdf"
    path.write_text(arm(f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>'))
    robot = Robot.from_urdf(path, end_effector="tool")
    with pytest.raises(URDFParseError) as caught:
        robot.collision_model
    message = str(caught.value)
    assert "\n" not in message and "File is empty" in message and str(mesh) in message
    assert "assimp.cpp" not in message


def test_a_plan_reports_the_fixed_base_overlap(jaco, caplog):
    """A table slab through the base (z 0-0.1) is planned around as usual and the plan says the
    base overlaps it: result.fixed_overlaps and the verdict's JSON, with a warning."""
    from clamp import learn_prior, plan
    from scenes import Scene, make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", num_demos=6, seed=0))
    table = Box([0.0, 0.0, 0.05], [0.5, 0.5, 0.1])
    with caplog.at_level(logging.WARNING, logger="robots"):
        result = plan(prior, jaco, Scene([table]), prior.mean[0, :3], covariance=False)
    assert [(link, name) for link, name, _ in result.fixed_overlaps] == [
        ("j2s6s200_link_base", "box_0")]
    assert result.verdict()["fixed_overlaps"][0][:2] == ["j2s6s200_link_base", "box_0"]
    assert "j2s6s200_link_base" in caplog.text


def test_a_microsecond_time_step_is_a_verdict_not_a_crash(jaco):
    """Issue 20: dt = 1e-6 s crashed plan() in the covariance step; at the demonstrations' speed
    (time_scale 1) the plan now fails with that step's reason and the honest one (the velocity
    limits), as covariance=False does; slowed down to the arm automatically it is a verdict too."""
    from clamp import PlannerConfig, learn_prior, plan
    from scenes import make_demonstrations
    prior = learn_prior(make_demonstrations("box_closing", dt=1e-6, seed=0))
    # Qc as given (a 0.25 ms skill would take 10 Qc, docs/decisions.md#qc_duration, and its
    # posterior covariance no longer fails): the reproducer as it was found
    config = PlannerConfig(Qc_duration=None)
    result = plan(prior, jaco, None, prior.mean[0, :3], time_scale=1.0, config=config)
    assert not result.success and result.state_covariance is None
    assert result.reasons[0].startswith("posterior covariance failed")
    assert any("faster than its limit" in r for r in result.reasons)
    without = plan(prior, jaco, None, prior.mean[0, :3], covariance=False, time_scale=1.0,
                   config=config)
    assert without.reasons == result.reasons[1:]
    slowed = plan(prior, jaco, None, prior.mean[0, :3], covariance=False)
    assert slowed.time_scale > 1e3 and slowed.success == (not slowed.reasons)   # a verdict
