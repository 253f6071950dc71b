"""Robot: built-in arms against independent references, joint conventions, the error catalogue."""
from __future__ import annotations

import importlib.metadata

import numpy as np
import pinocchio as pin
import pytest

from bad_input import raises_naming
from robots import (InvalidArrayError, Robot, RobotError, SphereModel, UnknownFrameError, UnknownRobotError,
                    UnsupportedJointError, URDFParseError, available_robots, load_robot)


def test_available_robots_and_their_joints(jaco, sawyer):
    assert set(available_robots()) == {"jaco", "sawyer"}
    assert jaco.n == 6 and jaco.model.nq == 9 and jaco.end_effector == "j2s6s200_end_effector"
    assert jaco.joint_names == tuple(f"j2s6s200_joint_{k}" for k in range(1, 7))
    assert sawyer.n == 7 and sawyer.model.nq == 7 and sawyer.end_effector == "right_hand"
    assert sawyer.joint_names == tuple(f"right_j{k}" for k in range(7))


def test_limits_come_from_the_urdf(jaco, sawyer):
    # continuous Jaco joints 1, 4, 6 are unbounded; the others keep their URDF limits
    assert np.all(np.isinf(jaco.lower_limits[[0, 3, 5]])) and np.all(np.isinf(jaco.upper_limits[[0, 3, 5]]))
    np.testing.assert_allclose(jaco.lower_limits[[1, 2, 4]], [0.820304748437, 0.331612557879, 0.523598775598])
    np.testing.assert_allclose(jaco.velocity_limits, [0.628318530718] * 3 + [0.837758040957] * 3)
    np.testing.assert_allclose(sawyer.upper_limits, [3.0503, 2.2736, 3.0426, 3.0439, 2.9761, 2.9761, 4.7124])
    np.testing.assert_allclose(sawyer.lower_limits, [-3.0503, -3.8095, -3.0426, -3.0439, -2.9761, -2.9761, -4.7124])
    np.testing.assert_allclose(sawyer.velocity_limits, [1.74, 1.328, 1.957, 1.957, 3.485, 3.485, 4.545])


def _kinova_urdf() -> str:
    share = importlib.metadata.distribution("example-robot-data").locate_file("cmeel.prefix/share")
    return str(share / "example-robot-data" / "robots" / "kinova_description" / "robots" / "kinova.urdf")


def test_jaco_fk_equals_pinocchio_on_the_unmodified_urdf(jaco):
    model = pin.buildModelFromUrdf(_kinova_urdf())
    data = model.createData()
    base = model.getFrameId("j2s6s200_link_base")
    ee = model.getFrameId("j2s6s200_end_effector")
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = jaco.random_configuration(rng)
        c, s = np.cos(q), np.sin(q)
        q_pin = np.array([c[0], s[0], q[1], q[2], c[3], s[3], q[4], c[5], s[5]])  # continuous: 1, 4, 6
        np.testing.assert_allclose(jaco.to_pinocchio(q), q_pin, atol=1e-15)
        pin.framesForwardKinematics(model, data, q_pin)
        expected = (data.oMf[base].inverse() * data.oMf[ee]).translation
        np.testing.assert_allclose(jaco.fk(q), expected, atol=1e-12)


# Sawyer reference numbers typed from sawyer_base.urdf.xacro: (xyz, rpy) of right_j0..right_j6,
# all about the joint's z axis, then the fixed right_hand joint.
SAWYER_JOINTS = [
    ((0, 0, 0.08), (0, 0, 0)),
    ((0.081, 0.05, 0.237), (-1.57079632679, 1.57079632679, 0)),
    ((0, -0.14, 0.1425), (1.57079632679, 0, 0)),
    ((0, -0.042, 0.26), (-1.57079632679, 0, 0)),
    ((0, -0.125, -0.1265), (1.57079632679, 0, 0)),
    ((0, 0.031, 0.275), (-1.57079632679, 0, 0)),
    ((0, -0.11, 0.1053), (-1.57079632679, -0.17453, 3.1416)),
]
SAWYER_HAND = ((0, 0, 0.0245), (0, 0, 1.570796))


