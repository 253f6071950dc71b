"""Bad-input catalogue of ``robots``: every public function of docs/interfaces.md fed bad
input answers with the project's error naming the argument (see tests/bad_input.py)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bad_input import Case, cases, check
from robots import Robot, load_robot
from robots.errors import (RobotTypeError, InvalidArrayError, RetimingError, RobotError,
                           SphereFileError, TrajectoryError, TrajectoryFileError,
                           UnknownFrameError, UnknownRobotError, URDFParseError)
from robots.retiming import check_limits, retime, uniform_scaling
from robots.sphere_model import SphereModel, load_sphere_file, save_sphere_file
from robots.spheres import fit_spheres, sphere_coverage
from robots.trajectory import JointTrajectory, load_trajectory


def _q(fx, **changes):
    q = fx.robot.neutral_configuration()
    for index, value in changes.items():
        q[int(index[1:])] = value
    return q


def _traj(fx) -> JointTrajectory:
    t = np.linspace(0, 1, 5)
    q = np.tile(fx.robot.neutral_configuration(), (5, 1))
    return JointTrajectory.from_plan(fx.robot, t, q, np.zeros_like(q))


def _write(fx, name: str, text: str | bytes):
    path = fx.tmp / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


IA, E, F = InvalidArrayError, RobotTypeError, UnknownFrameError
URDF = """<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="revolute"><parent link="a"/><child link="b"/>
<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>"""

CATALOGUE: list[Case] = [
    Case("load-robot-unknown", lambda fx: load_robot("ur5"), UnknownRobotError, "ur5"),
    Case("load-robot-list", lambda fx: load_robot(["jaco"]), E, "name"),
    Case("load-robot-none", lambda fx: load_robot(None), E, "name"),
    Case("load-robot-case", lambda fx: load_robot("Jaco "), UnknownRobotError, "jaco"),
    Case("from-urdf-missing", lambda fx: Robot.from_urdf(fx.tmp / "no.urdf", "b"), URDFParseError, "path"),
    Case("from-urdf-directory", lambda fx: Robot.from_urdf(fx.tmp, "b"), URDFParseError, "directory"),
    Case("from-urdf-garbage", lambda fx: Robot.from_urdf(_write(fx, "g.urdf", "<robot"), "b"),
         URDFParseError, "path"),
    Case("from-urdf-latin1", lambda fx: Robot.from_urdf(_write(fx, "l.urdf", "<robot name='\xe9'/>"
                                                                .encode("latin-1")), "b"), URDFParseError, "path"),
    Case("from-urdf-path-type", lambda fx: Robot.from_urdf(3, "b"), E, "path"),
    Case("from-urdf-ee-unknown", lambda fx: Robot.from_urdf(_write(fx, "ok.urdf", URDF), "tool0"),
         F, "end_effector"),
    Case("from-urdf-ee-type", lambda fx: Robot.from_urdf(_write(fx, "ok2.urdf", URDF), 3), RobotError,
         "end_effector"),
    Case("from-urdf-base-unknown", lambda fx: Robot.from_urdf(_write(fx, "ok3.urdf", URDF), "b",
                                                               base_frame="world0"), F, "base_frame"),
    Case("from-urdf-spheres-type", lambda fx: Robot.from_urdf(_write(fx, "ok4.urdf", URDF), "b",
                                                               spheres=3), RobotError, "spheres"),
    Case("fk-shape", lambda fx: fx.robot.fk(np.zeros(fx.robot.n + 1)), IA, "q"),
    Case("fk-nan", lambda fx: fx.robot.fk(_q(fx, j0=np.nan)), IA, "q"),
    Case("fk-text", lambda fx: fx.robot.fk("zero"), IA, "q"),
    Case("fk-bools", lambda fx: fx.robot.fk([True] * fx.robot.n), IA, "q"),
    Case("fk-none", lambda fx: fx.robot.fk(None), IA, "q"),
    Case("ee-kinematics-qdot-shape", lambda fx: fx.robot.ee_kinematics(
        np.zeros((4, fx.robot.n)), np.zeros((3, fx.robot.n))), IA, "qdot"),
    Case("ee-kinematics-qdot-inf", lambda fx: fx.robot.ee_kinematics(
        np.zeros((4, fx.robot.n)), np.full((4, fx.robot.n), np.inf)), IA, "qdot"),
    Case("sphere-centres-shape", lambda fx: fx.robot.sphere_centres(np.zeros((4, 2))), IA, "q"),
    Case("frame-positions-shape", lambda fx: fx.robot.frame_positions(np.zeros(2)), IA, "q"),
    Case("frame-position-unknown", lambda fx: fx.robot.frame_position(_q(fx), "nowhere"), F, "frame"),
    Case("frame-position-q", lambda fx: fx.robot.frame_position([1, 2], fx.robot.end_effector), IA, "q"),
    Case("to-pinocchio-shape", lambda fx: fx.robot.to_pinocchio(np.zeros(1)), IA, "q"),
    Case("from-pinocchio-shape", lambda fx: fx.robot.from_pinocchio(np.zeros(1)), IA, "q_pin"),
    Case("within-limits-shape", lambda fx: fx.robot.within_limits(np.zeros(2)), IA, "q"),
    Case("within-limits-tolerance", lambda fx: fx.robot.within_limits(_q(fx), tolerance=-1.0),
         RobotError, "tolerance"),
    Case("clip-shape", lambda fx: fx.robot.clip_to_limits(np.zeros(2)), IA, "q"),
    Case("random-configuration-rng", lambda fx: fx.robot.random_configuration("seed"), RobotError, "rng"),
    Case("ik-target-shape", lambda fx: fx.robot.ik([0.1, 0.2]), RobotError, "target"),
    Case("ik-target-nan", lambda fx: fx.robot.ik([0.1, np.nan, 0.2]), RobotError, "target"),
    Case("ik-seed-shape", lambda fx: fx.robot.ik([0.3, -0.3, 0.3], seed=[0.0]), RobotError, "seed"),
    Case("ik-tol", lambda fx: fx.robot.ik([0.3, -0.3, 0.3], tol=0.0), RobotError, "tol"),
    Case("ik-max-iter", lambda fx: fx.robot.ik([0.3, -0.3, 0.3], max_iter=2.5), RobotError, "max_iter"),
    Case("ik-restarts", lambda fx: fx.robot.ik([0.3, -0.3, 0.3], restarts=-1), RobotError, "restarts"),
    Case("ik-rng", lambda fx: fx.robot.ik([0.3, -0.3, 0.3], rng="x"), RobotError, "rng"),
    Case("ik-trajectory-shape", lambda fx: fx.robot.ik_trajectory(np.zeros((4, 2))), RobotError, "targets"),
    Case("ik-trajectory-tol", lambda fx: fx.robot.ik_trajectory(np.zeros((4, 3)), tol=-1.0), RobotError,
         "tol"),
    Case("spheres-setter-type", lambda fx: setattr(load_robot("sawyer"), "spheres", 3), RobotError, "spheres"),
    Case("spheres-setter-missing", lambda fx: setattr(load_robot("sawyer"), "spheres", fx.tmp / "no.json"),
         SphereFileError, "no.json"),
    # sphere models
    Case("sphere-model-radii", lambda fx: SphereModel(("a",), np.zeros((1, 3)), [-0.1]), IA, "radii"),
    Case("sphere-model-centres", lambda fx: SphereModel(("a",), np.zeros((2, 3)), [0.1]), IA, "centres"),
    Case("sphere-model-names", lambda fx: SphereModel("a", np.zeros((1, 3)), [0.1]), IA, "link_names"),
    Case("sphere-model-inflation", lambda fx: SphereModel(("a",), np.zeros((1, 3)), [0.1], inflation=-1),
         IA, "inflation"),
    Case("sphere-model-nan", lambda fx: SphereModel(("a",), [[0, np.nan, 0]], [0.1]), IA, "centres"),
    Case("load-sphere-missing", lambda fx: load_sphere_file(fx.tmp / "none.json"), SphereFileError, "none.json"),
    Case("load-sphere-garbage", lambda fx: load_sphere_file(_write(fx, "s.json", "{")), SphereFileError, "s.json"),
    Case("load-sphere-latin1", lambda fx: load_sphere_file(_write(fx, "sl.json", "{\"\xe9\": 1}"
                                                                  .encode("latin-1"))), SphereFileError, "sl.json"),
    Case("save-sphere-model-type", lambda fx: save_sphere_file({"a": 1}, fx.tmp / "x.json"), RobotError, "model"),
    Case("fit-spheres-max", lambda fx: fit_spheres(fx.robot.model, fx.robot.collision_model,
                                                    max_spheres=0), RobotError, "max_spheres"),
    Case("fit-spheres-links", lambda fx: fit_spheres(fx.robot.model, fx.robot.collision_model,
                                                      links=["nowhere"]), RobotError, "nowhere"),
    Case("sphere-coverage-samples", lambda fx: sphere_coverage(
        fx.robot.model, fx.robot.collision_model, fx.robot.spheres, samples=0), RobotError, "samples"),
    # trajectories and retiming
    Case("from-plan-time-order", lambda fx: JointTrajectory.from_plan(
        fx.robot, [0, 1, 1], np.zeros((3, fx.robot.n)), np.zeros((3, fx.robot.n))), TrajectoryError, "time"),
    Case("from-plan-q-shape", lambda fx: JointTrajectory.from_plan(
        fx.robot, [0, 1, 2], np.zeros((3, 2)), np.zeros((3, fx.robot.n))), TrajectoryError, "q"),
    Case("from-plan-qdot-nan", lambda fx: JointTrajectory.from_plan(
        fx.robot, [0, 1, 2], np.zeros((3, fx.robot.n)), np.full((3, fx.robot.n), np.nan)),
         TrajectoryError, "qdot"),
    Case("to-json-exists", lambda fx: _traj(fx).to_json(_write(fx, "exists.json", "{}")),
         TrajectoryFileError, "exists.json"),
    Case("to-csv-exists", lambda fx: _traj(fx).to_csv(_write(fx, "exists.csv", "x")),
         TrajectoryFileError, "exists.csv"),
    Case("load-trajectory-missing", lambda fx: load_trajectory(fx.tmp / "none.json"),
         TrajectoryFileError, "none.json"),
    Case("load-trajectory-garbage", lambda fx: load_trajectory(_write(fx, "t.json", "[1, 2]")),
         TrajectoryFileError, "t.json"),
    Case("retime-method", lambda fx: retime(_traj(fx), fx.robot, method="fastest"), RetimingError, "method"),
    Case("retime-accel", lambda fx: retime(_traj(fx), fx.robot, acceleration_limits=-1.0), RetimingError,
         "acceleration_limits"),
    Case("retime-traj-type", lambda fx: retime("plan.json", fx.robot), RetimingError, "traj"),
    Case("retime-jerk-negative", lambda fx: retime(_traj(fx), fx.robot, method="ruckig", jerk_limits=-5.0),
         RetimingError, "jerk_limits"),
    Case("check-limits-jerk-shape", lambda fx: check_limits(_traj(fx), fx.robot.velocity_limits,
                                                            jerk_limits=[1.0, 2.0]), RetimingError, "jerk_limits"),
    Case("check-limits-shape", lambda fx: check_limits(_traj(fx), [1.0, 2.0]), RetimingError,
         "velocity_limits"),
    Case("uniform-scaling-negative", lambda fx: uniform_scaling(_traj(fx), -np.ones(fx.robot.n)),
         RetimingError, "velocity_limits"),
    # --- end-effector rotation, spheres per link
    Case("ee-rotation-shape", lambda fx: fx.robot.ee_rotation([1, 2]), IA, "q"),
    Case("ee-rotation-nan", lambda fx: fx.robot.ee_rotation([np.nan] * fx.robot.n), IA, "q"),
    Case("ee-rotation-text", lambda fx: fx.robot.ee_rotation("home"), IA, "q"),
    Case("for-link-type", lambda fx: fx.robot.spheres.for_link(5), E, "link"),
]


@pytest.fixture(scope="module")
def fx(jaco, tmp_path_factory):
    return SimpleNamespace(robot=jaco, tmp=tmp_path_factory.mktemp("bad_robots"))


@pytest.mark.parametrize("case", cases(CATALOGUE))
def test_bad_input(case: Case, fx) -> None:
    check(case, fx)


def test_robot_name_is_exact_and_listed() -> None:
    with pytest.raises(UnknownRobotError) as info:
        load_robot("kuka")
    assert "jaco" in str(info.value) and "sawyer" in str(info.value)
