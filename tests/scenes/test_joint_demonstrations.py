"""Joint-space demonstrations (kinesthetic teaching): loaded with the robot's forward
kinematics (scenes.joint_demonstrations), kept for the planner's initialisation
(clamp.planning.initialisation.demonstration_initialisation)."""
from __future__ import annotations

import numpy as np
import pytest

from bad_input import raises_naming
from clamp import learn_prior, plan
from clamp.planning.initialisation import demonstration_initialisation
from scenes import DemonstrationFileError, Demonstrations, load_demonstrations, make_demonstrations
from scenes.errors import ScenesTypeError

START = [0.2054, -0.4722, 0.2625]


def joint_recordings(robot, demos: Demonstrations) -> np.ndarray:
    """q (M, T, n): inverse kinematics of every demonstration's path, continuous in time."""
    q = []
    for path in demos.positions:
        first = robot.ik(path[0], tol=1e-7)
        ik = robot.ik_trajectory(path, seed=first.q, tol=1e-7)
        assert ik.success and ik.errors.max() < 1e-6
        q.append(ik.q)
    return np.array(q)


def write_joint_csv(path, robot, time, q, order=None):
    """demo,t,<joint names> (columns in ``order`` of the joints, default the robot's)."""
    order = np.arange(robot.n) if order is None else np.asarray(order)
    M, T, n = q.shape
    rows = np.column_stack([np.repeat(np.arange(M), T), np.tile(time, M),
                            q[:, :, order].reshape(-1, n)])
    header = "demo,t," + ",".join(robot.joint_names[j] for j in order)
    np.savetxt(path, rows, delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def check_joint_prior(robot, demos: Demonstrations, tmp_path):
    """Joint CSV made by IK of ``demos``, loaded back with the robot: the learned prior's mean
    is the workspace prior's within 1 mm (and 1 mm/s)."""
    q = joint_recordings(robot, demos)
    path = write_joint_csv(tmp_path / "joints.csv", robot, demos.time, q,
                           order=np.arange(robot.n)[::-1])          # any column order
    loaded = load_demonstrations(path, robot=robot)
    assert loaded.joint_names == robot.joint_names
    np.testing.assert_allclose(loaded.joint_positions, q, atol=1e-12)   # kept as recorded
    np.testing.assert_allclose(loaded.positions, demos.positions, atol=1e-5)
    workspace, joint = learn_prior(demos), learn_prior(loaded)
    assert np.abs(joint.mean[:, :3] - workspace.mean[:, :3]).max() < 1e-3
    assert np.abs(joint.mean[:, 3:] - workspace.mean[:, 3:]).max() < 1e-3
    return loaded, joint


def test_box_closing_recorded_in_joint_space_learns_the_workspace_prior(jaco, shared_dataset,
                                                                         tmp_path):
    """Acceptance (issue 21 item 2), on the real box_closing.mat recordings."""
    check_joint_prior(jaco, load_demonstrations(shared_dataset("box_closing")), tmp_path)


def test_synthetic_box_closing_in_joint_space_plans_from_its_demonstrations(jaco, tmp_path):
    """The same on the synthetic box_closing (always available), then a plan initialised
    from the recorded joint trajectories."""
    demos = make_demonstrations("box_closing", num_demos=6, seed=0)
    loaded, prior = check_joint_prior(jaco, demos, tmp_path)
    init = demonstration_initialisation(jaco, loaded.joint_positions, prior.dt, START)
    assert np.linalg.norm(jaco.fk(init.q[0]) - START) < 1e-4
    nearest = int(np.argmin(np.linalg.norm(loaded.positions[:, 0] - START, axis=1)))
    np.testing.assert_allclose(init.q[-1], loaded.joint_positions[nearest, -1], atol=1e-12)
    result = plan(prior, jaco, None, init.q[0], initial=init.theta)
    assert result.success, result.reasons
    np.testing.assert_allclose(result.initial_q, init.q)
    assert np.linalg.norm(jaco.fk(result.q[0]) - START) < 2e-3


def test_demonstration_initialisation_from_a_configuration(jaco):
    rng = np.random.default_rng(0)
    base = np.stack([jaco.neutral_configuration() + 0.1 * k for k in range(3)])
    q = base[:, None, :] + np.linspace(0.0, 0.3, 20)[None, :, None]          # (3, 20, n)
    q_start = base[2] + 0.01 * rng.standard_normal(jaco.n)
    init = demonstration_initialisation(jaco, q, 0.1, q_start)
    np.testing.assert_allclose(init.q[0], q_start)
    np.testing.assert_allclose(init.q[-1], q[2, -1], atol=1e-12)            # the nearest one
    np.testing.assert_allclose(init.qdot[5], (init.q[6] - init.q[4]) / 0.2)
    np.testing.assert_allclose(init.path, jaco.fk(init.q))


def test_joint_npz_and_save_round_trip(jaco, tmp_path):
    demos = make_demonstrations("box_closing", num_demos=3, num_points=60, seed=1)
    q = joint_recordings(jaco, demos)
    path = tmp_path / "joints.npz"
    np.savez(path, joint_positions=q, time=demos.time, joint_names=np.array(jaco.joint_names))
    loaded = load_demonstrations(path, robot=jaco)
    np.testing.assert_allclose(loaded.positions, demos.positions, atol=1e-5)
    np.testing.assert_allclose(loaded.joint_positions, q)
    saved = tmp_path / "saved.npz"
    loaded.resample(40).save_npz(saved)
    again = load_demonstrations(saved)                       # no robot needed any more
    assert again.joint_names == jaco.joint_names and again.joint_positions.shape == (3, 40, 6)
    np.testing.assert_allclose(jaco.fk(again.joint_positions), again.positions, atol=2e-4)
    assert loaded.translated([0.1, 0, 0]).joint_positions is None


@pytest.mark.parametrize("change, column", [
    (lambda names: names[:-1], "j2s6s200_joint_6"),
    (lambda names: names[:-1] + ["wrist"], "wrist"),
])
def test_joint_columns_must_be_the_robots_joints(jaco, tmp_path, change, column):
    names = change(list(jaco.joint_names))
    rows = ["demo,t," + ",".join(names)] + [f"{m},{t},{','.join(['0.5'] * len(names))}"
                                            for m in range(2) for t in range(3)]
    path = tmp_path / "j.csv"
    path.write_text("\n".join(rows) + "\n")
    with raises_naming(DemonstrationFileError, "j.csv", "header", column):
        load_demonstrations(path, robot=jaco)


def test_joint_files_need_a_robot(tmp_path):
    path = tmp_path / "joints.npz"
    np.savez(path, joint_positions=np.zeros((2, 5, 6)), time=np.arange(5.0),
             joint_names=np.array([f"j{k}" for k in range(6)]))
    with raises_naming(DemonstrationFileError, "joints.npz", "robot"):
        load_demonstrations(path)
    with raises_naming(ScenesTypeError, "robot"):
        load_demonstrations(path, robot="jaco")


def test_joint_recordings_of_unequal_length_are_resampled_together(jaco, tmp_path):
    demos = make_demonstrations("box_closing", num_demos=2, num_points=80, seed=2)
    q = joint_recordings(jaco, demos)
    rows = ["demo,t," + ",".join(jaco.joint_names)]
    for m, length in enumerate((80, 60)):                   # the second one stops early
        for i in range(length):
            rows.append(f"{m},{demos.time[i]:.17g}," + ",".join(f"{v:.17g}" for v in q[m, i]))
    path = tmp_path / "unequal.csv"
    path.write_text("\n".join(rows) + "\n")
    loaded = load_demonstrations(path, robot=jaco)
    assert loaded.joint_positions.shape == (2, 80, 6)
    np.testing.assert_allclose(loaded.joint_positions[1, [0, -1]], q[1, [0, 59]], atol=1e-12)
    # resampled by phase, the paths are still the forward kinematics of the joint trajectories
    np.testing.assert_allclose(jaco.fk(loaded.joint_positions), loaded.positions, atol=1e-4)


def test_clamp_plan_takes_joint_space_demonstrations(jaco, tmp_path):
    """Acceptance (issue 21): ``clamp plan --demos joints.csv --urdf ...`` learns from a joint
    CSV through the arm's forward kinematics."""
    import json

    from clamp.cli.commands import main
    demos = make_demonstrations("box_closing", num_demos=6, seed=0, num_points=60)
    path = write_joint_csv(tmp_path / "joints.csv", jaco, demos.time, joint_recordings(jaco, demos))
    out = tmp_path / "out"
    assert main(["plan", "--robot", "jaco", "--demos", str(path), "--start",
                 *map(str, demos.positions[0, 0] + [0.02, 0.0, 0.0]), "--out", str(out),
                 "-q"]) == 0
    plan_json = json.loads((out / "plan.json").read_text())
    assert plan_json["success"]
    np.testing.assert_allclose(plan_json["ee_path"][-1], demos.positions[:, -1].mean(0), atol=0.02)