def _homogeneous(xyz, rpy) -> np.ndarray:
    roll, pitch, yaw = rpy
    rx = np.array([[1, 0, 0], [0, np.cos(roll), -np.sin(roll)], [0, np.sin(roll), np.cos(roll)]])
    ry = np.array([[np.cos(pitch), 0, np.sin(pitch)], [0, 1, 0], [-np.sin(pitch), 0, np.cos(pitch)]])
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    out = np.eye(4)
    out[:3, :3] = rz @ ry @ rx  # URDF fixed-axis roll-pitch-yaw
    out[:3, 3] = xyz
    return out


def _sawyer_reference_hand(q: np.ndarray) -> np.ndarray:
    transform = np.eye(4)
    for (xyz, rpy), angle in zip(SAWYER_JOINTS, q):
        transform = transform @ _homogeneous(xyz, rpy) @ _homogeneous((0, 0, 0), (0, 0, angle))
    return (transform @ _homogeneous(*SAWYER_HAND))[:3, 3]


@pytest.mark.parametrize("q", [
    [0.00, -1.18, 0.00, 2.18, 0.00, 0.57, 3.3161],      # named pose "neutral"
    [0.00, -1.57, 0.00, 2.79, 0.00, -2.79, 3.3161],     # named pose "shipping"
    [0.3, -0.4, 1.1, -0.9, 2.0, 0.7, -1.5],
])
def test_sawyer_fk_equals_independent_transform_chain(sawyer, q):
    np.testing.assert_allclose(sawyer.fk(q), _sawyer_reference_hand(np.array(q)), rtol=0, atol=1e-9)


def test_joint_conventions_and_limits(jaco):
    rng = np.random.default_rng(1)
    q = np.array([jaco.random_configuration(rng) for _ in range(20)])
    assert jaco.within_limits(q).all()
    assert jaco.to_pinocchio(q).shape == (20, 9)
    wrapped = jaco.from_pinocchio(jaco.to_pinocchio(q))
    np.testing.assert_allclose(np.cos(wrapped), np.cos(q), atol=1e-12)
    np.testing.assert_allclose(wrapped[:, [1, 2, 4]], q[:, [1, 2, 4]], atol=1e-12)
    outside = q[0].copy()
    outside[1] = jaco.lower_limits[1] - 0.1
    assert not jaco.within_limits(outside)
    assert jaco.within_limits(jaco.clip_to_limits(outside))
    outside[0] = 100.0  # continuous joint: any angle is within limits
    assert jaco.within_limits(jaco.clip_to_limits(outside))


def test_custom_spheres_are_attached_to_their_links(sawyer):
    robot = load_robot("sawyer")
    robot.spheres = SphereModel(("right_l6", "right_arm_base_link"), np.array([[0, 0, 0.0], [0, 0, 0.1]]),
                                np.array([0.05, 0.1]))
    q = np.array([0.3, -0.4, 1.1, -0.9, 2.0, 0.7, -1.5])
    centres, jac = robot.sphere_centres(q, jacobians=True)
    np.testing.assert_allclose(centres[0], robot.frame_position(q, "right_l6"), atol=1e-15)
    np.testing.assert_allclose(centres[1], [0, 0, 0.1], atol=1e-15)
    np.testing.assert_array_equal(jac[1], 0.0)


# ------------------------------------------------------------------ error catalogue
def test_unknown_robot_lists_valid_names():
    with raises_naming(UnknownRobotError, "ur5", "jaco", "sawyer"):
        load_robot("ur5")
    assert issubclass(UnknownRobotError, ValueError)


def test_unknown_frames_list_valid_frames(sawyer, tmp_path):
    urdf = sawyer.urdf_path
    with raises_naming(UnknownFrameError, "end_effector", "gripper", "right_hand"):
        Robot.from_urdf(urdf, end_effector="gripper")
    with raises_naming(UnknownFrameError, "base_frame", "pedestal"):
        Robot.from_urdf(urdf, end_effector="right_hand", base_frame="pedestal")
    with raises_naming(UnknownFrameError, "frame", "camera", "right_l0"):
        sawyer.frame_position(np.zeros(7), "camera")
    robot = load_robot("sawyer")
    robot.spheres = SphereModel(("right_l9",), np.zeros((1, 3)), np.ones(1))
    with raises_naming(UnknownFrameError, "spheres.link_names", "right_l9"):
        robot.sphere_centres(np.zeros(7))


def test_bad_urdf_raises_parse_error(tmp_path):
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'><joint></robot")
    with raises_naming(URDFParseError, "broken.urdf"):
        Robot.from_urdf(broken, end_effector="a")
    with raises_naming(URDFParseError, "missing.urdf"):
        Robot.from_urdf(tmp_path / "missing.urdf", end_effector="a")


def test_unsupported_joint_type_is_named(tmp_path):
    path = tmp_path / "planar.urdf"
    path.write_text("""<robot name="p"><link name="a"/><link name="b"/>
      <joint name="plane" type="planar"><parent link="a"/><child link="b"/></joint></robot>""")
    with raises_naming(UnsupportedJointError, "plane"):
        Robot.from_urdf(path, end_effector="b")


@pytest.mark.parametrize("call", [
    lambda r: r.fk(np.zeros(6)),
    lambda r: r.fk(np.zeros((4, 8))),
    lambda r: r.fk([0, 0, np.nan, 0, 0, 0, 0]),
    lambda r: r.ee_kinematics(np.zeros((3, 7)), np.zeros((4, 7))),
    lambda r: r.ee_kinematics(np.zeros((3, 7)), np.full((3, 7), np.inf)),
    lambda r: r.sphere_centres("not numbers"),
    lambda r: r.to_pinocchio(np.zeros(3)),
    lambda r: r.within_limits(np.zeros((2, 2))),
    lambda r: r.random_configuration(42),
])
def test_bad_joint_arrays_raise_robot_error(sawyer, call):
    with pytest.raises(RobotError) as info:
        call(sawyer)
    assert any(word in str(info.value) for word in ("q", "qdot", "rng"))


def test_bad_array_message_names_argument_and_shape(sawyer):
    with raises_naming(InvalidArrayError, "q", "(6,)"):
        sawyer.fk(np.zeros(6))
    with raises_naming(InvalidArrayError, "qdot"):
        sawyer.ee_kinematics(np.zeros(7), [np.nan] * 7)


BRANCHED_URDF = """<?xml version="1.0"?>
<robot name="branched">
  <link name="root"/><link name="l1"/><link name="l2"/><link name="finger"/>
  <joint name="j1" type="revolute"><parent link="root"/><child link="l1"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="finger_joint" type="revolute"><parent link="l1"/><child link="finger"/>
    <origin xyz="0.1 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3"/><axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>
"""


def test_joints_off_the_end_effector_chain_are_locked(tmp_path):
    path = tmp_path / "branched.urdf"
    path.write_text(BRANCHED_URDF)
    robot = Robot.from_urdf(path, end_effector="l2")
    assert robot.joint_names == ("j1", "j2") and robot.n == 2
    np.testing.assert_allclose(robot.fk([0.0, np.pi / 2]), [0.0, 0.0, 0.5], atol=1e-12)
    finger = Robot.from_urdf(path, end_effector="finger")
    assert finger.joint_names == ("j1", "finger_joint")


def test_spheres_from_a_sphere_file(tmp_path, sawyer):
    from robots.sphere_model import save_sphere_file

    spheres = SphereModel(("right_l3",), np.array([[0.0, 0.1, 0.0]]), np.array([0.04]))
    save_sphere_file(spheres, tmp_path / "s.json")
    robot = Robot.from_urdf(sawyer.urdf_path, end_effector="right_hand", spheres=tmp_path / "s.json")
    np.testing.assert_allclose(robot.spheres.centres, spheres.centres)
    with raises_naming(RobotError, "spheres"):
        Robot.from_urdf(sawyer.urdf_path, end_effector="right_hand", spheres=[1, 2, 3])
    with raises_naming(RobotError, "model"):
        Robot("not a model", end_effector="right_hand")


@pytest.mark.parametrize("name", ["jaco", "sawyer"])
def test_single_configuration_pinocchio_path_equals_the_chain(name, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = robot.random_configuration(rng)
        position, jacobian = robot.ee_position_jacobian(q)
        kin = robot.ee_kinematics(q[None])
        np.testing.assert_allclose(position, kin.position[0], atol=1e-12)
        np.testing.assert_allclose(jacobian, kin.jacobian[0], atol=1e-12)
